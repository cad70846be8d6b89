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
  use config, only: nuno_config
  use checkpoint_check, only: checkpoint_t, checkpoint_refusal, scene_refusal
  use safe_files, only: lock_acquire, lock_release, same_file, file_exists, rename_file, free_bytes, &
                        path_kind, kind_none, kind_file, kind_link, kind_dir, kind_unknown, remove_file, &
                        is_nuno_output, is_nuno_sidecar, tmp_open, tmp_write, tmp_commit, cleanup_add, &
                        cleanup_drop, cleanup_file
  implicit none
  private

  public :: output_open, output_write_step, output_close, output_write_run_info, output_write_wall_time
  public :: output_config_key
  public :: output_write_checkpoint, output_reopen, output_steps
  public :: output_write_identify, output_write_control

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
  end type run_info

  ! checkpoint_t (what a checkpoint holds) is module checkpoint_check's.
  public :: checkpoint_t

  ! Time-dependent datasets, in the order they are extended and written.
  integer, parameter :: d_time = 1, d_position = 2, d_velocity = 3, d_kinetic = 4, &
    d_stretch = 5, d_bend = 6, d_dissipated = 7, d_external_work = 8, d_momentum = 9, &
    d_angular_momentum = 10, d_length = 11, d_flatness = 12, d_steps = 13, &
    d_rejected_steps = 14, d_newton_iterations = 15, d_linear_iterations = 16, d_wall_time = 17
  integer, parameter :: n_dsets = 17
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

  !> Opaque handle of an open output file.
  type, public :: output_file
    private
    logical :: is_open = .false.
    logical :: write_velocity = .false.
    integer :: comm = MPI_COMM_NULL, rank = 0, n_ranks = 1
    integer :: nx = 0, ny = 0, ys = 0, ym = 0   ! lattice and this rank's rows
    integer :: nt = 0                           ! output steps completely written
    integer(hid_t) :: file = -1, dxpl = -1
    integer(hid_t) :: dset(n_dsets) = -1
    integer :: drank(n_dsets) = 0
    integer(hsize_t) :: ddims(4, n_dsets) = 0   ! Fortran dims, the last one is t
    character(len=:), allocatable :: xmf_path, h5_base
    character(len=:), allocatable :: final_path  ! the output file's name
    character(len=:), allocatable :: work_path   ! <final>.partial: written until committed
    character(len=:), allocatable :: lock_path   ! <final>.lock: flock'd by rank 0
    integer :: lock_fd = -1                      ! rank 0's lock file descriptor
    logical :: committed = .false.               ! work_path renamed onto final_path
    logical :: had_earlier = .false.             ! final_path was an earlier nuno output when the run began
    logical :: overwrite = .false.               ! -nuno_overwrite: replace it at the first step, not at the end
    logical :: stepped = .false.                 ! an output step after a successful time step is written
    real(rp), allocatable :: times(:)           ! output times, for the XDMF file
    logical :: reopened = .false.               ! continued by output_reopen (-nuno_restart)
    integer :: restarts = 0                     ! restarts of the series, this one included
    integer :: ck_seq = 0                       ! sequence of the last valid checkpoint (0: none)
    integer :: ck_slot = -1                     ! its slot, /checkpoint/slot_0 or slot_1 (-1: none)
  end type output_file


