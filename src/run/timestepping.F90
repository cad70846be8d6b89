! SPDX-License-Identifier: BSD-2-Clause
!> The run driver of the time integration with PETSc TS on a DMDA of 1 x P
!> strips (docs/model.md sections 5 and 6): the loop over time windows that
!> stops exactly at output, keyframe and release times, the output steps
!> and the run's end. The rest of the solver has one module per concern:
!> app_context (the context passed to every callback), cloth_model (the
!> IFunction and IJacobian callbacks), newton_policy (the convergence
!> test, forcing, line-search fallback, Newton start), solver_setup
!> (option resolution, solver_create and solver_destroy), step_monitor
!> (the TS monitor), run_checkpoint (checkpoints and restarts),
!> provenance (run information and configuration in the output) and
!> failure_text (failure messages, string helpers). The state and the
!> form of F are described in module cloth_model.
module timestepping
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_double
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: rp
  use lattice, only: link_dir
  use forces, only: link_stretch_extremes
  use constraints, only: constraints_set_window, constraint_target, constraint_events, constraints_active, &
                         constraint_count, constraint_node
  use diagnostics, only: state_diagnostics_t, state_diagnostics
  use output, only: output_file, output_record, output_write_step, output_write_wall_time, output_write_retried_steps
  use reduced, only: reduced_set_fixed
  use app_context, only: app_ctx, nuno_walltime_arm, nuno_checkpoint_due, nuno_signal_agreed
  use step_monitor, only: energy_add_work, energy_integrals_start, energy_set_mgx0, step_enter_window, progress_start, &
                          progress_output_written, progress_said, progress_stretch_warned
  use cloth_model, only: model_enter_window
  use newton_policy, only: newton_enter_window
  use newton_start, only: newton_start_reset
  use contact_forces, only: contact_on, contact_summary
  use contact_solver, only: contact_observe
  use failure_text, only: signal_name, failure_reason, report_io_error
  use strings, only: num => real_brief, inum => itoa
  use run_checkpoint, only: run_counts, take_checkpoint, keep_restart_point, solver_restore, restart_state_init, &
                            restart_output_written
  use provenance, only: write_run_info
  use solver_setup, only: check_decomposition, solver_create, solver_destroy
  implicit none
  private
  public :: app_ctx, solver_create, solver_destroy, solver_run, check_decomposition, solver_restore
  public :: restart_state_init      ! module run_checkpoint: main's -nuno_checkpoint_walltime
  public :: advance_window          ! module identify_adjoint: its forward run's windows
  public :: enter_window            ! module identify_adjoint: the constraint state of an adjoint window

