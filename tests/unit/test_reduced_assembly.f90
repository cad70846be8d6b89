! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the direct assembly of S = a M - C - K/a (module
!> reduced_assembly: assemble_csr, assemble_stencil, kc_products) against
!> the element-buffer path of module reduced_blocks (forces' scalar
!> element kernels into the rolling buffer, reduced_row_blocks,
!> buffer_row_apply), which sums the same element blocks in another order
!> with other kernels: S, the products g = -(K w_x + C w_v) and the
!> diagonals kd agree to round-off, for each bending model, with and
!> without damping, clamped compression and Gauss-Newton bending, on a
!> whole lattice and on strips with ghost rows on one or both sides, with
!> constrained nodes (their rows a m I, their columns empty), and a row
!> longer than the kernels' 32 lanes. Then: every CSR entry is written
!> (av, bv start as NaN), kc_products and assemble_stencil give the same
!> g and kd bit for bit (one element loop, the same lane kernels), and the
!> multigrid's finest level made on the way from a ring of rows equals the
!> one made from the whole strip.
program test_reduced_assembly
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE, BEND_PAPER, BEND_ENERGY, SPRING_AXIAL, SPRING_LINEAR, &
                    SCALING_ELEMENT, MASS_AREA
  use lattice, only: lattice_t, lattice_init, rest_position
  use forces, only: jac_buffer_t, jac_buffer_init, jac_buffer_row, slot_of, first_anchor_row
  use reduced_blocks, only: reduced_row_blocks, buffer_row_apply
  use reduced_assembly, only: assemble_csr, assemble_stencil, kc_products
  use csr_layout, only: csr_row_blocks
  use node_blocks, only: node_blocks_t, node_blocks_begin, node_blocks_add, node_blocks_add_pair, node_blocks_end
  use offset_product, only: offset_count, offset_slot
  use mg_kernels, only: stencil_t, stencil_init, stencil_row_from_full
  use check, only: check_true, check_report
  implicit none

  ! bending, spring model, damping, clamp, gauss_newton, nx, ny, ys, ye
  call one(BEND_NONE, SPRING_AXIAL, .true., .false., .false., 37, 9, 0, 8, 'no bending, whole lattice')
  call one(BEND_NONE, SPRING_LINEAR, .true., .false., .false., 7, 10, 3, 6, 'no bending, linear springs, middle strip')
  call one(BEND_NONE, SPRING_AXIAL, .false., .true., .false., 9, 8, 0, 3, 'no bending, undamped, clamped, first strip')
  call one(BEND_PAPER, SPRING_AXIAL, .true., .false., .false., 37, 9, 0, 8, 'paper bending, whole lattice')
  call one(BEND_PAPER, SPRING_AXIAL, .true., .false., .false., 8, 11, 4, 7, 'paper bending, middle strip')
  call one(BEND_ENERGY, SPRING_AXIAL, .true., .false., .false., 37, 9, 0, 8, 'energy bending, whole lattice')
  call one(BEND_ENERGY, SPRING_AXIAL, .true., .false., .false., 9, 12, 4, 7, 'energy bending, middle strip')
  call one(BEND_ENERGY, SPRING_AXIAL, .true., .true., .true., 35, 10, 6, 9, 'energy bending, Gauss-Newton, clamped, last strip')
  call one(BEND_ENERGY, SPRING_AXIAL, .false., .false., .false., 6, 9, 2, 5, 'energy bending, undamped, middle strip')
  ! forces on single nodes (contact's blocks, module node_blocks) on the diagonal
  call one(BEND_NONE, SPRING_AXIAL, .true., .false., .false., 37, 9, 0, 8, 'no bending, node blocks, whole lattice', &
           nodal=.true.)
  call one(BEND_ENERGY, SPRING_AXIAL, .true., .false., .false., 9, 12, 4, 7, 'energy bending, node blocks, middle strip', &
           nodal=.true.)
  call check_report()

contains

  subroutine one(bending, spring, damping, clamp, gauss_newton, nx, ny, ys, ye, what, nodal)
    integer, intent(in) :: bending, spring, nx, ny, ys, ye
    logical, intent(in) :: damping, clamp, gauss_newton
    character(*), intent(in) :: what
    logical, intent(in), optional :: nodal
    real(rp), parameter :: a = 40.0_rp               ! TS shift [1/s]
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    type(node_blocks_t) :: nb
    type(jac_buffer_t) :: buf
    type(stencil_t) :: fine, fine_ref
    real(rp), allocatable :: u(:, :, :), w(:, :, :), noise(:, :, :), lb(:, :, :, :, :)
    real(rp), allocatable :: sref(:, :, :, :, :, :), gref(:, :, :), kdref(:, :, :)
    real(rp), allocatable :: g(:, :, :), kd(:, :, :), g2(:, :, :), kd2(:, :, :), g3(:, :, :), kd3(:, :, :)
    real(rp), allocatable :: st(:, :, :, :, :), ring(:, :, :, :, :), av(:), bv(:), blk(:, :, :, :)
    real(rp) :: vals(3, 3, 25), scale, gscale, err_st, err_csr, err_g, err_kd, bx(3, 3), bv3(3, 3)
    integer, allocatable :: ia(:), ib(:)
    integer :: cols(25), nc, i, j, ja, n, q, iq, jq, di, dj, hw, k, nd, no, row, lag
    logical, allocatable :: fixedg(:, :)

    cfg%lattice%nx = nx
    cfg%lattice%ny = ny
    cfg%lattice%lx = 1.0_rp
    cfg%lattice%ly = 1.2_rp
    cfg%lattice%ax = cfg%lattice%lx / (nx - 1)
    cfg%lattice%ay = cfg%lattice%ly / (ny - 1)
    cfg%lattice%total_mass = 0.1_rp
    cfg%material%e_s = 100.0_rp
    cfg%material%eta_s = 0.1_rp
    cfg%material%e_d = 70.0_rp
    cfg%material%eta_d = 0.05_rp
    cfg%material%k_b = 0.1_rp
    cfg%material%eta_b = 1.0e-3_rp
    cfg%material%spring_code = spring
    cfg%material%bending_code = bending
    cfg%lattice%scaling_code = SCALING_ELEMENT
    cfg%lattice%mass_code = MASS_AREA
    call lattice_init(lat, cfg, ys, ye)
    hw = lat%halo

    ! A crumpled, moving state: rest positions moved by up to 0.3 spacings
    ! in every direction (links stretched and compressed), random velocities.
    allocate(u(0:5, 0:nx - 1, lat%gys:lat%gye), w(0:5, 0:nx - 1, lat%gys:lat%gye), noise(0:5, 0:nx - 1, lat%gys:lat%gye))
    call random_number(noise)
    do j = lat%gys, lat%gye
      do i = 0, nx - 1
        u(0:2, i, j) = rest_position(lat, i, j) + 0.6_rp * cfg%lattice%ax * (noise(0:2, i, j) - 0.5_rp)
        u(3:5, i, j) = noise(3:5, i, j) - 0.5_rp
      end do
    end do
    call random_number(w)
    w = w - 0.5_rp
    ! constrained nodes: a corner, a run inside one 32-lane block, a node of a ghost row
    allocate(fixedg(0:nx - 1, lat%gys:lat%gye))
    fixedg = .false.
    fixedg(0, lat%gys) = .true.
    fixedg(2:4, (lat%ys + lat%ye) / 2) = .true.
    fixedg(nx - 1, lat%gye) = .true.
    do j = lat%gys, lat%gye
      do i = 0, nx - 1
        if (fixedg(i, j)) w(3:5, i, j) = 0.5_rp   ! a prescribed velocity change, as reduced's right-hand side
      end do
    end do

    ! Random blocks on every third free owned node of each row (the list by row).
    ! (about 110 on the whole lattice: the list grows past its first 64)
    call node_blocks_begin(nb, ys, ye)
    if (present(nodal)) then
      do j = ys, ye
        do i = mod(j, 3), nx - 1, 3
          if (fixedg(i, j)) cycle
          call random_number(bx)
          call random_number(bv3)
          call node_blocks_add(nb, i, j, -50.0_rp * bx, -0.2_rp * bv3)
          ! and blocks to two stencil neighbours (a quad's contact, module
          ! face_contact): across the row above and below (ghost rows at the
          ! strip's ends), to a constrained node where one is near
          do k = -1, 1, 2
            if (i + k < 0 .or. i + k > nx - 1 .or. j + k < 0 .or. j + k > ny - 1) cycle
            call random_number(bx)
            call random_number(bv3)
            call node_blocks_add_pair(nb, i, j, k, k, -30.0_rp * bx, -0.1_rp * bv3)
          end do
        end do
      end do
    end if
    call node_blocks_end(nb)

    ! The reference: the element buffer, as module reduced's third storage path.
    allocate(sref(3, 3, -hw:hw, -hw:hw, 0:nx - 1, ys:ye), gref(3, 0:nx - 1, ys:ye), kdref(3, 0:nx - 1, ys:ye))
    sref = 0.0_rp
    call jac_buffer_init(buf, lat)
    do ja = first_anchor_row(lat), ye
      call jac_buffer_row(buf, lat, nb, u, ja, clamp, gauss_newton)
      if (ja >= ys) then
        call buffer_row_apply(buf, lat, w, ja, damping, gref(:, :, ja))
        do i = 0, nx - 1
          do q = 1, 3
            kdref(q, i, ja) = buf%k(q, q, 0, 0, i, slot_of(ja))
          end do
          call reduced_row_blocks(buf, lat, fixedg, i, ja, a, damping, vals, cols, nc)
          do n = 1, nc
            iq = mod(cols(n), nx)
            jq = cols(n) / nx + lat%gys
            sref(:, :, iq - i, jq - ja, i, ja) = vals(:, :, n)
          end do
        end do
      end if
      ! row ja is complete: its slot takes row ja + 3
      buf%k(:, :, :, :, :, slot_of(ja)) = 0.0_rp
      buf%c(:, :, :, :, :, slot_of(ja)) = 0.0_rp
    end do
    scale = maxval(abs(sref))
    gscale = maxval(abs(gref))

    ! kc_products: S not written.
    allocate(g(3, 0:nx - 1, ys:ye), kd(3, 0:nx - 1, ys:ye), g2(3, 0:nx - 1, ys:ye), kd2(3, 0:nx - 1, ys:ye))
    allocate(g3(3, 0:nx - 1, ys:ye), kd3(3, 0:nx - 1, ys:ye))
    allocate(lb(0:nx - 1, 3, 3, 4, 0:1))
    call kc_products(lat, nb, u, fixedg, damping, clamp, gauss_newton, w, lb, g, kd)
    err_g = maxval(abs(g - gref))
    err_kd = maxval(abs(kd - kdref))
    call check_true(err_g <= 1.0e-12_rp * gscale .and. gscale > 0.0_rp, what//': kc_products g = -(K w_x + C w_v) as the buffer''s')
    call check_true(err_kd <= 1.0e-12_rp * maxval(abs(kdref)), what//': kc_products kd as the buffer''s diagonal')
    if (err_g > 1.0e-12_rp * gscale) write(*, '(a,2es11.3)') '  |g - gref|, scale: ', err_g, gscale

    ! assemble_stencil over the whole strip (and the finest level fine_ref made on the way).
    allocate(st(0:nx - 1, 3, 3, offset_count(hw), 0:ye - ys))
    st = ieee_value(1.0_rp, ieee_quiet_nan)
    call stencil_init(fine_ref, nx, ny, ys, ye, hw, lines=.true.)
    call assemble_stencil(lat, nb, u, fixedg, a, damping, clamp, gauss_newton, w, lb, g2, kd2, st, fine_ref)
    call check_true(all(st == st), what//': assemble_stencil writes every slot')
    err_st = 0.0_rp
    do j = ys, ye
      do i = 0, nx - 1
        do dj = -hw, hw
          do di = -hw, hw
            k = offset_slot(hw, di, dj)
            if (k == 0) then
              err_st = max(err_st, maxval(abs(sref(:, :, di, dj, i, j))))   ! the elements never couple it
            else if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) then
              err_st = max(err_st, maxval(abs(st(i, :, :, k, j - ys))))    ! zero outside the lattice
            else
              err_st = max(err_st, maxval(abs(st(i, :, :, k, j - ys) - sref(:, :, di, dj, i, j))))
            end if
          end do
        end do
      end do
    end do
    call check_true(err_st <= 1.0e-12_rp * scale, what//': assemble_stencil S as the buffer''s')
    if (err_st > 1.0e-12_rp * scale) write(*, '(a,2es11.3)') '  |S_st - Sref|, scale: ', err_st, scale
    call check_true(all(g2 == g) .and. all(kd2 == kd), what//': assemble_stencil g, kd bitwise as kc_products''')

    ! assemble_stencil on a ring of rows, the finest level made on the way,
    ! against that level made from the whole strip row by row.
    lag = merge(0, 2, bending == BEND_NONE)
    allocate(ring(0:nx - 1, 3, 3, offset_count(hw), 0:lag))
    call stencil_init(fine, nx, ny, ys, ye, hw, lines=.true.)
    call assemble_stencil(lat, nb, u, fixedg, a, damping, clamp, gauss_newton, w, lb, g3, kd3, ring, fine)
    do j = ys, ye
      call stencil_row_from_full(fine_ref, st(:, :, :, :, j - ys), j)
    end do
    call check_true(all(fine%b == fine_ref%b) .and. all(fine%br == fine_ref%br) .and. all(fine%d == fine_ref%d), &
                    what//': the finest level from a ring of rows as from the whole strip')
    call check_true(all(g3 == g) .and. all(kd3 == kd), what//': assemble_stencil (ring) g, kd bitwise as kc_products''')

    ! assemble_csr into the layout of module csr_layout's header.
    allocate(ia(0:3 * nx * (ye - ys + 1)), ib(0:3 * nx * (ye - ys + 1)))
    ia(0) = 0
    ib(0) = 0
    do j = ys, ye
      do i = 0, nx - 1
        nd = 0
        no = 0
        do dj = max(-hw, -j), min(hw, ny - 1 - j)
          n = min(hw, nx - 1 - i) - max(-hw, -i) + 1
          if (j + dj >= ys .and. j + dj <= ye) then
            nd = nd + n
          else
            no = no + n
          end if
        end do
        do q = 0, 2
          row = 3 * (i + (j - ys) * nx) + q
          ia(row + 1) = ia(row) + 3 * nd
          ib(row + 1) = ib(row) + 3 * no
        end do
      end do
    end do
    allocate(av(0:ia(3 * nx * (ye - ys + 1)) - 1), bv(0:ib(3 * nx * (ye - ys + 1)) - 1))
    av = ieee_value(1.0_rp, ieee_quiet_nan)
    bv = av(0)
    call assemble_csr(lat, nb, u, fixedg, a, damping, clamp, gauss_newton, w, lb, g3, kd3, ia, av, ib, bv)
    call check_true(all(av == av) .and. all(bv == bv), what//': assemble_csr writes every stored entry')
    allocate(blk(3, 3, -hw:hw, -hw:hw))
    err_csr = 0.0_rp
    do j = ys, ye
      do i = 0, nx - 1
        call csr_row_blocks(lat, ia, av, ib, bv, i, j, blk)
        err_csr = max(err_csr, maxval(abs(blk - sref(:, :, :, :, i, j))))
      end do
    end do
    call check_true(err_csr <= 1.0e-12_rp * scale, what//': assemble_csr S as the buffer''s')
    if (err_csr > 1.0e-12_rp * scale) write(*, '(a,2es11.3)') '  |S_csr - Sref|, scale: ', err_csr, scale
    ! (energy triples go into the AIJ S one at a time, their products in
    ! another order than the lanes': equal to round-off only)
    call check_true(maxval(abs(g3 - gref)) <= 1.0e-12_rp * gscale .and. maxval(abs(kd3 - kdref)) <= 1.0e-12_rp * maxval(abs(kdref)), &
                    what//': assemble_csr g, kd as the buffer''s')
  end subroutine one

end program test_reduced_assembly
