! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the contact kernel (module contact): signed distances
!> against closed forms (plane, sphere, box faces, edges, corners and
!> inside, capsule body and caps), gradients and Hessians against central
!> finite differences; the IPC barrier against a closed form, its
!> derivatives against finite differences and its C2 end at dhat; the time
!> of impact against hand-solved paths (falls onto each shape, a box edge
!> and corner, misses, tangent grazing) and against a dense sampling of
!> random paths; contact_node's force against its energy, kx and kv against
!> finite differences of the force, the PSD projection; friction in the
!> sticking and sliding regimes and its power.
program test_contact
  use kinds, only: rp
  use contact, only: obstacle_t, contact_params_t, SHAPE_PLANE, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE, &
                     signed_distance, barrier, time_of_impact, time_of_impact_moving, contact_node, &
                     friction_power, psd_project3
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  type(obstacle_t) :: o, ob(4)
  type(contact_params_t) :: cp
  real(rp) :: d, g(3), hd(3, 3), rot(3, 3), c(3)
  real(rp) :: e, de, d2e, s, dhat, hs, ep, em, dep, dem, dum
  real(rp) :: alpha, th
  integer :: i, k
  real(rp), parameter :: sfrac(6) = [1.0e-4_rp, 0.01_rp, 0.2_rp, 0.5_rp, 0.9_rp, 0.999_rp]

  ! A fixed rotation (about (1,2,2)/3 by 0.7 rad) for the oblique cases.
  rot = rotation([1.0_rp, 2.0_rp, 2.0_rp] / 3.0_rp, 0.7_rp)
  call check_close_array(reshape(matmul(transpose(rot), rot), [9]), reshape(eye3(), [9]), 0.0_rp, 1.0e-14_rp, &
                         'test rotation is orthogonal')

  ! ---- signed distance: closed forms ------------------------------------
  ! Plane through (1,0,0) with normal (1,2,2)/3 (given unnormalised as (1,2,2)):
  ! x = (2,1,3): d = (1 + 2 + 6)/3 = 3.
  o = obstacle_t(shape=SHAPE_PLANE, p=[1.0_rp, 0.0_rp, 0.0_rp], n=[1.0_rp, 2.0_rp, 2.0_rp])
  call signed_distance(o, [2.0_rp, 1.0_rp, 3.0_rp], d, g, hd)
  call check_close(d, 3.0_rp, 1.0e-14_rp, 0.0_rp, 'plane d')
  call check_close_array(g, [1.0_rp, 2.0_rp, 2.0_rp] / 3.0_rp, 1.0e-14_rp, 0.0_rp, 'plane g')
  call check_true(all(hd == 0.0_rp), 'plane hd = 0')
  call signed_distance(o, [0.0_rp, -1.0_rp, -1.0_rp], d, g, hd)
  call check_close(d, -5.0_rp / 3.0_rp, 1.0e-14_rp, 0.0_rp, 'plane d below')

  ! Sphere centre (1,2,3), radius 2: x = c + (3,0,4): d = 3, g = (0.6,0,0.8).
  o = obstacle_t(shape=SHAPE_SPHERE, p=[1.0_rp, 2.0_rp, 3.0_rp], r=2.0_rp)
  call signed_distance(o, [4.0_rp, 2.0_rp, 7.0_rp], d, g, hd)
  call check_close(d, 3.0_rp, 1.0e-14_rp, 0.0_rp, 'sphere d')
  call check_close_array(g, [0.6_rp, 0.0_rp, 0.8_rp], 1.0e-14_rp, 0.0_rp, 'sphere g')
  ! Hessian (I - g g^T)/5 at |x - c| = 5
  call check_close_array(reshape(hd, [9]), reshape((eye3() - outer([0.6_rp, 0.0_rp, 0.8_rp], &
                         [0.6_rp, 0.0_rp, 0.8_rp])) / 5.0_rp, [9]), 1.0e-14_rp, 0.0_rp, 'sphere hd')
  call signed_distance(o, [1.0_rp, 3.0_rp, 3.0_rp], d, g, hd)
  call check_close(d, -1.0_rp, 1.0e-14_rp, 0.0_rp, 'sphere d inside')
  call check_close_array(g, [0.0_rp, 1.0_rp, 0.0_rp], 1.0e-14_rp, 0.0_rp, 'sphere g inside')

  ! Box centre c, axes = the columns of rot, half extents (1,2,3); x = c + rot y.
  c = [1.0_rp, -1.0_rp, 0.5_rp]
  o = obstacle_t(shape=SHAPE_BOX, p=c, h=[1.0_rp, 2.0_rp, 3.0_rp], axes=rot)
  ! face: y = (3,0,0): d = 2, g = axis 1
  call box_case([3.0_rp, 0.0_rp, 0.0_rp], 2.0_rp, [1.0_rp, 0.0_rp, 0.0_rp], 'box face +x')
  call box_case([0.0_rp, -2.5_rp, 1.0_rp], 0.5_rp, [0.0_rp, -1.0_rp, 0.0_rp], 'box face -y')
  ! edge: y = (1+3, 2+4, 0): d = 5, g = (0.6, 0.8, 0)
  call box_case([4.0_rp, 6.0_rp, 0.0_rp], 5.0_rp, [0.6_rp, 0.8_rp, 0.0_rp], 'box edge')
  ! corner: y = (-(1+2), 2+3, -(3+6)): d = 7, g = (-2,3,-6)/7
  call box_case([-3.0_rp, 5.0_rp, -9.0_rp], 7.0_rp, [-2.0_rp, 3.0_rp, -6.0_rp] / 7.0_rp, 'box corner')
  ! inside: nearest face x (0.5 away), and nearest face -z
  call box_case([0.5_rp, 0.0_rp, 0.0_rp], -0.5_rp, [1.0_rp, 0.0_rp, 0.0_rp], 'box inside +x')
  call box_case([0.0_rp, 0.5_rp, -2.7_rp], -0.3_rp, [0.0_rp, 0.0_rp, -1.0_rp], 'box inside -z')
  ! the Hessian at the edge: (P - gl gl^T)/5 in the local frame, P = diag(1,1,0)
  call signed_distance(o, c + matmul(rot, [4.0_rp, 6.0_rp, 0.0_rp]), d, g, hd)
  call check_close_array(reshape(matmul(transpose(rot), matmul(hd, rot)), [9]), &
                         [0.64_rp, -0.48_rp, 0.0_rp, -0.48_rp, 0.36_rp, 0.0_rp, 0.0_rp, 0.0_rp, 0.0_rp] / 5.0_rp, &
                         1.0e-13_rp, 1.0e-15_rp, 'box edge hd')
  call signed_distance(o, c + matmul(rot, [3.0_rp, 0.0_rp, 0.0_rp]), d, g, hd)
  call check_close_array(reshape(hd, [9]), [(0.0_rp, i = 1, 9)], 0.0_rp, 1.0e-15_rp, 'box face hd = 0')

  ! Capsule (0,0,0)-(0,0,4), radius 1.
  o = obstacle_t(shape=SHAPE_CAPSULE, p=[0.0_rp, 0.0_rp, 0.0_rp], q=[0.0_rp, 0.0_rp, 4.0_rp], r=1.0_rp)
  call signed_distance(o, [3.0_rp, 4.0_rp, 2.0_rp], d, g, hd)
  call check_close(d, 4.0_rp, 1.0e-14_rp, 0.0_rp, 'capsule body d')
  call check_close_array(g, [0.6_rp, 0.8_rp, 0.0_rp], 1.0e-14_rp, 0.0_rp, 'capsule body g')
  call signed_distance(o, [0.0_rp, 3.0_rp, 8.0_rp], d, g, hd)
  call check_close(d, 4.0_rp, 1.0e-14_rp, 0.0_rp, 'capsule cap q d')
  call check_close_array(g, [0.0_rp, 0.6_rp, 0.8_rp], 1.0e-14_rp, 0.0_rp, 'capsule cap q g')
  call signed_distance(o, [0.0_rp, 0.0_rp, -3.0_rp], d, g, hd)
  call check_close(d, 2.0_rp, 1.0e-14_rp, 0.0_rp, 'capsule cap p d')
  call check_close_array(g, [0.0_rp, 0.0_rp, -1.0_rp], 1.0e-14_rp, 0.0_rp, 'capsule cap p g')
  call signed_distance(o, [0.5_rp, 0.0_rp, 1.0_rp], d, g, hd)
  call check_close(d, -0.5_rp, 1.0e-14_rp, 0.0_rp, 'capsule inside d')

  ! ---- gradients and Hessians against finite differences ------------------
  ob(1) = obstacle_t(shape=SHAPE_PLANE, p=[0.1_rp, 0.2_rp, -0.3_rp], n=rot(:, 3))
  ob(2) = obstacle_t(shape=SHAPE_SPHERE, p=[0.1_rp, 0.2_rp, -0.3_rp], r=0.7_rp)
  ob(3) = obstacle_t(shape=SHAPE_BOX, p=[0.1_rp, 0.2_rp, -0.3_rp], h=[0.5_rp, 0.8_rp, 0.3_rp], axes=rot)
  ob(4) = obstacle_t(shape=SHAPE_CAPSULE, p=[0.1_rp, 0.2_rp, -0.3_rp], q=[0.9_rp, -0.4_rp, 0.5_rp], r=0.3_rp)
  call fd_distance(ob(1), [0.7_rp, -0.2_rp, 0.9_rp], 'plane')
  call fd_distance(ob(2), [0.7_rp, -0.2_rp, 0.9_rp], 'sphere outside')
  call fd_distance(ob(2), [0.3_rp, 0.1_rp, -0.1_rp], 'sphere inside')
  call fd_distance(ob(3), ob(3)%p + matmul(rot, [0.9_rp, 0.1_rp, -0.1_rp]), 'box face')
  call fd_distance(ob(3), ob(3)%p + matmul(rot, [0.9_rp, 1.3_rp, -0.1_rp]), 'box edge')
  call fd_distance(ob(3), ob(3)%p + matmul(rot, [-0.9_rp, 1.3_rp, 0.6_rp]), 'box corner')
  call fd_distance(ob(3), ob(3)%p + matmul(rot, [0.1_rp, 0.2_rp, -0.15_rp]), 'box inside')
  call fd_distance(ob(4), [0.9_rp, 0.4_rp, 0.0_rp], 'capsule body')
  call fd_distance(ob(4), [1.3_rp, -0.6_rp, 0.9_rp], 'capsule cap q')
  call fd_distance(ob(4), [-0.3_rp, 0.2_rp, -0.6_rp], 'capsule cap p')

  ! ---- barrier ------------------------------------------------------------
  dhat = 0.01_rp
  ! s = dhat/e: log = -1, so b = (s - dhat)^2, b' = 2(s - dhat) - (s - dhat)^2/s
  s = dhat / exp(1.0_rp)
  call barrier(s, dhat, e, de, d2e)
  call check_close(e, (s - dhat)**2, 1.0e-14_rp, 0.0_rp, 'barrier closed form at dhat/e')
  call check_close(de, 2.0_rp * (s - dhat) - (s - dhat)**2 / s, 1.0e-13_rp, 0.0_rp, 'barrier derivative at dhat/e')
  do k = 1, 6
    s = dhat * sfrac(k)
    call barrier(s, dhat, e, de, d2e)
    hs = 1.0e-5_rp * min(s, dhat - s)
    call barrier(s + hs, dhat, ep, dep, dum)
    call barrier(s - hs, dhat, em, dem, dum)
    call check_close(de, (ep - em) / (2.0_rp * hs), 1.0e-6_rp, 1.0e-12_rp * dhat, 'barrier b'' against FD')
    call check_close(d2e, (dep - dem) / (2.0_rp * hs), 1.0e-6_rp, 1.0e-12_rp, 'barrier b'''' against FD')
    call check_true(e > 0.0_rp .and. de < 0.0_rp .and. d2e > 0.0_rp, 'barrier b > 0, b'' < 0, b'''' > 0 inside')
  end do
  call barrier(dhat, dhat, e, de, d2e)
  call check_true(e == 0.0_rp .and. de == 0.0_rp .and. d2e == 0.0_rp, 'barrier at dhat: all 0')
  call barrier(dhat * (1.0_rp - 1.0e-6_rp), dhat, e, de, d2e)
  call check_true(abs(e) < 1.0e-15_rp * dhat**2 .and. abs(de) < 1.0e-10_rp * dhat .and. abs(d2e) < 1.0e-5_rp, &
                  'barrier C2 from the left at dhat')
  call barrier(2.0_rp * dhat, dhat, e, de, d2e)
  call check_true(e == 0.0_rp .and. de == 0.0_rp .and. d2e == 0.0_rp, 'barrier beyond dhat: 0')
  call barrier(0.0_rp, dhat, e, de, d2e)
  call check_true(e == huge(1.0_rp) .and. de == 0.0_rp, 'barrier at 0: huge')
  call barrier(-1.0_rp, dhat, e, de, d2e)
  call check_true(e == huge(1.0_rp), 'barrier below 0: huge')

  ! ---- time of impact: hand-solved paths ---------------------------------
  ! Plane z = 0, thickness 0.1: from z = 1.1 by dz = -2, the gap 1 closes at t = 0.5.
  o = obstacle_t(shape=SHAPE_PLANE, p=[0.0_rp, 0.0_rp, 0.0_rp], n=[0.0_rp, 0.0_rp, 1.0_rp])
  th = 0.1_rp
  call toi_case(o, th, [0.0_rp, 0.0_rp, 1.1_rp], [0.3_rp, 0.0_rp, -2.0_rp], 0.5_rp, 'plane fall')
  call toi_case(o, th, [0.0_rp, 0.0_rp, 1.1_rp], [0.3_rp, 0.0_rp, -0.5_rp], 1.0_rp, 'plane short of it')
  call toi_case(o, th, [0.0_rp, 0.0_rp, 1.1_rp], [0.3_rp, 0.0_rp, 0.5_rp], 1.0_rp, 'plane away')
  call toi_case(o, th, [0.0_rp, 0.0_rp, 1.1_rp], [3.0_rp, 0.0_rp, 0.0_rp], 1.0_rp, 'plane parallel')
  call toi_case(o, th, [0.0_rp, 0.0_rp, 0.05_rp], [0.0_rp, 0.0_rp, 1.0_rp], 0.0_rp, 'plane start inside')
  ! Sphere r = 1, thickness 0.5 (R = 1.5), centre 0.
  o = obstacle_t(shape=SHAPE_SPHERE, p=[0.0_rp, 0.0_rp, 0.0_rp], r=1.0_rp)
  th = 0.5_rp
  call toi_case(o, th, [0.0_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -4.0_rp], 0.375_rp, 'sphere head-on')
  ! off axis by 0.9: enters at z = sqrt(1.5^2 - 0.9^2) = 1.2, t = 1.8/4
  call toi_case(o, th, [0.9_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -4.0_rp], 0.45_rp, 'sphere off axis')
  ! tangent: grazes at z = 0, t = 0.5; just outside the tangent line: misses
  call toi_case(o, th, [1.5_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -6.0_rp], 0.5_rp, 'sphere tangent graze')
  call toi_case(o, th, [1.5_rp + 1.0e-6_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -6.0_rp], 1.0_rp, 'sphere miss')
  ! Capsule (0,0,0)-(4,0,0), r = 0.5, thickness 0.25 (R = 0.75).
  o = obstacle_t(shape=SHAPE_CAPSULE, p=[0.0_rp, 0.0_rp, 0.0_rp], q=[4.0_rp, 0.0_rp, 0.0_rp], r=0.5_rp)
  th = 0.25_rp
  call toi_case(o, th, [2.0_rp, 0.0_rp, 2.0_rp], [0.0_rp, 0.0_rp, -2.0_rp], 0.625_rp, 'capsule body')
  ! over the cap at x = 4.6: z = sqrt(0.75^2 - 0.6^2) = 0.45, t = 1.55/2
  call toi_case(o, th, [4.6_rp, 0.0_rp, 2.0_rp], [0.0_rp, 0.0_rp, -2.0_rp], 0.775_rp, 'capsule cap')
  call toi_case(o, th, [6.0_rp, 0.0_rp, 0.0_rp], [-2.0_rp, 0.0_rp, 0.0_rp], 0.625_rp, 'capsule along axis')
  call toi_case(o, th, [5.0_rp, 0.0_rp, 2.0_rp], [0.0_rp, 0.0_rp, -2.0_rp], 1.0_rp, 'capsule miss beyond cap')
  call toi_case(o, th, [2.0_rp, 0.75_rp, 2.0_rp], [0.0_rp, 0.0_rp, -4.0_rp], 0.5_rp, 'capsule side graze')
  ! Box: unit half extents, thickness 0.2, rotated by rot about centre c; y = local coordinates.
  th = 0.2_rp
  o = obstacle_t(shape=SHAPE_BOX, p=c, h=[1.0_rp, 1.0_rp, 1.0_rp], axes=rot)
  call toi_local(o, th, [0.0_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -4.0_rp], 0.45_rp, 'box face')
  ! 0.1 beyond the edge x = z = 1: the edge's round of radius 0.2 is reached at z = 1 + sqrt(0.03)
  call toi_local(o, th, [1.1_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -4.0_rp], (2.0_rp - sqrt(0.03_rp)) / 4.0_rp, &
                 'box edge, falling')
  call toi_local(o, th, [3.0_rp, 0.4_rp, 3.0_rp], [-4.0_rp, 0.0_rp, -4.0_rp], (2.0_rp - 0.2_rp / sqrt(2.0_rp)) / 4.0_rp, &
                 'box edge, diagonal')
  call toi_local(o, th, [3.0_rp, 3.0_rp, 3.0_rp], [-4.0_rp, -4.0_rp, -4.0_rp], (2.0_rp - 0.2_rp / sqrt(3.0_rp)) / 4.0_rp, &
                 'box corner')
  ! tangent to the edge x = z = 1 (exact in binary: an unrotated box and thickness 0.25)
  call toi_case(obstacle_t(shape=SHAPE_BOX, h=[1.0_rp, 1.0_rp, 1.0_rp]), 0.25_rp, [1.25_rp, 0.0_rp, 3.0_rp], &
                [0.0_rp, 0.0_rp, -4.0_rp], 0.5_rp, 'box edge graze')
  call toi_case(obstacle_t(shape=SHAPE_BOX, h=[1.0_rp, 1.0_rp, 1.0_rp]), 0.25_rp, [1.25_rp + 1.0e-9_rp, 0.0_rp, 3.0_rp], &
                [0.0_rp, 0.0_rp, -4.0_rp], 1.0_rp, 'box edge just missed')
  call toi_local(o, th, [1.3_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -4.0_rp], 1.0_rp, 'box miss')
  call toi_local(o, th, [0.0_rp, 0.0_rp, 3.0_rp], [0.0_rp, 0.0_rp, -1.0_rp], 1.0_rp, 'box short of it')
  call toi_local(o, 0.0_rp, [0.0_rp, 0.0_rp, 3.0_rp], [0.5_rp, 0.0_rp, -4.0_rp], 0.5_rp, 'box face, no thickness')
  ! Moving obstacle: plane z = 0 rising by 0.4 while the node falls by 0.6 from gap 0.5: t = 0.5.
  o = obstacle_t(shape=SHAPE_PLANE)
  alpha = time_of_impact_moving(o, 0.1_rp, [0.0_rp, 0.0_rp, 0.6_rp], [1.0_rp, 0.0_rp, -0.6_rp], [0.0_rp, 0.0_rp, 0.4_rp])
  call check_close(alpha, 0.5_rp, 1.0e-14_rp, 0.0_rp, 'moving plane toi')
  alpha = time_of_impact_moving(o, 0.1_rp, [0.0_rp, 0.0_rp, 0.6_rp], [1.0_rp, 0.0_rp, 0.0_rp], [0.0_rp, 0.0_rp, -0.4_rp])
  call check_close(alpha, 1.0_rp, 0.0_rp, 0.0_rp, 'moving plane moving away')

  ! ---- time of impact: random paths against dense sampling ----------------
  do i = 1, 4
    call toi_random(ob(i), 0.05_rp, i)
  end do

  ! ---- contact_node: force, energy, Jacobians -----------------------------
  cp = contact_params_t(thickness=0.05_rp, dhat=0.1_rp, kappa=30.0_rp, eps_v=0.01_rp)
  do i = 1, 4
    ob(i)%mu = 0.4_rp
    ob(i)%vel = [0.01_rp, -0.02_rp, 0.005_rp]
  end do
  ! points with 0 < gap < dhat: 0.12 from the surface, thickness 0.05, so gap 0.07
  call node_fd(ob(1), ob(1)%p + 0.12_rp * rot(:, 3) + 0.3_rp * rot(:, 1), 'plane')
  call node_fd(ob(2), ob(2)%p + (0.7_rp + 0.12_rp) * [0.6_rp, 0.0_rp, 0.8_rp], 'sphere')
  call node_fd(ob(3), ob(3)%p + matmul(rot, [0.62_rp, 0.1_rp, -0.1_rp]), 'box face')
  call node_fd(ob(3), ob(3)%p + matmul(rot, [0.5_rp + 0.072_rp, 0.8_rp + 0.096_rp, 0.0_rp]), 'box edge')
  call node_fd(ob(3), ob(3)%p + matmul(rot, [-0.5_rp - 0.04_rp, 0.8_rp + 0.08_rp, 0.3_rp + 0.08_rp]), 'box corner')
  call node_fd(ob(4), 0.5_rp * (ob(4)%p + ob(4)%q) + 0.42_rp * unit3(cross([1.0_rp, 0.0_rp, 0.0_rp], &
               ob(4)%q - ob(4)%p)), 'capsule body')
  call node_fd(ob(4), ob(4)%q + 0.42_rp * unit3(ob(4)%q - ob(4)%p + [0.0_rp, 0.3_rp, 0.0_rp]), 'capsule cap')

  ! ---- friction: sticking, sliding, power ----------------------------------
  call friction_cases()

  ! ---- PSD projection: R diag(2, -1, 3) R^T -> R diag(2, 0, 3) R^T -----------
  block
    real(rp) :: a(3, 3), p(3, 3), pp(3, 3)
    a = matmul(rot, matmul(diag3([2.0_rp, -1.0_rp, 3.0_rp]), transpose(rot)))
    p = psd_project3(a)
    call check_close_array(reshape(p, [9]), reshape(matmul(rot, matmul(diag3([2.0_rp, 0.0_rp, 3.0_rp]), &
                           transpose(rot))), [9]), 0.0_rp, 1.0e-13_rp, 'psd_project3 clips the negative eigenvalue')
    pp = psd_project3(p)
    call check_close_array(reshape(pp, [9]), reshape(p, [9]), 0.0_rp, 1.0e-13_rp, 'psd_project3 keeps a PSD matrix')
    a = -a
    p = psd_project3(a)
    call check_close_array(reshape(p, [9]), reshape(matmul(rot, matmul(diag3([0.0_rp, 1.0_rp, 0.0_rp]), &
                           transpose(rot))), [9]), 0.0_rp, 1.0e-13_rp, 'psd_project3 of a mostly negative matrix')
  end block

  call check_report()

