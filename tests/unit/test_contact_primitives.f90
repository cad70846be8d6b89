! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the contact primitives (module contact_primitives): the
!> squared point-triangle and edge-edge distances against closed forms (a
!> point above a triangle's interior, beside an edge, off a corner; skew
!> lines, also moved rigidly; two ends nearest; parallel edges), against a
!> brute-force minimum over a grid of the primitives' parameters, and their
!> gradients and Hessians against central finite differences of the distance
!> and of the gradient at random configurations of every closest-feature type;
!> the distance-only functions against the full ones; IPC's edge-edge
!> mollifier against finite differences, its limits and its C1 end; the
!> positive semidefinite projection of a 9 x 9 matrix of known eigenvectors.
program test_contact_primitives
  use kinds, only: rp
  use contact_primitives, only: point_triangle_distance, edge_edge_distance, point_triangle_d2, edge_edge_d2, &
                                point_triangle_type, edge_edge_type, edge_edge_mollifier, psd_project, &
                                PT_P_T0, PT_P_E01, PT_P_PLANE, EE_A1_B0, EE_LINES
  use check, only: check_true, check_close, check_close_array, check_report, seed_random
  use strings, only: itoa
  implicit none
  real(rp) :: d2, g(12), h(12, 12), r(3), rot(3, 3), sh(3), hh
  integer :: ty

  call seed_random(4711)
  rot = rotation([1.0_rp, 2.0_rp, 2.0_rp] / 3.0_rp, 0.7_rp)
  sh = [0.3_rp, -1.2_rp, 2.5_rp]

  ! ---- point-triangle closed forms ----------------------------------------
  ! p above the interior of the unit right triangle at height 0.5: plane type, d2 = 0.25,
  ! r = (0, 0, 0.5), barycentric weights (0.5, 0.2, 0.3) of the foot.
  call point_triangle_distance([0.2_rp, 0.3_rp, 0.5_rp], [0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], &
                               [0.0_rp, 1.0_rp, 0.0_rp], d2, g, h, ty)
  call check_true(ty == PT_P_PLANE, 'pt above interior: plane type')
  call check_close(d2, 0.25_rp, 1.0e-15_rp, 0.0_rp, 'pt above interior: d2')
  r = [0.0_rp, 0.0_rp, 0.5_rp]
  call check_close_array(g, [2.0_rp * r, -1.0_rp * r, -0.4_rp * r, -0.6_rp * r], 1.0e-14_rp, 0.0_rp, &
                         'pt above interior: gradient 2 c (x) r')
  call check_close_array(reshape(h(1:3, 1:3), [9]), [0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, &
                         2.0_rp], 0.0_rp, 1.0e-14_rp, 'pt above interior: d2 hessian in p = 2 n n^T')
  ! the same configuration moved rigidly: same d2, gradient rotated
  call point_triangle_distance(sh + matmul(rot, [0.2_rp, 0.3_rp, 0.5_rp]), sh, sh + rot(:, 1), sh + rot(:, 2), &
                               d2, g, h, ty)
  call check_close(d2, 0.25_rp, 1.0e-14_rp, 0.0_rp, 'pt above interior, moved: d2')
  call check_close_array(g(1:3), matmul(rot, [0.0_rp, 0.0_rp, 1.0_rp]), 1.0e-14_rp, 1.0e-15_rp, &
                         'pt above interior, moved: gradient in p')
  ! beside edge t0-t1 at (0.5, 0, 0): d2 = 1 + 1
  call point_triangle_distance([0.5_rp, -1.0_rp, 1.0_rp], [0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], &
                               [0.0_rp, 1.0_rp, 0.0_rp], d2, g, h, ty)
  call check_true(ty == PT_P_E01, 'pt beside edge 01: type')
  call check_close(d2, 2.0_rp, 1.0e-15_rp, 0.0_rp, 'pt beside edge 01: d2')
  ! off corner t0
  call point_triangle_distance([-1.0_rp, -1.0_rp, 0.5_rp], [0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], &
                               [0.0_rp, 1.0_rp, 0.0_rp], d2, g, h, ty)
  call check_true(ty == PT_P_T0, 'pt off corner t0: type')
  call check_close(d2, 2.25_rp, 1.0e-15_rp, 0.0_rp, 'pt off corner t0: d2')

  ! ---- edge-edge closed forms ---------------------------------------------
  ! skew lines: x axis and a line along y at height hh, crossing at their middles
  hh = 0.3_rp
  call edge_edge_distance([-1.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], [0.0_rp, -1.0_rp, hh], &
                          [0.0_rp, 1.0_rp, hh], d2, g, h, ty)
  call check_true(ty == EE_LINES, 'skew lines: type')
  call check_close(d2, hh * hh, 1.0e-15_rp, 0.0_rp, 'skew lines: d2 = h^2')
  r = [0.0_rp, 0.0_rp, -hh]
  call check_close_array(g, [r, r, -r, -r], 1.0e-14_rp, 0.0_rp, 'skew lines: gradient (s = t = 1/2)')
  call edge_edge_distance(sh + matmul(rot, [-1.0_rp, 0.0_rp, 0.0_rp]), sh + matmul(rot, [2.0_rp, 0.0_rp, 0.0_rp]), &
                          sh + matmul(rot, [0.0_rp, -1.0_rp, hh]), sh + matmul(rot, [0.0_rp, 3.0_rp, hh]), d2, g, h, ty)
  call check_close(d2, hh * hh, 1.0e-13_rp, 0.0_rp, 'skew lines, moved: d2 = h^2')
  ! two ends nearest: a1 = (1,0,0), b0 = (2,1,0)
  call edge_edge_distance([0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], [2.0_rp, 1.0_rp, 0.0_rp], &
                          [3.0_rp, 2.0_rp, 0.0_rp], d2, g, h, ty)
  call check_true(ty == EE_A1_B0, 'ends a1, b0: type')
  call check_close(d2, 2.0_rp, 1.0e-15_rp, 0.0_rp, 'ends a1, b0: d2')
  ! parallel edges 1 apart, overlapping: a point-edge type, d2 = 1, finite derivatives
  call edge_edge_distance([0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], [0.5_rp, 1.0_rp, 0.0_rp], &
                          [1.5_rp, 1.0_rp, 0.0_rp], d2, g, h, ty)
  call check_true(ty /= EE_LINES, 'parallel edges: not the line-line type')
  call check_close(d2, 1.0_rp, 1.0e-15_rp, 0.0_rp, 'parallel edges: d2')
  call check_true(all(abs(h) < 10.0_rp) .and. all(abs(g) <= 2.0_rp), 'parallel edges: bounded derivatives')
  ! parallel up to round-off: two lattice diagonals of spacing 0.01 made of rounded
  ! differences, sqrt(2) spacings apart (Lagrange's aa bb - ab^2 took them for lines at 0)
  call edge_edge_distance([0.01_rp, 0.01_rp, 0.0_rp], [0.0_rp, 0.02_rp, 0.0_rp], [0.02_rp, 0.02_rp, 0.0_rp], &
                          [0.01_rp, 0.03_rp, 0.0_rp], d2, g, h, ty)
  call check_close(d2, 2.0e-4_rp, 1.0e-12_rp, 0.0_rp, 'parallel lattice diagonals: d2 = (sqrt 2 spacing)^2')

  ! ---- lattice diagonals of rounded coordinates: parallel and collinear --------
  call lattice_diagonals()

  ! ---- every type: random configurations -----------------------------------
  call random_types_pt()
  call random_types_ee()

  ! ---- mollifier ------------------------------------------------------------
  call mollifier_cases()

  ! ---- PSD projection -------------------------------------------------------
  call psd_cases()

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

  !> Diagonals of a flat lattice in a random plane: nodes o + R (i a, j a, 0) in floating
  !> point (the coordinates rounded; the edges' vectors rounded differences, as a sheet
  !> moved by round-off), at spacings of 0.5 m / 128, / 256, / 1024 and 1 cm, 400 random
  !> origins, rotations and nodes each: beside each other in the next quad along x
  !> (parallel, a / sqrt 2 apart) and one quad further along their own line (collinear,
  !> their ends sqrt 2 a apart), also with the second edge raised off the plane by a
  !> round-off (1e-15 a). Lagrange's aa bb - ab^2 for |a x b|^2 is round-off there
  !> (~1e-16 aa bb, above the parallel threshold), and the lines' distance, about 0, was
  !> taken for the edges' (a gap of 0 on a flat sheet at 257 x 257). Every distance must
  !> be the exact one to 1e-9 of it, for both diagonal directions.
  subroutine lattice_diagonals()
    real(rp), parameter :: spacing(4) = [0.5_rp / 128, 0.5_rp / 256, 0.5_rp / 1024, 0.01_rp]
    real(rp) :: a, o(3), u(8), d2e, d2, pa(3, 2), pb(3, 2), z(3), rt(3, 3), ax(3)
    integer :: k, m, i, j, dir, kind, bad, tried
    bad = 0
    tried = 0
    do k = 1, size(spacing)
      a = spacing(k)
      do m = 1, 400
        call random_number(u)
        o = [u(1) - 0.5_rp, u(2) - 0.5_rp, u(3)]
        ax = u(5:7) - 0.5_rp
        rt = rotation(ax / norm2(ax), 6.0_rp * u(8))
        i = int(u(4) * 1000)
        j = mod(7 * i + m, 1000)
        do dir = 1, 2
          do kind = 1, 3
            ! the first diagonal: (i, j)-(i+1, j+1), or (i+1, j)-(i, j+1)
            pa(:, 1) = lattice_node(o, rt, a, i + merge(0, 1, dir == 1), j)
            pa(:, 2) = lattice_node(o, rt, a, i + merge(1, 0, dir == 1), j + 1)
            z = merge(1.0e-15_rp * a, 0.0_rp, kind == 3) * rt(:, 3)
            if (kind == 1) then
              pb(:, 1) = lattice_node(o, rt, a, i + 1 + merge(0, 1, dir == 1), j)
              pb(:, 2) = lattice_node(o, rt, a, i + 1 + merge(1, 0, dir == 1), j + 1)
              d2e = 0.5_rp * a * a
            else
              pb(:, 1) = lattice_node(o, rt, a, i + merge(2, -1, dir == 1), j + 2) + z
              pb(:, 2) = lattice_node(o, rt, a, i + merge(3, -2, dir == 1), j + 3) + z
              d2e = 2.0_rp * a * a
            end if
            d2 = edge_edge_d2(pa(:, 1), pa(:, 2), pb(:, 1), pb(:, 2))
            tried = tried + 1
            if (abs(d2 - d2e) > 1.0e-9_rp * d2e) bad = bad + 1
            call edge_edge_distance(pa(:, 1), pa(:, 2), pb(:, 1), pb(:, 2), d2, g, h, ty)
            if (abs(d2 - d2e) > 1.0e-9_rp * d2e) bad = bad + 1
          end do
        end do
      end do
    end do
    call check_true(bad == 0, 'lattice diagonals, parallel and collinear, rounded coordinates: '// &
                    'the exact distance in all of 2 x '//itoa(tried)//' (wrong: '//itoa(bad)//')')
  end subroutine lattice_diagonals

  !> Node (ii, jj) of lattice_diagonals' lattice: o + rt (ii a, jj a, 0) in floating point.
  pure function lattice_node(o, rt, a, ii, jj) result(p)
    real(rp), intent(in) :: o(3), rt(3, 3), a
    integer, intent(in) :: ii, jj
    real(rp) :: p(3)
    p = o + matmul(rt, [ii * a, jj * a, 0.0_rp])
  end function lattice_node

  !> Squared distance, gradient, Hessian and type of a pair (kind 1: point-triangle, 2: edge-edge).

  subroutine pair(kind, x, d2, g, h, ty)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(12)
    real(rp), intent(out) :: d2, g(12), h(12, 12)
    integer, intent(out) :: ty
    if (kind == 1) then
      call point_triangle_distance(x(1:3), x(4:6), x(7:9), x(10:12), d2, g, h, ty)
    else
      call edge_edge_distance(x(1:3), x(4:6), x(7:9), x(10:12), d2, g, h, ty)
    end if
  end subroutine pair

  integer function pair_type(kind, x) result(ty)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(12)
    if (kind == 1) then
      ty = point_triangle_type(x(1:3), x(4:6), x(7:9), x(10:12))
    else
      ty = edge_edge_type(x(1:3), x(4:6), x(7:9), x(10:12))
    end if
  end function pair_type

  !> Brute-force minimum of the squared distance over a grid of the primitives' parameters.
  real(rp) function grid_min(kind, x) result(dm)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(12)
    integer, parameter :: NG = 120
    integer :: i, j
    real(rp) :: s, t, q(3)
    dm = huge(1.0_rp)
    do j = 0, NG
      do i = 0, NG
        s = real(i, rp) / NG
        t = real(j, rp) / NG
        if (kind == 1) then
          if (i + j > NG) cycle
          q = x(1:3) - ((1.0_rp - s - t) * x(4:6) + s * x(7:9) + t * x(10:12))
        else
          q = (1.0_rp - s) * x(1:3) + s * x(4:6) - (1.0_rp - t) * x(7:9) - t * x(10:12)
        end if
        dm = min(dm, dot_product(q, q))
      end do
    end do
  end function grid_min

  !> One configuration x of a pair: d2 against the grid, the d2-only function, and (when the
  !> type is the same within +-5 h of x in every coordinate) g and h against central differences.
  !> ok: the finite-difference checks ran.
  subroutine fd_pair(kind, x, ty, ok)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(12)
    integer, intent(out) :: ty
    logical, intent(out) :: ok
    real(rp), parameter :: hx = 1.0e-6_rp
    real(rp) :: d0, g0(12), h0(12, 12), dp, dm, gp(12), gm(12), hd(12, 12), gfd(12), hfd(12, 12), xp(12), dg, dd
    integer :: j, tp

    call pair(kind, x, d0, g0, h0, ty)
    dg = grid_min(kind, x)
    if (kind == 1) then
      dd = point_triangle_d2(x(1:3), x(4:6), x(7:9), x(10:12))
    else
      dd = edge_edge_d2(x(1:3), x(4:6), x(7:9), x(10:12))
    end if
    call check_close(dd, d0, 1.0e-14_rp, 1.0e-16_rp, 'd2-only function = full one')
    call check_true(d0 <= dg * (1.0_rp + 1.0e-12_rp) + 1.0e-14_rp .and. dg - d0 <= 0.05_rp * (sqrt(d0) + 0.05_rp), &
                    'd2 = the minimum over the primitives (brute-force grid)')
    ok = .false.
    do j = 1, 12
      xp = x
      xp(j) = x(j) + 5.0_rp * hx
      tp = pair_type(kind, xp)
      if (tp /= ty) return
      xp(j) = x(j) - 5.0_rp * hx
      tp = pair_type(kind, xp)
      if (tp /= ty) return
    end do
    ok = .true.
    do j = 1, 12
      xp = x
      xp(j) = x(j) + hx
      call pair(kind, xp, dp, gp, hd, tp)
      xp(j) = x(j) - hx
      call pair(kind, xp, dm, gm, hd, tp)
      gfd(j) = (dp - dm) / (2.0_rp * hx)
      hfd(:, j) = (gp - gm) / (2.0_rp * hx)
    end do
    call check_close_array(g0, gfd, 1.0e-7_rp, 1.0e-9_rp, 'gradient against FD of d2')
    call check_close_array(reshape(h0, [144]), reshape(hfd, [144]), 1.0e-5_rp, 1.0e-7_rp, 'Hessian against FD of g')
    call check_close_array(reshape(h0, [144]), reshape(transpose(h0), [144]), 1.0e-13_rp, 1.0e-14_rp, &
                           'Hessian symmetric')
  end subroutine fd_pair

  !> Random point-triangle configurations until every one of the 7 types had 4 FD checks.
  subroutine random_types_pt()
    integer :: ngood(7), it, ty
    real(rp) :: x(12)
    logical :: ok
    ngood = 0
    do it = 1, 20000
      call random_number(x)
      x = 2.0_rp * x - 1.0_rp
      x(1:3) = 2.0_rp * x(1:3)
      if (ngood(point_triangle_type(x(1:3), x(4:6), x(7:9), x(10:12))) >= 4) cycle
      call fd_pair(1, x, ty, ok)
      if (ok) ngood(ty) = ngood(ty) + 1
      if (all(ngood >= 4)) exit
    end do
    print '(a,7i3)', 'point-triangle FD checks per type: ', ngood
    call check_true(all(ngood >= 4), 'point-triangle: every type checked against FD')
  end subroutine random_types_pt

  !> Random edge-edge configurations until every one of the 9 types had 4 FD checks.
  subroutine random_types_ee()
    integer :: ngood(9), it, ty
    real(rp) :: x(12)
    logical :: ok
    ngood = 0
    do it = 1, 20000
      call random_number(x)
      x = 2.0_rp * x - 1.0_rp
      if (ngood(edge_edge_type(x(1:3), x(4:6), x(7:9), x(10:12))) >= 4) cycle
      call fd_pair(2, x, ty, ok)
      if (ok) ngood(ty) = ngood(ty) + 1
      if (all(ngood >= 4)) exit
    end do
    print '(a,9i3)', 'edge-edge FD checks per type: ', ngood
    call check_true(all(ngood >= 4), 'edge-edge: every type checked against FD')
  end subroutine random_types_ee

  !> k, gk, hk of nearly parallel edges against FD; k = 1 beyond eps_x; k(parallel) = 0; C1 at eps_x.
  subroutine mollifier_cases()
    real(rp), parameter :: hx = 1.0e-7_rp
    real(rp) :: x(12), xp(12), k0, g0(12), h0(12, 12), kp, km, gp(12), gm(12), gfd(12), hfd(12, 12), hd(12, 12)
    real(rp) :: eps_x, c
    integer :: j, n
    eps_x = 1.0e-3_rp * 4.0_rp * 1.0_rp
    do n = 1, 3
      ! a: length 2 along x; b: length 1, tilted by a small angle in two planes
      x(1:3) = [-1.0_rp, 0.0_rp, 0.0_rp]
      x(4:6) = [1.0_rp, 0.0_rp, 0.0_rp]
      x(7:9) = [0.1_rp, 0.2_rp, 0.1_rp]
      x(10:12) = x(7:9) + [1.0_rp, 0.008_rp * n, -0.005_rp * n]
      c = sum(cross(x(4:6) - x(1:3), x(10:12) - x(7:9))**2)
      call check_true(c < eps_x, 'mollifier test pair below eps_x')
      call edge_edge_mollifier(x(1:3), x(4:6), x(7:9), x(10:12), eps_x, k0, g0, h0)
      call check_close(k0, (2.0_rp - c / eps_x) * c / eps_x, 1.0e-12_rp, 0.0_rp, 'mollifier closed form')
      do j = 1, 12
        xp = x
        xp(j) = x(j) + hx
        call edge_edge_mollifier(xp(1:3), xp(4:6), xp(7:9), xp(10:12), eps_x, kp, gp, hd)
        xp(j) = x(j) - hx
        call edge_edge_mollifier(xp(1:3), xp(4:6), xp(7:9), xp(10:12), eps_x, km, gm, hd)
        gfd(j) = (kp - km) / (2.0_rp * hx)
        hfd(:, j) = (gp - gm) / (2.0_rp * hx)
      end do
      call check_close_array(g0, gfd, 1.0e-6_rp, 1.0e-9_rp, 'mollifier gradient against FD')
      call check_close_array(reshape(h0, [144]), reshape(hfd, [144]), 1.0e-5_rp, 1.0e-7_rp, &
                             'mollifier Hessian against FD')
    end do
    call edge_edge_mollifier([0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], [0.0_rp, 1.0_rp, 0.0_rp], &
                             [3.0_rp, 1.0_rp, 0.0_rp], eps_x, k0, g0, h0)
    call check_true(k0 == 0.0_rp, 'mollifier: parallel edges give 0')
    call edge_edge_mollifier([0.0_rp, 0.0_rp, 0.0_rp], [1.0_rp, 0.0_rp, 0.0_rp], [0.0_rp, 1.0_rp, 0.0_rp], &
                             [0.0_rp, 1.0_rp, 1.0_rp], eps_x, k0, g0, h0)
    call check_true(k0 == 1.0_rp .and. all(g0 == 0.0_rp) .and. all(h0 == 0.0_rp), 'mollifier: 1 beyond eps_x')
    ! C1 at eps_x: b tilted so that c = eps_x (1 - 1e-8): k ~ 1, |gk| ~ 0
    x(1:3) = [0.0_rp, 0.0_rp, 0.0_rp]
    x(4:6) = [1.0_rp, 0.0_rp, 0.0_rp]
    x(7:9) = [0.0_rp, 1.0_rp, 0.0_rp]
    x(10:12) = [1.0_rp, 1.0_rp, sqrt(eps_x * (1.0_rp - 1.0e-8_rp))]
    call edge_edge_mollifier(x(1:3), x(4:6), x(7:9), x(10:12), eps_x, k0, g0, h0)
    call check_true(abs(k0 - 1.0_rp) < 1.0e-12_rp .and. maxval(abs(g0)) < 1.0e-6_rp, 'mollifier C1 at eps_x')
    call edge_edge_mollifier(x(1:3), x(4:6), x(7:9), x(10:12), 0.0_rp, k0, g0, h0)
    call check_true(k0 == 1.0_rp, 'mollifier off for eps_x = 0')
  end subroutine mollifier_cases

  !> Q diag(lam) Q^T with mixed signs -> Q diag(max(lam, 0)) Q^T; a PSD matrix is kept.
  subroutine psd_cases()
    real(rp) :: q(9, 9), a(9, 9), p(9, 9), lam(9), v(9)
    integer :: i, j
    call random_number(q)
    do j = 1, 9
      do i = 1, j - 1
        q(:, j) = q(:, j) - dot_product(q(:, i), q(:, j)) * q(:, i)
      end do
      q(:, j) = q(:, j) / norm2(q(:, j))
    end do
    lam = [3.0_rp, -2.0_rp, 1.0_rp, 0.5_rp, -0.1_rp, 7.0_rp, -5.0_rp, 0.0_rp, 2.0_rp]
    a = matmul(q, matmul(diag(lam), transpose(q)))
    p = a
    call psd_project(p)
    call check_close_array(reshape(p, [81]), reshape(matmul(q, matmul(diag(max(lam, 0.0_rp)), transpose(q))), [81]), &
                           0.0_rp, 1.0e-12_rp, 'psd_project clips the negative eigenvalues (9 x 9)')
    a = p
    call psd_project(p)
    call check_close_array(reshape(p, [81]), reshape(a, [81]), 0.0_rp, 1.0e-12_rp, 'psd_project keeps a PSD matrix')
    call random_number(v)
    call check_true(dot_product(v, matmul(p, v)) >= -1.0e-12_rp, 'projected matrix PSD on a random vector')
  end subroutine psd_cases

  pure function diag(v) result(a)
    real(rp), intent(in) :: v(:)
    real(rp) :: a(size(v), size(v))
    integer :: i
    a = 0.0_rp
    do i = 1, size(v)
      a(i, i) = v(i)
    end do
  end function diag

  pure function cross(a, b) result(r)
    real(rp), intent(in) :: a(3), b(3)
    real(rp) :: r(3)
    r = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
  end function cross

end program test_contact_primitives
