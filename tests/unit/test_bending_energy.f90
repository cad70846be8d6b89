! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the energy bending kernels (module bending_energy): forces
!> against finite differences of the energy and of the Rayleigh function,
!> exact K9 and C9 against finite differences of the forces (flat to large
!> angles, 3-D, with and without damping), translation and rotation
!> invariance, |kb| = 2 tan(theta/2), the Gauss-Newton part, degenerate cases;
!> the row-of-triples kernels (energy_force_lanes, energy_jacobian_lanes,
!> energy_power_lanes)
!> against the one-triple kernels lane by lane (so against the finite
!> differences above).
program test_bending_energy
  use kinds, only: rp
  use bending_energy, only: energy_force, energy_force_lanes, energy_jacobian, energy_jacobian_edges, energy_jacobian_lanes, energy_bend_energy, energy_power, &
                            energy_power_lanes
  use check, only: check_true, check_close, check_close_array, check_report, rotation
  use vec3, only: cross
  implicit none
  real(rp), parameter :: PI = acos(-1.0_rp)
  real(rp), parameter :: KB = 0.9_rp, ETA = 0.3_rp
  real(rp) :: angles(6), x9(9), v9(9), f9(9), K9(9,9), C9(9,9), y(9)
  logical :: ok
  integer :: ia, io, i

  angles = [0.0_rp, 1.0e-4_rp, 0.1_rp, 0.7_rp, 1.6_rp, 2.5_rp]
  v9 = [0.3_rp, -0.8_rp, 0.5_rp, 1.1_rp, 0.2_rp, -0.4_rp, -0.6_rp, 0.9_rp, 0.7_rp]

  do io = 1, 3
    do ia = 1, size(angles)
      call make_triple(angles(ia), 1.3_rp, 0.7_rp, io, x9)
      call all_checks(angles(ia), io, x9)
    end do
  end do

  ! ---- degenerate triples: not ok, zeros, no NaN --------------------------
  call make_triple(PI - 1.0e-8_rp, 1.0_rp, 1.0_rp, 2, x9)
  call energy_force(KB, ETA, x9, v9, f9, ok)
  call check_true(.not. ok .and. all(f9 == 0.0_rp), 'theta ~ pi: not ok, f9 = 0')
  call energy_jacobian(KB, ETA, x9, v9, .false., K9, C9, ok)
  call check_true(.not. ok .and. all(K9 == 0.0_rp) .and. all(C9 == 0.0_rp), 'theta ~ pi: Jacobian not ok, 0')
  call check_true(energy_bend_energy(KB, x9) == 0.0_rp .and. energy_power(ETA, x9, v9) == 0.0_rp, &
    'theta ~ pi: energy and power 0')
  call make_triple(0.4_rp, 1.0_rp, 1.0_rp, 3, x9)
  x9(7:9) = x9(4:6)
  call energy_force(KB, ETA, x9, v9, f9, ok)
  call check_true(.not. ok .and. all(f9 == 0.0_rp), 'zero edge q-r: not ok, f9 = 0')
  call energy_jacobian(KB, ETA, x9, v9, .true., K9, C9, ok)
  call check_true(.not. ok .and. all(K9 == 0.0_rp), 'zero edge q-r: Jacobian not ok')
  x9 = 0.0_rp
  call energy_force(KB, ETA, x9, v9, f9, ok)
  call check_true(.not. ok .and. all(f9 == 0.0_rp), 'all points equal: not ok')

  ! ---- a uniform (translational) velocity dissipates nothing ------------
  call make_triple(0.7_rp, 1.3_rp, 0.7_rp, 2, x9)
  y = [(0.4_rp, -0.3_rp, 1.2_rp, i = 1, 3)]
  call energy_force(0.0_rp, ETA, x9, y, f9, ok)
  call check_close_array(f9, [(0.0_rp, i = 1, 9)], 0.0_rp, 1.0e-14_rp, 'translation: no damping force')
  call check_close(energy_power(ETA, x9, y), 0.0_rp, 0.0_rp, 1.0e-28_rp, 'translation: no power')

  call lanes_checks()

  call check_report()

