! SPDX-License-Identifier: BSD-2-Clause
!> Contact of a node with a rigid obstacle (IPC barrier, lagged smoothed
!> Coulomb friction). MINIMAL STUB of the fixed API (plane and sphere only;
!> box and capsule never touch): replaced by the full kernel at merge.
module contact
  use kinds, only: rp
  implicit none
  private
  public :: signed_distance, barrier, time_of_impact, contact_node, friction_power

  integer, parameter, public :: SHAPE_PLANE = 1, SHAPE_SPHERE = 2, SHAPE_BOX = 3, SHAPE_CAPSULE = 4

  !> One rigid obstacle at one instant.
  type, public :: obstacle_t
    integer  :: shape = 0
    real(rp) :: p(3) = 0.0_rp            !< plane: a point on it; sphere, box: centre; capsule: first end [length]
    real(rp) :: n(3) = [0.0_rp, 0.0_rp, 1.0_rp]  !< plane: outward unit normal [1]
    real(rp) :: q(3) = 0.0_rp            !< capsule: second end [length]
    real(rp) :: r = 0.0_rp               !< sphere, capsule: radius [length]
    real(rp) :: h(3) = 0.0_rp            !< box: half extents along its axes [length]
    real(rp) :: axes(3, 3) = reshape([1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp], [3, 3])
                                         !< box: columns are its unit axes in the world frame [1]
    real(rp) :: vel(3) = 0.0_rp          !< obstacle velocity at this instant [length/time]
    real(rp) :: mu = 0.0_rp              !< Coulomb friction coefficient [1]
  end type obstacle_t

  !> Barrier and friction parameters shared by all obstacles.
  type, public :: contact_params_t
    real(rp) :: thickness = 0.0_rp   !< gap = signed_distance - thickness [length]
    real(rp) :: dhat = 0.0_rp        !< barrier active for 0 < gap < dhat [length]
    real(rp) :: kappa = 0.0_rp       !< barrier stiffness [force/length]
    real(rp) :: eps_v = 0.0_rp       !< friction smoothing velocity [length/time]
  end type contact_params_t

