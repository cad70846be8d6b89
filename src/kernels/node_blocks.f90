! SPDX-License-Identifier: BSD-2-Clause
!> Forces that act on single nodes (contact with obstacles) enter the
!> Jacobians as 3 x 3 blocks on the node's diagonal: this is their sparse
!> list, by owned row, and what the assemblies do with it. The process
!> models' Jacobian hooks (module process_model) fill it between
!> node_blocks_begin and node_blocks_end (module process_models calls
!> those two around the hooks), each with node_blocks_add, in any order of
!> the rows: node_blocks_end orders the entries by row, keeping the order
!> of the entries within a row (so a node with blocks from two models
!> has two entries, added in the models' order). The assemblies of S
!> (reduced_assembly) and of the 6-dof Jacobian (forces' jac_buffer_row)
!> take it intent(in) and add it (node_blocks_products,
!> node_blocks_sub_row, node_blocks_sub_node, node_blocks_sub_diagonal).
!> Empty (node_blocks_count 0) in a scene without such forces: then no
!> assembly loop looks at it. The components are private: only this
!> module's procedures write them.
module node_blocks
  use kinds, only: rp
  implicit none
  private
  public :: node_blocks_t, node_blocks_begin, node_blocks_add, node_blocks_end, node_blocks_count
  public :: node_blocks_products, node_blocks_sub_row, node_blocks_sub_node, node_blocks_sub_diagonal

  type :: node_blocks_t
    private
    integer :: n = 0                        !< nodes with a block
    integer :: ys = 0, ye = -1              !< the owned rows
    logical :: ordered = .true.             !< while filled: the entries so far are in the order of the rows
    integer, allocatable :: row_start(:)    !< (ys:ye+1): entries of row j are row_start(j) .. row_start(j+1)-1
    integer, allocatable :: col(:)          !< (capacity) column i of each entry
    integer, allocatable :: row(:)          !< (capacity) row j of each entry
    real(rp), allocatable :: kx(:, :, :)    !< (3, 3, capacity) df/dx of the node's force [force/length]
    real(rp), allocatable :: kv(:, :, :)    !< (3, 3, capacity) df/dv [force time/length]
  end type node_blocks_t

contains

  !> Start a new list for the owned rows ys..ye (the arrays are kept from
  !> the last list: nothing is allocated once they are large enough).
  subroutine node_blocks_begin(nb, ys, ye)
    type(node_blocks_t), intent(inout) :: nb
    integer, intent(in) :: ys, ye
    if (allocated(nb%row_start)) then
      if (lbound(nb%row_start, 1) /= ys .or. ubound(nb%row_start, 1) /= ye + 1) deallocate(nb%row_start)
    end if
    if (.not. allocated(nb%row_start)) allocate(nb%row_start(ys:ye + 1))
    if (.not. allocated(nb%col)) allocate(nb%col(64), nb%row(64), nb%kx(3, 3, 64), nb%kv(3, 3, 64))
    nb%ys = ys
    nb%ye = ye
    nb%ordered = .true.
    nb%n = 0
  end subroutine node_blocks_begin

  !> Append the blocks kx = df/dx, kv = df/dv of node (i, j), an owned
  !> node (ys <= j <= ye); the rows may come in any order.
  subroutine node_blocks_add(nb, i, j, kx, kv)
    type(node_blocks_t), intent(inout) :: nb
    integer, intent(in) :: i, j
    real(rp), intent(in) :: kx(3, 3), kv(3, 3)
    if (nb%n > 0) then
      if (j < nb%row(nb%n)) nb%ordered = .false.
    end if
    nb%n = nb%n + 1
    if (nb%n > size(nb%col)) call grow(nb, 2 * nb%n)
    nb%col(nb%n) = i
    nb%row(nb%n) = j
    nb%kx(:, :, nb%n) = kx
    nb%kv(:, :, nb%n) = kv
  end subroutine node_blocks_add

  !> The list is complete: each row's entries found by row_start, the
  !> entries ordered by row first where they came in another order (a
  !> stable counting sort: within a row, the order in which they came).
  subroutine node_blocks_end(nb)
    type(node_blocks_t), intent(inout) :: nb
    integer :: m, j, c
    integer, allocatable :: at(:), perm(:)
    nb%row_start = 0
    do m = 1, nb%n
      nb%row_start(nb%row(m)) = nb%row_start(nb%row(m)) + 1
    end do
    ! counts into starts: row j's entries begin after those of the rows before
    m = 1
    do j = nb%ys, nb%ye + 1
      c = nb%row_start(j)
      nb%row_start(j) = m
      m = m + c
    end do
    if (nb%ordered) return
    at = nb%row_start(nb%ys:nb%ye)
    allocate(perm(nb%n))
    do m = 1, nb%n
      j = nb%row(m)
      perm(at(j - nb%ys + 1)) = m
      at(j - nb%ys + 1) = at(j - nb%ys + 1) + 1
    end do
    nb%col(1:nb%n) = nb%col(perm)
    nb%row(1:nb%n) = nb%row(perm)
    nb%kx(:, :, 1:nb%n) = nb%kx(:, :, perm)
    nb%kv(:, :, 1:nb%n) = nb%kv(:, :, perm)
    nb%ordered = .true.
  end subroutine node_blocks_end

  subroutine grow(nb, m)
    type(node_blocks_t), intent(inout) :: nb
    integer, intent(in) :: m
    integer, allocatable :: c(:), r(:)
    real(rp), allocatable :: a(:, :, :), b(:, :, :)
    allocate(c(m), r(m), a(3, 3, m), b(3, 3, m))
    c(1:size(nb%col)) = nb%col
    r(1:size(nb%row)) = nb%row
    a(:, :, 1:size(nb%col)) = nb%kx
    b(:, :, 1:size(nb%col)) = nb%kv
    call move_alloc(c, nb%col)
    call move_alloc(r, nb%row)
    call move_alloc(a, nb%kx)
    call move_alloc(b, nb%kv)
  end subroutine grow

  !> Nodes with a block (0: the assemblies skip the list).
  pure integer function node_blocks_count(nb)
    type(node_blocks_t), intent(in) :: nb
    node_blocks_count = nb%n
  end function node_blocks_count

  !> Their products with w(0:5, 0:nx-1, ys:ye) into g(3, 0:nx-1, ys:ye),
  !> g -= kx w_x + kv w_v, and their diagonals into kd, kd -= diag(kx)
  !> (the element products and the round-off floor's diagonal of module
  !> reduced_assembly).
  pure subroutine node_blocks_products(nb, w, g, kd)
    type(node_blocks_t), intent(in) :: nb
    real(rp), intent(in) :: w(0:, 0:, nb%ys:)
    real(rp), intent(inout) :: g(:, 0:, nb%ys:), kd(:, 0:, nb%ys:)
    integer :: m, i, j, r
    do j = nb%ys, nb%ye
      do m = nb%row_start(j), nb%row_start(j + 1) - 1
        i = nb%col(m)
        g(:, i, j) = g(:, i, j) - matmul(nb%kx(:, :, m), w(0:2, i, j)) - matmul(nb%kv(:, :, m), w(3:5, i, j))
        do r = 1, 3
          kd(r, i, j) = kd(r, i, j) - nb%kx(r, r, m)
        end do
      end do
    end do
  end subroutine node_blocks_products

  !> The diagonal blocks d(i, :, :) of the nodes i of row j of S stored by
  !> stencil offset, d(0:nx-1, 3, 3), get -(kv + kx/a) (rinv = 1/a [time]).
  pure subroutine node_blocks_sub_row(nb, j, rinv, d)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: j
    real(rp), intent(in) :: rinv
    real(rp), intent(inout) :: d(0:, :, :)
    integer :: m, i
    do m = nb%row_start(j), nb%row_start(j + 1) - 1
      i = nb%col(m)
      d(i, :, :) = d(i, :, :) - nb%kv(:, :, m) - rinv * nb%kx(:, :, m)
    end do
  end subroutine node_blocks_sub_row

  !> The diagonal block blk(3, 3) of node (i, j) of S gets -(kv + kx/a)
  !> when the node has a block (rinv = 1/a [time]).
  pure subroutine node_blocks_sub_node(nb, i, j, rinv, blk)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: i, j
    real(rp), intent(in) :: rinv
    real(rp), intent(inout) :: blk(3, 3)
    integer :: m
    do m = nb%row_start(j), nb%row_start(j + 1) - 1
      if (nb%col(m) == i) blk = blk - nb%kv(:, :, m) - rinv * nb%kx(:, :, m)
    end do
  end subroutine node_blocks_sub_node

  !> The diagonal blocks of the 6-dof Jacobian's v-rows of row j, dk and dc
  !> (3, 3, 0:nx-1): -df/dx and -df/dv, get -kx and -kv.
  pure subroutine node_blocks_sub_diagonal(nb, j, dk, dc)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: j
    real(rp), intent(inout) :: dk(:, :, 0:), dc(:, :, 0:)
    integer :: m, i
    do m = nb%row_start(j), nb%row_start(j + 1) - 1
      i = nb%col(m)
      dk(:, :, i) = dk(:, :, i) - nb%kx(:, :, m)
      dc(:, :, i) = dc(:, :, i) - nb%kv(:, :, m)
    end do
  end subroutine node_blocks_sub_diagonal

end module node_blocks
