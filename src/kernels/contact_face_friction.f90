! SPDX-License-Identifier: BSD-2-Clause
!> Lagged, smoothed Coulomb friction on the pairs of module contact_faces
!> (a cloth triangle against an obstacle's points, a cloth edge against its
!> edges), as IPC lags it (Li et al. 2020, section 5): at the step's start
!> each active pair keeps the barycentric weights w of its nearest point on
!> the cloth primitive, the unit normal n of the pair (the direction of the
!> difference of the nearest points) and the normal force lam = -kappa k b'(gap)
!> (k: the edge-edge mollifier); during the step the sliding velocity of that
!> point relative to the rigid obstacle is u = (I - n n^T)(sum_a w_a v_a - vel),
!> its friction force f_c = -mu lam f1(|u|) u/|u| (f1 smoothed below
!> eps_v) acts on node a as w_a f_c, and df_a/dv_b = w_a w_b kv_c with the
!> node's kv_c (kernel smoothed_coulomb's law and spread). Friction is then implicit in v with a fixed magnitude
!> and has no x-derivative (as the node contact's). A translating obstacle
!> moves every point with its velocity o%vel, so the obstacle's side needs no
!> weights. Plain arrays only: no PETSc, no MPI, no allocation.
module contact_face_friction
  use kinds, only: rp
  use contact, only: obstacle_t, contact_params_t, barrier
  use smoothed_coulomb, only: coulomb_slip, coulomb_power, spread_by_weights, coulomb_turn
  use contact_primitives, only: point_triangle_closest, edge_edge_closest, edge_edge_mollifier
  use contact_faces, only: obstacle_points, obstacle_edges, obstacle_radius, EE_MOLLIFY_REL
  implicit none
  private
  public :: face_lag_t, triangle_lag, edge_lag, pair_friction, pair_friction_power, pair_turn

  !> One pair's lagged friction data (taken at the step's start).
  type :: face_lag_t
    real(rp) :: w(3) = 0.0_rp     !< weights of the nearest point on the cloth nodes (an edge: w(3) = 0) [1]
    real(rp) :: n(3) = [0.0_rp, 0.0_rp, 1.0_rp]   !< unit normal of the pair [1]
    real(rp) :: lam = 0.0_rp      !< normal force magnitude [force]
  end type face_lag_t

