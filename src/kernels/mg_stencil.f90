! SPDX-License-Identifier: BSD-2-Clause
!> The operator of one level of nuno's structured multigrid (module
!> stencil_mg) on a strip of lattice rows, stored by stencil offset: its
!> set-up from full blocks or from Galerkin sums, its blocks and the
!> inverted diagonal blocks of the smoother. Plain arrays; no PETSc, no
!> MPI (tests/unit/test_mg_kernels.f90 through module mg_kernels).
!>
!> Storage. An operator A on 3 dof per node with stencil reach r (|di|,
!> |dj| <= r) is kept in "difference form":
!>   (A x)_p = D_p x_p + sum_{o /= 0} B_{p,o} (x_{p+o} - x_p),
!> with B_{p,o} = A(p, p+o) the off-diagonal blocks and D_p = sum over the
!> whole block row (the row sums: a m I for a free node of S = a M - C -
!> K/a, since every element's forces are invariant under a translation).
!> The large stiffness blocks then enter only through differences, and the
!> small mass term is kept apart, so storing B in single precision (kind
!> mp) loses nothing of the smooth modes, where K x nearly cancels: the
!> operator stored is exactly D + L with L x = 0 for x constant. The
!> diagonal block A_pp = D_p - sum_o B_{p,o} is only needed inverted, for
!> the smoother. Arrays run along x fastest, (0:nx-1, 3, 3, offset, row),
!> so that every loop over a row vectorises.
!>
!> Vectors are padded: x(-h:nx-1+h, 3, ys-h:ye+h), h >= r; the padding
!> outside the lattice stays zero and blocks pointing outside it are zero,
!> so the loops need no tests at the edges. Ghost rows inside the lattice
!> (another rank's) are filled by the caller.
module mg_stencil
  use, intrinsic :: iso_fortran_env, only: real32
  use kinds, only: rp
  use offset_product, only: coupled_by_elements, offset_slot
  implicit none
  private
  public :: mp, stencil_t, stencil_init, stencil_put_row, stencil_finish, stencil_from_full, stencil_row_from_full, &
            offset_index, stencil_block, diagonal_block, block_inverse

  !> Kind of the multigrid's matrices and vectors (single precision: half
  !> the bytes of every pass; the smoother and the coarse correction only
  !> have to be good to a few digits, the outer Krylov method works in
  !> double precision on the exact S).
  integer, parameter :: mp = real32

  !> One level's operator on rows ys..ye of an nx x ny lattice. The blocks
  !> coupling a node to other rows are stored along x fastest (the smoother
  !> sums them over a whole row at once); those within its row and the
  !> inverted diagonal blocks node by node (the smoother's point-by-point
  !> part reads them in that order: along x fastest, their 36 streams
  !> outran the prefetchers and that part took longer than the rest).
  type :: stencil_t
    integer :: nx = 0, ny = 0, ys = 0, ye = -1
    integer :: r = 0                             !< stencil reach
    integer :: nb = 0                            !< off-diagonal offsets stored
    integer, allocatable :: odi(:), odj(:)       !< (nb) offsets, (dj, di) in lexicographic order
    integer, allocatable :: slot(:)              !< (nb) index of offset k in b (dj /= 0) or br (dj == 0)
    integer :: nv = 0, nr = 0                    !< offsets to other rows, within the row
    integer, allocatable :: kv(:), kr(:)         !< (nv), (nr) their k
    integer, allocatable :: dik(:)               !< (nr) di of the offsets within the row, odi(kr(:)) (the
                                                 !< kernels' point loops take it whole; a copy of the
                                                 !< size nr in each sweep was a malloc and a free)
    !> A(p, p + o) = A(p + o, p) for every offset o (block for block, not
    !> transposed): S without bending, whose every element is a link with
    !> f_q = -f_p a function of x_q - x_p and v_q - v_p, and the Galerkin
    !> operators P^T A P of such an A (P scalar weights times I). Then a
    !> block to a row below is the block back from that row, which a sweep
    !> or product along the rows read a row before: the kernels take it
    !> from there (kmir), in the cache, instead of from memory. Set by the
    !> caller; the blocks are stored either way.
    logical :: paired = .false.
    integer, allocatable :: kmir(:)              !< (nv) slot in b of the offset -o of slot kk's o
    real(mp), allocatable :: b(:, :, :, :, :)    !< (0:nx-1, 3, 3, nv, ys:ye) A(p, p+o), o to another row
    real(mp), allocatable :: br(:, :, :, :, :)   !< (3, 3, nr, 0:nx-1, ys:ye) A(p, p+o), o within the row
    real(mp), allocatable :: d(:, :, :, :)       !< (0:nx-1, 3, 3, ys:ye) row sums D_p
    real(mp), allocatable :: ainv(:, :, :, :)    !< (3, 3, 0:nx-1, ys:ye) inverse of A_pp
    real(rp), allocatable :: rsum(:)             !< (0:nx-1) row_sums' work: a local sized by nx was a
                                                 !< malloc and a free a row of every assembly
  end type stencil_t


contains

  !> Allocate the operator of rows ys..ye of an nx x ny lattice with reach r.
  !> lines: only the offsets that the cloth's elements couple (the eight
  !> neighbours of the links and, at reach 2, the far ends of the bending
  !> triples along x, y and the diagonals): the finest level's S, where
  !> the other eight offsets of the 5 x 5 stencil ((1, 2), (2, 1), ...) are
  !> always zero. Coarse levels (Galerkin) fill the whole square.
  subroutine stencil_init(st, nx, ny, ys, ye, r, lines)
    type(stencil_t), intent(inout) :: st
    integer, intent(in) :: nx, ny, ys, ye, r
    logical, intent(in), optional :: lines
    integer :: di, dj, k, kk, pass
    st%nx = nx
    st%ny = ny
    st%ys = ys
    st%ye = ye
    st%r = r
    if (allocated(st%odi)) deallocate(st%odi, st%odj, st%slot, st%kv, st%kr, st%dik, st%kmir, st%b, st%br, st%d, st%ainv, st%rsum)
    st%paired = .false.
    do pass = 1, 2
      k = 0
      do dj = -r, r
        do di = -r, r
          if (di == 0 .and. dj == 0) cycle
          if (present(lines)) then
            if (lines .and. .not. coupled_by_elements(di, dj)) cycle
          end if
          k = k + 1
          if (pass == 2) then
            st%odi(k) = di
            st%odj(k) = dj
          end if
        end do
      end do
      if (pass == 1) then
        st%nb = k
        allocate(st%odi(st%nb), st%odj(st%nb), st%slot(st%nb))
      end if
    end do
    st%nr = count(st%odj == 0)
    st%nv = st%nb - st%nr
    allocate(st%kv(st%nv), st%kr(st%nr))
    st%nv = 0
    st%nr = 0
    do k = 1, st%nb
      if (st%odj(k) == 0) then
        st%nr = st%nr + 1
        st%kr(st%nr) = k
        st%slot(k) = st%nr
      else
        st%nv = st%nv + 1
        st%kv(st%nv) = k
        st%slot(k) = st%nv
      end if
    end do
    st%dik = st%odi(st%kr)
    ! the stored offsets are symmetric about 0 (the square, or the lines)
    allocate(st%kmir(st%nv))
    do kk = 1, st%nv
      st%kmir(kk) = st%slot(offset_index(st, -st%odi(st%kv(kk)), -st%odj(st%kv(kk))))
    end do
    allocate(st%b(0:nx - 1, 3, 3, st%nv, ys:ye), st%br(3, 3, st%nr, 0:nx - 1, ys:ye))
    allocate(st%d(0:nx - 1, 3, 3, ys:ye), st%ainv(3, 3, 0:nx - 1, ys:ye), st%rsum(0:nx - 1))
    st%b = 0.0_mp
    st%br = 0.0_mp
    st%d = 0.0_mp
    st%ainv = 0.0_mp
  end subroutine stencil_init


  !> Index k of offset (di, dj) in st%odi, st%odj; 0 if not stored.
  pure integer function offset_index(st, di, dj) result(k)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: di, dj
    do k = 1, st%nb
      if (st%odi(k) == di .and. st%odj(k) == dj) return
    end do
    k = 0
  end function offset_index

  !> Block A(p, p + offset k) of node (i, j), in double precision.
  pure function stencil_block(st, i, j, k) result(blk)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: i, j, k
    real(rp) :: blk(3, 3)
    if (st%odj(k) == 0) then
      blk = real(st%br(:, :, st%slot(k), i, j), rp)
    else
      blk = real(st%b(i, :, :, st%slot(k), j), rp)
    end if
  end function stencil_block

  !> Diagonal block A_pp = D_p - sum_o B_{p,o} of node (i, j), in double precision.
  pure function diagonal_block(st, i, j) result(blk)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: i, j
    real(rp) :: blk(3, 3)
    integer :: k
    blk = real(st%d(i, :, :, j), rp)
    do k = 1, st%nb
      blk = blk - stencil_block(st, i, j, k)
    end do
  end function diagonal_block

  !> Set block A(p, p + offset k) of node (i, j) (rounded to kind mp).
  pure subroutine set_block(st, i, j, k, blk)
    type(stencil_t), intent(inout) :: st
    integer, intent(in) :: i, j, k
    real(rp), intent(in) :: blk(3, 3)
    if (st%odj(k) == 0) then
      st%br(:, :, st%slot(k), i, j) = real(blk, mp)
    else
      st%b(i, :, :, st%slot(k), j) = real(blk, mp)
    end if
  end subroutine set_block

  !> Store the block row of node (i, j) given as full blocks
  !> blk(3, 3, -r:r, -r:r) = A(p, p + (di, dj)) (zero outside the lattice),
  !> in double precision: B, the row sum D and the inverse of the diagonal
  !> block are formed before rounding to kind mp.
  subroutine stencil_put_row(st, i, j, blk)
    type(stencil_t), intent(inout) :: st
    integer, intent(in) :: i, j
    real(rp), intent(in) :: blk(:, :, -st%r:, -st%r:)
    real(rp) :: dsum(3, 3), inv(3, 3)
    integer :: k
    dsum = sum(sum(blk, dim=4), dim=3)
    do k = 1, st%nb
      call set_block(st, i, j, k, blk(:, :, st%odi(k), st%odj(k)))
    end do
    st%d(i, :, :, j) = real(dsum, mp)
    call block_inverse(blk(:, :, 0, 0), inv)
    st%ainv(:, :, i, j) = real(inv, mp)
  end subroutine stencil_put_row

  !> The coarse operator from its Galerkin sums ac(0:nx-1, 3, 3, -r:r, -r:r,
  !> ys:ye) (full blocks, double precision, nodes fastest; see
  !> galerkin_add), row by row in vector loops: the blocks to other rows,
  !> those within the row node by node, the row sums formed in double
  !> precision, the diagonal blocks inverted (row_inverses).
  subroutine stencil_finish(st, ac)
    type(stencil_t), intent(inout) :: st
    real(rp), intent(in), contiguous :: ac(0:, :, :, -st%r:, -st%r:, st%ys:)
    integer :: j, k, kk
    integer :: sk(0:(2 * st%r + 1)**2 - 1)
    ! every offset of the square (its slots in ac(:, :, :, :, :, j) taken
    ! as (0:nx-1, 9, slot)) into the row sums
    do k = 0, size(sk) - 1
      sk(k) = k + 1
    end do
    do j = st%ys, st%ye
      call row_sums(st%nx, size(sk), size(sk) - 1, sk, ac(:, :, :, :, :, j), st%d(:, :, :, j), st%rsum)
      do kk = 1, st%nv
        k = st%kv(kk)
        call to_single(st%nx * 9, ac(:, :, :, st%odi(k), st%odj(k), j), st%b(:, :, :, kk, j))
      end do
      do kk = 1, st%nr
        k = st%kr(kk)
        call put_within_row(st%nx, st%nr, kk, ac(:, :, :, st%odi(k), 0, j), st%br(:, :, :, :, j))
      end do
      call row_inverses(st%nx, ac(:, :, :, 0, 0, j), st%ainv(:, :, :, j))
    end do
  end subroutine stencil_finish

  !> stencil_finish's blocks of one offset within the row, a(i, :) (nodes
  !> fastest, double precision), into slot kk of br (node by node).
  !> Explicit shapes: over the derived type's component, the copy reloaded
  !> its descriptor at every node and took 40 % of stencil_finish.
  pure subroutine put_within_row(nx, nr, kk, a, br)
    integer, intent(in) :: nx, nr, kk
    real(rp), intent(in) :: a(0:nx - 1, 9)
    real(mp), intent(inout) :: br(9, nr, 0:nx - 1)
    integer :: i, e
    do i = 0, nx - 1
      do e = 1, 9
        br(e, kk, i) = real(a(i, e), mp)
      end do
    end do
  end subroutine put_within_row

  !> The row sums of stencil_row_from_full and stencil_finish: d(:, e) = sum over the slots sk(0:nb)
  !> of full(:, e, slot), in double precision, rounded to kind mp. Along
  !> the whole row (in tiles of 16 nodes, its 81 short loops a tile were
  !> half of stencil_row_from_full). acc(0:nx-1): work (stencil_t%rsum).
  pure subroutine row_sums(nx, nslot, nb, sk, full, d, acc)
    integer, intent(in) :: nx, nslot, nb
    integer, intent(in) :: sk(0:nb)
    real(rp), intent(in) :: full(0:nx - 1, 9, nslot)
    real(mp), intent(out) :: d(0:nx - 1, 9)
    real(rp), intent(inout) :: acc(0:nx - 1)
    integer :: e, k
    do e = 1, 9
      acc = full(:, e, sk(0))
      do k = 1, nb
        acc = acc + full(:, e, sk(k))
      end do
      d(:, e) = real(acc, mp)
    end do
  end subroutine row_sums

  !> The inverted diagonal blocks of a row, ainv(:, :, i) (node by node,
  !> kind mp), from the blocks dg(i, :) (nodes fastest, double precision):
  !> TILE nodes at a time through block_inverse_lanes. Explicit shapes, as
  !> put_within_row (written node by node over the derived type's
  !> component, the descriptor was reloaded at every node).
  pure subroutine row_inverses(nx, dg, ainv)
    integer, intent(in) :: nx
    real(rp), intent(in) :: dg(0:nx - 1, 9)
    real(mp), intent(out) :: ainv(9, 0:nx - 1)
    integer, parameter :: TILE = 16
    real(rp) :: a0(TILE, 9), inv(TILE, 9)
    integer :: i0, n, l, e
    do i0 = 0, nx - 1, TILE
      n = min(TILE, nx - i0)
      do e = 1, 9
        a0(1:n, e) = dg(i0:i0 + n - 1, e)
      end do
      call block_inverse_lanes(n, TILE, a0, inv)
      do l = 1, n
        do e = 1, 9
          ainv(e, i0 + l - 1) = real(inv(l, e), mp)
        end do
      end do
    end do
  end subroutine row_inverses

  !> y = x rounded to kind mp, n values.
  pure subroutine to_single(n, x, y)
    integer, intent(in) :: n
    real(rp), intent(in) :: x(n)
    real(mp), intent(out) :: y(n)
    y = real(x, mp)
  end subroutine to_single

  !> The whole operator (a level that stores the offsets the elements
  !> couple) from its blocks in double precision, by offset along the row,
  !> as module offset_product keeps S: B, the row sums D and the inverted
  !> diagonal blocks.
  subroutine stencil_from_full(st, full)
    type(stencil_t), intent(inout) :: st
    !> (0:nx-1, 3, 3, slot, ys:ye) A(p, p + (di, dj)) in slot
    !> offset_slot(r, di, dj), zero outside the lattice
    real(rp), intent(in) :: full(0:, :, :, :, st%ys:)
    integer :: j
    do j = st%ys, st%ye
      call stencil_row_from_full(st, full(:, :, :, :, j), j)
    end do
  end subroutine stencil_from_full

  !> Row j of the operator from that row of full, as stencil_from_full
  !> (the assembly calls it for each row as soon as the row is complete,
  !> while its blocks are still in the cache: module reduced_assembly).
  !> full keeps the nodes fastest, as this level's blocks to other rows,
  !> the row sums and the inverted diagonal blocks: those are formed in
  !> vector loops along the row (the inverses in tiles: row_inverses);
  !> only the blocks within the row go node by node (the smoother's point
  !> loop keeps them so).
  subroutine stencil_row_from_full(st, full, j)
    type(stencil_t), intent(inout) :: st
    real(rp), intent(in) :: full(0:, :, :, :)   !< (0:nx-1, 3, 3, slot) row j of full in stencil_from_full
    integer, intent(in) :: j
    integer, parameter :: MAXNB = 24               ! offsets of a reach-2 square (no allocation per row)
    integer :: k, kk, c1, c2, sk(0:MAXNB)
    ! (an internal invariant: only the finest level, reach 1 or 2, comes here)
    if (st%nb > MAXNB) error stop 'stencil_from_full: more offsets than a reach-2 level'
    ! the slot in full of every offset this level stores (the level stores
    ! the offsets the elements couple: stencil_init with lines)
    sk(0) = offset_slot(st%r, 0, 0)
    do k = 1, st%nb
      sk(k) = offset_slot(st%r, st%odi(k), st%odj(k))
    end do
    ! (an internal invariant: only the finest level, made with lines, comes here)
    if (any(sk(0:st%nb) == 0)) error stop 'stencil_from_full: the level stores offsets S does not'
    ! the blocks to other rows, along x
    do kk = 1, st%nv
      do c2 = 1, 3
        do c1 = 1, 3
          st%b(:, c1, c2, kk, j) = real(full(0:st%nx - 1, c1, c2, sk(st%kv(kk))), mp)
        end do
      end do
    end do
    ! the blocks within the row, node by node
    do kk = 1, st%nr
      call put_within_row(st%nx, st%nr, kk, full(:, :, :, sk(st%kr(kk))), st%br(:, :, :, :, j))
    end do
    ! the row sums, in double precision before rounding (the small mass
    ! term is what is left of the large stiffness blocks)
    call row_sums(st%nx, size(full, 4), st%nb, sk(0:st%nb), full, st%d(:, :, :, j), st%rsum)
    call row_inverses(st%nx, full(:, :, :, sk(0)), st%ainv(:, :, :, j))
  end subroutine stencil_row_from_full

  !> Inverse of a 3 x 3 block by cofactors (identity for a singular block:
  !> the smoother then leaves that node to the coarse correction).
  pure subroutine block_inverse(a, inv)
    real(rp), intent(in) :: a(3, 3)
    real(rp), intent(out) :: inv(3, 3)
    real(rp) :: det
    inv(1, 1) = a(2, 2) * a(3, 3) - a(2, 3) * a(3, 2)
    inv(1, 2) = a(1, 3) * a(3, 2) - a(1, 2) * a(3, 3)
    inv(1, 3) = a(1, 2) * a(2, 3) - a(1, 3) * a(2, 2)
    inv(2, 1) = a(2, 3) * a(3, 1) - a(2, 1) * a(3, 3)
    inv(2, 2) = a(1, 1) * a(3, 3) - a(1, 3) * a(3, 1)
    inv(2, 3) = a(1, 3) * a(2, 1) - a(1, 1) * a(2, 3)
    inv(3, 1) = a(2, 1) * a(3, 2) - a(2, 2) * a(3, 1)
    inv(3, 2) = a(1, 2) * a(3, 1) - a(1, 1) * a(3, 2)
    inv(3, 3) = a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)
    det = a(1, 1) * inv(1, 1) + a(1, 2) * inv(2, 1) + a(1, 3) * inv(3, 1)
    if (det == 0.0_rp) then
      inv = 0.0_rp
      inv(1, 1) = 1.0_rp
      inv(2, 2) = 1.0_rp
      inv(3, 3) = 1.0_rp
    else
      inv = inv / det
    end if
  end subroutine block_inverse

  !> block_inverse for n blocks at once, a(l, :, :), l = 1..n (lanes fastest,
  !> leading dimension ld): the same cofactors, the identity for a singular
  !> block.
  pure subroutine block_inverse_lanes(n, ld, a, inv)
    integer, intent(in) :: n, ld
    real(rp), intent(in) :: a(ld, 3, 3)
    real(rp), intent(out) :: inv(ld, 3, 3)
    real(rp) :: det
    logical :: sing
    integer :: l, c1, c2
    do l = 1, n
      inv(l, 1, 1) = a(l, 2, 2) * a(l, 3, 3) - a(l, 2, 3) * a(l, 3, 2)
      inv(l, 1, 2) = a(l, 1, 3) * a(l, 3, 2) - a(l, 1, 2) * a(l, 3, 3)
      inv(l, 1, 3) = a(l, 1, 2) * a(l, 2, 3) - a(l, 1, 3) * a(l, 2, 2)
      inv(l, 2, 1) = a(l, 2, 3) * a(l, 3, 1) - a(l, 2, 1) * a(l, 3, 3)
      inv(l, 2, 2) = a(l, 1, 1) * a(l, 3, 3) - a(l, 1, 3) * a(l, 3, 1)
      inv(l, 2, 3) = a(l, 1, 3) * a(l, 2, 1) - a(l, 1, 1) * a(l, 2, 3)
      inv(l, 3, 1) = a(l, 2, 1) * a(l, 3, 2) - a(l, 2, 2) * a(l, 3, 1)
      inv(l, 3, 2) = a(l, 1, 2) * a(l, 3, 1) - a(l, 1, 1) * a(l, 3, 2)
      inv(l, 3, 3) = a(l, 1, 1) * a(l, 2, 2) - a(l, 1, 2) * a(l, 2, 1)
      det = a(l, 1, 1) * inv(l, 1, 1) + a(l, 1, 2) * inv(l, 2, 1) + a(l, 1, 3) * inv(l, 3, 1)
      sing = det == 0.0_rp
      det = merge(1.0_rp, det, sing)
      do c2 = 1, 3
        do c1 = 1, 3
          inv(l, c1, c2) = merge(merge(1.0_rp, 0.0_rp, c1 == c2), inv(l, c1, c2) / det, sing)
        end do
      end do
    end do
  end subroutine block_inverse_lanes

end module mg_stencil
