! SPDX-License-Identifier: BSD-2-Clause
!> Shared by the self-contact tests (unit and MPI): crumpled and folded
!> lattices, and the brute-force reference of the broad phase (module
!> self_broad): every point against every triangle and every edge against
!> every edge of the present rows, enumerated here on their own, with the
!> same rules (no shared node, not neighbours at rest, ownership, reach or
!> the swept test), as sorted integer keys; the broad phase's list as keys.
module self_shapes
  use, intrinsic :: iso_fortran_env, only: int64
  use kinds, only: rp
  use contact_faces, only: quad_triangles, quad_diagonal
  use contact_ccd, only: accd_rate_bound
  use self_broad, only: self_lattice_t, self_pairs_t, PAIR_PT, PAIR_EE, OWN_TOUCH, self_row_slots, self_pair_positions, &
                        self_pair_rest, self_pair_distance2, self_pair_owner_row
  implicit none
  private
  public :: roll_shape, fold_shape, crumple_shape, brute_keys, pair_keys, sort_keys, all_pairs

contains

  !> The sheet rolled about the x axis into a spiral whose turns are delta apart (first
  !> radius r0), each node moved by a uniform random amount in [-noise, noise] a coordinate.
  subroutine roll_shape(lat, r0, delta, noise, x)
    type(self_lattice_t), intent(in) :: lat
    real(rp), intent(in) :: r0, delta, noise
    real(rp), intent(out) :: x(3, 0:lat%nx - 1, 0:lat%ny - 1)
    real(rp), parameter :: PI = acos(-1.0_rp)
    real(rp) :: s, th, r, u(3)
    integer :: i, j

    do j = 0, lat%ny - 1
      ! arc length s = r0 th + delta th^2 / (4 pi) along the spiral r = r0 + delta th / (2 pi)
      s = j * lat%ay
      th = (-r0 + sqrt(r0**2 + delta * s / PI)) / (delta / (2.0_rp * PI))
      r = r0 + delta * th / (2.0_rp * PI)
      do i = 0, lat%nx - 1
        call random_number(u)
        x(:, i, j) = [i * lat%ax, r * cos(th), r * sin(th)] + noise * (2.0_rp * u - 1.0_rp)
      end do
    end do
  end subroutine roll_shape

  !> The sheet folded back onto itself about row jm: rows above it turn on a half circle
  !> of diameter delta and lie delta above the rows below, with a small deterministic
  !> wobble (the same on every rank, no random numbers).
  subroutine fold_shape(lat, jm, delta, x)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: jm
    real(rp), intent(in) :: delta
    real(rp), intent(out) :: x(3, 0:lat%nx - 1, 0:lat%ny - 1)
    real(rp), parameter :: PI = acos(-1.0_rp)
    real(rp) :: s, y, z, rh, w
    integer :: i, j

    rh = 0.5_rp * delta
    do j = 0, lat%ny - 1
      s = (j - jm) * lat%ay
      if (s <= 0.0_rp) then
        y = j * lat%ay
        z = 0.0_rp
      else if (s <= PI * rh) then
        y = jm * lat%ay + rh * sin(s / rh)
        z = rh - rh * cos(s / rh)
      else
        y = jm * lat%ay - (s - PI * rh)
        z = delta
      end if
      do i = 0, lat%nx - 1
        w = 0.1_rp * delta * sin(1.7_rp * i + 2.3_rp * j) * cos(0.9_rp * i - 1.3_rp * j)
        x(:, i, j) = [i * lat%ax + 0.3_rp * w, y - 0.2_rp * w, z + w]
      end do
    end do
  end subroutine fold_shape

  !> Rest positions plus nm random smooth modes of amplitude amp in each coordinate
  !> (wavelengths of a few cells): a crumpled, possibly self-intersecting sheet.
  subroutine crumple_shape(lat, amp, nm, x)
    type(self_lattice_t), intent(in) :: lat
    real(rp), intent(in) :: amp
    integer, intent(in) :: nm
    real(rp), intent(out) :: x(3, 0:lat%nx - 1, 0:lat%ny - 1)
    real(rp) :: kx(nm), ky(nm), ph(nm), a(3, nm), u(4)
    integer :: i, j, m

    do m = 1, nm
      call random_number(u)
      kx(m) = (0.3_rp + 1.2_rp * u(1)) / lat%ax
      ky(m) = (0.3_rp + 1.2_rp * u(2)) / lat%ay
      ph(m) = 6.0_rp * u(3)
      call random_number(a(:, m))
      a(:, m) = amp * (2.0_rp * a(:, m) - 1.0_rp)
    end do
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        x(:, i, j) = [i * lat%ax, j * lat%ay, 0.0_rp]
        do m = 1, nm
          x(:, i, j) = x(:, i, j) + a(:, m) * sin(kx(m) * i * lat%ax + ky(m) * j * lat%ay + ph(m))
        end do
      end do
    end do
  end subroutine crumple_shape

  !> Every point-triangle and edge-edge pair of the present rows that shares no node (no
  !> rest rule, no ownership, no distance test), in broad phase order.
  subroutine all_pairs(lat, rows, pairs)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    type(self_pairs_t), intent(out) :: pairs
    integer, allocatable :: tri(:, :), edg(:, :), eid(:), pts(:)
    integer :: a, b, n, node(4), kind

    call primitives(lat, rows, tri, edg, eid, pts)
    pairs%n = 0
    allocate(pairs%kind(size(pts) * size(tri, 2) + size(eid)**2), pairs%node(4, size(pairs%kind)))
    do a = 1, size(pts)
      do b = 1, size(tri, 2)
        if (any(tri(:, b) == pts(a))) cycle
        call put(PAIR_PT, [pts(a), tri(:, b)])
      end do
    end do
    do a = 1, size(eid)
      do b = 1, size(eid)
        if (eid(b) <= eid(a)) cycle
        if (any(edg(:, b) == edg(1, a) .or. edg(:, b) == edg(2, a))) cycle
        call put(PAIR_EE, [edg(:, a), edg(:, b)])
      end do
    end do

  contains

    subroutine put(k, nd)
      integer, intent(in) :: k, nd(4)

      kind = k
      node = nd
      n = pairs%n + 1
      pairs%n = n
      pairs%kind(n) = kind
      pairs%node(:, n) = node
    end subroutine put

  end subroutine all_pairs

  !> The brute-force reference of self_candidates (swept false: x1 unused) or
  !> self_candidates_swept (x1 = x0 + dx), as sorted keys.
  subroutine brute_keys(lat, rows, x0, x1, swept, own_lo, own_hi, own_rule, reach, rest_reach, keys)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:), own_lo, own_hi, own_rule
    real(rp), intent(in) :: x0(:, 0:, :), x1(:, 0:, :), reach, rest_reach
    logical, intent(in) :: swept
    integer(int64), allocatable, intent(out) :: keys(:)
    type(self_pairs_t) :: every, kept
    integer, allocatable :: slot(:)
    real(rp) :: xa(3, 4), xb(3, 4), d2, lo1(3), hi1(3), lo2(3), hi2(3)
    integer :: m, j, nd(4), na

    allocate(slot(0:lat%ny - 1))
    call self_row_slots(lat, rows, slot)
    call all_pairs(lat, rows, every)
    kept%n = 0
    allocate(kept%kind(every%n), kept%node(4, every%n))
    do m = 1, every%n
      nd = every%node(:, m)
      if (own_rule == OWN_TOUCH) then
        if (.not. any(nd / lat%nx >= own_lo .and. nd / lat%nx <= own_hi)) cycle
      else
        j = self_pair_owner_row(lat, nd)
        if (j < own_lo .or. j > own_hi) cycle
      end if
      if (rest_reach > 0.0_rp) then
        if (self_pair_distance2(every%kind(m), self_pair_rest(lat, nd)) < rest_reach**2) cycle
      end if
      xa = self_pair_positions(lat, slot, x0, nd)
      d2 = self_pair_distance2(every%kind(m), xa)
      if (swept) then
        xb = self_pair_positions(lat, slot, x1, nd)
        na = merge(1, 2, every%kind(m) == PAIR_PT)
        lo1 = min(minval(xa(:, 1:na), dim=2), minval(xb(:, 1:na), dim=2))
        hi1 = max(maxval(xa(:, 1:na), dim=2), maxval(xb(:, 1:na), dim=2))
        lo2 = min(minval(xa(:, na + 1:4), dim=2), minval(xb(:, na + 1:4), dim=2)) - reach
        hi2 = max(maxval(xa(:, na + 1:4), dim=2), maxval(xb(:, na + 1:4), dim=2)) + reach
        if (any(lo1 > hi2 .or. lo2 > hi1)) cycle
        if (sqrt(d2) - accd_rate_bound(every%kind(m), xb - xa) >= reach) cycle
      else
        if (d2 >= reach**2) cycle
      end if
      kept%n = kept%n + 1
      kept%kind(kept%n) = every%kind(m)
      kept%node(:, kept%n) = nd
    end do
    call pair_keys(lat, kept, keys)
  end subroutine brute_keys

  !> The pairs as sorted keys (kind - 1) + 2 (n1 + N (n2 + N (n3 + N n4))), N = nx ny.
  subroutine pair_keys(lat, pairs, keys)
    type(self_lattice_t), intent(in) :: lat
    type(self_pairs_t), intent(in) :: pairs
    integer(int64), allocatable, intent(out) :: keys(:)
    integer(int64) :: nn
    integer :: m

    nn = int(lat%nx, int64) * lat%ny
    allocate(keys(pairs%n))
    do m = 1, pairs%n
      keys(m) = (pairs%kind(m) - 1) + 2_int64 * (pairs%node(1, m) + nn * (pairs%node(2, m) &
                + nn * (pairs%node(3, m) + nn * int(pairs%node(4, m), int64))))
    end do
    call sort_keys(keys)
  end subroutine pair_keys

  !> Heap sort, ascending.
  subroutine sort_keys(a)
    integer(int64), intent(inout) :: a(:)
    integer :: n, k, e
    integer(int64) :: t

    n = size(a)
    do k = n / 2, 1, -1
      call sift(k, n)
    end do
    do e = n, 2, -1
      t = a(1)
      a(1) = a(e)
      a(e) = t
      call sift(1, e - 1)
    end do

  contains

    subroutine sift(start, last)
      integer, intent(in) :: start, last
      integer :: r, c
      integer(int64) :: v

      r = start
      v = a(r)
      do
        c = 2 * r
        if (c > last) exit
        if (c < last) then
          if (a(c + 1) > a(c)) c = c + 1
        end if
        if (a(c) <= v) exit
        a(r) = a(c)
        r = c
      end do
      a(r) = v
    end subroutine sift

  end subroutine sort_keys

  !> The primitives of the present rows, enumerated for the reference (self_broad's header).
  subroutine primitives(lat, rows, tri, edg, eid, pts)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    integer, allocatable, intent(out) :: tri(:, :), edg(:, :), eid(:), pts(:)
    integer :: r, i, j, g, t, qt(3, 2), ca, cb, c(4), nx
    logical :: up

    nx = lat%nx
    call quad_triangles(lat%split, qt)
    call quad_diagonal(lat%split, ca, cb)
    allocate(tri(3, 0), edg(2, 0), eid(0), pts(0))
    do r = 1, size(rows)
      j = rows(r)
      up = j + 1 <= lat%ny - 1 .and. any(rows == j + 1)
      do i = 0, nx - 1
        g = i + nx * j
        pts = [pts, g]
        if (i + 1 < nx) then
          edg = reshape([edg, g, g + 1], [2, size(edg, 2) + 1])
          eid = [eid, 3 * g]
        end if
        if (.not. up) cycle
        edg = reshape([edg, g, g + nx], [2, size(edg, 2) + 1])
        eid = [eid, 3 * g + 1]
        if (i + 1 >= nx) cycle
        c = [g, g + 1, g + nx, g + nx + 1]
        do t = 1, 2
          tri = reshape([tri, c(qt(:, t))], [3, size(tri, 2) + 1])
        end do
        edg = reshape([edg, c(ca), c(cb)], [2, size(edg, 2) + 1])
        eid = [eid, 3 * g + 2]
      end do
    end do
  end subroutine primitives

end module self_shapes
