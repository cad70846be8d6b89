! SPDX-License-Identifier: BSD-2-Clause
!> Microbenchmark of the multigrid's finest-level kernels alone (module
!> mg_kernels): one symmetric Gauss-Seidel sweep (forward and backward,
!> with the kept sums over the rows below, as the cycle does) and the
!> mixed-precision product, on an N x N lattice with reach R (2: the
!> stencil of energy bending, 1: links only), random blocks; only the
!> offsets the cloth's elements couple (the finest level), or with a third
!> argument "square" the whole square of reach R (a coarse level: 65 x 65
!> at reach 4, 33 x 33 at reach 5 on hang 257 with bending). Prints the
!> best of 40 runs of each, its bytes a node as mg_describe counts them
!> and the rate they were read at, and the interpolation of a coarse
!> correction to the N x N level (bilinear and cubic: module stencil_mg's
!> interpolate, not added), and the Galerkin sums of the next coarser
!> level (galerkin_add, bilinear; its sums zeroed first, as
!> mg_build_coarse does). With a fourth argument "paired", the kernels take
!> the blocks to the rows below from the rows below (stencil_t's paired:
!> S without bending). Run: bash bench/mg_micro.sh [N] [R] [lines|square] [paired].
program mg_micro
  use kinds, only: rp
  use mg_kernels, only: mp, stencil_t, transfer_t, stencil_init, gs_sweep, stencil_product_mixed, transfer_init, interpolate, &
                        galerkin_add, coarse_reach
  implicit none
  type(stencil_t) :: st
  type(transfer_t) :: tl, tc
  real(mp), allocatable :: xc(:, :, :), tw(:, :)
  real(rp) :: til, tic, tga
  real(rp), allocatable :: ac(:, :, :, :, :, :), bx(:, :, :, :, :), rw(:, :, :, :)
  integer :: rc
  integer :: nc
  integer :: n, r, rep
  integer, parameter :: nrep = 40
  real(mp), allocatable :: x(:, :, :), rhs(:, :, :), t(:, :), low(:, :, :), ds(:, :)
  real(rp), allocatable :: xd(:, :, :), yd(:, :, :), xs(:, :, :), acc(:, :)
  integer(8) :: c0, c1, cr
  real(rp) :: tg, tp, bytes_sweep, bytes_prod
  character(len=32) :: arg
  logical :: lines
  n = 257
  r = 2
  if (command_argument_count() > 0) then
    call get_command_argument(1, arg)
    read(arg, *) n
  end if
  if (command_argument_count() > 1) then
    call get_command_argument(2, arg)
    read(arg, *) r
  end if
  lines = .true.
  if (command_argument_count() > 2) then
    call get_command_argument(3, arg)
    lines = trim(arg) /= 'square'
  end if
  call stencil_init(st, n, n, 0, n - 1, r, lines=lines)
  if (command_argument_count() > 3) then
    call get_command_argument(4, arg)
    st%paired = trim(arg) == 'paired'
  end if
  call random_number(st%b)
  call random_number(st%br)
  call random_number(st%d)
  call random_number(st%ainv)
  st%b = 0.01_mp * st%b
  st%br = 0.01_mp * st%br
  st%ainv = 0.1_mp * st%ainv
  allocate(x(-r:n - 1 + r, 3, -r:n - 1 + r), rhs(0:n - 1, 3, 0:n - 1), t(0:n - 1, 3), low(0:n - 1, 3, 0:n - 1))
  allocate(xd(3, 0:n - 1, 0:n - 1), yd(3, 0:n - 1, 0:n - 1), xs(-r:n - 1 + r, 3, 0:2 * r), acc(0:n - 1, 4), ds(0:n - 1, 3))
  x = 0.0_mp
  call random_number(rhs)
  call random_number(xd)
  call system_clock(count_rate=cr)
  tg = huge(1.0_rp)
  tp = huge(1.0_rp)
  do rep = 1, nrep
    call system_clock(c0)
    call gs_sweep(st, r, x, rhs, .true., t, low)
    call gs_sweep(st, r, x, rhs, .false., t, low)
    call system_clock(c1)
    tg = min(tg, real(c1 - c0, rp) / real(cr, rp))
    call system_clock(c0)
    call stencil_product_mixed(st, 0, n - 1, xd, yd, xs, acc, ds)
    call system_clock(c1)
    tp = min(tp, real(c1 - c0, rp) / real(cr, rp))
  end do
  ! the coarse correction interpolated (padding 3 rows and columns, as
  ! level 2 with cubic parents)
  nc = (n - 1) / 2 + 1
  call transfer_init(tl, n, .false.)
  call transfer_init(tc, n, .true.)
  allocate(xc(-3:nc + 2, 3, -3:nc + 2), tw(0:nc - 1, 3))
  call random_number(xc)
  til = huge(1.0_rp)
  tic = huge(1.0_rp)
  do rep = 1, nrep
    call system_clock(c0)
    call interpolate(tl, tl, 0, n - 1, 3, 0, xc, r, x, .false., tw)
    call system_clock(c1)
    til = min(til, real(c1 - c0, rp) / real(cr, rp))
    call system_clock(c0)
    call interpolate(tc, tc, 0, n - 1, 3, 0, xc, r, x, .false., tw)
    call system_clock(c1)
    tic = min(tic, real(c1 - c0, rp) / real(cr, rp))
  end do
  ! the Galerkin sums of the coarse level (its rows padded by 3, as
  ! mg_build_coarse's)
  rc = coarse_reach(tl, r)
  allocate(ac(0:nc - 1, 3, 3, -rc:rc, -rc:rc, -3:nc + 2), bx(0:nc - 1, 3, 3, -rc:rc, -r:r), rw(0:n - 1, 3, 3, 2))
  tga = huge(1.0_rp)
  do rep = 1, nrep / 4
    call system_clock(c0)
    ac = 0.0_rp
    call galerkin_add(st, tl, tl, rc, -3, ac, bx, rw)
    call system_clock(c1)
    tga = min(tga, real(c1 - c0, rp) / real(cr, rp))
  end do
  ! as mg_describe: each sweep the blocks, the inverse, rhs and x; the
  ! backward one not the blocks to the rows below but the kept sums
  bytes_sweep = 2.0_rp * (36.0_rp * (st%nb + 1) + 36.0_rp) - 36.0_rp * count(st%odj < 0) + 24.0_rp
  ! the blocks, the row sums, x and y in double precision
  bytes_prod = 36.0_rp * (st%nb + 1) + 48.0_rp
  print '(a, i0, a, i0, a, i0, a, i0, a)', 'lattice ', n, ' x ', n, ', reach ', r, ', ', st%nb, ' blocks a node'
  print '(a, f8.3, a, f6.0, a, f6.2, a)', 'symmetric sweep ', 1.0e3_rp * tg, ' ms, ', bytes_sweep, ' B a node, ', &
    bytes_sweep * n * n / tg / 1.0e9_rp, ' GB/s'
  print '(a, f8.3, a, f6.0, a, f6.2, a)', 'mixed product   ', 1.0e3_rp * tp, ' ms, ', bytes_prod, ' B a node, ', &
    bytes_prod * n * n / tp / 1.0e9_rp, ' GB/s'
  print '(a, f8.3, a, f8.3, a)', 'interpolation   ', 1.0e3_rp * til, ' ms bilinear, ', 1.0e3_rp * tic, ' ms cubic'
  print '(a, f8.3, a, i0, a)', 'Galerkin sums   ', 1.0e3_rp * tga, ' ms (bilinear, coarse reach ', rc, ')'
  ! (keeps the results live)
  if (.not. (sum(x) + sum(yd) + sum(ac) < huge(1.0_rp))) print '(a)', 'overflow'
end program mg_micro
