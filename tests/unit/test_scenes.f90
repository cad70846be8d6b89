! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module scenes: the initial state and the constraints of
!> each scene against the definitions of docs/model.md section 7, checked
!> by geometry rather than by the formulas of scene_position:
!> - lift_release: flat up to the node column nearest x = lx - lift_length,
!>   the part beyond it folded by a rigid rotation: every link keeps its
!>   rest length, edge i = nx-1 is lift_height up (a 30 degree fold at
!>   11 x 11), y unchanged, at rest; edge i = 0 pinned on every strip;
!> - bend_release: every node on the circle of radius lx / angle about
!>   (lx/2, y, R), the centre line subtending bend_angle (the end nodes at
!>   +-bend_angle/2 from the middle), neighbours along x an arc of ax apart
!>   (total arc length lx), symmetric about x = lx/2, ends up; nothing
!>   constrained, never a release;
!> - wave_point: flat; corner (0, 0) (or every node of edge i = 0) on the
!>   keyframe path, which the constraint follows: z linear to -10 at 0.5,
!>   to +15 at 1.0, then held;
!> - hang: flat, 1 x 1, the two corners of edge j = ny-1 pinned, only on
!>   the strip that owns that row;
!> - flat: flat, nothing constrained;
!> - an initial spin: v = omega x (x - c) about the mass centroid c of the
!>   whole lattice (also on a strip), so the total momentum is zero.
!> Every scene is also set up strip by strip: the rows equal the whole
!> lattice's and the constraints of the strips together are the whole's.
program test_scenes
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE, BEND_PAPER, BEND_ENERGY, SPRING_AXIAL, SCALING_ELEMENT, &
                    MASS_UNIFORM, MASS_AREA, SCENE_LIFT_RELEASE, SCENE_BEND_RELEASE, SCENE_WAVE_POINT, &
                    SCENE_HANG, SCENE_FLAT
  use lattice, only: lattice_t, lattice_init, link_dir, node_mass
  use constraints, only: constraint_set_t, constraints_set_window, constraint_target, PATH_FIXED, PATH_KEYFRAMES, &
                         constraint_count, constraint_node, constraint_path, constraint_base, constraints_global, &
                         constraint_release_time, constraint_keyframes
  use scenes, only: scene_setup, scene_position
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none

  real(rp), parameter :: pi = acos(-1.0_rp)

  !> A constraint set's contents, read through module constraints' accessors
  !> (view), for the checks below.
  type :: cset_view_t
    integer :: n = 0, nk = 0
    integer, allocatable :: node(:, :)     ! (2, n)
    integer, allocatable :: path(:)        ! (n)
    real(rp), allocatable :: x0(:, :)      ! (3, n)
    logical :: any_global = .false.
    real(rp) :: release_time = 0
  end type cset_view_t

  call lift_release(11, 30.0_rp, 15.0_rp, 7)
  call lift_release(11, 33.0_rp, 15.0_rp, 7)     ! x = 67: nearest column x = 70
  call lift_release(11, 24.0_rp, 15.0_rp, 8)     ! x = 76: nearest column x = 80
  call lift_release(21, 30.0_rp, 10.0_rp, 14)
  call bend_release(11, 30.0_rp)
  call bend_release(14, 75.0_rp)
  call wave_point('corner')
  call wave_point('edge')
  call hang()
  call flat()
  call spin()
  call check_report()