contains

  !> Signed distance of x to the surface (< 0 inside), unit normal g, Hessian hd.
  pure subroutine signed_distance(o, x, d, g, hd)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: x(3)
    real(rp), intent(out) :: d, g(3), hd(3, 3)
    real(rp) :: y(3), ry
    integer :: k
    hd = 0.0_rp
    select case (o%shape)
    case (SHAPE_PLANE)
      g = o%n
      d = dot_product(x - o%p, o%n)
    case (SHAPE_SPHERE)
      y = x - o%p
      ry = norm2(y)
      g = y / ry
      d = ry - o%r
      hd = -spread(g, 2, 3) * spread(g, 1, 3) / ry
      do k = 1, 3
        hd(k, k) = hd(k, k) + 1.0_rp / ry
      end do
    case default
      g = [0.0_rp, 0.0_rp, 1.0_rp]
      d = huge(1.0_rp)
    end select
  end subroutine signed_distance

  !> IPC barrier b(s) = -(s - dhat)^2 log(s / dhat) on 0 < s < dhat and its derivatives.
  pure subroutine barrier(s, dhat, e, de, d2e)
    real(rp), intent(in) :: s, dhat
    real(rp), intent(out) :: e, de, d2e
    if (s <= 0.0_rp) then
      e = huge(1.0_rp); de = 0.0_rp; d2e = 0.0_rp
    else if (s >= dhat) then
      e = 0.0_rp; de = 0.0_rp; d2e = 0.0_rp
    else
      e = -(s - dhat)**2 * log(s / dhat)
      de = -2.0_rp * (s - dhat) * log(s / dhat) - (s - dhat)**2 / s
      d2e = -2.0_rp * log(s / dhat) - 4.0_rp * (s - dhat) / s + (s - dhat)**2 / s**2
    end if
  end subroutine barrier

  !> Largest alpha in [0, 1] with gap > 0 along x0 + t dx for t in [0, alpha).
  pure function time_of_impact(o, thickness, x0, dx) result(alpha)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness, x0(3), dx(3)
    real(rp) :: alpha, a, b, c, disc, t, rr, dn
    alpha = 1.0_rp
    select case (o%shape)
    case (SHAPE_PLANE)
      dn = dot_product(dx, o%n)
      if (dn >= 0.0_rp) return
      t = (dot_product(x0 - o%p, o%n) - thickness) / (-dn)
      alpha = max(0.0_rp, min(1.0_rp, t))
    case (SHAPE_SPHERE)
      rr = o%r + thickness
      a = dot_product(dx, dx)
      if (a == 0.0_rp) return
      b = 2.0_rp * dot_product(x0 - o%p, dx)
      c = dot_product(x0 - o%p, x0 - o%p) - rr**2
      disc = b * b - 4.0_rp * a * c
      if (disc < 0.0_rp .or. b >= 0.0_rp) return
      t = (-b - sqrt(disc)) / (2.0_rp * a)
      alpha = max(0.0_rp, min(1.0_rp, t))
    end select
  end function time_of_impact

  !> One node against one obstacle: barrier force plus lagged smoothed friction.
  pure subroutine contact_node(o, cp, x, v, lam, nlag, f, kx, kv, e, fn, active)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: x(3), v(3), lam, nlag(3)
    real(rp), intent(out) :: f(3), kx(3, 3), kv(3, 3), e, fn
    logical, intent(out) :: active
    real(rp) :: d, g(3), hd(3, 3), s, b, db, d2b, pt(3, 3), vt(3), sv, f1, df1
    integer :: k
    f = 0.0_rp; kx = 0.0_rp; kv = 0.0_rp; e = 0.0_rp; fn = 0.0_rp
    call signed_distance(o, x, d, g, hd)
    s = d - cp%thickness
    active = s < cp%dhat
    if (active) then
      call barrier(s, cp%dhat, b, db, d2b)
      e = cp%kappa * b
      fn = -cp%kappa * db
      f = fn * g
      kx = -cp%kappa * (d2b * spread(g, 2, 3) * spread(g, 1, 3) + db * hd)
    end if
    if (o%mu > 0.0_rp .and. lam > 0.0_rp) then
      pt = -spread(nlag, 2, 3) * spread(nlag, 1, 3)
      do k = 1, 3
        pt(k, k) = pt(k, k) + 1.0_rp
      end do
      vt = matmul(pt, v - o%vel)
      sv = norm2(vt)
      if (sv >= cp%eps_v) then
        f1 = 1.0_rp / sv
        f = f - o%mu * lam * vt * f1
        kv = kv - o%mu * lam * f1 * (pt - spread(vt, 2, 3) * spread(vt, 1, 3) / sv**2)
      else
        ! f1(s)/s = (2 - s/eps)/eps (IPC's mollifier), smooth through 0
        f1 = (2.0_rp - sv / cp%eps_v) / cp%eps_v
        df1 = -1.0_rp / cp%eps_v**2
        f = f - o%mu * lam * f1 * vt
        if (sv > 0.0_rp) then
          kv = kv - o%mu * lam * (f1 * pt + df1 / sv * matmul(spread(vt, 2, 3) * spread(vt, 1, 3), pt))
        else
          kv = kv - o%mu * lam * f1 * pt
        end if
      end if
    end if
  end subroutine contact_node

  !> Friction power dissipated (>= 0) [energy/time].
  pure function friction_power(o, cp, v, lam, nlag) result(p)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: v(3), lam, nlag(3)
    real(rp) :: p, vt(3), sv
    p = 0.0_rp
    if (o%mu <= 0.0_rp .or. lam <= 0.0_rp) return
    vt = (v - o%vel) - dot_product(v - o%vel, nlag) * nlag
    sv = norm2(vt)
    if (sv >= cp%eps_v) then
      p = o%mu * lam * sv
    else
      p = o%mu * lam * (2.0_rp - sv / cp%eps_v) / cp%eps_v * sv**2
    end if
  end function friction_power

end module contact
