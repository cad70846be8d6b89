! SPDX-License-Identifier: BSD-2-Clause
!> Forces between two nodes that need not be stencil neighbours (the
!> cloth's self-contact: a node against a triangle, an edge against an
!> edge, anywhere on the lattice, on this rank or another) enter S as
!> 3 x 3 blocks between the two nodes: this is their list, beside
!> node_blocks' diagonal blocks. An entry is one block df_a/dx_b (and
!> df_a/dv_b) of an owned free node a and another node b, which may lie in
!> a row of another rank; the same (a, b) may come several times (one
!> entry a pair of primitives), the products sum them. A process model's
!> Jacobian hook (module process_model) adds entries; module
!> process_models opens and closes the list around the hooks and forms
!> the products (pair_blocks_apply) on the rows the model gathers.
!> The components are private: only this module's procedures write them.
module pair_blocks
  use kinds, only: rp
  implicit none
  private
  public :: pair_blocks_t, pair_blocks_begin, pair_blocks_add, pair_blocks_end, pair_blocks_count, pair_blocks_apply

  type :: pair_blocks_t
    private
    integer :: n = 0                        !< entries in the list
    integer, allocatable :: node(:, :)      !< (4, capacity) (i, j) of node a (owned), (i, j) of node b (any)
    logical, allocatable :: b_fixed(:)      !< (capacity) node b is constrained (no column of S)
    real(rp), allocatable :: kx(:, :, :)    !< (3, 3, capacity) df_a/dx_b [force/length]
    real(rp), allocatable :: kv(:, :, :)    !< (3, 3, capacity) df_a/dv_b [force time/length]
  end type pair_blocks_t

contains

  !> Start a new, empty list (its arrays kept).
  subroutine pair_blocks_begin(pb)
    type(pair_blocks_t), intent(inout) :: pb
    pb%n = 0
  end subroutine pair_blocks_begin

  !> Append the block of the force on node a = (ia, ja) (owned, free) by
  !> node b = (ib, jb) (any, b_fixed: constrained): kx = df_a/dx_b,
  !> kv = df_a/dv_b. The arrays grow (doubled) only when full.
  subroutine pair_blocks_add(pb, ia, ja, ib, jb, b_fixed, kx, kv)
    type(pair_blocks_t), intent(inout) :: pb
    integer, intent(in) :: ia, ja, ib, jb
    logical, intent(in) :: b_fixed
    real(rp), intent(in) :: kx(3, 3), kv(3, 3)
    integer, allocatable :: nd(:, :)
    logical, allocatable :: bf(:)
    real(rp), allocatable :: a(:, :, :), b(:, :, :)
    integer :: m
    if (.not. allocated(pb%node)) allocate(pb%node(4, 64), pb%b_fixed(64), pb%kx(3, 3, 64), pb%kv(3, 3, 64))
    if (pb%n == size(pb%node, 2)) then
      m = 2 * pb%n
      allocate(nd(4, m), bf(m), a(3, 3, m), b(3, 3, m))
      nd(:, 1:pb%n) = pb%node
      bf(1:pb%n) = pb%b_fixed
      a(:, :, 1:pb%n) = pb%kx
      b(:, :, 1:pb%n) = pb%kv
      call move_alloc(nd, pb%node)
      call move_alloc(bf, pb%b_fixed)
      call move_alloc(a, pb%kx)
      call move_alloc(b, pb%kv)
    end if
    pb%n = pb%n + 1
    pb%node(:, pb%n) = [ia, ja, ib, jb]
    pb%b_fixed(pb%n) = b_fixed
    pb%kx(:, :, pb%n) = kx
    pb%kv(:, :, pb%n) = kv
  end subroutine pair_blocks_add

  !> The list is complete.
  subroutine pair_blocks_end(pb)
    type(pair_blocks_t), intent(inout) :: pb
  end subroutine pair_blocks_end

  !> Entries in the list (0: nothing to add).
  pure integer function pair_blocks_count(pb)
    type(pair_blocks_t), intent(in) :: pb
    pair_blocks_count = pb%n
  end function pair_blocks_count

  !> y(:, ia, ja) += cx kx vx(:, ib, b's row) + cv kv vv(:, ib, b's row)
  !> over the entries (free_b_only: those whose node b is free, S's
  !> columns; else all, the right-hand side's products). vx, vv (3,
  !> 0:nx-1, nrows): the rows the entries reach, slot(j) the position of
  !> row j there (0: absent, err = 1 and nothing added); y (3, 0:nx-1,
  !> ys:ye) the owned rows. S = a M - C - K/a takes cx = -1/a, cv = -1.
  subroutine pair_blocks_apply(pb, slot, vx, vv, cx, cv, free_b_only, ys, y, err)
    type(pair_blocks_t), intent(in) :: pb
    integer, intent(in) :: slot(0:)
    real(rp), intent(in) :: vx(:, 0:, :), vv(:, 0:, :)
    real(rp), intent(in) :: cx, cv
    logical, intent(in) :: free_b_only
    integer, intent(in) :: ys
    real(rp), intent(inout) :: y(:, 0:, ys:)
    integer, intent(out) :: err
    integer :: m, k
    err = 0
    do m = 1, pb%n
      if (free_b_only .and. pb%b_fixed(m)) cycle
      k = slot(pb%node(4, m))
      if (k < 1) then
        err = 1
        return
      end if
      associate (ia => pb%node(1, m), ja => pb%node(2, m), ib => pb%node(3, m))
        if (cx /= 0.0_rp) y(:, ia, ja) = y(:, ia, ja) + cx * matmul(pb%kx(:, :, m), vx(:, ib, k))
        if (cv /= 0.0_rp) y(:, ia, ja) = y(:, ia, ja) + cv * matmul(pb%kv(:, :, m), vv(:, ib, k))
      end associate
    end do
  end subroutine pair_blocks_apply

end module pair_blocks
