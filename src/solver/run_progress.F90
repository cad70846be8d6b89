! SPDX-License-Identifier: BSD-2-Clause
!> Progress of the run: its wall clock, the last output step, the lines
!> on stdout (the heartbeat), the stretch warning, and the TS monitor's
!> stall check. The record app_ctx%progress; this module is its only
!> writer.
module run_progress
#include "petsc/finclude/petscsys.h"
  use petscsys
  use mpi
  use kinds, only: rp
  implicit none
  private
  public :: progress_t, progress_start, progress_output_written, progress_said, progress_warn_stretch, &
            progress_restore, progress_reset, progress_stall_check, progress_collapse_check
  public :: progress_heartbeat_due, progress_wall, progress_t_written, progress_stretch_warned

  !> Wall seconds without a line on stdout after which the monitor prints one.
  real(rp), parameter :: HEARTBEAT_S = 10.0_rp
  !> Accepted steps in a row that do not advance t after which the run stops.
  integer, parameter :: STALLED_MAX = 10
  !> Accepted steps in a row shorter than COLLAPSE_FRACTION t_end after
  !> which the run stops: the step has collapsed (issue 47 item 4; at
  !> 1e-13 s drop_table took 45 000 steps at t = 0.098 s and went on).
  integer, parameter, public :: COLLAPSE_MAX = 10
  real(rp), parameter, public :: COLLAPSE_FRACTION = 1.0e-10_rp

  type :: progress_t
    private
    logical :: monitor_seen = .false.           !< the TS monitor has run (its stall check)
    PetscInt :: monitor_step = 0                !< the step number it saw last
    integer :: stalled_steps = 0                !< accepted steps in a row that did not advance t
    real(rp) :: wall0 = 0                       !< MPI_Wtime at the start of solver_run [s]
    real(rp) :: t_written = -1                  !< time of the last output step [time]
    real(rp) :: wall_said = 0                   !< MPI_Wtime of the last line on stdout (rank 0) [s]
    logical :: stretch_warned = .false.         !< the stretch_limit warning was given
    integer :: short_steps = 0                  !< accepted steps in a row shorter than the collapse bound
    PetscInt :: collapse_step = -1              !< the step number the collapse check saw last
    !> at the last accepted step not that short: its time [time], the TS's
    !> failed Newton solves and rejected steps so far
    real(rp) :: t_normal = 0
    PetscInt :: fails_normal = 0, rejects_normal = 0
  end type progress_t

contains

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
  subroutine progress_warn_stretch(p)
    type(progress_t), intent(inout) :: p
    p%stretch_warned = .true.
  end subroutine progress_warn_stretch

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

  !> The monitor's stall check at accepted step number step (advanced: it
  !> advanced t). Accepted steps that do not advance t (retries shrank them
  !> below t's resolution next to a stop time) could repeat forever:
  !> stalled after STALLED_MAX in a row (one alone, after many retries, is
  !> harmless); the step is then not counted as seen.
  subroutine progress_stall_check(p, step, advanced, stalled)
    type(progress_t), intent(inout) :: p
    PetscInt, intent(in) :: step
    logical, intent(in) :: advanced
    logical, intent(out) :: stalled
    stalled = .false.
    if (p%monitor_seen .and. step > p%monitor_step) then
      if (advanced) then
        p%stalled_steps = 0
      else
        p%stalled_steps = p%stalled_steps + 1
      end if
      stalled = p%stalled_steps >= STALLED_MAX
      if (stalled) return
    end if
    p%monitor_seen = .true.
    p%monitor_step = step
  end subroutine progress_stall_check

  !> The monitor's collapse check at accepted step number step, of length
  !> h, ending at t [time] (t_end the run's end; fails and rejects, the TS's failed
  !> Newton solves and rejected steps so far): collapsed after
  !> COLLAPSE_MAX steps in a row shorter than COLLAPSE_FRACTION t_end.
  !> Then t_normal is the end of the last step that was not (the collapse
  !> began there), and nfail, nreject the failed solves and rejected steps
  !> since. fresh: the check had not seen this step (the monitor sees a
  !> step again when TSSolve goes on after an output step).
  subroutine progress_collapse_check(p, step, t, h, t_end, fails, rejects, collapsed, t_normal, nfail, nreject, fresh)
    type(progress_t), intent(inout) :: p
    PetscInt, intent(in) :: step, fails, rejects
    real(rp), intent(in) :: t, h, t_end
    logical, intent(out) :: collapsed, fresh
    real(rp), intent(out) :: t_normal
    integer, intent(out) :: nfail, nreject
    collapsed = .false.
    t_normal = p%t_normal
    nfail = int(fails - p%fails_normal)
    nreject = int(rejects - p%rejects_normal)
    fresh = step > p%collapse_step
    if (.not. fresh) return
    p%collapse_step = step
    ! a step that did not advance t is the stall check's (step_monitor's
    ! stall_check names that cause: t's resolution)
    if (.not. (h > 0.0_rp)) return
    if (h >= COLLAPSE_FRACTION * t_end) then
      p%short_steps = 0
      p%t_normal = t
      p%fails_normal = fails
      p%rejects_normal = rejects
      return
    end if
    p%short_steps = p%short_steps + 1
    collapsed = p%short_steps >= COLLAPSE_MAX
  end subroutine progress_collapse_check

  !> HEARTBEAT_S of wall time have passed without a line on stdout.
  logical function progress_heartbeat_due(p)
    type(progress_t), intent(in) :: p
    progress_heartbeat_due = MPI_Wtime() - p%wall_said >= HEARTBEAT_S
  end function progress_heartbeat_due

  !> Wall-clock seconds since the run's start, the runs it continues
  !> included [s] (this rank's clock).
  real(rp) function progress_wall(p)
    type(progress_t), intent(in) :: p
    progress_wall = MPI_Wtime() - p%wall0
  end function progress_wall

  !> The time of the last output step written [time] (-1: none).
  pure real(rp) function progress_t_written(p)
    type(progress_t), intent(in) :: p
    progress_t_written = p%t_written
  end function progress_t_written

  !> The stretch_limit warning was given.
  pure logical function progress_stretch_warned(p)
    type(progress_t), intent(in) :: p
    progress_stretch_warned = p%stretch_warned
  end function progress_stretch_warned

end module run_progress
