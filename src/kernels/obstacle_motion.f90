! SPDX-License-Identifier: BSD-2-Clause
!> Keyframed rigid motion of an obstacle (docs/model.md section 10): a
!> translation that is piecewise linear in time through keyframes, plus, for
!> a gripper finger, a closing offset (a scalar, piecewise linear too) along
!> the finger's closing direction. As for prescribed nodes (model.md
!> section 4), the pose is held before the first and after the last keyframe
!> and the velocity is the slope of the current segment: at a keyframe time
!> the segment that ends there, or with right = .true. the one that starts
!> there. Plain arrays, no PETSc, no MPI, no allocation.
module obstacle_motion
  use kinds, only: rp
  use contact, only: obstacle_t
  implicit none
  private
  public :: keyframe_value, obstacle_at, obstacle_translation

contains

  !> Piecewise-linear interpolation of the columns of val at time t, and its slope.
  !> tk: keyframe times, strictly increasing; val(:, k): value at tk(k).
  pure subroutine keyframe_value(tk, val, t, x, xdot, right)
    real(rp), intent(in) :: tk(:)            ! keyframe times [time]
    real(rp), intent(in) :: val(:, :)        ! values, one column a keyframe
    real(rp), intent(in) :: t                ! [time]
    real(rp), intent(out) :: x(size(val, 1)) ! value at t
    real(rp), intent(out) :: xdot(size(val, 1)) ! slope at t [value/time]
    logical, intent(in), optional :: right   ! at a keyframe, the slope of the segment after it
    integer :: k
    real(rp) :: w
    logical :: moving

    call segment(tk, t, right, k, w, moving)
    xdot = 0.0_rp
    if (k == 0) then
      x = 0.0_rp
    else if (.not. moving) then
      x = val(:, k)
    else
      x = (1.0_rp - w) * val(:, k) + w * val(:, k + 1)
      xdot = (val(:, k + 1) - val(:, k)) / (tk(k + 1) - tk(k))
    end if
  end subroutine keyframe_value

  !> The segment of t: moving = .true.: tk(k) <= t <= tk(k+1) at weight w of keyframe k+1;
  !> moving = .false.: the pose of keyframe k is held (before the first, after the last,
  !> one keyframe only); k = 0 without keyframes.
  pure subroutine segment(tk, t, right, k, w, moving)
    real(rp), intent(in) :: tk(:), t
    logical, intent(in), optional :: right
    integer, intent(out) :: k
    real(rp), intent(out) :: w
    logical, intent(out) :: moving
    integer :: nk
    logical :: after

    nk = size(tk)
    after = .false.
    if (present(right)) after = right
    w = 0.0_rp
    moving = .false.
    k = min(nk, 1)
    if (nk <= 1) return
    if (t < tk(1) .or. (t == tk(1) .and. .not. after)) return
    k = nk
    if (t > tk(nk) .or. (t == tk(nk) .and. after)) return
    ! Segment k: tk(k) < t <= tk(k+1) (left), tk(k) <= t < tk(k+1) (right).
    do k = 1, nk - 1
      if (after) then
        if (t < tk(k + 1)) exit
      else
        if (t <= tk(k + 1)) exit
      end if
    end do
    k = min(k, nk - 1)
    w = (t - tk(k)) / (tk(k + 1) - tk(k))
    moving = .true.
  end subroutine segment

  !> Translation of the obstacle at t: offset(t) + closing(t) * close_dir, and its velocity.
  pure subroutine obstacle_translation(tk, off, close, close_dir, t, d, vel, right)
    real(rp), intent(in) :: tk(:)            ! keyframe times [time]
    real(rp), intent(in) :: off(:, :)        ! offset (3, nk) [length]
    real(rp), intent(in) :: close(:)         ! closing offset (nk) [length]
    real(rp), intent(in) :: close_dir(3)     ! unit closing direction [1]
    real(rp), intent(in) :: t
    real(rp), intent(out) :: d(3)            ! [length]
    real(rp), intent(out) :: vel(3)          ! [length/time]
    logical, intent(in), optional :: right
    integer :: k
    real(rp) :: w, c, cdot
    logical :: moving

    call keyframe_value(tk, off, t, d, vel, right)
    call segment(tk, t, right, k, w, moving)
    c = 0.0_rp
    cdot = 0.0_rp
    if (k > 0) c = close(k)
    if (moving) then
      c = (1.0_rp - w) * close(k) + w * close(k + 1)
      cdot = (close(k + 1) - close(k)) / (tk(k + 1) - tk(k))
    end if
    d = d + c * close_dir
    vel = vel + cdot * close_dir
  end subroutine obstacle_translation

  !> The obstacle base (its pose with zero offset) moved to time t, with o%vel set.
  pure subroutine obstacle_at(base, tk, off, close, close_dir, t, o, right)
    type(obstacle_t), intent(in) :: base
    real(rp), intent(in) :: tk(:), off(:, :), close(:), close_dir(3), t
    type(obstacle_t), intent(out) :: o
    logical, intent(in), optional :: right
    real(rp) :: d(3), vel(3)

    call obstacle_translation(tk, off, close, close_dir, t, d, vel, right)
    o = base
    o%p = base%p + d
    o%q = base%q + d
    o%vel = vel
  end subroutine obstacle_at

end module obstacle_motion
