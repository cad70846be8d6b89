! SPDX-License-Identifier: BSD-2-Clause
!> Coarse levels of nuno's multigrid gathered on fewer ranks (issue 46,
!> PETSc's PCTELESCOPE idea; -nuno_mg_gather): a level too thin for the
!> strips of the ranks above it (fewer rows a rank than its halo) is not
!> replicated on every rank but split over ranks 0..k-1 (module
!> stencil_mg, mg_create), the others idle on it and below. The
!> restriction into it and the interpolation out of it cross between the
!> strips of the level above and its own: each rank of the level above
!> restricts into, and interpolates from, its "natural window" (the
!> coarse rows of its own fine rows and the transfers' reach around
!> them, the rows it would own if the level were not gathered), and a
!> point-to-point exchange of whole rows (row_plan_t, planned once in
!> mg_create) sums those windows into the owners' rows and copies the
!> owners' rows back into them. No allocation after the plan is made.
!>
!> A row plan moves whole rows of a level (the last index of an array,
!> contiguous rows of rowlen values): each rank holds the rows s0..s1
!> (its source) and wants the rows d0..d1 (its destination); the plan
!> sends every rank the intersection of its source with that rank's
!> destination, one message a pair. Copy: every destination row comes
!> from one source (disjoint sources). Sum: a destination row is the sum
!> of every source's copy of it (overlapping windows of partial sums),
!> added in the order of the ranks.
module mg_gather
  use mpi
  use kinds, only: rp
  use mg_kernels, only: mp, stencil_t, transfer_t, interpolate, restrict_add, galerkin_add
  implicit none
  private
  public :: row_plan_t, plan_create, plan_copy_dp, level_gather_t, gather_init, gather_on, gather_restrict, &
            gather_interpolate, gather_galerkin, coarse_layout, natural_rows

  !> -nuno_mg_gather auto: on more than this many ranks a level too thin
  !> for the strips is gathered on fewer; on at most this many it is the
  !> replicated coarsest (about 2 x 4 + 1 rows a side, or 4 x 4 + 1
  !> with the cubic Galerkin product's halo)
  integer, parameter :: GATHER_ABOVE = 4

  !> A point-to-point exchange of whole rows, planned once.
  type :: row_plan_t
    private
    integer :: comm = MPI_COMM_NULL
    integer :: tag = 0
    integer :: d0 = 0, d1 = -1                   !< the rows this rank receives
    integer, allocatable :: speer(:), slo(:), shi(:)   !< (nsend) the ranks sent to and the rows each gets
    integer, allocatable :: rpeer(:), rlo(:), rhi(:)   !< (nrecv) the ranks received from and their rows
    integer, allocatable :: req(:)               !< (nsend + nrecv) requests
    real(mp), allocatable :: bs(:)               !< single-precision sums: the received rows, in turn
    real(rp), allocatable :: bd(:)               !< double-precision sums: likewise
  end type row_plan_t

  !> A gathered level's link to the level above it (finer).
  type :: level_gather_t
    private
    logical :: on = .false.                      !< the level is gathered
    integer :: h = 0                             !< the level's padding rows and columns
    integer :: nx = 0                            !< the level's side along x
    integer :: ysn = 0, yen = -1                 !< the natural window's own rows (empty: idle on the level above)
    real(mp), allocatable :: wn(:, :, :)         !< (-h:nx-1+h, 3, ysn-h:yen+h) restriction sums of this rank's fine rows
    real(mp), allocatable :: xn(:, :, :)         !< (-h:nx-1+h, 3, ysn-h:yen+h) the owners' x, for the interpolation
    !> (0:nx-1, 3, 3, -r:r, -r:r, ysn-h:yen+h) Galerkin sums of this
    !> rank's fine rows (Galerkin coarse levels only)
    real(rp), allocatable :: acn(:, :, :, :, :, :)
    type(row_plan_t) :: up                       !< wn summed into the owners' rows (sum)
    type(row_plan_t) :: down                     !< the owners' x copied into xn (copy)
    type(row_plan_t) :: acup                     !< acn summed into the owners' rows (sum; Galerkin)
  end type level_gather_t

contains

  !> Rows ys..ye of rank of n rows split over ranks 0..k-1 as PETSc's
  !> DMDA splits them (n/k each, the first mod(n, k) one more); empty
  !> (ys = 0, ye = -1) on the ranks from k on.
  pure subroutine strip_split(n, k, rank, ys, ye)
    integer, intent(in) :: n, k, rank
    integer, intent(out) :: ys, ye
    ys = 0
    ye = -1
    if (rank >= k) return
    ys = rank * (n / k) + min(rank, mod(n, k))
    ye = ys + n / k - 1
    if (rank < mod(n, k)) ye = ye + 1
  end subroutine strip_split

  !> The coarse rows ysc..yec whose parents (row 2 J) are among the rows
  !> ysf..yef of a rank on the level above: its natural rows, those it
  !> owns where the level is not gathered; empty (0, -1) where ysf > yef.
  pure subroutine natural_rows(ysf, yef, ysc, yec)
    integer, intent(in) :: ysf, yef
    integer, intent(out) :: ysc, yec
    ysc = 0
    yec = -1
    if (ysf > yef) return
    ysc = (ysf + 1) / 2
    yec = yef / 2
  end subroutine natural_rows

  !> The layout of a coarse level of ny rows and halo hc below a level of
  !> which this rank holds rows (holds) or none: on entry ysc..yec its
  !> natural rows (the parents of its own rows on the level above; empty
  !> where it holds none) and below, above that level's neighbours. Kept
  !> so while every rank of the level above owns hc rows of it; else,
  !> with may_gather, more than GATHER_ABOVE ranks on comm and not the
  !> last level of the hierarchy (short), gathered on the first k of the
  !> level above's ranks with hc rows each at least (rows and neighbours
  !> set; k may be 1): the hierarchy of one rank; else the last level,
  !> the coarsest (last; every row). Collective.
  subroutine coarse_layout(comm, holds, ny, hc, short, may_gather, ysc, yec, below, above, gathered, last)
    integer, intent(in) :: comm, ny, hc
    logical, intent(in) :: holds, short, may_gather
    integer, intent(inout) :: ysc, yec, below, above
    logical, intent(out) :: gathered, last
    integer :: fewest, nact, k, rank, nranks, ierr
    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, nranks, ierr)
    call MPI_Allreduce(merge(yec - ysc + 1, huge(1), holds), fewest, 1, MPI_INTEGER, MPI_MIN, comm, ierr)
    call MPI_Allreduce(merge(1, 0, holds), nact, 1, MPI_INTEGER, MPI_SUM, comm, ierr)
    gathered = fewest < max(hc, 1) .and. .not. short .and. may_gather .and. nranks > GATHER_ABOVE
    if (gathered) then
      k = min(nact, ny / max(hc, 1))
      call strip_split(ny, k, rank, ysc, yec)
      below = merge(rank - 1, MPI_PROC_NULL, rank > 0 .and. rank < k)
      above = merge(rank + 1, MPI_PROC_NULL, rank < k - 1)
    end if
    last = short .or. (fewest < max(hc, 1) .and. .not. gathered)
    if (last) then
      ysc = 0
      yec = ny - 1
    end if
  end subroutine coarse_layout

  !> The plan of a row exchange on comm: this rank holds rows s0..s1 and
  !> wants rows d0..d1 (either empty: s1 < s0, d1 < d0). tag: the
  !> plan's message tag. Collective (an allgather of the ranges).
  subroutine plan_create(p, comm, tag, s0, s1, d0, d1)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: comm, tag, s0, s1, d0, d1
    integer, allocatable :: all(:, :)            ! (4, 0:nranks-1) every rank's s0, s1, d0, d1
    integer :: nranks, q, ierr, ns, nr, pass
    call MPI_Comm_size(comm, nranks, ierr)
    allocate(all(4, 0:nranks - 1))
    call MPI_Allgather([s0, s1, d0, d1], 4, MPI_INTEGER, all, 4, MPI_INTEGER, comm, ierr)
    p%comm = comm
    p%tag = tag
    p%d0 = d0
    p%d1 = d1
    do pass = 1, 2
      ns = 0
      nr = 0
      do q = 0, nranks - 1
        if (max(s0, all(3, q)) <= min(s1, all(4, q))) then
          ns = ns + 1
          if (pass == 2) then
            p%speer(ns) = q
            p%slo(ns) = max(s0, all(3, q))
            p%shi(ns) = min(s1, all(4, q))
          end if
        end if
        if (max(all(1, q), d0) <= min(all(2, q), d1)) then
          nr = nr + 1
          if (pass == 2) then
            p%rpeer(nr) = q
            p%rlo(nr) = max(all(1, q), d0)
            p%rhi(nr) = min(all(2, q), d1)
          end if
        end if
      end do
      if (pass == 1) then
        if (allocated(p%speer)) deallocate(p%speer, p%slo, p%shi, p%rpeer, p%rlo, p%rhi, p%req)
        allocate(p%speer(ns), p%slo(ns), p%shi(ns), p%rpeer(nr), p%rlo(nr), p%rhi(nr), p%req(ns + nr))
      end if
    end do
  end subroutine plan_create

  !> The receive buffer of a sum in single precision, rows of rowlen values.
  subroutine plan_buffer_sp(p, rowlen)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: rowlen
    if (allocated(p%bs)) deallocate(p%bs)
    allocate(p%bs(max(1, rowlen * sum(p%rhi - p%rlo + 1))))
  end subroutine plan_buffer_sp

  !> The receive buffer of a sum in double precision, rows of rowlen values.
  subroutine plan_buffer_dp(p, rowlen)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: rowlen
    if (allocated(p%bd)) deallocate(p%bd)
    allocate(p%bd(max(1, rowlen * sum(p%rhi - p%rlo + 1))))
  end subroutine plan_buffer_dp

  !> dst(:, d0..d1) = the sources' rows: src(rowlen, sfirst:) this rank's
  !> (rows s0..s1 of the plan), dst(rowlen, dfirst:). Collective over the
  !> plan's ranks.
  subroutine plan_copy_sp(p, rowlen, src, sfirst, dst, dfirst)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: rowlen, sfirst, dfirst
    real(mp), intent(in) :: src(rowlen, sfirst:*)
    real(mp), intent(inout) :: dst(rowlen, dfirst:*)
    integer :: m, ns, ierr
    ns = size(p%speer)
    do m = 1, size(p%rpeer)
      call MPI_Irecv(dst(1, p%rlo(m)), rowlen * (p%rhi(m) - p%rlo(m) + 1), MPI_REAL, p%rpeer(m), p%tag, p%comm, &
                     p%req(ns + m), ierr)
    end do
    do m = 1, ns
      call MPI_Isend(src(1, p%slo(m)), rowlen * (p%shi(m) - p%slo(m) + 1), MPI_REAL, p%speer(m), p%tag, p%comm, &
                     p%req(m), ierr)
    end do
    call MPI_Waitall(size(p%req), p%req, MPI_STATUSES_IGNORE, ierr)
  end subroutine plan_copy_sp

  !> plan_copy_sp in double precision.
  subroutine plan_copy_dp(p, rowlen, src, sfirst, dst, dfirst)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: rowlen, sfirst, dfirst
    real(rp), intent(in) :: src(rowlen, sfirst:*)
    real(rp), intent(inout) :: dst(rowlen, dfirst:*)
    integer :: m, ns, ierr
    ns = size(p%speer)
    do m = 1, size(p%rpeer)
      call MPI_Irecv(dst(1, p%rlo(m)), rowlen * (p%rhi(m) - p%rlo(m) + 1), MPI_DOUBLE_PRECISION, p%rpeer(m), p%tag, &
                     p%comm, p%req(ns + m), ierr)
    end do
    do m = 1, ns
      call MPI_Isend(src(1, p%slo(m)), rowlen * (p%shi(m) - p%slo(m) + 1), MPI_DOUBLE_PRECISION, p%speer(m), p%tag, &
                     p%comm, p%req(m), ierr)
    end do
    call MPI_Waitall(size(p%req), p%req, MPI_STATUSES_IGNORE, ierr)
  end subroutine plan_copy_dp

  !> dst(:, d0..d1) = the sum of every source's rows there (plan_buffer_sp
  !> made the buffer for rowlen), added in the order of the ranks.
  !> Collective over the plan's ranks.
  subroutine plan_sum_sp(p, rowlen, src, sfirst, dst, dfirst)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: rowlen, sfirst, dfirst
    real(mp), intent(in) :: src(rowlen, sfirst:*)
    real(mp), intent(inout) :: dst(rowlen, dfirst:*)
    integer :: m, ns, ierr, off, j
    ns = size(p%speer)
    off = 0
    do m = 1, size(p%rpeer)
      call MPI_Irecv(p%bs(off + 1), rowlen * (p%rhi(m) - p%rlo(m) + 1), MPI_REAL, p%rpeer(m), p%tag, p%comm, &
                     p%req(ns + m), ierr)
      off = off + rowlen * (p%rhi(m) - p%rlo(m) + 1)
    end do
    do m = 1, ns
      call MPI_Isend(src(1, p%slo(m)), rowlen * (p%shi(m) - p%slo(m) + 1), MPI_REAL, p%speer(m), p%tag, p%comm, &
                     p%req(m), ierr)
    end do
    call MPI_Waitall(size(p%req), p%req, MPI_STATUSES_IGNORE, ierr)
    do j = p%d0, p%d1
      dst(:, j) = 0.0_mp
    end do
    off = 0
    do m = 1, size(p%rpeer)
      do j = p%rlo(m), p%rhi(m)
        dst(:, j) = dst(:, j) + p%bs(off + 1:off + rowlen)
        off = off + rowlen
      end do
    end do
  end subroutine plan_sum_sp

  !> plan_sum_sp in double precision (plan_buffer_dp).
  subroutine plan_sum_dp(p, rowlen, src, sfirst, dst, dfirst)
    type(row_plan_t), intent(inout) :: p
    integer, intent(in) :: rowlen, sfirst, dfirst
    real(rp), intent(in) :: src(rowlen, sfirst:*)
    real(rp), intent(inout) :: dst(rowlen, dfirst:*)
    integer :: m, ns, ierr, off, j
    ns = size(p%speer)
    off = 0
    do m = 1, size(p%rpeer)
      call MPI_Irecv(p%bd(off + 1), rowlen * (p%rhi(m) - p%rlo(m) + 1), MPI_DOUBLE_PRECISION, p%rpeer(m), p%tag, &
                     p%comm, p%req(ns + m), ierr)
      off = off + rowlen * (p%rhi(m) - p%rlo(m) + 1)
    end do
    do m = 1, ns
      call MPI_Isend(src(1, p%slo(m)), rowlen * (p%shi(m) - p%slo(m) + 1), MPI_DOUBLE_PRECISION, p%speer(m), p%tag, &
                     p%comm, p%req(m), ierr)
    end do
    call MPI_Waitall(size(p%req), p%req, MPI_STATUSES_IGNORE, ierr)
    do j = p%d0, p%d1
      dst(:, j) = 0.0_rp
    end do
    off = 0
    do m = 1, size(p%rpeer)
      do j = p%rlo(m), p%rhi(m)
        dst(:, j) = dst(:, j) + p%bd(off + 1:off + rowlen)
        off = off + rowlen
      end do
    end do
  end subroutine plan_sum_dp

  !> A gathered level (nx x ny, padding h, reach r, rows ys..ye on this
  !> rank, empty where idle) below the rows ysf..yef of this rank on the
  !> level above (empty where idle there): its natural window and the
  !> plans. galerkin: its operator is a Galerkin product (the sums
  !> gathered too). Collective.
  subroutine gather_init(g, comm, nx, ny, h, r, ysf, yef, ys, ye, galerkin)
    type(level_gather_t), intent(inout) :: g
    integer, intent(in) :: comm, nx, ny, h, r, ysf, yef, ys, ye
    logical, intent(in) :: galerkin
    integer :: lo, hi
    g%on = .true.
    g%h = h
    g%nx = nx
    call natural_rows(ysf, yef, g%ysn, g%yen)
    ! the window's rows in the lattice (none where idle above)
    lo = max(0, g%ysn - h)
    hi = merge(min(ny - 1, g%yen + h), -1, ysf <= yef)
    allocate(g%wn(-h:nx - 1 + h, 3, g%ysn - h:g%yen + h), g%xn(-h:nx - 1 + h, 3, g%ysn - h:g%yen + h))
    g%wn = 0.0_mp
    g%xn = 0.0_mp
    call plan_create(g%up, comm, 31, lo, hi, ys, ye)
    call plan_buffer_sp(g%up, size(g%wn(:, :, g%ysn - h)))
    call plan_create(g%down, comm, 32, ys, ye, lo, hi)
    if (galerkin) then
      allocate(g%acn(0:nx - 1, 3, 3, -r:r, -r:r, g%ysn - h:g%yen + h))
      call plan_create(g%acup, comm, 33, lo, hi, ys, ye)
      call plan_buffer_dp(g%acup, size(g%acn(:, :, :, :, :, g%ysn - h)))
    end if
  end subroutine gather_init

  !> The level is gathered (gather_init made its link).
  pure logical function gather_on(g)
    type(level_gather_t), intent(in) :: g
    gather_on = g%on
  end function gather_on

  !> The restriction into a gathered level: this rank's fine rows
  !> ysf..yef of rf (its residual or right-hand side; none where idle
  !> above) restricted into its window, the windows summed into the
  !> owners' rows of w (padded as the level's x, rows ys-h..ye+h) and
  !> copied into rhs(0:nx-1, 3, ys:ye). t(0:nx-1, 3): work. Collective.
  subroutine gather_restrict(g, tx, ty, ysf, yef, rf, ys, ye, w, rhs, t)
    type(level_gather_t), intent(inout) :: g
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: ysf, yef, ys, ye
    real(mp), intent(in) :: rf(0:, :, ysf:)
    real(mp), intent(inout), contiguous :: w(-g%h:, :, ys - g%h:)
    real(mp), intent(inout), contiguous :: rhs(0:, :, ys:)
    real(mp), intent(inout) :: t(0:, :)
    if (ysf <= yef) then
      g%wn = 0.0_mp
      call restrict_add(tx, ty, ysf, yef, rf, g%h, g%ysn, g%wn, t)
    end if
    call plan_sum_sp(g%up, size(g%wn(:, :, g%ysn - g%h)), g%wn, g%ysn - g%h, w, ys - g%h)
    if (ys <= ye) rhs(:, :, ys:ye) = w(0:g%nx - 1, :, ys:ye)
  end subroutine gather_restrict

  !> The interpolation out of a gathered level: the owners' rows of its
  !> x (padded, rows ys-h..ye+h) copied into this rank's window, then
  !> xf = P x (add: xf + P x) on this rank's fine rows ysf..yef (none
  !> where idle above; xf padded by hf). t(0:nx-1, 3): work. Collective.
  subroutine gather_interpolate(g, ux, uy, ys, x, ysf, yef, hf, xf, add, t)
    type(level_gather_t), intent(inout) :: g
    type(transfer_t), intent(in) :: ux, uy
    integer, intent(in) :: ys, ysf, yef, hf
    real(mp), intent(in), contiguous :: x(-g%h:, :, ys - g%h:)
    real(mp), intent(inout) :: xf(-hf:, :, ysf - hf:)
    logical, intent(in) :: add
    real(mp), intent(inout) :: t(0:, :)
    call plan_copy_sp(g%down, size(g%xn(:, :, g%ysn - g%h)), x, ys - g%h, g%xn, g%ysn - g%h)
    if (ysf <= yef) call interpolate(ux, uy, ysf, yef, g%h, g%ysn, g%xn, hf, xf, add, t)
  end subroutine gather_interpolate

  !> The Galerkin sums of a gathered level (reach r) from the fine
  !> operator fst (this rank's fine rows; none where idle above), summed
  !> into the owners' rows ys..ye of ac(0:nx-1, 3, 3, -r:r, -r:r,
  !> ys-h:ye+h). bx, rw: galerkin_add's work. Collective.
  subroutine gather_galerkin(g, fst, tx, ty, r, ys, ac, bx, rw)
    type(level_gather_t), intent(inout) :: g
    type(stencil_t), intent(in) :: fst
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: r, ys
    real(rp), intent(inout), contiguous :: ac(0:, :, :, -r:, -r:, ys - g%h:)
    real(rp), intent(inout), contiguous :: bx(:, :, :, :, :)
    real(rp), intent(inout), contiguous :: rw(:, :, :, :)
    if (fst%ye >= fst%ys) then
      g%acn = 0.0_rp
      call galerkin_add(fst, tx, ty, r, g%ysn - g%h, g%acn, bx, rw)
    end if
    call plan_sum_dp(g%acup, size(g%acn(:, :, :, :, :, g%ysn - g%h)), g%acn, g%ysn - g%h, ac, ys - g%h)
  end subroutine gather_galerkin

end module mg_gather
