! SPDX-License-Identifier: BSD-2-Clause
!> Direct assembly of the reduced matrix S = a M - C - K/a, element by
!> element (no PETSc, no MPI), through three entry points over one element
!> loop (assemble_rows): assemble_csr into the CSR arrays of an AIJ matrix,
!> assemble_stencil by stencil offset (and the multigrid's finest level
!> from it), kc_products S not written, only the element products
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
!> Layout (as made by the DMDA for 1 x P strips, natural ordering): the owned
!> node (i, j) has the scalar rows 3 lp + 0..2, lp = i + (j - ys) nx. Its
!> stencil blocks (i + di, j + dj), |di|, |dj| <= w, inside the lattice, are
!> stored in the order of (dj, di), in the diagonal part (av, row starts ia)
!> when row j + dj is owned, in the off-diagonal part (bv, ib) otherwise;
!> each block takes three consecutive columns of each of the three rows.
!> module reduced checks once that the matrix has exactly this layout.
module reduced_assembly
  use kinds, only: rp
  use config, only: BEND_NONE, BEND_PAPER, BEND_ENERGY
  use lattice, only: lattice_t, link_dir, line_dir, triple_constants, link_lane_constants
  use springs, only: link_jacobian_lanes
  use bending_paper, only: paper_jacobian
  use bending_energy, only: energy_jacobian_lanes
  use offset_product, only: offset_table
  use forces, only: triple_lane_range, TRIPLE_LANES, link_lane_range, RING_ROWS, ring_load, ring_link_diffs, ring_triple_edges
  use mg_kernels, only: stencil_t, stencil_row_from_full
  implicit none
  private
  public :: assemble_csr, assemble_stencil, kc_products, csr_block_pos, csr_row_blocks

