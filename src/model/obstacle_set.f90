! SPDX-License-Identifier: BSD-2-Clause
!> The rigid obstacles of &contact as a set (docs/design.md, "Contact"):
!> their shapes and base poses, their keyframes, and what follows from
!> them alone: each obstacle's pose and velocity at a time (a pure
!> function of t: nothing caches a "current" pose; kernel
!> obstacle_motion), its translation over a step, and the continuous
!> collision check of nodes' paths over a step against the obstacles'
!> motion (the swept check), and Newton's start of a step carried along
!> by the obstacles that move into the cloth. No barrier, no friction, no MPI: the
!> contact model (module contact_model) and any later user of the same
!> obstacles (cloth faces and edges against them) build on it. Its
!> components are private: only obstacle_set_init writes them.
module obstacle_set
  use kinds, only: rp
  use config, only: contact_config
  use lattice, only: lattice_t
  use contact, only: obstacle_t, time_of_impact_moving, signed_distance, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE
  use obstacle_motion, only: obstacle_at
  implicit none
  private
  public :: obstacle_set_t, obstacle_set_init, obstacle_from_config, obstacle_set_count, obstacle_set_moving
  public :: obstacle_set_poses, obstacle_set_pose, obstacle_set_moves, obstacle_set_pair, obstacle_set_keyframed
  public :: obstacle_set_key_times, obstacle_set_shape_name, obstacle_set_swept, obstacle_set_carry

  character(len=*), parameter :: SHAPE_NAMES(4) = [character(len=8) :: 'plane', 'sphere', 'box', 'capsule']

  !> The obstacles and their keyframes (&contact's obstacle_time,
  !> obstacle_offset, obstacle_close).
  type :: obstacle_set_t
    private
    integer :: n = 0                                !< obstacles
    type(obstacle_t), allocatable :: base(:)        !< (n) poses with zero keyframe offset
    integer, allocatable :: nk(:)                   !< (n) keyframes of each obstacle; 0: static
    real(rp), allocatable :: tk(:, :)               !< (max nk, n) keyframe times [time]
    real(rp), allocatable :: off(:, :, :)           !< (3, max nk, n) translations at the keyframes [length]
    real(rp), allocatable :: close(:, :)            !< (max nk, n) closing offsets at the keyframes [length]
    real(rp), allocatable :: cdir(:, :)             !< (3, n) unit closing directions [1]
    logical :: moving = .false.                     !< some obstacle has keyframes
  end type obstacle_set_t

