! SPDX-License-Identifier: BSD-2-Clause
!> The run driver of the time integration with PETSc TS on a DMDA of 1 x P
!> strips (docs/model.md sections 5 and 6): the loop over time windows that
!> stops exactly at keyframe and release times and t_end (and at output
!> times only where the method cannot interpolate to them), when the
!> output steps are written (between stops: the state of the step that
!> ends on one, or the TS's interpolant; the integration untouched; what
!> they hold: module output_steps) and the run's end. Beside it in
!> src/run: solver_setup (option resolution, solver_create and
!> solver_destroy), run_checkpoint (checkpoints and restarts), provenance
!> (run information and configuration in the output) and failure_text
!> (failure messages); the solver it drives is src/solver, one module per
!> concern (docs/design.md, "Module layout"). The state and the form of F
!> are described in module cloth_model.
module timestepping
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: rp
  use constraints, only: constraints_set_window, constraint_target, constraint_events, constraints_active, &
                         constraint_count, constraint_node
  use output, only: output_file, output_write_wall_time, output_write_retried_steps
  use app_context, only: app_ctx, nuno_walltime_arm, nuno_checkpoint_due, nuno_signal_agreed, nuno_output_arm, &
                         nuno_ts_interpolates
  use step_settings, only: step_enter_window, step_dt, step_t_end, step_fixed, step_max_steps
  use energy_integrals, only: energy_add_work, energy_integrals_start
  use run_progress, only: progress_start, progress_wall, progress_t_written
  use run_error, only: run_error_first, run_error_any, run_error_text
  use model_state, only: model_enter_window, model_fixed_to_reduced
  use newton_state, only: newton_enter_window
  use newton_start, only: newton_start_reset
  use step_monitor, only: integrals_after
  use failure_text, only: signal_name, failure_reason, report_io_error
  use strings, only: num => real_brief, inum => itoa
  use run_checkpoint, only: restart_state_t, run_counts, take_checkpoint, keep_restart_point, solver_restore, &
                            restart_state_init, restart_state_free, restart_wall_before, restart_walltime, &
                            restart_from, restart_t_checkpoint, restart_current, restart_file, &
                            restart_judge_t, restart_judge, checkpoint_pm_names
  use provenance, only: write_run_info
  use output_steps, only: write_output, write_state
  use solver_setup, only: check_decomposition, solver_create, solver_destroy
  implicit none
  private
  public :: app_ctx, solver_create, solver_destroy, solver_run, check_decomposition, solver_restore
  public :: restart_state_t, restart_state_init, restart_state_free  ! module run_checkpoint: main's record of them
  public :: restart_judge_t, restart_judge, checkpoint_pm_names      ! module run_checkpoint: a restart's checks
  public :: advance_window          ! module identify_adjoint: its forward run's windows
  public :: enter_window            ! module identify_adjoint: the constraint state of an adjoint window

  !> The run's output steps (multiples of output_interval, and t_end) and
  !> its stop times: the constraints' events (keyframes, releases), t_end,
  !> and, for a method without an interpolant, the output times.
  type :: schedule_t
    real(rp), allocatable :: events(:)          !< the constraints' event times [time]
    real(rp) :: interval = 0                    !< output_interval [time]
    real(rp) :: t_end = 0                       !< [time]
    real(rp) :: eps = 0                         !< times closer than this are the same [time]
    !> a step that ends this close to an output time ends on it (its own
    !> state is written): eps, and for fixed steps 1e-3 dt, as t sums the
    !> steps' rounding [time]
    real(rp) :: eps_on = 0
    integer :: iout = 0                         !< the next output step's number (output_time)
    !> output times between stops are written from the TS's interpolant
    !> (nuno_ts_interpolates); else every output time is a stop
    logical :: interpolate = .false.
    !> the next window starts the solver afresh (enter_window,
    !> TSRestartStep): after an event, and a restart's first window
    logical :: enter_next = .false.
  end type schedule_t

  !> TS_CONVERGED_USER (TSSolve ended by nuno's post-step or monitor), which
  !> the Fortran interface of PETSc 3.18 does not define (petscts.h).
  integer, parameter :: TS_STOPPED_BY_US = 3

  !> What the run does after a window (window_end): the next window, its
  !> end (status says why; the final checkpoint and summary), or its end
  !> after a failed write (status says why; nothing more is written).
  integer, parameter :: GO_ON = 0, ENDS = 1, LOST = 2

contains

  ! ------------------------------------------------------------- time windows

  !> Set the constraints of the window [ta, tb] and move the constrained
  !> nodes onto their prescribed path; returns the jump of their kinetic
  !> energy (the work of the impulse at a keyframe). Collective.
  subroutine enter_window(ctx, ta, tb, dke, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: ta, tb
    real(rp), intent(out) :: dke
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: ua(:, :, :)
    real(rp) :: xb(3), vb(3), loc(3), m
    integer :: k, i, j

    call constraints_set_window(ctx%cs, ta, tb)
    ! The Newton remainder is learnt anew in each window, so that a run
    ! restarted at a window's start takes the same iterations as the run
    ! that went through it.
    call newton_enter_window(ctx%newton)
    loc = 0.0_rp
    PetscCall(DMDAVecGetArrayF90(ctx%da, ctx%u, ua, ierr))
    if (constraints_active(ctx%cs)) then
      do k = 1, constraint_count(ctx%cs)
        call constraint_node(ctx%cs, k, i, j)
        call constraint_target(ctx%cs, k, ta, xb, vb)
        m = ctx%lat%mass(i, j)
        loc(1) = loc(1) + 0.5_rp * m * (dot_product(vb, vb) - dot_product(ua(3:5, i, j), ua(3:5, i, j)))
        if (any(vb /= 0.0_rp)) loc(2) = 1.0_rp
        if (any(ua(0:2, i, j) /= xb) .or. any(ua(3:5, i, j) /= vb)) loc(3) = 1.0_rp
        ua(0:2, i, j) = xb
        ua(3:5, i, j) = vb
      end do
    end if
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, ctx%u, ua, ierr))
    call MPI_Allreduce(MPI_IN_PLACE, loc, 3, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    ! the window's constrained nodes, and whether one moves (module model_state)
    call model_enter_window(ctx%model, ctx%cs, moving=loc(2) > 0.0_rp)
    if (ctx%use_reduced) then
      PetscCall(model_fixed_to_reduced(ctx%model, ctx%red, ierr))
    end if
    ! The Newton start's kept states end here where the state jumps (a
    ! keyframe's start, a constraint's target moved); elsewhere they go on
    ! across the window's start (a checkpoint keeps them for a restart:
    ! take_checkpoint, solver_restore). Forgetting them at every window
    ! cost 12 % of hang's 1 s at 257 x 257 (1100 instead of 1005 Newton
    ! iterations, 4697 instead of 4001 inner ones).
    if (loc(3) > 0.0_rp) call newton_start_reset(ctx%start)
    dke = loc(1)
  end subroutine enter_window

  !> Advance the solution from t = ta to tb, the window between two stop
  !> times (output, observed, keyframe and release times): with enter,
  !> first the window's constraint state (enter_window; the work of its
  !> impulse added to the constraint work) and a fresh start of the
  !> integrator; then steps of h (dt for fixed steps; the adaptive step
  !> carried from the window before), the last one clipped to end on tb. On
  !> return t and reason are the TS's (t is tb up to round-off unless the
  !> solve stopped early: the caller decides what that means) and h the
  !> step the window began with. The window loop of identification and
  !> control (module identify_adjoint); the run's is run_window, which also
  !> writes the wall-clock checkpoints. Collective.
  subroutine advance_window(ctx, t, tb, h, enter, reason, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(inout) :: t
    real(rp), intent(in) :: tb
    real(rp), intent(inout) :: h
    logical, intent(in) :: enter
    TSConvergedReason, intent(out) :: reason
    PetscErrorCode, intent(out) :: ierr

    PetscCall(window_start(ctx, t, tb, h, enter, enter, ierr))
    do
      PetscCall(window_solve(ctx, t, reason, ierr))
      ! (a wall-clock checkpoint's end of TSSolve, due = 2: the window goes on)
      if (nuno_checkpoint_due() /= 2) exit
    end do
  end subroutine advance_window

  !> advance_window for the run, which enters a window (the solver's and
  !> the integrator's fresh start) only after an event and at a restart
  !> (sc%enter_next; the first window is entered before the output step at
  !> t = 0: run_start): the output steps between the window's ends
  !> (outputs_passed) and the wall-clock
  !> checkpoints (-nuno_checkpoint_walltime) due inside the window are
  !> written into out between steps, TSSolve going on after them as if
  !> nothing happened; a failed write ends the window early with the run's
  !> error set (module run_error). Collective.
  subroutine run_window(ctx, r, out, sc, t, tb, h, reason, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    type(schedule_t), intent(inout) :: sc
    real(rp), intent(inout) :: t, h
    real(rp), intent(in) :: tb
    TSConvergedReason, intent(out) :: reason
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: hnext
    integer :: due
    logical :: taken

    PetscCall(window_start(ctx, t, tb, h, sc%enter_next, sc%enter_next, ierr))
    sc%enter_next = .false.
    do
      call arm_output(sc, tb)
      PetscCall(window_solve(ctx, t, reason, ierr))
      call nuno_output_arm(0_c_int, 0.0_c_double)
      ! The output steps the last step reached or passed, before a
      ! checkpoint takes the restart point they keep. After a failed step
      ! the TS's interpolant is the failed attempt's: none.
      if (reason >= 0) then
        call outputs_passed(ctx, r, out, sc, t, tb, ierr)
        if (ierr /= 0) then
          ! a failed write ends the run (window_end reads the run's error)
          if (run_error_any(ctx%error)) ierr = 0
          return
        end if
      end if
      ! -nuno_checkpoint_walltime, due after the step just taken (agreed by
      ! the post-step, src/solver/nuno_signals.c): the restart point of the last
      ! output step (keep_restart_point; before the first one, this step's
      ! state with its energy integrals), h the step the TS takes next.
      ! Where the post-step ended TSSolve for it (due = 2), or for an output
      ! step, the window goes on with the same TS: no new window, the step
      ! the TS chose.
      due = int(nuno_checkpoint_due())
      if (due /= 0) then
        PetscCall(TSGetTimeStep(ctx%ts, hnext, ierr))
        call take_checkpoint(ctx, r, out, t, hnext, 'wall time', .true., ierr)
        if (ierr /= 0) then
          ! a failed write ends the run (solver_run reads the run's error)
          ierr = 0
          call run_error_first(ctx%error, 'the wall-clock checkpoint at t = '//num(t)//' failed', taken)
          exit
        end if
      end if
      if (reason /= TS_STOPPED_BY_US .or. nuno_signal_agreed() /= 0 .or. run_error_any(ctx%error) .or. &
          t >= tb - 1.0e3_rp * sc%eps) exit
    end do
  end subroutine run_window

  !> The post-step ends TSSolve after the step that reaches the next
  !> output time inside the window [t, tb] that is no stop (none where
  !> there is none). Not collective.
  subroutine arm_output(sc, tb)
    type(schedule_t), intent(in) :: sc
    real(rp), intent(in) :: tb
    real(rp) :: tout
    tout = output_time(sc, sc%iout)
    if (tout < tb - 1.0e3_rp * sc%eps) then
      call nuno_output_arm(1_c_int, real(tout - sc%eps_on, c_double))
    else
      call nuno_output_arm(0_c_int, 0.0_c_double)
    end if
  end subroutine arm_output

  !> The output steps inside the window that ends at tb which the step
  !> that ended at t has reached or passed (tb's own is window_end's): the
  !> step's state where it ends on one, else the TS's interpolant there
  !> (TSInterpolate; the energy integrals taken back to it,
  !> integrals_after); nothing in the integration changes. Then, as at a
  !> window's end, the restart point (the state at t) and a
  !> checkpoint_interval checkpoint. Collective.
  subroutine outputs_passed(ctx, r, out, sc, t, tb, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    type(schedule_t), intent(inout) :: sc
    real(rp), intent(in) :: t, tb
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: tout, tlast, hnext, de(2)
    type(tVec) :: w
    PetscErrorCode :: err

    ierr = 0
    tlast = -1.0_rp
    do
      tout = output_time(sc, sc%iout)
      if (tout > t + sc%eps_on .or. tout >= tb - 1.0e3_rp * sc%eps) exit
      if (abs(t - tout) <= sc%eps_on) then
        call write_output(ctx, r, out, tout, ierr)
      else
        PetscCall(DMGetGlobalVector(ctx%da, w, ierr))
        PetscCall(TSInterpolate(ctx%ts, tout, w, ierr))
        PetscCall(integrals_after(ctx%ts, ctx, tout, w, de, ierr))
        call write_state(ctx, r, out, tout, w, de, ierr)
        call DMRestoreGlobalVector(ctx%da, w, err)
        if (ierr == 0) ierr = err
      end if
      if (ierr /= 0) return
      sc%iout = sc%iout + 1
      tlast = tout
    end do
    if (tlast < 0.0_rp .or. t >= sc%t_end - sc%eps) return
    PetscCall(TSGetTimeStep(ctx%ts, hnext, ierr))
    call keep_restart_point(ctx, r, out, t, hnext, ierr)
    if (ierr /= 0) return
    if (ctx%cfg%output%checkpoint_interval > 0.0_rp .and. &
        tlast >= restart_t_checkpoint(r) + ctx%cfg%output%checkpoint_interval - sc%eps) then
      call take_checkpoint(ctx, r, out, t, hnext, 'checkpoint_interval', .false., ierr)
    end if
  end subroutine outputs_passed

  !> A window's start (advance_window): the monitor's window end, with
  !> enter the constraint state and the solver's fresh start (enter_window),
  !> with restart also the integrator's (TSRestartStep: a multistep method
  !> begins again at first order), the TS's stop time tb and its first step
  !> h (dt for fixed steps), clipped to end on tb. Collective.
  subroutine window_start(ctx, t, tb, h, enter, restart, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t, tb
    real(rp), intent(inout) :: h
    logical, intent(in) :: enter, restart
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: dke

    ierr = 0
    call step_enter_window(ctx%step, tstop=tb)
    if (enter) then
      call enter_window(ctx, t, tb, dke, ierr)
      if (ierr /= 0) return
      call energy_add_work(ctx%energy, dke)
      if (restart) then
        PetscCall(TSRestartStep(ctx%ts, ierr))
      end if
    end if
    PetscCall(TSSetMaxTime(ctx%ts, tb, ierr))
    if (step_fixed(ctx%step)) h = step_dt(ctx%step)
    if (t + 1.01_rp * h >= tb) h = tb - t
    PetscCall(TSSetTimeStep(ctx%ts, h, ierr))
  end subroutine window_start

  !> TSSolve from the TS's state to its stop time, or until a signal or a
  !> wall-clock checkpoint ends it after a step; t and reason: where and why
  !> it stopped. Collective.
  subroutine window_solve(ctx, t, reason, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(out) :: t
    TSConvergedReason, intent(out) :: reason
    PetscErrorCode, intent(out) :: ierr
    PetscCall(TSSolve(ctx%ts, ctx%u, ierr))
    PetscCall(TSGetConvergedReason(ctx%ts, reason, ierr))
    PetscCall(TSGetTime(ctx%ts, t, ierr))
  end subroutine window_solve

  ! -------------------------------------------------------------- the run

  !> Integrate from t = 0 (or from the checkpoint of solver_restore, r) to
  !> t_end, writing every output step and the checkpoints (every
  !> checkpoint_interval at an output step, every -nuno_checkpoint_walltime
  !> after a step, on SIGTERM/SIGINT, and at the end). On a failed step,
  !> status says why and ierr = 0 (the output so far is kept); ierr /= 0
  !> is left for PETSc or HDF5 errors. -ts_max_steps ends the run early but
  !> complete, with the state of its last step written. Collective.
  subroutine solver_run(ctx, r, out, status, ierr)
    type(app_ctx), intent(inout), target :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout), target :: out
    character(len=*), intent(out) :: status
    PetscErrorCode, intent(out) :: ierr
    type(schedule_t) :: sc
    real(rp) :: t, tstop, h
    integer :: next
    integer(c_int) :: interpolates
    TSConvergedReason :: reason

    status = 'complete'
    call progress_start(ctx%progress, wall_before=restart_wall_before(r))
    call write_run_info(ctx, out, restart_file(r), ierr)
    if (io_failed(ctx, status, ierr)) return
    call nuno_walltime_arm(real(restart_walltime(r), c_double))
    sc%events = constraint_events(ctx%cs, step_t_end(ctx%step))
    sc%t_end = step_t_end(ctx%step)
    sc%interval = ctx%cfg%output%output_interval
    sc%eps = 1.0e-12_rp * max(1.0_rp, sc%t_end)
    sc%eps_on = sc%eps
    if (step_fixed(ctx%step)) sc%eps_on = max(sc%eps, 1.0e-3_rp * step_dt(ctx%step))
    ierr = nuno_ts_interpolates(ctx%ts%v, interpolates)
    if (ierr /= 0) return
    sc%interpolate = interpolates /= 0
    if (ctx%rank == 0) call say_outputs(sc)
    h = step_dt(ctx%step)
    t = 0.0_rp
    call run_start(ctx, r, out, sc, t, h, status, ierr)
    if (ierr /= 0 .or. status /= 'complete') return
    next = GO_ON
    do while (t < sc%t_end - sc%eps .and. next == GO_ON)
      tstop = next_stop(sc, t)
      call run_window(ctx, r, out, sc, t, tstop, h, reason, ierr)
      if (ierr /= 0) return
      call window_end(ctx, r, out, sc, reason, tstop, t, h, status, next, ierr)
      if (ierr /= 0 .or. next == LOST) return
    end do
    call run_end(ctx, r, out, t, h, status, ierr)
  end subroutine solver_run

  !> The run's first output step: at t = 0 after entering the first
  !> window, or, for a restart, the output step the checkpoint's run was
  !> about to write; sc%iout the next output step's number after it, t and
  !> h where the run goes on. A failed write: status says why (io_failed).
  !> Collective.
  subroutine run_start(ctx, r, out, sc, t, h, status, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    type(schedule_t), intent(inout) :: sc
    real(rp), intent(inout) :: t, h
    character(len=*), intent(inout) :: status
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: tstop, dke, t_ck, h_ck
    logical :: restarted

    ierr = 0
    call restart_from(r, restarted, t_ck, h_ck)
    if (.not. restarted) then
      sc%iout = 0
      tstop = next_stop(sc, t)
      call enter_window(ctx, t, tstop, dke, ierr)
      if (ierr /= 0) return
      call energy_integrals_start(ctx%energy, 0.0_rp)
      call write_output(ctx, r, out, t, ierr)
      if (io_failed(ctx, status, ierr)) return
      sc%iout = 1
      return
    end if
    ! Go on from the checkpoint: its state, time and step number are in
    ! the TS (solver_restore); the next output step is the first after the
    ! last one written.
    t = t_ck
    if (.not. step_fixed(ctx%step)) h = h_ck
    ! (the TS holds no history of the run it continues)
    sc%enter_next = .true.
    sc%iout = 1
    do while (output_time(sc, sc%iout) <= progress_t_written(ctx%progress) + sc%eps .and. &
              real(sc%iout, rp) * sc%interval < sc%t_end)
      sc%iout = sc%iout + 1
    end do
    call energy_integrals_start(ctx%energy, t)
    ! A wall-clock checkpoint after a window's last step is at the
    ! window's end, before solver_run wrote that output step: as the run
    ! did next, put t onto it and write it.
    tstop = next_stop(sc, t - 1.0e3_rp * sc%eps)
    if (abs(t - tstop) <= 1.0e3_rp * sc%eps) then
      t = tstop
      call energy_integrals_start(ctx%energy, t)
      PetscCall(TSSetTime(ctx%ts, t, ierr))
      if (abs(t - output_time(sc, sc%iout)) <= sc%eps) then
        call write_output(ctx, r, out, t, ierr)
        if (io_failed(ctx, status, ierr)) return
        sc%iout = sc%iout + 1
      end if
    end if
  end subroutine run_start

  !> After a window that was to end at tstop: the run's error, a signal,
  !> a failed step or an early stop end the run (status says why, next =
  !> ENDS); otherwise t is put onto tstop (h: the TS's next step) and the
  !> output step and checkpoints due there are written. -ts_max_steps ends
  !> the run complete (next = ENDS). A failed write: status says why and
  !> next = LOST (no summary; io_failed). Collective.
  subroutine window_end(ctx, r, out, sc, reason, tstop, t, h, status, next, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    type(schedule_t), intent(inout) :: sc
    TSConvergedReason, intent(in) :: reason
    real(rp), intent(in) :: tstop
    real(rp), intent(inout) :: t, h
    character(len=*), intent(inout) :: status
    integer, intent(out) :: next
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: unorm
    logical :: at_max_steps
    character(len=900) :: msg

    next = ENDS
    ierr = 0
    if (run_error_any(ctx%error)) then
      ! A wall-clock checkpoint could not be written (run_window), or the
      ! monitor's stall check ended the run.
      status = 'failed: '//run_error_text(ctx%error)
      return
    end if
    PetscCall(VecNorm(ctx%u, NORM_INFINITY, unorm, ierr))
    if (reason >= 0 .and. nuno_signal_agreed() /= 0) then
      call interrupted(ctx, r, out, t, sc%eps_on, h, status, next, ierr)
      return
    end if
    if (reason < 0 .or. unorm /= unorm .or. unorm > huge(1.0_rp)) then
      call failure_reason(ctx, reason, t, msg)
      call run_failed(ctx, msg, status)
      return
    end if
    ! -ts_max_steps: PETSc counts steps over all TSSolve calls and stops
    ! with TS_CONVERGED_ITS, possibly inside a window: a clean end.
    at_max_steps = reason == TS_CONVERGED_ITS
    if (abs(t - tstop) > 1.0e3_rp * sc%eps .and. .not. at_max_steps) then
      write(msg, '(a,es12.5,a,es12.5)') 'time integration stopped at t = ', t, ' before ', tstop
      call run_failed(ctx, msg, status)
      return
    end if
    if (abs(t - tstop) <= 1.0e3_rp * sc%eps) then
      t = tstop
      PetscCall(TSSetTime(ctx%ts, t, ierr))
      PetscCall(TSGetTimeStep(ctx%ts, h, ierr))
    end if
    next = LOST
    if (abs(t - output_time(sc, sc%iout)) <= sc%eps) then
      call write_output(ctx, r, out, t, ierr)
      if (io_failed(ctx, status, ierr)) return
      sc%iout = sc%iout + 1
      if (t < sc%t_end - sc%eps) then
        call keep_restart_point(ctx, r, out, t, h, ierr)
        if (ierr /= 0) return
      end if
      if (ctx%cfg%output%checkpoint_interval > 0.0_rp .and. t < sc%t_end - sc%eps .and. &
          t >= restart_t_checkpoint(r) + ctx%cfg%output%checkpoint_interval - sc%eps) then
        call take_checkpoint(ctx, r, out, t, h, 'checkpoint_interval', .false., ierr)
        if (io_failed(ctx, status, ierr)) return
      end if
    else if (at_max_steps .and. t > progress_t_written(ctx%progress) + sc%eps_on) then
      ! Off the output grid (inside a window, or at a keyframe): the last state.
      call write_output(ctx, r, out, t, ierr)
      if (io_failed(ctx, status, ierr)) return
    end if
    next = merge(ENDS, GO_ON, at_max_steps)
    ! After an event the solver and the integrator start afresh; after a
    ! stop at an output time (a method without an interpolant) they go on
    ! as if it had been none.
    sc%enter_next = at_event(sc, t)
    if (at_max_steps .and. t < sc%t_end - sc%eps .and. ctx%rank == 0) &
      write(output_unit, '(a,es13.5e2,a)') 'nuno: -ts_max_steps '//inum(step_max_steps(ctx%step))// &
        ' reached at t =', t, ': the run ends here, complete, with this state written'
  end subroutine window_end

  !> SIGTERM/SIGINT: every rank finished the same step; keep its state
  !> (unless it was the output step just written: within eps_on of it) and
  !> a checkpoint to continue from (the restart point of the last output
  !> step: keep_restart_point), and say so (next = ENDS). A failed write:
  !> status says why (io_failed; next = LOST). Collective.
  subroutine interrupted(ctx, r, out, t, eps_on, h, status, next, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t, eps_on                !< [time]
    real(rp), intent(out) :: h
    character(len=*), intent(inout) :: status
    integer, intent(out) :: next
    PetscErrorCode, intent(out) :: ierr
    character(len=900) :: msg

    ierr = 0
    next = LOST
    if (t > progress_t_written(ctx%progress) + eps_on) then
      call write_output(ctx, r, out, t, ierr)
      if (io_failed(ctx, status, ierr)) return
    end if
    PetscCall(TSGetTimeStep(ctx%ts, h, ierr))
    call take_checkpoint(ctx, r, out, t, h, trim(signal_name(nuno_signal_agreed())), .true., ierr)
    if (io_failed(ctx, status, ierr)) return
    write(msg, '(a,es12.5,a)') trim(signal_name(nuno_signal_agreed()))//' at t = ', t, &
      ': the run stopped after that step, with its state and a checkpoint written (continue it with'// &
      ' -nuno_restart '//restart_file(r)//')'
    status = 'interrupted: '//trim(msg)
    if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: interrupted: '//trim(msg)
    next = ENDS
  end subroutine interrupted

  !> The run has failed for the reason msg: its status, and the line on
  !> stderr (rank 0).
  subroutine run_failed(ctx, msg, status)
    type(app_ctx), intent(in) :: ctx
    character(len=*), intent(in) :: msg
    character(len=*), intent(out) :: status
    status = 'failed: '//trim(msg)
    if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(msg)
  end subroutine run_failed

  !> The end of the run: a complete run's checkpoint (so that it can be
  !> continued to a later t_end), the run's wall time in the file, the
  !> closing line. A failed write: status says why (io_failed). Collective.
  subroutine run_end(ctx, r, out, t, h, status, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t, h
    character(len=*), intent(inout) :: status
    PetscErrorCode, intent(out) :: ierr
    character(len=512) :: errmsg
    real(rp) :: wall, counts(5)

    ierr = 0
    if (status == 'complete' .and. .not. restart_current(r)) then
      call take_checkpoint(ctx, r, out, t, h, 'end', .false., ierr)
      if (io_failed(ctx, status, ierr)) return
    end if
    ! The run's wall time, the same value on every rank (an attribute).
    wall = progress_wall(ctx%progress)
    call MPI_Allreduce(MPI_IN_PLACE, wall, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call output_write_wall_time(out, wall, ierr, errmsg)
    ! and the steps retried smaller (rejected): with fixed steps, those not dt
    if (ierr == 0) call run_counts(ctx, r, counts, ierr)
    if (ierr == 0) call output_write_retried_steps(out, nint(counts(2)), ierr, errmsg)
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      if (io_failed(ctx, status, ierr)) return
    end if
    call final_summary(ctx, r, status, wall, ierr)
  end subroutine run_end

  !> An output or checkpoint write failed on some rank (a full disk):
  !> agreed by every rank and reported in one line already (the run's
  !> error), so the run ends collectively as failed (status; ierr = 0);
  !> other errors stay errors. True for both.
  logical function io_failed(ctx, status, ierr)
    type(app_ctx), intent(in) :: ctx
    character(len=*), intent(inout) :: status
    PetscErrorCode, intent(inout) :: ierr
    io_failed = ierr /= 0
    if (io_failed .and. run_error_any(ctx%error)) then
      status = 'failed: '//run_error_text(ctx%error)
      ierr = 0
    end if
  end function io_failed

  !> One start-up line (rank 0): how the output steps are reached, and so
  !> whether output_interval can change the solution.
  subroutine say_outputs(sc)
    type(schedule_t), intent(in) :: sc
    character(len=*), parameter :: head = 'outputs   : '
    if (.not. sc%interpolate) then
      write(output_unit, '(a)') head//'the integrator stops at every output time (this method has no usable '// &
        'interpolant in PETSc 3.18), so output_interval changes its steps, within the tolerance'
    else
      write(output_unit, '(a)') head//'the state of a step that ends on the output time, else the TS''s '// &
        'interpolant; the integrator stops only at keyframes, releases and t_end: output_interval does not '// &
        'change the solution'
    end if
    flush(output_unit)
  end subroutine say_outputs

  !> Output time k: a multiple of output_interval, or t_end.
  pure real(rp) function output_time(sc, k)
    type(schedule_t), intent(in) :: sc
    integer, intent(in) :: k
    output_time = min(real(k, rp) * sc%interval, sc%t_end)
  end function output_time

  !> Next time at which the integrator must stop after tt: the next
  !> constraint event or t_end, and the next output time for a method
  !> without an interpolant (nuno_ts_interpolates: there the steps are cut
  !> to end on it, as they always were). Other output times are written
  !> between steps (outputs_passed), the integration untouched.
  pure real(rp) function next_stop(sc, tt)
    type(schedule_t), intent(in) :: sc
    real(rp), intent(in) :: tt
    integer :: m
    next_stop = sc%t_end
    if (.not. sc%interpolate) next_stop = output_time(sc, sc%iout)
    do m = 1, size(sc%events)
      if (sc%events(m) > tt + sc%eps) next_stop = min(next_stop, sc%events(m))
    end do
  end function next_stop

  !> t is a constraint event's time (a keyframe, a release).
  pure logical function at_event(sc, t)
    type(schedule_t), intent(in) :: sc
    real(rp), intent(in) :: t
    at_event = any(abs(sc%events - t) <= 1.0e3_rp * sc%eps)
  end function at_event

  !> One closing line on rank 0 (stdout; a failure's reason is already on
  !> stderr) with the totals, the retries and the wall time.
  subroutine final_summary(ctx, r, status, wall, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(in) :: r
    character(len=*), intent(in) :: status
    real(rp), intent(in) :: wall
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: steps, rejects, fails
    real(rp) :: t, c(5)
    integer :: kw

    call run_counts(ctx, r, c, ierr)
    if (ierr /= 0) return
    steps = int(c(1), kind(steps))
    rejects = int(c(2), kind(rejects))
    fails = int(c(5), kind(fails))
    PetscCall(TSGetTime(ctx%ts, t, ierr))
    ! the status's first word: complete, failed or interrupted (its
    ! reason, after the colon, is on stderr already)
    kw = index(status, ':') - 1
    if (kw < 1) kw = len_trim(status)
    if (ctx%rank == 0) then
      write(output_unit, '(a,es13.5e2,a,i0,a,i0,a,i0,a,es11.3e2,a)', advance='no') 'nuno: '// &
        status(1:kw)//' at t =', t, ': ', steps, ' steps, ', rejects, ' rejected (', fails, &
        ' retried after a failed Newton solve), wall time', wall, ' s'
      ! Fixed steps are dt but where a step was retried smaller (dt/4).
      if (step_fixed(ctx%step) .and. rejects > 0) write(output_unit, '(a,i0,a)', advance='no') &
        '; fixed steps: ', rejects, ' retried smaller, so not every step was dt (/run retried_steps)'
      write(output_unit, '(a)') ''
      flush(output_unit)
    end if
  end subroutine final_summary

end module timestepping
