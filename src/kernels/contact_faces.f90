! SPDX-License-Identifier: BSD-2-Clause
!> Contact of the cloth's triangles and edges with one rigid obstacle (issue
!> 47 item 3; docs/contact-faces-kernels.md): which primitive pairs of IPC
!> (module contact_primitives) a cloth triangle or edge must be checked
!> against so that no part of it enters the obstacle, given that the nodes
!> already have node-against-shape contact (module contact):
!>   plane    nothing beyond the nodes (a triangle's nearest point to a plane is a vertex);
!>   sphere   the centre against each triangle, minus the radius;
!>   capsule  its two axis ends against each triangle and its axis against each
!>            cloth edge (edge-edge), minus the radius;
!>   box      its 8 corners against each triangle and its 12 edges against each
!>            cloth edge (the nodes against its faces are the node contact).
!> Each pair has the gap = distance - radius - contact thickness and the
!> energy kappa b(gap) with contact's IPC barrier b (on the gap, as the node
!> contact: not IPC's squared form), times IPC's mollifier for edge-edge
!> pairs; this module gives its force on the 3 (triangle) or 2 (edge) cloth
!> nodes and the 3 x 3 blocks df_a/dx_b, exact or from the pair's Hessian
!> projected on the positive semidefinite cone, summed over the pairs.
!> For a Newton update of the cloth's nodes it gives the pairs' second-order
!> correction (triangle_correction, edge_correction): the move that lifts a
!> gap which the update's path loses below its linear prediction back to it.
!> Pairs are summed as IPC sums them: where a pair's nearest point is a
!> cloth node, the pair repeats that node's own contact (the energy stays
!> smooth; the barrier there is stiffer). The obstacle is rigid: its
!> features are data, not unknowns.
!> Lattice quads: corners 1 = (i,j), 2 = (i+1,j), 3 = (i,j+1), 4 = (i+1,j+1),
!> split along one diagonal (an argument: the lattice has both as shear links).
!> Plain arrays only: no PETSc, no MPI, no allocation.
module contact_faces
  use kinds, only: rp
  use contact, only: obstacle_t, contact_params_t, barrier, signed_distance, SHAPE_PLANE, SHAPE_SPHERE, SHAPE_BOX, &
                     SHAPE_CAPSULE
  use contact_primitives, only: point_triangle_distance, edge_edge_distance, point_triangle_d2, edge_edge_d2, &
                                edge_edge_mollifier, psd_project, point_triangle_range, point_triangle_closest, &
                                edge_edge_closest
  implicit none
  private
  public :: SPLIT_MAIN, SPLIT_ANTI, EE_MOLLIFY_REL
  public :: quad_triangles, quad_diagonal, obstacle_points, obstacle_edges, obstacle_radius
  public :: near_obstacle, contact_triangle, contact_edge, contact_quad, triangle_gap, edge_gap
  public :: triangle_correction, edge_correction
  ! One pair's barrier and the projection in a span: self-contact's pairs (module self_barrier) too.
  public :: pair_barrier, psd_project_in_span

  !> Quad split: SPLIT_MAIN along (i,j)-(i+1,j+1), triangles (1,2,4) and (1,4,3);
  !> SPLIT_ANTI along (i+1,j)-(i,j+1), triangles (1,2,3) and (2,4,3) (both counter-clockwise
  !> in the rest state seen from +z).
  integer, parameter :: SPLIT_MAIN = 1, SPLIT_ANTI = 2
  !> IPC's mollifier threshold: eps_x = EE_MOLLIFY_REL |a_rest|^2 |b_rest|^2.
  real(rp), parameter :: EE_MOLLIFY_REL = 1.0e-3_rp
  !> A gap's loss below its linear prediction that pair_correction takes
  !> for round-off, relative to the pair's scale (radius + gap + move).
  real(rp), parameter :: LOSS_ROUND = 1.0e-12_rp
  !> The fraction of its predicted gap a pair's path must lose before pair_correction
  !> lifts it: a smaller loss leaves most of the gap, which the barrier and the step limit
  !> handle, and a correction there can only fight Newton (where the gap's gradient turns
  !> at a feature the loss is of first order, and the correction, capped at the update,
  !> cancelled it at every iteration: gripper with the faces, docs/contact.md).
  real(rp), parameter :: LOSS_SIGNIFICANT = 0.01_rp

