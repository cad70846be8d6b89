! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the one smoothed Coulomb law (module smoothed_coulomb)
!> against expectations computed here: the slip is dv less its normal part;
!> the force -s u has Coulomb's magnitude c when sliding faster than eps_v
!> and c (2y/eps_v - y^2/eps_v^2) below; the block kc against central
!> differences of the force in dv, sticking and sliding, and c 2/eps_v
!> times the tangent projector at no slip; -kc positive semidefinite; the
!> power -f . u, and 0 without friction; the spread of a pair's point force
!> and block by weights that sum to zero (forces summing to zero, blocks
!> w_a w_b kc); the Newton update's guard where a slip turns (coulomb_turn):
!> the fraction where the slip along the update is least, from the closed
!> form of two numbers' line, when the slip reverses from beyond eps_v / 2
!> to beyond eps_v through the band, and 1 for a slip that keeps its way,
!> speeds up, slows, starts deeper in the band than eps_v / 2, ends in it,
!> or turns past it.
program test_smoothed_coulomb
  use kinds, only: rp
  use smoothed_coulomb, only: coulomb_slip, coulomb_power, spread_by_weights, coulomb_turn
  use check, only: check_true, check_close, check_close_array, check_report, seed_random
  implicit none
  real(rp), parameter :: C = 0.7_rp, EPS_V = 1.0e-3_rp          ! [force], [length/time]
  real(rp), parameter :: SCALES(4) = [0.05_rp, 0.4_rp, 3.0_rp, 300.0_rp]   ! slip speeds / eps_v
  real(rp) :: n(3), dv(3), u(3), s, kc(3, 3), pm(3, 3), fd(3, 3), fp(3), fm(3), up(3), sp, kp(3, 3), h, y, z(3)
  real(rp) :: w(4), f(3, 4), kv(3, 3, 4, 4), t1(3), t2(3), al
  integer :: k, i, trial, a, b

  call seed_random(11)
  do trial = 1, 20
    call random_number(n)
    n = n - 0.5_rp
    n = n / norm2(n)
    do i = 1, 3
      pm(:, i) = -n * n(i)
      pm(i, i) = pm(i, i) + 1.0_rp
    end do
    do k = 1, size(SCALES)
      call random_number(dv)
      dv = dv - 0.5_rp
      ! a tangential slip of the chosen speed, plus a normal part the law ignores
      dv = matmul(pm, dv)
      dv = SCALES(k) * EPS_V * dv / norm2(dv) + 5.0_rp * EPS_V * n
      call coulomb_slip(C, EPS_V, n, dv, u, s, kc)
      call check_close_array(u, dv - dot_product(n, dv) * n, 1.0e-12_rp, 1.0e-15_rp, 'slip = tangential part of dv')
      y = SCALES(k) * EPS_V
      if (SCALES(k) >= 1.0_rp) then
        call check_close(s * norm2(u), C, 1.0e-12_rp, 0.0_rp, 'sliding: |f| = mu lam')
      else
        call check_close(s * norm2(u), C * (2.0_rp * y / EPS_V - y**2 / EPS_V**2), 1.0e-12_rp, 0.0_rp, &
                         'sticking: |f| = mu lam f1(|u|)')
      end if
      call check_close(coulomb_power(C, EPS_V, n, dv), s * dot_product(u, u), 1.0e-12_rp, 0.0_rp, 'power = -f . u')
      ! kc against central differences of f(dv) = -s u
      h = 1.0e-6_rp * y
      do i = 1, 3
        call coulomb_slip(C, EPS_V, n, dv + h * unit(i), up, sp, kp)
        fp = -sp * up
        call coulomb_slip(C, EPS_V, n, dv - h * unit(i), up, sp, kp)
        fm = -sp * up
        fd(:, i) = (fp - fm) / (2.0_rp * h)
      end do
      call check_close_array(reshape(kc, [9]), reshape(fd, [9]), 1.0e-5_rp, 1.0e-6_rp * maxval(abs(kc)), &
                             'kc = df/d(dv) (central differences)')
      do i = 1, 10
        call random_number(z)
        z = z - 0.5_rp
        call check_true(dot_product(z, matmul(-kc, z)) >= -1.0e-12_rp * maxval(abs(kc)), '-kc positive semidefinite')
      end do
    end do
    ! no slip: u = 0, s = 2 c / eps_v, kc = -(2 c / eps_v) P
    call coulomb_slip(C, EPS_V, n, 3.0_rp * n, u, s, kc)
    call check_true(norm2(u) <= 1.0e-15_rp, 'no slip: u = 0')
    ! (u is round-off, y/eps_v ~ 1e-13: phi = 2/eps_v to that)
    call check_close(s, 2.0_rp * C / EPS_V, 1.0e-9_rp, 0.0_rp, 'no slip: s = 2 mu lam / eps_v')
    call check_close_array(reshape(kc, [9]), reshape(-2.0_rp * C / EPS_V * pm, [9]), 1.0e-12_rp, 1.0e-9_rp, &
                           'no slip: kc = -(2 mu lam / eps_v) P')
  end do
  call check_true(coulomb_power(0.0_rp, EPS_V, n, [1.0_rp, 2.0_rp, 3.0_rp]) == 0.0_rp, 'power 0 without mu lam')
  call check_true(coulomb_power(C, 0.0_rp, n, [1.0_rp, 2.0_rp, 3.0_rp]) == 0.0_rp, 'power 0 without eps_v')

  ! spread: a point force on sum_a w_a x_a, the w summing to zero (a pair's two sides)
  w = [0.3_rp, 0.7_rp, -0.25_rp, -0.75_rp]
  call coulomb_slip(C, EPS_V, n, [2.0e-3_rp, -1.0e-3_rp, 4.0e-4_rp], u, s, kc)
  call spread_by_weights(w, -s * u, kc, f, kv)
  call check_close_array(sum(f, dim=2), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp * C, 'spread: forces sum to zero')
  call check_close_array(f(:, 3), 0.25_rp * s * u, 1.0e-15_rp, 0.0_rp, 'spread: f_a = w_a fc')
  do b = 1, 4
    do a = 1, 4
      call check_close_array(reshape(kv(:, :, a, b), [9]), reshape(w(a) * w(b) * kc, [9]), 1.0e-15_rp, 0.0_rp, &
                             'spread: kv_ab = w_a w_b kc')
    end do
  end do

  ! the guard where a slip turns: in the tangent plane of n (t1, t2), the
  ! normal parts of dv and its update ignored
  t1 = [n(2), -n(1), 0.0_rp] / hypot(n(1), n(2))
  t2 = [n(2) * t1(3) - n(3) * t1(2), n(3) * t1(1) - n(1) * t1(3), n(1) * t1(2) - n(2) * t1(1)]
  ! straight reversal, 5 eps_v to -5.5 eps_v: least (0) at 5/10.5 of the update
  al = coulomb_turn(EPS_V, n, EPS_V * (5.0_rp * t1 + 2.0_rp * n), EPS_V * (-10.5_rp * t1 - 7.0_rp * n))
  call check_close(al, 5.0_rp / 10.5_rp, 1.0e-13_rp, 0.0_rp, 'turn: a reversal stops where the slip is 0')
  ! a turn past the band: (3, 0) eps_v to (-3, 2) eps_v, du = (-6, 2): least at 18/40, slip (0.3, 0.9) eps_v
  al = coulomb_turn(EPS_V, n, 3.0_rp * EPS_V * t1, EPS_V * (-6.0_rp * t1 + 2.0_rp * t2))
  call check_close(al, 0.45_rp, 1.0e-13_rp, 0.0_rp, 'turn: the fraction where the slip is least')
  call coulomb_slip(C, EPS_V, n, 3.0_rp * EPS_V * t1 + al * EPS_V * (-6.0_rp * t1 + 2.0_rp * t2), u, s, kc)
  call check_close(norm2(u), EPS_V * sqrt(0.9_rp), 1.0e-12_rp, 0.0_rp, 'turn: there the slip is in the band')
  ! untouched: keeps its way (faster, slower, sideways), or starts or ends in the band
  call check_true(coulomb_turn(EPS_V, n, 5.0_rp * EPS_V * t1, 3.0_rp * EPS_V * t1) == 1.0_rp, 'turn: speeding up, kept')
  call check_true(coulomb_turn(EPS_V, n, 5.0_rp * EPS_V * t1, -3.0_rp * EPS_V * t1) == 1.0_rp, 'turn: slowing, kept')
  call check_true(coulomb_turn(EPS_V, n, 5.0_rp * EPS_V * t1, EPS_V * (-4.0_rp * t1 + 9.0_rp * t2)) == 1.0_rp, &
                  'turn: turning less than 90 degrees, kept')
  call check_true(coulomb_turn(EPS_V, n, 0.4_rp * EPS_V * t1, -5.0_rp * EPS_V * t1) == 1.0_rp, &
                  'turn: from deeper in the band than eps_v / 2, kept')
  ! from the band's outer half, 0.8 eps_v to -5 eps_v: least (0) at 0.8/5.8
  call check_close(coulomb_turn(EPS_V, n, 0.8_rp * EPS_V * t1, -5.8_rp * EPS_V * t1), 0.8_rp / 5.8_rp, 1.0e-13_rp, 0.0_rp, &
                   'turn: from the band''s outer half, limited')
  ! a turn that misses the band: (3, 0) eps_v to (-3, 4) eps_v, least |u| = 1.66 eps_v at 18/52
  call check_true(coulomb_turn(EPS_V, n, 3.0_rp * EPS_V * t1, EPS_V * (-6.0_rp * t1 + 4.0_rp * t2)) == 1.0_rp, &
                  'turn: past the band, kept')
  call check_true(coulomb_turn(EPS_V, n, 5.0_rp * EPS_V * t1, -5.5_rp * EPS_V * t1) == 1.0_rp, 'turn: into the band, kept')
  call check_true(coulomb_turn(EPS_V, n, 5.0_rp * EPS_V * t1, -10.0_rp * EPS_V * n) == 1.0_rp, &
                  'turn: a normal update, kept')
  call check_report()

contains

  pure function unit(i) result(e)
    integer, intent(in) :: i
    real(rp) :: e(3)
    e = 0.0_rp
    e(i) = 1.0_rp
  end function unit

end program test_smoothed_coulomb
