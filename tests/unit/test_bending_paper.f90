! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the paper bending kernels (module bending_paper): size,
!> direction and plane of the end forces against a triple built from a known
!> angle, straightening, the exact Jacobian against central finite
!> differences from the flat state to large angles in 3-D, the first-order
!> flat-state Jacobian, and the degenerate cases.
program test_bending_paper
  use kinds, only: rp
  use bending_paper, only: paper_force, paper_jacobian, paper_energy
  use check, only: check_true, check_close, check_close_array, check_report, rotation
  use vec3, only: cross
  implicit none
  real(rp), parameter :: PI = acos(-1.0_rp)
  real(rp), parameter :: KB = 1.7_rp
  real(rp) :: angles(7), x9(9), f9(9), K9(9,9), Kexp(9,9), Q(3,3), t(3), theta, a
  logical :: ok
  integer :: i, ia, io

  angles = [0.0_rp, 1.0e-4_rp, 0.1_rp, 0.1414_rp, 0.1416_rp, 0.7_rp, 2.5_rp]

  do io = 1, 3
    do ia = 1, size(angles)
      call make_triple(angles(ia), 1.3_rp, 0.7_rp, io, x9, t)
      call force_checks(angles(ia), x9, io)
      call jacobian_check(x9, angles(ia), io)
    end do
  end do

  ! ---- flat state: K9 nonzero and equal to the first-order formula -------
  ! f_p = f_r = -(k_b/a) Q (dp - 2 dq + dr), Q = I - t t^T (t the line direction).
  a = 0.8_rp
  do io = 1, 3
    call make_triple(0.0_rp, a, a, io, x9, t)
    call paper_jacobian(KB, x9, K9, ok)
    call check_true(ok, 'flat Jacobian ok')
    call check_true(maxval(abs(K9)) > 0.5_rp*KB/a, 'flat Jacobian is not zero')
    Q = -spread(t, 2, 3)*spread(t, 1, 3)
    do i = 1, 3
      Q(i,i) = Q(i,i) + 1.0_rp
    end do
    Kexp = 0.0_rp
    Kexp(1:3,1:3) = -(KB/a)*Q; Kexp(1:3,4:6) = 2*(KB/a)*Q; Kexp(1:3,7:9) = -(KB/a)*Q
    Kexp(7:9,:) = Kexp(1:3,:)
    call check_close_array(reshape(K9, [81]), reshape(Kexp, [81]), 1.0e-14_rp, 0.0_rp, 'flat Jacobian = first-order formula')
  end do

  ! ---- near theta = pi and zero edges: not ok, zeros, no NaN ------------
  call make_triple(PI - 1.0e-8_rp, 1.0_rp, 1.0_rp, 2, x9, t)
  call paper_force(KB, x9, f9, theta, ok)
  call check_true(.not. ok .and. all(f9 == 0.0_rp), 'theta ~ pi: not ok, f9 = 0')
  call paper_jacobian(KB, x9, K9, ok)
  call check_true(.not. ok .and. all(K9 == 0.0_rp), 'theta ~ pi: Jacobian not ok, 0')
  call make_triple(PI - 1.0e-4_rp, 1.0_rp, 1.0_rp, 2, x9, t)
  call paper_force(KB, x9, f9, theta, ok)
  call check_true(ok .and. all(f9 == f9), 'theta = pi - 1e-4 still ok and finite')
  call make_triple(0.4_rp, 1.0_rp, 1.0_rp, 2, x9, t)
  x9(1:3) = x9(4:6)
  call paper_force(KB, x9, f9, theta, ok)
  call check_true(.not. ok .and. all(f9 == 0.0_rp), 'zero edge p-q: not ok, f9 = 0')
  call paper_jacobian(KB, x9, K9, ok)
  call check_true(.not. ok .and. all(K9 == 0.0_rp), 'zero edge p-q: Jacobian not ok')
  x9 = 0.0_rp
  call paper_force(KB, x9, f9, theta, ok)
  call check_true(.not. ok .and. all(f9 == 0.0_rp) .and. theta == theta, 'all points equal: not ok')
  call check_true(paper_energy(KB, x9) == 0.0_rp, 'all points equal: energy 0')

  call check_report()

