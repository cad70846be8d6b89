! SPDX-License-Identifier: BSD-2-Clause
!> Direct assembly of the reduced matrix S = a M - C - K/a, element by
!> element (no PETSc, no MPI), through three entry points over one pass
!> over the rows (assemble_rows, its mode an argument: S_CSR, S_STENCIL,
!> S_NONE): assemble_csr into the CSR arrays of an AIJ matrix,
!> assemble_stencil by stencil offset and the multigrid's finest level
!> from it, kc_products S not written, only the element products
!> g = -(K w_x + C w_v) and the diagonal kd that the other two also give.
!>
!> Each link's 3 x 3 block B = (c + k/a) belongs to four places of S (two
!> diagonal blocks with one sign, the two coupling blocks with the other):
!> the blocks of the links of two anchor rows are kept, and every node row
!> is then gathered from them and written once, whole, in the CSR order.
!> Each bending triple then adds its nine 3 x 3 blocks at positions
!> computed from the stencil (csr_block_pos). This replaces
!> the rolling block buffer of module forces, which is zeroed, summed per
!> row and copied once more before the CSR write (the Jacobian over 30 bw
!> steps at 257 x 257 without bending 1.75 -> 1.22 s when this path
!> replaced it); that buffer path stays for the other storage formats
!> (module reduced_blocks, against which tests/unit/test_reduced_assembly
!> checks all three entry points).
!>
!> The CSR layout (module csr_layout: csr_block_pos) is the DMDA's for
!> 1 x P strips; module reduced checks once that the matrix has it.
module reduced_assembly
  use kinds, only: rp
  use config, only: BEND_NONE, BEND_PAPER, BEND_ENERGY
  use lattice, only: lattice_t, link_dir, line_dir, stencil_box
  use node_blocks, only: node_blocks_t, node_blocks_count, node_blocks_products, node_blocks_sub_row, &
                         node_blocks_sub_node
  use springs, only: link_jacobian_lanes
  use bending_paper, only: paper_jacobian
  use bending_energy, only: energy_jacobian_lanes
  use offset_product, only: offset_table
  use forces, only: TRIPLE_LANES, link_lane_range, link_lanes, triple_lane_setup, triple_lane_edges, rest_link, triple_at, &
                    RING_ROWS, ring_load, ring_link_diffs, ring_triple_edges
  use csr_layout, only: csr_put_block_row, csr_add_block
  use reduced_lanes, only: put_link_blocks
  use mg_kernels, only: stencil_t, stencil_row_from_full
  implicit none
  private
  public :: assemble_csr, assemble_stencil, kc_products

  !> What a pass over the rows writes besides the products g and kd.
  integer, parameter :: S_NONE = 0      !< nothing (kc_products)
  integer, parameter :: S_CSR = 1       !< S into the CSR arrays of an AIJ matrix (assemble_csr)
  integer, parameter :: S_STENCIL = 2   !< S by stencil offset, each row converted for the multigrid (assemble_stencil)

  !> One pass's settings and the tables it derives once (scalars only: the
  !> arrays go as arguments).
  type :: pass_t
    integer :: mode = S_NONE                 !< S_NONE, S_CSR or S_STENCIL
    real(rp) :: a = 1.0_rp                   !< TS shift [1/time]
    real(rp) :: rinv = 1.0_rp                !< 1/a [time]
    logical :: with_damping = .true., clamp = .false., gauss_newton = .false.
    !> rows from an anchor row's links to the triples whose rows are then
    !> all written: 2 with bending (triples reach two rows), 0 without
    integer :: lag = 0
    integer :: kof(-2:2, -2:2) = 0           !< slot of each offset in st (module offset_product)
    real(rp) :: len0(4) = 0.0_rp             !< rest length of each link direction [length]
  end type pass_t