contains

  ! energy_jacobian_lanes on 11 triples of arrays with room for 16 (lanes
  ! beyond n untouched): every angle and orientation above, a folded-back
  ! triple and a zero edge among them; each lane equal to
  ! energy_jacobian_edges up to round-off, with and without damping and
  ! Gauss-Newton.
  subroutine lanes_checks()
    integer, parameter :: LD = 16, N = 11
    real(rp) :: x(9, N), v(9, N), e1(LD, 3), e2(LD, 3), de(LD, 6), ke(LD, 6, 6), ce(LD, 6, 6), kes(6, 6), ces(6, 6)
    real(rp) :: fl(LD, 9), fs(9), pwl(LD)
    real(rp) :: eta_l                ! (not eta: that is the host's ETA)
    logical :: okl(LD), oks, gn
    integer :: l, m, c
    character(len=40) :: tag
    do l = 1, N
      call make_triple(angles(mod(l - 1, size(angles)) + 1), 1.3_rp - 0.05_rp*l, 0.7_rp, mod(l - 1, 3) + 1, x(:, l))
      v(:, l) = [(sin(0.37_rp*real(l*c, rp)), c = 1, 9)]
    end do
    call make_triple(PI - 1.0e-8_rp, 1.0_rp, 1.0_rp, 2, x(:, 4))
    x(7:9, 9) = x(4:6, 9)
    do l = 1, N
      e1(l, :) = x(4:6, l) - x(1:3, l)
      e2(l, :) = x(7:9, l) - x(4:6, l)
      de(l, 1:3) = v(4:6, l) - v(1:3, l)
      de(l, 4:6) = v(7:9, l) - v(4:6, l)
    end do
    do m = 1, 3
      eta_l = merge(0.0_rp, ETA, m == 1)
      gn = m == 3
      ke = -7.0_rp
      ce = -7.0_rp
      call energy_jacobian_lanes(N, LD, KB, eta_l, e1, e2, de, gn, ke, ce, okl)
      do l = 1, N
        write(tag, '(a,i0,a,i0)') ' (lanes: case ', m, ', lane ', l
        call energy_jacobian_edges(KB, eta_l, x(:, l), v(:, l), gn, kes, ces, oks)
        call check_true(okl(l) .eqv. oks, 'ok'//trim(tag)//')')
        call check_close_array(reshape(ke(l, :, :), [36]), reshape(kes, [36]), 1.0e-12_rp, 0.0_rp, 'ke'//trim(tag)//')')
        call check_close_array(reshape(ce(l, :, :), [36]), reshape(ces, [36]), 1.0e-12_rp, 0.0_rp, 'ce'//trim(tag)//')')
      end do
      call check_true(all(ke(N + 1:, :, :) == -7.0_rp) .and. all(ce(N + 1:, :, :) == -7.0_rp), &
        'lanes beyond n untouched')
      if (gn) cycle
      fl = -7.0_rp
      call energy_force_lanes(N, LD, KB, eta_l, e1, e2, de, fl, okl)
      do l = 1, N
        write(tag, '(a,i0,a,i0)') ' (force lanes: case ', m, ', lane ', l
        call energy_force(KB, eta_l, x(:, l), v(:, l), fs, oks)
        call check_true(okl(l) .eqv. oks, 'ok'//trim(tag)//')')
        call check_close_array(fl(l, :), fs, 1.0e-12_rp, 0.0_rp, 'f'//trim(tag)//')')
      end do
      call check_true(all(fl(N + 1:, :) == -7.0_rp), 'force lanes beyond n untouched')
      pwl = -7.0_rp
      call energy_power_lanes(N, LD, eta_l, e1, e2, de, pwl, okl)
      do l = 1, N
        write(tag, '(a,i0,a,i0)') ' (power lanes: case ', m, ', lane ', l
        call check_close(pwl(l), energy_power(eta_l, x(:, l), v(:, l)), 1.0e-12_rp, 0.0_rp, 'power'//trim(tag)//')')
      end do
      call check_true(all(pwl(N + 1:) == -7.0_rp), 'power lanes beyond n untouched')
    end do
    call check_true(.not. okl(4) .and. .not. okl(9) .and. count(okl(1:N)) == N - 2, 'lanes: the two degenerate triples found')
  end subroutine lanes_checks

  ! A triple with bend angle theta, |x_q - x_p| = l1, |x_r - x_q| = l2,
  ! rotated by orientation io (1: identity, 2, 3: about oblique axes), shifted.
  subroutine make_triple(theta, l1, l2, io, x9)
    real(rp), intent(in) :: theta, l1, l2
    integer, intent(in) :: io
    real(rp), intent(out) :: x9(9)
    real(rp) :: r(3,3), e1(3), e2(3), q(3)
    r = rotation(io)
    e1 = matmul(r, [1.0_rp, 0.0_rp, 0.0_rp])
    e2 = matmul(r, [cos(theta), sin(theta), 0.0_rp])
    q = [0.3_rp, -0.2_rp, 0.5_rp]*real(io, rp)
    x9(4:6) = q
    x9(1:3) = q - l1*e1
    x9(7:9) = q + l2*e2
  end subroutine make_triple

  ! Forces on x9 with (k_b, eta_b) at velocity v9 (plain wrapper for differencing).
  function force(k_b, eta_b, x9, v9) result(f9)
    real(rp), intent(in) :: k_b, eta_b, x9(9), v9(9)
    real(rp) :: f9(9)
    logical :: ok
    call energy_force(k_b, eta_b, x9, v9, f9, ok)
  end function force

  subroutine all_checks(th, io, x9)
    real(rp), intent(in) :: th, x9(9)
    integer, intent(in) :: io
    real(rp), parameter :: h = 1.0e-6_rp
    real(rp) :: fel(9), fd(9), f(9), g(9), y(9), K9(9,9), C9(9,9), Kfd(9,9), Cfd(9,9), Kgn(9,9), Cgn(9,9)
    real(rp) :: torque(3), z(9), kbmag
    logical :: ok
    integer :: j, k, m
    character(48) :: tag
    write(tag, '(a,es9.2,a,i0)') ' theta=', th, ' orient=', io

    ! |kb| = 2 tan(theta/2): W = 1/2 k_b (2 tan(theta/2))^2
    kbmag = 2.0_rp*tan(0.5_rp*th)
    call check_close(energy_bend_energy(KB, x9), 0.5_rp*KB*kbmag**2, 1.0e-12_rp, 1.0e-14_rp*KB*max(th, 1.0e-14_rp), &
      'W = 1/2 k_b (2 tan(theta/2))^2'//tag)

    ! elastic force = -dW/dx (eta_b = 0)
    call energy_force(KB, 0.0_rp, x9, v9, fel, ok)
    call check_true(ok, 'ok'//tag)
    do j = 1, 9
      y = x9; y(j) = y(j) + h; g(j) = energy_bend_energy(KB, y)
      y(j) = y(j) - 2*h; g(j) = (g(j) - energy_bend_energy(KB, y))/(2*h)
    end do
    call check_close_array(fel, -g, 1.0e-7_rp, 1.0e-10_rp, 'f = -dW/dx'//tag)
    ! translation and rotation invariance of the elastic force
    call check_close_array(fel(1:3) + fel(4:6) + fel(7:9), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, &
      1.0e-14_rp*max(maxval(abs(fel)), 1.0_rp), 'sum f = 0'//tag)
    torque = cross(x9(1:3), fel(1:3)) + cross(x9(4:6), fel(4:6)) + cross(x9(7:9), fel(7:9))
    call check_close_array(torque, [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-13_rp*max(maxval(abs(fel)), 1.0_rp), &
      'sum x cross f = 0'//tag)

    ! damping force = -dR/dv, R = 1/2 eta_b |J v|^2 = power/2; power = -f_d.v
    fd = force(0.0_rp, ETA, x9, v9)
    do j = 1, 9
      y = v9; y(j) = y(j) + h; g(j) = 0.5_rp*energy_power(ETA, x9, y)
      y(j) = y(j) - 2*h; g(j) = (g(j) - 0.5_rp*energy_power(ETA, x9, y))/(2*h)
    end do
    call check_close_array(fd, -g, 1.0e-7_rp, 1.0e-10_rp, 'f_damp = -dR/dv'//tag)
    call check_close(energy_power(ETA, x9, v9), -dot_product(fd, v9), 1.0e-12_rp, 1.0e-15_rp, 'power = -f_damp.v'//tag)
    call check_true(energy_power(ETA, x9, v9) > 0.0_rp, 'power > 0'//tag)
    f = force(KB, ETA, x9, v9)
    call check_close_array(f, fel + fd, 1.0e-13_rp, 1.0e-15_rp, 'f = f_elastic + f_damp'//tag)
    call check_close_array(f(1:3) + f(4:6) + f(7:9), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, &
      1.0e-14_rp*max(maxval(abs(f)), 1.0_rp), 'sum f = 0 with damping'//tag)

    ! K9 and C9 against central differences, undamped at rest and damped moving
    do m = 1, 2
      if (m == 1) then
        call energy_jacobian(KB, 0.0_rp, x9, 0.0_rp*v9, .false., K9, C9, ok)
      else
        call energy_jacobian(KB, ETA, x9, v9, .false., K9, C9, ok)
      end if
      call check_true(ok, 'Jacobian ok'//tag)
      do j = 1, 9
        if (m == 1) then
          y = x9; y(j) = y(j) + h; f = force(KB, 0.0_rp, y, 0.0_rp*v9)
          y(j) = y(j) - 2*h; Kfd(:,j) = (f - force(KB, 0.0_rp, y, 0.0_rp*v9))/(2*h)
          Cfd(:,j) = 0.0_rp
        else
          y = x9; y(j) = y(j) + h; f = force(KB, ETA, y, v9)
          y(j) = y(j) - 2*h; Kfd(:,j) = (f - force(KB, ETA, y, v9))/(2*h)
          y = v9; y(j) = y(j) + h; f = force(KB, ETA, x9, y)
          y(j) = y(j) - 2*h; Cfd(:,j) = (f - force(KB, ETA, x9, y))/(2*h)
        end if
      end do
      call check_close_array(reshape(K9, [81]), reshape(Kfd, [81]), 1.0e-6_rp, 1.0e-9_rp, &
        merge('K9 vs FD undamped', 'K9 vs FD damped  ', m == 1)//tag)
      call check_close_array(reshape(C9, [81]), reshape(Cfd, [81]), 1.0e-6_rp, 1.0e-9_rp, &
        merge('C9 vs FD undamped', 'C9 vs FD damped  ', m == 1)//tag)
    end do

    ! Gauss-Newton: symmetric negative semidefinite; same C9; equal to exact at the flat state
    call energy_jacobian(KB, ETA, x9, v9, .true., Kgn, Cgn, ok)
    call check_close_array(reshape(Cgn, [81]), reshape(C9, [81]), 1.0e-14_rp, 0.0_rp, 'GN C9 = exact C9'//tag)
    call check_close_array(reshape(Kgn, [81]), reshape(transpose(Kgn), [81]), 1.0e-14_rp, 0.0_rp, 'GN K9 symmetric'//tag)
    do j = 1, 4
      z = [(sin(1.7_rp*real(j*k + 3*j, rp)), k = 1, 9)]
      call check_true(dot_product(z, matmul(Kgn, z)) <= 1.0e-14_rp*maxval(abs(Kgn)), 'GN z^T K z <= 0'//tag)
    end do
    if (th == 0.0_rp) then
      call energy_jacobian(KB, 0.0_rp, x9, v9, .false., K9, C9, ok)
      call energy_jacobian(KB, 0.0_rp, x9, v9, .true., Kgn, Cgn, ok)
      call check_close_array(reshape(Kgn, [81]), reshape(K9, [81]), 1.0e-14_rp, 0.0_rp, 'flat: GN = exact (eta_b = 0)'//tag)
      call check_true(maxval(abs(K9)) > 0.1_rp*KB, 'flat: K9 is not zero'//tag)
    end if
  end subroutine all_checks

end program test_bending_energy