contains

  ! A triple with bend angle theta, |x_p - x_q| = lu, |x_r - x_q| = lw,
  ! rotated by orientation io (1: identity, 2, 3: rotations about oblique
  ! axes) and shifted. t = direction of e1 = x_q - x_p.
  subroutine make_triple(theta, lu, lw, io, x9, t)
    real(rp), intent(in) :: theta, lu, lw
    integer, intent(in) :: io
    real(rp), intent(out) :: x9(9), t(3)
    real(rp) :: r(3,3), e1(3), e2(3), q(3)
    r = rotation(io)
    e1 = matmul(r, [1.0_rp, 0.0_rp, 0.0_rp])
    e2 = matmul(r, [cos(theta), sin(theta), 0.0_rp])
    q = [0.3_rp, -0.2_rp, 0.5_rp]*real(io, rp)
    x9(4:6) = q
    x9(1:3) = q - lu*e1
    x9(7:9) = q + lw*e2
    t = e1
  end subroutine make_triple

  ! Size k_b theta, perpendicular to own segment, in the plane, straightening, f_q = 0.
  subroutine force_checks(th, x9, io)
    real(rp), intent(in) :: th, x9(9)
    integer, intent(in) :: io
    real(rp) :: f9(9), u(3), w(3), nrm(3), theta, theta2, h, y9(9)
    logical :: ok
    character(48) :: tag
    write(tag, '(a,es9.2,a,i0)') ' theta=', th, ' orient=', io
    call paper_force(KB, x9, f9, theta, ok)
    call check_true(ok, 'ok'//tag)
    ! the rotated triple carries position round-off ~1e-16: absolute angle error ~1e-15
    call check_close(theta, th, 1.0e-12_rp, 1.0e-14_rp, 'theta out'//tag)
    call check_close(norm2(f9(1:3)), KB*th, 1.0e-12_rp, 1.0e-14_rp*KB, '|f_p| = k_b theta'//tag)
    call check_close(norm2(f9(7:9)), KB*th, 1.0e-12_rp, 1.0e-14_rp*KB, '|f_r| = k_b theta'//tag)
    call check_true(all(f9(4:6) == 0.0_rp), 'f_q = 0'//tag)
    call check_close(paper_energy(KB, x9), 0.5_rp*KB*th**2, 1.0e-12_rp, 1.0e-14_rp*KB*max(th, 1.0e-14_rp), 'energy indicator'//tag)
    u = x9(1:3) - x9(4:6)
    w = x9(7:9) - x9(4:6)
    call check_close(dot_product(f9(1:3), u), 0.0_rp, 0.0_rp, 1.0e-13_rp, 'f_p perpendicular to u'//tag)
    call check_close(dot_product(f9(7:9), w), 0.0_rp, 0.0_rp, 1.0e-13_rp, 'f_r perpendicular to w'//tag)
    if (th > 0.0_rp) then
      nrm = cross(u, w)
      nrm = nrm/norm2(nrm)
      call check_close(dot_product(f9(1:3), nrm), 0.0_rp, 0.0_rp, 1.0e-12_rp*KB*th, 'f_p in plane'//tag)
      call check_close(dot_product(f9(7:9), nrm), 0.0_rp, 0.0_rp, 1.0e-12_rp*KB*th, 'f_r in plane'//tag)
      ! a small step along the force straightens the triple
      h = 1.0e-3_rp*min(th, 0.1_rp)
      y9 = x9 + h*f9
      call paper_force(KB, y9, f9, theta2, ok)
      call check_true(theta2 < th, 'moving along f decreases theta'//tag)
    end if
  end subroutine force_checks

  ! K9 against central differences of paper_force.
  subroutine jacobian_check(x9, th, io)
    real(rp), intent(in) :: x9(9), th
    integer, intent(in) :: io
    real(rp) :: K9(9,9), Kfd(9,9), y9(9), fp(9), fm(9), theta
    real(rp), parameter :: h = 1.0e-6_rp
    logical :: ok
    integer :: j
    character(48) :: tag
    write(tag, '(a,es9.2,a,i0)') ' theta=', th, ' orient=', io
    call paper_jacobian(KB, x9, K9, ok)
    call check_true(ok, 'Jacobian ok'//tag)
    do j = 1, 9
      y9 = x9; y9(j) = y9(j) + h
      call paper_force(KB, y9, fp, theta, ok)
      y9(j) = y9(j) - 2*h
      call paper_force(KB, y9, fm, theta, ok)
      Kfd(:,j) = (fp - fm)/(2*h)
    end do
    call check_close_array(reshape(K9, [81]), reshape(Kfd, [81]), 1.0e-6_rp, 1.0e-9_rp, 'K9 vs FD'//tag)
  end subroutine jacobian_check

end program test_bending_paper
