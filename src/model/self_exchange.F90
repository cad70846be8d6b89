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
  use work_arrays, only: grow, push
  implicit none
  private
  public :: self_exchange_t, self_exchange_plan, self_exchange_plan_swept, self_exchange_rows
  public :: self_exchange_gather, self_exchange_add, self_exchange_min, self_exchange_free, self_exchange_counts
  public :: self_exchange_nrows, self_exchange_rows_copy, self_exchange_regrown

  !> The rows exchanged with other ranks, grouped by rank (CSR: the rows of rank(q) are
  !> rows(first(q):first(q+1)-1), q = 1..n; the arrays may be longer).
  type :: msg_list_t
    integer :: n = 0, nrows = 0
    integer, allocatable :: rank(:), first(:), rows(:)
  end type msg_list_t

  !> The plan's tables, kept from one plan to the next (grown when too short).
  type :: plan_work_t
    integer, allocatable :: counts(:), displ(:), first(:)   ! (0:nranks-1), (0:nranks-1), (0:nranks) patches a rank
    integer, allocatable :: vcounts(:)                      ! (0:nranks-1) numbers a rank in an MPI_Allgatherv
    integer, allocatable :: own_lo(:), own_hi(:)            ! (0:nranks-1) each rank's rows
    integer, allocatable :: owner(:)                        ! (0:ny-1) each row's rank
    logical, allocatable :: mark(:)                         ! (0:ny-1) rows needed
    integer, allocatable :: qlist(:)                        ! (ntot+) patches tested
    integer, allocatable :: rr(:, :), gr(:, :)              ! (2, np+), (2, ntot+) anchor rows: own, all
    real(rp), allocatable :: bb(:, :), gb(:, :)             ! (6, np+), (6, ntot+) boxes: own, all [length]
    real(rp), allocatable :: x1(:, :, :)                    ! (3, 0:nx-1, rows+) a swept plan's end positions [length]
  end type plan_work_t

  !> One plan: the present rows and the messages that fill them, with the buffers of
  !> those messages (kept from call to call; regrown counts their reallocations).
  type :: self_exchange_t
    private
    integer :: comm = MPI_COMM_NULL
    integer :: nx = 0, ny = 0, ys = 0, ye = -1
    integer :: npatch_total = 0
    integer :: nrows = 0
    integer, allocatable :: rows(:)                 ! (nrows+) present rows, ascending: owned and fetched
    integer, allocatable :: slot(:)                 ! (0:ny-1) position in rows, 0 when absent
    type(msg_list_t) :: recv                        ! fetched rows by owner
    type(msg_list_t) :: send                        ! owned rows by the rank they go to
    real(rp), allocatable :: rbuf(:), sbuf(:)       ! message buffers
    integer, allocatable :: req(:)                  ! their requests
    type(plan_work_t) :: pw
    integer :: regrown = 0
  end type self_exchange_t

  integer, parameter :: TAG_FETCH = 4901, TAG_RETURN = 4902
  integer, parameter :: OP_ADD = 1, OP_MIN = 2

