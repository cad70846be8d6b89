! SPDX-License-Identifier: BSD-2-Clause
!> The lattice of one rank: its strip of whole rows, the rest geometry, the
!> node masses and the per-element constants (docs/model.md sections 1 and 6).
!>
!> Index convention (everywhere in nuno): nodes (i, j) with 0-based global
!> indices, i = 0..nx-1 along x, j = 0..ny-1 along y. A rank owns rows
!> j = ys..ye (whole rows: the DMDA has 1 x P processes) and sees ghost rows
!> gys..gye (gys = max(0, ys-w), gye = min(ny-1, ye+w), w the halo width).
!> State arrays are u(0:5, 0:nx-1, gys:gye): u(0:2) position, u(3:5) velocity.
!>
!> Elements (links and bending triples) are enumerated from their ANCHOR,
!> the node of the lowest row (lowest i within it): a link from anchor p to
!> p + s for s in link_dir, a triple p, p + s, p + 2s for s in line_dir.
!> An element is computed by every rank one of whose rows it touches; its
!> energy and power are counted only by the rank that owns its anchor, so
!> global sums count each element once.
module lattice
  use kinds, only: rp
  use config, only: nuno_config, SCALING_CONTINUUM, MASS_AREA, BEND_NONE, BEND_ENERGY, BEND_PAPER
  implicit none
  private
  public :: lattice_t, lattice_init, lattice_coarsened, link_dir, line_dir, link_constants, link_lane_constants, triple_constants
  public :: rest_position, node_mass, rest_strip, halo_width, stencil_box

  !> Link directions from the anchor: +x, +y, +x+y, -x+y (each link once).
  integer, parameter :: link_dir(2, 4) = reshape([1, 0, 0, 1, 1, 1, -1, 1], [2, 4])
  !> Line directions of bending triples from the anchor (each triple once).
  integer, parameter :: line_dir(2, 4) = reshape([1, 0, 0, 1, 1, 1, -1, 1], [2, 4])

  type :: lattice_t
    integer :: nx = 0, ny = 0          !< lattice size
    integer :: ys = 0, ye = -1         !< owned rows
    integer :: gys = 0, gye = -1       !< owned + ghost rows
    integer :: halo = 1                !< ghost width: 2 with bending, 1 without
    real(rp) :: ax = 0, ay = 0         !< spacings [length]
    integer :: spring_model = 1
    integer :: bending_model = BEND_NONE
    logical :: continuum = .false.
    real(rp) :: e_s = 0, eta_s = 0, e_d = 0, eta_d = 0   !< as read (element or material values)
    real(rp) :: k_b = 0, eta_b = 0
    real(rp) :: total_mass = 0, lx = 0, ly = 0
    logical :: area_mass = .false.
    real(rp), allocatable :: mass(:, :)   !< (0:nx-1, gys:gye) node masses [mass]
  end type lattice_t

