! SPDX-License-Identifier: BSD-2-Clause
!> A lane kernel of module reduced_assembly on plain arrays with explicit
!> shapes (no lattice, no PETSc, no MPI): a row's link blocks written into
!> S by stencil offset. (The bending triples' lane kernels stay in
!> reduced_assembly itself: their loops run over at most TRIPLE_LANES
!> lanes, and only inlined into add_triple_lanes, with the lanes' leading
!> dimension known, are they vector loops; called across modules they made
!> S's assembly with bending 15 % slower.)
module reduced_lanes
  use kinds, only: rp
  implicit none
  private
  public :: put_link_blocks

contains

  !> put_rows_st's work for one offset (di, dj) of a row, i = ilo..ihi: the
  !> link's block src(i + dil, :, k) into S's slot sl of node i, or zero to or
  !> from a constrained node (fixed_p(i), fixed_q(i + di)), and subtracted
  !> from the diagonal slot sd. Explicit shapes: over the assumed-shape
  !> arrays, each nine-entry copy went through the compiler's general
  !> strided loop.
  pure subroutine put_link_blocks(nx, nslot, ilo, ihi, di, dil, k, src, fixed_p, fixed_q, sl, sd, dst)
    integer, intent(in) :: nx, nslot, ilo, ihi, di, dil, k, sl, sd
    real(rp), intent(in) :: src(0:nx - 1, 9, 4)      !< the link blocks kept at their lower ends
    logical, intent(in) :: fixed_p(0:nx - 1), fixed_q(0:nx - 1)
    real(rp), intent(inout) :: dst(0:nx - 1, 9, nslot)
    ! nodes a tile: keep sized by a constant (sized by nx, gfortran put it
    ! on the heap: a malloc and a free a call, eight a row)
    integer, parameter :: TILE = 64
    integer :: i, e, i0, i1
    real(rp) :: keep(TILE)
    do i0 = ilo, ihi, TILE
      i1 = min(i0 + TILE - 1, ihi)
      ! the test once per node, as a factor 1 or 0 (inside the loop over the
      ! entries it was compiled into a gather of fixed_q for every entry, a
      ! quarter of csr_assemble's own time without bending; a logical mask
      ! there, into scalar branches)
      do i = i0, i1
        keep(i - i0 + 1) = merge(0.0_rp, 1.0_rp, fixed_p(i) .or. fixed_q(i + di))
      end do
      do e = 1, 9
        do i = i0, i1
          dst(i, e, sd) = dst(i, e, sd) - src(i + dil, e, k)
          dst(i, e, sl) = keep(i - i0 + 1) * src(i + dil, e, k)
        end do
      end do
    end do
  end subroutine put_link_blocks

end module reduced_lanes
