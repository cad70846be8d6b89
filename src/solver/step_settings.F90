! SPDX-License-Identifier: BSD-2-Clause
!> The time integration as used: the namelist's values after the PETSc
!> options (resolved by module solver_setup), the error tolerances of
!> adaptive steps, and the current time window with the return to the
!> fixed step after a retried one (the TS monitor, module step_monitor).
!> The record app_ctx%step; this module is its only writer, every other
!> module reads it through the functions below.
module step_settings
#include "petsc/finclude/petscsys.h"
  use petscsys
  use kinds, only: rp
  implicit none
  private
  public :: step_settings_t, step_settings_init, step_set_tolerances, step_enter_window, step_rejections, &
            step_back_to_dt
  public :: step_dt, step_t_end, step_fixed, step_adaptive_default, step_max_steps, step_tolerances

  type :: step_settings_t
    private
    real(rp) :: dt = 0                          !< fixed (or initial) step [time]: -ts_dt, else the namelist's
    real(rp) :: t_end = 0                       !< end time [time]: -ts_max_time, else the namelist's
    logical :: fixed_step = .true.              !< -ts_adapt_type none: every step is dt unless retried
    logical :: adaptive_default = .false.       !< the TS type is -nuno_adaptive_ts_type's (no -ts_type given)
    PetscInt :: max_steps = 0                   !< -ts_max_steps: a clean end after this many steps
    !> error tolerances of adaptive steps (TSSetTolerances: scalar rtol, vector atol)
    real(rp) :: rtol = 0                        !< -ts_rtol [1]
    real(rp) :: atol_x = 0                      !< absolute tolerance of positions [length]
    real(rp) :: atol_v = 0                      !< absolute tolerance of velocities [length/time]
    real(rp) :: tstop = 0                       !< end of the current time window [time]
    PetscInt :: rejects_seen = 0                !< step rejections already answered by the monitor
  end type step_settings_t

contains

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

  !> The monitor after an accepted step: rejects, the TS's rejected steps
  !> so far. retried: a step was rejected since (a failed Newton solve,
  !> retried with dt/4) and the steps are fixed: the TS keeps the smaller
  !> step with -ts_adapt_type none, so the caller returns it to dt
  !> (step_back_to_dt).
  subroutine step_rejections(s, rejects, retried)
    type(step_settings_t), intent(inout) :: s
    PetscInt, intent(in) :: rejects
    logical, intent(out) :: retried
    retried = .false.
    if (rejects <= s%rejects_seen) return
    s%rejects_seen = rejects
    retried = s%fixed_step
  end subroutine step_rejections

  !> h, the TS's next step [time] after a retried step accepted at t, back
  !> to dt, clipped to the window's end as PETSc's matchstep does (no
  !> sliver step); set: h was changed (the caller sets it on the TS).
  pure subroutine step_back_to_dt(s, t, h, set)
    type(step_settings_t), intent(in) :: s
    real(rp), intent(in) :: t
    real(rp), intent(inout) :: h
    logical, intent(out) :: set
    real(rp) :: hmax
    hmax = s%tstop - t
    set = h < s%dt .and. hmax > 0.0_rp
    if (.not. set) return
    h = s%dt
    if (t + 1.01_rp * h >= s%tstop) then
      h = hmax
    else if (2.0_rp * h > hmax) then
      h = 0.5_rp * hmax
    end if
  end subroutine step_back_to_dt

  pure real(rp) function step_dt(s)
    type(step_settings_t), intent(in) :: s
    step_dt = s%dt
  end function step_dt

  pure real(rp) function step_t_end(s)
    type(step_settings_t), intent(in) :: s
    step_t_end = s%t_end
  end function step_t_end

  !> Fixed steps (-ts_adapt_type none).
  pure logical function step_fixed(s)
    type(step_settings_t), intent(in) :: s
    step_fixed = s%fixed_step
  end function step_fixed

  !> The TS type is -nuno_adaptive_ts_type's.
  pure logical function step_adaptive_default(s)
    type(step_settings_t), intent(in) :: s
    step_adaptive_default = s%adaptive_default
  end function step_adaptive_default

  pure PetscInt function step_max_steps(s)
    type(step_settings_t), intent(in) :: s
    step_max_steps = s%max_steps
  end function step_max_steps

  !> The error tolerances of adaptive steps: rtol [1], atol_x [length],
  !> atol_v [length/time] (step_set_tolerances).
  pure subroutine step_tolerances(s, rtol, atol_x, atol_v)
    type(step_settings_t), intent(in) :: s
    real(rp), intent(out) :: rtol, atol_x, atol_v
    rtol = s%rtol
    atol_x = s%atol_x
    atol_v = s%atol_v
  end subroutine step_tolerances

end module step_settings
