! SPDX-License-Identifier: BSD-2-Clause
!> The one table of namelist keys: for each key its name, group, type,
!> unit, default, allowed values and a one-line meaning. Everything else
!> that names keys reads it: the -nuno_set lexer and the type check of
!> values (module input_text), the choice checks and the key lists of
!> `nuno --help` and `nuno --list-keys` (module input, input_usage). The
!> namelist reader (input_namelist.f90) must declare its variables by name;
!> tests/mpi/test_input_keys.F90 checks that its groups hold exactly these
!> keys with these types, sizes and defaults, tests/unit/test_input_text.f90
!> that ranges and choices read here are the ones refused, and
!> tests/python/test_input_keys.py that input/README.md's key tables agree.
!> No MPI, no PETSc.
!>
!> The default is written as input/README.md shows it: the plain default,
!> then "; SCENE VALUE" for each scene that sets another. A value in namelist
!> syntax (arrays without their parentheses after stripping, `<scene>` for
!> the scene's name) is checked against the reader; text such as
!> "(required)" or "from the scene (see above)" is a description.
module input_keys
  implicit none
  private
  public :: key_info, keys, n_keys, key_index, key_type_text, group_names, n_groups, key_group_list
  public :: KEY_INTEGER, KEY_REAL, KEY_LOGICAL, KEY_STRING
  public :: G_LATTICE, G_MATERIAL, G_SCENE, G_TIME, G_OUTPUT, G_IDENTIFY, G_CONTROL, G_CONTACT

  integer, parameter :: KEY_INTEGER = 1, KEY_REAL = 2, KEY_LOGICAL = 3, KEY_STRING = 4

  !> The namelist groups, in the order of --help and input/README.md.
  integer, parameter :: n_groups = 8
  character(8), parameter :: group_names(n_groups) = &
    [character(8) :: 'lattice', 'material', 'scene', 'time', 'output', 'identify', 'control', 'contact']
  !> Group codes: positions in group_names.
  integer, parameter :: G_LATTICE = 1, G_MATERIAL = 2, G_SCENE = 3, G_TIME = 4, G_OUTPUT = 5, G_IDENTIFY = 6, &
                        G_CONTROL = 7, G_CONTACT = 8

  type :: key_info
    character(20) :: name      !< the key, lower case (unique across groups)
    character(8) :: group      !< its namelist group
    integer :: kind            !< KEY_*
    integer :: size            !< 1: a scalar; n: an array of n values
    character(36) :: unit      !< unit in the scene's units ('' for none)
    character(56) :: default   !< as input/README.md writes it (see above)
    character(64) :: allowed   !< range or choices; a choice list's order is its code order; a range
                               !< of bounds '>= A, <= B' ('>' and '<' too) is the one module
                               !< input_checks' need_in_range enforces
    character(96) :: meaning   !< one line
  end type key_info

  integer, parameter :: n_keys = 69
  type(key_info), parameter :: keys(n_keys) = [ &
    ! &lattice
    key_info('nx', 'lattice', KEY_INTEGER, 1, '', '11; hang 21', '>= 3', 'nodes along x'), &
    key_info('ny', 'lattice', KEY_INTEGER, 1, '', '11; hang 21', '>= 3', 'nodes along y (the rows are split over the ranks)'), &
    key_info('lx', 'lattice', KEY_REAL, 1, 'length', '100; bend_release 50; hang 1', '> 0', 'rest size along x'), &
    key_info('ly', 'lattice', KEY_REAL, 1, 'length', '100; bend_release 50; hang 1', '> 0', 'rest size along y'), &
    key_info('total_mass', 'lattice', KEY_REAL, 1, 'mass', '1; bend_release 0.25; hang 0.1', '>= 1e-30, <= 1e30', &
             'mass of the whole cloth'), &
    key_info('mass_distribution', 'lattice', KEY_STRING, 1, '', "'uniform'; hang 'area'", 'uniform, area', &
             'node masses: equal, or Voronoi cells (continuum scaling: area)'), &
    key_info('lattice_scaling', 'lattice', KEY_STRING, 1, '', "'element'", 'element, continuum', &
             'constants per link as given, or continuum values scaled to the lattice'), &
    ! &material
    key_info('spring_model', 'material', KEY_STRING, 1, '', "'axial'", 'axial, linear', &
             'exact Voigt element about the rest length, or the report''s linear element'), &
    key_info('e_s', 'material', KEY_REAL, 1, 'force/length', '1; hang 100', '>= 0, <= 1e30', 'stiffness of structural links'), &
    key_info('eta_s', 'material', KEY_REAL, 1, 'force time/length', '1; hang 0.1', '>= 0, <= 1e30', &
             'damping of structural links'), &
    key_info('e_d', 'material', KEY_REAL, 1, 'force/length', '1; hang 100', '>= 0, <= 1e30', &
             'stiffness of shear (diagonal) links'), &
    key_info('eta_d', 'material', KEY_REAL, 1, 'force time/length', '1; hang 0.1', '>= 0, <= 1e30', 'damping of shear links'), &
    key_info('bending_model', 'material', KEY_STRING, 1, '', "'paper'; wave_point 'none'; hang 'energy'", &
             'none, paper, energy', 'bending: none, the report''s force, or discrete-curvature energy'), &
    key_info('k_b', 'material', KEY_REAL, 1, 'paper: force/rad; energy: energy', 'from the scene (see above)', &
             '>= 0, <= 1e30', 'bending constant'), &
    key_info('eta_b', 'material', KEY_REAL, 1, 'energy time', '0; hang 1e-4', '>= 0, <= 1e30', &
             'bending damping of the energy model'), &
    ! &scene
    key_info('scene', 'scene', KEY_STRING, 1, '', "'lift_release'", &
             'lift_release, bend_release, wave_point, hang, flat', 'the scene; sets the defaults of all other keys'), &
    key_info('gravity', 'scene', KEY_REAL, 3, 'length/time^2', '(0, 0, 0); hang (0, 0, -9.81)', 'finite', &
             'uniform acceleration on every node'), &
    key_info('lift_length', 'scene', KEY_REAL, 1, 'length', '30', '> 0', 'lift_release: length of the folded part'), &
    key_info('lift_height', 'scene', KEY_REAL, 1, 'length', '15', '>= 0', 'lift_release: height of edge i = nx-1'), &
    key_info('bend_angle', 'scene', KEY_REAL, 1, 'degree', '30', '[0, 360)', &
             'bend_release: total angle of the arc'), &
    key_info('n_keyframes', 'scene', KEY_INTEGER, 1, '', '3', '1..32', 'wave_point: keyframes used'), &
    key_info('keyframe_time', 'scene', KEY_REAL, 32, 'time', '0, 0.5, 1.0', '>= 0, strictly increasing', &
             'wave_point: keyframe times'), &
    key_info('keyframe_dx', 'scene', KEY_REAL, 32, 'length', '0', 'finite', &
             'wave_point: x offset of the driven nodes at the keyframes'), &
    key_info('keyframe_dy', 'scene', KEY_REAL, 32, 'length', '0', 'finite', &
             'wave_point: y offset of the driven nodes at the keyframes'), &
    key_info('keyframe_dz', 'scene', KEY_REAL, 32, 'length', '0, -10, 15', 'finite', &
             'wave_point: z offset of the driven nodes at the keyframes'), &
    key_info('wave_nodes', 'scene', KEY_STRING, 1, '', "'corner'", 'corner, edge', &
             'wave_point: the driven nodes: corner (0,0) or edge i = 0'), &
    key_info('release_time', 'scene', KEY_REAL, 1, 'time', 'never (huge)', '>= 0', &
             'the scene''s constraints end at this time'), &
    key_info('initial_omega', 'scene', KEY_REAL, 3, 'rad/time', '(0, 0, 0)', 'finite', &
             'initial rigid angular velocity about the centroid'), &
    key_info('units', 'scene', KEY_STRING, 1, '', "'mm g s'; hang 'SI'", 'mm g s, SI', &
             'the unit system of the values given, recorded in the output (labels)'), &
    ! &time
    key_info('t_end', 'time', KEY_REAL, 1, 'time', '5; wave_point 3; hang 2; flat 1', '> 0', 'final time'), &
    key_info('dt', 'time', KEY_REAL, 1, 'time', '1e-3', '> 0', 'time step (the first one of adaptive steps)'), &
    ! &output
    key_info('output_interval', 'output', KEY_REAL, 1, 'time', '0.02; hang 0.05; flat 0.1', '> 0', &
             'time between stored states'), &
    key_info('write_velocity', 'output', KEY_LOGICAL, 1, '', '.true.', '', &
             'also store /velocity (.false. halves the output)'), &
    key_info('output_file', 'output', KEY_STRING, 1, '', "'<scene>.h5'", 'not empty', &
             'HDF5 file (an XDMF file beside it)'), &
    key_info('petsc_options', 'output', KEY_STRING, 1, '', "''", '', &
             'PETSc options, as on a command line (the command line wins)'), &
    key_info('stretch_limit', 'output', KEY_REAL, 1, '1', '5', '> 1, or 0: no check', &
             'warn once when a link''s l/L leaves [1/limit, limit]'), &
    key_info('checkpoint_interval', 'output', KEY_REAL, 1, 'time', '0', '>= 0', &
             'time between checkpoints (at output steps); 0: at the end only'), &
    ! &identify
    key_info('observed_file', 'identify', KEY_STRING, 1, '', '(required)', 'not empty', &
             'HDF5 file of the observed motion (/time, /position)'), &
    key_info('fit', 'identify', KEY_STRING, 1, '', '(required)', 'e_s, e_d, eta_s, eta_d, k_b, eta_b, total_mass', &
             'comma-separated parameters to fit, each once'), &
    key_info('fit_lower', 'identify', KEY_REAL, 7, 'as the parameter', 'initial / 1000', '0 < lower <= initial', &
             'lower bounds, in the order of fit'), &
    key_info('fit_upper', 'identify', KEY_REAL, 7, 'as the parameter', 'initial x 1000', 'initial <= upper', &
             'upper bounds, in the order of fit'), &
    key_info('tikhonov', 'identify', KEY_REAL, 1, 'length^2', '0', '>= 0', &
             'weight of sum (ln p - ln p_initial)^2 in the objective'), &
    ! &control
    key_info('target_file', 'control', KEY_STRING, 1, '', '(required)', 'not empty', &
             'HDF5 file of the target motion (/time, /position, optional /velocity)'), &
    key_info('components', 'control', KEY_STRING, 1, '', "'xyz'", 'letters of xyz, each once', &
             'components of the keyframe path that are optimised'), &
    key_info('max_speed', 'control', KEY_REAL, 1, 'length/time', 'none', '> 0', &
             'bound on each optimised component''s speed of the driven nodes'), &
    key_info('velocity_weight', 'control', KEY_REAL, 1, 'time^2', '0', '>= 0', &
             'weight of |v - v_target|^2 beside |x - x_target|^2'), &
    key_info('keyframe_tikhonov', 'control', KEY_REAL, 1, '1', '0', '>= 0', &
             'weight of sum (d - d_initial)^2 over the optimised keyframe steps'), &
    ! &contact
    key_info('n_obstacles', 'contact', KEY_INTEGER, 1, '', '0', '0..8', &
             'obstacles in use (0: no contact, no cost)'), &
    key_info('obstacle_shape', 'contact', KEY_STRING, 8, '', "'plane'", 'plane, sphere, box, capsule', &
             'obstacle k''s shape, obstacle_shape(k)'), &
    key_info('obstacle_point', 'contact', KEY_REAL, 24, 'length', '0', 'finite', &
             'plane: a point on it; sphere, box: centre; capsule: first end; obstacle_point(:, k)'), &
    key_info('obstacle_normal', 'contact', KEY_REAL, 24, '1', '0, 0, 1', 'not zero', &
             'plane: outward normal; box: its local z axis (normalised), obstacle_normal(:, k)'), &
    key_info('obstacle_radius', 'contact', KEY_REAL, 8, 'length', '0', '> 0 for a sphere or capsule', &
             'sphere, capsule: radius, obstacle_radius(k)'), &
    key_info('obstacle_half_size', 'contact', KEY_REAL, 24, 'length', '0', '> 0 for a box', &
             'box: half extents along its local x, y, z axes, obstacle_half_size(:, k)'), &
    key_info('obstacle_axis', 'contact', KEY_REAL, 24, '1', '1, 0, 0', 'not zero, not parallel to the normal', &
             'box: its local x axis (orthogonalised against the normal), obstacle_axis(:, k)'), &
    key_info('obstacle_end', 'contact', KEY_REAL, 24, 'length', '0', 'finite', &
             'capsule: the second end of its axis, obstacle_end(:, k)'), &
    key_info('obstacle_n_keyframes', 'contact', KEY_INTEGER, 8, '', '0', '0..16', &
             'keyframes of obstacle k''s motion, obstacle_n_keyframes(k); 0: static'), &
    key_info('obstacle_time', 'contact', KEY_REAL, 128, 'time', '0', '>= 0, strictly increasing', &
             'keyframe times (keyframe j of obstacle k), obstacle_time(j, k)'), &
    key_info('obstacle_offset', 'contact', KEY_REAL, 384, 'length', '0', 'finite', &
             'translation of obstacle k at keyframe j, obstacle_offset(:, j, k)'), &
    key_info('obstacle_close', 'contact', KEY_REAL, 128, 'length', '0', 'finite', &
             'gripper: closing offset along obstacle_close_dir at keyframe j, obstacle_close(j, k)'), &
    key_info('obstacle_close_dir', 'contact', KEY_REAL, 24, '1', '0', 'not zero where obstacle_close is not', &
             'gripper: closing direction (normalised), obstacle_close_dir(:, k)'), &
    key_info('obstacle_mu', 'contact', KEY_REAL, 8, '1', '0', '>= 0', &
             'Coulomb friction coefficient of obstacle k'), &
    key_info('contact_thickness', 'contact', KEY_REAL, 1, 'length', '0', '>= 0', &
             'contact distance: the gap is the distance to the surface minus this'), &
    key_info('contact_dhat', 'contact', KEY_REAL, 1, 'length', '1e-3', '> 0, with obstacles 1e-4 .. 1 lattice spacing', &
             'the barrier acts on gaps below this'), &
    key_info('contact_stiffness', 'contact', KEY_REAL, 1, 'force/length', '1', '> 0, with obstacles at most 100 m/dt^2 and holding m g', &
             'barrier stiffness kappa: energy kappa b(gap)'), &
    key_info('friction_eps_v', 'contact', KEY_REAL, 1, 'length/time', '1e-3', '> 0, with friction 1e-7 .. 1 lattice spacing/dt', &
             'friction: sliding speed below which friction is smoothed (sticking)'), &
    key_info('contact_faces', 'contact', KEY_LOGICAL, 1, '', '.false.', '', &
             'the cloth''s triangles and edges, not only its nodes, kept outside spheres, boxes and capsules'), &
    key_info('self_contact', 'contact', KEY_LOGICAL, 1, '', '.false.', 'contact_dhat + 2 contact_thickness < 0.7 lattice spacing', &
             'the cloth''s triangles and edges kept apart from each other (self-contact)'), &
    key_info('self_mu', 'contact', KEY_REAL, 1, '1', '0', '>= 0, with self_contact', &
             'Coulomb friction coefficient between two pieces of the cloth (self-contact)'), &
    key_info('self_step', 'contact', KEY_STRING, 1, '', "'accd'", 'accd, ogc', &
             'self-contact''s step guarantee: the global ACCD fraction of each update, or OGC''s per-node bounds')]

contains

  !> Index of key `name` (lower case, no subscript) in keys; 0 when none.
  pure integer function key_index(name) result(k)
    character(*), intent(in) :: name
    integer :: i
    k = 0
    if (len_trim(name) == 0) return
    do i = 1, n_keys
      if (trim(keys(i)%name) == trim(name)) then
        k = i
        return
      end if
    end do
  end function key_index

  !> The type as input/README.md writes it: integer, real, logical, string,
  !> real(3) for an array of 3.
  function key_type_text(k) result(s)
    integer, intent(in) :: k
    character(:), allocatable :: s
    character(12) :: n
    select case (keys(k)%kind)
    case (KEY_INTEGER); s = 'integer'
    case (KEY_REAL);    s = 'real'
    case (KEY_LOGICAL); s = 'logical'
    case default;       s = 'string'
    end select
    if (keys(k)%size > 1) then
      write(n, '(i0)') keys(k)%size
      s = s//'('//trim(n)//')'
    end if
  end function key_type_text

  !> The keys of group `group`, separated by ', '.
  function key_group_list(group) result(s)
    character(*), intent(in) :: group
    character(:), allocatable :: s
    integer :: i
    s = ''
    do i = 1, n_keys
      if (trim(keys(i)%group) /= trim(group)) cycle
      if (len(s) > 0) s = s//', '
      s = s//trim(keys(i)%name)
    end do
  end function key_group_list

end module input_keys
