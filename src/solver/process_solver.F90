! SPDX-License-Identifier: BSD-2-Clause
!> The process models on the PETSc side (module process_models holds
!> their loops; docs/design.md, "Process models"): the solver's options
!> from their hints, Newton's start of a step moved into their domains
!> (the SNES's initial guess), the Newton update's limit (a line-search pre-check;
!> in the Baraff-Witkin mode the post-solve of the SNES's KSP), the check
!> of a step's end state before the TS accepts it (the TS's stage check),
!> the accepted states (called by the TS monitor of module step_monitor
!> and by the output step at t = 0), and the one place where a hook's
!> infeasible status becomes PETSc's domain error. No physics here: with
!> contact as the only model, what it needs (beuler, Newton from the last
!> accepted state, no penetration) is in module contact_model's hooks.
!>
!> Infeasible states, never NaN: a hook's status PM_INFEASIBLE (a
!> residual's state outside a model's domain, a step limit that finds no
!> feasible update) is the list's flag, agreed on every rank
!> (pm_list_infeasible); pm_domain_error, called by the residual, makes
!> it SNES's domain error (SNESSetFunctionDomainError: the SNES fails and
!> the TS retries the step smaller), and the TS's stage check (the C
!> trampoline of src/solver/nuno_pm_checks.c, stage_check here) rejects a
!> stage whose flag is set (SNES KSPONLY does not look at the domain
!> error) or that a model's accept hook rejects.
module process_solver
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_intptr_t, c_ptr, c_loc, c_f_pointer, c_double
  use kinds, only: rp
  use ghosted_state, only: ghosted_get, ghosted_restore
  use app_context, only: app_ctx
  use newton_start, only: newton_start_limited
  use newton_state, only: newton_update_limited, newton_start_moved, newton_set_lag_settled
  use model_state, only: model_pm_step_limit, model_pm_correct, model_pm_accept, model_pm_accepted, model_pm_unresolved, &
                         model_pm_start_limit, model_pm_start, model_pm_limit_nodes
  use step_errors, only: step_errors_on, step_errors_weighs, step_errors_stage, step_errors_stage_masks, step_errors_tolerances, &
                         step_errors_accepted, step_errors_impacts, step_errors_order_dropped, step_errors_drop_order, &
                         step_errors_take_scale, step_errors_min_step, step_errors_save_scale, &
                         step_errors_max_step, step_errors_unresolved
  use step_settings, only: step_dt
  use strings, only: itoa
  use process_model, only: pm_hints_t
  use process_models, only: pm_list_on, pm_list_hints, pm_list_ts_refusal, pm_list_name, pm_list_infeasible
  implicit none
  private
  public :: pm_solver_options, pm_solver_setup, pm_observe, pm_domain_error

  interface
    !> src/solver/nuno_pm_checks.c: KSPSetPostSolve with the C trampoline that
    !> calls pm_limit_update_c(y, ctx).
    integer(c_int) function nuno_ksp_set_pm_post_solve(ksp, ctx) bind(C, name='nuno_ksp_set_pm_post_solve')
      import :: c_int, c_intptr_t, c_ptr
      integer(c_intptr_t) :: ksp                 !< KSP*
      type(c_ptr), value :: ctx
    end function nuno_ksp_set_pm_post_solve
    !> src/solver/nuno_pm_checks.c: TSSetFunctionDomainError with the C
    !> trampoline that calls pm_stage_check_c(t, y, ctx, accept).
    integer(c_int) function nuno_ts_set_pm_stage_check(ts, ctx) bind(C, name='nuno_ts_set_pm_stage_check')
      import :: c_int, c_intptr_t, c_ptr
      integer(c_intptr_t) :: ts                  !< TS*
      type(c_ptr), value :: ctx
    end function nuno_ts_set_pm_stage_check
  end interface

