! SPDX-License-Identifier: BSD-2-Clause
!> The report's bending force (eqs. (2)-(3), docs/model.md section 3 'paper') on
!> one triple (p, q, r) centred on q, packed as x9 = [x_p; x_q; x_r].
!> With u = x_p - x_q, w = x_r - x_q, c = cos(theta) = -u_hat.w_hat and
!> g(c) = theta/sin(theta):
!>   f_p = -k_b g(c) Q_u w_hat,  f_r = -k_b g(c) Q_w u_hat,  f_q = 0,
!> so |f_p| = |f_r| = k_b theta. Neither momentum nor energy is conserved: the
!> Jacobian is not symmetric. g is smooth through theta = 0 (series in
!> t = 1 - c there), so force and Jacobian are smooth at the flat state.
module bending_paper
  use kinds, only: rp
  implicit none
  private
  public :: paper_force, paper_jacobian, paper_energy

  ! Triples with 1 + cos(theta) below this are (nearly) folded back: the
  ! straightening direction is undefined (docs/model.md: stop with a message).
  real(rp), parameter :: FOLD_TOL = 1.0e-12_rp
  ! An edge shorter than this fraction of the other (or than EDGE_ABS) counts as zero.
  real(rp), parameter :: EDGE_REL = 1.0e-12_rp
  real(rp), parameter :: EDGE_ABS = 1.0e-150_rp
  ! Below this t = 1 - cos(theta) (theta < ~0.14) g and g' come from their series.
  real(rp), parameter :: T_SERIES = 1.0e-2_rp

