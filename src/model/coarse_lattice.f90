! SPDX-License-Identifier: BSD-2-Clause
!> The cloth on a lattice coarsened by 2 (every other node), for the
!> multigrid's rediscretised coarse levels (module mg_coarse; issue 46):
!> the same cloth, so that its S, assembled by the same element kernels
!> (module reduced_assembly), is a coarse operator of the finest one's
!> reach and storage shape with a consistent fourth-order (bending) part,
!> which the Galerkin product of bilinear transfers is not
!> (docs/performance.md, "The multigrid with bending"). No PETSc, no MPI.
!>
!> The coarse lattice itself is built by module lattice (lattice_coarsened,
!> the lattice's only builder); this module gives it its masses and state.
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
  use lattice, only: lattice_t
  implicit none
  private
  public :: mass_factors, restrict_factors, inject_rows, restrict_offset_blocks

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

  !> The Galerkin product P^T B P of blocks B between a node and its
  !> stencil neighbours (offsets -1..1: the faces' contact, module
  !> node_blocks), P the bilinear interpolation from the coarse lattice:
  !> coarse row jc's blocks for jc = j0..j1 (the rest of dst untouched),
  !> dst(:, dI, dJ, I, J) = sum over fine a, b of w_I,J(a) B(a, b)
  !> w_I+dI,J+dJ(b), w the bilinear weights (1, 1/2 at the fine nodes
  !> between), from the fine rows src(:, di, dj, i, j) (18 values: kx
  !> 1:9, kv 10:18) of rows sys..sye (2 jc - 1 .. 2 jc + 1 where they lie
  !> in the lattice). The coarse offsets stay within -1..1 (a fine
  !> neighbour pair's coarse parents are at most one coarse node apart).
  !> A barrier across an element, stiff along a combination of the
  !> element's nodes, so reaches every coarse mode whose interpolant moves
  !> that combination, and only those, where its row sums (lumped) reach
  !> every mode that moves the node.
  pure subroutine restrict_offset_blocks(nxs, sys, sye, src, nxc, nyc, dys, dye, j0, j1, dst)
    integer, intent(in) :: nxs, sys, sye               !< src's columns 0..nxs-1 and rows
    real(rp), intent(in) :: src(18, -1:1, -1:1, 0:nxs - 1, sys:sye)
    integer, intent(in) :: nxc, nyc                    !< the coarse lattice's nodes a side
    integer, intent(in) :: dys, dye, j0, j1            !< dst's rows; the rows to make
    real(rp), intent(inout) :: dst(18, -1:1, -1:1, 0:nxc - 1, dys:dye)
    integer :: ic, jc, ia, jb, di, dj, bi, bj, ci, cj
    real(rp) :: wa, wab
    dst(:, :, :, :, j0:j1) = 0.0_rp
    do jc = j0, j1
      do jb = max(2 * jc - 1, sys), min(2 * jc + 1, sye)
        do ic = 0, nxc - 1
          do ia = max(2 * ic - 1, 0), min(2 * ic + 1, nxs - 1)
            wa = (1.0_rp - 0.5_rp * abs(ia - 2 * ic)) * (1.0_rp - 0.5_rp * abs(jb - 2 * jc))
            do dj = -1, 1
              do di = -1, 1
                if (all(src(:, di, dj, ia, jb) == 0.0_rp)) cycle
                bi = ia + di
                bj = jb + dj
                ! the coarse parents of fine node (bi, bj): |b - 2 c| <= 1
                do cj = bj / 2, min((bj + 1) / 2, nyc - 1)
                  do ci = bi / 2, min((bi + 1) / 2, nxc - 1)
                    wab = wa * (1.0_rp - 0.5_rp * abs(bi - 2 * ci)) * (1.0_rp - 0.5_rp * abs(bj - 2 * cj))
                    dst(:, ci - ic, cj - jc, ic, jc) = dst(:, ci - ic, cj - jc, ic, jc) + wab * src(:, di, dj, ia, jb)
                  end do
                end do
              end do
            end do
          end do
        end do
      end do
    end do
  end subroutine restrict_offset_blocks

end module coarse_lattice