contains

  ! ------------------------------------------------------------- time loop

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
    ! the window's constrained nodes, and whether one moves (module cloth_model)
    call model_enter_window(ctx%model, ctx%cs, moving=loc(2) > 0.0_rp)
    if (ctx%use_reduced) then
      PetscCall(reduced_set_fixed(ctx%red, ctx%model%fixed, ierr))
    end if
    ! The Newton start's kept states end here where the state jumps (a
    ! keyframe's start, a constraint's target moved); elsewhere they go on
    ! across the window's start (a checkpoint keeps them for a restart:
    ! take_checkpoint, solver_restore). Forgetting them at every window
    ! cost 12 % of hang's 1 s at 257 x 257 (1100 instead of 1005 Newton
    ! iterations, 4697 instead of 4001 inner ones).
    if (loc(3) > 0.0_rp) call newton_start_reset(ctx%newton%start)
    dke = loc(1)
  end subroutine enter_window

  !> Advance the solution from ta to tb, the window between two stop times
  !> (output, observed, keyframe and release times): with enter, first
  !> the window's constraint state (enter_window; the work of its impulse
  !> added to the constraint work) and a fresh start of the integrator;
  !> then steps of h (dt for fixed steps; the adaptive step carried from
  !> the window before), the last one clipped to end on tb. On return t
  !> and reason are the TS's (t is tb up to round-off unless the solve
  !> stopped early: the caller decides what that means) and h the step
  !> the window began with. With out, the wall-clock checkpoints
  !> (-nuno_checkpoint_walltime) due inside the window are written into
  !> it between steps; a failed write ends the window early with
  !> ctx%io_error set. The one window loop of the run (solver_run) and of
  !> identification and control (module identify_adjoint). Collective.
  subroutine advance_window(ctx, t, tb, h, enter, reason, ierr, out)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(inout) :: t
    real(rp), intent(in) :: tb
    real(rp), intent(inout) :: h
    logical, intent(in) :: enter
    TSConvergedReason, intent(out) :: reason
    PetscErrorCode, intent(out) :: ierr
    type(output_file), intent(inout), optional :: out
    real(rp) :: dke, hnext
    integer :: due

    ierr = 0
    call step_enter_window(ctx%step, tstop=tb)
    if (enter) then
      call enter_window(ctx, t, tb, dke, ierr)
      if (ierr /= 0) return
      call energy_add_work(ctx%energy, dke)
      PetscCall(TSRestartStep(ctx%ts, ierr))
    end if
    PetscCall(TSSetMaxTime(ctx%ts, tb, ierr))
    if (ctx%step%fixed_step) h = ctx%step%dt
    if (t + 1.01_rp * h >= tb) h = tb - t
    PetscCall(TSSetTimeStep(ctx%ts, h, ierr))
    do
      PetscCall(TSSolve(ctx%ts, ctx%u, ierr))
      PetscCall(TSGetConvergedReason(ctx%ts, reason, ierr))
      PetscCall(TSGetTime(ctx%ts, t, ierr))
      ! -nuno_checkpoint_walltime, due after the step just taken (agreed by
      ! the post-step, src/solver/nuno_signals.c): the restart point of the last
      ! output step (keep_restart_point; before the first one, this step's
      ! state with its energy integrals), h the step the TS takes next.
      ! Where the post-step ended TSSolve for it (due = 2), the window goes
      ! on with the same TS: no new window, the step the TS chose.
      due = int(nuno_checkpoint_due())
      if (due == 0) exit
      if (present(out)) then
        PetscCall(TSGetTimeStep(ctx%ts, hnext, ierr))
        call take_checkpoint(ctx, out, t, hnext, 'wall time', ierr, restart_point=.true.)
        if (ierr /= 0) then
          ! a failed write ends the run (solver_run reads io_error)
          ierr = 0
          if (len_trim(ctx%io_error) == 0) ctx%io_error = 'the wall-clock checkpoint at t = '//num(t)//' failed'
          exit
        end if
      end if
      if (due /= 2) exit
    end do
  end subroutine advance_window

  !> Integrate from t = 0 (or from the checkpoint of solver_restore) to
  !> t_end, writing every output step and the checkpoints (every
  !> checkpoint_interval at an output step, every -nuno_checkpoint_walltime
  !> after a step, on SIGTERM/SIGINT, and at the end). On a failed step,
  !> status says why and ierr = 0 (the output so far is kept); ierr /= 0
  !> is left for PETSc or HDF5 errors. -ts_max_steps ends the run early but
  !> complete, with the state of its last step written. Collective.
  subroutine solver_run(ctx, out, status, ierr)
    type(app_ctx), intent(inout), target :: ctx
    type(output_file), intent(inout), target :: out
    character(len=*), intent(out) :: status
    PetscErrorCode, intent(out) :: ierr
    real(rp), allocatable :: events(:)
    real(rp) :: t, tstop, h, dke, eps, unorm, wall, counts(5)
    integer :: iout, ie
    logical :: at_max_steps
    TSConvergedReason :: reason
    character(len=900) :: msg
    character(len=256) :: reasonname
    character(len=512) :: errmsg

    status = 'complete'
    call progress_start(ctx%progress, wall_before=ctx%restart%wall_before)
    call write_run_info(ctx, out, ierr)
    if (io_failed()) return
    call nuno_walltime_arm(real(ctx%restart%checkpoint_walltime, c_double))
    events = constraint_events(ctx%cs, ctx%step%t_end)
    eps = 1.0e-12_rp * max(1.0_rp, ctx%step%t_end)
    h = ctx%step%dt
    t = 0.0_rp
    ie = 1
    iout = 0
    at_max_steps = .false.
    if (ctx%restart%restarted) then
      ! Go on from the checkpoint: its state, time and step number are in
      ! the TS (solver_restore); the next output step is the first after t.
      t = ctx%restart%t_restart
      if (.not. ctx%step%fixed_step) h = ctx%restart%h_restart
      ! The next output step is the first after the last one written.
      iout = 1
      do while (output_time(iout) <= ctx%progress%t_written + eps .and. real(iout, rp) * ctx%cfg%output%output_interval < ctx%step%t_end)
        iout = iout + 1
      end do
      call energy_integrals_start(ctx%energy, t)
      ! A wall-clock checkpoint after a window's last step is at the
      ! window's end, before solver_run wrote that output step: as the run
      ! did next, put t onto it and write it.
      tstop = next_stop(t - 1.0e3_rp * eps)
      if (abs(t - tstop) <= 1.0e3_rp * eps) then
        t = tstop
        call energy_integrals_start(ctx%energy, t)
        PetscCall(TSSetTime(ctx%ts, t, ierr))
        if (abs(t - output_time(iout)) <= eps) then
          call write_output(ctx, out, t, ierr)
          if (io_failed()) return
          iout = iout + 1
        end if
      end if
    else
      tstop = next_stop(t)
      call enter_window(ctx, t, tstop, dke, ierr)
      if (ierr /= 0) return
      call energy_integrals_start(ctx%energy, 0.0_rp)
      call write_output(ctx, out, t, ierr)
      if (io_failed()) return
      iout = 1
    end if

    do while (t < ctx%step%t_end - eps .and. .not. at_max_steps)
      tstop = next_stop(t)
      ! The first window was entered above, before the output step at t = 0.
      call advance_window(ctx, t, tstop, h, t > 0.0_rp, reason, ierr, out)
      if (ierr /= 0) return
      if (len_trim(ctx%io_error) > 0) then
        ! A wall-clock checkpoint could not be written (advance_window), or
        ! the monitor's stall check ended the run.
        status = 'failed: '//trim(ctx%io_error)
        exit
      end if
      PetscCall(VecNorm(ctx%u, NORM_INFINITY, unorm, ierr))
      if (reason >= 0 .and. nuno_signal_agreed() /= 0) then
        ! SIGTERM/SIGINT: every rank finished the same step; keep its state
        ! and a checkpoint to continue from (the restart point of the last
        ! output step: keep_restart_point).
        if (t > ctx%progress%t_written) then
          call write_output(ctx, out, t, ierr)
          if (io_failed()) return
        end if
        PetscCall(TSGetTimeStep(ctx%ts, h, ierr))
        call take_checkpoint(ctx, out, t, h, trim(signal_name(nuno_signal_agreed())), ierr, restart_point=.true.)
        if (io_failed()) return
        write(msg, '(a,es12.5,a)') trim(signal_name(nuno_signal_agreed()))//' at t = ', t, &
          ': the run stopped after that step, with its state and a checkpoint written (continue it with'// &
          ' -nuno_restart '//trim(ctx%cfg%output%output_file)//')'
        status = 'interrupted: '//trim(msg)
        if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: interrupted: '//trim(msg)
        exit
      end if
      if (reason < 0 .or. unorm /= unorm .or. unorm > huge(1.0_rp)) then
        call failure_reason(ctx, reason, t, msg)
        status = 'failed: '//trim(msg)
        if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(msg)
        exit
      end if
      ! -ts_max_steps: PETSc counts steps over all TSSolve calls and stops
      ! with TS_CONVERGED_ITS, possibly inside a window: a clean end.
      at_max_steps = reason == TS_CONVERGED_ITS
      if (abs(t - tstop) > 1.0e3_rp * eps .and. .not. at_max_steps) then
        write(reasonname, '(a,es12.5,a,es12.5)') 'time integration stopped at t = ', t, ' before ', tstop
        status = 'failed: '//trim(reasonname)
        if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(reasonname)
        exit
      end if
      if (abs(t - tstop) <= 1.0e3_rp * eps) then
        t = tstop
        PetscCall(TSSetTime(ctx%ts, t, ierr))
        PetscCall(TSGetTimeStep(ctx%ts, h, ierr))
      end if
      if (abs(t - output_time(iout)) <= eps) then
        call write_output(ctx, out, t, ierr)
        if (io_failed()) return
        iout = iout + 1
        if (t < ctx%step%t_end - eps) then
          call keep_restart_point(ctx, out, t, h, ierr)
          if (ierr /= 0) return
        end if
        if (ctx%cfg%output%checkpoint_interval > 0.0_rp .and. t < ctx%step%t_end - eps .and. &
            t >= ctx%restart%t_checkpoint + ctx%cfg%output%checkpoint_interval - eps) then
          call take_checkpoint(ctx, out, t, h, 'checkpoint_interval', ierr)
          if (io_failed()) return
        end if
      else if (at_max_steps .and. t > ctx%progress%t_written) then
        ! Off the output grid (inside a window, or at a keyframe): the last state.
        call write_output(ctx, out, t, ierr)
        if (io_failed()) return
      end if
      if (at_max_steps .and. t < ctx%step%t_end - eps .and. ctx%rank == 0) &
        write(output_unit, '(a,es13.5e2,a)') 'nuno: -ts_max_steps '//inum(ctx%step%max_steps)// &
          ' reached at t =', t, ': the run ends here, complete, with this state written'
    end do
    ! The end of a complete run: a checkpoint, so that it can be continued
    ! to a later t_end.
    if (status == 'complete' .and. .not. ctx%restart%checkpoint_current) then
      call take_checkpoint(ctx, out, t, h, 'end', ierr)
      if (io_failed()) return
    end if

    ! The run's wall time, the same value on every rank (an attribute).
    wall = MPI_Wtime() - ctx%progress%wall0
    call MPI_Allreduce(MPI_IN_PLACE, wall, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call output_write_wall_time(out, wall, ierr, errmsg)
    ! and the steps retried smaller (rejected): with fixed steps, those not dt
    if (ierr == 0) call run_counts(ctx, counts, ierr)
    if (ierr == 0) call output_write_retried_steps(out, nint(counts(2)), ierr, errmsg)
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      if (io_failed()) return
    end if
    call final_summary(ctx, status, wall, ierr)

  contains

    !> An output or checkpoint write failed on some rank (a full disk):
    !> agreed by every rank and reported in one line already, so the run
    !> ends collectively as failed (ierr = 0); other errors stay errors.
    logical function io_failed()
      io_failed = ierr /= 0
      if (io_failed .and. len_trim(ctx%io_error) > 0) then
        status = 'failed: '//trim(ctx%io_error)
        ierr = 0
      end if
    end function io_failed

    !> Output times: multiples of output_interval, and t_end.
    real(rp) function output_time(k)
      integer, intent(in) :: k
      output_time = min(real(k, rp) * ctx%cfg%output%output_interval, ctx%step%t_end)
    end function output_time

    !> Next time at which the integrator must stop after t.
    real(rp) function next_stop(tt)
      real(rp), intent(in) :: tt
      integer :: m
      next_stop = output_time(iout)
      do m = 1, size(events)
        if (events(m) > tt + eps) next_stop = min(next_stop, events(m))
      end do
    end function next_stop

  end subroutine solver_run

  !> One closing line on rank 0 (stdout; a failure's reason is already on
  !> stderr) with the totals, the retries and the wall time.
  subroutine final_summary(ctx, status, wall, ierr)
    type(app_ctx), intent(inout) :: ctx
    character(len=*), intent(in) :: status
    real(rp), intent(in) :: wall
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: steps, rejects, fails
    real(rp) :: t, c(5)
    integer :: kw

    call run_counts(ctx, c, ierr)
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
      if (ctx%step%fixed_step .and. rejects > 0) write(output_unit, '(a,i0,a)', advance='no') &
        '; fixed steps: ', rejects, ' retried smaller, so not every step was dt (/run retried_steps)'
      write(output_unit, '(a)') ''
      flush(output_unit)
    end if
  end subroutine final_summary

  !> Diagnostics and one output step; a one-line summary on rank 0.
  subroutine write_output(ctx, out, t, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    type(state_diagnostics_t) :: d
    type(output_record) :: rec
    PetscInt :: steps, rejects, nits, lits, fails
    character(len=512) :: errmsg
    integer :: j
    real(rp) :: wall, rate, eta, c(5)

    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, ctx%u, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, ctx%u, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    call state_diagnostics(ctx%lat, u, ctx%model%gravity, ctx%comm, d, ierr)
    if (.not. ctx%progress%stretch_warned .and. ctx%cfg%output%stretch_limit > 0.0_rp) call check_stretch(ctx, u, t)
    do j = ctx%lat%ys, ctx%lat%ye
      ctx%xout(:, :, j) = u(0:2, :, j)
      ctx%vout(:, :, j) = u(3:5, :, j)
    end do
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
    if (t == 0.0_rp) call energy_set_mgx0(ctx%energy, d%mgx)
    ! the state's contact record (the monitor's after a step; at t = 0,
    ! before any step, made here: the barrier energy of the start)
    if (contact_on(ctx%contact)) then
      PetscCall(contact_observe(ctx, t, ctx%u, ierr))
    end if

    call run_counts(ctx, c, ierr)
    if (ierr /= 0) return
    steps = int(c(1), kind(steps))
    rejects = int(c(2), kind(rejects))
    nits = int(c(3), kind(nits))
    lits = int(c(4), kind(lits))
    fails = int(c(5), kind(fails))
    rec%time = t
    rec%kinetic = d%kinetic
    rec%stretch = d%stretch
    rec%bend = d%bend
    rec%dissipated = ctx%energy%dissipated
    rec%external_work = ctx%energy%work_constraints + (d%mgx - ctx%energy%mgx0)
    rec%momentum = d%momentum
    rec%angular_momentum = d%angular_momentum
    rec%length = d%length
    rec%flatness = d%flatness
    if (contact_on(ctx%contact)) then
      ! The barrier energy is a potential energy of the balance, the
      ! friction work a dissipation and the moving obstacles' work an
      ! external work (docs/model.md section 10): the state's record of the
      ! contact monitor (module contact_solver).
      associate (c => contact_summary(ctx%contact))
        rec%barrier = c%energy
        rec%dissipated = rec%dissipated + c%friction_work
        rec%external_work = rec%external_work + c%obstacle_work
        rec%contact_active = c%active
        rec%contact_force = c%force
        rec%normal_force = c%normal_force
        rec%friction_work = c%friction_work
        rec%min_gap = c%min_gap
        rec%min_gap_run = c%min_gap_run
        rec%states_checked = c%states_checked
      end associate
    end if
    rec%steps = steps
    rec%rejected_steps = rejects
    rec%newton_iterations = nits
    rec%linear_iterations = lits
    wall = MPI_Wtime() - ctx%progress%wall0
    rec%wall_time = wall
    if (ctx%cfg%output%write_velocity) then
      call output_write_step(out, rec, ctx%xout, ierr, errmsg, v=ctx%vout)
    else
      call output_write_step(out, rec, ctx%xout, ierr, errmsg)
    end if
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      return
    end if
    call progress_output_written(ctx%progress, t)
    call restart_output_written(ctx%restart)
    ! Progress for a person and for awk: every field has a blank before it
    ! (es13.5e2 of a negative value still starts with one; the integer
    ! widths hold 10^8 steps), rates from the start of the run. Flushed: a
    ! redirected run shows its progress and keeps it when killed. The order
    ! up to 'linear' is the one bench/solver.py parses.
    ! Before any step (t = 0) there is no rate yet: '-' for the rate and
    ! the ETA (same fields, so awk's columns stay).
    if (ctx%rank == 0) then
      write(output_unit, '(a,es12.5e2, a,i9, a,i6, a,i9, a,i11, a,i6, 2(a,es13.5e2), a,es10.3e2)', advance='no') &
        't =', t, '  steps', steps, '  rejected', rejects, '  newton', nits, '  linear', lits, &
        '  retries', fails, '  E_kin', d%kinetic, &
        '  E_total', d%kinetic + d%stretch + d%bend + rec%barrier + rec%dissipated - rec%external_work, &
        '  wall_s', wall
      if (t > 0.0_rp .and. wall > 0.0_rp) then
        rate = t / wall
        eta = (ctx%step%t_end - t) / rate
        write(output_unit, '(2(a,es10.3e2))') '  sim_per_wall_s', rate, '  eta_s', eta
      else
        write(output_unit, '(a)') '  sim_per_wall_s -  eta_s -'
      end if
      flush(output_unit)
      call progress_said(ctx%progress)
    end if
  end subroutine write_output

  !> Warn once (stderr, rank 0) when a link has stretched or shrunk beyond
  !> stretch_limit times its rest length: a model far outside its regime
  !> (a spun sheet, a step too large) that would otherwise complete silently.
  !> At output steps only. Collective.
  subroutine check_stretch(ctx, u, t)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: u(0:, 0:, ctx%lat%gys:)
    real(rp), intent(in) :: t
    real(rp) :: r(2), g(2), lim
    integer :: atmax(3), atmin(3), loc(3), glob(3), mpierr, iq, jq
    character(len=16) :: what

    call link_stretch_extremes(ctx%lat, u, r(1), atmax, r(2), atmin)
    r(2) = 1.0_rp / max(r(2), tiny(1.0_rp))      ! shrink as a factor > 1
    call MPI_Allreduce(r, g, 2, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, mpierr)
    lim = ctx%cfg%output%stretch_limit
    if (g(1) <= lim .and. g(2) <= lim) return
    call progress_stretch_warned(ctx%progress)
    loc = -1
    if (g(1) > lim) then
      if (r(1) == g(1)) loc = atmax
      what = 'stretched'
    else
      if (r(2) == g(2)) loc = atmin
      what = 'compressed'
    end if
    call MPI_Allreduce(loc, glob, 3, MPI_INTEGER, MPI_MAX, ctx%comm, mpierr)
    iq = glob(1) + link_dir(1, glob(3))
    jq = glob(2) + link_dir(2, glob(3))
    if (ctx%rank == 0) then
      write(error_unit, '(a)') 'nuno: warning: at t = '//num(t)//' the link from node ('//inum(glob(1))//', '// &
        inum(glob(2))//') to ('//inum(iq)//', '//inum(jq)//') is '//trim(what)//' by a factor '// &
        num(merge(g(1), g(2), g(1) > lim))//', beyond stretch_limit = '//num(lim)// &
        ' (&output); the model is far outside its regime: check dt and the scene (warned once)'
      flush(error_unit)
    end if
  end subroutine check_stretch

end module timestepping
