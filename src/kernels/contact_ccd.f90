! SPDX-License-Identifier: BSD-2-Clause
!> Continuous collision detection of the contact primitives (issue 47 item 3;
!> docs/contact-faces-kernels.md): a point against a triangle and an edge
!> against an edge, each of the four points moving linearly over the step,
!> by additive CCD (ACCD, Li, Kaufman and Jiang 2021, "Codimensional
!> Incremental Potential Contact", Algorithm 1), and on top of it the step
!> limit of a cloth triangle or edge against one obstacle that translates by
!> dobs over the step (the cloth's motion relative to the obstacle against
!> its pose at the step's start).
!>
!> ACCD: a common translation of all four points does not change their
!> distance, so the mean displacement is removed first; then the distance
!> changes at most at the rate l_p = |p_1| + max(|p_2|, |p_3|, |p_4|)
!> (point-triangle) or max(|p_1|, |p_2|) + max(|p_3|, |p_4|) (edge-edge)
!> per unit of t, and a step of gap/l_p cannot close the gap. ACCD advances
!> by (1 - s) gap0/l_p, then by 0.9 gap/l_p, and stops before the first
!> evaluated t whose gap is below s gap0. Guarantee (exact arithmetic): the
!> returned t has gap(t') > 0 for every t' in [0, t] and gap(t) >= s gap0
!> (> 0: a Newton step cut to t leaves the pair apart); it is conservative,
!> t <= t_s, the first time the gap falls to s gap0, and t >= t_s - 0.9
!> gap(t)/l_p. Cost: one distance a iteration; the count grows like
!> log(1/s) for a head-on approach and like l_p/(s gap0) for a sliding
!> one, so it is capped at ACCD_MAX_ITER (the t reached so far is returned:
!> still safe, only more conservative). Plain arrays, no PETSc, no MPI.
module contact_ccd
  use kinds, only: rp
  use contact, only: obstacle_t
  use contact_primitives, only: point_triangle_d2, edge_edge_d2
  use contact_faces, only: obstacle_points, obstacle_edges, obstacle_radius
  implicit none
  private
  public :: accd_point_triangle, accd_edge_edge, accd_rate_bound, ccd_triangle, ccd_edge
  public :: ACCD_MAX_ITER, ACCD_S

  !> Iterations of one ACCD call at most (the t reached is returned).
  integer, parameter :: ACCD_MAX_ITER = 1000
  !> The fraction of the start's gap that ACCD keeps by default (CIPC's choice: 0.1).
  real(rp), parameter :: ACCD_S = 0.1_rp

  integer, parameter :: KIND_PT = 1, KIND_EE = 2

contains

  !> ACCD of point x(:, 1) against triangle x(:, 2:4), moving by dx: the largest t in [0, tmax]
  !> that ACCD certifies (module header) for the gap sqrt(d2) - xi; tmax when the gap stays at
  !> or above s gap0 up to tmax; 0 when gap0 <= 0.
  pure function accd_point_triangle(x, dx, xi, s, tmax) result(t)
    real(rp), intent(in) :: x(3, 4)    ! start positions [length]
    real(rp), intent(in) :: dx(3, 4)   ! displacements over the step [length]
    real(rp), intent(in) :: xi         ! distance at which the gap is 0: radius + thickness [length]
    real(rp), intent(in) :: s          ! in (0, 1): keep at least s gap0 [1]
    real(rp), intent(in) :: tmax       ! in (0, 1] [1]
    real(rp) :: t

    t = accd(KIND_PT, x, dx, xi, s, tmax)
  end function accd_point_triangle

  !> ACCD of edge x(:, 1)-x(:, 2) against edge x(:, 3)-x(:, 4), moving by dx; as accd_point_triangle.
  pure function accd_edge_edge(x, dx, xi, s, tmax) result(t)
    real(rp), intent(in) :: x(3, 4), dx(3, 4), xi, s, tmax
    real(rp) :: t

    t = accd(KIND_EE, x, dx, xi, s, tmax)
  end function accd_edge_edge

  !> l_p: a bound of |d distance/dt| along the path (module header), the mean displacement
  !> removed; kind 1 point-triangle, 2 edge-edge.
  pure real(rp) function accd_rate_bound(kind, dx) result(lp)
    integer, intent(in) :: kind
    real(rp), intent(in) :: dx(3, 4)
    real(rp) :: pbar(3), ln(4)
    integer :: k

    pbar = 0.25_rp * sum(dx, dim=2)
    do k = 1, 4
      ln(k) = norm2(dx(:, k) - pbar)
    end do
    if (kind == KIND_PT) then
      lp = ln(1) + maxval(ln(2:4))
    else
      lp = max(ln(1), ln(2)) + max(ln(3), ln(4))
    end if
  end function accd_rate_bound

  !> Gap of the pair at positions y.
  pure real(rp) function pair_gap(kind, y, xi) result(gap)
    integer, intent(in) :: kind
    real(rp), intent(in) :: y(3, 4), xi
    real(rp) :: d2, den

    if (kind == KIND_PT) then
      d2 = point_triangle_d2(y(:, 1), y(:, 2), y(:, 3), y(:, 4))
    else
      d2 = edge_edge_d2(y(:, 1), y(:, 2), y(:, 3), y(:, 4))
    end if
    ! (d2 - xi^2)/(d + xi): the gap without the cancellation of d - xi when xi >> gap.
    den = sqrt(d2) + xi
    gap = 0.0_rp
    if (den > 0.0_rp) gap = (d2 - xi * xi) / den
  end function pair_gap

  !> ACCD's loop (CIPC's Algorithm 1) for either kind.
  pure real(rp) function accd(kind, x, dx, xi, s, tmax) result(t)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(3, 4), dx(3, 4), xi, s, tmax
    real(rp) :: p(3, 4), pbar(3), lp, gap0, gap, gtarget, tl
    integer :: it, k

    t = 0.0_rp
    gap0 = pair_gap(kind, x, xi)
    if (gap0 <= 0.0_rp) return
    lp = accd_rate_bound(kind, dx)
    t = tmax
    if (lp <= 0.0_rp) return
    pbar = 0.25_rp * sum(dx, dim=2)
    do k = 1, 4
      p(:, k) = dx(:, k) - pbar
    end do
    gtarget = s * gap0
    t = 0.0_rp
    tl = (1.0_rp - s) * gap0 / lp
    do it = 1, ACCD_MAX_ITER
      gap = pair_gap(kind, x + (t + tl) * p, xi)
      if (t > 0.0_rp .and. gap < gtarget) return
      t = t + tl
      if (t >= tmax) then
        t = tmax
        return
      end if
      tl = 0.9_rp * gap / lp
    end do
  end function accd

  !> Step limit of cloth triangle xt0 moving by dxt against the obstacle o (its pose at the
  !> step's start) translating by dobs: the smallest ACCD t (fraction s kept) over the
  !> obstacle's points against the triangle, 1 if none comes near. Together with the nodes'
  !> exact time_of_impact_moving (module contact) and ccd_edge on the triangle's edges it
  !> keeps every gap of the triangle positive along [0, alpha].
  pure function ccd_triangle(o, thickness, xt0, dxt, dobs, s) result(alpha)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness     ! [length]
    real(rp), intent(in) :: xt0(3, 3)     ! start positions [length]
    real(rp), intent(in) :: dxt(3, 3)     ! displacements over the step [length]
    real(rp), intent(in) :: dobs(3)       ! obstacle translation over the step [length]
    real(rp), intent(in) :: s             ! fraction of each pair's gap kept, e.g. ACCD_S [1]
    real(rp) :: alpha
    real(rp) :: pts(3, 8), xi, rel(3, 3), lo(3), hi(3), x(3, 4), dx(3, 4)
    integer :: np, k

    alpha = 1.0_rp
    call obstacle_points(o, pts, np)
    if (np == 0) return
    xi = obstacle_radius(o) + thickness
    do k = 1, 3
      rel(:, k) = dxt(:, k) - dobs
    end do
    lo = min(minval(xt0, dim=2), minval(xt0 + rel, dim=2)) - xi
    hi = max(maxval(xt0, dim=2), maxval(xt0 + rel, dim=2)) + xi
    x(:, 2:4) = xt0
    dx(:, 1) = 0.0_rp
    dx(:, 2:4) = rel
    do k = 1, np
      if (any(pts(:, k) < lo .or. pts(:, k) > hi)) cycle
      x(:, 1) = pts(:, k)
      alpha = min(alpha, accd(KIND_PT, x, dx, xi, s, alpha))
      if (alpha <= 0.0_rp) return
    end do
  end function ccd_triangle

  !> Step limit of cloth edge xe0 moving by dxe against the obstacle's edges (capsule axis,
  !> box edges) translating by dobs; as ccd_triangle.
  pure function ccd_edge(o, thickness, xe0, dxe, dobs, s) result(alpha)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness, xe0(3, 2), dxe(3, 2), dobs(3), s
    real(rp) :: alpha
    real(rp) :: ea(3, 12), eb(3, 12), xi, rel(3, 2), lo(3), hi(3), x(3, 4), dx(3, 4)
    integer :: ne, k

    alpha = 1.0_rp
    call obstacle_edges(o, ea, eb, ne)
    if (ne == 0) return
    xi = obstacle_radius(o) + thickness
    do k = 1, 2
      rel(:, k) = dxe(:, k) - dobs
    end do
    lo = min(minval(xe0, dim=2), minval(xe0 + rel, dim=2)) - xi
    hi = max(maxval(xe0, dim=2), maxval(xe0 + rel, dim=2)) + xi
    x(:, 1:2) = xe0
    dx(:, 1:2) = rel
    dx(:, 3:4) = 0.0_rp
    do k = 1, ne
      if (any(min(ea(:, k), eb(:, k)) > hi .or. max(ea(:, k), eb(:, k)) < lo)) cycle
      x(:, 3) = ea(:, k)
      x(:, 4) = eb(:, k)
      alpha = min(alpha, accd(KIND_EE, x, dx, xi, s, alpha))
      if (alpha <= 0.0_rp) return
    end do
  end function ccd_edge

end module contact_ccd
