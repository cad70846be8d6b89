! SPDX-License-Identifier: BSD-2-Clause
!> MPI test of nuno's structured multigrid (module stencil_mg) on a stiff
!> model of the reduced system: per component a biharmonic (bending,
!> 1e4) plus a Laplacian (stretching, 1e2) plus a small non-symmetric
!> coupling between the components, zero row sums, and a mass term 1 on a
!> 65 x 65 lattice (reach 2), the two top corners "pinned" (row a m I, no
!> coupling), as S of hang looks:
!>  1. on P ranks the coarse operators of every level equal those of the
!>     same hierarchy built on one rank (each rank builds that one on
!>     MPI_COMM_SELF), to single-precision round-off: the partial Galerkin
!>     sums crossing strip boundaries are added where they belong;
!>  2. V-cycles as a stationary iteration, with the residual in double
!>     precision, reduce it by at least 0.75 per cycle on average (bilinear
!>     and cubic transfer; measured 0.65-0.70), and the kaskade cycle
!>     inside a one-vector minimal-residual iteration too on one rank;
!>  3. one cycle on P ranks gives the one-rank cycle's answer to 1 % (the
!>     smoother couples the strips block-Jacobi-wise: measured 1e-4 V,
!>     3e-3 kaskade), and P-rank V-cycles converge to the one-rank solution.
!>  4. with the seam sweeps on (module mg_coarse sets them where the
!>     faces' blocks couple neighbours), the product A x that the finest
!>     level's last smoothing forms as it goes (mg_apply's ax) is the
!>     finest operator's product of the cycle's x (mg_product of x, its
!>     halo exchanged) to the last bit: the rows the seam sweeps change
!>     after the backward sweep, here and on the neighbour below, have
!>     their products formed again.
!> Run on 1, 3 and 8 ranks: on 8 the thin coarse levels are gathered on
!> fewer ranks (module mg_gather), and checks 1 and 3 compare their
!> Galerkin sums and transfers with one rank's.
!> Kaskade on several strips is a preconditioner, not a convergent
!> stationary iteration, for this operator: its last smoothing starts from
!> the interpolated coarse answer, and the strips' block-Jacobi coupling
!> leaves differences at their boundaries that a stiffness of 1e4 times the
!> mass amplifies (the minimal-residual iteration stalls at 0.88 on 3
!> ranks). Inside FGMRES on hang it takes the one-rank iteration count
!> (tests/python/test_solver_reduced.py, docs/performance.md).
program test_stencil_mg
  use mpi
  use kinds, only: rp
  use stencil_mg, only: stencil_mg_t, mg_create, mg_destroy, mg_set_fine, mg_build_coarse, mg_apply, mg_set_seam, &
                        mg_product
  use solver_choices, only: CYCLE_V, CYCLE_KASKADE
  use check, only: check_true, check_close, check_report
  use offset_product, only: offset_count, offset_slot
  implicit none
  integer, parameter :: n = 65, r = 2
  integer :: ierr, rank, nranks, ys, ye, rows, base, extra, k

  call MPI_Init(ierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, ierr)
  call MPI_Comm_size(MPI_COMM_WORLD, nranks, ierr)
  ! strips as a DMDA makes them: whole rows, the first ranks one more
  base = n / nranks
  extra = mod(n, nranks)
  ys = 0
  do k = 0, rank - 1
    ys = ys + base + merge(1, 0, k < extra)
  end do
  rows = base + merge(1, 0, rank < extra)
  ye = ys + rows - 1

  call run_case(.false., CYCLE_V, 'bilinear, V', .false.)
  call run_case(.true., CYCLE_V, 'cubic, V', .false.)
  call run_case(.true., CYCLE_KASKADE, 'cubic, kaskade', .false.)
  ! nuno's default with bending: the finest level's correction cubic too
  ! (its restriction and Galerkin product bilinear)
  call run_case(.true., CYCLE_KASKADE, 'cubic, kaskade, cubic correction', .true.)
  call run_case(.true., CYCLE_V, 'cubic, V, cubic correction', .true.)
  call check_report()
  call MPI_Finalize(ierr)

