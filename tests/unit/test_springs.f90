! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the Voigt link kernels (module springs): hand-computed
!> forces, action = reaction, Jacobians against central finite differences of
!> the force, energy against the force, power against the damping force;
!> the row-of-links kernels (link_jacobian_lanes, link_force_lanes,
!> link_power_lanes) against link_jacobian, link_force and link_power lane
!> by lane.
program test_springs
  use kinds, only: rp
  use springs, only: link_force, link_force_lanes, link_jacobian, link_jacobian_lanes, link_energy, link_power, &
                     link_power_lanes
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  integer, parameter :: AXIAL = 1, LINEAR = 2
  real(rp) :: xp(3), xq(3), vp(3), vq(3), d0(3), L, E, eta
  real(rp) :: f(3), fq(3), f0(3), K(3,3), C(3,3), Kc(3,3), Q(3,3), n(3), ln
  logical :: ok
  integer :: i, model

  ! ---- hand-computed forces --------------------------------------------
  ! xp - xq = (3,2,3) - (1,1,1) = (2,1,2): l = 3, n = (2,1,2)/3.
  ! vp - vq = (3,1,0) - (0,1,0) = (3,0,0): ldot = n.(3,0,0) = 2.
  ! E = 5, eta = 0.5, L = 2, d0 = (2,0,0).
  xp = [3.0_rp, 2.0_rp, 3.0_rp]; xq = [1.0_rp, 1.0_rp, 1.0_rp]
  vp = [3.0_rp, 1.0_rp, 0.0_rp]; vq = [0.0_rp, 1.0_rp, 0.0_rp]
  d0 = [2.0_rp, 0.0_rp, 0.0_rp]; L = 2.0_rp; E = 5.0_rp; eta = 0.5_rp
  ! axial: -(E (l-L) + eta ldot) n = -(5*1 + 0.5*2) (2,1,2)/3 = -2 (2,1,2) = (-4,-2,-4)
  call link_force(AXIAL, E, eta, d0, L, xp, xq, vp, vq, f, ok)
  call check_true(ok, 'axial ok')
  call check_close_array(f, [-4.0_rp, -2.0_rp, -4.0_rp], 1.0e-14_rp, 0.0_rp, 'axial hand force')
  ! axial, eta = 0: -5*1*(2,1,2)/3 = (-10/3, -5/3, -10/3)
  call link_force(AXIAL, E, 0.0_rp, d0, L, xp, xq, vp, vq, f, ok)
  call check_close_array(f, [-10.0_rp/3, -5.0_rp/3, -10.0_rp/3], 1.0e-14_rp, 0.0_rp, 'axial hand force eta=0')
  ! linear: -(E (d - d0) + eta (vp-vq)) = -(5 (0,1,2) + 0.5 (3,0,0)) = (-1.5, -5, -10)
  call link_force(LINEAR, E, eta, d0, L, xp, xq, vp, vq, f, ok)
  call check_true(ok, 'linear ok')
  call check_close_array(f, [-1.5_rp, -5.0_rp, -10.0_rp], 1.0e-14_rp, 0.0_rp, 'linear hand force')
  ! energies: axial 1/2*5*(3-2)^2 = 2.5; linear 1/2*5*(0+1+4) = 12.5
  call check_close(link_energy(AXIAL, E, d0, L, xp, xq), 2.5_rp, 1.0e-14_rp, 0.0_rp, 'axial hand energy')
  call check_close(link_energy(LINEAR, E, d0, L, xp, xq), 12.5_rp, 1.0e-14_rp, 0.0_rp, 'linear hand energy')
  ! powers: axial 0.5*2^2 = 2; linear 0.5*9 = 4.5
  call check_close(link_power(AXIAL, eta, xp, xq, vp, vq), 2.0_rp, 1.0e-14_rp, 0.0_rp, 'axial hand power')
  call check_close(link_power(LINEAR, eta, xp, xq, vp, vq), 4.5_rp, 1.0e-14_rp, 0.0_rp, 'linear hand power')

  ! ---- action = reaction: the kernel seen from q gives -f_p -------------
  xp = [0.3_rp, -1.1_rp, 0.7_rp]; xq = [1.2_rp, 0.4_rp, -0.2_rp]
  vp = [0.5_rp, -0.2_rp, 0.9_rp]; vq = [-0.3_rp, 0.8_rp, 0.1_rp]
  d0 = [-1.0_rp, -1.0_rp, 0.5_rp]; L = norm2(d0); E = 3.0_rp; eta = 0.7_rp
  do model = AXIAL, LINEAR
    call link_force(model, E, eta, d0, L, xp, xq, vp, vq, f, ok)
    call link_force(model, E, eta, -d0, L, xq, xp, vq, vp, fq, ok)
    call check_close_array(f + fq, [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-14_rp*maxval(abs(f)), 'f_p + f_q = 0')
  end do

  ! ---- Jacobians against finite differences -----------------------------
  do model = AXIAL, LINEAR
    ! stretched, at rest
    call jac_case(model, [0.9_rp, 0.2_rp, -0.4_rp], [0.0_rp, 0.0_rp, 0.0_rp], 0.6_rp, 0.0_rp, 'stretched')
    ! compressed, at rest
    call jac_case(model, [0.3_rp, 0.2_rp, -0.1_rp], [0.0_rp, 0.0_rp, 0.0_rp], 0.6_rp, 0.0_rp, 'compressed')
    ! stretched, moving (relative velocity with axial and transverse parts)
    call jac_case(model, [0.9_rp, 0.2_rp, -0.4_rp], [0.4_rp, -1.3_rp, 0.8_rp], 0.6_rp, 0.35_rp, 'stretched moving')
    ! compressed, moving
    call jac_case(model, [0.3_rp, 0.2_rp, -0.1_rp], [-0.7_rp, 0.5_rp, 1.1_rp], 0.6_rp, 0.35_rp, 'compressed moving')
  end do

  ! ---- clamp: equal to exact in tension, exact + E(1-L/l) Q in compression
  xq = [0.1_rp, -0.2_rp, 0.3_rp]; vp = [0.4_rp, -1.3_rp, 0.8_rp]; vq = 0.0_rp
  E = 2.5_rp; eta = 0.35_rp; L = 0.6_rp; d0 = [0.6_rp, 0.0_rp, 0.0_rp]
  xp = xq + [0.9_rp, 0.2_rp, -0.4_rp]
  call link_jacobian(AXIAL, E, eta, d0, L, xp, xq, vp, vq, .false., K, C, ok)
  call link_jacobian(AXIAL, E, eta, d0, L, xp, xq, vp, vq, .true., Kc, C, ok)
  call check_close_array(reshape(Kc, [9]), reshape(K, [9]), 1.0e-15_rp, 0.0_rp, 'clamp == exact in tension')
  xp = xq + [0.3_rp, 0.2_rp, -0.1_rp]
  call link_jacobian(AXIAL, E, eta, d0, L, xp, xq, vp, vq, .false., K, C, ok)
  call link_jacobian(AXIAL, E, eta, d0, L, xp, xq, vp, vq, .true., Kc, C, ok)
  ln = norm2(xp - xq); n = (xp - xq)/ln
  Q = -spread(n, 2, 3)*spread(n, 1, 3)
  do i = 1, 3
    Q(i,i) = Q(i,i) + 1.0_rp
  end do
  call check_true(ln < L, 'compressed case is compressed')
  call check_close_array(reshape(Kc - K, [9]), reshape(E*(1.0_rp - L/ln)*Q, [9]), 1.0e-12_rp, 1.0e-14_rp, &
    'clamp - exact = E(1-L/l)Q in compression')
  call check_true(maxval(abs(Kc - K)) > 0.1_rp, 'clamp differs from exact in compression')

  ! ---- energy: -dW/dxp == force (eta = 0); power = -f_damping.(vp-vq) -----
  xq = [0.1_rp, -0.2_rp, 0.3_rp]; xp = [1.0_rp, 0.3_rp, -0.5_rp]
  vp = [0.4_rp, -1.3_rp, 0.8_rp]; vq = [-0.2_rp, 0.1_rp, 0.6_rp]
  d0 = [0.5_rp, 0.3_rp, -0.2_rp]; L = norm2(d0); E = 2.5_rp; eta = 0.35_rp
  do model = AXIAL, LINEAR
    call link_force(model, E, 0.0_rp, d0, L, xp, xq, vp, vq, f0, ok)
    call check_close_array(-grad_energy(model), f0, 1.0e-8_rp, 0.0_rp, 'force = -dW/dxp')
    call link_force(model, E, eta, d0, L, xp, xq, vp, vq, f, ok)
    call check_close(link_power(model, eta, xp, xq, vp, vq), -dot_product(f - f0, vp - vq), &
      1.0e-13_rp, 1.0e-15_rp, 'power = -f_damping.(vp-vq)')
    call check_true(link_power(model, eta, xp, xq, vp, vq) > 0.0_rp, 'power positive')
  end do

  ! ---- degenerate links -------------------------------------------------
  xp = xq
  call link_force(AXIAL, E, eta, d0, L, xp, xq, vp, vq, f, ok)
  call check_true(.not. ok .and. all(f == 0.0_rp), 'zero-length axial link: not ok, f = 0')
  call link_jacobian(AXIAL, E, eta, d0, L, xp, xq, vp, vq, .false., K, C, ok)
  call check_true(.not. ok .and. all(K == 0.0_rp) .and. all(C == 0.0_rp), 'zero-length axial Jacobian: not ok, 0')
  call check_true(link_power(AXIAL, eta, xp, xq, vp, vq) == 0.0_rp, 'zero-length axial power 0')
  call link_force(LINEAR, E, eta, d0, L, xp, xq, vp, vq, f, ok)
  call check_true(ok, 'zero-length linear link is fine')
  call link_force(7, E, eta, d0, L, xp, xq, vp, vq, f, ok)
  call check_true(.not. ok, 'unknown model: not ok')

  call lanes_checks()
  call force_lanes_checks()
  call power_lanes_checks()

  call check_report()

contains

  ! link_jacobian_lanes on 9 links in arrays with room for 12 (lanes beyond
  ! n untouched): stretched, compressed (clamped or not), a zero-length
  ! one, each model; every lane equal to link_jacobian up to round-off.
  subroutine lanes_checks()
    integer, parameter :: LD = 12, N = 9
    real(rp) :: dl(LD, 3), vl(LD, 3), el(LD), etal(LD), kl(LD, 3, 3), cl(LD, 3, 3), ks(3, 3), cs(3, 3)
    real(rp) :: zero(3)
    logical :: okl(LD), oks, cl_on
    integer :: l, m, pass
    character(len=48) :: tag
    zero = 0.0_rp
    call lane_data(N, dl, vl, el, etal)
    do pass = 1, 4
      m = merge(AXIAL, LINEAR, pass <= 2)
      cl_on = mod(pass, 2) == 0
      kl = -7.0_rp
      cl = -7.0_rp
      call link_jacobian_lanes(N, LD, m, el, etal, 1.5_rp, dl, vl, cl_on, kl, cl, okl)
      do l = 1, N
        write(tag, '(a,i0,a,i0,a)') ' (lanes: pass ', pass, ', lane ', l, ')'
        call link_jacobian(m, el(l), etal(l), zero, 1.5_rp, dl(l, :), zero, vl(l, :), zero, cl_on, ks, cs, oks)
        call check_true(okl(l) .eqv. oks, 'ok'//trim(tag))
        call check_close_array(reshape(kl(l, :, :), [9]), reshape(ks, [9]), 1.0e-13_rp, 1.0e-300_rp, 'K'//trim(tag))
        call check_close_array(reshape(cl(l, :, :), [9]), reshape(cs, [9]), 1.0e-13_rp, 1.0e-300_rp, 'C'//trim(tag))
      end do
      call check_true(all(kl(N + 1:, :, :) == -7.0_rp) .and. all(cl(N + 1:, :, :) == -7.0_rp), 'lanes beyond n untouched')
      if (m == AXIAL) call check_true(.not. okl(5) .and. count(okl(1:N)) == N - 1, 'lanes: the zero-length axial link found')
    end do
  end subroutine lanes_checks

  ! The links of the lane tests: n of them, stretched and compressed, lane 5
  ! of zero length.
  subroutine lane_data(n, dl, vl, el, etal)
    integer, intent(in) :: n
    real(rp), intent(out) :: dl(:, :), vl(:, :), el(:), etal(:)
    integer :: l, c
    do l = 1, n
      dl(l, :) = [(cos(0.7_rp*real(l*c, rp)) * (0.3_rp + 0.25_rp*l), c = 1, 3)]
      vl(l, :) = [(sin(0.37_rp*real(l + c, rp)), c = 1, 3)]
      el(l) = 3.0_rp + l
      etal(l) = 0.1_rp*l
    end do
    dl(5, :) = 0.0_rp
  end subroutine lane_data

  ! link_force_lanes on 9 links in arrays with room for 12 (lanes beyond n
  ! untouched): stretched, compressed, a zero-length one, each model, with a
  ! rest vector d0 (the linear model's); every lane equal to link_force up
  ! to round-off, the zero-length axial link reported with no force.
  subroutine force_lanes_checks()
    integer, parameter :: LD = 12, N = 9
    real(rp) :: dl(LD, 3), vl(LD, 3), el(LD), etal(LD), fl(LD, 3), fs(3), zero(3), d0(3)
    logical :: okl(LD), oks
    integer :: l, m, pass
    character(len=48) :: tag
    zero = 0.0_rp
    d0 = [0.9_rp, -0.6_rp, 0.9_rp]
    call lane_data(N, dl, vl, el, etal)
    do pass = 1, 2
      m = merge(AXIAL, LINEAR, pass == 1)
      fl = -7.0_rp
      call link_force_lanes(N, LD, m, el, etal, d0, 1.5_rp, dl, vl, fl, okl)
      do l = 1, N
        write(tag, '(a,i0,a,i0,a)') ' (force lanes: pass ', pass, ', lane ', l, ')'
        call link_force(m, el(l), etal(l), d0, 1.5_rp, dl(l, :), zero, vl(l, :), zero, fs, oks)
        call check_true(okl(l) .eqv. oks, 'ok'//trim(tag))
        call check_close_array(fl(l, :), fs, 1.0e-13_rp, 1.0e-300_rp, 'f'//trim(tag))
      end do
      call check_true(all(fl(N + 1:, :) == -7.0_rp), 'force lanes beyond n untouched')
      if (m == AXIAL) call check_true(.not. okl(5) .and. count(okl(1:N)) == N - 1 .and. all(fl(5, :) == 0.0_rp), &
                                      'force lanes: the zero-length axial link found, no force')
    end do
  end subroutine force_lanes_checks

  ! link_power_lanes on 9 links in arrays with room for 12 (lanes beyond n
  ! untouched), each model: every lane equal to link_power up to round-off,
  ! the zero-length axial link with no power.
  subroutine power_lanes_checks()
    integer, parameter :: LD = 12, N = 9
    real(rp) :: dl(LD, 3), vl(LD, 3), el(LD), etal(LD), pl(LD), zero(3)
    integer :: l, m, pass
    character(len=48) :: tag
    zero = 0.0_rp
    call lane_data(N, dl, vl, el, etal)
    do pass = 1, 2
      m = merge(AXIAL, LINEAR, pass == 1)
      pl = -7.0_rp
      call link_power_lanes(N, LD, m, etal, dl, vl, pl)
      do l = 1, N
        write(tag, '(a,i0,a,i0,a)') ' (power lanes: pass ', pass, ', lane ', l, ')'
        call check_close(pl(l), link_power(m, etal(l), dl(l, :), zero, vl(l, :), zero), 1.0e-13_rp, 1.0e-300_rp, &
                         'power'//trim(tag))
      end do
      call check_true(all(pl(N + 1:) == -7.0_rp), 'power lanes beyond n untouched')
      if (m == AXIAL) call check_true(pl(5) == 0.0_rp, 'power lanes: the zero-length axial link dissipates nothing')
      if (m == LINEAR) call check_true(pl(5) > 0.0_rp, 'power lanes: the zero-length linear link dissipates')
    end do
  end subroutine power_lanes_checks

  ! Compare K = df_p/dx_p, -K = df_p/dx_q, C = df_p/dv_p, -C = df_p/dv_q with
  ! central differences of link_force, for d = xp - xq and vr = vp - vq.
  subroutine jac_case(model, d, vr, L, eta, what)
    integer, intent(in) :: model
    real(rp), intent(in) :: d(3), vr(3), L, eta
    character(*), intent(in) :: what
    real(rp) :: xp(3), xq(3), vp(3), vq(3), d0(3), K(3,3), C(3,3), Kfd(3,3), Cfd(3,3), Kq(3,3), Cq(3,3)
    real(rp) :: fplus(3), fminus(3), h
    real(rp), parameter :: E = 2.5_rp
    logical :: ok
    integer :: j
    character(16) :: mname

    mname = merge('axial ', 'linear', model == AXIAL)
    xq = [0.1_rp, -0.2_rp, 0.3_rp]; xp = xq + d
    vq = [0.2_rp, 0.1_rp, -0.3_rp]; vp = vq + vr
    d0 = L*[0.6_rp, 0.0_rp, 0.8_rp]
    h = 1.0e-6_rp
    call link_jacobian(model, E, eta, d0, L, xp, xq, vp, vq, .false., K, C, ok)
    call check_true(ok, trim(mname)//' '//what//' jacobian ok')
    do j = 1, 3
      xp(j) = xp(j) + h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fplus, ok)
      xp(j) = xp(j) - 2*h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fminus, ok)
      xp(j) = xp(j) + h
      Kfd(:,j) = (fplus - fminus)/(2*h)
      xq(j) = xq(j) + h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fplus, ok)
      xq(j) = xq(j) - 2*h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fminus, ok)
      xq(j) = xq(j) + h
      Kq(:,j) = (fplus - fminus)/(2*h)
      vp(j) = vp(j) + h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fplus, ok)
      vp(j) = vp(j) - 2*h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fminus, ok)
      vp(j) = vp(j) + h
      Cfd(:,j) = (fplus - fminus)/(2*h)
      vq(j) = vq(j) + h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fplus, ok)
      vq(j) = vq(j) - 2*h; call link_force(model, E, eta, d0, L, xp, xq, vp, vq, fminus, ok)
      vq(j) = vq(j) + h
      Cq(:,j) = (fplus - fminus)/(2*h)
    end do
    call check_close_array(reshape(K, [9]), reshape(Kfd, [9]), 1.0e-6_rp, 1.0e-9_rp, trim(mname)//' '//what//' K vs FD')
    call check_close_array(reshape(-K, [9]), reshape(Kq, [9]), 1.0e-6_rp, 1.0e-9_rp, trim(mname)//' '//what//' -K vs FD x_q')
    call check_close_array(reshape(C, [9]), reshape(Cfd, [9]), 1.0e-6_rp, 1.0e-9_rp, trim(mname)//' '//what//' C vs FD')
    call check_close_array(reshape(-C, [9]), reshape(Cq, [9]), 1.0e-6_rp, 1.0e-9_rp, trim(mname)//' '//what//' -C vs FD v_q')
  end subroutine jac_case

  ! Central-difference gradient of link_energy with respect to xp (host xp, xq, d0, L, E).
  function grad_energy(model) result(g)
    integer, intent(in) :: model
    real(rp) :: g(3), x(3)
    real(rp), parameter :: h = 1.0e-6_rp
    integer :: j
    do j = 1, 3
      x = xp; x(j) = x(j) + h
      g(j) = link_energy(model, E, d0, L, x, xq)
      x(j) = x(j) - 2*h
      g(j) = (g(j) - link_energy(model, E, d0, L, x, xq))/(2*h)
    end do
  end function grad_energy

end program test_springs
