! SPDX-License-Identifier: BSD-2-Clause
!> The text of a run's end: what failed and what to try (failure_reason,
!> failure_hints), signal names, and the collective output error
!> (report_io_error, which sets the run's error). Numbers as text are
!> module strings'.
module failure_text
#include "petsc/finclude/petscts.h"
  use process_models, only: pm_list_rejection
  use run_progress, only: progress_t_written
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int
  use, intrinsic :: iso_fortran_env, only: error_unit
  use kinds, only: rp
  use app_context, only: app_ctx
  use reduced, only: reduced_inner_ksp
  use step_settings, only: step_fixed, step_dt
  use run_error, only: run_error_set
  use model_state, only: model_singular
  implicit none
  private
  public :: signal_name, failure_reason, report_io_error

  !> TS_DIVERGED_STEP_REJECTED, which PETSc 3.18's Fortran interface does
  !> not define (petscts.h): -ts_max_reject rejections of one step in a row.
  integer, parameter :: TS_STEP_REJECTED = -2

contains

  !> What is known to help a failed Newton solve, leaving out what the user
  !> has already set: a smaller fixed step or adaptivity, more retries, a
  !> stronger inner preconditioner or the full Jacobian, and the monitors.
  function failure_hints(ctx) result(h)
    type(app_ctx), intent(in) :: ctx
    character(len=512) :: h
    character(len=32) :: dtq
    character(len=64) :: pctype
    type(tPC) :: pc
    type(tKSP) :: ksp
    type(tSNES) :: snes
    PetscErrorCode :: ierr
    h = 'try'
    if (step_fixed(ctx%step)) then
      write(dtq, '(es10.3)') 0.25_rp * step_dt(ctx%step)
      h = trim(h)//' a smaller step (-ts_dt '//trim(adjustl(dtq))//'), adaptive steps (-ts_adapt_type basic),'
    else if (.not. (given('-ts_max_snes_failures') .or. given('-ts_max_reject'))) then
      ! (adaptive steps: failed solves are rejected steps, unlimited in
      ! number, but at most -ts_max_reject of one step in a row)
      h = trim(h)//' more retries of a step (-ts_max_reject 100),'
    end if
    ! Each path names its own linear solve: the inner 3-dof one (reduced_
    ! prefix) or the 6-dof Krylov solve (no prefix).
    if (ctx%use_reduced) then
      ! (-reduced_pc_type is always in the options: nuno sets its default.)
      call KSPGetPC(reduced_inner_ksp(ctx%red), pc, ierr)
      if (ierr == 0) call PCGetType(pc, pctype, ierr)
      if (ierr == 0 .and. pctype /= PCLU .and. pctype /= PCCHOLESKY) &
        h = trim(h)//' a stronger inner preconditioner (-reduced_pc_type lu on small lattices),'
      h = trim(h)//' the assembled 6-dof Jacobian (-nuno_jacobian full),'
    else
      call TSGetSNES(ctx%ts, snes, ierr)
      if (ierr == 0) call SNESGetKSP(snes, ksp, ierr)
      if (ierr == 0) call KSPGetPC(ksp, pc, ierr)
      if (ierr == 0) call PCGetType(pc, pctype, ierr)
      if (ierr == 0 .and. pctype /= PCLU .and. pctype /= PCCHOLESKY) &
        h = trim(h)//' an exact linear solve (-ksp_type preonly -pc_type lu on small lattices),'
      h = trim(h)//' the default reduced Newton step (without -nuno_jacobian full),'
    end if
    if (given('-snes_monitor')) then
      h = trim(h)//' and the monitor output above'
    else if (ctx%use_reduced) then
      h = trim(h)//' and -snes_monitor -reduced_ksp_converged_reason to see where it stalls'
    else
      h = trim(h)//' and -snes_monitor -ksp_converged_reason -snes_linesearch_monitor to see where it stalls'
    end if
  contains
    logical function given(name)
      character(len=*), intent(in) :: name
      PetscBool :: set
      PetscErrorCode :: ierr
      call PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, name, set, ierr)
      given = set .and. ierr == 0
    end function given
  end function failure_hints

  !> SIGTERM, SIGINT or the signal's number.
  function signal_name(sig) result(name)
    integer(c_int), intent(in) :: sig
    character(len=16) :: name
    select case (sig)
    case (15)
      name = 'SIGTERM'
    case (2)
      name = 'SIGINT'
    case default
      write(name, '(a,i0)') 'signal ', sig
    end select
  end function signal_name

  !> One line saying why the run stopped.
  subroutine failure_reason(ctx, reason, t, msg)
    type(app_ctx), intent(in) :: ctx
    TSConvergedReason, intent(in) :: reason
    real(rp), intent(in) :: t
    character(len=*), intent(out) :: msg
    integer :: nbad(1), gbad(1), ierr, loc(3), glob(3), bad(2)
    real(rp) :: t_bad

    call model_singular(ctx%model, nbad(1), bad, t_bad)
    call MPI_Allreduce(nbad, gbad, 1, MPI_INTEGER, MPI_MAX, ctx%comm, ierr)
    if (gbad(1) > 0) then
      loc = -1
      if (nbad(1) > 0) loc = [bad(1), bad(2), 1]
      call MPI_Allreduce(loc, glob, 3, MPI_INTEGER, MPI_MAX, ctx%comm, ierr)
      write(msg, '(a,es12.5,a,i0,a,i0,a)') 'singular element at t = ', t_bad, &
        ' (zero-length link or bending triple folded back to theta = pi) anchored at node (', &
        glob(1), ', ', glob(2), ')'
    else if (len(pm_list_rejection(ctx%pms, progress_t_written(ctx%progress))) > 0 .and. reason < 0) then
      ! a process model rejected end states since the last output step (and
      ! the retries with smaller steps did not get the run past): its reason
      write(msg, '(a,es12.5,a)') 'time step from t = ', t, ' failed after step end states were rejected '// &
        '(each retried with a smaller step), the last: '//pm_list_rejection(ctx%pms, progress_t_written(ctx%progress))
    else if (reason == TS_DIVERGED_NONLINEAR_SOLVE) then
      write(msg, '(a,es12.5,a)') 'time step from t = ', t, ' failed: nonlinear solve diverged '// &
        '(TS_DIVERGED_NONLINEAR_SOLVE): the run''s failed Newton solves reached -ts_max_snes_failures '// &
        '(each retried with a smaller step); '//trim(failure_hints(ctx))
    else if (reason == TS_STEP_REJECTED .and. last_solve_failed(ctx)) then
      write(msg, '(a,es12.5,a)') 'time step from t = ', t, ' failed: its Newton solves failed -ts_max_reject '// &
        'times in a row (each retried with a quarter of the step); '//trim(failure_hints(ctx))
    else if (reason < 0) then
      write(msg, '(a,es12.5,a,i0,a)') 'time step from t = ', t, ' failed (TSConvergedReason ', reason, &
        ', e.g. -2 = step rejected too often by the error controller)'
    else
      write(msg, '(a,es12.5)') 'state became NaN or infinite at t = ', t
    end if
  end subroutine failure_reason

  !> The last Newton solve failed (adaptive steps: the rejected step that
  !> ended the run was a failed solve, not the error estimate's).
  logical function last_solve_failed(ctx)
    type(app_ctx), intent(in) :: ctx
    type(tSNES) :: snes
    SNESConvergedReason :: r
    PetscErrorCode :: ierr
    last_solve_failed = .false.
    call TSGetSNES(ctx%ts, snes, ierr)
    if (ierr /= 0) return
    call SNESGetConvergedReason(snes, r, ierr)
    last_solve_failed = ierr == 0 .and. r < 0
  end function last_solve_failed

  !> An output write failed (agreed by every rank): its one line on stderr
  !> (rank 0), and the run's error (module run_error), so that solver_run
  !> ends the run as failed.
  subroutine report_io_error(ctx, errmsg)
    type(app_ctx), intent(inout) :: ctx
    character(*), intent(in) :: errmsg
    if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(errmsg)
    call run_error_set(ctx%error, errmsg)
  end subroutine report_io_error

end module failure_text
