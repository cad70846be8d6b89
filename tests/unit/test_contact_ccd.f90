! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the primitives' continuous collision detection (module
!> contact_ccd): ACCD of a point falling onto a triangle against the hand-
!> solved path; the trivial cases (start in contact, no motion, moving
!> away); ACCD of random point-triangle and edge-edge paths against a dense
!> sampling of the path (every sample before alpha apart, the kept fraction
!> s of the gap at alpha, alpha not later than the first sample below s gap0
!> and not earlier than ACCD's last step before it, alpha = 1 when the path
!> stays clear); and the step limit of whole cloth triangles (nodes, points
!> against the triangle, obstacle edges against its edges) near a moving
!> sphere, box and capsule against a dense sampling of the triangle along
!> the path, including a capsule that passes between two node columns and a
!> small sphere through a triangle's interior, which node contact misses.
program test_contact_ccd
  use kinds, only: rp
  use contact, only: obstacle_t, signed_distance, time_of_impact_moving, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE
  use contact_primitives, only: point_triangle_d2, edge_edge_d2
  use contact_ccd, only: accd_point_triangle, accd_edge_edge, accd_rate_bound, ccd_triangle, ccd_edge, ACCD_S
  use check, only: check_true, check_close, check_report, seed_random
  implicit none
  type(obstacle_t) :: ob(3)
  real(rp) :: rot(3, 3)
  real(rp), parameter :: TH = 0.002_rp
  integer :: k

  call seed_random(2021)
  rot = rotation([1.0_rp, 2.0_rp, 2.0_rp] / 3.0_rp, 0.7_rp)
  ob(1) = obstacle_t(shape=SHAPE_SPHERE, p=[0.1_rp, -0.2_rp, 0.05_rp], r=0.25_rp)
  ob(2) = obstacle_t(shape=SHAPE_BOX, p=[0.1_rp, 0.2_rp, -0.3_rp], h=[0.3_rp, 0.2_rp, 0.15_rp], axes=rot)
  ob(3) = obstacle_t(shape=SHAPE_CAPSULE, p=[-0.3_rp, 0.1_rp, 0.0_rp], q=[0.4_rp, -0.2_rp, 0.1_rp], r=0.01_rp)

  call hand_cases()
  call random_pairs(1)
  call random_pairs(2)
  call between_nodes()
  do k = 1, 3
    call random_triangles(ob(k))
  end do
  call check_report()