contains

  !> The lag of each active pair (gap < dhat, gap > 0) of cloth triangle xt against the
  !> obstacle's points, in the order of contact_faces' obstacle_points: nlag of them.
  pure subroutine triangle_lag(o, cp, xt, lags, nlag)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xt(3, 3)              ! [length]
    type(face_lag_t), intent(out) :: lags(8)
    integer, intent(out) :: nlag
    real(rp) :: pts(3, 8), xi, c(4), dc(4, 2), r(3), dist, b, db, d2b
    integer :: np, k, ty, m

    nlag = 0
    call obstacle_points(o, pts, np)
    xi = obstacle_radius(o) + cp%thickness
    do k = 1, np
      call point_triangle_closest(pts(:, k), xt(:, 1), xt(:, 2), xt(:, 3), ty, c, dc, m)
      r = c(1) * pts(:, k) + matmul(xt, c(2:4))
      dist = norm2(r)
      if (dist - xi >= cp%dhat .or. dist - xi <= 0.0_rp) cycle
      call barrier(dist - xi, cp%dhat, b, db, d2b)
      nlag = nlag + 1
      lags(nlag)%w = -c(2:4)
      lags(nlag)%n = r / dist
      lags(nlag)%lam = -cp%kappa * db
    end do
  end subroutine triangle_lag

  !> The lag of each active pair of cloth edge xe (rest length rest_len) against the
  !> obstacle's edges, lam with the pair's mollifier; nlag of them.
  pure subroutine edge_lag(o, cp, xe, rest_len, lags, nlag)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    real(rp), intent(in) :: xe(3, 2), rest_len   ! [length]
    type(face_lag_t), intent(out) :: lags(12)
    integer, intent(out) :: nlag
    real(rp) :: ea(3, 12), eb(3, 12), xi, c(4), dc(4, 2), r(3), dist, b, db, d2b, mk, gk(12), hk(12, 12), eps_x
    integer :: ne, k, ty, m

    nlag = 0
    call obstacle_edges(o, ea, eb, ne)
    xi = obstacle_radius(o) + cp%thickness
    do k = 1, ne
      call edge_edge_closest(xe(:, 1), xe(:, 2), ea(:, k), eb(:, k), ty, c, dc, m)
      r = matmul(xe, c(1:2)) + c(3) * ea(:, k) + c(4) * eb(:, k)
      dist = norm2(r)
      if (dist - xi >= cp%dhat .or. dist - xi <= 0.0_rp) cycle
      call barrier(dist - xi, cp%dhat, b, db, d2b)
      eps_x = EE_MOLLIFY_REL * rest_len**2 * sum((eb(:, k) - ea(:, k))**2)
      call edge_edge_mollifier(xe(:, 1), xe(:, 2), ea(:, k), eb(:, k), eps_x, mk, gk, hk)
      nlag = nlag + 1
      lags(nlag)%w = [c(1), c(2), 0.0_rp]
      lags(nlag)%n = r / dist
      lags(nlag)%lam = -cp%kappa * mk * db
    end do
  end subroutine edge_lag

  !> Friction of one lagged pair on the nn = size(v, 2) nodes (3: triangle, 2: edge):
  !> forces f(:, a) and blocks kv(:, :, a, b) = df_a/dv_b (-kv PSD). Nothing when
  !> o%mu, lam or eps_v is 0.
  pure subroutine pair_friction(o, cp, lag, v, f, kv)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(face_lag_t), intent(in) :: lag
    real(rp), intent(in) :: v(:, :)            ! (3, nn) node velocities [length/time]
    real(rp), intent(out) :: f(:, :)           ! (3, nn) [force]
    real(rp), intent(out) :: kv(:, :, :, :)    ! (3, 3, nn, nn) [force*time/length]
    real(rp) :: cmu, u(3), s, kc(3, 3)
    integer :: nn

    f = 0.0_rp
    kv = 0.0_rp
    cmu = o%mu * lag%lam
    if (cmu <= 0.0_rp .or. cp%eps_v <= 0.0_rp) return
    nn = size(v, 2)
    call coulomb_slip(cmu, cp%eps_v, lag%n, matmul(v, lag%w(1:nn)) - o%vel, u, s, kc)
    call spread_by_weights(lag%w(1:nn), -s * u, kc, f, kv)
  end subroutine pair_friction

  !> Power dissipated by one lagged pair's friction (>= 0): mu lam f1(|u|) |u| [energy/time].
  pure real(rp) function pair_friction_power(o, cp, lag, v) result(p)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(face_lag_t), intent(in) :: lag
    real(rp), intent(in) :: v(:, :)            ! (3, nn) node velocities [length/time]

    p = coulomb_power(o%mu * lag%lam, cp%eps_v, lag%n, matmul(v, lag%w(1:size(v, 2))) - o%vel)
  end function pair_friction_power

  !> The fraction in (0, 1] of a Newton update dv of the nodes' velocities v
  !> that one lagged pair allows: where the update turns its slip (the
  !> velocity of its point by the weights, relative to the obstacle)
  !> through the sticking band, the fraction where it is least (kernel
  !> smoothed_coulomb's coulomb_turn), else 1; 1 when o%mu, lam or eps_v
  !> is 0.
  pure real(rp) function pair_turn(o, cp, lag, v, dv) result(alpha)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(face_lag_t), intent(in) :: lag
    real(rp), intent(in) :: v(:, :)            ! (3, nn) node velocities [length/time]
    real(rp), intent(in) :: dv(:, :)           ! (3, nn) their Newton update [length/time]
    integer :: nn

    alpha = 1.0_rp
    if (o%mu * lag%lam <= 0.0_rp .or. cp%eps_v <= 0.0_rp) return
    nn = size(v, 2)
    alpha = coulomb_turn(cp%eps_v, lag%n, matmul(v, lag%w(1:nn)) - o%vel, matmul(dv, lag%w(1:nn)))
  end function pair_turn

end module contact_face_friction
