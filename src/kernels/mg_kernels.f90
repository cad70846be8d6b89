! SPDX-License-Identifier: BSD-2-Clause
!> Kernels of nuno's structured multigrid (module stencil_mg) on a level's
!> vectors: the smoother (block Gauss-Seidel), the residual and the
!> products with a level's operator. Plain arrays; no PETSc, no MPI
!> (unit-tested alone: tests/unit/test_mg_kernels.f90). The operator's
!> storage is module mg_stencil, the transfers and the Galerkin coarse
!> operator module mg_transfer; this module passes both on, so that its
!> users take the multigrid's kernels from one place.
!>
!> Vectors are padded: x(-h:nx-1+h, 3, ys-h:ye+h), h >= r; the padding
!> outside the lattice stays zero and blocks pointing outside it are zero,
!> so the loops need no tests at the edges. Ghost rows inside the lattice
!> (another rank's) are filled by the caller.
module mg_kernels
  use kinds, only: rp
  use offset_product, only: coupled_by_elements
  use mg_stencil, only: mp, stencil_t, stencil_init, stencil_put_row, stencil_finish, stencil_from_full, &
                        stencil_row_from_full, offset_index, stencil_block, diagonal_block, block_inverse
  use mg_transfer, only: transfer_t, transfer_init, coarse_reach, interpolate, restrict_add, galerkin_add
  implicit none
  private
  public :: mp, stencil_t, transfer_t, stencil_init, stencil_put_row, stencil_finish, stencil_from_full, stencil_row_from_full, transfer_init, &
            coarse_reach, &
            coupled_by_elements, offset_index, stencil_block, diagonal_block
  public :: gs_sweep, residual, stencil_apply, interpolate, restrict_add, galerkin_add, block_inverse
  public :: stencil_product_mixed, level_product_rows

contains

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
  !>
  !> rows (j0, j1; without low and the product): only rows j0..j1 of the
  !> strip (stencil_mg's seam sweep).
  subroutine gs_sweep(st, h, x, rhs, forward, t, low, xs, acc, ds, y, rows)
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
    integer, intent(in), optional :: rows(2)
    integer :: j, jj, nx, nlow, kbeg, j0, j1, k

    nx = st%nx
    ! the offsets to other rows are in lexicographic order: those to the
    ! rows below first (counted in a loop: count() over the vector
    ! subscript made a temporary, a malloc and a free a sweep)
    nlow = 0
    do k = 1, st%nv
      if (st%odj(st%kv(k)) < 0) nlow = nlow + 1
    end do
    ! the padding columns of the product's rows stay zero
    if (present(y)) xs = 0.0_rp
    j0 = st%ys
    j1 = st%ye
    if (present(rows)) then
      j0 = rows(1)
      j1 = rows(2)
    end if
    do jj = 0, j1 - j0
      j = merge(j0 + jj, j1 - jj, forward)
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
      call point_row(nx, h, st%nr, st%dik, st%br(:, :, :, :, j), st%ainv(:, :, :, j), t, x(:, :, j), forward)
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
    nx = st%nx
    r = st%r
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
    call product_within_row(nx, r, st%nr, st%dik, st%br(:, :, :, :, j), xs(:, :, sj), acc, y(:, :, j))
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

end module mg_kernels
