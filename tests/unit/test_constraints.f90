! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module constraints against a keyframe path whose values and
!> slopes are computed by hand:
!> - a set holds what was added (nodes, paths, base positions, keyframes);
!> - a pinned node stays at its base position with zero velocity;
!> - a node on the path: before the first keyframe at its offset, at rest;
!>   at each keyframe exactly its offset (from both segments that meet
!>   there, to round-off from the one that ends there); linear between, the
!>   velocity the segment's slope; after the last keyframe held, at rest;
!> - the window: its segment from its midpoint, active until release_time;
!> - the event times: the keyframes and the release time within (0, t_end);
!> - constraint_step_sensitivity equals the difference quotient of
!>   constraint_target when one step of the path changes (the path is
!>   linear in its steps, so the quotient is exact to round-off).
program test_constraints
  use kinds, only: rp
  use constraints, only: constraint_set_t, constraints_init, constraints_add, constraints_set_window, &
                         constraint_target, constraint_events, constraint_step_sensitivity, &
                         constraint_count, constraint_node, constraint_path, constraint_base, constraint_keyframes, &
                         constraint_release_time, constraint_segment, constraints_active, PATH_FIXED, PATH_KEYFRAMES
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none

  ! keyframes at 0.2, 0.5, 1.0, 1.6; slopes (0, 10, 0), (2, 0, -10), (0, -10, 10)
  real(rp), parameter :: kt(4) = [0.2_rp, 0.5_rp, 1.0_rp, 1.6_rp]
  real(rp), parameter :: koff(3, 4) = reshape([1.0_rp, 0.0_rp, -2.0_rp, 1.0_rp, 3.0_rp, -2.0_rp, &
                                               2.0_rp, 3.0_rp, -7.0_rp, 2.0_rp, -3.0_rp, -1.0_rp], [3, 4])
  real(rp), parameter :: slope(3, 3) = reshape([0.0_rp, 10.0_rp, 0.0_rp, 2.0_rp, 0.0_rp, -10.0_rp, &
                                                0.0_rp, -10.0_rp, 10.0_rp], [3, 3])
  real(rp), parameter :: xa(3) = [0.5_rp, 0.25_rp, 0.0_rp], xk(3) = [-1.5_rp, 4.0_rp, 0.125_rp]
  real(rp), parameter :: release = 2.5_rp

  call contents()
  call path()
  call windows()
  call events()
  call no_path()
  call sensitivity()
  call check_report()

