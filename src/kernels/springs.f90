! SPDX-License-Identifier: BSD-2-Clause
!> Voigt element (spring + dashpot in parallel) on one link p-q: force,
!> Jacobian blocks, energy and dissipated power (docs/model.md section 2).
!> Only the force on p is returned: the force on q is its negative, and the
!> Jacobian blocks of q follow by sign (df_p/dx_q = -K, df_q/dx_q = K, same for C).
!> The model code is a plain integer (1 = axial, 2 = linear, the values of
!> config's SPRING_AXIAL / SPRING_LINEAR) so that the kernels need nothing
!> outside src/kernels.
module springs
  use kinds, only: rp
  implicit none
  private
  public :: link_force, link_force_lanes, link_jacobian, link_jacobian_lanes, link_energy, link_power, link_power_lanes

  ! Same values as config's SPRING_AXIAL / SPRING_LINEAR; kept private here.
  integer, parameter :: MODEL_AXIAL = 1
  integer, parameter :: MODEL_LINEAR = 2
  ! An axial link shorter than this fraction of its rest length has no
  ! direction n = d/l: the kernels report it instead of dividing by ~0.
  real(rp), parameter :: SHORT_REL = 1.0e-12_rp
  ! Absolute floor so that 1/l cannot overflow when L itself is ~0.
  real(rp), parameter :: SHORT_ABS = 1.0e-150_rp

contains

  !> Force on p of link p-q; ok = .false. (and f = 0) for a zero-length axial link or an unknown model.
  pure subroutine link_force(model, E, eta, d0, L, xp, xq, vp, vq, f, ok)
    integer, intent(in) :: model              ! 1 axial, 2 linear
    real(rp), intent(in) :: E                 ! stiffness [force/length]
    real(rp), intent(in) :: eta               ! damping [force*time/length]
    real(rp), intent(in) :: d0(3)             ! rest vector X_p - X_q [length]
    real(rp), intent(in) :: L                 ! rest length |d0| [length]
    real(rp), intent(in) :: xp(3), xq(3)      ! positions [length]
    real(rp), intent(in) :: vp(3), vq(3)      ! velocities [length/time]
    real(rp), intent(out) :: f(3)             ! force on p [force]
    logical, intent(out) :: ok
    real(rp) :: d(3), vr(3), ln, n(3), ldot

    d = xp - xq
    vr = vp - vq
    ok = .true.
    select case (model)
    case (MODEL_LINEAR)
      f = -(E*(d - d0) + eta*vr)
    case (MODEL_AXIAL)
      ln = sqrt(dot_product(d, d))
      if (ln <= max(SHORT_REL*L, SHORT_ABS)) then
        ok = .false.
        f = 0.0_rp
        return
      end if
      n = d/ln
      ldot = dot_product(n, vr)
      f = -(E*(ln - L) + eta*ldot)*n
    case default
      ok = .false.
      f = 0.0_rp
    end select
  end subroutine link_force

  !> K = df_p/dx_p, C = df_p/dv_p; clamp drops the indefinite compression term (preconditioner only).
  pure subroutine link_jacobian(model, E, eta, d0, L, xp, xq, vp, vq, clamp, K, C, ok)
    integer, intent(in) :: model              ! 1 axial, 2 linear
    real(rp), intent(in) :: E, eta            ! stiffness, damping
    real(rp), intent(in) :: d0(3)             ! rest vector (unused by both Jacobians; kept for a uniform call)
    real(rp), intent(in) :: L                 ! rest length
    real(rp), intent(in) :: xp(3), xq(3), vp(3), vq(3)
    logical, intent(in) :: clamp              ! .true.: drop E(1-L/l)Q when l < L
    real(rp), intent(out) :: K(3,3)           ! df_p/dx_p [force/length]
    real(rp), intent(out) :: C(3,3)           ! df_p/dv_p [force*time/length]
    logical, intent(out) :: ok
    real(rp) :: d(3), vr(3), ln, il, n(3), ldot, qv(3), geo
    integer :: i, j

    d = xp - xq
    vr = vp - vq
    ok = .true.
    select case (model)
    case (MODEL_LINEAR)
      K = 0.0_rp
      C = 0.0_rp
      do i = 1, 3
        K(i,i) = -E
        C(i,i) = -eta
      end do
    case (MODEL_AXIAL)
      ln = sqrt(dot_product(d, d))
      if (ln <= max(SHORT_REL*L, SHORT_ABS)) then
        ok = .false.
        K = 0.0_rp
        C = 0.0_rp
        return
      end if
      il = 1.0_rp/ln
      n = d*il
      ldot = dot_product(n, vr)
      qv = vr - ldot*n                        ! Q (vp - vq), the transverse relative velocity
      ! Coefficient of Q: geometric stiffness E(1 - L/l) plus the dashpot's
      ! turning term eta*ldot/l. Clamping removes only the negative part of
      ! the former (compression), the latter is not a stiffness.
      geo = E*(1.0_rp - L*il)
      if (clamp) geo = max(geo, 0.0_rp)
      geo = geo + eta*ldot*il
      do j = 1, 3
        do i = 1, 3
          ! -E P - geo Q - eta n (Q vr)^T / l, with P = n n^T, Q = I - P
          K(i,j) = -(E - geo)*n(i)*n(j) - eta*il*n(i)*qv(j)
          C(i,j) = -eta*n(i)*n(j)
        end do
        K(j,j) = K(j,j) - geo
      end do
    case default
      ok = .false.
      K = 0.0_rp
      C = 0.0_rp
    end select
  end subroutine link_jacobian

  !> link_force for n links at once (the same model, rest vector d0 and
  !> length L), lane i from d(i, :) = x_p - x_q, vr(i, :) = v_p - v_q and
  !> its constants e(i), eta(i): f(i, :), ok(i) as link_force gives them, up
  !> to round-off. As link_jacobian_lanes, one loop without a branch (a too
  !> short axial link computed on a unit length and zeroed); the residual
  !> takes a row of links of one direction at a time (link by link, the
  !> links were a third of a residual evaluation).
  pure subroutine link_force_lanes(n, ld, model, e, eta, d0, L, d, vr, f, ok)
    integer, intent(in) :: n                  ! lanes 1..n of arrays of leading dimension ld >= n
    integer, intent(in) :: ld
    integer, intent(in) :: model              ! 1 axial, 2 linear
    real(rp), intent(in) :: e(ld), eta(ld)    ! stiffness, damping
    real(rp), intent(in) :: d0(3)             ! rest vector X_p - X_q [length]
    real(rp), intent(in) :: L                 ! rest length |d0| [length]
    real(rp), intent(in) :: d(ld, 3), vr(ld, 3)
    real(rp), intent(inout) :: f(ld, 3)       ! force on p [force] (lanes 1..n set)
    logical, intent(inout) :: ok(ld)
    real(rp) :: ln, il, ldot, keep, s
    integer :: i, a

    if (model == MODEL_LINEAR) then
      do a = 1, 3
        f(1:n, a) = -(e(1:n)*(d(1:n, a) - d0(a)) + eta(1:n)*vr(1:n, a))
      end do
      ok(1:n) = .true.
      return
    end if
    if (model /= MODEL_AXIAL) then
      f(1:n, :) = 0.0_rp
      ok(1:n) = .false.
      return
    end if
    do i = 1, n
      ln = sqrt(d(i, 1)*d(i, 1) + d(i, 2)*d(i, 2) + d(i, 3)*d(i, 3))
      keep = merge(1.0_rp, 0.0_rp, ln > max(SHORT_REL*L, SHORT_ABS))
      ln = merge(ln, 1.0_rp, keep > 0.0_rp)
      il = 1.0_rp/ln
      ldot = (d(i, 1)*il)*vr(i, 1) + (d(i, 2)*il)*vr(i, 2) + (d(i, 3)*il)*vr(i, 3)
      s = keep*(-(e(i)*(ln - L) + eta(i)*ldot))
      f(i, 1) = s*(d(i, 1)*il)
      f(i, 2) = s*(d(i, 2)*il)
      f(i, 3) = s*(d(i, 3)*il)
    end do
    do i = 1, n
      ok(i) = sqrt(d(i, 1)*d(i, 1) + d(i, 2)*d(i, 2) + d(i, 3)*d(i, 3)) > max(SHORT_REL*L, SHORT_ABS)
    end do
  end subroutine link_force_lanes

  !> link_jacobian for n links at once (the same model, rest length L and
  !> clamp), lane i from d(i, :) = x_p - x_q, vr(i, :) = v_p - v_q and its
  !> constants e(i), eta(i): K(i, :, :), C(i, :, :), ok(i) as link_jacobian
  !> gives them, up to round-off. One loop the compiler vectorises (no
  !> branch in it: a too short axial link is computed on a unit length and
  !> zeroed); the assembly takes a row of links of one direction at a time.
  pure subroutine link_jacobian_lanes(n, ld, model, e, eta, L, d, vr, clamp, K, C, ok)
    integer, intent(in) :: n                  ! lanes 1..n of arrays of leading dimension ld >= n
    integer, intent(in) :: ld
    integer, intent(in) :: model              ! 1 axial, 2 linear
    real(rp), intent(in) :: e(ld), eta(ld)    ! stiffness, damping
    real(rp), intent(in) :: L                 ! rest length
    real(rp), intent(in) :: d(ld, 3), vr(ld, 3)
    logical, intent(in) :: clamp
    real(rp), intent(inout) :: K(ld, 3, 3)    ! df_p/dx_p [force/length] (lanes 1..n set)
    real(rp), intent(inout) :: C(ld, 3, 3)    ! df_p/dv_p [force*time/length] (lanes 1..n set)
    logical, intent(inout) :: ok(ld)
    real(rp) :: ln, il, nv(3), ldot, qv(3), geo, keep, cmin
    integer :: i, a, b

    if (model == MODEL_LINEAR) then
      do b = 1, 3
        do a = 1, 3
          K(1:n, a, b) = 0.0_rp
          C(1:n, a, b) = 0.0_rp
        end do
        K(1:n, b, b) = -e(1:n)
        C(1:n, b, b) = -eta(1:n)
      end do
      ok(1:n) = .true.
      return
    end if
    if (model /= MODEL_AXIAL) then
      K(1:n, :, :) = 0.0_rp
      C(1:n, :, :) = 0.0_rp
      ok(1:n) = .false.
      return
    end if
    ! clamp: geo >= 0; else no bound
    cmin = merge(0.0_rp, -huge(1.0_rp), clamp)
    !GCC$ ivdep
    do i = 1, n
      ln = sqrt(d(i, 1)*d(i, 1) + d(i, 2)*d(i, 2) + d(i, 3)*d(i, 3))
      keep = merge(1.0_rp, 0.0_rp, ln > max(SHORT_REL*L, SHORT_ABS))
      ln = merge(ln, 1.0_rp, keep > 0.0_rp)
      il = 1.0_rp/ln
      !GCC$ unroll 3
      do a = 1, 3
        nv(a) = d(i, a)*il
      end do
      ldot = nv(1)*vr(i, 1) + nv(2)*vr(i, 2) + nv(3)*vr(i, 3)
      !GCC$ unroll 3
      do a = 1, 3
        qv(a) = vr(i, a) - ldot*nv(a)
      end do
      geo = max(e(i)*(1.0_rp - L*il), cmin) + eta(i)*ldot*il
      !GCC$ unroll 3
      do b = 1, 3
        !GCC$ unroll 3
        do a = 1, 3
          K(i, a, b) = keep*(-(e(i) - geo)*nv(a)*nv(b) - eta(i)*il*nv(a)*qv(b) - merge(geo, 0.0_rp, a == b))
          C(i, a, b) = keep*(-eta(i)*nv(a)*nv(b))
        end do
      end do
    end do
    ! (apart: a logical stored in the loop above kept it from vectorising)
    do i = 1, n
      ok(i) = sqrt(d(i, 1)*d(i, 1) + d(i, 2)*d(i, 2) + d(i, 3)*d(i, 3)) > max(SHORT_REL*L, SHORT_ABS)
    end do
  end subroutine link_jacobian_lanes

  !> Stored energy of the link: 1/2 E (l-L)^2 (axial) or 1/2 E |d-d0|^2 (linear); 0 for an unknown model.
  pure function link_energy(model, E, d0, L, xp, xq) result(w)
    integer, intent(in) :: model
    real(rp), intent(in) :: E, d0(3), L, xp(3), xq(3)
    real(rp) :: w                              ! [energy]

    select case (model)
    case (MODEL_LINEAR)
      w = 0.5_rp*E*sum((xp - xq - d0)**2)
    case (MODEL_AXIAL)
      w = 0.5_rp*E*(sqrt(dot_product(xp - xq, xp - xq)) - L)**2
    case default
      w = 0.0_rp
    end select
  end function link_energy

  !> Power dissipated by the dashpot: eta ldot^2 (axial) or eta |vp-vq|^2 (linear); >= 0.
  pure function link_power(model, eta, xp, xq, vp, vq) result(pw)
    integer, intent(in) :: model
    real(rp), intent(in) :: eta, xp(3), xq(3), vp(3), vq(3)
    real(rp) :: pw                             ! [energy/time]
    real(rp) :: d(3), ln

    select case (model)
    case (MODEL_LINEAR)
      pw = eta*sum((vp - vq)**2)
    case (MODEL_AXIAL)
      d = xp - xq
      ln = sqrt(dot_product(d, d))
      ! A zero-length link has no axis, hence no axial rate: no power.
      if (ln <= SHORT_ABS) then
        pw = 0.0_rp
      else
        pw = eta*(dot_product(d, vp - vq)/ln)**2
      end if
    case default
      pw = 0.0_rp
    end select
  end function link_power

  !> link_power for n links at once (the same model), lane i from
  !> d(i, :) = x_p - x_q, vr(i, :) = v_p - v_q and its eta(i): pw(i) as
  !> link_power gives it, up to round-off. One loop without a branch (a
  !> zero-length axial link is computed on a unit length and zeroed), as
  !> link_force_lanes: link by link, the diagnostics' dissipated power
  !> took 3-4 % of a Baraff-Witkin step without bending.
  pure subroutine link_power_lanes(n, ld, model, eta, d, vr, pw)
    integer, intent(in) :: n                  ! lanes 1..n of arrays of leading dimension ld >= n
    integer, intent(in) :: ld
    integer, intent(in) :: model              ! 1 axial, 2 linear
    real(rp), intent(in) :: eta(ld)           ! [force*time/length]
    real(rp), intent(in) :: d(ld, 3), vr(ld, 3)
    real(rp), intent(inout) :: pw(ld)         ! [energy/time] (lanes 1..n set)
    real(rp) :: ln, keep, s
    integer :: i

    select case (model)
    case (MODEL_LINEAR)
      do i = 1, n
        pw(i) = eta(i)*(vr(i, 1)**2 + vr(i, 2)**2 + vr(i, 3)**2)
      end do
    case (MODEL_AXIAL)
      do i = 1, n
        ln = sqrt(d(i, 1)*d(i, 1) + d(i, 2)*d(i, 2) + d(i, 3)*d(i, 3))
        keep = merge(1.0_rp, 0.0_rp, ln > SHORT_ABS)
        ln = merge(ln, 1.0_rp, keep > 0.0_rp)
        s = (d(i, 1)*vr(i, 1) + d(i, 2)*vr(i, 2) + d(i, 3)*vr(i, 3))/ln
        pw(i) = keep*eta(i)*s**2
      end do
    case default
      pw(1:n) = 0.0_rp
    end select
  end subroutine link_power_lanes

end module springs
