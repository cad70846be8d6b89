! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the lagged friction of the faces' and edges' pairs (module
!> contact_face_friction): the lag of a sphere under a triangle's interior
!> (the foot's barycentric weights, the normal, lam = the barrier's normal
!> force of contact_triangle) and of an edge across a capsule (weights 1/2,
!> lam with the mollifier); pair_friction's blocks against finite
!> differences of its forces in the sticking and sliding regimes, its
!> forces tangential, distributed by the weights, of size mu lam when
!> sliding, -kv positive semidefinite; the power against -f . u; the
!> Newton update's guard where a pair's slip turns (pair_turn) at the
!> point's velocity by the weights, relative to the moving obstacle.
program test_contact_face_friction
  use kinds, only: rp
  use contact, only: obstacle_t, contact_params_t, barrier, SHAPE_SPHERE, SHAPE_CAPSULE
  use contact_faces, only: contact_triangle, contact_edge
  use contact_face_friction, only: face_lag_t, triangle_lag, edge_lag, pair_friction, pair_friction_power, pair_turn
  use check, only: check_true, check_close, check_close_array, check_report, seed_random
  implicit none
  type(obstacle_t) :: sph, cap
  type(contact_params_t) :: cp
  type(face_lag_t) :: lags(8), elags(12)
  real(rp) :: xt(3, 3), xe(3, 2), e, f(3, 3), kx(3, 3, 3, 3), fe(3, 2), ke(3, 3, 2, 2), hgt, b, db, d2b, u(3)
  integer :: nlag, na, k
  real(rp) :: vt(3, 3), dvt(3, 3)
  type(obstacle_t) :: smooth
  real(rp), parameter :: SCALES(3) = [0.3_rp, 3.0_rp, 300.0_rp]   ! sliding speeds / eps_v

  call seed_random(5)
  cp = contact_params_t(thickness=0.002_rp, dhat=0.01_rp, kappa=50.0_rp, eps_v=1.0e-3_rp)
  sph = obstacle_t(shape=SHAPE_SPHERE, p=[0.1_rp, -0.2_rp, 0.05_rp], r=0.25_rp, mu=0.4_rp, &
                   vel=[0.01_rp, -0.02_rp, 0.003_rp])
  cap = obstacle_t(shape=SHAPE_CAPSULE, p=[-0.3_rp, 0.1_rp, 0.0_rp], q=[0.4_rp, -0.2_rp, 0.1_rp], r=0.01_rp, mu=0.3_rp)

  ! ---- lag: sphere under a triangle, foot at the centre's projection -----------
  hgt = 0.25_rp + 0.002_rp + 0.004_rp
  xt(:, 1) = sph%p + [-0.3_rp, -0.3_rp, hgt]
  xt(:, 2) = sph%p + [0.4_rp, -0.2_rp, hgt]
  xt(:, 3) = sph%p + [0.0_rp, 0.5_rp, hgt]
  call triangle_lag(sph, cp, xt, lags, nlag)
  call contact_triangle(sph, cp, xt, .false., e, f, kx, na)
  call barrier(0.004_rp, cp%dhat, b, db, d2b)
  call check_true(nlag == 1, 'sphere lag: one pair')
  call check_close(sum(lags(1)%w), 1.0_rp, 1.0e-14_rp, 0.0_rp, 'sphere lag: weights sum to 1')
  call check_close_array(matmul(xt, lags(1)%w), sph%p + [0.0_rp, 0.0_rp, hgt], 1.0e-14_rp, 0.0_rp, &
                         'sphere lag: weights give the foot')
  call check_close(abs(lags(1)%n(3)), 1.0_rp, 1.0e-14_rp, 0.0_rp, 'sphere lag: normal along z')
  call check_close(lags(1)%lam, -cp%kappa * db, 1.0e-10_rp, 0.0_rp, 'sphere lag: lam = -kappa b''')
  call check_close(lags(1)%lam, norm2(sum(f, dim=2)), 1.0e-10_rp, 0.0_rp, 'sphere lag: lam = |barrier force|')

  ! ---- lag: an edge across the capsule's axis, 3 mm gap ---------------------------
  u = (cap%q - cap%p) / norm2(cap%q - cap%p)
  xe(:, 1) = 0.5_rp * (cap%p + cap%q) + 0.015_rp * [0.0_rp, 0.0_rp, 1.0_rp] - 0.025_rp * unit3(cross(u, [0.0_rp, 0.0_rp, &
             1.0_rp]))
  xe(:, 2) = xe(:, 1) + 0.05_rp * unit3(cross(u, [0.0_rp, 0.0_rp, 1.0_rp]))
  call edge_lag(cap, cp, xe, 0.05_rp, elags, nlag)
  call contact_edge(cap, cp, xe, 0.05_rp, .false., e, fe, ke, na)
  call check_true(nlag == 1 .and. na == 1, 'capsule edge lag: one pair')
  call check_close_array(elags(1)%w, [0.5_rp, 0.5_rp, 0.0_rp], 1.0e-6_rp, 0.0_rp, 'capsule edge lag: weights 1/2')
  call check_close(elags(1)%lam, norm2(sum(fe, dim=2)), 1.0e-8_rp, 0.0_rp, 'capsule edge lag: lam = |barrier force|')

  ! ---- friction of a pair: triangle (3 nodes) and edge (2 nodes), both regimes ------
  do k = 1, 3
    call friction_fd(sph, lags(1), 3, SCALES(k))
    call friction_fd(cap, elags(1), 2, SCALES(k))
  end do
  ! no lam: nothing
  lags(2) = face_lag_t(w=[0.2_rp, 0.3_rp, 0.5_rp], n=[0.0_rp, 0.0_rp, 1.0_rp], lam=0.0_rp)
  call pair_friction(sph, cp, lags(2), reshape([(1.0_rp, k = 1, 9)], [3, 3]), f, kx)
  call check_true(all(f == 0.0_rp) .and. all(kx == 0.0_rp), 'lam = 0: no friction')

  ! the guard where the slip turns: the point (weights 0.2, 0.3, 0.5) slides at
  ! 5 eps_v along x relative to the sphere, the update takes it to -5.5 eps_v,
  ! all of it on the third node (0.5 of -21 eps_v): least at 5/10.5
  lags(2) = face_lag_t(w=[0.2_rp, 0.3_rp, 0.5_rp], n=[0.0_rp, 0.0_rp, 1.0_rp], lam=2.0_rp)
  do k = 1, 3
    vt(:, k) = sph%vel + [5.0e-3_rp, 0.0_rp, 0.0_rp]
  end do
  dvt = 0.0_rp
  dvt(:, 3) = [-21.0e-3_rp, 0.0_rp, 0.0_rp]
  call check_close(pair_turn(sph, cp, lags(2), vt, dvt), 5.0_rp / 10.5_rp, 1.0e-12_rp, 0.0_rp, &
                   'turn: the point''s slip by the weights, relative to the obstacle')
  dvt(:, 3) = [-11.0e-3_rp, 0.0_rp, 0.0_rp]
  call check_true(pair_turn(sph, cp, lags(2), vt, dvt) == 1.0_rp, 'turn: into the band, kept')
  smooth = sph
  smooth%mu = 0.0_rp
  dvt(:, 3) = [-21.0e-3_rp, 0.0_rp, 0.0_rp]
  call check_true(pair_turn(smooth, cp, lags(2), vt, dvt) == 1.0_rp, 'turn: no friction, kept')

  call check_report()

