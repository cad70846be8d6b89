! SPDX-License-Identifier: BSD-2-Clause
!> Forces that act on single nodes (contact with obstacles) enter the
!> Jacobians as 3 x 3 blocks on the node's diagonal: this is their sparse
!> list, by owned row, that the assemblies of S (reduced_assembly) and of
!> the 6-dof Jacobian (forces' jac_buffer_row) add. Empty (n = 0) in a
!> scene without such forces: then no assembly loop looks at it.
module node_blocks
  use kinds, only: rp
  implicit none
  private
  public :: node_blocks_t

  type :: node_blocks_t
    integer :: n = 0                        !< nodes with a block
    integer, allocatable :: row_start(:)    !< (ys:ye+1): entries of row j are row_start(j) .. row_start(j+1)-1
    integer, allocatable :: col(:)          !< (n) column i of each entry
    real(rp), allocatable :: kx(:, :, :)    !< (3, 3, n) df/dx of the node's force [force/length]
    real(rp), allocatable :: kv(:, :, :)    !< (3, 3, n) df/dv [force time/length]
  end type node_blocks_t
end module node_blocks
