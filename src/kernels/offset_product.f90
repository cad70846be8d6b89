! SPDX-License-Identifier: BSD-2-Clause
!> S stored by stencil offset, nodes fastest, in double precision: the
!> layout the assembly writes (module reduced_assembly), the product
!> y = S x the Krylov method uses in double precision (module reduced_mg,
!> -nuno_mg_product double), and what the
!> multigrid's finest level is made from (module mg_kernels). Plain arrays;
!> no PETSc, no MPI (unit-tested alone: tests/unit/test_offset_product.f90).
!>
!> Only the offsets the elements couple are stored, the diagonal among
!> them: links to the eight neighbours and, at reach w = 2, bending triples
!> to the far ends along x, y and the diagonals (coupled_by_elements):
!> 9 blocks a node at w = 1, 17 at w = 2 (the eight
!> like (1, 2) of the 5 x 5 square are always zero and are not stored,
!> 576 bytes a node less to read in every product). Slot k of
!> st(i, :, :, k, j) = S(p, p + (di, dj)) counts the stored offsets in
!> lexicographic order, dj slowest (offset_slot); blocks pointing outside
!> the lattice are zero and never read. The nodes of a row are fastest
!> (not node by node, st(3, 3, k, i, j)): the
!> assembly's element kernels form their blocks for many nodes at once
!> (lanes), and the multigrid's finest level keeps its blocks so too, so
!> both write and read S in vector loops, without transposing.
!>
!> Why a product of its own: written over the PETSc arrays (pointers of
!> unknown stride) with the stencil bounds tested at every node, it ran at a
!> third of the memory bandwidth. Here the arrays are contiguous, and each
!> offset is one vector loop over the nodes of a row it reaches.
module offset_product
  use kinds, only: rp
  implicit none
  private
  public :: stencil_product, offset_count, offset_slot, offset_table, coupled_by_elements

  !> The stored offsets of reach 2 and 1, in slot order.
  integer, parameter :: ODI2(17) = [-2, 0, 2, -1, 0, 1, -2, -1, 0, 1, 2, -1, 0, 1, -2, 0, 2]
  integer, parameter :: ODJ2(17) = [-2, -2, -2, -1, -1, -1, 0, 0, 0, 0, 0, 1, 1, 1, 2, 2, 2]
  integer, parameter :: ODI1(9) = [-1, 0, 1, -1, 0, 1, -1, 0, 1]
  integer, parameter :: ODJ1(9) = [-1, -1, -1, 0, 0, 0, 1, 1, 1]

contains

  !> Offset (di, dj) couples two nodes through a link (|di|, |dj| <= 1) or
  !> through the ends of a bending triple along a lattice line (2 s, s one
  !> of (1, 0), (0, 1), (1, 1), (1, -1)).
  pure logical function coupled_by_elements(di, dj)
    integer, intent(in) :: di, dj
    coupled_by_elements = max(abs(di), abs(dj)) <= 1 .or. &
      (mod(di, 2) == 0 .and. mod(dj, 2) == 0 .and. max(abs(di), abs(dj)) == 2)
  end function coupled_by_elements

  !> Number of blocks stored a node at reach w (1 or 2).
  pure integer function offset_count(w)
    integer, intent(in) :: w
    offset_count = 8 * w + 1       ! 9 and 17
  end function offset_count

  !> Slot of offset (di, dj) at reach w; 0 when it is not stored.
  pure integer function offset_slot(w, di, dj) result(k)
    integer, intent(in) :: w, di, dj
    integer :: a, b
    k = 0
    if (max(abs(di), abs(dj)) > w .or. .not. coupled_by_elements(di, dj)) return
    do b = -w, w
      do a = -w, w
        if (coupled_by_elements(a, b)) k = k + 1
        if (a == di .and. b == dj) return
      end do
    end do
  end function offset_slot

  !> kof(di, dj) = offset_slot(w, di, dj) for the whole square of reach w.
  pure subroutine offset_table(w, kof)
    integer, intent(in) :: w
    integer, intent(out) :: kof(-w:w, -w:w)
    integer :: di, dj
    do dj = -w, w
      do di = -w, w
        kof(di, dj) = offset_slot(w, di, dj)
      end do
    end do
  end subroutine offset_table

  !> y(:, i, j) = sum over the stored offsets of st(i, :, :, k, j) x(:, i + di, j + dj)
  !> on the owned rows ys..ye of an nx x ny lattice; x holds rows gys..gye,
  !> gys <= max(0, ys - w), gye >= min(ny - 1, ye + w). w = 1 or 2. The
  !> offsets in slot order, each over the nodes whose neighbour along it
  !> lies in the lattice (the same sums in the same order, node by node, as
  !> when each node summed its offsets in turn).
  pure subroutine stencil_product(nx, ny, ys, ye, gys, gye, w, st, x, y)
    integer, intent(in) :: nx, ny, ys, ye, gys, gye, w
    real(rp), intent(in) :: st(0:nx - 1, 3, 3, 8 * w + 1, ys:ye)   !< offset_count(w) slots
    real(rp), intent(in) :: x(3, 0:nx - 1, gys:gye)
    real(rp), intent(out) :: y(3, 0:nx - 1, ys:ye)
    integer :: i, j, k, di, dj
    real(rp) :: x1, x2, x3
    do j = ys, ye
      y(:, :, j) = 0.0_rp
      do k = 1, offset_count(w)
        if (w == 1) then
          di = ODI1(k)
          dj = ODJ1(k)
        else
          di = ODI2(k)
          dj = ODJ2(k)
        end if
        if (j + dj < 0 .or. j + dj >= ny) cycle
        do i = max(0, -di), min(nx - 1, nx - 1 - di)
          x1 = x(1, i + di, j + dj)
          x2 = x(2, i + di, j + dj)
          x3 = x(3, i + di, j + dj)
          y(1, i, j) = y(1, i, j) + st(i, 1, 1, k, j) * x1 + st(i, 1, 2, k, j) * x2 + st(i, 1, 3, k, j) * x3
          y(2, i, j) = y(2, i, j) + st(i, 2, 1, k, j) * x1 + st(i, 2, 2, k, j) * x2 + st(i, 2, 3, k, j) * x3
          y(3, i, j) = y(3, i, j) + st(i, 3, 1, k, j) * x1 + st(i, 3, 2, k, j) * x2 + st(i, 3, 3, k, j) * x3
        end do
      end do
    end do
  end subroutine stencil_product

end module offset_product
