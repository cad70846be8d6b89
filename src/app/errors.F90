! SPDX-License-Identifier: BSD-2-Clause
!> Command-line helpers and the collective exit path.
!> Every rank takes the same branch for input errors (all ranks parse the
!> same text), so fatal_collective is called by all ranks together: rank 0
!> prints one line, PETSc and MPI are finalised, and every rank exits 1.
!> No barrier anywhere in an error path.
!> Exits use `stop 1, quiet=.true.` (Fortran 2018): gfortran's `error stop 1`
!> prints 'ERROR STOP 1' and a backtrace on every rank, and plain `stop 1`
!> prints 'STOP 1', which made one clear line read as a crash. The banner
!> mpirun adds on a non-zero exit is Open MPI's own (mpirun -q hides it):
!> Open MPI 4.1 prints it for any rank's non-zero exit, after MPI_Finalize
!> too, so no exit of ours avoids it; MPI_Abort adds a banner of its own and
!> is kept for errors that some ranks may not have seen (input/README.md).
module errors
#include "petsc/finclude/petscsys.h"
  use petscsys
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_null_char
  use kinds, only: rp
  use safe_files, only: cleanup_run
  use input_text, only: lower
  implicit none
  private
  public :: help_requested, version_requested, list_keys_requested, input_path_argument, fatal_collective, fatal_local, apply_namelist_options
  public :: petsc_options_text, quiet_exit, read_input_options, quiet_petsc_errors
  public :: stray_argument, options_file_refusal, petsc_help_given

  interface
    !> src/app/nuno_errors.c: PETSc errors kept as text instead of printed.
    function nuno_quiet_petsc_errors() bind(C, name='nuno_quiet_petsc_errors') result(code)
      import :: c_int
      integer(c_int) :: code
    end function nuno_quiet_petsc_errors
    subroutine nuno_petsc_error_text(buf, buflen) bind(C, name='nuno_petsc_error_text')
      import :: c_int, c_char
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_int), value :: buflen
    end subroutine nuno_petsc_error_text
    subroutine nuno_signals_default() bind(C, name='nuno_signals_default')
    end subroutine nuno_signals_default
    subroutine nuno_pause_ms(ms) bind(C, name='nuno_pause_ms')
      import :: c_int
      integer(c_int), value :: ms
    end subroutine nuno_pause_ms
    !> src/app/nuno_input_options.c: the -nuno_allow_long option block.
    function nuno_input_options_read(fcomm, allow_long, ts_dt, ts_dt_set, restart, restart_len, walltime, bad, bad_len) &
        bind(C, name='nuno_input_options_read') result(code)
      import :: c_int, c_double, c_char
      integer(c_int), value :: fcomm
      integer(c_int), intent(out) :: allow_long, ts_dt_set
      real(c_double), intent(out) :: ts_dt
      character(kind=c_char), intent(inout) :: restart(*)
      integer(c_int), value :: restart_len
      real(c_double), intent(out) :: walltime
      character(kind=c_char), intent(inout) :: bad(*)
      integer(c_int), value :: bad_len
      integer(c_int) :: code
    end function nuno_input_options_read
  end interface

