! SPDX-License-Identifier: BSD-2-Clause
!> The TS monitor, run after every accepted step: the progress line, the
!> energy integrals (dissipated power, constraint work), the step-stall
!> checks and the process models' accepted hooks (contact). Checkpoints are the run
!> driver's (module timestepping). The records it advances are written by
!> their own modules' routines: step_settings (the return to the fixed
!> step), energy_integrals, run_progress (the stall check, the heartbeat).
!>
!> It is the run's only Fortran TS monitor: PETSc 3.18's Fortran
!> TSMonitorSet keeps one Fortran callback per TS, and a second call
!> silently replaces the first (TSMonitorSet finds its C wrapper set
!> already). Other per-step work, as the process models' accepted hooks,
!> is called from here.
module step_monitor
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: rp
  use ghosted_state, only: ghosted_get, ghosted_restore
  use forces, only: dissipated_power
  use model_state, only: model_moving, model_constraint_power
  use reduced, only: reduced_step_accepted
  use app_context, only: app_ctx, nuno_ts_stop
  use newton_start, only: newton_start_push
  use strings, only: num => real_brief
  use newton_policy, only: linesearch_fallback
  use newton_state, only: newton_fallback_pending, newton_has_failed
  use process_solver, only: pm_observe
  use step_settings, only: step_rejections, step_back_to_dt, step_t_end
  use energy_integrals, only: energy_gauss, energy_t_prev, energy_gauss_time, energy_gauss_add, energy_trapezoid_add, &
                              energy_integrals_start, energy_work_vector, energy_gauss_at, energy_gauss_share, &
                              energy_powers_prev
  use run_progress, only: progress_stall_check, progress_heartbeat_due, progress_wall, progress_said
  use run_error, only: run_error_first, run_error_text
  implicit none
  private
  public :: ts_monitor, integrals_after

