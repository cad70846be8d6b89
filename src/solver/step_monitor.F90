! SPDX-License-Identifier: BSD-2-Clause
!> The TS monitor, run after every accepted step: the progress line, the
!> energy integrals (dissipated power, constraint work), the step-stall
!> checks and, with obstacles, the contact check. Checkpoints are the run
!> driver's (module timestepping). It owns the records it advances, step,
!> energy and progress of app_ctx: their other writers call the routines at
!> the end of this module.
!>
!> It is the run's only Fortran TS monitor: PETSc 3.18's Fortran
!> TSMonitorSet keeps one Fortran callback per TS, and a second call
!> silently replaces the first (TSMonitorSet finds its C wrapper set
!> already). Other per-step work, as the contact check, is called from here.
module step_monitor
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_double
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: rp
  use forces, only: dissipated_power
  use cloth_model, only: model_internal_forces
  use constraints, only: constraint_target, constraint_count, constraint_node
  use reduced, only: reduced_step_accepted
  use app_context, only: app_ctx, nuno_ts_stop, step_settings_t, energy_integrals_t, progress_t
  use newton_start, only: newton_start_push
  use strings, only: num => real_brief
  use newton_policy, only: linesearch_fallback
  use contact_solver, only: contact_observe
  implicit none
  private
  public :: ts_monitor
  ! the step, energy and progress records of app_ctx: written only here
  public :: step_settings_init, step_set_tolerances, step_enter_window
  public :: energy_integrals_init, energy_integrals_free, energy_integrals_reset, energy_integrals_start, &
            energy_integrals_restore, energy_add_work, energy_set_mgx0
  public :: progress_start, progress_output_written, progress_said, progress_stretch_warned, progress_restore, &
            progress_reset

  !> Wall seconds without a line on stdout after which the monitor prints one.
  real(rp), parameter :: HEARTBEAT_S = 10.0_rp
  !> Gauss-Legendre points (on [0, 1]) and weights, 3 points.
  real(rp), parameter :: GAUSS_X(3) = [0.5_rp - sqrt(0.15_rp), 0.5_rp, 0.5_rp + sqrt(0.15_rp)]
  real(rp), parameter :: GAUSS_W(3) = [5.0_rp / 18.0_rp, 8.0_rp / 18.0_rp, 5.0_rp / 18.0_rp]

