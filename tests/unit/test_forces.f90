! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module forces' element loops on a small randomly perturbed
!> lattice (the kernels alone are tested in test_springs and
!> test_bending_energy; this tests the loops over a strip that gather them):
!> - internal_forces at rest velocities is minus the gradient of the total
!>   energy of element_energies (stretch + bending), by central differences
!>   of every node coordinate, for axial and linear links, without bending
!>   and with the energy model, element and continuum scaling;
!> - dissipated_power is the power the damping forces take out,
!>   -sum (f(x, v) - f(x, 0)) . v, the damping being linear in v;
!> - the internal forces sum to zero (action and reaction), and their torque
!>   about the origin is zero for the rotation-invariant elements (axial
!>   links, energy bending).
!> The paper bending force is not the gradient of an energy (the report's
!> model: no force on the middle node) and is left to test_bending_paper.
program test_forces
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE, BEND_ENERGY, SPRING_AXIAL, SPRING_LINEAR, &
                    SCALING_ELEMENT, SCALING_CONTINUUM
  use lattice, only: lattice_t, lattice_init
  use forces, only: internal_forces, element_energies, dissipated_power
  use check, only: check_true, check_close, check_close_array, check_report, lattice_config, seed_random, perturbed_state
  implicit none

  integer, parameter :: nx = 6, ny = 7

  call one(SPRING_AXIAL, BEND_NONE, SCALING_ELEMENT, 'axial links')
  call one(SPRING_LINEAR, BEND_NONE, SCALING_ELEMENT, 'linear links')
  call one(SPRING_AXIAL, BEND_ENERGY, SCALING_ELEMENT, 'axial links, energy bending')
  call one(SPRING_AXIAL, BEND_ENERGY, SCALING_CONTINUUM, 'axial links, energy bending, continuum')
  call one(SPRING_LINEAR, BEND_ENERGY, SCALING_CONTINUUM, 'linear links, energy bending, continuum')
  call check_report()

contains

  subroutine one(spring, bending, scaling, what)
    integer, intent(in) :: spring, bending, scaling
    character(*), intent(in) :: what
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    real(rp) :: u(0:5, 0:nx - 1, 0:ny - 1), up(0:5, 0:nx - 1, 0:ny - 1), noise(3, 0:nx - 1, 0:ny - 1)
    real(rp) :: f(3, 0:nx - 1, 0:ny - 1), fv(3, 0:nx - 1, 0:ny - 1), grad(3, 0:nx - 1, 0:ny - 1)
    real(rp) :: h, ep, em, s, b, power, fscale, torque(3)
    integer :: i, j, c, nbad, bad(2)

    cfg = lattice_config(nx, ny, 1.0_rp, 1.5_rp, 0.1_rp, 100.0_rp, 60.0_rp, 0.1_rp, bending, spring, scaling)
    call lattice_init(lat, cfg, 0, ny - 1)
    call seed_random(4711)
    call perturbed_state(lat, 0.2_rp * cfg%lattice%ax, u)

    ! forces against the central difference of the energy
    call internal_forces(lat, u, f, nbad, bad)
    call check_true(nbad == 0, what//': a regular state')
    h = 1.0e-5_rp * cfg%lattice%ax
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 0, 2
          up = u
          up(c, i, j) = u(c, i, j) + h
          call element_energies(lat, up, s, b)
          ep = s + b
          up(c, i, j) = u(c, i, j) - h
          call element_energies(lat, up, s, b)
          em = s + b
          grad(c + 1, i, j) = (ep - em) / (2.0_rp * h)
        end do
      end do
    end do
    call check_close_array(reshape(f, [3 * nx * ny]), reshape(-grad, [3 * nx * ny]), 1.0e-8_rp, 0.0_rp, &
                           what//': f = -dE/dx')
    fscale = maxval(abs(f))
    call check_true(fscale > 0.0_rp, what//': strained')
    call check_true(all(abs(sum(sum(f, 3), 2)) <= 1.0e-13_rp * fscale * nx * ny), what//': forces sum to zero')
    if (spring == SPRING_AXIAL) then
      torque = 0.0_rp
      do j = 0, ny - 1
        do i = 0, nx - 1
          torque = torque + [u(1, i, j) * f(3, i, j) - u(2, i, j) * f(2, i, j), &
                             u(2, i, j) * f(1, i, j) - u(0, i, j) * f(3, i, j), &
                             u(0, i, j) * f(2, i, j) - u(1, i, j) * f(1, i, j)]
        end do
      end do
      call check_true(all(abs(torque) <= 1.0e-13_rp * fscale * nx * ny * cfg%lattice%ly), what//': zero torque')
    end if

    ! damping: the power the damping forces take out
    cfg%material%eta_s = 0.3_rp
    cfg%material%eta_d = 0.2_rp
    if (bending == BEND_ENERGY) cfg%material%eta_b = 1.0e-3_rp
    call lattice_init(lat, cfg, 0, ny - 1)
    call internal_forces(lat, u, f, nbad, bad)
    call random_number(noise)
    u(3:5, :, :) = 2.0_rp * noise - 1.0_rp
    call internal_forces(lat, u, fv, nbad, bad)
    call dissipated_power(lat, u, power)
    call check_true(power > 0.0_rp, what//': damped')
    call check_close(power, -sum((fv - f) * u(3:5, :, :)), 1.0e-12_rp, 0.0_rp, &
                     what//': dissipated power = -(f(x, v) - f(x, 0)) . v')
  end subroutine one

end program test_forces
