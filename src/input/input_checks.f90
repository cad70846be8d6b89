! SPDX-License-Identifier: BSD-2-Clause
!> The configuration completed and checked after the namelist groups are
!> read (module input): the string choices as codes,
!> the keys whose default depends on others, and the checks, one small
!> routine per concern whose message names the group, the key and the
!> value (one key's checks: module input_bounds; &contact's: module
!> input_contact_checks). The choice lists come from the key table
!> (module input_keys).
!> No MPI, no PETSc: every rank reaches the same result alone.
module input_checks
  use kinds, only: rp
  use config, only: nuno_config, keyframe_max, unset_real, &
                    BEND_NONE, BEND_PAPER, BEND_ENERGY, SCALING_CONTINUUM, MASS_AREA, &
                    SCENE_LIFT_RELEASE, SCENE_BEND_RELEASE, SCENE_WAVE_POINT, SCENE_HANG, &
                    n_fit_kinds, fit_kind_names
  use input_text, only: lower, item_end
  use strings, only: real_short
  use input_bounds, only: choices, check_choice, need_int_ge, need_in_range, need_positive, need_nonnegative
  use input_contact_checks, only: check_contact
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

end module input_checks
