! SPDX-License-Identifier: BSD-2-Clause
!> The cloth on a lattice coarsened by 2 (every other node), for the
!> multigrid's rediscretised coarse levels (module mg_coarse; issue 46):
!> the same cloth, so that its S, assembled by the same element kernels
!> (module reduced_assembly), is a coarse operator of the finest one's
!> reach and storage shape with a consistent fourth-order (bending) part,
!> which the Galerkin product of bilinear transfers is not
!> (docs/performance.md, "Why the cycles grew with N"). No PETSc, no MPI.
!>
!> Constants from the consistency of the energy of a smooth field on the
!> two lattices: the total mass kept, every coarse node's mass the sum of
!> the finer masses with the bilinear weights (exactly the area masses of
!> the coarse spacing; for uniform masses, 2 in the interior and 1.5 at the
!> ends along each direction); link E and eta unchanged (a square
!> lattice's spring constant is resolution-independent in 2-D); energy
!> bending k_b and eta_b unchanged (|kb| ~ h x curvature, triples ~ 1/h^2);
!> the paper model's k_b, a force per radian whose stiffness is k_b / h,
!> halved. Under lattice_scaling = 'continuum' the lattice derives its
!> per-element values from the material ones at its own spacing (module
!> lattice), which is the same rule.
module coarse_lattice
  use kinds, only: rp
  use config, only: BEND_PAPER
  use lattice, only: lattice_t
  implicit none
  private
  public :: coarse_lattice_init, mass_factors, restrict_factors, inject_rows

contains

  !> The 1-D factors of the masses of lattice lat, m(i, j) = scale mx(i)
  !> my(j) (module lattice's node_mass: area masses and uniform ones are
  !> both products of a factor along x and one along y), over the whole
  !> lattice: mx(0:nx-1), my(0:ny-1).
  subroutine mass_factors(lat, mx, my, scale)
    type(lattice_t), intent(in) :: lat
    real(rp), allocatable, intent(out) :: mx(:), my(:)
    real(rp), intent(out) :: scale
    allocate(mx(0:lat%nx - 1), my(0:lat%ny - 1))
    if (lat%area_mass) then
      mx = lat%ax
      mx(0) = 0.5_rp * lat%ax
      mx(lat%nx - 1) = 0.5_rp * lat%ax
      my = lat%ay
      my(0) = 0.5_rp * lat%ay
      my(lat%ny - 1) = 0.5_rp * lat%ay
      scale = lat%total_mass / (lat%lx * lat%ly)
    else
      mx = 1.0_rp
      my = 1.0_rp
      scale = lat%total_mass / real(lat%nx * lat%ny, rp)
    end if
  end subroutine mass_factors

  !> A 1-D factor f(0:n-1) (n odd) summed onto every other point with the
  !> bilinear weights (1/2, 1, 1/2): c(0:(n-1)/2). The sum of c is the sum
  !> of f.
  pure subroutine restrict_factors(f, c)
    real(rp), intent(in) :: f(0:)
    real(rp), intent(out) :: c(0:)
    integer :: k, n
    n = size(f)
    do k = 0, size(c) - 1
      c(k) = f(2 * k)
      if (2 * k - 1 >= 0) c(k) = c(k) + 0.5_rp * f(2 * k - 1)
      if (2 * k + 1 <= n - 1) c(k) = c(k) + 0.5_rp * f(2 * k + 1)
    end do
  end subroutine restrict_factors

  !> The lattice coarsened by 2 from fine (nx - 1 and ny - 1 even), rows
  !> ys..ye of it on this rank (the ghost rows as fine's halo), its masses
  !> scale mx(i) my(j) (the coarse factors: restrict_factors of the fine
  !> ones). What the element kernels read: sizes, spacings, models and
  !> constants, masses.
  subroutine coarse_lattice_init(fine, lat, ys, ye, mx, my, scale)
    type(lattice_t), intent(in) :: fine
    type(lattice_t), intent(out) :: lat
    integer, intent(in) :: ys, ye
    real(rp), intent(in) :: mx(0:), my(0:), scale
    integer :: i, j
    lat%nx = (fine%nx - 1) / 2 + 1
    lat%ny = (fine%ny - 1) / 2 + 1
    lat%ys = ys
    lat%ye = ye
    lat%halo = fine%halo
    lat%gys = max(0, ys - lat%halo)
    lat%gye = min(lat%ny - 1, ye + lat%halo)
    lat%ax = 2.0_rp * fine%ax
    lat%ay = 2.0_rp * fine%ay
    lat%spring_model = fine%spring_model
    lat%bending_model = fine%bending_model
    lat%continuum = fine%continuum
    lat%e_s = fine%e_s
    lat%eta_s = fine%eta_s
    lat%e_d = fine%e_d
    lat%eta_d = fine%eta_d
    lat%k_b = fine%k_b
    lat%eta_b = fine%eta_b
    ! the paper model's force per radian: its stiffness k_b / h kept
    ! (no continuum mode for it: input_checks rejects the pair)
    if (fine%bending_model == BEND_PAPER .and. .not. fine%continuum) lat%k_b = 0.5_rp * fine%k_b
    lat%total_mass = fine%total_mass
    lat%lx = fine%lx
    lat%ly = fine%ly
    lat%area_mass = fine%area_mass
    allocate(lat%mass(0:lat%nx - 1, lat%gys:lat%gye))
    do j = lat%gys, lat%gye
      do i = 0, lat%nx - 1
        lat%mass(i, j) = scale * mx(i) * my(j)
      end do
    end do
  end subroutine coarse_lattice_init

  !> The rows jc0..jc1 of a coarse state uc(0:ncomp-1, 0:nxc-1, rows) from
  !> the fine uf(0:ncomp-1, 0:nxf-1, rows): node (i, j) of the lattice
  !> coarsened stride times (stride a power of 2) is fine node
  !> (stride i, stride j), which row jf0 + ... of uf holds (uf's first
  !> row is jf0).
  pure subroutine inject_rows(stride, uf, jf0, uc, jc_first, jc0, jc1)
    integer, intent(in) :: stride, jf0, jc_first, jc0, jc1
    real(rp), intent(in) :: uf(0:, 0:, jf0:)
    real(rp), intent(inout) :: uc(0:, 0:, jc_first:)
    integer :: i, j
    do j = jc0, jc1
      do i = 0, size(uc, 2) - 1
        uc(:, i, j) = uf(:, stride * i, stride * j)
      end do
    end do
  end subroutine inject_rows

end module coarse_lattice
