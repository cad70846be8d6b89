! SPDX-License-Identifier: BSD-2-Clause
!> The lane kernels of module reduced_assembly: what the direct assembly of
!> S does with the blocks of many elements of one direction at once (vector
!> loops over the lanes l), on plain arrays with explicit shapes (no
!> lattice, no PETSc, no MPI): the nine node blocks of nl bending triples,
!> their adds to a row of S by stencil offset, their products and
!> diagonals, and a row's link blocks written into S by stencil offset.
module reduced_lanes
  use kinds, only: rp
  implicit none
  private
  public :: triple_node_blocks, add_lane_blocks, sub_lane_forces, put_link_blocks

contains

  !> The nine node blocks B(P, Q) = sum_ab t(a, P) t(b, Q) m_ab of nl
  !> bending triples (T = [[-I, I, 0], [0, -I, I]], m = -(ce + ke/a), m_ab
  !> its 3 x 3 quarter of edges a, b), by lanes: blk(:, :, :, 3 (P - 1) + Q).
  !> T's entries are -1, 0 and 1, so each block is a sum of one to four
  !> quarters: B11 = m11, B12 = m12 - m11, B13 = -m12, B21 = m21 - m11,
  !> B22 = m11 - m12 - m21 + m22, B23 = m12 - m22, B31 = -m21,
  !> B32 = m21 - m22, B33 = m22.
  pure subroutine triple_node_blocks(nl, ld, rinv, ke, ce, blk)
    integer, intent(in) :: nl, ld
    real(rp), intent(in) :: rinv                   ! 1/a [time]
    real(rp), intent(in) :: ke(ld, 6, 6), ce(ld, 6, 6)
    real(rp), intent(out) :: blk(ld, 3, 3, 9)
    integer :: l, c1, c2
    real(rp) :: m11, m12, m21, m22
    do c2 = 1, 3
      do c1 = 1, 3
        do l = 1, nl
          m11 = -(ce(l, c1, c2) + rinv * ke(l, c1, c2))
          m12 = -(ce(l, c1, 3 + c2) + rinv * ke(l, c1, 3 + c2))
          m21 = -(ce(l, 3 + c1, c2) + rinv * ke(l, 3 + c1, c2))
          m22 = -(ce(l, 3 + c1, 3 + c2) + rinv * ke(l, 3 + c1, 3 + c2))
          blk(l, c1, c2, 1) = m11
          blk(l, c1, c2, 2) = m12 - m11
          blk(l, c1, c2, 3) = -m12
          blk(l, c1, c2, 4) = m21 - m11
          blk(l, c1, c2, 5) = (m11 - m12) + (m22 - m21)
          blk(l, c1, c2, 6) = m12 - m22
          blk(l, c1, c2, 7) = -m21
          blk(l, c1, c2, 8) = m21 - m22
          blk(l, c1, c2, 9) = m22
        end do
      end do
    end do
  end subroutine triple_node_blocks

  !> Add the blocks b(l, :, :) (times free(l) where masked) to slot sl of
  !> nl consecutive nodes ip0.. of a row of S by stencil offset (node
  !> blocks of nl bending triples), nodes fastest, as S keeps them: one
  !> vector loop for each entry; with S node by node these adds were
  !> scalar, 3 % of a bw step with bending. Explicit shapes, as
  !> put_link_blocks.
  pure subroutine add_lane_blocks(nl, ld, nx, nslot, sl, ip0, b, masked, free, dst)
    integer, intent(in) :: nl, ld, nx, nslot, sl, ip0
    real(rp), intent(in) :: b(ld, 3, 3), free(ld)
    logical, intent(in) :: masked
    real(rp), intent(inout) :: dst(0:nx - 1, 3, 3, nslot)
    integer :: l, c1, c2
    do c2 = 1, 3
      do c1 = 1, 3
        if (masked) then
          do l = 1, nl
            dst(ip0 + l - 1, c1, c2, sl) = dst(ip0 + l - 1, c1, c2, sl) + free(l) * b(l, c1, c2)
          end do
        else
          do l = 1, nl
            dst(ip0 + l - 1, c1, c2, sl) = dst(ip0 + l - 1, c1, c2, sl) + b(l, c1, c2)
          end do
        end if
      end do
    end do
  end subroutine add_lane_blocks

  !> add_triple_lanes' products and diagonals for node P of nl triples
  !> (t1, t2: its factors in the two edges): g -= t1 h(1:3) + t2 h(4:6) and
  !> kd -= the diagonal of the block (P, P) of T^T ke T.
  pure subroutine sub_lane_forces(nl, ld, t1, t2, h, ke, g, kd)
    integer, intent(in) :: nl, ld
    real(rp), intent(in) :: t1, t2, h(ld, 6), ke(ld, 6, 6)
    real(rp), intent(inout) :: g(3, nl), kd(3, nl)
    integer :: l, c1
    do l = 1, nl
      do c1 = 1, 3
        g(c1, l) = g(c1, l) - (t1 * h(l, c1) + t2 * h(l, 3 + c1))
        kd(c1, l) = kd(c1, l) - (t1**2 * ke(l, c1, c1) + t1 * t2 * (ke(l, c1, 3 + c1) + ke(l, 3 + c1, c1)) &
                                 + t2**2 * ke(l, 3 + c1, 3 + c1))
      end do
    end do
  end subroutine sub_lane_forces

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
    integer :: i, e
    real(rp) :: keep(0:nx - 1)
    ! the test once per node, as a factor 1 or 0 (inside the loop over the
    ! entries it was compiled into a gather of fixed_q for every entry, a
    ! quarter of csr_assemble's own time without bending; a logical mask
    ! there, into scalar branches)
    do i = ilo, ihi
      keep(i) = merge(0.0_rp, 1.0_rp, fixed_p(i) .or. fixed_q(i + di))
    end do
    do e = 1, 9
      do i = ilo, ihi
        dst(i, e, sd) = dst(i, e, sd) - src(i + dil, e, k)
        dst(i, e, sl) = keep(i) * src(i + dil, e, k)
      end do
    end do
  end subroutine put_link_blocks

end module reduced_lanes