contains

  logical pure function pinned(i, j)
    integer, intent(in) :: i, j
    pinned = j == n - 1 .and. (i == 0 .or. i == n - 1)
  end function pinned

  !> The model operator's block row of node (i, j) by offset.
  pure subroutine model_row(i, j, blk)
    integer, intent(in) :: i, j
    real(rp), intent(out) :: blk(3, 3, -r:r, -r:r)
    real(rp), parameter :: kb = 1.0e4_rp, ks = 1.0e2_rp, eps = 0.05_rp
    real(rp) :: bih(-2:2, -2:2), lap(-1:1, -1:1), cpl(3, 3)
    integer :: di, dj, c
    bih = 0.0_rp
    bih(0, -2) = 1; bih(0, 2) = 1; bih(-2, 0) = 1; bih(2, 0) = 1
    bih(-1, -1) = 2; bih(1, -1) = 2; bih(-1, 1) = 2; bih(1, 1) = 2
    bih(0, -1) = -8; bih(0, 1) = -8; bih(-1, 0) = -8; bih(1, 0) = -8
    lap = 0.0_rp
    lap(0, -1) = -1; lap(0, 1) = -1; lap(-1, 0) = -1; lap(1, 0) = -1
    cpl = 0.0_rp
    cpl(1, 2) = eps
    cpl(2, 3) = -eps
    cpl(3, 1) = 0.5_rp * eps
    blk = 0.0_rp
    if (.not. pinned(i, j)) then
      do dj = -r, r
        do di = -r, r
          if (di == 0 .and. dj == 0) cycle
          if (i + di < 0 .or. i + di >= n .or. j + dj < 0 .or. j + dj >= n) cycle
          if (pinned(i + di, j + dj)) cycle
          do c = 1, 3
            blk(c, c, di, dj) = kb * bih(di, dj)
            if (abs(di) <= 1 .and. abs(dj) <= 1) blk(c, c, di, dj) = blk(c, c, di, dj) + ks * lap(di, dj)
          end do
          if (abs(di) + abs(dj) == 1) blk(:, :, di, dj) = blk(:, :, di, dj) - ks * cpl
          ! zero row sum: the diagonal takes minus the coupling (a
          ! positive semidefinite stiffness wherever the stencil is whole)
          blk(:, :, 0, 0) = blk(:, :, 0, 0) - blk(:, :, di, dj)
        end do
      end do
    end if
    do c = 1, 3
      blk(c, c, 0, 0) = blk(c, c, 0, 0) + 1.0_rp
    end do
  end subroutine model_row

  !> The model operator in the storage of module offset_product: only the
  !> offsets the elements couple (the model has no others: checked).
  subroutine fill(full, y0, y1)
    real(rp), intent(out) :: full(0:, :, :, :, y0:)
    integer, intent(in) :: y0, y1
    real(rp) :: blk(3, 3, -r:r, -r:r)
    integer :: i, j, di, dj, k
    logical :: others_zero
    others_zero = .true.
    do j = y0, y1
      do i = 0, n - 1
        call model_row(i, j, blk)
        do dj = -r, r
          do di = -r, r
            k = offset_slot(r, di, dj)
            if (k > 0) then
              full(i, :, :, k, j) = blk(:, :, di, dj)
            else
              others_zero = others_zero .and. all(blk(:, :, di, dj) == 0.0_rp)
            end if
          end do
        end do
      end do
    end do
    call check_true(others_zero, 'the model couples only the stored offsets')
  end subroutine fill

  !> res = b - A x on rows y0..y1, double precision; x on rows y0-r..y1+r
  !> (those outside the lattice zero); also the whole lattice on one rank.
  subroutine model_residual(x, b, res, y0, y1)
    integer, intent(in) :: y0, y1
    real(rp), intent(in) :: x(:, -r:, y0 - r:), b(:, 0:, y0:)
    real(rp), intent(out) :: res(:, 0:, y0:)
    real(rp) :: blk(3, 3, -r:r, -r:r)
    integer :: i, j, di, dj
    do j = y0, y1
      do i = 0, n - 1
        call model_row(i, j, blk)
        res(:, i, j) = b(:, i, j)
        do dj = -r, r
          do di = -r, r
            res(:, i, j) = res(:, i, j) - matmul(blk(:, :, di, dj), x(:, i + di, j + dj))
          end do
        end do
      end do
    end do
  end subroutine model_residual

  !> Halo rows of x(3, -r:n-1+r, ys-r:ye+r) from the neighbouring strips.
  subroutine halo(x, comm)
    real(rp), intent(inout) :: x(:, -r:, ys - r:)
    integer, intent(in) :: comm
    integer :: below, above, cnt, np, me
    call MPI_Comm_size(comm, np, ierr)
    call MPI_Comm_rank(comm, me, ierr)
    if (np == 1) return
    below = merge(me - 1, MPI_PROC_NULL, me > 0)
    above = merge(me + 1, MPI_PROC_NULL, me < np - 1)
    cnt = size(x(:, :, ys:ys + r - 1))
    call MPI_Sendrecv(x(1, -r, ys), cnt, MPI_DOUBLE_PRECISION, below, 1, x(1, -r, ye + 1), cnt, MPI_DOUBLE_PRECISION, &
                      above, 1, comm, MPI_STATUS_IGNORE, ierr)
    call MPI_Sendrecv(x(1, -r, ye - r + 1), cnt, MPI_DOUBLE_PRECISION, above, 2, x(1, -r, ys - r), cnt, &
                      MPI_DOUBLE_PRECISION, below, 2, comm, MPI_STATUS_IGNORE, ierr)
  end subroutine halo

  real(rp) function gnorm(v)
    real(rp), intent(in) :: v(:, :, :)
    real(rp) :: s
    s = sum(v**2)
    call MPI_Allreduce(MPI_IN_PLACE, s, 1, MPI_DOUBLE_PRECISION, MPI_SUM, MPI_COMM_WORLD, ierr)
    gnorm = sqrt(s)
  end function gnorm

  real(rp) function gdot(u, v)
    real(rp), intent(in) :: u(:, :, :), v(:, :, :)
    real(rp) :: s
    s = sum(u * v)
    call MPI_Allreduce(MPI_IN_PLACE, s, 1, MPI_DOUBLE_PRECISION, MPI_SUM, MPI_COMM_WORLD, ierr)
    gdot = s
  end function gdot

  subroutine run_case(cubic, cycle_type, label, up)
    logical, intent(in) :: cubic
    integer, intent(in) :: cycle_type
    character(len=*), intent(in) :: label
    logical, intent(in) :: up                 ! the finest level's coarse correction interpolated cubic
    type(stencil_mg_t) :: mg, mg1
    real(rp), allocatable :: full(:, :, :, :, :), full1(:, :, :, :, :)
    real(rp), allocatable :: x(:, :, :), b(:, :, :), res(:, :, :), e(:, :, :), ae(:, :, :), xs(:, :, :), x1(:, :, :)
    logical :: flags(10), flags_up(10)
    real(rp) :: err, scale, r0, rk, alpha
    integer :: l, i, j, it, nit, c
    character(len=96) :: what

    flags = cubic
    flags(1) = .false.              ! the finest transfer bilinear, as nuno's default with bending
    flags_up = flags
    flags_up(1) = up
    allocate(full(0:n - 1, 3, 3, offset_count(r), ys:ye), full1(0:n - 1, 3, 3, offset_count(r), 0:n - 1))
    call fill(full, ys, ye)
    call fill(full1, 0, n - 1)
    call mg_create(mg, MPI_COMM_WORLD, n, n, ys, ye, r, flags, 10, cycle_type, 1, flags_up, gather=.true.)
    call mg_create(mg1, MPI_COMM_SELF, n, n, 0, n - 1, r, flags, 10, cycle_type, 1, flags_up)
    call mg_set_fine(mg, full)
    call mg_set_fine(mg1, full1)
    call mg_build_coarse(mg, ierr)
    call check_true(ierr == 0, label//': coarsest factorised')
    call mg_build_coarse(mg1, ierr)

    ! 1. Coarse operators: the distributed levels against the one-rank ones.
    ! (on more than 3 strips of this 65 x 65 lattice the cubic transfers'
    ! halo makes the third level too thin to distribute; on more than 4
    ! it is gathered on fewer ranks, module mg_gather, and the hierarchy
    ! is the one-rank one: its Galerkin sums gathered from every rank)
    call check_true(mg%nlev >= 4, label//': at least 4 levels')
    if (nranks > 4) call check_true(mg%nlev == mg1%nlev, label//': the levels of one rank')
    do l = 2, mg%nlev
      associate (a => mg%lev(l)%a, a1 => mg1%lev(l)%a)
        err = 0.0_rp
        scale = 0.0_rp
        if (a%r == a1%r .and. a%nx == a1%nx) then
          do j = a%ys, a%ye
            err = max(err, maxval(abs(a%b(:, :, :, :, j) - a1%b(:, :, :, :, j))), maxval(abs(a%d(:, :, :, j) - a1%d(:, :, :, j))), &
                      maxval(abs(a%br(:, :, :, :, j) - a1%br(:, :, :, :, j))))
            scale = max(scale, maxval(abs(a1%b(:, :, :, :, j))), maxval(abs(a1%d(:, :, :, j))), maxval(abs(a1%br(:, :, :, :, j))))
          end do
        else
          err = huge(1.0_rp)
        end if
        call MPI_Allreduce(MPI_IN_PLACE, err, 1, MPI_DOUBLE_PRECISION, MPI_MAX, MPI_COMM_WORLD, ierr)
        call MPI_Allreduce(MPI_IN_PLACE, scale, 1, MPI_DOUBLE_PRECISION, MPI_MAX, MPI_COMM_WORLD, ierr)
        write(what, '(a, a, i0, a)') label, ': level ', l, ' as on one rank'
        call check_close(err, 0.0_rp, 0.0_rp, 1.0e-6_rp * scale, trim(what))
      end associate
    end do

    ! 2. Convergence: x <- x + alpha M^{-1} res, residual in double precision
    ! (alpha = 1 for the V-cycle; for kaskade the minimal-residual step).
    allocate(x(3, -r:n - 1 + r, ys - r:ye + r), b(3, 0:n - 1, ys:ye), res(3, 0:n - 1, ys:ye), e(3, 0:n - 1, ys:ye))
    allocate(xs(3, -r:n - 1 + r, ys - r:ye + r), ae(3, 0:n - 1, ys:ye))
    do j = ys, ye
      do i = 0, n - 1
        do c = 1, 3
          b(c, i, j) = sin(0.3_rp * i + 0.1_rp * c) * cos(0.2_rp * j) + merge(1.0_rp, 0.0_rp, i == 20 .and. j == 40)
        end do
      end do
    end do
    x = 0.0_rp
    r0 = gnorm(b)
    nit = 12
    do it = 1, nit
      call halo(x, MPI_COMM_WORLD)
      call model_residual(x, b, res, ys, ye)
      call mg_apply(mg, res, e)
      if (cycle_type == CYCLE_KASKADE) then
        xs = 0.0_rp
        xs(:, 0:n - 1, ys:ye) = e
        call halo(xs, MPI_COMM_WORLD)
        res = 0.0_rp
        call model_residual(xs, res, ae, ys, ye)    ! ae = -A e
        call model_residual(x, b, res, ys, ye)
        alpha = -gdot(ae, res) / gdot(ae, ae)
      else
        alpha = 1.0_rp
      end if
      x(:, 0:n - 1, ys:ye) = x(:, 0:n - 1, ys:ye) + alpha * e
    end do
    call halo(x, MPI_COMM_WORLD)
    call model_residual(x, b, res, ys, ye)
    rk = gnorm(res)
    write(what, '(a, a, es9.2)') label, ': 12 cycles reduce the residual by 0.75^12, measured ', rk / r0
    ! (kaskade on several strips: see the header)
    if (cycle_type /= CYCLE_KASKADE .or. nranks == 1) call check_true(rk < 0.75_rp**nit * r0, trim(what))

    ! 3. The same answer as the one-rank hierarchy (each rank runs it whole).
    allocate(x1(3, -r:n - 1 + r, -r:n - 1 + r))
    x1 = 0.0_rp
    block
      real(rp), allocatable :: b1(:, :, :), res1(:, :, :), e1(:, :, :)
      allocate(b1(3, 0:n - 1, 0:n - 1), res1(3, 0:n - 1, 0:n - 1), e1(3, 0:n - 1, 0:n - 1))
      do j = 0, n - 1
        do i = 0, n - 1
          do c = 1, 3
            b1(c, i, j) = sin(0.3_rp * i + 0.1_rp * c) * cos(0.2_rp * j) + merge(1.0_rp, 0.0_rp, i == 20 .and. j == 40)
          end do
        end do
      end do
      call mg_apply(mg1, b1, e1)
      call mg_apply(mg, b, e)
      err = maxval(abs(e - e1(:, :, ys:ye)))
      call MPI_Allreduce(MPI_IN_PLACE, err, 1, MPI_DOUBLE_PRECISION, MPI_MAX, MPI_COMM_WORLD, ierr)
      write(what, '(a, a, i0, a)') label, ': one cycle on ', nranks, ' ranks as on one, to 1 %'
      call check_close(err, 0.0_rp, 0.0_rp, 1.0e-2_rp * maxval(abs(e1)), trim(what))
      do it = 1, 40
        call model_residual(x1, b1, res1, 0, n - 1)
        call mg_apply(mg1, res1, e1)
        x1(:, 0:n - 1, 0:n - 1) = x1(:, 0:n - 1, 0:n - 1) + e1
        if (cycle_type == CYCLE_KASKADE) exit      ! (step 3 only for the V-cycle)
      end do
    end block
    if (cycle_type /= CYCLE_KASKADE) then
      do it = 1, 28
        call halo(x, MPI_COMM_WORLD)
        call model_residual(x, b, res, ys, ye)
        call mg_apply(mg, res, e)
        x(:, 0:n - 1, ys:ye) = x(:, 0:n - 1, ys:ye) + e
      end do
      err = maxval(abs(x(:, 0:n - 1, ys:ye) - x1(:, 0:n - 1, ys:ye)))
      scale = maxval(abs(x1))
      call MPI_Allreduce(MPI_IN_PLACE, err, 1, MPI_DOUBLE_PRECISION, MPI_MAX, MPI_COMM_WORLD, ierr)
      write(what, '(a, a, i0, a)') label, ': ', nranks, ' ranks give the one-rank solution'
      call check_close(err, 0.0_rp, 0.0_rp, 1.0e-6_rp * scale, trim(what))
    end if
    call fused_product_with_seams(mg, b, label)
    call mg_destroy(mg)
    call mg_destroy(mg1)
  end subroutine run_case

  !> Check 4: with the seam sweeps on, one cycle's fused product ax
  !> against mg_product of its x (the same arithmetic: equal to the bit).
  subroutine fused_product_with_seams(mg, b, label)
    type(stencil_mg_t), intent(inout) :: mg
    real(rp), intent(in) :: b(:, 0:, ys:)
    character(len=*), intent(in) :: label
    real(rp), allocatable :: e(:, :, :), ax(:, :, :), y(:), xs(:, :, :), xg(:, :, :)
    logical :: formed
    real(rp) :: err, scale
    integer :: gys, gye
    character(len=96) :: what
    allocate(e(3, 0:n - 1, ys:ye), ax(3, 0:n - 1, ys:ye), y(3 * n * (ye - ys + 1)), xs(3, -r:n - 1 + r, ys - r:ye + r))
    call mg_set_seam(mg, .true.)
    call mg_apply(mg, b, e, ax, formed)
    call check_true(formed, label//': seam sweeps: the product formed')
    xs = 0.0_rp
    xs(:, 0:n - 1, ys:ye) = e
    call halo(xs, MPI_COMM_WORLD)
    gys = max(ys - r, 0)
    gye = min(ye + r, n - 1)
    xg = xs(:, 0:n - 1, gys:gye)
    call mg_product(mg, gys, gye, reshape(xg, [size(xg)]), y)
    err = maxval(abs(reshape(ax, [size(ax)]) - y))
    scale = maxval(abs(y))
    call MPI_Allreduce(MPI_IN_PLACE, err, 1, MPI_DOUBLE_PRECISION, MPI_MAX, MPI_COMM_WORLD, ierr)
    call MPI_Allreduce(MPI_IN_PLACE, scale, 1, MPI_DOUBLE_PRECISION, MPI_MAX, MPI_COMM_WORLD, ierr)
    write(what, '(a, a, i0, a)') label, ': seam sweeps on ', nranks, ' ranks: the fused product is A x'
    call check_close(err, 0.0_rp, 0.0_rp, 1.0e-12_rp * scale, trim(what))
    call mg_set_seam(mg, .false.)
  end subroutine fused_product_with_seams

end program test_stencil_mg
