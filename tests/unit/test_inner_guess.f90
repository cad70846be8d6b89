! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the inner initial guess (module inner_guess): for a rate
!> linear in time, r(t) = r0 + q t, and steps of changing size whose first
!> corrections are dv_n = r(t_n) dt_n^p (p = 1: the velocity change of a
!> start from the last state; p = 2: what an extrapolated start misses;
!> shift a_n = 1/dt_n), the extrapolated guess reproduces the next
!> correction exactly, the previous one is off by q dt^(p+1), and with too
!> few stored corrections or steps that changed by more than a factor 2
!> the guess falls back as documented. The second Newton iteration's
!> weight (second_weight) scales the last correction by the ratio of the
!> right-hand sides, and gives no guess across a step or a right-hand side
!> that changed too much. The projection's weights (projection_weights)
!> reproduce a right-hand side in the span of the kept ones exactly, leave
!> otherwise a residual orthogonal to all of them (the least-squares
!> condition, checked with the vectors, not the Gram matrix), and give a
!> repeated right-hand side no weight of its own.
program test_inner_guess
  use kinds, only: rp
  use inner_guess, only: GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, guess_weights, second_weight, &
                         projection_weights
  use check, only: check_close, check_close_array, check_true, check_report
  implicit none
  real(rp), parameter :: r0 = -9.81_rp, q = 3.7_rp
  real(rp) :: t(0:3), dt(3), dv(3), c(2), g
  integer :: n, p
  character(len=8) :: tag
  integer, parameter :: m = 12                     ! length of the vectors of the projection's cases
  real(rp) :: bk(m, 4), b(m), res(m), gram(4, 4), dk(4), y(4)
  integer :: i, k

  ! three steps of sizes 1e-3, 1.6e-3, 0.9e-3 from t = 0.2 (neighbours within a factor 2)
  dt = [1.0e-3_rp, 1.6e-3_rp, 0.9e-3_rp]
  t(0) = 0.2_rp
  do n = 1, 3
    t(n) = t(n - 1) + dt(n)
  end do
  do p = 1, 2
    write(tag, '(a,i0,a)') '(p = ', p, ') '
    dv = (r0 + q * t(1:3)) * dt**p
    ! guess for step 3 from steps 2 (dv1) and 1 (dv2)
    c = guess_weights(GUESS_EXTRAPOLATE, 2, 1.0_rp / dt(3), 1.0_rp / dt(2), 1.0_rp / dt(1), p)
    g = c(1) * dv(2) + c(2) * dv(1)
    call check_close(g, dv(3), 1.0e-13_rp, 0.0_rp, tag//'extrapolate: exact for a linear rate, steps of any size')
    ! previous: the last step's rate, scaled to this step
    c = guess_weights(GUESS_PREVIOUS, 2, 1.0_rp / dt(3), 1.0_rp / dt(2), 1.0_rp / dt(1), p)
    g = c(1) * dv(2) + c(2) * dv(1)
    call check_close(g, (r0 + q * t(2)) * dt(3)**p, 1.0e-13_rp, 0.0_rp, tag//'previous: the last rate times this step')
    call check_close(dv(3) - g, q * dt(3)**(p + 1), 1.0e-8_rp, 0.0_rp, tag//'previous: off by q dt^(p+1) (a difference)')
    ! fallbacks
    c = guess_weights(GUESS_EXTRAPOLATE, 1, 1.0_rp / dt(3), 1.0_rp / dt(2), 0.0_rp, p)
    call check_close(c(1), (dt(3) / dt(2))**p, 1.0e-15_rp, 0.0_rp, tag//'extrapolate with one stored: previous')
    call check_close(c(2), 0.0_rp, 0.0_rp, 0.0_rp, tag//'extrapolate with one stored: no second weight')
  end do
  ! equal steps: 2 dv1 - dv2 whatever p
  do p = 1, 2
    c = guess_weights(GUESS_EXTRAPOLATE, 2, 500.0_rp, 500.0_rp, 500.0_rp, p)
    call check_close(c(1), 2.0_rp, 1.0e-15_rp, 0.0_rp, 'extrapolate, equal steps: c1 = 2')
    call check_close(c(2), -1.0_rp, 1.0e-15_rp, 0.0_rp, 'extrapolate, equal steps: c2 = -1')
  end do
  ! steps that changed by more than a factor 2: no reach across them
  c = guess_weights(GUESS_EXTRAPOLATE, 2, 1000.0_rp, 800.0_rp, 2000.0_rp, 2)
  call check_close(c(2), 0.0_rp, 0.0_rp, 0.0_rp, 'dt1 / dt2 = 2.5: only the previous correction')
  call check_close(c(1), 0.8_rp**2, 1.0e-15_rp, 0.0_rp, 'dt1 / dt2 = 2.5: the previous one, scaled')
  c = guess_weights(GUESS_EXTRAPOLATE, 2, 4.0_rp * 500.0_rp, 500.0_rp, 500.0_rp, 2)
  call check_close(abs(c(1)) + abs(c(2)), 0.0_rp, 0.0_rp, 0.0_rp, 'a retry at dt / 4: zero guess')
  c = guess_weights(GUESS_PREVIOUS, 1, 500.0_rp, 4.0_rp * 500.0_rp, 0.0_rp, 1)
  call check_close(abs(c(1)) + abs(c(2)), 0.0_rp, 0.0_rp, 0.0_rp, 'back to dt after a retry: zero guess')
  c = guess_weights(GUESS_EXTRAPOLATE, 0, 1.0_rp / dt(3), 0.0_rp, 0.0_rp, 2)
  call check_close(abs(c(1)) + abs(c(2)), 0.0_rp, 0.0_rp, 0.0_rp, 'nothing stored: zero guess')
  c = guess_weights(GUESS_NONE, 2, 1.0_rp / dt(3), 1.0_rp / dt(2), 1.0_rp / dt(1), 2)
  call check_close(abs(c(1)) + abs(c(2)), 0.0_rp, 0.0_rp, 0.0_rp, 'none: zero guess')
  ! the second iteration: a linear response, so the correction of a right-hand
  ! side 1.5 times as large is 1.5 times as large
  call check_close(second_weight(1000.0_rp, 1000.0_rp, 3.0e-8_rp, 2.0e-8_rp), 1.5_rp, 1.0e-15_rp, 0.0_rp, &
                   'second: scaled by the right-hand sides')
  call check_close(second_weight(1000.0_rp, 1600.0_rp, 2.0e-8_rp, 2.0e-8_rp), 1.0_rp, 1.0e-15_rp, 0.0_rp, &
                   'second: steps within a factor 2')
  call check_close(second_weight(1000.0_rp, 2500.0_rp, 2.0e-8_rp, 2.0e-8_rp), 0.0_rp, 0.0_rp, 0.0_rp, &
                   'second: no guess across a step changed 2.5-fold')
  call check_close(second_weight(1000.0_rp, 1000.0_rp, 2.56e-8_rp, 2.57e-5_rp), 0.0_rp, 0.0_rp, 0.0_rp, &
                   'second: no guess across a right-hand side 1000 times smaller')
  call check_close(second_weight(1000.0_rp, 1000.0_rp, 9.0e-8_rp, 2.0e-8_rp), 0.0_rp, 0.0_rp, 0.0_rp, &
                   'second: nor across one 4.5 times larger')
  call check_close(second_weight(1000.0_rp, 1000.0_rp, 2.0e-8_rp, 0.0_rp), 0.0_rp, 0.0_rp, 0.0_rp, &
                   'second: none stored')

  ! the projection: four kept right-hand sides, independent, of unlike sizes
  do k = 1, 4
    do i = 1, m
      bk(i, k) = sin(0.7_rp * i * k + 0.3_rp * k) * 10.0_rp**(k - 2)
    end do
  end do
  b = 0.5_rp * bk(:, 1) - 2.0_rp * bk(:, 2) + 0.25_rp * bk(:, 4)
  call weights_of(4)
  call check_close_array(y, [0.5_rp, -2.0_rp, 0.0_rp, 0.25_rp], 1.0e-9_rp, 1.0e-12_rp, &
                         'project: a combination of the kept ones, its weights')
  ! b outside their span: the residual is orthogonal to every kept one
  do i = 1, m
    b(i) = cos(1.3_rp * i) + 0.1_rp * bk(i, 3)
  end do
  call weights_of(4)
  res = b - matmul(bk, y)
  do k = 1, 4
    call check_close(dot_product(bk(:, k), res) / (norm2(bk(:, k)) * norm2(b)), 0.0_rp, 0.0_rp, 1.0e-12_rp, &
                     'project: the residual is orthogonal to each kept right-hand side')
  end do
  call check_true(norm2(res) < norm2(b), 'project: the residual is smaller than the right-hand side')
  ! a kept right-hand side repeated (the third = the first): finite weights, the same projection
  bk(:, 3) = bk(:, 1)
  b = 1.5_rp * bk(:, 1) + bk(:, 2)
  call weights_of(4)
  call check_close_array(matmul(bk, y), b, 1.0e-9_rp, 1.0e-12_rp, 'project, a repeat among the kept: b reproduced')
  call check_true(abs(y(1)) + abs(y(3)) < 1.5_rp + 1.0e-9_rp, 'project, a repeat among the kept: no amplified weights')
  ! nothing kept, or all kept zero: no guess
  call projection_weights(0, gram, dk, y)
  gram = 0.0_rp
  dk = 0.0_rp
  y = 1.0_rp
  call projection_weights(2, gram, dk, y)
  call check_close(abs(y(1)) + abs(y(2)), 0.0_rp, 0.0_rp, 0.0_rp, 'project: kept right-hand sides all zero, no guess')
  call check_report()
contains
  !> y = projection_weights of b on the first n columns of bk, with their Gram
  !> matrix and products formed here from the vectors
  subroutine weights_of(n)
    integer, intent(in) :: n
    integer :: k1, k2
    do k1 = 1, n
      do k2 = 1, n
        gram(k1, k2) = dot_product(bk(:, k1), bk(:, k2))
      end do
      dk(k1) = dot_product(bk(:, k1), b)
    end do
    call projection_weights(n, gram, dk, y)
  end subroutine weights_of
end program test_inner_guess
