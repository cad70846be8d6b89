! SPDX-License-Identifier: BSD-2-Clause
!> Forces between two nodes that need not be stencil neighbours (a later
!> self-contact: a node against a triangle, an edge against an edge,
!> anywhere on the lattice) enter the Jacobians as 3 x 3 blocks between
!> the two nodes: this is their list, beside node_blocks' diagonal blocks.
!> A process model's Jacobian hook (module process_model) may add pairs;
!> module process_models opens and closes the list around the hooks.
!> Not yet assembled: S is a stencil of the lattice's offsets and has no
!> slot for a pair of distant nodes. The plan (docs/design.md, "Process
!> models"): S x adds each pair's products (the halo widened to the
!> contact distance), the multigrid's smoother takes the pairs' diagonal
!> parts; until then a non-empty list is refused by the solver (module
!> process_solver), so no pair is ever dropped silently. The components
!> are private: only this module's procedures write them.
module pair_blocks
  use kinds, only: rp
  implicit none
  private
  public :: pair_blocks_t, pair_blocks_begin, pair_blocks_add, pair_blocks_end, pair_blocks_count

  type :: pair_blocks_t
    private
    integer :: n = 0                        !< pairs in the list
    integer, allocatable :: node(:, :)      !< (4, capacity) (i, j) of the first node, (i, j) of the second
    !> (3, 3, 4, capacity) d f_a/d x_a, d f_a/d x_b, d f_b/d x_a, d f_b/d x_b
    !> (dx blocks) [force/length]; the velocity blocks likewise in kv
    real(rp), allocatable :: kx(:, :, :, :), kv(:, :, :, :)
  end type pair_blocks_t

contains

  !> Start a new, empty list (its arrays kept).
  subroutine pair_blocks_begin(pb)
    type(pair_blocks_t), intent(inout) :: pb
    pb%n = 0
  end subroutine pair_blocks_begin

  !> Append the pair of nodes a = (ia, ja) (owned) and b = (ib, jb) (any)
  !> with its blocks kx(3, 3, 4) = df/dx and kv(3, 3, 4) = df/dv, in the
  !> order aa, ab, ba, bb.
  subroutine pair_blocks_add(pb, ia, ja, ib, jb, kx, kv)
    type(pair_blocks_t), intent(inout) :: pb
    integer, intent(in) :: ia, ja, ib, jb
    real(rp), intent(in) :: kx(3, 3, 4), kv(3, 3, 4)
    integer, allocatable :: nd(:, :)
    real(rp), allocatable :: a(:, :, :, :), b(:, :, :, :)
    integer :: m
    if (.not. allocated(pb%node)) allocate(pb%node(4, 16), pb%kx(3, 3, 4, 16), pb%kv(3, 3, 4, 16))
    if (pb%n == size(pb%node, 2)) then
      m = 2 * pb%n
      allocate(nd(4, m), a(3, 3, 4, m), b(3, 3, 4, m))
      nd(:, 1:pb%n) = pb%node
      a(:, :, :, 1:pb%n) = pb%kx
      b(:, :, :, 1:pb%n) = pb%kv
      call move_alloc(nd, pb%node)
      call move_alloc(a, pb%kx)
      call move_alloc(b, pb%kv)
    end if
    pb%n = pb%n + 1
    pb%node(:, pb%n) = [ia, ja, ib, jb]
    pb%kx(:, :, :, pb%n) = kx
    pb%kv(:, :, :, pb%n) = kv
  end subroutine pair_blocks_add

  !> The list is complete.
  subroutine pair_blocks_end(pb)
    type(pair_blocks_t), intent(inout) :: pb
  end subroutine pair_blocks_end

  !> Pairs in the list (0: nothing to assemble).
  pure integer function pair_blocks_count(pb)
    type(pair_blocks_t), intent(in) :: pb
    pair_blocks_count = pb%n
  end function pair_blocks_count

end module pair_blocks