contains

  !> The obstacles of &contact (cc, checked by input_checks).
  subroutine obstacle_set_init(set, cc)
    type(obstacle_set_t), intent(out) :: set
    type(contact_config), intent(in) :: cc
    integer :: k, m
    set%n = cc%n_obstacles
    allocate(set%base(set%n))
    do k = 1, set%n
      set%base(k) = obstacle_from_config(cc, k)
    end do
    set%nk = cc%n_keyframes(1:set%n)
    set%moving = any(set%nk > 0)
    m = max(1, maxval(set%nk))
    set%tk = cc%key_time(1:m, 1:set%n)
    set%off = cc%key_offset(:, 1:m, 1:set%n)
    set%close = cc%key_close(1:m, 1:set%n)
    set%cdir = cc%close_dir(:, 1:set%n)
  end subroutine obstacle_set_init

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

  !> The obstacles in the set.
  pure integer function obstacle_set_count(set) result(n)
    type(obstacle_set_t), intent(in) :: set
    n = set%n
  end function obstacle_set_count

  !> Some obstacle has keyframes.
  pure logical function obstacle_set_moving(set) result(mv)
    type(obstacle_set_t), intent(in) :: set
    mv = set%moving
  end function obstacle_set_moving

  !> Obstacle k has keyframes (it may move).
  pure logical function obstacle_set_keyframed(set, k) result(kf)
    type(obstacle_set_t), intent(in) :: set
    integer, intent(in) :: k
    kf = set%nk(k) > 0
  end function obstacle_set_keyframed

  !> Every obstacle's pose at t (and its velocity, the slope of the
  !> keyframe segment that ends at t; with right, of the one that starts
  !> there): a static obstacle is its base pose.
  pure subroutine obstacle_set_poses(set, t, obs, right)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: t
    type(obstacle_t), intent(out) :: obs(:)
    logical, intent(in), optional :: right
    integer :: k
    do k = 1, set%n
      obs(k) = obstacle_set_pose(set, k, t, right)
    end do
  end subroutine obstacle_set_poses

  !> Obstacle k's pose at t (obstacle_set_poses).
  pure function obstacle_set_pose(set, k, t, right) result(o)
    type(obstacle_set_t), intent(in) :: set
    integer, intent(in) :: k
    real(rp), intent(in) :: t
    logical, intent(in), optional :: right
    type(obstacle_t) :: o
    integer :: m
    m = set%nk(k)
    if (m == 0) then
      o = set%base(k)
    else
      call obstacle_at(set%base(k), set%tk(1:m, k), set%off(:, 1:m, k), set%close(1:m, k), set%cdir(:, k), t, o, right)
    end if
  end function obstacle_set_pose

  !> Whether some obstacle moves between t0 and t1.
  pure logical function obstacle_set_moves(set, t0, t1) result(mv)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: t0, t1
    integer :: k
    real(rp) :: d(3)
    type(obstacle_t) :: o0, o1
    mv = .false.
    if (.not. set%moving) return
    do k = 1, set%n
      if (set%nk(k) < 2) cycle
      call obstacle_set_pair(set, k, t0, t1, o0, o1, d)
      if (any(d /= 0.0_rp)) mv = .true.
    end do
  end function obstacle_set_moves

  !> Obstacle k at t0 and t1 and its translation d over [t0, t1].
  pure subroutine obstacle_set_pair(set, k, t0, t1, o0, o1, d)
    type(obstacle_set_t), intent(in) :: set
    integer, intent(in) :: k
    real(rp), intent(in) :: t0, t1
    type(obstacle_t), intent(out) :: o0, o1
    real(rp), intent(out) :: d(3)
    o0 = obstacle_set_pose(set, k, t0)
    o1 = obstacle_set_pose(set, k, t1)
    d = o1%p - o0%p
  end subroutine obstacle_set_pair

  !> Obstacle k's keyframe times (none for a static one) [time].
  pure function obstacle_set_key_times(set, k) result(tk)
    type(obstacle_set_t), intent(in) :: set
    integer, intent(in) :: k
    real(rp), allocatable :: tk(:)
    tk = set%tk(1:set%nk(k), k)
  end function obstacle_set_key_times

  !> Obstacle k's shape as &contact names it ('plane', 'sphere', ...).
  pure function obstacle_set_shape_name(set, k) result(s)
    type(obstacle_set_t), intent(in) :: set
    integer, intent(in) :: k
    character(len=:), allocatable :: s
    s = trim(SHAPE_NAMES(set%base(k)%shape))
  end function obstacle_set_shape_name

  !> Free owned nodes whose path over the step, from x0 (the accepted
  !> state at t0) to x + dx (a Newton candidate at t1), passes through an
  !> obstacle that moves over the step (crosses: the motion relative to
  !> the obstacle against its core). A candidate outside every obstacle at
  !> t1 can still have crossed a thin or fast one on the way: this counts
  !> such nodes (this rank; the caller sums).
  integer function obstacle_set_swept(set, thickness, lat, fixed, t0, t1, x0, x, dx) result(n)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: thickness
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer :: i, j, k
    real(rp) :: d(3)
    type(obstacle_t) :: o0, o1
    n = 0
    if (.not. set%moving) return
    do k = 1, set%n
      if (set%nk(k) < 2) cycle
      call obstacle_set_pair(set, k, t0, t1, o0, o1, d)
      if (all(d == 0.0_rp)) cycle
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          if (fixed(i, j)) cycle
          if (crosses(o0, thickness, x0(0:2, i, j), x(0:2, i, j) + dx(0:2, i, j) - x0(0:2, i, j), d)) n = n + 1
        end do
      end do
    end do
  end function obstacle_set_swept


  !> Newton's start of a step from t0 to t1 carried by the moving
  !> obstacles (docs/design.md, "Contact", moving obstacles): the start
  !> x (0:5, 0:nx-1, ys:ye) of each free owned node that an obstacle k
  !> reaches over the step is put where the node sat relative to the
  !> obstacle at t0, x0 + d_k (d_k: k's translation over the step, its
  !> velocity d_k / (t1 - t0)), so that its gap to k at t1 is its gap at
  !> t0, which the step before accepted. Obstacle k reaches the node when
  !> the start's gap to k at t1 is below both reach and the node's gap at
  !> t0 (k approaches it: a node resting on a rising plane), or when k
  !> sweeps over the path from x0 to the start (a fast or thin obstacle
  !> that passes it within the step). Several obstacles that reach a node
  !> are tried nearest first, and the first whose carried start lies
  !> outside every obstacle at t1 and crosses none on its way from x0 is
  !> taken; without one the start is left as it was (the step then fails
  !> and is retried smaller, as before). n: the nodes carried (this rank).
  !> Gaps are signed distances less thickness. No communication.
  integer function obstacle_set_carry(set, thickness, reach, lat, fixed, t0, t1, x0, x) result(n)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: thickness, reach
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: x(0:, 0:, lat%ys:)
    integer :: i, j, k, m, try
    real(rp) :: d(3, set%n), g1(set%n), xc(3)
    type(obstacle_t) :: o0(set%n), o1(set%n)
    logical :: mv(set%n), reached(set%n)
    n = 0
    if (.not. set%moving .or. .not. t1 > t0) return
    do k = 1, set%n
      call obstacle_set_pair(set, k, t0, t1, o0(k), o1(k), d(:, k))
      mv(k) = any(d(:, k) /= 0.0_rp)
    end do
    if (.not. any(mv)) return
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, set%n
          reached(k) = .false.
          if (.not. mv(k)) cycle
          g1(k) = gap(o1(k), thickness, x(0:2, i, j))
          reached(k) = g1(k) < min(reach, gap(o0(k), thickness, x0(0:2, i, j))) .or. &
                       crosses(o0(k), thickness, x0(0:2, i, j), x(0:2, i, j) - x0(0:2, i, j), d(:, k))
        end do
        do try = 1, count(reached)
          k = minloc(g1, 1, mask=reached)
          reached(k) = .false.
          xc = x0(0:2, i, j) + d(:, k)
          if (.not. clear(xc)) cycle
          x(0:2, i, j) = xc
          x(3:5, i, j) = d(:, k) / (t1 - t0)
          n = n + 1
          exit
        end do
      end do
    end do

  contains

    !> xc, a node's carried start, is outside every obstacle at t1 and its
    !> path from x0 crosses none that moves.
    logical function clear(xc)
      real(rp), intent(in) :: xc(3)
      clear = .false.
      do m = 1, set%n
        if (.not. gap(o1(m), thickness, xc) > 0.0_rp) return
        if (.not. mv(m)) cycle
        if (crosses(o0(m), thickness, x0(0:2, i, j), xc - x0(0:2, i, j), d(:, m))) return
      end do
      clear = .true.
    end function clear
  end function obstacle_set_carry

  !> Whether a node that moves from xa by dx over a step, while obstacle o
  !> (its pose at the step's start, grown by thickness) translates by d,
  !> passes through the obstacle's core: its relative path, a straight
  !> segment (time_of_impact_moving: exact for a translation linear over
  !> the step), enters the shape shrunk by half its smallest half-extent
  !> (a sphere's or capsule's radius halved, a box's half-sizes less half
  !> the smallest). Not the whole shape: a node that slides along a
  !> curved surface over the step (carried by a rising sphere, at a gap of
  !> a micrometre) has a chord that cuts the surface's cap though the
  !> node never was inside; the cap of a chord over a quarter turn is 0.3
  !> of the radius deep, while a node that an obstacle passes over, or
  !> that passes over a finger, crosses the core. A half-space has none:
  !> a segment between two points outside it stays outside.
  pure logical function crosses(o, thickness, xa, dx, d)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness, xa(3), dx(3), d(3)
    type(obstacle_t) :: core
    real(rp) :: th
    core = o
    th = thickness
    select case (o%shape)
    case (SHAPE_SPHERE, SHAPE_CAPSULE)
      core%r = 0.5_rp * (o%r + thickness)
      th = 0.0_rp
    case (SHAPE_BOX)
      core%h = o%h - 0.5_rp * minval(o%h)
    case default
      crosses = .false.
      return
    end select
    crosses = time_of_impact_moving(core, th, xa, dx, d) < 1.0_rp
  end function crosses

  !> The gap of point x to obstacle o: its signed distance less thickness [length].
  real(rp) function gap(o, thickness, x)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness, x(3)
    real(rp) :: d, g(3), hd(3, 3)
    call signed_distance(o, x, d, g, hd)
    gap = d - thickness
  end function gap

end module obstacle_set
