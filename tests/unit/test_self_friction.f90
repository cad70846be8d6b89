! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the friction between layers (module self_friction): the
!> lag of a point over a flat triangle and of two crossing edges, set up so
!> that the nearest points, the normal and the weights are known by hand
!> (the foot's barycentric weights, the edges' parameters), lam against
!> the barrier's normal force (-kappa b'(gap), and the size of the
!> barrier's force on the point from self_barrier); the friction's blocks
!> against central differences of its forces, sticking and sliding; the
!> force on the point's side Coulomb's -mu lam u/|u| when sliding faster
!> than eps_v, with u the slip of the two nearest points computed here from
!> the node velocities; forces summing to zero, tangential; -kv positive
!> semidefinite; the power -f . u.
program test_self_friction
  use kinds, only: rp
  use contact, only: contact_params_t, barrier
  use self_broad, only: PAIR_PT, PAIR_EE
  use self_barrier, only: self_pair_barrier
  use self_friction, only: self_lag_t, self_pair_lag, self_pair_friction, self_pair_friction_power
  use check, only: check_true, check_close, check_close_array, check_report, seed_random
  implicit none
  type(contact_params_t) :: cp
  type(self_lag_t) :: lag
  real(rp) :: xp(3, 4), xr(3, 4), b, db, d2b, e, fb(3, 4), kb(3, 3, 4, 4), v(3, 4), f(3, 4), kv(3, 3, 4, 4)
  real(rp) :: w_pt(4), w_ee(4), gap
  logical :: active
  integer :: k
  real(rp), parameter :: MU = 0.4_rp
  real(rp), parameter :: SCALES(3) = [0.3_rp, 3.0_rp, 300.0_rp]   ! slip speeds / eps_v

  call seed_random(7)
  cp = contact_params_t(thickness=0.002_rp, dhat=0.01_rp, kappa=50.0_rp, eps_v=1.0e-3_rp)
  gap = 0.004_rp
  call barrier(gap, cp%dhat, b, db, d2b)

  ! ---- point over the triangle (0,0,0) (1,0,0) (0,1,0), foot (0.2, 0.3) ----------
  xp(:, 1) = [0.2_rp, 0.3_rp, cp%thickness + gap]
  xp(:, 2) = [0.0_rp, 0.0_rp, 0.0_rp]
  xp(:, 3) = [1.0_rp, 0.0_rp, 0.0_rp]
  xp(:, 4) = [0.0_rp, 1.0_rp, 0.0_rp]
  xr = xp
  w_pt = [1.0_rp, -0.5_rp, -0.2_rp, -0.3_rp]
  call self_pair_lag(PAIR_PT, xp, xr, cp, lag, active)
  call self_pair_barrier(PAIR_PT, xp, xr, cp, .false., e, fb, kb, active)
  call check_true(active, 'PT lag: active')
  call check_close_array(lag%w, w_pt, 1.0e-14_rp, 0.0_rp, 'PT lag: weights (1, -foot''s barycentrics)')
  call check_close_array(lag%n, [0.0_rp, 0.0_rp, 1.0_rp], 0.0_rp, 1.0e-14_rp, 'PT lag: normal along z')
  call check_close(lag%lam, -cp%kappa * db, 1.0e-12_rp, 0.0_rp, 'PT lag: lam = -kappa b''(gap)')
  call check_close(lag%lam, norm2(fb(:, 1)), 1.0e-10_rp, 0.0_rp, 'PT lag: lam = |barrier force on the point|')
  do k = 1, 3
    call friction_checks(lag, w_pt, SCALES(k), 'PT')
  end do

  ! ---- edge (-0.5,0.3,h)-(0.5,0.3,h) over edge (0.1,-0.5,0)-(0.1,0.5,0) ----------
  xp(:, 1) = [-0.5_rp, 0.3_rp, cp%thickness + gap]
  xp(:, 2) = [0.5_rp, 0.3_rp, cp%thickness + gap]
  xp(:, 3) = [0.1_rp, -0.5_rp, 0.0_rp]
  xp(:, 4) = [0.1_rp, 0.5_rp, 0.0_rp]
  xr = xp
  w_ee = [0.4_rp, 0.6_rp, -0.2_rp, -0.8_rp]
  call self_pair_lag(PAIR_EE, xp, xr, cp, lag, active)
  call self_pair_barrier(PAIR_EE, xp, xr, cp, .false., e, fb, kb, active)
  call check_true(active, 'EE lag: active')
  call check_close_array(lag%w, w_ee, 1.0e-14_rp, 0.0_rp, 'EE lag: weights (the edges'' parameters)')
  call check_close_array(lag%n, [0.0_rp, 0.0_rp, 1.0_rp], 0.0_rp, 1.0e-14_rp, 'EE lag: normal along z')
  call check_close(lag%lam, -cp%kappa * db, 1.0e-12_rp, 0.0_rp, &
                   'EE lag: lam = -kappa b''(gap) (crossing: no mollifier)')
  call check_close(lag%lam, norm2(fb(:, 1) + fb(:, 2)), 1.0e-10_rp, 0.0_rp, 'EE lag: lam = |barrier force on edge a|')
  do k = 1, 3
    call friction_checks(lag, w_ee, SCALES(k), 'EE')
  end do

  ! ---- beyond dhat or at a gap <= 0: no lag --------------------------------------
  xp(3, 1:2) = cp%thickness + 1.5_rp * cp%dhat
  call self_pair_lag(PAIR_EE, xp, xr, cp, lag, active)
  call check_true(.not. active .and. lag%lam == 0.0_rp, 'EE lag: none beyond dhat')
  xp(3, 1:2) = 0.5_rp * cp%thickness
  call self_pair_lag(PAIR_EE, xp, xr, cp, lag, active)
  call check_true(.not. active .and. lag%lam == 0.0_rp, 'EE lag: none at a gap <= 0')
  ! no lam, or mu = 0: nothing
  lag = self_lag_t(w=w_pt, n=[0.0_rp, 0.0_rp, 1.0_rp], lam=0.0_rp)
  call random_number(v)
  call self_pair_friction(lag, MU, cp%eps_v, v, f, kv)
  call check_true(all(f == 0.0_rp) .and. all(kv == 0.0_rp), 'lam = 0: no friction')
  lag%lam = 1.0_rp
  call self_pair_friction(lag, 0.0_rp, cp%eps_v, v, f, kv)
  call check_true(all(f == 0.0_rp) .and. all(kv == 0.0_rp), 'mu = 0: no friction')

  call check_report()