contains

  !> A pinned node (1) and a node on the path (2).
  subroutine make(cs)
    type(constraint_set_t), intent(out) :: cs
    call constraints_init(cs, 5, kt, koff, release, .true.)
    call constraints_add(cs, 3, 7, xa, PATH_FIXED)
    call constraints_add(cs, 0, 2, xk, PATH_KEYFRAMES)
  end subroutine make

  subroutine contents()
    type(constraint_set_t) :: cs
    integer :: n(2, 5), k, nk
    real(rp), allocatable :: kt1(:), koff1(:, :)
    call make(cs)
    call check_true(constraint_count(cs) == 2, 'two nodes added')
    do k = 1, 2
      call constraint_node(cs, k, n(1, k), n(2, k))
    end do
    call check_true(all(n(:, 1) == [3, 7]) .and. all(n(:, 2) == [0, 2]), 'their indices')
    call check_true(constraint_path(cs, 1) == PATH_FIXED .and. constraint_path(cs, 2) == PATH_KEYFRAMES, 'their paths')
    call check_true(all(constraint_base(cs, 1) == xa) .and. all(constraint_base(cs, 2) == xk), 'their base positions')
    call constraint_keyframes(cs, nk, kt1, koff1)
    call check_true(nk == 4 .and. all(kt1 == kt) .and. all(koff1 == koff), 'the keyframes')
    call check_true(constraint_release_time(cs) == release, 'the release time')
    do k = 3, 5
      call constraints_add(cs, k, 1, xa, PATH_FIXED)
      call constraint_node(cs, k, n(1, k), n(2, k))
    end do
    call check_true(constraint_count(cs) == 5 .and. all(n(1, 3:5) == [3, 4, 5]), 'room for nmax nodes')
  end subroutine contents

  !> Position and velocity of both nodes along the path, window by window
  !> (the windows between the event times 0, 0.2, 0.5, 1.0, 1.6, 2.5, 3).
  subroutine path()
    type(constraint_set_t) :: cs
    real(rp), parameter :: ev(7) = [0.0_rp, kt, release, 3.0_rp]
    real(rp) :: xb(3), vb(3), t, xe(3), ve(3)
    integer :: w, q, s
    character(60) :: what
    call make(cs)
    do w = 1, 6
      call constraints_set_window(cs, ev(w), ev(w + 1))
      s = w - 1                            ! the segment: 0 before, 4 after
      call check_true(constraint_segment(cs) == min(s, 4), 'segment of the window')
      do q = 0, 4
        t = ev(w) + 0.25_rp * q * (ev(w + 1) - ev(w))
        write(what, '(a,i0,a,f0.3)') 'window ', w, ' t = ', t
        call constraint_target(cs, 1, t, xb, vb)
        call check_true(all(xb == xa) .and. all(vb == 0.0_rp), trim(what)//': pinned node at its base, at rest')
        if (s == 0) then
          xe = koff(:, 1)
          ve = 0.0_rp
        else if (s >= 4) then
          xe = koff(:, 4)
          ve = 0.0_rp
        else
          ! by hand: the keyframe before, plus the slope times the time since
          xe = koff(:, s) + (t - kt(s)) * slope(:, s)
          ve = slope(:, s)
        end if
        call constraint_target(cs, 2, t, xb, vb)
        call check_close_array(xb, xk + xe, 1.0e-14_rp, 1.0e-14_rp, trim(what)//': position on the path')
        call check_close_array(vb, ve, 1.0e-14_rp, 1.0e-14_rp, trim(what)//': velocity the segment''s slope')
        ! at a keyframe: exactly its offset from the segment that starts there
        if (q == 0 .and. s >= 1 .and. s <= 4) then
          call check_true(all(xb == xk + koff(:, s)), trim(what)//': exactly the keyframe''s offset')
        end if
        if (q == 4 .and. s >= 1 .and. s <= 3) then
          call check_close_array(xb, xk + koff(:, s + 1), 1.0e-15_rp, 1.0e-15_rp, &
                                 trim(what)//': the next keyframe''s offset at the segment''s end')
        end if
      end do
    end do
    ! midpoints of the segments: the mean of the offsets at their ends
    do s = 1, 3
      call constraints_set_window(cs, kt(s), kt(s + 1))
      call constraint_target(cs, 2, 0.5_rp * (kt(s) + kt(s + 1)), xb, vb)
      call check_close_array(xb, xk + 0.5_rp * (koff(:, s) + koff(:, s + 1)), 1.0e-15_rp, 1.0e-14_rp, &
                             'linear between keyframes: the midpoint')
    end do
    ! long after the last keyframe: held
    call constraints_set_window(cs, 10.0_rp, 20.0_rp)
    call constraint_target(cs, 2, 17.0_rp, xb, vb)
    call check_true(all(xb == xk + koff(:, 4)) .and. all(vb == 0.0_rp), 'held after the last keyframe')
  end subroutine path

  !> Segment and release state from the window's midpoint.
  subroutine windows()
    type(constraint_set_t) :: cs
    call make(cs)
    call constraints_set_window(cs, 0.0_rp, 0.1_rp)
    call check_true(constraint_segment(cs) == 0 .and. constraints_active(cs), 'before the first keyframe: segment 0, active')
    call constraints_set_window(cs, 0.2_rp, 0.3_rp)
    call check_true(constraint_segment(cs) == 1, 'a window starting at a keyframe: its segment')
    call constraints_set_window(cs, 0.4_rp, 0.5_rp)
    call check_true(constraint_segment(cs) == 1, 'a window ending at a keyframe: the segment before it')
    ! a window's ends a round-off off the keyframes: its segment still from
    ! its midpoint
    call constraints_set_window(cs, nearest(0.5_rp, -1.0_rp), nearest(1.0_rp, -1.0_rp))
    call check_true(constraint_segment(cs) == 2, 'a window starting a round-off before a keyframe: the segment after it')
    call constraints_set_window(cs, 1.6_rp, release)
    call check_true(constraint_segment(cs) == 4 .and. constraints_active(cs), 'the window ending at release: still active')
    call constraints_set_window(cs, release, 3.0_rp)
    call check_true(.not. constraints_active(cs), 'the window starting at release: released')
    call constraints_set_window(cs, 0.0_rp, 0.2_rp)
    call check_true(constraints_active(cs) .and. constraint_segment(cs) == 0, 'a later window before release: active again')
  end subroutine windows

  !> Event times: keyframes and release within (0, t_end).
  subroutine events()
    type(constraint_set_t) :: cs
    real(rp), allocatable :: ev(:)
    real(rp) :: kt0(4)
    allocate(ev(0))
    call make(cs)
    ev = constraint_events(cs, 3.0_rp)
    call check_true(size(ev) == 5, 'events up to 3: four keyframes and the release')
    if (size(ev) == 5) call check_true(all(ev == [kt, release]), 'events: their times')
    ev = constraint_events(cs, 1.0_rp)
    call check_true(size(ev) == 2, 'events before 1: 0.2 and 0.5 (not t_end itself)')
    if (size(ev) == 2) call check_true(all(ev == kt(1:2)), 'events before 1: their times')
    kt0 = [0.0_rp, kt(2:4)]
    call constraints_init(cs, 1, kt0, koff, huge(1.0_rp), .true.)
    ev = constraint_events(cs, 5.0_rp)
    call check_true(size(ev) == 3, 'no event at t = 0, none for a release that never comes')
  end subroutine events

  !> A node on the path of a set without keyframes stays at its base.
  subroutine no_path()
    type(constraint_set_t) :: cs
    real(rp) :: kt0(0), koff0(3, 0), xb(3), vb(3)
    call constraints_init(cs, 1, kt0, koff0, huge(1.0_rp), .true.)
    call constraints_add(cs, 1, 1, xk, PATH_KEYFRAMES)
    call constraints_set_window(cs, 0.0_rp, 1.0_rp)
    call constraint_target(cs, 1, 0.5_rp, xb, vb)
    call check_true(all(xb == xk) .and. all(vb == 0.0_rp), 'no keyframes: at the base, at rest')
    call check_true(size(constraint_events(cs, 1.0_rp)) == 0, 'no keyframes, no release: no event')
  end subroutine no_path

  !> d(xb, vb)/d(step m of the path) against the difference quotient: the
  !> step d_m = koff(c, m) - koff(c, m-1) grows by h with the other steps
  !> held, so koff(c, m:nk) all move by h.
  subroutine sensitivity()
    type(constraint_set_t) :: cs, cp
    real(rp), parameter :: ev(7) = [0.0_rp, kt, release, 3.0_rp], h = 0.5_rp
    real(rp) :: t, xb(3), vb(3), xp(3), vp(3), sx, sv, kp(3, 4)
    integer :: w, q, m, c
    logical :: ok
    call make(cs)
    ok = .true.
    do m = 1, 5           ! m = 1 and m = nk + 1 are no steps: zero
      do c = 1, 3
        kp = koff
        if (m >= 2 .and. m <= 4) kp(c, m:4) = kp(c, m:4) + h
        call constraints_init(cp, 5, kt, kp, release, .true.)
        call constraints_add(cp, 0, 2, xk, PATH_KEYFRAMES)
        do w = 1, 6
          call constraints_set_window(cs, ev(w), ev(w + 1))
          call constraints_set_window(cp, ev(w), ev(w + 1))
          do q = 0, 4
            t = ev(w) + 0.25_rp * q * (ev(w + 1) - ev(w))
            call constraint_target(cs, 2, t, xb, vb)
            call constraint_target(cp, 1, t, xp, vp)
            call constraint_step_sensitivity(cs, t, m, sx, sv)
            ! round-off of offsets ~10 and slopes ~100 over h
            ok = ok .and. abs((xp(c) - xb(c)) / h - sx) <= 1.0e-13_rp &
                    .and. abs((vp(c) - vb(c)) / h - sv) <= 1.0e-12_rp
            ! the other components do not move
            ok = ok .and. all(pack(xp - xb, [1, 2, 3] /= c) == 0.0_rp)
          end do
        end do
      end do
    end do
    call check_true(ok, 'step sensitivity equals the difference quotient of the target')
  end subroutine sensitivity

end program test_constraints
