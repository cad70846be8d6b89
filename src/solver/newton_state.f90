! SPDX-License-Identifier: BSD-2-Clause
!> Newton's policy state within a run (the record app_ctx%newton): the
!> round-off floor's test and its residuals, the inexact-Newton forcing's
!> constant, the inner guess in use, the line-search fallback, the
!> failures to inject (tests). This module is the record's only writer;
!> module newton_policy (the SNES callbacks) calls it. The PETSc-free
!> rules it applies are newton_control and newton_forcing.
module newton_state
  use, intrinsic :: iso_c_binding, only: c_int
  use kinds, only: rp
  use newton_control, only: FLOOR_FACTOR, floor_verdict, update_at_floor
  use newton_forcing, only: forcing_term, quadratic_constant
  use inner_guess, only: GUESS_AUTO
  implicit none
  private
  public :: newton_state_t, SNES_FLOOR_DEFAULT
  public :: newton_state_init, newton_set_inner_guess, newton_enter_window, newton_set_floor, newton_set_failures_before
  public :: newton_take_injected_failure, newton_first_residual, newton_iterated, newton_verdict, newton_inner_rtol, &
            newton_fallback_switched, newton_update_limited, newton_start_moved
  public :: newton_guess, newton_guess_given, newton_forcing_on, newton_floor_est, newton_snorm_prev, newton_fallback, &
            newton_fallback_pending, newton_has_failed, newton_rate_usable, newton_limited_lately, newton_settled, newton_set_lag_settled, newton_lag_settled, newton_target, &
            newton_update_floor

  !> -nuno_snes_floor's default: stagnation below this relative residual is convergence
  real(rp), parameter :: SNES_FLOOR_DEFAULT = 1.0e-6_rp
  !> The inexact Newton's loosest inner tolerance.
  real(rp), parameter :: ETA_MAX = 0.1_rp
  !> Guarded forcing (newton_inner_rtol): the loosest inner tolerance in a
  !> Newton solve whose start or update a step limit cut (a contact's
  !> onset against a still obstacle). With rtol0 (1e-6) there,
  !> drape_sphere's onset at 129 x 129 took 11-14 cycles an iteration;
  !> with 1e-3, 4-9, and as many Newton iterations. A solve whose start a
  !> moving obstacle carried stays at rtol0: with 1e-3 or 1e-4 there, a
  !> sphere or capsule pushing cloth at 5 m/s with dt = 10 ms retried
  !> steps (tests/python/test_contact_moving.py).
  real(rp), parameter :: ETA_LIMITED = 1.0e-3_rp
  !> Guarded forcing: a stalled iteration tightens the next inner solve to
  !> rtol0 only within this factor of the convergence test's residual
  !> (near the round-off floor, where a loose solve from the projected
  !> guess took no cycle); far above it (an onset's iterations whose
  !> updates the step limit cut, ||F|| rising 7e3 -> 1.5e4) the limited
  !> solve's tolerance stands.
  real(rp), parameter :: NEAR_FLOOR = 1.0e3_rp
  !> newton_settled: the contraction of ||F|| since the solve's start
  !> after which its Jacobian is kept for the rest of the solve
  real(rp), parameter :: SETTLED_CONTRACTION = 1.0e-2_rp
  !> newton_settled: how far above the convergence test's residual
  real(rp), parameter :: SETTLED_NEAR = 1.0e2_rp

  type :: newton_state_t
    private
    real(rp) :: snes_floor = SNES_FLOOR_DEFAULT !< -nuno_snes_floor [1]
    real(rp) :: fnorm0 = 0, fnorm_prev = 0      !< ||F|| at this solve's start and at the last iteration
    real(rp) :: floor_est = 0                   !< round-off floor of ||F||_2 at the last 6-dof assembly (module newton_control)
    real(rp) :: snorm_prev = 0                  !< ||update|| of the previous Newton iteration
    !> a process model's step limit scaled this iteration's update (limited)
    !> or the previous one's (limited_prev): their lengths say nothing of
    !> Newton's convergence (an update cut at an obstacle is short, not
    !> converged), and their inexact solves are no guide for the next one
    logical :: limited = .false., limited_prev = .false.
    !> an update of this Newton solve was scaled by a step limit
    !> (limited_solve), or one of the solve before (limited_solve_prev): a
    !> contact's onset, where the forcing's loose inner solves failed
    !> steps (a sphere pushing cloth at 5 m/s, dt = 10 ms): the inner
    !> solves stay at rtol0 for the rest of such a solve and the next
    !> solve's first iteration (newton_inner_rtol)
    logical :: limited_solve = .false., limited_solve_prev = .false.
    !> the coming solve's start was cut by a step limit or carried by a
    !> moving obstacle (newton_start_moved): limited_solve from its start
    logical :: limited_start = .false.
    !> a moving obstacle carried this solve's start (carried_solve), the
    !> last solve's (carried_solve_prev), the coming one's (carried_start)
    logical :: carried_solve = .false., carried_solve_prev = .false., carried_start = .false.
    logical :: newton_forcing = .true.          !< inner tolerance from the step's needs (reduced path)
    logical :: forcing_guarded = .false.        !< the forcing only where the process models' state settled
    !> the Jacobian of a Newton solve kept once it has settled (newton_settled; a process model's hint)
    logical :: lag_settled = .false.
    integer(c_int) :: guess = GUESS_AUTO        !< -nuno_inner_guess (module inner_guess)
    integer(c_int) :: guess_given = 0           !< 1: set on the command line
    real(rp) :: cquad = 0                       !< estimate of C in ||F_k+1|| ~ C ||F_k||^2; 0 at every window start
    integer :: fail_newton = 0                  !< -nuno_fail_newton: Newton solves still to be declared failed
    !> -nuno_linesearch_fallback: 0 none, 1 bt, 2 l2 (the line search once a
    !> Newton solve has failed); ls_switched once it has been put in place
    integer :: ls_fallback = 0
    logical :: ls_switched = .false.
    integer :: fails_before = 0                 !< failed Newton solves of the runs a restart continues
  end type newton_state_t

contains

  !> Newton's policy as the options resolved it (solver_create):
  !> snes_floor (-nuno_snes_floor, relative residual), guess and
  !> guess_given (-nuno_inner_guess and whether it was given), forcing
  !> (-nuno_newton_forcing), guarded (a process model's hint
  !> forcing_guarded: newton_inner_rtol), fail_newton (-nuno_fail_newton,
  !> tests), ls_fallback (-nuno_linesearch_fallback's code; 0: none).
  subroutine newton_state_init(n, snes_floor, guess, guess_given, forcing, guarded, fail_newton, ls_fallback)
    type(newton_state_t), intent(inout) :: n
    real(rp), intent(in) :: snes_floor
    integer(c_int), intent(in) :: guess, guess_given
    logical, intent(in) :: forcing, guarded
    integer, intent(in) :: fail_newton, ls_fallback
    n%snes_floor = snes_floor
    n%guess = guess
    n%guess_given = guess_given
    n%newton_forcing = forcing
    n%forcing_guarded = guarded
    n%fail_newton = fail_newton
    n%ls_fallback = ls_fallback
  end subroutine newton_state_init

  !> The inner guess the run uses (auto resolved, or none where the run
  !> cannot use one: module solver_setup's set_inner_guess).
  subroutine newton_set_inner_guess(n, guess)
    type(newton_state_t), intent(inout) :: n
    integer(c_int), intent(in) :: guess
    n%guess = guess
  end subroutine newton_set_inner_guess

  !> A time window's start (enter_window): the Newton remainder is learnt
  !> anew in each window, so that a run restarted at a window's start takes
  !> the same iterations as the run that went through it; so is whether
  !> the solve before had a limited update.
  subroutine newton_enter_window(n)
    type(newton_state_t), intent(inout) :: n
    n%cquad = 0.0_rp
    n%limited_solve = .false.
    n%limited_start = .false.
  end subroutine newton_enter_window

  !> The round-off floor of ||F||_2 estimated at the last 6-dof assembly
  !> (module cloth_model; the reduced path keeps its own in reduced_t).
  subroutine newton_set_floor(n, floor_est)
    type(newton_state_t), intent(inout) :: n
    real(rp), intent(in) :: floor_est
    n%floor_est = floor_est
  end subroutine newton_set_floor

  !> A restart (module run_checkpoint): fails Newton solves failed in the
  !> runs it continues, so that it backtracks from its first step as they
  !> did (-nuno_linesearch_fallback).
  subroutine newton_set_failures_before(n, fails)
    type(newton_state_t), intent(inout) :: n
    integer, intent(in) :: fails
    n%fails_before = fails
  end subroutine newton_set_failures_before

  !> -nuno_fail_newton (tests): fail, this Newton solve is to be declared
  !> failed (one fewer left). The same decision on every rank.
  subroutine newton_take_injected_failure(n, fail)
    type(newton_state_t), intent(inout) :: n
    logical, intent(out) :: fail
    fail = n%fail_newton > 0
    if (fail) n%fail_newton = n%fail_newton - 1
  end subroutine newton_take_injected_failure

  !> A Newton solve starts with the residual norm fnorm.
  subroutine newton_first_residual(n, fnorm)
    type(newton_state_t), intent(inout) :: n
    real(rp), intent(in) :: fnorm
    n%fnorm0 = fnorm
    n%limited = .false.
    n%limited_prev = .false.
    n%limited_solve_prev = n%limited_solve
    n%limited_solve = n%limited_start
    n%limited_start = .false.
    n%carried_solve_prev = n%carried_solve
    n%carried_solve = n%carried_start
    n%carried_start = .false.
  end subroutine newton_first_residual

  !> The coming Newton solve's start was cut by a process model's step
  !> limit or moved by its start hook (module process_solver), or not
  !> (limited: the same on every rank).
  subroutine newton_start_moved(n, limited, carried)
    type(newton_state_t), intent(inout) :: n
    logical, intent(in) :: limited
    logical, intent(in) :: carried              !< by a moving obstacle (its start hook)
    n%limited_start = n%limited_start .or. limited .or. carried
    n%carried_start = n%carried_start .or. carried
  end subroutine newton_start_moved

  !> A process model's step limit (module process_solver) has scaled the
  !> coming update (limited), or let it be.
  subroutine newton_update_limited(n, limited)
    type(newton_state_t), intent(inout) :: n
    logical, intent(in) :: limited
    n%limited = n%limited .or. limited
    n%limited_solve = n%limited_solve .or. limited
  end subroutine newton_update_limited

  !> The convergence test has seen an iteration's residual norm fnorm and
  !> update norm snorm.
  subroutine newton_iterated(n, fnorm, snorm)
    type(newton_state_t), intent(inout) :: n
    real(rp), intent(in) :: fnorm, snorm
    n%fnorm_prev = fnorm
    n%snorm_prev = snorm
    n%limited_prev = n%limited
    n%limited = .false.
  end subroutine newton_iterated

  !> The last two updates' lengths measure Newton's rate (neither was
  !> scaled by a step limit): the adaptive steps' test of the remaining
  !> Newton error (module newton_policy) may use them.
  pure logical function newton_rate_usable(n)
    type(newton_state_t), intent(in) :: n
    newton_rate_usable = n%snorm_prev > 0.0_rp .and. .not. (n%limited .or. n%limited_prev)
  end function newton_rate_usable

  !> A step limit scaled this iteration's update or the one before.
  !> This Newton solve has settled: no step limit cut its start or an
  !> update, no moving obstacle carried its start, and ||F|| has fallen
  !> below SETTLED_CONTRACTION times its start's and within SETTLED_NEAR
  !> of the residual at which the convergence test stops (target: what
  !> is left is round-off and the remainder of a Jacobian that hardly
  !> changes, newton_lag_settled).
  pure logical function newton_settled(n, fnorm, target)
    type(newton_state_t), intent(in) :: n
    real(rp), intent(in) :: fnorm, target
    newton_settled = .not. (n%limited_solve .or. n%carried_solve) .and. fnorm <= SETTLED_CONTRACTION * n%fnorm0 &
                     .and. fnorm <= SETTLED_NEAR * target
  end function newton_settled

  !> The residual at which the convergence test stops: max(atol, rtol
  !> ||F_0||, and with the floor test FLOOR_FACTOR times floor_est, the
  !> round-off floor of the last assembly).
  pure real(rp) function newton_target(n, atol, rtol, floor_est) result(target)
    type(newton_state_t), intent(in) :: n
    real(rp), intent(in) :: atol, rtol, floor_est
    target = max(atol, rtol * n%fnorm0)
    if (n%snes_floor > 0.0_rp) target = max(target, FLOOR_FACTOR * floor_est)
  end function newton_target

  !> Keep the Jacobian of a Newton solve once it has settled (on: a process
  !> model's hint jacobian_settled, without -snes_lag_jacobian given).
  subroutine newton_set_lag_settled(n, on)
    type(newton_state_t), intent(inout) :: n
    logical, intent(in) :: on
    n%lag_settled = on
  end subroutine newton_set_lag_settled

  !> The Jacobian of a settled Newton solve is kept (newton_set_lag_settled).
  pure logical function newton_lag_settled(n)
    type(newton_state_t), intent(in) :: n
    newton_lag_settled = n%lag_settled
  end function newton_lag_settled

  pure logical function newton_limited_lately(n)
    type(newton_state_t), intent(in) :: n
    newton_limited_lately = n%limited .or. n%limited_prev
  end function newton_limited_lately

  !> The update's floor (module newton_control's update_at_floor): this
  !> iteration (residual fnorm, update snorm, state xnorm) stalled near
  !> the floor's estimate floor_est with an update of round-off's size.
  pure logical function newton_update_floor(n, fnorm, snorm, xnorm, floor_est)
    type(newton_state_t), intent(in) :: n
    real(rp), intent(in) :: fnorm, snorm, xnorm, floor_est
    newton_update_floor = update_at_floor(fnorm, n%fnorm_prev, snorm, xnorm, floor_est)
  end function newton_update_floor

  !> The round-off floor's verdict on the residual norm fnorm (module
  !> newton_control's floor_verdict; floor_est the floor estimated at the
  !> last assembly, ls_failed a line search that found no decrease).
  pure integer function newton_verdict(n, fnorm, floor_est, ls_failed)
    type(newton_state_t), intent(in) :: n
    real(rp), intent(in) :: fnorm, floor_est
    logical, intent(in) :: ls_failed
    newton_verdict = floor_verdict(fnorm, n%fnorm_prev, n%fnorm0, n%snes_floor, floor_est, ls_failed)
  end function newton_verdict

  !> The inner tolerance eta of the coming Newton iteration's solve (module
  !> newton_forcing) after iteration it with residual norm fnorm: no tighter
  !> than the Newton remainder C ||F||^2 that the step leaves anyway, nor
  !> than half the residual at which the convergence test stops:
  !> max(atol, rtol ||F_0||, and with the floor test FLOOR_FACTOR times
  !> floor_est, the round-off floor of the last assembly). C comes from the
  !> iterations before (lin_rel: the last inner solve's relative residual),
  !> in this window; the bounds are the inner solver's own rtol0 (never
  !> tighter than without this) and ETA_MAX. Guarded (a process model's
  !> hint), at most ETA_LIMITED where a step limit cut the start or an
  !> update of this solve, and in the next solve's first iteration
  !> (limited_solve: a contact's onset), rtol0 itself where a start hook
  !> moved the start (carried_solve: a moving obstacle; a sphere pushing
  !> cloth at 5 m/s, dt = 10 ms, retried steps with looser solves there)
  !> and in the next solve's first iteration, and after an iteration that reduced ||F|| by
  !> less than a tenth within NEAR_FLOOR of the test's residual (near the
  !> round-off floor a loose solve from the projected guess took no cycle
  !> and Newton stalled: a 7 x 7 sheet falling after a retried step).
  subroutine newton_inner_rtol(n, it, fnorm, lin_rel, atol, rtol, floor_est, rtol0, eta)
    type(newton_state_t), intent(inout) :: n
    integer, intent(in) :: it
    real(rp), intent(in) :: fnorm, lin_rel, atol, rtol, floor_est, rtol0
    real(rp), intent(out) :: eta
    real(rp) :: target
    if (it >= 1) n%cquad = quadratic_constant(n%fnorm_prev, fnorm, lin_rel)
    target = newton_target(n, atol, rtol, floor_est)
    eta = forcing_term(fnorm, target, n%cquad, rtol0, ETA_MAX)
    if (.not. n%forcing_guarded) return
    if (n%limited_solve .or. (it == 0 .and. n%limited_solve_prev)) eta = max(rtol0, min(eta, ETA_LIMITED))
    if (n%carried_solve .or. (it == 0 .and. n%carried_solve_prev)) eta = rtol0
    if (it >= 1 .and. fnorm > 0.9_rp * n%fnorm_prev .and. fnorm < NEAR_FLOOR * target) eta = rtol0
  end subroutine newton_inner_rtol

  !> The fallback line search is in place.
  subroutine newton_fallback_switched(n)
    type(newton_state_t), intent(inout) :: n
    n%ls_switched = .true.
  end subroutine newton_fallback_switched

  !> The inner guess (-nuno_inner_guess's code, module inner_guess).
  pure integer(c_int) function newton_guess(n)
    type(newton_state_t), intent(in) :: n
    newton_guess = n%guess
  end function newton_guess

  !> -nuno_inner_guess was given.
  pure logical function newton_guess_given(n)
    type(newton_state_t), intent(in) :: n
    newton_guess_given = n%guess_given /= 0
  end function newton_guess_given

  !> The inexact-Newton forcing is on (-nuno_newton_forcing).
  pure logical function newton_forcing_on(n)
    type(newton_state_t), intent(in) :: n
    newton_forcing_on = n%newton_forcing
  end function newton_forcing_on

  !> The round-off floor of the last 6-dof assembly.
  pure real(rp) function newton_floor_est(n)
    type(newton_state_t), intent(in) :: n
    newton_floor_est = n%floor_est
  end function newton_floor_est

  !> ||update|| of the previous Newton iteration.
  pure real(rp) function newton_snorm_prev(n)
    type(newton_state_t), intent(in) :: n
    newton_snorm_prev = n%snorm_prev
  end function newton_snorm_prev

  !> -nuno_linesearch_fallback's code (0: none).
  pure integer function newton_fallback(n)
    type(newton_state_t), intent(in) :: n
    newton_fallback = n%ls_fallback
  end function newton_fallback

  !> A fallback line search is chosen and not yet in place.
  pure logical function newton_fallback_pending(n)
    type(newton_state_t), intent(in) :: n
    newton_fallback_pending = n%ls_fallback > 0 .and. .not. n%ls_switched
  end function newton_fallback_pending

  !> A Newton solve has failed in this run (nfails: the TS's count) or in
  !> the runs a restart continues.
  pure logical function newton_has_failed(n, nfails)
    type(newton_state_t), intent(in) :: n
    integer, intent(in) :: nfails
    newton_has_failed = nfails + n%fails_before > 0
  end function newton_has_failed

end module newton_state