contains

  !> Set up the strip of rows ys..ye of the lattice described by cfg.
  subroutine lattice_init(lat, cfg, ys, ye)
    type(lattice_t), intent(out) :: lat
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: ys, ye
    integer :: i, j

    lat%nx = cfg%lattice%nx
    lat%ny = cfg%lattice%ny
    lat%ys = ys
    lat%ye = ye
    lat%halo = halo_width(cfg)
    lat%gys = max(0, ys - lat%halo)
    lat%gye = min(cfg%lattice%ny - 1, ye + lat%halo)
    lat%ax = cfg%lattice%ax
    lat%ay = cfg%lattice%ay
    lat%spring_model = cfg%material%spring_code
    lat%bending_model = cfg%material%bending_code
    lat%continuum = cfg%lattice%scaling_code == SCALING_CONTINUUM
    lat%e_s = cfg%material%e_s
    lat%eta_s = cfg%material%eta_s
    lat%e_d = cfg%material%e_d
    lat%eta_d = cfg%material%eta_d
    lat%k_b = cfg%material%k_b
    lat%eta_b = cfg%material%eta_b

    lat%total_mass = cfg%lattice%total_mass
    lat%lx = cfg%lattice%lx
    lat%ly = cfg%lattice%ly
    lat%area_mass = cfg%lattice%mass_code == MASS_AREA .or. lat%continuum
    allocate(lat%mass(0:lat%nx - 1, lat%gys:lat%gye))
    do j = lat%gys, lat%gye
      do i = 0, lat%nx - 1
        lat%mass(i, j) = node_mass(lat, i, j)
      end do
    end do
  end subroutine lattice_init

  !> The lattice coarsened by 2 from fine (nx - 1 and ny - 1 even) for the
  !> multigrid's rediscretised coarse levels (module mg_coarse; the rule
  !> for its constants: module coarse_lattice), rows ys..ye of it on this rank (the ghost rows as fine's halo), its masses
  !> scale mx(i) my(j) (the coarse factors: restrict_factors of the fine
  !> ones). What the element kernels read: sizes, spacings, models and
  !> constants, masses.
  subroutine lattice_coarsened(fine, lat, ys, ye, mx, my, scale)
    type(lattice_t), intent(in) :: fine
    type(lattice_t), intent(out) :: lat
    integer, intent(in) :: ys, ye
    real(rp), intent(in) :: mx(0:), my(0:), scale
    integer :: i, j
    lat%nx = (fine%nx - 1) / 2 + 1
    lat%ny = (fine%ny - 1) / 2 + 1
    lat%ys = ys
    lat%ye = ye
    lat%halo = fine%halo
    lat%gys = max(0, ys - lat%halo)
    lat%gye = min(lat%ny - 1, ye + lat%halo)
    lat%ax = 2.0_rp * fine%ax
    lat%ay = 2.0_rp * fine%ay
    lat%spring_model = fine%spring_model
    lat%bending_model = fine%bending_model
    lat%continuum = fine%continuum
    lat%e_s = fine%e_s
    lat%eta_s = fine%eta_s
    lat%e_d = fine%e_d
    lat%eta_d = fine%eta_d
    lat%k_b = fine%k_b
    lat%eta_b = fine%eta_b
    ! the paper model's force per radian: its stiffness k_b / h kept
    ! (no continuum mode for it: input_checks rejects the pair)
    if (fine%bending_model == BEND_PAPER .and. .not. fine%continuum) lat%k_b = 0.5_rp * fine%k_b
    lat%total_mass = fine%total_mass
    lat%lx = fine%lx
    lat%ly = fine%ly
    lat%area_mass = fine%area_mass
    allocate(lat%mass(0:lat%nx - 1, lat%gys:lat%gye))
    do j = lat%gys, lat%gye
      do i = 0, lat%nx - 1
        lat%mass(i, j) = scale * mx(i) * my(j)
      end do
    end do
  end subroutine lattice_coarsened

  !> Ghost width of the strips: bending triples reach two rows, links one.
  pure integer function halo_width(cfg)
    type(nuno_config), intent(in) :: cfg
    halo_width = merge(1, 2, cfg%material%bending_code == BEND_NONE)
  end function halo_width

  !> Mass of node (i, j) [mass]: uniform (the report), or the node's Voronoi
  !> cell times the areal density (corners 1/4, edges 1/2 of an interior cell).
  pure real(rp) function node_mass(lat, i, j)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j
    real(rp) :: wi, wj
    if (lat%area_mass) then
      wj = merge(0.5_rp, 1.0_rp, j == 0 .or. j == lat%ny - 1)
      wi = merge(0.5_rp, 1.0_rp, i == 0 .or. i == lat%nx - 1)
      node_mass = lat%total_mass / (lat%lx * lat%ly) * lat%ax * lat%ay * wi * wj
    else
      node_mass = lat%total_mass / real(lat%nx * lat%ny, rp)
    end if
  end function node_mass

  !> Rest position X(i, j) = (i ax, j ay, 0).
  pure function rest_position(lat, i, j) result(x)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j
    real(rp) :: x(3)
    x = [real(i, rp) * lat%ax, real(j, rp) * lat%ay, 0.0_rp]
  end function rest_position

  !> Rest positions of the owned rows, (3, 0:nx-1, ys:ye) [length].
  pure function rest_strip(lat) result(x)
    type(lattice_t), intent(in) :: lat
    real(rp) :: x(3, 0:lat%nx - 1, lat%ys:lat%ye)
    integer :: i, j
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        x(:, i, j) = rest_position(lat, i, j)
      end do
    end do
  end function rest_strip

  !> The offsets (di, dj), |di|, |dj| <= w, from node (i, j) to nodes of
  !> the lattice: di0..di1, dj0..dj1 (a node's stencil of half-width w).
  pure subroutine stencil_box(lat, i, j, w, di0, di1, dj0, dj1)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j, w
    integer, intent(out) :: di0, di1, dj0, dj1
    di0 = max(-w, -i)
    di1 = min(w, lat%nx - 1 - i)
    dj0 = max(-w, -j)
    dj1 = min(w, lat%ny - 1 - j)
  end subroutine stencil_box

  !> Stiffness E and damping eta of the link from anchor (i, j) along
  !> link_dir(:, k). Continuum scaling: E = Y * (spacing across / spacing
  !> along) for structural links, halved on the boundary; diagonals as given.
  pure subroutine link_constants(lat, i, j, k, e, eta)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j, k
    real(rp), intent(out) :: e, eta
    real(rp) :: s
    if (k >= 3) then
      e = lat%e_d
      eta = lat%eta_d
      return
    end if
    e = lat%e_s
    eta = lat%eta_s
    if (.not. lat%continuum) return
    if (k == 1) then          ! along x, across y
      s = lat%ay / lat%ax
      if (j == 0 .or. j == lat%ny - 1) s = 0.5_rp * s
    else                      ! along y, across x
      s = lat%ax / lat%ay
      if (i == 0 .or. i == lat%nx - 1) s = 0.5_rp * s
    end if
    e = e * s
    eta = eta * s
  end subroutine link_constants

  !> link_constants of the nl links anchored at (i0 + l - 1, j) along
  !> link_dir(:, k), by lanes: one value for the whole row but for the
  !> boundary columns of links along y (continuum scaling), so the element
  !> loops need no call per link (2 % of a Baraff-Witkin step without
  !> bending went to those calls).
  pure subroutine link_lane_constants(lat, j, k, i0, nl, ld, e, eta)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: j, k, i0, nl, ld
    real(rp), intent(out) :: e(ld), eta(ld)
    real(rp) :: e0, eta0
    ! column 1 is an interior one (nx >= 3, lattice_init)
    call link_constants(lat, 1, j, k, e0, eta0)
    e(1:nl) = e0
    eta(1:nl) = eta0
    if (lat%continuum .and. k == 2) then
      if (i0 == 0) call link_constants(lat, 0, j, k, e(1), eta(1))
      if (i0 + nl - 1 == lat%nx - 1) call link_constants(lat, lat%nx - 1, j, k, e(nl), eta(nl))
    end if
  end subroutine link_lane_constants

  !> Bending stiffness and damping of a triple along line_dir(:, k).
  !> Continuum (energy model): rigidity x (across / along) for x and y lines,
  !> the rigidity itself for diagonal lines; boundary triples not halved.
  pure subroutine triple_constants(lat, k, kb, etab)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: k
    real(rp), intent(out) :: kb, etab
    real(rp) :: s
    kb = lat%k_b
    etab = lat%eta_b
    if (.not. lat%continuum) return
    select case (k)
    case (1)
      s = lat%ay / lat%ax
    case (2)
      s = lat%ax / lat%ay
    case default
      s = 1.0_rp
    end select
    kb = kb * s
    etab = etab * s
  end subroutine triple_constants

end module lattice