contains

  !> Random velocities whose nearest points slip at about eps_v * scale relative to each
  !> other (all nodes also move by a common velocity and along the normal, which friction
  !> ignores): kv against central differences of f; f's sum zero; the point's side's force
  !> tangential and Coulomb's when sliding; -kv PSD; power = -f . u >= 0.
  subroutine friction_checks(lag, w, scale, what)
    type(self_lag_t), intent(in) :: lag
    real(rp), intent(in) :: w(4), scale
    character(*), intent(in) :: what
    real(rp) :: v(3, 4), f(3, 4), kv(3, 3, 4, 4), fp(3, 4), fm(3, 4), kd(3, 3, 4, 4), kfd(12, 12), m(12, 12)
    real(rp) :: vp(3, 4), hv, fa(3), u(3), y(12), pw, common(3)
    integer :: j, a, c, ic, jn
    call random_number(v)
    call random_number(common)
    v = cp%eps_v * scale * (v - 0.5_rp) + spread(common + 0.7_rp * lag%n, 2, 4)
    call self_pair_friction(lag, MU, cp%eps_v, v, f, kv)
    hv = 1.0e-6_rp * cp%eps_v
    do j = 1, 12
      ic = mod(j - 1, 3) + 1
      jn = (j - ic) / 3 + 1
      vp = v
      vp(ic, jn) = vp(ic, jn) + hv
      call self_pair_friction(lag, MU, cp%eps_v, vp, fp, kd)
      vp(ic, jn) = vp(ic, jn) - 2.0_rp * hv
      call self_pair_friction(lag, MU, cp%eps_v, vp, fm, kd)
      kfd(:, j) = reshape(fp - fm, [12]) / (2.0_rp * hv)
    end do
    do c = 1, 4
      do a = 1, 4
        m(3 * a - 2:3 * a, 3 * c - 2:3 * c) = kv(:, :, a, c)
      end do
    end do
    call check_close_array(reshape(m, [144]), reshape(kfd, [144]), 1.0e-5_rp, 0.0_rp, &
                           what//' friction: kv against FD of f')
    call check_close_array(sum(f, dim=2), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp * maxval(abs(f)), &
                           what//' friction: forces sum to zero')
    ! the slip of the nearest points, from the hand-made weights; z is the normal
    u = matmul(v, w)
    u(3) = 0.0_rp
    ! the first side's share: the point, or edge a (weights summing to 1)
    fa = f(:, 1)
    if (what == 'EE') fa = f(:, 1) + f(:, 2)
    call check_close(fa(3), 0.0_rp, 0.0_rp, 1.0e-12_rp * norm2(fa), what//' friction: tangential')
    if (norm2(u) > cp%eps_v) call check_close_array(fa, -MU * lag%lam * u / norm2(u), 1.0e-12_rp, 0.0_rp, &
                                                    what//' friction: sliding f = -mu lam u/|u| (Coulomb)')
    if (norm2(u) < cp%eps_v) call check_true(norm2(fa) < MU * lag%lam, what//' friction: below mu lam in the band')
    pw = self_pair_friction_power(lag, MU, cp%eps_v, v)
    call check_close(pw, -sum(f * v), 1.0e-12_rp, 1.0e-20_rp, what//' friction: power = -f . v')
    call check_true(pw >= 0.0_rp, what//' friction: power >= 0')
    do j = 1, 50
      call random_number(y)
      y = y - 0.5_rp
      if (dot_product(y, matmul(-m, y)) < -1.0e-12_rp * maxval(abs(m)) * dot_product(y, y)) then
        call check_true(.false., what//' friction: -kv PSD')
        exit
      end if
    end do
  end subroutine friction_checks

end program test_self_friction
