! SPDX-License-Identifier: BSD-2-Clause
!> Loops over the elements of one strip: internal forces, element energies,
!> dissipated power and the Jacobian blocks of one anchor row. Plain arrays
!> in and out (no PETSc, no MPI); the per-element work is done by the kernels
!> (springs, bending_paper, bending_energy). See module lattice for the index
!> convention and the anchor rule.
module forces
  use kinds, only: rp
  use config, only: BEND_NONE, BEND_PAPER, BEND_ENERGY
  use lattice, only: lattice_t, link_dir, line_dir, link_constants, link_lane_constants, triple_constants
  use springs, only: link_force_lanes, link_jacobian, link_energy, link_power_lanes
  use bending_paper, only: paper_force, paper_jacobian, paper_energy
  use bending_energy, only: energy_force_lanes, energy_jacobian, energy_bend_energy, energy_power_lanes
  use node_blocks, only: node_blocks_t, node_blocks_count, node_blocks_sub_diagonal
  implicit none
  private
  public :: internal_forces, element_energies, dissipated_power
  public :: jac_buffer_t, jac_buffer_init, jac_buffer_row, slot_of
  public :: first_anchor_row, link_stretch_extremes, triple_lane_range, TRIPLE_LANES
  public :: link_lane_range, link_lanes, triple_lane_setup, triple_lane_edges, rest_link, triple_at
  public :: RING_ROWS, ring_load, ring_link_diffs, ring_triple_edges

  !> Jacobian blocks of the v-rows of three consecutive node rows (a rolling
  !> buffer indexed by slot_of(j)): k(:,:,di,dj,i,s) = dF_v(i,j)/dx(i+di,j+dj)
  !> = -df/dx, c(...) = dF_v/dv = -df/dv, without the mass term.
  type :: jac_buffer_t
    integer :: w = 1                      !< stencil half-width (halo)
    real(rp), allocatable :: k(:, :, :, :, :, :)  !< (3,3,-w:w,-w:w,0:nx-1,0:2)
    real(rp), allocatable :: c(:, :, :, :, :, :)  !< (3,3,-w:w,-w:w,0:nx-1,0:2)
  end type jac_buffer_t

  !> Triples of one direction taken at once by the vectorised bending
  !> kernels (energy_force_lanes, energy_jacobian_lanes).
  integer, parameter :: TRIPLE_LANES = 32

  !> Rows of an array in the state's layout (0:5, 0:nx-1, rows) kept along
  !> x fastest in a ring s(0:nx-1, 0:5, 0:RING_ROWS-1), row j in slot
  !> modulo(j, RING_ROWS): the element loops take their lanes' differences
  !> from it in vector loops (ring_link_diffs, ring_triple_edges), where
  !> from the state itself each was a gather of stride 6 (4 % of a
  !> Baraff-Witkin step without bending); each row is transposed
  !> once for the 4 to 12 lanes that read it. 4 rows: the links anchored at
  !> row j and the triples anchored up to two rows below reach j - 2 .. j + 1
  !> (module reduced_assembly), those anchored at j reach j .. j + 2.
  integer, parameter :: RING_ROWS = 4

