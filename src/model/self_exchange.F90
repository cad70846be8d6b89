! SPDX-License-Identifier: BSD-2-Clause
!> The distributed side of the cloth's self-contact (issue 49 item 2;
!> docs/self-contact.md): which rows of the other ranks' strips a rank needs
!> for its broad phase (module self_broad), and the messages that bring them
!> and that take forces and bounds back, without gathering the cloth. The
!> elastic stencil's halo (the DMDA's ghost rows) is not touched.
!>
!> Patches: a rank splits its owned rows ys..ye into blocks of at most
!> patch_rows anchor rows r0..r1; a patch's box holds the nodes of rows
!> r0..r1+1 (the primitives anchored at its rows: self_broad's quads, links
!> and diagonals need the row above), so every primitive lies in the box of
!> the patch of its anchor row; the first patch's box also holds row ys-1,
!> so that the primitives anchored there, which touch owned nodes, are in
!> an own box too (self_broad's OWN_TOUCH; the row is then fetched). The boxes of all ranks are gathered
!> (MPI_Allgather of the counts, MPI_Allgatherv of the boxes: a few numbers
!> a patch). Rank p needs the rows r0..r1+1 of every patch Q (its own
!> included: the row above its strip) whose box meets one of p's boxes grown
!> by reach, less p's own rows; each row comes from its owner by a
!> point-to-point message, and each owner decides what to send from the same
!> gathered boxes (the same test on the same numbers, so the two sides
!> agree without asking). Swept plans take boxes over the start and end of
!> an update (for the CCD's candidates).
!>
!> Why it is complete: a pair of a rank (self_broad's OWN_LOWEST: its lowest
!> node owned; OWN_TOUCH: any node owned) has a primitive with an owned
!> node, anchored at an owned row or at ys-1, so in an own box; the other
!> primitive lies in the box of its anchor's patch Q; both within reach
!> means the grown box meets Q's, so Q's rows r0..r1+1 are present. Messages: per neighbour in space, one message each way per
!> fetch (positions) and per return (forces, bounds); the rows fetched are
!> those of the patches in reach, not the whole strip of the other rank.
module self_exchange
  use mpi
  use kinds, only: rp
  implicit none
  private
  public :: self_exchange_t, self_exchange_plan, self_exchange_plan_swept, self_exchange_rows
  public :: self_exchange_gather, self_exchange_add, self_exchange_min, self_exchange_free, self_exchange_counts

  !> One plan: the present rows and the messages that fill them.
  type :: self_exchange_t
    private
    integer :: comm = MPI_COMM_NULL
    integer :: nx = 0, ny = 0, ys = 0, ye = -1
    integer :: npatch_total = 0
    integer, allocatable :: rows(:)                 ! present rows, ascending: owned and fetched
    integer, allocatable :: slot(:)                 ! (0:ny-1) position in rows, 0 when absent
    integer, allocatable :: recv_rank(:), recv_first(:), recv_rows(:)   ! fetched rows by owner
    integer, allocatable :: send_rank(:), send_first(:), send_rows(:)   ! owned rows by the rank they go to
  end type self_exchange_t

  integer, parameter :: TAG_FETCH = 4901, TAG_RETURN = 4902
  integer, parameter :: OP_ADD = 1, OP_MIN = 2

contains

  !> Plan the exchange for the positions x of the owned rows ys..ye and the rows below
  !> and above (x(:, :, max(ys - 1, 0):min(ye + 1, ny - 1)), the DMDA's ghost rows): boxes
  !> grown by reach. Collective.
  subroutine self_exchange_plan(xch, comm, nx, ny, ys, ye, x, reach, patch_rows, ierr)
    type(self_exchange_t), intent(out) :: xch
    integer, intent(in) :: comm, nx, ny, ys, ye
    real(rp), intent(in) :: x(:, 0:, max(ys - 1, 0):)   ! (3+, 0:nx-1, max(ys-1,0):min(ye+1,ny-1)) [length]
    real(rp), intent(in) :: reach                    ! [length], the same on every rank
    integer, intent(in) :: patch_rows                ! anchor rows a patch, >= 1
    integer, intent(out) :: ierr
    real(rp), allocatable :: lo(:, :), hi(:, :)

    call local_boxes(nx, ny, ys, ye, x, x, patch_rows, lo, hi)
    call plan_from_boxes(xch, comm, nx, ny, ys, ye, patch_rows, lo, hi, reach, ierr)
  end subroutine self_exchange_plan

  !> As self_exchange_plan for the paths x -> x + dx (boxes over both ends), grown by margin.
  subroutine self_exchange_plan_swept(xch, comm, nx, ny, ys, ye, x, dx, margin, patch_rows, ierr)
    type(self_exchange_t), intent(out) :: xch
    integer, intent(in) :: comm, nx, ny, ys, ye
    real(rp), intent(in) :: x(:, 0:, max(ys - 1, 0):), dx(:, 0:, max(ys - 1, 0):)   ! as x of self_exchange_plan
    real(rp), intent(in) :: margin
    integer, intent(in) :: patch_rows
    integer, intent(out) :: ierr
    real(rp), allocatable :: lo(:, :), hi(:, :), x1(:, :, :)

    x1 = x(1:3, :, :) + dx(1:3, :, :)
    call local_boxes(nx, ny, ys, ye, x, x1, patch_rows, lo, hi)
    call plan_from_boxes(xch, comm, nx, ny, ys, ye, patch_rows, lo, hi, margin, ierr)
  end subroutine self_exchange_plan_swept

  !> The present rows (owned and fetched), ascending: the rows of self_broad's arrays.
  subroutine self_exchange_rows(xch, rows)
    type(self_exchange_t), intent(in) :: xch
    integer, allocatable, intent(out) :: rows(:)

    rows = xch%rows
  end subroutine self_exchange_rows

  !> Counts for the diagnostics: rows fetched, ranks they come from, patches of all ranks.
  subroutine self_exchange_counts(xch, nfetched, nsources, npatches)
    type(self_exchange_t), intent(in) :: xch
    integer, intent(out) :: nfetched, nsources, npatches

    nfetched = size(xch%recv_rows)
    nsources = size(xch%recv_rank)
    npatches = xch%npatch_total
  end subroutine self_exchange_counts

  !> xall(:, :, k) <- the values of row rows(k): the owned rows from x, the others from their
  !> owners (nc = size(x, 1) values a node: 3 positions, 6 with an update, ...). Collective.
  subroutine self_exchange_gather(xch, x, xall, ierr)
    type(self_exchange_t), intent(in) :: xch
    real(rp), intent(in) :: x(:, 0:, xch%ys:)         ! (nc, 0:nx-1, ys:ye) at least
    real(rp), intent(out) :: xall(:, 0:, :)           ! (nc, 0:nx-1, size(rows))
    integer, intent(out) :: ierr
    real(rp), allocatable :: rbuf(:), sbuf(:)
    integer, allocatable :: req(:)
    integer :: nc, nrow, k, q, j, m, nreq

    nc = size(x, 1)
    nrow = nc * xch%nx
    do j = xch%ys, xch%ye
      xall(:, :, xch%slot(j)) = x(:, :, j)
    end do
    allocate(rbuf(nrow * size(xch%recv_rows)), sbuf(nrow * size(xch%send_rows)))
    allocate(req(size(xch%recv_rank) + size(xch%send_rank)))
    nreq = 0
    ierr = 0
    do q = 1, size(xch%recv_rank)
      m = xch%recv_first(q + 1) - xch%recv_first(q)
      nreq = nreq + 1
      call MPI_Irecv(rbuf(nrow * (xch%recv_first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%recv_rank(q), &
                     TAG_FETCH, xch%comm, req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    do k = 1, size(xch%send_rows)
      sbuf(nrow * (k - 1) + 1:nrow * k) = reshape(x(:, :, xch%send_rows(k)), [nrow])
    end do
    do q = 1, size(xch%send_rank)
      m = xch%send_first(q + 1) - xch%send_first(q)
      nreq = nreq + 1
      call MPI_Isend(sbuf(nrow * (xch%send_first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%send_rank(q), &
                     TAG_FETCH, xch%comm, req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    call MPI_Waitall(nreq, req, MPI_STATUSES_IGNORE, ierr)
    if (ierr /= MPI_SUCCESS) return
    do k = 1, size(xch%recv_rows)
      xall(:, :, xch%slot(xch%recv_rows(k))) = reshape(rbuf(nrow * (k - 1) + 1:nrow * k), [nc, xch%nx])
    end do
  end subroutine self_exchange_gather

  !> f(:, :, ys:ye) += the values of fall on the owned rows, here and on every rank that
  !> fetched them (forces of pairs on fetched nodes go back to their owners). Collective.
  subroutine self_exchange_add(xch, fall, f, ierr)
    type(self_exchange_t), intent(in) :: xch
    real(rp), intent(in) :: fall(:, 0:, :)            ! (nc, 0:nx-1, size(rows))
    real(rp), intent(inout) :: f(:, 0:, xch%ys:)      ! (nc, 0:nx-1, ys:ye)
    integer, intent(out) :: ierr

    call return_values(xch, fall, f, OP_ADD, ierr)
  end subroutine self_exchange_add

  !> d(:, :, ys:ye) <- min(d, the values of dall on the owned rows, here and on every rank
  !> that fetched them) (the per-vertex distances of OGC's bounds). Collective.
  subroutine self_exchange_min(xch, dall, d, ierr)
    type(self_exchange_t), intent(in) :: xch
    real(rp), intent(in) :: dall(:, 0:, :)
    real(rp), intent(inout) :: d(:, 0:, xch%ys:)
    integer, intent(out) :: ierr

    call return_values(xch, dall, d, OP_MIN, ierr)
  end subroutine self_exchange_min

  !> Release the plan.
  subroutine self_exchange_free(xch)
    type(self_exchange_t), intent(inout) :: xch
    type(self_exchange_t) :: empty

    xch = empty
  end subroutine self_exchange_free

  ! ------------------------------------------------------------------------
  ! Plan
  ! ------------------------------------------------------------------------

  !> Boxes of the own patches over the positions x0 and x1 (rows r0..r1+1, the first
  !> patch from ys-1).
  subroutine local_boxes(nx, ny, ys, ye, x0, x1, patch_rows, lo, hi)
    integer, intent(in) :: nx, ny, ys, ye, patch_rows
    real(rp), intent(in) :: x0(:, 0:, max(ys - 1, 0):), x1(:, 0:, max(ys - 1, 0):)
    real(rp), allocatable, intent(out) :: lo(:, :), hi(:, :)
    integer :: np, k, r0, r1, j, i

    np = (ye - ys + patch_rows) / max(patch_rows, 1)
    allocate(lo(3, np), hi(3, np))
    do k = 1, np
      r0 = ys + (k - 1) * patch_rows
      r1 = min(r0 + patch_rows - 1, ye)
      lo(:, k) = huge(1.0_rp)
      hi(:, k) = -huge(1.0_rp)
      do j = merge(max(r0 - 1, 0), r0, k == 1), min(r1 + 1, ny - 1)
        do i = 0, nx - 1
          lo(:, k) = min(lo(:, k), x0(1:3, i, j), x1(1:3, i, j))
          hi(:, k) = max(hi(:, k), x0(1:3, i, j), x1(1:3, i, j))
        end do
      end do
    end do
  end subroutine local_boxes

  !> Gather every rank's patch boxes and derive the rows to fetch and to send (header).
  subroutine plan_from_boxes(xch, comm, nx, ny, ys, ye, patch_rows, lo, hi, reach, ierr)
    type(self_exchange_t), intent(inout) :: xch
    integer, intent(in) :: comm, nx, ny, ys, ye, patch_rows
    real(rp), intent(in) :: lo(:, :), hi(:, :), reach
    integer, intent(out) :: ierr
    integer :: nranks, rank, np, ntot, p, k, j, n
    integer, allocatable :: counts(:), displ(:), rr(:, :), gr(:, :), first(:), own_lo(:), own_hi(:), owner(:)
    real(rp), allocatable :: bb(:, :), gb(:, :)
    logical, allocatable :: mark(:)
    integer, allocatable :: qlist(:)

    call MPI_Comm_size(comm, nranks, ierr)
    if (ierr /= MPI_SUCCESS) return
    call MPI_Comm_rank(comm, rank, ierr)
    if (ierr /= MPI_SUCCESS) return
    xch%comm = comm
    xch%nx = nx
    xch%ny = ny
    xch%ys = ys
    xch%ye = ye
    np = size(lo, 2)
    allocate(counts(0:nranks - 1), displ(0:nranks - 1), first(0:nranks))
    call MPI_Allgather(np, 1, MPI_INTEGER, counts, 1, MPI_INTEGER, comm, ierr)
    if (ierr /= MPI_SUCCESS) return
    first(0) = 1
    do p = 0, nranks - 1
      first(p + 1) = first(p) + counts(p)
    end do
    ntot = first(nranks) - 1
    xch%npatch_total = ntot
    ! Boxes (6 numbers) and anchor rows (2) of every patch.
    allocate(bb(6, np), rr(2, np), gb(6, ntot), gr(2, ntot))
    do k = 1, np
      bb(1:3, k) = lo(:, k)
      bb(4:6, k) = hi(:, k)
      rr(1, k) = ys + (k - 1) * patch_rows
      rr(2, k) = min(rr(1, k) + patch_rows - 1, ye)
    end do
    displ = 6 * (first(0:nranks - 1) - 1)
    call MPI_Allgatherv(bb, 6 * np, MPI_DOUBLE_PRECISION, gb, 6 * counts, displ, MPI_DOUBLE_PRECISION, comm, ierr)
    if (ierr /= MPI_SUCCESS) return
    displ = 2 * (first(0:nranks - 1) - 1)
    call MPI_Allgatherv(rr, 2 * np, MPI_INTEGER, gr, 2 * counts, displ, MPI_INTEGER, comm, ierr)
    if (ierr /= MPI_SUCCESS) return
    ! Each rank's owned rows, and each row's owner.
    allocate(own_lo(0:nranks - 1), own_hi(0:nranks - 1), owner(0:ny - 1), mark(0:ny - 1))
    owner = -1
    do p = 0, nranks - 1
      own_lo(p) = huge(1)
      own_hi(p) = -1
      do k = first(p), first(p + 1) - 1
        own_lo(p) = min(own_lo(p), gr(1, k))
        own_hi(p) = max(own_hi(p), gr(2, k))
      end do
      if (own_hi(p) >= own_lo(p)) owner(own_lo(p):own_hi(p)) = p
    end do

    ! Fetch: the rows of every patch within reach of an own one, less the own rows.
    qlist = [(k, k = 1, ntot)]
    call needed_rows(rank, qlist, mark)
    mark(ys:ye) = .false.
    call group_by_rank(mark, owner, xch%recv_rank, xch%recv_first, xch%recv_rows)

    ! Send: to each other rank p, the own rows it needs; only own patches and the patch
    ! that ends just below the strip (its row above is ys) hold own rows.
    qlist = [(k, k = first(rank), first(rank + 1) - 1)]
    do k = 1, ntot
      if (gr(2, k) == ys - 1) qlist = [qlist, k]
    end do
    allocate(xch%send_first(1))
    allocate(xch%send_rank(0), xch%send_rows(0))
    xch%send_first(1) = 1
    do p = 0, nranks - 1
      if (p == rank) cycle
      call needed_rows(p, qlist, mark)
      mark(0:ny - 1) = mark(0:ny - 1) .and. owner(0:ny - 1) == rank
      n = count(mark)
      if (n == 0) cycle
      xch%send_rank = [xch%send_rank, p]
      xch%send_rows = [xch%send_rows, pack([(j, j = 0, ny - 1)], mark)]
      xch%send_first = [xch%send_first, size(xch%send_rows) + 1]
    end do

    ! Present rows: own and fetched, ascending.
    mark = .false.
    mark(ys:ye) = .true.
    mark(xch%recv_rows) = .true.
    xch%rows = pack([(j, j = 0, ny - 1)], mark)
    allocate(xch%slot(0:ny - 1))
    xch%slot = 0
    do k = 1, size(xch%rows)
      xch%slot(xch%rows(k)) = k
    end do

  contains

    !> mark = the rows r0..r1+1 of each patch in qs whose box meets a box of rank p grown by reach.
    subroutine needed_rows(p, qs, mk)
      integer, intent(in) :: p, qs(:)
      logical, intent(out) :: mk(0:)
      integer :: a, b, q

      mk = .false.
      do a = first(p), first(p + 1) - 1
        do b = 1, size(qs)
          q = qs(b)
          if (any(gb(1:3, a) - reach > gb(4:6, q) .or. gb(1:3, q) > gb(4:6, a) + reach)) cycle
          mk(gr(1, q):min(gr(2, q) + 1, ny - 1)) = .true.
        end do
      end do
    end subroutine needed_rows

  end subroutine plan_from_boxes

  !> The marked rows grouped by their owner, ascending (CSR: rows of rank(q) are
  !> rows(first(q):first(q+1)-1)).
  subroutine group_by_rank(mark, owner, rank, first, rows)
    logical, intent(in) :: mark(0:)
    integer, intent(in) :: owner(0:)
    integer, allocatable, intent(out) :: rank(:), first(:), rows(:)
    integer :: j, n

    allocate(rank(0), rows(0), first(1))
    first(1) = 1
    n = 0
    do j = 0, size(mark) - 1
      if (.not. mark(j)) cycle
      if (size(rank) == 0) then
        rank = [owner(j)]
      else if (rank(size(rank)) /= owner(j)) then
        first = [first, size(rows) + 1]
        rank = [rank, owner(j)]
      end if
      rows = [rows, j]
    end do
    if (size(rank) > 0) first = [first, size(rows) + 1]
  end subroutine group_by_rank

  ! ------------------------------------------------------------------------
  ! Return
  ! ------------------------------------------------------------------------

  !> The fetched rows of vall go back to their owners, who combine them (op) into v;
  !> the owned rows of vall are combined here.
  subroutine return_values(xch, vall, v, op, ierr)
    type(self_exchange_t), intent(in) :: xch
    real(rp), intent(in) :: vall(:, 0:, :)
    real(rp), intent(inout) :: v(:, 0:, xch%ys:)
    integer, intent(in) :: op
    integer, intent(out) :: ierr
    real(rp), allocatable :: rbuf(:), sbuf(:), row(:, :)
    integer, allocatable :: req(:)
    integer :: nc, nrow, k, q, j, m, nreq

    nc = size(vall, 1)
    nrow = nc * xch%nx
    allocate(rbuf(nrow * size(xch%send_rows)), sbuf(nrow * size(xch%recv_rows)))
    allocate(req(size(xch%recv_rank) + size(xch%send_rank)))
    nreq = 0
    ierr = 0
    ! The reverse of the fetch: what was sent comes back, what was received goes back.
    do q = 1, size(xch%send_rank)
      m = xch%send_first(q + 1) - xch%send_first(q)
      nreq = nreq + 1
      call MPI_Irecv(rbuf(nrow * (xch%send_first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%send_rank(q), &
                     TAG_RETURN, xch%comm, req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    do k = 1, size(xch%recv_rows)
      sbuf(nrow * (k - 1) + 1:nrow * k) = reshape(vall(:, :, xch%slot(xch%recv_rows(k))), [nrow])
    end do
    do q = 1, size(xch%recv_rank)
      m = xch%recv_first(q + 1) - xch%recv_first(q)
      nreq = nreq + 1
      call MPI_Isend(sbuf(nrow * (xch%recv_first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%recv_rank(q), &
                     TAG_RETURN, xch%comm, req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    do j = xch%ys, xch%ye
      call combine(v(:, :, j), vall(:, :, xch%slot(j)))
    end do
    call MPI_Waitall(nreq, req, MPI_STATUSES_IGNORE, ierr)
    if (ierr /= MPI_SUCCESS) return
    ! In the order of the send list: a fixed order, so sums do not depend on arrival.
    allocate(row(nc, 0:xch%nx - 1))
    do k = 1, size(xch%send_rows)
      row = reshape(rbuf(nrow * (k - 1) + 1:nrow * k), [nc, xch%nx])
      call combine(v(:, :, xch%send_rows(k)), row)
    end do

  contains

    subroutine combine(a, b)
      real(rp), intent(inout) :: a(:, :)
      real(rp), intent(in) :: b(:, :)

      if (op == OP_ADD) then
        a = a + b
      else
        a = min(a, b)
      end if
    end subroutine combine

  end subroutine return_values

end module self_exchange
