! SPDX-License-Identifier: BSD-2-Clause
!> The parameters of an identification or a control (docs/identification.md):
!> which variables theta the optimisation moves, their bounds, scaling and
!> Tikhonov weight, and how theta enters the configuration.
!>
!> Identification: theta = ln p for the fitted p (&identify fit).
!> Control: theta = the steps d = koff(c, m) - koff(c, m-1) of the keyframe
!> path of the driven nodes into keyframes m = 2..nk, for the chosen
!> components c (&control components), so that a bound on the speed of a
!> segment, |d| <= max_speed (kt(m) - kt(m-1)), is a bound on one variable.
module identify_params
  use kinds, only: rp
  use config, only: nuno_config, fit_kind_names, unset_real
  use input_checks, only: fit_initial
  use constraints, only: constraint_set_t, constraint_step_sensitivity
  implicit none
  private
  public :: ident_params_t, params_setup_identify, params_setup_control, keyframes, row_values, apply_theta, &
            values_text, max_speed_of, var_name, check_direction, control_variables, step_sensitivities
  public :: params_mode, params_tag, params_np, params_nrow, params_initial, params_bounds, &
            params_tikhonov, params_fd_step, params_code, params_nk, params_times, params_initial_offsets
  public :: MODE_IDENTIFY, MODE_CONTROL, FD_STEP

  integer, parameter :: MODE_IDENTIFY = 1, MODE_CONTROL = 2
  !> Step of the central differences (the Gauss-Newton Hessian of the
  !> uncertainty, -identify_check_gradient): in ln p; for control in the
  !> keyframe positions, times the cloth size max(lx, ly).
  real(rp), parameter :: FD_STEP = 1.0e-4_rp, FD_STEP_LENGTH = 1.0e-5_rp
  !> No bound: TAO's PETSC_INFINITY (PETSC_MAX_REAL / 4; no Fortran name in 3.18).
  real(rp), parameter :: NO_BOUND = huge(1.0_rp) / 4
  character(len=1), parameter :: XYZ(3) = ['x', 'y', 'z']

  !> The optimisation variables; written only by params_setup_identify and
  !> params_setup_control.
  type :: ident_params_t
    private
    integer :: mode = MODE_IDENTIFY
    character(len=8) :: tag = 'identify'          !< prefix of the printed lines: identify | control
    integer :: np = 0                             !< TAO variables theta
    real(rp), allocatable :: theta0(:)            !< (np) initial theta
    real(rp), allocatable :: lo(:), hi(:)         !< (np) bounds of theta
    real(rp) :: tikhonov = 0                      !< weight of sum (theta - theta0)^2
    real(rp) :: fd_step = FD_STEP                 !< step of the central differences in theta
    integer :: nrow = 0                           !< values per history row after the objective
    ! identification: theta = ln p
    integer, allocatable :: code(:)               !< (np) parameter codes (config: fit_kind_names)
    ! control: theta(k) = step of component kc(k) into keyframe km(k)
    integer, allocatable :: km(:), kc(:)          !< (np) keyframe 2..nk, component 1..3
    integer :: nk = 0                             !< keyframes of the path
    real(rp), allocatable :: kt(:)                !< (nk) keyframe times [time]
    real(rp), allocatable :: koff0(:, :)          !< (3, nk) initial keyframe offsets [length]
  end type ident_params_t