contains

  !> After every accepted step (and at the start of each TSSolve): keep its
  !> first Newton correction for the inner guesses, advance the integrals
  !> of dissipated power and constraint power, after a retried step go
  !> back to the fixed step, and with obstacles check the state (module
  !> contact_solver).
  subroutine ts_monitor(ts, step, t, uvec, ctx, ierr)
    type(tTS) :: ts
    PetscInt :: step
    PetscReal :: t
    type(tVec) :: uvec
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    real(rp) :: p(2), h, hmax, tq, pq(2)
    real(rp) :: wall   ! wall-clock seconds since the start of the run [s]
    PetscInt :: rejects, nfails
    integer :: q

    ! A failed Newton solve makes the TS retry the step with dt/4, and with
    ! -ts_adapt_type none it keeps that step: a fixed step would silently
    ! stay 4 times smaller. Once the retried step is accepted, return to dt,
    ! clipped to the window end as PETSc's matchstep does (no sliver step).
    ! Accepted steps that do not advance t (retries shrank them below t's
    ! resolution next to a stop time) could repeat forever: after ten in a
    ! row, stop and say so (one alone, after many retries, is harmless).
    if (ctx%progress%monitor_seen .and. step > ctx%progress%monitor_step) then
      if (t > ctx%energy%t_prev) then
        ctx%progress%stalled_steps = 0
      else
        ctx%progress%stalled_steps = ctx%progress%stalled_steps + 1
      end if
      if (ctx%progress%stalled_steps >= 10) then
        if (len_trim(ctx%io_error) == 0) then
          PetscCall(TSGetTimeStep(ts, h, ierr))
          ctx%io_error = 'ten accepted steps at t = '//num(t)//' did not advance t: the step, '//num(h)// &
            ', is below the resolution of t there ('//num(spacing(t))//'); the run cannot advance (a larger -ts_dt;'// &
            ' after failed solves, adaptive steps: -ts_adapt_type basic)'
          if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(ctx%io_error)
        end if
        ierr = nuno_ts_stop(ts%v)
        return
      end if
    end if
    ctx%progress%monitor_seen = .true.
    ctx%progress%monitor_step = step
    ! After a failed Newton solve (its step retried smaller and now
    ! accepted) the run's remaining steps take -nuno_linesearch_fallback
    ! instead of full steps: a membrane without bending that buckles at the
    ! lattice's scale can make full Newton steps overshoot again and again
    ! (hang 257 x 257, dt = 1 ms: eight failures and the run stopped at
    ! t = 0.21 s). It costs nothing until then (bt: a product with the
    ! 6-dof Jacobian an iteration, for its slope). A run restarted from a
    ! checkpoint after such a failure (counts_before) backtracks from its
    ! first step, as the run it continues did.
    if (ctx%newton%ls_fallback > 0 .and. .not. ctx%newton%ls_switched) then
      PetscCall(TSGetSNESFailures(ts, nfails, ierr))
      if (nfails + nint(ctx%restart%counts_before(5)) > 0) then
        PetscCall(linesearch_fallback(ts, ctx, t, ierr))
      end if
    end if
    ! the accepted step's first Newton correction, for the next inner guesses
    if (ctx%use_reduced) call reduced_step_accepted(ctx%red)
    ! and its state, for the next Newton start
    PetscCall(newton_start_push(ctx%newton%start, uvec, t, ierr))
    PetscCall(TSGetStepRejections(ts, rejects, ierr))
    if (rejects > ctx%step%rejects_seen) then
      ctx%step%rejects_seen = rejects
      if (ctx%step%fixed_step) then
        PetscCall(TSGetTimeStep(ts, h, ierr))
        hmax = ctx%step%tstop - t
        if (h < ctx%step%dt .and. hmax > 0.0_rp) then
          h = ctx%step%dt
          if (t + 1.01_rp * h >= ctx%step%tstop) then
            h = hmax
          else if (2.0_rp * h > hmax) then
            h = 0.5_rp * hmax
          end if
          PetscCall(TSSetTimeStep(ts, h, ierr))
        end if
      end if
    end if

    if (ctx%energy%gauss) then
      ! Three Gauss-Legendre points on [t_prev, t] (exact to degree 5): the
      ! error is that of the interpolant, the method's order. (The end
      ! point's power is not needed.)
      if (t > ctx%energy%t_prev .and. step > 0) then
        h = t - ctx%energy%t_prev
        do q = 1, 3
          tq = ctx%energy%t_prev + h * GAUSS_X(q)
          PetscCall(TSInterpolate(ts, tq, ctx%energy%uq, ierr))
          call powers(ctx, ctx%energy%uq, tq, pq, ierr)
          if (ierr /= 0) return
          ctx%energy%dissipated = ctx%energy%dissipated + h * GAUSS_W(q) * pq(1)
          ctx%energy%work_constraints = ctx%energy%work_constraints + h * GAUSS_W(q) * pq(2)
        end do
      end if
    else
      call powers(ctx, uvec, t, p, ierr)
      if (ierr /= 0) return
      if (t > ctx%energy%t_prev) then
        ctx%energy%dissipated = ctx%energy%dissipated + 0.5_rp * (ctx%energy%pdiss_prev + p(1)) * (t - ctx%energy%t_prev)
        ctx%energy%work_constraints = ctx%energy%work_constraints + 0.5_rp * (ctx%energy%pcon_prev + p(2)) * (t - ctx%energy%t_prev)
      end if
      ctx%energy%pdiss_prev = p(1)
      ctx%energy%pcon_prev = p(2)
    end if
    ctx%energy%t_prev = t
    ! A long output interval (tiny adaptive steps on a stiff scene) must not
    ! look like a hang: rank 0 says where it is every HEARTBEAT_S of wall
    ! time (TS values only, so nothing collective).
    if (ctx%rank == 0 .and. step > 0) then
      if (MPI_Wtime() - ctx%progress%wall_said >= HEARTBEAT_S) then
        PetscCall(TSGetTimeStep(ts, h, ierr))
        ! Rate and ETA as on the output step's line (simulated time per wall
        ! second since the start; t > 0 here, since a step was taken).
        wall = MPI_Wtime() - ctx%progress%wall0
        write(output_unit, '(a,es12.5e2,a,i9,4(a,es10.3e2),a)') '  ... t =', t, '  steps', step, &
          '  dt', h, '  wall_s', wall, '  sim_per_wall_s', t / wall, '  eta_s', (ctx%step%t_end - t) * wall / t, &
          '  (between output steps)'
        flush(output_unit)
        ctx%progress%wall_said = MPI_Wtime()
      end if
    end if
    ! no node inside an obstacle, and friction's lag for the next step
    if (ctx%cfg%contact%n_obstacles > 0) then
      PetscCall(contact_observe(ctx, t, uvec, ierr))
    end if
  end subroutine ts_monitor

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
    real(rp) :: loc(2), xb(3), vb(3)
    integer :: k, i, j, nbad, bad(2)

    loc = 0.0_rp
    p = 0.0_rp
    ierr = 0
    if (.not. ctx%cfg%material%has_damping .and. ctx%cfg%material%eta_b == 0.0_rp .and. .not. ctx%model%moving_constraints) return
    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    call dissipated_power(ctx%lat, u, loc(1))
    if (ctx%model%moving_constraints) then
      call model_internal_forces(ctx%model, ctx%lat, u, nbad, bad)
      do k = 1, constraint_count(ctx%cs)
        call constraint_target(ctx%cs, k, t, xb, vb)
        call constraint_node(ctx%cs, k, i, j)
        loc(2) = loc(2) - dot_product(ctx%model%f(:, i, j) + ctx%lat%mass(i, j) * ctx%model%gravity, vb)
      end do
    end if
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
    call MPI_Allreduce(loc, p, 2, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
  end subroutine powers

  ! --------------------------------- the step, energy and progress records

  !> The time integration in force after the options (module solver_setup):
  !> dt the fixed (or initial) step and t_end the end [time], max_steps
  !> (-ts_max_steps), fixed_step (-ts_adapt_type none), adaptive_default
  !> (the TS type is -nuno_adaptive_ts_type's).
  subroutine step_settings_init(s, dt, t_end, max_steps, fixed_step, adaptive_default)
    type(step_settings_t), intent(inout) :: s
    real(rp), intent(in) :: dt, t_end
    PetscInt, intent(in) :: max_steps
    logical, intent(in) :: fixed_step, adaptive_default
    s%dt = dt
    s%t_end = t_end
    s%max_steps = max_steps
    s%fixed_step = fixed_step
    s%adaptive_default = adaptive_default
  end subroutine step_settings_init

  !> The error tolerances of adaptive steps (module solver_setup's
  !> set_tolerances): rtol [1], atol_x [length], atol_v [length/time].
  subroutine step_set_tolerances(s, rtol, atol_x, atol_v)
    type(step_settings_t), intent(inout) :: s
    real(rp), intent(in) :: rtol, atol_x, atol_v
    s%rtol = rtol
    s%atol_x = atol_x
    s%atol_v = atol_v
  end subroutine step_set_tolerances

  !> The current time window ends at tstop [time] (advance_window): a
  !> retried fixed step returns to dt clipped to it.
  subroutine step_enter_window(s, tstop)
    type(step_settings_t), intent(inout) :: s
    real(rp), intent(in) :: tstop
    s%tstop = tstop
  end subroutine step_enter_window

  !> The integration rule (gauss: Gauss-Legendre on the interpolant, for
  !> bdf; else the trapezoid rule) and the work vector of its points, like
  !> the state u. Collective.
  subroutine energy_integrals_init(e, gauss, u, ierr)
    type(energy_integrals_t), intent(inout) :: e
    logical, intent(in) :: gauss
    type(tVec), intent(in) :: u                 !< the state (its layout)
    PetscErrorCode, intent(out) :: ierr
    e%gauss = gauss
    PetscCall(VecDuplicate(u, e%uq, ierr))
  end subroutine energy_integrals_init

  !> The interpolated state of the Gauss points. Collective.
  subroutine energy_integrals_free(e, ierr)
    type(energy_integrals_t), intent(inout) :: e
    PetscErrorCode, intent(out) :: ierr
    PetscCall(VecDestroy(e%uq, ierr))
  end subroutine energy_integrals_free

  !> The integrals back at their start (t = 0, nothing dissipated, no work
  !> done) for a new run over the same solver (identification, control);
  !> the integration rule and its work vector stay.
  subroutine energy_integrals_reset(e)
    type(energy_integrals_t), intent(inout) :: e
    e%t_prev = 0
    e%pdiss_prev = 0
    e%pcon_prev = 0
    e%dissipated = 0
    e%work_constraints = 0
    e%mgx0 = 0
  end subroutine energy_integrals_reset

  !> The integrals go on from t [time] (the run's start, or a restart's
  !> checkpoint time): the monitor's next step integrates from there.
  subroutine energy_integrals_start(e, t)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: t
    e%t_prev = t
  end subroutine energy_integrals_start

  !> The integrals of a checkpoint [energy] (module run_checkpoint).
  subroutine energy_integrals_restore(e, dissipated, work_constraints, mgx0)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: dissipated, work_constraints, mgx0
    e%dissipated = dissipated
    e%work_constraints = work_constraints
    e%mgx0 = mgx0
  end subroutine energy_integrals_restore

  !> sum m g . x at t = 0 [energy], the reference of the potential energy
  !> of gravity in the external work (the output step at t = 0).
  subroutine energy_set_mgx0(e, mgx0)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: mgx0
    e%mgx0 = mgx0
  end subroutine energy_set_mgx0

  !> The work dw [energy] done on the cloth at a window's start (the
  !> impulse of a keyframe: enter_window) added to the constraint work.
  subroutine energy_add_work(e, dw)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: dw
    e%work_constraints = e%work_constraints + dw
  end subroutine energy_add_work

  !> The run's clock starts (solver_run): wall_before [s] is the wall time
  !> of the runs a restart continues; the heartbeat counts from now.
  subroutine progress_start(p, wall_before)
    type(progress_t), intent(inout) :: p
    real(rp), intent(in) :: wall_before
    p%wall0 = MPI_Wtime() - wall_before
    p%wall_said = MPI_Wtime()
  end subroutine progress_start

  !> The output step at t [time] is written.
  subroutine progress_output_written(p, t)
    type(progress_t), intent(inout) :: p
    real(rp), intent(in) :: t
    p%t_written = t
  end subroutine progress_output_written

  !> Rank 0 has just printed a line on stdout (the heartbeat waits
  !> HEARTBEAT_S from now).
  subroutine progress_said(p)
    type(progress_t), intent(inout) :: p
    p%wall_said = MPI_Wtime()
  end subroutine progress_said

  !> The stretch_limit warning was given (once a run).
  subroutine progress_stretch_warned(p)
    type(progress_t), intent(inout) :: p
    p%stretch_warned = .true.
  end subroutine progress_stretch_warned

  !> A checkpoint's progress (module run_checkpoint): the time of its last
  !> output step [time] and whether the stretch warning was given.
  subroutine progress_restore(p, t_written, stretch_warned)
    type(progress_t), intent(inout) :: p
    real(rp), intent(in) :: t_written
    logical, intent(in) :: stretch_warned
    p%t_written = t_written
    p%stretch_warned = stretch_warned
  end subroutine progress_restore

  !> No output step written, the monitor's stall check afresh: a new run
  !> over the same solver (identification, control).
  subroutine progress_reset(p)
    type(progress_t), intent(inout) :: p
    p = progress_t()
  end subroutine progress_reset

end module step_monitor
