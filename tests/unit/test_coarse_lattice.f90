! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module coarse_lattice (the multigrid's rediscretised
!> coarse levels, issue 46): the coarse lattice's masses and constants
!> against a lattice made directly at the coarse size, and the S that the
!> finest level's assembly (module reduced_assembly) makes on it against
!> the fine S on smooth fields, which is what a coarse operator has to
!> get right: x_c^T S_c x_c = (P x_c)^T S_f (P x_c) to O(h^2) for the
!> rediscretised S_c and a smooth interpolation P (cubic), while the
!> bilinear P's Galerkin energy doubles the bending (the cause of the
!> cycles' growth, docs/performance.md).
program test_coarse_lattice
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE, BEND_PAPER, BEND_ENERGY, SPRING_AXIAL, SCALING_ELEMENT, SCALING_CONTINUUM, &
                    MASS_AREA, MASS_UNIFORM
  use lattice, only: lattice_t, lattice_init, lattice_coarsened, rest_position, link_constants, triple_constants
  use coarse_lattice, only: mass_factors, restrict_factors, inject_rows, restrict_offset_blocks
  use reduced_assembly, only: assemble_stencil
  use node_blocks, only: node_blocks_t
  use offset_product, only: offset_count, offset_slot
  use interpolation, only: cubic_weights
  use mg_kernels, only: stencil_t, stencil_init
  use check, only: check_true, check_close, check_report, lattice_config
  implicit none

  call masses_and_constants(MASS_AREA, SCALING_ELEMENT, BEND_ENERGY, 'area masses, element constants, energy bending')
  call masses_and_constants(MASS_UNIFORM, SCALING_ELEMENT, BEND_PAPER, 'uniform masses, element constants, paper bending')
  call masses_and_constants(MASS_AREA, SCALING_CONTINUUM, BEND_ENERGY, 'continuum constants, energy bending')
  call injection()
  call offset_blocks_galerkin()
  call smooth_energies()
  call check_report()

