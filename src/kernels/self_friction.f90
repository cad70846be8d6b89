! SPDX-License-Identifier: BSD-2-Clause
!> Lagged, smoothed Coulomb friction between two pieces of the cloth: a
!> point-triangle or edge-edge pair of the self-contact (modules
!> self_broad, self_barrier; docs/self-contact.md, "Friction between
!> layers"), lagged as IPC lags it (Li et al. 2020, section 5) and as
!> contact_face_friction lags a face against an obstacle, but with both
!> sides moving. At the lag's state (an accepted state) each active pair
!> keeps the coefficients w of r = sum_a w_a x_a, the difference of its
!> nearest points (point-triangle: w = (1, -b0, -b1, -b2) with b the
!> foot's barycentric weights; edge-edge: (s0, s1, -t0, -t1)), the unit
!> normal n = r/|r| and the normal force lam = -kappa k b'(gap) (k: the
!> edge-edge mollifier, 1 for point-triangle). During the step the slip of
!> the two nearest points is u = (I - n n^T) sum_a w_a v_a, the friction
!> force on the first side's point f_c = -mu lam f1(|u|) u/|u| (f1
!> smoothed below eps_v), on node a w_a f_c (the w sum to zero: the
!> pair's forces sum to zero), and df_a/dv_b = w_a w_b kc with kc = df_c/du
!> (-kc positive semidefinite, so is the pair's 12 x 12 block matrix,
!> w w^T times it): kernel smoothed_coulomb's law and spread, as the
!> obstacles' frictions. Friction is implicit in v with a fixed magnitude and
!> has no x-derivative. Plain arrays only: no PETSc, no MPI, no allocation.
module self_friction
  use kinds, only: rp
  use contact, only: contact_params_t, barrier
  use smoothed_coulomb, only: coulomb_slip, coulomb_power, spread_by_weights
  use contact_faces, only: EE_MOLLIFY_REL
  use contact_primitives, only: point_triangle_closest, edge_edge_closest, edge_edge_mollifier
  use self_broad, only: PAIR_PT
  implicit none
  private
  public :: self_lag_t, self_pair_lag, self_pair_friction, self_pair_friction_power

  !> One pair's lagged friction data, taken at the lag's state.
  type :: self_lag_t
    real(rp) :: w(4) = 0.0_rp                        !< r = sum_a w_a x_a, the nearest points' difference [1]
    real(rp) :: n(3) = [0.0_rp, 0.0_rp, 1.0_rp]      !< unit normal r/|r| [1]
    real(rp) :: lam = 0.0_rp                         !< normal force magnitude [force]
  end type self_lag_t

contains

  !> The lag of a pair (kind PAIR_PT or PAIR_EE) at positions xp (rest positions xr:
  !> the mollifier's scale); active when 0 < gap < dhat (gap = distance - cp%thickness),
  !> else lag is the default (lam = 0: no friction).
  pure subroutine self_pair_lag(kind, xp, xr, cp, lag, active)
    integer, intent(in) :: kind
    real(rp), intent(in) :: xp(3, 4), xr(3, 4)    ! [length]
    type(contact_params_t), intent(in) :: cp
    type(self_lag_t), intent(out) :: lag
    logical, intent(out) :: active
    real(rp) :: c(4), dc(4, 2), r(3), dist, gap, b, db, d2b, mk, gk(12), hk(12, 12), eps_x
    integer :: ty, m

    if (kind == PAIR_PT) then
      call point_triangle_closest(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), ty, c, dc, m)
    else
      call edge_edge_closest(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), ty, c, dc, m)
    end if
    r = matmul(xp, c)
    dist = norm2(r)
    gap = dist - cp%thickness
    active = gap > 0.0_rp .and. gap < cp%dhat
    if (.not. active) return
    call barrier(gap, cp%dhat, b, db, d2b)
    mk = 1.0_rp
    if (kind /= PAIR_PT) then
      eps_x = EE_MOLLIFY_REL * sum((xr(:, 2) - xr(:, 1))**2) * sum((xr(:, 4) - xr(:, 3))**2)
      call edge_edge_mollifier(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), eps_x, mk, gk, hk)
    end if
    lag%w = c
    lag%n = r / dist
    lag%lam = -cp%kappa * mk * db
  end subroutine self_pair_lag

  !> Friction of one lagged pair at node velocities v: forces f(:, a) on its 4 nodes and
  !> blocks kv(:, :, a, b) = df_a/dv_b (-kv PSD). Nothing when mu, lam or eps_v is 0.
  pure subroutine self_pair_friction(lag, mu, eps_v, v, f, kv)
    type(self_lag_t), intent(in) :: lag
    real(rp), intent(in) :: mu                     ! Coulomb coefficient [1]
    real(rp), intent(in) :: eps_v                  ! smoothing speed [length/time]
    real(rp), intent(in) :: v(3, 4)                ! node velocities [length/time]
    real(rp), intent(out) :: f(3, 4)               ! [force]
    real(rp), intent(out) :: kv(3, 3, 4, 4)        ! [force*time/length]
    real(rp) :: cmu, u(3), s, kc(3, 3)

    f = 0.0_rp
    kv = 0.0_rp
    cmu = mu * lag%lam
    if (cmu <= 0.0_rp .or. eps_v <= 0.0_rp) return
    call coulomb_slip(cmu, eps_v, lag%n, matmul(v, lag%w), u, s, kc)
    call spread_by_weights(lag%w, -s * u, kc, f, kv)
  end subroutine self_pair_friction

  !> Power dissipated by one lagged pair's friction (>= 0): mu lam f1(|u|) |u| [energy/time].
  pure real(rp) function self_pair_friction_power(lag, mu, eps_v, v) result(p)
    type(self_lag_t), intent(in) :: lag
    real(rp), intent(in) :: mu, eps_v, v(3, 4)

    p = coulomb_power(mu * lag%lam, eps_v, lag%n, matmul(v, lag%w))
  end function self_pair_friction_power

end module self_friction
