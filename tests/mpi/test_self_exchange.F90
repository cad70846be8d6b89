! SPDX-License-Identifier: BSD-2-Clause
!> MPI test of self-contact's exchange (module self_exchange) with the
!> kernels of self_broad, self_barrier and self_step. Each rank holds the
!> rows of its strip (as a DMDA makes them) and the row above; the test
!> builds the whole sheet on every rank only as the one-rank reference.
!> On a sheet folded onto itself (the layers on different ranks) and on a
!> rolled one, with patches of 1, 4 and 1000 rows:
!>  1. the candidate pairs found by the ranks (own rows plus the fetched
!>     ones, each pair on the rank of its lowest node) are, as a set of
!>     global node numbers, those that one rank finds over the whole sheet,
!>     and no pair is found on two ranks;
!>  2. the same for the swept candidates of an update, and the global ACCD
!>     alpha (the minimum over the ranks) equals the one-rank alpha;
!>  3. the barrier's forces, with those on fetched nodes sent back to their
!>     owners, equal the one-rank forces on every owned node (to round-off),
!>     the energies add up, the pair blocks' count is the one-rank count;
!>  4. OGC's per-vertex distances, with the minimum taken on the owners,
!>     equal the one-rank distances;
!>  5. a plan made again at the same positions, and its gathers of 3 and
!>     6 values a node, reallocate nothing (the plan keeps its tables and
!>     message buffers: the time loop's rule) and fetch the same rows.
!> Run on 1 and 3 ranks by CTest; 2, 4 and 8 ranks by hand (--oversubscribe).
program test_self_exchange
  use, intrinsic :: iso_fortran_env, only: int64, output_unit
  use mpi
  use kinds, only: rp
  use contact, only: contact_params_t
  use contact_ccd, only: ACCD_S
  use contact_faces, only: SPLIT_MAIN, SPLIT_ANTI
  use self_broad, only: self_lattice_t, self_pairs_t, self_candidates, self_candidates_swept, OWN_LOWEST, OWN_TOUCH
  use self_barrier, only: self_blocks_t, self_barrier_forces
  use self_step, only: self_alpha_ccd, self_vertex_dmin
  use self_exchange, only: self_exchange_t, self_exchange_plan, self_exchange_plan_swept, self_exchange_rows, &
                           self_exchange_gather, self_exchange_add, self_exchange_min, self_exchange_free, &
                           self_exchange_counts, self_exchange_regrown
  use self_shapes, only: fold_shape, roll_shape, pair_keys, sort_keys
  use check, only: check_true, check_close_array, check_report, seed_random
  implicit none
  integer :: ierr, rank, nranks, ys, ye, k, shape, ip
  integer, parameter :: PATCHES(3) = [1, 4, 1000]
  type(contact_params_t) :: cp

  call MPI_Init(ierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, ierr)
  call MPI_Comm_size(MPI_COMM_WORLD, nranks, ierr)
  cp = contact_params_t(thickness=0.001_rp, dhat=0.002_rp, kappa=50.0_rp)
  do shape = 1, 2
    do ip = 1, size(PATCHES)
      call run_case(shape, PATCHES(ip))
    end do
  end do
  call check_report()
  call MPI_Finalize(ierr)

contains

  !> Rows ys..ye of rank r of ny rows on nranks, as a DMDA splits them.
  subroutine strip(ny, r, ys, ye)
    integer, intent(in) :: ny, r
    integer, intent(out) :: ys, ye
    integer :: base, extra, q

    base = ny / nranks
    extra = mod(ny, nranks)
    ys = 0
    do q = 0, r - 1
      ys = ys + base + merge(1, 0, q < extra)
    end do
    ye = ys + base + merge(1, 0, r < extra) - 1
  end subroutine strip

  subroutine run_case(shape, patch_rows)
    integer, intent(in) :: shape, patch_rows
    type(self_lattice_t) :: lat
    type(self_exchange_t) :: xch
    type(self_pairs_t) :: pairs
    type(self_blocks_t) :: blocks
    real(rp), allocatable :: xg(:, :, :), dxg(:, :, :), x6(:, :, :), xall(:, :, :), fall(:, :, :), f(:, :, :)
    real(rp), allocatable :: fser(:, :, :), dall(:, :, :), d(:, :, :), dser(:, :, :)
    integer, allocatable :: rows(:), allrows(:), rows2(:)
    integer(int64), allocatable :: keys(:), kser(:)
    real(rp) :: reach, alpha, alpha_ser, e, eser, esum, r
    integer :: j, i, ys0, ye1, nact, nact_ser, nb, nbsum, nf, ns, np, k0, n1
    character(len=48) :: what

    reach = cp%dhat + cp%thickness
    if (shape == 1) then
      lat = self_lattice_t(nx=12, ny=40, split=SPLIT_MAIN, ax=0.01_rp, ay=0.01_rp)
      allocate(xg(3, 0:lat%nx - 1, 0:lat%ny - 1))
      call fold_shape(lat, 20, cp%thickness + 0.6_rp * cp%dhat, xg)
      write(what, '(a,i0)') 'folded sheet, patches of ', patch_rows
    else
      lat = self_lattice_t(nx=8, ny=36, split=SPLIT_ANTI, ax=0.01_rp, ay=0.01_rp)
      allocate(xg(3, 0:lat%nx - 1, 0:lat%ny - 1))
      call seed_random(4904)            ! the same sheet on every rank
      call roll_shape(lat, 0.012_rp, 0.0035_rp, 0.0005_rp, xg)
      write(what, '(a,i0)') 'rolled sheet, patches of ', patch_rows
    end if
    allocate(dxg, mold=xg)
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        dxg(:, i, j) = 0.004_rp * [sin(0.9_rp * i + 1.3_rp * j), cos(0.7_rp * i - 0.4_rp * j), sin(0.5_rp * i * j + 0.2_rp)]
      end do
    end do
    call strip(lat%ny, rank, ys, ye)
    ys0 = max(ys - 1, 0)
    ye1 = min(ye + 1, lat%ny - 1)
    allrows = [(j, j = 0, lat%ny - 1)]

    ! 1. candidates at positions
    call self_exchange_plan(xch, MPI_COMM_WORLD, lat%nx, lat%ny, ys, ye, xg(:, :, ys0:ye1), reach, patch_rows, ierr)
    call check_true(ierr == 0, trim(what)//': plan')
    call self_exchange_rows(xch, rows)
    allocate(xall(3, 0:lat%nx - 1, size(rows)))
    call self_exchange_gather(xch, xg(:, :, ys:ye), xall, ierr)
    call check_true(all(xall == xg(:, :, rows)), trim(what)//': the fetched rows are the owners'' rows')
    call self_exchange_counts(xch, nf, ns, np)
    if (patch_rows == 4) write(output_unit, '(a,i0,a,i0,a,i0,a,i0,a,i0,a)') trim(what)//': rank ', rank, ' owns ', &
      ye - ys + 1, ' rows, fetched ', nf, ' from ', ns, ' ranks (', np, ' patches in all)'
    call self_candidates(lat, rows, xall, ys, ye, OWN_LOWEST, reach, reach, pairs)
    call pair_keys(lat, pairs, keys)
    call self_candidates(lat, allrows, xg, 0, lat%ny - 1, OWN_LOWEST, reach, reach, pairs)
    call pair_keys(lat, pairs, kser)
    call check_true(same_set(keys, kser, what), trim(what)//': candidates on P ranks = on one')
    ! Without the exchange (the strip and its row above only) the layers on other ranks
    ! are missed: the comparison above sees it.
    if (shape == 1 .and. nranks > 1) then
      call self_candidates(lat, [(j, j = ys, ye1)], xg(:, :, ys:ye1), ys, ye, OWN_LOWEST, reach, reach, pairs)
      call pair_keys(lat, pairs, keys)
      call check_true(.not. same_set(keys, kser, what), trim(what)//': without the exchange pairs are missed')
    end if

    ! 3. forces, energy, blocks
    allocate(fall(3, 0:lat%nx - 1, size(rows)), f(3, 0:lat%nx - 1, ys:ye))
    fall = 0.0_rp
    f = 0.0_rp
    call self_candidates(lat, rows, xall, ys, ye, OWN_LOWEST, reach, reach, pairs)
    call self_barrier_forces(lat, rows, xall, pairs, ys, ye, cp, .false., e, fall, blocks, nact)
    nb = blocks%n
    call self_exchange_add(xch, fall, f, ierr)
    call check_true(ierr == 0, trim(what)//': forces returned')
    allocate(fser(3, 0:lat%nx - 1, 0:lat%ny - 1))
    fser = 0.0_rp
    call self_candidates(lat, allrows, xg, 0, lat%ny - 1, OWN_LOWEST, reach, reach, pairs)
    call self_barrier_forces(lat, allrows, xg, pairs, 0, lat%ny - 1, cp, .false., eser, fser, blocks, nact_ser)
    call check_close_array(reshape(f, [size(f)]), reshape(fser(:, :, ys:ye), [size(f)]), 0.0_rp, &
                           1.0e-12_rp * maxval(abs(fser)), trim(what)//': forces on owned nodes = one rank''s')
    call MPI_Allreduce(e, esum, 1, MPI_DOUBLE_PRECISION, MPI_SUM, MPI_COMM_WORLD, ierr)
    call check_close_array([esum], [eser], 1.0e-12_rp, 0.0_rp, trim(what)//': energies add up')
    call MPI_Allreduce(nb, nbsum, 1, MPI_INTEGER, MPI_SUM, MPI_COMM_WORLD, ierr)
    call check_true(nbsum == blocks%n .and. nact_ser > 0, trim(what)//': pair blocks counted once')
    ! The other rule: each rank takes every pair that touches its rows and keeps its own
    ! rows' forces, nothing sent back; the energy counts each pair once all the same.
    call self_candidates(lat, rows, xall, ys, ye, OWN_TOUCH, reach, reach, pairs)
    fall = 0.0_rp
    call self_barrier_forces(lat, rows, xall, pairs, ys, ye, cp, .false., e, fall, blocks, nact)
    k0 = findloc(rows, ys, dim=1)
    call check_close_array(reshape(fall(:, :, k0:k0 + ye - ys), [size(f)]), reshape(fser(:, :, ys:ye), [size(f)]), &
                           0.0_rp, 1.0e-12_rp * maxval(abs(fser)), trim(what)//': pairs touching the rows: own forces = one rank''s')
    call MPI_Allreduce(e, esum, 1, MPI_DOUBLE_PRECISION, MPI_SUM, MPI_COMM_WORLD, ierr)
    call check_close_array([esum], [eser], 1.0e-12_rp, 0.0_rp, trim(what)//': pairs touching the rows: energies add up')

    ! 4. OGC's per-vertex distances (search radius 2 reach)
    call self_exchange_free(xch)
    r = 2.0_rp * reach
    call self_exchange_plan(xch, MPI_COMM_WORLD, lat%nx, lat%ny, ys, ye, xg(:, :, ys0:ye1), r, patch_rows, ierr)
    call self_exchange_rows(xch, rows)
    deallocate(xall)
    allocate(xall(3, 0:lat%nx - 1, size(rows)), dall(1, 0:lat%nx - 1, size(rows)), d(1, 0:lat%nx - 1, ys:ye))
    call self_exchange_gather(xch, xg(:, :, ys:ye), xall, ierr)
    call self_candidates(lat, rows, xall, ys, ye, OWN_LOWEST, r, reach, pairs)
    dall = r
    d = r
    call self_vertex_dmin(lat, rows, xall, pairs, dall(1, :, :))
    call self_exchange_min(xch, dall, d, ierr)
    allocate(dser(1, 0:lat%nx - 1, 0:lat%ny - 1))
    dser = r
    call self_candidates(lat, allrows, xg, 0, lat%ny - 1, OWN_LOWEST, r, reach, pairs)
    call self_vertex_dmin(lat, allrows, xg, pairs, dser(1, :, :))
    call check_true(all(d(1, :, :) == dser(1, :, ys:ye)), trim(what)//': per-vertex distances = one rank''s')
    call check_true(any(d < r), trim(what)//': some vertices have a near pair')

    ! 2. swept candidates and the global alpha
    call self_exchange_free(xch)
    call self_exchange_plan_swept(xch, MPI_COMM_WORLD, lat%nx, lat%ny, ys, ye, xg(:, :, ys0:ye1), &
                                  dxg(:, :, ys0:ye1), cp%thickness, patch_rows, ierr)
    call self_exchange_rows(xch, rows)
    allocate(x6(6, 0:lat%nx - 1, ys:ye))
    x6(1:3, :, :) = xg(:, :, ys:ye)
    x6(4:6, :, :) = dxg(:, :, ys:ye)
    deallocate(xall)
    allocate(xall(6, 0:lat%nx - 1, size(rows)))
    call self_exchange_gather(xch, x6, xall, ierr)
    call self_candidates_swept(lat, rows, xall(1:3, :, :), xall(4:6, :, :), ys, ye, OWN_LOWEST, cp%thickness, reach, pairs)
    call pair_keys(lat, pairs, keys)
    alpha = self_alpha_ccd(lat, rows, xall(1:3, :, :), xall(4:6, :, :), pairs, cp%thickness, ACCD_S)
    call MPI_Allreduce(MPI_IN_PLACE, alpha, 1, MPI_DOUBLE_PRECISION, MPI_MIN, MPI_COMM_WORLD, ierr)
    call self_candidates_swept(lat, allrows, xg, dxg, 0, lat%ny - 1, OWN_LOWEST, cp%thickness, reach, pairs)
    call pair_keys(lat, pairs, kser)
    call check_true(same_set(keys, kser, what), trim(what)//': swept candidates on P ranks = on one')
    alpha_ser = self_alpha_ccd(lat, allrows, xg, dxg, pairs, cp%thickness, ACCD_S)
    call check_true(alpha == alpha_ser .and. alpha < 1.0_rp, trim(what)//': global alpha = one rank''s (< 1)')

    ! 5. the same plan again: nothing reallocated, the same rows
    call self_exchange_plan(xch, MPI_COMM_WORLD, lat%nx, lat%ny, ys, ye, xg(:, :, ys0:ye1), reach, patch_rows, ierr)
    call self_exchange_rows(xch, rows)
    deallocate(xall)
    allocate(xall(6, 0:lat%nx - 1, size(rows)))
    call self_exchange_gather(xch, x6, xall, ierr)
    n1 = self_exchange_regrown(xch)
    call self_exchange_plan(xch, MPI_COMM_WORLD, lat%nx, lat%ny, ys, ye, xg(:, :, ys0:ye1), reach, patch_rows, ierr)
    call self_exchange_gather(xch, x6, xall, ierr)
    call self_exchange_gather(xch, xg(:, :, ys:ye), xall(1:3, :, :), ierr)
    call self_exchange_rows(xch, rows2)
    call check_true(self_exchange_regrown(xch) == n1, trim(what)//': a plan made again reallocates nothing')
    call check_true(size(rows2) == size(rows) .and. all(rows2 == rows) .and. all(xall(1:3, :, :) == xg(:, :, rows)), &
                    trim(what)//': a plan made again fetches the same rows')
    call self_exchange_free(xch)
  end subroutine run_case

  !> Whether the union of every rank's keys equals ref, with no key on two ranks (rank 0
  !> compares; every rank gets the answer). Collective.
  logical function same_set(keys, ref, what) result(same)
    integer(int64), intent(in) :: keys(:), ref(:)
    character(*), intent(in) :: what
    integer :: n, counts(0:nranks - 1), displ(0:nranks - 1), q, ok
    integer(int64), allocatable :: got(:)

    n = size(keys)
    call MPI_Gather(n, 1, MPI_INTEGER, counts, 1, MPI_INTEGER, 0, MPI_COMM_WORLD, ierr)
    displ(0) = 0
    do q = 1, nranks - 1
      displ(q) = displ(q - 1) + counts(q - 1)
    end do
    if (rank == 0) then
      allocate(got(sum(counts)))
    else
      allocate(got(0))
    end if
    call MPI_Gatherv(keys, n, MPI_INTEGER8, got, counts, displ, MPI_INTEGER8, 0, MPI_COMM_WORLD, ierr)
    ok = 0
    if (rank == 0) then
      call sort_keys(got)
      if (size(got) == size(ref)) then
        if (all(got == ref)) ok = 1
      end if
      if (ok == 0) write(output_unit, '(a,i0,a,i0)') '  '//trim(what)//': pairs on P ranks ', size(got), &
                                                     ', on one ', size(ref)
    end if
    call MPI_Bcast(ok, 1, MPI_INTEGER, 0, MPI_COMM_WORLD, ierr)
    same = ok == 1 .and. size(ref) > 0
  end function same_set

end program test_self_exchange