contains

  !> Before TSSetFromOptions, the process models' hints that are options:
  !> the Jacobian at every Newton iteration (-snes_lag_jacobian 1 unless
  !> given; module solver_options' step_defaults lags it to every other
  !> iteration otherwise), kept once a solve has settled where the models
  !> allow it (hint jacobian_settled; module newton_policy's
  !> lag_when_settled; not where -snes_lag_jacobian is given). (A feasible start needs no option: every start
  !> is limited, pm_solver_setup.) Nothing without process models.
  !> Collective.
  subroutine pm_solver_options(ctx, ierr)
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    PetscBool :: given
    type(pm_hints_t) :: h
    ierr = 0
    if (.not. pm_list_on(ctx%pms)) return
    h = pm_list_hints(ctx%pms)
    if (h%jacobian_every_iteration) then
      PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-snes_lag_jacobian', given, ierr))
      if (.not. given) then
        PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-snes_lag_jacobian', '1', ierr))
        call newton_set_lag_settled(ctx%newton, h%jacobian_settled)
      end if
    end if
  end subroutine pm_solver_options

  !> After the TS and SNES are set up: the TS scheme every model allows
  !> (bdf with its order; else refusal, one line naming -ts_type and what
  !> the model allows, and nothing more is set up), every Newton start limited by the step limit
  !> and moved into the models' domains by their start hooks where a
  !> model needs a feasible start (module newton_start; the limiter
  !> pm_limit_start), the step limit as the line search's pre-check (and
  !> in the Baraff-Witkin mode, -snes_type ksponly, which has no line
  !> search, as the post-solve of the SNES's KSP, on the update SNES
  !> KSPONLY then takes in full, x - y), and the TS's stage check.
  !> Nothing without process models. Collective.
  subroutine pm_solver_setup(ctx, refusal, ierr)
    type(app_ctx), intent(inout), target :: ctx
    character(*), intent(inout) :: refusal     !< a TS type a model refuses: one line, the same on every rank
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    type(tKSP) :: ksp
    SNESLineSearch :: ls
    character(len=64) :: tstype, sntype
    character(len=:), allocatable :: allowed, scheme
    type(pm_hints_t) :: h
    PetscBool :: bdf
    PetscInt :: order
    integer :: k
    ierr = 0
    if (.not. pm_list_on(ctx%pms)) return
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    scheme = trim(tstype)
    PetscCall(PetscObjectTypeCompare(ctx%ts, 'bdf', bdf, ierr))           ! (no TSBDF in 3.18's Fortran)
    if (bdf) then
      PetscCall(TSBDFGetOrder(ctx%ts, order, ierr))
      scheme = 'bdf'//itoa(int(order))
    end if
    call pm_list_ts_refusal(ctx%pms, scheme, k, allowed)
    if (k > 0) then
      if (bdf) scheme = 'bdf -ts_bdf_order '//scheme(4:)
      refusal = '-ts_type '//scheme//': '//pm_list_name(ctx%pms, k)//' needs -ts_type '//allowed
      return
    end if
    h = pm_list_hints(ctx%pms)
    if (h%feasible_start) then
      PetscCall(newton_start_limited(ctx%start, ctx%ts, pm_limit_start, c_loc(ctx), ierr))
    end if
    PetscCall(TSGetSNES(ctx%ts, snes, ierr))
    PetscCall(SNESGetLineSearch(snes, ls, ierr))
    PetscCall(SNESLineSearchSetPreCheck(ls, pm_precheck, ctx, ierr))
    PetscCall(SNESGetType(snes, sntype, ierr))
    if (trim(sntype) == SNESKSPONLY) then
      PetscCall(SNESGetKSP(snes, ksp, ierr))
      ierr = nuno_ksp_set_pm_post_solve(ksp%v, c_loc(ctx))
      if (ierr /= 0) return
    end if
    ierr = nuno_ts_set_pm_stage_check(ctx%ts%v, c_loc(ctx))
  end subroutine pm_solver_setup

  !> The residual's verdict (module model_state's model_residual): where
  !> the process models found the state, or the candidate a failed step
  !> limit left, infeasible, SNES's domain error (the flag is the same on
  !> every rank). The one place where a hook's status becomes a PETSc
  !> error (the stage check reads the same flag).
  subroutine pm_domain_error(ts, ctx, ierr)
    type(tTS) :: ts
    type(app_ctx), intent(in) :: ctx
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    ierr = 0
    if (.not. pm_list_infeasible(ctx%pms)) return
    PetscCall(TSGetSNES(ts, snes, ierr))
    PetscCall(SNESSetFunctionDomainError(snes, ierr))
  end subroutine pm_domain_error

  !> A Newton start x limited (module newton_start's limiter): x_n +
  !> alpha (x - x_n), each node's x - x_n first shortened by the models'
  !> per-node limits (model_pm_limit_nodes), x_n the step's start (the TS's solution), alpha the
  !> largest fraction the process models' step limits allow from x_n
  !> (their time of impact, as for every Newton update), 0 where they
  !> allow none; then moved into the models' domains by their start hooks
  !> (model_pm_start: a moving obstacle carries the nodes it reaches over
  !> the step, which x_n may lie inside at t_n + dt). So the start is
  !> feasible by construction and as near the predictor as the obstacles
  !> let it be (issue 47 items 2, 4 and 6). Collective.
  subroutine pm_limit_start(cp, xvec, cut, ierr)
    type(c_ptr), value :: cp
    type(tVec) :: xvec
    logical, intent(out) :: cut
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: ctx
    type(tVec) :: x0vec, dxvec
    PetscScalar, pointer :: x(:, :, :), x0(:, :, :), dx(:, :, :)
    real(rp) :: alpha, t0, dt
    logical :: infeasible, clamped
    integer :: moved, mpierr
    call c_f_pointer(cp, ctx)
    PetscCall(TSGetTime(ctx%ts, t0, ierr))
    PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
    PetscCall(TSGetSolution(ctx%ts, x0vec, ierr))
    ! dx = x - x0 in a vector of the DM's pool (no allocation a step)
    PetscCall(DMGetGlobalVector(ctx%da, dxvec, ierr))
    PetscCall(VecWAXPY(dxvec, -1.0_rp, x0vec, xvec, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, x0vec, x0, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, dxvec, dx, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, xvec, x, ierr))
    ! the models' per-node limits first (self-contact's OGC bounds), then their fractions
    call model_pm_limit_nodes(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x0, dx, ctx%comm, clamped)
    call model_pm_start_limit(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x0, dx, ctx%comm, alpha, infeasible)
    if (infeasible) alpha = 0.0_rp
    cut = alpha < 1.0_rp .or. clamped
    if (cut) x = x0 + alpha * dx
    call model_pm_start(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x0, x, moved)
    ! (a start cut short or carried by an obstacle is a contact's onset:
    ! the Newton solve's inner rtol stays tight, tightest where carried,
    ! module newton_state)
    call MPI_Allreduce(MPI_IN_PLACE, moved, 1, MPI_INTEGER, MPI_MAX, ctx%comm, mpierr)
    call newton_start_moved(ctx%newton, cut, moved > 0)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, xvec, x, ierr))
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, dxvec, dx, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, x0vec, x0, ierr))
    PetscCall(DMRestoreGlobalVector(ctx%da, dxvec, ierr))
  end subroutine pm_limit_start

  !> The Baraff-Witkin mode's step limit (src/solver/nuno_pm_checks.c: the
  !> post-solve of the SNES's KSP): the update y at the SNES's solution x,
  !> limited as limit_update says. Collective.
  subroutine pm_limit_update_c(y_h, cp, ierr) bind(C, name='nuno_pm_limit_update')
    integer(c_intptr_t), intent(in) :: y_h           !< Vec
    type(c_ptr), value :: cp                         !< the app_ctx
    integer(c_int), intent(out) :: ierr              !< PetscErrorCode, as C's int
    type(app_ctx), pointer :: ctx
    type(tSNES) :: snes
    type(tVec) :: x, y
    logical :: changed
    ierr = 0
    call c_f_pointer(cp, ctx)
    y%v = y_h
    PetscCall(TSGetSNES(ctx%ts, snes, ierr))
    PetscCall(SNESGetSolution(snes, x, ierr))
    PetscCall(limit_update(ctx, x, y, changed, ierr))
  end subroutine pm_limit_update_c

  !> The line search's pre-check: PETSc steps x - lambda y; y is limited
  !> as limit_update says.
  subroutine pm_precheck(ls, xvec, yvec, changed, ctx, ierr)
    SNESLineSearch :: ls
    type(tVec) :: xvec, yvec
    PetscBool :: changed
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    logical :: ch
    PetscCall(limit_update(ctx, xvec, yvec, ch, ierr))
    changed = merge(PETSC_TRUE, PETSC_FALSE, ch)
  end subroutine pm_precheck

  !> The Newton update y at x (the step is x - y, from the step's start
  !> x_n, the TS's solution, at t_n to t_n + dt) corrected and shortened
  !> node by node by the process models (model_pm_correct,
  !> model_pm_limit_nodes: y written back, changed set, so that the line
  !> search and SNES take the new direction), then scaled by the fraction
  !> they allow (module model_state's model_pm_step_limit);
  !> where they allow none, y = 0 and the list's flag makes the candidate,
  !> and so the stage, infeasible (the step is retried smaller). changed:
  !> y was altered (the same on every rank). Collective.
  subroutine limit_update(ctx, xvec, yvec, changed, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tVec) :: xvec, yvec
    logical, intent(out) :: changed
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: x(:, :, :), y(:, :, :), x0(:, :, :), dx(:, :, :)
    type(tVec) :: x0vec, dxvec
    real(rp) :: alpha, t0, dt
    logical :: infeasible, bent, clamped
    changed = .false.
    PetscCall(TSGetTime(ctx%ts, t0, ierr))
    PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
    ! x_n: the TS's solution until the step is accepted
    PetscCall(TSGetSolution(ctx%ts, x0vec, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, xvec, x, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, yvec, y, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, x0vec, x0, ierr))
    ! the step dx = -y (x - y from x) in a vector of the DM's pool (no allocation an update)
    PetscCall(DMGetGlobalVector(ctx%da, dxvec, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, dxvec, dx, ierr))
    dx = -y
    call model_pm_correct(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x, dx, ctx%comm, bent)
    call model_pm_limit_nodes(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x, dx, ctx%comm, clamped)
    changed = bent .or. clamped
    if (changed) y = -dx
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, yvec, y, ierr))
    call model_pm_step_limit(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x0, x, dx, ctx%comm, alpha, infeasible)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, dxvec, dx, ierr))
    PetscCall(DMRestoreGlobalVector(ctx%da, dxvec, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, x0vec, x0, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, xvec, x, ierr))
    if (infeasible) then
      PetscCall(VecSet(yvec, 0.0_rp, ierr))
      changed = .true.
    else if (alpha < 1.0_rp) then
      PetscCall(VecScale(yvec, alpha, ierr))
      changed = .true.
    end if
    ! (Newton's convergence test then does not take the update's length
    ! for its rate)
    call newton_update_limited(ctx%newton, changed)
  end subroutine limit_update

  !> The TS's stage check (src/solver/nuno_pm_checks.c, TSSetFunctionDomainError):
  !> the stage's state y at t is accepted unless its candidate was
  !> infeasible (the list's flag) or a process model's accept hook
  !> rejects it (module model_state's model_pm_accept); a rejected stage
  !> is a failed step, retried smaller. Collective.
  subroutine pm_stage_check_c(t, y_h, cp, accept, ierr) bind(C, name='nuno_pm_stage_check')
    real(c_double), value :: t                       !< the stage's time
    integer(c_intptr_t), intent(in) :: y_h           !< Vec
    type(c_ptr), value :: cp                         !< the app_ctx
    integer(c_int), intent(out) :: accept            !< 1: accepted
    integer(c_int), intent(out) :: ierr              !< PetscErrorCode, as C's int
    type(app_ctx), pointer :: ctx
    type(tVec) :: y, yloc
    PetscScalar, pointer :: u(:, :, :)
    logical :: ok
    ierr = 0
    call c_f_pointer(cp, ctx)
    y%v = y_h
    PetscCall(ghosted_get(ctx%da, y, yloc, u, ierr))
    call model_pm_accept(ctx%model, ctx%pms, ctx%lat, real(t, rp), u, ctx%comm, ok)
    if (ok .and. step_errors_on(ctx%errw)) then
      PetscCall(stage_unresolved(ctx, real(t, rp), u, ok, ierr))
    end if
    PetscCall(ghosted_restore(ctx%da, yloc, u, ierr))
    accept = merge(1_c_int, 0_c_int, ok)
  end subroutine pm_stage_check_c

  !> The stage u at t's nodes that the process models leave unresolved
  !> (module step_errors), judged at this step's dt, or at the run's
  !> initial dt where the step is smaller: a node pressed into a barrier
  !> has a time scale that shrinks without end as it goes deeper, and
  !> judged at the step alone each smaller step would let the error
  !> estimate see it again and shrink the step further (drop_table at
  !> -ts_rtol 1e-6 went down to 1e-17 s so). Adaptive steps: the TS's
  !> tolerance vectors leave them out of the error estimate that follows,
  !> and while there are any the adaptor's smallest step is a tenth of the
  !> run's initial one (module step_errors).
  !> bdf2: a stage with nodes unresolved that were resolved at the step's
  !> start (an impact) is rejected once and solved again at order 1, at
  !> the same step (ok false). Collective.
  subroutine stage_unresolved(ctx, t, u, ok, ierr)
    type(app_ctx), intent(inout), target :: ctx      ! (target: step_errors_stage_masks)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, ctx%lat%gys:)
    logical, intent(inout) :: ok
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: vatol, vrtol
    type(tTSAdapt) :: adapt
    PetscReal :: atol, rtol, dt, scale, t0, hstep
    PetscScalar, pointer :: va(:, :, :), vr(:, :, :), x0(:, :, :)
    type(tVec) :: x0vec, x0loc
    logical, pointer :: mask(:, :), start(:, :)
    integer :: nnew
    PetscInt, parameter :: one = 1
    ierr = 0
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    ! the stage solved again after an impact: the adaptor's factor back
    call step_errors_take_scale(ctx%errw, scale)
    if (scale > 0.0_rp) then
      PetscCall(TSAdaptSetScaleSolveFailed(adapt, scale, ierr))
    end if
    PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
    dt = max(dt, step_dt(ctx%step))
    call step_errors_stage_masks(ctx%errw, mask, start)
    call model_pm_unresolved(ctx%model, ctx%pms, ctx%lat, t, u, dt, mask)
    ! and at the step's start x_n (the TS's solution until it accepts)
    PetscCall(TSGetSolution(ctx%ts, x0vec, ierr))
    PetscCall(TSGetTime(ctx%ts, t0, ierr))
    PetscCall(ghosted_get(ctx%da, x0vec, x0loc, x0, ierr))
    call model_pm_unresolved(ctx%model, ctx%pms, ctx%lat, t0, x0, dt, start)
    PetscCall(ghosted_restore(ctx%da, x0loc, x0, ierr))
    call step_errors_stage(ctx%errw, t, ctx%comm, nnew)
    if (step_errors_weighs(ctx%errw)) then
      PetscCall(TSGetTolerances(ctx%ts, atol, vatol, rtol, vrtol, ierr))
      PetscCall(DMDAVecGetArrayF90(ctx%da, vatol, va, ierr))
      PetscCall(DMDAVecGetArrayF90(ctx%da, vrtol, vr, ierr))
      call step_errors_tolerances(ctx%errw, va, vr)
      PetscCall(DMDAVecRestoreArrayF90(ctx%da, vrtol, vr, ierr))
      PetscCall(DMDAVecRestoreArrayF90(ctx%da, vatol, va, ierr))
      PetscCall(TSAdaptSetStepLimits(adapt, step_errors_min_step(ctx%errw), step_errors_max_step(ctx%errw), ierr))
    end if
    ! An impact within an adaptive step longer than the namelist's dt: the
    ! stage is solved again with that dt. Where no error is left to
    ! estimate (bdf2 integrates a free fall exactly) the adaptor's steps
    ! grow to 0.05 s and more, and one that ends past an impact puts the
    ! output steps inside it on an interpolant across the impact (drop at
    ! -ts_rtol 1e-6: 3.8 mm off the free fall 20 ms before it).
    PetscCall(TSGetTimeStep(ctx%ts, hstep, ierr))
    if (step_errors_weighs(ctx%errw) .and. nnew > 0 .and. hstep > 1.001_rp * step_dt(ctx%step)) then
      PetscCall(TSAdaptGetScaleSolveFailed(adapt, scale, ierr))
      call step_errors_save_scale(ctx%errw, scale)
      PetscCall(TSAdaptSetScaleSolveFailed(adapt, step_dt(ctx%step) / hstep, ierr))
      ok = .false.
      return
    end if
    if (step_errors_impacts(ctx%errw) .and. nnew > 0 .and. .not. step_errors_order_dropped(ctx%errw)) then
      PetscCall(TSAdaptGetScaleSolveFailed(adapt, scale, ierr))
      call step_errors_drop_order(ctx%errw, .true., scale)
      PetscCall(TSAdaptSetScaleSolveFailed(adapt, 1.0_rp, ierr))
      PetscCall(TSBDFSetOrder(ctx%ts, one, ierr))
      PetscCall(TSRestartStep(ctx%ts, ierr))
      ok = .false.
    end if
  end subroutine stage_unresolved

  !> The step accepted at t ends the stage checked last (module
  !> step_errors); bdf2 at order 1 after an impact goes back to order 2
  !> from the first step after which no node is unresolved (at it and the
  !> two states before), its history started anew (TSRestartStep: a half
  !> step of order 1, then order 2 on states after the impact). Back at
  !> order 2 as soon as the impact's step was over, with the sheet still
  !> deep in the barrier, the drop bounced off the table (5 cm at
  !> -ts_rtol 1e-4, the impact's step 1 ms). Collective.
  subroutine impact_done(ctx, t, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    PetscErrorCode, intent(out) :: ierr
    logical :: impact
    PetscInt, parameter :: two = 2
    ierr = 0
    call step_errors_accepted(ctx%errw, t, impact)
    if (.not. step_errors_order_dropped(ctx%errw) .or. impact .or. step_errors_unresolved(ctx%errw)) return
    call step_errors_drop_order(ctx%errw, .false., 0.0_rp)
    PetscCall(TSBDFSetOrder(ctx%ts, two, ierr))
    PetscCall(TSRestartStep(ctx%ts, ierr))
  end subroutine impact_done

  !> An accepted state uvec at t (called by the TS monitor of module
  !> step_monitor after each accepted step and at each TSSolve's start, and
  !> by the output step at t = 0, before the first step): the process
  !> models' accepted hooks (friction's lag, the records of the output,
  !> their lines); a hook's error ends the run. Collective.
  subroutine pm_observe(ctx, t, uvec, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    type(tVec), intent(in) :: uvec
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    integer :: err
    character(len=512) :: msg
    ierr = 0
    if (.not. pm_list_on(ctx%pms)) return
    PetscCall(impact_done(ctx, t, ierr))
    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    call model_pm_accepted(ctx%model, ctx%pms, ctx%lat, t, u, ctx%comm, err, msg)
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    if (err /= 0) then
      ierr = PETSC_ERR_NOT_CONVERGED
      SETERRQ(ctx%comm, ierr, trim(msg))
    end if
  end subroutine pm_observe

end module process_solver
