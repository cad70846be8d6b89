! SPDX-License-Identifier: BSD-2-Clause
!> Broad phase of the cloth's self-contact on a set of lattice rows (issue 49
!> item 1; docs/self-contact.md): the candidate point-triangle and edge-edge
!> pairs of IPC (module contact_primitives) among the primitives of the rows
!> a rank holds, found with a uniform spatial hash in O(N).
!>
!> Primitives, each with a global number that every rank computes alike
!> (node g = i + nx j, 0-based, as the DMDA's):
!>   points     every node of a present row;
!>   triangles  the two of quad (i, j) (contact_faces' quad_triangles with the
!>              split given), number 2 g(i,j) + t - 1, t = 1, 2;
!>   edges      x-link (i,j)-(i+1,j) 3 g, y-link (i,j)-(i,j+1) 3 g + 1, the
!>              split's diagonal 3 g + 2 (g = g(i,j), the anchor).
!> A quad, its y-link and its diagonal exist where rows j and j+1 are both
!> present; an x-link where row j is.
!>
!> A candidate pair is a point and a triangle, or two edges, that
!>   - share no node;
!>   - are not neighbours at rest: their distance in the rest lattice
!>     (X = (i ax, j ay, 0)) is at least rest_reach (dhat + thickness: a
!>     flat cloth at rest has no active pair; such pairs are left to the
!>     elastic elements and are not protected by the step limit);
!>   - belong to this rank, by one of two rules: OWN_LOWEST, the row of the
!>     pair's lowest global node number lies in own_lo..own_hi (each pair on
!>     one rank only: energies, counts, the CCD's alpha; forces on the other
!>     ranks' nodes go back to them), or OWN_TOUCH, a node of the pair lies
!>     in own_lo..own_hi (a pair on every rank it touches: each rank adds
!>     the forces and blocks of its own nodes, nothing goes back; the
!>     present rows must then include the row below the strip);
!>   - are near: the distance is below reach (self_candidates), or the two
!>     paths from x to x + dx may come within margin of each other
!>     (self_candidates_swept: boxes of both ends overlap and the start
!>     distance minus ACCD's rate bound is below margin).
!> Point-triangle pairs are (p, t0, t1, t2) with the triangle's corners in
!> quad_triangles' order; edge-edge pairs (a0, a1, b0, b1) with the edge of
!> the smaller number first, each edge's nodes in anchor order.
!>
!> The hash: cells of size h = the mean largest side of the triangles' and
!> edges' boxes grown by reach (a typical box covers 2 x 2 x 2 cells; a
!> stretched element more cells, rather than every cell larger), keys hashed
!> into a table of a power of 2 at least the number of entries, filled by a
!> counting sort. Each triangle and edge goes into
!> the cells of its grown box; each point (its box over the path) and edge
!> asks the cells of its own box and takes a hit only in the cell that holds
!> the lowest corner of the two boxes' intersection, so a pair is met once.
!> Plain arrays, no PETSc, no MPI. The tables (primitives, boxes, the two
!> grids, the rest rule's table) are kept in the pair list between calls and
!> reallocated only when too small (self_pairs_regrown counts that), so a
!> caller that keeps its list allocates nothing once the sizes have settled.
module self_broad
  use, intrinsic :: iso_fortran_env, only: int64
  use kinds, only: rp
  use contact_faces, only: quad_triangles, quad_diagonal, SPLIT_MAIN, SPLIT_ANTI
  use self_far, only: self_pair_far, self_pair_distance2   ! the distance re-exported: self_step and the tests take it from here
  use work_arrays, only: grow, grow_from0
  implicit none
  private
  public :: self_lattice_t, self_pairs_t, PAIR_PT, PAIR_EE, OWN_LOWEST, OWN_TOUCH
  public :: self_row_slots, self_candidates, self_candidates_swept
  public :: self_pair_positions, self_pair_rest, self_pairs_clear, self_pair_owner_row
  public :: self_pair_distance2, self_pairs_reserve, self_pairs_regrown, self_rest_gap

  !> Pair kinds (the same codes as contact_ccd's rate bound).
  integer, parameter :: PAIR_PT = 1, PAIR_EE = 2
  !> Pair ownership (module header): the lowest node's row owned, or any node's.
  integer, parameter :: OWN_LOWEST = 1, OWN_TOUCH = 2

  !> The lattice that the global numbers refer to.
  type :: self_lattice_t
    integer :: nx = 0, ny = 0              !< nodes along x and y
    integer :: split = SPLIT_MAIN          !< quad split: contact_faces' SPLIT_MAIN or SPLIT_ANTI
    real(rp) :: ax = 0.0_rp, ay = 0.0_rp   !< rest spacing along x and y [length]
  end type self_lattice_t


  !> The rest rule by index offsets: pt(t, di, dj) for a point at (di, dj) from the anchor of
  !> a triangle t, ee(ka, kb, di, dj) for edge kb anchored (di, dj) from edge ka (ka's number
  !> the smaller): .true. where the pair is nearer than rest_reach at rest; .false. beyond
  !> the offsets held (ri, rj).
  type :: rest_table_t
    integer :: ri = -1, rj = -1
    logical, allocatable :: pt(:, :, :)        ! (2, -ri:ri, -rj:rj)
    logical, allocatable :: ee(:, :, :, :)     ! (0:2, 0:2, -ri:ri, -rj:rj)
  end type rest_table_t

  !> The spatial hash of one set of boxes (arrays at least as long as used).
  type :: grid_t
    integer :: nbucket = 0                 ! a power of 2
    integer, allocatable :: first(:)       ! (0:nbucket+) start of each bucket in item
    integer, allocatable :: item(:)        ! (n+) box number of each entry
    integer(int64), allocatable :: key(:)  ! (n+) the entry's cell, packed (cell_key)
    integer, allocatable :: fill(:)        ! (0:nbucket-1+) the counting sort's counters
  end type grid_t

  !> The broad phase's tables, kept between calls (each array at least as long as the
  !> last call needed; the first ntri, ned, npt columns used).
  type :: broad_work_t
    integer, allocatable :: slot(:)                    ! (0:ny-1) self_row_slots
    integer, allocatable :: tri(:, :), tid(:)          ! (3, ntri+), (ntri+) triangles' nodes and numbers
    integer, allocatable :: edg(:, :), eid(:)          ! (2, ned+), (ned+) edges' nodes and numbers
    integer, allocatable :: pts(:)                     ! (npt+) points' nodes
    real(rp), allocatable :: tlo(:, :), thi(:, :)      ! (3, ntri+) triangles' boxes [length]
    real(rp), allocatable :: elo(:, :), ehi(:, :)      ! (3, ned+) edges' boxes [length]
    real(rp), allocatable :: plo(:, :), phi(:, :)      ! (3, npt+) points' boxes [length]
    type(grid_t) :: gt, ge                             ! the hashes of triangles and edges
    type(rest_table_t) :: rt                           ! the rest rule's table, for rt_reach
    real(rp) :: rt_reach = -1.0_rp                     ! the rest_reach rt was built for [length]
    type(self_lattice_t) :: rt_lat                     ! and the lattice
  end type broad_work_t

  !> Candidate pairs: kind(k) PAIR_PT or PAIR_EE, node(:, k) their 4 global node numbers
  !> (k = 1..n; the arrays may be longer), and the tables that found them.
  type :: self_pairs_t
    integer :: n = 0
    integer, allocatable :: kind(:)
    integer, allocatable :: node(:, :)     !< (4, n+)
    integer :: regrown = 0                 !< times an array here was reallocated larger (self_pairs_regrown)
    type(broad_work_t), allocatable, private :: work
    real(rp), allocatable, private :: x1(:, :, :)   !< (3, 0:nx-1, nr+) a swept call's end positions [length]
  end type self_pairs_t

  real(rp), parameter :: CELL_FACTOR = 1.0_rp
  integer(int64), parameter :: P1 = 73856093_int64, P2 = 19349663_int64, P3 = 83492791_int64

contains

  ! ------------------------------------------------------------------------
  ! Rows, nodes, pairs
  ! ------------------------------------------------------------------------

  !> slot(j) = the position of global row j in rows (1..nr), 0 where absent.
  pure subroutine self_row_slots(lat, rows, slot)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)                 ! present global rows, each once
    integer, intent(out) :: slot(0:lat%ny - 1)
    integer :: r

    slot = 0
    do r = 1, size(rows)
      slot(rows(r)) = r
    end do
  end subroutine self_row_slots

  !> Positions of a pair's 4 nodes from the rows' array x(3, 0:nx-1, nr) (slot: self_row_slots).
  pure function self_pair_positions(lat, slot, x, node) result(xp)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: slot(0:), node(4)
    real(rp), intent(in) :: x(:, 0:, :)
    real(rp) :: xp(3, 4)
    integer :: k

    do k = 1, 4
      xp(:, k) = x(1:3, mod(node(k), lat%nx), slot(node(k) / lat%nx))
    end do
  end function self_pair_positions

  !> Rest positions of a pair's 4 nodes, ((i - imin) ax, (j - jmin) ay, 0) with imin, jmin
  !> the pair's smallest indices: a function of the index offsets alone, so that the same
  !> pattern anywhere on the lattice gives the same numbers (the rest rule's table).
  pure function self_pair_rest(lat, node) result(xr)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: node(4)
    real(rp) :: xr(3, 4)
    integer :: k, i(4), j(4)

    i = mod(node, lat%nx)
    j = node / lat%nx
    do k = 1, 4
      xr(:, k) = [(i(k) - minval(i)) * lat%ax, (j(k) - minval(j)) * lat%ay, 0.0_rp]
    end do
  end function self_pair_rest

  !> The row whose owner counts the pair: that of its lowest global node number.
  pure integer function self_pair_owner_row(lat, node) result(j)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: node(4)

    j = minval(node) / lat%nx
  end function self_pair_owner_row

  !> Empty the list (keeps its storage).
  pure subroutine self_pairs_clear(pairs)
    type(self_pairs_t), intent(inout) :: pairs

    pairs%n = 0
  end subroutine self_pairs_clear

  !> Room for at least n pairs (a size estimate made at set-up: the list then grows
  !> only past it).
  pure subroutine self_pairs_reserve(pairs, n)
    type(self_pairs_t), intent(inout) :: pairs
    integer, intent(in) :: n

    call grow_list(pairs, n)
  end subroutine self_pairs_reserve

  !> Times the list's arrays or its tables were reallocated larger since it was made.
  pure integer function self_pairs_regrown(pairs) result(n)
    type(self_pairs_t), intent(in) :: pairs

    n = pairs%regrown
  end function self_pairs_regrown

  pure subroutine add_pair(pairs, kind, node)
    type(self_pairs_t), intent(inout) :: pairs
    integer, intent(in) :: kind, node(4)

    if (.not. allocated(pairs%kind)) then
      call grow_list(pairs, 64)
    else if (pairs%n == size(pairs%kind)) then
      call grow_list(pairs, 2 * pairs%n)
    end if
    pairs%n = pairs%n + 1
    pairs%kind(pairs%n) = kind
    pairs%node(:, pairs%n) = node
  end subroutine add_pair

  !> The list's arrays at least cap long, its pairs kept.
  pure subroutine grow_list(pairs, cap)
    type(self_pairs_t), intent(inout) :: pairs
    integer, intent(in) :: cap
    integer, allocatable :: k2(:), n2(:, :)

    if (allocated(pairs%kind)) then
      if (size(pairs%kind) >= cap) return
    end if
    allocate(k2(cap), n2(4, cap))
    if (pairs%n > 0) then
      k2(1:pairs%n) = pairs%kind(1:pairs%n)
      n2(:, 1:pairs%n) = pairs%node(:, 1:pairs%n)
    end if
    call move_alloc(k2, pairs%kind)
    call move_alloc(n2, pairs%node)
    pairs%regrown = pairs%regrown + 1
  end subroutine grow_list

  ! ------------------------------------------------------------------------
  ! Candidates
  ! ------------------------------------------------------------------------

  !> Candidate pairs (module header) at positions x whose distance is below reach; pairs
  !> is emptied first.
  subroutine self_candidates(lat, rows, x, own_lo, own_hi, own_rule, reach, rest_reach, pairs)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)                  ! present global rows, each once
    real(rp), intent(in) :: x(:, 0:, :)             ! (3, 0:nx-1, size(rows)) positions [length]
    integer, intent(in) :: own_lo, own_hi           ! this rank's rows (pair ownership)
    integer, intent(in) :: own_rule                 ! OWN_LOWEST or OWN_TOUCH
    real(rp), intent(in) :: reach                   ! e.g. dhat + thickness [length]
    real(rp), intent(in) :: rest_reach              ! pairs nearer than this at rest are left out [length]
    type(self_pairs_t), intent(inout) :: pairs

    call find_pairs(lat, rows, x, x, .false., own_lo, own_hi, own_rule, reach, rest_reach, pairs)
  end subroutine self_candidates

  !> Candidate pairs (module header) for the straight paths from x to x + dx that may come
  !> within margin of each other (for a step's CCD: margin = the thickness); pairs is emptied.
  subroutine self_candidates_swept(lat, rows, x, dx, own_lo, own_hi, own_rule, margin, rest_reach, pairs)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    real(rp), intent(in) :: x(:, 0:, :)             ! (3, 0:nx-1, nr) start [length]
    real(rp), intent(in) :: dx(:, 0:, :)            ! (3, 0:nx-1, nr) displacement [length]
    integer, intent(in) :: own_lo, own_hi, own_rule
    real(rp), intent(in) :: margin                  ! [length]
    real(rp), intent(in) :: rest_reach              ! [length]
    type(self_pairs_t), intent(inout) :: pairs
    integer :: nr

    nr = size(rows)
    call grow(pairs%x1, 3, lat%nx, nr, pairs%regrown)
    associate (x1 => pairs%x1(:, :, 1:nr))
      x1 = x(1:3, :, 1:nr) + dx(1:3, :, 1:nr)
      call find_pairs(lat, rows, x, x1, .true., own_lo, own_hi, own_rule, margin, rest_reach, pairs)
    end associate
  end subroutine self_candidates_swept

  !> The broad phase proper: boxes over the start x0 and the end x1 of each primitive. The
  !> tables are pairs' own, moved out for the call (move_alloc: no copy) and back.
  subroutine find_pairs(lat, rows, x0, x1, swept, own_lo, own_hi, own_rule, reach, rest_reach, pairs)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    real(rp), intent(in) :: x0(:, 0:, :), x1(:, 0:, :)
    logical, intent(in) :: swept
    integer, intent(in) :: own_lo, own_hi, own_rule
    real(rp), intent(in) :: reach, rest_reach
    type(self_pairs_t), intent(inout) :: pairs
    type(broad_work_t), allocatable :: w
    real(rp) :: origin(3), h
    integer :: ntri, ned, npt

    pairs%n = 0
    if (.not. allocated(pairs%work)) then
      allocate(pairs%work)
      pairs%regrown = pairs%regrown + 1
    end if
    call move_alloc(pairs%work, w)
    call prepare_tables(w, lat, rows, x0, x1, reach, rest_reach, pairs%regrown, ntri, ned, npt, origin, h)
    if (npt > 0) then
      call point_triangle_pairs()
      call edge_edge_pairs()
    end if
    call move_alloc(w, pairs%work)

  contains

    subroutine point_triangle_pairs()
      integer(int64) :: c(3), clo(3), chi(3), cm(3), kc
      integer :: p, e, t, b, node(4), cx, cy, cz
      real(rp) :: glo(3), ghi(3)

      do p = 1, npt
        clo = cell_of(w%plo(:, p), origin, h)
        chi = cell_of(w%phi(:, p), origin, h)
        do cz = 0, int(chi(3) - clo(3))
          do cy = 0, int(chi(2) - clo(2))
            do cx = 0, int(chi(1) - clo(1))
              c = clo + [cx, cy, cz]
              b = bucket(w%gt, c)
              kc = cell_key(c)
              do e = w%gt%first(b), w%gt%first(b + 1) - 1
                if (w%gt%key(e) /= kc) cycle
                t = w%gt%item(e)
                if (any(w%tri(:, t) == w%pts(p))) cycle
                glo = w%tlo(:, t) - reach
                ghi = w%thi(:, t) + reach
                if (any(w%plo(:, p) > ghi .or. glo > w%phi(:, p))) cycle
                cm = cell_of(max(w%plo(:, p), glo), origin, h)
                if (any(cm /= c)) cycle
                node = [w%pts(p), w%tri(:, t)]
                call consider(PAIR_PT, node, w%pts(p), w%tid(t))
              end do
            end do
          end do
        end do
      end do
    end subroutine point_triangle_pairs

    subroutine edge_edge_pairs()
      integer(int64) :: c(3), clo(3), chi(3), cm(3), kc
      integer :: a, e, f, b, node(4), cx, cy, cz
      real(rp) :: glo(3), ghi(3)

      do a = 1, ned
        clo = cell_of(w%elo(:, a), origin, h)
        chi = cell_of(w%ehi(:, a), origin, h)
        do cz = 0, int(chi(3) - clo(3))
          do cy = 0, int(chi(2) - clo(2))
            do cx = 0, int(chi(1) - clo(1))
              c = clo + [cx, cy, cz]
              b = bucket(w%ge, c)
              kc = cell_key(c)
              do e = w%ge%first(b), w%ge%first(b + 1) - 1
                if (w%ge%key(e) /= kc) cycle
                f = w%ge%item(e)
                if (w%eid(f) <= w%eid(a)) cycle
                if (any(w%edg(:, f) == w%edg(1, a) .or. w%edg(:, f) == w%edg(2, a))) cycle
                glo = w%elo(:, f) - reach
                ghi = w%ehi(:, f) + reach
                if (any(w%elo(:, a) > ghi .or. glo > w%ehi(:, a))) cycle
                cm = cell_of(max(w%elo(:, a), glo), origin, h)
                if (any(cm /= c)) cycle
                node = [w%edg(:, a), w%edg(:, f)]
                call consider(PAIR_EE, node, w%eid(a), w%eid(f))
              end do
            end do
          end do
        end do
      end do
    end subroutine edge_edge_pairs

    !> The narrow tests: ownership, rest distance, distance (or the path's bound: self_far). ida, idb:
    !> the point's node and the triangle's number, or the two edges' numbers.
    subroutine consider(kind, node, ida, idb)
      integer, intent(in) :: kind, node(4), ida, idb
      real(rp) :: xa(3, 4), xb(3, 4)
      integer :: jown

      if (own_rule == OWN_TOUCH) then
        if (.not. any(node / lat%nx >= own_lo .and. node / lat%nx <= own_hi)) return
      else
        jown = self_pair_owner_row(lat, node)
        if (jown < own_lo .or. jown > own_hi) return
      end if
      if (rest_reach > 0.0_rp) then
        if (rest_near(lat, w%rt, kind, ida, idb)) return
      end if
      xa = self_pair_positions(lat, w%slot, x0, node)
      xb = xa
      if (swept) xb = self_pair_positions(lat, w%slot, x1, node)
      if (self_pair_far(kind, xa, xb, swept, reach)) return
      call add_pair(pairs, kind, node)
    end subroutine consider

  end subroutine find_pairs

  !> The tables of one call in w (grown where too short): the present rows' slots, the
  !> primitives and their boxes over x0 and x1, the hash's cell h and origin, the two grids
  !> (boxes grown by reach) and the rest rule's table.
  subroutine prepare_tables(w, lat, rows, x0, x1, reach, rest_reach, regrown, ntri, ned, npt, origin, h)
    type(broad_work_t), intent(inout) :: w
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    real(rp), intent(in) :: x0(:, 0:, :), x1(:, 0:, :)
    real(rp), intent(in) :: reach, rest_reach          ! [length]
    integer, intent(inout) :: regrown
    integer, intent(out) :: ntri, ned, npt
    real(rp), intent(out) :: origin(3), h              ! [length]
    integer :: p

    call grow_from0(w%slot, lat%ny - 1, regrown)
    call self_row_slots(lat, rows, w%slot)
    call list_primitives(lat, rows, w%slot, w%tri, w%tid, ntri, w%edg, w%eid, ned, w%pts, npt, regrown)
    if (npt == 0) return
    call grow(w%tlo, 3, ntri, regrown)
    call grow(w%thi, 3, ntri, regrown)
    call grow(w%elo, 3, ned, regrown)
    call grow(w%ehi, 3, ned, regrown)
    call grow(w%plo, 3, npt, regrown)
    call grow(w%phi, 3, npt, regrown)
    call boxes(lat, w%slot, x0, x1, w%tri(:, 1:ntri), w%tlo, w%thi)
    call boxes(lat, w%slot, x0, x1, w%edg(:, 1:ned), w%elo, w%ehi)
    do p = 1, npt
      call node_box(lat, w%slot, x0, x1, w%pts(p:p), w%plo(:, p), w%phi(:, p))
    end do
    h = cell_size(w%tlo(:, 1:ntri), w%thi(:, 1:ntri), w%elo(:, 1:ned), w%ehi(:, 1:ned), w%plo(:, 1:npt), &
                  w%phi(:, 1:npt), reach)
    origin = minval(w%plo(:, 1:npt), dim=2) - 2.0_rp * reach - h
    call build_grid(w%gt, w%tlo(:, 1:ntri), w%thi(:, 1:ntri), reach, origin, h, regrown)
    call build_grid(w%ge, w%elo(:, 1:ned), w%ehi(:, 1:ned), reach, origin, h, regrown)
    call rest_table_for(w, lat, rest_reach, regrown)
  end subroutine prepare_tables

  !> The hash's cell: CELL_FACTOR times the mean over triangles and edges of the largest
  !> side of the grown box (a typical box spans 2 cells an axis; one stretched element
  !> takes more cells instead of making every cell large).
  pure real(rp) function cell_size(tlo, thi, elo, ehi, plo, phi, reach) result(h)
    real(rp), intent(in) :: tlo(:, :), thi(:, :), elo(:, :), ehi(:, :), plo(:, :), phi(:, :), reach
    real(rp) :: s, span
    integer :: k, n

    s = 0.0_rp
    do k = 1, size(tlo, 2)
      s = s + maxval(thi(:, k) - tlo(:, k))
    end do
    do k = 1, size(elo, 2)
      s = s + maxval(ehi(:, k) - elo(:, k))
    end do
    n = size(tlo, 2) + size(elo, 2)
    if (n > 0) then
      h = CELL_FACTOR * (s / n + 2.0_rp * reach)
    else
      h = maxval(phi - plo) + 2.0_rp * reach
    end if
    if (.not. h > 0.0_rp) h = 1.0_rp
    ! At most 2^20 cells an axis over the points' span (plus the margin of origin):
    ! cell_key packs 21 bits a coordinate.
    span = 0.0_rp
    do k = 1, 3
      span = max(span, maxval(phi(k, :)) - minval(plo(k, :)))
    end do
    h = max(h, (span + 4.0_rp * reach) / 2.0_rp**20)
  end function cell_size

  !> The rest rule (module header) for a point and a triangle (ida: the node, idb: the
  !> triangle's number) or two edges (their numbers, ida < idb), by rt's offsets.
  pure logical function rest_near(lat, rt, kind, ida, idb) result(near)
    type(self_lattice_t), intent(in) :: lat
    type(rest_table_t), intent(in) :: rt
    integer, intent(in) :: kind, ida, idb
    integer :: ga, gb, di, dj

    if (kind == PAIR_PT) then
      ga = idb / 2
      gb = ida
    else
      ga = ida / 3
      gb = idb / 3
    end if
    di = mod(gb, lat%nx) - mod(ga, lat%nx)
    dj = gb / lat%nx - ga / lat%nx
    near = .false.
    if (abs(di) > rt%ri .or. abs(dj) > rt%rj) return
    if (kind == PAIR_PT) then
      near = rt%pt(mod(idb, 2) + 1, di, dj)
    else
      near = rt%ee(mod(ida, 3), mod(idb, 3), di, dj)
    end if
  end function rest_near

  !> The rest rule's table: the pairs nearer than rest_reach at rest (rest_pattern_d2).
  !> A primitive spans one index, so offsets beyond rest_reach / spacing + 1 are never near.
  subroutine build_rest_table(lat, rest_reach, rt)
    type(self_lattice_t), intent(in) :: lat
    real(rp), intent(in) :: rest_reach
    type(rest_table_t), intent(out) :: rt
    real(rp), allocatable :: dpt(:, :, :), dee(:, :, :, :)

    if (.not. rest_reach > 0.0_rp) return
    rt%ri = min(int(rest_reach / lat%ax) + 2, lat%nx)
    rt%rj = min(int(rest_reach / lat%ay) + 2, lat%ny)
    call rest_pattern_d2(lat, rt%ri, rt%rj, dpt, dee)
    ! allocated with dpt's bounds (an expression's would start at 1)
    allocate(rt%pt(2, -rt%ri:rt%ri, -rt%rj:rt%rj), rt%ee(0:2, 0:2, -rt%ri:rt%ri, -rt%rj:rt%rj))
    rt%pt = dpt < rest_reach**2
    rt%ee = dee < rest_reach**2
  end subroutine build_rest_table

  !> The smallest distance at rest between a point and a triangle, or two edges, that
  !> share no node and that the rest rule keeps (rest distance >= rest_reach) [length];
  !> huge where the offsets searched hold none. A primitive spans one index, so pairs
  !> (di, dj) apart are at least (|di| - 1) ax and (|dj| - 1) ay apart: the offsets
  !> searched hold every pair within rest_reach + max(ax, ay), and the pair of a node and
  !> the diagonal of a quad beside it (ax ay / sqrt(ax^2 + ay^2)) is nearer than that.
  !> On a square lattice with rest_reach below 0.707 spacings: 0.707 spacings.
  function self_rest_gap(lat, rest_reach) result(g)
    type(self_lattice_t), intent(in) :: lat
    real(rp), intent(in) :: rest_reach
    real(rp) :: g
    real(rp), allocatable :: dpt(:, :, :), dee(:, :, :, :)
    real(rp) :: r2

    r2 = max(rest_reach, 0.0_rp)**2
    call rest_pattern_d2(lat, int((rest_reach + max(lat%ax, lat%ay)) / lat%ax) + 2, &
                         int((rest_reach + max(lat%ax, lat%ay)) / lat%ay) + 2, dpt, dee)
    g = huge(1.0_rp)
    if (any(dpt >= r2)) g = min(g, sqrt(minval(dpt, mask=dpt >= r2)))
    if (any(dee >= r2)) g = min(g, sqrt(minval(dee, mask=dee >= r2)))
  end function self_rest_gap

  !> Squared rest distances of the pairs by index offsets (rest_table_t's layout), -1
  !> where the two share a node: each offset's pair placed on a lattice of its own (the
  !> same split and spacing) and measured with self_pair_rest, as the pair itself would be.
  subroutine rest_pattern_d2(lat, ri, rj, dpt, dee)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: ri, rj                          ! offsets held along x and y
    real(rp), allocatable, intent(out) :: dpt(:, :, :)      ! (2, -ri:ri, -rj:rj) [length^2]
    real(rp), allocatable, intent(out) :: dee(:, :, :, :)   ! (0:2, 0:2, -ri:ri, -rj:rj) [length^2]
    type(self_lattice_t) :: lv
    integer :: qt(3, 2), ca, cb, t, ka, kb, di, dj, ga, gb, ea(2), eb(2), nt(3)

    allocate(dpt(2, -ri:ri, -rj:rj), dee(0:2, 0:2, -ri:ri, -rj:rj))
    lv = lat
    lv%nx = 2 * ri + 4
    call quad_triangles(lat%split, qt)
    call quad_diagonal(lat%split, ca, cb)
    ga = (ri + 1) + lv%nx * (rj + 1)
    do dj = -rj, rj
      do di = -ri, ri
        gb = ga + di + lv%nx * dj
        do t = 1, 2
          nt = quad_node(ga, qt(:, t))
          dpt(t, di, dj) = merge(-1.0_rp, self_pair_distance2(PAIR_PT, self_pair_rest(lv, [gb, nt])), any(nt == gb))
        end do
        do kb = 0, 2
          eb = edge_nodes(gb, kb)
          do ka = 0, 2
            ea = edge_nodes(ga, ka)
            dee(ka, kb, di, dj) = merge(-1.0_rp, self_pair_distance2(PAIR_EE, self_pair_rest(lv, [ea, eb])), &
                                        any(ea(1) == eb) .or. any(ea(2) == eb))
          end do
        end do
      end do
    end do

  contains

    pure function quad_node(g, corners) result(nd)
      integer, intent(in) :: g, corners(:)
      integer :: nd(size(corners))
      integer :: k

      do k = 1, size(corners)
        nd(k) = g + merge(1, 0, corners(k) == 2 .or. corners(k) == 4) + merge(lv%nx, 0, corners(k) >= 3)
      end do
    end function quad_node

    pure function edge_nodes(g, k) result(nd)
      integer, intent(in) :: g, k
      integer :: nd(2)

      select case (k)
      case (0)
        nd = [g, g + 1]
      case (1)
        nd = [g, g + lv%nx]
      case default
        nd = quad_node(g, [ca, cb])
      end select
    end function edge_nodes

  end subroutine rest_pattern_d2

  !> The primitives of the present rows (module header), as global node numbers (the
  !> arrays grown where too short).
  subroutine list_primitives(lat, rows, slot, tri, tid, ntri, edg, eid, ned, pts, npt, regrown)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:), slot(0:)
    integer, allocatable, intent(inout) :: tri(:, :), tid(:), edg(:, :), eid(:), pts(:)
    integer, intent(out) :: ntri, ned, npt
    integer, intent(inout) :: regrown
    integer :: r, i, j, g, t, c(4), qt(3, 2), ca, cb, nx

    nx = lat%nx
    call grow(tri, 3, 2 * nx * size(rows), regrown)
    call grow(tid, 2 * nx * size(rows), regrown)
    call grow(edg, 2, 3 * nx * size(rows), regrown)
    call grow(eid, 3 * nx * size(rows), regrown)
    call grow(pts, nx * size(rows), regrown)
    call quad_triangles(lat%split, qt)
    call quad_diagonal(lat%split, ca, cb)
    ntri = 0
    ned = 0
    npt = 0
    do r = 1, size(rows)
      j = rows(r)
      do i = 0, nx - 1
        g = i + nx * j
        npt = npt + 1
        pts(npt) = g
        if (i < nx - 1) call put_edge([g, g + 1], 3 * g)
        if (j + 1 > lat%ny - 1) cycle
        if (slot(j + 1) == 0) cycle
        call put_edge([g, g + nx], 3 * g + 1)
        if (i == nx - 1) cycle
        c = [g, g + 1, g + nx, g + nx + 1]
        do t = 1, 2
          ntri = ntri + 1
          tri(:, ntri) = c(qt(:, t))
          tid(ntri) = 2 * g + t - 1
        end do
        call put_edge([c(ca), c(cb)], 3 * g + 2)
      end do
    end do

  contains

    subroutine put_edge(nodes, id)
      integer, intent(in) :: nodes(2), id

      ned = ned + 1
      edg(:, ned) = nodes
      eid(ned) = id
    end subroutine put_edge

  end subroutine list_primitives

  !> Boxes of primitives (a column of nodes each) over their nodes' positions at x0 and x1,
  !> into the first size(nodes, 2) columns of lo and hi.
  pure subroutine boxes(lat, slot, x0, x1, nodes, lo, hi)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: slot(0:), nodes(:, :)
    real(rp), intent(in) :: x0(:, 0:, :), x1(:, 0:, :)
    real(rp), intent(inout) :: lo(:, :), hi(:, :)      ! (3, size(nodes, 2)+) [length]
    integer :: k

    do k = 1, size(nodes, 2)
      call node_box(lat, slot, x0, x1, nodes(:, k), lo(:, k), hi(:, k))
    end do
  end subroutine boxes

  !> Box of the nodes' positions at x0 and x1.
  pure subroutine node_box(lat, slot, x0, x1, nodes, lo, hi)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: slot(0:), nodes(:)
    real(rp), intent(in) :: x0(:, 0:, :), x1(:, 0:, :)
    real(rp), intent(out) :: lo(3), hi(3)
    integer :: k, i, s

    lo = huge(1.0_rp)
    hi = -huge(1.0_rp)
    do k = 1, size(nodes)
      i = mod(nodes(k), lat%nx)
      s = slot(nodes(k) / lat%nx)
      lo = min(lo, x0(1:3, i, s), x1(1:3, i, s))
      hi = max(hi, x0(1:3, i, s), x1(1:3, i, s))
    end do
  end subroutine node_box

  ! ------------------------------------------------------------------------
  ! The spatial hash
  ! ------------------------------------------------------------------------

  pure function cell_of(y, origin, h) result(c)
    real(rp), intent(in) :: y(3), origin(3), h
    integer(int64) :: c(3)

    c = floor((y - origin) / h, kind=int64)
  end function cell_of

  !> A cell's coordinates (each in 0..2^21-1: cell_size keeps them there) in one integer.
  pure integer(int64) function cell_key(c) result(k)
    integer(int64), intent(in) :: c(3)

    k = c(1) + ishft(c(2), 21) + ishft(c(3), 42)
  end function cell_key

  pure integer function bucket(g, c) result(b)
    type(grid_t), intent(in) :: g
    integer(int64), intent(in) :: c(3)

    b = int(iand(ieor(ieor(c(1) * P1, c(2) * P2), c(3) * P3), int(g%nbucket - 1, int64)))
  end function bucket

  !> The hash of boxes lo(:, k) - pad..hi(:, k) + pad: each box in every cell it overlaps
  !> (counting sort); g's arrays grown where too short.
  pure subroutine build_grid(g, lo, hi, pad, origin, h, regrown)
    type(grid_t), intent(inout) :: g
    real(rp), intent(in) :: lo(:, :), hi(:, :), pad, origin(3), h
    integer, intent(inout) :: regrown
    integer(int64) :: clo(3), chi(3), c(3)
    integer :: k, n, b, cx, cy, cz, pass

    n = 0
    do k = 1, size(lo, 2)
      clo = cell_of(lo(:, k) - pad, origin, h)
      chi = cell_of(hi(:, k) + pad, origin, h)
      n = n + int(product(chi - clo + 1))
    end do
    g%nbucket = 1
    do while (g%nbucket < n)
      g%nbucket = 2 * g%nbucket
    end do
    call grow_from0(g%first, g%nbucket, regrown)
    call grow_from0(g%fill, g%nbucket - 1, regrown)
    call grow(g%item, n, regrown)
    call grow(g%key, n, regrown)
    associate (fill => g%fill)
      fill(0:g%nbucket - 1) = 0
      do pass = 1, 2
        do k = 1, size(lo, 2)
          clo = cell_of(lo(:, k) - pad, origin, h)
          chi = cell_of(hi(:, k) + pad, origin, h)
          do cz = 0, int(chi(3) - clo(3))
            do cy = 0, int(chi(2) - clo(2))
              do cx = 0, int(chi(1) - clo(1))
                c = clo + [cx, cy, cz]
                b = bucket(g, c)
                if (pass == 1) then
                  fill(b) = fill(b) + 1
                else
                  g%item(fill(b)) = k
                  g%key(fill(b)) = cell_key(c)
                  fill(b) = fill(b) + 1
                end if
              end do
            end do
          end do
        end do
        if (pass == 1) then
          g%first(0) = 1
          do b = 0, g%nbucket - 1
            g%first(b + 1) = g%first(b) + fill(b)
          end do
          fill(0:g%nbucket - 1) = g%first(0:g%nbucket - 1)
        end if
      end do
    end associate
  end subroutine build_grid

  ! ------------------------------------------------------------------------
  ! The tables kept between calls
  ! ------------------------------------------------------------------------

  !> w%rt: the rest rule's table for rest_reach on lat, made again only where it was
  !> built for others (once for a list).
  subroutine rest_table_for(w, lat, rest_reach, regrown)
    type(broad_work_t), intent(inout) :: w
    type(self_lattice_t), intent(in) :: lat
    real(rp), intent(in) :: rest_reach
    integer, intent(inout) :: regrown

    if (rest_reach == w%rt_reach .and. lat%nx == w%rt_lat%nx .and. lat%ny == w%rt_lat%ny .and. &
        lat%split == w%rt_lat%split .and. lat%ax == w%rt_lat%ax .and. lat%ay == w%rt_lat%ay) return
    call build_rest_table(lat, rest_reach, w%rt)
    w%rt_reach = rest_reach
    w%rt_lat = lat
    regrown = regrown + 1
  end subroutine rest_table_for

end module self_broad
