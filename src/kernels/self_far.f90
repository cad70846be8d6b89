! SPDX-License-Identifier: BSD-2-Clause
!> The last test of self-contact's broad phase (module self_broad's
!> find_pairs): whether a candidate pair is beyond the reach, at positions
!> xa (distance >= reach), or along its straight paths xa -> xb (distance at
!> xa minus ACCD's rate bound >= reach: contact_ccd). Why a module of its
!> own: where the halves of the self-contact benchmark meet at 257 x 257 the
!> exact distances of the pairs the hash met were 13 % of a step (perf,
!> docs/performance.md, "Self-contact"), most of them lattice neighbours a
!> spacing apart; the gap between the boxes of the pair's two primitives is
!> a lower bound of the distance at a tenth of its cost and settles most of
!> them. The answer is the exact test's, pair for pair (BOX_SAFE).
!> Plain arrays, no PETSc, no MPI.
module self_far
  use kinds, only: rp
  use contact_primitives, only: point_triangle_d2, edge_edge_d2
  use contact_ccd, only: accd_rate_bound
  implicit none
  private
  public :: self_pair_far, self_pair_distance2

  !> The pair kind of a point and a triangle (self_broad's PAIR_PT, contact_ccd's code).
  integer, parameter :: KIND_PT = 1
  !> The boxes' gap is scaled by this before the comparison: a pair it calls far is
  !> beyond the reach by 1e-9 of the gap, far above the exact distance's round-off
  !> (~1e-16 of the coordinates), so the exact test would call it far too.
  real(rp), parameter :: BOX_SAFE = 1.0_rp - 1.0e-9_rp

contains

  !> .true. where the pair (kind: 1 point-triangle, else edge-edge; columns: the point, or
  !> the first edge's nodes, then the triangle's or the second edge's) is beyond reach at
  !> xa, or (swept) along the paths xa -> xb by ACCD's bound.
  pure logical function self_pair_far(kind, xa, xb, swept, reach) result(far)
    integer, intent(in) :: kind
    real(rp), intent(in) :: xa(3, 4), xb(3, 4)   ! start and end positions [length]
    logical, intent(in) :: swept
    real(rp), intent(in) :: reach                ! [length]
    real(rp) :: rb

    if (swept) then
      rb = accd_rate_bound(kind, xb - xa)
      far = BOX_SAFE * sqrt(box_gap2(kind, xa)) - rb >= reach
      if (.not. far) far = sqrt(self_pair_distance2(kind, xa)) - rb >= reach
    else
      far = BOX_SAFE * box_gap2(kind, xa) >= reach**2
      if (.not. far) far = self_pair_distance2(kind, xa) >= reach**2
    end if
  end function self_pair_far

  !> Squared distance of a pair at positions xp(3, 4) [length^2] (kind: 1
  !> point-triangle, else edge-edge; columns as self_pair_far's).
  pure real(rp) function self_pair_distance2(kind, xp) result(d2)
    integer, intent(in) :: kind
    real(rp), intent(in) :: xp(3, 4)

    if (kind == KIND_PT) then
      d2 = point_triangle_d2(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4))
    else
      d2 = edge_edge_d2(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4))
    end if
  end function self_pair_distance2

  !> The squared gap between the boxes of the pair's two primitives [length^2]: no larger
  !> than the squared distance.
  pure real(rp) function box_gap2(kind, xp) result(g2)
    integer, intent(in) :: kind
    real(rp), intent(in) :: xp(3, 4)             ! [length]
    real(rp) :: alo(3), ahi(3), blo(3), bhi(3)

    if (kind == KIND_PT) then
      alo = xp(:, 1)
      ahi = xp(:, 1)
      blo = min(xp(:, 2), xp(:, 3), xp(:, 4))
      bhi = max(xp(:, 2), xp(:, 3), xp(:, 4))
    else
      alo = min(xp(:, 1), xp(:, 2))
      ahi = max(xp(:, 1), xp(:, 2))
      blo = min(xp(:, 3), xp(:, 4))
      bhi = max(xp(:, 3), xp(:, 4))
    end if
    g2 = sum(max(blo - ahi, alo - bhi, 0.0_rp)**2)
  end function box_gap2

end module self_far
