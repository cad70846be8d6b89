! SPDX-License-Identifier: BSD-2-Clause
!> Forces that act on single nodes (contact with obstacles) enter the
!> Jacobians as 3 x 3 blocks on the node's diagonal, and forces on the
!> nodes of one lattice quad (contact of the cloth's triangles and edges,
!> module face_contact) as 3 x 3 blocks between a node and a stencil
!> neighbour (offsets di, dj in -1..1, within S's 9-point stencil): this
!> is their sparse list, by owned row, and what the assemblies do with
!> it. A block between a node and a neighbour belongs to the node's row
!> alone (the neighbour's row, if owned, has its own entry); the
!> assemblies drop the blocks to or from a constrained node, as they do
!> links' (fixedg). The process
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
  public :: node_blocks_t, node_blocks_begin, node_blocks_add, node_blocks_add_pair, node_blocks_end, node_blocks_count
  public :: node_blocks_products, node_blocks_sub_row, node_blocks_sub_node, node_blocks_sub_diagonal, node_blocks_lumped
  public :: node_blocks_between, node_blocks_by_offset

  type :: node_blocks_t
    private
    integer :: n = 0                        !< nodes with a block
    integer :: ys = 0, ye = -1              !< the owned rows
    logical :: ordered = .true.             !< while filled: the entries so far are in the order of the rows
    integer, allocatable :: row_start(:)    !< (ys:ye+1): entries of row j are row_start(j) .. row_start(j+1)-1
    integer, allocatable :: col(:)          !< (capacity) column i of each entry
    integer, allocatable :: row(:)          !< (capacity) row j of each entry
    !> (2, capacity) offset (di, dj) of the column node from the row node
    !> (0, 0: the node's diagonal block)
    integer, allocatable :: off(:, :)
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
    if (.not. allocated(nb%col)) allocate(nb%col(64), nb%row(64), nb%off(2, 64), nb%kx(3, 3, 64), nb%kv(3, 3, 64))
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
    call node_blocks_add_pair(nb, i, j, 0, 0, kx, kv)
  end subroutine node_blocks_add

  !> Append the blocks kx = df/dx, kv = df/dv of the force on owned node
  !> (i, j) with respect to its stencil neighbour (i + di, j + dj)
  !> (di, dj in -1..1; 0, 0: the node's own, as node_blocks_add).
  subroutine node_blocks_add_pair(nb, i, j, di, dj, kx, kv)
    type(node_blocks_t), intent(inout) :: nb
    integer, intent(in) :: i, j, di, dj
    real(rp), intent(in) :: kx(3, 3), kv(3, 3)
    if (nb%n > 0) then
      if (j < nb%row(nb%n)) nb%ordered = .false.
    end if
    nb%n = nb%n + 1
    if (nb%n > size(nb%col)) call grow(nb, 2 * nb%n)
    nb%col(nb%n) = i
    nb%row(nb%n) = j
    nb%off(:, nb%n) = [di, dj]
    nb%kx(:, :, nb%n) = kx
    nb%kv(:, :, nb%n) = kv
  end subroutine node_blocks_add_pair

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
    nb%off(:, 1:nb%n) = nb%off(:, perm)
    nb%kx(:, :, 1:nb%n) = nb%kx(:, :, perm)
    nb%kv(:, :, 1:nb%n) = nb%kv(:, :, perm)
    nb%ordered = .true.
  end subroutine node_blocks_end

  subroutine grow(nb, m)
    type(node_blocks_t), intent(inout) :: nb
    integer, intent(in) :: m
    integer, allocatable :: c(:), r(:), o(:, :)
    real(rp), allocatable :: a(:, :, :), b(:, :, :)
    allocate(c(m), r(m), o(2, m), a(3, 3, m), b(3, 3, m))
    c(1:size(nb%col)) = nb%col
    r(1:size(nb%row)) = nb%row
    o(:, 1:size(nb%col)) = nb%off
    a(:, :, 1:size(nb%col)) = nb%kx
    b(:, :, 1:size(nb%col)) = nb%kv
    call move_alloc(c, nb%col)
    call move_alloc(r, nb%row)
    call move_alloc(o, nb%off)
    call move_alloc(a, nb%kx)
    call move_alloc(b, nb%kv)
  end subroutine grow

  !> Nodes with a block (0: the assemblies skip the list).
  pure integer function node_blocks_count(nb)
    type(node_blocks_t), intent(in) :: nb
    node_blocks_count = nb%n
  end function node_blocks_count

  !> Some entry is a block between a node and a neighbour (the faces'
  !> contact), not on a node's diagonal.
  pure logical function node_blocks_between(nb)
    type(node_blocks_t), intent(in) :: nb
    node_blocks_between = any(nb%off(:, 1:nb%n) /= 0)
  end function node_blocks_between

  !> Their products with the ghosted w(0:5, 0:nx-1, gys:gye) into
  !> g(3, 0:nx-1, ys:ye), g -= kx w_x + kv w_v (each block times w at its
  !> column node), and the diagonal blocks' diagonals into kd,
  !> kd -= diag(kx) (the element products and the round-off floor's
  !> diagonal of module reduced_assembly).
  pure subroutine node_blocks_products(nb, gys, w, g, kd)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: gys
    real(rp), intent(in) :: w(0:, 0:, gys:)
    real(rp), intent(inout) :: g(:, 0:, nb%ys:), kd(:, 0:, nb%ys:)
    integer :: m, i, j, r, ic, jc
    do j = nb%ys, nb%ye
      do m = nb%row_start(j), nb%row_start(j + 1) - 1
        i = nb%col(m)
        ic = i + nb%off(1, m)
        jc = j + nb%off(2, m)
        g(:, i, j) = g(:, i, j) - matmul(nb%kx(:, :, m), w(0:2, ic, jc)) - matmul(nb%kv(:, :, m), w(3:5, ic, jc))
        if (nb%off(1, m) /= 0 .or. nb%off(2, m) /= 0) cycle
        do r = 1, 3
          kd(r, i, j) = kd(r, i, j) - nb%kx(r, r, m)
        end do
      end do
    end do
  end subroutine node_blocks_products

  !> The blocks of row j of S stored by stencil offset, st(0:nx-1, 3, 3,
  !> slots) (slot of offset (di, dj): kof(di, dj)), get -(kv + kx/a)
  !> (rinv = 1/a [time]); a block to or from a constrained node
  !> (fixedg(0:nx-1, gys:gye)) is dropped (its row is a m I alone).
  pure subroutine node_blocks_sub_row(nb, j, rinv, kof, gys, fixedg, st)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: j
    real(rp), intent(in) :: rinv
    integer, intent(in) :: kof(-2:, -2:)
    integer, intent(in) :: gys
    logical, intent(in) :: fixedg(0:, gys:)
    real(rp), intent(inout) :: st(0:, :, :, :)
    integer :: m, i, sl
    do m = nb%row_start(j), nb%row_start(j + 1) - 1
      i = nb%col(m)
      if (fixedg(i, j) .or. fixedg(i + nb%off(1, m), j + nb%off(2, m))) cycle
      sl = kof(nb%off(1, m), nb%off(2, m))
      st(i, :, :, sl) = st(i, :, :, sl) - nb%kv(:, :, m) - rinv * nb%kx(:, :, m)
    end do
  end subroutine node_blocks_sub_row

  !> The blocks of node (i, j)'s row of S, vals(3, 3, *) over its stencil
  !> box di0..di1 x dj0.. (di fastest), get -(kv + kx/a) at their offsets
  !> (rinv = 1/a [time]); blocks to or from a constrained node dropped.
  pure subroutine node_blocks_sub_node(nb, i, j, rinv, di0, di1, dj0, gys, fixedg, vals)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: i, j
    real(rp), intent(in) :: rinv
    integer, intent(in) :: di0, di1, dj0, gys
    logical, intent(in) :: fixedg(0:, gys:)
    real(rp), intent(inout) :: vals(:, :, :)
    integer :: m, c
    do m = nb%row_start(j), nb%row_start(j + 1) - 1
      if (nb%col(m) /= i) cycle
      if (fixedg(i, j) .or. fixedg(i + nb%off(1, m), j + nb%off(2, m))) cycle
      c = (nb%off(2, m) - dj0) * (di1 - di0 + 1) + nb%off(1, m) - di0 + 1
      vals(:, :, c) = vals(:, :, c) - nb%kv(:, :, m) - rinv * nb%kx(:, :, m)
    end do
  end subroutine node_blocks_sub_node

  !> The blocks of the 6-dof Jacobian's v-rows of row j by offset, dk and
  !> dc (3, 3, -hw:hw, -hw:hw, 0:nx-1): -df/dx and -df/dv, get -kx and -kv
  !> (constrained nodes: the buffer's readers drop their blocks).
  pure subroutine node_blocks_sub_diagonal(nb, j, hw, dk, dc)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: j, hw
    real(rp), intent(inout) :: dk(:, :, -hw:, -hw:, 0:), dc(:, :, -hw:, -hw:, 0:)
    integer :: m, i, di, dj
    do m = nb%row_start(j), nb%row_start(j + 1) - 1
      i = nb%col(m)
      di = nb%off(1, m)
      dj = nb%off(2, m)
      dk(:, :, di, dj, i) = dk(:, :, di, dj, i) - nb%kx(:, :, m)
      dc(:, :, di, dj, i) = dc(:, :, di, dj, i) - nb%kv(:, :, m)
    end do
  end subroutine node_blocks_sub_diagonal

  !> Each row's blocks summed onto its node (lumped, for the rediscretised
  !> coarse levels of nuno's multigrid, module mg_coarse): d(1:9, i, j) +=
  !> kx, d(10:18, i, j) += kv (column-major 3 x 3) of every entry of owned
  !> row j whose node (i, j) and neighbour are free (fixedg false: the
  !> assemblies drop the others). A smooth coarse mode sees the blocks
  !> between neighbours only through their sum.
  pure subroutine node_blocks_lumped(nb, gys, fixedg, d)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: gys                       !< first row of fixedg and d
    logical, intent(in) :: fixedg(0:, gys:)
    real(rp), intent(inout) :: d(:, 0:, gys:)        !< (18, 0:nx-1, gys:gye)
    integer :: m, i, j
    do j = nb%ys, nb%ye
      do m = nb%row_start(j), nb%row_start(j + 1) - 1
        i = nb%col(m)
        if (fixedg(i, j) .or. fixedg(i + nb%off(1, m), j + nb%off(2, m))) cycle
        d(1:9, i, j) = d(1:9, i, j) + reshape(nb%kx(:, :, m), [9])
        d(10:18, i, j) = d(10:18, i, j) + reshape(nb%kv(:, :, m), [9])
      end do
    end do
  end subroutine node_blocks_lumped

  !> Each row's blocks by offset (for the Galerkin restriction of the
  !> rediscretised coarse levels where some blocks are between neighbours,
  !> module mg_coarse; lumped, a coarse level would see a barrier across
  !> an element only through its row sums): d(1:9, di, dj, i, j) += kx,
  !> d(10:18, di, dj, i, j) += kv (column-major 3 x 3) of every entry of
  !> owned row j at offset (di, dj) whose node and neighbour are free.
  pure subroutine node_blocks_by_offset(nb, nx, gys, gye, fixedg, d)
    type(node_blocks_t), intent(in) :: nb
    integer, intent(in) :: nx, gys, gye              !< d's columns 0..nx-1 and rows gys..gye
    logical, intent(in) :: fixedg(0:, gys:)
    real(rp), intent(inout) :: d(18, -1:1, -1:1, 0:nx - 1, gys:gye)
    integer :: m, i, j, di, dj
    do j = nb%ys, nb%ye
      do m = nb%row_start(j), nb%row_start(j + 1) - 1
        i = nb%col(m)
        di = nb%off(1, m)
        dj = nb%off(2, m)
        if (fixedg(i, j) .or. fixedg(i + di, j + dj)) cycle
        d(1:9, di, dj, i, j) = d(1:9, di, dj, i, j) + reshape(nb%kx(:, :, m), [9])
        d(10:18, di, dj, i, j) = d(10:18, di, dj, i, j) + reshape(nb%kv(:, :, m), [9])
      end do
    end do
  end subroutine node_blocks_by_offset

end module node_blocks
