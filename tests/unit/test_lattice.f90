! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module lattice (and of the element enumeration of module
!> forces that follows its anchor rule), against hand-computed facts:
!> - the index convention: owned and ghost rows of a strip (halo 1 without
!>   bending, 2 with), the mass array's bounds, rest positions (i ax, j ay, 0);
!> - link_dir and line_dir: with their opposites they are the 8 neighbours,
!>   each once; the far end lies above the anchor (or to its right in the
!>   same row); enumerated from every anchor they give each eight-neighbour
!>   pair once, 4 nx ny - 3 nx - 3 ny + 2 links, and each line triple once,
!>   (nx-2) ny + nx (ny-2) + 2 (nx-2)(ny-2) triples (also through forces'
!>   link_lane_range and triple_lane_range);
!> - the links counted by their energy: with every node at the origin a
!>   linear link holds 1/2 E |d0|^2, so element_energies is a closed formula
!>   in the counts of x, y and diagonal links, on the whole lattice and
!>   summed over strips of several splits; with continuum scaling the
!>   structural links then hold Y lx ly whatever the resolution;
!> - on a randomly perturbed state, the stretch and bending energies of the
!>   strips of several splits sum to the whole lattice's, and each strip's
!>   forces on its owned rows equal the whole lattice's;
!> - masses: uniform M/(nx ny); area: corners 1/4 and edges 1/2 of an
!>   interior node, summing to M; continuum scaling takes area masses;
!> - continuum constants: E = Y (across/along), halved on the boundary,
!>   diagonals as given; k_b x (across/along) for x and y lines;
!>   link_lane_constants equals link_constants for every lane.
program test_lattice
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE, BEND_PAPER, BEND_ENERGY, SPRING_AXIAL, SPRING_LINEAR, &
                    SCALING_ELEMENT, SCALING_CONTINUUM, MASS_UNIFORM, MASS_AREA
  use lattice, only: lattice_t, lattice_init, link_dir, line_dir, link_constants, link_lane_constants, &
                     triple_constants, rest_position, node_mass, rest_strip, halo_width
  use forces, only: internal_forces, element_energies, link_lane_range, triple_lane_range
  use check, only: check_true, check_close, check_close_array, check_report, lattice_config, seed_random, perturbed_state
  implicit none

  call index_convention()
  call directions()
  call enumeration(5, 4)
  call enumeration(3, 7)
  call enumeration(9, 6)
  call counts_by_energy(SCALING_ELEMENT)
  call counts_by_energy(SCALING_CONTINUUM)
  call strips_sum_to_whole(BEND_NONE, SPRING_AXIAL, SCALING_ELEMENT)
  call strips_sum_to_whole(BEND_PAPER, SPRING_AXIAL, SCALING_ELEMENT)
  call strips_sum_to_whole(BEND_ENERGY, SPRING_AXIAL, SCALING_CONTINUUM)
  call strips_sum_to_whole(BEND_ENERGY, SPRING_LINEAR, SCALING_ELEMENT)
  call masses()
  call continuum_constants()
  call check_report()

