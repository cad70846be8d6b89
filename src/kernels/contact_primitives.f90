! SPDX-License-Identifier: BSD-2-Clause
!> Squared distances of the contact primitives of IPC (Li et al. 2020,
!> "Incremental Potential Contact"): a point against a triangle and an edge
!> against an edge, piecewise by the closest-feature type (point-point,
!> point-edge, point-plane; for two edges also line-line), each with its
!> gradient (12) and Hessian (12 x 12) with respect to the four points; IPC's
!> edge-edge mollifier for nearly parallel edges; the positive semidefinite
!> projection of a small symmetric matrix.
!>
!> Every type is one form: the difference of the two closest points is
!> r = sum_k c_k x_k, with coefficients c affine in the m free parameters u
!> of the type (m = 0 for point-point, 1 for point-edge, 2 for point-plane
!> and line-line), d2 = |r|^2 at the minimising u. Then (u* minimises f = |r|^2)
!>   grad d2 = 2 c (x) r,    hess d2 = 2 c c^T (x) I - B F^-1 B^T,
!> with F = f_uu = 2 [D_i . D_j], D_j = dr/du_j, and B = f_xu, block k,
!> column j: 2 (c_k D_j + dc_k/du_j r) (implicit differentiation of the
!> minimum). This is the same function, gradient and Hessian as IPC's
!> per-type closed forms (its supplement); one routine serves every type.
!> Nearly parallel edges (|a x b|^2 <= PARALLEL_REL |a|^2 |b|^2) take the
!> smallest of the four point-edge distances, which is their distance
!> (documented fallback); the mollifier makes the edge-edge energy smooth there.
!> Plain arrays only: no PETSc, no MPI, no allocation.
module contact_primitives
  use kinds, only: rp
  use vec3, only: cross
  implicit none
  private
  public :: point_triangle_distance, edge_edge_distance, point_triangle_d2, edge_edge_d2
  public :: point_triangle_type, edge_edge_type, point_triangle_closest, edge_edge_closest
  public :: edge_edge_mollifier, psd_project, point_triangle_range
  public :: PT_P_T0, PT_P_T1, PT_P_T2, PT_P_E01, PT_P_E12, PT_P_E20, PT_P_PLANE
  public :: EE_A0_B0, EE_A0_B1, EE_A1_B0, EE_A1_B1, EE_A0_EB, EE_A1_EB, EE_EA_B0, EE_EA_B1, EE_LINES
  public :: PARALLEL_REL

  ! Point-triangle (p; t0, t1, t2) closest features: a vertex, an edge (ti-tj) or the plane.
  integer, parameter :: PT_P_T0 = 1, PT_P_T1 = 2, PT_P_T2 = 3, PT_P_E01 = 4, PT_P_E12 = 5, PT_P_E20 = 6, &
                        PT_P_PLANE = 7
  ! Edge-edge (a0-a1; b0-b1): two end points, an end point against the other edge (EB: edge b,
  ! EA: edge a), or the two lines.
  integer, parameter :: EE_A0_B0 = 1, EE_A0_B1 = 2, EE_A1_B0 = 3, EE_A1_B1 = 4, EE_A0_EB = 5, EE_A1_EB = 6, &
                        EE_EA_B0 = 7, EE_EA_B1 = 8, EE_LINES = 9
  !> Edges with |a x b|^2 <= PARALLEL_REL |a|^2 |b|^2 count as parallel (IPC's choice).
  real(rp), parameter :: PARALLEL_REL = 1.0e-20_rp
  !> The lines' closest points are taken for the edges' only where their difference is off
  !> the common normal by at most this times |a|^2 + |b|^2 (squared: 1e-6 of an edge's
  !> length; round-off of well-posed edges is some 1e-16).
  real(rp), parameter :: OFF_NORMAL_REL = 1.0e-12_rp

  real(rp), parameter :: EYE(3, 3) = reshape([1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp], &
                                             [3, 3])

contains

  ! ------------------------------------------------------------------------
  ! Closest-feature types and the coefficients of r
  ! ------------------------------------------------------------------------

  !> Parameter t in [0, 1] of the point of segment a-b nearest to p, and its squared distance.
  pure subroutine point_segment(p, a, b, t, d2)
    real(rp), intent(in) :: p(3), a(3), b(3)
    real(rp), intent(out) :: t, d2
    real(rp) :: e(3), ee

    e = b - a
    ee = dot_product(e, e)
    t = 0.0_rp
    if (ee > 0.0_rp) t = min(1.0_rp, max(0.0_rp, dot_product(p - a, e) / ee))
    d2 = sum((p - a - t * e)**2)
  end subroutine point_segment

  !> Closest-feature type of p against triangle t0 t1 t2 (a PT_* code), with the
  !> coefficients c of r = c1 p + c2 t0 + c3 t1 + c4 t2 and their derivatives dc(:, 1:m)
  !> in the type's m free parameters. A degenerate triangle (zero area) has no plane type.
  pure subroutine point_triangle_closest(p, t0, t1, t2, ty, c, dc, m)
    real(rp), intent(in) :: p(3), t0(3), t1(3), t2(3)
    integer, intent(out) :: ty
    real(rp), intent(out) :: c(4), dc(4, 2)
    integer, intent(out) :: m
    real(rp) :: e1(3), e2(3), w(3), a11, a12, a22, b1, b2, det, s, t, tt(3), dd(3)
    integer :: k

    c = 0.0_rp
    dc = 0.0_rp
    e1 = t1 - t0
    e2 = t2 - t0
    w = p - t0
    a11 = dot_product(e1, e1)
    a12 = dot_product(e1, e2)
    a22 = dot_product(e2, e2)
    det = a11 * a22 - a12 * a12
    if (det > 1.0e-14_rp * a11 * a22) then
      b1 = dot_product(e1, w)
      b2 = dot_product(e2, w)
      s = (a22 * b1 - a12 * b2) / det
      t = (a11 * b2 - a12 * b1) / det
      if (s >= 0.0_rp .and. t >= 0.0_rp .and. s + t <= 1.0_rp) then
        ty = PT_P_PLANE
        m = 2
        c = [1.0_rp, -(1.0_rp - s - t), -s, -t]
        dc(:, 1) = [0.0_rp, 1.0_rp, -1.0_rp, 0.0_rp]
        dc(:, 2) = [0.0_rp, 1.0_rp, 0.0_rp, -1.0_rp]
        return
      end if
    end if
    ! Outside the triangle (or degenerate): the nearest point is on an edge.
    call point_segment(p, t0, t1, tt(1), dd(1))
    call point_segment(p, t1, t2, tt(2), dd(2))
    call point_segment(p, t2, t0, tt(3), dd(3))
    k = minloc(dd, dim=1)
    c(1) = 1.0_rp
    m = 0
    if (tt(k) <= 0.0_rp) then
      ty = PT_P_T0 + k - 1                 ! the edge's first vertex: t0, t1, t2 for k = 1, 2, 3
      c(1 + k) = -1.0_rp
    else if (tt(k) >= 1.0_rp) then
      ty = PT_P_T0 + mod(k, 3)             ! its second vertex: t1, t2, t0
      c(1 + mod(k, 3) + 1) = -1.0_rp
    else
      ty = PT_P_E01 + k - 1
      m = 1
      c(1 + k) = -(1.0_rp - tt(k))
      c(1 + mod(k, 3) + 1) = -tt(k)
      dc(1 + k, 1) = 1.0_rp
      dc(1 + mod(k, 3) + 1, 1) = -1.0_rp
    end if
  end subroutine point_triangle_closest

  !> Closest-feature type of edges a0-a1 and b0-b1 (an EE_* code), with the coefficients c
  !> of r = c1 a0 + c2 a1 + c3 b0 + c4 b1 (r = point on a - point on b) and dc(:, 1:m).
  !> Parallel edges (PARALLEL_REL) and lines whose nearest points fall outside either edge
  !> take the nearest of the four end-point-against-edge pairs: the least of a convex
  !> function on the square of parameters lies on its border.
  pure subroutine edge_edge_closest(a0, a1, b0, b1, ty, c, dc, m)
    real(rp), intent(in) :: a0(3), a1(3), b0(3), b1(3)
    integer, intent(out) :: ty
    real(rp), intent(out) :: c(4), dc(4, 2)
    integer, intent(out) :: m
    real(rp) :: a(3), b(3), w(3), aa, ab, bb, aw, bw, det, s, t, tt(4), dd(4)
    integer :: k

    dc = 0.0_rp
    a = a1 - a0
    b = b1 - b0
    w = a0 - b0
    aa = dot_product(a, a)
    ab = dot_product(a, b)
    bb = dot_product(b, b)
    ! det = |a x b|^2 from the cross product: aa bb - ab^2 (Lagrange) cancels to a
    ! round-off of ~1e-16 aa bb, far above PARALLEL_REL, and two parallel edges whose
    ! coordinates are rounded differences (lattice diagonals) passed as lines with the
    ! normal's round-off for n: distance 0 (found by self-contact's broad phase).
    det = sum(cross(a, b)**2)
    if (det > PARALLEL_REL * aa * bb .and. det > 0.0_rp) then
      aw = dot_product(a, w)
      bw = dot_product(b, w)
      s = (ab * bw - bb * aw) / det
      t = (aa * bw - ab * aw) / det
      ! The lines' closest points only where they are the segments' too: inside both, and
      ! their difference along the common normal. Nearly collinear edges (a lattice line's
      ! diagonals one quad apart) pass the parallel test with s, t of the cancellation's
      ! round-off, which may fall inside while the points lie a spacing apart: the lines'
      ! distance (about 0) is then not theirs (found at 257 x 257: a gap of 0 on a flat sheet).
      if (s >= 0.0_rp .and. s <= 1.0_rp .and. t >= 0.0_rp .and. t <= 1.0_rp .and. &
          off_normal2(a0 + s * a - b0 - t * b, cross(a, b), det) <= OFF_NORMAL_REL * (aa + bb)) then
        ty = EE_LINES
        m = 2
        c = [1.0_rp - s, s, -(1.0_rp - t), -t]
        dc(:, 1) = [-1.0_rp, 1.0_rp, 0.0_rp, 0.0_rp]
        dc(:, 2) = [0.0_rp, 0.0_rp, 1.0_rp, -1.0_rp]
        return
      end if
    end if
    call point_segment(a0, b0, b1, tt(1), dd(1))
    call point_segment(a1, b0, b1, tt(2), dd(2))
    call point_segment(b0, a0, a1, tt(3), dd(3))
    call point_segment(b1, a0, a1, tt(4), dd(4))
    k = minloc(dd, dim=1)
    m = 0
    if (k <= 2) then
      ! an end of a (s = 0 or 1) against edge b at tt(k)
      s = real(k - 1, rp)
      t = tt(k)
      if (t > 0.0_rp .and. t < 1.0_rp) then
        ty = EE_A0_EB + k - 1
        m = 1
        dc(:, 1) = [0.0_rp, 0.0_rp, 1.0_rp, -1.0_rp]
      else
        ty = EE_A0_B0 + 2 * (k - 1) + nint(t)
      end if
    else
      ! an end of b (t = 0 or 1) against edge a at tt(k)
      t = real(k - 3, rp)
      s = tt(k)
      if (s > 0.0_rp .and. s < 1.0_rp) then
        ty = EE_EA_B0 + k - 3
        m = 1
        dc(:, 1) = [-1.0_rp, 1.0_rp, 0.0_rp, 0.0_rp]
      else
        ty = EE_A0_B0 + 2 * nint(s) + (k - 3)
      end if
    end if
    c = [1.0_rp - s, s, -(1.0_rp - t), -t]
  end subroutine edge_edge_closest

  !> |d - (d.n / nn) n|^2: the part of d off the normal n (nn = |n|^2 > 0) [length^2].
  pure real(rp) function off_normal2(d, n, nn) result(q)
    real(rp), intent(in) :: d(3), n(3), nn
    real(rp) :: e(3)

    e = d - (dot_product(d, n) / nn) * n
    q = dot_product(e, e)
  end function off_normal2

  !> The closest-feature type (PT_*) of point p against triangle t0 t1 t2.
  pure integer function point_triangle_type(p, t0, t1, t2) result(ty)
    real(rp), intent(in) :: p(3), t0(3), t1(3), t2(3)
    real(rp) :: c(4), dc(4, 2)
    integer :: m

    call point_triangle_closest(p, t0, t1, t2, ty, c, dc, m)
  end function point_triangle_type

  !> The closest-feature type (EE_*) of edges a0-a1 and b0-b1.
  pure integer function edge_edge_type(a0, a1, b0, b1) result(ty)
    real(rp), intent(in) :: a0(3), a1(3), b0(3), b1(3)
    real(rp) :: c(4), dc(4, 2)
    integer :: m

    call edge_edge_closest(a0, a1, b0, b1, ty, c, dc, m)
  end function edge_edge_type

  ! ------------------------------------------------------------------------
  ! Distances
  ! ------------------------------------------------------------------------

  !> r = sum_k c_k x_k; for the two-parameter types the part of w = x1 - x2 (the first
  !> points of the two primitives) along the normal n: the same vector at the minimum,
  !> with less cancellation when |r| << |x|.
  pure function closest_difference(x, c, m, w, n) result(r)
    real(rp), intent(in) :: x(3, 4), c(4), w(3), n(3)
    integer, intent(in) :: m
    real(rp) :: r(3), nn

    nn = dot_product(n, n)
    if (m == 2 .and. nn > 0.0_rp) then
      r = (dot_product(w, n) / nn) * n
    else
      r = matmul(x, c)
    end if
  end function closest_difference

  !> Squared distance of p to triangle t0 t1 t2 [length^2], no derivatives (for CCD).
  pure real(rp) function point_triangle_d2(p, t0, t1, t2) result(d2)
    real(rp), intent(in) :: p(3), t0(3), t1(3), t2(3)
    real(rp) :: x(3, 4), c(4), dc(4, 2), r(3)
    integer :: ty, m

    call point_triangle_closest(p, t0, t1, t2, ty, c, dc, m)
    x(:, 1) = p
    x(:, 2) = t0
    x(:, 3) = t1
    x(:, 4) = t2
    r = closest_difference(x, c, m, p - t0, cross(t1 - t0, t2 - t0))
    d2 = dot_product(r, r)
  end function point_triangle_d2

  !> Squared distance of edges a0-a1 and b0-b1 [length^2], no derivatives (for CCD).
  pure real(rp) function edge_edge_d2(a0, a1, b0, b1) result(d2)
    real(rp), intent(in) :: a0(3), a1(3), b0(3), b1(3)
    real(rp) :: x(3, 4), c(4), dc(4, 2), r(3)
    integer :: ty, m

    call edge_edge_closest(a0, a1, b0, b1, ty, c, dc, m)
    x(:, 1) = a0
    x(:, 2) = a1
    x(:, 3) = b0
    x(:, 4) = b1
    r = closest_difference(x, c, m, a0 - b0, cross(a1 - a0, b1 - b0))
    d2 = dot_product(r, r)
  end function edge_edge_d2

  !> Squared distance d2 of point p to triangle t0 t1 t2, its gradient g and Hessian h
  !> with respect to (p, t0, t1, t2) (components 1:3 p, 4:6 t0, ...), and the type ty.
  pure subroutine point_triangle_distance(p, t0, t1, t2, d2, g, h, ty)
    real(rp), intent(in) :: p(3), t0(3), t1(3), t2(3)     ! [length]
    real(rp), intent(out) :: d2                           ! [length^2]
    real(rp), intent(out) :: g(12)                        ! [length]
    real(rp), intent(out) :: h(12, 12)                    ! [1]
    integer, intent(out) :: ty                            ! PT_* code
    real(rp) :: x(3, 4), c(4), dc(4, 2), r(3)
    integer :: m

    call point_triangle_closest(p, t0, t1, t2, ty, c, dc, m)
    x(:, 1) = p
    x(:, 2) = t0
    x(:, 3) = t1
    x(:, 4) = t2
    r = closest_difference(x, c, m, p - t0, cross(t1 - t0, t2 - t0))
    d2 = dot_product(r, r)
    call form_derivatives(x, c, dc, m, r, g, h)
  end subroutine point_triangle_distance

  !> Vectors v(:, 1:nv) (nv <= 5) that span the range of point_triangle_distance's Hessian
  !> (and hold its gradient): c (x) e_i for i = 1..3 and the columns of B (module header).
  !> A projection on the PSD cone can then work in that subspace (a 5 x 5 problem, not 12 x 12).
  pure subroutine point_triangle_range(p, t0, t1, t2, v, nv)
    real(rp), intent(in) :: p(3), t0(3), t1(3), t2(3)
    real(rp), intent(out) :: v(12, 5)
    integer, intent(out) :: nv
    real(rp) :: x(3, 4), c(4), dc(4, 2), r(3), dd(3, 2)
    integer :: m, ty, i, j, k

    call point_triangle_closest(p, t0, t1, t2, ty, c, dc, m)
    x(:, 1) = p
    x(:, 2) = t0
    x(:, 3) = t1
    x(:, 4) = t2
    r = closest_difference(x, c, m, p - t0, cross(t1 - t0, t2 - t0))
    v = 0.0_rp
    do i = 1, 3
      do k = 1, 4
        v(3 * k - 3 + i, i) = c(k)
      end do
    end do
    nv = 3 + m
    if (m == 0) return
    dd(:, 1:m) = matmul(x, dc(:, 1:m))
    do j = 1, m
      do k = 1, 4
        v(3 * k - 2:3 * k, 3 + j) = c(k) * dd(:, j) + dc(k, j) * r
      end do
    end do
  end subroutine point_triangle_range

  !> Squared distance d2 of edges a0-a1 and b0-b1, its gradient g and Hessian h with
  !> respect to (a0, a1, b0, b1), and the type ty (EE_*).
  pure subroutine edge_edge_distance(a0, a1, b0, b1, d2, g, h, ty)
    real(rp), intent(in) :: a0(3), a1(3), b0(3), b1(3)   ! [length]
    real(rp), intent(out) :: d2                          ! [length^2]
    real(rp), intent(out) :: g(12)                       ! [length]
    real(rp), intent(out) :: h(12, 12)                   ! [1]
    integer, intent(out) :: ty                           ! EE_* code
    real(rp) :: x(3, 4), c(4), dc(4, 2), r(3)
    integer :: m

    call edge_edge_closest(a0, a1, b0, b1, ty, c, dc, m)
    x(:, 1) = a0
    x(:, 2) = a1
    x(:, 3) = b0
    x(:, 4) = b1
    r = closest_difference(x, c, m, a0 - b0, cross(a1 - a0, b1 - b0))
    d2 = dot_product(r, r)
    call form_derivatives(x, c, dc, m, r, g, h)
  end subroutine edge_edge_distance

  !> Gradient and Hessian of d2 = |r|^2, r = sum_k c_k(u) x_k minimised over the m free u
  !> (module header): g = 2 c (x) r, h = 2 c c^T (x) I - B F^-1 B^T.
  pure subroutine form_derivatives(x, c, dc, m, r, g, h)
    real(rp), intent(in) :: x(3, 4), c(4), dc(4, 2), r(3)
    integer, intent(in) :: m
    real(rp), intent(out) :: g(12), h(12, 12)
    real(rp) :: dd(3, 2), f(2, 2), fi(2, 2), b(12, 2), det, bf(12, 2)
    integer :: k, l, i, j

    h = 0.0_rp
    do k = 1, 4
      g(3 * k - 2:3 * k) = 2.0_rp * c(k) * r
      do l = 1, 4
        do i = 1, 3
          h(3 * k - 3 + i, 3 * l - 3 + i) = 2.0_rp * c(k) * c(l)
        end do
      end do
    end do
    if (m == 0) return
    dd(:, 1:m) = matmul(x, dc(:, 1:m))
    do j = 1, m
      do i = 1, m
        f(i, j) = 2.0_rp * dot_product(dd(:, i), dd(:, j))
      end do
      do k = 1, 4
        b(3 * k - 2:3 * k, j) = 2.0_rp * (c(k) * dd(:, j) + dc(k, j) * r)
      end do
    end do
    if (m == 1) then
      if (f(1, 1) <= 0.0_rp) return
      fi(1, 1) = 1.0_rp / f(1, 1)
    else
      det = f(1, 1) * f(2, 2) - f(1, 2) * f(2, 1)
      if (det <= 0.0_rp) return
      fi = reshape([f(2, 2), -f(2, 1), -f(1, 2), f(1, 1)], [2, 2]) / det
    end if
    bf(:, 1:m) = matmul(b(:, 1:m), fi(1:m, 1:m))
    do j = 1, 12
      do i = 1, 12
        h(i, j) = h(i, j) - dot_product(bf(i, 1:m), b(j, 1:m))
      end do
    end do
  end subroutine form_derivatives

  ! ------------------------------------------------------------------------
  ! Edge-edge mollifier
  ! ------------------------------------------------------------------------

  !> IPC's mollifier of edge-edge pairs: with c = |a x b|^2 (a = a1 - a0, b = b1 - b0),
  !> k(c) = (2 - c/eps_x) c/eps_x for c < eps_x, 1 from eps_x on (C1 at eps_x, 0 for
  !> parallel edges), with gradient and Hessian in (a0, a1, b0, b1). IPC takes
  !> eps_x = 1e-3 |a_rest|^2 |b_rest|^2. eps_x <= 0: k = 1.
  pure subroutine edge_edge_mollifier(a0, a1, b0, b1, eps_x, k, gk, hk)
    real(rp), intent(in) :: a0(3), a1(3), b0(3), b1(3)   ! [length]
    real(rp), intent(in) :: eps_x                        ! [length^4]
    real(rp), intent(out) :: k                           ! [1]
    real(rp), intent(out) :: gk(12)                      ! [1/length]
    real(rp), intent(out) :: hk(12, 12)                  ! [1/length^2]
    real(rp) :: a(3), b(3), aa, bb, ab, cc, dk, d2k, ga(3), gb(3), haa(3, 3), hbb(3, 3), hab(3, 3), hba(3, 3)
    real(rp) :: gc(12), hc(12, 12)
    integer :: i, j

    k = 1.0_rp
    gk = 0.0_rp
    hk = 0.0_rp
    if (eps_x <= 0.0_rp) return
    a = a1 - a0
    b = b1 - b0
    aa = dot_product(a, a)
    bb = dot_product(b, b)
    ab = dot_product(a, b)
    cc = aa * bb - ab * ab                 ! Lagrange's identity: |a x b|^2
    if (cc >= eps_x) return
    cc = max(cc, 0.0_rp)
    k = (2.0_rp - cc / eps_x) * cc / eps_x
    dk = 2.0_rp / eps_x - 2.0_rp * cc / eps_x**2
    d2k = -2.0_rp / eps_x**2
    ga = 2.0_rp * (bb * a - ab * b)
    gb = 2.0_rp * (aa * b - ab * a)
    do j = 1, 3
      haa(:, j) = 2.0_rp * (bb * EYE(:, j) - b * b(j))
      hbb(:, j) = 2.0_rp * (aa * EYE(:, j) - a * a(j))
      hab(:, j) = 4.0_rp * a * b(j) - 2.0_rp * b * a(j) - 2.0_rp * ab * EYE(:, j)
    end do
    ! a = a1 - a0, b = b1 - b0: the point blocks are +-the edge blocks.
    gc = [-ga, ga, -gb, gb]
    hc = 0.0_rp
    call put_pm(hc, 1, 1, haa)
    call put_pm(hc, 3, 3, hbb)
    call put_pm(hc, 1, 3, hab)
    hba = transpose(hab)
    call put_pm(hc, 3, 1, hba)
    do j = 1, 12
      do i = 1, 12
        hk(i, j) = d2k * gc(i) * gc(j) + dk * hc(i, j)
      end do
    end do
    gk = dk * gc
  end subroutine edge_edge_mollifier

  !> Adds the edge block m (d2/d e_p d e_q) at points (p, p+1) x (q, q+1) with signs -, + per end.
  pure subroutine put_pm(hc, p, q, m)
    real(rp), intent(inout) :: hc(12, 12)
    integer, intent(in) :: p, q
    real(rp), intent(in) :: m(3, 3)
    integer :: i, j
    real(rp) :: si, sj

    do j = 0, 1
      sj = merge(1.0_rp, -1.0_rp, j == 1)
      do i = 0, 1
        si = merge(1.0_rp, -1.0_rp, i == 1)
        hc(3 * (p + i) - 2:3 * (p + i), 3 * (q + j) - 2:3 * (q + j)) = &
          hc(3 * (p + i) - 2:3 * (p + i), 3 * (q + j) - 2:3 * (q + j)) + si * sj * m
      end do
    end do
  end subroutine put_pm

  ! ------------------------------------------------------------------------
  ! Helpers
  ! ------------------------------------------------------------------------

  !> Positive semidefinite part of a symmetric n x n matrix, n <= 12 (cyclic Jacobi
  !> rotations, eigenvalues below 0 set to 0; a is symmetrised first). In place.
  pure subroutine psd_project(a)
    real(rp), intent(inout) :: a(:, :)
    integer, parameter :: NMAX = 12
    real(rp) :: s(NMAX, NMAX), v(NMAX, NMAX), th, t, cs, sn, off, scale, cp(NMAX), cq(NMAX), lam(NMAX)
    integer :: n, sweep, ip, iq, k

    n = size(a, 1)
    if (n > NMAX) return
    s(1:n, 1:n) = 0.5_rp * (a + transpose(a))
    scale = maxval(abs(s(1:n, 1:n)))
    if (scale == 0.0_rp) return
    v(1:n, 1:n) = 0.0_rp
    do k = 1, n
      v(k, k) = 1.0_rp
    end do
    do sweep = 1, 60
      off = 0.0_rp
      do iq = 2, n
        off = off + sum(abs(s(1:iq - 1, iq)))
      end do
      if (off <= 1.0e-17_rp * scale) exit
      do ip = 1, n - 1
        do iq = ip + 1, n
          if (s(ip, iq) == 0.0_rp) cycle
          th = (s(iq, iq) - s(ip, ip)) / (2.0_rp * s(ip, iq))
          t = sign(1.0_rp, th) / (abs(th) + sqrt(th * th + 1.0_rp))
          cs = 1.0_rp / sqrt(t * t + 1.0_rp)
          sn = t * cs
          cp(1:n) = s(1:n, ip)
          cq(1:n) = s(1:n, iq)
          s(1:n, ip) = cs * cp(1:n) - sn * cq(1:n)
          s(1:n, iq) = sn * cp(1:n) + cs * cq(1:n)
          cp(1:n) = s(ip, 1:n)
          cq(1:n) = s(iq, 1:n)
          s(ip, 1:n) = cs * cp(1:n) - sn * cq(1:n)
          s(iq, 1:n) = sn * cp(1:n) + cs * cq(1:n)
          cp(1:n) = v(1:n, ip)
          cq(1:n) = v(1:n, iq)
          v(1:n, ip) = cs * cp(1:n) - sn * cq(1:n)
          v(1:n, iq) = sn * cp(1:n) + cs * cq(1:n)
        end do
      end do
    end do
    do k = 1, n
      lam(k) = max(s(k, k), 0.0_rp)
    end do
    do iq = 1, n
      do ip = 1, n
        a(ip, iq) = sum(lam(1:n) * v(ip, 1:n) * v(iq, 1:n))
      end do
    end do
  end subroutine psd_project

end module contact_primitives
