! SPDX-License-Identifier: BSD-2-Clause
!> Identification and deformation control (docs/identification.md): one
!> forward run, one objective and one exact TSAdjoint gradient serve both;
!> this module is their TAO driver and their results.
!>
!> Identification fits model parameters to an observed motion: theta = ln p
!> for the fitted p (&identify fit). Deformation control optimises the
!> keyframe path of the driven nodes (wave_point's corner or edge, a
!> gripper) so that the cloth reaches a target: theta = the steps
!> d = koff(c, m) - koff(c, m-1) of the path into keyframes m = 2..nk, for
!> the chosen components c (&control components), so that a bound on the
!> speed of a segment, |d| <= max_speed (kt(m) - kt(m-1)), is a bound on
!> one variable (module identify_params). In both,
!>   J(theta) = sum_k w_k sum_nodes mask_n (|x_n(t_k) - xobs_n,k|^2
!>              + velocity_weight |v_n(t_k) - vobs_n,k|^2)
!>              + tikhonov sum_i (theta_i - theta_i,initial)^2,
!> (module identify_objective) minimised within bounds by PETSc TAO (bqnls
!> by default), with the exact gradient of the discrete trajectory from
!> TSAdjoint (module identify_adjoint; its check: identify_check).
!>
!> The adjoint needs the transpose of the Newton matrix: both run with the
!> assembled 6-dof Jacobian (-nuno_jacobian full), whose KSP (GMRES + ILU
!> by default) does KSPSolveTranspose; the reduced path's PCSHELL has no
!> transpose apply.
module identify
#include "petsc/finclude/petscts.h"
#include "petsc/finclude/petsctao.h"
  use petscts
  use petsctao
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit
  use, intrinsic :: iso_c_binding, only: c_int
  use kinds, only: rp
  use timestepping, only: app_ctx
  use identify_params, only: ident_params_t, MODE_IDENTIFY, MODE_CONTROL, FD_STEP, keyframes, row_values, values_text, &
                             max_speed_of, var_name, params_mode, params_tag, params_np, params_nrow, params_initial, &
                             params_bounds, params_tikhonov, params_nk, params_times, params_initial_offsets
  use identify_objective, only: ident_obs_t, obs_sizes, obs_last_residuals, obs_gauss_newton
  use identify_adjoint, only: ident_core_t, identify_setup, reset_state, forward, objective_gradient, failed_run, &
                              identify_scratch_remove, core_app, core_params, core_obs, core_np, theta_vec_create, &
                              run_failed, run_fail_message, run_objective_data, write_cost
  use identify_check, only: check_gradient
  implicit none
  private
  public :: ident_t, identify_prepare_options, identify_run, identify_result, control_result, identify_scratch_remove

  !> An identification or a control: the TS callbacks' record and the TAO
  !> driver's current point and results (written only by this module).
  type, extends(ident_core_t) :: ident_t
    private
    real(rp), allocatable :: theta(:)             !< (np) current theta (the optimum after the fit)
    real(rp), allocatable :: unc(:)               !< (np) 1-sigma uncertainty of the fitted values [their units]
    real(rp) :: objective = 0                     !< J at the optimum
    integer :: nhist = 0
    real(rp), allocatable :: hist(:, :)           !< (0:nrow, nhist): objective, then the fitted values
                                                  !< (identify) or the keyframe offsets (3, nk) (control)
  end type ident_t

  interface
    !> src/identify/nuno_adjoint.c: -identify_check_gradient, -control_check_gradient (in -help).
    integer(c_int) function nuno_adjoint_options_read(fcomm, check_identify, check_control) &
        bind(C, name='nuno_adjoint_options_read')
      import :: c_int
      integer(c_int), value :: fcomm
      integer(c_int), intent(out) :: check_identify, check_control
    end function nuno_adjoint_options_read
  end interface

