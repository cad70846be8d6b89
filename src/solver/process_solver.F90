! SPDX-License-Identifier: BSD-2-Clause
!> The process models on the PETSc side (module process_models holds
!> their loops; docs/design.md, "Process models"): the solver's options
!> from their hints, the Newton update's limit (a line-search pre-check;
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
  use newton_start, only: newton_start_order
  use model_state, only: model_pm_step_limit, model_pm_accept, model_pm_accepted
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
  !> a feasible start (beuler's extrapolated start off: Newton starts from
  !> the last accepted state) and the Jacobian at every Newton iteration
  !> (-snes_lag_jacobian 1 unless given; module solver_options'
  !> step_defaults lags it to every other iteration otherwise). Nothing
  !> without process models. Collective.
  subroutine pm_solver_options(ctx, ierr)
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    PetscBool :: given
    type(pm_hints_t) :: h
    ierr = 0
    if (.not. pm_list_on(ctx%pms)) return
    h = pm_list_hints(ctx%pms)
    if (h%feasible_start) then
      PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-ts_theta_initial_guess_extrapolate', 'false', ierr))
    end if
    if (h%jacobian_every_iteration) then
      PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-snes_lag_jacobian', given, ierr))
      if (.not. given) then
        PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-snes_lag_jacobian', '1', ierr))
      end if
    end if
  end subroutine pm_solver_options

  !> After the TS and SNES are set up: the TS type every model allows, the
  !> Newton start a feasible start needs (the cubic start is refused: it
  !> may lie outside a model's domain), the step limit as the line
  !> search's pre-check (and in the Baraff-Witkin mode, -snes_type
  !> ksponly, which has no line search, as the post-solve of the SNES's
  !> KSP, on the update SNES KSPONLY then takes in full, x - y), and the
  !> TS's stage check. Nothing without process models. Collective.
  subroutine pm_solver_setup(ctx, ierr)
    type(app_ctx), intent(inout), target :: ctx
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    type(tKSP) :: ksp
    SNESLineSearch :: ls
    character(len=64) :: tstype, sntype
    character(len=:), allocatable :: allowed
    type(pm_hints_t) :: h
    integer :: k
    ierr = 0
    if (.not. pm_list_on(ctx%pms)) return
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    call pm_list_ts_refusal(ctx%pms, trim(tstype), k, allowed)
    if (k > 0) then
      ierr = PETSC_ERR_SUP
      SETERRQ(ctx%comm, ierr, 'nuno: '//pm_list_name(ctx%pms, k)//' needs -ts_type '//allowed//' (its Newton solve starts from the last accepted, feasible state), not -ts_type '//trim(tstype))
    end if
    h = pm_list_hints(ctx%pms)
    if (h%feasible_start .and. newton_start_order(ctx%start) == 3) then
      ierr = PETSC_ERR_SUP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_newton_start cubic is refused with '//pm_list_name(ctx%pms, 1)//': its start may lie outside the feasible states')
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
  !> x_n, the TS's solution, at t_n to t_n + dt) scaled by the fraction
  !> the process models allow (module model_state's model_pm_step_limit);
  !> where they allow none, y = 0 and the list's flag makes the candidate,
  !> and so the stage, infeasible (the step is retried smaller). changed:
  !> y was altered (the same on every rank). Collective.
  subroutine limit_update(ctx, xvec, yvec, changed, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tVec) :: xvec, yvec
    logical, intent(out) :: changed
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: x(:, :, :), y(:, :, :), x0(:, :, :)
    type(tVec) :: x0vec
    real(rp) :: alpha, t0, dt
    real(rp), allocatable :: dx(:, :, :)
    logical :: infeasible
    changed = .false.
    PetscCall(TSGetTime(ctx%ts, t0, ierr))
    PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
    ! x_n: the TS's solution until the step is accepted
    PetscCall(TSGetSolution(ctx%ts, x0vec, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, xvec, x, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, yvec, y, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, x0vec, x0, ierr))
    allocate(dx(0:5, 0:ctx%lat%nx - 1, ctx%lat%ys:ctx%lat%ye))
    dx = -y
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, yvec, y, ierr))
    call model_pm_step_limit(ctx%model, ctx%pms, ctx%lat, t0, t0 + dt, x0, x, dx, ctx%comm, alpha, infeasible)
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, x0vec, x0, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, xvec, x, ierr))
    if (infeasible) then
      PetscCall(VecSet(yvec, 0.0_rp, ierr))
      changed = .true.
    else if (alpha < 1.0_rp) then
      PetscCall(VecScale(yvec, alpha, ierr))
      changed = .true.
    end if
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
    PetscCall(ghosted_restore(ctx%da, yloc, u, ierr))
    accept = merge(1_c_int, 0_c_int, ok)
  end subroutine pm_stage_check_c

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
    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    call model_pm_accepted(ctx%model, ctx%pms, ctx%lat, t, u, ctx%comm, err, msg)
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    if (err /= 0) then
      ierr = PETSC_ERR_NOT_CONVERGED
      SETERRQ(ctx%comm, ierr, trim(msg))
    end if
  end subroutine pm_observe

end module process_solver