contains

  !> Forces on p, q (zero), r of one triple and its bend angle; ok = .false. (f9 = 0) when degenerate.
  pure subroutine paper_force(k_b, x9, f9, theta, ok)
    real(rp), intent(in) :: k_b          ! bending constant [force/radian]
    real(rp), intent(in) :: x9(9)        ! [x_p; x_q; x_r] [length]
    real(rp), intent(out) :: f9(9)       ! [f_p; f_q = 0; f_r] [force]
    real(rp), intent(out) :: theta       ! bend angle, 0 when straight [radian]
    logical, intent(out) :: ok
    real(rp) :: uh(3), wh(3), lu, lw, c, g, dg

    f9 = 0.0_rp
    call triple_geometry(x9, uh, wh, lu, lw, c, theta, g, dg, ok)
    if (.not. ok) return
    f9(1:3) = -k_b*g*(wh + c*uh)   ! Q_u w_hat = w_hat - (u_hat.w_hat) u_hat = w_hat + c u_hat
    f9(7:9) = -k_b*g*(uh + c*wh)
  end subroutine paper_force

  !> Exact K9 = d f9 / d x9 (9x9, rows of q are zero); ok = .false. (K9 = 0) when degenerate.
  pure subroutine paper_jacobian(k_b, x9, K9, ok)
    real(rp), intent(in) :: k_b          ! [force/radian]
    real(rp), intent(in) :: x9(9)        ! [length]
    real(rp), intent(out) :: K9(9,9)     ! [force/length]
    logical, intent(out) :: ok
    real(rp) :: uh(3), wh(3), lu, lw, c, theta, g, dg
    real(rp) :: a(3), b(3), qu(3,3), qw(3,3)
    real(rp) :: fpu(3,3), fpw(3,3), fru(3,3), frw(3,3)
    integer :: i, j

    K9 = 0.0_rp
    call triple_geometry(x9, uh, wh, lu, lw, c, theta, g, dg, ok)
    if (.not. ok) return
    a = wh + c*uh                        ! Q_u w_hat, f_p = -k_b g a
    b = uh + c*wh                        ! Q_w u_hat, f_r = -k_b g b
    ! dc/du = -a^T/lu, dc/dw = -b^T/lw; d(u_hat)/du = Q_u/lu. Hence
    !   da/du = (c Q_u - u_hat a^T)/lu,  da/dw = (Q_w - u_hat b^T)/lw
    !   db/dw = (c Q_w - w_hat b^T)/lw,  db/du = (Q_u - w_hat a^T)/lu
    ! and d(g a) = g' a dc + g da.
    do j = 1, 3
      do i = 1, 3
        qu(i,j) = -uh(i)*uh(j)
        qw(i,j) = -wh(i)*wh(j)
      end do
      qu(j,j) = qu(j,j) + 1.0_rp
      qw(j,j) = qw(j,j) + 1.0_rp
    end do
    do j = 1, 3
      do i = 1, 3
        fpu(i,j) = -k_b*(-dg*a(i)*a(j) + g*(c*qu(i,j) - uh(i)*a(j)))/lu
        fpw(i,j) = -k_b*(-dg*a(i)*b(j) + g*(qw(i,j) - uh(i)*b(j)))/lw
        frw(i,j) = -k_b*(-dg*b(i)*b(j) + g*(c*qw(i,j) - wh(i)*b(j)))/lw
        fru(i,j) = -k_b*(-dg*b(i)*a(j) + g*(qu(i,j) - wh(i)*a(j)))/lu
      end do
    end do
    ! u = x_p - x_q, w = x_r - x_q: d/dx_p = d/du, d/dx_r = d/dw, d/dx_q = -(d/du + d/dw).
    K9(1:3, 1:3) = fpu
    K9(1:3, 4:6) = -(fpu + fpw)
    K9(1:3, 7:9) = fpw
    K9(7:9, 1:3) = fru
    K9(7:9, 4:6) = -(fru + frw)
    K9(7:9, 7:9) = frw
  end subroutine paper_jacobian

  !> Indicator 1/2 k_b theta^2 (the paper model has no energy); 0 for a degenerate triple.
  pure function paper_energy(k_b, x9) result(w)
    real(rp), intent(in) :: k_b, x9(9)
    real(rp) :: w
    real(rp) :: uh(3), wh(3), lu, lw, c, theta, g, dg
    logical :: ok

    call triple_geometry(x9, uh, wh, lu, lw, c, theta, g, dg, ok)
    w = 0.0_rp
    if (ok) w = 0.5_rp*k_b*theta**2
  end function paper_energy

  ! Unit edge vectors from q, their lengths, c = cos(theta), theta, and
  ! g = theta/sin(theta) with g' = dg/dc. ok = .false. (other outputs
  ! meaningless but finite) for a zero edge or a folded-back triple.
  pure subroutine triple_geometry(x9, uh, wh, lu, lw, c, theta, g, dg, ok)
    real(rp), intent(in) :: x9(9)
    real(rp), intent(out) :: uh(3), wh(3), lu, lw, c, theta, g, dg
    logical, intent(out) :: ok
    real(rp) :: u(3), w(3), cr(3), sn, t

    u = x9(1:3) - x9(4:6)
    w = x9(7:9) - x9(4:6)
    lu = norm2(u)
    lw = norm2(w)
    uh = 0.0_rp
    wh = 0.0_rp
    c = 1.0_rp
    theta = 0.0_rp
    g = 1.0_rp
    dg = 0.0_rp
    ok = min(lu, lw) > max(EDGE_REL*max(lu, lw), EDGE_ABS)
    if (.not. ok) return
    uh = u/lu
    wh = w/lw
    c = -dot_product(uh, wh)
    if (1.0_rp + c <= FOLD_TOL) then
      ok = .false.
      return
    end if
    cr(1) = uh(2)*wh(3) - uh(3)*wh(2)
    cr(2) = uh(3)*wh(1) - uh(1)*wh(3)
    cr(3) = uh(1)*wh(2) - uh(2)*wh(1)
    sn = norm2(cr)
    ! e1 = -u, e2 = w: e1.e2 = c |e1||e2|, |e1 x e2| = sn |e1||e2|.
    theta = atan2(sn, c)
    t = 2.0_rp*sin(0.5_rp*theta)**2    ! 1 - cos(theta) without cancellation
    if (t < T_SERIES) then
      call g_series(t, g, dg)
    else
      ! g = theta/s, dg/dc = (theta c - s)/s^3 (dtheta/dc = -1/s, ds/dc = -c/s);
      ! s >= sin(0.14) here and s > 0 away from the fold, so no division by 0.
      sn = sin(theta)
      g = theta/sn
      dg = (theta*c - sn)/sn**3
    end if
  end subroutine triple_geometry

  ! g(c) = acos(c)/sqrt(1-c^2) = sum_k a_k t^k with t = 1 - c,
  ! a_0 = 1, a_k = a_{k-1} k/(2k+1) (1, 1/3, 2/15, 2/35, ...); dg/dc = -dg/dt.
  ! Nine terms: the first omitted one is < 1e-21 for t < 1e-2.
  pure subroutine g_series(t, g, dg)
    real(rp), intent(in) :: t
    real(rp), intent(out) :: g, dg
    real(rp), parameter :: a(0:8) = [1.0_rp, 1.0_rp/3.0_rp, 2.0_rp/15.0_rp, 2.0_rp/35.0_rp, &
      8.0_rp/315.0_rp, 8.0_rp/693.0_rp, 16.0_rp/3003.0_rp, 16.0_rp/6435.0_rp, 128.0_rp/109395.0_rp]
    integer :: k

    g = a(8)
    dg = 8.0_rp*a(8)
    do k = 7, 1, -1
      g = g*t + a(k)
      dg = dg*t + real(k, rp)*a(k)
    end do
    g = g*t + a(0)
    dg = -dg
  end subroutine g_series

end module bending_paper