contains

  !> S on the owned rows into the CSR arrays of an AIJ matrix, written over
  !> the values of av and bv (every stored entry is set), with g and kd as
  !> kc_products. Constrained rows get a m I and constrained columns
  !> nothing, as in module reduced_blocks. u, w(0:5, 0:nx-1, gys:gye),
  !> ghost rows filled.
  subroutine assemble_csr(lat, nodal, u, fixedg, a, with_damping, clamp, gauss_newton, w, lb, g, kd, ia, av, ib, bv)
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal       !< forces on single nodes and quads (contact): their blocks
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) state
    logical, intent(in) :: fixedg(0:, lat%gys:)    !< (0:nx-1, gys:gye) constrained nodes
    real(rp), intent(in) :: a                      !< TS shift [1/time]
    logical, intent(in) :: with_damping, clamp, gauss_newton
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) vector of the products
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:) !< (0:nx-1, 3, 3, 4, 0:1) work: link blocks c + k/a
    real(rp), intent(out) :: g(:, 0:, lat%ys:)     !< (3, 0:nx-1, ys:ye) [force]
    real(rp), intent(out) :: kd(:, 0:, lat%ys:)    !< (3, 0:nx-1, ys:ye) [force/length]
    integer, intent(in) :: ia(0:), ib(0:)          !< row starts (0-based offsets into av, bv)
    real(rp), intent(inout) :: av(0:), bv(0:)      !< the diagonal and off-diagonal parts' values
    real(rp) :: nost(0:-1, 3, 3, 1, 0:0)           ! no S by stencil offset
    type(stencil_t) :: nofine
    call assemble_rows(pass_init(S_CSR, lat, a, with_damping, clamp, gauss_newton), lat, nodal, u, fixedg, w, lb, g, kd, &
                       ia, av, ib, bv, nost, nofine)
  end subroutine assemble_csr

  !> S on the owned rows by stencil offset, with g and kd as kc_products
  !> (constraints as assemble_csr), and the multigrid's finest level fine
  !> made from it row by row (stencil_row_from_full) while each row is
  !> still in the cache.
  subroutine assemble_stencil(lat, nodal, u, fixedg, a, with_damping, clamp, gauss_newton, w, lb, g, kd, st, fine)
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal       !< forces on single nodes and quads (contact): their blocks
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) state
    logical, intent(in) :: fixedg(0:, lat%gys:)    !< (0:nx-1, gys:gye) constrained nodes
    real(rp), intent(in) :: a                      !< TS shift [1/time]
    logical, intent(in) :: with_damping, clamp, gauss_newton
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) vector of the products
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:) !< (0:nx-1, 3, 3, 4, 0:1) work: link blocks c + k/a
    real(rp), intent(out) :: g(:, 0:, lat%ys:)     !< (3, 0:nx-1, ys:ye) [force]
    real(rp), intent(out) :: kd(:, 0:, lat%ys:)    !< (3, 0:nx-1, ys:ye) [force/length]
    !> S node by node (3, 3, offset_count(halo), 0:nx-1, 0:nrow-1)
    !> transposed: st(0:nx-1, 3, 3, offset_count(halo), 0:nrow-1),
    !> S(p, p + (di, dj)) = st(i, :, :, kof(di, dj), srow(j)) (module
    !> offset_product), zero outside the lattice; row j in slot
    !> modulo(j - ys, nrow): nrow = ye - ys + 1 keeps the whole strip, and
    !> nrow = lag + 1 (3 with bending, 1 without) is enough, a ring of the
    !> rows the assembly is writing (each row is converted for the
    !> multigrid as soon as it is complete, then overwritten)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    type(stencil_t), intent(inout) :: fine
    integer :: noi(0:-1)                           ! no CSR arrays
    real(rp) :: nor(0:-1)
    call assemble_rows(pass_init(S_STENCIL, lat, a, with_damping, clamp, gauss_newton), lat, nodal, u, fixedg, w, lb, g, &
                       kd, noi, nor, noi, nor, st, fine)
  end subroutine assemble_stencil

  !> g = -(K w_x + C w_v) on the owned rows and kd(:, i, j) the diagonal
  !> of -df/dx of node (i, j) (round-off floor), S not written: one pass
  !> over the elements with the assembly's vector kernels (the 6-dof
  !> Jacobian's product, module reduced's element_products). No TS shift:
  !> neither depends on it. lb: the caller's work array, as the
  !> assemblies' (the link blocks are formed and kept by the loop whether
  !> S is written or not: a test for it in the lane loop cost the assembly
  !> 0.4 % of its instructions).
  subroutine kc_products(lat, nodal, u, fixedg, with_damping, clamp, gauss_newton, w, lb, g, kd)
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal       !< forces on single nodes and quads (contact): their blocks
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) state
    logical, intent(in) :: fixedg(0:, lat%gys:)    !< (0:nx-1, gys:gye) constrained nodes
    logical, intent(in) :: with_damping, clamp, gauss_newton
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) vector of the products
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:) !< (0:nx-1, 3, 3, 4, 0:1) work
    real(rp), intent(out) :: g(:, 0:, lat%ys:)     !< (3, 0:nx-1, ys:ye) [force]
    real(rp), intent(out) :: kd(:, 0:, lat%ys:)    !< (3, 0:nx-1, ys:ye) [force/length]
    integer :: noi(0:-1)
    real(rp) :: nor(0:-1), nost(0:-1, 3, 3, 1, 0:0)
    type(stencil_t) :: nofine
    call assemble_rows(pass_init(S_NONE, lat, 1.0_rp, with_damping, clamp, gauss_newton), lat, nodal, u, fixedg, w, lb, &
                       g, kd, noi, nor, noi, nor, nost, nofine)
  end subroutine kc_products

  !> A pass's settings for the lattice lat (see pass_t).
  function pass_init(mode, lat, a, with_damping, clamp, gauss_newton) result(p)
    integer, intent(in) :: mode
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: a
    logical, intent(in) :: with_damping, clamp, gauss_newton
    type(pass_t) :: p
    real(rp) :: d0(3)
    integer :: k
    p%mode = mode
    p%a = a
    p%rinv = 1.0_rp / a
    p%with_damping = with_damping
    p%clamp = clamp
    p%gauss_newton = gauss_newton
    if (lat%bending_model /= BEND_NONE) p%lag = 2
    call offset_table(lat%halo, p%kof(-lat%halo:lat%halo, -lat%halo:lat%halo))
    do k = 1, 4
      call rest_link(lat, link_dir(:, k), d0, p%len0(k))
    end do
  end function pass_init

  !> The one pass over the rows of the three entry points, writing S as
  !> p%mode says: into the CSR arrays (ia, av, ib, bv), or by stencil
  !> offset (st, and each complete row into fine), or not at all (the
  !> products g and kd alone); the arrays of the other modes are not
  !> touched (the entry points pass empty ones). lb: the link blocks'
  !> work array (0:nx-1, 3, 3, 4, 0:1).
  !>
  !> Links are gathered: the blocks of the links of two anchor rows are kept
  !> (lb), and each node row is then written whole, in the CSR order, with
  !> no zeroing and no read-modify-write. Bending triples (9 blocks each,
  !> reaching two rows) are added to the written rows two rows later.
  subroutine assemble_rows(p, lat, nodal, u, fixedg, w, lb, g, kd, ia, av, ib, bv, st, fine)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:)
    real(rp), intent(out) :: g(:, 0:, lat%ys:)
    real(rp), intent(out) :: kd(:, 0:, lat%ys:)
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    type(stencil_t), intent(inout) :: fine
    integer :: i, j, jt, jr
    ! rows j - 2 .. j + 1 of u and w, x fastest (forces' ring_load)
    real(rp) :: us(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1), ws(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)
    integer :: utag(0:RING_ROWS - 1), wtag(0:RING_ROWS - 1)

    g = 0.0_rp
    kd = 0.0_rp
    ! (an internal invariant: a ring of rows only where each row is converted when complete)
    if (p%mode == S_STENCIL .and. size(st, 5) < lat%ye - lat%ys + 1 .and. size(st, 5) < p%lag + 1) &
      error stop 'assemble_stencil: st holds too few rows'
    ! One pass over the rows: row j's links and its block row written, the
    ! bending triples anchored lag rows below added (they reach rows
    ! j - lag .. j, all written by then), and row j - lag, now complete,
    ! converted for the multigrid while its blocks are still in the cache
    ! (as separate passes over S, the first touches of S's rows in each
    ! were most of the bending pass and of the conversion).
    utag = -huge(1)
    wtag = -huge(1)
    do j = max(0, lat%ys - 1), lat%ye + p%lag
      do jr = j - 2, j + 1
        call ring_load(lat, u, jr, us, utag)
        call ring_load(lat, w, jr, ws, wtag)
      end do
      if (j <= lat%ye) call link_row(p, lat, us, ws, j, lb, g, kd)
      if (j >= lat%ys .and. j <= lat%ye) then
        select case (p%mode)
        case (S_STENCIL)
          call put_rows_st(p, lat, nodal, fixedg, lb, j, st)
        case (S_CSR)
          do i = 0, lat%nx - 1
            call put_row(p, lat, nodal, fixedg, lb, i, j, ia, av, ib, bv)
          end do
        end select
      end if
      jt = j - p%lag
      if (jt < max(0, lat%ys - lat%halo) .or. jt > lat%ye) cycle
      if (lat%bending_model == BEND_ENERGY) call energy_triple_row(p, lat, us, ws, w, fixedg, jt, g, kd, ia, av, ib, bv, st)
      if (lat%bending_model == BEND_PAPER) call paper_triple_row(p, lat, u, w, fixedg, jt, g, kd, ia, av, ib, bv, st)
      if (p%mode == S_STENCIL .and. jt >= lat%ys) call stencil_row_from_full(fine, st(:, :, :, :, srow(lat, st, jt)), jt)
    end do
    ! the forces on single nodes (contact, module node_blocks): their
    ! products in g and diagonals in kd (S's blocks: put_rows_st, put_row)
    if (node_blocks_count(nodal) > 0) call node_blocks_products(nodal, lat%gys, w, g, kd)
  end subroutine assemble_rows

  !> Slot of owned row j in st.
  pure integer function srow(lat, st, j)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in), contiguous :: st(0:, :, :, :, 0:)
    integer, intent(in) :: j
    srow = modulo(j - lat%ys, size(st, 5))
  end function srow

  !> The links anchored at row j0 (kept in lb, their products in g, their
  !> diagonals in kd) from the rings us, ws of u and w. The links of one
  !> direction NL at a time through the vectorised kernel
  !> (link_jacobian_lanes).
  subroutine link_row(p, lat, us, ws, j0, lb, g, kd)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: us(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1), ws(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)
    integer, intent(in) :: j0
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:)
    real(rp), intent(inout) :: g(:, 0:, lat%ys:), kd(:, 0:, lat%ys:)
    integer, parameter :: NL = 32
    integer :: i, k, iq, jq, l, r, c, dx, ilo, ihi, i0, nl1, sj
    real(rp) :: e(NL), eta(NL), dd(NL, 3), vr(NL, 3), kl(NL, 3, 3), cll(NL, 3, 3), t(NL, 3), wx(NL, 3), wv(NL, 3)
    logical :: okl(NL), own_p, own_q
    own_p = j0 >= lat%ys
    sj = modulo(j0, 2)
    do k = 1, 4
      dx = link_dir(1, k)
      call link_lane_range(lat, j0, k, ilo, ihi, jq)
      own_q = jq <= lat%ye
      do i0 = ilo, ihi, NL
        call link_lanes(lat, us, j0, k, i0, ihi, NL, nl1, e, eta, dd, vr)
        call ring_link_diffs(lat%nx, ws, j0, k, i0, nl1, NL, wx, wv)
        call link_jacobian_lanes(nl1, NL, lat%spring_model, e, eta, p%len0(k), dd, vr, p%clamp, kl, cll, okl)
        ! f_p = -f_q: dF_p/dx_p = dF_q/dx_q = kl, dF_p/dx_q = dF_q/dx_p = -kl (same for cl).
        if (.not. p%with_damping) cll(1:nl1, :, :) = 0.0_rp
        t(1:nl1, :) = 0.0_rp
        do c = 1, 3
          do r = 1, 3
            do l = 1, nl1
              t(l, r) = t(l, r) + kl(l, r, c) * wx(l, c) + cll(l, r, c) * wv(l, c)
            end do
          end do
        end do
        do l = 1, nl1
          i = i0 + l - 1
          iq = i + dx
          lb(i, :, :, k, sj) = cll(l, :, :) + p%rinv * kl(l, :, :)
          do r = 1, 3
            if (own_p) kd(r, i, j0) = kd(r, i, j0) - kl(l, r, r)
            if (own_q) kd(r, iq, jq) = kd(r, iq, jq) - kl(l, r, r)
          end do
          if (own_p) g(:, i, j0) = g(:, i, j0) - t(l, :)
          if (own_q) g(:, iq, jq) = g(:, iq, jq) + t(l, :)
        end do
      end do
    end do
  end subroutine link_row

  !> Write the whole block rows of owned row j0 into S by stencil offset,
  !> offset by offset along the row: every slot of a node's row written
  !> once (it was zeroed whole first, 3 % of a bw step without bending):
  !> the link blocks (zero outside the lattice and to or from a
  !> constrained node), zero at the bending triples' far ends, which the
  !> triples then add to, and the diagonal a m I minus the blocks of the
  !> node's links (a m I alone on a constrained node). Node by node, the
  !> link's lookup for each of the eight neighbours was most of the
  !> assembly without bending.
  subroutine put_rows_st(p, lat, nodal, fixedg, lb, j0, st)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal
    logical, intent(in) :: fixedg(0:, lat%gys:)
    real(rp), intent(in) :: lb(0:, :, :, :, 0:)
    integer, intent(in) :: j0
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    integer :: di, dj, i, k, ilo, ihi, s0, sl, sd, dil, jl, r
    s0 = srow(lat, st, j0)
    ! the diagonal slot takes minus the sum of the node's link blocks
    sd = p%kof(0, 0)
    st(:, :, :, sd, s0) = 0.0_rp
    do dj = -1, 1
      do di = -1, 1
        if (di == 0 .and. dj == 0) cycle
        sl = p%kof(di, dj)
        if (j0 + dj < 0 .or. j0 + dj >= lat%ny) then
          st(:, :, :, sl, s0) = 0.0_rp
          cycle
        end if
        ilo = max(0, -di)
        ihi = min(lat%nx - 1, lat%nx - 1 - di)
        if (ilo > 0) st(0, :, :, sl, s0) = 0.0_rp
        if (ihi < lat%nx - 1) st(lat%nx - 1, :, :, sl, s0) = 0.0_rp
        call link_slot(di, dj, j0, k, dil, jl)
        call put_link_blocks(lat%nx, size(st, 4), ilo, ihi, di, dil, k, lb(:, :, :, :, jl), fixedg(:, j0), &
                             fixedg(:, j0 + dj), sl, sd, st(:, :, :, :, s0))
      end do
    end do
    if (lat%halo == 2) then
      do dj = -2, 2, 2
        do di = -2, 2, 2
          if (di /= 0 .or. dj /= 0) st(:, :, :, p%kof(di, dj), s0) = 0.0_rp
        end do
      end do
    end if
    do i = 0, lat%nx - 1
      if (fixedg(i, j0)) st(i, :, :, sd, s0) = 0.0_rp
      do r = 1, 3
        st(i, r, r, sd, s0) = st(i, r, r, sd, s0) + p%a * lat%mass(i, j0)
      end do
    end do
    if (node_blocks_count(nodal) > 0) call node_blocks_sub_row(nodal, j0, p%rinv, p%kof, lat%gys, fixedg, st(:, :, :, :, s0))
  end subroutine put_rows_st

  !> Where lb keeps the link from a node of row j0 to its neighbour
  !> (+di, +dj): a link is kept at its lower end, in direction k, at the
  !> node di_l along the row (0: this node, di: the neighbour) and in lb's
  !> row slot jl.
  pure subroutine link_slot(di, dj, j0, k, dil, jl)
    integer, intent(in) :: di, dj, j0
    integer, intent(out) :: k, dil, jl
    if (dj > 0 .or. (dj == 0 .and. di > 0)) then
      k = link_index(di, dj)
      dil = 0
      jl = modulo(j0, 2)
    else
      k = link_index(-di, -dj)
      dil = di
      jl = modulo(j0 + dj, 2)
    end if
  end subroutine link_slot

  !> Write the whole block row of owned node (i0, j0) into the AIJ S: a m I
  !> minus the blocks of its links on the diagonal, the link blocks at the
  !> link neighbours, zero elsewhere in the stencil (constraints as above).
  subroutine put_row(p, lat, nodal, fixedg, lb, i0, j0, ia, av, ib, bv)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal
    logical, intent(in) :: fixedg(0:, lat%gys:)
    real(rp), intent(in) :: lb(0:, :, :, :, 0:)
    integer, intent(in) :: i0, j0
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    integer :: di, dj, nc, r, m, di0, di1, dj0, dj1, k, dil, jl
    logical :: fixed_row, owned_blk(25)
    real(rp) :: dsum(3, 3), blk(3, 3), vals(3, 3, 25)   ! the blocks of a halo-2 stencil at most
    fixed_row = fixedg(i0, j0)
    dsum = 0.0_rp
    nc = 0
    call stencil_box(lat, i0, j0, lat%halo, di0, di1, dj0, dj1)
    do dj = dj0, dj1
      do di = di0, di1
        nc = nc + 1
        owned_blk(nc) = j0 + dj >= lat%ys .and. j0 + dj <= lat%ye
        vals(:, :, nc) = 0.0_rp
        if (max(abs(di), abs(dj)) /= 1) cycle
        call link_slot(di, dj, j0, k, dil, jl)
        blk = lb(i0 + dil, :, :, k, jl)
        dsum = dsum + blk
        if (.not. (fixed_row .or. fixedg(i0 + di, j0 + dj))) vals(:, :, nc) = blk
      end do
    end do
    ! The diagonal block: index of (0, 0) among the blocks.
    m = -dj0 * (di1 - di0 + 1) - di0 + 1
    if (fixed_row) dsum = 0.0_rp
    vals(:, :, m) = -dsum
    do r = 1, 3
      vals(r, r, m) = vals(r, r, m) + p%a * lat%mass(i0, j0)
    end do
    if (node_blocks_count(nodal) > 0) call node_blocks_sub_node(nodal, i0, j0, p%rinv, di0, di1, dj0, lat%gys, fixedg, vals)
    call csr_put_block_row(lat, ia, av, ib, bv, i0, j0, nc, owned_blk, vals)
  end subroutine put_row

  !> The energy-bending triples anchored at row j0 (their lowest row),
  !> added to the block rows of their owned nodes: the triples of one
  !> direction TRIPLE_LANES at a time through the vectorised kernel
  !> (energy_jacobian_lanes; one at a time they were a sixth of a
  !> Baraff-Witkin step), then by stencil offset (or for the products
  !> alone) lane by lane (add_triple_lanes), into the CSR arrays triple by
  !> triple (add_triple_edges).
  subroutine energy_triple_row(p, lat, us, ws, w, fixedg, j0, g, kd, ia, av, ib, bv, st)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: us(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1), ws(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    integer, intent(in) :: j0
    real(rp), intent(inout) :: g(:, 0:, lat%ys:), kd(:, 0:, lat%ys:)
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    integer, parameter :: NL = TRIPLE_LANES
    integer :: k, n(2, 3), ilo, ihi, i0, nl1, l
    real(rp) :: kb, etab, e1(NL, 3), e2(NL, 3), de(NL, 6), ke(NL, 6, 6), ce(NL, 6, 6)
    logical :: okl(NL)
    do k = 1, 4
      call triple_lane_setup(lat, j0, k, ilo, ihi, kb, etab)
      do i0 = ilo, ihi, NL
        call triple_lane_edges(lat%nx, us, j0, k, i0, ihi, NL, nl1, e1, e2, de)
        call energy_jacobian_lanes(nl1, NL, kb, etab, e1, e2, de, p%gauss_newton, ke, ce, okl)
        if (.not. p%with_damping) ce = 0.0_rp
        if (p%mode /= S_CSR) then
          call add_triple_lanes(p, lat, ws, fixedg, j0, k, i0, nl1, ke, ce, g, kd, st)
          cycle
        end if
        do l = 1, nl1
          n(:, 1) = [i0 + l - 1, j0]
          n(:, 2) = n(:, 1) + line_dir(:, k)
          n(:, 3) = n(:, 2) + line_dir(:, k)
          call add_triple_edges(p, lat, w, fixedg, n, ke(l, :, :), ce(l, :, :), g, kd, ia, av, ib, bv)
        end do
      end do
    end do
  end subroutine energy_triple_row

  !> The paper-bending triples anchored at row j0, one at a time, added
  !> to the block rows of their owned nodes (add_element_block; no damping).
  subroutine paper_triple_row(p, lat, u, w, fixedg, j0, g, kd, ia, av, ib, bv, st)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:), w(0:, 0:, lat%gys:)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    integer, intent(in) :: j0
    real(rp), intent(inout) :: g(:, 0:, lat%ys:), kd(:, 0:, lat%ys:)
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    integer :: i, k, n(2, 3), pp, qq
    real(rp) :: x9(9), k9(9, 9), c9(9, 9), kb, etab
    logical :: ok, inl
    c9 = 0.0_rp
    do i = 0, lat%nx - 1
      do k = 1, 4
        call triple_at(lat, u, i, j0, k, n, x9, kb, etab, inl)
        if (.not. inl) cycle
        call paper_jacobian(kb, x9, k9, ok)
        do pp = 1, 3
          do qq = 1, 3
            call add_element_block(p, lat, w, fixedg, n, pp, qq, k9, c9, g, kd, ia, av, ib, bv, st)
          end do
        end do
      end do
    end do
  end subroutine paper_triple_row

  !> add_triple_edges for the nl triples (i0 + l - 1, j0) + (0, 1, 2) (dx, dy),
  !> l = 1..nl, from their Jacobians in the edge variables ke(l, :, :),
  !> ce(l, :, :), into S by stencil offset: each sum formed for all the
  !> triples at once (vector loops over l), then added to nl consecutive
  !> nodes of a row (no two the same). With T = [[-I, I, 0], [0, -I, I]]
  !> the nine node blocks of T^T m T are sums of m's 3 x 3 quarters m_ab
  !> (edges a, b) with weights -1, 0, 1, spelled out (add_triple_block_row)
  !> rather than formed as products with T's entries. Each node's three
  !> blocks are formed and added in one loop (add_triple_block_row): kept
  !> as an array of the nine blocks (ld x 81 doubles, 20 KB) between
  !> forming and adding them, they filled the L1 cache with ke and ce, and
  !> the adds into S's ring of rows (past the L2 cache) waited on them.
  !> S_NONE: g and kd alone.
  subroutine add_triple_lanes(p, lat, ws, fixedg, j0, kdir, i0, nl, ke, ce, g, kd, st)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: ws(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    integer, intent(in) :: j0, kdir, i0, nl       ! kdir: the line direction, line_dir(:, kdir)
    ! the lanes' leading dimension, a constant: gfortran allocates arrays
    ! sized by a dummy argument on the heap (four mallocs and frees a call,
    ! about 15 ns a node of the assembly at 257 x 257)
    integer, parameter :: ld = TRIPLE_LANES
    real(rp), intent(in) :: ke(ld, 6, 6), ce(ld, 6, 6)
    real(rp), intent(inout) :: g(:, 0:, lat%ys:), kd(:, 0:, lat%ys:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    ! t(a, P): the factor of node P in edge a (T above)
    real(rp), parameter :: t(2, 3) = reshape([-1.0_rp, 0.0_rp, 1.0_rp, -1.0_rp, 0.0_rp, 1.0_rp], [2, 3])
    real(rp) :: ewx(ld, 6), ewv(ld, 6), h(ld, 6), free(ld, 3), s
    integer :: l, pp, qq, ip0, jp, iq0, jq2, c1, c2, sl(3), sp, dx, dy
    logical :: fixed_run(3), write_s
    write_s = p%mode /= S_NONE
    dx = line_dir(1, kdir)
    dy = line_dir(2, kdir)
    ! the edges' differences of w, as ring_triple_edges forms them of u
    call ring_triple_edges(lat%nx, ws, j0, kdir, i0, nl, ld, ewx(:, 1:3), ewx(:, 4:6), ewv)
    ! h = ke ewx + ce ewv, each entry summed in registers (as a sum into
    ! h(l, c1) over c2, h was loaded and stored 36 times)
    do c1 = 1, 6
      do l = 1, nl
        s = 0.0_rp
        !GCC$ unroll 6
        do c2 = 1, 6
          s = s + ke(l, c1, c2) * ewx(l, c2) + ce(l, c1, c2) * ewv(l, c2)
        end do
        h(l, c1) = s
      end do
    end do
    if (write_s) then
      ! whether node P's run of nl nodes holds a constrained one, once
      ! for the nine blocks (scanned for each, 9 % of triple_row)
      do pp = 1, 3
        fixed_run(pp) = any(fixedg(i0 + (pp - 1) * dx:i0 + (pp - 1) * dx + nl - 1, j0 + (pp - 1) * dy))
      end do
    end if
    do pp = 1, 3
      ip0 = i0 + (pp - 1) * dx
      jp = j0 + (pp - 1) * dy
      if (jp < lat%ys .or. jp > lat%ye) cycle
      call sub_lane_forces(nl, ld, t(1, pp), t(2, pp), h, ke, g(:, ip0:ip0 + nl - 1, jp), kd(:, ip0:ip0 + nl - 1, jp))
      if (.not. write_s) cycle
      sp = srow(lat, st, jp)
      ! constrained rows and columns get nothing (as add_triple_edges): a
      ! factor 0 there, 1 elsewhere (b + 1 x exactly b: the same sums)
      do qq = 1, 3
        iq0 = i0 + (qq - 1) * dx
        jq2 = j0 + (qq - 1) * dy
        sl(qq) = p%kof((qq - pp) * dx, (qq - pp) * dy)
        if (fixed_run(pp) .or. fixed_run(qq)) then
          do l = 1, nl
            free(l, qq) = merge(0.0_rp, 1.0_rp, fixedg(ip0 + l - 1, jp) .or. fixedg(iq0 + l - 1, jq2))
          end do
        else
          free(1:nl, qq) = 1.0_rp
        end if
      end do
      call add_triple_block_row(nl, ld, lat%nx, size(st, 4), pp, sl, ip0, p%rinv, ke, ce, free, st(:, :, :, :, sp))
    end do
  end subroutine add_triple_lanes

  !> Block (p, q) of a bending triple with nodes n(:, 1..3), from its
  !> 9 x 9 matrices: kk = dF_p/dx_q, cc = dF_p/dv_q (rows and columns
  !> 3p-2:3p, 3q-2:3q). S gets -(cc + kk/a) in row p, column q,
  !> g_p gets -(kk w_x(q) + cc w_v(q)), kd_p the diagonal of -kk.
  subroutine add_element_block(ps, lat, w, fixedg, n, p, q, k9, c9, g, kd, ia, av, ib, bv, st)
    type(pass_t), intent(in) :: ps
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    integer, intent(in) :: n(:, :), p, q
    real(rp), intent(in) :: k9(9, 9), c9(9, 9)
    real(rp), intent(inout) :: g(:, 0:, lat%ys:), kd(:, 0:, lat%ys:)
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    real(rp) :: blk(3, 3)
    integer :: ip, jp, iq2, jq2, l, m, r0, c0
    ip = n(1, p)
    jp = n(2, p)
    if (jp < lat%ys .or. jp > lat%ye) return
    iq2 = n(1, q)
    jq2 = n(2, q)
    r0 = 3 * p - 3
    c0 = 3 * q - 3
    do l = 1, 3
      g(l, ip, jp) = g(l, ip, jp) - sum(k9(r0 + l, c0 + 1:c0 + 3) * w(0:2, iq2, jq2) &
                                        + c9(r0 + l, c0 + 1:c0 + 3) * w(3:5, iq2, jq2))
    end do
    if (p == q) then
      do l = 1, 3
        kd(l, ip, jp) = kd(l, ip, jp) - k9(r0 + l, c0 + l)
      end do
    end if
    if (fixedg(ip, jp) .or. fixedg(iq2, jq2)) return
    do m = 1, 3
      do l = 1, 3
        blk(l, m) = -(c9(r0 + l, c0 + m) + ps%rinv * k9(r0 + l, c0 + m))
      end do
    end do
    call add_block(ps, lat, ip, jp, iq2 - ip, jq2 - jp, blk, ia, av, ib, bv, st)
  end subroutine add_element_block

  !> The nine blocks of an energy-bending triple with nodes n(:, 1..3)
  !> from its Jacobians in the edge variables, K9 = T^T ke T, C9 = T^T ce T
  !> (e_a = sum_P t(a, P) x_P: e1 = x_q - x_p, e2 = x_r - x_q), combined
  !> there first: S_PQ gets sum_ab t(a, P) t(b, Q) m_ab with
  !> m = -(ce + ke/a), g_P gets -(T^T (ke T w_x + ce T w_v))_P, kd_P the
  !> diagonal of -K9_PP. (Two 9 x 9 matrices and their 81-entry blocks are
  !> never formed: a third of the bending assembly.) Into the CSR arrays.
  subroutine add_triple_edges(p, lat, w, fixedg, n, ke, ce, g, kd, ia, av, ib, bv)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    integer, intent(in) :: n(:, :)
    real(rp), intent(in) :: ke(6, 6), ce(6, 6)
    real(rp), intent(inout) :: g(:, 0:, lat%ys:), kd(:, 0:, lat%ys:)
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    integer, parameter :: t(2, 3) = reshape([-1, 0, 1, -1, 0, 1], [2, 3])
    real(rp) :: m(6, 6), ewx(6), ewv(6), h(6), tm(3, 6, 3), blk(3, 3)
    integer :: pp, qq, ip, jp, iq2, jq2, l
    m = -(ce + p%rinv * ke)
    ewx(1:3) = w(0:2, n(1, 2), n(2, 2)) - w(0:2, n(1, 1), n(2, 1))
    ewx(4:6) = w(0:2, n(1, 3), n(2, 3)) - w(0:2, n(1, 2), n(2, 2))
    ewv(1:3) = w(3:5, n(1, 2), n(2, 2)) - w(3:5, n(1, 1), n(2, 1))
    ewv(4:6) = w(3:5, n(1, 3), n(2, 3)) - w(3:5, n(1, 2), n(2, 2))
    h = matmul(ke, ewx) + matmul(ce, ewv)
    ! The rows of T^T m by node, tm(:, :, P) = sum_a t(a, P) m(rows of
    ! edge a, :), then block (P, Q) = sum_b t(b, Q) tm(:, cols of edge b, P):
    ! t is -1, 0 or 1, so sums and differences, no products.
    tm(:, :, 1) = -m(1:3, :)
    tm(:, :, 2) = m(1:3, :) - m(4:6, :)
    tm(:, :, 3) = m(4:6, :)
    do pp = 1, 3
      ip = n(1, pp)
      jp = n(2, pp)
      if (jp < lat%ys .or. jp > lat%ye) cycle
      g(:, ip, jp) = g(:, ip, jp) - (t(1, pp) * h(1:3) + t(2, pp) * h(4:6))
      do l = 1, 3
        kd(l, ip, jp) = kd(l, ip, jp) - (t(1, pp)**2 * ke(l, l) + t(1, pp) * t(2, pp) * (ke(l, 3 + l) + ke(3 + l, l)) &
                                         + t(2, pp)**2 * ke(3 + l, 3 + l))
      end do
      if (fixedg(ip, jp)) cycle
      do qq = 1, 3
        iq2 = n(1, qq)
        jq2 = n(2, qq)
        if (fixedg(iq2, jq2)) cycle
        select case (qq)
        case (1)
          blk = -tm(:, 1:3, pp)
        case (2)
          blk = tm(:, 1:3, pp) - tm(:, 4:6, pp)
        case default
          blk = tm(:, 4:6, pp)
        end select
        call csr_add_block(lat, ia, av, ib, bv, ip, jp, iq2 - ip, jq2 - jp, blk)
      end do
    end do
  end subroutine add_triple_edges

  !> S(node (ip, jp), node (ip + di, jp + dj)) += blk, as p%mode says.
  subroutine add_block(p, lat, ip, jp, di, dj, blk, ia, av, ib, bv, st)
    type(pass_t), intent(in) :: p
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ip, jp, di, dj
    real(rp), intent(in) :: blk(3, 3)
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(inout) :: av(0:), bv(0:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    select case (p%mode)
    case (S_STENCIL)
      st(ip, :, :, p%kof(di, dj), srow(lat, st, jp)) = st(ip, :, :, p%kof(di, dj), srow(lat, st, jp)) + blk
    case (S_CSR)
      call csr_add_block(lat, ia, av, ib, bv, ip, jp, di, dj, blk)
    end select
  end subroutine add_block

  !> Index k of link_dir for the direction (di, dj) of a link from its anchor.
  pure integer function link_index(di, dj) result(k)
    integer, intent(in) :: di, dj
    do k = 1, 4
      if (link_dir(1, k) == di .and. link_dir(2, k) == dj) return
    end do
    k = 0
  end function link_index

  ! ------------------------------------------------- bending triples' lanes
  ! Here rather than in module reduced_lanes: inlined into add_triple_lanes
  ! (ld = TRIPLE_LANES known there) their short loops are vector loops.

  !> Node P's three blocks B(P, Q) = sum_ab t(a, P) t(b, Q) m_ab of nl
  !> bending triples (T = [[-I, I, 0], [0, -I, I]], m = -(ce + ke/a), m_ab
  !> its 3 x 3 quarter of edges a, b), times free(l, Q), added to slot
  !> sl(Q) of nl consecutive nodes ip0.. of a row of S by stencil offset,
  !> nodes fastest, as S keeps them: one vector loop for each entry. T's
  !> entries are -1, 0 and 1, so each block is a sum of one to four
  !> quarters: B11 = m11, B12 = m12 - m11, B13 = -m12, B21 = m21 - m11,
  !> B22 = m11 - m12 - m21 + m22, B23 = m12 - m22, B31 = -m21,
  !> B32 = m21 - m22, B33 = m22. Explicit shapes, as put_link_blocks.
  pure subroutine add_triple_block_row(nl, ld, nx, nslot, pp, sl, ip0, rinv, ke, ce, free, dst)
    integer, intent(in) :: nl, ld, nx, nslot, pp, sl(3), ip0
    real(rp), intent(in) :: rinv                   ! 1/a [time]
    real(rp), intent(in) :: ke(ld, 6, 6), ce(ld, 6, 6), free(ld, 3)
    real(rp), intent(inout) :: dst(0:nx - 1, 3, 3, nslot)
    integer :: l, c1, c2, i
    real(rp) :: m11, m12, m21, m22
    do c2 = 1, 3
      do c1 = 1, 3
        select case (pp)
        case (1)
          do l = 1, nl
            i = ip0 + l - 1
            m11 = -(ce(l, c1, c2) + rinv * ke(l, c1, c2))
            m12 = -(ce(l, c1, 3 + c2) + rinv * ke(l, c1, 3 + c2))
            dst(i, c1, c2, sl(1)) = dst(i, c1, c2, sl(1)) + free(l, 1) * m11
            dst(i, c1, c2, sl(2)) = dst(i, c1, c2, sl(2)) + free(l, 2) * (m12 - m11)
            dst(i, c1, c2, sl(3)) = dst(i, c1, c2, sl(3)) + free(l, 3) * (-m12)
          end do
        case (2)
          do l = 1, nl
            i = ip0 + l - 1
            m11 = -(ce(l, c1, c2) + rinv * ke(l, c1, c2))
            m12 = -(ce(l, c1, 3 + c2) + rinv * ke(l, c1, 3 + c2))
            m21 = -(ce(l, 3 + c1, c2) + rinv * ke(l, 3 + c1, c2))
            m22 = -(ce(l, 3 + c1, 3 + c2) + rinv * ke(l, 3 + c1, 3 + c2))
            dst(i, c1, c2, sl(1)) = dst(i, c1, c2, sl(1)) + free(l, 1) * (m21 - m11)
            dst(i, c1, c2, sl(2)) = dst(i, c1, c2, sl(2)) + free(l, 2) * ((m11 - m12) + (m22 - m21))
            dst(i, c1, c2, sl(3)) = dst(i, c1, c2, sl(3)) + free(l, 3) * (m12 - m22)
          end do
        case default
          do l = 1, nl
            i = ip0 + l - 1
            m21 = -(ce(l, 3 + c1, c2) + rinv * ke(l, 3 + c1, c2))
            m22 = -(ce(l, 3 + c1, 3 + c2) + rinv * ke(l, 3 + c1, 3 + c2))
            dst(i, c1, c2, sl(1)) = dst(i, c1, c2, sl(1)) + free(l, 1) * (-m21)
            dst(i, c1, c2, sl(2)) = dst(i, c1, c2, sl(2)) + free(l, 2) * (m21 - m22)
            dst(i, c1, c2, sl(3)) = dst(i, c1, c2, sl(3)) + free(l, 3) * m22
          end do
        end select
      end do
    end do
  end subroutine add_triple_block_row

  !> add_triple_lanes' products and diagonals for node P of nl triples
  !> (t1, t2: its factors in the two edges): g -= t1 h(1:3) + t2 h(4:6) and
  !> kd -= the diagonal of the block (P, P) of T^T ke T.
  pure subroutine sub_lane_forces(nl, ld, t1, t2, h, ke, g, kd)
    integer, intent(in) :: nl, ld
    real(rp), intent(in) :: t1, t2, h(ld, 6), ke(ld, 6, 6)
    real(rp), intent(inout) :: g(3, nl), kd(3, nl)
    integer :: l, c1
    do l = 1, nl
      do c1 = 1, 3
        g(c1, l) = g(c1, l) - (t1 * h(l, c1) + t2 * h(l, 3 + c1))
        kd(c1, l) = kd(c1, l) - (t1**2 * ke(l, c1, c1) + t1 * t2 * (ke(l, c1, 3 + c1) + ke(l, 3 + c1, c1)) &
                                 + t2**2 * ke(l, 3 + c1, 3 + c1))
      end do
    end do
  end subroutine sub_lane_forces

end module reduced_assembly
