! SPDX-License-Identifier: BSD-2-Clause
!> The barrier and friction of every free node of a rank's strip against
!> every obstacle (kernel contact's contact_node over the strip; the
!> obstacles' poses from module obstacle_set at the time asked): the
!> forces, their 3 x 3 node blocks, the smallest gap, the Newton update's
!> time of impact, friction's lag and the statistics of a state. Plain
!> arrays, no MPI: module contact_model reduces.
!>
!> Friction's normal force lam and normal nlag are lagged: taken at the
!> last accepted state (the step's start, t_n; lag_take) and frozen
!> during the step's Newton solve, so that friction is implicit in the
!> velocity with a fixed magnitude (IPC's lagged friction). The lag is
!> contact_lag_t, whose components are private: only lag_init and
!> lag_take write it. Constrained nodes take no contact force (their rows
!> are replaced).
module contact_nodes
  use kinds, only: rp
  use lattice, only: lattice_t
  use node_blocks, only: node_blocks_t, node_blocks_add
  use contact, only: obstacle_t, contact_params_t, contact_node, time_of_impact, signed_distance, friction_power, &
                     SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE
  use obstacle_set, only: obstacle_set_t, obstacle_set_count, obstacle_set_poses, obstacle_set_moving
  use smoothed_coulomb, only: coulomb_turn
  implicit none
  private
  public :: contact_lag_t, lag_init, lag_free, lag_take
  public :: strip_forces, strip_blocks, strip_toi, strip_slip_limit, strip_smallest_gap, strip_stats, strip_unresolved

  !> Friction's lag on a rank's strip.
  type :: contact_lag_t
    private
    real(rp), allocatable :: lam(:, :, :)           !< (n_obs, 0:nx-1, ys:ye) lagged normal force [force]
    real(rp), allocatable :: nlag(:, :, :, :)       !< (3, n_obs, 0:nx-1, ys:ye) lagged normal [1]
  end type contact_lag_t

contains

  !> The lag of n_obs obstacles on the strip of lat: zero (no friction at
  !> the first step).
  subroutine lag_init(lag, n_obs, lat)
    type(contact_lag_t), intent(inout) :: lag
    integer, intent(in) :: n_obs
    type(lattice_t), intent(in) :: lat
    allocate(lag%lam(n_obs, 0:lat%nx - 1, lat%ys:lat%ye), lag%nlag(3, n_obs, 0:lat%nx - 1, lat%ys:lat%ye))
    lag%lam = 0.0_rp
    lag%nlag = 0.0_rp
  end subroutine lag_init

  subroutine lag_free(lag)
    type(contact_lag_t), intent(inout) :: lag
    if (allocated(lag%lam)) deallocate(lag%lam)
    if (allocated(lag%nlag)) deallocate(lag%nlag)
  end subroutine lag_free

  !> f += contact forces on the free owned nodes, the obstacles at t;
  !> nbad: the node-obstacle pairs with a gap <= 0 (then f is not used).
  subroutine strip_forces(set, cp, lag, lat, fixed, t, u, f, nbad)
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(contact_lag_t), intent(in) :: lag
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: nbad
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(obstacle_set_count(set))
    logical :: act
    call obstacle_set_poses(set, t, obs)
    nbad = 0
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, size(obs)
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          if (.not. (d - cp%thickness > 0.0_rp)) then
            nbad = nbad + 1
            cycle
          end if
          call contact_node(obs(k), cp, u(0:2, i, j), u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          f(:, i, j) = f(:, i, j) + fc
        end do
      end do
    end do
  end subroutine strip_forces

  !> The diagonal blocks df/dx, df/dv of the nodes in contact (or with
  !> friction) at state u, the obstacles at t, into nodal. The barrier's
  !> block is its exact Jacobian, whose tangential part on a curved
  !> surface is negative (-f_n / R: a node pressed onto a sphere of radius
  !> R is pushed off it as it slides), except against a sharp feature
  !> (sharp): there it is projected (the negative eigenvalues of the
  !> energy Hessian set to zero), docs/design.md, "Contact".
  subroutine strip_blocks(set, cp, lag, lat, fixed, t, u, nodal)
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(contact_lag_t), intent(in) :: lag
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nodal
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, bx(3, 3), bv(3, 3)
    type(obstacle_t) :: obs(obstacle_set_count(set))
    logical :: act, any_blk, proj(obstacle_set_count(set))
    call obstacle_set_poses(set, t, obs)
    do k = 1, size(obs)
      proj(k) = sharp(obs(k), cp)
    end do
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        bx = 0.0_rp
        bv = 0.0_rp
        any_blk = .false.
        do k = 1, size(obs)
          call contact_node(obs(k), cp, u(0:2, i, j), u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act, project=proj(k))
          if (.not. (act .or. lag%lam(k, i, j) > 0.0_rp)) cycle
          any_blk = .true.
          bx = bx + kx
          bv = bv + kv
        end do
        if (any_blk) call node_blocks_add(nodal, i, j, bx, bv)
      end do
    end do
  end subroutine strip_blocks

  !> mask(i, j) set for the free nodes whose barrier a step of dt does
  !> not resolve at u, the obstacles at t (module contact_model's
  !> unresolved hook): in the barrier's reach and closing the gap within
  !> dt (relative normal speed times dt above the gap), or with a normal
  !> stiffness k (the Frobenius norm of the projected barrier blocks,
  !> summed over the obstacles) with k dt^2 > m, the node's mass
  !> (omega dt > 1).
  subroutine strip_unresolved(set, cp, lag, lat, fixed, t, u, dt, mask)
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(contact_lag_t), intent(in) :: lag
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t, dt
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(inout) :: mask(0:, lat%ys:)     !< (0:nx-1, ys:ye) .true.: unresolved
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, stiff, d, g(3), hd(3, 3), gap, vn
    type(obstacle_t) :: obs(obstacle_set_count(set))
    logical :: act
    call obstacle_set_poses(set, t, obs)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        stiff = 0.0_rp                               ! [force/length]
        do k = 1, size(obs)
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          gap = d - cp%thickness
          if (.not. (gap < cp%dhat)) cycle
          vn = dot_product(u(3:5, i, j) - obs(k)%vel, g)
          if (-vn * dt > gap) mask(i, j) = .true.
          call contact_node(obs(k), cp, u(0:2, i, j), u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act, project=.true.)
          stiff = stiff + norm2(kx)
        end do
        if (stiff * dt**2 > lat%mass(i, j)) mask(i, j) = .true.
      end do
    end do
  end subroutine strip_unresolved

  !> Whether obstacle o has a feature sharper than the barrier's reach:
  !> a curvature radius (a sphere's or capsule's radius, a box's edges and
  !> corners, rounded by contact_thickness) plus the thickness below
  !> contact_dhat. There the barrier's tangential stiffness, about
  !> -kappa |b'(gap)| / (R + gap), rivals its normal stiffness: a node on
  !> a knife edge is an unstable equilibrium, and the exact block would
  !> make S indefinite. Elsewhere it is at most gap / R of the normal one,
  !> and the node's inertia, its links and friction outweigh it.
  pure logical function sharp(o, cp)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    select case (o%shape)
    case (SHAPE_SPHERE, SHAPE_CAPSULE)
      sharp = o%r + cp%thickness < cp%dhat
    case (SHAPE_BOX)
      sharp = cp%thickness < cp%dhat
    case default
      sharp = .false.
    end select
  end function sharp

  !> The first time of impact (in [0, 1]) of the free owned nodes moving
  !> from x by dx against the obstacles at t (static: their pose there),
  !> each grown by thickness; 1 when none is reached (this rank).
  real(rp) function strip_toi(set, thickness, lat, fixed, t, x, dx) result(a)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: thickness
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer :: i, j, k
    type(obstacle_t) :: obs(obstacle_set_count(set))
    call obstacle_set_poses(set, t, obs)
    a = 1.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, size(obs)
          a = min(a, time_of_impact(obs(k), thickness, x(0:2, i, j), dx(0:2, i, j)))
        end do
      end do
    end do
  end function strip_toi

  !> The largest fraction a <= 1 of the Newton update dx from x (6 dofs a
  !> node) that carries no node's sliding through friction's sticking band
  !> to sliding the other way: where a node with friction on obstacle k
  !> (lagged normal force > 0) slides relative to k at |u0| >= eps_v / 2
  !> (u its tangential relative velocity) and the update would end it
  !> sliding faster than eps_v against its way before (u0 . u1 < 0),
  !> passing through the band (|u| < eps_v), a is the fraction where |u|
  !> is smallest. Sliding, friction's size is constant and its exact block
  !> has no stiffness along u; towards the band's edge the mollifier's
  !> slope goes to zero too. So Newton from a node that must stop
  !> overshoots to the other side and back: a 2-cycle (box_on_table's
  !> corners landing on the table at 0.5 m/s, residual norms 2.82e3 and
  !> 2.81e3 alternately for 50 iterations; on the 11 x 11 lattice its box's
  !> corner nodes between u = 5.6 mm/s and -12 mm/s, eps_v = 1 cm/s). Near
  !> u = 0 friction's block has its full stiffness, 2 mu lam / eps_v, and
  !> Newton's model is good: a node deeper in the band than eps_v / 2 is
  !> left to it (limiting those too stalled the gripper's pinch at
  !> eps_v = 1 mm/s). Kernel smoothed_coulomb's coulomb_turn, which the
  !> faces' pairs share (module face_lags). The obstacles' velocities at t
  !> (the step's end); 1 when none (this rank).
  real(rp) function strip_slip_limit(set, cp, lag, lat, fixed, t, x, dx) result(a)
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(contact_lag_t), intent(in) :: lag
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer :: i, j, k
    type(obstacle_t) :: obs(obstacle_set_count(set))
    a = 1.0_rp
    if (cp%eps_v <= 0.0_rp) return
    call obstacle_set_poses(set, t, obs)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, size(obs)
          if (obs(k)%mu <= 0.0_rp .or. lag%lam(k, i, j) <= 0.0_rp) cycle
          a = min(a, coulomb_turn(cp%eps_v, lag%nlag(:, k, i, j), x(3:5, i, j) - obs(k)%vel, dx(3:5, i, j)))
        end do
      end do
    end do
  end function strip_slip_limit

  !> This rank's smallest gap over the free nodes of u and the obstacles at t.
  real(rp) function strip_smallest_gap(set, cp, lat, fixed, t, u) result(gmin)
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer :: i, j, k
    real(rp) :: d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(obstacle_set_count(set))
    call obstacle_set_poses(set, t, obs)
    gmin = huge(1.0_rp)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, size(obs)
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          gmin = min(gmin, d - cp%thickness)
        end do
      end do
    end do
  end function strip_smallest_gap

  !> Friction's lag from an accepted state u at t (the next step's start):
  !> lam = the barrier's normal force, nlag = the surface normal; pstart,
  !> this rank's friction power at u with the new lag [energy/time] (the
  !> start of the next step's friction work), and pobs, the power of the
  !> moving obstacles' contact forces on the cloth there [energy/time] (the
  !> start of the next step's obstacle work). Both take the obstacles'
  !> velocities over the next step (at a keyframe, the segment after it).
  subroutine lag_take(lag, set, cp, lat, fixed, t, u, pstart, pobs)
    type(contact_lag_t), intent(inout) :: lag
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: pstart, pobs
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3), zero3(3)
    type(obstacle_t) :: obs(obstacle_set_count(set)), onext(obstacle_set_count(set))
    logical :: act
    zero3 = 0.0_rp
    call obstacle_set_poses(set, t, obs)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, size(obs)
          lag%lam(k, i, j) = 0.0_rp
          lag%nlag(:, k, i, j) = 0.0_rp
          if (fixed(i, j) .or. obs(k)%mu <= 0.0_rp) cycle
          call contact_node(obs(k), cp, u(0:2, i, j), u(3:5, i, j), 0.0_rp, zero3, fc, kx, kv, e, fn, act)
          if (.not. act) cycle
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          lag%lam(k, i, j) = fn
          lag%nlag(:, k, i, j) = g
        end do
      end do
    end do
    ! the poses at t with the velocities of the step that starts there
    onext = obs
    if (obstacle_set_moving(set)) call obstacle_set_poses(set, t, onext, right=.true.)
    pstart = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, size(obs)
          if (lag%lam(k, i, j) > 0.0_rp) pstart = pstart + &
            friction_power(onext(k), cp, u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j))
        end do
      end do
    end do
    pobs = 0.0_rp
    if (.not. obstacle_set_moving(set)) return
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, size(obs)
          if (all(onext(k)%vel == 0.0_rp)) cycle
          call signed_distance(onext(k), u(0:2, i, j), d, g, hd)
          if (.not. (d - cp%thickness > 0.0_rp)) cycle
          call contact_node(onext(k), cp, u(0:2, i, j), u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          pobs = pobs + dot_product(fc, onext(k)%vel)
        end do
      end do
    end do
  end subroutine lag_take

  !> This rank's contact statistics at state u, the obstacles at t: the
  !> smallest gap (free nodes), the active contacts (gap < dhat), the total
  !> contact force (3) and its barrier part fnrm (3, sum of f_n g), the
  !> barrier energy, the friction power (with the lag of the step that
  !> ended at u) and the power of the obstacles' contact forces on the
  !> cloth, sum of f . v_obs (with that lag and the obstacles' velocities
  !> over that step).
  subroutine strip_stats(set, cp, lag, lat, fixed, t, u, gmin, nact, ftot, fnrm, ebar, pfric, pobs)
    type(obstacle_set_t), intent(in) :: set
    type(contact_params_t), intent(in) :: cp
    type(contact_lag_t), intent(in) :: lag
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: gmin, ftot(3), fnrm(3), ebar, pfric, pobs
    integer, intent(out) :: nact
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(obstacle_set_count(set))
    logical :: act
    call obstacle_set_poses(set, t, obs)
    gmin = huge(1.0_rp)
    nact = 0
    ftot = 0.0_rp
    fnrm = 0.0_rp
    ebar = 0.0_rp
    pfric = 0.0_rp
    pobs = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, size(obs)
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          gmin = min(gmin, d - cp%thickness)
          if (.not. (d - cp%thickness > 0.0_rp)) cycle
          call contact_node(obs(k), cp, u(0:2, i, j), u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          if (act) nact = nact + 1
          ftot = ftot + fc
          fnrm = fnrm + fn * g
          ebar = ebar + e
          pfric = pfric + friction_power(obs(k), cp, u(3:5, i, j), lag%lam(k, i, j), lag%nlag(:, k, i, j))
          pobs = pobs + dot_product(fc, obs(k)%vel)
        end do
      end do
    end do
  end subroutine strip_stats

end module contact_nodes
