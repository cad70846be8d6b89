! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of self-contact's broad phase (module self_broad) against the
!> brute force of tests/unit/self_shapes.f90 (every point against every
!> triangle, every edge against every edge): the same pairs, as a set, on
!> random rolled (spiral, turns closer than the reach), crumpled (random
!> smooth modes, self-intersecting) and folded sheets, with both quad splits,
!> at positions (self_candidates) and along random updates
!> (self_candidates_swept); on a subset of rows; split by ownership into
!> three bands of rows, the bands' lists are disjoint and make the whole;
!> the rest-distance rule (a flat sheet at rest has no pair with rest_reach =
!> reach; its lattice neighbours are pairs without it); each pair once, no
!> pair with a shared node; a list called again keeps its tables (no
!> reallocation where the sizes do not grow: the time loop's rule), with
!> the same pairs. Prints the broad phase's cost per vertex on
!> rolled sheets of 129 x 129 and 257 x 257 nodes.
program test_self_broad
  use, intrinsic :: iso_fortran_env, only: int64, output_unit
  use kinds, only: rp
  use contact_faces, only: SPLIT_MAIN, SPLIT_ANTI
  use self_broad, only: self_lattice_t, self_pairs_t, self_candidates, self_candidates_swept, PAIR_PT, &
                        OWN_LOWEST, OWN_TOUCH, self_pairs_regrown, self_rest_gap
  use self_shapes, only: roll_shape, fold_shape, crumple_shape, brute_keys, pair_keys
  use self_far, only: self_pair_far
  use contact_primitives, only: point_triangle_d2, edge_edge_d2
  use contact_ccd, only: accd_rate_bound
  use check, only: check_true, check_report, seed_random
  implicit none
  integer :: trial

  call seed_random(49)
  do trial = 1, 6
    call against_brute(trial)
  end do
  call ownership_bands()
  call rest_rule()
  call rest_gap()
  call kept_tables()
  call far_is_exact()
  call random_moves()
  call cost(129)
  call cost(257)
  call check_report()

contains

  !> Candidates (static and swept) against the brute force on one shape.
  subroutine against_brute(trial)
    integer, intent(in) :: trial
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :), dx(:, :, :)
    integer(int64), allocatable :: kb(:), kh(:)
    integer, allocatable :: rows(:)
    real(rp) :: reach
    character(len=40) :: what
    integer :: j

    lat = self_lattice_t(nx=9, ny=14, split=merge(SPLIT_MAIN, SPLIT_ANTI, mod(trial, 2) == 1), &
                         ax=0.01_rp, ay=0.012_rp)
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1), dx(3, 0:lat%nx - 1, 0:lat%ny - 1))
    reach = 0.004_rp
    select case ((trial + 1) / 2)
    case (1)
      call roll_shape(lat, 0.012_rp, 0.005_rp, 0.0015_rp, x)
      what = 'rolled'
    case (2)
      call crumple_shape(lat, 0.02_rp, 4, x)
      what = 'crumpled'
    case default
      call fold_shape(lat, 6, 0.003_rp, x)
      what = 'folded'
    end select
    write(what, '(a,a,i0)') trim(what), ', split ', lat%split
    rows = [(j, j = 0, lat%ny - 1)]

    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, reach, reach, pairs)
    call pair_keys(lat, pairs, kh)
    call brute_keys(lat, rows, x, x, .false., 0, lat%ny - 1, OWN_LOWEST, reach, reach, kb)
    call check_true(size(kb) > 20, trim(what)//': the shape has pairs in reach')
    call check_true(same(kh, kb), trim(what)//': candidates = brute force')
    call check_true(all(kh(2:) > kh(:size(kh) - 1)), trim(what)//': each pair once')
    call check_true(no_shared(pairs), trim(what)//': no pair shares a node')

    call random_number(dx)
    dx = 0.008_rp * (2.0_rp * dx - 1.0_rp)
    call self_candidates_swept(lat, rows, x, dx, 0, lat%ny - 1, OWN_LOWEST, 0.001_rp, reach, pairs)
    call pair_keys(lat, pairs, kh)
    call brute_keys(lat, rows, x, x + dx, .true., 0, lat%ny - 1, OWN_LOWEST, 0.001_rp, reach, kb)
    call check_true(size(kb) > 20, trim(what)//': paths come near')
    call check_true(same(kh, kb), trim(what)//': swept candidates = brute force')

    ! Reach and rest rule beyond the spacing: the rule's table of index offsets against
    ! the rest distance of each pair.
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.016_rp, 0.016_rp, pairs)
    call pair_keys(lat, pairs, kh)
    call brute_keys(lat, rows, x, x, .false., 0, lat%ny - 1, OWN_LOWEST, 0.016_rp, 0.016_rp, kb)
    call check_true(same(kh, kb), trim(what)//': reach and rest rule 1.6 spacings = brute force')
    call brute_keys(lat, rows, x, x, .false., 0, lat%ny - 1, OWN_LOWEST, 0.016_rp, 0.0_rp, kh)
    call check_true(size(kh) > size(kb) + 50, trim(what)//': the rest rule leaves out pairs')

    ! A subset of rows: rows 3..9 present, the primitives of 9 without their row above.
    rows = [(j, j = 3, 9)]
    call self_candidates(lat, rows, x(:, :, 3:9), 0, lat%ny - 1, OWN_LOWEST, reach, reach, pairs)
    call pair_keys(lat, pairs, kh)
    call brute_keys(lat, rows, x(:, :, 3:9), x(:, :, 3:9), .false., 0, lat%ny - 1, OWN_LOWEST, reach, reach, kb)
    call check_true(same(kh, kb), trim(what)//': rows 3..9 alone = brute force')
  end subroutine against_brute

  !> self_far's test (the boxes' gap before the exact distance) against the exact test
  !> alone, sqrt(d2) - ACCD's rate bound >= reach (swept) or d2 >= reach^2, on random
  !> pairs whose reach is their own distance give or take a few ulps (where a lower bound
  !> that cut too much would call a needed pair far) or a random one: the same answer on
  !> every pair.
  subroutine far_is_exact()
    real(rp) :: xa(3, 4), xb(3, 4), u(3, 4), r(2), d2, rb, reach
    integer :: m, kind, bad, nfar
    logical :: swept, exact

    bad = 0
    nfar = 0
    do m = 1, 40000
      call random_number(u)
      xa = 0.01_rp * u
      call random_number(u)
      xb = xa + 0.004_rp * (2.0_rp * u - 1.0_rp)
      call random_number(r)
      kind = merge(PAIR_PT, 2, r(1) < 0.5_rp)
      swept = r(2) < 0.5_rp
      if (kind == PAIR_PT) then
        d2 = point_triangle_d2(xa(:, 1), xa(:, 2), xa(:, 3), xa(:, 4))
      else
        d2 = edge_edge_d2(xa(:, 1), xa(:, 2), xa(:, 3), xa(:, 4))
      end if
      rb = 0.0_rp
      if (swept) rb = accd_rate_bound(kind, xb - xa)
      call random_number(r)
      if (r(1) < 0.5_rp) then
        reach = max(sqrt(d2) - rb, 0.0_rp) * (1.0_rp + (2.0_rp * r(2) - 1.0_rp) * 4.0_rp * epsilon(1.0_rp))
      else
        reach = 0.01_rp * r(2)
      end if
      if (swept) then
        exact = sqrt(d2) - rb >= reach
      else
        exact = d2 >= reach**2
      end if
      if (exact .neqv. self_pair_far(kind, xa, xb, swept, reach)) bad = bad + 1
      if (exact) nfar = nfar + 1
    end do
    call check_true(bad == 0, 'self_pair_far = the exact test on 40000 random pairs')
    write(output_unit, '(a, i0)') 'far pairs of 40000: ', nfar
    call check_true(nfar > 4000 .and. nfar < 36000, 'the random pairs are near and far')
  end subroutine far_is_exact

  !> The swept candidates against the brute force for random moves of a folded sheet at
  !> the benchmark's proportions where the halves meet (reach 0.6 spacings, moves of up
  !> to 1.5 spacings a node, smooth and noisy), on both ownership rules and two bands:
  !> a pair left out that the brute force keeps fails it.
  subroutine random_moves()
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :), dx(:, :, :), u(:, :, :)
    integer(int64), allocatable :: kb(:), kh(:)
    integer, allocatable :: rows(:)
    real(rp) :: v(3)
    integer :: trial, j, i, rule, lo, hi
    logical :: ok

    lat = self_lattice_t(nx=17, ny=17, split=SPLIT_MAIN, ax=0.01_rp, ay=0.01_rp)
    allocate(x(3, 0:16, 0:16), dx(3, 0:16, 0:16), u(3, 0:16, 0:16))
    rows = [(j, j = 0, 16)]
    ok = .true.
    do trial = 1, 8
      call fold_shape(lat, 8, 0.008_rp, x)
      call random_number(v)
      call random_number(u)
      do j = 0, 16
        do i = 0, 16
          ! the halves swinging toward each other, plus noise
          dx(:, i, j) = 0.015_rp * (2.0_rp * v - 1.0_rp) * merge(1.0_rp, -1.0_rp, j < 8) * sin(0.3_rp * (i + j)) &
                        + 0.004_rp * (2.0_rp * u(:, i, j) - 1.0_rp)
        end do
      end do
      rule = merge(OWN_LOWEST, OWN_TOUCH, mod(trial, 2) == 1)
      lo = merge(0, 5, trial <= 4)
      hi = merge(16, 11, trial <= 4)
      call self_candidates_swept(lat, rows, x, dx, lo, hi, rule, 0.006_rp, 0.005_rp, pairs)
      call pair_keys(lat, pairs, kh)
      call brute_keys(lat, rows, x, x + dx, .true., lo, hi, rule, 0.006_rp, 0.005_rp, kb)
      ok = ok .and. same(kh, kb) .and. size(kb) > 100
    end do
    call check_true(ok, 'random moves: swept candidates = brute force (8 moves, both rules, two bands)')
  end subroutine random_moves

  !> The tables stay with the list: a second call of the same size (static, then swept)
  !> reallocates nothing and finds the same pairs; a smaller one neither; a larger reach
  !> (more pairs, more cells) grows them.
  subroutine kept_tables()
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :), dx(:, :, :)
    integer(int64), allocatable :: k1(:), k2(:)
    integer, allocatable :: rows(:)
    integer :: j, n1, n2

    lat = self_lattice_t(nx=9, ny=14, split=SPLIT_MAIN, ax=0.01_rp, ay=0.012_rp)
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1), dx(3, 0:lat%nx - 1, 0:lat%ny - 1))
    call crumple_shape(lat, 0.02_rp, 4, x)
    rows = [(j, j = 0, lat%ny - 1)]
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.004_rp, 0.004_rp, pairs)
    call pair_keys(lat, pairs, k1)
    n1 = self_pairs_regrown(pairs)
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.004_rp, 0.004_rp, pairs)
    call pair_keys(lat, pairs, k2)
    call check_true(self_pairs_regrown(pairs) == n1, 'kept tables: a second call reallocates nothing')
    call check_true(size(k1) > 20 .and. same(k1, k2), 'kept tables: the same pairs again')
    call self_candidates(lat, rows(3:10), x(:, :, 3:10), 0, lat%ny - 1, OWN_LOWEST, 0.004_rp, 0.004_rp, pairs)
    call check_true(self_pairs_regrown(pairs) == n1, 'kept tables: fewer rows reallocate nothing')
    dx = 0.0_rp
    call self_candidates_swept(lat, rows, x, dx, 0, lat%ny - 1, OWN_LOWEST, 0.001_rp, 0.004_rp, pairs)
    n2 = self_pairs_regrown(pairs)
    call self_candidates_swept(lat, rows, x, dx, 0, lat%ny - 1, OWN_LOWEST, 0.001_rp, 0.004_rp, pairs)
    call check_true(self_pairs_regrown(pairs) == n2, 'kept tables: a second swept call reallocates nothing')
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.02_rp, 0.004_rp, pairs)
    call check_true(self_pairs_regrown(pairs) > n2, 'kept tables: a larger reach grows them')
  end subroutine kept_tables

  !> Three bands of owned rows, all rows present: disjoint lists whose union is the whole.
  subroutine ownership_bands()
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :)
    integer(int64), allocatable :: kall(:), kband(:), kunion(:)
    integer, allocatable :: rows(:)
    integer :: j, b, lo(3), hi(3), ntouch

    lat = self_lattice_t(nx=8, ny=20, split=SPLIT_MAIN, ax=0.01_rp, ay=0.01_rp)
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1))
    call fold_shape(lat, 10, 0.003_rp, x)
    rows = [(j, j = 0, lat%ny - 1)]
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.004_rp, 0.004_rp, pairs)
    call pair_keys(lat, pairs, kall)
    lo = [0, 6, 13]
    hi = [5, 12, 19]
    allocate(kunion(0))
    do b = 1, 3
      call self_candidates(lat, rows, x, lo(b), hi(b), OWN_LOWEST, 0.004_rp, 0.004_rp, pairs)
      call pair_keys(lat, pairs, kband)
      kunion = [kunion, kband]
    end do
    call check_true(size(kunion) == size(kall), 'bands: counts add up (no pair on two bands)')
    call sort_local(kunion)
    call check_true(same(kunion, kall), 'bands: their union is the whole list')
    call check_true(size(kall) > 50, 'bands: the fold has pairs across its layers')
    ! The other rule: the pairs that touch a band's rows, against the brute force; the
    ! layers' pairs between the first and the last band are on both.
    ntouch = 0
    do b = 1, 3
      call self_candidates(lat, rows, x, lo(b), hi(b), OWN_TOUCH, 0.004_rp, 0.004_rp, pairs)
      call pair_keys(lat, pairs, kband)
      ntouch = ntouch + size(kband)
      call brute_keys(lat, rows, x, x, .false., lo(b), hi(b), OWN_TOUCH, 0.004_rp, 0.004_rp, kunion)
      call check_true(same(kband, kunion), 'bands, pairs touching a band = brute force')
    end do
    call check_true(ntouch > size(kall), 'bands: pairs across bands touch both')
  end subroutine ownership_bands

  !> The rest-distance rule on a flat sheet at rest.
  subroutine rest_rule()
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :)
    integer, allocatable :: rows(:)
    integer :: i, j

    lat = self_lattice_t(nx=6, ny=5, split=SPLIT_ANTI, ax=0.01_rp, ay=0.01_rp)
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1))
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        x(:, i, j) = [i * lat%ax, j * lat%ay, 0.0_rp]
      end do
    end do
    rows = [(j, j = 0, lat%ny - 1)]
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.015_rp, 0.015_rp, pairs)
    call check_true(pairs%n == 0, 'flat at rest, rest_reach = reach > spacing: no pair')
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.008_rp, 0.0_rp, pairs)
    call check_true(pairs%n > 0 .and. count(pairs%kind(1:pairs%n) == PAIR_PT) > 0, &
                    'flat at rest, no rest rule, reach 0.8 spacing: the lattice neighbours are pairs')
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.006_rp, 0.0_rp, pairs)
    call check_true(pairs%n == 0, 'flat at rest, reach 0.6 spacing: nothing nearer than 0.707 spacing')
  end subroutine rest_rule

  !> self_rest_gap against the lattice's geometry: a node and the diagonal of a quad beside
  !> it lie ax ay / sqrt(ax^2 + ay^2) apart (a / sqrt 2 on a square lattice, either split);
  !> with the rest rule past that, the next pairs are a spacing apart (a node and the
  !> triangle of the next row, parallel links). And on a flat sheet at rest, a reach just
  !> below the gap finds no pair, just above it finds some (the Verlet list's cap).
  subroutine rest_gap()
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :)
    integer, allocatable :: rows(:)
    real(rp) :: g
    integer :: i, j, split

    do split = SPLIT_MAIN, SPLIT_ANTI, SPLIT_ANTI - SPLIT_MAIN
      lat = self_lattice_t(nx=9, ny=7, split=split, ax=0.01_rp, ay=0.01_rp)
      call check_true(abs(self_rest_gap(lat, 0.005_rp) - 0.01_rp / sqrt(2.0_rp)) < 1.0e-15_rp, &
                      'rest gap, square lattice: spacing / sqrt 2')
      call check_true(abs(self_rest_gap(lat, 0.0_rp) - 0.01_rp / sqrt(2.0_rp)) < 1.0e-15_rp, &
                      'rest gap, no rest rule: spacing / sqrt 2')
      call check_true(abs(self_rest_gap(lat, 0.0095_rp) - 0.01_rp) < 1.0e-15_rp, &
                      'rest gap, rest rule past the diagonal: a spacing')
      lat = self_lattice_t(nx=9, ny=7, split=split, ax=0.01_rp, ay=0.02_rp)
      g = self_rest_gap(lat, 0.005_rp)
      call check_true(abs(g - 0.02_rp / sqrt(5.0_rp)) < 1.0e-15_rp, 'rest gap, ax = ay / 2: ax ay / |(ax, ay)|')
      allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1))
      do j = 0, lat%ny - 1
        do i = 0, lat%nx - 1
          x(:, i, j) = [i * lat%ax, j * lat%ay, 0.0_rp]
        end do
      end do
      rows = [(j, j = 0, lat%ny - 1)]
      call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 0.999_rp * g, 0.005_rp, pairs)
      call check_true(pairs%n == 0, 'flat at rest, reach just below the rest gap: no pair')
      call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, 1.001_rp * g, 0.005_rp, pairs)
      call check_true(pairs%n > 0, 'flat at rest, reach just above the rest gap: pairs')
      deallocate(x)
    end do
  end subroutine rest_gap

  !> Time of one static broad phase on a rolled n x n sheet, per vertex (printed).
  subroutine cost(n)
    integer, intent(in) :: n
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :)
    integer, allocatable :: rows(:)
    integer(int64) :: c0, c1, rate
    integer :: j, rep
    real(rp) :: best

    lat = self_lattice_t(nx=n, ny=n, split=SPLIT_MAIN, ax=1.0_rp / (n - 1), ay=1.0_rp / (n - 1))
    allocate(x(3, 0:n - 1, 0:n - 1))
    ! turns 0.4 spacing apart (closer than the reach, 0.5 spacing), 0.05 spacing of noise
    call roll_shape(lat, 0.05_rp, 0.4_rp * lat%ay, 0.05_rp * lat%ax, x)
    rows = [(j, j = 0, n - 1)]
    best = huge(1.0_rp)
    do rep = 1, 3
      call system_clock(c0, rate)
      call self_candidates(lat, rows, x, 0, n - 1, OWN_LOWEST, 0.5_rp * lat%ax, 0.5_rp * lat%ax, pairs)
      call system_clock(c1)
      best = min(best, real(c1 - c0, rp) / rate)
    end do
    write(output_unit, '(a,i0,a,i0,a,f8.1,a,f6.2,a)') 'broad phase, rolled ', n, ' x ', n, ': ', &
      1.0e9_rp * best / (n * n), ' ns a vertex, ', real(pairs%n, rp) / (n * n), ' pairs a vertex'
    call check_true(pairs%n > n * n, 'rolled sheet: the turns are in reach')
  end subroutine cost

  logical function same(a, b)
    integer(int64), intent(in) :: a(:), b(:)
    same = size(a) == size(b)
    if (same) same = all(a == b)
  end function same

  logical function no_shared(pairs)
    type(self_pairs_t), intent(in) :: pairs
    integer :: m, k
    no_shared = .true.
    do m = 1, pairs%n
      do k = 1, 3
        if (any(pairs%node(k + 1:, m) == pairs%node(k, m))) no_shared = .false.
      end do
    end do
  end function no_shared

  subroutine sort_local(a)
    use self_shapes, only: sort_keys
    integer(int64), intent(inout) :: a(:)
    call sort_keys(a)
  end subroutine sort_local

end program test_self_broad
