!> The inner solve's initial guess at the first Newton iteration of a step
!> (-nuno_inner_guess; docs/design.md, "The inner initial guess"). Plain
!> numbers in and out: unit-tested alone (tests/unit/test_inner_guess.f90).
!>
!> The first Newton correction of the velocities of a one-stage implicit
!> step is smooth from step to step: without an extrapolated start it is
!> the velocity change over the step, dt times the mean acceleration; with
!> the extrapolated start beuler uses (x + dt xdot, nuno's default,
!> -ts_theta_initial_guess_extrapolate) it is what that start misses, dt^2
!> times the change of acceleration. So dv_k = r_k / a_k^p, with a_k the
!> shift (1/dt for backward Euler, 1/(theta dt) for theta methods), p = 1
!> or 2 and r_k a rate that varies smoothly in time. From the first
!> corrections of the last steps, dv1 (shift a1) and dv2 (shift a2):
!>   previous:     r = r1
!>   extrapolate:  r = r1 + (r1 - r2) (dt / dt1) = r1 + (r1 - r2) a1 / a
!> with r_k = a_k^p dv_k, so guess = r / a^p = c1 dv1 + c2 dv2. The
!> extrapolation is exact when the rate is linear in time, whatever the
!> steps; with equal steps it is 2 dv1 - dv2.
module inner_guess
  use kinds, only: rp
  implicit none
  private
  public :: GUESS_AUTO, GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, guess_weights, second_weight

  integer, parameter :: GUESS_AUTO = 0, GUESS_NONE = 1, GUESS_PREVIOUS = 2, GUESS_EXTRAPOLATE = 3
  !> the largest ratio of neighbouring steps a guess reaches across
  real(rp), parameter :: RATIO = 2.0_rp
  !> the largest ratio of right-hand sides the second iteration's guess
  !> scales across
  real(rp), parameter :: RHS_RATIO = 4.0_rp

contains

  !> Weights c(1:2) of dv1, dv2 in the guess at shift a (> 0), given the
  !> shifts a1, a2 (> 0) of the stored corrections, how many are stored
  !> (nh = 0, 1, 2) and the power p (1 or 2) of the shift in dv = r / a^p.
  !> With fewer than the mode needs: the previous one, or nothing (c = 0:
  !> a zero guess); the same where neighbouring steps differ by more than
  !> a factor RATIO.
  pure function guess_weights(mode, nh, a, a1, a2, p) result(c)
    integer, intent(in) :: mode, nh, p
    real(rp), intent(in) :: a, a1, a2
    real(rp) :: c(2)
    c = 0.0_rp
    if (nh < 1 .or. .not. (a > 0.0_rp)) return
    ! across a step that changed by more than RATIO (a retry, a sliver
    ! before a stop time) the rate is not smooth: no guess from there
    if (.not. near(a1, a)) return
    select case (mode)
    case (GUESS_PREVIOUS)
      c(1) = (a1 / a)**p
    case (GUESS_EXTRAPOLATE)
      if (nh >= 2 .and. near(a2, a1)) then
        c(1) = (a1 / a)**p * (1.0_rp + a1 / a)
        c(2) = -(a2 / a)**p * (a1 / a)
      else
        c(1) = (a1 / a)**p
      end if
    end select
  contains
    pure logical function near(x, y)
      real(rp), intent(in) :: x, y
      near = x <= RATIO * y .and. y <= RATIO * x
    end function near
  end function guess_weights

  !> Weight of the last step's second Newton correction (shift a1 > 0, its
  !> inner right-hand side's norm b1) in the guess of this step's (shift
  !> a, right-hand side's norm b). The second correction is what the
  !> first Newton iteration's remainder (and its inexact solve) left: its
  !> direction changes slowly from step to step (hang 257 x 257: 13-17 %
  !> fewer inner iterations over a run), its size with the remainder's, so
  !> the last one scaled by b / b1. No guess (0) across a step that
  !> changed by more than RATIO, nor where the right-hand sides differ by
  !> more than RHS_RATIO: at a run's start the second remainder falls
  !> 1000-fold in one step, and the correction of the step before, even
  !> scaled, was a worse start than zero.
  pure real(rp) function second_weight(a, a1, b, b1) result(c)
    real(rp), intent(in) :: a, a1, b, b1
    c = 0.0_rp
    if (.not. (a > 0.0_rp .and. a1 > 0.0_rp .and. b > 0.0_rp .and. b1 > 0.0_rp)) return
    if (a1 > RATIO * a .or. a > RATIO * a1) return
    if (b > RHS_RATIO * b1 .or. b1 > RHS_RATIO * b) return
    c = b / b1
  end function second_weight

end module inner_guess