contains

  !> Offsets pos(0:2) of the first entry of block (i + di, j + dj) in the
  !> three scalar rows of owned node (i, j); diag: in av (else in bv).
  pure subroutine csr_block_pos(lat, ia, ib, i, j, di, dj, pos, diag)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ia(0:), ib(0:)
    integer, intent(in) :: i, j, di, dj
    integer, intent(out) :: pos(0:2)
    logical, intent(out) :: diag
    integer :: w, di0, ndi, dj0, ja0, ja1, r0, idx, r, below

    w = lat%halo
    di0 = max(-w, -i)
    ndi = min(w, lat%nx - 1 - i) - di0 + 1
    dj0 = max(-w, -j)
    ja0 = max(dj0, lat%ys - j)                    ! owned rows of the stencil: ja0..ja1
    ja1 = min(w, lat%ny - 1 - j, lat%ye - j)
    r0 = 3 * (i + (j - lat%ys) * lat%nx)
    diag = dj >= ja0 .and. dj <= ja1
    if (diag) then
      idx = (dj - ja0) * ndi + (di - di0)
      do r = 0, 2
        pos(r) = ia(r0 + r) + 3 * idx
      end do
    else
      below = dj - dj0                            ! stencil rows before dj ...
      if (dj > ja1) below = below - (ja1 - ja0 + 1)   ! ... that are not owned
      idx = below * ndi + (di - di0)
      do r = 0, 2
        pos(r) = ib(r0 + r) + 3 * idx
      end do
    end if
  end subroutine csr_block_pos

  !> S on the owned rows into the CSR arrays of an AIJ matrix, written over
  !> the values of av and bv (every stored entry is set), with g and kd as
  !> kc_products. Constrained rows get a m I and constrained columns
  !> nothing, as in module reduced_blocks. u, w(0:5, 0:nx-1, gys:gye),
  !> ghost rows filled.
  subroutine assemble_csr(lat, u, fixedg, a, with_damping, clamp, gauss_newton, w, lb, g, kd, ia, av, ib, bv)
    type(lattice_t), intent(in) :: lat
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
    call assemble_rows(lat, u, fixedg, a, with_damping, clamp, gauss_newton, w, g, kd, lb, ia=ia, av=av, ib=ib, bv=bv)
  end subroutine assemble_csr

  !> S on the owned rows by stencil offset, with g and kd as kc_products
  !> (constraints as assemble_csr), and, when fine is given, the
  !> multigrid's finest level made from it row by row
  !> (stencil_row_from_full) while each row is still in the cache.
  subroutine assemble_stencil(lat, u, fixedg, a, with_damping, clamp, gauss_newton, w, lb, g, kd, st, fine)
    type(lattice_t), intent(in) :: lat
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
    !> with fine, nrow = lag + 1 (3 with bending, 1 without) is enough, a
    !> ring of the rows the assembly is writing (each row is converted for
    !> the multigrid as soon as it is complete, then overwritten)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    type(stencil_t), intent(inout), optional :: fine
    call assemble_rows(lat, u, fixedg, a, with_damping, clamp, gauss_newton, w, g, kd, lb, st=st, fine=fine)
  end subroutine assemble_stencil

  !> g = -(K w_x + C w_v) on the owned rows and kd(:, i, j) the diagonal
  !> of -df/dx of node (i, j) (round-off floor), S not written: one pass
  !> over the elements with the assembly's vector kernels (the 6-dof
  !> Jacobian's product, module reduced's element_products). No TS shift:
  !> neither depends on it.
  subroutine kc_products(lat, u, fixedg, with_damping, clamp, gauss_newton, w, g, kd)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) state
    logical, intent(in) :: fixedg(0:, lat%gys:)    !< (0:nx-1, gys:gye) constrained nodes
    logical, intent(in) :: with_damping, clamp, gauss_newton
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye) vector of the products
    real(rp), intent(out) :: g(:, 0:, lat%ys:)     !< (3, 0:nx-1, ys:ye) [force]
    real(rp), intent(out) :: kd(:, 0:, lat%ys:)    !< (3, 0:nx-1, ys:ye) [force/length]
    ! the link blocks are formed and kept by the loop whether S is written
    ! or not (a test for it in the lane loop cost the assembly 0.4 % of its
    ! instructions): a work array of its own, 0.6 KB a lattice column
    real(rp), allocatable :: lb(:, :, :, :, :)
    allocate(lb(0:lat%nx - 1, 3, 3, 4, 0:1))
    call assemble_rows(lat, u, fixedg, 1.0_rp, with_damping, clamp, gauss_newton, w, g, kd, lb)
  end subroutine kc_products

  !> The one element loop of the three entry points: S into the CSR arrays
  !> (ia, av, ib, bv), or by stencil offset (st, fine), or not at all
  !> (neither: the products g and kd alone); lb the link blocks' work
  !> array (0:nx-1, 3, 3, 4, 0:1).
  !>
  !> Links are gathered: the blocks of the links of two anchor rows are kept
  !> (lb), and each node row is then written whole, in the CSR order, with
  !> no zeroing and no read-modify-write. Bending triples (9 blocks each,
  !> reaching two rows) are added to the written rows two rows later.
  subroutine assemble_rows(lat, u, fixedg, a, with_damping, clamp, gauss_newton, w, g, kd, lb, ia, av, ib, bv, st, fine)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(in) :: fixedg(0:, lat%gys:)
    real(rp), intent(in) :: a
    logical, intent(in) :: with_damping, clamp, gauss_newton
    real(rp), intent(in) :: w(0:, 0:, lat%gys:)
    real(rp), intent(out) :: g(:, 0:, lat%ys:)
    real(rp), intent(out) :: kd(:, 0:, lat%ys:)
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:)
    integer, intent(in), optional :: ia(0:), ib(0:)
    real(rp), intent(inout), optional :: av(0:), bv(0:)
    real(rp), intent(inout), optional, contiguous :: st(0:, :, :, :, 0:)
    type(stencil_t), intent(inout), optional :: fine
    integer :: j, k, jt, lag, jr
    real(rp) :: d0(3, 4), len0(4), c9(9, 9), rinv
    ! rows j - 2 .. j + 1 of u and w, x fastest (forces' ring_load)
    real(rp) :: us(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1), ws(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)
    integer :: utag(0:RING_ROWS - 1), wtag(0:RING_ROWS - 1)
    logical :: write_s                             ! false: the products g, kd only
    integer :: kof(-2:2, -2:2)                     ! slot of each offset in st

    write_s = present(st) .or. present(ia)
    kof = 0
    call offset_table(lat%halo, kof(-lat%halo:lat%halo, -lat%halo:lat%halo))
    g = 0.0_rp
    kd = 0.0_rp
    rinv = 1.0_rp / a
    do k = 1, 4
      d0(:, k) = [-real(link_dir(1, k), rp) * lat%ax, -real(link_dir(2, k), rp) * lat%ay, 0.0_rp]
      len0(k) = norm2(d0(:, k))
    end do
    c9 = 0.0_rp
    ! One pass over the rows: row j's links and its block row written, the
    ! bending triples anchored lag rows below added (they reach rows
    ! j - lag .. j, all written by then), and row j - lag, now complete,
    ! converted for the multigrid while its blocks are still in the cache
    ! (as separate passes over S, the first touches of S's rows in each
    ! were most of the bending pass and of the conversion).
    lag = 0
    if (lat%bending_model /= BEND_NONE) lag = 2
    if (present(st)) then
      ! (an internal invariant: a ring of rows only where each row is converted when complete)
      if (size(st, 5) < lat%ye - lat%ys + 1 .and. (size(st, 5) < lag + 1 .or. .not. present(fine))) &
        error stop 'assemble_stencil: st holds too few rows'
    end if
    utag = -huge(1)
    wtag = -huge(1)
    do j = max(0, lat%ys - 1), lat%ye + lag
      do jr = j - 2, j + 1
        call ring_load(lat, u, jr, us, utag)
        call ring_load(lat, w, jr, ws, wtag)
      end do
      if (j <= lat%ye) call link_row(j)
      jt = j - lag
      if (lag > 0 .and. jt >= max(0, lat%ys - lat%halo) .and. jt <= lat%ye) call triple_row(jt)
      if (present(fine) .and. present(st) .and. jt >= lat%ys .and. jt <= lat%ye) &
        call stencil_row_from_full(fine, st(:, :, :, :, srow(jt)), jt)
    end do
    if (lat%nodal%n > 0) call nodal_products()

  contains

    !> The forces on single nodes (contact, module node_blocks): their
    !> products in g and diagonals in kd (S's diagonal: put_rows_st, put_row).
    subroutine nodal_products()
      integer :: m, i, jn, r
      do jn = lat%ys, lat%ye
        do m = lat%nodal%row_start(jn), lat%nodal%row_start(jn + 1) - 1
          i = lat%nodal%col(m)
          g(:, i, jn) = g(:, i, jn) - matmul(lat%nodal%kx(:, :, m), w(0:2, i, jn)) &
                        - matmul(lat%nodal%kv(:, :, m), w(3:5, i, jn))
          do r = 1, 3
            kd(r, i, jn) = kd(r, i, jn) - lat%nodal%kx(r, r, m)
          end do
        end do
      end do
    end subroutine nodal_products

    !> Slot of owned row j in st.
    pure integer function srow(j)
      integer, intent(in) :: j
      srow = modulo(j - lat%ys, size(st, 5))
    end function srow

    !> The links anchored at row j0 (kept in lb, their products in g, their
    !> diagonals in kd) and, when row j0 is owned, its block row. The links
    !> of one direction NL at a time through the vectorised kernel
    !> (link_jacobian_lanes).
    subroutine link_row(j0)
      integer, intent(in) :: j0
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
          nl1 = min(NL, ihi - i0 + 1)
          call link_lane_constants(lat, j0, k, i0, nl1, NL, e, eta)
          call ring_link_diffs(lat%nx, us, j0, k, i0, nl1, NL, dd, vr)
          call ring_link_diffs(lat%nx, ws, j0, k, i0, nl1, NL, wx, wv)
          call link_jacobian_lanes(nl1, NL, lat%spring_model, e, eta, len0(k), dd, vr, clamp, kl, cll, okl)
          ! f_p = -f_q: dF_p/dx_p = dF_q/dx_q = kl, dF_p/dx_q = dF_q/dx_p = -kl (same for cl).
          if (.not. with_damping) cll(1:nl1, :, :) = 0.0_rp
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
            lb(i, :, :, k, sj) = cll(l, :, :) + rinv * kl(l, :, :)
            do r = 1, 3
              if (own_p) kd(r, i, j0) = kd(r, i, j0) - kl(l, r, r)
              if (own_q) kd(r, iq, jq) = kd(r, iq, jq) - kl(l, r, r)
            end do
            if (own_p) g(:, i, j0) = g(:, i, j0) - t(l, :)
            if (own_q) g(:, iq, jq) = g(:, iq, jq) + t(l, :)
          end do
        end do
      end do
      if (own_p .and. write_s) then
        if (present(st)) then
          call put_rows_st(j0)
        else
          do i = 0, lat%nx - 1
            call put_row(i, j0)
          end do
        end if
      end if
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
    subroutine put_rows_st(j0)
      integer, intent(in) :: j0
      integer :: di, dj, i, k, ilo, ihi, s0, sl, sd, dil, jl, r
      s0 = srow(j0)
      ! the diagonal slot takes minus the sum of the node's link blocks
      sd = kof(0, 0)
      st(:, :, :, sd, s0) = 0.0_rp
      do dj = -1, 1
        do di = -1, 1
          if (di == 0 .and. dj == 0) cycle
          sl = kof(di, dj)
          if (j0 + dj < 0 .or. j0 + dj >= lat%ny) then
            st(:, :, :, sl, s0) = 0.0_rp
            cycle
          end if
          ilo = max(0, -di)
          ihi = min(lat%nx - 1, lat%nx - 1 - di)
          if (ilo > 0) st(0, :, :, sl, s0) = 0.0_rp
          if (ihi < lat%nx - 1) st(lat%nx - 1, :, :, sl, s0) = 0.0_rp
          ! a link is kept at its lower end (link_block)
          if (dj > 0 .or. (dj == 0 .and. di > 0)) then
            k = link_index(di, dj)
            dil = 0
            jl = modulo(j0, 2)
          else
            k = link_index(-di, -dj)
            dil = di
            jl = modulo(j0 + dj, 2)
          end if
          call put_link_blocks(lat%nx, size(st, 4), ilo, ihi, di, dil, k, lb(:, :, :, :, jl), fixedg(:, j0), &
                               fixedg(:, j0 + dj), sl, sd, st(:, :, :, :, s0))
        end do
      end do
      if (lat%halo == 2) then
        do dj = -2, 2, 2
          do di = -2, 2, 2
            if (di /= 0 .or. dj /= 0) st(:, :, :, kof(di, dj), s0) = 0.0_rp
          end do
        end do
      end if
      do i = 0, lat%nx - 1
        if (fixedg(i, j0)) st(i, :, :, sd, s0) = 0.0_rp
        do r = 1, 3
          st(i, r, r, sd, s0) = st(i, r, r, sd, s0) + a * lat%mass(i, j0)
        end do
      end do
      if (lat%nodal%n > 0) then
        do r = lat%nodal%row_start(j0), lat%nodal%row_start(j0 + 1) - 1
          i = lat%nodal%col(r)
          st(i, :, :, sd, s0) = st(i, :, :, sd, s0) - lat%nodal%kv(:, :, r) - rinv * lat%nodal%kx(:, :, r)
        end do
      end if
    end subroutine put_rows_st

    !> The bending triples anchored at row j0 (their lowest row), added to
    !> the block rows of their owned nodes. Energy bending: the triples of
    !> one direction TRIPLE_LANES at a time through the vectorised kernel
    !> (energy_jacobian_lanes; one at a time they were a sixth of a
    !> Baraff-Witkin step).
    subroutine triple_row(j0)
      integer, intent(in) :: j0
      integer, parameter :: NL = TRIPLE_LANES
      integer :: i, k, iq, jq, ir, jr, n(2, 3), p, q, dx, dy, ilo, ihi, i0, nl1, l
      real(rp) :: x9(9), k9(9, 9), kb, etab
      real(rp) :: e1(NL, 3), e2(NL, 3), de(NL, 6), ke(NL, 6, 6), ce(NL, 6, 6)
      logical :: ok, okl(NL)
      if (lat%bending_model == BEND_ENERGY) then
        do k = 1, 4
          dx = line_dir(1, k)
          dy = line_dir(2, k)
          call triple_lane_range(lat, j0, k, ilo, ihi)
          call triple_constants(lat, k, kb, etab)
          do i0 = ilo, ihi, NL
            nl1 = min(NL, ihi - i0 + 1)
            call ring_triple_edges(lat%nx, us, j0, k, i0, nl1, NL, e1, e2, de)
            call energy_jacobian_lanes(nl1, NL, kb, etab, e1, e2, de, gauss_newton, ke, ce, okl)
            if (.not. with_damping) ce = 0.0_rp
            if (present(st) .or. .not. write_s) then
              call add_triple_lanes(j0, k, i0, nl1, NL, ke, ce)
              cycle
            end if
            do l = 1, nl1
              i = i0 + l - 1
              n(:, 1) = [i, j0]
              n(:, 2) = [i + dx, j0 + dy]
              n(:, 3) = [i + 2 * dx, j0 + 2 * dy]
              call add_triple_edges(n, ke(l, :, :), ce(l, :, :))
            end do
          end do
        end do
        return
      end if
      do i = 0, lat%nx - 1
        do k = 1, 4
          iq = i + line_dir(1, k)
          jq = j0 + line_dir(2, k)
          ir = iq + line_dir(1, k)
          jr = jq + line_dir(2, k)
          if (ir < 0 .or. ir >= lat%nx .or. jr >= lat%ny .or. jr < lat%ys) cycle
          call triple_constants(lat, k, kb, etab)
          x9 = [u(0:2, i, j0), u(0:2, iq, jq), u(0:2, ir, jr)]
          n(:, 1) = [i, j0]
          n(:, 2) = [iq, jq]
          n(:, 3) = [ir, jr]
          call paper_jacobian(kb, x9, k9, ok)
          do p = 1, 3
            do q = 1, 3
              call add_element_block(n, p, q, k9, c9)
            end do
          end do
        end do
      end do
    end subroutine triple_row

    !> add_triple_edges for the nl triples (i0 + l - 1, j0) + (0, 1, 2) (dx, dy),
    !> l = 1..nl, from their Jacobians in the edge variables ke(l, :, :),
    !> ce(l, :, :), into S by stencil offset: each sum formed for all the
    !> triples at once (vector loops over l), then added to nl consecutive
    !> nodes of a row (no two the same). With T = [[-I, I, 0], [0, -I, I]]
    !> the nine node blocks of T^T m T are sums of m's 3 x 3 quarters m_ab
    !> (edges a, b) with weights -1, 0, 1, spelled out (triple_node_blocks)
    !> rather than formed as products with T's entries (fewer operations,
    !> 1.7 % of the assembly: what this routine's time goes to is its adds
    !> into S's ring of rows, past the L2 cache).
    subroutine add_triple_lanes(j0, kdir, i0, nl, ld, ke, ce)
      integer, intent(in) :: j0, kdir, i0, nl, ld   ! kdir: the line direction, line_dir(:, kdir)
      real(rp), intent(in) :: ke(ld, 6, 6), ce(ld, 6, 6)
      ! t(a, P): the factor of node P in edge a (T above)
      real(rp), parameter :: t(2, 3) = reshape([-1.0_rp, 0.0_rp, 1.0_rp, -1.0_rp, 0.0_rp, 1.0_rp], [2, 3])
      real(rp) :: blk(ld, 3, 3, 9), ewx(ld, 6), ewv(ld, 6), h(ld, 6), free(ld)
      integer :: l, pp, qq, ip0, jp, iq0, jq2, c1, c2, sl, sp, dx, dy
      logical :: masked, fixed_run(3)
      dx = line_dir(1, kdir)
      dy = line_dir(2, kdir)
      ! the edges' differences of w, as ring_triple_edges forms them of u
      call ring_triple_edges(lat%nx, ws, j0, kdir, i0, nl, ld, ewx(:, 1:3), ewx(:, 4:6), ewv)
      h(1:nl, :) = 0.0_rp
      do c2 = 1, 6
        do c1 = 1, 6
          do l = 1, nl
            h(l, c1) = h(l, c1) + ke(l, c1, c2) * ewx(l, c2) + ce(l, c1, c2) * ewv(l, c2)
          end do
        end do
      end do
      if (write_s) then
        call triple_node_blocks(nl, ld, rinv, ke, ce, blk)
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
        sp = srow(jp)                 ! (st is absent for the products alone)
        do qq = 1, 3
          iq0 = i0 + (qq - 1) * dx
          jq2 = j0 + (qq - 1) * dy
          sl = kof((qq - pp) * dx, (qq - pp) * dy)
          ! constrained rows and columns get nothing (as add_triple_edges)
          masked = fixed_run(pp) .or. fixed_run(qq)
          if (masked) then
            do l = 1, nl
              free(l) = merge(0.0_rp, 1.0_rp, fixedg(ip0 + l - 1, jp) .or. fixedg(iq0 + l - 1, jq2))
            end do
          end if
          call add_lane_blocks(nl, ld, lat%nx, size(st, 4), sl, ip0, blk(:, :, :, 3 * (pp - 1) + qq), masked, free, &
                               st(:, :, :, :, sp))
        end do
      end do
    end subroutine add_triple_lanes

    !> Write the whole block row of owned node (i0, j0) into the AIJ S: a m I
    !> minus the blocks of its links on the diagonal, the link blocks at the
    !> link neighbours, zero elsewhere in the stencil (constraints as above).
    subroutine put_row(i0, j0)
      integer, intent(in) :: i0, j0
      integer :: di, dj, nc, kk, r, pa, pb, m, hw
      logical :: fixed_row, owned_blk(25)
      real(rp) :: dsum(3, 3), blk(3, 3), vals(3, 3, 25)   ! the blocks of a halo-2 stencil at most
      hw = lat%halo
      fixed_row = fixedg(i0, j0)
      dsum = 0.0_rp
      nc = 0
      do dj = -hw, hw
        if (j0 + dj < 0 .or. j0 + dj >= lat%ny) cycle
        do di = -hw, hw
          if (i0 + di < 0 .or. i0 + di >= lat%nx) cycle
          nc = nc + 1
          owned_blk(nc) = j0 + dj >= lat%ys .and. j0 + dj <= lat%ye
          vals(:, :, nc) = 0.0_rp
          if (max(abs(di), abs(dj)) /= 1) cycle
          blk = link_block(i0, j0, di, dj)
          dsum = dsum + blk
          if (.not. (fixed_row .or. fixedg(i0 + di, j0 + dj))) vals(:, :, nc) = blk
        end do
      end do
      ! The diagonal block: index of (0, 0) among the blocks.
      m = (min(hw, j0) ) * (min(hw, lat%nx - 1 - i0) + min(hw, i0) + 1) + min(hw, i0) + 1
      if (fixed_row) dsum = 0.0_rp
      vals(:, :, m) = -dsum
      do r = 1, 3
        vals(r, r, m) = vals(r, r, m) + a * lat%mass(i0, j0)
      end do
      if (lat%nodal%n > 0) then
        do r = lat%nodal%row_start(j0), lat%nodal%row_start(j0 + 1) - 1
          if (lat%nodal%col(r) == i0) vals(:, :, m) = vals(:, :, m) - lat%nodal%kv(:, :, r) - rinv * lat%nodal%kx(:, :, r)
        end do
      end if
      do r = 0, 2
        pa = ia(3 * (i0 + (j0 - lat%ys) * lat%nx) + r)
        pb = 0
        if (size(ib) > 0) pb = ib(3 * (i0 + (j0 - lat%ys) * lat%nx) + r)
        do kk = 1, nc
          if (owned_blk(kk)) then
            av(pa:pa + 2) = vals(r + 1, :, kk)
            pa = pa + 3
          else
            bv(pb:pb + 2) = vals(r + 1, :, kk)
            pb = pb + 3
          end if
        end do
      end do
    end subroutine put_row

    !> Block (p, q) of a bending triple with nodes n(:, 1..3), from its
    !> 9 x 9 matrices: kk = dF_p/dx_q, cc = dF_p/dv_q (rows and columns
    !> 3p-2:3p, 3q-2:3q). S gets -(cc + kk/a) in row p, column q,
    !> g_p gets -(kk w_x(q) + cc w_v(q)), kd_p the diagonal of -kk.
    subroutine add_element_block(n, p, q, k9, c9)
      integer, intent(in) :: n(:, :), p, q
      real(rp), intent(in) :: k9(9, 9), c9(9, 9)
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
          blk(l, m) = -(c9(r0 + l, c0 + m) + rinv * k9(r0 + l, c0 + m))
        end do
      end do
      call add_block(ip, jp, iq2 - ip, jq2 - jp, blk)
    end subroutine add_element_block
    !> The kept block c + k/a of the link from node (i0, j0) to its
    !> neighbour (i0 + di, j0 + dj): a link is anchored at its lower end.
    function link_block(i0, j0, di, dj) result(blk)
      integer, intent(in) :: i0, j0, di, dj
      real(rp) :: blk(3, 3)
      if (dj > 0 .or. (dj == 0 .and. di > 0)) then
        blk = lb(i0, :, :, link_index(di, dj), modulo(j0, 2))
      else
        blk = lb(i0 + di, :, :, link_index(-di, -dj), modulo(j0 + dj, 2))
      end if
    end function link_block

    !> The nine blocks of an energy-bending triple with nodes n(:, 1..3)
    !> from its Jacobians in the edge variables, K9 = T^T ke T, C9 = T^T ce T
    !> (e_a = sum_P t(a, P) x_P: e1 = x_q - x_p, e2 = x_r - x_q), combined
    !> there first: S_PQ gets sum_ab t(a, P) t(b, Q) m_ab with
    !> m = -(ce + ke/a), g_P gets -(T^T (ke T w_x + ce T w_v))_P, kd_P the
    !> diagonal of -K9_PP. (Two 9 x 9 matrices and their 81-entry blocks are
    !> never formed: a third of the bending assembly.)
    subroutine add_triple_edges(n, ke, ce)
      integer, intent(in) :: n(:, :)
      real(rp), intent(in) :: ke(6, 6), ce(6, 6)
      integer, parameter :: t(2, 3) = reshape([-1, 0, 1, -1, 0, 1], [2, 3])
      real(rp) :: m(6, 6), ewx(6), ewv(6), h(6), tm(3, 6, 3), blk(3, 3)
      integer :: pp, qq, ip, jp, iq2, jq2, l
      m = -(ce + rinv * ke)
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
          call add_block(ip, jp, iq2 - ip, jq2 - jp, blk)
        end do
      end do
    end subroutine add_triple_edges

    !> S(node (ip, jp), node (ip + di, jp + dj)) += blk.
    subroutine add_block(ip, jp, di, dj, blk)
      integer, intent(in) :: ip, jp, di, dj
      real(rp), intent(in) :: blk(3, 3)
      integer :: pos(0:2), r
      logical :: diag
      if (.not. write_s) return
      if (present(st)) then
        st(ip, :, :, kof(di, dj), srow(jp)) = st(ip, :, :, kof(di, dj), srow(jp)) + blk
        return
      end if
      call csr_block_pos(lat, ia, ib, ip, jp, di, dj, pos, diag)
      if (diag) then
        do r = 0, 2
          av(pos(r):pos(r) + 2) = av(pos(r):pos(r) + 2) + blk(r + 1, :)
        end do
      else
        do r = 0, 2
          bv(pos(r):pos(r) + 2) = bv(pos(r):pos(r) + 2) + blk(r + 1, :)
        end do
      end if
    end subroutine add_block

  end subroutine assemble_rows

  !> The block row of owned node (i, j) of an AIJ S in this layout, as full
  !> blocks blk(3, 3, -w:w, -w:w) = S(p, p + (di, dj)), zero outside the
  !> lattice (w = lat%halo).
  subroutine csr_row_blocks(lat, ia, av, ib, bv, i, j, blk)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ia(0:), ib(0:)
    real(rp), intent(in) :: av(0:), bv(0:)
    integer, intent(in) :: i, j
    real(rp), intent(out) :: blk(:, :, -lat%halo:, -lat%halo:)
    integer :: di, dj, pos(0:2), r
    logical :: diag
    blk = 0.0_rp
    do dj = max(-lat%halo, -j), min(lat%halo, lat%ny - 1 - j)
      do di = max(-lat%halo, -i), min(lat%halo, lat%nx - 1 - i)
        call csr_block_pos(lat, ia, ib, i, j, di, dj, pos, diag)
        do r = 0, 2
          if (diag) then
            blk(r + 1, :, di, dj) = av(pos(r):pos(r) + 2)
          else
            blk(r + 1, :, di, dj) = bv(pos(r):pos(r) + 2)
          end if
        end do
      end do
    end do
  end subroutine csr_row_blocks

  !> The nine node blocks B(P, Q) = sum_ab t(a, P) t(b, Q) m_ab of nl
  !> bending triples (T = [[-I, I, 0], [0, -I, I]], m = -(ce + ke/a), m_ab
  !> its 3 x 3 quarter of edges a, b), by lanes: blk(:, :, :, 3 (P - 1) + Q).
  !> T's entries are -1, 0 and 1, so each block is a sum of one to four
  !> quarters: B11 = m11, B12 = m12 - m11, B13 = -m12, B21 = m21 - m11,
  !> B22 = m11 - m12 - m21 + m22, B23 = m12 - m22, B31 = -m21,
  !> B32 = m21 - m22, B33 = m22.
  pure subroutine triple_node_blocks(nl, ld, rinv, ke, ce, blk)
    integer, intent(in) :: nl, ld
    real(rp), intent(in) :: rinv                   ! 1/a [time]
    real(rp), intent(in) :: ke(ld, 6, 6), ce(ld, 6, 6)
    real(rp), intent(out) :: blk(ld, 3, 3, 9)
    integer :: l, c1, c2
    real(rp) :: m11, m12, m21, m22
    do c2 = 1, 3
      do c1 = 1, 3
        do l = 1, nl
          m11 = -(ce(l, c1, c2) + rinv * ke(l, c1, c2))
          m12 = -(ce(l, c1, 3 + c2) + rinv * ke(l, c1, 3 + c2))
          m21 = -(ce(l, 3 + c1, c2) + rinv * ke(l, 3 + c1, c2))
          m22 = -(ce(l, 3 + c1, 3 + c2) + rinv * ke(l, 3 + c1, 3 + c2))
          blk(l, c1, c2, 1) = m11
          blk(l, c1, c2, 2) = m12 - m11
          blk(l, c1, c2, 3) = -m12
          blk(l, c1, c2, 4) = m21 - m11
          blk(l, c1, c2, 5) = (m11 - m12) + (m22 - m21)
          blk(l, c1, c2, 6) = m12 - m22
          blk(l, c1, c2, 7) = -m21
          blk(l, c1, c2, 8) = m21 - m22
          blk(l, c1, c2, 9) = m22
        end do
      end do
    end do
  end subroutine triple_node_blocks

  !> Add the blocks b(l, :, :) (times free(l) where masked) to slot sl of
  !> nl consecutive nodes ip0.. of a row of S by stencil offset (node
  !> blocks of nl bending triples), nodes fastest, as S keeps them: one
  !> vector loop for each entry; with S node by node these adds were
  !> scalar, 3 % of a bw step with bending. Explicit shapes, as
  !> put_link_blocks.
  pure subroutine add_lane_blocks(nl, ld, nx, nslot, sl, ip0, b, masked, free, dst)
    integer, intent(in) :: nl, ld, nx, nslot, sl, ip0
    real(rp), intent(in) :: b(ld, 3, 3), free(ld)
    logical, intent(in) :: masked
    real(rp), intent(inout) :: dst(0:nx - 1, 3, 3, nslot)
    integer :: l, c1, c2
    do c2 = 1, 3
      do c1 = 1, 3
        if (masked) then
          do l = 1, nl
            dst(ip0 + l - 1, c1, c2, sl) = dst(ip0 + l - 1, c1, c2, sl) + free(l) * b(l, c1, c2)
          end do
        else
          do l = 1, nl
            dst(ip0 + l - 1, c1, c2, sl) = dst(ip0 + l - 1, c1, c2, sl) + b(l, c1, c2)
          end do
        end if
      end do
    end do
  end subroutine add_lane_blocks

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

  !> put_rows_st's work for one offset (di, dj) of a row, i = ilo..ihi: the
  !> link's block src(i + dil, :, k) into S's slot sl of node i, or zero to or
  !> from a constrained node (fixed_p(i), fixed_q(i + di)), and subtracted
  !> from the diagonal slot sd. Explicit shapes: over the assumed-shape
  !> arrays, each nine-entry copy went through the compiler's general
  !> strided loop.
  pure subroutine put_link_blocks(nx, nslot, ilo, ihi, di, dil, k, src, fixed_p, fixed_q, sl, sd, dst)
    integer, intent(in) :: nx, nslot, ilo, ihi, di, dil, k, sl, sd
    real(rp), intent(in) :: src(0:nx - 1, 9, 4)      !< the link blocks kept at their lower ends
    logical, intent(in) :: fixed_p(0:nx - 1), fixed_q(0:nx - 1)
    real(rp), intent(inout) :: dst(0:nx - 1, 9, nslot)
    integer :: i, e
    real(rp) :: keep(0:nx - 1)
    ! the test once per node, as a factor 1 or 0 (inside the loop over the
    ! entries it was compiled into a gather of fixed_q for every entry, a
    ! quarter of csr_assemble's own time without bending; a logical mask
    ! there, into scalar branches)
    do i = ilo, ihi
      keep(i) = merge(0.0_rp, 1.0_rp, fixed_p(i) .or. fixed_q(i + di))
    end do
    do e = 1, 9
      do i = ilo, ihi
        dst(i, e, sd) = dst(i, e, sd) - src(i + dil, e, k)
        dst(i, e, sl) = keep(i) * src(i + dil, e, k)
      end do
    end do
  end subroutine put_link_blocks

  !> Index k of link_dir for the direction (di, dj) of a link from its anchor.
  pure integer function link_index(di, dj) result(k)
    integer, intent(in) :: di, dj
    do k = 1, 4
      if (link_dir(1, k) == di .and. link_dir(2, k) == dj) return
    end do
    k = 0
  end function link_index

end module reduced_assembly