contains

  pure function eye3() result(a)
    real(rp) :: a(3, 3)
    a = diag3([1.0_rp, 1.0_rp, 1.0_rp])
  end function eye3

  pure function diag3(v) result(a)
    real(rp), intent(in) :: v(3)
    real(rp) :: a(3, 3)
    a = 0.0_rp
    a(1, 1) = v(1)
    a(2, 2) = v(2)
    a(3, 3) = v(3)
  end function diag3

  pure function outer(a, b) result(m)
    real(rp), intent(in) :: a(3), b(3)
    real(rp) :: m(3, 3)
    integer :: j
    do j = 1, 3
      m(:, j) = a * b(j)
    end do
  end function outer

  pure function cross(a, b) result(r)
    real(rp), intent(in) :: a(3), b(3)
    real(rp) :: r(3)
    r = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
  end function cross

  pure function unit3(a) result(u)
    real(rp), intent(in) :: a(3)
    real(rp) :: u(3)
    u = a / norm2(a)
  end function unit3

  !> Rodrigues: rotation about unit axis k by angle t.
  pure function rotation(k, t) result(r)
    real(rp), intent(in) :: k(3), t
    real(rp) :: r(3, 3), kx(3, 3)
    kx = reshape([0.0_rp, k(3), -k(2), -k(3), 0.0_rp, k(1), k(2), -k(1), 0.0_rp], [3, 3])
    r = eye3() + sin(t) * kx + (1.0_rp - cos(t)) * matmul(kx, kx)
  end function rotation

  !> Box o (axes rot, centre c) at local point yl: distance dd and local gradient gl.
  subroutine box_case(yl, dd, gl, what)
    real(rp), intent(in) :: yl(3), dd, gl(3)
    character(*), intent(in) :: what
    real(rp) :: dx, gx(3), hx(3, 3)
    call signed_distance(o, c + matmul(rot, yl), dx, gx, hx)
    call check_close(dx, dd, 1.0e-13_rp, 1.0e-15_rp, what//' d')
    call check_close_array(gx, matmul(rot, gl), 1.0e-13_rp, 1.0e-15_rp, what//' g')
  end subroutine box_case

  !> Gradient and Hessian of the signed distance against central differences at x0.
  subroutine fd_distance(ob1, x0, what)
    type(obstacle_t), intent(in) :: ob1
    real(rp), intent(in) :: x0(3)
    character(*), intent(in) :: what
    real(rp), parameter :: h = 1.0e-6_rp
    real(rp) :: d0, g0(3), h0(3, 3), dp, dm, gp(3), gm(3), hp(3, 3), hm(3, 3), gfd(3), hfd(3, 3), xp(3), xm(3)
    integer :: j
    call signed_distance(ob1, x0, d0, g0, h0)
    do j = 1, 3
      xp = x0
      xp(j) = xp(j) + h
      xm = x0
      xm(j) = xm(j) - h
      call signed_distance(ob1, xp, dp, gp, hp)
      call signed_distance(ob1, xm, dm, gm, hm)
      gfd(j) = (dp - dm) / (2.0_rp * h)
      hfd(:, j) = (gp - gm) / (2.0_rp * h)
    end do
    call check_close_array(g0, gfd, 1.0e-8_rp, 1.0e-9_rp, what//': g against FD of d')
    call check_close_array(reshape(h0, [9]), reshape(hfd, [9]), 1.0e-6_rp, 1.0e-7_rp, what//': hd against FD of g')
    call check_close(norm2(g0), 1.0_rp, 1.0e-14_rp, 0.0_rp, what//': |g| = 1')
    call check_close_array(matmul(h0, g0), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-13_rp, what//': hd g = 0')
  end subroutine fd_distance

  !> Gap along x0 + t dx.
  real(rp) function gap_at(ob1, thick, x0, dx, t)
    type(obstacle_t), intent(in) :: ob1
    real(rp), intent(in) :: thick, x0(3), dx(3), t
    real(rp) :: dd, gg(3), hh(3, 3)
    call signed_distance(ob1, x0 + t * dx, dd, gg, hh)
    gap_at = dd - thick
  end function gap_at

  !> time_of_impact against a hand-solved value; at a hit the gap there is ~0 and positive just before.
  subroutine toi_case(ob1, thick, x0, dx, expect, what)
    type(obstacle_t), intent(in) :: ob1
    real(rp), intent(in) :: thick, x0(3), dx(3), expect
    character(*), intent(in) :: what
    real(rp) :: a, scale
    integer :: j
    a = time_of_impact(ob1, thick, x0, dx)
    call check_close(a, expect, 1.0e-12_rp, 1.0e-14_rp, what//': alpha')
    scale = norm2(dx)
    if (expect > 0.0_rp .and. expect < 1.0_rp) then
      call check_true(gap_at(ob1, thick, x0, dx, a) >= -1.0e-12_rp * scale, what//': gap(alpha) >= -tiny')
      call check_true(abs(gap_at(ob1, thick, x0, dx, a)) <= 1.0e-12_rp * scale, what//': gap(alpha) ~ 0')
      call check_true(gap_at(ob1, thick, x0, dx, a * (1.0_rp - 1.0e-6_rp)) > 0.0_rp, what//': gap > 0 before alpha')
    end if
    do j = 0, 99
      if (j * a / 100.0_rp < a) then
        if (.not. gap_at(ob1, thick, x0, dx, j * a / 100.0_rp) > 0.0_rp) then
          call check_true(.false., what//': gap > 0 on [0, alpha)')
          return
        end if
      end if
    end do
  end subroutine toi_case

  !> toi_case with the path given in the box's local frame.
  subroutine toi_local(ob1, thick, y0, dy, expect, what)
    type(obstacle_t), intent(in) :: ob1
    real(rp), intent(in) :: thick, y0(3), dy(3), expect
    character(*), intent(in) :: what
    call toi_case(ob1, thick, ob1%p + matmul(ob1%axes, y0), matmul(ob1%axes, dy), expect, what)
  end subroutine toi_local

  !> Random segments: no sample before alpha has gap <= 0, and the first sample with gap <= 0
  !> (if any) is at or after alpha; alpha < 1 only where the gap reaches ~0 at alpha.
  subroutine toi_random(ob1, thick, seed)
    type(obstacle_t), intent(in) :: ob1
    real(rp), intent(in) :: thick
    integer, intent(in) :: seed
    integer, parameter :: NSEG = 150, NS = 1000
    real(rp) :: x0(3), dx(3), a, t, gmin, tg(3), ctr(3)
    integer :: j, m, nbad, nhit, nmiss
    integer, allocatable :: sd(:)
    call random_seed(size=m)
    allocate(sd(m))
    sd = 12345 + 97 * seed + [(j, j = 1, m)]
    call random_seed(put=sd)
    nbad = 0
    nhit = 0
    nmiss = 0
    do j = 1, NSEG
      ! from around the shape towards a point near its centre, sometimes past it
      call random_number(x0)
      call random_number(tg)
      call random_number(dx)
      ctr = ob1%p
      if (ob1%shape == SHAPE_CAPSULE) ctr = 0.5_rp * (ob1%p + ob1%q)
      x0 = ctr + 3.0_rp * (x0 - 0.5_rp)
      tg = ctr + 1.2_rp * (tg - 0.5_rp)
      dx = 1.5_rp * (tg - x0) + 0.6_rp * (dx - 0.5_rp)
      if (gap_at(ob1, thick, x0, dx, 0.0_rp) <= 0.0_rp) cycle
      a = time_of_impact(ob1, thick, x0, dx)
      if (a >= 1.0_rp) nmiss = nmiss + 1
      if (a < 1.0_rp) then
        nhit = nhit + 1
        if (abs(gap_at(ob1, thick, x0, dx, a)) > 1.0e-12_rp) nbad = nbad + 1
      end if
      gmin = huge(1.0_rp)
      do m = 0, NS
        t = real(m, rp) / NS
        if (t < a) then
          if (gap_at(ob1, thick, x0, dx, t) <= 0.0_rp) nbad = nbad + 1
        else
          gmin = min(gmin, gap_at(ob1, thick, x0, dx, t))
        end if
      end do
      ! missed entirely: every sample positive
      if (a >= 1.0_rp .and. gmin <= 0.0_rp) nbad = nbad + 1
    end do
    call check_true(nbad == 0, 'random paths: time_of_impact agrees with dense sampling')
    call check_true(nhit > 30 .and. nmiss > 5, 'random paths: enough hits and misses to test')
    print '(a,i0,a,i0,a,i0,a,i0)', 'shape ', ob1%shape, ': hits ', nhit, ' misses ', nmiss, ' bad ', nbad
  end subroutine toi_random

  !> contact_node at x: f = -dE/dx (FD of e), kx and kv against FD of f, projected kx PSD.
  subroutine node_fd(ob1, x0, what)
    type(obstacle_t), intent(in) :: ob1
    real(rp), intent(in) :: x0(3)
    character(*), intent(in) :: what
    real(rp), parameter :: hx = 1.0e-7_rp
    real(rp) :: v0(3), nl(3), lam, f0(3), kx0(3, 3), kv0(3, 3), e0, fn0, fp(3), fm(3), kdum(3, 3), kvd(3, 3)
    real(rp) :: epl, emi, fnd, kxfd(3, 3), kvfd(3, 3), efd(3), kxp(3, 3), w(3), hv, dd, gg(3), hh(3, 3)
    logical :: act
    integer :: j
    call signed_distance(ob1, x0, dd, gg, hh)
    call check_true(dd - cp%thickness > 0.0_rp .and. dd - cp%thickness < cp%dhat, what//': test point in the barrier')
    nl = gg
    lam = 2.0_rp
    ! sliding speed ~ eps_v: both terms of kv matter
    v0 = ob1%vel + 0.6_rp * cp%eps_v * unit3(cross(nl, [0.3_rp, 0.5_rp, 0.7_rp])) + 0.2_rp * nl
    call contact_node(ob1, cp, x0, v0, lam, nl, f0, kx0, kv0, e0, fn0, act)
    call check_true(act, what//': active')
    call check_true(fn0 > 0.0_rp, what//': fn > 0 (pushes out)')
    do j = 1, 3
      call contact_node(ob1, cp, x0 + hx * unit_e(j), v0, lam, nl, fp, kdum, kvd, epl, fnd, act)
      call contact_node(ob1, cp, x0 - hx * unit_e(j), v0, lam, nl, fm, kdum, kvd, emi, fnd, act)
      kxfd(:, j) = (fp - fm) / (2.0_rp * hx)
      efd(j) = (epl - emi) / (2.0_rp * hx)
      hv = 1.0e-4_rp * cp%eps_v
      call contact_node(ob1, cp, x0, v0 + hv * unit_e(j), lam, nl, fp, kdum, kvd, epl, fnd, act)
      call contact_node(ob1, cp, x0, v0 - hv * unit_e(j), lam, nl, fm, kdum, kvd, emi, fnd, act)
      kvfd(:, j) = (fp - fm) / (2.0_rp * hv)
    end do
    ! barrier part of f: lam = 0 switches friction off
    call contact_node(ob1, cp, x0, v0, 0.0_rp, nl, fp, kdum, kvd, epl, fnd, act)
    call check_close_array(fp, -efd, 1.0e-6_rp, 0.0_rp, what//': barrier force = -dE/dx')
    call check_close_array(fp, fn0 * gg, 1.0e-14_rp, 0.0_rp, what//': barrier force = fn g')
    call check_close_array(reshape(kx0, [9]), reshape(kxfd, [9]), 1.0e-5_rp, 0.0_rp, what//': kx against FD')
    call check_close_array(reshape(kv0, [9]), reshape(kvfd, [9]), 1.0e-6_rp, 0.0_rp, what//': kv against FD')
    call check_close_array(reshape(kx0, [9]), reshape(transpose(kx0), [9]), 1.0e-14_rp, 0.0_rp, what//': kx symmetric')
    ! projected: -kx PSD and equal to the exact one where the exact one is already so
    call contact_node(ob1, cp, x0, v0, lam, nl, fp, kxp, kvd, epl, fnd, act, project=.true.)
    call check_close_array(fp, f0, 0.0_rp, 0.0_rp, what//': project leaves f alone')
    do j = 1, 20
      call random_number(w)
      w = w - 0.5_rp
      if (dot_product(w, matmul(-kxp, w)) < -1.0e-12_rp * maxval(abs(kxp)) * dot_product(w, w)) then
        call check_true(.false., what//': projected -kx PSD')
        exit
      end if
      if (dot_product(w, matmul(-kv0, w)) < -1.0e-12_rp * maxval(abs(kv0)) * dot_product(w, w)) then
        call check_true(.false., what//': -kv PSD')
        exit
      end if
    end do
    call check_close_array(matmul(kxp, gg), matmul(kx0, gg), 1.0e-12_rp, 0.0_rp, &
                           what//': projection keeps the normal stiffness')
    if (all(hh == 0.0_rp)) then
      call check_close_array(reshape(kxp, [9]), reshape(kx0, [9]), 1.0e-12_rp, 0.0_rp, what//': flat: projected = exact')
    else
      call check_true(maxval(abs(kxp - kx0)) > 1.0e-6_rp * maxval(abs(kx0)), what//': curved: projection changes kx')
    end if
  end subroutine node_fd

  pure function unit_e(j) result(u)
    integer, intent(in) :: j
    real(rp) :: u(3)
    u = 0.0_rp
    u(j) = 1.0_rp
  end function unit_e

  !> Friction alone (barrier inactive: the node is beyond dhat): sticking and sliding.
  subroutine friction_cases()
    type(obstacle_t) :: pl
    type(contact_params_t) :: cq
    real(rp) :: xx(3), v(3), u(3), f(3), f2(3), kx1(3, 3), kv1(3, 3), e1, fn1, lam, nl(3), y1, pw
    logical :: act
    integer :: j
    pl = obstacle_t(shape=SHAPE_PLANE, n=[0.0_rp, 0.0_rp, 1.0_rp], mu=0.3_rp, vel=[0.2_rp, -0.1_rp, 0.0_rp])
    cq = contact_params_t(thickness=0.01_rp, dhat=0.01_rp, kappa=5.0_rp, eps_v=1.0e-3_rp)
    xx = [0.0_rp, 0.0_rp, 1.0_rp]          ! gap 0.99 > dhat: only friction acts
    nl = [0.0_rp, 0.0_rp, 1.0_rp]
    lam = 4.0_rp
    ! sticking: |u| = 1e-3 eps_v: f ~ -mu lam (2/eps_v) u, linear in u, opposing it
    u = 1.0e-6_rp * [0.6_rp, -0.8_rp, 0.0_rp]
    v = pl%vel + u + [0.0_rp, 0.0_rp, 5.0_rp]   ! the normal velocity plays no part
    call contact_node(pl, cq, xx, v, lam, nl, f, kx1, kv1, e1, fn1, act)
    call check_true(.not. act .and. e1 == 0.0_rp .and. fn1 == 0.0_rp, 'friction case: barrier inactive')
    call check_close_array(f, -0.3_rp * lam * (2.0_rp / 1.0e-3_rp) * u, 1.0e-3_rp, 0.0_rp, &
                           'sticking: f = -mu lam (2/eps_v) u to O(|u|/eps_v)')
    call check_true(dot_product(f, u) < 0.0_rp, 'sticking: f opposes u')
    call contact_node(pl, cq, xx, pl%vel + 2.0_rp * u, lam, nl, f2, kx1, kv1, e1, fn1, act)
    call check_close_array(f2, 2.0_rp * f, 1.0e-3_rp, 0.0_rp, 'sticking: f linear in u')
    ! at u = 0 exactly: no force, kv = -mu lam (2/eps_v) P
    call contact_node(pl, cq, xx, pl%vel, lam, nl, f, kx1, kv1, e1, fn1, act)
    call check_close_array(f, [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 0.0_rp, 'u = 0: no friction force')
    call check_close_array(reshape(kv1, [9]), reshape(-0.3_rp * lam * 2.0e3_rp * diag3([1.0_rp, 1.0_rp, 0.0_rp]), [9]), &
                           1.0e-14_rp, 0.0_rp, 'u = 0: kv = -mu lam (2/eps_v) P')
    ! sliding: |f| = mu lam exactly, along -u, tangential; friction_power = mu lam |u| = -f.u
    do j = 1, 3
      u = [0.05_rp, 0.02_rp, 0.0_rp] * j
      v = pl%vel + u + [0.0_rp, 0.0_rp, -0.3_rp]
      call contact_node(pl, cq, xx, v, lam, nl, f, kx1, kv1, e1, fn1, act)
      y1 = norm2(u)
      call check_close(norm2(f), 0.3_rp * lam, 1.0e-14_rp, 0.0_rp, 'sliding: |f| = mu lam')
      call check_close_array(f, -0.3_rp * lam * u / y1, 1.0e-14_rp, 0.0_rp, 'sliding: f along -u')
      pw = friction_power(pl, cq, v, lam, nl)
      call check_close(pw, 0.3_rp * lam * y1, 1.0e-14_rp, 0.0_rp, 'sliding: power = mu lam |u|')
      call check_close(pw, -dot_product(f, u), 1.0e-14_rp, 0.0_rp, 'sliding: power = -f.u')
    end do
    ! the mollifier's two pieces meet at eps_v: |f| = mu lam on both sides
    u = [1.0_rp, 0.0_rp, 0.0_rp] * 1.0e-3_rp * (1.0_rp - 1.0e-9_rp)
    call contact_node(pl, cq, xx, pl%vel + u, lam, nl, f, kx1, kv1, e1, fn1, act)
    call check_close(norm2(f), 0.3_rp * lam, 1.0e-8_rp, 0.0_rp, 'f1 continuous at eps_v')
    ! power >= 0 and = -f.u for random velocities in both regimes
    do j = 1, 50
      call random_number(v)
      v = (v - 0.5_rp) * 4.0e-3_rp * merge(1.0_rp, 100.0_rp, mod(j, 2) == 0)
      call contact_node(pl, cq, xx, pl%vel + v, lam, nl, f, kx1, kv1, e1, fn1, act)
      pw = friction_power(pl, cq, pl%vel + v, lam, nl)
      u = [v(1), v(2), 0.0_rp]
      if (pw < 0.0_rp .or. abs(pw + dot_product(f, u)) > 1.0e-13_rp * max(pw, 1.0e-20_rp)) then
        call check_true(.false., 'friction_power >= 0 and = -f.u (random)')
        exit
      end if
    end do
    ! no friction without a lagged normal force or coefficient
    call contact_node(pl, cq, xx, pl%vel + [1.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, nl, f, kx1, kv1, e1, fn1, act)
    call check_true(all(f == 0.0_rp) .and. all(kv1 == 0.0_rp), 'lam = 0: no friction')
    call check_true(friction_power(pl, cq, pl%vel + [1.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, nl) == 0.0_rp, &
                    'lam = 0: no friction power')
  end subroutine friction_cases

end program test_contact