contains

  !> Lock the file, create `<filename>.partial` (an earlier `filename` is left
  !> alone), write root attributes and the lattice, create the time series. Collective.
  subroutine output_open(out, filename, comm, nx, ny, ys, ym, rest, mass, write_velocity, &
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
    integer :: mpierr, rows
    logical :: made
    character(len=256) :: detail

    ierr = 0
    errmsg = ''
    if (out%is_open) then
      ierr = 1
      errmsg = 'output_open: handle already open ('//filename//')'
      return
    end if
    call MPI_Comm_rank(comm, out%rank, mpierr)
    call MPI_Comm_size(comm, out%n_ranks, mpierr)
    ! Shape checks, then a reduction so that every rank takes the same branch.
    if (nx < 1 .or. ny < 1 .or. ys < 0 .or. ym < 0 .or. ys + ym > ny) then
      ierr = 1
      errmsg = 'output_open: bad lattice strip (nx, ny, ys, ym) for '//filename
    else if (size(rest, 1) /= 3 .or. size(rest, 2) /= nx .or. size(rest, 3) /= ym) then
      ierr = 1
      errmsg = 'output_open: rest must be (3, nx, ym) for /lattice/rest_position'
    else if (size(mass, 1) /= nx .or. size(mass, 2) /= ym) then
      ierr = 1
      errmsg = 'output_open: mass must be (nx, ym) for /lattice/mass'
    end if
    call MPI_Allreduce(ym, rows, 1, MPI_INTEGER, MPI_SUM, comm, mpierr)
    if (ierr == 0 .and. rows /= ny) then
      ierr = 1
      errmsg = 'output_open: the ranks'' rows do not add up to ny'
    end if
    call agree(comm, 'output_open', ierr, errmsg)
    if (ierr /= 0) return

    out%comm = comm
    out%nx = nx
    out%ny = ny
    out%ys = ys
    out%ym = ym
    out%nt = 0
    out%write_velocity = write_velocity
    call sidecar_names(filename, out%xmf_path, out%h5_base)
    if (allocated(out%times)) deallocate(out%times)
    allocate(out%times(16))
    out%final_path = filename
    out%work_path = filename//'.partial'
    out%lock_path = filename//'.lock'
    out%committed = .false.
    out%reopened = .false.
    out%stepped = .false.
    out%overwrite = .false.
    if (present(overwrite)) out%overwrite = overwrite

    ! Before anything is written: not the input file, no other writer, and
    ! only nuno's own files under the names this run writes.
    if (out%rank == 0) call claim_files(out, ierr, errmsg, protect)
    call agree(comm, 'output_open', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
      return
    end if
    call MPI_Bcast(out%had_earlier, 1, MPI_LOGICAL, 0, comm, mpierr)

    ! The file, the lattice and a first step must fit (check_space).
    call check_space(out, 32.0_rp * nx * ny + step_bytes(out) + 2.0_rp * (len(attrs_namelist) + len(attrs_petsc_options)), &
                     'a new output file', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
      return
    end if
    call open_local(out, out%work_path, rest, mass, attrs_namelist, attrs_petsc_options, ierr, errmsg, version)
    call agree(comm, 'output_open', ierr, errmsg)
    ! Made by this run (created: the file is open here): an error exit
    ! before it holds a result removes it (errors: cleanup_run), and so
    ! does a failure here; a name this run did not create is left alone.
    made = out%is_open
    if (out%rank == 0 .and. made) call cleanup_add(out%work_path, cleanup_file)
    if (ierr /= 0) then
      call close_ids(out, ierr, errmsg)   ! best effort; ierr/errmsg keep the first error
      out%is_open = .false.
      if (out%rank == 0 .and. made) then
        call remove_file(out%work_path, made, detail)
        call cleanup_drop(out%work_path)
      end if
      if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
    end if
  end subroutine output_open

  !> Rank 0: refuse to write over `protect` (by any of the names this run
  !> writes), then take the lock. The lock file is made beside the output,
  !> so a missing or unwritable directory is reported here, with its cause.
  subroutine claim_files(out, ierr, errmsg, protect)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(*), intent(in), optional :: protect
    character(len=256) :: detail
    integer :: code
    logical :: stale, ok

    if (present(protect)) then
      if (same_file(protect, out%final_path) .or. same_file(protect, out%work_path) .or. &
          same_file(protect, out%lock_path) .or. same_file(protect, out%xmf_path)) then
        ierr = 1
        errmsg = "input: &output: output_file = '"//out%final_path//"' would overwrite the input file "// &
                 protect//': choose another output_file'
        return
      end if
    end if
    call lock_acquire(out%lock_path, out%lock_fd, code, detail)
    if (code == 1) then
      ierr = 1
      errmsg = 'output: '//out%final_path//' is being written by another run ('//trim(detail)// &
               ', lock '//out%lock_path//'): wait for it to end or choose another output_file'
    else if (code == 3) then
      ierr = 1
      errmsg = 'output: nuno''s lock file '//out%lock_path//' cannot be made: '//trim(detail)// &
               '; nuno never writes through or over what it did not make: move it away or choose another output_file'
    else if (code /= 0) then
      ierr = 1
      errmsg = 'output: cannot create '//out%lock_path//' beside the output file: '//trim(detail)
    end if
    if (ierr /= 0) return
    ! Under the lock, the names this run writes: each must be free or a
    ! regular file that nuno wrote (an earlier result, a killed run's
    ! attempt, a sidecar), never a link, a directory or a user's file.
    out%had_earlier = .false.
    if (out%work_path /= out%final_path) then
      call own_or_free(out%final_path, 'output file', out%had_earlier)
      if (ierr == 0 .and. .not. out%reopened) then
        call own_or_free(out%work_path, 'working file', stale)
        ! A killed run's attempt (nuno's, under this lock): replaced.
        if (ierr == 0 .and. stale) then
          call remove_file(out%work_path, ok, detail)
          if (.not. ok) then
            ierr = 1
            errmsg = 'output: cannot remove the earlier attempt '//out%work_path//': '//trim(detail)
          end if
        end if
      end if
    end if
    if (ierr == 0 .and. out%reopened) then
      ! Opened for writing only when it is nuno's (an HDF5 file of another
      ! program could be changed by the mere open and close).
      if (path_kind(out%work_path, detail) /= kind_file) then
        ierr = 1
        errmsg = '-nuno_restart '//out%work_path//': not a regular file (a symbolic link, a directory or '// &
                 'another kind of file): nuno continues only its own output files'
      else if (.not. is_nuno_output(out%work_path)) then
        ierr = 1
        errmsg = '-nuno_restart '//out%work_path//': not a nuno output file: nuno continues only its own output files'
      end if
    end if
    if (ierr == 0) call own_or_free(out%xmf_path, 'XDMF sidecar', stale, sidecar=.true.)
  contains
    !> ierr = 1 unless path is free or a regular file of nuno's (exists: it is).
    subroutine own_or_free(path, what, exists, sidecar)
      character(*), intent(in) :: path, what
      logical, intent(out) :: exists
      logical, intent(in), optional :: sidecar
      character(len=256) :: why
      integer :: k
      logical :: own
      exists = .false.
      k = path_kind(path, why)
      if (k == kind_none) return
      exists = k == kind_file
      if (k == kind_file) then
        if (present(sidecar)) then
          own = is_nuno_sidecar(path)
        else
          own = is_nuno_output(path)
        end if
        if (own) return
        why = 'it exists and is not '//merge('an XDMF sidecar written by nuno', 'an output file of nuno         ', &
                                           present(sidecar))
      else if (k == kind_link) then
        why = 'it is a symbolic link'
      else if (k == kind_dir) then
        why = 'it is a directory'
      else if (k /= kind_unknown) then
        why = 'it is not a regular file'
      end if
      ierr = 1
      errmsg = 'output: '//path//' (this run''s '//what//'): '//trim(why)// &
               '; nuno replaces only its own files, never through a link: move it away or choose another output_file'
    end subroutine own_or_free
  end subroutine claim_files

  !> Rename `<file>.partial` onto `<file>` (rank 0), then write the XDMF
  !> sidecar, which names `<file>`. Collective; from here on an earlier
  !> `<file>` is replaced, atomically.
  subroutine commit(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=256) :: detail
    logical :: ok

    if (out%committed .or. ierr /= 0) return
    if (out%rank == 0) then
      call rename_file(out%work_path, out%final_path, ok, detail)
      if (.not. ok) then
        ierr = 1
        errmsg = 'output: cannot rename '//out%work_path//' to '//out%final_path//': '//trim(detail)
      else
        call cleanup_drop(out%work_path)
      end if
    end if
    call agree(out%comm, 'output: rename', ierr, errmsg)
    if (ierr /= 0) return
    out%committed = .true.
    if (out%rank == 0) call write_xdmf(out, ierr, errmsg)
  end subroutine commit

  !> Append one output step: extend all datasets, write this rank's strip and rank 0's scalars, flush. Collective.
  subroutine output_write_step(out, rec, x, ierr, errmsg, v)
    type(output_file), intent(inout) :: out
    type(output_record), intent(in) :: rec
    real(rp), intent(in) :: x(:, :, :)            ! positions (3, 0:nx-1, ys:ys+ym-1)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp), intent(in), optional :: v(:, :, :)  ! velocities, same shape; needed if write_velocity

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_write_step: the output file is not open'
      return
    end if
    if (size(x, 1) /= 3 .or. size(x, 2) /= out%nx .or. size(x, 3) /= out%ym) then
      ierr = 1
      errmsg = 'output_write_step: x must be (3, nx, ym) for /position'
    else if (out%write_velocity .and. .not. present(v)) then
      ierr = 1
      errmsg = 'output_write_step: v is required for /velocity'
    else if (out%write_velocity) then
      if (size(v, 1) /= 3 .or. size(v, 2) /= out%nx .or. size(v, 3) /= out%ym) then
        ierr = 1
        errmsg = 'output_write_step: v must be (3, nx, ym) for /velocity'
      end if
    end if
    call agree(out%comm, 'output_write_step', ierr, errmsg)
    if (ierr /= 0) return
    call check_space(out, step_bytes(out), 'output step '//str(out%nt), ierr, errmsg)
    if (ierr /= 0) return

    if (out%write_velocity) then
      call write_step_local(out, rec, x, ierr, errmsg, v)
    else
      call write_step_local(out, rec, x, ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_step', ierr, errmsg)
    if (ierr /= 0) call add_cause(out, errmsg)
    ! rec%steps > 0: a time step succeeded and its result is on disk: the
    ! file is a result now (an error exit keeps it), and takes the output's
    ! name unless that would replace an earlier result before this run
    ! completes (output_close; -nuno_overwrite: now).
    if (ierr == 0 .and. rec%steps > 0) then
      if (.not. out%stepped .and. out%rank == 0) call cleanup_drop(out%work_path)
      out%stepped = .true.
      if (.not. out%had_earlier .or. out%overwrite) call commit(out, ierr, errmsg)
    end if
    ! The memory parallel HDF5 keeps for the objects made so far (the views)
    if (ierr == 0 .and. mod(out%nt, REFRESH_STEPS) == 0) then
      call refresh_library(out, ierr, errmsg)
      call agree(out%comm, 'output_write_step', ierr, errmsg)
    end if
  end subroutine output_write_step

  !> Bytes of one output step in the file (the strips and a margin for the
  !> scalars and metadata).
  real(rp) function step_bytes(out)
    type(output_file), intent(in) :: out
    step_bytes = 24.0_rp * out%nx * out%ny * merge(2, 1, out%write_velocity) + 65536.0_rp
  end function step_bytes

  !> Refuse a write of about `bytes` before any HDF5 call when the file
  !> system does not have twice that free: a full disk found inside a
  !> collective HDF5 call fails on some ranks only, and parallel HDF5 1.10
  !> then leaves the others waiting (a hang). Rank 0 asks (statvfs), every
  !> rank gets the answer. Collective.
  subroutine check_space(out, bytes, what, ierr, errmsg)
    type(output_file), intent(in) :: out
    real(rp), intent(in) :: bytes
    character(*), intent(in) :: what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp) :: free
    character(len=24) :: fb, nb
    character(len=:), allocatable :: path

    if (out%rank == 0) then
      path = out%work_path
      if (out%committed) path = out%final_path
      free = free_bytes(path)
      if (free >= 0.0_rp .and. free < 2.0_rp * bytes) then
        write(fb, '(es10.3e2)') free
        write(nb, '(es10.3e2)') 2.0_rp * bytes
        ierr = 1
        errmsg = 'output: no space left for '//what//' in '//path//' ('//trim(adjustl(fb))//' bytes free, '// &
                 trim(adjustl(nb))//' needed)'
        if (out%is_open) errmsg = trim(errmsg)//': the file holds the '//str(out%nt)//' output steps before it'
      end if
    end if
    call agree(out%comm, 'output', ierr, errmsg)
  end subroutine check_space

  !> A failed write says nothing of its cause through HDF5: rank 0 adds
  !> what the file system says (a full disk, or free space: then quota,
  !> permissions or an I/O error), the same text on every rank. Collective.
  subroutine add_cause(out, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(inout) :: errmsg
    real(rp) :: free
    character(len=32) :: buf
    integer :: mpierr
    character(len=:), allocatable :: path

    if (out%rank == 0) then
      path = out%work_path
      if (out%committed) path = out%final_path
      free = free_bytes(path)
      write(buf, '(es10.3e2)') free
      if (free < 0.0_rp) then
        continue
      else if (free < 2.0_rp * step_bytes(out)) then
        errmsg = trim(errmsg)//' in '//path//': no space left on its file system ('//trim(adjustl(buf))//' bytes free)'
      else
        errmsg = trim(errmsg)//' in '//path//' (its file system has '//trim(adjustl(buf))// &
                 ' bytes free: a quota, permissions or an I/O error)'
      end if
    end if
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, 0, out%comm, mpierr)
  end subroutine add_cause

  !> Write the XDMF file, then the root attribute status (last), then close every id and the file. Collective.
  subroutine output_close(out, status, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: status   ! 'complete' or 'failed: <reason>'
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: e2, mpierr
    character(len=len(errmsg)) :: msg2
    logical :: keep

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) return   ! never opened, failed open, or closed already
    ! Not committed: no time step succeeded (or none was written). A complete
    ! run, or one with no earlier file to protect, takes the name now; a
    ! failed one leaves an earlier file as it was and its own as .partial.
    if (.not. out%committed) then
      keep = .false.
      if (out%rank == 0) keep = status /= 'complete' .and. file_exists(out%final_path)
      call MPI_Bcast(keep, 1, MPI_LOGICAL, 0, out%comm, mpierr)
      if (keep) then
        if (out%rank == 0) write(*, '(a)') 'output: the earlier '//out%final_path// &
          ' is kept as it was; this run''s file is '//out%work_path//' (-nuno_restart '//out%final_path// &
          ' continues it from its checkpoint, if it has one)'
        if (out%rank == 0) call cleanup_drop(out%work_path)   ! the record of the failure
      else
        call commit(out, ierr, errmsg)   ! writes the XDMF sidecar
      end if
    else
      if (out%rank == 0) call write_xdmf(out, ierr, errmsg)
    end if
    ! status after everything else, so that 'complete' means complete.
    e2 = 0
    call set_attr_str(out%file, 'status', status, '/', e2, msg2)
    if (e2 == 0) then
      call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, e2)
      if (e2 < 0) call fail('h5fflush_f', '/', e2, msg2)
    end if
    call keep_first(ierr, errmsg, e2, msg2)
    call close_ids(out, ierr, errmsg)
    out%is_open = .false.
    if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
    call agree(out%comm, 'output_close', ierr, errmsg)
  end subroutine output_close

  !> The group /run (provenance: versions, git commit, solver as used, date,
  !> host), the root attribute units, and the /wall_time series. Call once,
  !> after output_open and before the first output_write_step. Collective.
  subroutine output_write_run_info(out, info, ierr, errmsg)
    type(output_file), intent(inout) :: out
    type(run_info), intent(in) :: info
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    ! git_commit: the build's commit (cmake/git_commit.cmake, rewritten at every build)
    include 'nuno_git_commit.inc'
    integer(hid_t) :: grp
    integer :: h, major, minor, release
    character(len=32) :: hdf5_version
    character(len=:), allocatable :: where

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_write_run_info: the output file is not open'
      return
    end if
    if (out%nt /= 0 .and. .not. out%reopened) then
      ierr = 1
      errmsg = 'output_write_run_info: must come before the first output step (/wall_time)'
    end if
    ! The library actually linked, not the headers compiled against.
    if (ierr == 0) then
      call h5get_libversion_f(major, minor, release, h)
      if (h < 0) call fail('h5get_libversion_f', '/run', ierr, errmsg)
      write(hdf5_version, '(i0,a,i0,a,i0)') major, '.', minor, '.', release
    end if
    if (ierr == 0) call set_attr_str(out%file, 'units', trim(info%units), '/', ierr, errmsg)
    ! A continued run (output_reopen) keeps the first run's /run and
    ! describes itself in /run/restart_<k>.
    if (out%reopened) then
      where = '/run/restart_'//str(out%restarts)
    else
      where = '/run'
    end if
    if (ierr == 0) call open_or_create_group(out%file, where, grp, ierr, errmsg)
    if (ierr == 0) then
      call set_attr_str(grp, 'git_commit', git_commit, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'petsc_version', trim(info%petsc_version), where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'hdf5_version', trim(hdf5_version), where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'ts_type', trim(info%ts_type), where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'ts_adapt_type', trim(info%ts_adapt_type), where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'dt', [info%dt], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 't_end', [info%t_end], where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'max_steps', info%max_steps, where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'rtol', [info%rtol], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'atol_position', [info%atol_position], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'atol_velocity', [info%atol_velocity], where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'start_date', trim(info%start_date), where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'host', trim(info%host), where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'n_ranks', out%n_ranks, where, ierr, errmsg)
      call h5gclose_f(grp, h)
      if (h < 0) call fail('h5gclose_f', where, ierr, errmsg)
    end if
    if (ierr == 0 .and. out%dset(d_wall_time) < 0) &
      call create_series(out, d_wall_time, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    if (ierr == 0) then
      call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
      if (h < 0) call fail('h5fflush_f', '/', ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_run_info', ierr, errmsg)
  end subroutine output_write_run_info

  !> /identify of an identification run (docs/identification.md): names
  !> [np] (strings), values, uncertainty, initial [np], objective (scalar),
  !> history [n_iterations][np+1] (objective, then the values, per TAO
  !> iteration). Small datasets: every rank writes the same values. Collective.
  subroutine output_write_identify(out, names, values, unc, initial, objective, hist, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(len=*), intent(in) :: names(:)
    real(rp), intent(in) :: values(:), unc(:), initial(:), objective, hist(:, :)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: grp, strtype, space, dset
    integer :: h

    ierr = 0
    errmsg = ''
    call open_or_create_group(out%file, '/identify', grp, ierr, errmsg)
    if (ierr /= 0) goto 900
    call put_doubles(grp, '/identify', 'values', values, [int(size(values), hsize_t)], ierr, errmsg)
    call put_doubles(grp, '/identify', 'uncertainty', unc, [int(size(unc), hsize_t)], ierr, errmsg)
    call put_doubles(grp, '/identify', 'initial', initial, [int(size(initial), hsize_t)], ierr, errmsg)
    call put_doubles(grp, '/identify', 'objective', [objective], [1_hsize_t], ierr, errmsg)
    call put_doubles(grp, '/identify', 'history', reshape(hist, [size(hist)]), &
                     [int(size(hist, 1), hsize_t), int(size(hist, 2), hsize_t)], ierr, errmsg)
    if (ierr == 0) then
      call h5tcopy_f(H5T_FORTRAN_S1, strtype, h)
      call h5tset_size_f(strtype, int(len(names), size_t), h)
      call h5screate_simple_f(1, [int(size(names), hsize_t)], space, h)
      call h5dcreate_f(grp, 'names', strtype, space, dset, h)
      if (h < 0) then
        call fail('h5dcreate_f', '/identify/names', ierr, errmsg)
      else
        call h5dwrite_f(dset, strtype, names, [int(size(names), hsize_t)], h)
        if (h < 0) call fail('h5dwrite_f', '/identify/names', ierr, errmsg)
        call h5dclose_f(dset, h)
      end if
      call h5sclose_f(space, h)
      call h5tclose_f(strtype, h)
    end if
    call close_and_flush(out, grp, '/identify', ierr, errmsg)
900 call agree(out%comm, 'output_write_identify', ierr, errmsg)
  end subroutine output_write_identify

  !> /control of a deformation-control run (docs/identification.md):
  !> keyframe_time [nk], keyframe_offset and initial_offset [nk][3] (the
  !> optimised and the initial offsets of the driven nodes from rest),
  !> objective [1] (at the optimum), objective_history [nit] and
  !> keyframe_history [nit][nk][3] (per TAO iteration), max_speed [1] (the
  !> bound; +Infinity: none), attribute components. Small datasets: every
  !> rank writes the same values. Collective.
  subroutine output_write_control(out, times, offsets, initial, objective, objective_hist, offset_hist, &
                                  max_speed, components, ierr, errmsg)
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: times(:), offsets(:, :), initial(:, :), objective, objective_hist(:), &
                            offset_hist(:, :, :), max_speed
    character(*), intent(in) :: components
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: grp
    integer(hsize_t) :: nk, nit

    ierr = 0
    errmsg = ''
    nk = int(size(times), hsize_t)
    nit = int(size(objective_hist), hsize_t)
    call open_or_create_group(out%file, '/control', grp, ierr, errmsg)
    if (ierr /= 0) goto 900
    call put_doubles(grp, '/control', 'keyframe_time', times, [nk], ierr, errmsg)
    call put_doubles(grp, '/control', 'keyframe_offset', reshape(offsets, [size(offsets)]), [3_hsize_t, nk], &
                     ierr, errmsg)
    call put_doubles(grp, '/control', 'initial_offset', reshape(initial, [size(initial)]), [3_hsize_t, nk], &
                     ierr, errmsg)
    call put_doubles(grp, '/control', 'objective', [objective], [1_hsize_t], ierr, errmsg)
    call put_doubles(grp, '/control', 'objective_history', objective_hist, [nit], ierr, errmsg)
    call put_doubles(grp, '/control', 'keyframe_history', reshape(offset_hist, [size(offset_hist)]), &
                     [3_hsize_t, nk, nit], ierr, errmsg)
    call put_doubles(grp, '/control', 'max_speed', [max_speed], [1_hsize_t], ierr, errmsg)
    if (ierr == 0) call set_attr_str(grp, 'components', trim(components), '/control', ierr, errmsg)
    call close_and_flush(out, grp, '/control', ierr, errmsg)
900 call agree(out%comm, 'output_write_control', ierr, errmsg)
  end subroutine output_write_control

  !> Close the group grp (at gpath, for messages) and flush the file, so
  !> that what was written survives a later failure.
  subroutine close_and_flush(out, grp, gpath, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: gpath
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5gclose_f(grp, h)
    if (ierr /= 0) return
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', gpath, ierr, errmsg)
  end subroutine close_and_flush

  !> A float64 dataset `name` of shape dims (Fortran order: C order reversed)
  !> in grp (at path gpath, for messages); nothing when ierr /= 0 already.
  subroutine put_doubles(grp, gpath, name, v, dims, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: gpath, name
    real(rp), intent(in) :: v(:)
    integer(hsize_t), intent(in) :: dims(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: sp, ds
    integer :: h
    if (ierr /= 0) return
    call h5screate_simple_f(size(dims), dims, sp, h)
    call h5dcreate_f(grp, name, H5T_NATIVE_DOUBLE, sp, ds, h)
    if (h < 0) then
      call fail('h5dcreate_f', gpath//'/'//name, ierr, errmsg)
    else
      call h5dwrite_f(ds, H5T_NATIVE_DOUBLE, v, dims, h)
      if (h < 0) call fail('h5dwrite_f', gpath//'/'//name, ierr, errmsg)
      call h5dclose_f(ds, h)
    end if
    call h5sclose_f(sp, h)
  end subroutine put_doubles

  !> Open the group path (absolute, one level below an existing group), or
  !> create it; grp must be closed by the caller.
  subroutine open_or_create_group(file, path, grp, ierr, errmsg)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: path
    integer(hid_t), intent(out) :: grp
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    grp = -1
    call h5lexists_f(file, path, exists, h)
    if (h < 0) then
      call fail('h5lexists_f', path, ierr, errmsg); return
    end if
    if (exists) then
      call h5gopen_f(file, path, grp, h)
      if (h < 0) call fail('h5gopen_f', path, ierr, errmsg)
    else
      call h5gcreate_f(file, path, grp, h)
      if (h < 0) call fail('h5gcreate_f', path, ierr, errmsg)
    end if
    if (ierr /= 0) grp = -1
  end subroutine open_or_create_group

  !> /config/<group>, created on first use; grp must be closed by the caller.
  subroutine config_group(out, group, grp, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: group
    integer(hid_t), intent(out) :: grp
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: top

    grp = -1
    if (ierr /= 0) return
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_config_key: the output file is not open'
      return
    end if
    call open_or_create_group(out%file, '/config', top, ierr, errmsg)
    if (ierr /= 0) return
    call open_or_create_group(out%file, '/config/'//group, grp, ierr, errmsg)
    call close_group(top, '/config', ierr, errmsg)
  end subroutine config_group

  subroutine close_group(grp, where, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: where
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    if (grp < 0) return
    call h5gclose_f(grp, h)
    if (h < 0) call fail('h5gclose_f', where, ierr, errmsg)
  end subroutine close_group

  !> A string key of /config/<group>. Collective (same values on all ranks);
  !> keeps the first error in ierr/errmsg, so that calls can be chained.
  subroutine config_key_str(out, group, key, value, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: group, key, value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    call config_group(out, group, grp, ierr, errmsg)
    if (ierr == 0) call set_attr_str(grp, key, value, '/config/'//group, ierr, errmsg)
    call close_group(grp, '/config/'//group, ierr, errmsg)
  end subroutine config_key_str

  subroutine config_key_int(out, group, key, value, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: group, key
    integer, intent(in) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    call config_group(out, group, grp, ierr, errmsg)
    if (ierr == 0) call set_attr_int(grp, key, value, '/config/'//group, ierr, errmsg)
    call close_group(grp, '/config/'//group, ierr, errmsg)
  end subroutine config_key_int

  !> A real key (one value: a scalar attribute; several: a 1-D one).
  subroutine config_key_reals(out, group, key, values, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp

    call config_group(out, group, grp, ierr, errmsg)
    if (ierr == 0) call set_attr_reals(grp, key, values, '/config/'//group, ierr, errmsg)
    call close_group(grp, '/config/'//group, ierr, errmsg)
  end subroutine config_key_reals

  !> The attribute /run/wall_time [s], the wall time of the whole run; the
  !> same value on every rank (attributes are collective). Collective.
  subroutine output_write_wall_time(out, seconds, ierr, errmsg)
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: seconds
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: grp
    integer :: h

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_write_wall_time: the output file is not open'
      return
    end if
    call h5gopen_f(out%file, 'run', grp, h)
    if (h < 0) then
      call fail('h5gopen_f (output_write_run_info first)', '/run', ierr, errmsg)
    else
      call set_attr_reals(grp, 'wall_time', [seconds], '/run', ierr, errmsg)
      call h5gclose_f(grp, h)
      if (h < 0) call fail('h5gclose_f', '/run', ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_wall_time', ierr, errmsg)
  end subroutine output_write_wall_time

  ! ---------------------------------------------------------------------------
  ! Open: file, root attributes, lattice, time series.

  subroutine open_local(out, filename, rest, mass, namelist, petsc_options, ierr, errmsg, version)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: filename
    real(rp), intent(in) :: rest(:, :, :), mass(:, :)
    character(*), intent(in) :: namelist, petsc_options
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(*), intent(in), optional :: version
    integer(hid_t) :: fapl, grp
    integer :: h, i
    integer(hsize_t) :: chunk_rows
#ifdef NUNO_VERSION
    character(len=*), parameter :: default_version = NUNO_VERSION
#else
    character(len=*), parameter :: default_version = '0.1.0'
#endif

    call h5open_f(h)
    if (h < 0) then
      call fail('h5open_f', filename, ierr, errmsg); return
    end if
    ! No HDF5 error stack on stderr: a failure comes back as one line of ours.
    call h5eset_auto_f(0, h)
    call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
    if (h < 0) then
      call fail('h5pcreate_f(file access)', filename, ierr, errmsg); return
    end if
    call h5pset_fapl_mpio_f(fapl, out%comm, MPI_INFO_NULL, h)
    if (h < 0) call fail('h5pset_fapl_mpio_f', filename, ierr, errmsg)
    ! The 1.8 file format: attributes over 64 KiB (long namelists) are allowed,
    ! and a file left open by a crash still opens without h5clear (superblock
    ! version 2). Objects up to the 1.10 format are allowed, for the virtual
    ! datasets of /xdmf (layout message version 4; HDF5 refuses them with
    ! the bound at 1.8); everything else is written as with 1.8 bounds.
    if (ierr == 0) then
      call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V110_F, h)
      if (h < 0) call fail('h5pset_libver_bounds_f', filename, ierr, errmsg)
    end if
    if (ierr == 0) then
      ! EXCL: a new file (O_EXCL), never one that took the name meanwhile
      ! nor the target of a symbolic link (claim_files cleared the name).
      call h5fcreate_f(filename, H5F_ACC_EXCL_F, out%file, h, access_prp=fapl)
      if (h < 0) call fail('h5fcreate_f', filename, ierr, errmsg)
    end if
    call h5pclose_f(fapl, h)
    if (h < 0) call fail('h5pclose_f(file access)', filename, ierr, errmsg)
    if (ierr /= 0) return
    out%is_open = .true.

    call h5pcreate_f(H5P_DATASET_XFER_F, out%dxpl, h)
    if (h < 0) then
      call fail('h5pcreate_f(dataset transfer)', filename, ierr, errmsg); return
    end if
    call h5pset_dxpl_mpio_f(out%dxpl, H5FD_MPIO_COLLECTIVE_F, h)
    if (h < 0) then
      call fail('h5pset_dxpl_mpio_f', filename, ierr, errmsg); return
    end if

    ! Root attributes (metadata: every rank makes the same calls with the same values).
    if (present(version)) then
      call set_attr_str(out%file, 'program_version', version, '/', ierr, errmsg)
    else
      call set_attr_str(out%file, 'program_version', default_version, '/', ierr, errmsg)
    end if
    if (ierr == 0) call set_attr_int(out%file, 'nx', out%nx, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'ny', out%ny, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_ranks', out%n_ranks, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%file, 'namelist', namelist, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%file, 'petsc_options', petsc_options, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%file, 'status', 'running', '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_output_steps', 0, '/', ierr, errmsg)
    if (ierr /= 0) return

    ! Groups.
    do i = 1, 3
      block
        character(len=12), parameter :: groups(3) = [character(len=12) :: 'lattice', 'energy', 'diagnostics']
        call h5gcreate_f(out%file, trim(groups(i)), grp, h)
        if (h < 0) then
          call fail('h5gcreate_f', '/'//trim(groups(i)), ierr, errmsg); return
        end if
        call h5gclose_f(grp, h)
        if (h < 0) then
          call fail('h5gclose_f', '/'//trim(groups(i)), ierr, errmsg); return
        end if
      end block
    end do

    call write_lattice(out, rest, mass, ierr, errmsg)
    if (ierr /= 0) return
    call lattice_views(out, ierr, errmsg)
    if (ierr /= 0) return

    ! Time series. Position chunks hold one step (whole rows, at most ~1 GiB).
    chunk_rows = max(1_hsize_t, min(int(out%ny, hsize_t), (2_hsize_t**30)/(24_hsize_t*out%nx)))
    call create_series(out, d_time, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    if (ierr == 0) call create_series(out, d_position, [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], &
      [3_hsize_t, int(out%nx, hsize_t), chunk_rows, 1_hsize_t], H5T_NATIVE_DOUBLE, ierr, errmsg)
    if (ierr == 0 .and. out%write_velocity) call create_series(out, d_velocity, &
      [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], &
      [3_hsize_t, int(out%nx, hsize_t), chunk_rows, 1_hsize_t], H5T_NATIVE_DOUBLE, ierr, errmsg)
    do i = d_kinetic, d_external_work
      if (ierr == 0) call create_series(out, i, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    end do
    do i = d_momentum, d_angular_momentum
      if (ierr == 0) call create_series(out, i, [3_hsize_t], [3_hsize_t, scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    end do
    do i = d_length, d_flatness
      if (ierr == 0) call create_series(out, i, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    end do
    do i = d_steps, d_linear_iterations
      if (ierr == 0) call create_series(out, i, [integer(hsize_t) ::], [scalar_chunk], H5T_STD_I64LE, ierr, errmsg)
    end do
    if (ierr /= 0) return

    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', filename, ierr, errmsg)
  end subroutine open_local

  !> /lattice/rest_position (3, nx, ny) and /lattice/mass (nx, ny), each rank its rows.
  subroutine write_lattice(out, rest, mass, ierr, errmsg)
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: rest(:, :, :), mass(:, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dset
    integer(hsize_t) :: nx, ny, ys, ym

    nx = out%nx; ny = out%ny; ys = out%ys; ym = out%ym
    call create_fixed(out, '/lattice/rest_position', [3_hsize_t, nx, ny], &
                      'rest positions of the nodes [j][i][xyz]', dset, ierr, errmsg)
    if (ierr /= 0) return
    call write_rows3(out, dset, '/lattice/rest_position', [0_hsize_t, 0_hsize_t, ys], &
                     [3_hsize_t, nx, ym], rest, ierr, errmsg)
    call close_dset(dset, '/lattice/rest_position', ierr, errmsg)
    if (ierr /= 0) return

    call create_fixed(out, '/lattice/mass', [nx, ny], 'nodal masses [j][i]', dset, ierr, errmsg)
    if (ierr /= 0) return
    call write_rows2(out, dset, '/lattice/mass', [0_hsize_t, ys], [nx, ym], mass, ierr, errmsg)
    call close_dset(dset, '/lattice/mass', ierr, errmsg)
  end subroutine write_lattice

  subroutine create_fixed(out, name, dims, description, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name, description
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer :: h

    dset = -1
    call h5screate_simple_f(size(dims), dims, space, h)
    if (h < 0) then
      call fail('h5screate_simple_f', name, ierr, errmsg); return
    end if
    call h5dcreate_f(out%file, name, H5T_NATIVE_DOUBLE, space, dset, h)
    if (h < 0) call fail('h5dcreate_f', name, ierr, errmsg)
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    if (ierr == 0) call set_attr_str(dset, 'description', description, name, ierr, errmsg)
  end subroutine create_fixed

  ! ---------------------------------------------------------------------------
  ! XDMF views: HDF5 virtual datasets in /xdmf that map a part of a dataset
  ! of the same file (source file '.', so a renamed or moved file keeps
  ! them). Shapes have a leading 1 (one layer of points, the sidecar's
  ! 3DSMesh "1 ny nx"): /xdmf/position_<k>, /xdmf/velocity_<k> [1][ny][nx][3]
  ! (step k, 0-based), /xdmf/rest_position [1][ny][nx][3], /xdmf/mass
  ! [1][ny][nx]. Creating or deleting one is metadata only; every rank
  ! makes the same calls.

  !> The group /xdmf and its views of the lattice, made when missing.
  subroutine lattice_views(out, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    integer(hsize_t) :: nx, ny
    logical :: exists
    integer :: h

    nx = out%nx; ny = out%ny
    call open_or_create_group(out%file, '/xdmf', grp, ierr, errmsg)
    if (ierr == 0) call set_attr_str(grp, 'description', 'views for the XDMF sidecar NAME.xmf: '// &
      'HDF5 virtual datasets (no data of their own) of /lattice and of step k of /position and /velocity, '// &
      'shaped [1][ny][nx](3); only the first n_output_steps steps are complete', '/xdmf', ierr, errmsg)
    call close_group(grp, '/xdmf', ierr, errmsg)
    if (ierr /= 0) return
    call h5lexists_f(out%file, '/xdmf/rest_position', exists, h)
    if (h < 0) then
      call fail('h5lexists_f', '/xdmf/rest_position', ierr, errmsg); return
    end if
    if (.not. exists) call make_view(out, 'rest_position', '/lattice/rest_position', [0_hsize_t, 0_hsize_t, 0_hsize_t], &
                                     [3_hsize_t, nx, ny], ierr, errmsg)
    if (ierr /= 0) return
    call h5lexists_f(out%file, '/xdmf/mass', exists, h)
    if (h < 0) then
      call fail('h5lexists_f', '/xdmf/mass', ierr, errmsg); return
    end if
    if (.not. exists) call make_view(out, 'mass', '/lattice/mass', [0_hsize_t, 0_hsize_t], [nx, ny], ierr, errmsg)
  end subroutine lattice_views

  !> /xdmf/<name>: a virtual dataset of Fortran dims (count..., 1) (C order
  !> [1][...]) that maps the hyperslab (start, count) of the dataset src of
  !> this file, counted the source's way (a t index stays in count as 1).
  subroutine make_view(out, name, src, start, count, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name, src
    integer(hsize_t), intent(in) :: start(:), count(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: sdset, sspace, vspace, dcpl, dset
    integer(hsize_t) :: vdims(4)
    integer :: h, r
    character(len=:), allocatable :: path

    if (ierr /= 0) return
    path = '/xdmf/'//name
    ! The view's dims: the source's selection without its t index, then 1.
    r = size(count)
    if (size(count) == 4) r = 3
    vdims(1:r) = count(1:r)
    vdims(r + 1) = 1
    sdset = -1; sspace = -1; vspace = -1; dcpl = -1
    call h5dopen_f(out%file, src, sdset, h)
    if (h < 0) then
      call fail('h5dopen_f', src, ierr, errmsg); return
    end if
    call h5dget_space_f(sdset, sspace, h)
    if (h < 0) then
      sspace = -1
      call fail('h5dget_space_f', src, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5sselect_hyperslab_f(sspace, H5S_SELECT_SET_F, start, count, h)
      if (h < 0) call fail('h5sselect_hyperslab_f', src//' for '//path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5screate_simple_f(r + 1, vdims(1:r + 1), vspace, h)
      if (h < 0) then
        vspace = -1
        call fail('h5screate_simple_f', path, ierr, errmsg)
      end if
    end if
    if (ierr == 0) then
      call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, h)
      if (h < 0) then
        dcpl = -1
        call fail('h5pcreate_f(dataset create)', path, ierr, errmsg)
      end if
    end if
    if (ierr == 0) then
      call h5pset_virtual_f(dcpl, vspace, '.', src, sspace, h)
      if (h < 0) call fail('h5pset_virtual_f', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5dcreate_f(out%file, path, H5T_NATIVE_DOUBLE, vspace, dset, h, dcpl_id=dcpl)
      if (h < 0) then
        call fail('h5dcreate_f(virtual)', path, ierr, errmsg)
      else
        call close_dset(dset, path, ierr, errmsg)
      end if
    end if
    if (dcpl >= 0) then
      call h5pclose_f(dcpl, h)
      if (h < 0) call fail('h5pclose_f(dataset create)', path, ierr, errmsg)
    end if
    call close_spaces(sspace, vspace, path, ierr, errmsg)
    call close_dset(sdset, src, ierr, errmsg)
  end subroutine make_view

  !> Delete /xdmf/<name> if it is there (its link; the few bytes of its
  !> header stay in the file).
  subroutine drop_view(out, name, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    if (ierr /= 0) return
    call h5lexists_f(out%file, '/xdmf/'//name, exists, h)
    if (h < 0) then
      call fail('h5lexists_f', '/xdmf/'//name, ierr, errmsg); return
    end if
    if (exists) then
      call h5ldelete_f(out%file, '/xdmf/'//name, h)
      if (h < 0) call fail('h5ldelete_f', '/xdmf/'//name, ierr, errmsg)
    end if
  end subroutine drop_view

  !> The name in /xdmf of the view of step k (0-based) of /position or /velocity.
  function step_view(idx, k) result(name)
    integer, intent(in) :: idx, k
    character(len=:), allocatable :: name
    name = trim(dset_names(idx)(2:))//'_'//str(k)
  end function step_view

  !> An extendable dataset: Fortran dims (fixed..., 0), unlimited along t, chunked.
  subroutine create_series(out, idx, fixed, chunk, ftype, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(in) :: idx
    integer(hsize_t), intent(in) :: fixed(:), chunk(:)
    integer(hid_t), intent(in) :: ftype
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hsize_t) :: dims(4), maxdims(4)
    integer(hid_t) :: space, dcpl
    integer :: r, h
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    r = size(fixed) + 1
    dims(1:r) = [fixed, 0_hsize_t]
    maxdims(1:r) = [fixed, H5S_UNLIMITED_F]
    out%drank(idx) = r
    out%ddims(1:r, idx) = dims(1:r)

    call h5screate_simple_f(r, dims(1:r), space, h, maxdims(1:r))
    if (h < 0) then
      call fail('h5screate_simple_f', name, ierr, errmsg); return
    end if
    call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, h)
    if (h < 0) then
      call fail('h5pcreate_f(dataset create)', name, ierr, errmsg)
    else
      call h5pset_chunk_f(dcpl, r, chunk, h)
      if (h < 0) call fail('h5pset_chunk_f', name, ierr, errmsg)
      ! Parallel HDF5 allocates a chunk when the extent grows; without this
      ! it also writes fill values into it there, a second write of every
      ! output step (and, on a full disk, a write that fails inside the
      ! collective H5Dset_extent on some ranks only, which hangs the others).
      if (ierr == 0) then
        call h5pset_fill_time_f(dcpl, H5D_FILL_TIME_NEVER_F, h)
        if (h < 0) call fail('h5pset_fill_time_f', name, ierr, errmsg)
      end if
      if (ierr == 0) then
        call h5dcreate_f(out%file, name, ftype, space, out%dset(idx), h, dcpl_id=dcpl)
        if (h < 0) call fail('h5dcreate_f', name, ierr, errmsg)
      end if
      call h5pclose_f(dcpl, h)
      if (h < 0) call fail('h5pclose_f(dataset create)', name, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%dset(idx), 'description', trim(dset_descriptions(idx)), name, ierr, errmsg)
  end subroutine create_series

  ! ---------------------------------------------------------------------------
  ! One output step.

  !> Every collective call is followed by an agreement on its error
  !> (agree): a rank whose write failed (a full disk shows on the MPI-IO
  !> aggregators only) must not leave the others waiting in the next
  !> collective call. So all ranks stop at the same call, with the message of
  !> the first rank that failed.
  subroutine write_step_local(out, rec, x, ierr, errmsg, v)
    type(output_file), intent(inout) :: out
    type(output_record), intent(in) :: rec
    real(rp), intent(in) :: x(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp), intent(in), optional :: v(:, :, :)
    integer(hsize_t) :: t, nx, ys, ym
    integer :: i, h
    real(rp), allocatable :: grown(:)

    t = out%nt   ! 0-based index of the new step
    nx = out%nx; ys = out%ys; ym = out%ym

    ! Extend every dataset by one step (collective).
    do i = 1, n_dsets
      if (out%dset(i) < 0) cycle
      out%ddims(out%drank(i), i) = t + 1
      call h5dset_extent_f(out%dset(i), out%ddims(1:out%drank(i), i), h)
      if (h < 0) call fail('h5dset_extent_f', trim(dset_names(i)), ierr, errmsg)
      if (.not. all_ok()) return
    end do

    ! Strips, each rank its rows.
    call write_rows3(out, out%dset(d_position), '/position', [0_hsize_t, 0_hsize_t, ys, t], &
                     [3_hsize_t, nx, ym, 1_hsize_t], x, ierr, errmsg)
    if (.not. all_ok()) return
    if (out%write_velocity) then
      call write_rows3(out, out%dset(d_velocity), '/velocity', [0_hsize_t, 0_hsize_t, ys, t], &
                       [3_hsize_t, nx, ym, 1_hsize_t], v, ierr, errmsg)
      if (.not. all_ok()) return
    end if

    ! Scalars: rank 0 writes, the others join with an empty selection.
    call write_reals(out, d_time, [rec%time], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_kinetic, [rec%kinetic], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_stretch, [rec%stretch], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_bend, [rec%bend], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_dissipated, [rec%dissipated], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_external_work, [rec%external_work], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_momentum, rec%momentum, ierr, errmsg)
    if (all_ok()) call write_reals(out, d_angular_momentum, rec%angular_momentum, ierr, errmsg)
    if (all_ok()) call write_reals(out, d_length, [rec%length], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_flatness, [rec%flatness], ierr, errmsg)
    if (all_ok()) call write_int(out, d_steps, rec%steps, ierr, errmsg)
    if (all_ok()) call write_int(out, d_rejected_steps, rec%rejected_steps, ierr, errmsg)
    if (all_ok()) call write_int(out, d_newton_iterations, rec%newton_iterations, ierr, errmsg)
    if (all_ok()) call write_int(out, d_linear_iterations, rec%linear_iterations, ierr, errmsg)
    ! Created by output_write_run_info; absent for callers that never call it.
    if (all_ok() .and. out%dset(d_wall_time) >= 0) call write_reals(out, d_wall_time, [rec%wall_time], ierr, errmsg)
    if (.not. all_ok()) return

    ! The step's views for the XDMF sidecar (metadata only). None of this
    ! step is there: a new file has none, output_reopen deleted those of the
    ! steps it cut off (sync_views); were one there, h5dcreate_f would fail.
    do i = d_position, d_velocity
      if (out%dset(i) < 0) cycle
      call make_view(out, step_view(i, out%nt), trim(dset_names(i)), [0_hsize_t, 0_hsize_t, 0_hsize_t, t], &
                     [3_hsize_t, nx, int(out%ny, hsize_t), 1_hsize_t], ierr, errmsg)
      if (.not. all_ok()) return
    end do

    ! The step is complete: count it, then flush so that a later crash keeps it.
    call set_attr_int(out%file, 'n_output_steps', out%nt + 1, '/', ierr, errmsg)
    if (.not. all_ok()) return
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', '/', ierr, errmsg)
    if (.not. all_ok()) return
    out%nt = out%nt + 1
    if (out%nt > size(out%times)) then
      allocate(grown(2*size(out%times)))
      grown(1:size(out%times)) = out%times
      call move_alloc(grown, out%times)
    end if
    out%times(out%nt) = rec%time
    if (out%rank == 0 .and. out%committed) call write_xdmf(out, ierr, errmsg)
  contains
    logical function all_ok()
      call agree(out%comm, 'output', ierr, errmsg)
      all_ok = ierr == 0
    end function all_ok
  end subroutine write_step_local

  !> Collective write of a rank-3 strip a(count(1:3)) at start(:) (rank 3 or 4 file space).
  subroutine write_rows3(out, dset, name, start, count, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    real(rp), intent(in) :: a(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer :: h
    real(rp) :: empty(1) = 0

    call select_spaces(dset, name, start, count, product(count) == 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      if (product(count) == 0) then
        call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, empty, [1_hsize_t], h, &
                        mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      else
        call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, a, count(1:3), h, &
                        mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      end if
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_rows3

  !> Collective write of a rank-2 strip a(count(1:2)) at start(:).
  subroutine write_rows2(out, dset, name, start, count, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    real(rp), intent(in) :: a(:, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer :: h
    real(rp) :: empty(1) = 0

    call select_spaces(dset, name, start, count, product(count) == 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      if (product(count) == 0) then
        call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, empty, [1_hsize_t], h, &
                        mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      else
        call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, a, count(1:2), h, &
                        mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      end if
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_rows2

  !> Step t of a real series ([t] or [t][k]): rank 0 writes vals, the others nothing.
  subroutine write_reals(out, idx, vals, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: idx
    real(rp), intent(in) :: vals(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer(hsize_t) :: start(2), count(2)
    integer :: r, h
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    r = out%drank(idx)
    start(1:r) = 0
    start(r) = out%nt
    count(1:r) = out%ddims(1:r, idx)
    count(r) = 1
    call select_spaces(out%dset(idx), name, start(1:r), count(1:r), out%rank /= 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dwrite_f(out%dset(idx), H5T_NATIVE_DOUBLE, vals, [int(size(vals), hsize_t)], h, &
                      mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_reals

  !> Step t of an integer series [t], stored as 64-bit integers.
  subroutine write_int(out, idx, val, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: idx, val
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer(int64) :: buf(1)
    integer :: h
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    buf(1) = val
    call select_spaces(out%dset(idx), name, [int(out%nt, hsize_t)], [1_hsize_t], out%rank /= 0, &
                       fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dwrite_f(out%dset(idx), h5kind_to_type(int64, H5_INTEGER_KIND), buf, [1_hsize_t], h, &
                      mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_int

  !> File space with the hyperslab (start, count) selected, and a matching memory
  !> space; with empty, both select nothing (this rank joins the collective call only).
  subroutine select_spaces(dset, name, start, count, empty, fspace, mspace, ierr, errmsg)
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    logical, intent(in) :: empty
    integer(hid_t), intent(out) :: fspace, mspace
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    fspace = -1
    mspace = -1
    call h5dget_space_f(dset, fspace, h)
    if (h < 0) then
      fspace = -1
      call fail('h5dget_space_f', name, ierr, errmsg); return
    end if
    if (empty) then
      call h5sselect_none_f(fspace, h)
      if (h < 0) then
        call fail('h5sselect_none_f', name, ierr, errmsg); return
      end if
      call h5screate_simple_f(1, [1_hsize_t], mspace, h)
      if (h < 0) then
        mspace = -1
        call fail('h5screate_simple_f', name, ierr, errmsg); return
      end if
      call h5sselect_none_f(mspace, h)
      if (h < 0) call fail('h5sselect_none_f', name, ierr, errmsg)
    else
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, start, count, h)
      if (h < 0) then
        call fail('h5sselect_hyperslab_f', name, ierr, errmsg); return
      end if
      call h5screate_simple_f(size(count), count, mspace, h)
      if (h < 0) then
        mspace = -1
        call fail('h5screate_simple_f', name, ierr, errmsg)
      end if
    end if
  end subroutine select_spaces

  subroutine close_spaces(fspace, mspace, name, ierr, errmsg)
    integer(hid_t), intent(in) :: fspace, mspace
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    if (mspace >= 0) then
      call h5sclose_f(mspace, h)
      if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    end if
    if (fspace >= 0) then
      call h5sclose_f(fspace, h)
      if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    end if
  end subroutine close_spaces

  ! ---------------------------------------------------------------------------
  ! Attributes (scalar; an existing one is deleted and re-created).

  subroutine set_attr_str(loc, name, value, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, value, where   ! where: the object, for messages
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: stype, space, attr
    integer :: h
    character(len=:), allocatable :: what, text

    what = 'attribute '//name//' of '//where
    ! A zero-size string type is not allowed: store an empty value as one NUL.
    if (len(value) == 0) then
      text = achar(0)
    else
      text = value
    end if
    call delete_attr(loc, name, what, ierr, errmsg)
    if (ierr /= 0) return
    call h5tcopy_f(H5T_NATIVE_CHARACTER, stype, h)
    if (h < 0) then
      call fail('h5tcopy_f', what, ierr, errmsg); return
    end if
    call h5tset_size_f(stype, int(len(text), size_t), h)
    if (h < 0) call fail('h5tset_size_f', what, ierr, errmsg)
    if (ierr == 0) then
      call h5tset_strpad_f(stype, H5T_STR_NULLPAD_F, h)
      if (h < 0) call fail('h5tset_strpad_f', what, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5screate_f(H5S_SCALAR_F, space, h)
      if (h < 0) then
        call fail('h5screate_f', what, ierr, errmsg)
      else
        call h5acreate_f(loc, name, stype, space, attr, h)
        if (h < 0) then
          call fail('h5acreate_f', what, ierr, errmsg)
        else
          call h5awrite_f(attr, stype, text, [1_hsize_t], h)
          if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
          call h5aclose_f(attr, h)
          if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
        end if
        call h5sclose_f(space, h)
        if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
      end if
    end if
    call h5tclose_f(stype, h)
    if (h < 0) call fail('h5tclose_f', what, ierr, errmsg)
  end subroutine set_attr_str

  subroutine set_attr_int(loc, name, value, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    integer, intent(in) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space, attr
    integer :: h
    character(len=:), allocatable :: what

    what = 'attribute '//name//' of '//where
    call delete_attr(loc, name, what, ierr, errmsg)
    if (ierr /= 0) return
    call h5screate_f(H5S_SCALAR_F, space, h)
    if (h < 0) then
      call fail('h5screate_f', what, ierr, errmsg); return
    end if
    call h5acreate_f(loc, name, H5T_NATIVE_INTEGER, space, attr, h)
    if (h < 0) then
      call fail('h5acreate_f', what, ierr, errmsg)
    else
      call h5awrite_f(attr, H5T_NATIVE_INTEGER, value, [1_hsize_t], h)
      if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
      call h5aclose_f(attr, h)
      if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
  end subroutine set_attr_int

  !> Real attribute: a scalar for one value, a 1-D array otherwise.
  subroutine set_attr_reals(loc, name, values, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    real(rp), intent(in) :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space, attr
    integer :: h
    character(len=:), allocatable :: what

    what = 'attribute '//name//' of '//where
    call delete_attr(loc, name, what, ierr, errmsg)
    if (ierr /= 0) return
    if (size(values) == 1) then
      call h5screate_f(H5S_SCALAR_F, space, h)
    else
      call h5screate_simple_f(1, [int(size(values), hsize_t)], space, h)
    end if
    if (h < 0) then
      call fail('h5screate_f', what, ierr, errmsg); return
    end if
    call h5acreate_f(loc, name, H5T_NATIVE_DOUBLE, space, attr, h)
    if (h < 0) then
      call fail('h5acreate_f', what, ierr, errmsg)
    else
      call h5awrite_f(attr, H5T_NATIVE_DOUBLE, values, [int(size(values), hsize_t)], h)
      if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
      call h5aclose_f(attr, h)
      if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
  end subroutine set_attr_reals

  subroutine delete_attr(loc, name, what, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    call h5aexists_f(loc, name, exists, h)
    if (h < 0) then
      call fail('h5aexists_f', what, ierr, errmsg); return
    end if
    if (exists) then
      call h5adelete_f(loc, name, h)
      if (h < 0) call fail('h5adelete_f', what, ierr, errmsg)
    end if
  end subroutine delete_attr

  ! ---------------------------------------------------------------------------
  ! Closing, errors, file names.

  !> Close every id that is open (datasets, transfer list, file); keeps the first error.
  subroutine close_ids(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: i, h

    do i = 1, n_dsets
      if (out%dset(i) >= 0) call close_dset(out%dset(i), trim(dset_names(i)), ierr, errmsg)
      out%dset(i) = -1
    end do
    if (out%dxpl >= 0) then
      call h5pclose_f(out%dxpl, h)
      if (h < 0) call fail('h5pclose_f(dataset transfer)', 'the output file', ierr, errmsg)
      out%dxpl = -1
    end if
    if (out%file >= 0) then
      call h5fclose_f(out%file, h)
      if (h < 0) call fail('h5fclose_f', 'the output file', ierr, errmsg)
      out%file = -1
    end if
  end subroutine close_ids

  subroutine close_dset(dset, name, ierr, errmsg)
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    if (dset < 0) return
    call h5dclose_f(dset, h)
    if (h < 0) call fail('h5dclose_f', name, ierr, errmsg)
  end subroutine close_dset

  !> Record a failed call unless an earlier error is already recorded.
  subroutine fail(call_name, what, ierr, errmsg)
    character(*), intent(in) :: call_name, what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    if (ierr /= 0) return
    ierr = 1
    errmsg = 'output: '//call_name//' failed for '//what
  end subroutine fail

  subroutine keep_first(ierr, errmsg, e2, msg2)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer, intent(in) :: e2
    character(*), intent(in) :: msg2
    if (ierr == 0 .and. e2 /= 0) then
      ierr = e2
      errmsg = msg2
    end if
  end subroutine keep_first

  !> Make the error flag collective: every rank returns non-zero if any rank
  !> failed, and every rank gets the message of the first rank that failed
  !> (so that rank 0's one error line names the cause, wherever it arose).
  subroutine agree(comm, where, ierr, errmsg)
    integer, intent(in) :: comm
    character(*), intent(in) :: where
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: local, global, mpierr, rank, first, size_

    local = merge(1, 0, ierr /= 0)
    call MPI_Allreduce(local, global, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    if (mpierr /= MPI_SUCCESS) then
      if (ierr == 0) then
        ierr = 1
        errmsg = where//': MPI_Allreduce of the error flag failed'
      end if
      return
    end if
    if (global == 0) return
    call MPI_Comm_rank(comm, rank, mpierr)
    call MPI_Comm_size(comm, size_, mpierr)
    local = merge(rank, size_, ierr /= 0)
    call MPI_Allreduce(local, first, 1, MPI_INTEGER, MPI_MIN, comm, mpierr)
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, first, comm, mpierr)
    if (ierr == 0) ierr = 1
  end subroutine agree

  !> run.h5 -> run.xmf beside it; the sidecar names the h5 file by its base name.
  subroutine sidecar_names(filename, xmf_path, h5_base)
    character(*), intent(in) :: filename
    character(len=:), allocatable, intent(out) :: xmf_path, h5_base
    integer :: n, slash

    n = len_trim(filename)
    if (n >= 3) then
      if (filename(n-2:n) == '.h5') then
        xmf_path = filename(1:n-3)//'.xmf'
      else
        xmf_path = filename(1:n)//'.xmf'
      end if
    else
      xmf_path = filename(1:n)//'.xmf'
    end if
    slash = index(filename(1:n), '/', back=.true.)
    h5_base = filename(slash+1:n)
  end subroutine sidecar_names

  ! ---------------------------------------------------------------------------
  ! Checkpoints in the run's own file, and the reopening of that file to
  ! continue the run (-nuno_restart).
  !
  ! Layout (docs/model.md section 9, docs/design.md "Checkpoints"):
  ! /checkpoint/slot_0 and /checkpoint/slot_1, each with the datasets
  ! position and velocity [ny][nx][3] (float64, the exact state) and the
  ! attributes of checkpoint_t. A checkpoint goes into the slot that does not
  ! hold the last valid one: its attribute sequence is set to 0 (invalid)
  ! and flushed, then the state and attributes are written and flushed, then
  ! sequence = the next number is written and flushed, last. A kill at any
  ! moment leaves the other slot valid; a reader takes the slot with the
  ! largest sequence > 0.


  !> Write a checkpoint: the state strips x, v (3, 0:nx-1, ys:ys+ym-1) and
  !> ck, into the slot that does not hold the last valid one; its
  !> sequence attribute, written last, makes it valid. Collective.
  subroutine output_write_checkpoint(out, ck, x, v, ierr, errmsg)
    type(output_file), intent(inout) :: out
    type(checkpoint_t), intent(inout) :: ck
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: grp, dset
    integer(hsize_t) :: nx, ny, ys, ym
    integer :: slot, k
    character(len=:), allocatable :: where
    character(len=*), parameter :: fields(2) = [character(len=8) :: 'position', 'velocity']

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_write_checkpoint: the output file is not open'
      return
    end if
    nx = out%nx; ny = out%ny; ys = out%ys; ym = out%ym
    if (size(x, 1) /= 3 .or. size(x, 2) /= out%nx .or. size(x, 3) /= out%ym .or. &
        any(shape(v) /= shape(x))) then
      ierr = 1
      errmsg = 'output_write_checkpoint: x and v must be (3, nx, ym)'
    end if
    call agree(out%comm, 'output_write_checkpoint', ierr, errmsg)
    if (ierr /= 0) return

    ! (a restart point, kept at an earlier output step, holds its own count)
    if (ck%n_output_steps <= 0) ck%n_output_steps = out%nt
    call check_space(out, 48.0_rp * (1 + ck%start_count) * out%nx * out%ny + 65536.0_rp, 'a checkpoint', ierr, errmsg)
    if (ierr /= 0) then
      errmsg = 'checkpoint not written: '//trim(errmsg)
      return
    end if
    slot = merge(0, 1 - out%ck_slot, out%ck_slot < 0)
    where = trim(slot_names(slot))
    grp = -1
    call open_or_create_group(out%file, '/checkpoint', grp, ierr, errmsg)
    if (grp >= 0) call close_group(grp, '/checkpoint', ierr, errmsg)
    grp = -1
    if (all_ok()) call open_or_create_group(out%file, where, grp, ierr, errmsg)
    ! Invalid while it is being written, and that on disk before anything else.
    if (all_ok()) call set_attr_int(grp, 'sequence', 0, where, ierr, errmsg)
    if (all_ok()) call flush_file(out, ierr, errmsg)
    do k = 1, 2
      if (.not. all_ok()) exit
      call open_or_create_state(out, grp, where//'/'//trim(fields(k)), trim(fields(k)), dset, ierr, errmsg)
      if (.not. all_ok()) exit
      if (k == 1) then
        call write_rows3(out, dset, where//'/position', [0_hsize_t, 0_hsize_t, ys], [3_hsize_t, nx, ym], x, ierr, errmsg)
      else
        call write_rows3(out, dset, where//'/velocity', [0_hsize_t, 0_hsize_t, ys], [3_hsize_t, nx, ym], v, ierr, errmsg)
      end if
      call close_dset(dset, where//'/'//trim(fields(k)), ierr, errmsg)
    end do
    ! The Newton start's earlier states (start_position_1.., start_velocity_1..)
    do k = 1, ck%start_count
      if (.not. all_ok()) exit
      call write_state(where//'/start_position_'//str(k), 'start_position_'//str(k), ck%start_x(:, :, :, k))
      if (.not. all_ok()) exit
      call write_state(where//'/start_velocity_'//str(k), 'start_velocity_'//str(k), ck%start_v(:, :, :, k))
    end do
    ! Attributes: metadata, written at the flush (which is agreed on).
    if (all_ok()) then
      call set_attr_reals(grp, 'time', [ck%time], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'dt_next', [ck%dt_next], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'wall_time', [ck%wall_time], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'dissipated', [ck%dissipated], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'work_constraints', [ck%work_constraints], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'mgx0', [ck%mgx0], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 't_written', [ck%t_written], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'counters', ck%counters, where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'n_output_steps', ck%n_output_steps, where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'stretch_warned', ck%stretch_warned, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'reason', trim(ck%reason), where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'ts_type', trim(ck%ts_type), where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'start_count', ck%start_count, where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'start_times', ck%start_t, where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'start_compare', ck%start_compare, where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'start_nc_prev', [ck%start_nc_prev], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'newton_floor', [ck%newton_floor], where, ierr, errmsg)
    end if
    if (all_ok()) call flush_file(out, ierr, errmsg)
    ! Valid from here on.
    if (all_ok()) call set_attr_int(grp, 'sequence', out%ck_seq + 1, where, ierr, errmsg)
    if (all_ok()) call flush_file(out, ierr, errmsg)
    if (grp >= 0) call close_group(grp, where, ierr, errmsg)
    call agree(out%comm, 'output_write_checkpoint', ierr, errmsg)
    if (ierr /= 0) then
      call add_cause(out, errmsg)
      errmsg = 'checkpoint not written: '//trim(errmsg)
      return
    end if
    out%ck_seq = out%ck_seq + 1
    out%ck_slot = slot
    ck%sequence = out%ck_seq
  contains
    logical function all_ok()
      call agree(out%comm, 'output_write_checkpoint', ierr, errmsg)
      all_ok = ierr == 0
    end function all_ok
    subroutine write_state(path, name, a)
      character(*), intent(in) :: path, name
      real(rp), intent(in) :: a(:, :, :)
      call open_or_create_state(out, grp, path, name, dset, ierr, errmsg)
      if (ierr /= 0) return
      call write_rows3(out, dset, path, [0_hsize_t, 0_hsize_t, ys], [3_hsize_t, nx, ym], a, ierr, errmsg)
      call close_dset(dset, path, ierr, errmsg)
    end subroutine write_state
  end subroutine output_write_checkpoint

  !> Close the file and the HDF5 library and open both again, with the
  !> series as they were (every REFRESH_STEPS output steps, from
  !> output_write_step). Parallel HDF5 1.10.8 keeps memory for every object
  !> created in a file opened with the MPI-IO driver until the library
  !> closes (about 20 kB a rank for each /xdmf view, 6 kB for a plain
  !> dataset; closing the file alone does not release it): without this a
  !> run grew by 10-25 kB a rank for each output step (docs/stability.md,
  !> "Memory over a long run"). Nothing else in nuno holds an HDF5 object
  !> while a run writes its output. Collective.
  subroutine refresh_library(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=:), allocatable :: path
    integer(hid_t) :: fapl
    integer :: h, i
    logical :: exists_

    if (ierr /= 0) return
    path = out%work_path
    if (out%committed) path = out%final_path
    call close_ids(out, ierr, errmsg)
    call h5close_f(h)
    if (h < 0) call fail('h5close_f', path, ierr, errmsg)
    call h5open_f(h)
    if (h < 0) call fail('h5open_f', path, ierr, errmsg)
    call h5eset_auto_f(0, h)
    fapl = -1
    if (ierr == 0) then
      call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
      if (h < 0) call fail('h5pcreate_f(file access)', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5pset_fapl_mpio_f(fapl, out%comm, MPI_INFO_NULL, h)
      if (h < 0) call fail('h5pset_fapl_mpio_f', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      ! (the bounds of open_local: the views need the 1.10 format)
      call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V110_F, h)
      if (h < 0) call fail('h5pset_libver_bounds_f', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5fopen_f(path, H5F_ACC_RDWR_F, out%file, h, access_prp=fapl)
      if (h < 0) then
        out%file = -1
        call fail('h5fopen_f (reopening)', path, ierr, errmsg)
      end if
    end if
    if (fapl >= 0) call h5pclose_f(fapl, h)
    if (ierr == 0) then
      call h5pcreate_f(H5P_DATASET_XFER_F, out%dxpl, h)
      if (h < 0) then
        out%dxpl = -1
        call fail('h5pcreate_f(dataset transfer)', path, ierr, errmsg)
      end if
    end if
    if (ierr == 0) then
      call h5pset_dxpl_mpio_f(out%dxpl, H5FD_MPIO_COLLECTIVE_F, h)
      if (h < 0) call fail('h5pset_dxpl_mpio_f', path, ierr, errmsg)
    end if
    do i = 1, n_dsets
      if (ierr /= 0) exit
      if (i == d_velocity .and. .not. out%write_velocity) cycle
      call h5lexists_f(out%file, trim(dset_names(i)), exists_, h)
      if (h < 0) call fail('h5lexists_f', trim(dset_names(i)), ierr, errmsg)
      if (ierr /= 0 .or. .not. exists_) cycle
      call h5dopen_f(out%file, trim(dset_names(i)), out%dset(i), h)
      if (h < 0) then
        out%dset(i) = -1
        call fail('h5dopen_f', trim(dset_names(i)), ierr, errmsg)
      end if
    end do
    if (ierr /= 0) out%is_open = out%file >= 0
  end subroutine refresh_library

  !> The output steps completely written so far.
  integer function output_steps(out)
    type(output_file), intent(in) :: out
    output_steps = out%nt
  end function output_steps

  !> Open an earlier run's file to continue it from its last valid
  !> checkpoint: lock it, check the lattice and that the checkpoint is
  !> before t_end, read ck and the state strips, cut the series back to the
  !> checkpoint's output steps, mark it running. Nothing is changed in the
  !> file when a check fails. Collective.
  subroutine output_reopen(out, filename, comm, nx, ny, ys, ym, write_velocity, t_end, attrs_namelist, &
                                  attrs_petsc_options, ck, x, v, ierr, errmsg, protect, overwrite, cfg)
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
    character(*), intent(in), optional :: protect
    logical, intent(in), optional :: overwrite      ! -nuno_overwrite (default .false.)
    type(nuno_config), intent(in), optional :: cfg   !< the input's: its scene and model must be the file's
    integer(hid_t) :: fapl, grp
    integer :: h, mpierr, fnx, fny, slot, seq(0:1), k, restarts, extent, n
    logical :: exists, has_velocity, attempt
    character(len=:), allocatable :: where
    character(len=256) :: why

    ierr = 0
    errmsg = ''
    if (out%is_open) then
      ierr = 1
      errmsg = 'output_reopen: handle already open ('//filename//')'
      return
    end if
    call MPI_Comm_rank(comm, out%rank, mpierr)
    call MPI_Comm_size(comm, out%n_ranks, mpierr)
    out%comm = comm
    out%nx = nx
    out%ny = ny
    out%ys = ys
    out%ym = ym
    out%write_velocity = write_velocity
    ! A run that has not yet given its file the output's name (killed
    ! before its first output step, or one that keeps an earlier result
    ! until it completes) left OUTPUT.partial: the restart continues that,
    ! named either way, and gives it the name OUTPUT as a run would.
    n = len(filename)
    attempt = .false.
    if (n > 8) attempt = filename(n - 7:n) == '.partial'
    if (attempt) then
      out%final_path = filename(1:n - 8)
      out%work_path = filename
    else
      if (out%rank == 0) attempt = path_kind(filename//'.partial', why) == kind_file
      call MPI_Bcast(attempt, 1, MPI_LOGICAL, 0, comm, mpierr)
      out%final_path = filename
      out%work_path = filename
      if (attempt) out%work_path = filename//'.partial'
    end if
    call sidecar_names(out%final_path, out%xmf_path, out%h5_base)
    out%lock_path = out%final_path//'.lock'
    ! In place: the checkpoint is in it already.
    out%committed = out%work_path == out%final_path
    out%reopened = .true.
    out%stepped = .true.          ! a result already: never removed
    out%overwrite = .false.
    if (present(overwrite)) out%overwrite = overwrite

    if (out%rank == 0) then
      if (.not. file_exists(out%work_path)) then
        ierr = 1
        errmsg = '-nuno_restart '//filename//': no such file'
      else
        call claim_files(out, ierr, errmsg, protect)
        if (ierr == 0 .and. .not. out%committed) write(*, '(a)') 'nuno: -nuno_restart: continuing '// &
          out%work_path//', the last run''s file; it becomes '//out%final_path//' as a run''s file does'
      end if
    end if
    call MPI_Bcast(out%had_earlier, 1, MPI_LOGICAL, 0, comm, mpierr)
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
      return
    end if

    call h5open_f(h)
    call h5eset_auto_f(0, h)
    call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
    if (h < 0) call fail('h5pcreate_f(file access)', filename, ierr, errmsg)
    if (ierr == 0) then
      call h5pset_fapl_mpio_f(fapl, comm, MPI_INFO_NULL, h)
      if (h < 0) call fail('h5pset_fapl_mpio_f', filename, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5fopen_f(out%work_path, H5F_ACC_RDWR_F, out%file, h, access_prp=fapl)
      if (h < 0) then
        ierr = 1
        errmsg = '-nuno_restart '//out%work_path//': not an HDF5 file that can be opened for writing'
      end if
      call h5pclose_f(fapl, h)
    end if
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
      return
    end if
    out%is_open = .true.
    call h5pcreate_f(H5P_DATASET_XFER_F, out%dxpl, h)
    if (h < 0) call fail('h5pcreate_f(dataset transfer)', filename, ierr, errmsg)
    if (ierr == 0) then
      call h5pset_dxpl_mpio_f(out%dxpl, H5FD_MPIO_COLLECTIVE_F, h)
      if (h < 0) call fail('h5pset_dxpl_mpio_f', filename, ierr, errmsg)
    end if

    ! The same lattice and series; a valid checkpoint.
    fnx = -1
    fny = -1
    if (ierr == 0) call get_attr_int(out%file, 'nx', '/', fnx, ierr, errmsg)
    if (ierr == 0) call get_attr_int(out%file, 'ny', '/', fny, ierr, errmsg)
    if (ierr /= 0) then
      errmsg = '-nuno_restart '//filename//': not a nuno output file ('//trim(errmsg)//')'
    else if (fnx /= nx .or. fny /= ny) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': its lattice is nx = '//str(fnx)//', ny = '//str(fny)// &
               ', the input''s nx = '//str(nx)//', ny = '//str(ny)
    end if
    if (ierr == 0) then
      call h5lexists_f(out%file, 'velocity', has_velocity, h)
      if (h < 0) call fail('h5lexists_f', '/velocity', ierr, errmsg)
      if (ierr == 0 .and. (has_velocity .neqv. write_velocity)) then
        ierr = 1
        errmsg = '-nuno_restart '//filename//': &output: write_velocity = '// &
                 trim(merge('.true. ', '.false.', write_velocity))//' but the file was written with '// &
                 trim(merge('.true. ', '.false.', has_velocity))//': the series must go on as it began'
      end if
    end if
    ! the same scene and model constants (module checkpoint_check)
    if (ierr == 0 .and. present(cfg)) call scene_refusal(out%file, filename, cfg, ierr, errmsg)
    seq = 0
    do k = 0, 1
      if (ierr /= 0) exit
      call h5lexists_f(out%file, 'checkpoint', exists, h)
      if (h < 0) call fail('h5lexists_f', '/checkpoint', ierr, errmsg)
      if (.not. exists .or. ierr /= 0) exit
      call h5lexists_f(out%file, trim(slot_names(k)), exists, h)
      if (h < 0) call fail('h5lexists_f', trim(slot_names(k)), ierr, errmsg)
      if (exists .and. ierr == 0) then
        call h5gopen_f(out%file, trim(slot_names(k)), grp, h)
        if (h < 0) then
          call fail('h5gopen_f', trim(slot_names(k)), ierr, errmsg)
        else
          call h5aexists_f(grp, 'sequence', exists, h)
          if (exists) call get_attr_int(grp, 'sequence', trim(slot_names(k)), seq(k), ierr, errmsg)
          call close_group(grp, trim(slot_names(k)), ierr, errmsg)
        end if
      end if
    end do
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr == 0 .and. maxval(seq) <= 0) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': no valid checkpoint in it (one is written at the end of a run, '// &
               'on SIGTERM/SIGINT, every checkpoint_interval and every -nuno_checkpoint_walltime)'
    end if
    if (ierr == 0) then
      slot = maxloc(seq, 1) - 1
      where = trim(slot_names(slot))
      call read_checkpoint(out, where, ck, x, v, ierr, errmsg)
      ck%sequence = seq(slot)
      out%ck_seq = seq(slot)
      out%ck_slot = slot
      ! a sound checkpoint, checked before anything in the file changes
      call agree(comm, '-nuno_restart', ierr, errmsg)
      if (ierr == 0) call checkpoint_refusal(out%file, filename, where, ck, x, v, comm, ierr, errmsg)
      if (ierr == 0 .and. ck%time >= t_end - 1.0e-12_rp * max(1.0_rp, t_end)) then
        ierr = 1
        write(errmsg, '(a,es12.5e2,a,es12.5e2,a)') '-nuno_restart '//filename//': its last checkpoint is at t =', &
          ck%time, ', not before t_end =', t_end, ': nothing to continue (a later t_end: -nuno_set t_end=...)'
      end if
    end if

    ! The series, cut back to the checkpoint's output steps: what a run
    ! wrote after its last checkpoint is computed again (the same way).
    ! So are the XDMF views: those of later steps are deleted, those of the
    ! kept steps (and of the lattice) made where the file lacks them (a file
    ! of an earlier version). All ranks take part (collective calls).
    call agree(comm, '-nuno_restart', ierr, errmsg)
    extent = 0
    if (ierr == 0) call open_series(out, ck%n_output_steps, extent, ierr, errmsg)
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr == 0) call sync_views(out, extent, ierr, errmsg)
    if (ierr == 0) then
      restarts = 0
      call h5aexists_by_name_f(out%file, 'run', 'restarts', exists, h)
      if (h >= 0 .and. exists) then
        call h5gopen_f(out%file, 'run', grp, h)
        if (h >= 0) then
          call get_attr_int(grp, 'restarts', '/run', restarts, ierr, errmsg)
          call close_group(grp, '/run', ierr, errmsg)
        end if
      end if
      out%restarts = restarts + 1
      call open_or_create_group(out%file, '/run', grp, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'restarts', out%restarts, '/run', ierr, errmsg)
      if (grp >= 0) call close_group(grp, '/run', ierr, errmsg)
      where = '/run/restart_'//str(out%restarts)
      if (ierr == 0) call open_or_create_group(out%file, where, grp, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'from_time', [ck%time], where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'from_checkpoint', ck%sequence, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'namelist', attrs_namelist, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'petsc_options', attrs_petsc_options, where, ierr, errmsg)
      if (grp >= 0) call close_group(grp, where, ierr, errmsg)
    end if
    if (ierr == 0) call set_attr_str(out%file, 'status', 'running', '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_ranks', out%n_ranks, '/', ierr, errmsg)
    if (ierr == 0) call flush_file(out, ierr, errmsg)
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr /= 0) then
      call close_ids(out, ierr, errmsg)
      out%is_open = .false.
      if (out%rank == 0) call lock_release(out%lock_path, out%lock_fd)
    end if
  end subroutine output_reopen

  ! ---------------------------------------------------------------------------

  !> The attributes and state strips of the checkpoint slot `where`.
  subroutine read_checkpoint(out, where, ck, x, v, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: where
    type(checkpoint_t), intent(out) :: ck
    real(rp), intent(out) :: x(:, :, :), v(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    integer :: h, k
    real(rp) :: r(1)
    logical :: exists

    call h5gopen_f(out%file, where, grp, h)
    if (h < 0) then
      call fail('h5gopen_f', where, ierr, errmsg); return
    end if
    call get_attr_reals(grp, 'time', where, r, ierr, errmsg); ck%time = r(1)
    call get_attr_reals(grp, 'dt_next', where, r, ierr, errmsg); ck%dt_next = r(1)
    call get_attr_reals(grp, 'wall_time', where, r, ierr, errmsg); ck%wall_time = r(1)
    call get_attr_reals(grp, 'dissipated', where, r, ierr, errmsg); ck%dissipated = r(1)
    call get_attr_reals(grp, 'work_constraints', where, r, ierr, errmsg); ck%work_constraints = r(1)
    call get_attr_reals(grp, 'mgx0', where, r, ierr, errmsg); ck%mgx0 = r(1)
    call get_attr_reals(grp, 't_written', where, r, ierr, errmsg); ck%t_written = r(1)
    call get_attr_reals(grp, 'counters', where, ck%counters, ierr, errmsg)
    call get_attr_int(grp, 'n_output_steps', where, ck%n_output_steps, ierr, errmsg)
    call get_attr_int(grp, 'stretch_warned', where, ck%stretch_warned, ierr, errmsg)
    call get_attr_str(grp, 'reason', where, ck%reason, ierr, errmsg)
    call get_attr_str(grp, 'ts_type', where, ck%ts_type, ierr, errmsg)
    ! the Newton start's earlier states: not in files written before 4 Dec 2026
    call h5aexists_f(grp, 'start_count', exists, h)
    if (h < 0) call fail('h5aexists_f', where//' start_count', ierr, errmsg)
    ck%start_count = 0
    if (ierr == 0 .and. exists) then
      call get_attr_int(grp, 'start_count', where, ck%start_count, ierr, errmsg)
      call get_attr_reals(grp, 'start_times', where, ck%start_t, ierr, errmsg)
      call get_attr_int(grp, 'start_compare', where, ck%start_compare, ierr, errmsg)
      call get_attr_reals(grp, 'start_nc_prev', where, r, ierr, errmsg); ck%start_nc_prev = r(1)
      if (ck%start_count < 0 .or. ck%start_count > 3) then
        ierr = 1
        errmsg = where//': start_count '//str(ck%start_count)//' is not 0..3'
      end if
    end if
    ! the Newton floor: not in files written before 5 Dec 2026
    call h5aexists_f(grp, 'newton_floor', exists, h)
    if (h < 0) call fail('h5aexists_f', where//' newton_floor', ierr, errmsg)
    ck%newton_floor = 0
    if (ierr == 0 .and. exists) then
      call get_attr_reals(grp, 'newton_floor', where, r, ierr, errmsg); ck%newton_floor = r(1)
    end if
    call close_group(grp, where, ierr, errmsg)
    if (ierr /= 0) return
    call read_rows3(out, where//'/position', x, ierr, errmsg)
    call read_rows3(out, where//'/velocity', v, ierr, errmsg)
    allocate(ck%start_x(size(x, 1), size(x, 2), size(x, 3), ck%start_count), &
             ck%start_v(size(x, 1), size(x, 2), size(x, 3), ck%start_count))
    do k = 1, ck%start_count
      call read_rows3(out, where//'/start_position_'//str(k), ck%start_x(:, :, :, k), ierr, errmsg)
      call read_rows3(out, where//'/start_velocity_'//str(k), ck%start_v(:, :, :, k), ierr, errmsg)
    end do
  end subroutine read_checkpoint

  !> Open the time series of an existing file and cut them to nt steps;
  !> extent: the steps /position had before (a killed run: n_output_steps + 1).
  subroutine open_series(out, nt, extent, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(in) :: nt
    integer, intent(out) :: extent
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer(hsize_t) :: dims(4), maxdims(4)
    integer :: i, h, r, have
    logical :: exists
    integer(hid_t) :: fspace, mspace

    extent = 0
    call get_attr_int(out%file, 'n_output_steps', '/', have, ierr, errmsg)
    if (ierr /= 0) return
    if (nt > have .or. nt < 1) then
      ierr = 1
      errmsg = '-nuno_restart: the checkpoint counts '//str(nt)//' output steps, the file holds '//str(have)
      return
    end if
    do i = 1, n_dsets
      if (i == d_velocity .and. .not. out%write_velocity) cycle
      call h5lexists_f(out%file, trim(dset_names(i)), exists, h)
      if (h < 0) then
        call fail('h5lexists_f', trim(dset_names(i)), ierr, errmsg); return
      end if
      if (.not. exists) then
        if (i == d_wall_time) cycle   ! files of callers that never wrote /run
        ierr = 1
        errmsg = '-nuno_restart: the file has no '//trim(dset_names(i))
        return
      end if
      call h5dopen_f(out%file, trim(dset_names(i)), out%dset(i), h)
      if (h < 0) then
        call fail('h5dopen_f', trim(dset_names(i)), ierr, errmsg); return
      end if
      call h5dget_space_f(out%dset(i), space, h)
      if (h < 0) then
        call fail('h5dget_space_f', trim(dset_names(i)), ierr, errmsg); return
      end if
      call h5sget_simple_extent_ndims_f(space, r, h)
      if (h >= 0) call h5sget_simple_extent_dims_f(space, dims(1:r), maxdims(1:r), h)
      call h5sclose_f(space, h)
      if (i == d_position) extent = int(dims(r))
      out%drank(i) = r
      out%ddims(1:r, i) = dims(1:r)
      out%ddims(r, i) = int(nt, hsize_t)
      call h5dset_extent_f(out%dset(i), out%ddims(1:r, i), h)
      if (h < 0) then
        call fail('h5dset_extent_f', trim(dset_names(i)), ierr, errmsg); return
      end if
    end do
    out%nt = nt
    if (allocated(out%times)) deallocate(out%times)
    allocate(out%times(max(16, 2 * nt)))
    call select_spaces(out%dset(d_time), '/time', [0_hsize_t], [int(nt, hsize_t)], .false., fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dread_f(out%dset(d_time), H5T_NATIVE_DOUBLE, out%times(1:nt), [int(nt, hsize_t)], h, &
                     mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dread_f', '/time', ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, '/time', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_output_steps', nt, '/', ierr, errmsg)
  end subroutine open_series

  !> After open_series cut the series to out%nt steps: delete the views of
  !> steps out%nt .. extent-1 (and any later ones), make those of the kept steps and of the
  !> lattice where missing. Collective; every call that changes the file is
  !> agreed on before the next.
  subroutine sync_views(out, extent, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: extent
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: i, k, h
    logical :: exists

    call lattice_views(out, ierr, errmsg)
    if (.not. all_ok()) return
    do i = d_position, d_velocity
      if (out%dset(i) < 0) cycle
      ! Views are made in step order: delete up to the extent, and on
      ! while there are more (left by an earlier cut that did not finish).
      k = out%nt
      do
        call h5lexists_f(out%file, '/xdmf/'//step_view(i, k), exists, h)
        if (h < 0) call fail('h5lexists_f', '/xdmf/'//step_view(i, k), ierr, errmsg)
        if (ierr == 0 .and. .not. exists .and. k >= extent) exit
        if (ierr == 0 .and. exists) call drop_view(out, step_view(i, k), ierr, errmsg)
        if (.not. all_ok()) return
        k = k + 1
      end do
      do k = 0, out%nt - 1
        call h5lexists_f(out%file, '/xdmf/'//step_view(i, k), exists, h)
        if (h < 0) call fail('h5lexists_f', '/xdmf/'//step_view(i, k), ierr, errmsg)
        if (ierr == 0 .and. .not. exists) &
          call make_view(out, step_view(i, k), trim(dset_names(i)), [0_hsize_t, 0_hsize_t, 0_hsize_t, int(k, hsize_t)], &
                         [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t), 1_hsize_t], ierr, errmsg)
        if (.not. all_ok()) return
      end do
    end do
  contains
    logical function all_ok()
      call agree(out%comm, '-nuno_restart', ierr, errmsg)
      all_ok = ierr == 0
    end function all_ok
  end subroutine sync_views

  !> A fixed [ny][nx][3] state dataset of a checkpoint slot, created on first use.
  subroutine open_or_create_state(out, grp, path, name, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: path, name
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    logical :: exists
    integer :: h

    dset = -1
    call h5lexists_f(grp, name, exists, h)
    if (h < 0) then
      call fail('h5lexists_f', path, ierr, errmsg); return
    end if
    if (exists) then
      call h5dopen_f(grp, name, dset, h)
      if (h < 0) call fail('h5dopen_f', path, ierr, errmsg)
      return
    end if
    call h5screate_simple_f(3, [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], space, h)
    if (h < 0) then
      call fail('h5screate_simple_f', path, ierr, errmsg); return
    end if
    call h5dcreate_f(grp, name, H5T_NATIVE_DOUBLE, space, dset, h)
    if (h < 0) call fail('h5dcreate_f', path, ierr, errmsg)
    call h5sclose_f(space, h)
    if (ierr /= 0) dset = -1
  end subroutine open_or_create_state

  !> Collective read of this rank's rows of a [ny][nx][3] dataset into a(3, nx, ym).
  subroutine read_rows3(out, path, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: path
    real(rp), intent(out) :: a(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dset, fspace, mspace
    integer(hsize_t) :: count(3)
    integer :: h
    real(rp) :: empty(1)

    a = 0
    if (ierr /= 0) return
    call h5dopen_f(out%file, path, dset, h)
    if (h < 0) then
      call fail('h5dopen_f', path, ierr, errmsg); return
    end if
    count = [3_hsize_t, int(out%nx, hsize_t), int(out%ym, hsize_t)]
    call select_spaces(dset, path, [0_hsize_t, 0_hsize_t, int(out%ys, hsize_t)], count, product(count) == 0, &
                       fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      if (product(count) == 0) then
        call h5dread_f(dset, H5T_NATIVE_DOUBLE, empty, [1_hsize_t], h, mem_space_id=mspace, file_space_id=fspace, &
                       xfer_prp=out%dxpl)
      else
        call h5dread_f(dset, H5T_NATIVE_DOUBLE, a, count, h, mem_space_id=mspace, file_space_id=fspace, &
                       xfer_prp=out%dxpl)
      end if
      if (h < 0) call fail('h5dread_f', path, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, path, ierr, errmsg)
    call close_dset(dset, path, ierr, errmsg)
  end subroutine read_rows3

  subroutine get_attr_int(loc, name, where, value, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    integer, intent(out) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: h, buf(1)

    value = 0
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call h5aread_f(attr, H5T_NATIVE_INTEGER, buf, [1_hsize_t], h)
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    value = buf(1)
    call h5aclose_f(attr, h)
  end subroutine get_attr_int

  !> A fixed-length string attribute into value (cut to its length).
  subroutine get_attr_str(loc, name, where, value, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    character(*), intent(out) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr, ftype, mtype
    integer(size_t) :: n
    integer :: h, k
    character(len=:), allocatable :: buf

    value = ''
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call h5aget_type_f(attr, ftype, h)
    if (h >= 0) call h5tget_size_f(ftype, n, h)
    if (h >= 0) then
      allocate(character(len=n) :: buf)
      call h5tcopy_f(H5T_NATIVE_CHARACTER, mtype, h)
      if (h >= 0) call h5tset_size_f(mtype, n, h)
      if (h >= 0) call h5aread_f(attr, mtype, buf, [1_hsize_t], h)
      call h5tclose_f(mtype, k)
      k = index(buf, achar(0))
      if (k > 0) buf = buf(1:k - 1)
      value = buf
    end if
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    call h5tclose_f(ftype, k)
    call h5aclose_f(attr, k)
  end subroutine get_attr_str

  subroutine get_attr_reals(loc, name, where, values, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    real(rp), intent(out) :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: h

    values = 0
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call h5aread_f(attr, H5T_NATIVE_DOUBLE, values, [int(size(values), hsize_t)], h)
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    call h5aclose_f(attr, h)
  end subroutine get_attr_reals

  subroutine flush_file(out, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', out%final_path, ierr, errmsg)
  end subroutine flush_file

  ! ---------------------------------------------------------------------------
  ! XDMF sidecar (rank 0, plain Fortran I/O, rewritten whole at each step).

  ! Layout, checked with ParaView 5.11's three XDMF readers (the legacy
  ! "XDMF Reader" on Xdmf2, and Xdmf3ReaderS/T) by tests/python/test_xdmf.py:
  ! a temporal collection of n_output_steps uniform grids, each a 3DSMesh of
  ! Dimensions "1 ny nx" (one layer of ny x nx points: VTK dimensions
  ! (nx, ny, 1), point j*nx + i), XYZ geometry /xdmf/position_<k>, and the
  ! point data
  !   velocity       /xdmf/velocity_<k> (when written)
  !   rest_position  /xdmf/rest_position
  !   mass           /xdmf/mass
  !   displacement   Function "$0 - $1" of /xdmf/position_<k> and
  !                  /lattice/rest_position (legacy reader only)
  ! Each is a plain HDF DataItem of a virtual dataset (lattice_views,
  ! make_view) shaped like the topology (+ 3 for vectors): the legacy reader
  ! selects the point range of a structured grid on it (not 2DSMesh
  ! "ny nx": with it that selection goes wrong for vector point data). The
  ! Xdmf3 readers read no HyperSlab or Function item (the item's number
  ! type is unknown to them before it is read): they skip displacement with
  ! one line "Skipping unrecognized array type [None]" per step and load
  ! everything else; Calculator "coords - rest_position" gives it there.
  ! No view is needed by the Function's operand rest_position (read whole).
  subroutine write_xdmf(out, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: u, k, nbuf
    logical :: good
    character(len=256) :: iom
    character(len=:), allocatable :: plane, surf, f8, h5, tmp
    character(len=65536) :: buf                   ! lines gathered for one write(2)

    if (ierr /= 0) return
    h5 = xml_escape(out%h5_base)                  ! the file's name in XML text
    plane = str(out%ny)//' '//str(out%nx)        ! /lattice/mass [ny][nx]
    surf = '1 '//plane                            ! the topology, one layer of points; the views
    f8 = 'NumberType="Float" Precision="8"'
    ! Written whole into a new file made exclusively beside it, then renamed
    ! onto the name: never through a symbolic link, never half-written.
    call tmp_open(out%xmf_path, tmp, u, good, iom)
    if (.not. good) then
      ierr = 1
      errmsg = 'output: cannot write '//out%xmf_path//': '//trim(iom)
      return
    end if
    nbuf = 0
    call put('<?xml version="1.0" ?>')
    call put('<Xdmf Version="3.0">')
    call put(' <Domain>')
    call put('  <Grid Name="cloth" GridType="Collection" CollectionType="Temporal">')
    do k = 1, out%nt
      call put('   <Grid Name="step_'//str(k - 1)//'" GridType="Uniform">')
      call put('    <Time Value="'//real_str(out%times(k))//'"/>')
      call put('    <Topology TopologyType="3DSMesh" Dimensions="'//surf//'"/>')
      call put('    <Geometry GeometryType="XYZ">')
      call item('     ', surf//' 3', '/xdmf/'//step_view(d_position, k - 1))
      call put('    </Geometry>')
      if (out%write_velocity) then
        call put('    <Attribute Name="velocity" AttributeType="Vector" Center="Node">')
        call item('     ', surf//' 3', '/xdmf/'//step_view(d_velocity, k - 1))
        call put('    </Attribute>')
      end if
      call put('    <Attribute Name="rest_position" AttributeType="Vector" Center="Node">')
      call item('     ', surf//' 3', '/xdmf/rest_position')
      call put('    </Attribute>')
      call put('    <Attribute Name="mass" AttributeType="Scalar" Center="Node">')
      call item('     ', surf, '/xdmf/mass')
      call put('    </Attribute>')
      call put('    <Attribute Name="displacement" AttributeType="Vector" Center="Node">')
      call put('     <DataItem ItemType="Function" Function="$0 - $1" Dimensions="'//surf//' 3" '//f8//'>')
      call item('      ', surf//' 3', '/xdmf/'//step_view(d_position, k - 1))
      call item('      ', plane//' 3', '/lattice/rest_position')
      call put('     </DataItem>')
      call put('    </Attribute>')
      call put('   </Grid>')
    end do
    call put('  </Grid>')
    call put(' </Domain>')
    call put('</Xdmf>')
    call flush_buf()
    if (.not. good) then
      ierr = 1
      errmsg = 'output: write error on '//out%xmf_path
    end if
    call tmp_commit(u, tmp, out%xmf_path, good, iom)
    if (.not. good .and. ierr == 0) then
      ierr = 1
      errmsg = 'output: cannot put '//out%xmf_path//' in place: '//trim(iom)
    end if
  contains
    subroutine put(line)
      character(*), intent(in) :: line
      if (nbuf + len(line) + 1 > len(buf)) call flush_buf()
      if (len(line) + 1 > len(buf)) then
        call tmp_write(u, line//achar(10), good)
      else
        buf(nbuf + 1:nbuf + len(line) + 1) = line//achar(10)
        nbuf = nbuf + len(line) + 1
      end if
    end subroutine put

    subroutine flush_buf()
      if (nbuf > 0) call tmp_write(u, buf(1:nbuf), good)
      nbuf = 0
    end subroutine flush_buf

    !> A plain float64 HDF DataItem of the dataset path (C-order dims).
    subroutine item(indent, dims, path)
      character(*), intent(in) :: indent, dims, path
      call put(indent//'<DataItem Dimensions="'//dims//'" '//f8//' Format="HDF">'//h5//':'//path//'</DataItem>')
    end subroutine item
  end subroutine write_xdmf

  pure function str(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write(buf, '(i0)') i
    s = trim(buf)
  end function str

  !> s with the characters that XML text and attribute values cannot hold escaped.
  pure function xml_escape(s) result(r)
    character(*), intent(in) :: s
    character(len=:), allocatable :: r
    integer :: i
    r = ''
    do i = 1, len(s)
      select case (s(i:i))
      case ('&'); r = r//'&amp;'
      case ('<'); r = r//'&lt;'
      case ('>'); r = r//'&gt;'
      case ('"'); r = r//'&quot;'
      case default; r = r//s(i:i)
      end select
    end do
  end function xml_escape

  pure function real_str(x) result(s)
    real(rp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    write(buf, '(es24.16e3)') x
    s = trim(adjustl(buf))
  end function real_str

end module output
