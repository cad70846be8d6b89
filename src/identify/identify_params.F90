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
  implicit none
  private
  public :: ident_params_t, params_setup_identify, params_setup_control, keyframes, row_values, apply_theta, &
            values_text, max_speed_of
  public :: MODE_IDENTIFY, MODE_CONTROL, FD_STEP, XYZ

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
