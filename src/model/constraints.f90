! SPDX-License-Identifier: BSD-2-Clause
!> Pinned and prescribed (keyframed) nodes of one rank (docs/model.md section 4).
!>
!> A constrained node k follows xbar(t) = x0_k + offset(t), where offset is 0
!> (pinned) or the scene's keyframe path, piecewise linear in time through
!> (kt(m), koff(:, m)) and held after the last keyframe. All constraints end
!> at release_time. The integrator is stopped at every keyframe and at the
!> release time; within one such time window the active segment is fixed
!> (set by constraints_set_window), so that the prescribed velocity is the
!> slope of that segment even when a stage is evaluated at the window's ends.
module constraints
  use kinds, only: rp
  implicit none
  private
  public :: constraint_set_t, constraints_init, constraints_add, constraints_set_window
  public :: constraint_target, constraint_events, constraint_step_sensitivity
  public :: constraint_count, constraints_active, constraint_node, constraint_path, constraint_base, constraints_global, &
            constraint_release_time, constraint_segment, constraint_keyframes

  integer, parameter, public :: PATH_FIXED = 0, PATH_KEYFRAMES = 1

  !> The set: built by constraints_init and constraints_add (module
  !> scenes), its window set by constraints_set_window; written by this
  !> module's procedures alone (private components), read through them.
  type :: constraint_set_t
    private
    integer :: n = 0                       !< constrained nodes owned by this rank
    integer, allocatable :: node(:, :)     !< (2, n) indices (i, j)
    integer, allocatable :: path(:)        !< (n) PATH_FIXED or PATH_KEYFRAMES
    real(rp), allocatable :: x0(:, :)      !< (3, n) base position [length]
    real(rp) :: release_time = huge(1.0_rp)  !< [time]
    integer :: nk = 0                      !< keyframes of the path
    real(rp), allocatable :: kt(:)         !< (nk) keyframe times [time], increasing
    real(rp), allocatable :: koff(:, :)    !< (3, nk) offsets at the keyframes [length]
    ! window state, set by constraints_set_window
    logical :: active = .true.             !< false once released
    integer :: seg = 0                     !< segment of the path: kt(seg) <= t < kt(seg+1); 0 before, nk after
    logical :: any_global = .false.        !< some rank has constraints (same on all ranks)
  end type constraint_set_t

