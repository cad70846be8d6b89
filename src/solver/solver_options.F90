! SPDX-License-Identifier: BSD-2-Clause
!> nuno's solver options on the Fortran side: the interfaces of the PETSc
!> options blocks in C (src/solver/nuno_options.c, src/solver/nuno_petsc_habits.c: PETSc
!> 3.18 has no Fortran PetscOptionsBegin/End, so an option shows in -help
!> only from C), and the policy around them: the defaults nuno puts in the
!> options database for the time step's Newton solve, the integrator of
!> adaptive runs, and the TS scheme's name for the start-up line. The
!> option choice lists are module solver_choices'.
module solver_options
#include "petsc/finclude/petscts.h"
  use petscts
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_null_char
  use strings, only: itoa, real_g0
  use input_text, only: lower
  implicit none
  private
  public :: nuno_options_read, nuno_linesearch_options_read, nuno_tolerance_options_read, nuno_options_report_unused
  public :: adaptive_default, step_defaults, ts_scheme, petsc_habits

  !> The integrator of adaptive runs when -ts_type is not given: the method
  !> that won the work-precision measurement at moderate tolerance
  !> (docs/workprecision.md, "The default of adaptive runs"). PETSc's rosw
  !> is Rosenbrock-W ra34pw2 unless -ts_rosw_type says otherwise.
  character(len=*), parameter :: ADAPTIVE_TS_TYPE = TSROSW

  interface
    !> src/solver/nuno_options.c: the Newton step's options in a PETSc options
    !> block; the choices as codes of the lists passed (module solver_choices).
    integer(c_int) function nuno_options_read(fcomm, jac_names, jac_n, jac_len, jacobian, pc_lag, pc_growth, &
                                              interp_names, interp_n, interp_len, mg_interp, snes_floor, gauss_newton, clamp, &
                                              mattype, mattype_len, fail_newton, forcing, guess_names, guess_n, guess_len, &
                                              guess, guess_given) bind(C, name='nuno_options_read')
      import :: c_int, c_double, c_char
      integer(c_int), value :: fcomm, jac_n, jac_len, interp_n, interp_len, guess_n, guess_len
      character(kind=c_char), intent(in) :: jac_names(*), interp_names(*), guess_names(*)
      integer(c_int), intent(inout) :: jacobian, pc_lag, mg_interp, gauss_newton, clamp, fail_newton, forcing, guess
      integer(c_int), intent(out) :: guess_given
      real(c_double), intent(inout) :: snes_floor, pc_growth
      character(kind=c_char), intent(inout) :: mattype(*)
      integer(c_int), value :: mattype_len
    end function nuno_options_read
    !> src/solver/nuno_petsc_habits.c: -pc_type (NUL-terminated) and -ksp_type in an options block.
    integer(c_int) function nuno_petsc_habits_options(fcomm, pctype, len, pcset) bind(C, name='nuno_petsc_habits_options')
      import :: c_int, c_char
      integer(c_int), value :: fcomm, len
      character(kind=c_char), intent(out) :: pctype(*)
      integer(c_int), intent(out) :: pcset
    end function nuno_petsc_habits_options
    !> src/solver/nuno_petsc_habits.c: whether mt (NUL-terminated) is a PETSc matrix type.
    integer(c_int) function nuno_mat_type_exists(mt, exists) bind(C, name='nuno_mat_type_exists')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: mt(*)
      integer(c_int), intent(out) :: exists
    end function nuno_mat_type_exists
    !> src/solver/nuno_petsc_habits.c: -ksp_*, -pc_*, ... moved to -reduced_*.
    integer(c_int) function nuno_petsc_habits_move(fcomm) bind(C, name='nuno_petsc_habits_move')
      import :: c_int
      integer(c_int), value :: fcomm
    end function nuno_petsc_habits_move
    !> src/solver/nuno_options.c: -nuno_linesearch_fallback, a code of the list names.
    integer(c_int) function nuno_linesearch_options_read(fcomm, names, n, len, fallback, given) &
        bind(C, name='nuno_linesearch_options_read')
      import :: c_int, c_char
      integer(c_int), value :: fcomm, n, len
      character(kind=c_char), intent(in) :: names(*)
      integer(c_int), intent(inout) :: fallback
      integer(c_int), intent(out) :: given
    end function nuno_linesearch_options_read
    !> src/solver/nuno_options.c: -nuno_atol_position, -nuno_atol_velocity (after TSSetFromOptions).
    integer(c_int) function nuno_tolerance_options_read(fcomm, atol_x, atol_v, given_x, given_v) &
        bind(C, name='nuno_tolerance_options_read')
      import :: c_int, c_double
      integer(c_int), value :: fcomm
      real(c_double), intent(inout) :: atol_x, atol_v
      integer(c_int), intent(out) :: given_x, given_v
    end function nuno_tolerance_options_read
    !> src/solver/nuno_options.c: -nuno_adaptive_ts_type (type in/out, NUL-terminated).
    integer(c_int) function nuno_adaptive_ts_type_option(fcomm, type, len) bind(C, name='nuno_adaptive_ts_type_option')
      import :: c_int, c_char
      integer(c_int), value :: fcomm
      character(kind=c_char), intent(inout) :: type(*)
      integer(c_int), value :: len
    end function nuno_adaptive_ts_type_option
    !> src/solver/nuno_options.c: warn about options that nothing read.
    integer(c_int) function nuno_options_report_unused(fcomm, nunused) bind(C, name='nuno_options_report_unused')
      import :: c_int
      integer(c_int), value :: fcomm
      integer(c_int), intent(out) :: nunused
    end function nuno_options_report_unused
  end interface

