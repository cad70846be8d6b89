! SPDX-License-Identifier: BSD-2-Clause
!> Parallel HDF5 output of a run (docs/model.md section 9) and its XDMF sidecar.
!>
!> Index convention: the caller's arrays are x(3, 0:nx-1, ys:ys+ym-1) with
!> 0-based global row indices (a DMDA strip of whole rows). Fortran dims
!> (3, nx, ny, nt) are C order [nt][ny][nx][3] in the file.
!>
!> Crash safety: every time-dependent dataset is extended by one step, written,
!> then the root attribute n_output_steps is updated and the file is flushed.
!> Readers trust the first n_output_steps steps only. The root attribute
!> status is 'running' until output_close writes its final value, last.
!>
!> Safe files (input/README.md, "Output files"): one writer per file (an
!> flock'd `<file>.lock`, taken by rank 0 before anything is written); the
!> run writes `<file>.partial` and renames it onto `<file>` once an output
!> step after the first successful time step is on disk (or at the close when
!> there is no earlier `<file>` to protect), so a run that fails at start-up
!> never destroys an earlier result. The XDMF sidecar is written from then on.
!>
!> XDMF views: /xdmf/position_<k> (and velocity_<k>) are HDF5 virtual
!> datasets [1][ny][nx][3] that map step k of /position (/velocity) of the
!> same file, /xdmf/mass and /xdmf/rest_position map the lattice: metadata
!> only, no data is copied. They let the sidecar name every array by a plain
!> HDF DataItem, which all of ParaView's XDMF readers read (write_xdmf).
!>
!> Obstacles (a scene with &contact, submodule output_obstacles): each
!> obstacle's surface as triangles in /obstacles/obstacle_<k>, its
!> vertices written once (static) or at every output step (moving, with a
!> view /xdmf/obstacle_<k>_vertices_<t> a step), and a second sidecar,
!> <file>-obstacles.xdmf, that opens them in ParaView beside <file>.xdmf.
!>
!> Errors: every h5*_f code is checked; a failure sets ierr /= 0 and a one-line
!> errmsg naming the call and the dataset. The collective routines end with an
!> MPI_Allreduce of the error flag, so all ranks return the same ierr and the
!> message of the first rank that failed; within a sequence of collective
!> calls that can fail on some ranks only (dataset writes and flushes: a
!> full disk), every call is agreed on before the next, so that no rank is
!> left waiting in a collective call the others have given up.
module output
  use, intrinsic :: iso_fortran_env, only: int64
  use hdf5
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, contact_config
  use checkpoint_record, only: checkpoint_t, named_value_t
  use process_model, only: pm_series_t, pm_group_t
  use checkpoint_check, only: checkpoint_refusal, scene_refusal
  use safe_files, only: lock_acquire, lock_release, same_file, file_exists, rename_file, free_bytes, &
                        path_kind, kind_none, kind_file, kind_link, kind_dir, kind_unknown, remove_file, &
                        is_nuno_output, is_nuno_sidecar, sidecar_path, obstacles_sidecar_path, tmp_open, tmp_write, &
                        tmp_commit, cleanup_add, cleanup_drop, cleanup_file
  use output_h5
  use strings, only: itoa, real_es
  implicit none
  private

  public :: output_open, output_write_step, output_close, output_write_run_info, output_write_wall_time
  public :: output_write_retried_steps
  public :: output_config_key
  public :: output_write_checkpoint, output_reopen, output_steps
  public :: output_write_identify, output_write_control
  public :: output_write_obstacles

  !> One key of the resolved configuration, as an attribute of /config/<group>.
  interface output_config_key
    module procedure config_key_str, config_key_int, config_key_reals
  end interface output_config_key

  !> One output step's scalars (docs/model.md section 8); identical on all ranks.
  type, public :: output_record
    real(rp) :: time = 0
    real(rp) :: kinetic = 0, stretch = 0, bend = 0, dissipated = 0, external_work = 0
    real(rp) :: momentum(3) = 0, angular_momentum(3) = 0
    real(rp) :: length = 0, flatness = 0
    integer :: steps = 0, rejected_steps = 0, newton_iterations = 0, linear_iterations = 0
    real(rp) :: wall_time = 0            !< wall-clock seconds since the run started (rank 0's clock) [s]
    !> the process models' series at this step (module process_model's
    !> output hook: contact's /energy/barrier and /contact), in the order
    !> of run_info%pm_series; none without process models
    type(pm_series_t), allocatable :: pm_series(:)
  end type output_record

  !> Provenance of a run for the /run group: what a reader needs to
  !> reproduce or compare it. Identical on all ranks (attributes are
  !> collective). Git commit and HDF5 version are filled in here.
  type, public :: run_info
    character(len=32) :: units = 'unknown'       !< the scene's unit system: 'mm g s' or 'SI'
    character(len=64) :: petsc_version = ''
    character(len=64) :: ts_type = '', ts_adapt_type = ''   !< as used, after the options
    real(rp) :: dt = 0, t_end = 0                !< effective (initial) step and end time [time]
    integer :: max_steps = 0                     !< -ts_max_steps (huge when not set)
    real(rp) :: rtol = 0                         !< -ts_rtol [1] (adaptive steps)
    real(rp) :: atol_position = 0                !< absolute tolerance of positions [length]
    real(rp) :: atol_velocity = 0                !< absolute tolerance of velocities [length/time]
    character(len=32) :: start_date = ''         !< ISO 8601, local time with offset
    character(len=256) :: host = ''              !< host of rank 0
    !> the process models' series (names, descriptions, units, shapes:
    !> their values do not matter here) and the groups they live in, made
    !> by output_write_run_info (a restarted file's cut back); none
    !> without process models
    type(pm_series_t), allocatable :: pm_series(:)
    type(pm_group_t), allocatable :: pm_groups(:)
  end type run_info

  ! checkpoint_t (what a checkpoint holds) is module checkpoint_record's.
  public :: checkpoint_t, named_value_t

  !> A restart's judgement of a checkpoint's state before the file changes
  !> (output_reopen): the caller extends it (the run's: the process
  !> models' check_state hooks); judge gives ierr /= 0 and a one-line
  !> errmsg, the same on every rank, to refuse the restart. Collective.
  type, abstract, public :: checkpoint_judge_t
  contains
    procedure(judge_i), deferred :: judge
  end type checkpoint_judge_t

  abstract interface
    !> The checkpoint's state at t: this rank's strips x, v (3, nx, ym).
    subroutine judge_i(this, t, x, v, ierr, errmsg)
      import :: checkpoint_judge_t, rp
      class(checkpoint_judge_t), intent(inout) :: this
      real(rp), intent(in) :: t
      real(rp), intent(in) :: x(:, :, :), v(:, :, :)
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine judge_i
  end interface

  ! Time-dependent datasets, in the order they are extended and written.
  integer, parameter :: d_time = 1, d_position = 2, d_velocity = 3, d_kinetic = 4, &
    d_stretch = 5, d_bend = 6, d_dissipated = 7, d_external_work = 8, d_momentum = 9, &
    d_angular_momentum = 10, d_length = 11, d_flatness = 12, d_steps = 13, &
    d_rejected_steps = 14, d_newton_iterations = 15, d_linear_iterations = 16, d_wall_time = 17
  !> the series every file has; the process models' come after them
  !> (run_info%pm_series, submodule output_pm)
  integer, parameter :: n_dsets = 17
  !> the series of counts, stored as 64-bit integers (the others are float64)
  integer, parameter :: count_series(4) = [d_steps, d_rejected_steps, d_newton_iterations, d_linear_iterations]
  !> the series of 3-vectors [t][xyz] (besides the strips /position and /velocity)
  integer, parameter :: vector_series(2) = [d_momentum, d_angular_momentum]
  character(len=*), parameter :: slot_names(0:1) = [character(len=24) :: '/checkpoint/slot_0', '/checkpoint/slot_1']
  character(len=*), parameter :: dset_names(n_dsets) = [character(len=32) :: &
    '/time', '/position', '/velocity', &
    '/energy/kinetic', '/energy/stretch', '/energy/bend', '/energy/dissipated', &
    '/energy/external_work', '/diagnostics/momentum', '/diagnostics/angular_momentum', &
    '/diagnostics/length', '/diagnostics/flatness', '/diagnostics/steps', &
    '/diagnostics/rejected_steps', '/diagnostics/newton_iterations', &
    '/diagnostics/linear_iterations', '/wall_time']
  character(len=*), parameter :: dset_descriptions(n_dsets) = [character(len=96) :: &
    'simulation time of each output step', &
    'node positions [t][j][i][xyz] of the ny-by-nx lattice', &
    'node velocities [t][j][i][xyz] of the ny-by-nx lattice', &
    'kinetic energy, sum of 1/2 m |v|^2 over the nodes', &
    'stretch (spring) energy', &
    'bending energy (energy model) or bending indicator 1/2 k_b theta^2 (paper model)', &
    'dissipated energy, time integral of the dissipated power', &
    'external work: work of the constraints plus work of gravity', &
    'total linear momentum, sum of m v, [t][xyz]', &
    'total angular momentum about the origin, sum of m x cross v, [t][xyz]', &
    'centre-line length along x at row j = (ny-1)/2', &
    'flatness: largest node distance from the least-squares plane', &
    'accepted time steps since the start (cumulative)', &
    'rejected time steps since the start (cumulative)', &
    'Newton iterations since the start (cumulative)', &
    'linear solver iterations since the start (cumulative)', &
    'wall-clock seconds from the start of the run to this output step']
  ! Output steps per chunk of the small datasets (one step per chunk would make
  ! thousands of tiny chunks; a crash still leaves complete steps readable).
  integer(hsize_t), parameter :: scalar_chunk = 256
  !> Output steps between two refreshes of the HDF5 library (refresh_library):
  !> at most 64 steps' views (2.5 MB a rank) held, for one reopening of the
  !> file (8-10 ms on 2 ranks) in 64 steps.
  integer, parameter :: REFRESH_STEPS = 64

  !> The time series of an open file (submodule output_series).
  type :: series_state
    private
    logical :: write_velocity = .false.
    integer :: nt = 0                           ! output steps completely written
    integer(hid_t) :: dset(n_dsets) = -1
    integer :: drank(n_dsets) = 0
    integer(hsize_t) :: ddims(4, n_dsets) = 0   ! Fortran dims, the last one is t
    real(rp), allocatable :: times(:)           ! output times, for the XDMF file
    ! The process models' series (output_pm): their headers, datasets, ranks, dims
    type(pm_series_t), allocatable :: pm(:)
    integer(hid_t), allocatable :: pm_dset(:)
    integer, allocatable :: pm_rank(:)
    integer(hsize_t), allocatable :: pm_dims(:, :)
  end type series_state

  !> The file names, the lock and the commit of the safety rules (submodule output_files).
  type :: safe_state
    private
    character(len=:), allocatable :: xmf_path, h5_base
    character(len=:), allocatable :: obst_path   ! <file>-obstacles.xdmf: the obstacles' sidecar
    character(len=:), allocatable :: final_path  ! the output file's name
    character(len=:), allocatable :: work_path   ! <final>.partial: written until committed
    character(len=:), allocatable :: lock_path   ! <final>.lock: flock'd by rank 0
    integer :: lock_fd = -1                      ! rank 0's lock file descriptor
    logical :: committed = .false.               ! work_path renamed onto final_path
    logical :: had_earlier = .false.             ! final_path was an earlier nuno output when the run began
    logical :: overwrite = .false.               ! -nuno_overwrite: replace it at the first step, not at the end
    logical :: stepped = .false.                 ! an output step after a successful time step is written
  end type safe_state

  !> Checkpoints and restarts of the series (submodule output_checkpoint).
  type :: checkpoint_state
    private
    logical :: reopened = .false.               ! continued by output_reopen (-nuno_restart)
    integer :: restarts = 0                     ! restarts of the series, this one included
    integer :: ck_seq = 0                       ! sequence of the last valid checkpoint (0: none)
    integer :: ck_slot = -1                     ! its slot, /checkpoint/slot_0 or slot_1 (-1: none)
  end type checkpoint_state

  !> The obstacles of a scene with contact (submodule output_obstacles):
  !> their surfaces in /obstacles and the sidecar <file>-obstacles.xdmf.
  !> n = 0 (no obstacles, or output_write_obstacles not called): nothing of them.
  type :: obstacles_state
    private
    integer :: n = 0                            ! obstacles
    type(contact_config) :: cc                  ! &contact: their shapes, poses and keyframes
    real(rp) :: centre(3) = 0, side = 0         ! a plane's patch: under this point, this side [length]
    character(len=16) :: units = ''             ! the vertices' unit ('m', 'mm'; '': none written)
    character(len=8), allocatable :: shape(:)   ! each one's shape: 'plane', 'sphere', 'box', 'capsule'
    integer, allocatable :: nv(:), nf(:)        ! each one's vertices and triangles
    logical, allocatable :: moving(:)           ! on keyframes: its vertices at every output step
  end type obstacles_state

  !> Opaque handle of an open output file: the open file itself, and one
  !> record per concern.
  type, public :: output_file
    private
    logical :: is_open = .false.
    integer :: comm = MPI_COMM_NULL, rank = 0, n_ranks = 1
    integer :: nx = 0, ny = 0, ys = 0, ym = 0   ! lattice and this rank's rows
    integer(hid_t) :: file = -1, dxpl = -1
    type(series_state) :: series
    type(safe_state) :: safe
    type(checkpoint_state) :: ckpt
    type(obstacles_state) :: obst
  end type output_file

  ! The procedures, by concern, in submodules: output_files (lifecycle and the
  ! safety rules), output_series (lattice, time series and views),
  ! output_results (run info, config, identify, control), output_checkpoint
  ! (checkpoint write, reopen, read), output_xdmf (the sidecar),
  ! output_dims (dimension scales and units for netCDF-4 readers),
  ! output_pm (the process models' series: contact's, for scenes with
  ! obstacles) and output_obstacles (the obstacles' surfaces).
  interface
    module subroutine output_open(out, filename, comm, nx, ny, ys, ym, rest, mass, write_velocity, &
                           attrs_namelist, attrs_petsc_options, ierr, errmsg, version, protect, overwrite)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: filename
      integer, intent(in) :: comm                 ! MPI communicator of the run
      integer, intent(in) :: nx, ny, ys, ym       ! lattice size, first row and row count here
      real(rp), intent(in) :: rest(:, :, :)       ! (3, 0:nx-1, ys:ys+ym-1)
      real(rp), intent(in) :: mass(:, :)          ! (0:nx-1, ys:ys+ym-1)
      logical, intent(in) :: write_velocity
      character(*), intent(in) :: attrs_namelist, attrs_petsc_options
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
      character(*), intent(in), optional :: version   ! default: the CMake project version
      character(*), intent(in), optional :: protect   ! a file that must not be written (the input)
      logical, intent(in), optional :: overwrite      ! -nuno_overwrite (default .false.)
    end subroutine output_open

    module subroutine claim_files(out, protect, ierr, errmsg)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: protect         ! a file that must not be written ('': none)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine claim_files

    module subroutine require_open(out, who, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: who               ! the caller, for the message
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine require_open

    module subroutine handle_init(out, who, filename, comm, nx, ny, ys, ym, write_velocity, overwrite, ierr, errmsg)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: who, filename   ! the caller and its file, for the message
      integer, intent(in) :: comm, nx, ny, ys, ym
      logical, intent(in) :: write_velocity, overwrite
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine handle_init

    module subroutine commit(out, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine commit

    module subroutine output_write_step(out, rec, x, ierr, errmsg, v)
      type(output_file), intent(inout) :: out
      type(output_record), intent(in) :: rec
      real(rp), intent(in) :: x(:, :, :)            ! positions (3, 0:nx-1, ys:ys+ym-1)
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
      real(rp), intent(in), optional :: v(:, :, :)  ! velocities, same shape; needed if write_velocity
    end subroutine output_write_step

    real(rp) module function step_bytes(out)
      type(output_file), intent(in) :: out
    end function step_bytes

    module subroutine check_space(out, bytes, what, ierr, errmsg)
      type(output_file), intent(in) :: out
      real(rp), intent(in) :: bytes
      character(*), intent(in) :: what
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine check_space

    module subroutine add_cause(out, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(inout) :: errmsg
    end subroutine add_cause

    module subroutine output_close(out, status, ierr, errmsg)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: status   ! 'complete' or 'failed: <reason>'
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_close

    module subroutine output_write_run_info(out, info, ierr, errmsg)
      type(output_file), intent(inout) :: out
      type(run_info), intent(in) :: info
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_run_info

    module subroutine output_write_identify(out, names, values, unc, initial, objective, hist, ierr, errmsg)
      type(output_file), intent(inout) :: out
      character(len=*), intent(in) :: names(:)
      real(rp), intent(in) :: values(:), unc(:), initial(:), objective, hist(:, :)
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_identify

    module subroutine output_write_control(out, times, offsets, initial, objective, objective_hist, offset_hist, &
                                    max_speed, components, ierr, errmsg)
      type(output_file), intent(inout) :: out
      real(rp), intent(in) :: times(:), offsets(:, :), initial(:, :), objective, objective_hist(:), &
                              offset_hist(:, :, :), max_speed
      character(*), intent(in) :: components
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_control

    module subroutine config_key_str(out, group, key, value, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: group, key, value
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine config_key_str

    module subroutine config_key_int(out, group, key, value, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: group, key
      integer, intent(in) :: value
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine config_key_int

    module subroutine config_key_reals(out, group, key, values, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: group, key
      real(rp), intent(in) :: values(:)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine config_key_reals

    module subroutine output_write_wall_time(out, seconds, ierr, errmsg)
      type(output_file), intent(inout) :: out
      real(rp), intent(in) :: seconds
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_wall_time

    module subroutine output_write_retried_steps(out, steps, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(in) :: steps
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_retried_steps

    module subroutine open_local(out, filename, rest, mass, namelist, petsc_options, version, ierr, errmsg)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: filename
      real(rp), intent(in) :: rest(:, :, :), mass(:, :)
      character(*), intent(in) :: namelist, petsc_options, version
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine open_local

    module subroutine write_lattice(out, rest, mass, ierr, errmsg)
      type(output_file), intent(inout) :: out
      real(rp), intent(in) :: rest(:, :, :), mass(:, :)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine write_lattice

    module subroutine lattice_views(out, ierr, errmsg)
      type(output_file), intent(in) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine lattice_views

    module subroutine make_view(out, name, src, start, count, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: name, src
      integer(hsize_t), intent(in) :: start(:), count(:)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine make_view

    module subroutine make_view_dims(out, name, src, start, count, vdims, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: name, src
      integer(hsize_t), intent(in) :: start(:), count(:)
      integer(hsize_t), intent(in) :: vdims(:)      ! the view's Fortran dims (C order reversed)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine make_view_dims

    module subroutine drop_view(out, name, ierr, errmsg)
      type(output_file), intent(in) :: out
      character(*), intent(in) :: name
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine drop_view

    module function step_view(idx, k) result(name)
      integer, intent(in) :: idx, k
      character(len=:), allocatable :: name
    end function step_view

    module subroutine create_series(out, idx, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(in) :: idx
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine create_series

    module subroutine close_ids(out, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine close_ids

    module subroutine sidecar_names(filename, xmf_path, h5_base, obst_path)
      character(*), intent(in) :: filename
      character(len=:), allocatable, intent(out) :: xmf_path, h5_base, obst_path
    end subroutine sidecar_names

    module subroutine output_write_checkpoint(out, ck, x, v, ierr, errmsg)
      type(output_file), intent(inout) :: out
      type(checkpoint_t), intent(inout) :: ck
      real(rp), intent(in) :: x(:, :, :), v(:, :, :)
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_checkpoint

    module subroutine refresh_library(out, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine refresh_library

    integer module function output_steps(out)
      type(output_file), intent(in) :: out
    end function output_steps

    module subroutine output_reopen(out, filename, comm, nx, ny, ys, ym, write_velocity, t_end, attrs_namelist, &
                                    attrs_petsc_options, ck, x, v, ierr, errmsg, protect, overwrite, cfg, pm_names, judge)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: filename
      integer, intent(in) :: comm, nx, ny, ys, ym
      logical, intent(in) :: write_velocity
      real(rp), intent(in) :: t_end
      character(*), intent(in) :: attrs_namelist, attrs_petsc_options
      type(checkpoint_t), intent(out) :: ck
      real(rp), intent(out) :: x(:, :, :), v(:, :, :)
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
      character(*), intent(in) :: protect             ! a file that must not be written (the input; '': none)
      logical, intent(in) :: overwrite                ! -nuno_overwrite
      type(nuno_config), intent(in) :: cfg            !< the input's: its scene and model must be the file's
      !> the process models' named values a checkpoint may hold (their
      !> names and kinds: read into ck%pm_values where the slot has them)
      type(named_value_t), intent(in), optional :: pm_names(:)
      !> the run's judgement of the checkpoint's state before the file
      !> changes (the process models' check_state hooks)
      class(checkpoint_judge_t), intent(inout), optional :: judge
    end subroutine output_reopen

    module subroutine open_series(out, nt, extent, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(in) :: nt
      integer, intent(out) :: extent
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine open_series

    module subroutine sync_views(out, extent, ierr, errmsg)
      type(output_file), intent(in) :: out
      integer, intent(in) :: extent
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine sync_views

    module subroutine flush_file(out, ierr, errmsg)
      type(output_file), intent(in) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine flush_file

    module subroutine netcdf_dims(out, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine netcdf_dims

    module subroutine write_units(out, system, ierr, errmsg)
      type(output_file), intent(inout) :: out
      character(*), intent(in) :: system
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine write_units

    module subroutine pm_series_register(out, series, groups, ierr, errmsg)
      type(output_file), intent(inout) :: out
      type(pm_series_t), intent(in) :: series(:)
      type(pm_group_t), intent(in) :: groups(:)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine pm_series_register

    module subroutine pm_series_extend(out, t, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer(hsize_t), intent(in) :: t
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine pm_series_extend

    module subroutine pm_series_write(out, series, ierr, errmsg)
      type(output_file), intent(in) :: out
      type(pm_series_t), intent(in) :: series(:)
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine pm_series_write

    module subroutine pm_series_close(out, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine pm_series_close

    module subroutine pm_series_reopen(out, ierr, errmsg)
      type(output_file), intent(inout) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine pm_series_reopen

    module subroutine write_xdmf(out, ierr, errmsg)
      type(output_file), intent(in) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine write_xdmf

    module subroutine output_write_obstacles(out, cfg, ierr, errmsg)
      type(output_file), intent(inout) :: out
      type(nuno_config), intent(in) :: cfg        !< its &contact, &lattice (a plane's patch) and &scene units
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine output_write_obstacles

    module subroutine obstacles_step(out, time, ierr, errmsg)
      type(output_file), intent(in) :: out
      real(rp), intent(in) :: time
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine obstacles_step

    module function obstacle_view(k, t) result(name)
      integer, intent(in) :: k, t
      character(len=:), allocatable :: name
    end function obstacle_view

    module subroutine drop_obstacles_sidecar(out, ierr, errmsg)
      type(output_file), intent(in) :: out
      integer, intent(inout) :: ierr
      character(*), intent(inout) :: errmsg
    end subroutine drop_obstacles_sidecar
  end interface

end module output
