! SPDX-License-Identifier: BSD-2-Clause
!> The self-contact model's pair blocks in S's product (issue 49; module
!> process_models' pm_list_pair_product and pm_list_pair_rhs, module
!> self_contact's jacobian, pair_rows and pair_gather hooks): on a sheet
!> folded over itself (rows 0..20 below, 21..39 above, 1.2 mm apart: the
!> layers on different ranks on 3), the pair part of S x on each rank's
!> owned rows equals the sum over the pairs' blocks -K_ab x_b / a formed
!> on the whole lattice on one rank, with every row present (the broad
!> phase and the barrier of the kernels, no exchange): the distributed
!> candidates, the gather of x's rows by the list's plan and the blocks'
!> rows and columns must all be right for the two to agree. The right-hand
!> side's products -(K_ab w_x,b + C_ab w_v,b) likewise. Run on 1 and 3 ranks.
program test_self_pairs
  use mpi
  use kinds, only: rp
  use config, only: nuno_config
  use input, only: input_parse
  use lattice, only: lattice_t, lattice_init
  use constraints, only: constraint_set_t
  use contact, only: contact_params_t
  use contact_faces, only: SPLIT_MAIN
  use self_broad, only: self_lattice_t, self_pairs_t, self_candidates, OWN_TOUCH
  use self_barrier, only: self_blocks_t, self_barrier_forces
  use self_contact, only: self_contact_model_t
  use process_model, only: process_model_t
  use process_models, only: pm_list_t, pm_list_add, pm_list_setup, pm_list_jacobian, pm_list_pair_product, &
                            pm_list_pair_rhs, pm_list_pairs_on
  use self_shapes, only: fold_shape
  use check, only: check_true, check_close_array, check_report
  implicit none
  character(len=*), parameter :: TEXT = &
    "&scene scene='flat' / &lattice nx=12 ny=40 lx=0.11 ly=0.39 total_mass=0.1 / " // &
    "&contact contact_dhat=2.0e-3 contact_thickness=0.5e-3 self_contact=.true. / &time t_end=0.01 dt=1.0e-3 / " // &
    "&output output_file='self_pairs.h5' /"
  real(rp), parameter :: A = 1000.0_rp     ! the shift [1/s]
  type(nuno_config) :: cfg
  type(lattice_t) :: lat
  type(constraint_set_t) :: cs
  type(self_lattice_t) :: sl
  type(contact_params_t) :: cp
  type(self_pairs_t) :: pairs
  type(self_blocks_t) :: blocks
  type(pm_list_t) :: list
  class(process_model_t), allocatable :: pm
  real(rp), allocatable :: xg(:, :, :), vg(:, :, :), u(:, :, :), f(:, :, :), expect(:, :, :), x(:, :, :), y(:, :, :)
  real(rp), allocatable :: w(:, :, :), g(:, :, :), gexp(:, :, :)
  logical, allocatable :: fixed(:, :)
  integer, allocatable :: rows(:)
  character(len=512) :: errmsg
  integer :: rank, nranks, mpierr, err, ys, ye, nx, ny, i, j, m, nact, nspan, gspan
  logical :: two
  real(rp) :: e

  call MPI_Init(mpierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, mpierr)
  call MPI_Comm_size(MPI_COMM_WORLD, nranks, mpierr)
  call input_parse(TEXT, cfg, err, errmsg)
  call check_true(err == 0, 'the namelist: '//trim(errmsg))
  nx = cfg%lattice%nx
  ny = cfg%lattice%ny
  ys = rank * ny / nranks
  ye = (rank + 1) * ny / nranks - 1
  call lattice_init(lat, cfg, ys, ye)
  sl = self_lattice_t(nx=nx, ny=ny, split=SPLIT_MAIN, ax=lat%ax, ay=lat%ay)
  cp = contact_params_t(thickness=2.0_rp * cfg%contact%thickness, dhat=cfg%contact%dhat, &
                        kappa=cfg%contact%stiffness, eps_v=cfg%contact%eps_v)
  allocate(xg(3, 0:nx - 1, 0:ny - 1), vg(3, 0:nx - 1, 0:ny - 1))
  call fold_shape(sl, 20, cp%thickness + 0.6_rp * cp%dhat, xg)
  do j = 0, ny - 1
    do i = 0, nx - 1
      vg(:, i, j) = [sin(0.3_rp * i + 0.7_rp * j), cos(0.5_rp * i - 0.2_rp * j), sin(0.11_rp * i * j + 0.4_rp)]
    end do
  end do

  ! the model on this rank's strip, its Jacobian at the folded state
  allocate(u(0:5, 0:nx - 1, lat%gys:lat%gye), fixed(0:nx - 1, ys:ye))
  u(0:2, :, :) = xg(:, :, lat%gys:lat%gye)
  u(3:5, :, :) = 0.0_rp
  fixed = .false.
  allocate(self_contact_model_t :: pm)
  call pm_list_add(list, pm)
  call pm_list_setup(list, cfg, lat, MPI_COMM_WORLD, u, cs, err, errmsg)
  call check_true(err == 0, 'set-up: '//trim(errmsg))
  call pm_list_jacobian(list, lat, fixed, 0.0_rp, u, MPI_COMM_WORLD, two)
  call check_true(.not. two .and. pm_list_pairs_on(list), 'one model gave pair blocks')
  allocate(x(3, 0:nx - 1, ys:ye), y(3, 0:nx - 1, ys:ye))
  x = vg(:, :, ys:ye)
  y = 0.0_rp
  call pm_list_pair_product(list, lat, MPI_COMM_WORLD, A, x, y, err)
  call check_true(err == 0, 'the product gathered its rows')
  allocate(w(0:5, 0:nx - 1, ys:ye), g(3, 0:nx - 1, ys:ye))
  w(0:2, :, :) = vg(:, :, ys:ye)
  w(3:5, :, :) = 2.0_rp * vg(:, :, ys:ye)
  g = 0.0_rp
  call pm_list_pair_rhs(list, lat, MPI_COMM_WORLD, w, g, err)
  call check_true(err == 0, 'the right-hand side gathered its rows')

  ! the expectation: the whole lattice on this rank, every row present
  rows = [(j, j = 0, ny - 1)]
  call self_candidates(sl, rows, xg, 0, ny - 1, OWN_TOUCH, 2.0_rp * (cp%dhat + cp%thickness), cp%dhat + cp%thickness, &
                       pairs)
  allocate(f(3, 0:nx - 1, 0:ny - 1), expect(3, 0:nx - 1, 0:ny - 1), gexp(3, 0:nx - 1, 0:ny - 1))
  f = 0.0_rp
  call self_barrier_forces(sl, rows, xg, pairs, 0, ny - 1, cp, .true., e, f, blocks, nact)
  expect = 0.0_rp
  nspan = 0
  do m = 1, blocks%n
    if (blocks%a(m) == blocks%b(m)) cycle
    associate (ia => mod(blocks%a(m), nx), ja => blocks%a(m) / nx, ib => mod(blocks%b(m), nx), jb => blocks%b(m) / nx)
      expect(:, ia, ja) = expect(:, ia, ja) - matmul(blocks%k(:, :, m), vg(:, ib, jb)) / A
      if (ja >= ys .and. ja <= ye .and. (jb < ys .or. jb > ye)) nspan = nspan + 1
    end associate
  end do
  ! frictionless: C_ab = 0, so the right-hand side's part is a K_ab's
  gexp = A * expect
  call MPI_Allreduce(nspan, gspan, 1, MPI_INTEGER, MPI_SUM, MPI_COMM_WORLD, mpierr)
  call check_true(nact > 100, 'the fold has active pairs')
  if (nranks > 1) call check_true(gspan > 100, 'blocks to nodes of other ranks')
  call check_true(maxval(abs(expect(:, :, ys:ye))) > 0.0_rp .or. (ye < 12 .or. ys > 28), 'the owned rows have blocks')
  call check_close_array(reshape(y, [size(y)]), reshape(expect(:, :, ys:ye), [size(y)]), 1.0e-12_rp, &
                         1.0e-12_rp * maxval(abs(expect)), 'S x: the pair part equals the one-rank sum of the blocks')
  call check_close_array(reshape(g, [size(g)]), reshape(gexp(:, :, ys:ye), [size(g)]), 1.0e-12_rp, &
                         1.0e-12_rp * maxval(abs(gexp)), 'the right-hand side''s pair products, the same')
  call check_report()
  call MPI_Finalize(mpierr)
end program test_self_pairs