contains

  !> Empty set with room for nmax nodes and the keyframe path (kt, koff).
  !> any_global: some rank has constraints (the same on every rank); if
  !> none has, nothing is released (release_time is taken as never).
  subroutine constraints_init(cs, nmax, kt, koff, release_time, any_global)
    type(constraint_set_t), intent(out) :: cs
    integer, intent(in) :: nmax
    real(rp), intent(in) :: kt(:), koff(:, :)
    real(rp), intent(in) :: release_time       !< [time]
    logical, intent(in) :: any_global
    allocate(cs%node(2, nmax), cs%path(nmax), cs%x0(3, nmax))
    cs%nk = size(kt)
    cs%kt = kt
    cs%koff = koff
    cs%any_global = any_global
    cs%release_time = merge(release_time, huge(1.0_rp), any_global)
  end subroutine constraints_init

  !> Constrain node (i, j) with base position x0 to a path.
  subroutine constraints_add(cs, i, j, x0, path)
    type(constraint_set_t), intent(inout) :: cs
    integer, intent(in) :: i, j, path
    real(rp), intent(in) :: x0(3)
    cs%n = cs%n + 1
    cs%node(:, cs%n) = [i, j]
    cs%x0(:, cs%n) = x0
    cs%path(cs%n) = path
  end subroutine constraints_add

  !> Fix the active segment and the release state for the window [ta, tb]
  !> between two consecutive event times.
  pure subroutine constraints_set_window(cs, ta, tb)
    type(constraint_set_t), intent(inout) :: cs
    real(rp), intent(in) :: ta, tb
    real(rp) :: tm
    integer :: m
    tm = 0.5_rp * (ta + tb)
    cs%active = tm < cs%release_time
    cs%seg = 0
    do m = 1, cs%nk
      if (cs%kt(m) <= tm) cs%seg = m
    end do
  end subroutine constraints_set_window

  !> Prescribed position xb(3) and velocity vb(3) of constrained node k at t.
  pure subroutine constraint_target(cs, k, t, xb, vb)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(in) :: k
    real(rp), intent(in) :: t
    real(rp), intent(out) :: xb(3), vb(3)
    integer :: m
    xb = cs%x0(:, k)
    vb = 0.0_rp
    if (cs%path(k) /= PATH_KEYFRAMES .or. cs%nk == 0) return
    m = cs%seg
    if (m == 0) then
      xb = xb + cs%koff(:, 1)
    else if (m >= cs%nk) then
      xb = xb + cs%koff(:, cs%nk)
    else
      vb = (cs%koff(:, m + 1) - cs%koff(:, m)) / (cs%kt(m + 1) - cs%kt(m))
      xb = xb + cs%koff(:, m) + (t - cs%kt(m)) * vb
    end if
  end subroutine constraint_target

  !> Derivatives of the prescribed position xb and velocity vb of a node on
  !> the keyframe path (constraint_target, same window) with respect to the
  !> step d_m = koff(c, m) - koff(c, m-1) of the path (2 <= m <= nk), with
  !> koff(:, 1) and the other steps held: dxb_c/dd_m = sx, dvb_c/dd_m = sv
  !> for each component c (components do not mix). With s = seg and
  !> koff(s) = koff(1) + d_2 + ... + d_s: before the first keyframe (s = 0)
  !> nothing depends on d_m; on segment s, xb = x0 + koff(s) + (t - kt(s)) vb
  !> with vb = d_(s+1) / (kt(s+1) - kt(s)); after the last (s = nk) xb = x0 +
  !> koff(nk). Module identify's deformation control (docs/identification.md).
  pure subroutine constraint_step_sensitivity(cs, t, m, sx, sv)
    type(constraint_set_t), intent(in) :: cs
    real(rp), intent(in) :: t
    integer, intent(in) :: m
    real(rp), intent(out) :: sx, sv
    integer :: s
    real(rp) :: h
    sx = 0.0_rp
    sv = 0.0_rp
    s = cs%seg
    if (s == 0 .or. m < 2 .or. m > cs%nk) return
    if (s >= cs%nk) then
      sx = 1.0_rp
      return
    end if
    h = cs%kt(s + 1) - cs%kt(s)
    if (m <= s) then
      sx = 1.0_rp
    else if (m == s + 1) then
      sx = (t - cs%kt(s)) / h
      sv = 1.0_rp / h
    end if
  end subroutine constraint_step_sensitivity

  !> Times in (0, t_end) at which the integrator must stop: keyframes and
  !> the release time.
  pure function constraint_events(cs, t_end) result(ev)
    type(constraint_set_t), intent(in) :: cs
    real(rp), intent(in) :: t_end
    real(rp), allocatable :: ev(:)
    integer :: m
    allocate(ev(0))
    do m = 1, cs%nk
      if (cs%kt(m) > 0.0_rp .and. cs%kt(m) < t_end) ev = [ev, cs%kt(m)]
    end do
    if (cs%release_time > 0.0_rp .and. cs%release_time < t_end) ev = [ev, cs%release_time]
  end function constraint_events

  !> Constrained nodes of this rank (in every window, released or not).
  pure integer function constraint_count(cs)
    type(constraint_set_t), intent(in) :: cs
    constraint_count = cs%n
  end function constraint_count

  !> The constraints hold in the current window (not yet released).
  pure logical function constraints_active(cs)
    type(constraint_set_t), intent(in) :: cs
    constraints_active = cs%active
  end function constraints_active

  !> Node (i, j) of constraint k.
  pure subroutine constraint_node(cs, k, i, j)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(in) :: k
    integer, intent(out) :: i, j
    i = cs%node(1, k)
    j = cs%node(2, k)
  end subroutine constraint_node

  !> Path of constraint k: PATH_FIXED or PATH_KEYFRAMES.
  pure integer function constraint_path(cs, k)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(in) :: k
    constraint_path = cs%path(k)
  end function constraint_path

  !> Base position of constraint k [length].
  pure function constraint_base(cs, k) result(x0)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(in) :: k
    real(rp) :: x0(3)
    x0 = cs%x0(:, k)
  end function constraint_base

  !> Some rank has constraints (the same on every rank).
  pure logical function constraints_global(cs)
    type(constraint_set_t), intent(in) :: cs
    constraints_global = cs%any_global
  end function constraints_global

  !> When the constraints end [time] (huge: never).
  pure real(rp) function constraint_release_time(cs)
    type(constraint_set_t), intent(in) :: cs
    constraint_release_time = cs%release_time
  end function constraint_release_time

  !> The current window's segment of the keyframe path (see constraints_set_window).
  pure integer function constraint_segment(cs)
    type(constraint_set_t), intent(in) :: cs
    constraint_segment = cs%seg
  end function constraint_segment

  !> The keyframe path: nk keyframes, their times kt(nk) [time] and offsets
  !> koff(3, nk) [length] (constraints_init's).
  pure subroutine constraint_keyframes(cs, nk, kt, koff)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: nk
    real(rp), allocatable, intent(out) :: kt(:), koff(:, :)
    nk = cs%nk
    kt = cs%kt
    koff = cs%koff
  end subroutine constraint_keyframes

end module constraints
