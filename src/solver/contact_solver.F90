! SPDX-License-Identifier: BSD-2-Clause
!> Contact on the PETSc side (module contact_forces holds the plain-array
!> work): set-up, the Newton step limited so that no node crosses an
!> obstacle, and the check of every accepted state.
!>
!> No penetration, ever: (1) each Newton solve starts from the last
!> accepted state x_n, which is feasible (beuler's extrapolated start
!> x_n + dt xdot_n and the cubic start may lie inside an obstacle, where
!> the barrier is undefined: with obstacles they are off, and an explicit
!> -nuno_newton_start cubic is refused); (2) each Newton update is limited
!> by the continuous collision test against the analytic shapes (a line
!> search pre-check; in the Baraff-Witkin mode, which has no line search,
!> the post-solve of the SNES's KSP): where a node would reach its obstacle within the
!> full update, the update is scaled by 0.8 alpha (IPC), alpha the first
!> time of impact over all nodes and obstacles (at their poses at the
!> step's end, t_n + dt); where an obstacle moves over the step, the
!> candidate's path from x_n is also checked against the obstacle's
!> motion (contact_swept), the update halved until no node crosses it,
!> and the step failed (retried smaller) if none is found; (3) a residual evaluated
!> at an infeasible state is NaN (the step fails and is retried smaller);
!> (4) every accepted state is checked (contact_observe, called by the TS
!> monitor of module step_monitor: the smallest gap over nodes and
!> obstacles, MPI_Allreduce), and a gap <= 0 ends the run with an error.
!> The check also lags friction's normal force and normal for the next
!> step and prints a contact line at each output time.
module contact_solver
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_intptr_t, c_ptr, c_loc, c_f_pointer
  use kinds, only: rp
  use ghosted_state, only: ghosted_get, ghosted_restore
  use app_context, only: app_ctx
  use newton_start, only: newton_start_order
  use contact_forces, only: contact_init, contact_record, contact_seen, contact_count_limited, contact_move, contact_moving, &
                            contact_keyframed, contact_summary
  use model_state, only: model_step_limit, model_swept, model_contact_state
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use strings, only: real_es, itoa
  implicit none
  private
  public :: contact_solver_options, contact_setup, contact_observe

  interface
    !> src/solver/nuno_contact_ksp.c: KSPSetPostSolve with the C trampoline that
    !> calls contact_limit_update_c(y, ctx).
    integer(c_int) function nuno_ksp_set_contact_post_solve(ksp, ctx) bind(C, name='nuno_ksp_set_contact_post_solve')
      import :: c_int, c_intptr_t, c_ptr
      integer(c_intptr_t) :: ksp                 !< KSP*
      type(c_ptr), value :: ctx
    end function nuno_ksp_set_contact_post_solve
    !> src/solver/nuno_contact_ksp.c: TSSetFunctionDomainError with its check
    !> that rejects a NaN state.
    integer(c_int) function nuno_ts_set_contact_domain(ts) bind(C, name='nuno_ts_set_contact_domain')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts                  !< TS*
    end function nuno_ts_set_contact_domain
  end interface

contains

  !> Before TSSetFromOptions: with obstacles, beuler starts Newton from x_n
  !> (see the module header), and the Jacobian is assembled at every
  !> Newton iteration (-snes_lag_jacobian 1 unless given; module
  !> solver_options' step_defaults lags it to every other iteration
  !> without obstacles). A lagged Jacobian's friction block belongs to the
  !> iterate before: where a node's slip crosses the smoothing band
  !> |u| = friction_eps_v between the two, its slope along the slip is
  !> mu lam f1'(|u|) on one side and 0 on the other, and the chord step
  !> overshoots to the other side and back, a two-cycle whenever
  !> mu lam dt / m >> friction_eps_v (input/drape_sphere.nml at
  !> t = 0.209 s: |u| = 6.7e-4 and 7.2e-3 m/s in turn, ||F|| stuck at 80
  !> for 50 iterations, eight retried steps and the run failed at 0.50 s;
  !> with S at every iteration no step is retried). Collective.
  subroutine contact_solver_options(ctx, ierr)
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    PetscBool :: given
    ierr = 0
    if (ctx%cfg%contact%n_obstacles == 0) return
    PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-ts_theta_initial_guess_extrapolate', 'false', ierr))
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-snes_lag_jacobian', given, ierr))
    if (.not. given) then
      PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-snes_lag_jacobian', '1', ierr))
    end if
  end subroutine contact_solver_options

  !> After the TS and SNES are set up: the obstacles and the step limit
  !> (the check of accepted states is called by the TS monitor). Nothing
  !> without obstacles. The step limit is the line search's pre-check;
  !> the Baraff-Witkin mode (-snes_type ksponly) has no line search: there
  !> the same limit runs as the post-solve of the SNES's KSP, on the update
  !> that SNES KSPONLY then takes in full (x - y), and a state made NaN by
  !> a failed limit (a moving obstacle crossed) is rejected by the TS's
  !> domain check (src/solver/nuno_contact_ksp.c), so the step is retried smaller.
  !> Collective.
  subroutine contact_setup(ctx, ierr)
    type(app_ctx), intent(inout), target :: ctx
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    type(tKSP) :: ksp
    SNESLineSearch :: ls
    character(len=64) :: tstype, sntype
    ierr = 0
    if (ctx%cfg%contact%n_obstacles == 0) return
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    if (trim(tstype) /= TSBEULER) then
      ierr = PETSC_ERR_SUP
      SETERRQ(ctx%comm, ierr, 'nuno: &contact: obstacles need -ts_type beuler (its Newton solve starts from the last accepted, feasible state), not -ts_type '//trim(tstype))
    end if
    if (newton_start_order(ctx%start) == 3) then
      ierr = PETSC_ERR_SUP
      SETERRQ(ctx%comm, ierr, 'nuno: &contact: -nuno_newton_start cubic is refused with obstacles: its start may lie inside an obstacle')
    end if
    call contact_init(ctx%contact, ctx%cfg%contact, ctx%lat)
    PetscCall(TSGetSNES(ctx%ts, snes, ierr))
    PetscCall(SNESGetLineSearch(snes, ls, ierr))
    PetscCall(SNESLineSearchSetPreCheck(ls, contact_precheck, ctx, ierr))
    PetscCall(SNESGetType(snes, sntype, ierr))
    if (trim(sntype) == SNESKSPONLY) then
      PetscCall(SNESGetKSP(snes, ksp, ierr))
      ierr = nuno_ksp_set_contact_post_solve(ksp%v, c_loc(ctx))
      if (ierr /= 0) return
      if (contact_keyframed(ctx%contact)) then
        ierr = nuno_ts_set_contact_domain(ctx%ts%v)
        if (ierr /= 0) return
      end if
    end if
  end subroutine contact_setup

  !> The Baraff-Witkin mode's step limit (src/solver/nuno_contact_ksp.c: the
  !> post-solve of the SNES's KSP): the update y at the SNES's solution x,
  !> limited as limit_update says. Collective.
  subroutine contact_limit_update_c(y_h, cp, ierr) bind(C, name='nuno_contact_limit_update')
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
  end subroutine contact_limit_update_c

  !> The line search's pre-check: PETSc steps x - lambda y; y is limited
  !> as limit_update says.
  subroutine contact_precheck(ls, xvec, yvec, changed, ctx, ierr)
    SNESLineSearch :: ls
    type(tVec) :: xvec, yvec
    PetscBool :: changed
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    logical :: ch
    PetscCall(limit_update(ctx, xvec, yvec, ch, ierr))
    changed = merge(PETSC_TRUE, PETSC_FALSE, ch)
  end subroutine contact_precheck

  !> The Newton update y at x (the step is x - y) limited: where a node
  !> would reach an obstacle (at its pose at the step's end) along -y, y
  !> is scaled by 0.8 alpha. Where
  !> obstacles move over the step, y is halved (at most 10 times) until no
  !> node's path from x_n crosses them, or set to NaN: the residual at the
  !> candidate is NaN and the step is retried smaller. changed: y was
  !> altered (the same on every rank). Collective.
  subroutine limit_update(ctx, xvec, yvec, changed, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tVec) :: xvec, yvec
    logical, intent(out) :: changed
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: x(:, :, :), y(:, :, :), x0(:, :, :)
    type(tVec) :: x0vec
    real(rp) :: alpha, galpha, s, t0, dt
    real(rp), allocatable :: dx(:, :, :)
    integer :: try, ncross, gcross
    logical :: moving
    changed = .false.
    moving = .false.
    if (contact_keyframed(ctx%contact)) then
      PetscCall(TSGetTime(ctx%ts, t0, ierr))
      PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
      call contact_move(ctx%contact, t0 + dt)
      moving = contact_moving(ctx%contact, t0, t0 + dt)
    end if
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, xvec, x, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, yvec, y, ierr))
    allocate(dx(0:5, 0:ctx%lat%nx - 1, ctx%lat%ys:ctx%lat%ye))
    dx = -y
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, yvec, y, ierr))
    alpha = model_step_limit(ctx%model, ctx%contact, ctx%lat, x, dx)
    call MPI_Allreduce(alpha, galpha, 1, MPI_DOUBLE_PRECISION, MPI_MIN, ctx%comm, ierr)
    s = 1.0_rp
    if (galpha < 1.0_rp) s = 0.8_rp * galpha
    gcross = 0
    if (moving) then
      ! x_n: the TS's solution until the step is accepted
      PetscCall(TSGetSolution(ctx%ts, x0vec, ierr))
      PetscCall(DMDAVecGetArrayReadF90(ctx%da, x0vec, x0, ierr))
      do try = 0, 10
        ncross = model_swept(ctx%model, ctx%contact, ctx%lat, t0, t0 + dt, x0, x, s * dx)
        call MPI_Allreduce(ncross, gcross, 1, MPI_INTEGER, MPI_SUM, ctx%comm, ierr)
        if (gcross == 0) exit
        s = 0.5_rp * s
      end do
      PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, x0vec, x0, ierr))
    end if
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, xvec, x, ierr))
    if (gcross > 0) then
      PetscCall(VecSet(yvec, ieee_value(1.0_rp, ieee_quiet_nan), ierr))
      changed = .true.
    else if (s < 1.0_rp) then
      PetscCall(VecScale(yvec, s, ierr))
      changed = .true.
      call contact_count_limited(ctx%contact)
    end if
  end subroutine limit_update

  !> An accepted state uvec at t (called by the TS monitor of module
  !> step_monitor after each accepted step and at each TSSolve's start, and
  !> by the output step at t = 0, before the first step): the smallest gap over every node and
  !> obstacle (collective); a gap <= 0 is an error. Then the friction lag
  !> for the next step, the state's record (contact_record: the /contact
  !> series, the friction work and the moving obstacles' work), and a line at each output time. A
  !> state recorded already is left alone. Collective.
  subroutine contact_observe(ctx, t, uvec, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    type(tVec), intent(in) :: uvec
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    real(rp) :: gmin, ftot(3), fnrm(3), ebar, pfric, pstart, pobs, ostart, loc(11), glob(11), r
    integer :: nact, gnact
    ierr = 0
    ! TSSolve calls its monitors at every window's start too, with the state
    ! its last step accepted: checked already
    if (contact_seen(ctx%contact, t)) return
    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    call model_contact_state(ctx%model, ctx%contact, ctx%lat, t, u, gmin, nact, ftot, fnrm, ebar, pfric, pobs, pstart, ostart)
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    call MPI_Allreduce(gmin, r, 1, MPI_DOUBLE_PRECISION, MPI_MIN, ctx%comm, ierr)
    gmin = r
    loc = [ftot, fnrm, ebar, pfric, pstart, pobs, ostart]
    call MPI_Allreduce(loc, glob, 11, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    call MPI_Allreduce(nact, gnact, 1, MPI_INTEGER, MPI_SUM, ctx%comm, ierr)
    call contact_record(ctx%contact, t, gmin, gnact, glob(1:3), glob(4:6), glob(7), glob(8), glob(9), glob(10), glob(11))
    if (.not. (gmin > 0.0_rp)) then
      ierr = PETSC_ERR_NOT_CONVERGED
      SETERRQ(ctx%comm, ierr, 'nuno: contact: an accepted state penetrates an obstacle at t = '//real_es(t)//': smallest gap '//real_es(gmin))
    end if
    r = t / ctx%cfg%output%output_interval
    if (ctx%rank == 0 .and. abs(r - anint(r)) <= 1.0e-9_rp * max(1.0_rp, r)) then
      associate (c => contact_summary(ctx%contact))
        write(*, '(a)') 'contact: t = '//real_es(t)//', active = '//itoa(gnact)//', force = '// &
          real_es(glob(1))//' '//real_es(glob(2))//' '//real_es(glob(3))//', min gap = '//real_es(gmin)// &
          ', min gap of all accepted states = '//real_es(c%min_gap_run)//', states checked = '// &
          itoa(c%states_checked)//', limited Newton steps = '//itoa(c%limited_steps)// &
          ', barrier energy = '//real_es(glob(7))//', friction work = '//real_es(c%friction_work)
      end associate
    end if
  end subroutine contact_observe

end module contact_solver
