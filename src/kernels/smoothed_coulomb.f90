! SPDX-License-Identifier: BSD-2-Clause
!> Lagged, smoothed Coulomb friction at one contact point (IPC, Li et al.
!> 2020, section 5), the one law of the three frictions: a node against an
!> obstacle (module contact's contact_node), a face pair against an obstacle
!> (contact_face_friction) and a pair of the cloth against itself
!> (self_friction). Each caller forms the relative velocity dv of the two
!> sides at its point and keeps a lagged unit normal n and a lagged
!> Coulomb bound c = mu lam; the slip is u = (I - n n^T) dv, the force on
!> the first side -c f1(|u|) u/|u| (f1 smoothed below eps_v) and its
!> derivative in dv a 3 x 3 block whose negative is positive semidefinite.
!> A pair's callers then spread the point's force and block over the
!> pair's nodes by the lag's weights (spread_by_weights). Kept in one
!> place so that the three stay the same law, to the floating-point
!> operation. Plain arrays only: no PETSc, no MPI, no allocation.
module smoothed_coulomb
  use kinds, only: rp
  implicit none
  private
  public :: friction_f1, coulomb_slip, coulomb_power, spread_by_weights, coulomb_turn

  real(rp), parameter :: EYE(3, 3) = reshape([1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp], &
                                             [3, 3])

contains

  !> IPC's friction mollifier f1(y) = 2y/eps - y^2/eps^2 below eps_v, 1 above; also f1(y)/y
  !> (-> 2/eps_v at 0) and d(f1(y)/y)/dy / y times y, i.e. phi'(y) y.
  pure subroutine friction_f1(y, eps_v, f1, phi, dphi_y)
    real(rp), intent(in) :: y        ! sliding speed |u| >= 0 [length/time]
    real(rp), intent(in) :: eps_v    ! > 0 [length/time]
    real(rp), intent(out) :: f1      ! [1]
    real(rp), intent(out) :: phi     ! f1(y)/y [time/length]
    real(rp), intent(out) :: dphi_y  ! phi'(y) y [time/length]

    if (y < eps_v) then
      f1 = y * (2.0_rp / eps_v - y / eps_v**2)
      phi = 2.0_rp / eps_v - y / eps_v**2
      dphi_y = -y / eps_v**2
    else
      f1 = 1.0_rp
      phi = 1.0_rp / y
      dphi_y = -1.0_rp / y
    end if
  end subroutine friction_f1

  !> The slip u = P dv (P = I - n n^T) of relative velocity dv, the force's factor s
  !> (the friction force is -s u, of magnitude c f1(|u|) <= c) and its velocity block
  !> kc = d(-s u)/d(dv) = -c (phi P + phi'(|u|)/|u| u u^T) (exact; -kc is positive
  !> semidefinite). For c > 0 and eps_v > 0 (the callers' test: no friction otherwise).
  pure subroutine coulomb_slip(c, eps_v, n, dv, u, s, kc)
    real(rp), intent(in) :: c          ! mu lam, the Coulomb bound of the force [force]
    real(rp), intent(in) :: eps_v      ! smoothing speed [length/time]
    real(rp), intent(in) :: n(3)       ! lagged unit normal [1]
    real(rp), intent(in) :: dv(3)      ! velocity of the first side relative to the second [length/time]
    real(rp), intent(out) :: u(3)      ! slip, dv's tangential part [length/time]
    real(rp), intent(out) :: s         ! c f1(|u|)/|u| [force*time/length]
    real(rp), intent(out) :: kc(3, 3)  ! d(-s u)/d(dv) [force*time/length]
    real(rp) :: pm(3, 3), y, f1, phi, dphi_y, uh(3)
    integer :: i

    do i = 1, 3
      pm(:, i) = EYE(:, i) - n * n(i)
    end do
    u = matmul(pm, dv)
    y = norm2(u)
    call friction_f1(y, eps_v, f1, phi, dphi_y)
    s = c * phi
    uh = 0.0_rp
    if (y > 0.0_rp) uh = u / y
    ! phi'(y)/y u u^T = phi'(y) y uh uh^T: bounded as y -> 0
    do i = 1, 3
      kc(:, i) = -c * (phi * pm(:, i) + dphi_y * uh * uh(i))
    end do
  end subroutine coulomb_slip

  !> Power the friction of coulomb_slip dissipates (>= 0): c f1(|u|) |u| = s |u|^2
  !> [energy/time]; 0 when c or eps_v is not > 0.
  pure real(rp) function coulomb_power(c, eps_v, n, dv) result(p)
    real(rp), intent(in) :: c, eps_v, n(3), dv(3)   ! as coulomb_slip's
    real(rp) :: u(3), y, f1, phi, dphi_y

    p = 0.0_rp
    if (c <= 0.0_rp .or. eps_v <= 0.0_rp) return
    u = dv - dot_product(n, dv) * n
    y = norm2(u)
    call friction_f1(y, eps_v, f1, phi, dphi_y)
    p = c * f1 * y
  end function coulomb_power

  !> The fraction alpha in (0, 1] of a Newton update ddv of the relative
  !> velocity dv that a friction pair takes where the update turns its
  !> slip through the sticking band: where the slip u0 = P dv (P = I - n
  !> n^T) is at least eps_v / 2 and u1 = P (dv + ddv) at least eps_v
  !> against it (u0 . u1 < 0), and the line between them passes through
  !> the band (|u| < eps_v), the alpha where |u0 + alpha P ddv| is
  !> smallest; else 1. Sliding, the smoothed law's force has a constant
  !> magnitude and no stiffness along the slip (towards the band's edge
  !> the mollifier's slope goes to zero too), so Newton's model does not
  !> see the force turn and a full update carries the point through the
  !> band to the other side, and back at the next iteration (a 2-cycle:
  !> docs/contact.md, "Friction"); stopped where the slip is least, the
  !> point is in the band, where the law's block has its full stiffness
  !> 2 c / eps_v. A point deeper in the band than eps_v / 2 is left to
  !> Newton's model (limiting those too stalled the gripper's pinch at
  !> eps_v = 1 mm/s). The node contact's and the faces' guards (modules
  !> contact_nodes, face_lags).
  pure real(rp) function coulomb_turn(eps_v, n, dv, ddv) result(alpha)
    real(rp), intent(in) :: eps_v      ! smoothing speed [length/time]
    real(rp), intent(in) :: n(3)       ! lagged unit normal [1]
    real(rp), intent(in) :: dv(3)      ! relative velocity at the iterate [length/time]
    real(rp), intent(in) :: ddv(3)     ! its Newton update [length/time]
    real(rp) :: u0(3), du(3), s

    alpha = 1.0_rp
    u0 = dv - dot_product(dv, n) * n
    du = ddv - dot_product(ddv, n) * n
    if (norm2(u0) < 0.5_rp * eps_v .or. norm2(u0 + du) < eps_v) return
    if (dot_product(u0, u0 + du) >= 0.0_rp) return
    ! u0 . u1 < 0 gives u0 . du < -|u0|^2 < 0 and u1 . du > 0: s in (0, 1)
    s = -dot_product(u0, du) / max(dot_product(du, du), tiny(1.0_rp))
    if (s > 0.0_rp .and. s < 1.0_rp .and. norm2(u0 + s * du) < eps_v) alpha = s
  end function coulomb_turn

  !> A pair's point force fc and block kc on its nn nodes, the point being sum_a w_a x_a:
  !> f(:, a) = w_a fc, kv(:, :, a, b) = w_a w_b kc (-kv positive semidefinite when -kc is).
  pure subroutine spread_by_weights(w, fc, kc, f, kv)
    real(rp), intent(in) :: w(:)                 ! (nn) the point's weights on the nodes [1]
    real(rp), intent(in) :: fc(3)                ! [force]
    real(rp), intent(in) :: kc(3, 3)             ! [force*time/length]
    real(rp), intent(out) :: f(:, :)             ! (3, nn) [force]
    real(rp), intent(out) :: kv(:, :, :, :)    ! (3, 3, nn, nn) [force*time/length]
    integer :: a, b

    do b = 1, size(w)
      f(:, b) = w(b) * fc
      do a = 1, size(w)
        kv(:, :, a, b) = w(a) * w(b) * kc
      end do
    end do
  end subroutine spread_by_weights

end module smoothed_coulomb
