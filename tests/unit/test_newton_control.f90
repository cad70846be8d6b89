! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the round-off floor rule (module newton_control):
!>  - the floor estimate is eps max|x| sqrt(sum (K_ii/m)^2 + 3 a^2) over the
!>    free nodes, worked out by hand for two nodes;
!>  - on a scalar Newton iteration computed in floating point, whose
!>    residual stalls at its round-off floor, the verdict converges at the
!>    floor and not before it (the exact root is far below the floor);
!>  - a line search that found no decrease converges at the floor and
!>    diverges above it; snes_floor = 0 turns the rule off.
program test_newton_control
  use kinds, only: rp
  use newton_control, only: FLOOR_FACTOR, NEWTON_ITERATE, NEWTON_CONVERGED, NEWTON_DIVERGED, &
                            floor_node_add, floor_estimate, floor_verdict, update_at_floor
  use check, only: check_true, check_close, check_report
  implicit none
  real(rp), parameter :: C = 1000.3_rp
  real(rp) :: sums(2), expect, floor, f, f0, fprev, x, k, m
  integer :: it, v, it_conv

  ! Two nodes by hand: (K/m)^2 terms 3 (2/1)^2 + 3 (6/2)^2 = 39, shift
  ! terms 2 x 3 a^2 = 24 for a = 2; max |x| = 5.
  sums = 0.0_rp
  call floor_node_add([-2.0_rp, -2.0_rp, -2.0_rp], 1.0_rp, [1.0_rp, -5.0_rp, 0.0_rp], 2.0_rp, sums)
  call floor_node_add([6.0_rp, -6.0_rp, 6.0_rp], 2.0_rp, [3.0_rp, 0.0_rp, 4.0_rp], 2.0_rp, sums)
  call check_close(sums(1), 63.0_rp, 1.0e-15_rp, 0.0_rp, 'sum of (K_ii/m)^2 + 3 a^2')
  call check_close(sums(2), 5.0_rp, 0.0_rp, 0.0_rp, 'max |x|')
  expect = epsilon(1.0_rp) * 5.0_rp * sqrt(63.0_rp)
  call check_close(floor_estimate(sums), expect, 1.0e-15_rp, 0.0_rp, 'floor estimate')

  ! A stiff scalar spring, a Newton iteration in floating point on
  ! F(x) = k/m x - k/m c + (x - c)^3 near c = 1000.3: k/m x is rounded to
  ! eps |x| k/m, so the residual of an exact Newton step cannot go below
  ! about that, which the estimate names.
  k = 1.0e6_rp
  m = 1.0e-2_rp
  x = C + 1.0e-2_rp
  sums = 0.0_rp
  call floor_node_add([-k, -k, -k], m, [x, x, x], 0.0_rp, sums)
  floor = floor_estimate(sums)
  f0 = abs(resid(x))
  fprev = f0
  it_conv = -1
  do it = 1, 30
    x = x - resid(x) / (k / m + 3.0_rp * (x - C)**2)
    f = abs(resid(x))
    v = floor_verdict(f, fprev, f0, 1.0e-6_rp, floor, .false.)
    if (v == NEWTON_CONVERGED) then
      it_conv = it
      exit
    end if
    fprev = f
  end do
  call check_true(it_conv > 0, 'Newton converged at the round-off floor')
  call check_true(f <= max(1.0e-6_rp * f0, floor), 'converged residual at or below the floor estimate')
  call check_true(f >= 0.01_rp * epsilon(1.0_rp) * abs(x) * k / m, 'the floor is real: no lower residual reached')
  ! The rule without the floor estimate: no convergence from a residual that
  ! is still falling fast.
  call check_true(floor_verdict(1.0e-3_rp, 1.0_rp, 1.0_rp, 1.0e-6_rp, 0.0_rp, .false.) == NEWTON_ITERATE, &
                  'falling residual above the floor: iterate')
  ! (b): below FLOOR_FACTOR times the estimate converges at once.
  call check_true(floor_verdict(0.4_rp, 1.0e3_rp, 1.0e3_rp, 1.0e-6_rp, 1.0_rp, .false.) == NEWTON_CONVERGED, &
                  'below FLOOR_FACTOR floor: converged')
  call check_true(FLOOR_FACTOR < 1.0_rp, 'FLOOR_FACTOR below 1')
  ! (a): stagnation below the estimate converges; fast decrease does not.
  call check_true(floor_verdict(0.8_rp, 0.85_rp, 1.0e3_rp, 1.0e-6_rp, 1.0_rp, .false.) == NEWTON_CONVERGED, &
                  'stagnant below floor: converged')
  call check_true(floor_verdict(0.8_rp, 8.0_rp, 1.0e3_rp, 1.0e-6_rp, 1.0_rp, .false.) == NEWTON_ITERATE, &
                  'falling below floor but above FLOOR_FACTOR floor: iterate')
  ! (a'): a failed line search.
  call check_true(floor_verdict(0.8_rp, 0.8_rp, 1.0e3_rp, 1.0e-6_rp, 1.0_rp, .true.) == NEWTON_CONVERGED, &
                  'line search failed at the floor: converged')
  call check_true(floor_verdict(10.0_rp, 10.0_rp, 1.0e3_rp, 1.0e-6_rp, 1.0_rp, .true.) == NEWTON_DIVERGED, &
                  'line search failed above the floor: diverged')
  call check_true(floor_verdict(0.8_rp, 0.8_rp, 1.0e3_rp, 0.0_rp, 1.0_rp, .true.) == NEWTON_DIVERGED, &
                  'snes_floor 0: a failed line search diverges')
  call check_true(floor_verdict(0.1_rp, 0.1_rp, 1.0e3_rp, 0.0_rp, 1.0_rp, .false.) == NEWTON_ITERATE, &
                  'snes_floor 0: no floor rule')
  ! the update's floor: a stalled iteration at the floor whose update moves
  ! the state by round-off alone has converged (the 7 x 7 sheet's numbers);
  ! a long update, a residual still falling by 10 % or one far above the
  ! floor's estimate has not
  call check_true(update_at_floor(5.89e-10_rp, 5.94e-10_rp, 3.5e-11_rp, 5.97_rp, 3.9e-10_rp), &
                  'stalled at the floor, update 6e-12 of the state: converged')
  call check_true(.not. update_at_floor(5.89e-10_rp, 5.94e-10_rp, 1.0e-8_rp, 5.97_rp, 3.9e-10_rp), &
                  'stalled, update 2e-9 of the state: iterate')
  call check_true(.not. update_at_floor(5.0e-10_rp, 5.94e-10_rp, 3.5e-11_rp, 5.97_rp, 3.9e-10_rp), &
                  'reduced by 16 %: iterate')
  call check_true(.not. update_at_floor(1.0e-6_rp, 1.0e-6_rp, 3.5e-11_rp, 5.97_rp, 3.9e-10_rp), &
                  'stalled 2500 times above the floor estimate: iterate')
  call check_report()

contains

  real(rp) function resid(y)
    real(rp), intent(in) :: y
    resid = k / m * y - k / m * C + (y - C)**3
  end function resid

end program test_newton_control