contains

  !> Plan the exchange for the positions x of the owned rows ys..ye and the rows below
  !> and above (x(:, :, max(ys - 1, 0):min(ye + 1, ny - 1)), the DMDA's ghost rows): boxes
  !> grown by reach. Collective.
  subroutine self_exchange_plan(xch, comm, nx, ny, ys, ye, x, reach, patch_rows, ierr)
    type(self_exchange_t), intent(inout) :: xch
    integer, intent(in) :: comm, nx, ny, ys, ye
    real(rp), intent(in) :: x(:, 0:, max(ys - 1, 0):)   ! (3+, 0:nx-1, max(ys-1,0):min(ye+1,ny-1)) [length]
    real(rp), intent(in) :: reach                    ! [length], the same on every rank
    integer, intent(in) :: patch_rows                ! anchor rows a patch, >= 1
    integer, intent(out) :: ierr
    integer :: np

    np = local_boxes(ny, ys, ye, x, x, patch_rows, xch%pw%bb, xch%regrown)
    call plan_from_boxes(xch, comm, nx, ny, ys, ye, patch_rows, np, reach, ierr)
  end subroutine self_exchange_plan

  !> As self_exchange_plan for the paths x -> x + dx (boxes over both ends), grown by margin.
  subroutine self_exchange_plan_swept(xch, comm, nx, ny, ys, ye, x, dx, margin, patch_rows, ierr)
    type(self_exchange_t), intent(inout) :: xch
    integer, intent(in) :: comm, nx, ny, ys, ye
    real(rp), intent(in) :: x(:, 0:, max(ys - 1, 0):), dx(:, 0:, max(ys - 1, 0):)   ! as x of self_exchange_plan
    real(rp), intent(in) :: margin
    integer, intent(in) :: patch_rows
    integer, intent(out) :: ierr
    integer :: np, nr

    nr = size(x, 3)
    call grow(xch%pw%x1, 3, nx, nr, xch%regrown)
    associate (x1 => xch%pw%x1(:, :, 1:nr))
      x1 = x(1:3, :, :) + dx(1:3, :, :)
      np = local_boxes(ny, ys, ye, x, x1, patch_rows, xch%pw%bb, xch%regrown)
    end associate
    call plan_from_boxes(xch, comm, nx, ny, ys, ye, patch_rows, np, margin, ierr)
  end subroutine self_exchange_plan_swept

  !> The present rows (owned and fetched), ascending: the rows of self_broad's arrays.
  subroutine self_exchange_rows(xch, rows)
    type(self_exchange_t), intent(in) :: xch
    integer, allocatable, intent(out) :: rows(:)

    rows = xch%rows(1:xch%nrows)
  end subroutine self_exchange_rows

  !> The number of present rows.
  pure integer function self_exchange_nrows(xch) result(n)
    type(self_exchange_t), intent(in) :: xch

    n = xch%nrows
  end function self_exchange_nrows

  !> rows(1:self_exchange_nrows(xch)) <- the present rows (rows at least that long).
  subroutine self_exchange_rows_copy(xch, rows)
    type(self_exchange_t), intent(in) :: xch
    integer, intent(inout) :: rows(:)

    rows(1:xch%nrows) = xch%rows(1:xch%nrows)
  end subroutine self_exchange_rows_copy

  !> Times the plan's tables and buffers were reallocated larger since it was made.
  pure integer function self_exchange_regrown(xch) result(n)
    type(self_exchange_t), intent(in) :: xch

    n = xch%regrown
  end function self_exchange_regrown

  !> Counts for the diagnostics: rows fetched, ranks they come from, patches of all ranks.
  subroutine self_exchange_counts(xch, nfetched, nsources, npatches)
    type(self_exchange_t), intent(in) :: xch
    integer, intent(out) :: nfetched, nsources, npatches

    nfetched = xch%recv%nrows
    nsources = xch%recv%n
    npatches = xch%npatch_total
  end subroutine self_exchange_counts

  !> xall(:, :, k) <- the values of row rows(k): the owned rows from x, the others from their
  !> owners (nc = size(x, 1) values a node: 3 positions, 6 with an update, ...). Collective.
  subroutine self_exchange_gather(xch, x, xall, ierr)
    type(self_exchange_t), intent(inout) :: xch
    real(rp), intent(in) :: x(:, 0:, xch%ys:)         ! (nc, 0:nx-1, ys:ye) at least
    real(rp), intent(out) :: xall(:, 0:, :)           ! (nc, 0:nx-1, size(rows))
    integer, intent(out) :: ierr
    integer :: nc, nrow, k, q, j, m, nreq, i

    nc = size(x, 1)
    nrow = nc * xch%nx
    do j = xch%ys, xch%ye
      xall(:, :, xch%slot(j)) = x(:, :, j)
    end do
    call buffers(xch, nrow * xch%recv%nrows, nrow * xch%send%nrows)
    nreq = 0
    ierr = 0
    do q = 1, xch%recv%n
      m = xch%recv%first(q + 1) - xch%recv%first(q)
      nreq = nreq + 1
      call MPI_Irecv(xch%rbuf(nrow * (xch%recv%first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%recv%rank(q), &
                     TAG_FETCH, xch%comm, xch%req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    do k = 1, xch%send%nrows
      do i = 0, xch%nx - 1
        xch%sbuf(nrow * (k - 1) + nc * i + 1:nrow * (k - 1) + nc * (i + 1)) = x(:, i, xch%send%rows(k))
      end do
    end do
    do q = 1, xch%send%n
      m = xch%send%first(q + 1) - xch%send%first(q)
      nreq = nreq + 1
      call MPI_Isend(xch%sbuf(nrow * (xch%send%first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%send%rank(q), &
                     TAG_FETCH, xch%comm, xch%req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    call MPI_Waitall(nreq, xch%req, MPI_STATUSES_IGNORE, ierr)
    if (ierr /= MPI_SUCCESS) return
    do k = 1, xch%recv%nrows
      do i = 0, xch%nx - 1
        xall(:, i, xch%slot(xch%recv%rows(k))) = xch%rbuf(nrow * (k - 1) + nc * i + 1:nrow * (k - 1) + nc * (i + 1))
      end do
    end do
  end subroutine self_exchange_gather

  !> The message buffers at least nr and ns long, and a request for each message.
  subroutine buffers(xch, nr, ns)
    type(self_exchange_t), intent(inout) :: xch
    integer, intent(in) :: nr, ns

    call grow(xch%rbuf, nr, xch%regrown)
    call grow(xch%sbuf, ns, xch%regrown)
    call grow(xch%req, xch%recv%n + xch%send%n, xch%regrown)
  end subroutine buffers

  !> f(:, :, ys:ye) += the values of fall on the owned rows, here and on every rank that
  !> fetched them (forces of pairs on fetched nodes go back to their owners). Collective.
  subroutine self_exchange_add(xch, fall, f, ierr)
    type(self_exchange_t), intent(inout) :: xch
    real(rp), intent(in) :: fall(:, 0:, :)            ! (nc, 0:nx-1, size(rows))
    real(rp), intent(inout) :: f(:, 0:, xch%ys:)      ! (nc, 0:nx-1, ys:ye)
    integer, intent(out) :: ierr

    call return_values(xch, fall, f, OP_ADD, ierr)
  end subroutine self_exchange_add

  !> d(:, :, ys:ye) <- min(d, the values of dall on the owned rows, here and on every rank
  !> that fetched them) (the per-vertex distances of OGC's bounds). Collective.
  subroutine self_exchange_min(xch, dall, d, ierr)
    type(self_exchange_t), intent(inout) :: xch
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
  !> patch from ys-1) into bb(1:3, k) (low corner) and bb(4:6, k) (high); their number.
  integer function local_boxes(ny, ys, ye, x0, x1, patch_rows, bb, regrown) result(np)
    integer, intent(in) :: ny, ys, ye, patch_rows
    real(rp), intent(in) :: x0(:, 0:, max(ys - 1, 0):), x1(:, 0:, max(ys - 1, 0):)
    real(rp), allocatable, intent(inout) :: bb(:, :)     ! (6, np+) [length]
    integer, intent(inout) :: regrown
    integer :: k, r0, r1, j, i

    np = (ye - ys + patch_rows) / max(patch_rows, 1)
    call grow(bb, 6, np, regrown)
    do k = 1, np
      r0 = ys + (k - 1) * patch_rows
      r1 = min(r0 + patch_rows - 1, ye)
      bb(1:3, k) = huge(1.0_rp)
      bb(4:6, k) = -huge(1.0_rp)
      do j = merge(max(r0 - 1, 0), r0, k == 1), min(r1 + 1, ny - 1)
        do i = 0, size(x0, 2) - 1
          bb(1:3, k) = min(bb(1:3, k), x0(1:3, i, j), x1(1:3, i, j))
          bb(4:6, k) = max(bb(4:6, k), x0(1:3, i, j), x1(1:3, i, j))
        end do
      end do
    end do
  end function local_boxes

  !> Gather every rank's patch boxes (the np own ones in pw%bb) and derive the rows to
  !> fetch and to send (header).
  subroutine plan_from_boxes(xch, comm, nx, ny, ys, ye, patch_rows, np, reach, ierr)
    type(self_exchange_t), intent(inout) :: xch
    integer, intent(in) :: comm, nx, ny, ys, ye, patch_rows, np
    real(rp), intent(in) :: reach
    integer, intent(out) :: ierr
    integer :: nranks, rank, ntot, p, k, j, nq

    call MPI_Comm_size(comm, nranks, ierr)
    if (ierr /= MPI_SUCCESS) return
    call MPI_Comm_rank(comm, rank, ierr)
    if (ierr /= MPI_SUCCESS) return
    xch%comm = comm
    xch%nx = nx
    xch%ny = ny
    xch%ys = ys
    xch%ye = ye
    call plan_tables(xch, nranks, ny)
    associate (w => xch%pw)
      call MPI_Allgather(np, 1, MPI_INTEGER, w%counts, 1, MPI_INTEGER, comm, ierr)
      if (ierr /= MPI_SUCCESS) return
      w%first(0) = 1
      do p = 0, nranks - 1
        w%first(p + 1) = w%first(p) + w%counts(p)
      end do
      ntot = w%first(nranks) - 1
      xch%npatch_total = ntot
      ! Boxes (6 numbers, in bb already) and anchor rows (2) of every patch.
      call grow(w%rr, 2, np, xch%regrown)
      call grow(w%gr, 2, ntot, xch%regrown)
      call grow(w%gb, 6, ntot, xch%regrown)
      call grow(w%qlist, ntot, xch%regrown)
      do k = 1, np
        w%rr(1, k) = ys + (k - 1) * patch_rows
        w%rr(2, k) = min(w%rr(1, k) + patch_rows - 1, ye)
      end do
      w%displ = 6 * (w%first(0:nranks - 1) - 1)
      w%vcounts = 6 * w%counts
      call MPI_Allgatherv(w%bb, 6 * np, MPI_DOUBLE_PRECISION, w%gb, w%vcounts, w%displ, MPI_DOUBLE_PRECISION, &
                          comm, ierr)
      if (ierr /= MPI_SUCCESS) return
      w%displ = 2 * (w%first(0:nranks - 1) - 1)
      w%vcounts = 2 * w%counts
      call MPI_Allgatherv(w%rr, 2 * np, MPI_INTEGER, w%gr, w%vcounts, w%displ, MPI_INTEGER, comm, ierr)
      if (ierr /= MPI_SUCCESS) return
      ! Each rank's owned rows, and each row's owner.
      w%owner = -1
      do p = 0, nranks - 1
        w%own_lo(p) = huge(1)
        w%own_hi(p) = -1
        do k = w%first(p), w%first(p + 1) - 1
          w%own_lo(p) = min(w%own_lo(p), w%gr(1, k))
          w%own_hi(p) = max(w%own_hi(p), w%gr(2, k))
        end do
        if (w%own_hi(p) >= w%own_lo(p)) w%owner(w%own_lo(p):w%own_hi(p)) = p
      end do

      ! Fetch: the rows of every patch within reach of an own one, less the own rows.
      do k = 1, ntot
        w%qlist(k) = k
      end do
      call needed_rows(w%first, w%gb, w%gr, rank, w%qlist(1:ntot), ny, reach, w%mark)
      w%mark(ys:ye) = .false.
      call group_by_rank(w%mark, w%owner, xch%recv, xch%regrown)

      ! Send: to each other rank p, the own rows it needs; only own patches and the patch
      ! that ends just below the strip (its row above is ys) hold own rows.
      nq = 0
      do k = w%first(rank), w%first(rank + 1) - 1
        nq = nq + 1
        w%qlist(nq) = k
      end do
      do k = 1, ntot
        if (w%gr(2, k) /= ys - 1) cycle
        nq = nq + 1
        w%qlist(nq) = k
      end do
      xch%send%n = 0
      xch%send%nrows = 0
      call push(xch%send%first, 0, 1, xch%regrown)
      do p = 0, nranks - 1
        if (p == rank) cycle
        call needed_rows(w%first, w%gb, w%gr, p, w%qlist(1:nq), ny, reach, w%mark)
        if (.not. any(w%mark .and. w%owner == rank)) cycle
        call push(xch%send%rank, xch%send%n, p, xch%regrown)
        do j = 0, ny - 1
          if (.not. (w%mark(j) .and. w%owner(j) == rank)) cycle
          call push(xch%send%rows, xch%send%nrows, j, xch%regrown)
          xch%send%nrows = xch%send%nrows + 1
        end do
        xch%send%n = xch%send%n + 1
        call push(xch%send%first, xch%send%n, xch%send%nrows + 1, xch%regrown)
      end do

      ! Present rows: own and fetched, ascending.
      w%mark = .false.
      w%mark(ys:ye) = .true.
      do k = 1, xch%recv%nrows
        w%mark(xch%recv%rows(k)) = .true.
      end do
      xch%nrows = 0
      xch%slot = 0
      do j = 0, ny - 1
        if (.not. w%mark(j)) cycle
        call push(xch%rows, xch%nrows, j, xch%regrown)
        xch%nrows = xch%nrows + 1
        xch%slot(j) = xch%nrows
      end do
    end associate
  end subroutine plan_from_boxes

  !> The plan's tables of a fixed size, made at the first plan (nranks and ny do not change).
  subroutine plan_tables(xch, nranks, ny)
    type(self_exchange_t), intent(inout) :: xch
    integer, intent(in) :: nranks, ny

    if (allocated(xch%pw%counts)) then
      if (size(xch%pw%counts) == nranks .and. size(xch%slot) == ny) return
      deallocate(xch%pw%counts, xch%pw%vcounts, xch%pw%displ, xch%pw%first, xch%pw%own_lo, xch%pw%own_hi, &
                 xch%pw%owner, xch%pw%mark, xch%slot)
    end if
    allocate(xch%pw%counts(0:nranks - 1), xch%pw%vcounts(0:nranks - 1), xch%pw%displ(0:nranks - 1), &
             xch%pw%first(0:nranks))
    allocate(xch%pw%own_lo(0:nranks - 1), xch%pw%own_hi(0:nranks - 1))
    allocate(xch%pw%owner(0:ny - 1), xch%pw%mark(0:ny - 1), xch%slot(0:ny - 1))
    xch%regrown = xch%regrown + 1
  end subroutine plan_tables

  !> mk = the rows r0..r1+1 of each patch in qs whose box meets a box of rank p grown by
  !> reach (first, gb, gr: plan_work_t's).
  pure subroutine needed_rows(first, gb, gr, p, qs, ny, reach, mk)
    integer, intent(in) :: first(0:), gr(:, :)
    real(rp), intent(in) :: gb(:, :)
    integer, intent(in) :: p, qs(:), ny
    real(rp), intent(in) :: reach
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

  !> The marked rows grouped by their owner, ascending, into ml (rank, first, rows).
  subroutine group_by_rank(mark, owner, ml, regrown)
    logical, intent(in) :: mark(0:)
    integer, intent(in) :: owner(0:)
    type(msg_list_t), intent(inout) :: ml
    integer, intent(inout) :: regrown
    integer :: j

    ml%n = 0
    ml%nrows = 0
    call push(ml%first, 0, 1, regrown)
    do j = 0, size(mark) - 1
      if (.not. mark(j)) cycle
      if (ml%n == 0) then
        call push(ml%rank, ml%n, owner(j), regrown)
        ml%n = 1
      else if (ml%rank(ml%n) /= owner(j)) then
        call push(ml%first, ml%n, ml%nrows + 1, regrown)
        call push(ml%rank, ml%n, owner(j), regrown)
        ml%n = ml%n + 1
      end if
      call push(ml%rows, ml%nrows, j, regrown)
      ml%nrows = ml%nrows + 1
    end do
    if (ml%n > 0) call push(ml%first, ml%n, ml%nrows + 1, regrown)
  end subroutine group_by_rank

  ! ------------------------------------------------------------------------
  ! Return
  ! ------------------------------------------------------------------------

  !> The fetched rows of vall go back to their owners, who combine them (op) into v;
  !> the owned rows of vall are combined here.
  subroutine return_values(xch, vall, v, op, ierr)
    type(self_exchange_t), intent(inout) :: xch
    real(rp), intent(in) :: vall(:, 0:, :)
    real(rp), intent(inout) :: v(:, 0:, xch%ys:)
    integer, intent(in) :: op
    integer, intent(out) :: ierr
    integer :: nc, nrow, k, q, j, m, nreq, i

    nc = size(vall, 1)
    nrow = nc * xch%nx
    ! The reverse of the fetch: what was sent comes back (rbuf), what was received goes back.
    call buffers(xch, nrow * xch%send%nrows, nrow * xch%recv%nrows)
    nreq = 0
    ierr = 0
    do q = 1, xch%send%n
      m = xch%send%first(q + 1) - xch%send%first(q)
      nreq = nreq + 1
      call MPI_Irecv(xch%rbuf(nrow * (xch%send%first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%send%rank(q), &
                     TAG_RETURN, xch%comm, xch%req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    do k = 1, xch%recv%nrows
      do i = 0, xch%nx - 1
        xch%sbuf(nrow * (k - 1) + nc * i + 1:nrow * (k - 1) + nc * (i + 1)) = vall(:, i, xch%slot(xch%recv%rows(k)))
      end do
    end do
    do q = 1, xch%recv%n
      m = xch%recv%first(q + 1) - xch%recv%first(q)
      nreq = nreq + 1
      call MPI_Isend(xch%sbuf(nrow * (xch%recv%first(q) - 1) + 1), nrow * m, MPI_DOUBLE_PRECISION, xch%recv%rank(q), &
                     TAG_RETURN, xch%comm, xch%req(nreq), ierr)
      if (ierr /= MPI_SUCCESS) return
    end do
    do j = xch%ys, xch%ye
      do i = 0, xch%nx - 1
        call combine(v(:, i, j), vall(:, i, xch%slot(j)))
      end do
    end do
    call MPI_Waitall(nreq, xch%req, MPI_STATUSES_IGNORE, ierr)
    if (ierr /= MPI_SUCCESS) return
    ! In the order of the send list: a fixed order, so sums do not depend on arrival.
    do k = 1, xch%send%nrows
      do i = 0, xch%nx - 1
        call combine(v(:, i, xch%send%rows(k)), xch%rbuf(nrow * (k - 1) + nc * i + 1:nrow * (k - 1) + nc * (i + 1)))
      end do
    end do

  contains

    subroutine combine(a, b)
      real(rp), intent(inout) :: a(:)
      real(rp), intent(in) :: b(:)

      if (op == OP_ADD) then
        a = a + b
      else
        a = min(a, b)
      end if
    end subroutine combine

  end subroutine return_values

end module self_exchange
