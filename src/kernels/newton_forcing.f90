! SPDX-License-Identifier: BSD-2-Clause
!> The inner tolerance of an inexact Newton step that does no more work than
!> the step needs (docs/design.md, "Newton"). Plain numbers in and out: the
!> policy is unit-tested alone (tests/unit/test_newton_forcing.f90).
!>
!> After a Newton update with a linear solve to relative residual eta, the
!> new residual is about  eta ||F_k||  (what the linear solve left) plus
!> C ||F_k||^2  (Newton's own remainder). Solving the linear system further
!> than either of
!>   - the remainder the step leaves anyway (eta = C ||F_k||), or
!>   - half the residual at which the convergence test stops (then this
!>     iteration is the last one: eta = target / (2 ||F_k||)),
!> whichever is larger, buys nothing. C is estimated from the previous
!> iterations, ||F_{k+1}|| / ||F_k||^2.
module newton_forcing
  use kinds, only: rp
  implicit none
  private
  public :: forcing_term, quadratic_constant

contains

  !> Relative tolerance of the linear solve of a Newton iteration.
  !> fnorm: ||F_k|| (> 0); target: the residual norm at which the
  !> convergence test stops; c: estimate of C (0: unknown); eta_min,
  !> eta_max: bounds of the answer (eta_min is the tolerance used without
  !> this policy: it is never tighter than that).
  pure real(rp) function forcing_term(fnorm, target, c, eta_min, eta_max) result(eta)
    real(rp), intent(in) :: fnorm, target, c, eta_min, eta_max
    if (.not. (fnorm > 0.0_rp)) then
      eta = eta_min
      return
    end if
    eta = max(c * fnorm, 0.5_rp * max(target, 0.0_rp) / fnorm)
    eta = min(eta_max, max(eta_min, eta))
  end function forcing_term

  !> Estimate of C in ||F_{k+1}|| ~ C ||F_k||^2 from two successive residual
  !> norms and the relative residual lin that the linear solve between them
  !> left (its part, lin ||F_k||, is taken off: a linear error that
  !> dominated ||F_{k+1}|| would otherwise read as a large C, loosen the
  !> next solve, and so feed itself). 0 when nothing is left to estimate
  !> from; use it only while the iteration has not converged (at the
  !> round-off floor ||F_{k+1}|| says nothing about C).
  pure real(rp) function quadratic_constant(fnorm_prev, fnorm, lin) result(c)
    real(rp), intent(in) :: fnorm_prev, fnorm, lin
    c = 0.0_rp
    if (fnorm_prev > 0.0_rp) c = max(fnorm - max(lin, 0.0_rp) * fnorm_prev, 0.0_rp) / fnorm_prev**2
  end function quadratic_constant

end module newton_forcing
