! SPDX-License-Identifier: BSD-2-Clause
!> Minimal assertion helpers for the Fortran unit-test programs.
!> Each check prints one line on failure and counts it; check_report prints
!> 'N passed, N failed' and stops with a non-zero code if anything failed.
!> Also the set-up the element tests share: a small lattice's configuration
!> and a reproducible, randomly perturbed state of it.
module check
  use, intrinsic :: iso_fortran_env, only: real64, output_unit
  use kinds, only: rp
  use config, only: nuno_config, MASS_UNIFORM
  use lattice, only: lattice_t, rest_position
  implicit none
  private
  public :: check_true, check_close, check_close_array, check_report
  public :: lattice_config, seed_random, perturbed_state, rotation
  integer, save :: n_pass = 0, n_fail = 0
contains
  !> Record a logical condition.
  subroutine check_true(cond, what)
    logical, intent(in) :: cond
    character(*), intent(in) :: what
    if (cond) then
      n_pass = n_pass + 1
    else
      n_fail = n_fail + 1
      write(output_unit, '(a)') 'FAIL: '//what
    end if
  end subroutine check_true

  !> |a - b| <= atol + rtol*|b|
  subroutine check_close(a, b, rtol, atol, what)
    real(real64), intent(in) :: a, b, rtol, atol
    character(*), intent(in) :: what
    if (abs(a - b) <= atol + rtol*abs(b) .and. a == a) then
      n_pass = n_pass + 1
    else
      n_fail = n_fail + 1
      write(output_unit, '(a,es24.16,a,es24.16)') 'FAIL: '//what//': got ', a, ' expected ', b
    end if
  end subroutine check_close

  !> max|a - b| <= atol + rtol*max|b| over all entries
  subroutine check_close_array(a, b, rtol, atol, what)
    real(real64), intent(in) :: a(:), b(:)
    real(real64), intent(in) :: rtol, atol
    character(*), intent(in) :: what
    real(real64) :: err, scale
    err = maxval(abs(a - b))
    scale = maxval(abs(b))
    if (size(a) == size(b) .and. err <= atol + rtol*scale .and. all(a == a)) then
      n_pass = n_pass + 1
    else
      n_fail = n_fail + 1
      write(output_unit, '(a,es12.4,a,es12.4)') 'FAIL: '//what//': max error ', err, ' scale ', scale
    end if
  end subroutine check_close_array

  !> Print the closing line and stop non-zero on any failure.
  subroutine check_report()
    write(output_unit, '(i0,a,i0,a)') n_pass, ' passed, ', n_fail, ' failed'
    if (n_fail > 0) error stop 1
  end subroutine check_report

  !> A test lattice: nx x ny nodes over lx x ly, the given element models
  !> (config's codes), total mass and stiffnesses, undamped (eta_s, eta_d,
  !> eta_b zero), uniform masses.
  function lattice_config(nx, ny, lx, ly, total_mass, e_s, e_d, k_b, bending, spring, scaling) result(cfg)
    integer, intent(in) :: nx, ny, bending, spring, scaling
    real(rp), intent(in) :: lx, ly, total_mass, e_s, e_d, k_b
    type(nuno_config) :: cfg
    cfg%lattice%nx = nx
    cfg%lattice%ny = ny
    cfg%lattice%lx = lx
    cfg%lattice%ly = ly
    cfg%lattice%ax = lx / (nx - 1)
    cfg%lattice%ay = ly / (ny - 1)
    cfg%lattice%total_mass = total_mass
    cfg%material%e_s = e_s
    cfg%material%eta_s = 0.0_rp
    cfg%material%e_d = e_d
    cfg%material%eta_d = 0.0_rp
    cfg%material%k_b = k_b
    cfg%material%eta_b = 0.0_rp
    cfg%material%bending_code = bending
    cfg%material%spring_code = spring
    cfg%lattice%scaling_code = scaling
    cfg%lattice%mass_code = MASS_UNIFORM
  end function lattice_config

  !> The same pseudo-random numbers at every run: the generator seeded
  !> from base.
  subroutine seed_random(base)
    integer, intent(in) :: base
    integer :: n, i
    integer, allocatable :: seed(:)
    call random_seed(size=n)
    allocate(seed(n))
    seed = base + 37 * [(i, i = 1, n)]
    call random_seed(put=seed)
  end subroutine seed_random

  !> A strained state of lat's rows gys..gye at rest velocity: each
  !> coordinate of each node moved from its rest position by a uniform
  !> pseudo-random amount in [-amp, amp] [length] (the generator as it
  !> stands: seed it first for the same state at every run).
  subroutine perturbed_state(lat, amp, u)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: amp
    real(rp), intent(out) :: u(0:, 0:, lat%gys:)   !< (0:5, 0:nx-1, gys:gye)
    real(rp) :: noise(3, 0:lat%nx - 1, lat%gys:lat%gye)
    integer :: i, j
    call random_number(noise)
    do j = lat%gys, lat%gye
      do i = 0, lat%nx - 1
        u(0:2, i, j) = rest_position(lat, i, j) + amp * (2.0_rp * noise(:, i, j) - 1.0_rp)
        u(3:5, i, j) = 0.0_rp
      end do
    end do
  end subroutine perturbed_state

  !> The element tests' orientations: a Rodrigues rotation about an oblique
  !> unit axis; io = 1 gives the identity, 2 and 3 two rotations.
  function rotation(io) result(r)
    integer, intent(in) :: io
    real(rp) :: r(3,3), k(3), kx(3,3), ang
    integer :: i
    select case (io)
    case (2)
      k = [0.3_rp, -0.5_rp, 0.8_rp]; ang = 0.9_rp
    case (3)
      k = [-0.7_rp, 0.2_rp, 0.4_rp]; ang = 2.1_rp
    case default
      k = [0.0_rp, 0.0_rp, 1.0_rp]; ang = 0.0_rp
    end select
    k = k/norm2(k)
    kx = reshape([0.0_rp, k(3), -k(2), -k(3), 0.0_rp, k(1), k(2), -k(1), 0.0_rp], [3,3])
    r = sin(ang)*kx + (1.0_rp - cos(ang))*matmul(kx, kx)
    do i = 1, 3
      r(i,i) = r(i,i) + 1.0_rp
    end do
  end function rotation
end module check
