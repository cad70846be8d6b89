! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the keyframed obstacle motion (module obstacle_motion):
!> hand-interpolated offsets and slopes inside segments, at keyframes from
!> either side, held before the first and after the last keyframe; the
!> closing offset along its direction; velocity against a central
!> difference of the position; a gripper finger's capsule moved whole; and
!> the time of impact of a node against a plane rising over one step
!> (contact's time_of_impact_moving with the translation over the step).
program test_obstacle_motion
  use kinds, only: rp
  use contact, only: obstacle_t, SHAPE_PLANE, SHAPE_CAPSULE, time_of_impact_moving
  use obstacle_motion, only: keyframe_value, obstacle_at, obstacle_translation
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  real(rp) :: tk(3), off(3, 3), cl(3), dir(3), x(3), xd(3), d0(3), d1(3), v0(3), h, alpha
  type(obstacle_t) :: base, o, op, om

  ! Keyframes t = 0, 1, 3: offsets (0,0,0), (1,0,2), (1,4,2); closing 0, 0.5, 0.5 along dir.
  tk = [0.0_rp, 1.0_rp, 3.0_rp]
  off = reshape([0.0_rp, 0.0_rp, 0.0_rp, 1.0_rp, 0.0_rp, 2.0_rp, 1.0_rp, 4.0_rp, 2.0_rp], [3, 3])
  cl = [0.0_rp, 0.5_rp, 0.5_rp]
  dir = [0.0_rp, 0.6_rp, -0.8_rp]

  call keyframe_value(tk, off, 0.5_rp, x, xd)
  call check_close_array(x, [0.5_rp, 0.0_rp, 1.0_rp], 1.0e-15_rp, 0.0_rp, 'first segment: value')
  call check_close_array(xd, [1.0_rp, 0.0_rp, 2.0_rp], 1.0e-15_rp, 0.0_rp, 'first segment: slope')
  call keyframe_value(tk, off, 2.0_rp, x, xd)
  call check_close_array(x, [1.0_rp, 2.0_rp, 2.0_rp], 1.0e-15_rp, 0.0_rp, 'second segment: value')
  call check_close_array(xd, [0.0_rp, 2.0_rp, 0.0_rp], 1.0e-15_rp, 0.0_rp, 'second segment: slope')
  ! at the keyframe t = 1: the value of the keyframe, the slope of either side
  call keyframe_value(tk, off, 1.0_rp, x, xd)
  call check_close_array(x, [1.0_rp, 0.0_rp, 2.0_rp], 0.0_rp, 0.0_rp, 'keyframe: value')
  call check_close_array(xd, [1.0_rp, 0.0_rp, 2.0_rp], 0.0_rp, 0.0_rp, 'keyframe: slope of the segment ending there')
  call keyframe_value(tk, off, 1.0_rp, x, xd, right=.true.)
  call check_close_array(x, [1.0_rp, 0.0_rp, 2.0_rp], 0.0_rp, 0.0_rp, 'keyframe (right): value')
  call check_close_array(xd, [0.0_rp, 2.0_rp, 0.0_rp], 0.0_rp, 0.0_rp, 'keyframe (right): slope of the segment after')
  ! held outside [tk(1), tk(nk)]; at the ends, the inner slope from the inside only
  call keyframe_value(tk, off, -1.0_rp, x, xd)
  call check_true(all(x == off(:, 1)) .and. all(xd == 0.0_rp), 'before the first keyframe: held')
  call keyframe_value(tk, off, 5.0_rp, x, xd)
  call check_true(all(x == off(:, 3)) .and. all(xd == 0.0_rp), 'after the last keyframe: held')
  call keyframe_value(tk, off, 0.0_rp, x, xd, right=.true.)
  call check_close_array(xd, [1.0_rp, 0.0_rp, 2.0_rp], 0.0_rp, 0.0_rp, 'first keyframe (right): first slope')
  call keyframe_value(tk, off, 3.0_rp, x, xd)
  call check_close_array(xd, [0.0_rp, 2.0_rp, 0.0_rp], 0.0_rp, 0.0_rp, 'last keyframe: last slope')
  call keyframe_value(tk(1:1), off(:, 1:1), 0.7_rp, x, xd)
  call check_true(all(x == off(:, 1)) .and. all(xd == 0.0_rp), 'one keyframe: constant')

  ! translation with closing: at t = 0.5, offset (0.5,0,1) + 0.25 dir; velocity (1,0,2) + 0.5 dir
  call obstacle_translation(tk, off, cl, dir, 0.5_rp, x, xd)
  call check_close_array(x, [0.5_rp, 0.0_rp, 1.0_rp] + 0.25_rp * dir, 1.0e-15_rp, 0.0_rp, 'translation with closing')
  call check_close_array(xd, [1.0_rp, 0.0_rp, 2.0_rp] + 0.5_rp * dir, 1.0e-15_rp, 0.0_rp, 'velocity with closing')

  ! a capsule finger moves whole; its velocity is the central difference of its position
  base = obstacle_t(shape=SHAPE_CAPSULE, p=[0.1_rp, 0.2_rp, 0.3_rp], q=[0.1_rp, 0.2_rp, 1.3_rp], r=0.05_rp, mu=0.7_rp)
  call obstacle_at(base, tk, off, cl, dir, 2.2_rp, o)
  h = 1.0e-3_rp
  call obstacle_at(base, tk, off, cl, dir, 2.2_rp + h, op)
  call obstacle_at(base, tk, off, cl, dir, 2.2_rp - h, om)
  call check_close_array(o%p, base%p + [1.0_rp, 2.4_rp, 2.0_rp] + 0.5_rp * dir, 1.0e-14_rp, 0.0_rp, 'capsule end p moved')
  call check_close_array(o%q - o%p, base%q - base%p, 1.0e-14_rp, 0.0_rp, 'capsule moved rigidly')
  call check_close_array(o%vel, (op%p - om%p) / (2.0_rp * h), 1.0e-10_rp, 0.0_rp, 'velocity = d position / dt')
  call check_true(o%r == base%r .and. o%mu == base%mu .and. o%shape == base%shape, 'other components kept')

  ! CCD over a step with a rising floor: plane z = 0 translated by (0,0,0.4 t) on [0, 1];
  ! a node at z = 0.6 falling by 0.6, thickness 0.1: the gap 0.5 closes at relative speed 1: t = 0.5.
  base = obstacle_t(shape=SHAPE_PLANE, n=[0.0_rp, 0.0_rp, 1.0_rp])
  call obstacle_translation([0.0_rp, 1.0_rp], reshape([0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.4_rp], [3, 2]), &
                            [0.0_rp, 0.0_rp], dir, 0.0_rp, d0, v0, right=.true.)
  call obstacle_translation([0.0_rp, 1.0_rp], reshape([0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.4_rp], [3, 2]), &
                            [0.0_rp, 0.0_rp], dir, 1.0_rp, d1, v0)
  o = base
  o%p = base%p + d0
  alpha = time_of_impact_moving(o, 0.1_rp, [0.0_rp, 0.0_rp, 0.6_rp], [0.3_rp, 0.0_rp, -0.6_rp], d1 - d0)
  call check_close(alpha, 0.5_rp, 1.0e-14_rp, 0.0_rp, 'rising floor: time of impact')
  call check_close_array(v0, [0.0_rp, 0.0_rp, 0.4_rp], 0.0_rp, 0.0_rp, 'rising floor: velocity')

  call check_report()
end program test_obstacle_motion
