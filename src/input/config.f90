! SPDX-License-Identifier: BSD-2-Clause
!> The run configuration: every namelist key and the values derived from
!> them. Filled by module input (read, validate, derive); read by every other
!> module. Plain data: no PETSc, no MPI. A run's defaults are the key table's
!> (module input_keys), read over the initial values below; these matter
!> only where the table's default is a description (k_b, release_time, the
!> files and bounds of &identify and &control).
module config
  use kinds, only: rp
  implicit none
  private
  public :: nuno_config, keyframe_max, label_len, path_len
  public :: lattice_config, material_config, scene_config, time_config, output_config, identify_config, control_config
  public :: SPRING_AXIAL, SPRING_LINEAR
  public :: BEND_NONE, BEND_PAPER, BEND_ENERGY
  public :: SCALING_ELEMENT, SCALING_CONTINUUM
  public :: MASS_UNIFORM, MASS_AREA
  public :: SCENE_LIFT_RELEASE, SCENE_BEND_RELEASE, SCENE_WAVE_POINT, SCENE_HANG, SCENE_FLAT
  public :: unset_real
  public :: contact_config, obstacle_max, obstacle_keyframe_max
  public :: n_fit_kinds, fit_kind_names

  integer, parameter :: keyframe_max = 32   !< most keyframes of a prescribed node
  integer, parameter :: label_len = 32      !< length of a choice string ('axial', ...)
  integer, parameter :: path_len = 512      !< length of a file name
  integer, parameter :: obstacle_max = 8    !< most obstacles of &contact
  integer, parameter :: obstacle_keyframe_max = 16  !< most keyframes of a moving obstacle
  !> Marks a real key the user did not set, so that a scene default applies.
  real(rp), parameter :: unset_real = -huge(1.0_rp)
  !> Parameters an identification run can fit (&identify fit), by code 1..7.
  integer, parameter :: n_fit_kinds = 7
  character(len=10), parameter :: fit_kind_names(n_fit_kinds) = &
    [character(len=10) :: 'e_s', 'e_d', 'eta_s', 'eta_d', 'k_b', 'eta_b', 'total_mass']

  integer, parameter :: SPRING_AXIAL = 1, SPRING_LINEAR = 2
  integer, parameter :: BEND_NONE = 0, BEND_PAPER = 1, BEND_ENERGY = 2
  integer, parameter :: SCALING_ELEMENT = 1, SCALING_CONTINUUM = 2
  integer, parameter :: MASS_UNIFORM = 1, MASS_AREA = 2
  integer, parameter :: SCENE_LIFT_RELEASE = 1, SCENE_BEND_RELEASE = 2, SCENE_WAVE_POINT = 3, &
                        SCENE_HANG = 4, SCENE_FLAT = 5

  !> &contact (docs/design.md, "Contact"): rigid obstacles, static or moving
  !> on keyframes, and the barrier's parameters. n_obstacles = 0: no contact code runs.
  type :: contact_config
    integer :: n_obstacles = 0                                  !< obstacles in use (0..obstacle_max)
    character(label_len) :: shape(obstacle_max) = 'plane'      !< plane | sphere | box | capsule
    real(rp) :: point(3, obstacle_max) = 0.0_rp                 !< plane: a point on it; sphere, box: centre; capsule: first end [length]
    real(rp) :: normal(3, obstacle_max) = spread([0.0_rp, 0.0_rp, 1.0_rp], 2, obstacle_max)  !< plane: outward normal; box: its local z axis [1]
    real(rp) :: axis(3, obstacle_max) = spread([1.0_rp, 0.0_rp, 0.0_rp], 2, obstacle_max)    !< box: its local x axis (orthogonalised against normal) [1]
    real(rp) :: half_size(3, obstacle_max) = 0.0_rp             !< box: half extents along its local x, y, z [length]
    real(rp) :: end_pt(3, obstacle_max) = 0.0_rp                !< capsule: second end [length]
    real(rp) :: radius(obstacle_max) = 0.0_rp                   !< sphere, capsule: radius [length]
    real(rp) :: mu(obstacle_max) = 0.0_rp                       !< Coulomb friction coefficient [1]
    integer :: n_keyframes(obstacle_max) = 0                    !< keyframes of obstacle k's motion; 0: static
    real(rp) :: key_time(obstacle_keyframe_max, obstacle_max) = 0.0_rp       !< keyframe times [time]
    real(rp) :: key_offset(3, obstacle_keyframe_max, obstacle_max) = 0.0_rp  !< translation at the keyframes [length]
    real(rp) :: key_close(obstacle_keyframe_max, obstacle_max) = 0.0_rp      !< closing offset at the keyframes [length]
    real(rp) :: close_dir(3, obstacle_max) = 0.0_rp                          !< closing direction (normalised) [1]
    real(rp) :: thickness = 0.0_rp        !< contact distance: gap = distance - thickness [length]
    real(rp) :: dhat = 1.0e-3_rp          !< barrier active for gap < dhat [length]
    real(rp) :: stiffness = 1.0_rp        !< barrier stiffness kappa [force/length]
    real(rp) :: eps_v = 1.0e-3_rp         !< friction smoothing velocity [length/time]
    !> the cloth's triangles and edges, not only its nodes, kept outside the
    !> obstacles that are not planes (module face_contact); off by default
    !> until fast obstacles take it without retried steps (docs/contact.md)
    logical :: faces = .false.
    !> the cloth against itself (module self_contact): its triangles and
    !> edges kept apart, the barrier above at distance 2 contact_thickness;
    !> off by default (nothing allocated, nothing run)
    logical :: self_contact = .false.
    !> Coulomb coefficient of the friction between two pieces of the cloth
    !> (self-contact's pairs, lagged; module self_lags); 0: frictionless [1]
    real(rp) :: self_mu = 0.0_rp
    !> self-contact's step guarantee (docs/self-contact.md, "The step
    !> guarantee"): 'accd', every update scaled by the global ACCD alpha, or
    !> 'ogc', each node's update shortened to its own bound
    character(label_len) :: self_step = 'accd'
    integer :: shape_code(obstacle_max) = 1   !< derived: 1 plane, 2 sphere, 3 box, 4 capsule (the kernel's SHAPE_*)
  end type contact_config

  !> &lattice and the values derived from it.
  type :: lattice_config
    integer :: nx = 11                       !< nodes along x (>= 3)
    integer :: ny = 11                       !< nodes along y (>= 3)
    real(rp) :: lx = 100.0_rp                !< rest size along x [length]
    real(rp) :: ly = 100.0_rp                !< rest size along y [length]
    real(rp) :: total_mass = 1.0_rp          !< mass of the whole cloth [mass]
    character(label_len) :: mass_distribution = 'uniform'   !< uniform | area
    character(label_len) :: lattice_scaling = 'element'     !< element | continuum
    ! derived
    integer :: scaling_code = SCALING_ELEMENT
    integer :: mass_code = MASS_UNIFORM
    real(rp) :: ax = 0.0_rp, ay = 0.0_rp  !< lattice spacings [length]
  end type lattice_config

  !> &material and the values derived from it.
  type :: material_config
    character(label_len) :: spring_model = 'axial'          !< axial | linear
    real(rp) :: e_s = 1.0_rp      !< structural stiffness [force/length] (continuum: Y_s [force/length])
    real(rp) :: eta_s = 1.0_rp    !< structural damping [force time/length]
    real(rp) :: e_d = 1.0_rp      !< shear (diagonal) stiffness
    real(rp) :: eta_d = 1.0_rp    !< shear (diagonal) damping
    character(label_len) :: bending_model = 'paper'         !< none | paper | energy
    real(rp) :: k_b = unset_real  !< bending: paper [force/rad], energy [energy]; unset -> scene default
    real(rp) :: eta_b = 0.0_rp    !< bending damping (energy model) [energy time]
    ! derived
    integer :: spring_code = SPRING_AXIAL
    integer :: bending_code = BEND_PAPER
    logical :: has_damping = .false.      !< any of eta_s, eta_d > 0
  end type material_config

  !> &scene and the values derived from it. The key `scene` (the scene's
  !> name) is the component `name`: cfg%scene is this record.
  type :: scene_config
    character(label_len) :: name = 'lift_release'  !< the key `scene`: lift_release | bend_release | wave_point | hang | flat
    real(rp) :: gravity(3) = 0.0_rp       !< [length/time^2]
    real(rp) :: lift_length = 30.0_rp     !< lift_release: length of the folded part [length]
    real(rp) :: lift_height = 15.0_rp     !< lift_release: height of edge i = nx-1 [length]
    real(rp) :: bend_angle = 30.0_rp      !< bend_release: total angle of the arc [degree]
    integer :: n_keyframes = 3            !< wave_point: number of keyframes used
    real(rp) :: keyframe_time(keyframe_max) = 0.0_rp   !< wave_point: keyframe times [time]
    real(rp) :: keyframe_dx(keyframe_max) = 0.0_rp     !< wave_point: x offset of the driven nodes at those times [length]
    real(rp) :: keyframe_dy(keyframe_max) = 0.0_rp     !< wave_point: y offset of the driven nodes at those times [length]
    real(rp) :: keyframe_dz(keyframe_max) = 0.0_rp     !< wave_point: z offset of the driven nodes at those times [length]
    character(label_len) :: wave_nodes = 'corner'  !< wave_point: driven nodes: corner (0,0) | edge (every node of i = 0)
    real(rp) :: release_time = huge(1.0_rp)  !< time at which the scene's constraints end [time]
    real(rp) :: initial_omega(3) = 0.0_rp    !< initial rigid angular velocity about the centroid [rad/time]
    !> the unit system the input's values are in: 'mm g s' | 'SI' (the
    !> program is unit-agnostic: recorded in the output, for its labels)
    character(label_len) :: units = 'mm g s'
    ! derived
    integer :: scene_code = SCENE_LIFT_RELEASE
    logical :: has_gravity = .false.
  end type scene_config

  !> &time.
  type :: time_config
    real(rp) :: t_end = 2.0_rp            !< [time]
    real(rp) :: dt = 1.0e-3_rp            !< (initial) step [time]
  end type time_config

  !> &output.
  type :: output_config
    real(rp) :: output_interval = 0.1_rp  !< [time]
    real(rp) :: checkpoint_interval = 0.0_rp  !< checkpoint at the first output step this long after the last; 0: at the end only [time]
    real(rp) :: stretch_limit = 5.0_rp    !< warn once when a link's l/L leaves [1/limit, limit]; 0: never [1]
    logical :: write_velocity = .true.    !< also store /velocity: ParaView's colouring and energy checks use it
    character(path_len) :: output_file = 'nuno.h5'
    character(1024) :: petsc_options = '' !< PETSc options; the command line overrides them
  end type output_config

  !> &identify (docs/identification.md): present = an identification run.
  type :: identify_config
    character(path_len) :: observed_file = ''  !< observed motion (HDF5: /time, /position [nt][ny][nx][3])
    character(256) :: fit = ''                 !< comma-separated parameters to fit (fit_kind_names)
    real(rp) :: fit_lower(n_fit_kinds) = unset_real  !< lower bounds, in the order of fit; unset: initial / 1000
    real(rp) :: fit_upper(n_fit_kinds) = unset_real  !< upper bounds, in the order of fit; unset: initial x 1000
    real(rp) :: tikhonov = 0.0_rp              !< weight of sum (ln p - ln p_initial)^2 in the objective [length^2]
    ! derived
    logical :: active = .false.           !< the input has an &identify group: an identification run
    integer :: n_fit = 0                  !< parameters fitted
    integer :: fit_code(n_fit_kinds) = 0  !< their codes (index into fit_kind_names), in the order of fit
  end type identify_config

  !> &control (docs/identification.md, "Deformation control"): present = a control run.
  type :: control_config
    character(path_len) :: target_file = ''    !< target (HDF5: /time, /position [nt][ny][nx][3], optional /velocity)
    character(label_len) :: components = 'xyz' !< components of the keyframe path that are optimised: letters of xyz
    real(rp) :: max_speed = unset_real         !< bound on each component of the driven nodes' speed [length/time]; unset: none
    real(rp) :: velocity_weight = 0.0_rp       !< weight of |v - v_target|^2 beside |x - x_target|^2 [time^2]
    real(rp) :: keyframe_tikhonov = 0.0_rp     !< weight of sum (d - d_initial)^2 over the optimised keyframe steps d [1]
    ! derived
    logical :: active = .false.           !< the input has a &control group: a control run
    logical :: control_comp(3) = .false.  !< x, y, z of the keyframe offsets optimised (components)
  end type control_config

  !> All inputs of a run, one record per namelist group: cfg%<group>%<key>
  !> (cfg%lattice%nx, cfg%time%dt, ...), the values derived from a group's
  !> keys beside them (cfg%material%bending_code, cfg%lattice%ax, ...).
  !> Strings hold the namelist spelling; the integer codes beside them are
  !> derived by the input module. Three names differ from the key: the key
  !> `scene` is cfg%scene%name, and cfg%identify%active, cfg%control%active
  !> say that the input has that group.
  type :: nuno_config
    type(lattice_config) :: lattice
    type(material_config) :: material
    type(scene_config) :: scene
    type(time_config) :: time
    type(output_config) :: output
    type(identify_config) :: identify
    type(control_config) :: control
    type(contact_config) :: contact
    character(:), allocatable :: namelist_text  !< the input file as read, for the output file
  end type nuno_config

end module config
