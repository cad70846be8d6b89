! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of self-contact's pair barrier (module self_barrier): for
!> random point-triangle pairs, skew edge-edge pairs and nearly parallel
!> (mollified) edge pairs with gaps inside dhat, the forces on the 4 nodes
!> against central differences of the energy, the blocks against central
!> differences of the forces, the exact blocks' symmetry, zero net force and
!> zero block row sums (the force depends on differences of positions), the
!> projected blocks' -K positive semidefinite; no energy beyond dhat, huge at
!> gap 0; and on a folded sheet the strip routine (broad phase, forces added
!> to the rows, the list of pair blocks by global node) against differences
!> of its total energy and of its forces, on the dense 3N x 3N matrix.
program test_self_barrier
  use kinds, only: rp
  use contact, only: contact_params_t
  use contact_primitives, only: psd_project
  use contact_faces, only: SPLIT_ANTI
  use self_broad, only: self_lattice_t, self_pairs_t, self_candidates, PAIR_PT, PAIR_EE, OWN_LOWEST
  use self_barrier, only: self_blocks_t, self_pair_barrier, self_barrier_forces, self_pair_gap
  use self_shapes, only: fold_shape
  use check, only: check_true, check_close_array, check_report, seed_random
  implicit none
  type(contact_params_t) :: cp
  real(rp), parameter :: A = 0.01_rp             ! lattice spacing of the rest positions
  integer :: k, nfd(3)

  call seed_random(4902)
  cp = contact_params_t(thickness=0.001_rp, dhat=0.002_rp, kappa=50.0_rp)
  nfd = 0
  do k = 1, 30
    call pair_case(1, nfd(1))
    call pair_case(2, nfd(2))
    call pair_case(3, nfd(3))
  end do
  write(*, '(a,3i4)') 'pairs checked (point-triangle, edge-edge, mollified edge-edge):', nfd
  call check_true(all(nfd >= 10), 'enough random pairs in the barrier band of each kind')
  call limits()
  call strip_case()
  call check_report()