contains

  pure function unit3(a) result(r)
    real(rp), intent(in) :: a(3)
    real(rp) :: r(3)
    r = a / norm2(a)
  end function unit3

  pure function cross(a, b) result(r)
    real(rp), intent(in) :: a(3), b(3)
    real(rp) :: r(3)
    r = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
  end function cross

  !> Random node velocities whose point slides at about speed eps_v * scale: kv against FD of
  !> f, f tangential and distributed by w, |f| = mu lam when sliding, power = -f . u >= 0.
  subroutine friction_fd(o, lag, nn, scale)
    type(obstacle_t), intent(in) :: o
    type(face_lag_t), intent(in) :: lag
    integer, intent(in) :: nn
    real(rp), intent(in) :: scale
    real(rp) :: v(3, nn), f(3, nn), kv(3, 3, nn, nn), fp(3, nn), fm(3, nn), kd(3, 3, nn, nn), kfd(3 * nn, 3 * nn)
    real(rp) :: vp(3, nn), hv, fc(3), uu(3), m(3 * nn, 3 * nn), w(3 * nn), pw
    integer :: j, a, b, ic, jn
    call random_number(v)
    v = spread(o%vel, 2, nn) + cp%eps_v * scale * (v - 0.5_rp) + spread(0.7_rp * lag%n, 2, nn)
    call pair_friction(o, cp, lag, v, f, kv)
    hv = 1.0e-6_rp * cp%eps_v
    do j = 1, 3 * nn
      ic = mod(j - 1, 3) + 1
      jn = (j - ic) / 3 + 1
      vp = v
      vp(ic, jn) = vp(ic, jn) + hv
      call pair_friction(o, cp, lag, vp, fp, kd)
      vp(ic, jn) = vp(ic, jn) - 2.0_rp * hv
      call pair_friction(o, cp, lag, vp, fm, kd)
      kfd(:, j) = reshape(fp - fm, [3 * nn]) / (2.0_rp * hv)
    end do
    do b = 1, nn
      do a = 1, nn
        m(3 * a - 2:3 * a, 3 * b - 2:3 * b) = kv(:, :, a, b)
      end do
    end do
    call check_close_array(reshape(m, [9 * nn * nn]), reshape(kfd, [9 * nn * nn]), 1.0e-5_rp, 0.0_rp, &
                           'pair friction: kv against FD of f')
    fc = sum(f, dim=2)
    call check_close(dot_product(fc, lag%n), 0.0_rp, 0.0_rp, 1.0e-11_rp * norm2(fc), 'pair friction: tangential')
    do a = 1, nn
      call check_close_array(f(:, a), lag%w(a) * fc, 1.0e-13_rp, 1.0e-18_rp, 'pair friction: node share w_a f_c')
    end do
    uu = matmul(v, lag%w(1:nn)) - o%vel
    uu = uu - dot_product(uu, lag%n) * lag%n
    if (norm2(uu) > cp%eps_v) call check_close(norm2(fc), o%mu * lag%lam, 1.0e-13_rp, 0.0_rp, &
                                               'pair friction: sliding |f| = mu lam')
    pw = pair_friction_power(o, cp, lag, v)
    call check_close(pw, -dot_product(fc, uu), 1.0e-12_rp, 1.0e-20_rp, 'pair friction: power = -f . u')
    call check_true(pw >= 0.0_rp, 'pair friction: power >= 0')
    do j = 1, 50
      call random_number(w)
      w = w - 0.5_rp
      if (dot_product(w, matmul(-m, w)) < -1.0e-12_rp * maxval(abs(m)) * dot_product(w, w)) then
        call check_true(.false., 'pair friction: -kv PSD')
        exit
      end if
    end do
  end subroutine friction_fd

end program test_contact_face_friction
