! SPDX-License-Identifier: BSD-2-Clause
!> Where the blocks of S = a M - C - K/a stand in the CSR arrays of an AIJ
!> matrix on the DMDA of 1 x P strips, natural ordering (no PETSc, no MPI):
!> the owned node (i, j) has the scalar rows 3 lp + 0..2, lp = i + (j - ys)
!> nx. Its stencil blocks (i + di, j + dj), |di|, |dj| <= w, inside the
!> lattice, are stored in the order of (dj, di), in the diagonal part (av,
!> row starts ia) when row j + dj is owned, in the off-diagonal part (bv,
!> ib) otherwise; each block takes three consecutive columns of each of the
!> three rows. Module reduced checks once that the matrix has exactly this
!> layout; module reduced_assembly writes S into it.
module csr_layout
  use kinds, only: rp
  use lattice, only: lattice_t, stencil_box
  implicit none
  private
  public :: csr_block_pos, csr_row_blocks, csr_put_block_row, csr_add_block

contains

  !> Offsets pos(0:2) of the first entry of block (i + di, j + dj) in the
  !> three scalar rows of owned node (i, j); diag: in av (else in bv).
  pure subroutine csr_block_pos(lat, ia, ib, i, j, di, dj, pos, diag)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ia(0:), ib(0:)
    integer, intent(in) :: i, j, di, dj
    integer, intent(out) :: pos(0:2)
    logical, intent(out) :: diag
    integer :: di0, di1, dj0, dj1, ndi, ja0, ja1, r0, idx, r, below

    call stencil_box(lat, i, j, lat%halo, di0, di1, dj0, dj1)
    ndi = di1 - di0 + 1
    ja0 = max(dj0, lat%ys - j)                    ! owned rows of the stencil: ja0..ja1
    ja1 = min(dj1, lat%ye - j)
    r0 = 3 * (i + (j - lat%ys) * lat%nx)
    diag = dj >= ja0 .and. dj <= ja1
    if (diag) then
      idx = (dj - ja0) * ndi + (di - di0)
      do r = 0, 2
        pos(r) = ia(r0 + r) + 3 * idx
      end do
    else
      below = dj - dj0                            ! stencil rows before dj ...
      if (dj > ja1) below = below - (ja1 - ja0 + 1)   ! ... that are not owned
      idx = below * ndi + (di - di0)
      do r = 0, 2
        pos(r) = ib(r0 + r) + 3 * idx
      end do
    end if
  end subroutine csr_block_pos

  !> The block row of owned node (i, j) of an AIJ S in this layout, as full
  !> blocks blk(3, 3, -w:w, -w:w) = S(p, p + (di, dj)), zero outside the
  !> lattice (w = lat%halo).
  subroutine csr_row_blocks(lat, ia, av, ib, bv, i, j, blk)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(in) :: av(0:), bv(0:)
    integer, intent(in) :: i, j
    real(rp), intent(out) :: blk(:, :, -lat%halo:, -lat%halo:)
    integer :: di, dj, pos(0:2), r, di0, di1, dj0, dj1
    logical :: diag
    blk = 0.0_rp
    call stencil_box(lat, i, j, lat%halo, di0, di1, dj0, dj1)
    do dj = dj0, dj1
      do di = di0, di1
        call csr_block_pos(lat, ia, ib, i, j, di, dj, pos, diag)
        do r = 0, 2
          if (diag) then
            blk(r + 1, :, di, dj) = av(pos(r):pos(r) + 2)
          else
            blk(r + 1, :, di, dj) = bv(pos(r):pos(r) + 2)
          end if
        end do
      end do
    end do
  end subroutine csr_row_blocks

  !> Write the whole block row of owned node (i, j): its nc stencil blocks
  !> vals(3, 3, nc) in the order of (dj, di), owned(n): block n's row is
  !> owned (diagonal part).
  pure subroutine csr_put_block_row(lat, ia, av, ib, bv, i, j, nc, owned, vals)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    integer, intent(in) :: i, j, nc
    logical, intent(in) :: owned(:)
    real(rp), intent(in) :: vals(:, :, :)
    integer :: r, kk, pa, pb
    do r = 0, 2
      pa = ia(3 * (i + (j - lat%ys) * lat%nx) + r)
      pb = 0
      if (size(ib) > 0) pb = ib(3 * (i + (j - lat%ys) * lat%nx) + r)
      do kk = 1, nc
        if (owned(kk)) then
          av(pa:pa + 2) = vals(r + 1, :, kk)
          pa = pa + 3
        else
          bv(pb:pb + 2) = vals(r + 1, :, kk)
          pb = pb + 3
        end if
      end do
    end do
  end subroutine csr_put_block_row

  !> S(node (ip, jp), node (ip + di, jp + dj)) += blk.
  pure subroutine csr_add_block(lat, ia, av, ib, bv, ip, jp, di, dj, blk)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    integer, intent(in) :: ip, jp, di, dj
    real(rp), intent(in) :: blk(3, 3)
    integer :: pos(0:2), r
    logical :: diag
    call csr_block_pos(lat, ia, ib, ip, jp, di, dj, pos, diag)
    if (diag) then
      do r = 0, 2
        av(pos(r):pos(r) + 2) = av(pos(r):pos(r) + 2) + blk(r + 1, :)
      end do
    else
      do r = 0, 2
        bv(pos(r):pos(r) + 2) = bv(pos(r):pos(r) + 2) + blk(r + 1, :)
      end do
    end if
  end subroutine csr_add_block

end module csr_layout
