! SPDX-License-Identifier: BSD-2-Clause
!> Newton's policy on the PETSc side: the convergence test (round-off
!> floor, forcing, the integrator's error estimate), the line-search
!> fallback and the Newton start of beuler. Its record, app_ctx%newton, is
!> written by module newton_state's routines; the PETSc-free rules are in
!> src/kernels/newton_control.f90 and newton_forcing.f90.
module newton_policy
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_ptr, c_loc, c_f_pointer
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use newton_control, only: NEWTON_CONVERGED, NEWTON_DIVERGED
  use app_context, only: app_ctx
  use newton_state, only: newton_take_injected_failure, newton_first_residual, newton_iterated, newton_verdict, &
                          newton_inner_rtol, newton_fallback_switched, newton_forcing_on, newton_floor_est, &
                          newton_snorm_prev, newton_fallback, newton_rate_usable, newton_update_floor, &
                          newton_settled, newton_lag_settled, newton_target
  use newton_start, only: newton_start_setup, newton_start_smooth_limited, newton_start_consistent
  use constraints, only: constraints_active, constraint_count, constraint_target, constraint_node
  use process_models, only: pm_list_hints
  use process_model, only: pm_hints_t
  use reduced, only: reduced_set_forcing, reduced_floor_est, reduced_lin_rel, reduced_rtol0
  use solver_choices, only: FALLBACK_NAMES
  use step_settings, only: step_fixed, step_tolerances
  use strings, only: num => real_brief
  implicit none
  private
  public :: set_newton_start, snes_converged, linesearch_fallback

  !> Adaptive steps: Newton has converged when its estimated remaining error
  !> is below this fraction of the time integrator's tolerance (the
  !> weighted RMS norm of TSAdapt, in which a step is accepted at <= 1).
  real(rp), parameter :: NEWTON_TS_FRACTION = 0.01_rp
  !> SNESLineSearchReason's SNES_LINESEARCH_SUCCEEDED and _FAILED_REDUCT
  !> (no decrease found; petscsnes.h: PETSc 3.18 gives Fortran no names)
  integer, parameter :: LS_SUCCEEDED = 0, LS_FAILED_REDUCT = 3

