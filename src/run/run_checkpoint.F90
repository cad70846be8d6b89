! SPDX-License-Identifier: BSD-2-Clause
!> Checkpoints and restarts of the solver (docs/design.md, "Checkpoints"):
!> what a checkpoint holds, the restart point kept at each output step,
!> and the restore of a checkpoint into the solver. The run driver's
!> record of them, restart_state_t (the run's, not the solver's: main
!> holds it and passes it to solver_restore and solver_run), is written
!> only here.
module run_checkpoint
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_double
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use output, only: output_file, checkpoint_t, output_write_checkpoint, output_steps, checkpoint_judge_t, named_value_t
  use app_context, only: app_ctx
  use step_settings, only: step_max_steps
  use energy_integrals, only: energy_integrals_restore, energy_totals
  use run_progress, only: progress_restore, progress_wall, progress_t_written, progress_stretch_warned
  use reduced, only: reduced_restore_floor, reduced_its, reduced_floor_est
  use process_models, only: pm_list_checkpoint, pm_list_restore, pm_list_check_state
  use newton_state, only: newton_set_failures_before
  use newton_start, only: newton_start_count, newton_start_get, newton_start_put
  use failure_text, only: report_io_error
  use strings, only: inum => itoa
  implicit none
  private
  public :: run_counts, solver_restore, take_checkpoint, keep_restart_point
  public :: restart_state_t, restart_state_init, restart_output_written, restart_state_free
  public :: state_to_strips
  public :: restart_judge_t, restart_judge, checkpoint_pm_names
  public :: restart_file, restart_wall_before, restart_walltime, restart_from, restart_t_checkpoint, &
            restart_current

  !> Checkpoints and restarts (docs/design.md, "Checkpoints").
  type :: restart_state_t
    private
    character(len=:), allocatable :: file       !< the file the run writes, its checkpoints' (a restart: the one it continues)
    real(rp) :: checkpoint_walltime = 0         !< -nuno_checkpoint_walltime: a checkpoint after each [s]; 0: none
    !> time of the last checkpoint written or restarted from [time]; the
    !> run's start at first, so that the first checkpoint_interval
    !> checkpoint comes one interval after it
    real(rp) :: t_checkpoint = 0
    logical :: restarted = .false.              !< continues a checkpoint (solver_restore)
    logical :: checkpoint_current = .false.     !< the last checkpoint was written after the last output step
    real(rp) :: t_restart = 0, h_restart = 0    !< its time and next step [time]
    real(rp) :: wall_before = 0                 !< wall-clock seconds of the runs before this one [s]
    !> The restart point: the state at the last output step and what a
    !> checkpoint of it holds (keep_restart_point), written by the
    !> checkpoints that come between output steps (SIGTERM, SIGINT, the wall
    !> clock), so that the file's series and the checkpoint go on from the
    !> same step.
    logical :: rp_valid = .false.
    type(checkpoint_t) :: rp_ck
    real(rp), allocatable :: rp_x(:, :, :), rp_v(:, :, :)  !< (3, 0:nx-1, ys:ye) [length], [length/time]
    !> rejected steps, Newton and linear iterations and retries of the runs
    !> before this one (the step count goes on in the TS itself)
    real(rp) :: counts_before(5) = 0
  end type restart_state_t

  !> A restart's judgement of the checkpoint's state before the file
  !> changes (module output's output_reopen): the process models'
  !> check_state hooks (contact: no node inside an obstacle as the input
  !> now describes them). Made by restart_judge.
  type, extends(checkpoint_judge_t) :: restart_judge_t
    private
    type(app_ctx), pointer :: ctx => null()
  contains
    procedure :: judge => judge_restart
  end type restart_judge_t

contains

  !> The judge of a restart's checkpoint for the solver ctx.
  function restart_judge(ctx) result(j)
    type(app_ctx), intent(in), target :: ctx
    type(restart_judge_t) :: j
    j%ctx => ctx
  end function restart_judge

  !> The checkpoint's state at t, this rank's strips x, v (3, nx, ym): the
  !> process models' refusal (one line, the same on every rank) or none.
  !> Collective.
  subroutine judge_restart(this, t, x, v, ierr, errmsg)
    class(restart_judge_t), intent(inout) :: this
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    call pm_list_check_state(this%ctx%pms, this%ctx%lat, t, x, this%ctx%comm, ierr, errmsg)
  end subroutine judge_restart

  !> The names and kinds of the process models' named values a checkpoint
  !> holds (module output reads them where the file has them).
  subroutine checkpoint_pm_names(ctx, names)
    type(app_ctx), intent(in) :: ctx
    type(named_value_t), allocatable, intent(out) :: names(:)
    call pm_list_checkpoint(ctx%pms, names)
  end subroutine checkpoint_pm_names

  !> Accepted steps, rejected steps, Newton iterations, linear iterations
  !> and retried Newton solves since t = 0, a restart's earlier runs
  !> included (the same on every rank).
  subroutine run_counts(ctx, r, c, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(in) :: r
    real(rp), intent(out) :: c(5)
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: steps, rejects, nits, lits, fails

    PetscCall(TSGetStepNumber(ctx%ts, steps, ierr))
    PetscCall(TSGetStepRejections(ctx%ts, rejects, ierr))
    PetscCall(TSGetSNESIterations(ctx%ts, nits, ierr))
    PetscCall(TSGetKSPIterations(ctx%ts, lits, ierr))
    PetscCall(TSGetSNESFailures(ctx%ts, fails, ierr))
    if (ctx%use_reduced) lits = reduced_its(ctx%red)        ! the outer KSP is preonly: count the inner iterations
    c = [real(steps, rp), real(rejects, rp), real(nits, rp), real(lits, rp), real(fails, rp)] + r%counts_before
    c(1) = real(steps, rp)                         ! the TS goes on counting from the checkpoint's step
  end subroutine run_counts

  !> Continue from a checkpoint: the state strips x, v (3, 0:nx-1, ys:ye)
  !> into the state vector, the TS's time and step number, the integrals
  !> and counters into the context. solver_run then goes on from ck%time.
  !> Collective.
  subroutine solver_restore(ctx, r, ck, x, v, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(checkpoint_t), intent(in) :: ck
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: step

    PetscCall(strips_to_state(ctx, x, v, ctx%u, ierr))
    step = int(ck%counters(1), kind(step))
    PetscCall(TSSetStepNumber(ctx%ts, step, ierr))
    PetscCall(TSSetTime(ctx%ts, ck%time, ierr))
    r%restarted = .true.
    r%t_restart = ck%time
    r%h_restart = ck%dt_next
    r%t_checkpoint = ck%time
    r%wall_before = ck%wall_time
    r%counts_before = [0.0_rp, ck%counters(2:5)]
    call newton_set_failures_before(ctx%newton, nint(ck%counters(5)))
    call energy_integrals_restore(ctx%energy, ck%dissipated, ck%work_constraints, ck%mgx0)
    ! the process models' state (each takes its own named values)
    if (allocated(ck%pm_values)) call pm_list_restore(ctx%pms, ck%pm_values)
    call progress_restore(ctx%progress, t_written=ck%t_written, stretch_warned=ck%stretch_warned /= 0)
    ! The first Newton iteration's inner tolerance takes the round-off floor
    ! of the last step's assembly (set_newton_forcing): without it the
    ! restart's first step solved to another tolerance and the run
    ! differed from the one it continues by 1e-13 m (hang 65 x 65).
    if (ctx%use_reduced) call reduced_restore_floor(ctx%red, ck%newton_floor)
    ! A checkpoint at an output step is the restart point until the next one.
    if (ck%time == ck%t_written) then
      r%rp_ck = ck
      r%rp_x = x
      r%rp_v = v
      r%rp_valid = .true.
    end if
    ! The Newton start's states: the checkpoint's, then the ones before it
    if (ck%start_count > 0) then
      block
        type(tVec) :: w
        integer :: kk, nk
        logical :: cmp
        PetscErrorCode :: err
        nk = ck%start_count + 1
        cmp = ck%start_compare /= 0
        PetscCall(newton_start_put(ctx%start, 1, ctx%u, ck%time, nk, cmp, ck%start_nc_prev, ierr))
        PetscCall(DMGetGlobalVector(ctx%da, w, ierr))
        do kk = 1, nk - 1
          PetscCall(strips_to_state(ctx, ck%start_x(:, :, :, kk), ck%start_v(:, :, :, kk), w, ierr))
          call newton_start_put(ctx%start, kk + 1, w, ck%start_t(kk), nk, cmp, ck%start_nc_prev, ierr)
          if (ierr /= 0) exit
        end do
        ! (a failed put's error code, not the restore's, is the answer)
        call DMRestoreGlobalVector(ctx%da, w, err)
        if (ierr == 0) ierr = err
      end block
    end if
  end subroutine solver_restore

  !> Write a checkpoint of the state at t, h being the step the run takes
  !> next (module output, output_write_checkpoint), and say so on stdout.
  !> restart_point: the checkpoint of the last output step instead
  !> (keep_restart_point; the state at t where there is none yet), for the
  !> checkpoints between output steps. Collective.
  subroutine take_checkpoint(ctx, r, out, t, h, reason, restart_point, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t, h
    character(*), intent(in) :: reason
    logical, intent(in) :: restart_point
    PetscErrorCode, intent(out) :: ierr
    type(checkpoint_t) :: ck
    character(len=512) :: errmsg
    logical :: point

    point = restart_point .and. r%rp_valid
    if (point) then
      ck = r%rp_ck
    else
      PetscCall(state_to_strips(ctx, ctx%u, ctx%xout, ctx%vout, ierr))
      call fill_checkpoint(ctx, r, t, h, ck, ierr)
      if (ierr /= 0) return
    end if
    ! Attributes must be equal on all ranks: the slowest rank's clock.
    ck%wall_time = progress_wall(ctx%progress)
    call MPI_Allreduce(MPI_IN_PLACE, ck%wall_time, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    ck%reason = reason
    if (point) then
      call output_write_checkpoint(out, ck, r%rp_x, r%rp_v, ierr, errmsg)
    else
      call output_write_checkpoint(out, ck, ctx%xout, ctx%vout, ierr, errmsg)
    end if
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      return
    end if
    r%t_checkpoint = ck%time
    ! (a restart point is older than the output steps written since)
    r%checkpoint_current = .not. point .or. ck%time >= progress_t_written(ctx%progress)
    if (ctx%rank == 0) then
      write(output_unit, '(a,i0,a,es12.5e2,a)') 'nuno: checkpoint ', ck%sequence, ' at t =', ck%time, &
        ' ('//trim(reason)//'), '//inum(int(ck%n_output_steps, kind(step_max_steps(ctx%step))))//' output steps'
      flush(output_unit)
    end if
  end subroutine take_checkpoint

  !> ck of the state at t (in ctx%u), h being the next step: everything
  !> but the wall time, the reason and (unless set: the output file's count
  !> at the write) the output steps. Collective.
  subroutine fill_checkpoint(ctx, r, t, h, ck, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(in) :: r
    real(rp), intent(in) :: t, h
    type(checkpoint_t), intent(inout) :: ck
    PetscErrorCode, intent(out) :: ierr

    ck%time = t
    ck%dt_next = h
    call energy_totals(ctx%energy, ck%dissipated, ck%work_constraints, ck%mgx0)
    ! the process models' state as named values (module process_models)
    call pm_list_checkpoint(ctx%pms, ck%pm_values)
    ck%t_written = progress_t_written(ctx%progress)
    call run_counts(ctx, r, ck%counters, ierr)
    if (ierr /= 0) return
    ck%stretch_warned = merge(1, 0, progress_stretch_warned(ctx%progress))
    ! the next step's first inner tolerance depends on it (set_newton_forcing)
    if (ctx%use_reduced) ck%newton_floor = reduced_floor_est(ctx%red)
    PetscCall(TSGetType(ctx%ts, ck%ts_type, ierr))
    PetscCall(checkpoint_start_states(ctx, t, ck, ierr))
  end subroutine fill_checkpoint

  !> Keep the restart point: the state at the output step just written
  !> (of the step that reached or passed it: t, h the next step) and its
  !> checkpoint, for the checkpoints written between output steps. A
  !> restart from it starts afresh what the reduced solve carries across
  !> output steps and no checkpoint holds (a preconditioner kept for pc_lag
  !> assemblies, the inner guesses' last solves, the Newton remainder):
  !> the run that went through to round-off (until issue 48 the run
  !> started them afresh at every output step too, and the restart was
  !> bitwise, but output_interval changed the solution). Costs a copy of
  !> the state and the Newton start's kept states an output step.
  !> Collective.
  subroutine keep_restart_point(ctx, r, out, t, h, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(in) :: out
    real(rp), intent(in) :: t, h
    PetscErrorCode, intent(out) :: ierr

    r%rp_valid = .false.
    if (.not. allocated(r%rp_x)) allocate(r%rp_x, mold=ctx%xout)
    if (.not. allocated(r%rp_v)) allocate(r%rp_v, mold=ctx%vout)
    PetscCall(state_to_strips(ctx, ctx%u, r%rp_x, r%rp_v, ierr))
    call fill_checkpoint(ctx, r, t, h, r%rp_ck, ierr)
    if (ierr /= 0) return
    r%rp_ck%n_output_steps = output_steps(out)
    r%rp_valid = .true.
  end subroutine keep_restart_point

  !> The Newton start's kept states before t (at most three, newest first)
  !> into ck, for a restart to start its next steps as this run does
  !> (module newton_start). Collective.
  subroutine checkpoint_start_states(ctx, t, ck, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    type(checkpoint_t), intent(inout) :: ck
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: w
    integer :: n, k, m
    logical :: compare
    real(rp) :: nc_prev, tk
    PetscErrorCode :: err

    ierr = 0
    call newton_start_count(ctx%start, n, compare, nc_prev)
    ck%start_count = 0
    ck%start_compare = merge(1, 0, compare)
    ck%start_nc_prev = nc_prev
    if (allocated(ck%start_x)) deallocate(ck%start_x)
    if (allocated(ck%start_v)) deallocate(ck%start_v)
    allocate(ck%start_x(3, ctx%lat%nx, ctx%lat%ye - ctx%lat%ys + 1, 3), ck%start_v(3, ctx%lat%nx, ctx%lat%ye - ctx%lat%ys + 1, 3))
    if (n == 0) return
    PetscCall(DMGetGlobalVector(ctx%da, w, ierr))
    do k = 1, n
      if (ck%start_count == 3) exit
      call newton_start_get(ctx%start, k, w, tk, ierr)
      if (ierr /= 0) exit
      ! (the step's own state, if pushed already, is the checkpoint's state)
      if (tk >= t) cycle
      m = ck%start_count + 1
      ck%start_count = m
      ck%start_t(m) = tk
      PetscCall(state_to_strips(ctx, w, ck%start_x(:, :, :, m), ck%start_v(:, :, :, m), ierr))
    end do
    ! (a failed get's error code, not the restore's, is the answer)
    call DMRestoreGlobalVector(ctx%da, w, err)
    if (ierr == 0) ierr = err
  end subroutine checkpoint_start_states

  !> The owned rows of a global state vector (ctx%da) into strips
  !> x, v (3, nx, ym) [length], [length/time], as module output writes them.
  subroutine state_to_strips(ctx, u, x, v, ierr)
    type(app_ctx), intent(in) :: ctx
    type(tVec), intent(in) :: u
    real(rp), intent(out) :: x(:, :, :), v(:, :, :)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: ua(:, :, :)
    integer :: j

    PetscCall(DMDAVecGetArrayReadF90(ctx%da, u, ua, ierr))
    do j = ctx%lat%ys, ctx%lat%ye
      x(:, :, j - ctx%lat%ys + 1) = ua(0:2, :, j)
      v(:, :, j - ctx%lat%ys + 1) = ua(3:5, :, j)
    end do
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, u, ua, ierr))
  end subroutine state_to_strips

  !> The reverse of state_to_strips: strips x, v (3, nx, ym) into the owned
  !> rows of the global state vector u.
  subroutine strips_to_state(ctx, x, v, u, ierr)
    type(app_ctx), intent(in) :: ctx
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    type(tVec), intent(inout) :: u
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: ua(:, :, :)
    integer :: j

    PetscCall(DMDAVecGetArrayF90(ctx%da, u, ua, ierr))
    do j = ctx%lat%ys, ctx%lat%ye
      ua(0:2, :, j) = x(:, :, j - ctx%lat%ys + 1)
      ua(3:5, :, j) = v(:, :, j - ctx%lat%ys + 1)
    end do
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, u, ua, ierr))
  end subroutine strips_to_state

  ! ---------------------------------------------------- the restart record

  !> The run's checkpoints (main): the file they go to (output_file, or the
  !> file a restart continues: -nuno_restart), checkpoint_walltime
  !> (-nuno_checkpoint_walltime) [s], 0 for none.
  subroutine restart_state_init(r, output_file, checkpoint_walltime)
    type(restart_state_t), intent(inout) :: r
    character(len=*), intent(in) :: output_file
    real(rp), intent(in) :: checkpoint_walltime
    r%file = output_file
    r%checkpoint_walltime = checkpoint_walltime
  end subroutine restart_state_init

  !> The file the run writes, its checkpoints' (-nuno_restart continues it).
  pure function restart_file(r) result(f)
    type(restart_state_t), intent(in) :: r
    character(len=:), allocatable :: f
    f = r%file
  end function restart_file

  !> An output step was written (solver_run): the last checkpoint is now
  !> older than it, so a complete run writes one at its end.
  subroutine restart_output_written(r)
    type(restart_state_t), intent(inout) :: r
    r%checkpoint_current = .false.
  end subroutine restart_output_written

  !> The restart point's state.
  subroutine restart_state_free(r)
    type(restart_state_t), intent(inout) :: r
    if (allocated(r%rp_x)) deallocate(r%rp_x)
    if (allocated(r%rp_v)) deallocate(r%rp_v)
    r%rp_valid = .false.
  end subroutine restart_state_free

  !> Wall-clock seconds of the runs a restart continues [s] (0: none).
  pure real(rp) function restart_wall_before(r)
    type(restart_state_t), intent(in) :: r
    restart_wall_before = r%wall_before
  end function restart_wall_before

  !> -nuno_checkpoint_walltime [s] (0: none).
  pure real(rp) function restart_walltime(r)
    type(restart_state_t), intent(in) :: r
    restart_walltime = r%checkpoint_walltime
  end function restart_walltime

  !> restarted: the run continues a checkpoint (solver_restore), at time t
  !> with the step h its run took next [time].
  pure subroutine restart_from(r, restarted, t, h)
    type(restart_state_t), intent(in) :: r
    logical, intent(out) :: restarted
    real(rp), intent(out) :: t, h
    restarted = r%restarted
    t = r%t_restart
    h = r%h_restart
  end subroutine restart_from

  !> The time of the last checkpoint written or restarted from [time].
  pure real(rp) function restart_t_checkpoint(r)
    type(restart_state_t), intent(in) :: r
    restart_t_checkpoint = r%t_checkpoint
  end function restart_t_checkpoint

  !> The last checkpoint was written after the last output step.
  pure logical function restart_current(r)
    type(restart_state_t), intent(in) :: r
    restart_current = r%checkpoint_current
  end function restart_current

end module run_checkpoint