contains

  !> The integrator of an adaptive run whose -ts_type is not given: nuno's
  !> default is backward Euler with the namelist's fixed step (the report's
  !> scheme); with -ts_adapt_type other than none and no -ts_type it is
  !> -nuno_adaptive_ts_type (default ADAPTIVE_TS_TYPE), so that a user who
  !> only asks for adaptive steps gets the fastest method at moderate
  !> tolerance. An explicit -ts_type always wins. Call after TSSetType(ts,
  !> beuler) and before TSSetFromOptions (which still applies -ts_rosw_type
  !> and the like). applied: it set the type. Collective.
  subroutine adaptive_default(ts, comm, applied, ierr)
    type(tTS), intent(inout) :: ts
    integer, intent(in) :: comm
    logical, intent(out) :: applied
    PetscErrorCode, intent(out) :: ierr
    character(len=64, kind=c_char) :: ctype
    character(len=64) :: adapt
    PetscBool :: has_adapt, has_type

    applied = .false.
    ctype = ADAPTIVE_TS_TYPE//c_null_char
    ierr = nuno_adaptive_ts_type_option(comm, ctype, len(ctype))
    if (ierr /= 0) return
    adapt = TSADAPTNONE
    PetscCall(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_adapt_type', adapt, has_adapt, ierr))
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_type', has_type, ierr))
    if (has_adapt .and. trim(adapt) /= TSADAPTNONE .and. .not. has_type) then
      PetscCall(TSSetType(ts, ctype(1:index(ctype, c_null_char) - 1), ierr))
      applied = .true.
    end if
  end subroutine adaptive_default

  !> Defaults of the time step's Newton solve that the options may override
  !> (set in the options database before TSSetFromOptions, after the type is
  !> set; measured with the structured multigrid's introduction, commit
  !> cdb1ad4). Collective.
  !> - Backward Euler starts each Newton solve from the state extrapolated
  !>   along the last step (x + dt xdot, PETSc's
  !>   -ts_theta_initial_guess_extrapolate) rather than from the last state:
  !>   its residual is 20-50 times smaller on hang 257 x 257, and Newton's
  !>   remainder after one iteration, quadratic in it, some 400-2500 times.
  !>   Only for beuler: theta < 1 (cn) keeps its stiff modes oscillating from
  !>   step to step, and extrapolating them doubles their error. The first
  !>   step of a window (TSRestartStep) is not extrapolated. Only on the
  !>   reduced path: the 6-dof path's GMRES + ILU(0) failed earlier from the
  !>   extrapolated start on hang 65 x 65 (t = 2 ms against 15 ms).
  !> - On the reduced path S is assembled at every other Newton iteration
  !>   (-snes_lag_jacobian 2): the second iteration of a step, which starts
  !>   from a residual some 1e-4 of the first, converges to the round-off
  !>   floor with the first one's S (a chord step), and an assembly is most
  !>   of an iteration's cost outside the inner solve. A third iteration, if
  !>   one is needed, assembles S again.
  subroutine step_defaults(ts, reduced, ierr)
    type(tTS), intent(in) :: ts
    logical, intent(in) :: reduced
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: tstype
    PetscBool :: given, has_type, beuler

    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_theta_initial_guess_extrapolate', given, ierr))
    if (reduced .and. .not. given) then
      tstype = ''
      PetscCall(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_type', tstype, has_type, ierr))
      if (has_type) then
        beuler = trim(tstype) == TSBEULER
      else
        PetscCall(PetscObjectTypeCompare(ts, TSBEULER, beuler, ierr))
      end if
      if (beuler) then
        PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-ts_theta_initial_guess_extrapolate', 'true', ierr))
      end if
    end if
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-snes_lag_jacobian', given, ierr))
    if (reduced .and. .not. given) then
      PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-snes_lag_jacobian', '2', ierr))
    end if
  end subroutine step_defaults

  !> PETSc's linear-solver options as users type them (input/README.md,
  !> "Linear solvers: PETSc options as you know them"), on the path in use;
  !> before anything reads -ksp_* or -pc_*. Collective (the options are the
  !> same on every rank, so is every decision).
  !> The default (reduced) path's outer linear solve is nuno's elimination
  !> around the 3-dof system S (a shell preconditioner under KSP preonly): a
  !> PETSc -pc_type there replaced the elimination and failed ("Could not
  !> locate a solver type for factorization type LU and matrix type shell").
  !> The linear solve a user means is the inner one, so on that path every
  !> option of the prefix-less solver, -ksp_*, -pc_*, and those of its
  !> sub-solvers -sub_*, -mg_levels_*, -mg_coarse_*, is read as the same
  !> option of the inner solve, -reduced_ksp_*, -reduced_pc_*, ... (-pc_type
  !> lu: an exact inner solve). Refused there, one line each with what to
  !> use: -pc_type fieldsplit and shell, -dm_mat_type, and an option given
  !> both ways with different values. On the 6-dof path (-nuno_jacobian
  !> full) PETSc's options act as usual; -dm_mat_type is checked against
  !> PETSc's matrix types, and -pc_type fieldsplit, which cannot split
  !> baij's 6 x 6 blocks, gets aij storage (mattype, NUL-terminated) unless
  !> -dm_mat_type says otherwise.
  subroutine petsc_habits(comm, reduced, mattype, ierr)
    integer, intent(in) :: comm
    logical, intent(in) :: reduced
    character(len=*, kind=c_char), intent(inout) :: mattype
    PetscErrorCode, intent(out) :: ierr
    character(len=64, kind=c_char) :: cpc
    character(len=64) :: pctype, mt
    integer(c_int) :: pcset, exists
    PetscBool :: mtset
    logical :: fieldsplit

    ierr = nuno_petsc_habits_options(comm, cpc, len(cpc), pcset)
    if (ierr /= 0) return
    pctype = cpc(1:index(cpc, c_null_char) - 1)
    mt = ''
    PetscCall(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-dm_mat_type', mt, mtset, ierr))
    fieldsplit = pcset /= 0 .and. lower(trim(pctype)) == PCFIELDSPLIT
    if (.not. reduced) then
      if (mtset) then
        ierr = nuno_mat_type_exists(trim(mt)//c_null_char, exists)
        if (ierr /= 0) return
        if (exists == 0) then
          ierr = PETSC_ERR_ARG_UNKNOWN_TYPE
          SETERRQ(comm, ierr, '-dm_mat_type '//trim(mt)//' is not a PETSc matrix type (baij: the default, 6 x 6 blocks; aij: for -pc_type fieldsplit)')
        end if
      end if
      if (fieldsplit) then
        if (.not. mtset) then
          mattype = MATAIJ//c_null_char
        else if (lower(trim(mt)) == MATBAIJ .or. lower(trim(mt)) == MATSBAIJ) then
          ierr = PETSC_ERR_ARG_INCOMP
          SETERRQ(comm, ierr, '-pc_type fieldsplit with -dm_mat_type '//trim(mt)//': PETSc''s field split cannot split the 6 x 6 blocks of '//trim(mt)//'; leave -dm_mat_type out (aij then) or give aij')
        end if
      end if
      return
    end if
    if (mtset) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, '-dm_mat_type '//trim(mt)//' is the storage of the 6-dof Jacobian, which the default (reduced) path does not assemble: -reduced_dm_mat_type sets that of S (with -reduced_pc_type), -nuno_jacobian full -dm_mat_type '//trim(mt)//' the 6-dof path')
    end if
    if (fieldsplit) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, '-pc_type fieldsplit: the default (reduced) path already eliminates the positions and solves their Schur complement S; for PETSc''s field split of the 6-dof Jacobian give -nuno_jacobian full -pc_type fieldsplit (input/README.md), for the inner solve of S -reduced_pc_type')
    end if
    if (pcset /= 0 .and. lower(trim(pctype)) == PCSHELL) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, '-pc_type shell: nuno has no user preconditioner to call; the default path''s own is its elimination (-reduced_pc_type for the inner solve)')
    end if
    ierr = nuno_petsc_habits_move(comm)
  end subroutine petsc_habits

  !> The TS type with its scheme, for the start-up line: "rosw ra34pw2",
  !> "arkimex 5", "bdf order 4", "theta 0.5", else the type alone. Collective.
  subroutine ts_scheme(ts, scheme, ierr)
    type(tTS), intent(in) :: ts
    character(len=:), allocatable, intent(out) :: scheme
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: tstype, sub
    PetscBool :: is, implicit
    PetscInt :: order
    PetscReal :: theta

    PetscCall(TSGetType(ts, tstype, ierr))
    scheme = trim(tstype)
    PetscCall(PetscObjectTypeCompare(ts, TSROSW, is, ierr))
    if (is) then
      PetscCall(TSRosWGetType(ts, sub, ierr))
      scheme = trim(tstype)//' '//trim(sub)
      return
    end if
    PetscCall(PetscObjectTypeCompare(ts, TSARKIMEX, is, ierr))
    if (is) then
      PetscCall(TSARKIMEXGetType(ts, sub, ierr))
      PetscCall(TSARKIMEXGetFullyImplicit(ts, implicit, ierr))
      scheme = trim(tstype)//' '//trim(sub)
      if (implicit) scheme = scheme//' fully implicit'
      return
    end if
    PetscCall(PetscObjectTypeCompare(ts, 'bdf', is, ierr))           ! (no TSBDF in 3.18's Fortran)
    if (is) then
      PetscCall(TSBDFGetOrder(ts, order, ierr))
      scheme = trim(tstype)//' order '//itoa(int(order))
      return
    end if
    PetscCall(PetscObjectTypeCompare(ts, TSTHETA, is, ierr))
    if (is) then
      PetscCall(TSThetaGetTheta(ts, theta, ierr))
      scheme = trim(tstype)//' '//real_g0(theta)
    end if
  end subroutine ts_scheme

end module solver_options
