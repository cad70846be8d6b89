!> Identification and deformation control (docs/identification.md): one
!> forward run, one objective and one exact TSAdjoint gradient serve both.
!>
!> Identification fits model parameters to an observed motion: theta = ln p
!> for the fitted p (&identify fit). Deformation control optimises the
!> keyframe path of the driven nodes (wave_point's corner or edge, a
!> gripper) so that the cloth reaches a target: theta = the steps
!> d = koff(c, m) - koff(c, m-1) of the path into keyframes m = 2..nk, for
!> the chosen components c (&control components), so that a bound on the
!> speed of a segment, |d| <= max_speed (kt(m) - kt(m-1)), is a bound on
!> one variable. In both,
!>   J(theta) = sum_k w_k sum_nodes mask_n (|x_n(t_k) - xobs_n,k|^2
!>              + velocity_weight |v_n(t_k) - vobs_n,k|^2)
!>              + tikhonov sum_i (theta_i - theta_i,initial)^2,
!> minimised within bounds by PETSc TAO (bqnls by default), with the exact
!> gradient of the discrete trajectory from TSAdjoint.
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
!> dF/dtheta (TSSetIJacobianP, through src/nuno_adjoint.c). Identification:
!> every force is linear in each of e_s, e_d, eta_s, eta_d, k_b, eta_b, so
!> dF_v/d(ln p) = -f_p/m with f_p the force of the elements computed with
!> only p non-zero (the kernels of module forces on a lattice copy); for
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
  use petscdmda
  use mpi
  use hdf5
  use, intrinsic :: iso_fortran_env, only: output_unit
  use, intrinsic :: iso_c_binding, only: c_null_char, c_int
  use kinds, only: rp
  use config, only: nuno_config, fit_kind_names, unset_real
  use lattice, only: lattice_t, lattice_init
  use forces, only: internal_forces
  use scenes, only: scene_setup
  use constraints, only: constraint_events, constraint_step_sensitivity, PATH_KEYFRAMES
  use timestepping, only: app_ctx, enter_window
  use safe_files, only: make_scratch_dir, remove_scratch
  implicit none
  private
  public :: ident_t, identify_prepare_options, identify_run, identify_result, control_result, identify_scratch_remove

  integer, parameter :: MODE_IDENTIFY = 1, MODE_CONTROL = 2
  !> Step of the central differences (the Gauss-Newton Hessian of the
  !> uncertainty, -identify_check_gradient): in ln p; for control in the
  !> keyframe positions, times the cloth size max(lx, ly).
  real(rp), parameter :: FD_STEP = 1.0e-4_rp, FD_STEP_LENGTH = 1.0e-5_rp
  !> No bound: TAO's PETSC_INFINITY (PETSC_MAX_REAL / 4; no Fortran name in 3.18).
  real(rp), parameter :: NO_BOUND = huge(1.0_rp) / 4
  character(len=1), parameter :: XYZ(3) = ['x', 'y', 'z']

  !> Everything the TAO and TS callbacks of an identification or a control need.
  type :: ident_t
    type(app_ctx), pointer :: app => null()
    integer :: mode = MODE_IDENTIFY
    character(len=8) :: tag = 'identify'          !< prefix of the printed lines: identify | control
    integer :: np = 0                             !< TAO variables theta
    real(rp), allocatable :: theta0(:), theta(:)  !< (np) initial and current theta
    real(rp), allocatable :: lo(:), hi(:)         !< (np) bounds of theta
    real(rp) :: tikhonov = 0                      !< weight of sum (theta - theta0)^2
    real(rp) :: fd_step = FD_STEP                 !< step of the central differences in theta
    ! identification: theta = ln p
    integer, allocatable :: code(:)               !< (np) parameter codes (config: fit_kind_names)
    real(rp), allocatable :: unc(:)               !< (np) 1-sigma uncertainty of the fitted values [their units]
    ! control: theta(k) = step of component kc(k) into keyframe km(k)
    integer, allocatable :: km(:), kc(:)          !< (np) keyframe 2..nk, component 1..3
    integer :: nk = 0                             !< keyframes of the path
    real(rp), allocatable :: kt(:)                !< (nk) keyframe times [time]
    real(rp), allocatable :: koff0(:, :)          !< (3, nk) initial keyframe offsets [length]
    real(rp) :: vweight = 0                       !< weight of the velocity term [time^2]
    ! observation or target (owned rows only)
    integer :: nt = 0                             !< observed times used (t > 0)
    real(rp), allocatable :: tobs(:), wt(:)       !< (nt) times [time], weights [1]
    real(rp), allocatable :: xobs(:, :, :, :)     !< (3, 0:nx-1, ys:ye, nt) observed positions [length]
    real(rp), allocatable :: vobs(:, :, :, :)     !< as xobs, velocities [length/time] (vweight > 0 only)
    real(rp), allocatable :: mask(:, :)           !< (0:nx-1, ys:ye) node weights (markers) [1]
    real(rp), allocatable :: res(:, :, :, :)      !< x - xobs of the last forward run, as xobs
    real(rp), allocatable :: resv(:, :, :, :)     !< v - vobs of the last forward run (vweight > 0 only)
    real(rp) :: nobs = 0                          !< scalar observations with weight > 0 (all ranks)
    ! time windows: [wa, wb], observation index at wb (0: none), TS step at wb
    integer :: nw = 0
    real(rp), allocatable :: wa(:), wb(:)
    integer, allocatable :: wobs(:)
    PetscInt, allocatable :: wsteps(:)
    ! PETSc objects of the adjoint
    type(tMat) :: jacp                            !< dF/dtheta, dense, np columns on rank 0
    type(tVec) :: lam(1), mu(1)                   !< cost gradients w.r.t. the state and theta
    ! results
    real(rp) :: objective = 0, objective_data = 0
    integer :: nrow = 0                           !< values per history row after the objective
    integer :: nhist = 0
    real(rp), allocatable :: hist(:, :)           !< (0:nrow, nhist): objective, then the fitted values
                                                  !< (identify) or the keyframe offsets (3, nk) (control)
    ! cost measurements
    integer :: n_forward = 0, n_adjoint = 0
    real(rp) :: t_forward = 0, t_adjoint = 0      !< wall-clock seconds of all forward / adjoint sweeps
    real(rp) :: traj_bytes = 0                    !< PETSc memory held by the trajectory of one forward run (max over ranks)
    real(rp) :: traj_disk_bytes = 0               !< size of the basic trajectory's files of one forward run (all ranks)
    integer :: nsteps = 0                         !< steps of one forward run
    logical :: failed = .false.                   !< a forward run failed (a step did not converge)
    character(len=512) :: fail_msg = ''           !< why, when not a failed step
    character(len=600) :: traj_dir = ''           !< directory of the basic trajectory's files
    character(len=600) :: scratch = ''            !< its private parent, made by this run (rank 0)
  end type ident_t

  interface
    !> src/nuno_adjoint.c: TSSetIJacobianP for Fortran callbacks.
    subroutine nuno_ts_set_ijacobianp(ts, a, func, ctx, ierr)
      import :: tTS, tMat, ident_t
      type(tTS) :: ts
      type(tMat) :: a
      external :: func
      type(ident_t) :: ctx
      PetscErrorCode :: ierr
    end subroutine nuno_ts_set_ijacobianp
    !> src/nuno_adjoint.c: a fresh trajectory (memory unless -ts_trajectory_type).
    subroutine nuno_ts_trajectory_fresh(ts, horizon, dt, nwindows, dirname, ierr)
      import :: tTS
      type(tTS) :: ts
      PetscReal :: horizon, dt
      PetscInt :: nwindows
      character(*) :: dirname
      PetscErrorCode :: ierr
    end subroutine nuno_ts_trajectory_fresh
    !> src/nuno_adjoint.c: -identify_check_gradient, -control_check_gradient (in -help).
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
  subroutine identify_prepare_options(ierr)
    PetscErrorCode, intent(out) :: ierr
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
  !> uncertainty too); on return ctx holds the fitted parameters or the
  !> optimised keyframes and the initial state, ready for solver_run to
  !> write the resulting motion. ierr = 1 with errmsg: a collective error
  !> (bad observation, failed forward run); ierr > 1: a PETSc error. done:
  !> nothing more to do (-identify_check_gradient, -control_check_gradient).
  subroutine identify_run(id, ctx, done, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    type(app_ctx), intent(inout), target :: ctx
    logical, intent(out) :: done
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(c_int) :: check_identify, check_control

    done = .false.
    errmsg = ''
    id%app => ctx
    ierr = nuno_adjoint_options_read(ctx%comm, check_identify, check_control)
    if (ierr /= 0) return
    call setup(id, ierr, errmsg)
    if (ierr /= 0) return
    ! The two names are one check (each reads better in its own input).
    if (check_identify /= 0 .or. check_control /= 0) then
      call check_gradient(id, ierr, errmsg)
      done = .true.
    else
      call fit(id, ierr, errmsg)
      if (ierr == 0) then
        if (id%mode == MODE_IDENTIFY) then
          call uncertainty(id, ierr, errmsg)
        else
          call final_objective(id, ierr, errmsg)
        end if
      end if
      if (ierr == 0) call report(id)
    end if
    if (ierr == 1 .and. len_trim(id%fail_msg) > 0) errmsg = id%fail_msg
    if (ierr /= 0) return
    ! The resulting motion, from t = 0, for solver_run.
    call reset_state(id, id%theta, ierr)
    if (ierr /= 0) ierr = 2
  end subroutine identify_run

  ! ------------------------------------------------------------------ set-up

  subroutine setup(id, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    type(app_ctx), pointer :: app
    PetscInt :: nloc, ncol, np, ntot
    real(rp), allocatable :: ev(:), stops(:)
    real(rp) :: eps, tmax
    integer :: k, w

    app => id%app
    if (app%cfg%control) then
      call setup_control(id, app%cfg)
      call read_observation(id, trim(app%cfg%target_file), 'control', 'target_file', ierr, errmsg)
    else
      call setup_identify(id, app%cfg)
      call read_observation(id, trim(app%cfg%observed_file), 'identify', 'observed_file', ierr, errmsg)
    end if
    if (ierr /= 0) return
    id%theta = id%theta0
    ! The trajectory's files go into a directory of this run's own, made
    ! anew (mkdtemp: OUTPUT.adjoint.XXXXXX, mode 0700) beside the output,
    ! and only it is removed at the end: a user's OUTPUT.adjoint (or a
    ! link of that name) is never touched. PETSc's basic trajectory makes
    ! and removes the subdirectory `trajectory` itself.
    call make_scratch(id, trim(app%cfg%output_file), ierr, errmsg)
    if (ierr /= 0) return
    id%traj_dir = trim(id%scratch)//'/trajectory'

    ! Windows: every observed time, keyframe and release time up to the last observation.
    tmax = id%tobs(id%nt)
    eps = 1.0e-12_rp * max(1.0_rp, tmax)
    ev = constraint_events(app%cs, tmax)
    stops = [id%tobs, pack(ev, ev < tmax - eps)]
    call sort_unique(stops, eps)
    id%nw = size(stops)
    allocate(id%wa(id%nw), id%wb(id%nw), id%wobs(id%nw), id%wsteps(0:id%nw))
    id%wb = stops
    id%wa(1) = 0.0_rp
    id%wa(2:) = stops(1:id%nw - 1)
    id%wobs = 0
    do w = 1, id%nw
      do k = 1, id%nt
        if (abs(id%tobs(k) - id%wb(w)) <= eps) id%wobs(w) = k
      end do
    end do
    id%wsteps = 0
    allocate(id%res, mold=id%xobs)
    id%res = 0.0_rp
    if (id%vweight > 0.0_rp) then
      allocate(id%resv, mold=id%xobs)
      id%resv = 0.0_rp
    end if
    allocate(id%hist(0:id%nrow, 0))

    ! dF/dtheta: dense, the state's rows, np columns kept on rank 0 (the
    ! layout of TAO's vector).
    nloc = 6 * app%lat%nx * (app%lat%ye - app%lat%ys + 1)
    np = id%np
    ncol = 0
    if (app%rank == 0) ncol = np
    ntot = 6 * app%lat%nx * app%lat%ny
    PetscCall(MatCreateDense(app%comm, nloc, ncol, ntot, np, PETSC_NULL_SCALAR, id%jacp, ierr))
    PetscCall(MatSetUp(id%jacp, ierr))
    PetscCall(MatAssemblyBegin(id%jacp, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatAssemblyEnd(id%jacp, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatCreateVecs(id%jacp, id%mu(1), PETSC_NULL_VEC, ierr))
    PetscCall(DMCreateGlobalVector(app%da, id%lam(1), ierr))
    call nuno_ts_set_ijacobianp(app%ts, id%jacp, ident_ijacobianp, id, ierr)
    if (ierr /= 0) return
    if (app%rank == 0) then
      if (id%mode == MODE_CONTROL) then
        write(output_unit, '(a,i0,a,i0,a,i0,a,i0,a)') 'control   : ', id%np, ' variable(s) (the steps of ', id%nk, &
          ' keyframes in '//trim(app%cfg%components)//'), ', id%nt, ' target time(s), ', id%nw, &
          ' time windows; '//trim(app%cfg%target_file)
      else
        write(output_unit, '(a,i0,a,i0,a,i0,a)') 'identify  : ', id%np, ' parameter(s), ', id%nt, &
          ' observed times, ', id%nw, ' time windows; '//trim(app%cfg%observed_file)
      end if
      flush(output_unit)
    end if
  end subroutine setup

  !> &identify: theta = ln p of the fitted parameters, within ln of the bounds.
  subroutine setup_identify(id, cfg)
    type(ident_t), intent(inout) :: id
    type(nuno_config), intent(in) :: cfg
    integer :: k
    id%mode = MODE_IDENTIFY
    id%tag = 'identify'
    id%np = cfg%n_fit
    id%code = cfg%fit_code(1:id%np)
    allocate(id%theta0(id%np), id%lo(id%np), id%hi(id%np), id%unc(id%np))
    do k = 1, id%np
      id%theta0(k) = log(param_value(cfg, id%code(k)))
      id%lo(k) = log(cfg%fit_lower(k))
      id%hi(k) = log(cfg%fit_upper(k))
    end do
    id%unc = 0.0_rp
    id%tikhonov = cfg%tikhonov
    id%fd_step = FD_STEP
    id%nrow = id%np
  end subroutine setup_identify

  !> &control: theta = the steps of the chosen components into keyframes
  !> 2..nk (keyframe-major), bounded by max_speed times the segment's
  !> duration when it is set; the first keyframe stays as given.
  subroutine setup_control(id, cfg)
    type(ident_t), intent(inout) :: id
    type(nuno_config), intent(in) :: cfg
    integer :: m, c, k
    real(rp) :: bound
    id%mode = MODE_CONTROL
    id%tag = 'control'
    id%nk = cfg%n_keyframes
    id%kt = cfg%keyframe_time(1:id%nk)
    allocate(id%koff0(3, id%nk))
    id%koff0(1, :) = cfg%keyframe_dx(1:id%nk)
    id%koff0(2, :) = cfg%keyframe_dy(1:id%nk)
    id%koff0(3, :) = cfg%keyframe_dz(1:id%nk)
    id%np = (id%nk - 1) * count(cfg%control_comp)
    allocate(id%km(id%np), id%kc(id%np), id%theta0(id%np), id%lo(id%np), id%hi(id%np))
    k = 0
    do m = 2, id%nk
      bound = NO_BOUND
      if (cfg%max_speed /= unset_real) bound = cfg%max_speed * (id%kt(m) - id%kt(m - 1))
      do c = 1, 3
        if (.not. cfg%control_comp(c)) cycle
        k = k + 1
        id%km(k) = m
        id%kc(k) = c
        id%theta0(k) = id%koff0(c, m) - id%koff0(c, m - 1)
        id%lo(k) = -bound
        id%hi(k) = bound
      end do
    end do
    id%tikhonov = cfg%keyframe_tikhonov
    id%vweight = cfg%velocity_weight
    id%fd_step = FD_STEP_LENGTH * max(cfg%lx, cfg%ly)
    id%nrow = 3 * id%nk
  end subroutine setup_control

  !> Sort ascending and drop values within eps of the previous one.
  subroutine sort_unique(a, eps)
    real(rp), allocatable, intent(inout) :: a(:)
    real(rp), intent(in) :: eps
    real(rp), allocatable :: b(:)
    real(rp) :: x
    integer :: i, j
    do i = 2, size(a)
      x = a(i)
      j = i - 1
      do while (j >= 1)
        if (a(j) <= x) exit
        a(j + 1) = a(j)
        j = j - 1
      end do
      a(j + 1) = x
    end do
    allocate(b(0))
    do i = 1, size(a)
      if (size(b) > 0) then
        if (a(i) <= b(size(b)) + eps) cycle
      end if
      b = [b, a(i)]
    end do
    a = b
  end subroutine sort_unique

  !> The observed motion: /time [nt] and /position [nt][ny][nx][3] (the
  !> layout of nuno's own output, model.md section 9), optional /mask
  !> [ny][nx] (node weights: 1 at an observed marker, 0 elsewhere) and
  !> /weight [nt] (per time), and /velocity [nt][ny][nx][3] where the
  !> objective weighs velocities (&control velocity_weight; absent: zero,
  !> the cloth at rest). Times <= 0 are left out (the initial positions do
  !> not depend on the parameters). Every rank reads its own rows; the
  !> checks are the same on every rank and the error flag is agreed.
  subroutine read_observation(id, path, group, key, ierr, errmsg)
    type(ident_t), intent(inout) :: id
    character(*), intent(in) :: path
    character(*), intent(in) :: group, key    !< the namelist key that names the file, for messages
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: file, dset, space, mspace
    integer(hsize_t) :: dims(4), maxdims(4), start(4), cnt(4)
    integer :: h, hopen, ndims, nx, ny, ys, nyl, ntall, k, n, e, mpierr
    real(rp), allocatable :: tall(:), wall(:), pall(:, :, :, :), vall(:, :, :, :), m2(:, :)
    logical :: exists, have_mask, have_weight
    character(len=:), allocatable :: where

    nx = id%app%lat%nx
    ny = id%app%lat%ny
    ys = id%app%lat%ys
    nyl = id%app%lat%ye - ys + 1
    where = '&'//group//': '//key//" '"//path//"'"
    hopen = 0
    e = 0
    ntall = 0          ! sizes the /weight buffer even when /time was never read
    errmsg = ''
    file = -1
    call h5open_f(h)
    inquire(file=path, exist=exists)
    if (.not. exists) then
      e = 1
      errmsg = 'input: '//where//': no such file'
    end if
    if (e == 0) then
      ! HDF5's own error printing stays off: the line below says it (a
      ! file that is not HDF5 made a 33-line stack before it). The open's
      ! code is kept apart from the other calls' (h).
      call h5eset_auto_f(0, h)
      call h5fopen_f(path, H5F_ACC_RDONLY_F, file, hopen)
      h = hopen
      if (h < 0) then
        e = 1
        errmsg = 'input: '//where//': not an HDF5 file (or not readable)'
      end if
    end if
    ! /time
    if (e == 0) call open_dset('/time', 1, .true.)
    if (e == 0) then
      ntall = int(dims(1))
      allocate(tall(ntall))
      call h5dread_f(dset, H5T_NATIVE_DOUBLE, tall, dims(1:1), h)
      if (h < 0) call bad('cannot read /time')
      call h5dclose_f(dset, h)
    end if
    ! /position, this rank's rows; /velocity (optional) as /position, when
    ! the objective has a velocity term (control's velocity_weight)
    if (e == 0) call read_states('/position', pall, .true.)
    if (e == 0) then
      allocate(vall(3, 0:nx - 1, ys:ys + nyl - 1, ntall))
      vall = 0.0_rp
      if (id%vweight > 0.0_rp) call read_states('/velocity', vall, .false.)
    end if
    ! optional /mask and /weight
    allocate(m2(0:nx - 1, 0:ny - 1))
    m2 = 1.0_rp
    have_mask = .false.
    if (e == 0) then
      call h5lexists_f(file, '/mask', have_mask, h)
      if (have_mask) then
        call open_dset('/mask', 2, .true.)
        if (e == 0 .and. (dims(1) /= nx .or. dims(2) /= ny)) then
          write(errmsg, '(a,i0,a,i0,a)') 'input: '//where//': /mask must be [ny][nx] = [', ny, '][', nx, ']'
          e = 1
        end if
        if (e == 0) then
          call h5dread_f(dset, H5T_NATIVE_DOUBLE, m2, dims(1:2), h)
          if (h < 0) call bad('cannot read /mask')
          call h5dclose_f(dset, h)
        end if
      end if
    end if
    allocate(wall(max(ntall, 0)))
    wall = 1.0_rp
    if (e == 0) then
      call h5lexists_f(file, '/weight', have_weight, h)
      if (have_weight) then
        call open_dset('/weight', 1, .true.)
        if (e == 0 .and. dims(1) /= ntall) then
          write(errmsg, '(a,i0,a)') 'input: '//where//': /weight must be [nt] = [', ntall, '] like /time'
          e = 1
        end if
        if (e == 0) then
          call h5dread_f(dset, H5T_NATIVE_DOUBLE, wall, dims(1:1), h)
          if (h < 0) call bad('cannot read /weight')
          call h5dclose_f(dset, h)
        end if
      end if
    end if
    if (file >= 0) call h5fclose_f(file, h)
    if (e == 0) then
      if (any(m2 /= m2) .or. any(m2 < 0.0_rp) .or. any(wall /= wall) .or. any(wall < 0.0_rp)) then
        e = 1
        errmsg = 'input: '//where//': /mask and /weight must be finite and >= 0'
      else if (any(tall(2:) <= tall(:ntall - 1))) then
        e = 1
        errmsg = 'input: '//where//': /time must increase'
      else if (count_pos(tall) == 0) then
        e = 1
        errmsg = 'input: '//where//': no observed time > 0'
      else if (any(pall /= pall) .or. any(vall /= vall)) then
        e = 1
        errmsg = 'input: '//where//': /position or /velocity holds NaN'
      end if
    end if
    ! One decision for all ranks.
    call MPI_Allreduce(MPI_IN_PLACE, e, 1, MPI_INTEGER, MPI_MAX, id%app%comm, mpierr)
    if (e /= 0) then
      ierr = 1
      if (len_trim(errmsg) == 0) errmsg = 'input: '//where//': could not be read on some rank'
      return
    end if
    ierr = 0
    n = count_pos(tall)
    id%nt = n
    allocate(id%tobs(n), id%wt(n), id%xobs(3, 0:nx - 1, ys:ys + nyl - 1, n))
    if (id%vweight > 0.0_rp) allocate(id%vobs, mold=id%xobs)
    n = 0
    do k = 1, ntall
      if (tall(k) <= 0.0_rp) cycle
      n = n + 1
      id%tobs(n) = tall(k)
      id%wt(n) = wall(k)
      id%xobs(:, :, :, n) = pall(:, :, :, k)
      if (id%vweight > 0.0_rp) id%vobs(:, :, :, n) = vall(:, :, :, k)
    end do
    allocate(id%mask(0:nx - 1, ys:ys + nyl - 1))
    id%mask = m2(:, ys:ys + nyl - 1)
    id%nobs = 3.0_rp * real(count(m2 > 0.0_rp), rp) * real(count(id%wt > 0.0_rp), rp)
  contains
    integer function count_pos(t)
      real(rp), intent(in) :: t(:)
      count_pos = count(t > 0.0_rp)
    end function count_pos
    subroutine bad(what)
      character(*), intent(in) :: what
      if (e /= 0) return
      e = 1
      errmsg = 'input: '//where//': '//what
    end subroutine bad
    !> A [nt][ny][nx][3] dataset like /position, this rank's rows, into a
    !> (3, 0:nx-1, ys:ye, nt); left as it is when absent and not required.
    subroutine read_states(name, a, required)
      character(*), intent(in) :: name
      real(rp), allocatable, intent(inout) :: a(:, :, :, :)
      logical, intent(in) :: required
      logical :: ex
      if (.not. required) then
        call h5lexists_f(file, name, ex, h)
        if (h < 0 .or. .not. ex) return
      end if
      call open_dset(name, 4, .true.)
      if (e /= 0) return
      if (dims(1) /= 3 .or. dims(2) /= nx .or. dims(3) /= ny .or. dims(4) /= ntall) then
        write(errmsg, '(a,4(i0,a),3(i0,a))') 'input: '//where//': '//name//' is [', dims(4), '][', dims(3), '][', &
          dims(2), '][', dims(1), '] but the run needs [nt][ny][nx][3] = [', ntall, '][', ny, '][', nx, &
          '][3] (nt from /time, the lattice from &lattice)'
        e = 1
        call h5dclose_f(dset, h)
        return
      end if
      if (.not. allocated(a)) allocate(a(3, 0:nx - 1, ys:ys + nyl - 1, ntall))
      start = [0_hsize_t, 0_hsize_t, int(ys, hsize_t), 0_hsize_t]
      cnt = [3_hsize_t, int(nx, hsize_t), int(nyl, hsize_t), int(ntall, hsize_t)]
      call h5dget_space_f(dset, space, h)
      call h5sselect_hyperslab_f(space, H5S_SELECT_SET_F, start, cnt, h)
      call h5screate_simple_f(4, cnt, mspace, h)
      call h5dread_f(dset, H5T_NATIVE_DOUBLE, a, cnt, h, mspace, space)
      if (h < 0) call bad('cannot read '//name)
      call h5sclose_f(mspace, h)
      call h5sclose_f(space, h)
      call h5dclose_f(dset, h)
    end subroutine read_states
    subroutine open_dset(name, rank, required)
      character(*), intent(in) :: name
      integer, intent(in) :: rank
      logical, intent(in) :: required
      logical :: ex
      call h5lexists_f(file, name, ex, h)
      if (h < 0 .or. .not. ex) then
        if (required) call bad('no dataset '//name)
        return
      end if
      call h5dopen_f(file, name, dset, h)
      if (h < 0) then
        call bad('cannot open '//name)
        return
      end if
      call h5dget_space_f(dset, space, h)
      call h5sget_simple_extent_ndims_f(space, ndims, h)
      if (ndims /= rank) then
        call h5sclose_f(space, h)
        call h5dclose_f(dset, h)
        write(errmsg, '(a,i0,a,i0)') 'input: '//where//': '//name//' has ', ndims, ' dimensions, expected ', rank
        e = 1
        return
      end if
      dims = 1
      call h5sget_simple_extent_dims_f(space, dims(1:rank), maxdims(1:rank), h)
      call h5sclose_f(space, h)
    end subroutine open_dset
  end subroutine read_observation

  ! --------------------------------------------------------- parameters

  !> Value of parameter `code` in cfg.
  pure real(rp) function param_value(cfg, code)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: code
    select case (code)
    case (1); param_value = cfg%e_s
    case (2); param_value = cfg%e_d
    case (3); param_value = cfg%eta_s
    case (4); param_value = cfg%eta_d
    case (5); param_value = cfg%k_b
    case (6); param_value = cfg%eta_b
    case default; param_value = cfg%total_mass
    end select
  end function param_value

  subroutine set_param(cfg, code, v)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(in) :: code
    real(rp), intent(in) :: v
    select case (code)
    case (1); cfg%e_s = v
    case (2); cfg%e_d = v
    case (3); cfg%eta_s = v
    case (4); cfg%eta_d = v
    case (5); cfg%k_b = v
    case (6); cfg%eta_b = v
    case default; cfg%total_mass = v
    end select
  end subroutine set_param

  !> Control: the keyframe offsets (3, nk) [length] of theta: the first
  !> keyframe and the components not optimised as given, the others the
  !> sums of the steps.
  pure function keyframes(id, theta) result(off)
    type(ident_t), intent(in) :: id
    real(rp), intent(in) :: theta(:)
    real(rp) :: off(3, id%nk)
    integer :: k
    off = id%koff0
    do k = 1, id%np                 ! keyframe-major: keyframe km(k) - 1 is already set
      off(id%kc(k), id%km(k)) = off(id%kc(k), id%km(k) - 1) + theta(k)
    end do
  end function keyframes

  !> The values a history row holds after the objective: the fitted values
  !> (identify) or the keyframe offsets (control).
  function row_values(id, theta) result(v)
    type(ident_t), intent(in) :: id
    real(rp), intent(in) :: theta(:)
    real(rp) :: v(id%nrow)
    if (id%mode == MODE_CONTROL) then
      v = reshape(keyframes(id, theta), [id%nrow])
    else
      v = exp(theta(1:id%np))
    end if
  end function row_values

  !> theta into the configuration: the parameters exp(theta), or the
  !> keyframe offsets of the path.
  subroutine apply_theta(id, theta, cfg)
    type(ident_t), intent(in) :: id
    real(rp), intent(in) :: theta(:)
    type(nuno_config), intent(inout) :: cfg
    real(rp) :: off(3, id%nk)
    integer :: k
    if (id%mode == MODE_CONTROL) then
      off = keyframes(id, theta)
      cfg%keyframe_dx(1:id%nk) = off(1, :)
      cfg%keyframe_dy(1:id%nk) = off(2, :)
      cfg%keyframe_dz(1:id%nk) = off(3, :)
    else
      do k = 1, id%np
        call set_param(cfg, id%code(k), exp(theta(k)))
      end do
      cfg%has_damping = cfg%eta_s > 0.0_rp .or. cfg%eta_d > 0.0_rp
    end if
  end subroutine apply_theta

  !> theta into the configuration and the lattice (masses, constants) or
  !> the constraints (keyframe path), the scene's initial state into the
  !> state vector, the TS back at t = 0 with a fresh trajectory. Collective.
  subroutine reset_state(id, theta, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: theta(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: ua(:, :, :)
    integer :: ys, ye
    PetscInt, parameter :: zero = 0
    PetscReal :: horizon
    PetscInt :: nw

    app => id%app
    call apply_theta(id, theta, app%cfg)
    ys = app%lat%ys
    ye = app%lat%ye
    call lattice_init(app%lat, app%cfg, ys, ye)
    PetscCall(DMDAVecGetArrayF90(app%da, app%u, ua, ierr))
    call scene_setup(app%cfg, app%lat, ua, app%cs)
    PetscCall(DMDAVecRestoreArrayF90(app%da, app%u, ua, ierr))
    PetscCall(TSSetTime(app%ts, 0.0_rp, ierr))
    PetscCall(TSSetStepNumber(app%ts, zero, ierr))
    ! Room for the whole run: its steps, one more per window, retries.
    horizon = 2.0_rp * (id%wb(id%nw) + real(id%nw + 1, rp) * app%step%dt)
    nw = id%nw
    call nuno_ts_trajectory_fresh(app%ts, horizon, app%step%dt, nw, trim(id%traj_dir)//c_null_char, ierr)
    if (ierr == -1) then
      ierr = 1
      id%failed = .true.
      id%fail_msg = '-ts_trajectory_type memory: PETSc 3.18 cannot checkpoint in memory across the '// &
        trim(id%tag)//' run''s time windows (observed, keyframe and release times); use basic (the default)'
      return
    end if
    if (ierr /= 0) return
    app%energy%dissipated = 0
    app%energy%work_constraints = 0
    app%energy%t_prev = 0
    app%energy%pdiss_prev = 0
    app%energy%pcon_prev = 0
    app%progress%t_written = -1
  end subroutine reset_state

  !> id%scratch: a new private directory beside the output file (rank 0
  !> makes it, every rank gets its name). ierr = 1 with errmsg when it
  !> cannot be made. Collective.
  subroutine make_scratch(id, output, ierr, errmsg)
    type(ident_t), intent(inout) :: id
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
        id%scratch = dir
      else
        e = 1
        errmsg = 'output: cannot make the scratch directory '//trim(output)//'.adjoint.XXXXXX of the '// &
                 'identification or control: '//trim(why)
      end if
    end if
    call MPI_Bcast(e, 1, MPI_INTEGER, 0, id%app%comm, mpierr)
    call MPI_Bcast(id%scratch, len(id%scratch), MPI_CHARACTER, 0, id%app%comm, mpierr)
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, 0, id%app%comm, mpierr)
    ierr = e
  end subroutine make_scratch

  ! ------------------------------------------------------ forward, adjoint

  !> One forward run at theta over all windows, saving the trajectory; the
  !> objective f and the residuals x - xobs (v - vobs) at the observed
  !> times. A failed step sets id%failed (f = huge). Collective.
  subroutine forward(id, theta, f, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: theta(:)
    real(rp), intent(out) :: f
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: ua(:, :, :)
    TSConvergedReason :: reason
    PetscLogDouble :: mem0, mem1
    real(rp) :: t, h, dke, floc, wall0, eps
    integer :: w, k, j, i, mpierr

    app => id%app
    wall0 = MPI_Wtime()
    call reset_state(id, theta, ierr)
    if (ierr /= 0) return
    PetscCall(PetscMallocGetCurrentUsage(mem0, ierr))
    id%failed = .false.
    floc = 0.0_rp
    t = 0.0_rp
    eps = 1.0e-12_rp * max(1.0_rp, id%wb(id%nw))
    do w = 1, id%nw
      call enter_window(app, id%wa(w), id%wb(w), dke, ierr)
      if (ierr /= 0) return
      app%step%tstop = id%wb(w)
      PetscCall(TSRestartStep(app%ts, ierr))
      ! The memory trajectory stores a window's first state only if the TS
      ! is not marked converged (from the previous window) when TSSolve
      ! saves it; otherwise the adjoint of the previous window pops the
      ! wrong checkpoint.
      PetscCall(TSSetConvergedReason(app%ts, TS_CONVERGED_ITERATING, ierr))
      PetscCall(TSSetMaxTime(app%ts, id%wb(w), ierr))
      h = app%step%dt
      if (t + 1.01_rp * h >= id%wb(w)) h = id%wb(w) - t
      PetscCall(TSSetTimeStep(app%ts, h, ierr))
      PetscCall(TSSolve(app%ts, app%u, ierr))
      PetscCall(TSGetConvergedReason(app%ts, reason, ierr))
      PetscCall(TSGetTime(app%ts, t, ierr))
      if (reason < 0 .or. abs(t - id%wb(w)) > 1.0e3_rp * eps) then
        id%failed = .true.
        if (app%rank == 0) write(output_unit, '(a,i0,a,es14.6,a,es14.6)') trim(id%tag)// &
          ': forward run stopped (TSConvergedReason ', reason, ') at t = ', t, ' in the window ending at ', id%wb(w)
        exit
      end if
      t = id%wb(w)
      PetscCall(TSSetTime(app%ts, t, ierr))
      PetscCall(TSGetStepNumber(app%ts, id%wsteps(w), ierr))
      k = id%wobs(w)
      if (k > 0) then
        PetscCall(DMDAVecGetArrayReadF90(app%da, app%u, ua, ierr))
        do j = app%lat%ys, app%lat%ye
          do i = 0, app%lat%nx - 1
            id%res(:, i, j, k) = ua(0:2, i, j) - id%xobs(:, i, j, k)
            floc = floc + id%wt(k) * id%mask(i, j) * sum(id%res(:, i, j, k)**2)
            if (id%vweight > 0.0_rp) then
              id%resv(:, i, j, k) = ua(3:5, i, j) - id%vobs(:, i, j, k)
              floc = floc + id%wt(k) * id%mask(i, j) * id%vweight * sum(id%resv(:, i, j, k)**2)
            end if
          end do
        end do
        PetscCall(DMDAVecRestoreArrayReadF90(app%da, app%u, ua, ierr))
      end if
    end do
    PetscCall(PetscMallocGetCurrentUsage(mem1, ierr))
    ! The trajectory: in memory what PETSc allocated during the run (max
    ! over ranks); the basic type's files hold the state and the one stage
    ! of beuler/theta per step instead, (2 x 6 x 8) bytes a node and step.
    id%traj_bytes = real(mem1 - mem0, rp)
    call MPI_Allreduce(MPI_IN_PLACE, id%traj_bytes, 1, MPI_DOUBLE_PRECISION, MPI_MAX, app%comm, mpierr)
    id%traj_disk_bytes = real(id%wsteps(id%nw) + 1, rp) * 96.0_rp * real(app%lat%nx, rp) * real(app%lat%ny, rp)
    call MPI_Allreduce(floc, f, 1, MPI_DOUBLE_PRECISION, MPI_SUM, app%comm, mpierr)
    id%objective_data = f
    f = f + id%tikhonov * sum((theta(1:id%np) - id%theta0)**2)
    if (id%failed) f = huge(1.0_rp)
    id%nsteps = int(id%wsteps(id%nw))
    id%n_forward = id%n_forward + 1
    id%t_forward = id%t_forward + (MPI_Wtime() - wall0)
  end subroutine forward

  !> Objective and its exact gradient with respect to theta (one forward
  !> run, then the adjoint backward over the windows). Collective.
  subroutine objective_gradient(id, theta, f, g, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: theta(:)
    real(rp), intent(out) :: f, g(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: la(:, :, :), ma(:)
    PetscInt :: nsteps
    real(rp) :: dke, wall0, greset(id%np)
    integer :: w, k, j, i, mpierr
    PetscInt, parameter :: one = 1

    app => id%app
    call forward(id, theta, f, ierr)
    if (ierr /= 0) return
    g = 0.0_rp
    if (id%failed) return
    wall0 = MPI_Wtime()
    greset = 0.0_rp
    PetscCall(VecZeroEntries(id%lam(1), ierr))
    PetscCall(VecZeroEntries(id%mu(1), ierr))
    PetscCall(TSSetCostGradients(app%ts, one, id%lam(1), id%mu(1), ierr))
    do w = id%nw, 1, -1
      k = id%wobs(w)
      if (k > 0) then
        PetscCall(DMDAVecGetArrayF90(app%da, id%lam(1), la, ierr))
        do j = app%lat%ys, app%lat%ye
          do i = 0, app%lat%nx - 1
            la(0:2, i, j) = la(0:2, i, j) + 2.0_rp * id%wt(k) * id%mask(i, j) * id%res(:, i, j, k)
            if (id%vweight > 0.0_rp) la(3:5, i, j) = la(3:5, i, j) + &
              2.0_rp * id%wt(k) * id%mask(i, j) * id%vweight * id%resv(:, i, j, k)
          end do
        end do
        PetscCall(DMDAVecRestoreArrayF90(app%da, id%lam(1), la, ierr))
      end if
      ! The constraint state of this window for its Jacobians.
      call enter_window(app, id%wa(w), id%wb(w), dke, ierr)
      if (ierr /= 0) return
      nsteps = id%wsteps(w) - id%wsteps(w - 1)
      PetscCall(TSAdjointSetSteps(app%ts, nsteps, ierr))
      PetscCall(TSAdjointSolve(app%ts, ierr))
      if (id%mode == MODE_CONTROL) then
        call reset_adjoint(id, id%wa(w), greset, ierr)
        if (ierr /= 0) return
      end if
    end do
    if (app%rank == 0) then
      PetscCall(VecGetArrayReadF90(id%mu(1), ma, ierr))
      g(1:id%np) = ma(1:id%np)
      PetscCall(VecRestoreArrayReadF90(id%mu(1), ma, ierr))
    end if
    call MPI_Bcast(g, id%np, MPI_DOUBLE_PRECISION, 0, app%comm, mpierr)
    call MPI_Allreduce(MPI_IN_PLACE, greset, id%np, MPI_DOUBLE_PRECISION, MPI_SUM, app%comm, mpierr)
    g(1:id%np) = g(1:id%np) + greset + 2.0_rp * id%tikhonov * (theta(1:id%np) - id%theta0)
    id%n_adjoint = id%n_adjoint + 1
    id%t_adjoint = id%t_adjoint + (MPI_Wtime() - wall0)
  end subroutine objective_gradient

  !> Remove the run's scratch directory (rank 0; after solver_destroy, which
  !> ends the trajectory). Collective in effect: every rank calls it.
  subroutine identify_scratch_remove(id)
    type(ident_t), intent(inout) :: id
    integer :: rank, mpierr
    call MPI_Comm_rank(MPI_COMM_WORLD, rank, mpierr)
    if (rank == 0 .and. len_trim(id%scratch) > 0) call remove_scratch(trim(id%scratch))
    id%scratch = ''
  end subroutine identify_scratch_remove

  !> Control: the adjoint of enter_window at the start ta of a window whose
  !> TSAdjointSolve has just run (lambda = dJ/dU there, the window's
  !> constraint state still set). There x = xb(ta) and v = vb of every
  !> constrained node, whatever they were before: g gets lambda_x . dxb/dd
  !> + lambda_v . dvb/dd of the driven nodes (this rank's part), and the
  !> lambda of every constrained node becomes 0.
  subroutine reset_adjoint(id, ta, g, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: ta
    real(rp), intent(inout) :: g(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: la(:, :, :)
    real(rp) :: sx, sv
    integer :: n, i, j, k, c

    app => id%app
    ierr = 0
    if (.not. app%cs%active) return
    PetscCall(DMDAVecGetArrayF90(app%da, id%lam(1), la, ierr))
    do n = 1, app%cs%n
      i = app%cs%node(1, n)
      j = app%cs%node(2, n)
      if (app%cs%path(n) == PATH_KEYFRAMES) then
        do k = 1, id%np
          call constraint_step_sensitivity(app%cs, ta, id%km(k), sx, sv)
          c = id%kc(k) - 1
          g(k) = g(k) + la(c, i, j) * sx + la(3 + c, i, j) * sv
        end do
      end if
      la(0:5, i, j) = 0.0_rp
    end do
    PetscCall(DMDAVecRestoreArrayF90(app%da, id%lam(1), la, ierr))
  end subroutine reset_adjoint

  !> TSSetIJacobianP callback: A = dF/dtheta at U (see the module header).
  subroutine ident_ijacobianp(ts, t, uvec, udotvec, shift, amat, id, ierr)
    type(tTS) :: ts
    PetscReal :: t, shift
    type(tVec) :: uvec, udotvec
    type(tMat) :: amat
    type(ident_t) :: id
    PetscErrorCode :: ierr
    type(app_ctx), pointer :: app
    type(lattice_t) :: lp
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :), a(:, :)
    integer :: k, i, j, r, n, nbad, bad(2)
    real(rp) :: sgn, sx, sv

    app => id%app
    PetscCall(MatDenseGetArrayF90(amat, a, ierr))
    a = 0.0_rp
    if (id%mode == MODE_CONTROL) then
      ! F_x = xdot - vb on the driven nodes: dF_x/dd = -dvb/dd.
      if (app%cs%active) then
        do n = 1, app%cs%n
          if (app%cs%path(n) /= PATH_KEYFRAMES) cycle
          r = 6 * (app%cs%node(1, n) + app%lat%nx * (app%cs%node(2, n) - app%lat%ys))
          do k = 1, id%np
            call constraint_step_sensitivity(app%cs, t, id%km(k), sx, sv)
            a(r + id%kc(k), k) = -sv
          end do
        end do
      end if
      PetscCall(MatDenseRestoreArrayF90(amat, a, ierr))
      return
    end if
    PetscCall(DMGetLocalVector(app%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(app%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(app%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(app%da, uloc, u, ierr))
    do k = 1, id%np
      lp = app%lat
      sgn = -1.0_rp
      if (id%code(k) == 7) then
        sgn = 1.0_rp                 ! total_mass: F_v = vdot - f/m - g, m proportional to M
      else
        lp%e_s = 0; lp%e_d = 0; lp%eta_s = 0; lp%eta_d = 0; lp%k_b = 0; lp%eta_b = 0
        select case (id%code(k))
        case (1); lp%e_s = app%lat%e_s
        case (2); lp%e_d = app%lat%e_d
        case (3); lp%eta_s = app%lat%eta_s
        case (4); lp%eta_d = app%lat%eta_d
        case (5); lp%k_b = app%lat%k_b
        case (6); lp%eta_b = app%lat%eta_b
        end select
      end if
      call internal_forces(lp, u, app%model%f, nbad, bad)
      do j = app%lat%ys, app%lat%ye
        do i = 0, app%lat%nx - 1
          if (app%model%fixed(i, j)) cycle
          r = 6 * (i + app%lat%nx * (j - app%lat%ys))
          a(r + 4:r + 6, k) = sgn * app%model%f(:, i, j) / app%lat%mass(i, j)
        end do
      end do
    end do
    PetscCall(MatDenseRestoreArrayF90(amat, a, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(app%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(app%da, uloc, ierr))
  end subroutine ident_ijacobianp

  ! ------------------------------------------------------------ gradient check

  !> -identify_check_gradient (-control_check_gradient): the adjoint
  !> gradient at the initial guess against central differences of the
  !> objective (step fd_step; second order for identification, fourth
  !> order for control), one line per direction on rank 0, and the
  !> measured costs. Identification: each ln p. Control: each optimised
  !> component of each keyframe position m = 2..nk (moving keyframe m alone
  !> changes the steps into m and out of it: dJ/dkoff(c, m) = dJ/dd_m -
  !> dJ/dd_(m+1)).
  subroutine check_gradient(id, ierr, errmsg)
    type(ident_t), intent(inout) :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: f, fp, fm, f2p, f2m, g(id%np), dir(id%np), gd, fd, tf, wall0
    integer :: k, q
    character(len=32) :: label

    wall0 = MPI_Wtime()
    call forward(id, id%theta0, f, ierr)
    if (ierr /= 0) return
    tf = MPI_Wtime() - wall0
    wall0 = MPI_Wtime()
    call objective_gradient(id, id%theta0, f, g, ierr)
    if (ierr /= 0) return
    if (failed_run(id, errmsg, ierr)) return
    if (id%app%rank == 0) then
      write(output_unit, '(a,es24.16)') trim(id%tag)//': objective ', f
      write(output_unit, '(a,es12.4,a,es12.4,a,f7.3,2(a,es12.4),a,i0,a)') trim(id%tag)//': cost forward_s ', tf, &
        ' gradient_s ', MPI_Wtime() - wall0, ' ratio ', (MPI_Wtime() - wall0) / tf, &
        ' trajectory_memory_bytes ', id%traj_bytes, ' trajectory_file_bytes ', id%traj_disk_bytes, ' steps ', id%nsteps, ' (gradient = forward + adjoint)'
    end if
    do k = 1, id%np
      dir = 0.0_rp
      dir(k) = 1.0_rp
      if (id%mode == MODE_CONTROL) then
        do q = 1, id%np
          if (id%km(q) == id%km(k) + 1 .and. id%kc(q) == id%kc(k)) dir(q) = -1.0_rp
        end do
        write(label, '(a,i0,a)') 'keyframe_d'//XYZ(id%kc(k))//'(', id%km(k), ')'
      else
        label = fit_kind_names(id%code(k))
      end if
      gd = dot_product(g, dir)
      call forward(id, id%theta0 + id%fd_step * dir, fp, ierr)
      if (ierr /= 0) return
      call forward(id, id%theta0 - id%fd_step * dir, fm, ierr)
      if (ierr /= 0) return
      if (failed_run(id, errmsg, ierr)) return
      fd = (fp - fm) / (2.0_rp * id%fd_step)
      if (id%mode == MODE_CONTROL) then
        ! The fourth-order central difference: in-plane steps stretch
        ! links, and the second-order one's truncation error (measured
        ! 1e-4 relative at a step of 1e-5 lx, 1e-6 at 1e-6 lx, where
        ! round-off begins) would hide an error of the adjoint.
        call forward(id, id%theta0 + 2.0_rp * id%fd_step * dir, f2p, ierr)
        if (ierr /= 0) return
        call forward(id, id%theta0 - 2.0_rp * id%fd_step * dir, f2m, ierr)
        if (ierr /= 0) return
        if (failed_run(id, errmsg, ierr)) return
        fd = (8.0_rp * (fp - fm) - (f2p - f2m)) / (12.0_rp * id%fd_step)
      end if
      if (id%app%rank == 0) write(output_unit, '(a,a,a,es24.16,a,es24.16,a,es10.3)') trim(id%tag)//': gradient ', &
        trim(label), ' adjoint ', gd, ' fd ', fd, ' relerr ', abs(gd - fd) / max(abs(fd), tiny(1.0_rp))
    end do
    if (id%app%rank == 0) flush(output_unit)
  end subroutine check_gradient

  logical function failed_run(id, errmsg, ierr)
    type(ident_t), intent(in) :: id
    character(*), intent(out) :: errmsg
    PetscErrorCode, intent(out) :: ierr
    failed_run = id%failed
    ierr = 0
    errmsg = ''
    if (failed_run) then
      ierr = 1
      errmsg = trim(id%tag)//': a forward run failed (a time step did not converge) at the '// &
               merge('keyframes ', 'parameters', id%mode == MODE_CONTROL)//trim(values_text(id, id%theta))
    end if
  end function failed_run

  !> theta for messages: the fitted values, or the keyframe offsets.
  function values_text(id, theta) result(s)
    type(ident_t), intent(in) :: id
    real(rp), intent(in) :: theta(:)
    character(len=2048) :: s
    character(len=32) :: b
    real(rp) :: off(3, id%nk)
    integer :: k, m, c
    s = ''
    if (id%mode == MODE_CONTROL) then
      off = keyframes(id, theta)
      do m = 2, id%nk
        write(b, '(i0)') m
        s = trim(s)//' '//trim(b)//': ('
        do c = 1, 3
          write(b, '(es12.4e2)') off(c, m)
          s = trim(s)//trim(adjustl(b))//merge(', ', ') ', c < 3)
        end do
      end do
      return
    end if
    do k = 1, id%np
      write(b, '(es14.6e2)') exp(theta(k))
      s = trim(s)//' '//trim(fit_kind_names(id%code(k)))//' = '//trim(adjustl(b))
    end do
  end function values_text

  !> Control: the largest speed of a component on a segment [length/time].
  real(rp) function max_speed_of(id, theta)
    type(ident_t), intent(in) :: id
    real(rp), intent(in) :: theta(:)
    integer :: k
    max_speed_of = 0.0_rp
    do k = 1, id%np
      max_speed_of = max(max_speed_of, abs(theta(k)) / (id%kt(id%km(k)) - id%kt(id%km(k) - 1)))
    end do
  end function max_speed_of

  ! --------------------------------------------------------------------- TAO

  !> Minimise J over theta within the bounds: TAO bqnls by default (a
  !> bound-constrained quasi-Newton), any -tao_* option.
  subroutine fit(id, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    Tao :: tao
    type(tVec) :: x, xl, xu
    TaoConvergedReason :: reason
    PetscInt :: its
    PetscInt, parameter :: maxit = 200

    errmsg = ''
    PetscCall(VecDuplicate(id%mu(1), x, ierr))
    PetscCall(VecDuplicate(id%mu(1), xl, ierr))
    PetscCall(VecDuplicate(id%mu(1), xu, ierr))
    call put_rank0(id, x, id%theta0, ierr); if (ierr /= 0) return
    call put_rank0(id, xl, id%lo, ierr);    if (ierr /= 0) return
    call put_rank0(id, xu, id%hi, ierr);    if (ierr /= 0) return
    PetscCall(TaoCreate(id%app%comm, tao, ierr))
    PetscCall(TaoSetType(tao, 'bqnls', ierr))
    PetscCall(TaoSetSolution(tao, x, ierr))
    PetscCall(TaoSetVariableBounds(tao, xl, xu, ierr))
    PetscCall(TaoSetObjectiveAndGradient(tao, PETSC_NULL_VEC, tao_objgrad, id, ierr))
    PetscCall(TaoSetMonitor(tao, tao_monitor, id, PETSC_NULL_FUNCTION, ierr))
    PetscCall(TaoSetMaximumIterations(tao, maxit, ierr))
    ! Control also stops when |g| fell by 1e-8 from the start (the
    ! objective by some 1e-16, its round-off floor for a target reached):
    ! gatol alone would spend the last half of 200 iterations there.
    if (id%mode == MODE_CONTROL) then
      PetscCall(TaoSetTolerances(tao, 1.0e-10_rp, 0.0_rp, 1.0e-8_rp, ierr))
    else
      PetscCall(TaoSetTolerances(tao, 1.0e-10_rp, 0.0_rp, 0.0_rp, ierr))
    end if
    PetscCall(TaoSetFromOptions(tao, ierr))
    PetscCall(TaoSolve(tao, ierr))
    PetscCall(TaoGetConvergedReason(tao, reason, ierr))
    PetscCall(TaoGetIterationNumber(tao, its, ierr))
    call get_rank0(id, x, id%theta, ierr)
    if (ierr /= 0) return
    PetscCall(TaoDestroy(tao, ierr))
    PetscCall(VecDestroy(xu, ierr))
    PetscCall(VecDestroy(xl, ierr))
    PetscCall(VecDestroy(x, ierr))
    if (id%app%rank == 0) then
      write(output_unit, '(a,i0,a,i0,a)') trim(id%tag)//': TAO stopped after ', its, &
        ' iterations (TaoConvergedReason ', reason, ')'
      flush(output_unit)
    end if
    if (id%failed .or. reason < 0) then
      ! A diverged TAO still returns its best point; a failed forward run is an error.
      if (id%failed) then
        ierr = 1
        if (id%mode == MODE_CONTROL) then
          errmsg = 'control: a forward run failed during the optimisation; try a smaller &time dt, a lower '// &
                   '&control max_speed or a better initial guess (&scene keyframe_dx, keyframe_dy, keyframe_dz)'
        else
          errmsg = 'identify: a forward run failed during the fit; try a smaller &time dt, tighter bounds '// &
                   '(&identify fit_lower, fit_upper) or a better initial guess'
        end if
      else if (id%app%rank == 0) then
        write(output_unit, '(a)') trim(id%tag)//': warning: TAO did not converge (negative reason); the values '// &
          'below are its last iterate'
      end if
    end if
  end subroutine fit

  !> v into TAO's vector x, whose entries all lie on rank 0.
  subroutine put_rank0(id, x, v, ierr)
    type(ident_t), intent(in) :: id
    type(tVec) :: x
    real(rp), intent(in) :: v(:)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: xa(:)
    ierr = 0
    if (id%app%rank /= 0) return
    PetscCall(VecGetArrayF90(x, xa, ierr))
    xa = v
    PetscCall(VecRestoreArrayF90(x, xa, ierr))
  end subroutine put_rank0

  !> TAO's vector x (entries on rank 0) into v on every rank. Collective.
  subroutine get_rank0(id, x, v, ierr)
    type(ident_t), intent(in) :: id
    type(tVec) :: x
    real(rp), intent(out) :: v(:)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: xa(:)
    integer :: mpierr
    ierr = 0
    if (id%app%rank == 0) then
      PetscCall(VecGetArrayReadF90(x, xa, ierr))
      v = xa
      PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    end if
    call MPI_Bcast(v, size(v), MPI_DOUBLE_PRECISION, 0, id%app%comm, mpierr)
  end subroutine get_rank0

  !> TAO callback: objective and gradient at x = theta.
  subroutine tao_objgrad(tao, x, f, g, id, ierr)
    Tao :: tao
    type(tVec) :: x, g
    PetscReal :: f
    type(ident_t) :: id
    PetscErrorCode :: ierr
    real(rp) :: theta(id%np), gl(id%np)

    call get_rank0(id, x, theta, ierr)
    if (ierr /= 0) return
    call objective_gradient(id, theta, f, gl, ierr)
    if (ierr /= 0) return
    call put_rank0(id, g, gl, ierr)
  end subroutine tao_objgrad

  !> TAO monitor: the history, one row per iteration, and a line on rank 0.
  subroutine tao_monitor(tao, id, ierr)
    Tao :: tao
    type(ident_t) :: id
    PetscErrorCode :: ierr
    type(tVec) :: x
    PetscInt :: its
    PetscReal :: f, gnorm, cnorm, xdiff
    TaoConvergedReason :: reason
    real(rp) :: theta(id%np), row(0:id%nrow)
    real(rp), allocatable :: grown(:, :)

    PetscCall(TaoGetSolutionStatus(tao, its, f, gnorm, cnorm, xdiff, reason, ierr))
    PetscCall(TaoGetSolution(tao, x, ierr))
    call get_rank0(id, x, theta, ierr)
    if (ierr /= 0) return
    row(0) = f
    row(1:) = row_values(id, theta)
    allocate(grown(0:id%nrow, id%nhist + 1))     ! (an assignment would reset the lower bound to 1)
    grown(:, 1:id%nhist) = id%hist
    grown(:, id%nhist + 1) = row
    call move_alloc(grown, id%hist)
    id%nhist = id%nhist + 1
    if (id%app%rank == 0) then
      if (id%mode == MODE_CONTROL) then
        write(output_unit, '(a,i4,a,es14.6e2,a,es10.3e2,a,es10.3e2)') 'control: iteration ', its, '  objective ', f, &
          '  |g| ', gnorm, '  max speed ', max_speed_of(id, theta)
      else
        write(output_unit, '(a,i4,a,es14.6e2,a,es10.3e2,a)') 'identify: iteration ', its, '  objective ', f, &
          '  |g| ', gnorm, trim(values_text(id, theta))
      end if
      flush(output_unit)
    end if
  end subroutine tao_monitor

  ! ------------------------------------------------------------ uncertainty

  !> Gauss-Newton Hessian of J at the fit, H = 2 A^T W A (+ 2 tikhonov I),
  !> A = d(x - xobs)/d(ln p) by central differences of the trajectory
  !> (2 np forward runs); the residual variance s^2 = J_data / (n_obs - np)
  !> gives the covariance of ln p, 2 s^2 H^-1, and the 1-sigma uncertainty
  !> of each fitted value p sqrt(cov_kk) (first order in the noise).
  subroutine uncertainty(id, ierr, errmsg)
    type(ident_t), intent(inout) :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp), allocatable :: a(:, :, :, :, :), rp_(:, :, :, :)
    real(rp) :: hmat(id%np, id%np), cov(id%np, id%np), lp(id%np), f, fdata, s2
    integer :: k, l, kt, np, info, mpierr, ipiv(id%np)

    np = id%np
    errmsg = ''
    allocate(a(3, 0:id%app%lat%nx - 1, id%app%lat%ys:id%app%lat%ye, id%nt, np))
    do k = 1, np
      lp = id%theta
      lp(k) = lp(k) + FD_STEP
      call forward(id, lp, f, ierr)
      if (ierr /= 0) return
      rp_ = id%res
      lp(k) = id%theta(k) - FD_STEP
      call forward(id, lp, f, ierr)
      if (ierr /= 0) return
      if (failed_run(id, errmsg, ierr)) return
      a(:, :, :, :, k) = (rp_ - id%res) / (2.0_rp * FD_STEP)
    end do
    hmat = 0.0_rp
    do k = 1, np
      do l = 1, np
        do kt = 1, id%nt
          hmat(k, l) = hmat(k, l) + 2.0_rp * id%wt(kt) * &
            sum(spread(id%mask, 1, 3) * a(:, :, :, kt, k) * a(:, :, :, kt, l))
        end do
      end do
    end do
    call MPI_Allreduce(MPI_IN_PLACE, hmat, np**2, MPI_DOUBLE_PRECISION, MPI_SUM, id%app%comm, mpierr)
    do k = 1, np
      hmat(k, k) = hmat(k, k) + 2.0_rp * id%tikhonov
    end do
    ! The objective at the fit (and its residuals, for what is written).
    call forward(id, id%theta, f, ierr)
    if (ierr /= 0) return
    fdata = id%objective_data
    id%objective = f
    s2 = fdata / max(id%nobs - real(np, rp), 1.0_rp)
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
    if (failed_run(id, errmsg, ierr)) return
  end subroutine final_objective

  !> The result on rank 0 (fitted values with their uncertainty, or the
  !> optimised keyframes), and the cost of a gradient.
  subroutine report(id)
    type(ident_t), intent(in) :: id
    real(rp) :: off(3, id%nk)
    integer :: k, m
    if (id%app%rank /= 0) return
    write(output_unit, '(a,es24.16)') trim(id%tag)//': objective ', id%objective
    if (id%mode == MODE_CONTROL) then
      off = keyframes(id, id%theta)
      do m = 1, id%nk
        write(output_unit, '(a,i3,a,es14.6e2,a,3es16.8e2,a,3es12.4e2,a)') 'control: keyframe ', m, '  t ', id%kt(m), &
          '  offset ', off(:, m), '  (initial', id%koff0(:, m), ')'
      end do
      write(output_unit, '(a,es12.4e2)') 'control: max speed of a component on a segment ', max_speed_of(id, id%theta)
    else
      do k = 1, id%np
        write(output_unit, '(a,a12,a,es24.16,a,es12.4e2,a,es12.4e2)') 'identify: fitted ', &
          trim(fit_kind_names(id%code(k))), ' ', exp(id%theta(k)), ' +- ', id%unc(k), '  initial ', exp(id%theta0(k))
      end do
    end if
    if (id%n_forward > 0 .and. id%n_adjoint > 0) &
      write(output_unit, '(a,es10.3,a,es10.3,a,f6.2,2(a,es10.3),a)') trim(id%tag)//': cost: forward run ', &
        id%t_forward / id%n_forward, ' s, adjoint sweep ', id%t_adjoint / id%n_adjoint, &
        ' s, gradient/forward ', 1.0_rp + (id%t_adjoint / id%n_adjoint) / (id%t_forward / id%n_forward), &
        ', trajectory ', id%traj_bytes, ' bytes in memory, ', id%traj_disk_bytes, ' bytes in files'
    flush(output_unit)
  end subroutine report

  !> What /identify holds: names, fitted values, their uncertainty, the
  !> initial guess, the objective, the history (objective, values per TAO
  !> iteration).
  subroutine identify_result(id, names, values, unc, initial, objective, hist)
    type(ident_t), intent(in) :: id
    character(len=16), allocatable, intent(out) :: names(:)
    real(rp), allocatable, intent(out) :: values(:), unc(:), initial(:), hist(:, :)
    real(rp), intent(out) :: objective
    integer :: k
    allocate(names(id%np))
    do k = 1, id%np
      names(k) = fit_kind_names(id%code(k))
    end do
    values = exp(id%theta)
    unc = id%unc
    initial = exp(id%theta0)
    objective = id%objective
    hist = id%hist
  end subroutine identify_result

  !> What /control holds: the keyframe times [nk], the optimised and the
  !> initial keyframe offsets (3, nk), the objective at the optimum, and per
  !> TAO iteration the objective [nit] and the keyframe offsets (3, nk, nit).
  subroutine control_result(id, times, offsets, initial, objective, objective_hist, offset_hist)
    type(ident_t), intent(in) :: id
    real(rp), allocatable, intent(out) :: times(:), offsets(:, :), initial(:, :), objective_hist(:), &
                                          offset_hist(:, :, :)
    real(rp), intent(out) :: objective
    times = id%kt
    offsets = keyframes(id, id%theta)
    initial = id%koff0
    objective = id%objective
    objective_hist = id%hist(0, :)
    offset_hist = reshape(id%hist(1:, :), [3, id%nk, id%nhist])
  end subroutine control_result

end module identify
