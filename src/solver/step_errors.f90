! SPDX-License-Identifier: BSD-2-Clause
!> The error estimate of adaptive steps where process models are stiff
!> (issue 47 item 4; docs/design.md, "Contact", adaptive steps): the
!> nodes whose process-model forces a step does not resolve (a node that
!> hit an obstacle within the step: the barrier's omega dt > 1) are left
!> out of the integrator's weighted error norm, at the step's end state
!> and at the two accepted states before it (the estimates of beuler and
!> bdf2 difference three states: one across an impact measures the
!> impact, not the method's error). Every other node is weighed with the
!> run's tolerances as before.
!>
!> Why: the exact motion stops a node that hits an obstacle at a gap far
!> below any step's resolution (docs/contact.md, "Where the impact's
!> energy goes"); an L-stable integrator (beuler, bdf2) damps that mode
!> within a step, and its error estimate of the node only shrinks the
!> step without end (drop_table at -ts_rtol 1e-4 looped at dt = 1e-13 s,
!> at 1e-3 stopped with a NaN norm once t + dt == t). So the error is
!> controlled away from impacts, and at an impact by the rest of the
!> cloth.
!>
!> The same nodes mark an impact for bdf2 (issue 47 item 4): its velocity
!> is a difference over two steps, and across an impact (a node stopped
!> within the step) it points away from the obstacle: the node bounces
!> (drop_table with -ts_type bdf -ts_rtol 1e-6 bounced 0.36 m after a
!> drop of 0.05 m). So a stage with nodes unresolved that were resolved
!> at the step's start is solved again at order 1 (backward Euler,
!> L-stable, whose velocity is the step's own), and bdf2 starts anew
!> after the first step with no node unresolved (module process_solver).
!> Such a stage of a step longer than the run's initial dt is first
!> solved again with that dt, and while nodes are unresolved the step
!> stays at most that dt (step_errors_max_step): where the estimate sees
!> nothing, nothing else bounds the step.
!>
!> The record app_ctx%errw; this module is its only writer. PETSc-free:
!> module process_solver hands it the stage's mask and the arrays of the
!> TS's tolerance vectors.
module step_errors
  use mpi
  use kinds, only: rp
  implicit none
  private
  public :: step_errors_t, step_errors_init, step_errors_free, step_errors_on, step_errors_weighs, step_errors_stage, &
            step_errors_stage_masks, &
            step_errors_tolerances, step_errors_accepted, step_errors_left_out, step_errors_drop_order, &
            step_errors_order_dropped, step_errors_impacts, step_errors_take_scale, step_errors_set_min_step, &
            step_errors_min_step, step_errors_save_scale, step_errors_max_step, step_errors_unresolved

  type :: step_errors_t
    private
    logical :: weigh = .false.                  !< adaptive steps with process models: unresolved nodes left out
    logical :: impacts = .false.                !< bdf2 with process models: impacts at order 1
    real(rp) :: rtol = 0, atol_x = 0, atol_v = 0   !< the run's tolerances (module step_settings)
    !> (0:nx-1, ys:ye) unresolved nodes: at the last stage checked, at the
    !> last accepted state x_n and at the one before, x_{n-1}
    logical, allocatable :: stage(:, :), at_n(:, :), at_nm1(:, :)
    real(rp) :: t_stage = -huge(1.0_rp)         !< time of the last stage checked [time]
    integer :: stage_out = 0                    !< nodes the last stage's estimate left out, all ranks
    integer :: stage_new = 0                    !< nodes unresolved at the last stage, resolved at x_n, all ranks
    integer :: left_out = 0                     !< accepted steps whose estimate left nodes out
    integer :: impacts_seen = 0                 !< accepted steps taken at order 1 for an impact (bdf2)
    logical :: dropped = .false.                !< bdf2 is at order 1 for an impact
    !> the TS adaptor's step factor after a rejected stage, while the
    !> impact's stage is solved again at the same step (0: none saved)
    real(rp) :: scale_saved = 0
    !> the adaptor's smallest step: the user's (-ts_adapt_dt_min), and
    !> while nodes are unresolved a fraction of the run's initial step
    !> (step_errors_min_step)
    real(rp) :: hmin_user = 0, hmin_contact = 0
    !> the adaptor's largest step: the user's (-ts_adapt_dt_max), and
    !> while nodes are unresolved the run's initial step (step_errors_max_step)
    real(rp) :: hmax_user = huge(1.0_rp), hmax_contact = huge(1.0_rp)
  end type step_errors_t

  !> While nodes are unresolved, adaptive steps stay above this fraction
  !> of the run's initial step (the namelist's dt, for which the barrier's
  !> parameters are checked, input/README.md "&contact"): below it the
  !> steps would resolve the stiff modes of nodes pressed into a barrier,
  !> whose ringing the error estimate then chases through their
  !> neighbours, and impacts would stop below the acceptance floor
  !> (drape_sphere at -ts_rtol 1e-6 went down to dt = 1e-17 s so: its
  !> sheet hangs on the sphere's top node, 1 um above it, omega = 7e4/s).
  real(rp), parameter :: MIN_STEP_FRACTION = 0.1_rp

contains

  !> weigh: adaptive steps with process models (the error estimate leaves
  !> unresolved nodes out); impacts: bdf2 with process models (an impact's
  !> step at order 1). On the strip of rows ys..ye of nx nodes; the run's
  !> tolerances rtol [1], atol_x [length], atol_v [length/time] (module
  !> solver_setup's set_tolerances).
  subroutine step_errors_init(e, weigh, impacts, nx, ys, ye, rtol, atol_x, atol_v)
    type(step_errors_t), intent(inout) :: e
    logical, intent(in) :: weigh, impacts
    integer, intent(in) :: nx, ys, ye
    real(rp), intent(in) :: rtol, atol_x, atol_v
    call step_errors_free(e)
    e%weigh = weigh
    e%impacts = impacts
    e%rtol = rtol
    e%atol_x = atol_x
    e%atol_v = atol_v
    if (.not. (weigh .or. impacts)) return
    allocate(e%stage(0:nx - 1, ys:ye), e%at_n(0:nx - 1, ys:ye), e%at_nm1(0:nx - 1, ys:ye))
    e%stage = .false.
    e%at_n = .false.
    e%at_nm1 = .false.
  end subroutine step_errors_init

  !> The adaptor's smallest step as the user set it, hmin_user, and the
  !> run's initial step dt0 [time].
  subroutine step_errors_set_min_step(e, hmin_user, dt0, hmax_user)
    type(step_errors_t), intent(inout) :: e
    real(rp), intent(in) :: hmin_user, dt0, hmax_user
    e%hmin_user = hmin_user
    e%hmin_contact = max(hmin_user, MIN_STEP_FRACTION * dt0)
    e%hmax_user = hmax_user
    e%hmax_contact = max(e%hmin_contact, min(hmax_user, dt0))
  end subroutine step_errors_set_min_step

  !> The adaptor's largest step for the last stage checked: with nodes
  !> unresolved there or at the two accepted states before, at most the
  !> run's initial step (the namelist's dt, for which the barrier is
  !> checked); else the user's. The nodes the estimate leaves out have no
  !> error control: where all are (a sheet resting on a table) the
  !> estimate is 0 and bdf2's steps doubled to 16 ms after the drop's
  !> impact, and the sheet bounced off the table (0.14 m at -ts_rtol 1e-4).
  pure real(rp) function step_errors_max_step(e)
    type(step_errors_t), intent(in) :: e
    step_errors_max_step = merge(e%hmax_contact, e%hmax_user, e%stage_out > 0)
  end function step_errors_max_step

  !> The adaptor's smallest step for the last stage checked: with nodes
  !> unresolved there or at the two accepted states before, at least
  !> MIN_STEP_FRACTION of the run's initial step; else the user's.
  pure real(rp) function step_errors_min_step(e)
    type(step_errors_t), intent(in) :: e
    step_errors_min_step = merge(e%hmin_contact, e%hmin_user, e%stage_out > 0)
  end function step_errors_min_step

  subroutine step_errors_free(e)
    type(step_errors_t), intent(inout) :: e
    if (allocated(e%stage)) deallocate(e%stage, e%at_n, e%at_nm1)
    e%weigh = .false.
    e%impacts = .false.
    e%t_stage = -huge(1.0_rp)
    e%left_out = 0
    e%impacts_seen = 0
    e%dropped = .false.
  end subroutine step_errors_free

  !> The stages' unresolved nodes are wanted (step_errors_stage).
  pure logical function step_errors_on(e)
    type(step_errors_t), intent(in) :: e
    step_errors_on = e%weigh .or. e%impacts
  end function step_errors_on

  !> The error estimate leaves unresolved nodes out (adaptive steps).
  pure logical function step_errors_weighs(e)
    type(step_errors_t), intent(in) :: e
    step_errors_weighs = e%weigh
  end function step_errors_weighs

  !> Impacts are taken at order 1 (bdf2).
  pure logical function step_errors_impacts(e)
    type(step_errors_t), intent(in) :: e
    step_errors_impacts = e%impacts
  end function step_errors_impacts

  !> The masks (0:nx-1, ys:ye) a stage check fills before
  !> step_errors_stage: stage, the stage's unresolved nodes, and at_start,
  !> those of the step's start x_n. They are the record's own arrays (no
  !> allocation a stage); e must be a target (a component of the solver's
  !> context), and the pointers are used until step_errors_stage only.
  subroutine step_errors_stage_masks(e, stage, at_start)
    type(step_errors_t), intent(inout), target :: e
    logical, pointer, intent(out) :: stage(:, :), at_start(:, :)
    stage => e%stage
    at_start => e%at_n
  end subroutine step_errors_stage_masks

  !> A stage at t checked (the TS's stage check), its masks filled
  !> (step_errors_stage_masks). n_new: nodes unresolved at the stage and
  !> not at x_n (an impact within the step), over all ranks of comm.
  !> Collective.
  subroutine step_errors_stage(e, t, comm, n_new)
    type(step_errors_t), intent(inout) :: e
    real(rp), intent(in) :: t
    integer, intent(in) :: comm
    integer, intent(out) :: n_new
    integer :: loc(2), glob(2), mpierr
    e%t_stage = t
    loc(1) = count(e%stage .and. .not. e%at_n)
    loc(2) = count(e%stage .or. e%at_n .or. e%at_nm1)
    call MPI_Allreduce(loc, glob, 2, MPI_INTEGER, MPI_SUM, comm, mpierr)
    n_new = glob(1)
    e%stage_new = glob(1)
    e%stage_out = glob(2)
  end subroutine step_errors_stage

  !> The TS's tolerance vectors for the last stage's error estimate:
  !> atol(0:5, 0:nx-1, ys:ye) and rtol(...) the run's tolerances, 0 (left
  !> out of the norm: PETSc's weighted norms skip an entry whose
  !> tolerances are both 0) at the nodes unresolved at the stage or at
  !> either of the two accepted states before.
  subroutine step_errors_tolerances(e, atol, rtol)
    type(step_errors_t), intent(in) :: e
    real(rp), intent(inout) :: atol(0:, 0:, :), rtol(0:, 0:, :)
    integer :: i, j, jj
    do j = 1, size(atol, 3)
      jj = lbound(e%stage, 2) + j - 1
      do i = 0, size(atol, 2) - 1
        if (e%stage(i, jj) .or. e%at_n(i, jj) .or. e%at_nm1(i, jj)) then
          atol(:, i, j) = 0.0_rp
          rtol(:, i, j) = 0.0_rp
        else
          atol(0:2, i, j) = e%atol_x
          atol(3:5, i, j) = e%atol_v
          rtol(0:2, i, j) = 0.0_rp
          rtol(3:5, i, j) = e%rtol
        end if
      end do
    end do
  end subroutine step_errors_tolerances

  !> bdf2 goes to order 1 for an impact (the caller solves the step again
  !> so, at the same step: scale, the TS adaptor's factor after a rejected
  !> stage, to be put back once that is done), or back to order 2 (dropped
  !> false; the caller restarts its history).
  subroutine step_errors_drop_order(e, dropped, scale)
    type(step_errors_t), intent(inout) :: e
    logical, intent(in) :: dropped
    real(rp), intent(in) :: scale
    e%dropped = dropped
    e%scale_saved = scale
  end subroutine step_errors_drop_order

  !> The adaptor's factor after a failed solve, scale, to put back at the
  !> next stage (step_errors_take_scale): a stage rejected to be solved
  !> again with another factor (an impact's step shortened).
  subroutine step_errors_save_scale(e, scale)
    type(step_errors_t), intent(inout) :: e
    real(rp), intent(in) :: scale
    e%scale_saved = scale
  end subroutine step_errors_save_scale

  !> The adaptor's factor after a rejected stage to put back (0: none),
  !> and forget it.
  subroutine step_errors_take_scale(e, scale)
    type(step_errors_t), intent(inout) :: e
    real(rp), intent(out) :: scale
    scale = e%scale_saved
    e%scale_saved = 0.0_rp
  end subroutine step_errors_take_scale

  !> The last stage checked, or one of the two accepted states before it,
  !> had nodes unresolved (over all ranks).
  pure logical function step_errors_unresolved(e)
    type(step_errors_t), intent(in) :: e
    step_errors_unresolved = e%stage_out > 0
  end function step_errors_unresolved

  !> bdf2 is at order 1 for an impact.
  pure logical function step_errors_order_dropped(e)
    type(step_errors_t), intent(in) :: e
    step_errors_order_dropped = e%dropped
  end function step_errors_order_dropped

  !> The step whose stage was checked last was accepted at t (its state
  !> is x_n now); impact: it had nodes unresolved that were resolved at
  !> its start. A state at another time (a window's start, the state at
  !> t = 0) changes nothing (impact false).
  subroutine step_errors_accepted(e, t, impact)
    type(step_errors_t), intent(inout) :: e
    real(rp), intent(in) :: t
    logical, intent(out) :: impact
    impact = .false.
    if (.not. (e%weigh .or. e%impacts) .or. t /= e%t_stage) return
    impact = e%stage_new > 0
    e%at_nm1 = e%at_n
    e%at_n = e%stage
    if (e%weigh .and. e%stage_out > 0) e%left_out = e%left_out + 1
    if (e%dropped) e%impacts_seen = e%impacts_seen + 1
    e%t_stage = -huge(1.0_rp)
  end subroutine step_errors_accepted

  !> Accepted steps whose error estimate left unresolved nodes out, and
  !> (bdf2) those taken at order 1 for an impact.
  pure subroutine step_errors_left_out(e, left_out, impacts)
    type(step_errors_t), intent(in) :: e
    integer, intent(out) :: left_out, impacts
    left_out = e%left_out
    impacts = e%impacts_seen
  end subroutine step_errors_left_out

end module step_errors