contains

  !> True when an argument is --help or -h, or PETSc's -help without an
  !> input file (with one, -help lists the options of that run's set-up:
  !> petsc_help_given).
  logical function help_requested()
    character(len=512) :: path
    help_requested = argument_given([character(len=6) :: '--help', '-h'])
    if (.not. help_requested .and. petsc_help_given()) help_requested = .not. input_path_argument(path)
  end function help_requested

  !> True when an argument is PETSc's -help (or --help's PETSc spelling
  !> -help intro).
  logical function petsc_help_given()
    petsc_help_given = argument_given(['-help'])
  end function petsc_help_given

  !> True when an argument is --version.
  logical function version_requested()
    version_requested = argument_given(['--version'])
  end function version_requested

  !> True when an argument is --list-keys.
  logical function list_keys_requested()
    list_keys_requested = argument_given(['--list-keys'])
  end function list_keys_requested

  !> True when an argument is one of names (a whole argument).
  logical function argument_given(names)
    character(*), intent(in) :: names(:)
    integer :: k
    character(len=64) :: arg
    argument_given = .false.
    do k = 1, command_argument_count()
      call get_command_argument(k, arg)
      if (any(arg == names)) argument_given = .true.
    end do
  end function argument_given

  !> The input file: the first argument, which must not be an option.
  logical function input_path_argument(path)
    character(len=*), intent(out) :: path
    path = ''
    input_path_argument = .false.
    if (command_argument_count() < 1) return
    call get_command_argument(1, path)
    input_path_argument = len_trim(path) > 0 .and. path(1:1) /= '-'
  end function input_path_argument

  !> The command line's words after the input file, as PETSc reads them
  !> (src/sys/objects/options.c, PetscOptionsInsertArgs): an option name
  !> takes the next word as its value unless that is an option name too;
  !> -options_file, -options_file_yaml, -options_string_yaml, -prefix_push
  !> (and nuno's -nuno_set, module input_text) take the next word always.
  !> PETSc skips any other word silently, so `nuno in.nml ts_max_steps 1`
  !> or a second namelist file ran the whole scene: msg is the one-line
  !> refusal of the first such word ('' when none), with a hint.
  subroutine stray_argument(msg)
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: arg, hint
    integer :: k, n

    msg = ''
    n = command_argument_count()
    k = 2
    do while (k <= n)
      arg = argument_text(k)
      if (.not. option_name(arg)) exit
      select case (arg)
      case ('-prefix_pop')
        k = k + 1
      case ('-nuno_set', '-options_file', '-options_file_yaml', '-options_string_yaml', '-prefix_push')
        k = k + 2
      case default
        k = k + 1
        if (k <= n) then
          if (.not. option_name(argument_text(k))) k = k + 1
        end if
      end select
    end do
    if (k > n) return
    if (index(arg, '=') > 0) then
      hint = ': a namelist key goes in -nuno_set, with the whole list quoted when it has blanks '// &
             '(-nuno_set "nx=33 ny=33")'
    else if (verify(arg, 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_') == 0 .and. &
             scan(arg(1:1), '0123456789') == 0) then
      hint = ' (an option is written -'//arg//')'
    else if (k == 2 .or. index(arg, '.nml') > 0) then
      hint = ': nuno reads one input file, the first argument'
    else
      hint = ''
    end if
    write(msg, '(a,i0,a)') "command line: '"//arg//"' (argument ", k, ') is neither the input file, an option '// &
      '(options start with -) nor an option''s value'//hint
  end subroutine stray_argument

  !> Whether word is an option name as PETSc decides it
  !> (PetscOptionsValidKey): -name or --name whose first letter is a letter
  !> and which is not a number (-inf, -nan).
  logical function option_name(word)
    character(len=*), intent(in) :: word
    character(len=:), allocatable :: w
    option_name = .false.
    if (len(word) < 2) return
    if (word(1:1) /= '-') return
    w = word(2:)
    if (w(1:1) == '-') w = w(2:)
    if (len(w) < 1) return
    if (scan(w(1:1), 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ') == 0) return
    select case (lower(w))
    case ('inf', 'infinity', 'nan')
      return
    end select
    option_name = .true.
  end function option_name

  !> Argument k of the command line, whole.
  function argument_text(k) result(arg)
    integer, intent(in) :: k
    character(len=:), allocatable :: arg
    integer :: n
    call get_command_argument(k, length=n)
    allocate(character(len=n) :: arg)
    if (n > 0) call get_command_argument(k, arg)
  end function argument_text

  !> An options file of the command line (-options_file FILE,
  !> -options_file_yaml FILE) that rank 0 cannot read, or that has no file
  !> name: the one-line refusal ('' when none; the same on every rank).
  !> PETSc reads these files inside PetscInitialize, and its failure was a
  !> 15-line report from every rank and an abort; so this runs before
  !> PETSc, with MPI alone. Collective.
  subroutine options_file_refusal(comm, msg)
    integer, intent(in) :: comm
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: arg, file
    character(len=512) :: iomsg
    integer :: k, n, rank, ios, u, mpierr

    msg = ''
    call MPI_Comm_rank(comm, rank, mpierr)
    n = command_argument_count()
    do k = 2, n
      arg = argument_text(k)
      if (arg /= '-options_file' .and. arg /= '-options_file_yaml') cycle
      file = ''
      if (k < n) file = argument_text(k + 1)
      if (len(file) == 0 .or. option_name(file)) then
        msg = 'command line: '//arg//' needs a file name ('//arg//' FILE)'
        return
      end if
      ios = 0
      if (rank == 0) then
        open(newunit=u, file=file, status='old', action='read', iostat=ios, iomsg=iomsg)
        if (ios == 0) close(u)
      end if
      call MPI_Bcast(ios, 1, MPI_INTEGER, 0, comm, mpierr)
      if (ios /= 0) then
        msg = 'command line: '//arg//' '//file//': cannot read it'
        if (rank == 0) msg = trim(msg)//' ('//trim(iomsg)//')'
        return
      end if
    end do
  end subroutine options_file_refusal

  !> Collective error exit: one line on rank 0 (stderr), exit code 1
  !> everywhere; with reported, no line (the cause was reported already and
  !> this error follows from it, e.g. a full disk refusing the close).
  subroutine fatal_collective(msg, reported)
    character(len=*), intent(in) :: msg
    logical, intent(in), optional :: reported
    integer :: rank, ierr
    PetscBool :: initialized
    logical :: quiet, finalized
    quiet = .false.
    if (present(reported)) quiet = reported
    call MPI_Comm_rank(MPI_COMM_WORLD, rank, ierr)
    if (rank == 0 .and. .not. quiet) then
      write(0, '(a)') 'nuno: error: '//trim(msg)
      flush(0)
    end if
    ! What this run made and that holds no result yet (a .partial before
    ! its first step, the lock, a scratch directory) goes: a failed start
    ! leaves nothing behind that it did not find.
    call cleanup_run()
    call PetscInitialized(initialized, ierr)
    if (initialized) call PetscFinalize(ierr)
    ! main starts MPI before PETSc (the command line's checks), so PETSc
    ! leaves it to us
    call MPI_Finalized(finalized, ierr)
    if (.not. finalized) call MPI_Finalize(ierr)
    call quiet_exit(1)
  end subroutine fatal_collective

  !> End this process with exit status `code` and nothing printed.
  subroutine quiet_exit(code)
    integer, intent(in) :: code
    flush(6)
    flush(0)
    stop code, quiet=.true.
  end subroutine quiet_exit

  !> Local error exit, for an error that some ranks may not have seen (a
  !> PETSc or HDF5 failure inside the run): one line with the rank and the
  !> PETSc error's text (quiet_petsc_errors), then MPI_Abort, which ends
  !> every rank, so nothing can hang in a collective. Most such errors are
  !> seen by every rank alike (a bad option value): ranks other than 0 wait
  !> a moment before printing, and rank 0's abort ends them first, so one
  !> line comes out; an error of one rank alone is still printed by it.
  !> (The SIGTERM handler of a run is removed first: the abort's SIGTERM
  !> would otherwise cut the wait short.)
  subroutine fatal_local(msg)
    character(len=*), intent(in) :: msg
    integer :: rank, ierr
    character(kind=c_char, len=512) :: buf
    character(len=:), allocatable :: petsc
    call MPI_Comm_rank(MPI_COMM_WORLD, rank, ierr)
    call nuno_signals_default()   ! the abort's SIGTERM must end the other ranks
    buf = ''
    call nuno_petsc_error_text(buf, int(len(buf), c_int))
    petsc = buf(1:max(0, index(buf, c_null_char) - 1))
    if (len_trim(petsc) > 0) petsc = ': PETSc: '//trim(petsc)
    if (rank /= 0) call nuno_pause_ms(2000_c_int)
    write(0, '(a,i0,a)') 'nuno: error (rank ', rank, '): '//trim(msg)//petsc
    flush(0)
    call cleanup_run()   ! as fatal_collective; only the rank that made them has any
    call MPI_Abort(MPI_COMM_WORLD, 1, ierr)
    call quiet_exit(1)   ! not reached: MPI_Abort does not return
  end subroutine fatal_local

  !> From here on a PETSc error prints nothing; fatal_local prints its text.
  subroutine quiet_petsc_errors(ierr)
    PetscErrorCode, intent(out) :: ierr
    ierr = nuno_quiet_petsc_errors()
  end subroutine quiet_petsc_errors

  !> nuno's input-check options (in -help): allow_long = -nuno_allow_long;
  !> ts_dt = -ts_dt when given (it overrides the namelist's dt), else
  !> dt_default; restart = -nuno_restart ('' if none); walltime =
  !> -nuno_checkpoint_walltime in seconds (0 if none); bad: the one-line
  !> error for an option value that was refused ('' if none). Collective.
  subroutine read_input_options(comm, dt_default, allow_long, ts_dt, ts_dt_set, restart, walltime, bad, ierr)
    integer, intent(in) :: comm
    PetscReal, intent(in) :: dt_default
    logical, intent(out) :: allow_long, ts_dt_set
    PetscReal, intent(out) :: ts_dt
    character(len=*), intent(out) :: restart, bad
    real(rp), intent(out) :: walltime
    PetscErrorCode, intent(out) :: ierr
    integer(c_int) :: al, set
    real(c_double) :: dt, wt
    character(len=1024, kind=c_char) :: cres
    character(len=512, kind=c_char) :: cbad
    al = 0
    set = 0
    dt = 0
    wt = 0
    cres = c_null_char
    cbad = c_null_char
    ierr = nuno_input_options_read(int(comm, c_int), al, dt, set, cres, int(len(cres), c_int), wt, &
                                   cbad, int(len(cbad), c_int))
    allow_long = al /= 0
    ts_dt_set = set /= 0
    ts_dt = dt_default
    if (ts_dt_set) ts_dt = real(dt, kind(ts_dt))
    restart = cres(1:max(0, index(cres, c_null_char) - 1))
    bad = cbad(1:max(0, index(cbad, c_null_char) - 1))
    walltime = real(wt, rp)
  end subroutine read_input_options

  !> Insert the namelist's petsc_options string, except options that the
  !> command line already set (the command line wins). These come after
  !> PetscInitialize, so two kinds are handled here:
  !> - a viewer that names a file (`-log_view :FILE`, `-ksp_view ascii:FILE`,
  !>   `-snes_monitor :FILE`, ...) is refused: PETSc would create or
  !>   truncate FILE, an existing file of the user's too, and nuno creates
  !>   or overwrites only its own files; on the command line it is the
  !>   user's explicit PETSc option and works as PETSc documents it;
  !> - `-log_view` to the screen is honoured: PETSc starts its log only
  !>   when -log_view is given at PetscInitialize, and PetscFinalize failed
  !>   on a log never started (exit 56), so it is started here.
  subroutine apply_namelist_options(opts, ierr, errmsg)
    character(len=*), intent(in) :: opts
    PetscErrorCode, intent(out) :: ierr
    character(len=*), intent(out) :: errmsg
    character(len=256) :: tok(128)
    integer :: n, k
    PetscBool :: set
    real :: r
    integer :: ios
    logical :: has_value, start_log

    ierr = 0
    errmsg = ''
    start_log = .false.
    call split_words(opts, tok, n)
    k = 1
    do while (k <= n)
      if (tok(k)(1:1) /= '-') then
        ierr = 1
        errmsg = "input: &output: petsc_options: '"//trim(tok(k))//"' is not an option (options start with -)"
        return
      end if
      call PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, trim(tok(k)), set, ierr)
      if (ierr /= 0) return
      ! A value follows unless the next word is another option (a negative number is a value).
      ios = 1
      if (k < n) read(tok(k + 1), *, iostat=ios) r
      has_value = k < n
      if (has_value) has_value = tok(k + 1)(1:1) /= '-' .or. ios == 0
      if (has_value) then
        if (viewer_file(tok(k), tok(k + 1))) then
          ierr = 1
          errmsg = "input: &output: petsc_options: '"//trim(tok(k))//' '//trim(tok(k + 1))// &
                   "' would have PETSc write the file it names, over any file of that name: give it on the "// &
                   'command line instead (nuno creates only its own files)'
          return
        end if
        if (.not. set) call PetscOptionsSetValue(PETSC_NULL_OPTIONS, trim(tok(k)), trim(tok(k + 1)), ierr)
      else
        if (.not. set) call PetscOptionsSetValue(PETSC_NULL_OPTIONS, trim(tok(k)), PETSC_NULL_CHARACTER, ierr)
      end if
      if (ierr /= 0) return
      if (.not. set .and. tok(k) == '-log_view') start_log = .true.
      k = k + merge(2, 1, has_value)
    end do
    if (start_log) then
      call PetscLogDefaultBegin(ierr)
      if (ierr /= 0) return
      ! Read by PetscFinalize, after the report of unused options: marked used here.
      call PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-log_view', set, ierr)
    end if
  end subroutine apply_namelist_options

  !> Whether option `name` with `value` is a PETSc viewer that writes a
  !> file: a viewing or monitoring option (its name has view or monitor, or
  !> it is a -log_ option) whose value has the viewer form TYPE:FILE[:...]
  !> with a file name (PETSc 3.18's PetscOptionsGetViewer), or
  !> -ts_monitor_solution_vtk, whose value is a file name template.
  logical function viewer_file(name, value)
    character(len=*), intent(in) :: name, value
    integer :: c1, c2
    viewer_file = name == '-ts_monitor_solution_vtk'
    if (viewer_file) return
    if (index(name, 'view') == 0 .and. index(name, 'monitor') == 0 .and. index(name, '-log_') /= 1) return
    c1 = index(value, ':')
    if (c1 == 0) return
    c2 = index(value(c1 + 1:), ':')
    if (c2 == 0) then
      c2 = len_trim(value) + 1
    else
      c2 = c1 + c2
    end if
    viewer_file = c2 > c1 + 1
  end function viewer_file

  !> Blank-separated words of s.
  subroutine split_words(s, words, n)
    character(len=*), intent(in) :: s
    character(len=*), intent(out) :: words(:)
    integer, intent(out) :: n
    integer :: i, start
    n = 0
    i = 1
    do while (i <= len_trim(s))
      if (s(i:i) == ' ') then
        i = i + 1
        cycle
      end if
      start = i
      do while (i <= len(s))
        if (s(i:i) == ' ') exit
        i = i + 1
      end do
      if (n < size(words)) then
        n = n + 1
        words(n) = s(start:i - 1)
      end if
    end do
  end subroutine split_words

  !> The PETSc options of this run, for the output file: the command-line
  !> arguments after the input file.
  function petsc_options_text() result(txt)
    character(len=:), allocatable :: txt
    character(len=1024) :: arg
    integer :: k
    txt = ''
    do k = 2, command_argument_count()
      call get_command_argument(k, arg)
      txt = txt//trim(arg)//' '
    end do
    txt = trim(txt)
  end function petsc_options_text

end module errors
