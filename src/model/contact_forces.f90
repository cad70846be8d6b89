! SPDX-License-Identifier: BSD-2-Clause
!> Contact with rigid obstacles, static or moving on keyframes, on a rank's
!> strip (plain arrays: no PETSc, no MPI; the kernel of one node is module
!> contact, an obstacle's motion module obstacle_motion). Each free
!> owned node meets each obstacle through contact_node: an IPC barrier on
!> the gap plus smoothed Coulomb friction whose normal force lam and normal
!> nlag are lagged: taken at the last accepted state (the step's start,
!> t_n) and frozen during the step's Newton solve, so that friction is
!> implicit in the velocity with a fixed magnitude (IPC's lagged friction).
!> Constrained nodes take no contact force (their rows are replaced).
!> Nothing here runs when the scene has no obstacle (n_obs = 0): the
!> callers test contact_on first.
!>
!> Moving obstacles: cs%obs holds every obstacle's pose at one time,
!> set by contact_move (the residual's and the Jacobian's stage time, the
!> accepted state's time in the monitor) from its keyframes (kernel
!> obstacle_motion), with its velocity for friction; a static scene's
!> contact_move returns at once. contact_swept checks a whole step's path
!> against the obstacles' motion over the step.
module contact_forces
  use kinds, only: rp
  use config, only: contact_config
  use lattice, only: lattice_t
  use node_blocks, only: node_blocks_t, node_blocks_begin, node_blocks_add, node_blocks_end
  use contact, only: obstacle_t, contact_params_t, contact_node, time_of_impact, signed_distance, friction_power, &
                     time_of_impact_moving, SHAPE_BOX, SHAPE_CAPSULE
  use obstacle_motion, only: obstacle_at
  implicit none
  private
  public :: contact_state_t, contact_init, contact_on, contact_add_forces, contact_blocks, contact_lag, &
            contact_step_limit, contact_stats, contact_move, contact_swept, contact_moving, obstacle_from_config
  public :: contact_record, contact_seen, contact_restore, contact_count_limited
  public :: contact_summary_t, contact_summary, contact_keyframed, contact_obstacle

  !> The keyframes of the obstacles (&contact's obstacle_time,
  !> obstacle_offset, obstacle_close): contact_move sets the poses from them.
  type :: obstacle_keys_t
    type(obstacle_t), allocatable :: base(:)        !< (n_obs) poses with zero keyframe offset
    integer, allocatable :: nk(:)                   !< (n_obs) keyframes of each obstacle; 0: static
    real(rp), allocatable :: tk(:, :)               !< (max nk, n_obs) keyframe times [time]
    real(rp), allocatable :: off(:, :, :)           !< (3, max nk, n_obs) translations at the keyframes [length]
    real(rp), allocatable :: close(:, :)            !< (max nk, n_obs) closing offsets at the keyframes [length]
    real(rp), allocatable :: cdir(:, :)             !< (3, n_obs) unit closing directions [1]
  end type obstacle_keys_t

  !> The contact diagnostics of the last accepted state and of the run so
  !> far, over all ranks (a value record: contact_summary hands out a copy
  !> for the output, the checkpoints and the messages).
  type :: contact_summary_t
    real(rp) :: min_gap_run = huge(1.0_rp)          !< smallest gap over every accepted state [length]
    integer :: states_checked = 0                   !< accepted states checked (the start included)
    integer :: limited_steps = 0                    !< Newton updates scaled by the step limit
    ! the last accepted state's
    integer :: active = 0                           !< node-obstacle pairs with gap < dhat
    real(rp) :: force(3) = 0.0_rp                   !< total contact force, barrier and friction [force]
    real(rp) :: normal_force(3) = 0.0_rp            !< the barrier's part of it, sum of f_n g [force]
    real(rp) :: energy = 0.0_rp                     !< barrier energy [energy]
    real(rp) :: min_gap = huge(1.0_rp)              !< smallest gap [length]
    !> friction work since the start [energy]: the trapezoid rule over each
    !> accepted step on the friction power with the step's own lag at both
    !> ends (the lag taken at its start), dissipated (>= 0)
    real(rp) :: friction_work = 0.0_rp
    !> work of the contact forces of moving obstacles on the cloth since the
    !> start [energy]: sum over obstacles of (their contact force on the
    !> cloth) . (their velocity), by the same trapezoid rule (an external
    !> work of the energy balance; 0 with static obstacles)
    real(rp) :: obstacle_work = 0.0_rp
  end type contact_summary_t

  !> Contact's state on a rank's strip: written by this module's
  !> procedures alone (private components), read through contact_on,
  !> contact_keyframed, contact_obstacle, contact_seen and contact_summary.
  type :: contact_state_t
    private
    integer :: n_obs = 0
    type(obstacle_t), allocatable :: obs(:)         !< (n_obs) poses at time t_pose (contact_move)
    type(obstacle_keys_t) :: keys                   !< keyframes of the moving ones (contact_move)
    logical :: moving = .false.                     !< some obstacle has keyframes
    real(rp) :: t_pose = 0.0_rp                     !< time of the poses in obs [time]
    type(contact_params_t) :: cp
    real(rp), allocatable :: lam(:, :, :)           !< (n_obs, 0:nx-1, ys:ye) lagged normal force [force]
    real(rp), allocatable :: nlag(:, :, :, :)       !< (3, n_obs, 0:nx-1, ys:ye) lagged normal [1]
    ! The run's diagnostics, over all ranks: written by contact_record (the
    ! monitor of accepted states, module contact_solver, after its
    ! reductions), contact_restore and contact_count_limited only.
    type(contact_summary_t) :: rec
    logical :: have_last = .false.                  !< t_last, pfric_last hold the last accepted state's
    !> the next state recorded is a checkpoint's, recorded already by the
    !> run that wrote it (contact_restore): not counted again
    logical :: resumed = .false.
    real(rp) :: t_last = 0.0_rp                     !< time of the last accepted state [time]
    real(rp) :: pfric_last = 0.0_rp                 !< friction power there with the next step's lag [energy/time]
    real(rp) :: pobs_last = 0.0_rp                  !< obstacles' power there with the next step's lag [energy/time]
  end type contact_state_t

contains

  !> Obstacles and parameters from &contact; lags zero (no friction at the first step).
  subroutine contact_init(cs, cc, lat)
    type(contact_state_t), intent(out) :: cs
    type(contact_config), intent(in) :: cc
    type(lattice_t), intent(in) :: lat
    integer :: k, m
    cs%n_obs = cc%n_obstacles
    if (cs%n_obs == 0) return
    allocate(cs%obs(cs%n_obs), cs%keys%base(cs%n_obs))
    do k = 1, cs%n_obs
      cs%keys%base(k) = obstacle_from_config(cc, k)
    end do
    cs%obs = cs%keys%base
    cs%keys%nk = cc%n_keyframes(1:cs%n_obs)
    cs%moving = any(cs%keys%nk > 0)
    m = max(1, maxval(cs%keys%nk))
    cs%keys%tk = cc%key_time(1:m, 1:cs%n_obs)
    cs%keys%off = cc%key_offset(:, 1:m, 1:cs%n_obs)
    cs%keys%close = cc%key_close(1:m, 1:cs%n_obs)
    cs%keys%cdir = cc%close_dir(:, 1:cs%n_obs)
    call contact_move(cs, 0.0_rp)
    cs%cp = contact_params_t(thickness=cc%thickness, dhat=cc%dhat, kappa=cc%stiffness, eps_v=cc%eps_v)
    allocate(cs%lam(cs%n_obs, 0:lat%nx - 1, lat%ys:lat%ye), cs%nlag(3, cs%n_obs, 0:lat%nx - 1, lat%ys:lat%ye))
    cs%lam = 0.0_rp
    cs%nlag = 0.0_rp
  end subroutine contact_init

  !> Obstacle k of &contact (checked: unit normal and box axis) at zero
  !> keyframe offset. A box's local z is the normal, its local x the axis
  !> (orthogonal to the normal), its local y = z x x.
  pure function obstacle_from_config(cc, k) result(o)
    type(contact_config), intent(in) :: cc
    integer, intent(in) :: k
    type(obstacle_t) :: o
    real(rp) :: ex(3), ez(3)
    o%shape = cc%shape_code(k)
    o%p = cc%point(:, k)
    o%n = cc%normal(:, k)
    o%r = cc%radius(k)
    o%mu = cc%mu(k)
    if (o%shape == SHAPE_BOX) then
      ez = cc%normal(:, k)
      ex = cc%axis(:, k)
      o%h = cc%half_size(:, k)
      o%axes(:, 1) = ex
      o%axes(:, 2) = [ez(2) * ex(3) - ez(3) * ex(2), ez(3) * ex(1) - ez(1) * ex(3), ez(1) * ex(2) - ez(2) * ex(1)]
      o%axes(:, 3) = ez
    else if (o%shape == SHAPE_CAPSULE) then
      o%q = cc%end_pt(:, k)
    end if
  end function obstacle_from_config

  !> The obstacles' poses (and velocities, the slope of the keyframe
  !> segment that ends at t) at time t into cs%obs. Static obstacles keep
  !> theirs; a scene without keyframes returns at once.
  subroutine contact_move(cs, t)
    type(contact_state_t), intent(inout) :: cs
    real(rp), intent(in) :: t    ! [time]
    integer :: k, m
    if (.not. cs%moving) return
    cs%t_pose = t
    do k = 1, cs%n_obs
      m = cs%keys%nk(k)
      if (m == 0) cycle
      call obstacle_at(cs%keys%base(k), cs%keys%tk(1:m, k), cs%keys%off(:, 1:m, k), cs%keys%close(1:m, k), cs%keys%cdir(:, k), t, cs%obs(k))
    end do
  end subroutine contact_move

  !> Whether some obstacle moves between t0 and t1.
  logical function contact_moving(cs, t0, t1) result(mv)
    type(contact_state_t), intent(in) :: cs
    real(rp), intent(in) :: t0, t1
    integer :: k
    real(rp) :: d(3)
    type(obstacle_t) :: o0, o1
    mv = .false.
    if (.not. cs%moving) return
    do k = 1, cs%n_obs
      if (cs%keys%nk(k) < 2) cycle
      call pose_pair(cs, k, t0, t1, o0, o1, d)
      if (any(d /= 0.0_rp)) mv = .true.
    end do
  end function contact_moving

  !> Obstacle k at t0 and t1 and its translation d over [t0, t1].
  subroutine pose_pair(cs, k, t0, t1, o0, o1, d)
    type(contact_state_t), intent(in) :: cs
    integer, intent(in) :: k
    real(rp), intent(in) :: t0, t1
    type(obstacle_t), intent(out) :: o0, o1
    real(rp), intent(out) :: d(3)
    integer :: m
    m = cs%keys%nk(k)
    call obstacle_at(cs%keys%base(k), cs%keys%tk(1:m, k), cs%keys%off(:, 1:m, k), cs%keys%close(1:m, k), cs%keys%cdir(:, k), t0, o0)
    call obstacle_at(cs%keys%base(k), cs%keys%tk(1:m, k), cs%keys%off(:, 1:m, k), cs%keys%close(1:m, k), cs%keys%cdir(:, k), t1, o1)
    d = o1%p - o0%p
  end subroutine pose_pair

  !> Free owned nodes whose path over the step, from x0 (the accepted
  !> state at t0) to x + dx (a Newton candidate at t1), meets an obstacle
  !> that moves over the step (continuous collision detection of the
  !> motion relative to the obstacle, time_of_impact_moving: exact for a
  !> translation linear over the step). A candidate outside every obstacle
  !> at t1 can still have crossed a thin or fast one on the way: this
  !> counts such nodes (this rank; the caller sums).
  integer function contact_swept(cs, lat, fixed, t0, t1, x0, x, dx) result(n)
    type(contact_state_t), intent(in) :: cs
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer :: i, j, k
    real(rp) :: d(3)
    type(obstacle_t) :: o0, o1
    n = 0
    if (.not. cs%moving) return
    do k = 1, cs%n_obs
      if (cs%keys%nk(k) < 2) cycle
      call pose_pair(cs, k, t0, t1, o0, o1, d)
      if (all(d == 0.0_rp)) cycle
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          if (fixed(i, j)) cycle
          if (time_of_impact_moving(o0, cs%cp%thickness, x0(0:2, i, j), &
                                    x(0:2, i, j) + dx(0:2, i, j) - x0(0:2, i, j), d) < 1.0_rp) n = n + 1
        end do
      end do
    end do
  end function contact_swept

  pure logical function contact_on(cs)
    type(contact_state_t), intent(in) :: cs
    contact_on = cs%n_obs > 0
  end function contact_on

  !> f += contact forces on the free owned nodes; nbad counts nodes with a
  !> gap <= 0 (the state is infeasible: the caller makes the residual NaN).
  subroutine contact_add_forces(cs, lat, fixed, u, f, nbad)
    type(contact_state_t), intent(in) :: cs
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: nbad
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3)
    logical :: act
    nbad = 0
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, cs%n_obs
          call signed_distance(cs%obs(k), u(0:2, i, j), d, g, hd)
          if (.not. (d - cs%cp%thickness > 0.0_rp)) then
            nbad = nbad + 1
            cycle
          end if
          call contact_node(cs%obs(k), cs%cp, u(0:2, i, j), u(3:5, i, j), cs%lam(k, i, j), cs%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          f(:, i, j) = f(:, i, j) + fc
        end do
      end do
    end do
  end subroutine contact_add_forces

  !> The diagonal blocks df/dx, df/dv of the nodes in contact (or with
  !> friction) at state u, by owned row, into nb (which both assemblies add).
  subroutine contact_blocks(cs, lat, fixed, u, nb)
    type(contact_state_t), intent(in) :: cs
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nb
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, bx(3, 3), bv(3, 3)
    logical :: act, any_blk
    call node_blocks_begin(nb, lat%ys, lat%ye)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        bx = 0.0_rp
        bv = 0.0_rp
        any_blk = .false.
        do k = 1, cs%n_obs
          ! project: the barrier's stiffness with the negative eigenvalues of
          ! its energy Hessian set to zero (curved shapes), so that S stays SPD.
          call contact_node(cs%obs(k), cs%cp, u(0:2, i, j), u(3:5, i, j), cs%lam(k, i, j), cs%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act, project=.true.)
          if (.not. (act .or. cs%lam(k, i, j) > 0.0_rp)) cycle
          any_blk = .true.
          bx = bx + kx
          bv = bv + kv
        end do
        if (any_blk) call node_blocks_add(nb, i, j, bx, bv)
      end do
    end do
    call node_blocks_end(nb)
  end subroutine contact_blocks

  !> Friction's lag from an accepted state u (the next step's start):
  !> lam = the barrier's normal force, nlag = the surface normal; pstart,
  !> this rank's friction power at u with the new lag [energy/time] (the
  !> start of the next step's friction work), and pobs, the power of the
  !> moving obstacles' contact forces on the cloth there [energy/time] (the
  !> start of the next step's obstacle work). Both take the obstacles'
  !> velocities over the next step (at a keyframe, the segment after it).
  subroutine contact_lag(cs, lat, fixed, u, pstart, pobs)
    type(contact_state_t), intent(inout) :: cs
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out), optional :: pstart, pobs
    integer :: i, j, k, m
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3), zero3(3)
    type(obstacle_t), allocatable :: onext(:)
    logical :: act
    zero3 = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, cs%n_obs
          cs%lam(k, i, j) = 0.0_rp
          cs%nlag(:, k, i, j) = 0.0_rp
          if (fixed(i, j) .or. cs%obs(k)%mu <= 0.0_rp) cycle
          call contact_node(cs%obs(k), cs%cp, u(0:2, i, j), u(3:5, i, j), 0.0_rp, zero3, fc, kx, kv, e, fn, act)
          if (.not. act) cycle
          call signed_distance(cs%obs(k), u(0:2, i, j), d, g, hd)
          cs%lam(k, i, j) = fn
          cs%nlag(:, k, i, j) = g
        end do
      end do
    end do
    if (.not. (present(pstart) .or. present(pobs))) return
    ! the poses at t with the velocities of the step that starts there
    onext = cs%obs
    if (cs%moving) then
      do k = 1, cs%n_obs
        m = cs%keys%nk(k)
        if (m == 0) cycle
        call obstacle_at(cs%keys%base(k), cs%keys%tk(1:m, k), cs%keys%off(:, 1:m, k), cs%keys%close(1:m, k), &
                         cs%keys%cdir(:, k), cs%t_pose, onext(k), right=.true.)
      end do
    end if
    if (present(pstart)) then
      pstart = 0.0_rp
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          do k = 1, cs%n_obs
            if (cs%lam(k, i, j) > 0.0_rp) pstart = pstart + &
              friction_power(onext(k), cs%cp, u(3:5, i, j), cs%lam(k, i, j), cs%nlag(:, k, i, j))
          end do
        end do
      end do
    end if
    if (present(pobs)) then
      pobs = 0.0_rp
      if (.not. cs%moving) return
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          if (fixed(i, j)) cycle
          do k = 1, cs%n_obs
            if (all(onext(k)%vel == 0.0_rp)) cycle
            call signed_distance(onext(k), u(0:2, i, j), d, g, hd)
            if (.not. (d - cs%cp%thickness > 0.0_rp)) cycle
            call contact_node(onext(k), cs%cp, u(0:2, i, j), u(3:5, i, j), cs%lam(k, i, j), cs%nlag(:, k, i, j), &
                              fc, kx, kv, e, fn, act)
            pobs = pobs + dot_product(fc, onext(k)%vel)
          end do
        end do
      end do
    end if
  end subroutine contact_lag

  !> Largest alpha in [0, 1] for which no free owned node's gap reaches 0
  !> along x + t dx, t < alpha (this rank; the caller takes the minimum).
  real(rp) function contact_step_limit(cs, lat, fixed, x, dx) result(alpha)
    type(contact_state_t), intent(in) :: cs
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer :: i, j, k
    alpha = 1.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, cs%n_obs
          alpha = min(alpha, time_of_impact(cs%obs(k), cs%cp%thickness, x(0:2, i, j), dx(0:2, i, j)))
        end do
      end do
    end do
  end function contact_step_limit

  !> This rank's contact statistics at state u: the smallest gap (free
  !> nodes), the active contacts (gap < dhat), the total contact force
  !> (3) and its barrier part fnrm (3, sum of f_n g), the barrier energy,
  !> the friction power (with the lag of the step that ended at u) and the
  !> power of the obstacles' contact forces on the cloth, sum of f . v_obs
  !> (with that lag and the obstacles' velocities over that step).
  subroutine contact_stats(cs, lat, fixed, u, gmin, nact, ftot, fnrm, ebar, pfric, pobs)
    type(contact_state_t), intent(in) :: cs
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: gmin, ftot(3), fnrm(3), ebar, pfric, pobs
    integer, intent(out) :: nact
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3)
    logical :: act
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
        do k = 1, cs%n_obs
          call signed_distance(cs%obs(k), u(0:2, i, j), d, g, hd)
          gmin = min(gmin, d - cs%cp%thickness)
          if (.not. (d - cs%cp%thickness > 0.0_rp)) cycle
          call contact_node(cs%obs(k), cs%cp, u(0:2, i, j), u(3:5, i, j), cs%lam(k, i, j), cs%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          if (act) nact = nact + 1
          ftot = ftot + fc
          fnrm = fnrm + fn * g
          ebar = ebar + e
          pfric = pfric + friction_power(cs%obs(k), cs%cp, u(3:5, i, j), cs%lam(k, i, j), cs%nlag(:, k, i, j))
          pobs = pobs + dot_product(fc, cs%obs(k)%vel)
        end do
      end do
    end do
  end subroutine contact_stats

  !> True when state t was recorded last (TSSolve calls its monitors at
  !> every window's start too, with the state its last step accepted).
  pure logical function contact_seen(cs, t)
    type(contact_state_t), intent(in) :: cs
    real(rp), intent(in) :: t
    contact_seen = cs%have_last .and. t == cs%t_last
  end function contact_seen

  !> Record an accepted state at t, its statistics reduced over all ranks
  !> (contact_stats, contact_lag): the smallest gap gmin, the active pairs,
  !> the total and normal forces, the barrier energy; pend the friction
  !> power at t with the lag of the step that ended there, pstart with the
  !> next step's [energy/time]; oend and ostart the same of the moving
  !> obstacles' power on the cloth. The friction work and the obstacle work
  !> grow by the trapezoid rule over the step, both ends with the step's own lag.
  subroutine contact_record(cs, t, gmin, nact, ftot, fnrm, ebar, pend, pstart, oend, ostart)
    type(contact_state_t), intent(inout) :: cs
    real(rp), intent(in) :: t, gmin, ftot(3), fnrm(3), ebar, pend, pstart, oend, ostart
    integer, intent(in) :: nact
    associate (r => cs%rec)
      if (cs%have_last) then
        r%friction_work = r%friction_work + 0.5_rp * (t - cs%t_last) * (cs%pfric_last + pend)
        r%obstacle_work = r%obstacle_work + 0.5_rp * (t - cs%t_last) * (cs%pobs_last + oend)
      end if
      if (.not. cs%resumed) r%states_checked = r%states_checked + 1
      r%min_gap_run = min(r%min_gap_run, gmin)
      r%active = nact
      r%force = ftot
      r%normal_force = fnrm
      r%energy = ebar
      r%min_gap = gmin
    end associate
    cs%resumed = .false.
    cs%have_last = .true.
    cs%t_last = t
    cs%pfric_last = pstart
    cs%pobs_last = ostart
  end subroutine contact_record

  !> A restart's run diagnostics from its checkpoint: the friction work
  !> and the obstacle work [energy], the smallest gap so far [length], the
  !> states checked and the limited Newton updates. The checkpoint's own
  !> state, recorded again at the restart's first monitor call, is not counted twice.
  subroutine contact_restore(cs, friction_work, obstacle_work, min_gap_run, states_checked, limited_steps)
    type(contact_state_t), intent(inout) :: cs
    real(rp), intent(in) :: friction_work, obstacle_work, min_gap_run
    integer, intent(in) :: states_checked, limited_steps
    cs%rec%friction_work = friction_work
    cs%rec%obstacle_work = obstacle_work
    cs%rec%min_gap_run = min_gap_run
    cs%rec%states_checked = states_checked
    cs%rec%limited_steps = limited_steps
    cs%have_last = .false.
    cs%resumed = states_checked > 0
  end subroutine contact_restore

  !> One more Newton update scaled by the step limit (module contact_solver's pre-check).
  subroutine contact_count_limited(cs)
    type(contact_state_t), intent(inout) :: cs
    cs%rec%limited_steps = cs%rec%limited_steps + 1
  end subroutine contact_count_limited

  !> The contact diagnostics of the last accepted state and of the run
  !> (contact_record, contact_restore, contact_count_limited).
  pure function contact_summary(cs) result(r)
    type(contact_state_t), intent(in) :: cs
    type(contact_summary_t) :: r
    r = cs%rec
  end function contact_summary

  !> Some obstacle has keyframes (it may move: contact_move, contact_moving).
  pure logical function contact_keyframed(cs)
    type(contact_state_t), intent(in) :: cs
    contact_keyframed = cs%moving
  end function contact_keyframed

  !> Obstacle k at the time of the last contact_move.
  pure function contact_obstacle(cs, k) result(o)
    type(contact_state_t), intent(in) :: cs
    integer, intent(in) :: k
    type(obstacle_t) :: o
    o = cs%obs(k)
  end function contact_obstacle

end module contact_forces
