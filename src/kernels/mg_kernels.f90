! SPDX-License-Identifier: BSD-2-Clause
!> Kernels of nuno's structured multigrid (module stencil_mg): a level's
!> operator on a strip of lattice rows stored by stencil offset, its
!> smoother, residual, Galerkin coarse operator and the transfers between
!> levels. Plain arrays; no PETSc, no MPI (unit-tested alone:
!> tests/unit/test_mg_kernels.f90).
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
!>
!> Transfers are tensor products of 1-D weights (bilinear, or the cubic
!> ones of module interpolation), fine point f of nf from coarse points of
!> nc = (nf - 1)/2 + 1.
module mg_kernels
  use, intrinsic :: iso_fortran_env, only: real32
  use kinds, only: rp
  use interpolation, only: cubic_weights
  use offset_product, only: coupled_by_elements, offset_slot
  implicit none
  private
  public :: mp, stencil_t, transfer_t, stencil_init, stencil_put_row, stencil_finish, stencil_from_full, stencil_row_from_full, transfer_init, &
            coarse_reach, &
            coupled_by_elements, offset_index, stencil_block, diagonal_block
  public :: gs_sweep, residual, stencil_apply, interpolate, restrict_add, galerkin_add, block_inverse
  public :: stencil_product_mixed, level_product_rows

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
  end type stencil_t

  !> 1-D transfer: fine point f takes w(1:n(f), f) of coarse points c(1:n(f), f).
  type :: transfer_t
    integer :: nf = 0, nc = 0
    integer, allocatable :: n(:)                 !< (0:nf-1)
    integer, allocatable :: c(:, :)              !< (4, 0:nf-1) 0-based coarse indices
    real(rp), allocatable :: w(:, :)             !< (4, 0:nf-1)
    !> The regular interior (found by transfer_init, used by interpolate and
    !> restrict_add along x in vector loops): every even fine point 2k is
    !> coarse point k (inject), and the odd fine points 2k + 1, k = klo..khi,
    !> take the same nodd (2 or 4) weights wodd of coarse points k + sodd ..
    !> k + sodd + nodd - 1; the other fine points, ends(:), point by point
    !> through the index arrays (every point when not inject). Point by
    !> point everywhere, these loops were 5 % of a step.
    logical :: inject = .false.
    integer :: klo = 0, khi = -1, nodd = 0, sodd = 0
    real(mp) :: wodd(4) = 0.0_mp
    integer, allocatable :: ends(:)
  end type transfer_t

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
    if (allocated(st%odi)) deallocate(st%odi, st%odj, st%slot, st%kv, st%kr, st%kmir, st%b, st%br, st%d, st%ainv)
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
    ! the stored offsets are symmetric about 0 (the square, or the lines)
    allocate(st%kmir(st%nv))
    do kk = 1, st%nv
      st%kmir(kk) = st%slot(offset_index(st, -st%odi(st%kv(kk)), -st%odj(st%kv(kk))))
    end do
    allocate(st%b(0:nx - 1, 3, 3, st%nv, ys:ye), st%br(3, 3, st%nr, 0:nx - 1, ys:ye))
    allocate(st%d(0:nx - 1, 3, 3, ys:ye), st%ainv(3, 3, 0:nx - 1, ys:ye))
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
      call row_sums(st%nx, size(sk), size(sk) - 1, sk, ac(:, :, :, :, :, j), st%d(:, :, :, j))
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
  !> half of stencil_row_from_full).
  pure subroutine row_sums(nx, nslot, nb, sk, full, d)
    integer, intent(in) :: nx, nslot, nb
    integer, intent(in) :: sk(0:nb)
    real(rp), intent(in) :: full(0:nx - 1, 9, nslot)
    real(mp), intent(out) :: d(0:nx - 1, 9)
    real(rp) :: acc(0:nx - 1)
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
    call row_sums(st%nx, size(full, 4), st%nb, sk(0:st%nb), full, st%d(:, :, :, j))
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

  !> 1-D weights from nc = (nf - 1)/2 + 1 coarse points to nf fine ones:
  !> bilinear, or cubic (module interpolation).
  subroutine transfer_init(tr, nf, cubic)
    type(transfer_t), intent(inout) :: tr
    integer, intent(in) :: nf
    logical, intent(in) :: cubic
    integer :: f, ix(4), n
    real(rp) :: w(4)
    tr%nf = nf
    tr%nc = (nf - 1) / 2 + 1
    if (allocated(tr%n)) deallocate(tr%n, tr%c, tr%w, tr%ends)
    allocate(tr%n(0:nf - 1), tr%c(4, 0:nf - 1), tr%w(4, 0:nf - 1))
    tr%c = 0
    tr%w = 0.0_rp
    do f = 0, nf - 1
      if (cubic) then
        call cubic_weights(f, tr%nc, ix, w, n)
      else if (mod(f, 2) == 0) then
        n = 1
        ix(1) = f / 2
        w(1) = 1.0_rp
      else
        n = 2
        ix(1:2) = [(f - 1) / 2, (f + 1) / 2]
        w(1:2) = 0.5_rp
      end if
      tr%n(f) = n
      tr%c(1:n, f) = ix(1:n)
      tr%w(1:n, f) = w(1:n)
    end do
    call find_regular(tr)
  end subroutine transfer_init

  !> The regular interior of a transfer (transfer_t): the odd fine points
  !> around the middle one with its weights, as far as they reach; the
  !> rest, in increasing order, its ends.
  subroutine find_regular(tr)
    type(transfer_t), intent(inout) :: tr
    integer :: f, k, km
    tr%inject = .true.
    do f = 0, tr%nf - 1, 2
      if (tr%n(f) /= 1 .or. tr%c(1, f) /= f / 2 .or. tr%w(1, f) /= 1.0_rp) tr%inject = .false.
    end do
    tr%klo = 0
    tr%khi = -1
    if (.not. tr%inject) then
      tr%ends = [(f, f = 0, tr%nf - 1)]
      return
    end if
    km = (tr%nf - 1) / 4                 ! the middle odd point, 2 km + 1
    if (tr%nf >= 3) then
      tr%nodd = tr%n(2 * km + 1)
      tr%sodd = tr%c(1, 2 * km + 1) - km
      tr%wodd = 0.0_mp
      tr%wodd(1:tr%nodd) = real(tr%w(1:tr%nodd, 2 * km + 1), mp)
    end if
    ! (interpolate_x's vector loops take 2 or 4 parents)
    if (tr%nf >= 3 .and. (tr%nodd == 2 .or. tr%nodd == 4)) then
      tr%klo = km
      tr%khi = km
      do while (tr%klo > 0)
        if (.not. regular(tr%klo - 1)) exit
        tr%klo = tr%klo - 1
      end do
      do while (2 * (tr%khi + 1) + 1 <= tr%nf - 1)
        if (.not. regular(tr%khi + 1)) exit
        tr%khi = tr%khi + 1
      end do
    end if
    tr%ends = [(2 * k + 1, k = 0, tr%klo - 1), (2 * k + 1, k = tr%khi + 1, (tr%nf - 2) / 2)]
  contains
    logical function regular(k)
      integer, intent(in) :: k
      integer :: a
      regular = tr%n(2 * k + 1) == tr%nodd
      if (.not. regular) return
      do a = 1, tr%nodd
        regular = regular .and. tr%c(a, 2 * k + 1) == k + tr%sodd + a - 1 &
                  .and. real(tr%w(a, 2 * k + 1), mp) == tr%wodd(a)
      end do
    end function regular
  end subroutine find_regular

  !> Reach of the Galerkin operator P^T A P along one direction, for an A
  !> of reach r: the largest |I - J| with I a parent of f1, J of f2,
  !> |f1 - f2| <= r (one-sided cubic weights at the ends included).
  pure integer function coarse_reach(tr, r) result(rc)
    type(transfer_t), intent(in) :: tr
    integer, intent(in) :: r
    integer :: f1, f2, a, b
    rc = 0
    do f1 = 0, tr%nf - 1
      do f2 = max(0, f1 - r), min(tr%nf - 1, f1 + r)
        do a = 1, tr%n(f1)
          do b = 1, tr%n(f2)
            rc = max(rc, abs(tr%c(a, f1) - tr%c(b, f2)))
          end do
        end do
      end do
    end do
  end function coarse_reach

  !> One Gauss-Seidel sweep with 3 x 3 blocks over rows ys..ye, forward
  !> (rows and points in increasing order) or backward. Within a row the
  !> couplings to other rows and to the points not yet visited are summed
  !> first, vectorised along the row; only the couplings to the points of
  !> the same row already visited are done point by point. Ghost rows of x
  !> hold the neighbour ranks' values (block Jacobi between strips, as
  !> PETSc's SOR). t(0:nx-1, 3): work.
  !>
  !> xs, acc, ds, y (backward sweeps only; all or none): the product
  !> y = A x of the sweep's result, formed as the sweep goes, as
  !> stencil_product_mixed forms it from x widened to double: row q's
  !> product needs rows q - r .. q + r final, which they are (on this
  !> strip) once the backward sweep has finished row q - r, so row j + r is
  !> formed right after row j, from blocks the sweep read r rows before (in
  !> the cache). Rows ys + r .. ye - r only: the others need the
  !> neighbours' final rows (level_product_rows, after an exchange).
  !> xs(-r:nx-1+r, 3, 0:2r), acc(0:nx-1, 4), ds(0:nx-1, 3): work;
  !> y(3, 0:nx-1, ys:ye).
  !>
  !> low(0:nx-1, 3, ys:ye), for a symmetric sweep (forward, then backward
  !> with the same rhs): the forward sweep keeps in it each row's rhs minus
  !> the sums over the blocks to the rows below, and the backward sweep
  !> takes it from there instead of reading those blocks again (a fifth of a symmetric
  !> sweep's bytes on the finest level with bending, more on the wide
  !> coarse levels): the rows below a row are not changed between its two
  !> visits. Not for the first r rows of a strip, whose rows below are the
  !> neighbour rank's, refreshed between the sweeps.
  subroutine gs_sweep(st, h, x, rhs, forward, t, low, xs, acc, ds, y)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: h
    real(mp), intent(inout), contiguous :: x(-h:, :, st%ys - h:)
    real(mp), intent(in) :: rhs(0:, :, st%ys:)
    logical, intent(in) :: forward
    real(mp), intent(inout), contiguous :: t(0:, :)
    real(mp), intent(inout), optional :: low(0:, :, st%ys:)
    real(rp), intent(inout), optional :: xs(-st%r:, :, 0:)
    real(rp), intent(inout), optional :: acc(0:, :)
    real(mp), intent(inout), optional :: ds(0:, :)
    real(rp), intent(inout), optional :: y(:, 0:, st%ys:)
    integer :: j, jj, k, nx, nlow, kbeg
    integer :: dik(st%nr)                         ! the offsets along the row, by k

    nx = st%nx
    do k = 1, st%nr
      dik(k) = st%odi(st%kr(k))
    end do
    ! the offsets to other rows are in lexicographic order: those to the
    ! rows below first
    nlow = count(st%odj(st%kv(1:st%nv)) < 0)
    ! the padding columns of the product's rows stay zero
    if (present(y)) xs = 0.0_rp
    do jj = 0, st%ye - st%ys
      j = merge(st%ys + jj, st%ye - jj, forward)
      kbeg = 1
      if (present(low)) then
        if (forward) then
          low(:, :, j) = rhs(:, :, j)
          call subtract_rows(1, nlow, j, low(:, :, j))
        end if
        if (forward .or. j >= st%ys + st%r) kbeg = nlow + 1
      end if
      if (kbeg > 1) then
        t = low(:, :, j)
      else
        t = rhs(:, :, j)
      end if
      ! the other rows: below already visited in a forward sweep, above not
      call subtract_rows(kbeg, st%nv, j, t)
      ! along the row, point by point: the points on one side visited already
      call point_row(nx, h, st%nr, dik, st%br(:, :, :, :, j), st%ainv(:, :, :, j), t, x(:, :, j), forward)
      if (present(y) .and. .not. forward) then
        call ring_row(st, h, x, j, xs)
        if (j + 2 * st%r <= st%ye) call product_row(st, j + st%r, xs, acc, ds, y)
      end if
    end do
  contains
    !> acc = acc - sum over the offsets kv(k0:k1) to other rows of row j's
    !> blocks times x, along the whole row.
    subroutine subtract_rows(k0, k1, j, acc)
      integer, intent(in) :: k0, k1, j
      real(mp), intent(inout) :: acc(0:, :)
      integer :: k, di, dj
      do k = k0, k1
        di = st%odi(st%kv(k))
        dj = st%odj(st%kv(k))
        if (st%paired .and. dj < 0 .and. j + dj >= st%ys) then
          call subtract_offset_mirror(nx, h, st%b(:, :, :, st%kmir(k), j + dj), x(:, :, j + dj), di, acc)
        else
          call subtract_offset(nx, h, st%b(:, :, :, k, j), x(:, :, j + dj), di, acc)
        end if
      end do
    end subroutine subtract_rows
  end subroutine gs_sweep

  !> acc = acc - B x(. + di) along a row for one offset to another row:
  !> its nine products in one loop, each x and acc value loaded once for
  !> three (nine loops of one product each: on the coarse levels, whose
  !> rows are short and offsets many, 15-25 % of a sweep went to the loops'
  !> starts and ends).
  pure subroutine subtract_offset(nx, h, b, xr, di, acc)
    integer, intent(in) :: nx, h, di
    real(mp), intent(in) :: b(0:nx - 1, 3, 3)          !< the row's blocks of this offset
    real(mp), intent(in) :: xr(-h:nx - 1 + h, 3)       !< the other row of the iterate
    real(mp), intent(inout) :: acc(0:nx - 1, 3)
    integer :: i
    real(mp) :: y1, y2, y3
    do i = 0, nx - 1
      y1 = xr(i + di, 1)
      y2 = xr(i + di, 2)
      y3 = xr(i + di, 3)
      acc(i, 1) = acc(i, 1) - b(i, 1, 1) * y1 - b(i, 1, 2) * y2 - b(i, 1, 3) * y3
      acc(i, 2) = acc(i, 2) - b(i, 2, 1) * y1 - b(i, 2, 2) * y2 - b(i, 2, 3) * y3
      acc(i, 3) = acc(i, 3) - b(i, 3, 1) * y1 - b(i, 3, 2) * y2 - b(i, 3, 3) * y3
    end do
  end subroutine subtract_offset

  !> subtract_offset for a paired operator, from the blocks bm(0:nx-1, 3, 3)
  !> of the other row's offset -(di, dj): A(p, p + o) = A(p + o, p), so
  !> acc(i) -= bm(i + di) x(i + di) where i + di lies in the row (the
  !> padding of x is zero, and so are the blocks that point there). A
  !> twin, not a shift argument of subtract_offset: that one loop over the
  !> nodes i + di reaches, with the block at i + shift, made the own
  !> blocks' sums 5-8 % slower (bench/mg_micro.sh 257 2 and 65 4 square);
  !> add_offset_mirror likewise for product_row.
  pure subroutine subtract_offset_mirror(nx, h, bm, xr, di, acc)
    integer, intent(in) :: nx, h, di
    real(mp), intent(in) :: bm(0:nx - 1, 3, 3)         !< the other row's blocks of offset -o
    real(mp), intent(in) :: xr(-h:nx - 1 + h, 3)       !< the other row of the iterate
    real(mp), intent(inout) :: acc(0:nx - 1, 3)
    integer :: i
    real(mp) :: y1, y2, y3
    do i = max(0, -di), min(nx - 1, nx - 1 - di)
      y1 = xr(i + di, 1)
      y2 = xr(i + di, 2)
      y3 = xr(i + di, 3)
      acc(i, 1) = acc(i, 1) - bm(i + di, 1, 1) * y1 - bm(i + di, 1, 2) * y2 - bm(i + di, 1, 3) * y3
      acc(i, 2) = acc(i, 2) - bm(i + di, 2, 1) * y1 - bm(i + di, 2, 2) * y2 - bm(i + di, 2, 3) * y3
      acc(i, 3) = acc(i, 3) - bm(i + di, 3, 1) * y1 - bm(i + di, 3, 2) * y2 - bm(i + di, 3, 3) * y3
    end do
  end subroutine subtract_offset_mirror

  !> The point-by-point part of a sweep over one row, in the sweep's order:
  !> x_i = A_ii^-1 (t_i - sum_k br(:, :, k, i) x_{i + dik(k)}), the points
  !> already visited at their new values. Each point waits on the one
  !> before it, so the work per point is the chain's length. The rows of
  !> reach 1 (dik = -1, 1) take their points in two colours instead
  !> (point_row_colour: odd, then even; backward the reverse); those of
  !> reach 2 (the finest level with bending, dik = -2, -1, 1, 2) go to a
  !> routine with its offsets fixed, which keeps the points just visited
  !> in registers and add their couplings last (the chain is then one block
  !> product and the inverse, not every block of the row); other reaches
  !> (the wide coarse levels) take the general loop. Explicit shapes and
  !> scalar temporaries: written over the derived type's components, the
  !> loop reloaded their descriptors and offsets at every point and took a
  !> third of a multigrid cycle.
  pure subroutine point_row(nx, h, nr, dik, br, ainv, t, x, forward)
    integer, intent(in) :: nx, h, nr
    integer, intent(in) :: dik(nr)
    real(mp), intent(in) :: br(3, 3, nr, 0:nx - 1)   !< blocks within the row
    real(mp), intent(in) :: ainv(3, 3, 0:nx - 1)     !< inverted diagonal blocks
    real(mp), intent(in) :: t(0:nx - 1, 3)           !< rhs minus the sums over the other rows
    real(mp), intent(inout) :: x(-h:nx - 1 + h, 3)   !< the row of the iterate (padding zero)
    logical, intent(in) :: forward
    integer :: ii, i, k, q
    real(mp) :: s1, s2, s3, y1, y2, y3
    if (nr == 2) then
      if (all(dik == [-1, 1])) then
        ! the odd points, then the even ones; backward the reverse
        if (forward) then
          call point_row_colour(nx, h, br, ainv, t, x, 1)
          call point_row_colour(nx, h, br, ainv, t, x, 0)
        else
          call point_row_colour(nx, h, br, ainv, t, x, 0)
          call point_row_colour(nx, h, br, ainv, t, x, 1)
        end if
        return
      end if
    else if (nr == 4) then
      if (all(dik == [-2, -1, 1, 2])) then
        if (forward) then
          call point_row_reach2(nx, h, br, ainv, t, x, 1, 2, 3, 4, 0, nx - 1, 1)
        else
          call point_row_reach2(nx, h, br, ainv, t, x, 4, 3, 2, 1, nx - 1, 0, -1)
        end if
        return
      end if
    end if
    do ii = 0, nx - 1
      i = ii
      if (.not. forward) i = nx - 1 - ii
      s1 = t(i, 1)
      s2 = t(i, 2)
      s3 = t(i, 3)
      do k = 1, nr
        q = i + dik(k)
        y1 = x(q, 1)
        y2 = x(q, 2)
        y3 = x(q, 3)
        s1 = s1 - br(1, 1, k, i) * y1 - br(1, 2, k, i) * y2 - br(1, 3, k, i) * y3
        s2 = s2 - br(2, 1, k, i) * y1 - br(2, 2, k, i) * y2 - br(2, 3, k, i) * y3
        s3 = s3 - br(3, 1, k, i) * y1 - br(3, 2, k, i) * y2 - br(3, 3, k, i) * y3
      end do
      x(i, 1) = ainv(1, 1, i) * s1 + ainv(1, 2, i) * s2 + ainv(1, 3, i) * s3
      x(i, 2) = ainv(2, 1, i) * s1 + ainv(2, 2, i) * s2 + ainv(2, 3, i) * s3
      x(i, 3) = ainv(3, 1, i) * s1 + ainv(3, 2, i) * s2 + ainv(3, 3, i) * s3
    end do
  end subroutine point_row

  !> point_row for dik = -1, 1 (the rows of reach 1: S without bending and
  !> its coarse levels): the points c, c + 2, .. of one colour (c = 0, 1),
  !> each from its two neighbours of the other colour, so no point waits on
  !> another. A sweep takes the odd points, then the even ones (backward
  !> the reverse, which keeps the symmetric sweep symmetric). Against the
  !> points in order (each waiting on the one before) it took fewer cycles
  !> (hang without bending, bw: 121 -> 116 at 257 x 257, 105 -> 102 at 129
  !> x 129, 61 -> 56 at 1025 x 1025 on 2 ranks, 162 both at 513 x 513;
  !> the even points first: 123 at 257 x 257) for the same time a point:
  !> that chain's latency was hidden by the loads of the blocks, so the
  !> points of a colour in vector loops (blocks along x) were no faster
  !> either (measured with commit bf6e404).
  pure subroutine point_row_colour(nx, h, br, ainv, t, x, c)
    integer, intent(in) :: nx, h, c
    real(mp), intent(in) :: br(3, 3, 2, 0:nx - 1), ainv(3, 3, 0:nx - 1), t(0:nx - 1, 3)
    real(mp), intent(inout) :: x(-h:nx - 1 + h, 3)
    integer :: i
    real(mp) :: s1, s2, s3, y1, y2, y3, z1, z2, z3
    do i = c, nx - 1, 2
      ! y: the point after (block 2, offset +1), z: the one before (block 1)
      y1 = x(i + 1, 1)
      y2 = x(i + 1, 2)
      y3 = x(i + 1, 3)
      z1 = x(i - 1, 1)
      z2 = x(i - 1, 2)
      z3 = x(i - 1, 3)
      s1 = t(i, 1) - (br(1, 1, 2, i) * y1 + br(1, 2, 2, i) * y2 + br(1, 3, 2, i) * y3) &
                   - (br(1, 1, 1, i) * z1 + br(1, 2, 1, i) * z2 + br(1, 3, 1, i) * z3)
      s2 = t(i, 2) - (br(2, 1, 2, i) * y1 + br(2, 2, 2, i) * y2 + br(2, 3, 2, i) * y3) &
                   - (br(2, 1, 1, i) * z1 + br(2, 2, 1, i) * z2 + br(2, 3, 1, i) * z3)
      s3 = t(i, 3) - (br(3, 1, 2, i) * y1 + br(3, 2, 2, i) * y2 + br(3, 3, 2, i) * y3) &
                   - (br(3, 1, 1, i) * z1 + br(3, 2, 1, i) * z2 + br(3, 3, 1, i) * z3)
      x(i, 1) = ainv(1, 1, i) * s1 + ainv(1, 2, i) * s2 + ainv(1, 3, i) * s3
      x(i, 2) = ainv(2, 1, i) * s1 + ainv(2, 2, i) * s2 + ainv(2, 3, i) * s3
      x(i, 3) = ainv(3, 1, i) * s1 + ainv(3, 2, i) * s2 + ainv(3, 3, i) * s3
    end do
  end subroutine point_row_colour

  !> The end of a point in point_row_reach2: s -= B p, the coupling to
  !> the point just visited (p, its new value), then p = A_ii^-1 s, this
  !> point's new value (the chain from one point to the next).
  pure subroutine point_finish(b, ainv, s1, s2, s3, p1, p2, p3)
    real(mp), intent(in) :: b(3, 3), ainv(3, 3)
    real(mp), intent(inout) :: s1, s2, s3, p1, p2, p3
    s1 = s1 - (b(1, 1) * p1 + b(1, 2) * p2 + b(1, 3) * p3)
    s2 = s2 - (b(2, 1) * p1 + b(2, 2) * p2 + b(2, 3) * p3)
    s3 = s3 - (b(3, 1) * p1 + b(3, 2) * p2 + b(3, 3) * p3)
    p1 = ainv(1, 1) * s1 + ainv(1, 2) * s2 + ainv(1, 3) * s3
    p2 = ainv(2, 1) * s1 + ainv(2, 2) * s2 + ainv(2, 3) * s3
    p3 = ainv(3, 1) * s1 + ainv(3, 2) * s2 + ainv(3, 3) * s3
  end subroutine point_finish

  !> point_row for dik = -2, -1, 1, 2, points i0, i0 + step, .., i1: kn1, kn2 the k of
  !> the offsets -step, -2 step (new), ko1, ko2 of +step, +2 step (old).
  pure subroutine point_row_reach2(nx, h, br, ainv, t, x, kn2, kn1, ko1, ko2, i0, i1, step)
    integer, intent(in) :: nx, h, kn2, kn1, ko1, ko2, i0, i1, step
    real(mp), intent(in) :: br(3, 3, 4, 0:nx - 1), ainv(3, 3, 0:nx - 1), t(0:nx - 1, 3)
    real(mp), intent(inout) :: x(-h:nx - 1 + h, 3)
    integer :: i
    real(mp) :: s1, s2, s3, p1, p2, p3, q1, q2, q3, y1, y2, y3, z1, z2, z3
    ! p: x at i - step, q: at i - 2 step, both new
    p1 = x(i0 - step, 1)
    p2 = x(i0 - step, 2)
    p3 = x(i0 - step, 3)
    q1 = x(i0 - 2 * step, 1)
    q2 = x(i0 - 2 * step, 2)
    q3 = x(i0 - 2 * step, 3)
    do i = i0, i1, step
      y1 = x(i + step, 1)
      y2 = x(i + step, 2)
      y3 = x(i + step, 3)
      z1 = x(i + 2 * step, 1)
      z2 = x(i + 2 * step, 2)
      z3 = x(i + 2 * step, 3)
      s1 = t(i, 1) - (br(1, 1, ko1, i) * y1 + br(1, 2, ko1, i) * y2 + br(1, 3, ko1, i) * y3) &
                   - (br(1, 1, ko2, i) * z1 + br(1, 2, ko2, i) * z2 + br(1, 3, ko2, i) * z3) &
                   - (br(1, 1, kn2, i) * q1 + br(1, 2, kn2, i) * q2 + br(1, 3, kn2, i) * q3)
      s2 = t(i, 2) - (br(2, 1, ko1, i) * y1 + br(2, 2, ko1, i) * y2 + br(2, 3, ko1, i) * y3) &
                   - (br(2, 1, ko2, i) * z1 + br(2, 2, ko2, i) * z2 + br(2, 3, ko2, i) * z3) &
                   - (br(2, 1, kn2, i) * q1 + br(2, 2, kn2, i) * q2 + br(2, 3, kn2, i) * q3)
      s3 = t(i, 3) - (br(3, 1, ko1, i) * y1 + br(3, 2, ko1, i) * y2 + br(3, 3, ko1, i) * y3) &
                   - (br(3, 1, ko2, i) * z1 + br(3, 2, ko2, i) * z2 + br(3, 3, ko2, i) * z3) &
                   - (br(3, 1, kn2, i) * q1 + br(3, 2, kn2, i) * q2 + br(3, 3, kn2, i) * q3)
      q1 = p1
      q2 = p2
      q3 = p3
      call point_finish(br(:, :, kn1, i), ainv(:, :, i), s1, s2, s3, p1, p2, p3)
      x(i, 1) = p1
      x(i, 2) = p2
      x(i, 3) = p3
    end do
  end subroutine point_row_reach2

  !> res = rhs - A x on rows ys..ye, in difference form (ghost rows of x filled).
  subroutine residual(st, h, x, rhs, res)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: h
    real(mp), intent(in) :: x(-h:, :, st%ys - h:)
    real(mp), intent(in) :: rhs(0:, :, st%ys:)
    real(mp), intent(out) :: res(0:, :, st%ys:)
    integer :: i, j, k, di, dj, c1, c2, nx
    nx = st%nx
    do j = st%ys, st%ye
      res(:, :, j) = rhs(:, :, j)
      do c2 = 1, 3
        do c1 = 1, 3
          res(:, c1, j) = res(:, c1, j) - st%d(:, c1, c2, j) * x(0:nx - 1, c2, j)
        end do
      end do
      do k = 1, st%nv
        di = st%odi(st%kv(k))
        dj = st%odj(st%kv(k))
        do c2 = 1, 3
          do c1 = 1, 3
            res(:, c1, j) = res(:, c1, j) - st%b(:, c1, c2, k, j) * (x(di:nx - 1 + di, c2, j + dj) - x(0:nx - 1, c2, j))
          end do
        end do
      end do
      do i = 0, nx - 1
        do k = 1, st%nr
          di = st%odi(st%kr(k))
          res(i, :, j) = res(i, :, j) - matmul(st%br(:, :, k, i, j), x(i + di, :, j) - x(i, :, j))
        end do
      end do
    end do
  end subroutine residual

  !> y = A x in double precision from this level's single-precision
  !> operator, in difference form: y_p = D_p x_p + sum_o B_{p,o} (x_{p+o} - x_p).
  !> The differences are formed in double; to the other rows, each offset's
  !> block times its difference (3 products and their sum) is formed in
  !> single precision and added to the node's sum in double; within the row
  !> and the mass term D in double. The Krylov method's product with S on the
  !> finest level (module reduced, -nuno_mg_product mixed): half the bytes
  !> of S in double precision, and every block's contribution is off by at
  !> most a few single roundings (a relative 2.4e-7) of itself, the mass term
  !> D by one (6e-8); the large stiffness blocks act only on differences and
  !> their contributions are summed in double, so no cancellation of K x
  !> magnifies that (docs/design.md). x(3, 0:nx-1, gys:gye) and
  !> y(3, 0:nx-1, ys:ye) in the layout of a 3-dof DMDA vector, x with the
  !> rows ys - r .. ye + r that lie in the lattice. xs(-r:nx-1+r, 3, 0:2r):
  !> work, 2 r + 1 rows of x along x fastest (row jr in slot
  !> modulo(jr, 2 r + 1)); acc(0:nx-1, 4) and ds(0:nx-1, 3): work.
  subroutine stencil_product_mixed(st, gys, gye, x, y, xs, acc, ds)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: gys, gye
    real(rp), intent(in) :: x(3, 0:st%nx - 1, gys:gye)
    real(rp), intent(out) :: y(3, 0:st%nx - 1, st%ys:st%ye)
    real(rp), intent(inout) :: xs(-st%r:, :, 0:)
    real(rp), intent(inout) :: acc(0:, :)
    real(mp), intent(inout) :: ds(0:, :)
    integer :: j, jr
    ! the padding columns stay zero (the blocks that point there are zero too)
    xs = 0.0_rp
    do jr = st%ys - st%r, st%ys + st%r - 1
      call load_row(jr)
    end do
    do j = st%ys, st%ye
      call load_row(j + st%r)
      call product_row(st, j, xs, acc, ds, y)
    end do
  contains
    !> Row jr of x into its slot of xs (zero outside the lattice).
    subroutine load_row(jr)
      integer, intent(in) :: jr
      integer :: s, ii
      s = modulo(jr, 2 * st%r + 1)
      if (jr < 0 .or. jr > st%ny - 1) then
        xs(:, :, s) = 0.0_rp
        return
      end if
      do ii = 0, st%nx - 1
        xs(ii, 1, s) = x(1, ii, jr)
        xs(ii, 2, s) = x(2, ii, jr)
        xs(ii, 3, s) = x(3, ii, jr)
      end do
    end subroutine load_row
  end subroutine stencil_product_mixed

  !> Row jr of a level's iterate x (single precision, padded, ghost rows
  !> ys - h .. ye + h) widened into its slot modulo(jr, 2 r + 1) of xs, as
  !> stencil_product_mixed keeps the rows of a double-precision x (zero
  !> outside the lattice).
  subroutine ring_row(st, h, x, jr, xs)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: h, jr
    real(mp), intent(in) :: x(-h:, :, st%ys - h:)
    real(rp), intent(inout) :: xs(-st%r:, :, 0:)
    integer :: s, c
    s = modulo(jr, 2 * st%r + 1)
    if (jr < 0 .or. jr > st%ny - 1) then
      xs(:, :, s) = 0.0_rp
      return
    end if
    do c = 1, 3
      xs(0:st%nx - 1, c, s) = real(x(0:st%nx - 1, c, jr), rp)
    end do
  end subroutine ring_row

  !> Rows j0..j1 (within ys..ye) of y = A x, x a level's iterate with its
  !> ghost rows exchanged, in the arithmetic of stencil_product_mixed (x
  !> widened to double): the rows of the product that gs_sweep cannot form
  !> as it goes. xs, acc, ds: work as there; y(3, 0:nx-1, ys:ye).
  subroutine level_product_rows(st, h, x, j0, j1, xs, acc, ds, y)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: h, j0, j1
    real(mp), intent(in) :: x(-h:, :, st%ys - h:)
    real(rp), intent(inout) :: xs(-st%r:, :, 0:)
    real(rp), intent(inout) :: acc(0:, :)
    real(mp), intent(inout) :: ds(0:, :)
    real(rp), intent(inout) :: y(:, 0:, st%ys:)
    integer :: j, jr
    if (j1 < j0) return
    xs = 0.0_rp
    do jr = j0 - st%r, j0 + st%r - 1
      call ring_row(st, h, x, jr, xs)
    end do
    do j = j0, j1
      call ring_row(st, h, x, j + st%r, xs)
      call product_row(st, j, xs, acc, ds, y)
    end do
  end subroutine level_product_rows

  !> Row j of y = A x, as stencil_product_mixed, from the rows j - r .. j + r
  !> of x in their slots of xs.
  subroutine product_row(st, j, xs, acc, ds, y)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: j
    real(rp), intent(in) :: xs(-st%r:, :, 0:)
    real(rp), intent(inout) :: acc(0:, :)
    real(mp), intent(inout) :: ds(0:, :)
    real(rp), intent(inout) :: y(:, 0:, st%ys:)
    integer :: nx, r, k, di, dj, c1, c2, sj, sq
    integer :: dik(st%nr)
    nx = st%nx
    r = st%r
    do k = 1, st%nr
      dik(k) = st%odi(st%kr(k))
    end do
    sj = modulo(j, 2 * r + 1)
    do c1 = 1, 3
      acc(0:nx - 1, c1) = st%d(:, c1, 1, j) * xs(0:nx - 1, 1, sj) + st%d(:, c1, 2, j) * xs(0:nx - 1, 2, sj) &
                        + st%d(:, c1, 3, j) * xs(0:nx - 1, 3, sj)
    end do
    ! the other rows, along the row: the difference rounded to single, the
    ! block times it in single (as wide a vector as the single blocks'
    ! loads; in double it ran at 6 GB/s against 10), the sum in double
    do k = 1, st%nv
      di = st%odi(st%kv(k))
      dj = st%odj(st%kv(k))
      sq = modulo(j + dj, 2 * r + 1)
      do c2 = 1, 3
        ds(0:nx - 1, c2) = real(xs(di:nx - 1 + di, c2, sq) - xs(0:nx - 1, c2, sj), mp)
      end do
      if (st%paired .and. dj < 0 .and. j + dj >= st%ys) then
        ! the blocks back from the row below, read with it (paired)
        call add_offset_mirror(nx, di, st%b(:, :, :, st%kmir(k), j + dj), ds, acc)
        cycle
      end if
      do c1 = 1, 3
        acc(0:nx - 1, c1) = acc(0:nx - 1, c1) + real(st%b(:, c1, 1, k, j) * ds(0:nx - 1, 1) &
          + st%b(:, c1, 2, k, j) * ds(0:nx - 1, 2) + st%b(:, c1, 3, k, j) * ds(0:nx - 1, 3), rp)
      end do
    end do
    ! within the row, node by node (as the smoother keeps these blocks),
    ! and the row of y
    call product_within_row(nx, r, st%nr, dik, st%br(:, :, :, :, j), xs(:, :, sj), acc, y(:, :, j))
  end subroutine product_row

  !> product_row's sum for one offset o = (di, dj) to another row of a
  !> paired operator: acc(i) += bm(i + di) ds(i), bm the other row's blocks
  !> of offset -o, where i + di lies in the row (elsewhere the block is 0).
  pure subroutine add_offset_mirror(nx, di, bm, ds, acc)
    integer, intent(in) :: nx, di
    real(mp), intent(in) :: bm(0:nx - 1, 3, 3)
    real(mp), intent(in) :: ds(0:nx - 1, 3)
    real(rp), intent(inout) :: acc(0:nx - 1, 3)
    integer :: i, c1
    do c1 = 1, 3
      do i = max(0, -di), min(nx - 1, nx - 1 - di)
        acc(i, c1) = acc(i, c1) + real(bm(i + di, c1, 1) * ds(i, 1) + bm(i + di, c1, 2) * ds(i, 2) &
                                       + bm(i + di, c1, 3) * ds(i, 3), rp)
      end do
    end do
  end subroutine add_offset_mirror

  !> The end of product_row: y_i = acc_i + sum_k br(:, :, k, i) (x_{i + dik(k)}
  !> - x_i) in double precision, node by node. Explicit shapes and the
  !> node's sums in registers: over the derived type's components, with
  !> the sums in acc, every product was a store and a reload (the scalar
  !> part was most of the product's time in the cache).
  pure subroutine product_within_row(nx, r, nr, dik, br, xr, acc, y)
    integer, intent(in) :: nx, r, nr
    integer, intent(in) :: dik(nr)
    real(mp), intent(in) :: br(3, 3, nr, 0:nx - 1)
    real(rp), intent(in) :: xr(-r:nx - 1 + r, 3)
    real(rp), intent(in) :: acc(0:nx - 1, 3)
    real(rp), intent(out) :: y(3, 0:nx - 1)
    integer :: i, k, q
    real(rp) :: s1, s2, s3, x1, x2, x3, d1, d2, d3
    do i = 0, nx - 1
      s1 = acc(i, 1)
      s2 = acc(i, 2)
      s3 = acc(i, 3)
      x1 = xr(i, 1)
      x2 = xr(i, 2)
      x3 = xr(i, 3)
      do k = 1, nr
        q = i + dik(k)
        d1 = xr(q, 1) - x1
        d2 = xr(q, 2) - x2
        d3 = xr(q, 3) - x3
        s1 = s1 + br(1, 1, k, i) * d1 + br(1, 2, k, i) * d2 + br(1, 3, k, i) * d3
        s2 = s2 + br(2, 1, k, i) * d1 + br(2, 2, k, i) * d2 + br(2, 3, k, i) * d3
        s3 = s3 + br(3, 1, k, i) * d1 + br(3, 2, k, i) * d2 + br(3, 3, k, i) * d3
      end do
      y(1, i) = s1
      y(2, i) = s2
      y(3, i) = s3
    end do
  end subroutine product_within_row

  !> y = A x on rows ys..ye (ghost rows of x filled); y(0:nx-1, 3, ys:ye).
  subroutine stencil_apply(st, h, x, y)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: h
    real(mp), intent(in) :: x(-h:, :, st%ys - h:)
    real(mp), intent(out) :: y(0:, :, st%ys:)
    real(mp), allocatable :: zero(:, :, :)
    allocate(zero(0:st%nx - 1, 3, st%ys:st%ye))
    zero = 0.0_mp
    call residual(st, h, x, zero, y)
    y = -y
  end subroutine stencil_apply

  !> xf = P xc (add: xf = xf + P xc) on fine rows ysf..yef. xc holds every
  !> coarse row that those rows need (its own padding hc). t(0:nxc-1, 3): work.
  subroutine interpolate(tx, ty, ysf, yef, hc, ysc, xc, hf, xf, add, t)
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: ysf, yef, hc, ysc, hf
    real(mp), intent(in) :: xc(-hc:, :, ysc - hc:)
    real(mp), intent(inout) :: xf(-hf:, :, ysf - hf:)
    logical, intent(in) :: add
    real(mp), intent(inout) :: t(0:, :)
    integer :: j, b, c, nxc
    nxc = tx%nc
    do j = ysf, yef
      t = 0.0_mp
      do b = 1, ty%n(j)
        t = t + real(ty%w(b, j), mp) * xc(0:nxc - 1, :, ty%c(b, j))
      end do
      if (.not. add) xf(0:tx%nf - 1, :, j) = 0.0_mp
      do c = 1, 3
        call interpolate_x(tx, tx%nf, tx%nc, t(:, c), xf(0:tx%nf - 1, c, j))
      end do
    end do
  end subroutine interpolate

  !> xf = xf + P_x t along one fine row (one component): the regular
  !> interior in vector loops (transfer_t), the rest point by point; the
  !> same sums in the same order either way.
  subroutine interpolate_x(tr, nf, nc, t, xf)
    type(transfer_t), intent(in) :: tr
    integer, intent(in) :: nf, nc
    real(mp), intent(in) :: t(0:nc - 1)
    real(mp), intent(inout) :: xf(0:nf - 1)
    integer :: m, k, s
    real(mp) :: w1, w2, w3, w4
    do m = 1, size(tr%ends)
      call point(tr%ends(m))
    end do
    if (.not. tr%inject) return
    do k = 0, (nf - 1) / 2
      xf(2 * k) = xf(2 * k) + t(k)
    end do
    s = tr%sodd
    w1 = tr%wodd(1)
    w2 = tr%wodd(2)
    w3 = tr%wodd(3)
    w4 = tr%wodd(4)
    select case (tr%nodd)
    case (2)
      do k = tr%klo, tr%khi
        xf(2 * k + 1) = xf(2 * k + 1) + w1 * t(k + s) + w2 * t(k + s + 1)
      end do
    case (4)
      do k = tr%klo, tr%khi
        xf(2 * k + 1) = xf(2 * k + 1) + w1 * t(k + s) + w2 * t(k + s + 1) + w3 * t(k + s + 2) + w4 * t(k + s + 3)
      end do
    end select
  contains
    subroutine point(i)
      integer, intent(in) :: i
      integer :: a
      do a = 1, tr%n(i)
        xf(i) = xf(i) + real(tr%w(a, i), mp) * t(tr%c(a, i))
      end do
    end subroutine point
  end subroutine interpolate_x

  !> t = P_x^T rf along one fine row (one component), as interpolate_x.
  subroutine restrict_x(tr, nf, nc, rf, t)
    type(transfer_t), intent(in) :: tr
    integer, intent(in) :: nf, nc
    real(mp), intent(in) :: rf(0:nf - 1)
    real(mp), intent(out) :: t(0:nc - 1)
    integer :: m, k, a, s
    real(mp) :: wa
    t = 0.0_mp
    do m = 1, size(tr%ends)
      call point(tr%ends(m))
    end do
    if (.not. tr%inject) return
    do k = 0, (nf - 1) / 2
      t(k) = t(k) + rf(2 * k)
    end do
    s = tr%sodd
    do a = 1, tr%nodd
      wa = tr%wodd(a)
      do k = tr%klo, tr%khi
        t(k + s + a - 1) = t(k + s + a - 1) + wa * rf(2 * k + 1)
      end do
    end do
  contains
    subroutine point(i)
      integer, intent(in) :: i
      integer :: a
      do a = 1, tr%n(i)
        t(tr%c(a, i)) = t(tr%c(a, i)) + real(tr%w(a, i), mp) * rf(i)
      end do
    end subroutine point
  end subroutine restrict_x

  !> rc = rc + P^T rf restricted to the contributions of fine rows
  !> ysf..yef; rc is padded (hc) so that it takes the coarse rows of other
  !> ranks too (the caller adds them where they belong). t(0:nxc-1, 3): work.
  subroutine restrict_add(tx, ty, ysf, yef, rf, hc, ysc, rc, t)
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: ysf, yef, hc, ysc
    real(mp), intent(in) :: rf(0:, :, ysf:)
    real(mp), intent(inout) :: rc(-hc:, :, ysc - hc:)
    real(mp), intent(inout) :: t(0:, :)
    integer :: j, b, c, nxc
    nxc = tx%nc
    do j = ysf, yef
      do c = 1, 3
        call restrict_x(tx, tx%nf, nxc, rf(0:tx%nf - 1, c, j), t(0:nxc - 1, c))
      end do
      do b = 1, ty%n(j)
        rc(0:nxc - 1, :, ty%c(b, j)) = rc(0:nxc - 1, :, ty%c(b, j)) + real(ty%w(b, j), mp) * t
      end do
    end do
  end subroutine restrict_add

  !> ac = ac + P^T A P restricted to the contributions of the fine rows
  !> ys..ye of A (full 3 x 3 blocks, double precision): ac(0:nxc-1, 3, 3,
  !> -rc:rc, -rc:rc, jc0:), coarse nodes fastest, with rows for every
  !> coarse row these fine rows touch (the caller adds other ranks' rows
  !> where they belong).
  !> Factored, P = P_y (x) P_x: each fine row j's blocks are first summed
  !> along x into bx(ci, 3, 3, cdi, dj) = sum_{i, i'} P_x(i, ci) A(ij, i'j')
  !> P_x(i', ci + cdi) (dj = j' - j), then bx along y into ac. Each fine
  !> block then takes (parents in x)^2 updates and each bx block (parents
  !> in y)^2, where the direct sum took their product: 16 against 4 + 4
  !> (bilinear), 256 against 16 + 16 (cubic), at worst. Nodes fastest
  !> everywhere, as the levels keep their blocks: the fine blocks are
  !> converted in vector loops, with bilinear transfers the sums along x
  !> are vector loops over the coarse nodes (galerkin_x_bilinear), the sums
  !> along y one vector loop over a coarse row, and stencil_finish makes
  !> the level from its sums in vector loops (node by node, with a block's
  !> nine entries together, these took 4-5 times as long: hang 257 x 257).
  subroutine galerkin_add(st, tx, ty, rc, jc0, ac, bx, rw)
    type(stencil_t), intent(in) :: st
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: rc, jc0
    real(rp), intent(inout), contiguous :: ac(0:, :, :, -rc:, -rc:, jc0:)
    real(rp), intent(inout), contiguous :: bx(0:, :, :, -rc:, -st%r:)  !< (0:nxc-1, 3, 3, -rc:rc, -r:r) work
    !> (0:nx-1, 3, 3, 2) work: a fine row's diagonal blocks D_p - sum_o B_{p,o}
    !> (dg) and its blocks of one offset (blk), in double precision
    real(rp), intent(inout), contiguous, target :: rw(0:, :, :, :)
    real(rp), pointer, contiguous :: dg(:, :), blk(:, :)
    integer :: j, k, di, dj, j2, b1, b2, cj, cdj, ilo, ihi, cilo, cihi, m
    logical :: bilinear
    dg(0:st%nx - 1, 1:9) => rw(:, :, :, 1)
    blk(0:st%nx - 1, 1:9) => rw(:, :, :, 2)
    ! bilinear along x: every odd fine point 2k + 1 takes 1/2 of coarse
    ! points k and k + 1 (transfer_init without cubic; find_regular found
    ! its interior regular), so coarse point ci has exactly the fine
    ! children 2 ci - 1, 2 ci and 2 ci + 1
    bilinear = tx%inject .and. tx%nodd == 2 .and. tx%sodd == 0 .and. size(tx%ends) == 0
    if (bilinear) bilinear = all(tx%wodd(1:2) == 0.5_mp)
    do j = st%ys, st%ye
      bx = 0.0_rp
      call row_sums_double(st%nx, st%d(:, :, :, j), dg)
      ! offset by offset along the row, the diagonal blocks last
      do k = 1, st%nb + 1
        if (k <= st%nb) then
          di = st%odi(k)
          dj = st%odj(k)
        else
          di = 0
          dj = 0
        end if
        j2 = j + dj
        if (j2 < 0 .or. j2 >= st%ny) cycle
        ilo = max(0, -di)
        ihi = min(st%nx - 1, st%nx - 1 - di)
        if (k > st%nb) then
          blk = dg
        else if (dj == 0) then
          call blocks_within_row(st%nx, st%nr, ilo, ihi, st%slot(k), st%br(:, :, :, :, j), blk, dg)
        else
          call blocks_to_row(st%nx, ilo, ihi, st%b(:, :, :, st%slot(k), j), blk, dg)
        end if
        ! the coarse nodes cilo..cihi whose fine children (2 ci - 1, 2 ci,
        ! 2 ci + 1 with weights 1/2, 1, 1/2) and their neighbours at di
        ! lie inside the row and the regular interior (bilinear
        ! transfers); the others through the general transfer
        cilo = 1
        cihi = 0
        if (bilinear) then
          m = min(ihi, 2 * tx%nc - 2, 2 * tx%nc - 2 - di)
          cilo = (ilo + 2) / 2
          cihi = cilo - 1
          if (m >= 1) cihi = (m - 1) / 2
        end if
        if (cilo <= cihi) then
          call galerkin_x_bilinear(st%nx, tx%nc, rc, st%r, cilo, cihi, di, dj, blk, bx)
          call galerkin_x(st%nx, tx%nc, rc, st%r, size(tx%c, 1), ilo, min(ihi, 2 * cilo - 1), di, dj, &
                          tx%n, tx%c, tx%w, blk, bx, cilo, cihi)
          call galerkin_x(st%nx, tx%nc, rc, st%r, size(tx%c, 1), max(ilo, 2 * cihi + 1), ihi, di, dj, &
                          tx%n, tx%c, tx%w, blk, bx, cilo, cihi)
        else
          call galerkin_x(st%nx, tx%nc, rc, st%r, size(tx%c, 1), ilo, ihi, di, dj, tx%n, tx%c, tx%w, blk, bx, 1, 0)
        end if
      end do
      do dj = -st%r, st%r
        j2 = j + dj
        if (j2 < 0 .or. j2 >= st%ny) cycle
        do b1 = 1, ty%n(j)
          cj = ty%c(b1, j)
          do b2 = 1, ty%n(j2)
            cdj = ty%c(b2, j2) - cj
            call galerkin_y(9 * (2 * rc + 1) * tx%nc, rc, st%r, dj, cdj, ty%w(b1, j) * ty%w(b2, j2), bx, &
                            ac(:, :, :, :, :, cj))
          end do
        end do
      end do
    end do
  end subroutine galerkin_add

  !> galerkin_add's sum along x of one offset (di, dj) of a fine row:
  !> bx(ci, :, cdi, dj) += P_x(i, ci) P_x(i + di, ci + cdi) blk(i, :) for
  !> i = ilo..ihi and their parents (n(i) of them, c(:, i), weights w(:, i)),
  !> but not for the coarse points xlo..xhi (galerkin_x_bilinear's).
  !> Explicit shapes (over the derived types' components, every update
  !> reloaded their descriptors: most of the coarse operators' set-up).
  pure subroutine galerkin_x(nx, nxc, rc, r, nmax, ilo, ihi, di, dj, n, c, w, blk, bx, xlo, xhi)
    integer, intent(in) :: nx, nxc, rc, r, nmax, ilo, ihi, di, dj, xlo, xhi
    integer, intent(in) :: n(0:nx - 1), c(nmax, 0:nx - 1)
    real(rp), intent(in) :: w(nmax, 0:nx - 1)
    real(rp), intent(in) :: blk(0:nx - 1, 9)
    real(rp), intent(inout) :: bx(0:nxc - 1, 9, -rc:rc, -r:r)
    integer :: i, i2, a1, a2, ci, cdi
    real(rp) :: wx, ww
    do i = ilo, ihi
      if (all(blk(i, :) == 0.0_rp)) cycle
      i2 = i + di
      do a1 = 1, n(i)
        ci = c(a1, i)
        if (ci >= xlo .and. ci <= xhi) cycle
        wx = w(a1, i)
        do a2 = 1, n(i2)
          cdi = c(a2, i2) - ci
          ww = wx * w(a2, i2)
          bx(ci, :, cdi, dj) = bx(ci, :, cdi, dj) + ww * blk(i, :)
        end do
      end do
    end do
  end subroutine galerkin_x

  !> galerkin_x for bilinear transfers, coarse points cilo..cihi, summed by
  !> coarse point in vector loops: bx(ci, :, cdi, dj) += sum_s wt(cdi, s)
  !> blk(2 ci + s, :), s = -1, 0, 1 (the children of ci, weights 1/2, 1,
  !> 1/2, each times the weight of coarse point ci + cdi in fine point
  !> 2 ci + s + di).
  pure subroutine galerkin_x_bilinear(nx, nxc, rc, r, cilo, cihi, di, dj, blk, bx)
    integer, intent(in) :: nx, nxc, rc, r, cilo, cihi, di, dj
    real(rp), intent(in) :: blk(0:nx - 1, 9)
    real(rp), intent(inout) :: bx(0:nxc - 1, 9, -rc:rc, -r:r)
    real(rp) :: wt(-rc:rc, -1:1), wa, w1, w0, w2
    integer :: s, t, ci, cdi, e
    wt = 0.0_rp
    do s = -1, 1
      wa = merge(1.0_rp, 0.5_rp, s == 0)
      t = s + di                                ! fine point 2 ci + t
      if (modulo(t, 2) == 0) then
        wt(t / 2, s) = wt(t / 2, s) + wa
      else
        wt((t - 1) / 2, s) = wt((t - 1) / 2, s) + 0.5_rp * wa
        wt((t + 1) / 2, s) = wt((t + 1) / 2, s) + 0.5_rp * wa
      end if
    end do
    do cdi = -rc, rc
      w1 = wt(cdi, -1)
      w0 = wt(cdi, 0)
      w2 = wt(cdi, 1)
      if (w1 == 0.0_rp .and. w0 == 0.0_rp .and. w2 == 0.0_rp) cycle
      do e = 1, 9
        do ci = cilo, cihi
          bx(ci, e, cdi, dj) = bx(ci, e, cdi, dj) + (w1 * blk(2 * ci - 1, e) + w0 * blk(2 * ci, e) + w2 * blk(2 * ci + 1, e))
        end do
      end do
    end do
  end subroutine galerkin_x_bilinear

  !> galerkin_add's diagonal blocks of a fine row start as its row sums
  !> d (single precision) in double precision.
  pure subroutine row_sums_double(nx, d, dg)
    integer, intent(in) :: nx
    real(mp), intent(in) :: d(0:nx - 1, 9)
    real(rp), intent(out) :: dg(0:nx - 1, 9)
    dg = real(d, rp)
  end subroutine row_sums_double

  !> galerkin_add's blocks of one offset to another row (b of row j,
  !> single precision) into blk(i, :), i = ilo..ihi, in double precision,
  !> and subtracted from the diagonal blocks dg.
  pure subroutine blocks_to_row(nx, ilo, ihi, b, blk, dg)
    integer, intent(in) :: nx, ilo, ihi
    real(mp), intent(in) :: b(0:nx - 1, 9)
    real(rp), intent(inout) :: blk(0:nx - 1, 9), dg(0:nx - 1, 9)
    integer :: e
    do e = 1, 9
      blk(ilo:ihi, e) = real(b(ilo:ihi, e), rp)
      dg(ilo:ihi, e) = dg(ilo:ihi, e) - blk(ilo:ihi, e)
    end do
  end subroutine blocks_to_row

  !> As blocks_to_row for the blocks of offset sl within the row (br of
  !> row j, node by node).
  pure subroutine blocks_within_row(nx, nr, ilo, ihi, sl, br, blk, dg)
    integer, intent(in) :: nx, nr, ilo, ihi, sl
    real(mp), intent(in) :: br(9, nr, 0:nx - 1)
    real(rp), intent(inout) :: blk(0:nx - 1, 9), dg(0:nx - 1, 9)
    integer :: i, e
    do e = 1, 9
      do i = ilo, ihi
        blk(i, e) = real(br(e, sl, i), rp)
        dg(i, e) = dg(i, e) - blk(i, e)
      end do
    end do
  end subroutine blocks_within_row

  !> galerkin_add's sum along y: coarse row cj's sums at offset cdj take
  !> wy times the fine row's sums along x at offset dj (n values: every
  !> coarse node's blocks of every cdi), one vector loop.
  pure subroutine galerkin_y(n, rc, r, dj, cdj, wy, bx, acj)
    integer, intent(in) :: n, rc, r, dj, cdj
    real(rp), intent(in) :: wy
    real(rp), intent(in) :: bx(n, -r:r)
    real(rp), intent(inout) :: acj(n, -rc:rc)
    acj(:, cdj) = acj(:, cdj) + wy * bx(:, dj)
  end subroutine galerkin_y

end module mg_kernels
