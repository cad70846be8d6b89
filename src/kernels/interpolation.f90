! SPDX-License-Identifier: BSD-2-Clause
!> One-dimensional weights of the multigrid's cubic interpolation (module
!> mg_transfer builds the 2-D tensor product from them, and module
!> reduced_mg PETSc's PCMG interpolation). Vertex-centred 2:1
!> coarsening: fine point f lies on coarse point f/2 when f is even, and
!> midway between (f-1)/2 and (f+1)/2 when odd. An odd point gets the
!> 4-point Lagrange weights of the coarse points around it, one-sided at
!> the two ends, so that cubic polynomials are interpolated exactly
!> everywhere (a fourth-order operator needs more than the bilinear
!> interpolation's second order for a multigrid that converges
!> independently of the lattice).
module interpolation
  use kinds, only: rp
  implicit none
  private
  public :: cubic_weights

contains

  !> Coarse points ix(1:n) (0-based) and weights w(1:n) of fine point f,
  !> for m coarse points (2m - 1 fine ones). Fewer than 4 coarse points:
  !> linear interpolation.
  pure subroutine cubic_weights(f, m, ix, w, n)
    integer, intent(in) :: f, m
    integer, intent(out) :: ix(4), n
    real(rp), intent(out) :: w(4)
    integer :: c0, s

    ix = 0
    w = 0.0_rp
    if (mod(f, 2) == 0) then
      n = 1
      ix(1) = f / 2
      w(1) = 1.0_rp
      return
    end if
    c0 = (f - 1) / 2
    if (m < 4) then
      n = 2
      ix(1:2) = [c0, c0 + 1]
      w(1:2) = 0.5_rp
      return
    end if
    n = 4
    if (c0 == 0) then
      s = 0                                            ! at 1/2 of 0, 1, 2, 3
      w = [0.3125_rp, 0.9375_rp, -0.3125_rp, 0.0625_rp]
    else if (c0 + 1 == m - 1) then
      s = c0 - 2                                       ! at 5/2 of 0, 1, 2, 3
      w = [0.0625_rp, -0.3125_rp, 0.9375_rp, 0.3125_rp]
    else
      s = c0 - 1                                       ! at 3/2 of 0, 1, 2, 3
      w = [-0.0625_rp, 0.5625_rp, 0.5625_rp, -0.0625_rp]
    end if
    ix = [s, s + 1, s + 2, s + 3]
  end subroutine cubic_weights

end module interpolation
