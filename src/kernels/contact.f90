! SPDX-License-Identifier: BSD-2-Clause
!> Contact of one node with one rigid obstacle (docs/model.md, "Contact"):
!> the signed distance to a plane, sphere, oriented box or capsule with its
!> gradient and Hessian; the IPC barrier (Li et al. 2020) on the gap
!> signed_distance - thickness; continuous collision detection of a node
!> moving on a straight line against the shape (exact: first root of the
!> shape's quadratic, slabs for the box); the barrier force with its
!> Jacobian and lagged, smoothed Coulomb friction with its velocity Jacobian.
!> Plain arrays only: no PETSc, no MPI, no allocation.
module contact
  use kinds, only: rp
  use smoothed_coulomb, only: coulomb_slip, coulomb_power
  implicit none
  private
  public :: SHAPE_PLANE, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE
  public :: obstacle_t, contact_params_t
  public :: signed_distance, barrier, time_of_impact, contact_node, friction_power
  public :: time_of_impact_moving, psd_project3

  integer, parameter :: SHAPE_PLANE = 1, SHAPE_SPHERE = 2, SHAPE_BOX = 3, SHAPE_CAPSULE = 4

  !> One rigid obstacle at one instant (the caller evaluates keyframed poses).
  type :: obstacle_t
    integer  :: shape = 0
    real(rp) :: p(3) = 0.0_rp            !< plane: a point on it; sphere, box: centre; capsule: first end [length]
    real(rp) :: n(3) = [0.0_rp, 0.0_rp, 1.0_rp]  !< plane: outward unit normal [1]
    real(rp) :: q(3) = 0.0_rp            !< capsule: second end [length]
    real(rp) :: r = 0.0_rp               !< sphere, capsule: radius [length]
    real(rp) :: h(3) = 0.0_rp            !< box: half extents along its axes [length]
    real(rp) :: axes(3, 3) = reshape([1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp], [3, 3])
                                         !< box: columns are its unit axes in the world frame [1]
    real(rp) :: vel(3) = 0.0_rp          !< obstacle velocity at this instant (translation) [length/time]
    real(rp) :: mu = 0.0_rp              !< Coulomb friction coefficient [1]
  end type obstacle_t

  !> Barrier and friction parameters shared by all obstacles.
  type :: contact_params_t
    real(rp) :: thickness = 0.0_rp   !< contact distance: gap = signed_distance - thickness [length]
    real(rp) :: dhat = 0.0_rp        !< barrier active for 0 < gap < dhat [length]
    real(rp) :: kappa = 0.0_rp       !< barrier stiffness: energy kappa * b(gap) [force/length]
    real(rp) :: eps_v = 0.0_rp       !< friction: smoothing velocity (IPC's f1 mollifier) [length/time]
  end type contact_params_t

  real(rp), parameter :: EYE(3, 3) = reshape([1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp], &
                                             [3, 3])

contains

  ! ------------------------------------------------------------------------
  ! Signed distance
  ! ------------------------------------------------------------------------

  !> Signed distance d of x to the obstacle's surface (< 0 inside), gradient g, Hessian hd.
  !> g is the unit outward normal at the nearest surface point; hd is 0 on flat
  !> faces and inside the box, and (P - g g^T)/dist on a round feature, where P
  !> projects on the directions in which the feature curves. Where the nearest
  !> point is not unique (the centre of a sphere, the axis of a capsule, the
  !> medial planes inside a box) a fixed choice is made and hd is 0 or one-sided.
  !> An unknown shape gives d = huge (no contact).
  pure subroutine signed_distance(o, x, d, g, hd)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: x(3)        ! point [length]
    real(rp), intent(out) :: d          ! signed distance [length]
    real(rp), intent(out) :: g(3)       ! gradient of d [1]
    real(rp), intent(out) :: hd(3, 3)   ! Hessian of d [1/length]

    select case (o%shape)
    case (SHAPE_PLANE)
      g = unit_or(o%n, [0.0_rp, 0.0_rp, 1.0_rp])
      d = dot_product(g, x - o%p)
      hd = 0.0_rp
    case (SHAPE_SPHERE)
      call point_distance(o%p, o%r, x, EYE, d, g, hd)
    case (SHAPE_CAPSULE)
      call capsule_distance(o%p, o%q, o%r, x, d, g, hd)
    case (SHAPE_BOX)
      call box_distance(o%p, o%axes, o%h, x, d, g, hd)
    case default
      d = huge(1.0_rp)
      g = [0.0_rp, 0.0_rp, 1.0_rp]
      hd = 0.0_rp
    end select
  end subroutine signed_distance

  !> Distance to a point c (curving in the directions of projector pc), minus radius r.
  !> pc = I: a sphere; pc = I - e e^T: an infinite cylinder of axis e through c.
  pure subroutine point_distance(c, r, x, pc, d, g, hd)
    real(rp), intent(in) :: c(3), r, x(3), pc(3, 3)
    real(rp), intent(out) :: d, g(3), hd(3, 3)
    real(rp) :: w(3), l
    integer :: i

    w = matmul(pc, x - c)
    l = norm2(w)
    d = l - r
    if (l > 0.0_rp) then
      g = w / l
      hd = pc
      do i = 1, 3
        hd(:, i) = (hd(:, i) - g * g(i)) / l
      end do
    else
      ! On the centre (or axis): no unique normal; pick one the projector keeps.
      g = any_unit_in(pc)
      hd = 0.0_rp
    end if
  end subroutine point_distance

  !> Capsule: segment a-b swept by a ball of radius r.
  pure subroutine capsule_distance(a, b, r, x, d, g, hd)
    real(rp), intent(in) :: a(3), b(3), r, x(3)
    real(rp), intent(out) :: d, g(3), hd(3, 3)
    real(rp) :: ab(3), l2, t, e(3), pc(3, 3)
    integer :: i

    ab = b - a
    l2 = dot_product(ab, ab)
    if (l2 <= 0.0_rp) then
      call point_distance(a, r, x, EYE, d, g, hd)
      return
    end if
    t = dot_product(x - a, ab) / l2
    if (t <= 0.0_rp) then
      call point_distance(a, r, x, EYE, d, g, hd)
    else if (t >= 1.0_rp) then
      call point_distance(b, r, x, EYE, d, g, hd)
    else
      ! Body: distance to the axis line, flat along it.
      e = ab / sqrt(l2)
      do i = 1, 3
        pc(:, i) = EYE(:, i) - e * e(i)
      end do
      call point_distance(a, r, x, pc, d, g, hd)
    end if
  end subroutine capsule_distance

  !> Oriented box of centre c, unit axes (columns of ax) and half extents h.
  !> Outside: distance to the nearest face, edge or corner (1, 2 or 3 local
  !> coordinates beyond the half extents). Inside: minus the distance to the
  !> nearest face (the first axis on a tie, + side at the centre plane).
  pure subroutine box_distance(c, ax, h, x, d, g, hd)
    real(rp), intent(in) :: c(3), ax(3, 3), h(3), x(3)
    real(rp), intent(out) :: d, g(3), hd(3, 3)
    real(rp) :: y(3), s(3), qo(3), gl(3), hl(3, 3)
    integer :: i, k

    y = matmul(transpose(ax), x - c)
    s = merge(-1.0_rp, 1.0_rp, y < 0.0_rp)
    qo = max(abs(y) - h, 0.0_rp)
    hl = 0.0_rp
    if (any(qo > 0.0_rp)) then
      d = norm2(qo)
      gl = s * qo / d
      if (count(qo > 0.0_rp) > 1) then
        ! Edge (2) or corner (3): curved across the axes that are outside.
        do i = 1, 3
          if (qo(i) > 0.0_rp) hl(i, i) = 1.0_rp
        end do
        do i = 1, 3
          hl(:, i) = (hl(:, i) - gl * gl(i)) / d
        end do
      end if
    else
      k = maxloc(abs(y) - h, dim=1)
      d = abs(y(k)) - h(k)
      gl = 0.0_rp
      gl(k) = s(k)
    end if
    g = matmul(ax, gl)
    hd = matmul(ax, matmul(hl, transpose(ax)))
  end subroutine box_distance

  ! ------------------------------------------------------------------------
  ! Barrier
  ! ------------------------------------------------------------------------

  !> IPC barrier b(s) = -(s - dhat)^2 log(s / dhat) on 0 < s < dhat, 0 from dhat on, with b', b''.
  !> C2 at dhat (b = b' = b'' = 0 there from both sides); b' < 0 and b'' > 0 inside.
  !> s <= 0 gives e = huge and de = d2e = 0: the caller must refuse such a state.
  pure subroutine barrier(s, dhat, e, de, d2e)
    real(rp), intent(in) :: s       ! gap [length]
    real(rp), intent(in) :: dhat    ! activation distance [length]
    real(rp), intent(out) :: e      ! b(s) [length^2]
    real(rp), intent(out) :: de     ! b'(s) [length]
    real(rp), intent(out) :: d2e    ! b''(s) [1]
    real(rp) :: lg, dm

    if (s <= 0.0_rp) then
      e = huge(1.0_rp)
      de = 0.0_rp
      d2e = 0.0_rp
    else if (s >= dhat) then
      e = 0.0_rp
      de = 0.0_rp
      d2e = 0.0_rp
    else
      lg = log(s / dhat)
      dm = s - dhat
      e = -dm * dm * lg
      de = -2.0_rp * dm * lg - dm * dm / s
      d2e = -2.0_rp * lg - 4.0_rp * dm / s + (dm / s)**2
    end if
  end subroutine barrier

  ! ------------------------------------------------------------------------
  ! Continuous collision detection
  ! ------------------------------------------------------------------------

  !> Largest alpha in [0, 1] with gap(x0 + t dx) > 0 for all t in [0, alpha), static obstacle.
  !> Exact for every shape: the first root of the sphere's or cylinder's
  !> quadratic, and for the box the first entry into the box grown by the
  !> thickness (three boxes grown along one axis each, by slabs, and twelve
  !> edge capsules of radius thickness). 0 when the start has gap <= 0;
  !> 1 when the segment never touches (or first touches at t = 1).
  pure function time_of_impact(o, thickness, x0, dx) result(alpha)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness   ! [length]
    real(rp), intent(in) :: x0(3)       ! start [length]
    real(rp), intent(in) :: dx(3)       ! displacement over the step [length]
    real(rp) :: alpha
    real(rp) :: d, g(3), hd(3, 3), nn(3), vn

    alpha = 1.0_rp
    call signed_distance(o, x0, d, g, hd)
    if (d - thickness <= 0.0_rp) then
      alpha = 0.0_rp
      return
    end if
    select case (o%shape)
    case (SHAPE_PLANE)
      nn = unit_or(o%n, [0.0_rp, 0.0_rp, 1.0_rp])
      vn = dot_product(nn, dx)
      if (vn < 0.0_rp) alpha = min(1.0_rp, (d - thickness) / (-vn))
    case (SHAPE_SPHERE)
      alpha = sphere_toi(o%p, o%r + thickness, x0, dx)
    case (SHAPE_CAPSULE)
      alpha = capsule_toi(o%p, o%q, o%r + thickness, x0, dx)
    case (SHAPE_BOX)
      alpha = box_toi(o%p, o%axes, o%h, thickness, x0, dx)
    end select
  end function time_of_impact

  !> time_of_impact for an obstacle that translates by dobs over the step (o: its pose at the
  !> step's start): the node's motion relative to the obstacle, dx - dobs, against the static
  !> pose. Exact for a translation linear in time (keyframed poses, gripper fingers).
  pure function time_of_impact_moving(o, thickness, x0, dx, dobs) result(alpha)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness, x0(3), dx(3)
    real(rp), intent(in) :: dobs(3)     ! obstacle translation over the step [length]
    real(rp) :: alpha

    alpha = time_of_impact(o, thickness, x0, dx - dobs)
  end function time_of_impact_moving

  !> First t in [0, 1] at which x0 + t dx reaches the ball |x - c| <= rr (1 if never).
  pure function sphere_toi(c, rr, x0, dx) result(t)
    real(rp), intent(in) :: c(3), rr, x0(3), dx(3)
    real(rp) :: t

    t = quadratic_entry(dot_product(dx, dx), dot_product(x0 - c, dx), dot_product(x0 - c, x0 - c) - rr * rr)
  end function sphere_toi

  !> First t >= 0 where a t^2 + 2 bh t + c reaches 0, from c > 0; min(t, 1), 1 if never.
  !> Stable root c / (-bh + sqrt(disc)); a tangent path (disc = 0) touches at -bh/a.
  pure function quadratic_entry(a, bh, c) result(t)
    real(rp), intent(in) :: a, bh, c
    real(rp) :: t, disc

    t = 1.0_rp
    if (c <= 0.0_rp) then
      t = 0.0_rp
      return
    end if
    if (bh >= 0.0_rp .or. a <= 0.0_rp) return
    disc = bh * bh - a * c
    if (disc < 0.0_rp) return
    t = min(1.0_rp, c / (-bh + sqrt(disc)))
  end function quadratic_entry

  !> First entry of x0 + t dx into the capsule a-b of radius rr: the earliest of the
  !> two end balls and the cylinder's side where the axial coordinate is within the
  !> segment (entering through an end disc means being inside that end's ball before).
  pure function capsule_toi(a, b, rr, x0, dx) result(t)
    real(rp), intent(in) :: a(3), b(3), rr, x0(3), dx(3)
    real(rp) :: t
    real(rp) :: ab(3), l, e(3), w(3), wp(3), dp(3), tc, s

    t = min(sphere_toi(a, rr, x0, dx), sphere_toi(b, rr, x0, dx))
    ab = b - a
    l = norm2(ab)
    if (l <= 0.0_rp) return
    e = ab / l
    w = x0 - a
    wp = w - dot_product(w, e) * e
    dp = dx - dot_product(dx, e) * e
    if (dot_product(wp, wp) <= rr * rr) return   ! inside the infinite cylinder: no side entry
    tc = quadratic_entry(dot_product(dp, dp), dot_product(wp, dp), dot_product(wp, wp) - rr * rr)
    if (tc >= t) return
    s = dot_product(w + tc * dx, e)
    if (s >= 0.0_rp .and. s <= l) t = tc
  end function capsule_toi

  !> First entry of x0 + t dx into the box grown by th (Minkowski sum with a ball):
  !> the union of the box grown by th along each one axis and the twelve edge capsules.
  pure function box_toi(c, ax, h, th, x0, dx) result(t)
    real(rp), intent(in) :: c(3), ax(3, 3), h(3), th, x0(3), dx(3)
    real(rp) :: t
    real(rp) :: y0(3), dy(3), hg(3), ea(3), eb(3)
    integer :: k, i, j, si, sj

    y0 = matmul(transpose(ax), x0 - c)
    dy = matmul(transpose(ax), dx)
    t = 1.0_rp
    do k = 1, 3
      hg = h
      hg(k) = h(k) + th
      t = min(t, slab_entry(hg, y0, dy))
    end do
    if (th <= 0.0_rp) return
    ! Edges along axis k at the corners (+-h(i), +-h(j)) of the other two axes.
    do k = 1, 3
      i = merge(2, 1, k == 1)
      j = merge(2, 3, k == 3)
      do si = -1, 1, 2
        do sj = -1, 1, 2
          ea = 0.0_rp
          ea(i) = si * h(i)
          ea(j) = sj * h(j)
          eb = ea
          ea(k) = -h(k)
          eb(k) = h(k)
          t = min(t, capsule_toi(ea, eb, th, y0, dy))
        end do
      end do
    end do
  end function box_toi

  !> Slab method: first t in [0, 1] at which y0 + t dy enters |y_i| <= hg_i for all i (1 if never).
  pure function slab_entry(hg, y0, dy) result(t)
    real(rp), intent(in) :: hg(3), y0(3), dy(3)
    real(rp) :: t
    real(rp) :: tin, tout, t1, t2
    integer :: i

    t = 1.0_rp
    tin = -huge(1.0_rp)
    tout = huge(1.0_rp)
    do i = 1, 3
      if (dy(i) == 0.0_rp) then
        if (abs(y0(i)) > hg(i)) return
      else
        t1 = (-hg(i) - y0(i)) / dy(i)
        t2 = (hg(i) - y0(i)) / dy(i)
        tin = max(tin, min(t1, t2))
        tout = min(tout, max(t1, t2))
      end if
    end do
    if (tin > tout .or. tout < 0.0_rp) return
    t = min(1.0_rp, max(tin, 0.0_rp))
  end function slab_entry

  ! ------------------------------------------------------------------------
  ! Node against obstacle: barrier and friction
  ! ------------------------------------------------------------------------

  !> One node against one obstacle: barrier force plus (lagged) smoothed Coulomb friction.
  !> Barrier: f = -kappa b'(gap) g, kx = -kappa (b'' g g^T + b' hd) (exact), fn = -kappa b'.
  !> Friction (when o%mu, lam and cp%eps_v are > 0, whatever the gap now, since lam is
  !> lagged): u = P (v - o%vel), P = I - nlag nlag^T, f = -mu lam f1(|u|) u/|u|,
  !> kv = -mu lam (phi P + phi'(|u|)/|u| u u^T) (exact; -kv is positive semidefinite;
  !> module smoothed_coulomb's coulomb_slip).
  !> project = .true.: kx is minus the positive semidefinite part of the barrier's Hessian
  !> kappa (b'' g g^T + b' hd) (eigenvalues clipped at 0), the one to assemble when the
  !> matrix must stay SPD. gap <= 0: e = huge and no barrier force (the caller refuses).
  pure subroutine contact_node(o, cp, x, v, lam, nlag, f, kx, kv, e, fn, active, project)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: x(3)        ! position [length]
    real(rp), intent(in) :: v(3)        ! velocity [length/time]
    real(rp), intent(in) :: lam         ! lagged normal force magnitude [force]
    real(rp), intent(in) :: nlag(3)     ! lagged unit normal [1]
    real(rp), intent(out) :: f(3)       ! force on the node [force]
    real(rp), intent(out) :: kx(3, 3)   ! df/dx [force/length]
    real(rp), intent(out) :: kv(3, 3)   ! df/dv [force*time/length]
    real(rp), intent(out) :: e          ! barrier energy kappa*b(gap) [energy]
    real(rp), intent(out) :: fn         ! normal force magnitude now [force]
    logical, intent(out) :: active      ! gap < dhat
    logical, intent(in), optional :: project
    real(rp) :: d, g(3), hd(3, 3), gap, b, db, d2b, u(3), s, c
    integer :: i

    f = 0.0_rp
    kx = 0.0_rp
    kv = 0.0_rp
    e = 0.0_rp
    fn = 0.0_rp
    call signed_distance(o, x, d, g, hd)
    gap = d - cp%thickness
    active = gap < cp%dhat
    if (active) then
      call barrier(gap, cp%dhat, b, db, d2b)
      e = cp%kappa * b
      if (gap <= 0.0_rp) e = huge(1.0_rp)
      fn = -cp%kappa * db
      f = fn * g
      do i = 1, 3
        kx(:, i) = -cp%kappa * (d2b * g * g(i) + db * hd(:, i))
      end do
      if (present(project)) then
        if (project) kx = -psd_project3(-kx)
      end if
    end if

    c = o%mu * lam
    if (c > 0.0_rp .and. cp%eps_v > 0.0_rp) then
      call coulomb_slip(c, cp%eps_v, nlag, v - o%vel, u, s, kv)
      f = f - s * u
    end if
  end subroutine contact_node

  !> Friction power dissipated (>= 0) [energy/time]: -f_fric . u = mu lam f1(|u|) |u|.
  pure function friction_power(o, cp, v, lam, nlag) result(p)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: v(3), lam, nlag(3)
    real(rp) :: p

    p = coulomb_power(o%mu * lam, cp%eps_v, nlag, v - o%vel)
  end function friction_power

  ! ------------------------------------------------------------------------
  ! Helpers
  ! ------------------------------------------------------------------------

  !> Positive semidefinite part of a symmetric 3 x 3 matrix: eigenvalues below 0 set to 0
  !> (cyclic Jacobi rotations; a is symmetrised first).
  pure function psd_project3(a) result(p)
    real(rp), intent(in) :: a(3, 3)
    real(rp) :: p(3, 3)
    real(rp) :: s(3, 3), v(3, 3), th, t, cs, sn, off, scale, lam(3), col_p(3), col_q(3)
    integer :: sweep, ip, iq, k

    s = 0.5_rp * (a + transpose(a))
    v = EYE
    scale = maxval(abs(s))
    if (scale == 0.0_rp) then
      p = 0.0_rp
      return
    end if
    do sweep = 1, 50
      off = abs(s(1, 2)) + abs(s(1, 3)) + abs(s(2, 3))
      if (off <= 1.0e-18_rp * scale) exit
      do ip = 1, 2
        do iq = ip + 1, 3
          if (s(ip, iq) == 0.0_rp) cycle
          th = (s(iq, iq) - s(ip, ip)) / (2.0_rp * s(ip, iq))
          t = sign(1.0_rp, th) / (abs(th) + sqrt(th * th + 1.0_rp))
          cs = 1.0_rp / sqrt(t * t + 1.0_rp)
          sn = t * cs
          ! s <- J^T s J for the rotation J in the (ip, iq) plane.
          do k = 1, 3
            col_p(k) = s(k, ip)
            col_q(k) = s(k, iq)
          end do
          s(:, ip) = cs * col_p - sn * col_q
          s(:, iq) = sn * col_p + cs * col_q
          do k = 1, 3
            col_p(k) = s(ip, k)
            col_q(k) = s(iq, k)
          end do
          s(ip, :) = cs * col_p - sn * col_q
          s(iq, :) = sn * col_p + cs * col_q
          col_p = v(:, ip)
          col_q = v(:, iq)
          v(:, ip) = cs * col_p - sn * col_q
          v(:, iq) = sn * col_p + cs * col_q
        end do
      end do
    end do
    do k = 1, 3
      lam(k) = max(s(k, k), 0.0_rp)
    end do
    p = 0.0_rp
    do k = 1, 3
      do ip = 1, 3
        p(:, ip) = p(:, ip) + lam(k) * v(:, k) * v(ip, k)
      end do
    end do
  end function psd_project3

  !> a / |a|, or fallback when a = 0.
  pure function unit_or(a, fallback) result(u)
    real(rp), intent(in) :: a(3), fallback(3)
    real(rp) :: u(3), l

    l = norm2(a)
    if (l > 0.0_rp) then
      u = a / l
    else
      u = fallback
    end if
  end function unit_or

  !> A unit vector in the range of the projector pc (its largest column, normalised).
  pure function any_unit_in(pc) result(u)
    real(rp), intent(in) :: pc(3, 3)
    real(rp) :: u(3)
    integer :: k

    k = maxloc([norm2(pc(:, 1)), norm2(pc(:, 2)), norm2(pc(:, 3))], dim=1)
    u = unit_or(pc(:, k), [0.0_rp, 0.0_rp, 1.0_rp])
  end function any_unit_in

end module contact
