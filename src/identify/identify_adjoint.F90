! SPDX-License-Identifier: BSD-2-Clause
!> The forward run and the exact TSAdjoint gradient of an identification or
!> a control (docs/identification.md; the objective: identify_objective).
!>
!> The time loop: one window per interval between consecutive observed
!> times, keyframe and release times (enter_window of module timestepping
!> fixes the constraints of each, as in solver_run). The adjoint runs the
!> windows backward, one TSAdjointSolve of exactly that window's steps each
!> (TSAdjointSetSteps), after adding dJ_k/dU(t_k) to lambda at the window's
!> end: the discrete sum of the objective enters at the observed times
!> themselves, and every window's Jacobians see the constraint state of that
!> window.
!>
!> dF/dtheta (TSSetIJacobianP, through src/identify/nuno_adjoint.c). Identification:
!> every force is linear in each of e_s, e_d, eta_s, eta_d, k_b, eta_b, so
!> dF_v/d(ln p) = -f_p/m with f_p the force of the elements computed with
!> only p non-zero (model_state's model_force_rows on a lattice copy); for
!> total_mass (every node mass is proportional to it) dF_v/d(ln M) = +f/m.
!> Control: only the x-rows of the driven nodes depend on theta, F_x =
!> xdot - vb with vb the slope of the window's segment, so dF_x/dd =
!> -dvb/dd (constraints: constraint_step_sensitivity).
!>
!> The start of a window: enter_window puts each constrained node on its
!> path, x = xb(ta), v = vb, forgetting the state it had. For
!> identification nothing of that depends on p, and the lambda of
!> constrained nodes never reaches free ones (their rows of F do not depend
!> on free nodes), so it needs no adjoint term. For control it does depend
!> on theta: after the window's TSAdjointSolve, lambda holds dJ/dU at the
!> window's start, and the adjoint of the reset adds lambda_x . dxb/dd +
!> lambda_v . dvb/dd of the driven nodes to the gradient and sets the
!> lambda of every constrained node to zero (it would otherwise enter
!> dF_x/dd of the window before).
module identify_adjoint
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit
  use, intrinsic :: iso_c_binding, only: c_null_char
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t, lattice_init
  use model_state, only: model_force_rows
  use ghosted_state, only: ghosted_get, ghosted_restore
  use scenes, only: scene_setup
  use constraints, only: PATH_KEYFRAMES, constraints_active, constraint_count, constraint_node, constraint_path
  use timestepping, only: app_ctx, enter_window, advance_window
  use energy_integrals, only: energy_integrals_reset
  use run_progress, only: progress_reset
  use step_settings, only: step_dt
  use safe_files, only: make_scratch_dir, remove_scratch
  use identify_params, only: ident_params_t, MODE_CONTROL, params_setup_identify, params_setup_control, &
                             apply_theta, values_text, params_mode, params_tag, params_np, params_nk, params_code, &
                             params_tikhonov, params_initial, control_variables, step_sensitivities
  use identify_objective, only: ident_obs_t, obs_read, obs_windows, obs_residuals, obs_adjoint_terms, obs_sizes, &
                                obs_n_windows, obs_window
  implicit none
  private
  public :: ident_core_t, identify_setup, reset_state, forward, objective_gradient, failed_run, &
            identify_scratch_remove
  public :: core_app, core_params, core_obs, core_np, theta_vec_create, run_failed, run_fail_message, run_objective_data, &
            run_trajectory, write_cost

  !> The PETSc objects of the adjoint, the scratch directory and what the
  !> forward runs measured; written only by this module.
  type :: ident_run_t
    private
    type(tMat) :: jacp                            !< dF/dtheta, dense, np columns on rank 0
    type(tVec) :: lam(1), mu(1)                   !< cost gradients w.r.t. the state and theta
    PetscInt, allocatable :: wsteps(:)            !< (0:nw) TS step at the end of each window
    real(rp) :: objective_data = 0                !< data term of J of the last forward run
    integer :: n_forward = 0, n_adjoint = 0
    real(rp) :: t_forward = 0, t_adjoint = 0      !< wall-clock seconds of all forward / adjoint sweeps
    real(rp) :: traj_bytes = 0                    !< PETSc memory held by the trajectory of one forward run (max over ranks)
    real(rp) :: traj_disk_bytes = 0               !< size of the basic trajectory's files of one forward run (all ranks)
    integer :: nsteps = 0                         !< steps of one forward run
    logical :: failed = .false.                   !< a forward run failed (a step did not converge)
    character(len=512) :: fail_msg = ''           !< why, when not a failed step
    character(len=600) :: traj_dir = ''           !< directory of the basic trajectory's files
    character(len=600) :: scratch = ''            !< its private parent, made by this run (rank 0)
  end type ident_run_t

  !> Everything the TS callbacks of an identification or a control need
  !> (module identify extends it with the TAO driver's results); written
  !> only by this module, its parts by their own modules' routines.
  type :: ident_core_t
    private
    type(app_ctx), pointer :: app => null()
    !> The trial configuration: the input's with theta applied (apply_theta);
    !> the solver's ctx%cfg points to it from identify_setup on, so that the
    !> forward runs and the run of the result read it and main's stays the
    !> input's.
    type(nuno_config) :: cfg
    type(ident_params_t) :: par                   !< the variables theta (identify_params)
    type(ident_obs_t) :: obs                      !< observation, windows, residuals (identify_objective)
    type(ident_run_t) :: run                      !< the adjoint's PETSc objects and what the forward runs measured
  end type ident_core_t

  interface
    !> src/identify/nuno_adjoint.c: TSSetIJacobianP for Fortran callbacks.
    subroutine nuno_ts_set_ijacobianp(ts, a, func, ctx, ierr)
      import :: tTS, tMat, ident_core_t
      type(tTS) :: ts
      type(tMat) :: a
      external :: func
      type(ident_core_t) :: ctx
      PetscErrorCode :: ierr
    end subroutine nuno_ts_set_ijacobianp
    !> src/identify/nuno_adjoint.c: a fresh trajectory (memory unless -ts_trajectory_type).
    subroutine nuno_ts_trajectory_fresh(ts, horizon, dt, nwindows, dirname, ierr)
      import :: tTS
      type(tTS) :: ts
      PetscReal :: horizon, dt
      PetscInt :: nwindows
      character(*) :: dirname
      PetscErrorCode :: ierr
    end subroutine nuno_ts_trajectory_fresh
  end interface

contains

  !> The trial configuration (a copy of the solver's, which ctx%cfg then
  !> points to); read the parameters and the observation or target, make
  !> the scratch directory and the windows, create the adjoint's PETSc
  !> objects. ierr = 1 with errmsg: a collective error. Collective.
  subroutine identify_setup(id, ctx, ierr, errmsg)
    class(ident_core_t), intent(inout), target :: id
    type(app_ctx), intent(inout), target :: ctx
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    type(app_ctx), pointer :: app
    PetscInt :: nloc, ncol, np, ntot

    id%app => ctx
    app => id%app
    id%cfg = ctx%cfg
    ctx%cfg => id%cfg
    if (id%cfg%control%active) then
      call params_setup_control(id%par, id%cfg)
      call obs_read(id%obs, app%lat, app%comm, id%cfg%control%velocity_weight, trim(id%cfg%control%target_file), 'control', &
                    'target_file', ierr, errmsg)
    else
      call params_setup_identify(id%par, id%cfg)
      call obs_read(id%obs, app%lat, app%comm, 0.0_rp, trim(id%cfg%identify%observed_file), 'identify', 'observed_file', &
                    ierr, errmsg)
    end if
    if (ierr /= 0) return
    ! The trajectory's files go into a directory of this run's own, made
    ! anew (mkdtemp: OUTPUT.adjoint.XXXXXX, mode 0700) beside the output,
    ! and only it is removed at the end: a user's OUTPUT.adjoint (or a
    ! link of that name) is never touched. PETSc's basic trajectory makes
    ! and removes the subdirectory `trajectory` itself.
    call make_scratch(id, trim(id%cfg%output%output_file), ierr, errmsg)
    if (ierr /= 0) return
    id%run%traj_dir = trim(id%run%scratch)//'/trajectory'

    call obs_windows(id%obs, app%cs)
    allocate(id%run%wsteps(0:obs_n_windows(id%obs)))
    id%run%wsteps = 0

    ! dF/dtheta: dense, the state's rows, np columns kept on rank 0 (the
    ! layout of TAO's vector).
    nloc = 6 * app%lat%nx * (app%lat%ye - app%lat%ys + 1)
    np = params_np(id%par)
    ncol = 0
    if (app%rank == 0) ncol = np
    ntot = 6 * app%lat%nx * app%lat%ny
    PetscCall(MatCreateDense(app%comm, nloc, ncol, ntot, np, PETSC_NULL_SCALAR, id%run%jacp, ierr))
    PetscCall(MatSetUp(id%run%jacp, ierr))
    PetscCall(MatAssemblyBegin(id%run%jacp, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatAssemblyEnd(id%run%jacp, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatCreateVecs(id%run%jacp, id%run%mu(1), PETSC_NULL_VEC, ierr))
    PetscCall(DMCreateGlobalVector(app%da, id%run%lam(1), ierr))
    call nuno_ts_set_ijacobianp(app%ts, id%run%jacp, ident_ijacobianp, id, ierr)
    if (ierr /= 0) return
    if (app%rank == 0) call setup_line(id)
  end subroutine identify_setup

  !> The line that says what is optimised, on rank 0.
  subroutine setup_line(id)
    class(ident_core_t), intent(in) :: id
    integer :: nt, nw
    real(rp) :: nobs
    call obs_sizes(id%obs, nt, nobs)
    nw = obs_n_windows(id%obs)
    if (params_mode(id%par) == MODE_CONTROL) then
      write(output_unit, '(a,i0,a,i0,a,i0,a,i0,a)') 'control   : ', params_np(id%par), ' variable(s) (the steps of ', &
        params_nk(id%par), ' keyframes in '//trim(id%cfg%control%components)//'), ', nt, ' target time(s), ', nw, &
        ' time windows; '//trim(id%cfg%control%target_file)
    else
      write(output_unit, '(a,i0,a,i0,a,i0,a)') 'identify  : ', params_np(id%par), ' parameter(s), ', nt, &
        ' observed times, ', nw, ' time windows; '//trim(id%cfg%identify%observed_file)
    end if
    flush(output_unit)
  end subroutine setup_line

  !> theta into the trial configuration and the lattice (masses, constants) or
  !> the constraints (keyframe path), the scene's initial state into the
  !> state vector, the TS back at t = 0 with a fresh trajectory. Collective.
  subroutine reset_state(id, theta, ierr)
    class(ident_core_t), intent(inout) :: id
    real(rp), intent(in) :: theta(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: ua(:, :, :)
    integer :: ys, ye
    PetscInt, parameter :: zero = 0
    PetscReal :: horizon, ta, tend
    PetscInt :: nw
    integer :: k

    app => id%app
    call apply_theta(id%par, theta, id%cfg)
    ys = app%lat%ys
    ye = app%lat%ye
    call lattice_init(app%lat, id%cfg, ys, ye)
    PetscCall(DMDAVecGetArrayF90(app%da, app%u, ua, ierr))
    call scene_setup(id%cfg, app%lat, ua, app%cs)
    PetscCall(DMDAVecRestoreArrayF90(app%da, app%u, ua, ierr))
    PetscCall(TSSetTime(app%ts, 0.0_rp, ierr))
    PetscCall(TSSetStepNumber(app%ts, zero, ierr))
    ! Room for the whole run: its steps, one more per window, retries.
    nw = obs_n_windows(id%obs)
    call obs_window(id%obs, int(nw), ta, tend, k)
    horizon = 2.0_rp * (tend + real(nw + 1, rp) * step_dt(app%step))
    call nuno_ts_trajectory_fresh(app%ts, horizon, step_dt(app%step), nw, trim(id%run%traj_dir)//c_null_char, ierr)
    if (ierr == -1) then
      ierr = 1
      id%run%failed = .true.
      id%run%fail_msg = '-ts_trajectory_type memory: PETSc 3.18 cannot checkpoint in memory across the '// &
        params_tag(id%par)//' run''s time windows (observed, keyframe and release times); use basic (the default)'
      return
    end if
    if (ierr /= 0) return
    call energy_integrals_reset(app%energy)
    call progress_reset(app%progress)
  end subroutine reset_state

  !> id%run%scratch: a new private directory beside the output file (rank 0
  !> makes it, every rank gets its name). ierr = 1 with errmsg when it
  !> cannot be made. Collective.
  subroutine make_scratch(id, output, ierr, errmsg)
    class(ident_core_t), intent(inout) :: id
    character(*), intent(in) :: output
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    character(len=:), allocatable :: dir
    character(len=256) :: why
    logical :: ok
    integer :: rank, mpierr, e
    ierr = 0
    e = 0
    errmsg = ''
    call MPI_Comm_rank(id%app%comm, rank, mpierr)
    if (rank == 0) then
      call make_scratch_dir(trim(output)//'.adjoint', dir, ok, why)
      if (ok) then
        id%run%scratch = dir
      else
        e = 1
        errmsg = 'output: cannot make the scratch directory '//trim(output)//'.adjoint.XXXXXX of the '// &
                 'identification or control: '//trim(why)
      end if
    end if
    call MPI_Bcast(e, 1, MPI_INTEGER, 0, id%app%comm, mpierr)
    call MPI_Bcast(id%run%scratch, len(id%run%scratch), MPI_CHARACTER, 0, id%app%comm, mpierr)
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, 0, id%app%comm, mpierr)
    ierr = e
  end subroutine make_scratch

  ! ------------------------------------------------------ forward, adjoint

  !> One forward run at theta over all windows, saving the trajectory; the
  !> objective f and the residuals x - xobs (v - vobs) at the observed
  !> times. A failed step sets id%run%failed (f = huge). Collective.
  subroutine forward(id, theta, f, ierr)
    class(ident_core_t), intent(inout) :: id
    real(rp), intent(in) :: theta(:)
    real(rp), intent(out) :: f
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: ua(:, :, :)
    TSConvergedReason :: reason
    PetscLogDouble :: mem0, mem1
    real(rp) :: t, h, floc, wall0, eps, ta, tb
    integer :: w, k, mpierr, nw, np

    app => id%app
    nw = obs_n_windows(id%obs)
    np = params_np(id%par)
    wall0 = MPI_Wtime()
    call reset_state(id, theta, ierr)
    if (ierr /= 0) return
    PetscCall(PetscMallocGetCurrentUsage(mem0, ierr))
    id%run%failed = .false.
    floc = 0.0_rp
    t = 0.0_rp
    call obs_window(id%obs, nw, ta, tb, k)
    eps = 1.0e-12_rp * max(1.0_rp, tb)
    ! The run's window loop (advance_window of the run driver), each window
    ! entered afresh; t = wa(w) here, the end of the window before.
    do w = 1, nw
      call obs_window(id%obs, w, ta, tb, k)
      ! The memory trajectory stores a window's first state only if the TS
      ! is not marked converged (from the previous window) when TSSolve
      ! saves it; otherwise the adjoint of the previous window pops the
      ! wrong checkpoint.
      PetscCall(TSSetConvergedReason(app%ts, TS_CONVERGED_ITERATING, ierr))
      h = step_dt(app%step)
      call advance_window(app, t, tb, h, .true., reason, ierr)
      if (ierr /= 0) return
      if (reason < 0 .or. abs(t - tb) > 1.0e3_rp * eps) then
        id%run%failed = .true.
        if (app%rank == 0) write(output_unit, '(a,i0,a,es14.6,a,es14.6)') params_tag(id%par)// &
          ': forward run stopped (TSConvergedReason ', reason, ') at t = ', t, ' in the window ending at ', tb
        exit
      end if
      t = tb
      PetscCall(TSSetTime(app%ts, t, ierr))
      PetscCall(TSGetStepNumber(app%ts, id%run%wsteps(w), ierr))
      if (k > 0) then
        PetscCall(DMDAVecGetArrayReadF90(app%da, app%u, ua, ierr))
        call obs_residuals(id%obs, k, app%lat, ua, floc)
        PetscCall(DMDAVecRestoreArrayReadF90(app%da, app%u, ua, ierr))
      end if
    end do
    PetscCall(PetscMallocGetCurrentUsage(mem1, ierr))
    ! The trajectory: in memory what PETSc allocated during the run (max
    ! over ranks); the basic type's files hold the state and the one stage
    ! of beuler/theta per step instead, (2 x 6 x 8) bytes a node and step.
    id%run%traj_bytes = real(mem1 - mem0, rp)
    call MPI_Allreduce(MPI_IN_PLACE, id%run%traj_bytes, 1, MPI_DOUBLE_PRECISION, MPI_MAX, app%comm, mpierr)
    id%run%traj_disk_bytes = real(id%run%wsteps(nw) + 1, rp) * 96.0_rp * real(app%lat%nx, rp) * real(app%lat%ny, rp)
    call MPI_Allreduce(floc, f, 1, MPI_DOUBLE_PRECISION, MPI_SUM, app%comm, mpierr)
    id%run%objective_data = f
    f = f + params_tikhonov(id%par) * sum((theta(1:np) - params_initial(id%par))**2)
    if (id%run%failed) f = huge(1.0_rp)
    id%run%nsteps = int(id%run%wsteps(nw))
    id%run%n_forward = id%run%n_forward + 1
    id%run%t_forward = id%run%t_forward + (MPI_Wtime() - wall0)
  end subroutine forward

  !> Objective and its exact gradient with respect to theta (one forward
  !> run, then the adjoint backward over the windows). Collective.
  subroutine objective_gradient(id, theta, f, g, ierr)
    class(ident_core_t), intent(inout) :: id
    real(rp), intent(in) :: theta(:)
    real(rp), intent(out) :: f, g(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: la(:, :, :), ma(:)
    PetscInt :: nsteps
    real(rp) :: dke, wall0, greset(params_np(id%par)), ta, tb
    integer :: w, k, mpierr, np
    PetscInt, parameter :: one = 1

    app => id%app
    np = params_np(id%par)
    call forward(id, theta, f, ierr)
    if (ierr /= 0) return
    g = 0.0_rp
    if (id%run%failed) return
    wall0 = MPI_Wtime()
    greset = 0.0_rp
    PetscCall(VecZeroEntries(id%run%lam(1), ierr))
    PetscCall(VecZeroEntries(id%run%mu(1), ierr))
    PetscCall(TSSetCostGradients(app%ts, one, id%run%lam(1), id%run%mu(1), ierr))
    do w = obs_n_windows(id%obs), 1, -1
      call obs_window(id%obs, w, ta, tb, k)
      if (k > 0) then
        PetscCall(DMDAVecGetArrayF90(app%da, id%run%lam(1), la, ierr))
        call obs_adjoint_terms(id%obs, k, app%lat, la)
        PetscCall(DMDAVecRestoreArrayF90(app%da, id%run%lam(1), la, ierr))
      end if
      ! The constraint state of this window for its Jacobians.
      call enter_window(app, ta, tb, dke, ierr)
      if (ierr /= 0) return
      nsteps = id%run%wsteps(w) - id%run%wsteps(w - 1)
      PetscCall(TSAdjointSetSteps(app%ts, nsteps, ierr))
      PetscCall(TSAdjointSolve(app%ts, ierr))
      if (params_mode(id%par) == MODE_CONTROL) then
        call reset_adjoint(id, ta, greset, ierr)
        if (ierr /= 0) return
      end if
    end do
    if (app%rank == 0) then
      PetscCall(VecGetArrayReadF90(id%run%mu(1), ma, ierr))
      g(1:np) = ma(1:np)
      PetscCall(VecRestoreArrayReadF90(id%run%mu(1), ma, ierr))
    end if
    call MPI_Bcast(g, np, MPI_DOUBLE_PRECISION, 0, app%comm, mpierr)
    call MPI_Allreduce(MPI_IN_PLACE, greset, np, MPI_DOUBLE_PRECISION, MPI_SUM, app%comm, mpierr)
    g(1:np) = g(1:np) + greset + 2.0_rp * params_tikhonov(id%par) * (theta(1:np) - params_initial(id%par))
    id%run%n_adjoint = id%run%n_adjoint + 1
    id%run%t_adjoint = id%run%t_adjoint + (MPI_Wtime() - wall0)
  end subroutine objective_gradient

  !> Remove the run's scratch directory (rank 0; after solver_destroy, which
  !> ends the trajectory). Collective in effect: every rank calls it.
  subroutine identify_scratch_remove(id)
    class(ident_core_t), intent(inout) :: id
    integer :: rank, mpierr
    call MPI_Comm_rank(MPI_COMM_WORLD, rank, mpierr)
    if (rank == 0 .and. len_trim(id%run%scratch) > 0) call remove_scratch(trim(id%run%scratch))
    id%run%scratch = ''
  end subroutine identify_scratch_remove

  !> Control: the adjoint of enter_window at the start ta of a window whose
  !> TSAdjointSolve has just run (lambda = dJ/dU there, the window's
  !> constraint state still set). There x = xb(ta) and v = vb of every
  !> constrained node, whatever they were before: g gets lambda_x . dxb/dd
  !> + lambda_v . dvb/dd of the driven nodes (this rank's part), and the
  !> lambda of every constrained node becomes 0.
  subroutine reset_adjoint(id, ta, g, ierr)
    class(ident_core_t), intent(inout) :: id
    real(rp), intent(in) :: ta
    real(rp), intent(inout) :: g(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: la(:, :, :)
    real(rp) :: sx(params_np(id%par)), sv(params_np(id%par))
    integer :: n, i, j, k, c, km(params_np(id%par)), kc(params_np(id%par))

    app => id%app
    ierr = 0
    if (.not. constraints_active(app%cs)) return
    call control_variables(id%par, km, kc)
    call step_sensitivities(id%par, app%cs, ta, sx, sv)
    PetscCall(DMDAVecGetArrayF90(app%da, id%run%lam(1), la, ierr))
    do n = 1, constraint_count(app%cs)
      call constraint_node(app%cs, n, i, j)
      if (constraint_path(app%cs, n) == PATH_KEYFRAMES) then
        do k = 1, size(kc)
          c = kc(k) - 1
          g(k) = g(k) + la(c, i, j) * sx(k) + la(3 + c, i, j) * sv(k)
        end do
      end if
      la(0:5, i, j) = 0.0_rp
    end do
    PetscCall(DMDAVecRestoreArrayF90(app%da, id%run%lam(1), la, ierr))
  end subroutine reset_adjoint

  !> TSSetIJacobianP callback: A = dF/dtheta at U (see the module header).
  subroutine ident_ijacobianp(ts, t, uvec, udotvec, shift, amat, id, ierr)
    type(tTS), intent(in) :: ts
    PetscReal, intent(in) :: t, shift
    type(tVec), intent(in) :: uvec, udotvec
    type(tMat), intent(in) :: amat
    type(ident_core_t), intent(in) :: id
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: a(:, :)

    PetscCall(MatDenseGetArrayF90(amat, a, ierr))
    a = 0.0_rp
    if (params_mode(id%par) == MODE_CONTROL) then
      call control_jacobianp(id, t, a)
    else
      call fit_jacobianp(id, uvec, a, ierr)
      if (ierr /= 0) return
    end if
    PetscCall(MatDenseRestoreArrayF90(amat, a, ierr))
  end subroutine ident_ijacobianp

  !> Control: F_x = xdot - vb on the driven nodes, dF_x/dd = -dvb/dd into
  !> a (this rank's rows, np columns; zero elsewhere).
  subroutine control_jacobianp(id, t, a)
    type(ident_core_t), intent(in) :: id
    real(rp), intent(in) :: t
    real(rp), intent(inout) :: a(:, :)
    type(app_ctx), pointer :: app
    real(rp) :: sx(params_np(id%par)), sv(params_np(id%par))
    integer :: n, k, r, i, j, km(params_np(id%par)), kc(params_np(id%par))

    app => id%app
    if (.not. constraints_active(app%cs)) return
    call control_variables(id%par, km, kc)
    call step_sensitivities(id%par, app%cs, t, sx, sv)
    do n = 1, constraint_count(app%cs)
      if (constraint_path(app%cs, n) /= PATH_KEYFRAMES) cycle
      call constraint_node(app%cs, n, i, j)
      r = 6 * (i + app%lat%nx * (j - app%lat%ys))
      do k = 1, size(kc)
        a(r + kc(k), k) = -sv(k)
      end do
    end do
  end subroutine control_jacobianp

  !> Identification: dF_v/d(ln p) = -f_p/m of each fitted p (f_p the force
  !> of the elements with only p non-zero), +f/m for total_mass, into a
  !> (this rank's rows, np columns; zero elsewhere) at the state uvec.
  subroutine fit_jacobianp(id, uvec, a, ierr)
    type(ident_core_t), intent(in) :: id
    type(tVec), intent(in) :: uvec
    real(rp), intent(inout) :: a(:, :)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    type(lattice_t) :: lp
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    integer :: k, i, j, r, nbad, bad(2)
    real(rp) :: sgn

    app => id%app
    PetscCall(ghosted_get(app%da, uvec, uloc, u, ierr))
    do k = 1, params_np(id%par)
      lp = app%lat
      sgn = -1.0_rp
      if (params_code(id%par, k) == 7) then
        sgn = 1.0_rp                 ! total_mass: F_v = vdot - f/m - g, m proportional to M
      else
        lp%e_s = 0; lp%e_d = 0; lp%eta_s = 0; lp%eta_d = 0; lp%k_b = 0; lp%eta_b = 0
        select case (params_code(id%par, k))
        case (1); lp%e_s = app%lat%e_s
        case (2); lp%e_d = app%lat%e_d
        case (3); lp%eta_s = app%lat%eta_s
        case (4); lp%eta_d = app%lat%eta_d
        case (5); lp%k_b = app%lat%k_b
        case (6); lp%eta_b = app%lat%eta_b
        end select
      end if
      call model_force_rows(app%model, lp, u, sgn, a(:, k), nbad, bad)
    end do
    PetscCall(ghosted_restore(app%da, uloc, u, ierr))
  end subroutine fit_jacobianp

  ! ----------------------------------------------------------------- readers

  !> The solver's context of the forward runs.
  function core_app(id) result(app)
    class(ident_core_t), intent(in) :: id
    type(app_ctx), pointer :: app
    app => id%app
  end function core_app

  !> The variables theta (read through identify_params' readers).
  function core_params(id) result(par)
    class(ident_core_t), intent(in), target :: id
    type(ident_params_t), pointer :: par
    par => id%par
  end function core_params

  !> The observation or target and the last forward run's residuals (read
  !> through identify_objective's readers).
  function core_obs(id) result(obs)
    class(ident_core_t), intent(in), target :: id
    type(ident_obs_t), pointer :: obs
    obs => id%obs
  end function core_obs

  !> The number of variables theta (for the size of an array of them).
  pure integer function core_np(id)
    class(ident_core_t), intent(in) :: id
    core_np = params_np(id%par)
  end function core_np

  !> A new vector of theta's layout (TAO's: np entries on rank 0).
  subroutine theta_vec_create(id, x, ierr)
    class(ident_core_t), intent(in) :: id
    type(tVec), intent(out) :: x
    PetscErrorCode, intent(out) :: ierr
    PetscCall(VecDuplicate(id%run%mu(1), x, ierr))
  end subroutine theta_vec_create

  !> Whether a forward run failed (a step did not converge) since the last
  !> one began.
  pure logical function run_failed(id)
    class(ident_core_t), intent(in) :: id
    run_failed = id%run%failed
  end function run_failed

  !> Why the last forward run failed when it was not a failed step ('' else).
  pure function run_fail_message(id) result(s)
    class(ident_core_t), intent(in) :: id
    character(len=len_trim(id%run%fail_msg)) :: s
    s = id%run%fail_msg
  end function run_fail_message

  !> The data term of J of the last forward run.
  pure real(rp) function run_objective_data(id)
    class(ident_core_t), intent(in) :: id
    run_objective_data = id%run%objective_data
  end function run_objective_data

  !> The size of the last forward run's trajectory: PETSc memory [bytes]
  !> (max over ranks), the basic trajectory's files [bytes] (all ranks),
  !> and its steps.
  pure subroutine run_trajectory(id, memory_bytes, file_bytes, nsteps)
    class(ident_core_t), intent(in) :: id
    real(rp), intent(out) :: memory_bytes, file_bytes
    integer, intent(out) :: nsteps
    memory_bytes = id%run%traj_bytes
    file_bytes = id%run%traj_disk_bytes
    nsteps = id%run%nsteps
  end subroutine run_trajectory

  !> The cost of a gradient, measured over all the forward runs and adjoint
  !> sweeps (a line on the caller's rank, after at least one of each).
  subroutine write_cost(id, unit)
    class(ident_core_t), intent(in) :: id
    integer, intent(in) :: unit
    real(rp) :: tf, ta
    if (id%run%n_forward == 0 .or. id%run%n_adjoint == 0) return
    tf = id%run%t_forward / id%run%n_forward
    ta = id%run%t_adjoint / id%run%n_adjoint
    write(unit, '(a,es10.3,a,es10.3,a,f6.2,2(a,es10.3),a)') params_tag(id%par)//': cost: forward run ', tf, &
      ' s, adjoint sweep ', ta, ' s, gradient/forward ', 1.0_rp + ta / tf, ', trajectory ', id%run%traj_bytes, &
      ' bytes in memory, ', id%run%traj_disk_bytes, ' bytes in files'
  end subroutine write_cost

  !> A failed forward run (at theta) as an error: ierr = 1 and errmsg.
  logical function failed_run(id, theta, errmsg, ierr)
    class(ident_core_t), intent(in) :: id
    real(rp), intent(in) :: theta(:)
    character(*), intent(out) :: errmsg
    PetscErrorCode, intent(out) :: ierr
    failed_run = id%run%failed
    ierr = 0
    errmsg = ''
    if (failed_run) then
      ierr = 1
      errmsg = params_tag(id%par)//': a forward run failed (a time step did not converge) at the '// &
               merge('keyframes ', 'parameters', params_mode(id%par) == MODE_CONTROL)//trim(values_text(id%par, theta))
    end if
  end function failed_run

end module identify_adjoint