contains

  !> The triples p, p + s, p + 2 s anchored at row j0 along s = line_dir(:, k)
  !> that touch the owned rows: i = ilo..ihi (none when ihi < ilo).
  pure subroutine triple_lane_range(lat, j0, k, ilo, ihi)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: j0, k
    integer, intent(out) :: ilo, ihi
    integer :: jr
    jr = j0 + 2 * line_dir(2, k)
    ilo = max(0, -2 * line_dir(1, k))
    ihi = min(lat%nx - 1, lat%nx - 1 - 2 * line_dir(1, k))
    if (jr >= lat%ny .or. jr < lat%ys) ihi = ilo - 1
  end subroutine triple_lane_range

  !> The links anchored at row j0 along link_dir(:, k) whose far end lies in
  !> the lattice and in a row this rank holds (jq >= ys): anchors
  !> ilo..ihi (none when ihi < ilo), far ends in row jq.
  pure subroutine link_lane_range(lat, j0, k, ilo, ihi, jq)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: j0, k
    integer, intent(out) :: ilo, ihi, jq
    jq = j0 + link_dir(2, k)
    ilo = max(0, -link_dir(1, k))
    ihi = min(lat%nx - 1, lat%nx - 1 - link_dir(1, k))
    if (jq >= lat%ny .or. jq < lat%ys) ihi = ilo - 1
  end subroutine link_lane_range

  !> Row j of a (0:5, 0:nx-1, gys:gye) into its slot of the ring s unless
  !> tag says it is there already (tag(slot) = row held; -huge(1) for none).
  pure subroutine ring_load(lat, a, j, s, tag)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: a(0:, 0:, lat%gys:)    !< (0:5, 0:nx-1, gys:gye)
    integer, intent(in) :: j
    real(rp), intent(inout) :: s(0:, 0:, 0:)       !< (0:nx-1, 0:5, 0:RING_ROWS-1)
    integer, intent(inout) :: tag(0:RING_ROWS - 1)
    integer :: sl, i, c
    if (j < lat%gys .or. j > lat%gye) return
    sl = modulo(j, RING_ROWS)
    if (tag(sl) == j) return
    do i = 0, lat%nx - 1
      do c = 0, 5
        s(i, c, sl) = a(c, i, j)
      end do
    end do
    tag(sl) = j
  end subroutine ring_load

  !> The differences of the nl links anchored at (i0 + l - 1, j0) along
  !> link_dir(:, k), from the ring s (rows j0 and j0 + link_dir(2, k)
  !> loaded): d = a_p - a_q of positions, dv of velocities, by lanes
  !> (leading dimension ld), as the lane kernels take them.
  pure subroutine ring_link_diffs(nx, s, j0, k, i0, nl, ld, d, dv)
    integer, intent(in) :: nx, j0, k, i0, nl, ld
    real(rp), intent(in) :: s(0:nx - 1, 0:5, 0:RING_ROWS - 1)
    real(rp), intent(out) :: d(ld, 3), dv(ld, 3)
    integer :: l, c, dx, sp, sq
    dx = link_dir(1, k)
    sp = modulo(j0, RING_ROWS)
    sq = modulo(j0 + link_dir(2, k), RING_ROWS)
    do c = 1, 3
      do l = 1, nl
        d(l, c) = s(i0 + l - 1, c - 1, sp) - s(i0 + l - 1 + dx, c - 1, sq)
        dv(l, c) = s(i0 + l - 1, c + 2, sp) - s(i0 + l - 1 + dx, c + 2, sq)
      end do
    end do
  end subroutine ring_link_diffs

  !> Edges e1 = x_q - x_p, e2 = x_r - x_q and their rates de of the nl
  !> triples anchored at (i0 + l - 1, j0) along line_dir(:, k), from the
  !> ring s (rows j0 .. j0 + 2 line_dir(2, k) loaded), by lanes (leading
  !> dimension ld), as the lane kernels take them.
  pure subroutine ring_triple_edges(nx, s, j0, k, i0, nl, ld, e1, e2, de)
    integer, intent(in) :: nx, j0, k, i0, nl, ld
    real(rp), intent(in) :: s(0:nx - 1, 0:5, 0:RING_ROWS - 1)
    real(rp), intent(out) :: e1(ld, 3), e2(ld, 3), de(ld, 6)
    integer :: l, c, dx, sp, sq, sr, ip, iq, ir
    dx = line_dir(1, k)
    sp = modulo(j0, RING_ROWS)
    sq = modulo(j0 + line_dir(2, k), RING_ROWS)
    sr = modulo(j0 + 2 * line_dir(2, k), RING_ROWS)
    do c = 1, 3
      do l = 1, nl
        ip = i0 + l - 1
        iq = ip + dx
        ir = iq + dx
        e1(l, c) = s(iq, c - 1, sq) - s(ip, c - 1, sp)
        e2(l, c) = s(ir, c - 1, sr) - s(iq, c - 1, sq)
        de(l, c) = s(iq, c + 2, sq) - s(ip, c + 2, sp)
        de(l, c + 3) = s(ir, c + 2, sr) - s(iq, c + 2, sq)
      end do
    end do
  end subroutine ring_triple_edges

  !> The next nl <= ld links anchored at (i0 + l - 1, j0) along
  !> link_dir(:, k), up to anchor ihi: their constants e, eta
  !> (link_lane_constants) and differences d, dv from the ring s
  !> (ring_link_diffs), by lanes, as the lane kernels take them.
  pure subroutine link_lanes(lat, s, j0, k, i0, ihi, ld, nl, e, eta, d, dv)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: s(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)
    integer, intent(in) :: j0, k, i0, ihi, ld
    integer, intent(out) :: nl
    real(rp), intent(out) :: e(ld), eta(ld), d(ld, 3), dv(ld, 3)
    nl = min(ld, ihi - i0 + 1)
    call link_lane_constants(lat, j0, k, i0, nl, ld, e, eta)
    call ring_link_diffs(lat%nx, s, j0, k, i0, nl, ld, d, dv)
  end subroutine link_lanes

  !> The triples anchored at row j0 along line_dir(:, k) that touch the
  !> owned rows, i = ilo..ihi (triple_lane_range), and their bending
  !> stiffness and damping (triple_constants).
  pure subroutine triple_lane_setup(lat, j0, k, ilo, ihi, kb, etab)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: j0, k
    integer, intent(out) :: ilo, ihi
    real(rp), intent(out) :: kb, etab
    call triple_lane_range(lat, j0, k, ilo, ihi)
    call triple_constants(lat, k, kb, etab)
  end subroutine triple_lane_setup

  !> The next nl <= ld triples anchored at (i0 + l - 1, j0) along
  !> line_dir(:, k), up to anchor ihi: their edges and rates from the ring
  !> s (ring_triple_edges).
  pure subroutine triple_lane_edges(nx, s, j0, k, i0, ihi, ld, nl, e1, e2, de)
    integer, intent(in) :: nx, j0, k, i0, ihi, ld
    real(rp), intent(in) :: s(0:nx - 1, 0:5, 0:RING_ROWS - 1)
    integer, intent(out) :: nl
    real(rp), intent(out) :: e1(ld, 3), e2(ld, 3), de(ld, 6)
    nl = min(ld, ihi - i0 + 1)
    call ring_triple_edges(nx, s, j0, k, i0, nl, ld, e1, e2, de)
  end subroutine triple_lane_edges

  !> Count the lanes whose element is singular (okl false) in nbad, and
  !> keep the anchor (i0 + l - 1, j0) of the last of them in bad.
  pure subroutine note_bad(nl, okl, i0, j0, nbad, bad)
    integer, intent(in) :: nl, i0, j0
    logical, intent(in) :: okl(:)
    integer, intent(inout) :: nbad, bad(2)
    integer :: l
    do l = 1, nl
      if (okl(l)) cycle
      nbad = nbad + 1
      bad = [i0 + l - 1, j0]
    end do
  end subroutine note_bad


  !> Lowest anchor row whose elements touch row ys.
  pure integer function first_anchor_row(lat)
    type(lattice_t), intent(in) :: lat
    first_anchor_row = max(0, lat%ys - lat%halo)
  end function first_anchor_row

  !> Slot of node row j in the rolling Jacobian buffer.
  pure integer function slot_of(j)
    integer, intent(in) :: j
    slot_of = modulo(j, 3)
  end function slot_of

  !> Rest vector X_p - X_q and rest length of a link p -> p + s.
  pure subroutine rest_link(lat, s, d0, len0)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: s(2)
    real(rp), intent(out) :: d0(3), len0
    d0 = [-real(s(1), rp) * lat%ax, -real(s(2), rp) * lat%ay, 0.0_rp]
    len0 = norm2(d0)
  end subroutine rest_link

  !> True when node (i, j) exists.
  pure logical function inside(lat, i, j)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j
    inside = i >= 0 .and. i < lat%nx .and. j >= 0 .and. j < lat%ny
  end function inside

  !> Far end (iq, jq) of the link from anchor (i, j) along link_dir(:, k);
  !> false when it lies outside the lattice.
  pure subroutine link_end(lat, i, j, k, iq, jq, ok)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j, k
    integer, intent(out) :: iq, jq
    logical, intent(out) :: ok
    iq = i + link_dir(1, k)
    jq = j + link_dir(2, k)
    ok = inside(lat, iq, jq)
  end subroutine link_end

  !> The triple from anchor (i, j) along line_dir(:, k), one at a time:
  !> its nodes n(:, 1..3) = (i, j) + (0, 1, 2) line_dir(:, k), their
  !> positions x9 from u(0:5, 0:nx-1, gys:gye) and its bending constants
  !> (triple_constants); false when its far end lies outside the lattice
  !> or below row ys (then the rest is not set).
  pure subroutine triple_at(lat, u, i, j, k, n, x9, kb, etab, ok)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: i, j, k
    integer, intent(out) :: n(2, 3)
    real(rp), intent(out) :: x9(9), kb, etab
    logical, intent(out) :: ok
    n(:, 1) = [i, j]
    n(:, 2) = n(:, 1) + line_dir(:, k)
    n(:, 3) = n(:, 2) + line_dir(:, k)
    ok = inside(lat, n(1, 3), n(2, 3)) .and. n(2, 3) >= lat%ys
    if (.not. ok) return
    call triple_constants(lat, k, kb, etab)
    x9 = [u(0:2, i, j), u(0:2, n(1, 2), n(2, 2)), u(0:2, n(1, 3), n(2, 3))]
  end subroutine triple_at

  !> Internal forces f(3, 0:nx-1, gys:gye) [force] of all elements touching
  !> the owned rows, from the state u(0:5, 0:nx-1, gys:gye). Entries of ghost
  !> rows are partial sums and must not be used. nbad counts elements whose
  !> geometry is singular (zero length, bending angle at pi); bad holds the
  !> anchor (i, j) of one of them.
  subroutine internal_forces(lat, u, f, nbad, bad)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(out) :: f(3, 0:lat%nx - 1, lat%gys:lat%gye)
    integer, intent(out) :: nbad, bad(2)
    integer :: i, j, k, jr
    real(rp) :: d0(3, 4), len0(4), kb, etab
    real(rp) :: us(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)   ! rows of u, x fastest (ring_load)
    integer :: tag(0:RING_ROWS - 1)

    f = 0.0_rp
    nbad = 0
    bad = -1
    tag = -huge(1)
    do k = 1, 4
      call rest_link(lat, link_dir(:, k), d0(:, k), len0(k))
    end do
    do j = first_anchor_row(lat), lat%ye
      do jr = j, j + 2
        call ring_load(lat, u, jr, us, tag)
      end do
      call link_row(j)
      if (lat%bending_model == BEND_PAPER) then
        do i = 0, lat%nx - 1
          call paper_triples(i, j)
        end do
      end if
      if (lat%bending_model == BEND_ENERGY) call energy_triples_row(j)
    end do

  contains

    !> The links anchored at row j0 (to the rows this rank holds), one
    !> direction NL at a time through the vectorised kernel (link_force_lanes).
    subroutine link_row(j0)
      integer, intent(in) :: j0
      integer, parameter :: NL = 32
      real(rp) :: el(NL), etal(NL), dd(NL, 3), vr(NL, 3), fl3(NL, 3)
      logical :: okl(NL)
      integer :: k, dx, jq0, ilo, ihi, i0, nl1, l, ii
      do k = 1, 4
        dx = link_dir(1, k)
        call link_lane_range(lat, j0, k, ilo, ihi, jq0)
        do i0 = ilo, ihi, NL
          call link_lanes(lat, us, j0, k, i0, ihi, NL, nl1, el, etal, dd, vr)
          call link_force_lanes(nl1, NL, lat%spring_model, el, etal, d0(:, k), len0(k), dd, vr, fl3, okl)
          call note_bad(nl1, okl, i0, j0, nbad, bad)
          do l = 1, nl1
            ii = i0 + l - 1
            f(:, ii, j0) = f(:, ii, j0) + fl3(l, :)
            f(:, ii + dx, jq0) = f(:, ii + dx, jq0) - fl3(l, :)
          end do
        end do
      end do
    end subroutine link_row

    !> Paper bending: the triples anchored at node (i, j), one at a time.
    subroutine paper_triples(i, j)
      integer, intent(in) :: i, j
      integer :: k, n(2, 3)
      real(rp) :: x9(9), f9(9), theta
      logical :: ok(1), inl
      do k = 1, 4
        call triple_at(lat, u, i, j, k, n, x9, kb, etab, inl)
        if (.not. inl) cycle
        call paper_force(kb, x9, f9, theta, ok(1))
        call note_bad(1, ok, i, j, nbad, bad)
        f(:, i, j) = f(:, i, j) + f9(1:3)
        f(:, n(1, 2), n(2, 2)) = f(:, n(1, 2), n(2, 2)) + f9(4:6)
        f(:, n(1, 3), n(2, 3)) = f(:, n(1, 3), n(2, 3)) + f9(7:9)
      end do
    end subroutine paper_triples

    !> Energy bending: the triples anchored at row j0, TRIPLE_LANES of one
    !> direction at a time through the vectorised kernel (energy_force_lanes).
    subroutine energy_triples_row(j0)
      integer, intent(in) :: j0
      integer, parameter :: NL = TRIPLE_LANES
      real(rp) :: e1(NL, 3), e2(NL, 3), de(NL, 6), fl9(NL, 9)
      logical :: okl(NL)
      integer :: k, dx, dy, ilo, ihi, i0, nl1, l, i
      do k = 1, 4
        dx = line_dir(1, k)
        dy = line_dir(2, k)
        call triple_lane_setup(lat, j0, k, ilo, ihi, kb, etab)
        do i0 = ilo, ihi, NL
          call triple_lane_edges(lat%nx, us, j0, k, i0, ihi, NL, nl1, e1, e2, de)
          call energy_force_lanes(nl1, NL, kb, etab, e1, e2, de, fl9, okl)
          call note_bad(nl1, okl, i0, j0, nbad, bad)
          do l = 1, nl1
            i = i0 + l - 1
            f(:, i, j0) = f(:, i, j0) + fl9(l, 1:3)
            f(:, i + dx, j0 + dy) = f(:, i + dx, j0 + dy) + fl9(l, 4:6)
            f(:, i + 2 * dx, j0 + 2 * dy) = f(:, i + 2 * dx, j0 + 2 * dy) + fl9(l, 7:9)
          end do
        end do
      end do
    end subroutine energy_triples_row
  end subroutine internal_forces

  !> Stretch and bending energy of the elements anchored on owned rows
  !> (so that a sum over ranks counts each element once).
  subroutine element_energies(lat, u, stretch, bend)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(out) :: stretch, bend
    integer :: i, j, k, iq, jq, n(2, 3)
    real(rp) :: d0(3, 4), len0(4), e, eta, x9(9), kb, etab
    logical :: inl

    stretch = 0.0_rp
    bend = 0.0_rp
    do k = 1, 4
      call rest_link(lat, link_dir(:, k), d0(:, k), len0(k))
    end do
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, 4
          call link_end(lat, i, j, k, iq, jq, inl)
          if (.not. inl) cycle
          call link_constants(lat, i, j, k, e, eta)
          stretch = stretch + link_energy(lat%spring_model, e, d0(:, k), len0(k), u(0:2, i, j), u(0:2, iq, jq))
        end do
      end do
    end do
    if (lat%bending_model == BEND_NONE) return
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, 4
          call triple_at(lat, u, i, j, k, n, x9, kb, etab, inl)
          if (.not. inl) cycle
          if (lat%bending_model == BEND_PAPER) then
            bend = bend + paper_energy(kb, x9)
          else
            bend = bend + energy_bend_energy(kb, x9)
          end if
        end do
      end do
    end do
  end subroutine element_energies

  !> Dissipated power [energy/time] of the elements anchored on owned rows:
  !> link dampers, and bending dampers of the energy model.
  subroutine dissipated_power(lat, u, power)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(out) :: power
    real(rp) :: kb, etab
    integer :: j, jr
    real(rp) :: us(0:lat%nx - 1, 0:5, 0:RING_ROWS - 1)   ! rows of u, x fastest (ring_load)
    integer :: tag(0:RING_ROWS - 1)

    power = 0.0_rp
    tag = -huge(1)
    do j = lat%ys, lat%ye
      do jr = j, j + 2
        call ring_load(lat, u, jr, us, tag)
      end do
      call link_power_row(j)
      if (lat%bending_model == BEND_ENERGY) call energy_power_row(j)
    end do

  contains

    !> The links anchored at row j0, NL of one direction at a time
    !> (link_power_lanes).
    subroutine link_power_row(j0)
      integer, intent(in) :: j0
      integer, parameter :: NL = 32
      real(rp) :: el(NL), etal(NL), dd(NL, 3), vr(NL, 3), pl(NL)
      integer :: k, jq0, ilo, ihi, i0, nl1
      do k = 1, 4
        call link_lane_range(lat, j0, k, ilo, ihi, jq0)
        do i0 = ilo, ihi, NL
          call link_lanes(lat, us, j0, k, i0, ihi, NL, nl1, el, etal, dd, vr)
          call link_power_lanes(nl1, NL, lat%spring_model, etal, dd, vr, pl)
          power = power + sum(pl(1:nl1))
        end do
      end do
    end subroutine link_power_row

    !> The energy-bending triples anchored at row j0, TRIPLE_LANES of one
    !> direction at a time (energy_power_lanes).
    subroutine energy_power_row(j0)
      integer, intent(in) :: j0
      integer, parameter :: NL = TRIPLE_LANES
      real(rp) :: e1(NL, 3), e2(NL, 3), de(NL, 6), pw(NL)
      logical :: okl(NL)
      integer :: k, ilo, ihi, i0, nl1
      do k = 1, 4
        call triple_lane_setup(lat, j0, k, ilo, ihi, kb, etab)
        if (etab == 0.0_rp) cycle
        do i0 = ilo, ihi, NL
          call triple_lane_edges(lat%nx, us, j0, k, i0, ihi, NL, nl1, e1, e2, de)
          call energy_power_lanes(nl1, NL, etab, e1, e2, de, pw, okl)
          power = power + sum(pw(1:nl1))
        end do
      end do
    end subroutine energy_power_row
  end subroutine dissipated_power

  !> Allocate the rolling buffer once (outside the time loop).
  subroutine jac_buffer_init(buf, lat)
    type(jac_buffer_t), intent(out) :: buf
    type(lattice_t), intent(in) :: lat
    buf%w = lat%halo
    allocate(buf%k(3, 3, -buf%w:buf%w, -buf%w:buf%w, 0:lat%nx - 1, 0:2))
    allocate(buf%c(3, 3, -buf%w:buf%w, -buf%w:buf%w, 0:lat%nx - 1, 0:2))
    buf%k = 0.0_rp
    buf%c = 0.0_rp
  end subroutine jac_buffer_init

  !> Add the Jacobian blocks of all elements anchored on row ja (that touch
  !> an owned row) to the buffer. After this call, row ja is complete.
  !> clamp drops the indefinite compression term of the springs and
  !> gauss_newton keeps only -k_b J^T J of energy bending (preconditioner use).
  subroutine jac_buffer_row(buf, lat, nodal, u, ja, clamp, gauss_newton)
    type(jac_buffer_t), intent(inout) :: buf
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal      !< forces on single nodes and quads (contact): their blocks
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    integer, intent(in) :: ja
    logical, intent(in) :: clamp, gauss_newton
    integer :: i, k, iq, jq, a, b, n(2, 3)
    real(rp) :: d0(3, 4), len0(4), e, eta, kl(3, 3), cl(3, 3), x9(9), v9(9), k9(9, 9), c9(9, 9), kb, etab
    logical :: ok, inl

    do k = 1, 4
      call rest_link(lat, link_dir(:, k), d0(:, k), len0(k))
    end do
    do i = 0, lat%nx - 1
      do k = 1, 4
        call link_end(lat, i, ja, k, iq, jq, inl)
        if (.not. inl) cycle
        if (jq < lat%ys) cycle
        call link_constants(lat, i, ja, k, e, eta)
        call link_jacobian(lat%spring_model, e, eta, d0(:, k), len0(k), u(0:2, i, ja), u(0:2, iq, jq), &
                           u(3:5, i, ja), u(3:5, iq, jq), clamp, kl, cl, ok)
        ! f_p depends on x_p through K and on x_q through -K; f_q = -f_p.
        call add_pair(i, ja, iq, jq, kl, cl)
      end do
      if (lat%bending_model == BEND_NONE) cycle
      do k = 1, 4
        call triple_at(lat, u, i, ja, k, n, x9, kb, etab, inl)
        if (.not. inl) cycle
        if (lat%bending_model == BEND_PAPER) then
          call paper_jacobian(kb, x9, k9, ok)
          c9 = 0.0_rp
        else
          v9 = [u(3:5, n(1, 1), n(2, 1)), u(3:5, n(1, 2), n(2, 2)), u(3:5, n(1, 3), n(2, 3))]
          call energy_jacobian(kb, etab, x9, v9, gauss_newton, k9, c9, ok)
        end if
        do a = 1, 3
          do b = 1, 3
            associate (dk => buf%k(:, :, n(1, b) - n(1, a), n(2, b) - n(2, a), n(1, a), slot_of(n(2, a))), &
                       dc => buf%c(:, :, n(1, b) - n(1, a), n(2, b) - n(2, a), n(1, a), slot_of(n(2, a))))
              dk = dk - k9(3*a - 2:3*a, 3*b - 2:3*b)
              if (lat%bending_model == BEND_ENERGY) dc = dc - c9(3*a - 2:3*a, 3*b - 2:3*b)
            end associate
          end do
        end do
      end do
    end do
    ! forces on single nodes and on a quad's nodes (contact): -df/dx, -df/dv
    ! on the node's diagonal and at its stencil neighbours
    if (node_blocks_count(nodal) > 0 .and. ja >= lat%ys) &
      call node_blocks_sub_diagonal(nodal, ja, buf%w, buf%k(:, :, :, :, :, slot_of(ja)), buf%c(:, :, :, :, :, slot_of(ja)))

  contains

    !> Blocks of one link p = (ip, jp), q = (iq2, jq2) with K = df_p/dx_p, C = df_p/dv_p.
    subroutine add_pair(ip, jp, iq2, jq2, kk, cc)
      integer, intent(in) :: ip, jp, iq2, jq2
      real(rp), intent(in) :: kk(3, 3), cc(3, 3)
      integer :: di, dj, sp, sq
      di = iq2 - ip
      dj = jq2 - jp
      sp = slot_of(jp)
      sq = slot_of(jq2)
      buf%k(:, :, 0, 0, ip, sp) = buf%k(:, :, 0, 0, ip, sp) - kk
      buf%k(:, :, di, dj, ip, sp) = buf%k(:, :, di, dj, ip, sp) + kk
      buf%k(:, :, 0, 0, iq2, sq) = buf%k(:, :, 0, 0, iq2, sq) - kk
      buf%k(:, :, -di, -dj, iq2, sq) = buf%k(:, :, -di, -dj, iq2, sq) + kk
      buf%c(:, :, 0, 0, ip, sp) = buf%c(:, :, 0, 0, ip, sp) - cc
      buf%c(:, :, di, dj, ip, sp) = buf%c(:, :, di, dj, ip, sp) + cc
      buf%c(:, :, 0, 0, iq2, sq) = buf%c(:, :, 0, 0, iq2, sq) - cc
      buf%c(:, :, -di, -dj, iq2, sq) = buf%c(:, :, -di, -dj, iq2, sq) + cc
    end subroutine add_pair

  end subroutine jac_buffer_row

  !> Largest and smallest stretch l/L of the links anchored in the owned
  !> rows (a link that crosses into a ghost row is seen by both ranks: no
  !> matter for extremes), with the anchor node and direction of each,
  !> at(:) = (i, j, k). u(0:5, 0:nx-1, gys:gye), ghost rows filled.
  pure subroutine link_stretch_extremes(lat, u, rmax, atmax, rmin, atmin)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(out) :: rmax, rmin
    integer, intent(out) :: atmax(3), atmin(3)
    real(rp) :: d0(3, 4), len0(4), r
    integer :: i, j, k, iq, jq
    logical :: inl
    do k = 1, 4
      call rest_link(lat, link_dir(:, k), d0(:, k), len0(k))
    end do
    rmax = -huge(1.0_rp)
    rmin = huge(1.0_rp)
    atmax = -1
    atmin = -1
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, 4
          call link_end(lat, i, j, k, iq, jq, inl)
          if (.not. inl) cycle
          r = norm2(u(0:2, iq, jq) - u(0:2, i, j)) / len0(k)
          if (r > rmax) then
            rmax = r
            atmax = [i, j, k]
          end if
          if (r < rmin) then
            rmin = r
            atmin = [i, j, k]
          end if
        end do
      end do
    end do
  end subroutine link_stretch_extremes

end module forces
