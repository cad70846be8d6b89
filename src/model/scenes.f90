! SPDX-License-Identifier: BSD-2-Clause
!> Initial state and constraints of each scene (docs/model.md section 7).
!> Every node's initial position is an analytic function of (i, j), so each
!> rank sets up its own rows without communication.
module scenes
  use kinds, only: rp
  use config, only: nuno_config, SCENE_LIFT_RELEASE, SCENE_BEND_RELEASE, SCENE_WAVE_POINT, SCENE_HANG
  use lattice, only: lattice_t, rest_position, node_mass
  use vec3, only: cross
  use constraints, only: constraint_set_t, constraints_init, constraints_add, PATH_FIXED, PATH_KEYFRAMES
  implicit none
  private
  public :: scene_setup, scene_position

  real(rp), parameter :: pi = acos(-1.0_rp)

contains

  !> Initial position [length] of node (i, j) in the scene of cfg.
  pure function scene_position(cfg, lat, i, j) result(x)
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j
    real(rp) :: x(3)
    integer :: ic
    real(rp) :: phi, s, radius, xc

    x = rest_position(lat, i, j)
    select case (cfg%scene%scene_code)
    case (SCENE_LIFT_RELEASE)
      ! Fold about the node column nearest to x = lx - lift_length, a rigid
      ! rotation of the part beyond it until edge i = nx-1 is lift_height up.
      ic = nint((cfg%lattice%lx - cfg%scene%lift_length) / lat%ax)
      ic = max(0, min(lat%nx - 2, ic))
      if (i > ic) then
        phi = asin(min(1.0_rp, cfg%scene%lift_height / (real(lat%nx - 1 - ic, rp) * lat%ax)))
        xc = real(ic, rp) * lat%ax
        s = x(1) - xc
        x(1) = xc + s * cos(phi)
        x(3) = s * sin(phi)
      end if
    case (SCENE_BEND_RELEASE)
      ! Circular arc in the x-z plane, symmetric about x = lx/2, ends up;
      ! x spacing kept along the arc; the whole centre line subtends bend_angle.
      if (cfg%scene%bend_angle > 0.0_rp) then
        radius = cfg%lattice%lx / (cfg%scene%bend_angle * pi / 180.0_rp)
        s = x(1) - 0.5_rp * cfg%lattice%lx
        phi = s / radius
        x(1) = 0.5_rp * cfg%lattice%lx + radius * sin(phi)
        x(3) = radius * (1.0_rp - cos(phi))
      end if
    case default
    end select
  end function scene_position

  !> Fill the owned rows of the state u(0:5, 0:nx-1, ys:ye) and the
  !> constraint set of this rank.
  subroutine scene_setup(cfg, lat, u, cs)
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    real(rp), intent(out) :: u(0:5, 0:lat%nx - 1, lat%ys:lat%ye)
    type(constraint_set_t), intent(out) :: cs
    integer :: i, j, nk
    real(rp) :: centroid(3), mtot, m, x(3)
    real(rp), allocatable :: kt(:), koff(:, :)

    ! Rigid initial spin about the mass centroid (all nodes, analytic).
    centroid = 0.0_rp
    mtot = 0.0_rp
    if (any(cfg%scene%initial_omega /= 0.0_rp)) then
      do j = 0, lat%ny - 1
        do i = 0, lat%nx - 1
          m = node_mass(lat, i, j)
          centroid = centroid + m * scene_position(cfg, lat, i, j)
          mtot = mtot + m
        end do
      end do
      centroid = centroid / mtot
    end if
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        x = scene_position(cfg, lat, i, j)
        u(0:2, i, j) = x
        u(3:5, i, j) = cross(cfg%scene%initial_omega, x - centroid)
      end do
    end do

    ! Constraints: keyframes only for the scene that has a path.
    if (cfg%scene%scene_code == SCENE_WAVE_POINT) then
      nk = cfg%scene%n_keyframes
      kt = cfg%scene%keyframe_time(1:nk)
      allocate(koff(3, nk))
      koff(1, :) = cfg%scene%keyframe_dx(1:nk)
      koff(2, :) = cfg%scene%keyframe_dy(1:nk)
      koff(3, :) = cfg%scene%keyframe_dz(1:nk)
    else
      allocate(kt(0), koff(3, 0))
    end if
    ! lift_release, wave_point and hang constrain nodes (on some rank)
    call constraints_init(cs, 2 * lat%ny + 4, kt, koff, cfg%scene%release_time, &
                          any(cfg%scene%scene_code == [SCENE_LIFT_RELEASE, SCENE_WAVE_POINT, SCENE_HANG]))
    select case (cfg%scene%scene_code)
    case (SCENE_LIFT_RELEASE)
      do j = lat%ys, lat%ye           ! edge i = 0 pinned
        call constraints_add(cs, 0, j, u(0:2, 0, j), PATH_FIXED)
      end do
    case (SCENE_WAVE_POINT)
      if (trim(cfg%scene%wave_nodes) == 'edge') then
        do j = lat%ys, lat%ye         ! every node of edge i = 0: a wave along +x
          call constraints_add(cs, 0, j, u(0:2, 0, j), PATH_KEYFRAMES)
        end do
      else                            ! corner (0,0): a wave along the diagonal
        if (lat%ys == 0) call constraints_add(cs, 0, 0, u(0:2, 0, 0), PATH_KEYFRAMES)
      end if
    case (SCENE_HANG)
      j = lat%ny - 1                  ! the two corners of edge j = ny-1
      if (j >= lat%ys .and. j <= lat%ye) then
        call constraints_add(cs, 0, j, u(0:2, 0, j), PATH_FIXED)
        call constraints_add(cs, lat%nx - 1, j, u(0:2, lat%nx - 1, j), PATH_FIXED)
      end if
    end select
  end subroutine scene_setup


end module scenes