contains

  !> A test lattice of nx x ny nodes over 1 x 1.2 (bending model, masses
  !> and scaling as given; hang's constants).
  function test_config(nx, ny, mass, scaling, bending) result(cfg)
    integer, intent(in) :: nx, ny, mass, scaling, bending
    type(nuno_config) :: cfg
    cfg = lattice_config(nx, ny, 1.0_rp, 1.2_rp, 0.1_rp, 100.0_rp, 80.0_rp, 0.1_rp, bending, SPRING_AXIAL, scaling)
    cfg%lattice%mass_code = mass
  end function test_config

  !> The coarse lattice of a 9 x 7 one: masses (summed with the bilinear
  !> weights: the total kept; area masses those of a 5 x 4 lattice made
  !> directly), link and triple constants as a lattice made at the coarse
  !> size, the paper model's k_b halved in element scaling.
  subroutine masses_and_constants(mass, scaling, bending, what)
    integer, intent(in) :: mass, scaling, bending
    character(*), intent(in) :: what
    type(lattice_t) :: fine, coarse, direct
    real(rp), allocatable :: mx(:), my(:), mxc(:), myc(:)
    real(rp) :: scale, e1, eta1, e2, eta2, kb1, etab1, kb2, etab2
    integer :: i, j, k
    call lattice_init(fine, test_config(9, 7, mass, scaling, bending), 0, 6)
    call lattice_init(direct, test_config(5, 4, mass, scaling, bending), 0, 3)
    call mass_factors(fine, mx, my, scale)
    allocate(mxc(0:4), myc(0:3))
    call restrict_factors(mx, mxc)
    call restrict_factors(my, myc)
    call check_close(sum(mxc), sum(mx), 1.0e-14_rp, 0.0_rp, what//': the factors along x summed keep their sum')
    call lattice_coarsened(fine, coarse, 0, 3, mxc, myc, scale)
    call check_true(coarse%nx == 5 .and. coarse%ny == 4 .and. abs(coarse%ax - direct%ax) < 1.0e-15_rp, &
                    what//': the coarse lattice''s size and spacing')
    call check_close(sum(coarse%mass), sum(fine%mass), 1.0e-14_rp, 0.0_rp, what//': the total mass kept')
    if (mass == MASS_AREA) call check_close(maxval(abs(coarse%mass - direct%mass)), 0.0_rp, 0.0_rp, &
                                            1.0e-15_rp * maxval(direct%mass), what//': area masses of the coarse spacing')
    if (mass == MASS_UNIFORM) call check_close(coarse%mass(0, 0), 2.25_rp * fine%mass(0, 0), 1.0e-14_rp, 0.0_rp, &
                                               what//': a uniform corner mass summed (1.5 x 1.5 of one)')
    do k = 1, 4
      do j = 0, 3
        do i = 0, 4
          call link_constants(coarse, i, j, k, e1, eta1)
          call link_constants(direct, i, j, k, e2, eta2)
          call check_true(abs(e1 - e2) <= 1.0e-14_rp * abs(e2) .and. abs(eta1 - eta2) <= 1.0e-14_rp * abs(eta2), &
                          what//': link constants as at the coarse size')
        end do
      end do
      call triple_constants(coarse, k, kb1, etab1)
      call triple_constants(direct, k, kb2, etab2)
      if (bending == BEND_PAPER) kb2 = 0.5_rp * kb2
      call check_close(kb1, kb2, 1.0e-14_rp, 0.0_rp, what//': triple constants (paper: halved)')
    end do
  end subroutine masses_and_constants

  !> Node (i, j) of a level coarsened 4 times from a strip is the fine
  !> node (4 i, 4 j).
  subroutine injection()
    real(rp) :: uf(0:1, 0:8, 3:12), uc(0:1, 0:2, 1:3)
    integer :: i, j
    do j = 3, 12
      do i = 0, 8
        uf(:, i, j) = [real(i, rp), real(100 * j, rp)]
      end do
    end do
    uc = -1.0_rp
    call inject_rows(4, uf, 3, uc, 1, 1, 3)
    call check_true(all(uc(0, :, :) == reshape([(4.0_rp * i, i = 0, 2), (4.0_rp * i, i = 0, 2), (4.0_rp * i, i = 0, 2)], &
                                               [3, 3])) .and. all(uc(1, :, 2) == 800.0_rp), 'injection with stride 4')
  end subroutine injection

  !> Blocks between neighbours (offsets -1..1, every value distinct) on a
  !> 9 x 7 lattice restricted by restrict_offset_blocks in two strips of
  !> coarse rows, against the Galerkin product P^T B P formed with dense
  !> matrices, P the bilinear interpolation from the 5 x 4 lattice (each
  !> of the 18 values a block holds in turn): equal to round-off, and no
  !> coarse coupling beyond the offsets -1..1.
  subroutine offset_blocks_galerkin()
    integer, parameter :: nxf = 9, nyf = 7, nxc = 5, nyc = 4, nf = nxf * nyf, nc = nxc * nyc
    real(rp) :: src(18, -1:1, -1:1, 0:nxf - 1, 0:nyf - 1), dst(18, -1:1, -1:1, 0:nxc - 1, 0:nyc - 1)
    real(rp) :: p(nf, nc), b(nf, nf), c(nc, nc), err, far
    integer :: i, j, di, dj, ic, jc, s
    src = 0.0_rp
    do j = 0, nyf - 1
      do i = 0, nxf - 1
        do dj = -1, 1
          do di = -1, 1
            if (i + di < 0 .or. i + di > nxf - 1 .or. j + dj < 0 .or. j + dj > nyf - 1) cycle
            do s = 1, 18
              src(s, di, dj, i, j) = sin(1.3_rp * i + 0.7_rp * j + 0.31_rp * di - 0.53_rp * dj + 0.17_rp * s)
            end do
          end do
        end do
      end do
    end do
    do jc = 0, nyc - 1
      do ic = 0, nxc - 1
        do j = 0, nyf - 1
          do i = 0, nxf - 1
            p(1 + i + nxf * j, 1 + ic + nxc * jc) = max(0.0_rp, 1.0_rp - 0.5_rp * abs(i - 2 * ic)) &
                                                    * max(0.0_rp, 1.0_rp - 0.5_rp * abs(j - 2 * jc))
          end do
        end do
      end do
    end do
    dst = -1.0_rp
    ! coarse rows 0..1 from fine rows 0..3, then 2..3 from fine rows 3..6
    call restrict_offset_blocks(nxf, 0, 3, src(:, :, :, :, 0:3), nxc, nyc, 0, nyc - 1, 0, 1, dst)
    call restrict_offset_blocks(nxf, 3, 6, src(:, :, :, :, 3:6), nxc, nyc, 0, nyc - 1, 2, 3, dst)
    err = 0.0_rp
    far = 0.0_rp
    do s = 1, 18
      b = 0.0_rp
      do j = 0, nyf - 1
        do i = 0, nxf - 1
          do dj = -1, 1
            do di = -1, 1
              if (i + di < 0 .or. i + di > nxf - 1 .or. j + dj < 0 .or. j + dj > nyf - 1) cycle
              b(1 + i + nxf * j, 1 + i + di + nxf * (j + dj)) = src(s, di, dj, i, j)
            end do
          end do
        end do
      end do
      c = matmul(transpose(p), matmul(b, p))
      do jc = 0, nyc - 1
        do ic = 0, nxc - 1
          do j = 0, nyc - 1
            do i = 0, nxc - 1
              if (abs(i - ic) <= 1 .and. abs(j - jc) <= 1) then
                err = max(err, abs(c(1 + ic + nxc * jc, 1 + i + nxc * j) - dst(s, i - ic, j - jc, ic, jc)))
              else
                far = max(far, abs(c(1 + ic + nxc * jc, 1 + i + nxc * j)))
              end if
            end do
          end do
        end do
      end do
    end do
    call check_close(err, 0.0_rp, 0.0_rp, 1.0e-13_rp, 'blocks between neighbours: the Galerkin product by offset')
    call check_close(far, 0.0_rp, 0.0_rp, 1.0e-15_rp, 'blocks between neighbours: no coarse coupling beyond one node')
  end subroutine offset_blocks_galerkin

  !> S on the flat lattice at rest (energy bending, Gauss-Newton, no
  !> damping) of 65 x 65 and its rediscretisation on 33 x 33: the energy
  !> of a smooth field w (out of plane, then in plane) on the coarse
  !> lattice against that of its cubic interpolant on the fine one
  !> (agree to a few per cent: O(h^2)), and of the bilinear interpolant
  !> (the Galerkin product of bilinear transfers: twice the bending).
  subroutine smooth_energies()
    type(lattice_t) :: fine, coarse
    type(nuno_config) :: cfg
    real(rp), allocatable :: mx(:), my(:), mxc(:), myc(:), sf(:, :, :, :, :), sc(:, :, :, :, :)
    real(rp), allocatable :: xc(:, :, :), xf(:, :, :), xl(:, :, :)
    real(rp) :: scale, ec, ef, el
    integer, parameter :: nf = 65, nc = 33
    integer :: comp
    cfg = test_config(nf, nf, MASS_AREA, SCALING_ELEMENT, BEND_ENERGY)
    call lattice_init(fine, cfg, 0, nf - 1)
    call mass_factors(fine, mx, my, scale)
    allocate(mxc(0:nc - 1), myc(0:nc - 1))
    call restrict_factors(mx, mxc)
    call restrict_factors(my, myc)
    call lattice_coarsened(fine, coarse, 0, nc - 1, mxc, myc, scale)
    call flat_s(fine, sf)
    call flat_s(coarse, sc)
    allocate(xc(3, 0:nc - 1, 0:nc - 1), xf(3, 0:nf - 1, 0:nf - 1), xl(3, 0:nf - 1, 0:nf - 1))
    do comp = 3, 1, -2
      call smooth_field(coarse, comp, .false., xc)
      call interpolate(xc, xf, .true.)
      ec = energy(coarse, sc, xc)
      ef = energy(fine, sf, xf)
      if (comp == 3) then
        call check_close(ec, ef, 0.05_rp, 0.0_rp, 'out of plane: the rediscretised energy of a smooth field as the fine one''s')
      else
        call check_close(ec, ef, 0.05_rp, 0.0_rp, 'in plane: the rediscretised energy of a smooth field as the fine one''s')
      end if
    end do
    ! a field along x alone, out of plane: its bending (the energy less
    ! the mass term) twice as large on the bilinear interpolant, the same
    ! on the rediscretised lattice
    call smooth_field(coarse, 3, .true., xc)
    call interpolate(xc, xf, .true.)
    call interpolate(xc, xl, .false.)
    ec = energy(coarse, sc, xc) - mass_energy(coarse, xc)
    ef = energy(fine, sf, xf) - mass_energy(fine, xf)
    el = energy(fine, sf, xl) - mass_energy(fine, xl)
    call check_close(ec, ef, 0.05_rp, 0.0_rp, 'along x: the rediscretised bending as the fine one''s')
    call check_close(el / ef, 2.0_rp, 0.05_rp, 0.0_rp, 'along x: the bilinear interpolant''s bending twice the fine one''s')
  end subroutine smooth_energies

  !> S of lat's whole lattice at its flat rest state, shift 10 / s, the
  !> bending Gauss-Newton, no damping, by stencil offset (module
  !> reduced_assembly; the whole strip kept).
  subroutine flat_s(lat, st)
    type(lattice_t), intent(in) :: lat
    real(rp), allocatable, intent(out) :: st(:, :, :, :, :)
    type(node_blocks_t) :: nodal
    type(stencil_t) :: level
    real(rp), allocatable :: u(:, :, :), w(:, :, :), lb(:, :, :, :, :), g(:, :, :), kd(:, :, :)
    logical, allocatable :: fixedg(:, :)
    integer :: i, j
    allocate(u(0:5, 0:lat%nx - 1, 0:lat%ny - 1), w(0:5, 0:lat%nx - 1, 0:lat%ny - 1), fixedg(0:lat%nx - 1, 0:lat%ny - 1))
    allocate(lb(0:lat%nx - 1, 3, 3, 4, 0:1), g(3, 0:lat%nx - 1, 0:lat%ny - 1), kd(3, 0:lat%nx - 1, 0:lat%ny - 1))
    allocate(st(0:lat%nx - 1, 3, 3, offset_count(lat%halo), 0:lat%ny - 1))
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        u(0:2, i, j) = rest_position(lat, i, j)
      end do
    end do
    u(3:5, :, :) = 0.0_rp
    w = 0.0_rp
    fixedg = .false.
    lb = 0.0_rp
    st = 0.0_rp
    call stencil_init(level, lat%nx, lat%ny, 0, lat%ny - 1, lat%halo, lines=.true.)
    call assemble_stencil(lat, nodal, u, fixedg, 10.0_rp, .false., .false., .true., w, lb, g, kd, st, level)
  end subroutine flat_s

  !> A smooth field of component comp (the rest zero) on lat's nodes:
  !> 1e-3 (cos(pi x) cos(pi y / 1.2) + x y), or 1e-3 cos(pi x).
  subroutine smooth_field(lat, comp, along_x, x)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comp
    logical, intent(in) :: along_x                 !< cos(pi x) alone
    real(rp), intent(out) :: x(:, 0:, 0:)
    real(rp), parameter :: pi = acos(-1.0_rp)
    real(rp) :: p(3)
    integer :: i, j
    x = 0.0_rp
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        p = rest_position(lat, i, j)
        if (along_x) then
          x(comp, i, j) = 1.0e-3_rp * cos(pi * p(1))
        else
          x(comp, i, j) = 1.0e-3_rp * (cos(pi * p(1)) * cos(pi * p(2) / 1.2_rp) + p(1) * p(2))
        end if
      end do
    end do
  end subroutine smooth_field

  !> xf = P xc on the lattice refined by 2: tensor-product cubic weights
  !> (module interpolation), or bilinear.
  subroutine interpolate(xc, xf, cubic)
    real(rp), intent(in) :: xc(:, 0:, 0:)
    real(rp), intent(out) :: xf(:, 0:, 0:)
    logical, intent(in) :: cubic
    integer :: i, j, a, b, ncx, ncy, ix(4), iy(4), nc
    real(rp) :: wx(4), wy(4)
    nc = size(xc, 2)
    xf = 0.0_rp
    do j = 0, size(xf, 3) - 1
      call weights(cubic, nc, j, iy, wy, ncy)
      do i = 0, size(xf, 2) - 1
        call weights(cubic, nc, i, ix, wx, ncx)
        do b = 1, ncy
          do a = 1, ncx
            xf(:, i, j) = xf(:, i, j) + wx(a) * wy(b) * xc(:, ix(a), iy(b))
          end do
        end do
      end do
    end do
  end subroutine interpolate

  !> The 1-D weights w(1:n) of coarse points idx(1:n) (of nc) for fine
  !> point f: cubic (module interpolation) or bilinear.
  subroutine weights(cubic, nc, f, idx, w, n)
    logical, intent(in) :: cubic
    integer, intent(in) :: nc, f
    integer, intent(out) :: idx(4), n
    real(rp), intent(out) :: w(4)
    if (cubic) then
      call cubic_weights(f, nc, idx, w, n)
    else if (mod(f, 2) == 0) then
      n = 1
      idx(1) = f / 2
      w(1) = 1.0_rp
    else
      n = 2
      idx(1:2) = [(f - 1) / 2, (f + 1) / 2]
      w(1:2) = 0.5_rp
    end if
  end subroutine weights

  !> The mass term of x^T S x: a sum m |x|^2, a = 10 / s (flat_s).
  real(rp) function mass_energy(lat, x) result(e)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: x(:, 0:, 0:)
    integer :: i, j
    e = 0.0_rp
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        e = e + 10.0_rp * lat%mass(i, j) * sum(x(:, i, j)**2)
      end do
    end do
  end function mass_energy

  !> x^T S x over the whole lattice, S by stencil offset (st).
  real(rp) function energy(lat, st, x) result(e)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: st(0:, :, :, :, 0:)
    real(rp), intent(in) :: x(:, 0:, 0:)
    integer :: i, j, di, dj, k
    e = 0.0_rp
    do j = 0, lat%ny - 1
      do i = 0, lat%nx - 1
        do dj = -lat%halo, lat%halo
          do di = -lat%halo, lat%halo
            k = offset_slot(lat%halo, di, dj)
            if (k == 0 .or. i + di < 0 .or. i + di >= lat%nx .or. j + dj < 0 .or. j + dj >= lat%ny) cycle
            e = e + dot_product(x(:, i, j), matmul(st(i, :, :, k, j), x(:, i + di, j + dj)))
          end do
        end do
      end do
    end do
  end function energy

end program test_coarse_lattice
