! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the inexact-Newton policy (module newton_forcing) on a
!> scalar problem whose Newton remainder is known exactly:
!> F(u) = u + q u^2 has Newton step du = F/(1 + 2 q u), and after an exact
!> step from u the residual is q du^2 (so C = q / (1 + 2 q u)^2 ~ q near
!> u = 0). Checks that
!>  - the tolerance never leaves [eta_min, eta_max];
!>  - with C unknown it aims at half the target, so one iteration passes
!>    the test when Newton's remainder allows;
!>  - quadratic_constant recovers C from exact steps, and takes off the
!>    linear error of inexact ones (it does not grow when the linear error
!>    dominates);
!>  - inexact Newton driven by the policy stops at the target on the
!>    scalar problem, in no more iterations than exact Newton needs.
program test_newton_forcing
  use kinds, only: rp
  use newton_forcing, only: forcing_term, quadratic_constant
  use check, only: check_true, check_close, check_report
  implicit none
  real(rp), parameter :: q = 0.3_rp, eta_min = 1.0e-6_rp, eta_max = 0.1_rp
  real(rp) :: eta, c, u, f0, f1, du, target
  integer :: k, n_exact, n_inexact

  ! Bounds.
  call check_close(forcing_term(1.0_rp, 0.0_rp, 0.0_rp, eta_min, eta_max), eta_min, 0.0_rp, 0.0_rp, 'no target, no C: eta_min')
  call check_close(forcing_term(1.0_rp, 10.0_rp, 0.0_rp, eta_min, eta_max), eta_max, 0.0_rp, 0.0_rp, 'huge target: eta_max')
  call check_close(forcing_term(1.0_rp, 0.0_rp, 5.0_rp, eta_min, eta_max), eta_max, 0.0_rp, 0.0_rp, 'huge C: eta_max')
  call check_close(forcing_term(0.0_rp, 1.0_rp, 1.0_rp, eta_min, eta_max), eta_min, 0.0_rp, 0.0_rp, 'zero residual: eta_min')
  ! Half the target when C is unknown; C ||F|| when that is larger.
  call check_close(forcing_term(100.0_rp, 1.0e-2_rp, 0.0_rp, eta_min, eta_max), 5.0e-5_rp, 1.0e-15_rp, 0.0_rp, 'target / (2 F)')
  call check_close(forcing_term(100.0_rp, 1.0e-2_rp, 1.0e-5_rp, eta_min, eta_max), 1.0e-3_rp, 1.0e-15_rp, 0.0_rp, 'C F')

  ! C from an exact step of the scalar problem.
  u = 1.0e-3_rp
  f0 = u + q * u**2
  du = f0 / (1.0_rp + 2.0_rp * q * u)
  f1 = abs((u - du) + q * (u - du)**2)
  c = quadratic_constant(f0, f1, 0.0_rp)
  call check_close(c, q / (1.0_rp + 2.0_rp * q * u)**2, 1.0e-6_rp, 0.0_rp, 'C of an exact Newton step')
  ! An inexact step that left lin = 1e-2 of F: C is not inflated by it.
  du = (1.0_rp - 1.0e-2_rp) * f0 / (1.0_rp + 2.0_rp * q * u)
  f1 = abs((u - du) + q * (u - du)**2)
  c = quadratic_constant(f0, f1, 1.0e-2_rp)
  call check_true(c <= 1.01_rp * q, 'linear error taken off C')
  call check_close(quadratic_constant(0.0_rp, 1.0_rp, 0.0_rp), 0.0_rp, 0.0_rp, 0.0_rp, 'no previous residual: C = 0')

  ! Newton on F(u) = u + q u^2 from u = 0.5 to |F| <= target, exact and
  ! with the policy (a linear solve to eta modelled as du (1 - eta)).
  target = 1.0e-10_rp
  n_exact = newton_iterations(.false.)
  n_inexact = newton_iterations(.true.)
  call check_true(n_inexact <= n_exact, 'inexact Newton needs no more iterations than exact Newton')
  call check_true(n_inexact >= 1, 'inexact Newton iterates')
  call check_report()

contains

  integer function newton_iterations(inexact) result(n)
    logical, intent(in) :: inexact
    real(rp) :: uu, f, fprev, cc, e, lin
    uu = 0.5_rp
    f = uu + q * uu**2
    cc = 0.0_rp
    lin = 0.0_rp
    fprev = 0.0_rp
    n = 0
    do k = 1, 50
      if (abs(f) <= target) exit
      if (inexact) then
        if (n >= 1) cc = quadratic_constant(fprev, abs(f), lin)
        e = forcing_term(abs(f), target, cc, eta_min, eta_max)
      else
        e = 0.0_rp
      end if
      lin = e
      fprev = abs(f)
      uu = uu - (1.0_rp - e) * f / (1.0_rp + 2.0_rp * q * uu)
      f = uu + q * uu**2
      n = n + 1
    end do
    call check_true(abs(f) <= target, 'Newton reaches the target')
  end function newton_iterations

end program test_newton_forcing