contains

  !> A configuration of nx x ny nodes over lx x ly with distinct constants.
  function make_cfg(nx, ny, lx, ly, bending, spring, scaling) result(cfg)
    integer, intent(in) :: nx, ny, bending, spring, scaling
    real(rp), intent(in) :: lx, ly
    type(nuno_config) :: cfg
    cfg = lattice_config(nx, ny, lx, ly, 0.3_rp, 7.0_rp, 3.0_rp, 0.2_rp, bending, spring, scaling)
  end function make_cfg

  !> Owned and ghost rows, array bounds, rest positions.
  subroutine index_convention()
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    integer, parameter :: nx = 7, ny = 9
    integer :: strips(2, 5), s, b, i, j, h
    integer, parameter :: bend(3) = [BEND_NONE, BEND_PAPER, BEND_ENERGY]
    real(rp), allocatable :: xs(:, :, :)
    logical :: ok
    character(80) :: what
    strips = reshape([0, 8, 0, 0, 1, 2, 4, 7, 8, 8], [2, 5])
    do b = 1, 3
      cfg = make_cfg(nx, ny, 3.0_rp, 2.0_rp, bend(b), SPRING_AXIAL, SCALING_ELEMENT)
      h = merge(1, 2, bend(b) == BEND_NONE)
      call check_true(halo_width(cfg) == h, 'halo width: 1 without bending, 2 with')
      do s = 1, 5
        write(what, '(a,i0,a,i0,a,i0)') 'strip ', strips(1, s), '..', strips(2, s), ' bending ', bend(b)
        call lattice_init(lat, cfg, strips(1, s), strips(2, s))
        call check_true(lat%nx == nx .and. lat%ny == ny .and. lat%ys == strips(1, s) .and. &
                        lat%ye == strips(2, s) .and. lat%halo == h, trim(what)//': sizes and owned rows')
        call check_true(lat%gys == max(0, strips(1, s) - h) .and. lat%gye == min(ny - 1, strips(2, s) + h), &
                        trim(what)//': ghost rows')
        call check_true(lbound(lat%mass, 1) == 0 .and. ubound(lat%mass, 1) == nx - 1 .and. &
                        lbound(lat%mass, 2) == lat%gys .and. ubound(lat%mass, 2) == lat%gye, &
                        trim(what)//': mass(0:nx-1, gys:gye)')
        call check_true(all(shape(rest_strip(lat)) == [3, nx, lat%ye - lat%ys + 1]), &
                        trim(what)//': rest_strip shape (3, nx, owned rows)')
        if (allocated(xs)) deallocate(xs)
        allocate(xs(3, 0:nx - 1, lat%ys:lat%ye))
        xs = rest_strip(lat)   ! keeps xs's bounds
        ok = .true.
        do j = lat%ys, lat%ye
          do i = 0, nx - 1
            ! ax = 0.5, ay = 0.25: exact in binary
            ok = ok .and. all(xs(:, i, j) == [0.5_rp * i, 0.25_rp * j, 0.0_rp])
            ok = ok .and. all(rest_position(lat, i, j) == [0.5_rp * i, 0.25_rp * j, 0.0_rp])
          end do
        end do
        call check_true(ok, trim(what)//': rest position (i ax, j ay, 0)')
      end do
    end do
  end subroutine index_convention

  !> link_dir and line_dir with their opposites are the 8 neighbours, each
  !> once; the far end is in a higher row or to the right in the same row.
  subroutine directions()
    integer :: seen_link(-1:1, -1:1), seen_line(-1:1, -1:1), k
    seen_link = 0
    seen_line = 0
    do k = 1, 4
      seen_link(link_dir(1, k), link_dir(2, k)) = seen_link(link_dir(1, k), link_dir(2, k)) + 1
      seen_link(-link_dir(1, k), -link_dir(2, k)) = seen_link(-link_dir(1, k), -link_dir(2, k)) + 1
      seen_line(line_dir(1, k), line_dir(2, k)) = seen_line(line_dir(1, k), line_dir(2, k)) + 1
      seen_line(-line_dir(1, k), -line_dir(2, k)) = seen_line(-line_dir(1, k), -line_dir(2, k)) + 1
      call check_true(link_dir(2, k) > 0 .or. (link_dir(2, k) == 0 .and. link_dir(1, k) > 0), &
                      'link far end above the anchor or right of it in its row')
      call check_true(line_dir(2, k) > 0 .or. (line_dir(2, k) == 0 .and. line_dir(1, k) > 0), &
                      'triple far end above the anchor or right of it in its row')
    end do
    call check_true(seen_link(0, 0) == 0 .and. count(seen_link == 1) == 8, 'link directions: 8 neighbours once')
    call check_true(seen_line(0, 0) == 0 .and. count(seen_line == 1) == 8, 'line directions: 8 neighbours once')
    ! structural first, then diagonals (link_constants' k <= 2 test)
    call check_true(all(abs(link_dir(1, 1:2)) + abs(link_dir(2, 1:2)) == 1) .and. &
                    all(abs(link_dir(1, 3:4)) + abs(link_dir(2, 3:4)) == 2), 'links 1, 2 structural, 3, 4 diagonal')
    call check_true(link_dir(2, 1) == 0 .and. link_dir(1, 2) == 0, 'link 1 along x, link 2 along y')
    call check_true(line_dir(2, 1) == 0 .and. line_dir(1, 2) == 0, 'line 1 along x, line 2 along y')
  end subroutine directions

  !> Links and triples enumerated from every anchor: each pair of
  !> eight-neighbours once, each line triple once; closed-form counts.
  subroutine enumeration(nx, ny)
    integer, intent(in) :: nx, ny
    integer :: hits(0:nx * ny - 1, 0:nx * ny - 1), thits(0:nx * ny - 1, 4)
    integer :: i, j, k, iq, jq, ir, jr, p, q, nlinks, ntrip, nlane, ilo, ihi, jq0, kk, di, dj, nexp
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    character(40) :: what
    write(what, '(i0,a,i0)') nx, ' x ', ny
    hits = 0
    thits = 0
    nlinks = 0
    ntrip = 0
    do j = 0, ny - 1
      do i = 0, nx - 1
        p = i + nx * j
        do k = 1, 4
          iq = i + link_dir(1, k)
          jq = j + link_dir(2, k)
          if (iq >= 0 .and. iq < nx .and. jq >= 0 .and. jq < ny) then
            q = iq + nx * jq
            hits(min(p, q), max(p, q)) = hits(min(p, q), max(p, q)) + 1
            nlinks = nlinks + 1
          end if
          ir = i + 2 * line_dir(1, k)
          jr = j + 2 * line_dir(2, k)
          if (ir >= 0 .and. ir < nx .and. jr >= 0 .and. jr < ny) then
            q = (i + line_dir(1, k)) + nx * (j + line_dir(2, k))   ! the middle node
            thits(q, k) = thits(q, k) + 1
            ntrip = ntrip + 1
          end if
        end do
      end do
    end do
    ! every pair of distinct nodes at Chebyshev distance 1 once, no other
    nexp = 0
    do p = 0, nx * ny - 1
      do q = p + 1, nx * ny - 1
        di = abs(mod(p, nx) - mod(q, nx))
        dj = abs(p / nx - q / nx)
        if (max(di, dj) == 1) then
          nexp = nexp + 1
          if (hits(p, q) /= 1) call check_true(.false., trim(what)//': an eight-neighbour pair not linked once')
        else if (hits(p, q) /= 0) then
          call check_true(.false., trim(what)//': a link between non-neighbours')
        end if
      end do
    end do
    call check_true(nlinks == 4 * nx * ny - 3 * nx - 3 * ny + 2 .and. nexp == nlinks, &
                    trim(what)//': 4 nx ny - 3 nx - 3 ny + 2 links')
    ! each middle node and line once, where both neighbours on the line exist
    do q = 0, nx * ny - 1
      i = mod(q, nx)
      j = q / nx
      call check_true(thits(q, 1) == merge(1, 0, i > 0 .and. i < nx - 1), trim(what)//': x-line triples')
      call check_true(thits(q, 2) == merge(1, 0, j > 0 .and. j < ny - 1), trim(what)//': y-line triples')
      do k = 3, 4
        call check_true(thits(q, k) == merge(1, 0, i > 0 .and. i < nx - 1 .and. j > 0 .and. j < ny - 1), &
                        trim(what)//': diagonal-line triples')
      end do
    end do
    call check_true(ntrip == (nx - 2) * ny + nx * (ny - 2) + 2 * (nx - 2) * (ny - 2), &
                    trim(what)//': (nx-2) ny + nx (ny-2) + 2 (nx-2)(ny-2) triples')

    ! the same counts from forces' lane ranges on the whole lattice
    if (nx >= 3) then
      cfg = make_cfg(nx, ny, 1.0_rp, 1.0_rp, BEND_ENERGY, SPRING_AXIAL, SCALING_ELEMENT)
      call lattice_init(lat, cfg, 0, ny - 1)
      nlane = 0
      do j = 0, ny - 1
        do kk = 1, 4
          call link_lane_range(lat, j, kk, ilo, ihi, jq0)
          nlane = nlane + max(0, ihi - ilo + 1)
        end do
      end do
      call check_true(nlane == nlinks, trim(what)//': links by link_lane_range')
      nlane = 0
      do j = 0, ny - 1
        do kk = 1, 4
          call triple_lane_range(lat, j, kk, ilo, ihi)
          nlane = nlane + max(0, ihi - ilo + 1)
        end do
      end do
      call check_true(nlane == ntrip, trim(what)//': triples by triple_lane_range')
    end if
  end subroutine enumeration

  !> Every node at the origin: a linear link holds 1/2 E |d0|^2, so the
  !> stretch energy counts the links of each kind. Whole lattice and the
  !> sum over the strips of several splits.
  subroutine counts_by_energy(scaling)
    integer, intent(in) :: scaling
    integer, parameter :: nx = 6, ny = 9
    type(nuno_config) :: cfg
    real(rp) :: expect, total, ax, ay
    integer :: split, s, ys, ye
    ! splits of the 9 rows: first rows of each strip, ending with ny
    integer, parameter :: cuts(0:9, 5) = reshape([ &
      0, 9, -1, -1, -1, -1, -1, -1, -1, -1, &
      0, 4, 9, -1, -1, -1, -1, -1, -1, -1, &
      0, 3, 6, 9, -1, -1, -1, -1, -1, -1, &
      0, 1, 2, 5, 8, 9, -1, -1, -1, -1, &
      0, 1, 2, 3, 4, 5, 6, 7, 8, 9], [10, 5])
    character(60) :: what
    cfg = make_cfg(nx, ny, 2.5_rp, 2.0_rp, BEND_NONE, SPRING_LINEAR, scaling)
    ax = 0.5_rp
    ay = 0.25_rp
    if (scaling == SCALING_ELEMENT) then
      expect = 0.5_rp * cfg%material%e_s * (real((nx - 1) * ny, rp) * ax**2 + real(nx * (ny - 1), rp) * ay**2) &
             + 0.5_rp * cfg%material%e_d * real(2 * (nx - 1) * (ny - 1), rp) * (ax**2 + ay**2)
    else
      ! E_x = Y ay/ax, E_y = Y ax/ay, halved on the boundary: each kind
      ! holds (nx-1)(ny-1) whole links, 1/2 Y ax ay each: Y lx ly in all.
      expect = cfg%material%e_s * cfg%lattice%lx * cfg%lattice%ly &
             + 0.5_rp * cfg%material%e_d * real(2 * (nx - 1) * (ny - 1), rp) * (ax**2 + ay**2)
    end if
    do split = 1, 5
      total = 0.0_rp
      do s = 0, 8
        if (cuts(s + 1, split) < 0) exit
        ys = cuts(s, split)
        ye = cuts(s + 1, split) - 1
        total = total + strip_stretch(cfg, ys, ye)
      end do
      write(what, '(a,i0,a,i0)') 'links counted by their energy, scaling ', scaling, ', split ', split
      call check_close(total, expect, 1.0e-13_rp, 0.0_rp, trim(what))
    end do
  end subroutine counts_by_energy

  !> Stretch energy of the links anchored on rows ys..ye, every node at the origin.
  real(rp) function strip_stretch(cfg, ys, ye) result(w)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: ys, ye
    type(lattice_t) :: lat
    real(rp), allocatable :: u(:, :, :)
    real(rp) :: bend
    call lattice_init(lat, cfg, ys, ye)
    allocate(u(0:5, 0:lat%nx - 1, lat%gys:lat%gye), source=0.0_rp)
    call element_energies(lat, u, w, bend)
  end function strip_stretch

  !> A randomly perturbed state: the strips' energies sum to the whole
  !> lattice's, and each strip's forces on its owned rows are the whole's.
  subroutine strips_sum_to_whole(bending, spring, scaling)
    integer, intent(in) :: bending, spring, scaling
    integer, parameter :: nx = 7, ny = 10
    integer, parameter :: cuts(0:10, 4) = reshape([ &
      0, 10, -1, -1, -1, -1, -1, -1, -1, -1, -1, &
      0, 5, 10, -1, -1, -1, -1, -1, -1, -1, -1, &
      0, 2, 3, 7, 10, -1, -1, -1, -1, -1, -1, &
      0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10], [11, 4])
    type(nuno_config) :: cfg
    type(lattice_t) :: lat, whole
    real(rp) :: uw(0:5, 0:nx - 1, 0:ny - 1), fw(3, 0:nx - 1, 0:ny - 1)
    real(rp), allocatable :: u(:, :, :), f(:, :, :)
    real(rp) :: sw, bw, ss, bs, st, bt, err, fscale
    integer :: split, s, nbad, bad(2)
    character(80) :: what

    cfg = make_cfg(nx, ny, 1.2_rp, 1.5_rp, bending, spring, scaling)
    call lattice_init(whole, cfg, 0, ny - 1)
    call seed_random(20261205)
    call perturbed_state(whole, 0.15_rp * cfg%lattice%ax, uw)
    call element_energies(whole, uw, sw, bw)
    call internal_forces(whole, uw, fw, nbad, bad)
    fscale = maxval(abs(fw))
    write(what, '(a,i0,a,i0,a,i0)') 'bending ', bending, ' spring ', spring, ' scaling ', scaling
    call check_true(nbad == 0 .and. sw > 0.0_rp .and. (bw > 0.0_rp .eqv. bending /= BEND_NONE), &
                    trim(what)//': perturbed state is regular and strained')
    do split = 1, 4
      st = 0.0_rp
      bt = 0.0_rp
      err = 0.0_rp
      do s = 0, 9
        if (cuts(s + 1, split) < 0) exit
        call lattice_init(lat, cfg, cuts(s, split), cuts(s + 1, split) - 1)
        u = uw(:, :, lat%gys:lat%gye)
        allocate(f(3, 0:nx - 1, lat%gys:lat%gye))
        call element_energies(lat, u, ss, bs)
        call internal_forces(lat, u, f, nbad, bad)
        st = st + ss
        bt = bt + bs
        err = max(err, maxval(abs(f(:, :, lat%ys:lat%ye) - fw(:, :, lat%ys:lat%ye))))
        deallocate(f)
      end do
      call check_close(st, sw, 1.0e-13_rp, 0.0_rp, trim(what)//': strips sum to the stretch energy')
      call check_close(bt, bw, 1.0e-13_rp, 0.0_rp, trim(what)//': strips sum to the bending energy')
      call check_true(err <= 1.0e-13_rp * fscale, trim(what)//': strip forces on owned rows are the whole''s')
    end do
  end subroutine strips_sum_to_whole

  !> Uniform and area (Voronoi) masses.
  subroutine masses()
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    integer, parameter :: nx = 6, ny = 5
    real(rp) :: interior
    integer :: i, j, nedge
    logical :: ok

    cfg = make_cfg(nx, ny, 2.5_rp, 2.0_rp, BEND_NONE, SPRING_AXIAL, SCALING_ELEMENT)
    call lattice_init(lat, cfg, 0, ny - 1)
    ok = .true.
    do j = 0, ny - 1
      do i = 0, nx - 1
        ok = ok .and. abs(lat%mass(i, j) - cfg%lattice%total_mass / (nx * ny)) <= 1.0e-15_rp
      end do
    end do
    call check_true(ok, 'uniform masses M/(nx ny)')

    cfg%lattice%mass_code = MASS_AREA
    call lattice_init(lat, cfg, 0, ny - 1)
    interior = cfg%lattice%total_mass / real((nx - 1) * (ny - 1), rp)   ! a cell's area times the density
    call check_close(sum(lat%mass), cfg%lattice%total_mass, 1.0e-14_rp, 0.0_rp, 'area masses sum to M')
    call check_close(lat%mass(2, 2), interior, 1.0e-14_rp, 0.0_rp, 'area mass of an interior node')
    call check_close(lat%mass(0, 0), interior / 4, 1.0e-14_rp, 0.0_rp, 'area mass of corner (0, 0)')
    call check_close(lat%mass(nx - 1, ny - 1), interior / 4, 1.0e-14_rp, 0.0_rp, 'area mass of corner (nx-1, ny-1)')
    call check_close(lat%mass(0, 2), interior / 2, 1.0e-14_rp, 0.0_rp, 'area mass of edge node (0, 2)')
    call check_close(lat%mass(3, ny - 1), interior / 2, 1.0e-14_rp, 0.0_rp, 'area mass of edge node (3, ny-1)')
    nedge = 0
    do j = 0, ny - 1
      do i = 0, nx - 1
        if (abs(lat%mass(i, j) - interior / 2) <= 1.0e-14_rp * interior) nedge = nedge + 1
      end do
    end do
    call check_true(nedge == 2 * (nx - 2) + 2 * (ny - 2), 'area masses: 2 (nx-2) + 2 (ny-2) edge nodes')

    ! continuum scaling takes area masses whatever mass_distribution says
    cfg%lattice%mass_code = MASS_UNIFORM
    cfg%lattice%scaling_code = SCALING_CONTINUUM
    call lattice_init(lat, cfg, 2, 3)
    call check_close(lat%mass(0, 1), interior / 2, 1.0e-14_rp, 0.0_rp, 'continuum: area mass of edge node (0, 1)')
    call check_close(lat%mass(3, 4), interior / 2, 1.0e-14_rp, 0.0_rp, 'continuum: area mass of edge ghost node (3, 4)')
    call check_close(lat%mass(3, 2), interior, 1.0e-14_rp, 0.0_rp, 'continuum: area mass of interior node (3, 2)')
    call check_true(lat%mass(1, 1) == node_mass(lat, 1, 1), 'mass array is node_mass')
  end subroutine masses

  !> Continuum constants by hand: ax = 0.5, ay = 0.25, Y_s = 7, Y_d = 3, kb = 0.2.
  subroutine continuum_constants()
    integer, parameter :: nx = 6, ny = 9
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    real(rp) :: e, eta, kb, etab, el(40), etal(40), e1, eta1
    integer :: i, j, k, i0, nl, l
    logical :: ok

    cfg = make_cfg(nx, ny, 2.5_rp, 2.0_rp, BEND_ENERGY, SPRING_AXIAL, SCALING_CONTINUUM)
    cfg%material%eta_s = 0.7_rp
    cfg%material%eta_d = 0.3_rp
    cfg%material%eta_b = 0.02_rp
    call lattice_init(lat, cfg, 0, ny - 1)
    call link_constants(lat, 2, 3, 1, e, eta)
    call check_close(e, 7.0_rp * 0.5_rp, 1.0e-15_rp, 0.0_rp, 'continuum x link: Y ay/ax')
    call check_close(eta, 0.7_rp * 0.5_rp, 1.0e-15_rp, 0.0_rp, 'continuum x link damping: eta ay/ax')
    call link_constants(lat, 2, 0, 1, e, eta)
    call check_close(e, 7.0_rp * 0.25_rp, 1.0e-15_rp, 0.0_rp, 'continuum x link on edge j = 0: halved')
    call link_constants(lat, 2, ny - 1, 1, e, eta)
    call check_close(e, 7.0_rp * 0.25_rp, 1.0e-15_rp, 0.0_rp, 'continuum x link on edge j = ny-1: halved')
    call link_constants(lat, 0, 3, 1, e, eta)
    call check_close(e, 7.0_rp * 0.5_rp, 1.0e-15_rp, 0.0_rp, 'continuum x link from column 0: not halved')
    call link_constants(lat, 2, 3, 2, e, eta)
    call check_close(e, 7.0_rp * 2.0_rp, 1.0e-15_rp, 0.0_rp, 'continuum y link: Y ax/ay')
    call link_constants(lat, 0, 3, 2, e, eta)
    call check_close(e, 7.0_rp, 1.0e-15_rp, 0.0_rp, 'continuum y link on edge i = 0: halved')
    call check_close(eta, 0.7_rp, 1.0e-15_rp, 0.0_rp, 'continuum y link damping on edge i = 0: halved')
    call link_constants(lat, nx - 1, 3, 2, e, eta)
    call check_close(e, 7.0_rp, 1.0e-15_rp, 0.0_rp, 'continuum y link on edge i = nx-1: halved')
    call link_constants(lat, 2, 0, 2, e, eta)
    call check_close(e, 7.0_rp * 2.0_rp, 1.0e-15_rp, 0.0_rp, 'continuum y link from row 0: not halved')
    do k = 3, 4
      call link_constants(lat, 0, 0, k, e, eta)
      call check_true(e == 3.0_rp .and. eta == 0.3_rp, 'continuum diagonal link: Y_d, eta_d as given')
    end do
    call triple_constants(lat, 1, kb, etab)
    call check_close(kb, 0.2_rp * 0.5_rp, 1.0e-15_rp, 0.0_rp, 'continuum x-line triple: k_b ay/ax')
    call check_close(etab, 0.02_rp * 0.5_rp, 1.0e-15_rp, 0.0_rp, 'continuum x-line triple: eta_b ay/ax')
    call triple_constants(lat, 2, kb, etab)
    call check_close(kb, 0.2_rp * 2.0_rp, 1.0e-15_rp, 0.0_rp, 'continuum y-line triple: k_b ax/ay')
    do k = 3, 4
      call triple_constants(lat, k, kb, etab)
      call check_true(kb == 0.2_rp .and. etab == 0.02_rp, 'continuum diagonal triple: k_b, eta_b as given')
    end do

    ! element scaling: every constant as given
    cfg%lattice%scaling_code = SCALING_ELEMENT
    call lattice_init(lat, cfg, 0, ny - 1)
    call link_constants(lat, 0, 0, 1, e, eta)
    call check_true(e == 7.0_rp .and. eta == 0.7_rp, 'element x link on the corner: E_s, eta_s')
    call link_constants(lat, nx - 1, 4, 2, e, eta)
    call check_true(e == 7.0_rp .and. eta == 0.7_rp, 'element y link on the edge: E_s, eta_s')
    call link_constants(lat, 1, 1, 4, e, eta)
    call check_true(e == 3.0_rp .and. eta == 0.3_rp, 'element diagonal link: E_d, eta_d')
    call triple_constants(lat, 2, kb, etab)
    call check_true(kb == 0.2_rp .and. etab == 0.02_rp, 'element y-line triple: k_b, eta_b')

    ! lanes: the same constants link by link, for every start and length
    do l = 1, 2
      cfg%lattice%scaling_code = merge(SCALING_CONTINUUM, SCALING_ELEMENT, l == 1)
      call lattice_init(lat, cfg, 0, ny - 1)
      ok = .true.
      do j = 0, ny - 1
        do k = 1, 4
          do i0 = 0, nx - 1
            do nl = 1, nx - i0
              el = -1.0_rp
              call link_lane_constants(lat, j, k, i0, nl, size(el), el, etal)
              do i = 1, nl
                call link_constants(lat, i0 + i - 1, j, k, e1, eta1)
                ok = ok .and. el(i) == e1 .and. etal(i) == eta1
              end do
            end do
          end do
        end do
      end do
      call check_true(ok, 'link_lane_constants equals link_constants, lane by lane')
    end do
  end subroutine continuum_constants

end program test_lattice