contains

  !> Before solver_create: the adjoint needs the assembled Jacobian, and
  !> exact gradients need tight linear solves (the same KSP solves the
  !> transposed systems). Options the user gave win, except the Jacobian.
  !> help: -help was given; the run ends before identify_run, so the
  !> options of the identification and control are shown here.
  subroutine identify_prepare_options(comm, help, ierr)
    integer, intent(in) :: comm
    logical, intent(in) :: help
    PetscErrorCode, intent(out) :: ierr
    integer(c_int) :: check_identify, check_control
    if (help) then
      ierr = nuno_adjoint_options_read(comm, check_identify, check_control)
      if (ierr /= 0) return
    end if
    PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-nuno_jacobian', 'full', ierr))
    call default_option('-ksp_rtol', '1e-12', ierr); if (ierr /= 0) return
    call default_option('-ksp_atol', '1e-50', ierr); if (ierr /= 0) return
    call default_option('-ksp_max_it', '10000', ierr); if (ierr /= 0) return
    ! Newton to its round-off floor (the stagnation test of timestepping's
    ! snes_converged) with full steps: a backtracking line search fails at
    ! the floor, and a retried step changes the step sequence, which makes
    ! the objective jump between neighbouring parameters.
    call default_option('-snes_rtol', '1e-10', ierr); if (ierr /= 0) return
    call default_option('-snes_linesearch_type', 'basic', ierr)
  contains
    subroutine default_option(name, value, ierr)
      character(*), intent(in) :: name, value
      PetscErrorCode, intent(out) :: ierr
      PetscBool :: set
      PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, name, set, ierr))
      if (.not. set) then
        PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, name, value, ierr))
      end if
    end subroutine default_option
  end subroutine identify_prepare_options

  !> The identification (&identify) or the control (&control): read the
  !> observation or target, optimise with TAO (identification: estimate the
  !> uncertainty too); on return ctx's configuration is identify's trial
  !> one, with the fitted parameters or the optimised keyframes, and ctx
  !> holds the initial state, ready for solver_run to write the resulting
  !> motion. ierr = 1 with errmsg: a collective error (bad observation,
  !> failed forward run); ierr > 1: a PETSc error. done: nothing more to do
  !> (-identify_check_gradient, -control_check_gradient).
  subroutine identify_run(id, ctx, done, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    type(app_ctx), intent(inout), target :: ctx
    logical, intent(out) :: done
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    type(ident_params_t), pointer :: par
    integer(c_int) :: check_identify, check_control

    done = .false.
    errmsg = ''
    ierr = nuno_adjoint_options_read(ctx%comm, check_identify, check_control)
    if (ierr /= 0) return
    call identify_setup(id, ctx, ierr, errmsg)
    if (ierr /= 0) return
    par => core_params(id)
    id%theta = params_initial(par)
    if (params_mode(par) == MODE_IDENTIFY) then
      allocate(id%unc(params_np(par)))
      id%unc = 0.0_rp
    end if
    allocate(id%hist(0:params_nrow(par), 0))
    ! The two names are one check (each reads better in its own input).
    if (check_identify /= 0 .or. check_control /= 0) then
      call check_gradient(id, ierr, errmsg)
      done = .true.
    else
      call fit(id, ierr, errmsg)
      if (ierr == 0) then
        if (params_mode(par) == MODE_IDENTIFY) then
          call uncertainty(id, ierr, errmsg)
        else
          call final_objective(id, ierr, errmsg)
        end if
      end if
      if (ierr == 0) call report(id)
    end if
    if (ierr == 1 .and. len(run_fail_message(id)) > 0) errmsg = run_fail_message(id)
    if (ierr /= 0) return
    ! The resulting motion, from t = 0, for solver_run.
    call reset_state(id, id%theta, ierr)
    if (ierr /= 0) ierr = 2
  end subroutine identify_run

  ! --------------------------------------------------------------------- TAO

  !> Minimise J over theta within the bounds: TAO bqnls by default (a
  !> bound-constrained quasi-Newton), any -tao_* option.
  subroutine fit(id, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    type(ident_params_t), pointer :: par
    type(app_ctx), pointer :: app
    Tao :: tao
    type(tVec) :: x, xl, xu
    TaoConvergedReason :: reason
    PetscInt :: its
    PetscInt, parameter :: maxit = 200
    real(rp) :: lo(core_np(id)), hi(core_np(id))

    errmsg = ''
    par => core_params(id)
    app => core_app(id)
    call theta_vec_create(id, x, ierr);  if (ierr /= 0) return
    call theta_vec_create(id, xl, ierr); if (ierr /= 0) return
    call theta_vec_create(id, xu, ierr); if (ierr /= 0) return
    call params_bounds(par, lo, hi)
    call put_rank0(app%rank, x, params_initial(par), ierr); if (ierr /= 0) return
    call put_rank0(app%rank, xl, lo, ierr);                 if (ierr /= 0) return
    call put_rank0(app%rank, xu, hi, ierr);                 if (ierr /= 0) return
    PetscCall(TaoCreate(app%comm, tao, ierr))
    PetscCall(TaoSetType(tao, 'bqnls', ierr))
    PetscCall(TaoSetSolution(tao, x, ierr))
    PetscCall(TaoSetVariableBounds(tao, xl, xu, ierr))
    PetscCall(TaoSetObjectiveAndGradient(tao, PETSC_NULL_VEC, tao_objgrad, id, ierr))
    PetscCall(TaoSetMonitor(tao, tao_monitor, id, PETSC_NULL_FUNCTION, ierr))
    PetscCall(TaoSetMaximumIterations(tao, maxit, ierr))
    ! Control also stops when |g| fell by 1e-8 from the start (the
    ! objective by some 1e-16, its round-off floor for a target reached):
    ! gatol alone would spend the last half of 200 iterations there.
    if (params_mode(par) == MODE_CONTROL) then
      PetscCall(TaoSetTolerances(tao, 1.0e-10_rp, 0.0_rp, 1.0e-8_rp, ierr))
    else
      PetscCall(TaoSetTolerances(tao, 1.0e-10_rp, 0.0_rp, 0.0_rp, ierr))
    end if
    PetscCall(TaoSetFromOptions(tao, ierr))
    PetscCall(TaoSolve(tao, ierr))
    PetscCall(TaoGetConvergedReason(tao, reason, ierr))
    PetscCall(TaoGetIterationNumber(tao, its, ierr))
    call get_rank0(app, x, id%theta, ierr)
    if (ierr /= 0) return
    PetscCall(TaoDestroy(tao, ierr))
    PetscCall(VecDestroy(xu, ierr))
    PetscCall(VecDestroy(xl, ierr))
    PetscCall(VecDestroy(x, ierr))
    if (app%rank == 0) then
      write(output_unit, '(a,i0,a,i0,a)') params_tag(par)//': TAO stopped after ', its, &
        ' iterations (TaoConvergedReason ', reason, ')'
      flush(output_unit)
    end if
    if (run_failed(id)) then
      ! A diverged TAO still returns its best point; a failed forward run is an error.
      ierr = 1
      if (params_mode(par) == MODE_CONTROL) then
        errmsg = 'control: a forward run failed during the optimisation; try a smaller &time dt, a lower '// &
                 '&control max_speed or a better initial guess (&scene keyframe_dx, keyframe_dy, keyframe_dz)'
      else
        errmsg = 'identify: a forward run failed during the fit; try a smaller &time dt, tighter bounds '// &
                 '(&identify fit_lower, fit_upper) or a better initial guess'
      end if
    else if (reason < 0 .and. app%rank == 0) then
      write(output_unit, '(a)') params_tag(par)//': warning: TAO did not converge (negative reason); the values '// &
        'below are its last iterate'
    end if
  end subroutine fit

  !> v into TAO's vector x, whose entries all lie on rank 0 (rank: this
  !> rank's; the others have nothing to do).
  subroutine put_rank0(rank, x, v, ierr)
    integer, intent(in) :: rank
    type(tVec), intent(in) :: x
    real(rp), intent(in) :: v(:)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: xa(:)
    ierr = 0
    if (rank /= 0) return
    PetscCall(VecGetArrayF90(x, xa, ierr))
    xa = v
    PetscCall(VecRestoreArrayF90(x, xa, ierr))
  end subroutine put_rank0

  !> TAO's vector x (entries on rank 0) into v on every rank. Collective.
  subroutine get_rank0(app, x, v, ierr)
    type(app_ctx), intent(in) :: app
    type(tVec), intent(in) :: x
    real(rp), intent(out) :: v(:)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: xa(:)
    integer :: mpierr
    ierr = 0
    if (app%rank == 0) then
      PetscCall(VecGetArrayReadF90(x, xa, ierr))
      v = xa
      PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    end if
    call MPI_Bcast(v, size(v), MPI_DOUBLE_PRECISION, 0, app%comm, mpierr)
  end subroutine get_rank0

  !> TAO callback: objective and gradient at x = theta.
  subroutine tao_objgrad(tao, x, f, g, id, ierr)
    Tao, intent(in) :: tao
    type(tVec), intent(in) :: x, g
    PetscReal, intent(out) :: f
    type(ident_t), intent(inout) :: id
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: theta(core_np(id)), gl(core_np(id))
    type(app_ctx), pointer :: app

    app => core_app(id)
    call get_rank0(app, x, theta, ierr)
    if (ierr /= 0) return
    call objective_gradient(id, theta, f, gl, ierr)
    if (ierr /= 0) return
    call put_rank0(app%rank, g, gl, ierr)
  end subroutine tao_objgrad

  !> TAO monitor: the history, one row per iteration, and a line on rank 0.
  subroutine tao_monitor(tao, id, ierr)
    Tao, intent(in) :: tao
    type(ident_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    type(ident_params_t), pointer :: par
    type(app_ctx), pointer :: app
    type(tVec) :: x
    PetscInt :: its
    PetscReal :: f, gnorm, cnorm, xdiff
    TaoConvergedReason :: reason
    real(rp) :: theta(core_np(id))
    real(rp), allocatable :: grown(:, :)

    par => core_params(id)
    app => core_app(id)
    PetscCall(TaoGetSolutionStatus(tao, its, f, gnorm, cnorm, xdiff, reason, ierr))
    PetscCall(TaoGetSolution(tao, x, ierr))
    call get_rank0(app, x, theta, ierr)
    if (ierr /= 0) return
    allocate(grown(0:params_nrow(par), id%nhist + 1))     ! (an assignment would reset the lower bound to 1)
    grown(:, 1:id%nhist) = id%hist
    grown(:, id%nhist + 1) = [f, row_values(par, theta)]
    call move_alloc(grown, id%hist)
    id%nhist = id%nhist + 1
    if (app%rank /= 0) return
    if (params_mode(par) == MODE_CONTROL) then
      write(output_unit, '(a,i4,a,es14.6e2,a,es10.3e2,a,es10.3e2)') 'control: iteration ', its, '  objective ', f, &
        '  |g| ', gnorm, '  max speed ', max_speed_of(par, theta)
    else
      write(output_unit, '(a,i4,a,es14.6e2,a,es10.3e2,a)') 'identify: iteration ', its, '  objective ', f, &
        '  |g| ', gnorm, trim(values_text(par, theta))
    end if
    flush(output_unit)
  end subroutine tao_monitor

  ! ------------------------------------------------------------ uncertainty

  !> Gauss-Newton Hessian of J at the fit, H = 2 A^T W A (+ 2 tikhonov I),
  !> A = d(x - xobs)/d(ln p) by central differences of the trajectory
  !> (2 np forward runs); the residual variance s^2 = J_data / (n_obs - np)
  !> gives the covariance of ln p, 2 s^2 H^-1, and the 1-sigma uncertainty
  !> of each fitted value p sqrt(cov_kk) (first order in the noise).
  subroutine uncertainty(id, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp), allocatable :: a(:, :, :, :, :), rp_(:, :, :, :)
    real(rp) :: hmat(core_np(id), core_np(id)), cov(core_np(id), core_np(id)), lp(core_np(id)), f, fdata, s2, nobs
    integer :: k, np, nt, info, mpierr, ipiv(core_np(id))
    type(app_ctx), pointer :: app
    type(ident_obs_t), pointer :: obs

    np = core_np(id)
    app => core_app(id)
    obs => core_obs(id)
    errmsg = ''
    call obs_sizes(obs, nt, nobs)
    allocate(a(3, 0:app%lat%nx - 1, app%lat%ys:app%lat%ye, nt, np))
    do k = 1, np
      lp = id%theta
      lp(k) = lp(k) + FD_STEP
      call forward(id, lp, f, ierr)
      if (ierr /= 0) return
      rp_ = obs_last_residuals(obs)
      lp(k) = id%theta(k) - FD_STEP
      call forward(id, lp, f, ierr)
      if (ierr /= 0) return
      if (failed_run(id, id%theta, errmsg, ierr)) return
      a(:, :, :, :, k) = (rp_ - obs_last_residuals(obs)) / (2.0_rp * FD_STEP)
    end do
    hmat = 0.0_rp
    call obs_gauss_newton(obs, a, hmat)
    call MPI_Allreduce(MPI_IN_PLACE, hmat, np**2, MPI_DOUBLE_PRECISION, MPI_SUM, app%comm, mpierr)
    do k = 1, np
      hmat(k, k) = hmat(k, k) + 2.0_rp * params_tikhonov(core_params(id))
    end do
    ! The objective at the fit (and its residuals, for what is written).
    call forward(id, id%theta, f, ierr)
    if (ierr /= 0) return
    fdata = run_objective_data(id)
    id%objective = f
    s2 = fdata / max(nobs - real(np, rp), 1.0_rp)
    cov = 0.0_rp
    do k = 1, np
      cov(k, k) = 1.0_rp
    end do
    call dgesv(np, np, hmat, np, ipiv, cov, np, info)
    id%unc = 0.0_rp
    if (info == 0) then
      do k = 1, np
        id%unc(k) = exp(id%theta(k)) * sqrt(max(2.0_rp * s2 * cov(k, k), 0.0_rp))
      end do
    else
      id%unc = huge(1.0_rp)   ! singular: a parameter the observation does not determine
    end if
  end subroutine uncertainty

  !> Control: the objective at the optimum (one forward run).
  subroutine final_objective(id, ierr, errmsg)
    type(ident_t), intent(inout) :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    call forward(id, id%theta, id%objective, ierr)
    if (ierr /= 0) return
    if (failed_run(id, id%theta, errmsg, ierr)) return
  end subroutine final_objective

  !> The result on rank 0 (fitted values with their uncertainty, or the
  !> optimised keyframes), and the cost of a gradient.
  subroutine report(id)
    type(ident_t), intent(in), target :: id
    type(ident_params_t), pointer :: par
    type(app_ctx), pointer :: app
    real(rp), allocatable :: off(:, :), kt(:), koff0(:, :), theta0(:)
    integer :: k, m
    app => core_app(id)
    if (app%rank /= 0) return
    par => core_params(id)
    write(output_unit, '(a,es24.16)') params_tag(par)//': objective ', id%objective
    if (params_mode(par) == MODE_CONTROL) then
      off = keyframes(par, id%theta)
      kt = params_times(par)
      koff0 = params_initial_offsets(par)
      do m = 1, params_nk(par)
        write(output_unit, '(a,i3,a,es14.6e2,a,3es16.8e2,a,3es12.4e2,a)') 'control: keyframe ', m, '  t ', kt(m), &
          '  offset ', off(:, m), '  (initial', koff0(:, m), ')'
      end do
      write(output_unit, '(a,es12.4e2)') 'control: max speed of a component on a segment ', max_speed_of(par, id%theta)
    else
      theta0 = params_initial(par)
      do k = 1, params_np(par)
        write(output_unit, '(a,a12,a,es24.16,a,es12.4e2,a,es12.4e2)') 'identify: fitted ', &
          trim(var_name(par, k)), ' ', exp(id%theta(k)), ' +- ', id%unc(k), '  initial ', exp(theta0(k))
      end do
    end if
    call write_cost(id, output_unit)
    flush(output_unit)
  end subroutine report

  !> What /identify holds: names, fitted values, their uncertainty, the
  !> initial guess, the objective, the history (objective, values per TAO
  !> iteration).
  subroutine identify_result(id, names, values, unc, initial, objective, hist)
    type(ident_t), intent(in), target :: id
    character(len=16), allocatable, intent(out) :: names(:)
    real(rp), allocatable, intent(out) :: values(:), unc(:), initial(:), hist(:, :)
    real(rp), intent(out) :: objective
    type(ident_params_t), pointer :: par
    integer :: k
    par => core_params(id)
    allocate(names(params_np(par)))
    do k = 1, params_np(par)
      names(k) = trim(var_name(par, k))
    end do
    values = exp(id%theta)
    unc = id%unc
    initial = exp(params_initial(par))
    objective = id%objective
    hist = id%hist
  end subroutine identify_result

  !> What /control holds: the keyframe times [nk], the optimised and the
  !> initial keyframe offsets (3, nk), the objective at the optimum, and per
  !> TAO iteration the objective [nit] and the keyframe offsets (3, nk, nit).
  subroutine control_result(id, times, offsets, initial, objective, objective_hist, offset_hist)
    type(ident_t), intent(in), target :: id
    real(rp), allocatable, intent(out) :: times(:), offsets(:, :), initial(:, :), objective_hist(:), &
                                          offset_hist(:, :, :)
    real(rp), intent(out) :: objective
    type(ident_params_t), pointer :: par
    par => core_params(id)
    times = params_times(par)
    offsets = keyframes(par, id%theta)
    initial = params_initial_offsets(par)
    objective = id%objective
    objective_hist = id%hist(0, :)
    offset_hist = reshape(id%hist(1:, :), [3, params_nk(par), id%nhist])
  end subroutine control_result

end module identify