contains

  ! ------------------------------------------------------------------------
  ! Lattice quads
  ! ------------------------------------------------------------------------

  !> The two triangles of a quad as corner numbers (1..4, header), one column each.
  pure subroutine quad_triangles(split, tri)
    integer, intent(in) :: split
    integer, intent(out) :: tri(3, 2)

    if (split == SPLIT_ANTI) then
      tri = reshape([1, 2, 3, 2, 4, 3], [3, 2])
    else
      tri = reshape([1, 2, 4, 1, 4, 3], [3, 2])
    end if
  end subroutine quad_triangles

  !> The corners (1..4) of a quad's diagonal edge, the one its split adds.
  pure subroutine quad_diagonal(split, ca, cb)
    integer, intent(in) :: split
    integer, intent(out) :: ca, cb

    if (split == SPLIT_ANTI) then
      ca = 2
      cb = 3
    else
      ca = 1
      cb = 4
    end if
  end subroutine quad_diagonal

  ! ------------------------------------------------------------------------
  ! Obstacle features
  ! ------------------------------------------------------------------------

  !> Radius that the obstacle's features carry: sphere and capsule r, else 0.
  pure real(rp) function obstacle_radius(o) result(r)
    type(obstacle_t), intent(in) :: o

    r = 0.0_rp
    if (o%shape == SHAPE_SPHERE .or. o%shape == SHAPE_CAPSULE) r = o%r
  end function obstacle_radius

  !> The obstacle's points checked against cloth triangles: sphere centre, capsule axis ends
  !> (the centre alone when the axis has zero length), box corners; none for a plane.
  pure subroutine obstacle_points(o, pts, np)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(out) :: pts(3, 8)   ! [length]
    integer, intent(out) :: np
    integer :: k

    pts = 0.0_rp
    np = 0
    select case (o%shape)
    case (SHAPE_SPHERE)
      np = 1
      pts(:, 1) = o%p
    case (SHAPE_CAPSULE)
      np = 1
      pts(:, 1) = o%p
      if (any(o%q /= o%p)) then
        np = 2
        pts(:, 2) = o%q
      end if
    case (SHAPE_BOX)
      np = 8
      do k = 1, 8
        pts(:, k) = box_corner(o, k)
      end do
    end select
  end subroutine obstacle_points

  !> Corner k (1..8) of a box: signs of the axes from the bits of k - 1.
  pure function box_corner(o, k) result(x)
    type(obstacle_t), intent(in) :: o
    integer, intent(in) :: k
    real(rp) :: x(3)
    integer :: i

    x = o%p
    do i = 1, 3
      x = x + merge(1.0_rp, -1.0_rp, btest(k - 1, i - 1)) * o%h(i) * o%axes(:, i)
    end do
  end function box_corner

  !> The obstacle's edges checked against cloth edges, ea(:, k)-eb(:, k): the capsule's
  !> axis (none when of zero length), the box's 12 edges; none for a plane or sphere.
  pure subroutine obstacle_edges(o, ea, eb, ne)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(out) :: ea(3, 12), eb(3, 12)   ! [length]
    integer, intent(out) :: ne
    integer :: ax, c

    ea = 0.0_rp
    eb = 0.0_rp
    ne = 0
    select case (o%shape)
    case (SHAPE_CAPSULE)
      if (any(o%q /= o%p)) then
        ne = 1
        ea(:, 1) = o%p
        eb(:, 1) = o%q
      end if
    case (SHAPE_BOX)
      ! Along axis ax: from each corner whose bit ax is clear to the one with it set.
      do ax = 1, 3
        do c = 1, 8
          if (btest(c - 1, ax - 1)) cycle
          ne = ne + 1
          ea(:, ne) = box_corner(o, c)
          eb(:, ne) = box_corner(o, ibset(c - 1, ax - 1) + 1)
        end do
      end do
    end select
  end subroutine obstacle_edges

  ! ------------------------------------------------------------------------
  ! Broad phase
  ! ------------------------------------------------------------------------

  !> .false. when every point of the convex hull of pts is at least margin away from the
  !> obstacle's surface on its outside (a cheap, conservative bound: .true. may still be
  !> far). margin = dhat + contact thickness for the barrier; for CCD, pts = the start and
  !> end positions relative to the obstacle (the hull holds the whole linear path) and
  !> margin = the thickness. Boxes are tested in their own frame, capsules by bounding boxes.
  pure logical function near_obstacle(o, margin, pts) result(near)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: margin        ! [length]
    real(rp), intent(in) :: pts(:, :)     ! (3, n) [length]
    real(rp) :: lo(3), hi(3), y(3), nn(3), q(3), rr
    integer :: k

    lo = minval(pts, dim=2)
    hi = maxval(pts, dim=2)
    select case (o%shape)
    case (SHAPE_PLANE)
      nn = o%n / max(norm2(o%n), tiny(1.0_rp))
      near = minval(matmul(nn, pts) - dot_product(nn, o%p)) < margin
    case (SHAPE_SPHERE)
      q = min(max(o%p, lo), hi) - o%p          ! nearest point of the bounding box to the centre
      near = dot_product(q, q) < (o%r + margin)**2
    case (SHAPE_CAPSULE)
      rr = o%r + margin
      near = all(lo < max(o%p, o%q) + rr) .and. all(hi > min(o%p, o%q) - rr)
    case (SHAPE_BOX)
      lo = huge(1.0_rp)
      hi = -huge(1.0_rp)
      do k = 1, size(pts, 2)
        q = pts(:, k) - o%p
        y = [dot_product(o%axes(:, 1), q), dot_product(o%axes(:, 2), q), dot_product(o%axes(:, 3), q)]
        lo = min(lo, y)
        hi = max(hi, y)
      end do
      near = all(lo < o%h + margin) .and. all(hi > -o%h - margin)
    case default
      near = .false.
    end select
  end function near_obstacle

  ! ------------------------------------------------------------------------
  ! Barrier of one pair
  ! ------------------------------------------------------------------------

  !> Energy e, gradient ge and Hessian he (in the n cloth coordinates) of kappa k b(gap),
  !> gap = sqrt(d2) - xi, from d2's gradient g and Hessian h and the mollifier k (gk, hk).
  !> gap <= 0: e = huge and no derivatives (the caller must refuse the state).
  pure subroutine pair_barrier(cp, xi, d2, g, h, k, gk, hk, e, ge, he)
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xi, d2, g(:), h(:, :), k, gk(:), hk(:, :)
    real(rp), intent(out) :: e, ge(:), he(:, :)
    real(rp) :: dist, gap, b, db, d2b, gd(size(g))
    integer :: i, n

    n = size(g)
    ge = 0.0_rp
    he = 0.0_rp
    dist = sqrt(d2)
    gap = dist - xi
    if (gap <= 0.0_rp) then
      e = huge(1.0_rp)
      return
    end if
    call barrier(gap, cp%dhat, b, db, d2b)
    e = cp%kappa * k * b
    gd = g / (2.0_rp * dist)
    ge = cp%kappa * (b * gk + k * db * gd)
    do i = 1, n
      ! Hessian of the distance: h/(2 dist) - g g^T/(4 dist^3) = (h/2 - gd gd^T)/dist
      he(:, i) = cp%kappa * (b * hk(:, i) + db * (gk * gd(i) + gd * gk(i)) &
                             + k * (d2b * gd * gd(i) + db * (0.5_rp * h(:, i) - gd * gd(i)) / dist))
    end do
  end subroutine pair_barrier

  !> Adds one pair's energy, force -ge and blocks -he on the nn nodes.
  pure subroutine add_pair(ep, ge, he, e, f, kx)
    real(rp), intent(in) :: ep, ge(:), he(:, :)
    real(rp), intent(inout) :: e, f(:, :), kx(:, :, :, :)
    integer :: a, b

    call add_energy(e, ep)
    do b = 1, size(f, 2)
      f(:, b) = f(:, b) - ge(3 * b - 2:3 * b)
      do a = 1, size(f, 2)
        kx(:, :, a, b) = kx(:, :, a, b) - he(3 * a - 2:3 * a, 3 * b - 2:3 * b)
      end do
    end do
  end subroutine add_pair

  !> he <- its positive semidefinite part, where he's range lies in the span of the columns
  !> of v (n <= 12 rows, at most 5 columns): orthonormalised (modified Gram-Schmidt, dependent ones dropped) into q, then
  !> he = q psd(q^T he q) q^T, an nv x nv eigenproblem instead of an n x n one.
  pure subroutine psd_project_in_span(he, v)
    real(rp), intent(inout) :: he(:, :)
    real(rp), intent(in) :: v(:, :)
    real(rp) :: q(12, 5), rr(5, 5), nrm, vmax
    integer :: j, i, k, n

    n = size(v, 1)

    vmax = maxval(abs(v))
    if (vmax == 0.0_rp) then
      he = 0.0_rp
      return
    end if
    k = 0
    do j = 1, min(size(v, 2), 5)
      k = k + 1
      q(1:n, k) = v(:, j)
      do i = 1, k - 1
        q(1:n, k) = q(1:n, k) - dot_product(q(1:n, i), q(1:n, k)) * q(1:n, i)
      end do
      nrm = norm2(q(1:n, k))
      if (nrm <= 1.0e-10_rp * vmax) then
        k = k - 1
      else
        q(1:n, k) = q(1:n, k) / nrm
      end if
    end do
    rr(1:k, 1:k) = matmul(transpose(q(1:n, 1:k)), matmul(he, q(1:n, 1:k)))
    call psd_project(rr(1:k, 1:k))
    he = matmul(q(1:n, 1:k), matmul(rr(1:k, 1:k), transpose(q(1:n, 1:k))))
  end subroutine psd_project_in_span

  ! ------------------------------------------------------------------------
  ! Cloth triangle and cloth edge against one obstacle
  ! ------------------------------------------------------------------------

  !> Barrier of cloth triangle xt (3 nodes) against the obstacle's points (sphere centre,
  !> capsule ends, box corners; nothing for a plane; its edges: contact_edge): energy e, forces f(:, a) on node a,
  !> blocks kx(:, :, a, b) = df_a/dx_b (project: minus the PSD part of each pair's
  !> Hessian), nact pairs with gap < dhat. e = huge where a pair has gap <= 0.
  pure subroutine contact_triangle(o, cp, xt, project, e, f, kx, nact)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xt(3, 3)          ! node positions [length]
    logical, intent(in) :: project
    real(rp), intent(out) :: e                ! [energy]
    real(rp), intent(out) :: f(3, 3)          ! [force]
    real(rp), intent(out) :: kx(3, 3, 3, 3)   ! [force/length]
    integer, intent(out) :: nact
    real(rp) :: pts(3, 8), xi, lo(3), hi(3), d2, g(12), h(12, 12), ep, ge(9), he(9, 9), gk(9), hk(9, 9), vr(12, 5)
    integer :: np, k, ty, nv

    e = 0.0_rp
    f = 0.0_rp
    kx = 0.0_rp
    nact = 0
    call obstacle_points(o, pts, np)
    if (np == 0) return
    xi = obstacle_radius(o) + cp%thickness
    lo = minval(xt, dim=2) - xi - cp%dhat
    hi = maxval(xt, dim=2) + xi + cp%dhat
    gk = 0.0_rp
    hk = 0.0_rp
    do k = 1, np
      if (any(pts(:, k) < lo .or. pts(:, k) > hi)) cycle
      d2 = point_triangle_d2(pts(:, k), xt(:, 1), xt(:, 2), xt(:, 3))
      if (sqrt(d2) - xi >= cp%dhat) cycle
      nact = nact + 1
      call point_triangle_distance(pts(:, k), xt(:, 1), xt(:, 2), xt(:, 3), d2, g, h, ty)
      call pair_barrier(cp, xi, d2, g(4:12), h(4:12, 4:12), 1.0_rp, gk, hk, ep, ge, he)
      if (project) then
        call point_triangle_range(pts(:, k), xt(:, 1), xt(:, 2), xt(:, 3), vr, nv)
        call psd_project_in_span(he, vr(4:12, 1:nv))
      end if
      call add_pair(ep, ge, he, e, f, kx)
    end do
  end subroutine contact_triangle

  !> Barrier of cloth edge xe (2 nodes, rest length rest_len) against the obstacle's edges
  !> (capsule axis, box edges; nothing for a plane or sphere), each pair times IPC's
  !> mollifier with eps_x = EE_MOLLIFY_REL rest_len^2 |obstacle edge|^2. Outputs as
  !> contact_triangle's, on 2 nodes.
  pure subroutine contact_edge(o, cp, xe, rest_len, project, e, f, kx, nact)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xe(3, 2)          ! node positions [length]
    real(rp), intent(in) :: rest_len          ! the edge's rest length [length]
    logical, intent(in) :: project
    real(rp), intent(out) :: e                ! [energy]
    real(rp), intent(out) :: f(3, 2)          ! [force]
    real(rp), intent(out) :: kx(3, 3, 2, 2)   ! [force/length]
    integer, intent(out) :: nact
    real(rp) :: ea(3, 12), eb(3, 12), xi, lo(3), hi(3), d2, g(12), h(12, 12), ep, ge(6), he(6, 6)
    real(rp) :: mk, gk(12), hk(12, 12), eps_x
    integer :: ne, k, ty

    e = 0.0_rp
    f = 0.0_rp
    kx = 0.0_rp
    nact = 0
    call obstacle_edges(o, ea, eb, ne)
    if (ne == 0) return
    xi = obstacle_radius(o) + cp%thickness
    lo = minval(xe, dim=2) - xi - cp%dhat
    hi = maxval(xe, dim=2) + xi + cp%dhat
    do k = 1, ne
      if (any(min(ea(:, k), eb(:, k)) > hi .or. max(ea(:, k), eb(:, k)) < lo)) cycle
      d2 = edge_edge_d2(xe(:, 1), xe(:, 2), ea(:, k), eb(:, k))
      if (sqrt(d2) - xi >= cp%dhat) cycle
      nact = nact + 1
      call edge_edge_distance(xe(:, 1), xe(:, 2), ea(:, k), eb(:, k), d2, g, h, ty)
      eps_x = EE_MOLLIFY_REL * rest_len**2 * sum((eb(:, k) - ea(:, k))**2)
      call edge_edge_mollifier(xe(:, 1), xe(:, 2), ea(:, k), eb(:, k), eps_x, mk, gk, hk)
      call pair_barrier(cp, xi, d2, g(1:6), h(1:6, 1:6), mk, gk(1:6), hk(1:6, 1:6), ep, ge, he)
      if (project) call psd_project(he)
      call add_pair(ep, ge, he, e, f, kx)
    end do
  end subroutine contact_edge

  !> A lattice quad's share: its two triangles (contact_triangle) and its diagonal edge
  !> (contact_edge, rest length diag_len), on its 4 corners xq(:, 1..4) (header). The
  !> structural links (x and y lattice lines) are each shared by two quads: the caller
  !> takes them once each through contact_edge.
  pure subroutine contact_quad(o, cp, split, xq, diag_len, project, e, f, kx, nact)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    integer, intent(in) :: split              ! SPLIT_MAIN or SPLIT_ANTI
    real(rp), intent(in) :: xq(3, 4)          ! corner positions [length]
    real(rp), intent(in) :: diag_len          ! rest length of the split's diagonal [length]
    logical, intent(in) :: project
    real(rp), intent(out) :: e                ! [energy]
    real(rp), intent(out) :: f(3, 4)          ! [force]
    real(rp), intent(out) :: kx(3, 3, 4, 4)   ! df_a/dx_b [force/length]
    integer, intent(out) :: nact
    real(rp) :: et, ft(3, 3), kt(3, 3, 3, 3), fe(3, 2), ke(3, 3, 2, 2)
    integer :: tri(3, 2), ed(2), t, a, b, na

    e = 0.0_rp
    f = 0.0_rp
    kx = 0.0_rp
    nact = 0
    call quad_triangles(split, tri)
    do t = 1, 2
      call contact_triangle(o, cp, xq(:, tri(:, t)), project, et, ft, kt, na)
      if (na == 0) cycle
      call add_energy(e, et)
      nact = nact + na
      do b = 1, 3
        f(:, tri(b, t)) = f(:, tri(b, t)) + ft(:, b)
        do a = 1, 3
          kx(:, :, tri(a, t), tri(b, t)) = kx(:, :, tri(a, t), tri(b, t)) + kt(:, :, a, b)
        end do
      end do
    end do
    call quad_diagonal(split, ed(1), ed(2))
    call contact_edge(o, cp, xq(:, ed), diag_len, project, et, fe, ke, na)
    if (na == 0) return
    call add_energy(e, et)
    nact = nact + na
    do b = 1, 2
      f(:, ed(b)) = f(:, ed(b)) + fe(:, b)
      do a = 1, 2
        kx(:, :, ed(a), ed(b)) = kx(:, :, ed(a), ed(b)) + ke(:, :, a, b)
      end do
    end do
  end subroutine contact_quad

  pure subroutine add_energy(e, ep)
    real(rp), intent(inout) :: e
    real(rp), intent(in) :: ep

    if (ep >= huge(1.0_rp) .or. e >= huge(1.0_rp)) then
      e = huge(1.0_rp)
    else
      e = e + ep
    end if
  end subroutine add_energy

  ! ------------------------------------------------------------------------
  ! Second-order correction of a Newton update (docs/contact.md, "Faces and edges")
  ! ------------------------------------------------------------------------

  !> Gap (distance - xi) of a pair, points x(:, 1..4) (point-triangle: the point first; edge-edge:
  !> the cloth edge first), and its gradient gr(:, k) with respect to each point (c_k r/|r|,
  !> r the difference of the closest points: the envelope of the closest-point problem).
  pure subroutine pair_gap_gradient(point_triangle, x, xi, gap, gr)
    logical, intent(in) :: point_triangle
    real(rp), intent(in) :: x(3, 4), xi
    real(rp), intent(out) :: gap, gr(3, 4)
    real(rp) :: c(4), dc(4, 2), r(3), d
    integer :: ty, m, k

    if (point_triangle) then
      call point_triangle_closest(x(:, 1), x(:, 2), x(:, 3), x(:, 4), ty, c, dc, m)
      d = sqrt(point_triangle_d2(x(:, 1), x(:, 2), x(:, 3), x(:, 4)))
    else
      call edge_edge_closest(x(:, 1), x(:, 2), x(:, 3), x(:, 4), ty, c, dc, m)
      d = sqrt(edge_edge_d2(x(:, 1), x(:, 2), x(:, 3), x(:, 4)))
    end if
    gap = d - xi
    r = matmul(x, c)
    gr = 0.0_rp
    if (norm2(r) <= 0.0_rp) return
    r = r / norm2(r)
    do k = 1, 4
      gr(:, k) = c(k) * r
    end do
  end subroutine pair_gap_gradient

  !> The second-order correction v(:, k) of the update dx of one pair's cloth points (movable:
  !> those the update may move; the obstacle's are fixed in the pair's frame), SQP's
  !> second-order correction along the update's path: at t = 1/4, 1/2, 3/4 and 1, where the
  !> gap at x + t dx falls below its linear prediction from x, g0 + t grad g . dx (capped at
  !> dhat: beyond, the barrier is 0), by more than round-off (LOSS_ROUND) and more than
  !> LOSS_SIGNIFICANT of that prediction, the least move of
  !> the movable points that lifts it back to first order there, (target - g_t) grad g_t /
  !> (t |grad g_t|^2) (t of it is taken at t); v the largest over the four, capped at the
  !> largest move of the pair's points. A path that bows into the obstacle between ends that
  !> keep their gaps (a link pivoting over a box's edge) is lifted as well as one whose end
  !> falls in. None where the pair passed over its feature at t (the closest points'
  !> difference reversed) [length].
  pure subroutine pair_correction(point_triangle, x, dx, movable, xi, dhat, v)
    logical, intent(in) :: point_triangle, movable(4)
    real(rp), intent(in) :: x(3, 4), dx(3, 4), xi, dhat
    real(rp), intent(out) :: v(3, 4)
    real(rp) :: g0, gr0(3, 4), g1, gr1(3, 4), target, den, vmax, dmax, vs(3, 4), ts
    integer :: k, m

    v = 0.0_rp
    call pair_gap_gradient(point_triangle, x, xi, g0, gr0)
    if (g0 <= 0.0_rp) return
    do m = 1, 4
      ts = 0.25_rp * m
      call pair_gap_gradient(point_triangle, x + ts * dx, xi, g1, gr1)
      target = min(g0 + ts * sum(gr0 * dx), dhat)
      if (target - g1 <= max(LOSS_ROUND * (xi + abs(g0) + ts * maxval(norm2(dx, dim=1))), LOSS_SIGNIFICANT * target) &
          .or. sum(gr0 * gr1) <= 0.0_rp) cycle
      do k = 1, 4
        if (.not. movable(k)) gr1(:, k) = 0.0_rp
      end do
      den = sum(gr1 * gr1)
      if (den <= 0.0_rp) cycle
      vs = ((target - g1) / (ts * den)) * gr1
      if (maxval(norm2(vs, dim=1)) > maxval(norm2(v, dim=1))) v = vs
    end do
    dmax = maxval(norm2(dx, dim=1))
    vmax = maxval(norm2(v, dim=1))
    if (vmax > dmax) v = v * (dmax / vmax)
  end subroutine pair_correction

  !> Keeps, for each of the n nodes, the larger of v(:, a) and vk(:, a) (by length).
  pure subroutine keep_larger(vk, v)
    real(rp), intent(in) :: vk(:, :)
    real(rp), intent(inout) :: v(:, :)
    integer :: a

    do a = 1, size(v, 2)
      if (norm2(vk(:, a)) > norm2(v(:, a))) v(:, a) = vk(:, a)
    end do
  end subroutine keep_larger

  !> The second-order correction of the update dxt of cloth triangle xt (free: its nodes the
  !> update moves) against the obstacle's points (pair_correction): v(:, a) the larger of
  !> its value and each pair's correction of node a [length].
  pure subroutine triangle_correction(o, cp, xt, dxt, free, v)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xt(3, 3), dxt(3, 3)   ! [length]
    logical, intent(in) :: free(3)
    real(rp), intent(inout) :: v(3, 3)            ! [length]
    real(rp) :: pts(3, 8), xi, lo(3), hi(3), x(3, 4), dx(3, 4), vk(3, 4)
    integer :: np, k

    call obstacle_points(o, pts, np)
    if (np == 0) return
    xi = obstacle_radius(o) + cp%thickness
    lo = min(minval(xt, dim=2), minval(xt + dxt, dim=2)) - xi - cp%dhat
    hi = max(maxval(xt, dim=2), maxval(xt + dxt, dim=2)) + xi + cp%dhat
    x(:, 2:4) = xt
    dx(:, 1) = 0.0_rp
    dx(:, 2:4) = dxt
    do k = 1, np
      if (any(pts(:, k) < lo .or. pts(:, k) > hi)) cycle
      x(:, 1) = pts(:, k)
      call pair_correction(.true., x, dx, [.false., free], xi, cp%dhat, vk)
      call keep_larger(vk(:, 2:4), v)
    end do
  end subroutine triangle_correction

  !> The same for cloth edge xe moving by dxe against the obstacle's edges (capsule axis,
  !> box edges).
  pure subroutine edge_correction(o, cp, xe, dxe, free, v)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xe(3, 2), dxe(3, 2)   ! [length]
    logical, intent(in) :: free(2)
    real(rp), intent(inout) :: v(3, 2)            ! [length]
    real(rp) :: ea(3, 12), eb(3, 12), xi, lo(3), hi(3), x(3, 4), dx(3, 4), vk(3, 4)
    integer :: ne, k

    call obstacle_edges(o, ea, eb, ne)
    if (ne == 0) return
    xi = obstacle_radius(o) + cp%thickness
    lo = min(minval(xe, dim=2), minval(xe + dxe, dim=2)) - xi - cp%dhat
    hi = max(maxval(xe, dim=2), maxval(xe + dxe, dim=2)) + xi + cp%dhat
    x(:, 1:2) = xe
    dx(:, 1:2) = dxe
    dx(:, 3:4) = 0.0_rp
    do k = 1, ne
      if (any(min(ea(:, k), eb(:, k)) > hi .or. max(ea(:, k), eb(:, k)) < lo)) cycle
      x(:, 3) = ea(:, k)
      x(:, 4) = eb(:, k)
      call pair_correction(.false., x, dx, [free, .false., .false.], xi, cp%dhat, vk)
      call keep_larger(vk(:, 1:2), v)
    end do
  end subroutine edge_correction

  ! ------------------------------------------------------------------------
  ! Gaps (for checks of accepted states and diagnostics)
  ! ------------------------------------------------------------------------

  !> Smallest gap (distance - radius - thickness) between the whole cloth triangle xt and
  !> the obstacle: its nodes (signed distance, module contact), the obstacle's points
  !> against the triangle and its edges against the triangle's 3 edges. Equal to the
  !> triangle's true gap while they do not intersect [length].
  pure real(rp) function triangle_gap(o, thickness, xt) result(gmin)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness      ! [length]
    real(rp), intent(in) :: xt(3, 3)       ! [length]
    real(rp) :: pts(3, 8), xi, d, g(3), hd(3, 3)
    integer :: np, k

    gmin = huge(1.0_rp)
    do k = 1, 3
      call signed_distance(o, xt(:, k), d, g, hd)
      gmin = min(gmin, d - thickness)
    end do
    call obstacle_points(o, pts, np)
    xi = obstacle_radius(o) + thickness
    do k = 1, np
      gmin = min(gmin, sqrt(point_triangle_d2(pts(:, k), xt(:, 1), xt(:, 2), xt(:, 3))) - xi)
    end do
    do k = 1, 3
      gmin = min(gmin, edge_gap(o, thickness, xt(:, [k, mod(k, 3) + 1])))
    end do
  end function triangle_gap

  !> Smallest gap between cloth edge xe and the obstacle: its two nodes and the obstacle's
  !> edges against it (for a sphere the nodes alone: not the edge's interior) [length].
  pure real(rp) function edge_gap(o, thickness, xe) result(gmin)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness, xe(3, 2)
    real(rp) :: ea(3, 12), eb(3, 12), xi, d, g(3), hd(3, 3)
    integer :: ne, k

    gmin = huge(1.0_rp)
    do k = 1, 2
      call signed_distance(o, xe(:, k), d, g, hd)
      gmin = min(gmin, d - thickness)
    end do
    call obstacle_edges(o, ea, eb, ne)
    xi = obstacle_radius(o) + thickness
    do k = 1, ne
      gmin = min(gmin, sqrt(edge_edge_d2(xe(:, 1), xe(:, 2), ea(:, k), eb(:, k))) - xi)
    end do
  end function edge_gap

end module contact_faces
