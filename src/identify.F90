!> Identification (docs/identification.md): fit model parameters to an
!> observed motion. The objective is
!>   J(p) = sum_k w_k sum_nodes mask_n |x_n(t_k; p) - xobs_n,k|^2
!>          + tikhonov sum_i (ln p_i - ln p_i,initial)^2,
!> minimised over ln p within bounds by PETSc TAO (bqnls by default), with
!> the exact gradient of the discrete trajectory from TSAdjoint.
!>
!> The time loop: one window per interval between consecutive observed
!> times, keyframe and release times (enter_window of module timestepping
!> fixes the constraints of each, as in solver_run). The adjoint runs the
!> windows backward, one TSAdjointSolve of exactly that window's steps each
!> (TSAdjointSetSteps), after adding dJ_k/dx(t_k) to lambda at the window's
!> end: the discrete sum of the objective enters at the observed times
!> themselves, and every window's Jacobians see the constraint state of that
!> window. What enter_window does to the state at a window's start (put
!> constrained nodes on their path) needs no adjoint: the constrained rows
!> of F do not depend on free nodes or on p, so the adjoint of the free
!> nodes never sees lambda of constrained ones, and the initial state does
!> not depend on p.
!>
!> dF/dp (TSSetIJacobianP, through src/nuno_adjoint.c): every force is
!> linear in each of e_s, e_d, eta_s, eta_d, k_b, eta_b, so dF_v/d(ln p) =
!> -f_p/m with f_p the force of the elements computed with only p non-zero
!> (the kernels of module forces on a lattice copy); for total_mass (every
!> node mass is proportional to it) dF_v/d(ln M) = +f/m. Constrained rows
!> and the x-rows do not depend on p.
!>
!> The adjoint needs the transpose of the Newton matrix: the identification
!> runs with the assembled 6-dof Jacobian (-nuno_jacobian full), whose KSP
!> (GMRES + ILU by default) does KSPSolveTranspose; the reduced path's
!> PCSHELL has no transpose apply.
module identify
#include "petsc/finclude/petscts.h"
#include "petsc/finclude/petsctao.h"
  use petscts
  use petsctao
  use petscdmda
  use mpi
  use hdf5
  use, intrinsic :: iso_fortran_env, only: output_unit
  use, intrinsic :: iso_c_binding, only: c_null_char
  use kinds, only: rp
  use config, only: nuno_config, n_fit_kinds, fit_kind_names
  use lattice, only: lattice_t, lattice_init
  use forces, only: internal_forces
  use scenes, only: scene_setup
  use constraints, only: constraint_events
  use timestepping, only: app_ctx, enter_window
  implicit none
  private
  public :: ident_t, identify_prepare_options, identify_run, identify_result

  !> Step of the central differences in ln p: the Gauss-Newton Hessian
  !> (uncertainty) and -identify_check_gradient.
  real(rp), parameter :: FD_STEP = 1.0e-4_rp

  !> Everything the TAO and TS callbacks of an identification need.
  type :: ident_t
    type(app_ctx), pointer :: app => null()
    integer :: np = 0                             !< fitted parameters
    integer :: code(n_fit_kinds) = 0              !< their codes (config: fit_kind_names)
    real(rp) :: logp0(n_fit_kinds) = 0            !< ln of the initial guess
    real(rp) :: lo(n_fit_kinds) = 0, hi(n_fit_kinds) = 0   !< ln of the bounds
    real(rp) :: logp(n_fit_kinds) = 0             !< current ln p
    real(rp) :: tikhonov = 0
    ! observation (owned rows only)
    integer :: nt = 0                             !< observed times used (t > 0)
    real(rp), allocatable :: tobs(:), wt(:)       !< (nt) times [time], weights [1]
    real(rp), allocatable :: xobs(:, :, :, :)     !< (3, 0:nx-1, ys:ye, nt) observed positions [length]
    real(rp), allocatable :: mask(:, :)           !< (0:nx-1, ys:ye) node weights (markers) [1]
    real(rp), allocatable :: res(:, :, :, :)      !< x - xobs of the last forward run, as xobs
    real(rp) :: nobs = 0                          !< scalar observations with weight > 0 (all ranks)
    ! time windows: [wa, wb], observation index at wb (0: none), TS step at wb
    integer :: nw = 0
    real(rp), allocatable :: wa(:), wb(:)
    integer, allocatable :: wobs(:)
    PetscInt, allocatable :: wsteps(:)
    ! PETSc objects of the adjoint
    type(tMat) :: jacp                            !< dF/d(ln p), dense, np columns on rank 0
    type(tVec) :: lam(1), mu(1)                   !< cost gradients w.r.t. the state and ln p
    ! results
    real(rp) :: objective = 0, objective_data = 0
    real(rp) :: unc(n_fit_kinds) = 0              !< 1-sigma uncertainty of the fitted values [their units]
    integer :: nhist = 0
    real(rp), allocatable :: hist(:, :)           !< (0:np, nhist): objective, fitted values per TAO iteration
    ! cost measurements
    integer :: n_forward = 0, n_adjoint = 0
    real(rp) :: t_forward = 0, t_adjoint = 0      !< wall-clock seconds of all forward / adjoint sweeps
    real(rp) :: traj_bytes = 0                    !< PETSc memory held by the trajectory of one forward run (max over ranks)
    real(rp) :: traj_disk_bytes = 0               !< size of the basic trajectory's files of one forward run (all ranks)
    integer :: nsteps = 0                         !< steps of one forward run
    logical :: failed = .false.                   !< a forward run failed (a step did not converge)
    character(len=512) :: fail_msg = ''           !< why, when not a failed step
    character(len=600) :: traj_dir = ''           !< directory of the basic trajectory's files
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

  !> The identification: read the observation, fit with TAO, estimate the
  !> uncertainty; on return ctx holds the fitted parameters and the initial
  !> state, ready for solver_run to write the fitted motion. ierr = 1 with
  !> errmsg: a collective error (bad observation, failed forward run); ierr
  !> > 1: a PETSc error. done: nothing more to do (-identify_check_gradient).
  subroutine identify_run(id, ctx, done, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    type(app_ctx), intent(inout), target :: ctx
    logical, intent(out) :: done
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    PetscBool :: check
    PetscErrorCode :: e

    done = .false.
    errmsg = ''
    id%app => ctx
    call setup(id, ierr, errmsg)
    if (ierr /= 0) return
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-identify_check_gradient', check, e))
    if (check) then
      call check_gradient(id, ierr, errmsg)
      done = .true.
    else
      call fit(id, ierr, errmsg)
      if (ierr == 0) call uncertainty(id, ierr, errmsg)
      if (ierr == 0) call report(id)
    end if
    if (ierr == 1 .and. len_trim(id%fail_msg) > 0) errmsg = id%fail_msg
    if (ierr /= 0) return
    ! The fitted motion, from t = 0, for solver_run.
    call reset_state(id, id%logp, ierr)
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
    id%np = app%cfg%n_fit
    id%code(1:id%np) = app%cfg%fit_code(1:id%np)
    do k = 1, id%np
      id%logp0(k) = log(param_value(app%cfg, id%code(k)))
      id%lo(k) = log(app%cfg%fit_lower(k))
      id%hi(k) = log(app%cfg%fit_upper(k))
    end do
    id%logp = id%logp0
    id%tikhonov = app%cfg%tikhonov
    id%traj_dir = trim(app%cfg%output_file)//'.adjoint'

    call read_observation(id, trim(app%cfg%observed_file), ierr, errmsg)
    if (ierr /= 0) return

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
    allocate(id%hist(0:id%np, 0))

    ! dF/d(ln p): dense, the state's rows, np columns kept on rank 0 (the
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
      write(output_unit, '(a,i0,a,i0,a,i0,a)') 'identify  : ', id%np, ' parameter(s), ', id%nt, &
        ' observed times, ', id%nw, ' time windows; '//trim(app%cfg%observed_file)
      flush(output_unit)
    end if
  end subroutine setup

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
  !> /weight [nt] (per time). Times <= 0 are left out (the initial state
  !> does not depend on the parameters). Every rank reads its own rows; the
  !> checks are the same on every rank and the error flag is agreed.
  subroutine read_observation(id, path, ierr, errmsg)
    type(ident_t), intent(inout) :: id
    character(*), intent(in) :: path
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: file, dset, space, mspace
    integer(hsize_t) :: dims(4), maxdims(4), start(4), cnt(4)
    integer :: h, ndims, nx, ny, ys, nyl, ntall, k, n, e, mpierr
    real(rp), allocatable :: tall(:), wall(:), pall(:, :, :, :), m2(:, :)
    logical :: exists, have_mask, have_weight
    character(len=:), allocatable :: where

    nx = id%app%lat%nx
    ny = id%app%lat%ny
    ys = id%app%lat%ys
    nyl = id%app%lat%ye - ys + 1
    where = "&identify: observed_file '"//path//"'"
    e = 0
    errmsg = ''
    file = -1
    call h5open_f(h)
    inquire(file=path, exist=exists)
    if (.not. exists) then
      e = 1
      errmsg = 'input: '//where//': no such file'
    end if
    if (e == 0) then
      call h5eset_auto_f(0, h)
      call h5fopen_f(path, H5F_ACC_RDONLY_F, file, h)
      call h5eset_auto_f(1, h)
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
    ! /position, this rank's rows
    if (e == 0) call open_dset('/position', 4, .true.)
    if (e == 0) then
      if (dims(1) /= 3 .or. dims(2) /= nx .or. dims(3) /= ny .or. dims(4) /= ntall) then
        write(errmsg, '(a,4(i0,a),3(i0,a))') 'input: '//where//': /position is [', dims(4), '][', dims(3), '][', &
          dims(2), '][', dims(1), '] but the run needs [nt][ny][nx][3] = [', ntall, '][', ny, '][', nx, &
          '][3] (nt from /time, the lattice from &lattice)'
        e = 1
      end if
    end if
    if (e == 0) then
      allocate(pall(3, 0:nx - 1, ys:ys + nyl - 1, ntall))
      start = [0_hsize_t, 0_hsize_t, int(ys, hsize_t), 0_hsize_t]
      cnt = [3_hsize_t, int(nx, hsize_t), int(nyl, hsize_t), int(ntall, hsize_t)]
      call h5dget_space_f(dset, space, h)
      call h5sselect_hyperslab_f(space, H5S_SELECT_SET_F, start, cnt, h)
      call h5screate_simple_f(4, cnt, mspace, h)
      call h5dread_f(dset, H5T_NATIVE_DOUBLE, pall, cnt, h, mspace, space)
      if (h < 0) call bad('cannot read /position')
      call h5sclose_f(mspace, h)
      call h5sclose_f(space, h)
      call h5dclose_f(dset, h)
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
      else if (any(pall /= pall)) then
        e = 1
        errmsg = 'input: '//where//': /position holds NaN'
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
    n = 0
    do k = 1, ntall
      if (tall(k) <= 0.0_rp) cycle
      n = n + 1
      id%tobs(n) = tall(k)
      id%wt(n) = wall(k)
      id%xobs(:, :, :, n) = pall(:, :, :, k)
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

  !> Parameters exp(logp) into the configuration and the lattice (masses,
  !> constants), the scene's initial state into the state vector, the TS
  !> back at t = 0 with a fresh trajectory. Collective.
  subroutine reset_state(id, logp, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: logp(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: ua(:, :, :)
    integer :: k, ys, ye
    PetscInt, parameter :: zero = 0
    PetscReal :: horizon
    PetscInt :: nw

    app => id%app
    do k = 1, id%np
      call set_param(app%cfg, id%code(k), exp(logp(k)))
    end do
    app%cfg%has_damping = app%cfg%eta_s > 0.0_rp .or. app%cfg%eta_d > 0.0_rp
    ys = app%lat%ys
    ye = app%lat%ye
    call lattice_init(app%lat, app%cfg, ys, ye)
    PetscCall(DMDAVecGetArrayF90(app%da, app%u, ua, ierr))
    call scene_setup(app%cfg, app%lat, ua, app%cs)
    PetscCall(DMDAVecRestoreArrayF90(app%da, app%u, ua, ierr))
    PetscCall(TSSetTime(app%ts, 0.0_rp, ierr))
    PetscCall(TSSetStepNumber(app%ts, zero, ierr))
    ! Room for the whole run: its steps, one more per window, retries.
    horizon = 2.0_rp * (id%wb(id%nw) + real(id%nw + 1, rp) * app%dt)
    nw = id%nw
    call nuno_ts_trajectory_fresh(app%ts, horizon, app%dt, nw, trim(id%traj_dir)//c_null_char, ierr)
    if (ierr == -1) then
      ierr = 1
      id%failed = .true.
      id%fail_msg = '-ts_trajectory_type memory: PETSc 3.18 cannot checkpoint in memory across the '// &
        'identification''s time windows (observed, keyframe and release times); use basic (the default)'
      return
    end if
    if (ierr /= 0) return
    app%dissipated = 0
    app%work_constraints = 0
    app%t_prev = 0
    app%pdiss_prev = 0
    app%pcon_prev = 0
    app%t_written = -1
  end subroutine reset_state

  ! ------------------------------------------------------ forward, adjoint

  !> One forward run at ln p = logp over all windows, saving the trajectory;
  !> the objective f and the residuals x - xobs at the observed times.
  !> A failed step sets id%failed (f = huge). Collective.
  subroutine forward(id, logp, f, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: logp(:)
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
    call reset_state(id, logp, ierr)
    if (ierr /= 0) return
    PetscCall(PetscMallocGetCurrentUsage(mem0, ierr))
    id%failed = .false.
    floc = 0.0_rp
    t = 0.0_rp
    eps = 1.0e-12_rp * max(1.0_rp, id%wb(id%nw))
    do w = 1, id%nw
      call enter_window(app, id%wa(w), id%wb(w), dke, ierr)
      if (ierr /= 0) return
      app%tstop = id%wb(w)
      PetscCall(TSRestartStep(app%ts, ierr))
      ! The memory trajectory stores a window's first state only if the TS
      ! is not marked converged (from the previous window) when TSSolve
      ! saves it; otherwise the adjoint of the previous window pops the
      ! wrong checkpoint.
      PetscCall(TSSetConvergedReason(app%ts, TS_CONVERGED_ITERATING, ierr))
      PetscCall(TSSetMaxTime(app%ts, id%wb(w), ierr))
      h = app%dt
      if (t + 1.01_rp * h >= id%wb(w)) h = id%wb(w) - t
      PetscCall(TSSetTimeStep(app%ts, h, ierr))
      PetscCall(TSSolve(app%ts, app%u, ierr))
      PetscCall(TSGetConvergedReason(app%ts, reason, ierr))
      PetscCall(TSGetTime(app%ts, t, ierr))
      if (reason < 0 .or. abs(t - id%wb(w)) > 1.0e3_rp * eps) then
        id%failed = .true.
        if (app%rank == 0) write(output_unit, '(a,i0,a,es14.6,a,es14.6)') 'identify: forward run stopped (TSConvergedReason ', &
          reason, ') at t = ', t, ' in the window ending at ', id%wb(w)
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
    f = f + id%tikhonov * sum((logp(1:id%np) - id%logp0(1:id%np))**2)
    if (id%failed) f = huge(1.0_rp)
    id%nsteps = int(id%wsteps(id%nw))
    id%n_forward = id%n_forward + 1
    id%t_forward = id%t_forward + (MPI_Wtime() - wall0)
  end subroutine forward

  !> Objective and its exact gradient with respect to ln p (one forward
  !> run, then the adjoint backward over the windows). Collective.
  subroutine objective_gradient(id, logp, f, g, ierr)
    type(ident_t), intent(inout) :: id
    real(rp), intent(in) :: logp(:)
    real(rp), intent(out) :: f, g(:)
    PetscErrorCode, intent(out) :: ierr
    type(app_ctx), pointer :: app
    PetscScalar, pointer :: la(:, :, :), ma(:)
    PetscInt :: nsteps
    real(rp) :: dke, wall0
    integer :: w, k, j, i, mpierr
    PetscInt, parameter :: one = 1

    app => id%app
    call forward(id, logp, f, ierr)
    if (ierr /= 0) return
    g = 0.0_rp
    if (id%failed) return
    wall0 = MPI_Wtime()
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
    end do
    if (app%rank == 0) then
      PetscCall(VecGetArrayReadF90(id%mu(1), ma, ierr))
      g(1:id%np) = ma(1:id%np)
      PetscCall(VecRestoreArrayReadF90(id%mu(1), ma, ierr))
    end if
    call MPI_Bcast(g, id%np, MPI_DOUBLE_PRECISION, 0, app%comm, mpierr)
    g(1:id%np) = g(1:id%np) + 2.0_rp * id%tikhonov * (logp(1:id%np) - id%logp0(1:id%np))
    id%n_adjoint = id%n_adjoint + 1
    id%t_adjoint = id%t_adjoint + (MPI_Wtime() - wall0)
  end subroutine objective_gradient

  !> TSSetIJacobianP callback: A = dF/d(ln p) at U (see the module header).
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
    integer :: k, i, j, r, nbad, bad(2)
    real(rp) :: sgn

    app => id%app
    PetscCall(DMGetLocalVector(app%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(app%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(app%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(app%da, uloc, u, ierr))
    PetscCall(MatDenseGetArrayF90(amat, a, ierr))
    a = 0.0_rp
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
      call internal_forces(lp, u, app%f, nbad, bad)
      do j = app%lat%ys, app%lat%ye
        do i = 0, app%lat%nx - 1
          if (app%fixed(i, j)) cycle
          r = 6 * (i + app%lat%nx * (j - app%lat%ys))
          a(r + 4:r + 6, k) = sgn * app%f(:, i, j) / app%lat%mass(i, j)
        end do
      end do
    end do
    PetscCall(MatDenseRestoreArrayF90(amat, a, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(app%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(app%da, uloc, ierr))
  end subroutine ident_ijacobianp

  ! ------------------------------------------------------------ gradient check

  !> -identify_check_gradient: the adjoint gradient at the initial guess
  !> against central differences of the objective (step FD_STEP in ln p),
  !> one line per parameter on rank 0, and the measured costs.
  subroutine check_gradient(id, ierr, errmsg)
    type(ident_t), intent(inout) :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: f, fp, fm, g(n_fit_kinds), lp(n_fit_kinds), fd, tf, wall0
    integer :: k

    wall0 = MPI_Wtime()
    call forward(id, id%logp0, f, ierr)
    if (ierr /= 0) return
    tf = MPI_Wtime() - wall0
    wall0 = MPI_Wtime()
    call objective_gradient(id, id%logp0, f, g, ierr)
    if (ierr /= 0) return
    if (failed_run(id, errmsg, ierr)) return
    if (id%app%rank == 0) then
      write(output_unit, '(a,es24.16)') 'identify: objective ', f
      write(output_unit, '(a,es12.4,a,es12.4,a,f7.3,2(a,es12.4),a,i0,a)') 'identify: cost forward_s ', tf, &
        ' gradient_s ', MPI_Wtime() - wall0, ' ratio ', (MPI_Wtime() - wall0) / tf, &
        ' trajectory_memory_bytes ', id%traj_bytes, ' trajectory_file_bytes ', id%traj_disk_bytes, ' steps ', id%nsteps, ' (gradient = forward + adjoint)'
    end if
    do k = 1, id%np
      lp = id%logp0
      lp(k) = lp(k) + FD_STEP
      call forward(id, lp, fp, ierr)
      if (ierr /= 0) return
      lp(k) = id%logp0(k) - FD_STEP
      call forward(id, lp, fm, ierr)
      if (ierr /= 0) return
      if (failed_run(id, errmsg, ierr)) return
      fd = (fp - fm) / (2.0_rp * FD_STEP)
      if (id%app%rank == 0) write(output_unit, '(a,a,a,es24.16,a,es24.16,a,es10.3)') 'identify: gradient ', &
        trim(fit_kind_names(id%code(k))), ' adjoint ', g(k), ' fd ', fd, ' relerr ', &
        abs(g(k) - fd) / max(abs(fd), tiny(1.0_rp))
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
      errmsg = 'identify: a forward run failed (a time step did not converge) at the parameters '// &
               trim(values_text(id, id%logp))
    end if
  end function failed_run

  function values_text(id, logp) result(s)
    type(ident_t), intent(in) :: id
    real(rp), intent(in) :: logp(:)
    character(len=512) :: s
    character(len=32) :: b
    integer :: k
    s = ''
    do k = 1, id%np
      write(b, '(es14.6e2)') exp(logp(k))
      s = trim(s)//' '//trim(fit_kind_names(id%code(k)))//' = '//trim(adjustl(b))
    end do
  end function values_text

  ! --------------------------------------------------------------------- TAO

  !> Minimise J over ln p within the bounds: TAO bqnls by default (a
  !> bound-constrained quasi-Newton), any -tao_* option.
  subroutine fit(id, ierr, errmsg)
    type(ident_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    Tao :: tao
    type(tVec) :: x, xl, xu
    PetscScalar, pointer :: xa(:)
    TaoConvergedReason :: reason
    PetscInt :: its
    integer :: mpierr
    PetscInt, parameter :: maxit = 200

    errmsg = ''
    PetscCall(VecDuplicate(id%mu(1), x, ierr))
    PetscCall(VecDuplicate(id%mu(1), xl, ierr))
    PetscCall(VecDuplicate(id%mu(1), xu, ierr))
    if (id%app%rank == 0) then
      PetscCall(VecGetArrayF90(x, xa, ierr))
      xa = id%logp0(1:id%np)
      PetscCall(VecRestoreArrayF90(x, xa, ierr))
      PetscCall(VecGetArrayF90(xl, xa, ierr))
      xa = id%lo(1:id%np)
      PetscCall(VecRestoreArrayF90(xl, xa, ierr))
      PetscCall(VecGetArrayF90(xu, xa, ierr))
      xa = id%hi(1:id%np)
      PetscCall(VecRestoreArrayF90(xu, xa, ierr))
    end if
    PetscCall(TaoCreate(id%app%comm, tao, ierr))
    PetscCall(TaoSetType(tao, 'bqnls', ierr))
    PetscCall(TaoSetSolution(tao, x, ierr))
    PetscCall(TaoSetVariableBounds(tao, xl, xu, ierr))
    PetscCall(TaoSetObjectiveAndGradient(tao, PETSC_NULL_VEC, tao_objgrad, id, ierr))
    PetscCall(TaoSetMonitor(tao, tao_monitor, id, PETSC_NULL_FUNCTION, ierr))
    PetscCall(TaoSetMaximumIterations(tao, maxit, ierr))
    PetscCall(TaoSetTolerances(tao, 1.0e-10_rp, 0.0_rp, 0.0_rp, ierr))
    PetscCall(TaoSetFromOptions(tao, ierr))
    PetscCall(TaoSolve(tao, ierr))
    PetscCall(TaoGetConvergedReason(tao, reason, ierr))
    PetscCall(TaoGetIterationNumber(tao, its, ierr))
    if (id%app%rank == 0) then
      PetscCall(VecGetArrayReadF90(x, xa, ierr))
      id%logp(1:id%np) = xa
      PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    end if
    call MPI_Bcast(id%logp, id%np, MPI_DOUBLE_PRECISION, 0, id%app%comm, mpierr)
    PetscCall(TaoDestroy(tao, ierr))
    PetscCall(VecDestroy(xu, ierr))
    PetscCall(VecDestroy(xl, ierr))
    PetscCall(VecDestroy(x, ierr))
    if (id%app%rank == 0) then
      write(output_unit, '(a,i0,a,i0,a)') 'identify: TAO stopped after ', its, ' iterations (TaoConvergedReason ', &
        reason, ')'
      flush(output_unit)
    end if
    if (id%failed .or. reason < 0) then
      ! A diverged TAO still returns its best point; a failed forward run is an error.
      if (id%failed) then
        ierr = 1
        errmsg = 'identify: a forward run failed during the fit; try a smaller &time dt, tighter bounds '// &
                 '(&identify fit_lower, fit_upper) or a better initial guess'
      else if (id%app%rank == 0) then
        write(output_unit, '(a)') 'identify: warning: TAO did not converge (negative reason); the values '// &
          'below are its last iterate'
      end if
    end if
  end subroutine fit

  !> TAO callback: objective and gradient at x = ln p.
  subroutine tao_objgrad(tao, x, f, g, id, ierr)
    Tao :: tao
    type(tVec) :: x, g
    PetscReal :: f
    type(ident_t) :: id
    PetscErrorCode :: ierr
    PetscScalar, pointer :: xa(:), ga(:)
    real(rp) :: lp(n_fit_kinds), gl(n_fit_kinds)
    integer :: mpierr

    lp = id%logp0
    if (id%app%rank == 0) then
      PetscCall(VecGetArrayReadF90(x, xa, ierr))
      lp(1:id%np) = xa
      PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    end if
    call MPI_Bcast(lp, id%np, MPI_DOUBLE_PRECISION, 0, id%app%comm, mpierr)
    call objective_gradient(id, lp, f, gl, ierr)
    if (ierr /= 0) return
    if (id%app%rank == 0) then
      PetscCall(VecGetArrayF90(g, ga, ierr))
      ga = gl(1:id%np)
      PetscCall(VecRestoreArrayF90(g, ga, ierr))
    end if
  end subroutine tao_objgrad

  !> TAO monitor: the history, one row per iteration, and a line on rank 0.
  subroutine tao_monitor(tao, id, ierr)
    Tao :: tao
    type(ident_t) :: id
    PetscErrorCode :: ierr
    type(tVec) :: x
    PetscScalar, pointer :: xa(:)
    PetscInt :: its
    PetscReal :: f, gnorm, cnorm, xdiff
    TaoConvergedReason :: reason
    real(rp) :: lp(n_fit_kinds), row(0:n_fit_kinds)
    integer :: mpierr

    PetscCall(TaoGetSolutionStatus(tao, its, f, gnorm, cnorm, xdiff, reason, ierr))
    PetscCall(TaoGetSolution(tao, x, ierr))
    lp = id%logp0
    if (id%app%rank == 0) then
      PetscCall(VecGetArrayReadF90(x, xa, ierr))
      lp(1:id%np) = xa
      PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    end if
    call MPI_Bcast(lp, id%np, MPI_DOUBLE_PRECISION, 0, id%app%comm, mpierr)
    row(0) = f
    row(1:id%np) = exp(lp(1:id%np))
    id%hist = reshape([reshape(id%hist, [size(id%hist)]), row(0:id%np)], [id%np + 1, id%nhist + 1])
    id%nhist = id%nhist + 1
    if (id%app%rank == 0) then
      write(output_unit, '(a,i4,a,es14.6e2,a,es10.3e2,a)') 'identify: iteration ', its, '  objective ', f, &
        '  |g| ', gnorm, ' '//trim(values_text(id, lp))
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
    real(rp) :: hmat(n_fit_kinds, n_fit_kinds), cov(n_fit_kinds, n_fit_kinds), lp(n_fit_kinds), f, fdata, s2
    integer :: k, l, kt, np, info, mpierr, ipiv(n_fit_kinds)

    np = id%np
    errmsg = ''
    allocate(a(3, 0:id%app%lat%nx - 1, id%app%lat%ys:id%app%lat%ye, id%nt, np))
    do k = 1, np
      lp = id%logp
      lp(k) = lp(k) + FD_STEP
      call forward(id, lp, f, ierr)
      if (ierr /= 0) return
      rp_ = id%res
      lp(k) = id%logp(k) - FD_STEP
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
    call MPI_Allreduce(MPI_IN_PLACE, hmat, n_fit_kinds**2, MPI_DOUBLE_PRECISION, MPI_SUM, id%app%comm, mpierr)
    do k = 1, np
      hmat(k, k) = hmat(k, k) + 2.0_rp * id%tikhonov
    end do
    ! The objective at the fit (and its residuals, for what is written).
    call forward(id, id%logp, f, ierr)
    if (ierr /= 0) return
    fdata = id%objective_data
    id%objective = f
    s2 = fdata / max(id%nobs - real(np, rp), 1.0_rp)
    cov = 0.0_rp
    do k = 1, np
      cov(k, k) = 1.0_rp
    end do
    call dgesv(np, np, hmat, n_fit_kinds, ipiv, cov, n_fit_kinds, info)
    id%unc = 0.0_rp
    if (info == 0) then
      do k = 1, np
        id%unc(k) = exp(id%logp(k)) * sqrt(max(2.0_rp * s2 * cov(k, k), 0.0_rp))
      end do
    else
      id%unc(1:np) = huge(1.0_rp)   ! singular: a parameter the observation does not determine
    end if
  end subroutine uncertainty

  !> The fitted values on rank 0, and the cost of a gradient.
  subroutine report(id)
    type(ident_t), intent(in) :: id
    integer :: k
    if (id%app%rank /= 0) return
    write(output_unit, '(a,es24.16)') 'identify: objective ', id%objective
    do k = 1, id%np
      write(output_unit, '(a,a12,a,es24.16,a,es12.4e2,a,es12.4e2)') 'identify: fitted ', &
        trim(fit_kind_names(id%code(k))), ' ', exp(id%logp(k)), ' +- ', id%unc(k), '  initial ', exp(id%logp0(k))
    end do
    if (id%n_forward > 0 .and. id%n_adjoint > 0) &
      write(output_unit, '(a,es10.3,a,es10.3,a,f6.2,2(a,es10.3),a)') 'identify: cost: forward run ', &
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
    values = exp(id%logp(1:id%np))
    unc = id%unc(1:id%np)
    initial = exp(id%logp0(1:id%np))
    objective = id%objective
    hist = id%hist
  end subroutine identify_result

end module identify
