! SPDX-License-Identifier: BSD-2-Clause
!> The inner solve's initial guess at the first Newton iteration of a step
!> (-nuno_inner_guess; docs/design.md, "the extrapolated inner start" and
!> "the projected inner start"). Plain
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
!>
!>   project:      the least-squares combination of the last PROJECT_PAIRS
!> inner solves (right-hand sides b_k, solutions x_k, any Newton iteration,
!> at the same shift): y = argmin |b - sum_k y_k b_k|, guess sum_k y_k x_k
!> (projection_weights). Exact where b lies in the span of the b_k and S
!> has not changed; S changes a little from step to step (the kept b_k
!> are S's products of the x_k at their own steps), so it is a guess, and
!> the inner tolerance still decides. It contains the extrapolation (whose
!> weights are one of the combinations), and no product with S: the b_k
!> are the right-hand sides themselves (S x_k = b_k up to the inner
!> tolerance).
module inner_guess
  use kinds, only: rp
  use solver_choices, only: GUESS_AUTO, GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, GUESS_PROJECT
  implicit none
  private
  public :: GUESS_AUTO, GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, GUESS_PROJECT, PROJECT_PAIRS
  public :: guess_weights, second_weight, projection_weights

  !> the inner solves the projection keeps (two 3-dof vectors each); 8 took
  !> 16 % fewer cycles than the extrapolation over 120 bw steps at 257 x
  !> 257, 16 another 5 % (measured with commit 0a41017)
  integer, parameter :: PROJECT_PAIRS = 8
  !> a kept right-hand side whose part outside the others' span is below
  !> this fraction of the largest (squared norms) adds nothing: its weight
  !> would amplify the inner tolerance's and S's changes, not b
  real(rp), parameter :: PROJECT_DROP = 1.0e-10_rp
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

  !> Least-squares weights y(1:n) of n kept right-hand sides b_k for a new
  !> one b, from their Gram matrix g(k, l) = b_k . b_l and d(k) = b_k . b:
  !> y minimises |b - sum_k y_k b_k|. By Cholesky of g with the largest
  !> remaining diagonal first (Gram-Schmidt in the order that keeps the
  !> most of each b_k): a b_k whose part outside the span of those taken is
  !> below PROJECT_DROP of the largest squared norm gets weight 0, so
  !> near-repeats (successive right-hand sides are alike) are dropped, not
  !> amplified. y = 0 for n = 0 or all b_k zero.
  pure subroutine projection_weights(n, g, d, y)
    integer, intent(in) :: n
    real(rp), intent(in) :: g(:, :)    !< (>= n, >= n) Gram matrix of the b_k
    real(rp), intent(in) :: d(:)       !< (>= n) b_k . b
    real(rp), intent(out) :: y(:)      !< (>= n) weights
    real(rp) :: w(n, n), l(n, n), z(n), dd(n), row(n), dmax, t
    integer :: piv(n), k, p, i, r, m
    y(1:n) = 0.0_rp
    if (n < 1) return
    w = g(1:n, 1:n)
    dd = d(1:n)
    piv = [(k, k = 1, n)]
    l = 0.0_rp
    dmax = 0.0_rp
    do k = 1, n
      dmax = max(dmax, w(k, k))
    end do
    if (.not. (dmax > 0.0_rp)) return
    r = 0
    do k = 1, n
      ! the remaining column with the largest part outside the span so far
      p = k - 1 + maxloc([(w(i, i), i = k, n)], 1)
      if (.not. (w(p, p) > PROJECT_DROP * dmax)) exit
      if (p /= k) then
        ! b_p first: swap p and k in w (rows and columns), l (rows), dd, piv
        row = w(p, :)
        w(p, :) = w(k, :)
        w(k, :) = row
        row = w(:, p)
        w(:, p) = w(:, k)
        w(:, k) = row
        row = l(p, :)
        l(p, :) = l(k, :)
        l(k, :) = row
        t = dd(p)
        dd(p) = dd(k)
        dd(k) = t
        i = piv(p)
        piv(p) = piv(k)
        piv(k) = i
      end if
      l(k, k) = sqrt(w(k, k))
      do i = k + 1, n
        l(i, k) = w(i, k) / l(k, k)
      end do
      do m = k + 1, n
        do i = m, n
          w(i, m) = w(i, m) - l(i, k) * l(m, k)
          w(m, i) = w(i, m)
        end do
      end do
      r = k
    end do
    if (r == 0) return
    ! L L^T z = dd on the r columns taken
    do i = 1, r
      t = dd(i)
      do k = 1, i - 1
        t = t - l(i, k) * z(k)
      end do
      z(i) = t / l(i, i)
    end do
    do i = r, 1, -1
      t = z(i)
      do k = i + 1, r
        t = t - l(k, i) * z(k)
      end do
      z(i) = t / l(i, i)
    end do
    do i = 1, r
      y(piv(i)) = z(i)
    end do
  end subroutine projection_weights

end module inner_guess
