! SPDX-License-Identifier: BSD-2-Clause
!> Plain-array pieces of the reduced (Baraff-Witkin) solve, no PETSc, no MPI:
!> the block row of the 3-dof matrix S = a M - C - K/a of one node row, and
!> the product of the element Jacobian blocks of one row with a state-sized
!> vector (the matrix-free K w_x + C w_v that the elimination needs).
!>
!> The blocks come from the rolling buffer of module forces, which holds
!> k = -df/dx and c = -df/dv (no mass term), so that S = a m I + c + k/a.
!> Constrained nodes: their row of S is a m I (dv = b_v / a, exact), and
!> their columns are left out of the free rows (the known dv is moved to the
!> right-hand side), which keeps S symmetric whenever K and C are.
module reduced_blocks
  use kinds, only: rp
  use lattice, only: lattice_t, stencil_box
  use forces, only: jac_buffer_t, slot_of
  implicit none
  private
  public :: reduced_row_blocks, buffer_row_apply, csr_fits_block_row

contains

  !> Block row of S for node (i, j): blocks vals(3, 3, nc) (column-major
  !> 3 x 3, as MatSetValuesBlocked takes with MAT_ROW_ORIENTED false) at the
  !> ghosted local block columns cols(nc) = i' + (j' - gys) nx. Every block
  !> of the preallocated stencil is written (zeros included), so the matrix
  !> needs no zeroing between assemblies.
  pure subroutine reduced_row_blocks(buf, lat, fixedg, i, j, a, with_damping, vals, cols, nc)
    type(jac_buffer_t), intent(in) :: buf
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixedg(0:, lat%gys:)   !< (0:nx-1, gys:gye) constrained nodes
    integer, intent(in) :: i, j                   !< the node of the row (an owned row)
    real(rp), intent(in) :: a                     !< TS shift [1/time]
    logical, intent(in) :: with_damping           !< add the damping blocks c
    real(rp), intent(out) :: vals(:, :, :)        !< (3, 3, >= nc) [mass/time]
    integer, intent(out) :: cols(:)               !< (>= nc)
    integer, intent(out) :: nc
    integer :: di, dj, s, q, di0, di1, dj0, dj1
    real(rp) :: am, rinv

    s = slot_of(j)
    am = a * lat%mass(i, j)
    rinv = 1.0_rp / a
    nc = 0
    call stencil_box(lat, i, j, buf%w, di0, di1, dj0, dj1)
    do dj = dj0, dj1
      do di = di0, di1
        nc = nc + 1
        cols(nc) = (i + di) + (j + dj - lat%gys) * lat%nx
        if (fixedg(i, j) .or. fixedg(i + di, j + dj)) then
          vals(:, :, nc) = 0.0_rp
        else if (with_damping) then
          vals(:, :, nc) = buf%c(:, :, di, dj, i, s) + rinv * buf%k(:, :, di, dj, i, s)
        else
          vals(:, :, nc) = rinv * buf%k(:, :, di, dj, i, s)
        end if
        if (di == 0 .and. dj == 0) then
          do q = 1, 3
            vals(q, q, nc) = vals(q, q, nc) + am
          end do
        end if
      end do
    end do
  end subroutine reduced_row_blocks

  !> g(:, i) = sum over the stencil of k w_x + c w_v for every node i of row
  !> j: minus (K w_x + C w_v) restricted to row j, w(0:5, 0:nx-1, gys:gye).
  pure subroutine buffer_row_apply(buf, lat, w, j, with_damping, g)
    type(jac_buffer_t), intent(in) :: buf
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)   !< (0:5, 0:nx-1, gys:gye)
    integer, intent(in) :: j
    logical, intent(in) :: with_damping
    real(rp), intent(out) :: g(:, 0:)             !< (3, 0:nx-1) [force]
    integer :: i, di, dj, s, di0, di1, dj0, dj1, q
    real(rp) :: acc(3)

    s = slot_of(j)
    do i = 0, lat%nx - 1
      call stencil_box(lat, i, j, buf%w, di0, di1, dj0, dj1)
      acc = 0.0_rp
      do dj = dj0, dj1
        do di = di0, di1
          do q = 1, 3
            acc = acc + buf%k(:, q, di, dj, i, s) * w(q - 1, i + di, j + dj)
          end do
          ! w_v is zero on most nodes for a Newton right-hand side: skip those.
          if (with_damping .and. any(w(3:5, i + di, j + dj) /= 0.0_rp)) then
            do q = 1, 3
              acc = acc + buf%c(:, q, di, dj, i, s) * w(q + 2, i + di, j + dj)
            end do
          end if
        end do
      end do
      g(:, i) = acc
    end do
  end subroutine buffer_row_apply

  !> Does the assembled structure hold exactly this block row, in this order?
  !> Diagonal part: row lengths and the column indices (local, 3 per block:
  !> 3 lcol(n) + 0..2); off-diagonal part: row lengths and ascending columns.
  pure logical function csr_fits_block_row(nc, owned, lcol, row0, ia, ja, ib, jb) result(ok)
    integer, intent(in) :: nc
    logical, intent(in) :: owned(:)
    integer, intent(in) :: lcol(:)          !< (>= nc) local node of an owned column
    integer, intent(in) :: row0
    integer, intent(in) :: ia(0:), ja(0:), ib(0:), jb(0:)
    integer :: r, n, pa, na, nb, c
    na = count(owned(1:nc))
    nb = nc - na
    ok = .true.
    do r = 0, 2
      if (ia(row0 + r + 1) - ia(row0 + r) /= 3 * na) ok = .false.
      if (size(ib) > 0) then
        if (ib(row0 + r + 1) - ib(row0 + r) /= 3 * nb) ok = .false.
        if (ok .and. nb > 1) then
          if (any(jb(ib(row0 + r) + 1:ib(row0 + r + 1) - 1) <= jb(ib(row0 + r):ib(row0 + r + 1) - 2))) ok = .false.
        end if
      else if (nb > 0) then
        ok = .false.
      end if
      if (.not. ok) return
      pa = ia(row0 + r)
      do n = 1, nc
        if (.not. owned(n)) cycle
        do c = 0, 2
          if (ja(pa + c) /= 3 * lcol(n) + c) ok = .false.
        end do
        pa = pa + 3
      end do
    end do
  end function csr_fits_block_row

end module reduced_blocks
