! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of &contact's obstacles as the run builds them (module
!> contact_model): a tilted box's frame (orthonormal, right-handed, local
!> z the given normal) and its signed distance at hand-placed points; a
!> capsule's ends; a keyframed obstacle's pose and velocity at a time (a
!> pure function of t: contact_obstacle_at) against the hand-interpolated
!> offset, the same whatever was asked before; and the swept
!> check of a step (contact_swept): a thin finger that passes through a
!> node over one step is caught although both ends of the step are outside
!> it, one that stops short is not.
program test_contact_shapes
  use kinds, only: rp
  use config, only: contact_config
  use lattice, only: lattice_t
  use contact, only: obstacle_t, signed_distance, SHAPE_BOX, SHAPE_CAPSULE
  use contact_model, only: contact_model_t, contact_init, contact_swept, obstacle_from_config, contact_obstacle_at
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  type(contact_config) :: cc
  type(contact_model_t) :: cs
  type(obstacle_t) :: o
  type(lattice_t) :: lat
  real(rp) :: ax(3, 3), eye(3, 3), d, g(3), hd(3, 3), c(3), n(3), e1(3), s, o15(3)
  real(rp), allocatable :: x0(:, :, :), x(:, :, :), dx(:, :, :)
  logical, allocatable :: fixed(:, :)
  integer :: i

  ! ---- a box tilted 30 degrees about y: normal (sin, 0, cos), axis (1, 0, 0) before orthogonalising
  s = 0.5_rp
  n = [s, 0.0_rp, sqrt(1.0_rp - s * s)]
  e1 = [n(3), 0.0_rp, -n(1)]        ! the given x axis (1, 0, 0) less its part along n, normalised by hand
  c = [1.0_rp, 2.0_rp, 3.0_rp]
  cc%n_obstacles = 1
  cc%shape_code(1) = SHAPE_BOX
  cc%point(:, 1) = c
  cc%normal(:, 1) = n
  cc%axis(:, 1) = e1                ! as input_checks leaves it
  cc%half_size(:, 1) = [0.4_rp, 0.3_rp, 0.1_rp]
  associate (o => obstacle_from_config(cc, 1))
    ax = o%axes
    eye = 0.0_rp
    do i = 1, 3
      eye(i, i) = 1.0_rp
    end do
    call check_close_array(reshape(matmul(transpose(ax), ax), [9]), reshape(eye, [9]), 1.0e-15_rp, 0.0_rp, &
                           'box frame orthonormal')
    call check_close(det3(ax), 1.0_rp, 0.0_rp, 1.0e-15_rp, 'box frame right-handed')
    call check_close_array(ax(:, 3), n, 0.0_rp, 0.0_rp, 'box local z = obstacle_normal')
    call check_close_array(ax(:, 2), [0.0_rp, 1.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp, 'box local y = z x x')
    ! 2 cm above the top face's centre: distance 0.02, normal n
    call signed_distance(o, c + (0.1_rp + 0.02_rp) * n, d, g, hd)
    call check_close(d, 0.02_rp, 0.0_rp, 1.0e-14_rp, 'box: above the top face')
    call check_close_array(g, n, 0.0_rp, 1.0e-14_rp, 'box: the top face''s normal')
    ! 3 cm beyond the face of local +x, inside the other extents
    call signed_distance(o, c + (0.4_rp + 0.03_rp) * e1 + 0.05_rp * n, d, g, hd)
    call check_close(d, 0.03_rp, 0.0_rp, 1.0e-14_rp, 'box: beyond the +x face')
    ! beyond the edge of local +x and +z by 3 and 4 cm: 5 cm to the edge
    call signed_distance(o, c + 0.43_rp * e1 + 0.14_rp * n, d, g, hd)
    call check_close(d, 0.05_rp, 0.0_rp, 1.0e-14_rp, 'box: beyond the edge (3-4-5)')
  end associate

  ! ---- a capsule: both ends taken, the radius around the segment
  cc%shape_code(1) = SHAPE_CAPSULE
  cc%point(:, 1) = [0.0_rp, 0.0_rp, 0.0_rp]
  cc%end_pt(:, 1) = [0.0_rp, 1.0_rp, 0.0_rp]
  cc%radius(1) = 0.01_rp
  associate (o => obstacle_from_config(cc, 1))
    call signed_distance(o, [0.03_rp, 0.5_rp, 0.0_rp], d, g, hd)
    call check_close(d, 0.02_rp, 0.0_rp, 1.0e-15_rp, 'capsule: beside its body')
    call signed_distance(o, [0.0_rp, 1.05_rp, 0.0_rp], d, g, hd)
    call check_close(d, 0.04_rp, 0.0_rp, 1.0e-15_rp, 'capsule: beyond its second end')
  end associate

  ! ---- the capsule keyframed: offset (0,0,0) at t = 1, (0.2,0,0) at t = 2; closing 0 -> -0.05 along x
  cc%n_keyframes(1) = 2
  cc%key_time(1:2, 1) = [1.0_rp, 2.0_rp]
  cc%key_offset(:, 2, 1) = [0.2_rp, 0.0_rp, 0.0_rp]
  cc%key_close(1:2, 1) = [0.0_rp, -0.05_rp]
  cc%close_dir(:, 1) = [1.0_rp, 0.0_rp, 0.0_rp]
  cc%thickness = 0.0_rp
  lat%nx = 1
  lat%ny = 1
  lat%ys = 0
  lat%ye = 0
  lat%gys = 0
  lat%gye = 0
  call contact_init(cs, cc, lat)
  o = contact_obstacle_at(cs, 1, 1.5_rp)
  o15 = o%p
  ! halfway: 0.1 - 0.025 along x, velocity 0.2 - 0.05
  call check_close_array(o%p, [0.075_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp, 'moved: first end')
  call check_close_array(o%q, [0.075_rp, 1.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp, 'moved: second end')
  call check_close_array(o%vel, [0.15_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp, 'moved: velocity')
  o = contact_obstacle_at(cs, 1, 5.0_rp)
  call check_close_array(o%p, [0.15_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-15_rp, 'held after the last keyframe')
  call check_true(all(o%vel == 0.0_rp), 'held: at rest')
  ! a pure function of t: the pose at 1.5 is the same after the one at 5 was asked
  o = contact_obstacle_at(cs, 1, 1.5_rp)
  call check_close_array(o%p, o15, 0.0_rp, 0.0_rp, 'the pose at t whatever was asked before')

  ! ---- the swept check: the finger (radius 1 cm, travelling +0.15 in x over [1, 2]) and one node
  allocate(x0(0:5, 0:0, 0:0), x(0:5, 0:0, 0:0), dx(0:5, 0:0, 0:0), fixed(0:0, 0:0))
  fixed = .false.
  x0 = 0.0_rp
  dx = 0.0_rp
  ! a node at x = 0.1 stays put: the finger's axis goes from x = 0 to 0.15 through it,
  ! while the node is outside the finger at both ends of the step
  x0(0:2, 0, 0) = [0.1_rp, 0.5_rp, 0.0_rp]
  x = x0
  call check_true(contact_swept(cs, lat, fixed, 1.0_rp, 2.0_rp, x0, x, dx) == 1, 'swept: a finger through a node')
  ! over [1, 1.5] the finger's axis ends at x = 0.075: 1.5 cm short of the node's gap
  call check_true(contact_swept(cs, lat, fixed, 1.0_rp, 1.5_rp, x0, x, dx) == 0, 'swept: a finger that stops short')
  ! the node carried along ahead of the finger: no crossing
  dx(0:2, 0, 0) = [0.15_rp, 0.0_rp, 0.0_rp]
  call check_true(contact_swept(cs, lat, fixed, 1.0_rp, 2.0_rp, x0, x, dx) == 0, 'swept: a node pushed ahead')
  ! a fixed node is not the obstacle's concern
  dx = 0.0_rp
  fixed = .true.
  call check_true(contact_swept(cs, lat, fixed, 1.0_rp, 2.0_rp, x0, x, dx) == 0, 'swept: fixed nodes skipped')

  call check_report()

contains

  pure real(rp) function det3(a)
    real(rp), intent(in) :: a(3, 3)
    det3 = a(1, 1) * (a(2, 2) * a(3, 3) - a(3, 2) * a(2, 3)) - a(1, 2) * (a(2, 1) * a(3, 3) - a(3, 1) * a(2, 3)) &
         + a(1, 3) * (a(2, 1) * a(3, 2) - a(3, 1) * a(2, 2))
  end function det3

end program test_contact_shapes
