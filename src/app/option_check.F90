! SPDX-License-Identifier: BSD-2-Clause
!> The options checked once the solver is set up and before its first step
!> (input/README.md, "Options are honoured or refused"), so that a 10-hour
!> job does not learn of a typo at its end:
!> - an option that nothing has read is refused, with the nearest option
!>   the run knows (-ts_tpye: did you mean -ts_type?), unless it is of a
!>   kind that PETSc reads only later (read_later: viewers and reports, the
!>   solvers PETSc makes at the first solve, the fit's TAO and adjoint);
!>   those are still reported at the end of the run if nothing read them;
!> - an integer option whose value is beyond PETSc's integers (PETSc 3.18
!>   wraps -ts_max_steps 4294967297 to 1);
!> - a TS type that nuno's residual cannot run (RUNNABLE_TS_TYPES).
!> The options the run knows are those PETSc's and nuno's options blocks
!> read during the set-up, collected from -help's text
!> (src/app/nuno_option_names.c). With -help itself, PETSc prints that
!> text, and the run stops here: nothing runs, no file is written.
module option_check
#include "petsc/finclude/petscts.h"
  use petscts
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char
  use, intrinsic :: iso_fortran_env, only: int64
  use nearest_word, only: nearest
  implicit none
  private
  public :: help_before_petsc, option_names_begin, options_before_run, RUNNABLE_TS_TYPES

  !> The TS types nuno runs: the implicit methods for its residual
  !> F(t, U, Udot) = 0 with the Jacobian dF/dU + a dF/dUdot, which keep the
  !> solution to the accuracy of their order on hang (checked against a
  !> converged cn run; glle chooses its own steps). Not: the explicit
  !> methods (euler, rk, ssp, glee, basicsymplectic, mprk: they need a
  !> right-hand side f(t, U), and glee ran to a wrong solution), alpha2 (a
  !> second-order form), irk (PETSc's KAIJ cannot take nuno's Jacobian),
  !> pseudo (a steady state), discgrad and mimex (they failed in the first
  !> step).
  character(len=8), parameter :: RUNNABLE_TS_TYPES(9) = [character(len=8) :: 'beuler', 'cn', 'theta', 'alpha', &
                                                        'bdf', 'arkimex', 'rosw', 'eimex', 'glle']
  character(len=8), parameter :: EXPLICIT_TS_TYPES(6) = [character(len=8) :: 'euler', 'rk', 'ssp', 'glee', &
                                                        'basicsym', 'mprk']
  !> Options read after the set-up, or only at the end, that the
  !> collected names cannot hold: hints for a misspelling of them.
  character(len=32), parameter :: LATER_NAMES(14) = [character(len=32) :: '-log_view', '-options_left', '-help', &
    '-ksp_view', '-snes_view', '-ts_view', '-reduced_ksp_view', '-ksp_converged_reason', '-snes_converged_reason', &
    '-reduced_ksp_converged_reason', '-mat_view', '-info', '-tao_type', '-identify_check_gradient']

  interface
    integer(c_int) function nuno_help_before_petsc() bind(C, name='nuno_help_before_petsc')
      import :: c_int
    end function nuno_help_before_petsc
    integer(c_int) function nuno_option_names_begin(help) bind(C, name='nuno_option_names_begin')
      import :: c_int
      integer(c_int), intent(out) :: help
    end function nuno_option_names_begin
    integer(c_int) function nuno_option_names_end() bind(C, name='nuno_option_names_end')
      import :: c_int
    end function nuno_option_names_end
    integer(c_int) function nuno_option_names_count() bind(C, name='nuno_option_names_count')
      import :: c_int
    end function nuno_option_names_count
    subroutine nuno_option_name(i, buf, len, integer) bind(C, name='nuno_option_name')
      import :: c_int, c_char
      integer(c_int), value :: i, len
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_int), intent(out) :: integer
    end subroutine nuno_option_name
    integer(c_int) function nuno_option_left(i, name, nlen, value, vlen, has_value, n) bind(C, name='nuno_option_left')
      import :: c_int, c_char
      integer(c_int), value :: i, nlen, vlen
      character(kind=c_char), intent(out) :: name(*), value(*)
      integer(c_int), intent(out) :: has_value, n
    end function nuno_option_left
  end interface