contains

  !> A random pair of kind 1 (point-triangle), 2 (skew edges) or 3 (nearly parallel edges)
  !> with gap in (0.1, 0.9) dhat, checked against differences when it falls there.
  subroutine pair_case(kind3, n)
    integer, intent(in) :: kind3
    integer, intent(inout) :: n
    real(rp) :: x(3, 4), xr(3, 4), u(3, 4), gap, e, f(3, 4), kx(3, 3, 4, 4), m(12, 12), mp(12, 12), ang
    integer :: kind
    logical :: active
    character(len=24) :: what

    call random_number(u)
    xr = reshape([0.0_rp, 0.0_rp, 0.0_rp, A, 0.0_rp, 0.0_rp, 0.0_rp, A, 0.0_rp, A, A, 0.0_rp], [3, 4])
    select case (kind3)
    case (1)
      kind = PAIR_PT
      what = 'point-triangle'
      x(:, 2) = [0.0_rp, 0.0_rp, 0.0_rp]
      x(:, 3) = [A, 0.0_rp, 0.0_rp] + 0.3_rp * A * (u(:, 3) - 0.5_rp)
      x(:, 4) = [0.0_rp, A, 0.0_rp] + 0.3_rp * A * (u(:, 4) - 0.5_rp)
      x(:, 1) = [1.2_rp * A * u(1, 1) - 0.1_rp * A, 1.2_rp * A * u(2, 1) - 0.1_rp * A, &
                 cp%thickness + 1.2_rp * cp%dhat * u(3, 1)]
    case (2)
      kind = PAIR_EE
      what = 'edge-edge'
      x(:, 1) = [0.0_rp, 0.0_rp, 0.0_rp] + 0.2_rp * A * (u(:, 1) - 0.5_rp)
      x(:, 2) = [A, 0.0_rp, 0.0_rp]
      x(:, 3) = [0.5_rp * A, -0.5_rp * A, cp%thickness + 1.2_rp * cp%dhat * u(3, 3)]
      x(:, 4) = x(:, 3) + [0.3_rp * A * (u(1, 4) - 0.5_rp), A, 0.2_rp * A * (u(3, 4) - 0.5_rp)]
    case default
      kind = PAIR_EE
      what = 'mollified edge-edge'
      ang = 0.02_rp * (u(1, 1) - 0.5_rp)        ! |a x b|^2 / (|a|^2 |b|^2) < 1e-4 < 1e-3: mollified
      x(:, 1) = [0.0_rp, 0.0_rp, 0.0_rp]
      x(:, 2) = [A, 0.0_rp, 0.0_rp]
      x(:, 3) = [0.3_rp * A * u(1, 2), 0.0_rp, cp%thickness + 1.2_rp * cp%dhat * u(3, 3)]
      x(:, 4) = x(:, 3) + A * [cos(ang), 0.0_rp, sin(ang)]
      x(2, 3:4) = x(2, 3:4) + 0.2_rp * A * (u(2, 4) - 0.5_rp)
    end select
    gap = self_pair_gap(kind, x, cp%thickness)
    if (gap < 0.1_rp * cp%dhat .or. gap > 0.9_rp * cp%dhat) return
    n = n + 1
    call self_pair_barrier(kind, x, xr, cp, .false., e, f, kx, active)
    call check_true(active .and. e > 0.0_rp, trim(what)//': active, positive energy')
    call check_close_array(reshape(f, [12]), reshape(fd_force(kind, x, xr), [12]), 1.0e-5_rp, 0.0_rp, &
                           trim(what)//': forces = -dE/dx')
    call check_close_array(reshape(kx, [144]), reshape(fd_blocks(kind, x, xr), [144]), 1.0e-5_rp, 0.0_rp, &
                           trim(what)//': blocks = df/dx')
    m = dense(kx)
    call check_close_array(reshape(m, [144]), reshape(transpose(m), [144]), 1.0e-12_rp, 0.0_rp, &
                           trim(what)//': exact blocks symmetric')
    call check_close_array(sum(f, dim=2), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-12_rp * maxval(abs(f)), &
                           trim(what)//': no net force')
    call check_close_array(reshape(sum(kx, dim=4), [36]), [(0.0_rp, k = 1, 36)], 0.0_rp, &
                           1.0e-10_rp * maxval(abs(kx)), trim(what)//': block rows sum to zero')
    call self_pair_barrier(kind, x, xr, cp, .true., e, f, kx, active)
    m = -dense(kx)
    mp = m
    call psd_project(mp)
    call check_close_array(reshape(mp, [144]), reshape(m, [144]), 1.0e-8_rp, 0.0_rp, &
                           trim(what)//': projected -K is positive semidefinite')
  end subroutine pair_case

  !> No energy beyond dhat; huge energy at gap <= 0.
  subroutine limits()
    real(rp) :: x(3, 4), e, f(3, 4), kx(3, 3, 4, 4)
    logical :: active

    x = reshape([0.2_rp * A, 0.2_rp * A, cp%thickness + 1.01_rp * cp%dhat, 0.0_rp, 0.0_rp, 0.0_rp, &
                 A, 0.0_rp, 0.0_rp, 0.0_rp, A, 0.0_rp], [3, 4])
    call self_pair_barrier(PAIR_PT, x, x, cp, .false., e, f, kx, active)
    call check_true(.not. active .and. e == 0.0_rp .and. all(f == 0.0_rp), 'beyond dhat: no energy, no force')
    x(3, 1) = 0.999_rp * cp%thickness
    call self_pair_barrier(PAIR_PT, x, x, cp, .false., e, f, kx, active)
    call check_true(active .and. e >= huge(1.0_rp), 'gap <= 0: energy huge (the state is refused)')
  end subroutine limits

  function fd_force(kind, x, xr) result(fd)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(3, 4), xr(3, 4)
    real(rp) :: fd(3, 4), y(3, 4), ep, em, f(3, 4), kx(3, 3, 4, 4), h
    logical :: active
    integer :: a, c
    h = 1.0e-8_rp
    do a = 1, 4
      do c = 1, 3
        y = x
        y(c, a) = x(c, a) + h
        call self_pair_barrier(kind, y, xr, cp, .false., ep, f, kx, active)
        y(c, a) = x(c, a) - h
        call self_pair_barrier(kind, y, xr, cp, .false., em, f, kx, active)
        fd(c, a) = -(ep - em) / (2.0_rp * h)
      end do
    end do
  end function fd_force

  function fd_blocks(kind, x, xr) result(fd)
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(3, 4), xr(3, 4)
    real(rp) :: fd(3, 3, 4, 4), y(3, 4), e, fp(3, 4), fm(3, 4), kx(3, 3, 4, 4), h
    logical :: active
    integer :: b, c
    h = 1.0e-9_rp
    do b = 1, 4
      do c = 1, 3
        y = x
        y(c, b) = x(c, b) + h
        call self_pair_barrier(kind, y, xr, cp, .false., e, fp, kx, active)
        y(c, b) = x(c, b) - h
        call self_pair_barrier(kind, y, xr, cp, .false., e, fm, kx, active)
        fd(:, c, :, b) = (fp - fm) / (2.0_rp * h)
      end do
    end do
  end function fd_blocks

  pure function dense(kx) result(m)
    real(rp), intent(in) :: kx(3, 3, 4, 4)
    real(rp) :: m(12, 12)
    integer :: a, b
    do b = 1, 4
      do a = 1, 4
        m(3 * a - 2:3 * a, 3 * b - 2:3 * b) = kx(:, :, a, b)
      end do
    end do
  end function dense

  !> The strip routine on a folded sheet: its energy, forces and pair blocks.
  subroutine strip_case()
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    type(self_blocks_t) :: blocks
    real(rp), allocatable :: x(:, :, :), f(:, :, :), y(:, :, :), fp(:, :, :), fm(:, :, :), kd(:, :), kfd(:, :)
    integer, allocatable :: rows(:)
    real(rp) :: e, ep, em, h, fe(3)
    integer :: j, nact, n, m, c, i, ia, ib, nn

    lat = self_lattice_t(nx=5, ny=10, split=SPLIT_ANTI, ax=A, ay=A)
    nn = lat%nx * lat%ny
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1))
    call fold_shape(lat, 5, cp%thickness + 0.6_rp * cp%dhat, x)
    rows = [(j, j = 0, lat%ny - 1)]
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, cp%dhat + cp%thickness, cp%dhat + cp%thickness, pairs)
    allocate(f, fp, fm, y, mold=x)
    f = 0.0_rp
    call self_barrier_forces(lat, rows, x, pairs, 0, lat%ny - 1, cp, .false., e, f, blocks, nact)
    write(*, '(a,i0,a,i0,a)') 'folded sheet: ', pairs%n, ' candidate pairs, ', nact, ' active'
    call check_true(nact > 10 .and. e > 0.0_rp .and. e < huge(1.0_rp), 'folded sheet: active pairs, finite energy')
    call check_true(blocks%n == 16 * nact, 'folded sheet: 16 blocks an active pair')
    call check_close_array(sum(sum(f, dim=3), dim=2), [0.0_rp, 0.0_rp, 0.0_rp], 0.0_rp, 1.0e-10_rp * maxval(abs(f)), &
                           'folded sheet: no net force')
    ! Dense K from the pair blocks, and its columns by central differences of the forces.
    allocate(kd(3 * nn, 3 * nn), kfd(3 * nn, 3 * nn))
    kd = 0.0_rp
    do m = 1, blocks%n
      ia = blocks%a(m)
      ib = blocks%b(m)
      kd(3 * ia + 1:3 * ia + 3, 3 * ib + 1:3 * ib + 3) = kd(3 * ia + 1:3 * ia + 3, 3 * ib + 1:3 * ib + 3) + blocks%k(:, :, m)
    end do
    h = 1.0e-9_rp
    n = 0
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        do c = 1, 3
          y = x
          y(c, i, j) = x(c, i, j) + h
          fp = 0.0_rp
          call self_barrier_forces(lat, rows, y, pairs, 0, lat%ny - 1, cp, .false., ep, fp, blocks, nact)
          y(c, i, j) = x(c, i, j) - h
          fm = 0.0_rp
          call self_barrier_forces(lat, rows, y, pairs, 0, lat%ny - 1, cp, .false., em, fm, blocks, nact)
          kfd(:, 3 * (i + lat%nx * j) + c) = reshape((fp - fm) / (2.0_rp * h), [3 * nn])
          fe(c) = -(ep - em) / (2.0_rp * h)
        end do
        if (any(abs(f(:, i, j)) > 0.0_rp)) then
          n = n + 1
          call check_close_array(fe, f(:, i, j), 1.0e-5_rp, 1.0e-6_rp * maxval(abs(f)), 'folded sheet: node force = -dE/dx')
        end if
      end do
    end do
    call check_true(n > 10, 'folded sheet: forces on many nodes')
    call check_close_array(reshape(kd, [9 * nn * nn]), reshape(kfd, [9 * nn * nn]), 1.0e-5_rp, 0.0_rp, &
                           'folded sheet: pair blocks = df/dx (dense)')
  end subroutine strip_case

end program test_self_barrier