contains

  pure function rotation(k, t) result(r)
    real(rp), intent(in) :: k(3), t
    real(rp) :: r(3, 3), kx(3, 3)
    integer :: i
    kx = reshape([0.0_rp, k(3), -k(2), -k(3), 0.0_rp, k(1), k(2), -k(1), 0.0_rp], [3, 3])
    r = sin(t) * kx + (1.0_rp - cos(t)) * matmul(kx, kx)
    do i = 1, 3
      r(i, i) = r(i, i) + 1.0_rp
    end do
  end function rotation

  !> Gap of a pair (kind 1 point-triangle, 2 edge-edge) at x + t dx.
  real(rp) function gap_at(kind, x, dx, xi, t) result(gap)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(3, 4), dx(3, 4), xi, t
    real(rp) :: y(3, 4)
    y = x + t * dx
    if (kind == 1) then
      gap = sqrt(point_triangle_d2(y(:, 1), y(:, 2), y(:, 3), y(:, 4))) - xi
    else
      gap = sqrt(edge_edge_d2(y(:, 1), y(:, 2), y(:, 3), y(:, 4))) - xi
    end if
  end function gap_at

  subroutine hand_cases()
    real(rp) :: x(3, 4), dx(3, 4), a, ts, lp, g0
    ! p = (0.2, 0.2, 1) falls by 2 onto the triangle z = 0; xi = 0.1: gap 0.9 - 2 t
    x = reshape([0.2_rp, 0.2_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp], [3, 4])
    dx = 0.0_rp
    dx(3, 1) = -2.0_rp
    a = accd_point_triangle(x, dx, 0.1_rp, ACCD_S, 1.0_rp)
    ts = (0.9_rp - ACCD_S * 0.9_rp) / 2.0_rp          ! gap = s gap0 at ts = 0.405
    lp = accd_rate_bound(1, dx)
    call check_close(lp, 2.0_rp, 1.0e-15_rp, 0.0_rp, 'rate bound: |1.5| + |0.5| after the mean')
    call check_true(a <= ts .and. a > 0.0_rp, 'falling point: 0 < alpha <= t_s')
    call check_true(gap_at(1, x, dx, 0.1_rp, a) >= ACCD_S * 0.9_rp * (1.0_rp - 1.0e-12_rp), &
                    'falling point: gap(alpha) >= s gap0')
    call check_true(a >= ts - 0.9_rp * gap_at(1, x, dx, 0.1_rp, a) / lp, 'falling point: alpha within one ACCD step')
    print '(a,f8.5,a,f8.5)', 'falling point: alpha ', a, ', t_s ', ts
    ! start in contact: 0; at rest, or moving away: 1; a shorter window: tmax
    x(3, 1) = 0.05_rp
    call check_true(accd_point_triangle(x, dx, 0.1_rp, ACCD_S, 1.0_rp) == 0.0_rp, 'start within xi: 0')
    x(3, 1) = 1.0_rp
    call check_true(accd_point_triangle(x, 0.0_rp * dx, 0.1_rp, ACCD_S, 1.0_rp) == 1.0_rp, 'no motion: 1')
    call check_true(accd_point_triangle(x, -dx, 0.1_rp, ACCD_S, 1.0_rp) == 1.0_rp, 'moving away: 1')
    call check_true(accd_point_triangle(x, dx, 0.1_rp, ACCD_S, 0.2_rp) == 0.2_rp, 'clear up to tmax: tmax')
    ! a common translation is no relative motion: 1
    dx = spread([0.3_rp, -5.0_rp, 2.0_rp], 2, 4)
    call check_true(accd_point_triangle(x, dx, 0.1_rp, ACCD_S, 1.0_rp) == 1.0_rp, 'common translation: 1')
    ! sliding 1e-6 above the triangle's plane across it: ACCD_MAX_ITER steps of ~gap/l_p do not
    ! reach t = 1; the t reached is returned (safe, conservative)
    x = reshape([0.1_rp, 0.1_rp, 1.1e-6_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp], &
                [3, 4])
    dx = 0.0_rp
    dx(1, 1) = 0.5_rp
    a = accd_point_triangle(x, dx, 1.0e-6_rp, ACCD_S, 1.0_rp)
    call check_true(a > 0.0_rp .and. a < 1.0_rp .and. gap_at(1, x, dx, 1.0e-6_rp, a) > 0.0_rp, &
                    'sliding at a tiny gap: capped at a safe t in (0, 1)')
    print '(a,es10.3)', 'sliding at a tiny gap: alpha ', a
    ! skew edges closing head-on: edge b at height 1 falls by 2, xi = 0
    x = reshape([-1.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, -1.0_rp, 1.0_rp, 0.0_rp, 1.0_rp, 1.0_rp], [3, 4])
    dx = 0.0_rp
    dx(3, 3:4) = -2.0_rp
    a = accd_edge_edge(x, dx, 0.0_rp, ACCD_S, 1.0_rp)
    g0 = 1.0_rp
    ts = (1.0_rp - ACCD_S) / 2.0_rp
    call check_true(a <= ts .and. a >= ts - 0.9_rp * gap_at(2, x, dx, 0.0_rp, a) / accd_rate_bound(2, dx), &
                    'skew edges: alpha in [t_s - last step, t_s]')
  end subroutine hand_cases

  !> Random pairs moving on random paths against 2000 samples of each path.
  subroutine random_pairs(kind)
    integer, intent(in) :: kind
    integer, parameter :: NPATH = 400, NS = 2000
    real(rp) :: x(3, 4), dx(3, 4), xi, a, g0, gt, gmin, tfirst, lp, t, ga
    integer :: it, m, nbad, nhit, nclear, ncut
    character(len=20) :: what
    what = merge('point-triangle', 'edge-edge     ', kind == 1)
    nbad = 0
    nhit = 0
    nclear = 0
    ncut = 0
    do it = 1, NPATH
      call random_number(x)
      call random_number(dx)
      x = x - 0.5_rp
      dx = 1.5_rp * (dx - 0.5_rp)
      ! the first primitive heads for the second one's middle
      dx(:, 1) = dx(:, 1) + 1.2_rp * (0.5_rp * (x(:, 3) + x(:, 4)) - x(:, 1))
      if (kind == 2) dx(:, 2) = dx(:, 2) + 1.2_rp * (0.5_rp * (x(:, 3) + x(:, 4)) - x(:, 2))
      xi = 0.02_rp * mod(it, 3)
      g0 = gap_at(kind, x, dx, xi, 0.0_rp)
      if (g0 <= 0.0_rp) cycle
      if (kind == 1) then
        a = accd_point_triangle(x, dx, xi, ACCD_S, 1.0_rp)
      else
        a = accd_edge_edge(x, dx, xi, ACCD_S, 1.0_rp)
      end if
      lp = accd_rate_bound(kind, dx)
      gmin = huge(1.0_rp)
      tfirst = 2.0_rp
      do m = 0, NS
        t = real(m, rp) / NS
        gt = gap_at(kind, x, dx, xi, t)
        gmin = min(gmin, gt)
        if (t <= a .and. gt <= 0.0_rp) nbad = nbad + 1                 ! safety
        if (gt < ACCD_S * g0 .and. tfirst > 1.0_rp) tfirst = t
      end do
      if (gmin <= 0.0_rp) nhit = nhit + 1
      ga = gap_at(kind, x, dx, xi, a)
      if (ga < ACCD_S * g0 * (1.0_rp - 1.0e-10_rp)) nbad = nbad + 1   ! keeps s gap0
      if (a < 1.0_rp) then
        ncut = ncut + 1
        ! not after the first sample below s gap0, not before ACCD's last step to it
        if (a > tfirst) nbad = nbad + 1
        if (a < tfirst - 0.9_rp * ga / lp - 1.0_rp / NS) nbad = nbad + 1
      end if
      if (gmin > ACCD_S * g0 + lp / NS) then
        nclear = nclear + 1
        if (a /= 1.0_rp) nbad = nbad + 1
      end if
    end do
    print '(a,a,i0,a,i0,a,i0,a,i0)', trim(what), ': paths that touch ', nhit, ', cut ', ncut, ', clear ', nclear, &
      ', bad ', nbad
    call check_true(nbad == 0, trim(what)//' ACCD agrees with dense sampling of the path')
    call check_true(nhit > 40 .and. nclear > 40, trim(what)//' random paths: enough hits and clear paths')
  end subroutine random_pairs

  !> The obstacle translated by t dobs.
  function moved(o, t, dobs) result(om)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: t, dobs(3)
    type(obstacle_t) :: om
    om = o
    om%p = o%p + t * dobs
    om%q = o%q + t * dobs
  end function moved

  !> Smallest of signed distance - thickness over a barycentric grid of ng on triangle xt.
  real(rp) function sampled_gap(o, xt, ng) result(gmin)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: xt(3, 3)
    integer, intent(in) :: ng
    real(rp) :: d, g(3), hd(3, 3)
    integer :: i, j
    gmin = huge(1.0_rp)
    do j = 0, ng
      do i = 0, ng - j
        call signed_distance(o, xt(:, 1) + (real(i, rp) * (xt(:, 2) - xt(:, 1)) + real(j, rp) * (xt(:, 3) - xt(:, 1))) &
                             / ng, d, g, hd)
        gmin = min(gmin, d - TH)
      end do
    end do
  end function sampled_gap

  !> Step limits of triangle xt0 moving by dxt: nodes (exact, module contact) and faces/edges.
  subroutine limits(o, xt0, dxt, dobs, anode, aface)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: xt0(3, 3), dxt(3, 3), dobs(3)
    real(rp), intent(out) :: anode, aface
    integer :: j
    anode = 1.0_rp
    aface = ccd_triangle(o, TH, xt0, dxt, dobs, ACCD_S)
    do j = 1, 3
      anode = min(anode, time_of_impact_moving(o, TH, xt0(:, j), dxt(:, j), dobs))
      aface = min(aface, ccd_edge(o, TH, xt0(:, [j, mod(j, 3) + 1]), dxt(:, [j, mod(j, 3) + 1]), dobs, ACCD_S))
    end do
  end subroutine limits

  !> A capsule (r = 1 cm) lying between two node columns 5 cm apart, a quad falling through
  !> it: the nodes never come near, the edges across the axis do. And a sphere of 1 cm
  !> moving through the middle of a 10 cm triangle.
  subroutine between_nodes()
    type(obstacle_t) :: cap, sph
    real(rp) :: xq(3, 4), dq(3, 4), anode, aface, a1, a2, t
    integer :: m, nbad
    cap = obstacle_t(shape=SHAPE_CAPSULE, p=[0.025_rp, -0.1_rp, 0.0_rp], q=[0.025_rp, 0.2_rp, 0.0_rp], r=0.01_rp)
    xq = reshape([0.0_rp, 0.0_rp, 0.03_rp, 0.05_rp, 0.0_rp, 0.03_rp, 0.0_rp, 0.05_rp, 0.03_rp, 0.05_rp, 0.05_rp, 0.03_rp], &
                 [3, 4])
    dq = 0.0_rp
    dq(3, :) = -0.06_rp
    call limits(cap, xq(:, [1, 2, 4]), dq(:, [1, 2, 4]), [0.0_rp, 0.0_rp, 0.0_rp], anode, a1)
    call limits(cap, xq(:, [1, 4, 3]), dq(:, [1, 4, 3]), [0.0_rp, 0.0_rp, 0.0_rp], anode, a2)
    call check_true(anode == 1.0_rp, 'capsule between node columns: the nodes never touch')
    aface = min(a1, a2)
    call check_true(aface < 0.5_rp .and. aface > 0.0_rp, 'capsule between node columns: the edges stop the step')
    call check_true(sampled_gap(cap, xq(:, [1, 2, 4]) + 0.5_rp * dq(:, [1, 2, 4]), 40) < 0.0_rp, &
                    'capsule between node columns: the unlimited step goes through')
    nbad = 0
    do m = 0, 200
      t = aface * m / 200.0_rp
      if (sampled_gap(cap, xq(:, [1, 2, 4]) + t * dq(:, [1, 2, 4]), 40) <= 0.0_rp) nbad = nbad + 1
      if (sampled_gap(cap, xq(:, [1, 4, 3]) + t * dq(:, [1, 4, 3]), 40) <= 0.0_rp) nbad = nbad + 1
    end do
    call check_true(nbad == 0, 'capsule between node columns: the limited step stays clear')
    ! the same, the capsule rising into a resting quad
    call limits(cap, xq(:, [1, 2, 4]), 0.0_rp * dq(:, [1, 2, 4]), [0.0_rp, 0.0_rp, 0.06_rp], anode, a1)
    call check_close(a1, min(aface, a1), 0.0_rp, 0.0_rp, 'rising capsule: stopped as the falling quad')
    call check_true(a1 < 0.5_rp .and. anode == 1.0_rp, 'rising capsule: caught by the edges, not the nodes')
    ! a small sphere through a large triangle's middle
    sph = obstacle_t(shape=SHAPE_SPHERE, p=[0.03_rp, 0.03_rp, -0.05_rp], r=0.01_rp)
    call limits(sph, xq(:, [1, 2, 3]), 0.0_rp * dq(:, [1, 2, 3]), [0.0_rp, 0.0_rp, 0.2_rp], anode, aface)
    call check_true(anode == 1.0_rp .and. aface < 0.5_rp .and. aface > 0.0_rp, &
                    'small sphere through a triangle: nodes miss it, the face stops it')
    call check_true(sampled_gap(moved(sph, aface, [0.0_rp, 0.0_rp, 0.2_rp]), xq(:, [1, 2, 3]), 40) > 0.0_rp, &
                    'small sphere through a triangle: clear at alpha')
  end subroutine between_nodes

  !> Random triangles moving near a moving obstacle: for every sampled time up to
  !> min(node limit, face limit) every sampled point of the triangle is outside.
  subroutine random_triangles(o)
    type(obstacle_t), intent(in) :: o
    integer, parameter :: NTRI = 120, NT = 100, NG = 16
    real(rp) :: xt0(3, 3), dxt(3, 3), dobs(3), ctr(3), anode, aface, a, t, sz
    integer :: it, m, nbad, nhit, nfaces, nused
    logical :: hits
    ctr = o%p
    if (o%shape == SHAPE_CAPSULE) ctr = 0.5_rp * (o%p + o%q)
    sz = merge(0.08_rp, 0.6_rp, o%shape == SHAPE_CAPSULE)
    nbad = 0
    nhit = 0
    nfaces = 0
    nused = 0
    do it = 1, NTRI
      call random_number(xt0)
      call random_number(dxt)
      call random_number(dobs)
      xt0 = spread(ctr, 2, 3) + 2.0_rp * sz * (xt0 - 0.5_rp)
      xt0 = xt0 + spread(0.8_rp * sz * [0.0_rp, 0.0_rp, 1.0_rp], 2, 3)
      dxt = spread(-1.6_rp * sz * [0.0_rp, 0.0_rp, 1.0_rp], 2, 3) + 0.5_rp * sz * (dxt - 0.5_rp)
      dobs = 0.3_rp * sz * (dobs - 0.5_rp)
      if (sampled_gap(o, xt0, NG) <= 0.01_rp * sz) cycle
      nused = nused + 1
      call limits(o, xt0, dxt, dobs, anode, aface)
      a = min(anode, aface)
      hits = .false.
      do m = 0, NT
        t = real(m, rp) / NT
        if (sampled_gap(moved(o, t, dobs), xt0 + t * dxt, NG) <= 0.0_rp) hits = .true.
        ! up to alpha, not at it: the nodes' exact limit has gap 0 there
        t = min(t, 1.0_rp - 1.0e-9_rp)
        if (sampled_gap(moved(o, t * a, dobs), xt0 + t * a * dxt, NG) <= 0.0_rp) nbad = nbad + 1
      end do
      if (hits) nhit = nhit + 1
      if (aface < anode) nfaces = nfaces + 1
    end do
    print '(a,i0,a,i0,a,i0,a,i0,a,i0)', 'shape ', o%shape, ': triangles ', nused, ', paths that enter ', nhit, &
      ', limited by faces or edges ', nfaces, ', bad ', nbad
    call check_true(nbad == 0, 'random triangles: the limited path stays outside the obstacle')
    call check_true(nhit > 20 .and. nfaces > 5, 'random triangles: enough entering paths, some limited by faces')
  end subroutine random_triangles

end program test_contact_ccd