contains

  !> Before PetscInitialize: with -help on the command line, a closed pipe
  !> ends the process quietly (`nuno IN.nml -help | head`), not through
  !> PETSc's signal handler (an error report and an abort).
  subroutine help_before_petsc(ierr)
    PetscErrorCode, intent(out) :: ierr
    ierr = nuno_help_before_petsc()
  end subroutine help_before_petsc

  !> Start collecting the names of the options the set-up reads; call right
  !> after PetscInitialize. help: the user gave -help (PETSc prints).
  subroutine option_names_begin(help, ierr)
    logical, intent(out) :: help
    PetscErrorCode, intent(out) :: ierr
    integer(c_int) :: h
    ierr = nuno_option_names_begin(h)
    help = h /= 0
  end subroutine option_names_begin

  !> After the solver's set-up, before the first step: with -help, one
  !> closing line and the end of the run (exit 0, nothing run or written);
  !> else the checks above. fit: an identification or control (their TAO
  !> and adjoint options are read when the fit starts). ierr 1: msg is the
  !> one-line refusal, the same decision on every rank; other ierr: PETSc's.
  !> Collective.
  subroutine options_before_run(ts, comm, fit, help, ierr, msg)
    type(tTS), intent(in) :: ts
    integer, intent(in) :: comm
    logical, intent(in) :: fit, help
    PetscErrorCode, intent(out) :: ierr
    character(len=*), intent(out) :: msg
    character(len=128), allocatable :: known(:)
    logical, allocatable :: integer_option(:)
    integer :: rank

    msg = ''
    ierr = nuno_option_names_end()
    if (ierr /= 0) return
    if (help) then
      call MPI_Comm_rank(comm, rank, ierr)
      if (rank == 0) write(*, '(a)') 'nuno: -help: above are the options of this run''s set-up (PETSc reads some '// &
        'more at its first solve, input/README.md, "Options are honoured or refused"); nothing was run or written'
      flush(6)
      call PetscFinalize(ierr)
      call MPI_Finalize(ierr)
      stop 0, quiet=.true.       ! (no note of the set-up's floating-point flags)
    end if
    call known_names(known, integer_option)
    call check_ts_type(ts, msg, ierr)
    if (ierr /= 0 .or. len_trim(msg) > 0) goto 9
    call check_integers(known, integer_option, msg, ierr)
    if (ierr /= 0 .or. len_trim(msg) > 0) goto 9
    call check_unread(known, fit, msg, ierr)
9   if (ierr == 0 .and. len_trim(msg) > 0) ierr = 1
  end subroutine options_before_run

  !> The option names collected during the set-up, and which are integers.
  subroutine known_names(known, integer_option)
    character(len=128), allocatable, intent(out) :: known(:)
    logical, allocatable, intent(out) :: integer_option(:)
    character(len=128, kind=c_char) :: buf
    integer(c_int) :: is_int
    integer :: k, n
    n = nuno_option_names_count()
    allocate(known(n + size(LATER_NAMES)), integer_option(n + size(LATER_NAMES)))
    do k = 1, n
      call nuno_option_name(k - 1, buf, len(buf), is_int)
      known(k) = c_text(buf)
      integer_option(k) = is_int /= 0
    end do
    known(n + 1:) = LATER_NAMES
    integer_option(n + 1:) = .false.
  end subroutine known_names

  !> The TS type in force must be one nuno runs (RUNNABLE_TS_TYPES): an
  !> explicit method failed at the first step, after the output file was
  !> made.
  subroutine check_ts_type(ts, msg, ierr)
    type(tTS), intent(in) :: ts
    character(len=*), intent(inout) :: msg
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: tstype
    character(len=:), allocatable :: list, source, why
    PetscBool :: given
    integer :: k

    PetscCall(TSGetType(ts, tstype, ierr))
    if (any(RUNNABLE_TS_TYPES == tstype)) return
    list = trim(RUNNABLE_TS_TYPES(1))
    do k = 2, size(RUNNABLE_TS_TYPES)
      list = list//', '//trim(RUNNABLE_TS_TYPES(k))
    end do
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_type', given, ierr))
    source = merge('-ts_type              ', '-nuno_adaptive_ts_type', logical(given))
    if (any(EXPLICIT_TS_TYPES == tstype(1:8))) then
      why = ' is an explicit method, which needs a right-hand side f(t, U)'
    else
      why = ' needs what nuno''s residual does not give'
    end if
    msg = trim(source)//' '//trim(tstype)//': '//trim(tstype)//why//'; nuno runs the implicit methods '//list// &
          ' (its residual is F(t, U, Udot) = 0 with its Jacobian)'
  end subroutine check_ts_type

  !> An integer option (PetscOptionsInt's, from the collected names) whose
  !> value is an integer beyond PetscInt's range: PETSc 3.18 converts it
  !> with strtol and a cast, so -ts_max_steps 4294967297 ran as 1 step and
  !> reported complete.
  subroutine check_integers(known, integer_option, msg, ierr)
    character(len=*), intent(in) :: known(:)
    logical, intent(in) :: integer_option(:)
    character(len=*), intent(inout) :: msg
    PetscErrorCode, intent(out) :: ierr
    character(len=256) :: value
    character(len=32) :: lo, hi
    integer(int64) :: v
    PetscInt :: pint
    PetscBool :: set
    integer :: k, ios, first

    ierr = 0
    do k = 1, size(known)
      if (.not. integer_option(k)) cycle
      PetscCall(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, trim(known(k)), value, set, ierr))
      if (.not. set) cycle
      value = adjustl(value)
      first = merge(2, 1, value(1:1) == '-' .or. value(1:1) == '+')
      if (len_trim(value) < first .or. verify(trim(value(first:)), '0123456789') /= 0) cycle
      read(value, *, iostat=ios) v
      if (ios == 0) then
        if (v >= -int(huge(pint), int64) - 1 .and. v <= int(huge(pint), int64)) cycle
      end if
      write(lo, '(i0)') -int(huge(pint), int64) - 1
      write(hi, '(i0)') huge(pint)
      msg = trim(known(k))//' '//trim(value)//': beyond the integers PETSc reads ('//trim(lo)//' .. '//trim(hi)//')'
      if (ios == 0 .and. bit_size(pint) == 32) then
        ! what PETSc's cast makes of it
        write(lo, '(i0)') modulo(v + 2_int64**31, 2_int64**32) - 2_int64**31
        msg = trim(msg)//': PETSc would read it as '//trim(lo)
      end if
      return
    end do
  end subroutine check_integers

  !> The options nothing read during the set-up, but for those read later
  !> (read_later): one line naming each with its value and the nearest
  !> option the run knows.
  subroutine check_unread(known, fit, msg, ierr)
    character(len=*), intent(in) :: known(:)
    logical, intent(in) :: fit
    character(len=*), intent(inout) :: msg
    PetscErrorCode, intent(out) :: ierr
    character(len=256, kind=c_char) :: cname
    character(len=1024, kind=c_char) :: cvalue
    character(len=:), allocatable :: name, list, near
    integer(c_int) :: has_value, n
    integer :: k, count

    list = ''
    count = 0
    ierr = nuno_option_left(-1, cname, len(cname), cvalue, len(cvalue), has_value, n)
    do k = 0, n - 1
      if (ierr /= 0) return
      ierr = nuno_option_left(k, cname, len(cname), cvalue, len(cvalue), has_value, n)
      name = c_text(cname)
      if (read_later(name, fit)) cycle
      count = count + 1
      if (count > 1) list = list//'; '
      list = list//name
      if (has_value /= 0) list = list//' '//c_text(cvalue)
      near = nearest(name, known)
      if (len(near) > 0) list = list//' (did you mean '//near//'?)'
    end do
    if (ierr /= 0 .or. count == 0) return
    msg = 'options: '//list//': '//trim(merge('not an option of this run', 'not options of this run  ', count == 1))// &
          ' (misspelt, or not for this solver), refused before the first step; '// &
          'nuno INPUT.nml -help lists the options of its run'
  end subroutine check_unread

  !> Whether option `name` (nothing read it during the set-up) is of a kind
  !> that PETSc reads only during the run or at its end, so that the set-up
  !> cannot know it (input/README.md, "Options are honoured or refused"):
  !> viewers and reports (read at the end of a solve or of the run:
  !> -ksp_view, -log_view, -*_converged_reason, -options_left, ...; the
  !> tests at a solve, -snes_test_jacobian), the
  !> options of the solvers and matrices PETSc makes at the first solve
  !> (block Jacobi's -sub_*, multigrid levels, field splits, factorisation
  !> packages), and in an identification or a control the fit's (-tao_*,
  !> its adjoint and trajectory).
  logical function read_later(name, fit)
    character(len=*), intent(in) :: name
    logical, intent(in) :: fit
    character(len=16), parameter :: inside(13) = [character(len=16) :: '_view', 'viewer', '_converged_reason', &
      '_test_', 'sub_', 'mg_levels_', 'mg_coarse_', 'fieldsplit_', 'pc_factor_', 'mat_', 'pc_gamg_', 'pc_hypre_', &
      'pc_ml_']
    character(len=24), parameter :: starting(5) = [character(len=24) :: '-log_', '-options_', '-malloc', '-memory_', &
      '-help']
    character(len=24), parameter :: fitting(5) = [character(len=24) :: '-tao_', '-identify_', '-control_', &
      '-ts_adjoint_', '-ts_trajectory_']
    integer :: k
    read_later = .true.
    do k = 1, size(inside)
      if (index(name, trim(inside(k))) > 0) return
    end do
    do k = 1, size(starting)
      if (index(name, trim(starting(k))) == 1) return
    end do
    if (fit) then
      do k = 1, size(fitting)
        if (index(name, trim(fitting(k))) == 1) return
      end do
    end if
    read_later = .false.
  end function read_later

  !> The text of a NUL-terminated C string.
  function c_text(buf) result(s)
    character(len=*, kind=c_char), intent(in) :: buf
    character(len=:), allocatable :: s
    integer :: k
    k = index(buf, c_null_char)
    if (k == 0) k = len(buf) + 1
    s = buf(1:k - 1)
  end function c_text

end module option_check