contains

  !> After every accepted step (and at the start of each TSSolve): the
  !> stall check, keep its first Newton correction for the inner guesses
  !> and its state for the Newton start, after a retried step go back to
  !> the fixed step, advance the integrals of dissipated power and
  !> constraint power, the heartbeat, and the process models' accepted
  !> hooks (module process_solver; none without obstacles).
  subroutine ts_monitor(ts, step, t, uvec, ctx, ierr)
    type(tTS) :: ts
    PetscInt :: step
    PetscReal :: t
    type(tVec) :: uvec
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    real(rp) :: h
    PetscInt :: rejects, nfails
    logical :: stalled, retried, set

    PetscCall(stall_check(ts, step, t, ctx, stalled, ierr))
    if (stalled) return
    ! After a failed Newton solve (its step retried smaller and now
    ! accepted) the run's remaining steps take -nuno_linesearch_fallback
    ! instead of full steps: a membrane without bending that buckles at the
    ! lattice's scale can make full Newton steps overshoot again and again
    ! (hang 257 x 257, dt = 1 ms: eight failures and the run stopped at
    ! t = 0.21 s). It costs nothing until then (bt: a product with the
    ! 6-dof Jacobian an iteration, for its slope). A run restarted from a
    ! checkpoint after such a failure (newton_set_failures_before) backtracks from its
    ! first step, as the run it continues did.
    if (newton_fallback_pending(ctx%newton)) then
      PetscCall(TSGetSNESFailures(ts, nfails, ierr))
      if (newton_has_failed(ctx%newton, int(nfails))) then
        PetscCall(linesearch_fallback(ts, ctx, t, ierr))
      end if
    end if
    ! the accepted step's first Newton correction, for the next inner guesses
    if (ctx%use_reduced) call reduced_step_accepted(ctx%red)
    ! and its state, for the next Newton start
    PetscCall(newton_start_push(ctx%start, uvec, t, ierr))
    ! a retried fixed step: back to dt (module step_settings)
    PetscCall(TSGetStepRejections(ts, rejects, ierr))
    call step_rejections(ctx%step, rejects, retried)
    if (retried) then
      PetscCall(TSGetTimeStep(ts, h, ierr))
      call step_back_to_dt(ctx%step, t, h, set)
      if (set) then
        PetscCall(TSSetTimeStep(ts, h, ierr))
      end if
    end if
    PetscCall(advance_integrals(ts, step, t, uvec, ctx, ierr))
    PetscCall(heartbeat(ts, step, t, ctx, ierr))
    ! the process models' accepted hooks (contact: friction's lag for the next step, its record)
    PetscCall(pm_observe(ctx, t, uvec, ierr))
  end subroutine ts_monitor

  !> Ten accepted steps in a row that did not advance t (module
  !> run_progress): stop the TS after this step and say why (the run's
  !> error, module run_error; solver_run ends the run with it).
  subroutine stall_check(ts, step, t, ctx, stalled, ierr)
    type(tTS) :: ts
    PetscInt, intent(in) :: step
    real(rp), intent(in) :: t
    type(app_ctx), intent(inout) :: ctx
    logical, intent(out) :: stalled
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: h
    logical :: taken
    ierr = 0
    call progress_stall_check(ctx%progress, step, t > energy_t_prev(ctx%energy), stalled)
    if (.not. stalled) return
    PetscCall(TSGetTimeStep(ts, h, ierr))
    call run_error_first(ctx%error, 'ten accepted steps at t = '//num(t)//' did not advance t: the step, '//num(h)// &
      ', is below the resolution of t there ('//num(spacing(t))//'); the run cannot advance (a larger -ts_dt;'// &
      ' after failed solves, adaptive steps: -ts_adapt_type basic)', taken)
    if (taken .and. ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//run_error_text(ctx%error)
    ierr = nuno_ts_stop(ts%v)
  end subroutine stall_check

  !> The energy integrals over the step that ended at t (module
  !> energy_integrals): three Gauss-Legendre points on [t_prev, t] on the
  !> TS's interpolant (the end point's power is not needed), or the
  !> trapezoid rule. Collective.
  subroutine advance_integrals(ts, step, t, uvec, ctx, ierr)
    type(tTS) :: ts
    PetscInt, intent(in) :: step
    real(rp), intent(in) :: t
    type(tVec) :: uvec
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: p(2), h, tq
    type(tVec) :: uq
    integer :: q

    ierr = 0
    if (energy_gauss(ctx%energy)) then
      if (t > energy_t_prev(ctx%energy) .and. step > 0) then
        h = t - energy_t_prev(ctx%energy)
        uq = energy_work_vector(ctx%energy)
        do q = 1, 3
          tq = energy_gauss_time(ctx%energy, h, q)
          PetscCall(TSInterpolate(ts, tq, uq, ierr))
          call powers(ctx, uq, tq, p, ierr)
          if (ierr /= 0) return
          call energy_gauss_add(ctx%energy, h, q, p)
        end do
      end if
    else
      call powers(ctx, uvec, t, p, ierr)
      if (ierr /= 0) return
      call energy_trapezoid_add(ctx%energy, t, p)
    end if
    call energy_integrals_start(ctx%energy, t)
  end subroutine advance_integrals

  !> The energy integrals over [ta, t] [energy], t the last accepted step's
  !> end, which the monitor has integrated to, ta inside that step (an
  !> output time the run driver writes from the TS's interpolant, module
  !> timestepping), ua the interpolated state at ta: de(1) dissipated
  !> energy, de(2) the constraints' work, by the monitor's rule (Gauss-Legendre
  !> on the interpolant, or the trapezoid rule with the powers at t the
  !> monitor kept), so that the output step's integrals, those to t less
  !> de, close at the method's order as at a step's end. Collective.
  subroutine integrals_after(ts, ctx, ta, ua, de, ierr)
    type(tTS) :: ts
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: ta
    type(tVec) :: ua
    real(rp), intent(out) :: de(2)
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: p(2), h, tq
    type(tVec) :: uq
    integer :: q

    de = 0.0_rp
    ierr = 0
    h = energy_t_prev(ctx%energy) - ta
    if (.not. h > 0.0_rp) return
    if (energy_gauss(ctx%energy)) then
      uq = energy_work_vector(ctx%energy)
      do q = 1, 3
        tq = energy_gauss_at(ta, h, q)
        PetscCall(TSInterpolate(ts, tq, uq, ierr))
        call powers(ctx, uq, tq, p, ierr)
        if (ierr /= 0) return
        de = de + energy_gauss_share(h, q) * p
      end do
    else
      call powers(ctx, ua, ta, p, ierr)
      if (ierr /= 0) return
      de = 0.5_rp * (p + energy_powers_prev(ctx%energy)) * h
    end if
  end subroutine integrals_after

  !> A long output interval (tiny adaptive steps on a stiff scene) must not
  !> look like a hang: rank 0 says where it is every HEARTBEAT_S of wall
  !> time (module run_progress; TS values only, so nothing collective).
  subroutine heartbeat(ts, step, t, ctx, ierr)
    type(tTS) :: ts
    PetscInt, intent(in) :: step
    real(rp), intent(in) :: t
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: h
    real(rp) :: wall   ! wall-clock seconds since the start of the run [s]
    ierr = 0
    if (ctx%rank /= 0 .or. step <= 0) return
    if (.not. progress_heartbeat_due(ctx%progress)) return
    PetscCall(TSGetTimeStep(ts, h, ierr))
    ! Rate and ETA as on the output step's line (simulated time per wall
    ! second since the start; t > 0 here, since a step was taken).
    wall = progress_wall(ctx%progress)
    write(output_unit, '(a,es12.5e2,a,i9,4(a,es10.3e2),a)') '  ... t =', t, '  steps', step, &
      '  dt', h, '  wall_s', wall, '  sim_per_wall_s', t / wall, '  eta_s', (step_t_end(ctx%step) - t) * wall / t, &
      '  (between output steps)'
    flush(output_unit)
    call progress_said(ctx%progress)
  end subroutine heartbeat

  !> Global dissipated power p(1) and power of the constraint reactions p(2)
  !> = -sum over moving constrained nodes of (f_internal + m g) . vbar.
  subroutine powers(ctx, uvec, t, p, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tVec) :: uvec
    real(rp), intent(in) :: t
    real(rp), intent(out) :: p(2)
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    real(rp) :: loc(2)

    loc = 0.0_rp
    p = 0.0_rp
    ierr = 0
    if (.not. ctx%cfg%material%has_damping .and. ctx%cfg%material%eta_b == 0.0_rp .and. .not. model_moving(ctx%model)) return
    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    call dissipated_power(ctx%lat, u, loc(1))
    if (model_moving(ctx%model)) loc(2) = model_constraint_power(ctx%model, ctx%lat, ctx%cs, u, t)
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    call MPI_Allreduce(loc, p, 2, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
  end subroutine powers

end module step_monitor