contains

  !> &identify: theta = ln p of the fitted parameters, within ln of the bounds.
  subroutine params_setup_identify(p, cfg)
    type(ident_params_t), intent(inout) :: p
    type(nuno_config), intent(in) :: cfg
    integer :: k
    p%mode = MODE_IDENTIFY
    p%tag = 'identify'
    p%np = cfg%identify%n_fit
    p%code = cfg%identify%fit_code(1:p%np)
    allocate(p%theta0(p%np), p%lo(p%np), p%hi(p%np))
    do k = 1, p%np
      p%theta0(k) = log(fit_initial(cfg, p%code(k)))
      p%lo(k) = log(cfg%identify%fit_lower(k))
      p%hi(k) = log(cfg%identify%fit_upper(k))
    end do
    p%tikhonov = cfg%identify%tikhonov
    p%fd_step = FD_STEP
    p%nrow = p%np
  end subroutine params_setup_identify

  !> &control: theta = the steps of the chosen components into keyframes
  !> 2..nk (keyframe-major), bounded by max_speed times the segment's
  !> duration when it is set; the first keyframe stays as given.
  subroutine params_setup_control(p, cfg)
    type(ident_params_t), intent(inout) :: p
    type(nuno_config), intent(in) :: cfg
    integer :: m, c, k
    real(rp) :: bound
    p%mode = MODE_CONTROL
    p%tag = 'control'
    p%nk = cfg%scene%n_keyframes
    p%kt = cfg%scene%keyframe_time(1:p%nk)
    allocate(p%koff0(3, p%nk))
    p%koff0(1, :) = cfg%scene%keyframe_dx(1:p%nk)
    p%koff0(2, :) = cfg%scene%keyframe_dy(1:p%nk)
    p%koff0(3, :) = cfg%scene%keyframe_dz(1:p%nk)
    p%np = (p%nk - 1) * count(cfg%control%control_comp)
    allocate(p%km(p%np), p%kc(p%np), p%theta0(p%np), p%lo(p%np), p%hi(p%np))
    k = 0
    do m = 2, p%nk
      bound = NO_BOUND
      if (cfg%control%max_speed /= unset_real) bound = cfg%control%max_speed * (p%kt(m) - p%kt(m - 1))
      do c = 1, 3
        if (.not. cfg%control%control_comp(c)) cycle
        k = k + 1
        p%km(k) = m
        p%kc(k) = c
        p%theta0(k) = p%koff0(c, m) - p%koff0(c, m - 1)
        p%lo(k) = -bound
        p%hi(k) = bound
      end do
    end do
    p%tikhonov = cfg%control%keyframe_tikhonov
    p%fd_step = FD_STEP_LENGTH * max(cfg%lattice%lx, cfg%lattice%ly)
    p%nrow = 3 * p%nk
  end subroutine params_setup_control

  !> Parameter `code` of the trial configuration set to v (read back by
  !> input_checks' fit_initial).
  subroutine set_param(cfg, code, v)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(in) :: code
    real(rp), intent(in) :: v
    select case (code)
    case (1); cfg%material%e_s = v
    case (2); cfg%material%e_d = v
    case (3); cfg%material%eta_s = v
    case (4); cfg%material%eta_d = v
    case (5); cfg%material%k_b = v
    case (6); cfg%material%eta_b = v
    case default; cfg%lattice%total_mass = v
    end select
  end subroutine set_param

  ! ---------------------------------------------------------------- readers

  !> MODE_IDENTIFY or MODE_CONTROL.
  pure integer function params_mode(p)
    type(ident_params_t), intent(in) :: p
    params_mode = p%mode
  end function params_mode

  !> The prefix of the printed lines: 'identify' or 'control' (trimmed).
  pure function params_tag(p) result(tag)
    type(ident_params_t), intent(in) :: p
    character(len=len_trim(p%tag)) :: tag
    tag = p%tag
  end function params_tag

  !> The number of variables theta (TAO's).
  pure integer function params_np(p)
    type(ident_params_t), intent(in) :: p
    params_np = p%np
  end function params_np

  !> Values per history row after the objective (row_values).
  pure integer function params_nrow(p)
    type(ident_params_t), intent(in) :: p
    params_nrow = p%nrow
  end function params_nrow

  !> The initial theta (np).
  pure function params_initial(p) result(v)
    type(ident_params_t), intent(in) :: p
    real(rp) :: v(p%np)
    v = p%theta0
  end function params_initial

  !> The bounds of theta, lo(np) <= theta <= hi(np).
  pure subroutine params_bounds(p, lo, hi)
    type(ident_params_t), intent(in) :: p
    real(rp), intent(out) :: lo(:), hi(:)
    lo = p%lo
    hi = p%hi
  end subroutine params_bounds

  !> The weight of sum (theta - theta0)^2.
  pure real(rp) function params_tikhonov(p)
    type(ident_params_t), intent(in) :: p
    params_tikhonov = p%tikhonov
  end function params_tikhonov

  !> The step of the central differences in theta.
  pure real(rp) function params_fd_step(p)
    type(ident_params_t), intent(in) :: p
    params_fd_step = p%fd_step
  end function params_fd_step

  !> Identification: the parameter code of variable k (config: fit_kind_names).
  pure integer function params_code(p, k)
    type(ident_params_t), intent(in) :: p
    integer, intent(in) :: k
    params_code = p%code(k)
  end function params_code

  !> Control: the keyframes of the path.
  pure integer function params_nk(p)
    type(ident_params_t), intent(in) :: p
    params_nk = p%nk
  end function params_nk

  !> Control: the keyframe times (nk) [time].
  pure function params_times(p) result(v)
    type(ident_params_t), intent(in) :: p
    real(rp) :: v(p%nk)
    v = p%kt
  end function params_times

  !> Control: the initial keyframe offsets (3, nk) [length].
  pure function params_initial_offsets(p) result(v)
    type(ident_params_t), intent(in) :: p
    real(rp) :: v(3, p%nk)
    v = p%koff0
  end function params_initial_offsets

  !> Control: variable k is the step of component kc(k) (1..3) into
  !> keyframe km(k) (2..nk); km, kc: (np).
  pure subroutine control_variables(p, km, kc)
    type(ident_params_t), intent(in) :: p
    integer, intent(out) :: km(:), kc(:)
    km = p%km
    kc = p%kc
  end subroutine control_variables

  !> Control: dxb/dtheta_k and dvb/dtheta_k of a driven node at time t in
  !> the constraint state cs (the component kc(k) of control_variables);
  !> sx, sv: (np) [1], [1/time]. The same for every driven node.
  pure subroutine step_sensitivities(p, cs, t, sx, sv)
    type(ident_params_t), intent(in) :: p
    type(constraint_set_t), intent(in) :: cs
    real(rp), intent(in) :: t
    real(rp), intent(out) :: sx(:), sv(:)
    integer :: k
    do k = 1, p%np
      call constraint_step_sensitivity(cs, t, p%km(k), sx(k), sv(k))
    end do
  end subroutine step_sensitivities

  !> The name of variable k: the fitted parameter's (identification) or
  !> keyframe_dC(m) (control: the position of keyframe m in component C).
  function var_name(p, k) result(s)
    type(ident_params_t), intent(in) :: p
    integer, intent(in) :: k
    character(len=32) :: s
    if (p%mode == MODE_CONTROL) then
      write(s, '(a,i0,a)') 'keyframe_d'//XYZ(p%kc(k))//'(', p%km(k), ')'
    else
      s = fit_kind_names(p%code(k))
    end if
  end function var_name

  !> The direction in theta of a check of variable k: theta_k alone
  !> (identification), or the position of keyframe km(k) alone (control:
  !> moving it changes the step into it and the step out of it, so
  !> dJ/dkoff(c, m) = dJ/dd_m - dJ/dd_(m+1)); (np), entries 0 and +-1.
  pure function check_direction(p, k) result(dir)
    type(ident_params_t), intent(in) :: p
    integer, intent(in) :: k
    real(rp) :: dir(p%np)
    integer :: q
    dir = 0.0_rp
    dir(k) = 1.0_rp
    if (p%mode /= MODE_CONTROL) return
    do q = 1, p%np
      if (p%km(q) == p%km(k) + 1 .and. p%kc(q) == p%kc(k)) dir(q) = -1.0_rp
    end do
  end function check_direction

  ! ---------------------------------------------------------------- theta

  !> Control: the keyframe offsets (3, nk) [length] of theta: the first
  !> keyframe and the components not optimised as given, the others the
  !> sums of the steps.
  pure function keyframes(p, theta) result(off)
    type(ident_params_t), intent(in) :: p
    real(rp), intent(in) :: theta(:)
    real(rp) :: off(3, p%nk)
    integer :: k
    off = p%koff0
    do k = 1, p%np                 ! keyframe-major: keyframe km(k) - 1 is already set
      off(p%kc(k), p%km(k)) = off(p%kc(k), p%km(k) - 1) + theta(k)
    end do
  end function keyframes

  !> The values a history row holds after the objective: the fitted values
  !> (identify) or the keyframe offsets (control).
  function row_values(p, theta) result(v)
    type(ident_params_t), intent(in) :: p
    real(rp), intent(in) :: theta(:)
    real(rp) :: v(p%nrow)
    if (p%mode == MODE_CONTROL) then
      v = reshape(keyframes(p, theta), [p%nrow])
    else
      v = exp(theta(1:p%np))
    end if
  end function row_values

  !> theta into the configuration: the parameters exp(theta), or the
  !> keyframe offsets of the path.
  subroutine apply_theta(p, theta, cfg)
    type(ident_params_t), intent(in) :: p
    real(rp), intent(in) :: theta(:)
    type(nuno_config), intent(inout) :: cfg
    real(rp) :: off(3, p%nk)
    integer :: k
    if (p%mode == MODE_CONTROL) then
      off = keyframes(p, theta)
      cfg%scene%keyframe_dx(1:p%nk) = off(1, :)
      cfg%scene%keyframe_dy(1:p%nk) = off(2, :)
      cfg%scene%keyframe_dz(1:p%nk) = off(3, :)
    else
      do k = 1, p%np
        call set_param(cfg, p%code(k), exp(theta(k)))
      end do
      cfg%material%has_damping = cfg%material%eta_s > 0.0_rp .or. cfg%material%eta_d > 0.0_rp
    end if
  end subroutine apply_theta

  !> theta for messages: the fitted values, or the keyframe offsets.
  function values_text(p, theta) result(s)
    type(ident_params_t), intent(in) :: p
    real(rp), intent(in) :: theta(:)
    character(len=2048) :: s
    character(len=32) :: b
    real(rp) :: off(3, p%nk)
    integer :: k, m, c
    s = ''
    if (p%mode == MODE_CONTROL) then
      off = keyframes(p, theta)
      do m = 2, p%nk
        write(b, '(i0)') m
        s = trim(s)//' '//trim(b)//': ('
        do c = 1, 3
          write(b, '(es12.4e2)') off(c, m)
          s = trim(s)//trim(adjustl(b))//merge(', ', ') ', c < 3)
        end do
      end do
      return
    end if
    do k = 1, p%np
      write(b, '(es14.6e2)') exp(theta(k))
      s = trim(s)//' '//trim(fit_kind_names(p%code(k)))//' = '//trim(adjustl(b))
    end do
  end function values_text

  !> Control: the largest speed of a component on a segment [length/time].
  real(rp) function max_speed_of(p, theta)
    type(ident_params_t), intent(in) :: p
    real(rp), intent(in) :: theta(:)
    integer :: k
    max_speed_of = 0.0_rp
    do k = 1, p%np
      max_speed_of = max(max_speed_of, abs(theta(k)) / (p%kt(p%km(k)) - p%kt(p%km(k) - 1)))
    end do
  end function max_speed_of

end module identify_params