contains

  !> A scene's configuration as the report's scenes: square, uniform
  !> masses, paper bending (the input module's part is set by hand here).
  function make_cfg(scene, n, l, mass) result(cfg)
    integer, intent(in) :: scene, n
    real(rp), intent(in) :: l, mass
    type(nuno_config) :: cfg
    cfg%scene%scene_code = scene
    cfg%lattice%nx = n
    cfg%lattice%ny = n
    cfg%lattice%lx = l
    cfg%lattice%ly = l
    cfg%lattice%ax = l / (n - 1)
    cfg%lattice%ay = l / (n - 1)
    cfg%lattice%total_mass = mass
    cfg%material%spring_code = SPRING_AXIAL
    cfg%material%bending_code = BEND_PAPER
    cfg%lattice%scaling_code = SCALING_ELEMENT
    cfg%lattice%mass_code = MASS_UNIFORM
    cfg%scene%release_time = huge(1.0_rp)
    cfg%scene%initial_omega = 0.0_rp
  end function make_cfg

  !> The contents of the constraint set cs.
  function view(cs) result(v)
    type(constraint_set_t), intent(in) :: cs
    type(cset_view_t) :: v
    real(rp), allocatable :: kt(:), koff(:, :)
    integer :: k
    v%n = constraint_count(cs)
    allocate(v%node(2, v%n), v%path(v%n), v%x0(3, v%n))
    do k = 1, v%n
      call constraint_node(cs, k, v%node(1, k), v%node(2, k))
      v%path(k) = constraint_path(cs, k)
      v%x0(:, k) = constraint_base(cs, k)
    end do
    call constraint_keyframes(cs, v%nk, kt, koff)
    v%any_global = constraints_global(cs)
    v%release_time = constraint_release_time(cs)
  end function view

  !> The whole lattice's state (one strip of all rows) and its constraints.
  subroutine whole(cfg, u, cs)
    type(nuno_config), intent(in) :: cfg
    real(rp), allocatable, intent(out) :: u(:, :, :)
    type(constraint_set_t), intent(out) :: cs
    type(lattice_t) :: lat
    call lattice_init(lat, cfg, 0, cfg%lattice%ny - 1)
    allocate(u(0:5, 0:cfg%lattice%nx - 1, 0:cfg%lattice%ny - 1))
    call scene_setup(cfg, lat, u, cs)
  end subroutine whole

  !> Set the scene up on the strips [0, 0], [1, 2], [3, 3], [4, ny-3], [ny-2, ny-1]:
  !> their rows equal the whole state's, and their constrained nodes
  !> together are the whole's (each with its path and base position).
  subroutine strips_agree(cfg, uw, csw, what)
    type(nuno_config), intent(in) :: cfg
    real(rp), intent(in) :: uw(0:, 0:, 0:)
    type(constraint_set_t), intent(in) :: csw
    character(*), intent(in) :: what
    type(lattice_t) :: lat
    type(constraint_set_t) :: cs
    type(cset_view_t) :: v, vw
    real(rp), allocatable :: u(:, :, :)
    integer :: cuts(6), s, k, m, found, ntotal
    logical :: same
    vw = view(csw)
    cuts = [0, 1, 3, 4, cfg%lattice%ny - 2, cfg%lattice%ny]
    same = .true.
    ntotal = 0
    do s = 1, 5
      call lattice_init(lat, cfg, cuts(s), cuts(s + 1) - 1)
      allocate(u(0:5, 0:cfg%lattice%nx - 1, lat%ys:lat%ye))
      call scene_setup(cfg, lat, u, cs)
      v = view(cs)
      same = same .and. all(u == uw(:, :, lat%ys:lat%ye))
      call check_true(v%any_global .eqv. vw%any_global, what//': strips agree on any_global')
      call check_true(v%release_time == vw%release_time, what//': strips agree on the release time')
      do k = 1, v%n
        found = 0
        do m = 1, vw%n
          if (all(vw%node(:, m) == v%node(:, k))) then
            found = found + 1
            call check_true(vw%path(m) == v%path(k) .and. all(vw%x0(:, m) == v%x0(:, k)), &
                            what//': a strip''s constraint has the whole''s path and base')
          end if
        end do
        call check_true(found == 1, what//': a strip''s constrained node is one of the whole''s')
        call check_true(v%node(2, k) >= lat%ys .and. v%node(2, k) <= lat%ye, &
                        what//': a strip constrains only its owned rows')
      end do
      ntotal = ntotal + v%n
      deallocate(u)
    end do
    call check_true(same, what//': each strip''s rows are the whole lattice''s')
    call check_true(ntotal == vw%n, what//': the strips'' constraints add up to the whole''s')
  end subroutine strips_agree

  !> True when every node of u is at its rest position (i ax, j ay, 0) and at rest.
  logical function flat_at_rest(cfg, u)
    type(nuno_config), intent(in) :: cfg
    real(rp), intent(in) :: u(0:, 0:, 0:)
    integer :: i, j
    flat_at_rest = .true.
    do j = 0, cfg%lattice%ny - 1
      do i = 0, cfg%lattice%nx - 1
        flat_at_rest = flat_at_rest .and. all(abs(u(0:2, i, j) - [i * cfg%lattice%ax, j * cfg%lattice%ay, 0.0_rp]) &
                                               <= 1.0e-13_rp * cfg%lattice%lx) .and. all(u(3:5, i, j) == 0.0_rp)
      end do
    end do
  end function flat_at_rest

  !> Largest |l - L| / L over the links (eight neighbours) of state u.
  real(rp) function max_link_strain(cfg, u) result(r)
    type(nuno_config), intent(in) :: cfg
    real(rp), intent(in) :: u(0:, 0:, 0:)
    integer :: i, j, k, iq, jq
    real(rp) :: l0, l
    r = 0.0_rp
    do j = 0, cfg%lattice%ny - 1
      do i = 0, cfg%lattice%nx - 1
        do k = 1, 4
          iq = i + link_dir(1, k)
          jq = j + link_dir(2, k)
          if (iq < 0 .or. iq >= cfg%lattice%nx .or. jq >= cfg%lattice%ny) cycle
          l0 = hypot(link_dir(1, k) * cfg%lattice%ax, link_dir(2, k) * cfg%lattice%ay)
          l = norm2(u(0:2, iq, jq) - u(0:2, i, j))
          r = max(r, abs(l - l0) / l0)
        end do
      end do
    end do
  end function max_link_strain

  !> lift_release, n x n over 100 x 100, folded part lift_length, edge
  !> lift_height up; ic the column (by hand) nearest x = 100 - lift_length.
  subroutine lift_release(n, lift_length, lift_height, ic)
    integer, intent(in) :: n, ic
    real(rp), intent(in) :: lift_length, lift_height
    type(nuno_config) :: cfg
    type(constraint_set_t) :: cs
    type(cset_view_t) :: v
    real(rp), allocatable :: u(:, :, :)
    real(rp) :: d(3), angle
    integer :: i, j, k
    logical :: ok_flat, ok_lifted, ok_y
    character(60) :: what
    write(what, '(a,i0,a,f0.1)') 'lift_release ', n, ' lift_length ', lift_length
    cfg = make_cfg(SCENE_LIFT_RELEASE, n, 100.0_rp, 1.0_rp)
    cfg%scene%lift_length = lift_length
    cfg%scene%lift_height = lift_height
    cfg%scene%release_time = 0.75_rp
    call whole(cfg, u, cs)
    v = view(cs)

    ok_flat = .true.
    ok_lifted = .true.
    ok_y = .true.
    do j = 0, n - 1
      do i = 0, n - 1
        if (i <= ic) then
          ok_flat = ok_flat .and. all(u(0:2, i, j) == [i * cfg%lattice%ax, j * cfg%lattice%ay, 0.0_rp])
        else
          ok_lifted = ok_lifted .and. u(2, i, j) > 0.0_rp
        end if
        ok_y = ok_y .and. u(1, i, j) == j * cfg%lattice%ay
      end do
    end do
    call check_true(ok_flat, trim(what)//': flat up to the fold column')
    call check_true(ok_lifted, trim(what)//': lifted beyond the fold column')
    call check_true(ok_y, trim(what)//': y unchanged')
    call check_true(all(u(3:5, :, :) == 0.0_rp), trim(what)//': at rest')
    call check_true(max_link_strain(cfg, u) <= 1.0e-13_rp, trim(what)//': every link at its rest length')
    do j = 0, n - 1
      call check_close(u(2, n - 1, j), lift_height, 1.0e-13_rp, 0.0_rp, trim(what)//': edge i = nx-1 at lift_height')
    end do
    ! the folded part is one plane through the fold line at the fold angle
    d = u(0:2, n - 1, 3) - u(0:2, ic, 3)
    angle = atan2(d(3), d(1))
    call check_close(angle, asin(lift_height / ((n - 1 - ic) * cfg%lattice%ax)), 1.0e-13_rp, 0.0_rp, &
                     trim(what)//': fold angle')
    if (n == 11 .and. ic == 7) call check_close(angle, pi / 6, 1.0e-13_rp, 0.0_rp, trim(what)//': a 30 degree fold')
    do i = ic + 1, n - 1
      d = u(0:2, i, 5) - u(0:2, ic, 5)
      call check_close(atan2(d(3), d(1)), angle, 1.0e-13_rp, 0.0_rp, trim(what)//': folded part is plane')
    end do

    ! edge i = 0 pinned, nothing else; release at release_time
    call check_true(v%n == n .and. v%any_global, trim(what)//': n constraints')
    do k = 1, v%n
      call check_true(v%node(1, k) == 0 .and. v%path(k) == PATH_FIXED .and. &
                      all(v%x0(:, k) == u(0:2, 0, v%node(2, k))), trim(what)//': edge i = 0 pinned where it lies')
    end do
    call check_true(count([(any(v%node(2, 1:v%n) == j), j = 0, n - 1)]) == n, trim(what)//': every row of edge i = 0')
    call check_true(v%release_time == 0.75_rp .and. v%nk == 0, trim(what)//': released at release_time, no path')
    call strips_agree(cfg, u, cs, trim(what))
  end subroutine lift_release

  !> bend_release, n x n over 50 x 50, arc of bend_angle degrees.
  subroutine bend_release(n, bend_angle)
    integer, intent(in) :: n
    real(rp), intent(in) :: bend_angle
    type(nuno_config) :: cfg
    type(constraint_set_t) :: cs
    type(cset_view_t) :: v
    real(rp), allocatable :: u(:, :, :)
    real(rp) :: r, c(3), th, arc, a0(3), a1(3)
    integer :: i, j
    logical :: ok_r, ok_y, ok_sym
    character(60) :: what
    write(what, '(a,i0,a,f0.1)') 'bend_release ', n, ' angle ', bend_angle
    cfg = make_cfg(SCENE_BEND_RELEASE, n, 50.0_rp, 0.25_rp)
    cfg%scene%bend_angle = bend_angle
    cfg%scene%release_time = 0.5_rp      ! nothing constrained: never released
    call whole(cfg, u, cs)
    v = view(cs)
    r = cfg%lattice%lx / (bend_angle * pi / 180.0_rp)
    ok_r = .true.
    ok_y = .true.
    ok_sym = .true.
    do j = 0, n - 1
      c = [0.5_rp * cfg%lattice%lx, j * cfg%lattice%ay, r]
      do i = 0, n - 1
        ok_r = ok_r .and. abs(norm2(u(0:2, i, j) - c) - r) <= 1.0e-12_rp * r
        ok_y = ok_y .and. u(1, i, j) == j * cfg%lattice%ay
        ok_sym = ok_sym .and. abs(u(0, i, j) + u(0, n - 1 - i, j) - cfg%lattice%lx) <= 1.0e-12_rp * cfg%lattice%lx &
                        .and. abs(u(2, i, j) - u(2, n - 1 - i, j)) <= 1.0e-12_rp * cfg%lattice%lx
      end do
      ! the centre line: the end nodes subtend bend_angle, each half of it
      ! from the middle (x = lx/2, z = 0, the lowest point)
      a0 = u(0:2, 0, j) - c
      a1 = u(0:2, n - 1, j) - c
      th = acos(dot_product(a0, a1) / (norm2(a0) * norm2(a1)))
      call check_close(th * 180.0_rp / pi, bend_angle, 1.0e-10_rp, 0.0_rp, trim(what)//': arc subtends bend_angle')
      a1 = [0.0_rp, 0.0_rp, -r]
      th = acos(dot_product(a0, a1) / (norm2(a0) * r))
      call check_close(th * 180.0_rp / pi, 0.5_rp * bend_angle, 1.0e-10_rp, 0.0_rp, &
                       trim(what)//': end node at half the angle from the middle')
      ! arc lengths: R times the angle between neighbours, ax each, lx in all
      arc = 0.0_rp
      do i = 0, n - 2
        a0 = u(0:2, i, j) - c
        a1 = u(0:2, i + 1, j) - c
        th = 2.0_rp * asin(0.5_rp * norm2(a1 - a0) / r)
        call check_close(r * th, cfg%lattice%ax, 1.0e-12_rp, 0.0_rp, trim(what)//': x spacing kept along the arc')
        arc = arc + r * th
      end do
      call check_close(arc, cfg%lattice%lx, 1.0e-12_rp, 0.0_rp, trim(what)//': arc length lx')
      call check_true(u(2, 0, j) > 0.0_rp .and. u(2, n - 1, j) > 0.0_rp .and. &
                      all(u(2, :, j) >= 0.0_rp), trim(what)//': ends up')
    end do
    call check_true(ok_r, trim(what)//': every node on the circle of radius lx/angle')
    call check_true(ok_y, trim(what)//': y unchanged')
    call check_true(ok_sym, trim(what)//': symmetric about x = lx/2')
    call check_true(all(u(3:5, :, :) == 0.0_rp), trim(what)//': at rest')
    call check_true(v%n == 0 .and. .not. v%any_global .and. v%release_time == huge(1.0_rp), &
                    trim(what)//': nothing constrained, no release')
    call strips_agree(cfg, u, cs, trim(what))
  end subroutine bend_release

  !> wave_point: flat, the corner or edge i = 0 on the keyframe path.
  subroutine wave_point(nodes)
    character(*), intent(in) :: nodes
    type(nuno_config) :: cfg
    type(constraint_set_t) :: cs
    type(cset_view_t) :: v
    real(rp), allocatable :: u(:, :, :)
    real(rp) :: xb(3), vb(3), x0(3)
    integer :: k, w, m
    real(rp), parameter :: tw(2, 4) = reshape([0.0_rp, 0.5_rp, 0.5_rp, 1.0_rp, 1.0_rp, 3.0_rp, &
                                                 0.2_rp, 0.4_rp], [2, 4])
    ! (t, expected z offset) per window of tw: model.md's path
    real(rp) :: t, zexp, vexp
    character(40) :: what
    what = 'wave_point '//nodes
    cfg = make_cfg(SCENE_WAVE_POINT, 11, 100.0_rp, 1.0_rp)
    cfg%material%bending_code = BEND_NONE
    cfg%scene%wave_nodes = nodes
    cfg%scene%n_keyframes = 3
    cfg%scene%keyframe_time(1:3) = [0.0_rp, 0.5_rp, 1.0_rp]
    cfg%scene%keyframe_dz(1:3) = [0.0_rp, -10.0_rp, 15.0_rp]
    cfg%scene%keyframe_time(4) = 9.0_rp        ! beyond n_keyframes: not used
    cfg%scene%keyframe_dz(4) = 99.0_rp
    call whole(cfg, u, cs)
    v = view(cs)
    call check_true(flat_at_rest(cfg, u), trim(what)//': flat and at rest')
    call check_true(v%any_global .and. v%nk == 3, trim(what)//': constrained, three keyframes')
    if (nodes == 'corner') then
      call check_true(v%n == 1, trim(what)//': one node')
      call check_true(all(v%node(:, 1) == [0, 0]), trim(what)//': the corner (0, 0)')
    else
      call check_true(v%n == cfg%lattice%ny, trim(what)//': every node of edge i = 0')
      call check_true(all(v%node(1, 1:v%n) == 0), trim(what)//': edge i = 0')
    end if
    call check_true(all(v%path(1:v%n) == PATH_KEYFRAMES), trim(what)//': on the keyframe path')
    ! the path: z linear to -10 at 0.5, then to +15 at 1.0, then held; x, y at rest
    do w = 1, 4
      call constraints_set_window(cs, tw(1, w), tw(2, w))
      do m = 0, 4
        t = tw(1, w) + 0.25_rp * m * (tw(2, w) - tw(1, w))
        if (w == 1 .or. w == 4) then
          zexp = -10.0_rp * t / 0.5_rp
          vexp = -20.0_rp
        else if (w == 2) then
          zexp = -10.0_rp + 25.0_rp * (t - 0.5_rp) / 0.5_rp
          vexp = 50.0_rp
        else
          zexp = 15.0_rp
          vexp = 0.0_rp
        end if
        do k = 1, v%n
          x0 = [0.0_rp, v%node(2, k) * cfg%lattice%ay, 0.0_rp]
          call constraint_target(cs, k, t, xb, vb)
          call check_close_array(xb, x0 + [0.0_rp, 0.0_rp, zexp], 1.0e-14_rp, 1.0e-13_rp, &
                                 trim(what)//': prescribed position')
          call check_close_array(vb, [0.0_rp, 0.0_rp, vexp], 1.0e-14_rp, 1.0e-13_rp, &
                                 trim(what)//': prescribed velocity')
        end do
      end do
    end do
    call strips_agree(cfg, u, cs, trim(what))
  end subroutine wave_point

  !> hang: 1 x 1, 21 x 21, area masses, flat; corners of edge j = ny-1 pinned.
  subroutine hang()
    type(nuno_config) :: cfg
    type(constraint_set_t) :: cs
    type(cset_view_t) :: v
    real(rp), allocatable :: u(:, :, :)
    type(lattice_t) :: lat
    integer :: a, b
    cfg = make_cfg(SCENE_HANG, 21, 1.0_rp, 0.1_rp)
    cfg%material%bending_code = BEND_ENERGY
    cfg%lattice%mass_code = MASS_AREA
    call whole(cfg, u, cs)
    v = view(cs)
    call check_true(flat_at_rest(cfg, u), 'hang: flat and at rest')
    call check_close(maxval(u(0, :, :)) - minval(u(0, :, :)), 1.0_rp, 1.0e-14_rp, 0.0_rp, 'hang: 1 m along x')
    call check_close(maxval(u(1, :, :)) - minval(u(1, :, :)), 1.0_rp, 1.0e-14_rp, 0.0_rp, 'hang: 1 m along y')
    call lattice_init(lat, cfg, 0, cfg%lattice%ny - 1)
    call check_close(sum(lat%mass), 0.1_rp, 1.0e-14_rp, 0.0_rp, 'hang: 0.1 kg')
    call check_true(v%n == 2 .and. v%any_global .and. v%nk == 0, 'hang: two pinned nodes')
    a = findloc(v%node(1, 1:2), 0, dim=1)
    b = findloc(v%node(1, 1:2), 20, dim=1)
    call check_true(a > 0 .and. b > 0 .and. all(v%node(2, 1:2) == 20), 'hang: the corners of edge j = ny-1')
    call check_true(all(v%path(1:2) == PATH_FIXED), 'hang: pinned')
    if (a > 0 .and. b > 0) then
      call check_close_array(v%x0(:, a), [0.0_rp, 1.0_rp, 0.0_rp], 0.0_rp, 1.0e-14_rp, 'hang: corner (0, ny-1) at (0, 1, 0)')
      call check_close_array(v%x0(:, b), [1.0_rp, 1.0_rp, 0.0_rp], 0.0_rp, 1.0e-14_rp, 'hang: corner (nx-1, ny-1) at (1, 1, 0)')
    end if
    call check_true(v%release_time == huge(1.0_rp), 'hang: never released by default')
    call strips_agree(cfg, u, cs, 'hang')
  end subroutine hang

  !> flat: at rest in the plane, nothing constrained.
  subroutine flat()
    type(nuno_config) :: cfg
    type(constraint_set_t) :: cs
    type(cset_view_t) :: v
    real(rp), allocatable :: u(:, :, :)
    cfg = make_cfg(SCENE_FLAT, 9, 2.0_rp, 1.0_rp)
    cfg%scene%release_time = 1.0_rp
    call whole(cfg, u, cs)
    v = view(cs)
    call check_true(flat_at_rest(cfg, u), 'flat: flat and at rest')
    call check_true(v%n == 0 .and. .not. v%any_global .and. v%release_time == huge(1.0_rp), &
                    'flat: nothing constrained, no release')
    call strips_agree(cfg, u, cs, 'flat')
  end subroutine flat

  !> An initial spin: v = omega x (x - c) about the whole lattice's mass
  !> centroid c (computed here from the positions and node masses), on the
  !> whole lattice and on strips; the total momentum is zero.
  subroutine spin()
    type(nuno_config) :: cfg
    type(constraint_set_t) :: cs
    type(lattice_t) :: lat
    real(rp), allocatable :: u(:, :, :)
    real(rp) :: c(3), p(3), m, mt, om(3), v(3), vscale
    integer :: i, j
    logical :: ok
    cfg = make_cfg(SCENE_LIFT_RELEASE, 11, 100.0_rp, 1.0_rp)
    cfg%lattice%mass_code = MASS_AREA
    om = [0.3_rp, -0.2_rp, 0.7_rp]
    cfg%scene%initial_omega = om
    call whole(cfg, u, cs)
    call lattice_init(lat, cfg, 0, cfg%lattice%ny - 1)
    c = 0.0_rp
    mt = 0.0_rp
    do j = 0, cfg%lattice%ny - 1
      do i = 0, cfg%lattice%nx - 1
        c = c + lat%mass(i, j) * u(0:2, i, j)
        mt = mt + lat%mass(i, j)
      end do
    end do
    c = c / mt
    call check_true(c(3) > 0.0_rp, 'spin: the fold lifts the centroid')
    ok = .true.
    p = 0.0_rp
    vscale = 0.0_rp
    do j = 0, cfg%lattice%ny - 1
      do i = 0, cfg%lattice%nx - 1
        m = lat%mass(i, j)
        v = [om(2) * (u(2, i, j) - c(3)) - om(3) * (u(1, i, j) - c(2)), &
             om(3) * (u(0, i, j) - c(1)) - om(1) * (u(2, i, j) - c(3)), &
             om(1) * (u(1, i, j) - c(2)) - om(2) * (u(0, i, j) - c(1))]
        ok = ok .and. all(abs(u(3:5, i, j) - v) <= 1.0e-12_rp * norm2(om) * cfg%lattice%lx)
        p = p + m * u(3:5, i, j)
        vscale = max(vscale, norm2(v))
      end do
    end do
    call check_true(ok, 'spin: v = omega x (x - c)')
    call check_true(norm2(p) <= 1.0e-13_rp * mt * vscale, 'spin: zero total momentum')
    call check_true(all(scene_position(cfg, lat, 3, 4) == u(0:2, 3, 4)), 'spin: positions unchanged by the spin')
    call strips_agree(cfg, u, cs, 'spin')
  end subroutine spin

end program test_scenes