contains

  !> Newton's start (-nuno_newton_start, module newton_start): auto
  !> is the consistent start for Newton with beuler at fixed steps (the
  !> cubic start, hang 257 x 257: one Newton iteration a step instead of
  !> two, commit 9f1bf04; with its positions x_n + dt v, a falling sheet
  !> at 129 x 129: 1.02 instead of 1.95; the linear start where its
  !> residual is the smaller, as in a membrane's transient), the linear one of PETSc (x_n + dt xdot_n)
  !> elsewhere: in the Baraff-Witkin mode (-snes_type ksponly) the start
  !> is the point of the one linearisation and its residual the scale of
  !> the solve's tolerance (163 -> 189 inner iterations over 30 steps
  !> there), adaptive steps change dt, identification and control
  !> runs keep their trajectories as they were, and a process model that
  !> needs a feasible start takes the consistent start limited by its step
  !> limit where its state moves smoothly (its hint smooth_start:
  !> contact; drape_sphere 129: 2.0 Newton iterations a step instead of
  !> 2.35), else the linear one limited.
  subroutine set_newton_start(ctx, ierr)
    type(app_ctx), intent(inout), target :: ctx
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    character(len=64) :: sntype
    logical :: auto_cubic, feasible_start
    type(pm_hints_t) :: h
    PetscCall(TSGetSNES(ctx%ts, snes, ierr))
    PetscCall(SNESGetType(snes, sntype, ierr))
    h = pm_list_hints(ctx%pms)
    feasible_start = h%feasible_start
    auto_cubic = step_fixed(ctx%step) .and. trim(sntype) /= SNESKSPONLY .and. &
                 .not. (ctx%cfg%identify%active .or. ctx%cfg%control%active) .and. &
                 (.not. feasible_start .or. h%smooth_start)
    PetscCall(newton_start_setup(ctx%start, ctx%ts, ctx%comm, auto_cubic, ierr))
    call newton_start_consistent(ctx%start, consistent_positions, c_loc(ctx))
  end subroutine set_newton_start

  !> The start's positions as backward Euler's position rows take them
  !> from its velocities (module model_state's residual): x = x_n + dt v,
  !> a prescribed node's x_n + dt vbar(t_n + dt). Collective (none here).
  subroutine consistent_positions(cp, xvec, ierr)
    type(c_ptr), value :: cp
    type(tVec) :: xvec
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: ctx
    type(tVec) :: x0vec
    PetscScalar, pointer :: x(:, :, :), x0(:, :, :)
    real(rp) :: t0, dt, xb(3), vb(3)
    integer :: i, j, k
    call c_f_pointer(cp, ctx)
    PetscCall(TSGetTime(ctx%ts, t0, ierr))
    PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
    PetscCall(TSGetSolution(ctx%ts, x0vec, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, x0vec, x0, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, xvec, x, ierr))
    x(0:2, :, ctx%lat%ys:ctx%lat%ye) = x0(0:2, :, ctx%lat%ys:ctx%lat%ye) + dt * x(3:5, :, ctx%lat%ys:ctx%lat%ye)
    if (constraints_active(ctx%cs)) then
      do k = 1, constraint_count(ctx%cs)
        call constraint_target(ctx%cs, k, t0 + dt, xb, vb)
        call constraint_node(ctx%cs, k, i, j)
        x(0:2, i, j) = x0(0:2, i, j) + dt * vb
      end do
    end if
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, xvec, x, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, x0vec, x0, ierr))
  end subroutine consistent_positions

  !> PETSc's residual test, plus the round-off floor of the residual, which
  !> grows with stiffness over mass (like N^5 for hang refined: 1.3e-5 at
  !> 129 x 129, 1.2e-2 at 513 x 513 against initial residuals of 1e3):
  !> Newton cannot go below it, and snes_rtol = 1e-8 would fail good steps.
  !> The same rule on both paths (module newton_control's floor_verdict),
  !> with the floor estimated at the last assembly of S (reduced; measured
  !> 14 times the actual floor at 129..513) or of the 6-dof Jacobian (full):
  !> converged is (a) a residual below snes_floor times its initial value
  !> or below the floor estimate that an iteration no longer reduces by
  !> 10 %, (b) a residual below FLOOR_FACTOR times the floor estimate, which
  !> saves the iteration that (a) needs, or (a') a line search that found
  !> no decrease (bt, the 6-dof path's default, or the reduced path's
  !> fallback) from a residual where (a) would stop: at the floor no step
  !> decreases ||F||. Any other failed line search diverges, as in PETSc.
  !> With the limited cubic start (a process model's hint smooth_start)
  !> also (d): an iteration that reduced ||F|| by less than 10 % with an
  !> update below 1e-10 of the state and a residual below 100 times the
  !> floor's estimate (newton_control's update_at_floor):
  !> that start can begin at the floor, where the estimate of (a) fell
  !> short of the floor met (a 7 x 7 sheet in free fall after a retried
  !> step, bt creeping by 1 % an iteration to the iteration limit).
  !> With adaptive steps also (c): the Newton error estimated from the
  !> update and the convergence rate, |du_k| rate/(1 - rate) in the time
  !> integrator's weighted norm (atol + rtol |u|), is below
  !> NEWTON_TS_FRACTION of the tolerance (the test of CVODE and IDA). Tight
  !> -ts_rtol shrinks the step, and with it the floor of F's x-rows
  !> (eps a |x|, a = 1/dt) grows past any residual test: (c) ties Newton to
  !> what the integrator asks for. It needs two iterations (a rate) and a
  !> rate below 0.9, so a stalled solve (a weak preconditioner, small but
  !> not shrinking updates) is not mistaken for a converged one, and two
  !> updates that no step limit scaled: an update cut short at an obstacle
  !> (process models, module process_solver) says nothing of the remaining
  !> error (drop_table with -ts_adapt_type basic: "converged" at ||F|| = 16
  !> after cut updates, a state the error estimate then rejected, 191
  !> times the tolerance).
  subroutine snes_converged(snes, it, xnorm, snorm, fnorm, reason, ctx, ierr)
    type(tSNES) :: snes
    PetscInt :: it
    PetscReal :: xnorm, snorm, fnorm
    SNESConvergedReason :: reason
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    real(rp) :: rate, wnorm, floor_est
    integer :: verdict
    logical :: fail
    SNESLineSearchReason :: lsreason
    call SNESConvergedDefault(snes, it, xnorm, snorm, fnorm, reason, PETSC_NULL_INTEGER, ierr)
    if (ierr /= 0) return
    fail = .false.
    ! -nuno_fail_newton (tests): the same decision on every rank.
    if (it == 0) call newton_take_injected_failure(ctx%newton, fail)
    if (fail) then
      reason = SNES_DIVERGED_FUNCTION_DOMAIN
    else if (it == 0) then
      call newton_first_residual(ctx%newton, fnorm)
    else if (reason == SNES_CONVERGED_ITERATING) then
      PetscCall(line_search_reason(snes, lsreason, ierr))
      if (lsreason /= LS_SUCCEEDED .and. lsreason /= LS_FAILED_REDUCT) then
        reason = SNES_DIVERGED_LINE_SEARCH        ! NaN, domain error: PETSc's own verdict
      else
        floor_est = merge(reduced_floor_est(ctx%red), newton_floor_est(ctx%newton), ctx%use_reduced)
        verdict = newton_verdict(ctx%newton, fnorm, floor_est, lsreason == LS_FAILED_REDUCT)
        if (verdict == NEWTON_CONVERGED) then
          reason = SNES_CONVERGED_FNORM_ABS
        else if (verdict == NEWTON_DIVERGED) then
          reason = SNES_DIVERGED_LINE_SEARCH
        else if (newton_start_smooth_limited(ctx%start)) then
          ! (d) the limited cubic start: stalled with an update of
          ! round-off's size (newton_control's update_at_floor)
          if (newton_update_floor(ctx%newton, fnorm, snorm, xnorm, floor_est)) reason = SNES_CONVERGED_SNORM_RELATIVE
        end if
      end if
    end if
    if (it >= 2 .and. reason == SNES_CONVERGED_ITERATING .and. .not. step_fixed(ctx%step) .and. &
        newton_rate_usable(ctx%newton)) then
      rate = snorm / newton_snorm_prev(ctx%newton)
      if (rate < 0.9_rp) then
        call update_wrms(snes, ctx, wnorm, ierr)
        if (ierr /= 0) return
        if (wnorm * rate / (1.0_rp - rate) <= NEWTON_TS_FRACTION) reason = SNES_CONVERGED_SNORM_RELATIVE
      end if
    end if
    if (reason == SNES_CONVERGED_ITERATING .and. ctx%use_reduced .and. newton_forcing_on(ctx%newton)) then
      PetscCall(set_newton_forcing(snes, it, fnorm, ctx, ierr))
    end if
    if (reason == SNES_CONVERGED_ITERATING .and. newton_lag_settled(ctx%newton)) then
      PetscCall(lag_when_settled(snes, it, fnorm, ctx, ierr))
    end if
    call newton_iterated(ctx%newton, fnorm, snorm)
  end subroutine snes_converged

  !> With a process model's hint jacobian_settled (newton_lag_settled):
  !> each Newton solve assembles its Jacobian at every iteration until it
  !> has settled (newton_state's newton_settled), and keeps it from then
  !> on (SNESSetLagJacobian -1 for the rest of the solve, 1 again at the
  !> next solve's start). A contact step's second iteration starts from
  !> 1e-2 to 1e-4 of the first residual and its remainder is round-off
  !> and the first iteration's inexact solve: the chord step takes it to
  !> the floor as a fresh Jacobian does (drop_table 129 x 129: 108 Newton
  !> iterations over 60 steps with 108 assemblies before, 114 with 62
  !> with this; docs/performance.md "Contact").
  subroutine lag_when_settled(snes, it, fnorm, ctx, ierr)
    type(tSNES) :: snes
    PetscInt, intent(in) :: it
    PetscReal, intent(in) :: fnorm
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: atol, rtol, floor_est
    character(len=64) :: sntype
    ierr = 0
    PetscCall(SNESGetType(snes, sntype, ierr))
    if (sntype /= SNESNEWTONLS) return            ! (KSPONLY, the bw mode: one solve a step, every step assembled)
    if (it == 0) then
      PetscCall(SNESSetLagJacobian(snes, 1, ierr))
      return
    end if
    PetscCall(snes_atol_rtol(snes, atol, rtol, ierr))
    floor_est = merge(reduced_floor_est(ctx%red), newton_floor_est(ctx%newton), ctx%use_reduced)
    if (newton_settled(ctx%newton, fnorm, newton_target(ctx%newton, atol, rtol, floor_est))) then
      PetscCall(SNESSetLagJacobian(snes, -1, ierr))
    end if
  end subroutine lag_when_settled

  !> The reason of this Newton iteration's line search (LS_SUCCEEDED for a
  !> SNES without one). PETSc's Newton hands the convergence test an
  !> iteration whose search failed only while fewer than -snes_max_fail
  !> searches have failed (solver_create sets 2), with the residual from
  !> before the search.
  subroutine line_search_reason(snes, lsreason, ierr)
    type(tSNES) :: snes
    SNESLineSearchReason, intent(out) :: lsreason
    PetscErrorCode, intent(out) :: ierr
    SNESLineSearch :: ls
    character(len=64) :: sntype
    lsreason = LS_SUCCEEDED
    PetscCall(SNESGetType(snes, sntype, ierr))
    if (sntype /= SNESNEWTONLS) return
    PetscCall(SNESGetLineSearch(snes, ls, ierr))
    PetscCall(SNESLineSearchGetReason(ls, lsreason, ierr))
  end subroutine line_search_reason

  !> The inner tolerance of the coming Newton iteration's solve (module
  !> newton_state's newton_inner_rtol): no tighter than the Newton
  !> remainder C ||F||^2 that the step leaves anyway, nor than half the
  !> residual at which snes_converged stops: max(snes_atol, snes_rtol
  !> ||F_0||, and on this path FLOOR_FACTOR times the round-off floor of the
  !> last assembly). C comes from the iterations before that did not
  !> converge (at the floor ||F|| says nothing about it), in this window.
  !> The reduced solve uses it unless -snes_ksp_ew or -reduced_ksp_rtol is given.
  subroutine set_newton_forcing(snes, it, fnorm, ctx, ierr)
    type(tSNES) :: snes
    PetscInt, intent(in) :: it
    PetscReal, intent(in) :: fnorm
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: atol, rtol, eta

    PetscCall(snes_atol_rtol(snes, atol, rtol, ierr))
    call newton_inner_rtol(ctx%newton, int(it), fnorm, reduced_lin_rel(ctx%red), atol, rtol, reduced_floor_est(ctx%red), &
                           reduced_rtol0(ctx%red), eta)
    call reduced_set_forcing(ctx%red, eta)
  end subroutine set_newton_forcing

  !> The SNES's absolute and relative residual tolerances (-snes_atol,
  !> -snes_rtol), the two of SNESGetTolerances' five that the monitors use.
  subroutine snes_atol_rtol(snes, atol, rtol, ierr)
    type(tSNES) :: snes
    real(rp), intent(out) :: atol, rtol          ! [the residual's norm], [1]
    PetscErrorCode, intent(out) :: ierr
    PetscReal :: stol
    PetscInt :: maxit, maxf
    PetscCall(SNESGetTolerances(snes, atol, rtol, stol, maxit, maxf, ierr))
  end subroutine snes_atol_rtol

  !> The last Newton update in the weighted RMS norm of the time integrator:
  !> sqrt(mean((du_i / (atol_i + rtol_i |u_i|))^2)) over all unknowns: the
  !> tolerances of set_tolerances, atol_x alone on positions, atol_v +
  !> rtol |v| on velocities.
  subroutine update_wrms(snes, ctx, wnorm, ierr)
    type(tSNES) :: snes
    type(app_ctx) :: ctx
    real(rp), intent(out) :: wnorm
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: x, y
    PetscScalar, pointer :: xa(:), ya(:)
    real(rp) :: loc(2), glob(2), atol_x, atol_v, rtol
    integer :: mpierr, k

    wnorm = huge(1.0_rp)
    call step_tolerances(ctx%step, rtol, atol_x, atol_v)
    PetscCall(SNESGetSolution(snes, x, ierr))
    PetscCall(SNESGetSolutionUpdate(snes, y, ierr))
    PetscCall(VecGetArrayReadF90(x, xa, ierr))
    PetscCall(VecGetArrayReadF90(y, ya, ierr))
    ! The vector atol of set_tolerances: the 6 dofs of a node are stored
    ! together, positions first.
    loc(1) = 0.0_rp
    do k = 1, size(xa)
      if (mod(k - 1, 6) < 3) then
        loc(1) = loc(1) + (ya(k) / atol_x)**2
      else
        loc(1) = loc(1) + (ya(k) / (atol_v + rtol * abs(xa(k))))**2
      end if
    end do
    loc(2) = real(size(xa), rp)
    PetscCall(VecRestoreArrayReadF90(y, ya, ierr))
    PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    call MPI_Allreduce(loc, glob, 2, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, mpierr)
    if (glob(2) > 0.0_rp) wnorm = sqrt(glob(1) / glob(2))
  end subroutine update_wrms

  !> Put -nuno_linesearch_fallback's line search in place of full steps
  !> (the user's other -snes_linesearch_* options apply to it) and say so
  !> once, on rank 0.
  subroutine linesearch_fallback(ts, ctx, t, ierr)
    type(tTS) :: ts
    type(app_ctx) :: ctx
    real(rp), intent(in) :: t
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    SNESLineSearch :: linesearch
    character(len=:), allocatable :: kind
    kind = trim(FALLBACK_NAMES(newton_fallback(ctx%newton)))
    PetscCall(TSGetSNES(ts, snes, ierr))
    PetscCall(SNESGetLineSearch(snes, linesearch, ierr))
    PetscCall(SNESLineSearchSetType(linesearch, kind, ierr))
    PetscCall(SNESLineSearchSetFromOptions(linesearch, ierr))
    call newton_fallback_switched(ctx%newton)
    if (ctx%rank == 0) write(output_unit, '(a)') 'nuno: after a failed Newton solve (its step retried smaller), line search '// &
      kind//' from t = '//num(t)//' on (-nuno_linesearch_fallback)'
  end subroutine linesearch_fallback

end module newton_policy
