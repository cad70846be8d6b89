! SPDX-License-Identifier: BSD-2-Clause
!> The configuration completed and checked after the namelist groups are
!> read (module input): the string choices as codes,
!> the keys whose default depends on others, and the checks, one small
!> routine per concern whose message names the group, the key and the
!> value. The choice lists come from the key table (module input_keys).
!> No MPI, no PETSc: every rank reaches the same result alone.
module input_checks
  use kinds, only: rp
  use config, only: nuno_config, keyframe_max, unset_real, contact_config, obstacle_keyframe_max, obstacle_max, &
                    BEND_NONE, BEND_PAPER, BEND_ENERGY, SCALING_CONTINUUM, MASS_AREA, &
                    SCENE_LIFT_RELEASE, SCENE_BEND_RELEASE, SCENE_WAVE_POINT, SCENE_HANG, &
                    n_fit_kinds, fit_kind_names
  use input_keys, only: keys, key_index
  use input_text, only: lower, item_end
  use strings, only: real_short, itoa
  use contact, only: barrier
  implicit none
  private
  public :: derive_codes, resolve_unset, validate, check_choice, choices
  public :: check_lattice
  public :: fit_initial             ! module identify_params: a fit parameter's value in a configuration

contains

  ! ==========================================================================
  ! Scene defaults and derived values
  ! ==========================================================================

  !> String choices to integer codes.
  subroutine derive_codes(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    cfg%lattice%lattice_scaling = lower(adjustl(cfg%lattice%lattice_scaling))
    cfg%lattice%mass_distribution = lower(adjustl(cfg%lattice%mass_distribution))
    cfg%material%spring_model = lower(adjustl(cfg%material%spring_model))
    cfg%material%bending_model = lower(adjustl(cfg%material%bending_model))
    cfg%scene%wave_nodes = lower(adjustl(cfg%scene%wave_nodes))
    ! the unit system as the output names it ('SI' in capitals), any case in
    cfg%scene%units = lower(adjustl(cfg%scene%units))
    if (trim(cfg%scene%units) == 'si') cfg%scene%units = 'SI'
    call check_choice('lattice', 'lattice_scaling', cfg%lattice%lattice_scaling, choices('lattice_scaling'), &
                      cfg%lattice%scaling_code, ierr, msg)
    if (ierr /= 0) return
    if (len_trim(cfg%lattice%mass_distribution) == 0) then
      ! Unset: the continuum mode needs area masses; else the scene's default.
      if (cfg%lattice%scaling_code == SCALING_CONTINUUM .or. cfg%scene%scene_code == SCENE_HANG) then
        cfg%lattice%mass_distribution = 'area'
      else
        cfg%lattice%mass_distribution = 'uniform'
      end if
    end if
    call check_choice('lattice', 'mass_distribution', cfg%lattice%mass_distribution, choices('mass_distribution'), &
                      cfg%lattice%mass_code, ierr, msg)
    if (ierr /= 0) return
    call check_choice('material', 'spring_model', cfg%material%spring_model, choices('spring_model'), &
                      cfg%material%spring_code, ierr, msg)
    if (ierr /= 0) return
    call check_choice('material', 'bending_model', cfg%material%bending_model, choices('bending_model'), &
                      cfg%material%bending_code, ierr, msg)
    if (ierr /= 0) return
    cfg%material%bending_code = cfg%material%bending_code - 1   ! list order none, paper, energy = 0, 1, 2
  end subroutine derive_codes

  !> Keys left unset take defaults that depend on other keys:
  !> k_b: the scene's value in the chosen model, converted between a force per
  !> radian (paper) and an energy (energy) by the link length ax (docs/model.md 3);
  !> eta_b: 1e-4 for hang with energy bending, else 0.
  subroutine resolve_unset(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    real(rp) :: kb_paper, kb_energy
    ierr = 0
    msg = ''
    if (cfg%scene%scene_code == SCENE_HANG) then
      kb_energy = 0.1_rp
      kb_paper = kb_energy/cfg%lattice%ax
    else
      kb_paper = 1.0_rp
      kb_energy = kb_paper*cfg%lattice%ax
    end if
    if (cfg%material%k_b == unset_real) then
      select case (cfg%material%bending_code)
      case (BEND_PAPER);  cfg%material%k_b = kb_paper
      case (BEND_ENERGY); cfg%material%k_b = kb_energy
      case default;       cfg%material%k_b = 0.0_rp
      end select
    end if
    if (cfg%material%eta_b == unset_real) then
      cfg%material%eta_b = 0.0_rp
      if (cfg%scene%scene_code == SCENE_HANG .and. cfg%material%bending_code == BEND_ENERGY) cfg%material%eta_b = 1.0e-4_rp
    end if
  end subroutine resolve_unset

  ! ==========================================================================
  ! Checks: the first error wins
  ! ==========================================================================

  !> Every check of the configuration, in order: the range of a single key
  !> here, a concern that relates keys in its own routine. Derives on the way
  !> what the checks establish: the obstacles' shape codes and unit vectors,
  !> the fitted parameters' codes and bounds, the controlled components.
  subroutine validate(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: code
    associate (ma => cfg%material, sc => cfg%scene)
      ! The mass and the material constants within the key table's bounds
      ! (need_in_range): far beyond any cloth in either unit system, and
      ! such that no product of the model (forces, energies, their squares
      ! in the norms, K/m in the Newton matrix) can overflow: e_s = 1e308
      ! ran and failed every step ("try a smaller step").
      call need_in_range('lattice', 'total_mass', cfg%lattice%total_mass, ierr, msg); if (ierr /= 0) return
      call need_in_range('material', 'e_s', ma%e_s, ierr, msg);     if (ierr /= 0) return
      call need_in_range('material', 'eta_s', ma%eta_s, ierr, msg); if (ierr /= 0) return
      call need_in_range('material', 'e_d', ma%e_d, ierr, msg);     if (ierr /= 0) return
      call need_in_range('material', 'eta_d', ma%eta_d, ierr, msg); if (ierr /= 0) return
      call need_in_range('material', 'k_b', ma%k_b, ierr, msg);     if (ierr /= 0) return
      call need_in_range('material', 'eta_b', ma%eta_b, ierr, msg); if (ierr /= 0) return
      call check_scaling_bending(cfg, ierr, msg); if (ierr /= 0) return
      call check_scene_geometry(cfg, ierr, msg);  if (ierr /= 0) return
      call check_keyframes(cfg, ierr, msg);       if (ierr /= 0) return
      ! wave_point's driven nodes: the corner (0,0) or the whole edge i = 0;
      ! the unit system of the input's values: 'mm g s' or 'SI'.
      call check_choice('scene', 'wave_nodes', sc%wave_nodes, choices('wave_nodes'), code, ierr, msg)
      if (ierr /= 0) return
      call check_choice('scene', 'units', sc%units, choices('units'), code, ierr, msg); if (ierr /= 0) return
      call need_positive('time', 't_end', cfg%time%t_end, ierr, msg); if (ierr /= 0) return
      call need_positive('time', 'dt', cfg%time%dt, ierr, msg);       if (ierr /= 0) return
    end associate
    call check_output(cfg, ierr, msg);   if (ierr /= 0) return
    call check_identify(cfg, ierr, msg); if (ierr /= 0) return
    call check_control(cfg, ierr, msg);  if (ierr /= 0) return
    call check_contact(cfg, ierr, msg)
  end subroutine validate

  !> &contact: the barrier's parameters always (a key given is checked
  !> even without obstacles), each obstacle in use; contact with
  !> identification or control is refused (the adjoint is not exact with contact).
  subroutine check_contact(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: k, code
    character(8) :: sub
    associate (c => cfg%contact)
      call need_nonnegative('contact', 'contact_thickness', c%thickness, ierr, msg); if (ierr /= 0) return
      call need_positive('contact', 'contact_dhat', c%dhat, ierr, msg);             if (ierr /= 0) return
      call need_positive('contact', 'contact_stiffness', c%stiffness, ierr, msg);   if (ierr /= 0) return
      call need_positive('contact', 'friction_eps_v', c%eps_v, ierr, msg);          if (ierr /= 0) return
      ierr = 1
      if (c%n_obstacles < 0 .or. c%n_obstacles > size(c%shape)) then
        write(msg, '(a,i0,a,i0)') 'input: &contact: n_obstacles = ', c%n_obstacles, ' must be in 0..', size(c%shape)
        return
      end if
      do k = 1, c%n_obstacles
        write(sub, '(a,i0,a)') '(', k, ')'
        c%shape(k) = lower(adjustl(c%shape(k)))
        call check_choice('contact', 'obstacle_shape'//trim(sub), c%shape(k), &
                          choices('obstacle_shape'), code, ierr, msg)
        if (ierr /= 0) return
        c%shape_code(k) = code
        ierr = 1
        if (c%mu(k) < 0.0_rp) then
          msg = 'input: &contact: obstacle_mu'//trim(sub)//' = '//real_short(c%mu(k))//' must be >= 0'
          return
        end if
        call check_obstacle_shape(c, k, ierr, msg); if (ierr /= 0) return
        call check_obstacle_motion(c, k, ierr, msg); if (ierr /= 0) return
        ierr = 1
      end do
      call check_unused_obstacles(c, ierr, msg); if (ierr /= 0) return
      if (c%n_obstacles > 0) then
        call check_contact_scales(cfg, ierr, msg); if (ierr /= 0) return
      end if
      ierr = 1
      ! The adjoint would be inexact with contact (docs/identification.md,
      ! "Contact"): friction's lagged normal force is not differentiated, the
      ! curved obstacles' Jacobian is PSD-projected, and the step limit's
      ! retries change the step sequence with the parameters.
      if (c%n_obstacles > 0 .and. (cfg%identify%active .or. cfg%control%active)) then
        write(msg, '(a,i0,a)') 'input: &contact: n_obstacles = ', c%n_obstacles, ' is refused with '// &
          trim(merge('&identify', '&control ', cfg%identify%active))//': the adjoint gradient is not exact with contact '// &
          "(friction's lag is not differentiated; docs/identification.md)"
        return
      end if
      ierr = 0
      msg = ''
    end associate
  end subroutine check_contact

  !> Obstacles described beyond n_obstacles: a key of an obstacle k >
  !> n_obstacles with a value other than its default is refused by name,
  !> rather than ignored (the obstacle would not be there).
  subroutine check_unused_obstacles(c, ierr, msg)
    type(contact_config), intent(in) :: c
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    type(contact_config) :: d
    integer :: k
    character(12) :: sub, sub3, sub2
    character(:), allocatable :: what
    ierr = 0
    msg = ''
    do k = max(c%n_obstacles, 0) + 1, obstacle_max
      write(sub, '(a,i0,a)') '(', k, ')'
      write(sub3, '(a,i0,a)') '(:, ', k, ')'
      write(sub2, '(a,i0,a)') '(:, ', k, ')'
      what = ''
      if (lower(adjustl(c%shape(k))) /= lower(adjustl(d%shape(k)))) then
        what = 'obstacle_shape'//trim(sub)//' = '''//trim(adjustl(c%shape(k)))//''''
      else if (any(c%point(:, k) /= d%point(:, k))) then
        what = 'obstacle_point'//trim(sub3)//' = '//vec_text(c%point(:, k))
      else if (any(c%normal(:, k) /= d%normal(:, k))) then
        what = 'obstacle_normal'//trim(sub3)//' = '//vec_text(c%normal(:, k))
      else if (any(c%axis(:, k) /= d%axis(:, k))) then
        what = 'obstacle_axis'//trim(sub3)//' = '//vec_text(c%axis(:, k))
      else if (any(c%half_size(:, k) /= d%half_size(:, k))) then
        what = 'obstacle_half_size'//trim(sub3)//' = '//vec_text(c%half_size(:, k))
      else if (any(c%end_pt(:, k) /= d%end_pt(:, k))) then
        what = 'obstacle_end'//trim(sub3)//' = '//vec_text(c%end_pt(:, k))
      else if (c%radius(k) /= d%radius(k)) then
        what = 'obstacle_radius'//trim(sub)//' = '//real_short(c%radius(k))
      else if (c%mu(k) /= d%mu(k)) then
        what = 'obstacle_mu'//trim(sub)//' = '//real_short(c%mu(k))
      else if (c%n_keyframes(k) /= d%n_keyframes(k)) then
        what = 'obstacle_n_keyframes'//trim(sub)//' = '//itoa(c%n_keyframes(k))
      else if (any(c%key_time(:, k) /= d%key_time(:, k))) then
        what = 'obstacle_time'//trim(sub2)
      else if (any(c%key_offset(:, :, k) /= d%key_offset(:, :, k))) then
        what = 'obstacle_offset(:, :, '//itoa(k)//')'
      else if (any(c%key_close(:, k) /= d%key_close(:, k))) then
        what = 'obstacle_close'//trim(sub2)
      else if (any(c%close_dir(:, k) /= d%close_dir(:, k))) then
        what = 'obstacle_close_dir'//trim(sub3)//' = '//vec_text(c%close_dir(:, k))
      end if
      if (len(what) == 0) cycle
      ierr = 1
      msg = 'input: &contact: '//what//' describes obstacle '//itoa(k)//', beyond n_obstacles = '// &
            itoa(c%n_obstacles)//': set n_obstacles = '//itoa(k)//' (or more), or leave the key out'
      return
    end do
  end subroutine check_unused_obstacles

  !> The barrier's and friction's parameters against the scene's scales
  !> (input/README.md, "&contact", where the reasons are), a the smaller
  !> lattice spacing, m_max and m_min the heaviest and the lightest node,
  !> g0 = |gravity|, dt the step:
  !>   contact_dhat in [1e-4 a, a];
  !>   contact_stiffness at most 100 m_min / dt^2, and with gravity at
  !>     least the stiffness whose barrier holds m_max g0 at a gap of
  !>     1e-5 contact_dhat (ten times the acceptance floor);
  !>   friction_eps_v in [1e-7, 1] a / dt where some obstacle has friction.
  subroutine check_contact_scales(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    real(rp) :: a, mmax, mmin, g0, dt, lo, hi, e, de, d2e
    ierr = 1
    associate (c => cfg%contact, l => cfg%lattice)
      a = min(l%ax, l%ay)
      if (l%mass_code == MASS_AREA) then
        mmax = l%total_mass / real((l%nx - 1) * (l%ny - 1), rp)
        mmin = 0.25_rp * mmax
      else
        mmax = l%total_mass / real(l%nx * l%ny, rp)
        mmin = mmax
      end if
      g0 = norm2(cfg%scene%gravity)
      dt = cfg%time%dt
      lo = 1.0e-4_rp * a
      hi = a
      if (.not. (c%dhat >= lo .and. c%dhat <= hi)) then
        msg = 'input: &contact: contact_dhat = '//real_short(c%dhat)//' must be between 1e-4 and 1 times the '// &
              'lattice spacing '//real_short(a)//' ('//real_short(lo)//' .. '//real_short(hi)// &
              '): the barrier acts on the nodes, within a link of an obstacle (input/README.md, "&contact")'
        return
      end if
      hi = 100.0_rp * mmin / dt**2
      if (.not. (c%stiffness <= hi)) then
        msg = 'input: &contact: contact_stiffness = '//real_short(c%stiffness)//' must be at most 100 m/dt^2 = '// &
              real_short(hi)//' (m = '//real_short(mmin)//' the lightest node, dt = '//real_short(dt)// &
              '): a stiffer barrier stops Newton at every impact (input/README.md, "&contact")'
        return
      end if
      if (g0 > 0.0_rp) then
        call barrier(1.0e-5_rp * c%dhat, c%dhat, e, de, d2e)
        lo = mmax * g0 / abs(de)
        if (.not. (c%stiffness >= lo)) then
          msg = 'input: &contact: contact_stiffness = '//real_short(c%stiffness)//' must be at least '// &
                real_short(lo)//': the barrier must hold the heaviest node''s weight (m g = '//real_short(mmax * g0)// &
                ') at a gap of at least 1e-5 contact_dhat, ten times the acceptance floor (input/README.md, "&contact")'
          return
        end if
      end if
      if (any(c%mu(1:c%n_obstacles) > 0.0_rp)) then
        lo = 1.0e-7_rp * a / dt
        hi = a / dt
        if (.not. (c%eps_v >= lo .and. c%eps_v <= hi)) then
          msg = 'input: &contact: friction_eps_v = '//real_short(c%eps_v)//' must be between 1e-7 and 1 times a/dt = '// &
                real_short(a / dt)//' (the lattice spacing '//real_short(a)//' a step, dt = '//real_short(dt)//'; '// &
                real_short(lo)//' .. '//real_short(hi)//'): friction''s smoothing band (input/README.md, "&contact")'
          return
        end if
      end if
    end associate
    ierr = 0
    msg = ''
  end subroutine check_contact_scales

  !> Obstacle k's geometry by its shape (code: 1 plane, 2 sphere, 3 box,
  !> 4 capsule): a plane's normal and a box's axes normalised (the box's x
  !> axis orthogonalised against its normal, its local z); radii and half
  !> extents > 0.
  subroutine check_obstacle_shape(c, k, ierr, msg)
    type(contact_config), intent(inout) :: c
    integer, intent(in) :: k
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(12) :: sub, sub3
    real(rp) :: nn, a(3), na
    write(sub, '(a,i0,a)') '(', k, ')'
    write(sub3, '(a,i0,a)') '(:, ', k, ')'
    ierr = 1
    if (c%shape_code(k) == 1 .or. c%shape_code(k) == 3) then
      nn = norm2(c%normal(:, k))
      if (.not. (nn > 0.0_rp)) then
        msg = 'input: &contact: obstacle_normal'//trim(sub3)//' = '//vec_text(c%normal(:, k))//' must not be zero'
        return
      end if
      c%normal(:, k) = c%normal(:, k) / nn
    end if
    select case (c%shape_code(k))
    case (2, 4)
      if (.not. (c%radius(k) > 0.0_rp)) then
        msg = 'input: &contact: obstacle_radius'//trim(sub)//' = '//real_short(c%radius(k))// &
              ' must be > 0 for a '//trim(c%shape(k))
        return
      end if
    case (3)
      if (.not. all(c%half_size(:, k) > 0.0_rp)) then
        msg = 'input: &contact: obstacle_half_size'//trim(sub3)//' = '//vec_text(c%half_size(:, k))// &
              ' must be > 0 (each) for a box'
        return
      end if
      ! the box's local x: the given axis less its part along the normal (local z)
      a = c%axis(:, k) - dot_product(c%axis(:, k), c%normal(:, k)) * c%normal(:, k)
      na = norm2(a)
      if (.not. (na > 1.0e-6_rp * norm2(c%axis(:, k)))) then
        msg = 'input: &contact: obstacle_axis'//trim(sub3)//' = '//vec_text(c%axis(:, k))// &
              ' must not be zero nor parallel to obstacle_normal'//trim(sub3)//' = '//vec_text(c%normal(:, k))
        return
      end if
      c%axis(:, k) = a / na
    end select
    ierr = 0
    msg = ''
  end subroutine check_obstacle_shape

  !> Obstacle k's keyframes: 0..obstacle_keyframe_max of them, times >= 0
  !> and strictly increasing, a closing direction (normalised) where a
  !> closing offset is given; offsets beyond the keyframes in use are
  !> refused rather than ignored.
  subroutine check_obstacle_motion(c, k, ierr, msg)
    type(contact_config), intent(inout) :: c
    integer, intent(in) :: k
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(24) :: sub, sub2
    integer :: nk, j
    real(rp) :: nd
    nk = c%n_keyframes(k)
    write(sub, '(a,i0,a)') '(', k, ')'
    ierr = 1
    if (nk < 0 .or. nk > obstacle_keyframe_max) then
      write(msg, '(a,i0,a,i0)') 'input: &contact: obstacle_n_keyframes'//trim(sub)//' = ', nk, ' must be in 0..', &
        obstacle_keyframe_max
      return
    end if
    do j = 1, nk
      write(sub2, '(a,i0,a,i0,a)') '(', j, ', ', k, ')'
      if (c%key_time(j, k) < 0.0_rp .or. (j > 1 .and. .not. (c%key_time(j, k) > c%key_time(max(j - 1, 1), k)))) then
        msg = 'input: &contact: obstacle_time'//trim(sub2)//' = '//real_short(c%key_time(j, k))// &
              ' must be >= 0 and greater than the keyframe before'
        return
      end if
    end do
    do j = nk + 1, obstacle_keyframe_max
      write(sub2, '(a,i0,a,i0,a)') '(', j, ', ', k, ')'
      if (c%key_time(j, k) /= 0.0_rp) then
        write(msg, '(a,i0,a)') 'input: &contact: obstacle_time'//trim(sub2)//' = '//real_short(c%key_time(j, k))// &
          ' is beyond obstacle_n_keyframes'//trim(sub)//' = ', nk, ': set obstacle_n_keyframes'
        return
      end if
      write(sub2, '(a,i0,a,i0,a)') '(:, ', j, ', ', k, ')'
      if (any(c%key_offset(:, j, k) /= 0.0_rp)) then
        write(msg, '(a,i0,a)') 'input: &contact: obstacle_offset'//trim(sub2)//' = '//vec_text(c%key_offset(:, j, k))// &
          ' is beyond obstacle_n_keyframes'//trim(sub)//' = ', nk, ': set obstacle_n_keyframes'
        return
      end if
      write(sub2, '(a,i0,a,i0,a)') '(', j, ', ', k, ')'
      if (c%key_close(j, k) /= 0.0_rp) then
        write(msg, '(a,i0,a)') 'input: &contact: obstacle_close'//trim(sub2)//' = '//real_short(c%key_close(j, k))// &
          ' is beyond obstacle_n_keyframes'//trim(sub)//' = ', nk, ': set obstacle_n_keyframes'
        return
      end if
    end do
    if (any(c%key_close(1:nk, k) /= 0.0_rp)) then
      nd = norm2(c%close_dir(:, k))
      if (.not. (nd > 0.0_rp)) then
        write(sub2, '(a,i0,a)') '(:, ', k, ')'
        msg = 'input: &contact: obstacle_close_dir'//trim(sub2)//' = '//vec_text(c%close_dir(:, k))// &
              ' must not be zero: obstacle '//trim(adjustl(sub(2:len_trim(sub) - 1)))//' has closing offsets'
        return
      end if
      c%close_dir(:, k) = c%close_dir(:, k) / nd
    end if
    ierr = 0
    msg = ''
  end subroutine check_obstacle_motion

  !> "a, b, c" of a 3-vector, as the namelist would write it back short.
  function vec_text(v) result(s)
    real(rp), intent(in) :: v(3)
    character(:), allocatable :: s
    s = real_short(v(1))//', '//real_short(v(2))//', '//real_short(v(3))
  end function vec_text

  !> &identify: known, distinct parameter names, each with an initial guess
  !> > 0 (fitted in log space) inside its bounds; a model that has the
  !> parameter; an observed file named. The names go to cfg%fit_code.
  subroutine check_identify(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: rest, name
    integer :: p, k, code
    real(rp) :: p0

    ierr = 0
    msg = ''
    cfg%identify%n_fit = 0
    if (.not. cfg%identify%active) return
    ierr = 1
    if (len_trim(cfg%identify%observed_file) == 0) then
      msg = "input: &identify: observed_file is required (an HDF5 file with /time and /position [nt][ny][nx][3])"
      return
    end if
    rest = lower(trim(adjustl(cfg%identify%fit)))
    if (len(rest) == 0) then
      msg = 'input: &identify: fit is required: a comma-separated list of '//kinds_list()
      return
    end if
    do while (len(rest) > 0)
      p = item_end(rest, 1, ',')
      name = trim(adjustl(rest(1:p - 1)))
      rest = trim(adjustl(rest(min(p + 1, len(rest) + 1):)))
      code = 0
      do k = 1, n_fit_kinds
        if (name == trim(fit_kind_names(k))) code = k
      end do
      if (code == 0) then
        msg = "input: &identify: fit: unknown parameter '"//name//"' (known: "//kinds_list()//')'
        return
      end if
      if (any(cfg%identify%fit_code(1:cfg%identify%n_fit) == code)) then
        msg = "input: &identify: fit: '"//name//"' is named twice"
        return
      end if
      cfg%identify%n_fit = cfg%identify%n_fit + 1
      cfg%identify%fit_code(cfg%identify%n_fit) = code
      if ((code == 5 .or. code == 6) .and. cfg%material%bending_code == BEND_NONE) then
        msg = "input: &identify: fit: '"//name//"' needs bending (&material bending_model = 'none')"
        return
      end if
      if (code == 6 .and. cfg%material%bending_code /= BEND_ENERGY) then
        msg = "input: &identify: fit: 'eta_b' exists only with bending_model = 'energy'"
        return
      end if
      p0 = fit_initial(cfg, code)
      if (.not. (p0 > 0.0_rp)) then
        msg = "input: &identify: fit: '"//name//"' = "//real_short(p0)//' cannot be fitted: parameters are '// &
              'fitted in log space, so the initial guess (the namelist value) must be > 0'
        return
      end if
      k = cfg%identify%n_fit
      if (cfg%identify%fit_lower(k) == unset_real) cfg%identify%fit_lower(k) = p0 / 1000.0_rp
      if (cfg%identify%fit_upper(k) == unset_real) cfg%identify%fit_upper(k) = p0 * 1000.0_rp
      if (.not. (cfg%identify%fit_lower(k) > 0.0_rp .and. cfg%identify%fit_lower(k) <= p0 .and. p0 <= cfg%identify%fit_upper(k))) then
        msg = "input: &identify: the bounds of '"//name//"' must satisfy 0 < fit_lower <= initial guess <= "// &
              'fit_upper (got '//real_short(cfg%identify%fit_lower(k))//' <= '//real_short(p0)//' <= '//real_short(cfg%identify%fit_upper(k))//')'
        return
      end if
    end do
    if (.not. (cfg%identify%tikhonov >= 0.0_rp)) then
      msg = 'input: &identify: tikhonov must be >= 0 (got '//real_short(cfg%identify%tikhonov)//')'
      return
    end if
    ierr = 0
  contains
    function kinds_list() result(s)
      character(:), allocatable :: s
      integer :: m
      s = trim(fit_kind_names(1))
      do m = 2, n_fit_kinds
        s = s//', '//trim(fit_kind_names(m))
      end do
    end function kinds_list
  end subroutine check_identify

  !> &control: not with &identify; a target file; a scene with keyframed
  !> nodes and at least two keyframes (the steps between them are what is
  !> optimised); components letters of xyz, each once; max_speed > 0 when
  !> set, and the initial keyframes within it; weights >= 0. The letters go
  !> to cfg%control_comp.
  subroutine check_control(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(*), parameter :: xyz = 'xyz'
    character(len=:), allocatable :: comps
    real(rp) :: off(3, keyframe_max), dt, speed
    integer :: k, c, m
    character(16) :: a, b

    ierr = 0
    msg = ''
    cfg%control%control_comp = .false.
    if (.not. cfg%control%active) return
    ierr = 1
    if (cfg%identify%active) then
      msg = 'input: &control and &identify cannot be in one input: a run either fits the model to an '// &
            'observation or optimises the keyframes for a target'
      return
    end if
    if (len_trim(cfg%control%target_file) == 0) then
      msg = 'input: &control: target_file is required (an HDF5 file with /time and /position [nt][ny][nx][3])'
      return
    end if
    if (cfg%scene%scene_code /= SCENE_WAVE_POINT) then
      msg = "input: &control: scene = '"//trim(cfg%scene%name)//"' has no nodes on a keyframe path to control "// &
            "(wave_point drives its corner or, with wave_nodes = 'edge', its edge i = 0)"
      return
    end if
    if (cfg%scene%n_keyframes < 2) then
      write(a, '(i0)') cfg%scene%n_keyframes
      msg = 'input: &control: &scene n_keyframes = '//trim(a)//' leaves nothing to optimise: the steps '// &
            'between consecutive keyframes are the controls, so at least 2 keyframes are needed'
      return
    end if
    comps = lower(trim(adjustl(cfg%control%components)))
    if (len(comps) == 0 .or. verify(comps, xyz) /= 0) then
      msg = "input: &control: components = '"//trim(cfg%control%components)//"' must be letters among x, y, z (e.g. 'z' or 'xyz')"
      return
    end if
    do k = 1, len(comps)
      c = index(xyz, comps(k:k))
      if (cfg%control%control_comp(c)) then
        msg = "input: &control: components = '"//trim(cfg%control%components)//"' names "//comps(k:k)//' twice'
        return
      end if
      cfg%control%control_comp(c) = .true.
    end do
    if (cfg%control%max_speed /= unset_real) then
      call need_positive('control', 'max_speed', cfg%control%max_speed, ierr, msg)
      if (ierr /= 0) return
      ierr = 1
      off(1, :) = cfg%scene%keyframe_dx
      off(2, :) = cfg%scene%keyframe_dy
      off(3, :) = cfg%scene%keyframe_dz
      do m = 2, cfg%scene%n_keyframes
        dt = cfg%scene%keyframe_time(m) - cfg%scene%keyframe_time(m - 1)
        do c = 1, 3
          if (.not. cfg%control%control_comp(c)) cycle
          speed = abs(off(c, m) - off(c, m - 1)) / dt
          if (speed > cfg%control%max_speed * (1.0_rp + 1.0e-12_rp)) then
            write(a, '(i0)') m
            write(b, '(i0)') m - 1
            msg = 'input: &control: the initial keyframes exceed max_speed = '//real_short(cfg%control%max_speed)// &
                  ': keyframe_d'//xyz(c:c)//'('//trim(a)//') - keyframe_d'//xyz(c:c)//'('//trim(b)//') = '// &
                  real_short(off(c, m) - off(c, m - 1))//' in '//real_short(dt)//' is a speed of '//real_short(speed)
            return
          end if
        end do
      end do
    end if
    call need_nonnegative('control', 'velocity_weight', cfg%control%velocity_weight, ierr, msg); if (ierr /= 0) return
    call need_nonnegative('control', 'keyframe_tikhonov', cfg%control%keyframe_tikhonov, ierr, msg)
  end subroutine check_control

  !> The namelist value of fit parameter `code` (the initial guess).
  pure real(rp) function fit_initial(cfg, code)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: code
    select case (code)
    case (1); fit_initial = cfg%material%e_s
    case (2); fit_initial = cfg%material%e_d
    case (3); fit_initial = cfg%material%eta_s
    case (4); fit_initial = cfg%material%eta_d
    case (5); fit_initial = cfg%material%k_b
    case (6); fit_initial = cfg%material%eta_b
    case default; fit_initial = cfg%lattice%total_mass
    end select
  end function fit_initial

  !> The allowed values of choice key `key` (the key table's list; its order
  !> is the order of the codes in module config).
  function choices(key) result(s)
    character(*), intent(in) :: key
    character(:), allocatable :: s
    s = trim(keys(key_index(key))%allowed)
  end function choices

  !> value (lower case) must be one of the comma-separated `allowed`; code = its position.
  subroutine check_choice(group, key, value, allowed, code, ierr, msg)
    character(*), intent(in) :: group, key, value, allowed
    integer, intent(out) :: code, ierr
    character(*), intent(out) :: msg
    integer :: p, q, n
    ierr = 0
    msg = ''
    code = 0
    n = 0
    p = 1
    do while (p <= len(allowed))
      q = item_end(allowed, p, ',')
      n = n + 1
      if (trim(adjustl(allowed(p:q - 1))) == trim(value)) then
        code = n
        return
      end if
      p = q + 1
    end do
    ierr = 1
    msg = 'input: &'//group//': '//key//" = '"//trim(value)//"' is not one of "//allowed
  end subroutine check_choice

  !> The lattice's node counts and extent, before its spacing is derived.
  subroutine check_lattice(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_int_ge('lattice', 'nx', cfg%lattice%nx, 3, ierr, msg); if (ierr /= 0) return
    call need_int_ge('lattice', 'ny', cfg%lattice%ny, 3, ierr, msg); if (ierr /= 0) return
    call need_positive('lattice', 'lx', cfg%lattice%lx, ierr, msg);  if (ierr /= 0) return
    call need_positive('lattice', 'ly', cfg%lattice%ly, ierr, msg)
  end subroutine check_lattice

  !> The paper bending force does not scale with the spacing: no continuum limit.
  subroutine check_scaling_bending(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    if (cfg%lattice%scaling_code == SCALING_CONTINUUM .and. cfg%material%bending_code == BEND_PAPER) then
      ierr = 1
      msg = "input: &material: bending_model = 'paper' has no continuum limit: " // &
            "not allowed with &lattice lattice_scaling = 'continuum' (use 'energy' or 'none')"
    else if (cfg%lattice%scaling_code == SCALING_CONTINUUM .and. cfg%lattice%mass_code /= MASS_AREA) then
      ierr = 1
      msg = "input: &lattice: mass_distribution = '"//trim(cfg%lattice%mass_distribution)// &
            "' not allowed with lattice_scaling = 'continuum' (needs 'area')"
    end if
  end subroutine check_scaling_bending

  !> Geometry keys of the scene in use; the others are not used and not checked.
  subroutine check_scene_geometry(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: i_fold
    real(rp) :: flap
    ierr = 0
    msg = ''
    if (.not. (cfg%scene%release_time >= 0.0_rp)) then
      ierr = 1
      msg = 'input: &scene: release_time = '//real_short(cfg%scene%release_time)//' must be >= 0'
      return
    end if
    select case (cfg%scene%scene_code)
    case (SCENE_LIFT_RELEASE)
      call need_positive('scene', 'lift_length', cfg%scene%lift_length, ierr, msg); if (ierr /= 0) return
      call need_nonnegative('scene', 'lift_height', cfg%scene%lift_height, ierr, msg); if (ierr /= 0) return
      ! The fold line is the node column nearest to x = lx - lift_length.
      i_fold = nint((cfg%lattice%lx - cfg%scene%lift_length)/cfg%lattice%ax)
      if (i_fold < 0 .or. i_fold >= cfg%lattice%nx - 1) then
        ierr = 1
        msg = 'input: &scene: lift_length = '//real_short(cfg%scene%lift_length)// &
              ' leaves no part to lift (must lie between ax/2 and lx)'
        return
      end if
      flap = cfg%lattice%lx - real(i_fold, rp)*cfg%lattice%ax
      if (cfg%scene%lift_height > flap*(1.0_rp + 1.0e-12_rp)) then
        ierr = 1
        msg = 'input: &scene: lift_height = '//real_short(cfg%scene%lift_height)// &
              ' must be <= the length of the lifted part ('//real_short(flap)//')'
      end if
    case (SCENE_BEND_RELEASE)
      if (.not. (cfg%scene%bend_angle >= 0.0_rp .and. cfg%scene%bend_angle < 360.0_rp)) then
        ierr = 1
        msg = 'input: &scene: bend_angle = '//real_short(cfg%scene%bend_angle)//' must be in [0, 360) degrees'
      end if
    end select
  end subroutine check_scene_geometry

  subroutine check_keyframes(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(16) :: a, b
    integer :: k
    ierr = 0
    msg = ''
    if (cfg%scene%n_keyframes < 1 .or. cfg%scene%n_keyframes > keyframe_max) then
      ierr = 1
      write(a, '(i0)') cfg%scene%n_keyframes
      write(b, '(i0)') keyframe_max
      msg = 'input: &scene: n_keyframes = '//trim(a)//' must be in 1..'//trim(b)
      return
    end if
    if (.not. (cfg%scene%keyframe_time(1) >= 0.0_rp)) then
      ierr = 1
      msg = 'input: &scene: keyframe_time(1) = '//real_short(cfg%scene%keyframe_time(1))//' must be >= 0'
      return
    end if
    do k = 2, cfg%scene%n_keyframes
      if (.not. (cfg%scene%keyframe_time(k) > cfg%scene%keyframe_time(k - 1))) then
        ierr = 1
        write(a, '(i0)') k
        write(b, '(i0)') k - 1
        msg = 'input: &scene: keyframe_time('//trim(a)//') = '//real_short(cfg%scene%keyframe_time(k))// &
              ' must be > keyframe_time('//trim(b)//') = '//real_short(cfg%scene%keyframe_time(k - 1))// &
              ' (strictly increasing)'
        return
      end if
    end do
  end subroutine check_keyframes

  subroutine check_output(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_positive('output', 'output_interval', cfg%output%output_interval, ierr, msg)
    if (ierr /= 0) return
    if (cfg%output%stretch_limit /= 0.0_rp .and. .not. cfg%output%stretch_limit > 1.0_rp) then
      ierr = 1
      msg = 'input: &output: stretch_limit = '//real_short(cfg%output%stretch_limit)//' must be > 1 (or 0: no warning)'
      return
    end if
    if (cfg%output%checkpoint_interval < 0.0_rp) then
      ierr = 1
      msg = 'input: &output: checkpoint_interval = '//real_short(cfg%output%checkpoint_interval)// &
            ' must be >= 0 (0: a checkpoint at the end of the run only)'
      return
    end if
    if (len_trim(cfg%output%output_file) == 0) then
      ierr = 1
      msg = "input: &output: output_file = '' must not be empty"
    end if
  end subroutine check_output

  subroutine need_int_ge(group, key, value, lo, ierr, msg)
    character(*), intent(in) :: group, key
    integer, intent(in) :: value, lo
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(16) :: a, b
    ierr = 0
    msg = ''
    if (value < lo) then
      ierr = 1
      write(a, '(i0)') value
      write(b, '(i0)') lo
      msg = 'input: &'//group//': '//key//' = '//trim(a)//' must be >= '//trim(b)
    end if
  end subroutine need_int_ge

  !> value within the bounds of key's `allowed` in the key table ('>= A',
  !> '> A', '<= B', '< B', separated by ', '); NaN fails too. The message
  !> gives the range as the table (and input/README.md) writes it.
  subroutine need_in_range(group, key, value, ierr, msg)
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: value
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: allowed, part
    real(rp) :: bound
    integer :: p, q, ios, w
    logical :: ok

    ierr = 0
    msg = ''
    allowed = trim(keys(key_index(key))%allowed)
    ok = value == value
    p = 1
    do while (p <= len(allowed) .and. ok)
      q = item_end(allowed, p, ', ')
      part = allowed(p:q - 1)
      w = merge(2, 1, part(2:2) == '=')
      read(part(w + 1:), *, iostat=ios) bound
      if (ios /= 0) part = '?'
      select case (part(1:w))
      case ('>=');  ok = value >= bound
      case ('>');   ok = value > bound
      case ('<=');  ok = value <= bound
      case ('<');   ok = value < bound
      case default
        ierr = 1
        msg = 'input: the key table''s range of '//key//' is not bounds: '//allowed   ! (test_input_text)
        return
      end select
      p = q + 2
    end do
    if (.not. ok) then
      ierr = 1
      msg = 'input: &'//group//': '//key//' = '//real_short(value)//' must be '//allowed// &
            ' (input/README.md, &'//group//')'
    end if
  end subroutine need_in_range

  !> value > 0 (NaN fails too).
  subroutine need_positive(group, key, value, ierr, msg)
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: value
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    if (.not. (value > 0.0_rp .and. value <= huge(value))) then
      ierr = 1
      msg = 'input: &'//group//': '//key//' = '//real_short(value)//' must be > 0'
    end if
  end subroutine need_positive

  !> value >= 0 (NaN fails too).
  subroutine need_nonnegative(group, key, value, ierr, msg)
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: value
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    if (.not. (value >= 0.0_rp .and. value <= huge(value))) then
      ierr = 1
      msg = 'input: &'//group//': '//key//' = '//real_short(value)//' must be >= 0'
    end if
  end subroutine need_nonnegative

end module input_checks
