! SPDX-License-Identifier: BSD-2-Clause
!> Solver set-up: the DMDA, TS, SNES and their options as resolved from
!> the namelist and the PETSc options (solver_create), and their
!> destruction (solver_destroy).
module solver_setup
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_null_char
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use config, only: nuno_config, SPRING_LINEAR, BEND_NONE, BEND_ENERGY
  use lattice, only: lattice_init, halo_width
  use scenes, only: scene_setup
  use solver_choices, only: JACOBIAN_NAMES, JACOBIAN_REDUCED, INTERP_AUTO, INTERP_NAMES, GUESS_AUTO, GUESS_NONE, &
                            GUESS_EXTRAPOLATE, GUESS_PROJECT, GUESS_NAMES, FALLBACK_BT, FALLBACK_NAMES
  use reduced, only: reduced_create, reduced_set_pairs, reduced_destroy, reduced_attach, reduced_set_guess, reduced_describe, &
                     reduced_jacobian, reduced_forward_ew, reduced_inner_ksp
  use app_context, only: app_ctx, nuno_signals_install
  use solver_options, only: nuno_options_read, nuno_linesearch_options_read, nuno_tolerance_options_read, &
                            nuno_options_report_unused, adaptive_default, step_defaults, ts_scheme, petsc_habits
  use newton_start, only: newton_start_free, newton_start_order, newton_start_is_consistent
  use strings, only: itoa, real_g0, num => real_brief, inum => itoa
  use cloth_model, only: form_ifunction, form_ijacobian
  use model_state, only: model_state_init, model_state_free, assembly_create, assembly_free, assembly_matrix
  use newton_policy, only: set_newton_start, snes_converged
  use pc_reuse, only: PC_GROWTH_DEFAULT
  use newton_state, only: SNES_FLOOR_DEFAULT, newton_state_init, newton_set_inner_guess, newton_guess, newton_guess_given, &
                          newton_forcing_on
  use process_solver, only: pm_solver_options, pm_solver_setup
  use process_model, only: process_model_t, pm_hints_t
  use process_models, only: pm_list_t, pm_list_add, pm_list_hints, pm_list_on, pm_list_setup, pm_list_nodal, &
                            pm_list_destroy, pm_list_take, pm_list_ts_refusal
  use contact_model, only: contact_model_t
  use face_contact, only: face_contact_t
  use self_contact, only: self_contact_model_t
  use ghosted_state, only: ghosted_get, ghosted_restore
  use step_monitor, only: ts_monitor
  use step_settings, only: step_settings_init, step_set_tolerances, step_dt, step_t_end, step_fixed, step_max_steps, &
                           step_tolerances, step_adaptive_default
  use energy_integrals, only: energy_integrals_init, energy_integrals_free
  use step_errors, only: step_errors_init, step_errors_free, step_errors_set_min_step
  implicit none
  private
  public :: check_decomposition, solver_create, solver_destroy

  !> The default velocity tolerance is the position tolerance over this
  !> [time]: one time unit (1 s in every scene), a constant, so that the
  !> tolerances, and so the steps, do not depend on t_end (a run to 2 s
  !> takes the steps of a run to 1 s over its first second, and a restart
  !> to a later t_end keeps them; docs/workprecision.md, "Tolerances").
  real(rp), parameter :: TOLERANCE_TIME = 1.0_rp

  !> nuno's own options of the Newton step as read (resolve_options), for
  !> the set-up that follows.
  type :: nuno_options_t
    integer(c_int) :: pc_lag = 0                !< -nuno_pc_lag (0: the default)
    real(c_double) :: pc_growth = 0.0_c_double  !< -nuno_pc_rebuild_growth (0: off)
    integer(c_int) :: mg_interp = 0             !< -nuno_mg_interpolation's code (module reduced)
    integer(c_int) :: gn = 0, cl = 0            !< -nuno_gauss_newton, -nuno_clamp (1: on)
    character(len=64) :: mattype = ''           !< the 6-dof matrix type (-dm_mat_type)
  end type nuno_options_t

contains

  !> Every rank must own at least halo rows (the DMDA cannot build a halo
  !> wider than a strip). Same answer on every rank: a collective check.
  subroutine check_decomposition(cfg, nranks, ierr, errmsg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: nranks
    integer, intent(out) :: ierr
    character(len=*), intent(out) :: errmsg
    integer :: w
    w = halo_width(cfg)
    ierr = 0
    errmsg = ''
    if (cfg%lattice%ny / nranks < w) then
      ierr = 1
      write(errmsg, '(a,i0,a,i0,a,i0,a,i0,a)') '&lattice: ny = ', cfg%lattice%ny, ' is too small for ', nranks, &
        ' ranks: each rank owns whole rows and needs at least ', w, ' (the halo width) of them; use at most ', &
        cfg%lattice%ny / w, ' ranks'
    end if
  end subroutine check_decomposition

  !> Create the DMDA, the lattice strip, the initial state, the process
  !> models, the Jacobian matrix and the TS. refusal: a process model's
  !> refusal of the scene (one line, the same on every rank: the caller
  !> ends the run collectively; '' when none); ierr: a PETSc error. extra:
  !> process models of the caller's, after the scene's (a new force tried
  !> out before it has a key; tests/mpi/test_process_models.F90), moved
  !> into the solver's list. Collective.
  subroutine solver_create(ctx, cfg, ierr, refusal, extra)
    type(app_ctx), intent(inout), target :: ctx
    !> the run's configuration: the context points to it from here on (one
    !> configuration for the caller and the solver; the effective dt and
    !> t_end are the step record's, module step_settings)
    type(nuno_config), intent(in), target :: cfg
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: refusal
    type(pm_list_t), intent(inout), optional :: extra
    PetscInt :: w, nxp, nyp
    PetscInt, parameter :: one = 1, six = 6
    type(nuno_options_t) :: opt
    logical :: applied

    refusal = ''
    ctx%cfg => cfg
    ctx%comm = PETSC_COMM_WORLD
    call MPI_Comm_rank(ctx%comm, ctx%rank, ierr)
    call MPI_Comm_size(ctx%comm, ctx%size, ierr)
    w = halo_width(cfg)
    nxp = cfg%lattice%nx
    nyp = cfg%lattice%ny
    ! 1 x P processes: each rank owns whole rows, ghost width 2 with bending.
    PetscCall(DMDACreate2d(ctx%comm, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DMDA_STENCIL_BOX, nxp, nyp, one, PETSC_DECIDE, six, w, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, ctx%da, ierr))
    call add_process_models(ctx, cfg)
    if (present(extra)) call pm_list_take(ctx%pms, extra)
    PetscCall(resolve_options(ctx, cfg, opt, ierr))
    PetscCall(setup_strips(ctx, cfg, opt, ierr))
    PetscCall(setup_process_models(ctx, cfg, refusal, ierr))
    if (len_trim(refusal) > 0) return
    PetscCall(create_jacobian(ctx, cfg, opt, ierr))
    PetscCall(create_ts(ctx, cfg, ierr))
    ! An adaptive run without -ts_type: the method that won the
    ! work-precision measurement at moderate tolerance (module solver_options).
    ! The identification and the control keep beuler: their adjoint needs a theta method.
    applied = .false.
    if (.not. (cfg%identify%active .or. cfg%control%active)) then
      PetscCall(adaptive_default(ctx%ts, ctx%comm, applied, ierr))
      PetscCall(adaptive_default_allowed(ctx, applied, ierr))
    end if
    PetscCall(pm_solver_options(ctx, ierr))
    PetscCall(step_defaults(ctx%ts, ctx%use_reduced, ierr))
    PetscCall(TSSetFromOptions(ctx%ts, ierr))
    PetscCall(effective_time_integration(ctx, applied, ierr))
    PetscCall(pm_solver_setup(ctx, refusal, ierr))
  end subroutine solver_create

  !> An adaptive run's default integrator that a process model refuses
  !> (contact allows beuler and bdf of order 1 or 2, not the default rosw)
  !> gives way to beuler, the type set before, unless
  !> -nuno_adaptive_ts_type was given (then the refusal names it):
  !> -ts_adapt_type basic alone runs a contact scene. applied: still the
  !> default's. Collective.
  subroutine adaptive_default_allowed(ctx, applied, ierr)
    type(app_ctx), intent(inout) :: ctx
    logical, intent(inout) :: applied
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: tstype
    character(len=:), allocatable :: allowed
    PetscBool :: given
    integer :: k
    ierr = 0
    if (.not. (applied .and. pm_list_on(ctx%pms))) return
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-nuno_adaptive_ts_type', given, ierr))
    if (given) return
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    call pm_list_ts_refusal(ctx%pms, trim(tstype), k, allowed)
    if (k == 0) return
    PetscCall(TSSetType(ctx%ts, TSBEULER, ierr))
    applied = .false.
  end subroutine adaptive_default_allowed

  !> The scene's process models into the list (module process_models),
  !> before anything reads their hints: contact with &contact's obstacles
  !> (none without), of the cloth's faces and edges with those that are
  !> not planes, and of the cloth with itself (self_contact). The one
  !> place that names the physics: a new force is added here
  !> (docs/design.md, "Process models").
  subroutine add_process_models(ctx, cfg)
    type(app_ctx), intent(inout) :: ctx
    type(nuno_config), intent(in) :: cfg
    class(process_model_t), allocatable :: pm
    if (cfg%contact%n_obstacles > 0) then
      allocate(contact_model_t :: pm)
      call pm_list_add(ctx%pms, pm)
    end if
    ! the cloth's triangles and edges against obstacles with features
    ! between the nodes (sphere, box, capsule: shape codes above 1); a
    ! scene of planes only, or with contact_faces = .false., is as before
    if (cfg%contact%faces .and. any(cfg%contact%shape_code(1:cfg%contact%n_obstacles) > 1)) then
      allocate(face_contact_t :: pm)
      call pm_list_add(ctx%pms, pm)
    end if
    ! the cloth against itself: only with &contact's self_contact
    if (cfg%contact%self_contact) then
      allocate(self_contact_model_t :: pm)
      call pm_list_add(ctx%pms, pm)
    end if
  end subroutine add_process_models

  !> The process models' set-up hooks with the lattice strip, the initial
  !> state and the constraints (module process_models' pm_list_setup);
  !> refusal: the first model's refusal of the scene, the same on every
  !> rank ('' when none). Nothing without process models. Collective.
  subroutine setup_process_models(ctx, cfg, refusal, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(nuno_config), intent(in) :: cfg
    character(*), intent(out) :: refusal
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    integer :: err
    ierr = 0
    refusal = ''
    if (.not. pm_list_on(ctx%pms)) return
    PetscCall(ghosted_get(ctx%da, ctx%u, uloc, u, ierr))
    call pm_list_setup(ctx%pms, cfg, ctx%lat, ctx%comm, u, ctx%cs, err, refusal)
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    if (err == 0) refusal = ''
  end subroutine setup_process_models

  !> nuno's own options, in an options block (so in -help), resolved into
  !> opt and Newton's record: the Newton step, reduced 3-dof elimination
  !> (default) or the assembled 6-dof Jacobian (the reference for
  !> -snes_test_jacobian and small scenes), and the storage of that
  !> Jacobian: BAIJ (6 x 6 blocks) assembles and multiplies fastest;
  !> -dm_mat_type aij for field splits. Refuses values and combinations
  !> the run cannot honour. Collective.
  subroutine resolve_options(ctx, cfg, opt, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(nuno_config), intent(in) :: cfg
    type(nuno_options_t), intent(out) :: opt
    PetscErrorCode, intent(out) :: ierr
    character(len=64, kind=c_char) :: cmattype
    integer(c_int) :: jac, nfail, forcing, ls_fallback, ls_given, guess, guess_given
    real(c_double) :: snes_floor
    PetscBool :: ls_type_given
    type(pm_hints_t) :: hints

    jac = JACOBIAN_REDUCED
    opt%pc_lag = 0                 ! the default: 3 with the multigrid, 1 otherwise (module reduced)
    opt%pc_growth = PC_GROWTH_DEFAULT
    opt%mg_interp = INTERP_AUTO    ! cubic with bending, linear without (module reduced)
    opt%gn = 0
    opt%cl = 0
    nfail = 0
    cmattype = MATBAIJ//c_null_char
    ! A process model may need the forcing guarded (contact: the forcing
    ! term's quadratic model of Newton's convergence does not hold at a
    ! contact's onset, and its loose inner solves (up to 0.1) failed
    ! drop_table's impact step (4 retries) where a fixed 1e-6 takes none:
    ! module newton_state keeps them tight there).
    hints = pm_list_hints(ctx%pms)
    forcing = 1
    guess = GUESS_AUTO
    snes_floor = SNES_FLOOR_DEFAULT
    ierr = nuno_options_read(ctx%comm, JACOBIAN_NAMES, size(JACOBIAN_NAMES), len(JACOBIAN_NAMES), jac, opt%pc_lag, opt%pc_growth, &
                             INTERP_NAMES, size(INTERP_NAMES), len(INTERP_NAMES), opt%mg_interp, snes_floor, opt%gn, opt%cl, &
                             cmattype, len(cmattype), nfail, forcing, &
                             GUESS_NAMES, size(GUESS_NAMES), len(GUESS_NAMES), guess, guess_given)
    if (ierr /= 0) return
    if (opt%pc_lag < 0) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, '-nuno_pc_lag '//itoa(int(opt%pc_lag))//' must be >= 1 (or 0: the default)')
    end if
    if (.not. (opt%pc_growth == 0.0_rp .or. opt%pc_growth > 1.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, '-nuno_pc_rebuild_growth '//real_g0(opt%pc_growth)//' must be 0 (off) or > 1')
    end if
    if (.not. (snes_floor >= 0.0_rp .and. snes_floor < 1.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, '-nuno_snes_floor '//real_g0(snes_floor)//' must be in [0, 1)')
    end if
    if (nfail < 0) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, '-nuno_fail_newton '//itoa(int(nfail))//' must be >= 0')
    end if
    ctx%use_reduced = jac == JACOBIAN_REDUCED
    ! -pc_type lu and friends on the path in use (before anything reads them)
    PetscCall(petsc_habits(ctx%comm, ctx%use_reduced, cmattype, ierr))
    if (.not. ctx%use_reduced .and. opt%mg_interp > 0) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_mg_interpolation is for the reduced solve, not -nuno_jacobian full')
    end if
    ls_fallback = FALLBACK_BT
    ierr = nuno_linesearch_options_read(ctx%comm, FALLBACK_NAMES, size(FALLBACK_NAMES), len(FALLBACK_NAMES), ls_fallback, ls_given)
    if (ierr /= 0) return
    ! the user's -snes_linesearch_type then holds for the whole run
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-snes_linesearch_type', ls_type_given, ierr))
    if (ls_given /= 0 .and. .not. ctx%use_reduced) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_linesearch_fallback is for the reduced path; with -nuno_jacobian full Newton backtracks (bt) from the start')
    end if
    if (ls_given /= 0 .and. ls_type_given) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_linesearch_fallback and -snes_linesearch_type: give one (the first changes the line search after a failed Newton solve, the second sets it for the whole run)')
    end if
    if (.not. ctx%use_reduced .or. ls_type_given) ls_fallback = 0
    call newton_state_init(ctx%newton, snes_floor=snes_floor, guess=guess, guess_given=guess_given, &
                           forcing=forcing /= 0, guarded=hints%forcing_guarded, fail_newton=nfail, &
                           ls_fallback=ls_fallback)
    opt%mattype = cmattype(1:index(cmattype, c_null_char) - 1)
  end subroutine resolve_options

  !> The DMDA's strips set up (matrix type opt%mattype, field names), this
  !> rank's lattice strip (refused unless the DMDA's strips are whole rows),
  !> the model's work arrays, the output buffers, and the scene's initial
  !> state and constraints. Collective.
  subroutine setup_strips(ctx, cfg, opt, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(nuno_config), intent(in) :: cfg
    type(nuno_options_t), intent(in) :: opt
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: xs, ys, zs, xm, ym, zm, gxs, gys, gzs, gxm, gym, gzm
    PetscScalar, pointer :: ua(:, :, :)

    PetscCall(DMSetMatType(ctx%da, opt%mattype, ierr))
    PetscCall(DMSetUp(ctx%da, ierr))
    PetscCall(DMDASetFieldName(ctx%da, 0, 'x', ierr))
    PetscCall(DMDASetFieldName(ctx%da, 1, 'y', ierr))
    PetscCall(DMDASetFieldName(ctx%da, 2, 'z', ierr))
    PetscCall(DMDASetFieldName(ctx%da, 3, 'vx', ierr))
    PetscCall(DMDASetFieldName(ctx%da, 4, 'vy', ierr))
    PetscCall(DMDASetFieldName(ctx%da, 5, 'vz', ierr))
    PetscCall(DMDAGetCorners(ctx%da, xs, ys, zs, xm, ym, zm, ierr))
    PetscCall(DMDAGetGhostCorners(ctx%da, gxs, gys, gzs, gxm, gym, gzm, ierr))

    call lattice_init(ctx%lat, cfg, ys, ys + ym - 1)
    if (xs /= 0 .or. xm /= cfg%lattice%nx .or. gys /= ctx%lat%gys .or. gys + gym - 1 /= ctx%lat%gye) then
      ierr = PETSC_ERR_PLIB
      SETERRQ(ctx%comm, ierr, 'nuno: the DMDA is not split into strips of whole rows')
    end if
    call model_state_init(ctx%model, ctx%lat, gravity=merge(cfg%scene%gravity, [0.0_rp, 0.0_rp, 0.0_rp], cfg%scene%has_gravity), &
                          clamp=opt%cl /= 0, gauss_newton=opt%gn /= 0)
    allocate(ctx%xout(3, 0:cfg%lattice%nx - 1, ys:ys + ym - 1), ctx%vout(3, 0:cfg%lattice%nx - 1, ys:ys + ym - 1))

    ! Initial state and constraints of the scene.
    PetscCall(DMCreateGlobalVector(ctx%da, ctx%u, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, ctx%u, ua, ierr))
    call scene_setup(cfg, ctx%lat, ua, ctx%cs)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, ctx%u, ua, ierr))
  end subroutine setup_strips

  !> The Newton step's matrices: S and the inner solver of the reduced
  !> solve (module reduced), or the assembled 6-dof Jacobian with the
  !> DMDA's exact box-stencil preallocation. Collective.
  subroutine create_jacobian(ctx, cfg, opt, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(nuno_config), intent(in) :: cfg
    type(nuno_options_t), intent(in) :: opt
    PetscErrorCode, intent(out) :: ierr
    logical :: symmetric, constant, damping
    type(pm_hints_t) :: hints

    ierr = 0
    if (.not. ctx%use_reduced) then
      PetscCall(assembly_create(ctx%asm, ctx%da, ctx%lat, halo_width(cfg), ierr))
      return
    end if
    ! S is symmetric when K and C are: no moving dampers (linear springs
    ! have constant ones), no paper bending, no bending damping.
    hints = pm_list_hints(ctx%pms)
    damping = cfg%material%has_damping .or. (cfg%material%bending_code == BEND_ENERGY .and. cfg%material%eta_b /= 0.0_rp) .or. &
              hints%velocity_blocks   ! a process model's df/dv (contact's friction)
    symmetric = (cfg%material%spring_code == SPRING_LINEAR .or. .not. cfg%material%has_damping) .and. &
                (cfg%material%bending_code == BEND_NONE .or. (cfg%material%bending_code == BEND_ENERGY .and. &
                 (cfg%material%eta_b == 0.0_rp .or. opt%gn /= 0)))
    constant = cfg%material%spring_code == SPRING_LINEAR .and. cfg%material%bending_code == BEND_NONE .and. .not. hints%state_blocks
    PetscCall(reduced_create(ctx%red, ctx%da, ctx%lat, pm_list_nodal(ctx%pms), symmetric, hints%stiff_neighbour_blocks, constant, damping, opt%cl /= 0, opt%gn /= 0, opt%pc_lag, opt%pc_growth, opt%mg_interp, ierr))
    ! blocks of nodes that are not stencil neighbours (self-contact): S's product adds them
    if (hints%pair_blocks) then
      PetscCall(reduced_set_pairs(ctx%red, ctx%pms, ierr))
    end if
  end subroutine create_jacobian

  !> The TS: the report's scheme by default, backward Euler with the
  !> namelist's fixed step (any implicit TS type and adaptivity through the
  !> options), nuno's callbacks, the retries of a failed step, and the
  !> SNES's convergence test and line search. Collective.
  subroutine create_ts(ctx, cfg, ierr)
    type(app_ctx), intent(inout), target :: ctx
    type(nuno_config), intent(in) :: cfg
    PetscErrorCode, intent(out) :: ierr
    PetscInt, parameter :: two = 2, eight = 8
    type(tSNES) :: snes
    type(tTSAdapt) :: adapt
    SNESLineSearch :: linesearch
    type(pm_hints_t) :: hints

    PetscCall(TSCreate(ctx%comm, ctx%ts, ierr))
    PetscCall(TSSetDM(ctx%ts, ctx%da, ierr))
    PetscCall(TSSetProblemType(ctx%ts, TS_NONLINEAR, ierr))
    PetscCall(TSSetType(ctx%ts, TSBEULER, ierr))
    PetscCall(TSSetIFunction(ctx%ts, PETSC_NULL_VEC, form_ifunction, ctx, ierr))
    if (ctx%use_reduced) then
      PetscCall(TSSetIJacobian(ctx%ts, reduced_jacobian(ctx%red), reduced_jacobian(ctx%red), form_ijacobian, ctx, ierr))
    else
      PetscCall(TSSetIJacobian(ctx%ts, assembly_matrix(ctx%asm), assembly_matrix(ctx%asm), form_ijacobian, ctx, ierr))
    end if
    PetscCall(TSSetTime(ctx%ts, 0.0_rp, ierr))
    PetscCall(TSSetTimeStep(ctx%ts, cfg%time%dt, ierr))
    PetscCall(TSSetMaxTime(ctx%ts, cfg%time%t_end, ierr))
    PetscCall(TSSetExactFinalTime(ctx%ts, TS_EXACTFINALTIME_MATCHSTEP, ierr))
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    PetscCall(TSAdaptSetType(adapt, TSADAPTNONE, ierr))
    ! A step whose Newton solve fails is retried with a smaller step a few
    ! times (then the run stops with the reason), never forever.
    PetscCall(TSSetMaxSNESFailures(ctx%ts, eight, ierr))
    ! A failed step is reported by solver_run (time, reason), not raised as an error.
    PetscCall(TSSetErrorIfStepFails(ctx%ts, PETSC_FALSE, ierr))
    PetscCall(TSMonitorSet(ctx%ts, ts_monitor, ctx, PETSC_NULL_FUNCTION, ierr))
    ierr = nuno_signals_install(ctx%ts%v)
    if (ierr /= 0) return
    ! Converge on the residual only: PETSc's default step-size test
    ! (stol = 1e-8) declares CONVERGED_SNORM_RELATIVE when a poor
    ! preconditioner stalls the line search, i.e. accepts an unsolved step.
    PetscCall(TSGetSNES(ctx%ts, snes, ierr))
    PetscCall(SNESSetTolerances(snes, PETSC_DEFAULT_REAL, PETSC_DEFAULT_REAL, 0.0_rp, PETSC_DEFAULT_INTEGER, PETSC_DEFAULT_INTEGER, ierr))
    PetscCall(SNESSetConvergenceTest(snes, snes_converged, ctx, PETSC_NULL_FUNCTION, ierr))
    ! A line search that finds no decrease goes to snes_converged, which
    ! accepts it at the round-off floor and fails it elsewhere (PETSc's
    ! default, 1, fails the solve before the test: the 6-dof path's bt
    ! failed the shipped hang scene so).
    PetscCall(SNESSetMaxNonlinearStepFailures(snes, two, ierr))
    hints = pm_list_hints(ctx%pms)
    if (ctx%use_reduced) then
      PetscCall(reduced_attach(ctx%red, snes, ierr))
      ! The full step is exact in x and Newton-exact in v: no backtracking by
      ! default (bt needs a Jacobian product, an extra pass over the
      ! elements, for every Newton iteration); -snes_linesearch_type bt works.
      PetscCall(SNESGetLineSearch(snes, linesearch, ierr))
      PetscCall(SNESLineSearchSetType(linesearch, SNESLINESEARCHBASIC, ierr))
    else if (hints%basic_line_search) then
      ! A process model that limits the update itself (contact: by the
      ! time of impact, module process_solver's pre-check; bt's cubic model
      ! of ||F||^2 does not hold across the barrier's log, and failed the
      ! 6-dof path at a drop's impact, drop_table to 0.15 s).
      ! -snes_linesearch_type bt works.
      PetscCall(SNESGetLineSearch(snes, linesearch, ierr))
      PetscCall(SNESLineSearchSetType(linesearch, SNESLINESEARCHBASIC, ierr))
    end if
  end subroutine create_ts

  !> Read back what the options made of the time integration, so that the
  !> run, the start-up line and the output file use the values actually in
  !> force: -ts_dt overrides the namelist's dt, -ts_max_time its t_end,
  !> -ts_max_steps ends the run early (complete). Options the time loop
  !> cannot honour are refused here. adaptive: the TS type is
  !> -nuno_adaptive_ts_type's (module solver_options' adaptive_default).
  !> Collective.
  subroutine effective_time_integration(ctx, adaptive, ierr)
    type(app_ctx), intent(inout) :: ctx
    logical, intent(in) :: adaptive
    PetscErrorCode, intent(out) :: ierr
    type(tTSAdapt) :: adapt
    TSExactFinalTimeOption :: eft
    PetscBool :: match, given
    character(len=64) :: tstype
    character(len=40) :: srcx, srcv
    PetscInt, parameter :: unlimited = -1
    real(rp) :: dt_namelist, t_end_namelist, dt, t_end
    PetscInt :: max_steps

    dt_namelist = ctx%cfg%time%dt
    t_end_namelist = ctx%cfg%time%t_end
    PetscCall(TSGetTimeStep(ctx%ts, dt, ierr))
    PetscCall(TSGetMaxTime(ctx%ts, t_end, ierr))
    PetscCall(TSGetMaxSteps(ctx%ts, max_steps, ierr))
    PetscCall(TSGetExactFinalTime(ctx%ts, eft, ierr))
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    PetscCall(PetscObjectTypeCompare(adapt, TSADAPTNONE, match, ierr))
    call step_settings_init(ctx%step, dt=dt, t_end=t_end, max_steps=max_steps, fixed_step=logical(match), &
                            adaptive_default=adaptive)
    ! Adaptive steps: a failed Newton solve is one more rejected step (its
    ! step retried at a quarter), not a count towards the run's end: the
    ! adaptor chooses the steps, at most -ts_max_reject rejections of one
    ! step in a row end it, and the collapse check (module step_monitor)
    ! a step that shrinks away. gripper with -ts_adapt_type basic spent its
    ! 8 failures on steps that met the moving fingers before t = 1 s.
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_max_snes_failures', given, ierr))
    if (.not. step_fixed(ctx%step) .and. .not. given) then
      PetscCall(TSSetMaxSNESFailures(ctx%ts, unlimited, ierr))
    end if
    ! The time loop stops exactly at output, keyframe and release times.
    if (eft /= TS_EXACTFINALTIME_MATCHSTEP) then
      ierr = PETSC_ERR_ARG_WRONG
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_exact_final_time must be matchstep: the run stops exactly at every output, keyframe and release time')
    end if
    if (.not. (step_dt(ctx%step) > 0.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_dt must be > 0')
    end if
    if (.not. (step_t_end(ctx%step) > 0.0_rp) .or. step_t_end(ctx%step) > huge(1.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_max_time must be > 0 and finite')
    end if
    if (step_max_steps(ctx%step) < 0) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_max_steps must be >= 0')
    end if
    ! The energy integrals close at the method's order: the trapezoid rule
    ! over each step (one power pass a step) is second order, enough for
    ! beuler, theta and cn (order <= 2); bdf (up to order 6) gets three
    ! Gauss-Legendre points on its interpolant, the Lagrange polynomial of
    ! its history (three passes a step). arkimex and rosw tableaus may lack
    ! an interpolant: trapezoid.
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    PetscCall(set_inner_guess(ctx, tstype, ierr))
    PetscCall(set_newton_start(ctx, ierr))
    PetscCall(energy_integrals_init(ctx%energy, trim(tstype) == 'bdf', ctx%u, ierr))
    PetscCall(set_tolerances(ctx, srcx, srcv, ierr))

    PetscCall(say_solver(ctx, adapt, dt_namelist, t_end_namelist, srcx, srcv, ierr))
  end subroutine effective_time_integration

  !> The start-up lines (rank 0) of the time integration in force: the
  !> scheme, its steps and tolerances (where the namelist's dt and t_end,
  !> dt_namelist and t_end_namelist [time], were overridden, both; srcx and
  !> srcv: where the tolerances came from), the Newton step and the inner
  !> solve. Collective (the descriptions are gathered on every rank).
  subroutine say_solver(ctx, adapt, dt_namelist, t_end_namelist, srcx, srcv, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tTSAdapt), intent(in) :: adapt
    real(rp), intent(in) :: dt_namelist, t_end_namelist
    character(len=*), intent(in) :: srcx, srcv
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: adtype, sntype
    character(len=:), allocatable :: scheme
    character(len=512) :: line, inner
    type(tSNES) :: snes
    real(rp) :: rtol, atol_x, atol_v

    PetscCall(ts_scheme(ctx%ts, scheme, ierr))
    inner = ''
    if (ctx%use_reduced) then
      PetscCall(reduced_describe(ctx%red, inner, ierr))
      PetscCall(TSGetSNES(ctx%ts, snes, ierr))
      PetscCall(SNESGetType(snes, sntype, ierr))
      if (trim(sntype) == SNESNEWTONLS .and. newton_forcing_on(ctx%newton) .and. reduced_forward_ew(ctx%red)) &
        inner = trim(inner)//'; Newton: inner rtol from the step''s needs (-nuno_newton_forcing)'
    end if
    if (ctx%rank == 0) then
      PetscCall(TSAdaptGetType(adapt, adtype, ierr))
      line = 'solver    : TS '//scheme
      if (step_adaptive_default(ctx%step)) line = trim(line)//' (the default of adaptive runs, -nuno_adaptive_ts_type)'
      line = trim(line)//', adapt '//trim(adtype)
      if (step_fixed(ctx%step)) then
        line = trim(line)//', dt = '//num(step_dt(ctx%step))
      else
        line = trim(line)//', initial dt = '//num(step_dt(ctx%step))
      end if
      if (step_dt(ctx%step) /= dt_namelist) line = trim(line)//' (-ts_dt; namelist '//num(dt_namelist)//')'
      line = trim(line)//', t_end = '//num(step_t_end(ctx%step))
      if (step_t_end(ctx%step) /= t_end_namelist) &
        line = trim(line)//' (-ts_max_time; namelist '//num(t_end_namelist)//')'
      if (step_max_steps(ctx%step) < huge(step_max_steps(ctx%step))) &
        line = trim(line)//', at most '//inum(step_max_steps(ctx%step))//' steps (-ts_max_steps)'
      call step_tolerances(ctx%step, rtol, atol_x, atol_v)
      if (.not. step_fixed(ctx%step)) line = trim(line)//', rtol '//num(rtol)//', atol position '// &
        num(atol_x)//' ('//trim(srcx)//'), velocity '//num(atol_v)//' ('//trim(srcv)//')'
      line = trim(line)//', Newton step '//trim(merge('reduced', 'full   ', ctx%use_reduced))
      if (newton_start_order(ctx%start) == 3) line = trim(line)//', started '// &
        trim(merge('consistent', 'cubic     ', newton_start_is_consistent(ctx%start)))//' (-nuno_newton_start)'
      write(output_unit, '(a)') trim(line)
      if (ctx%use_reduced) write(output_unit, '(a)') 'inner     : '//trim(inner)
      flush(output_unit)
    end if
  end subroutine say_solver

  !> The inner initial guess (-nuno_inner_guess, module inner_guess): the
  !> first Newton corrections of successive steps form a smooth sequence
  !> only for one-stage methods (beuler, theta, cn), whose shift is
  !> proportional to 1/dt; the stages of rosw, arkimex and bdf's history
  !> are other quantities. auto: project with bending (the extrapolation
  !> took 30 % fewer inner iterations in bw mode at 257 x 257, the
  !> projection 16 % fewer again, docs/performance.md; extrapolate with
  !> adaptive steps, whose changes of dt empty the projection), none without
  !> (there what the guesses cost ate the gain), and none in
  !> identification and control runs. An explicit choice the run cannot
  !> use is refused. Collective.
  subroutine set_inner_guess(ctx, tstype, ierr)
    type(app_ctx), intent(inout) :: ctx
    character(len=*), intent(in) :: tstype
    PetscErrorCode, intent(out) :: ierr
    logical :: one_stage, direct
    integer :: mode
    PetscBool :: extrap, set
    character(len=64) :: ktype
    ierr = 0
    extrap = PETSC_FALSE
    one_stage = tstype == TSBEULER .or. tstype == TSTHETA .or. tstype == TSCN
    ! a direct inner solve (preonly) takes no initial guess
    direct = .false.
    if (ctx%use_reduced) then
      PetscCall(KSPGetType(reduced_inner_ksp(ctx%red), ktype, ierr))
      direct = ktype == KSPPREONLY
    end if
    if (newton_guess_given(ctx%newton) .and. newton_guess(ctx%newton) /= GUESS_NONE .and. newton_guess(ctx%newton) /= GUESS_AUTO) then
      if (.not. ctx%use_reduced) then
        ierr = PETSC_ERR_ARG_INCOMP
        SETERRQ(ctx%comm, ierr, 'nuno: -nuno_inner_guess is for the reduced solve, not -nuno_jacobian full')
      end if
      if (.not. one_stage) then
        ierr = PETSC_ERR_ARG_INCOMP
        SETERRQ(ctx%comm, ierr, 'nuno: -nuno_inner_guess previous, extrapolate or project needs a one-stage method (-ts_type beuler, theta or cn), not -ts_type '//trim(tstype))
      end if
      if (direct) then
        ierr = PETSC_ERR_ARG_INCOMP
        SETERRQ(ctx%comm, ierr, 'nuno: -nuno_inner_guess previous, extrapolate or project needs an iterative inner solver, not -reduced_ksp_type preonly')
      end if
    end if
    if (.not. ctx%use_reduced) return
    mode = newton_guess(ctx%newton)
    ! (auto leaves the fits alone: their finite-difference checks compare
    ! runs whose inexact solves would otherwise start from other guesses)
    ! The projection drops its kept solves whenever dt changes, so with
    ! adaptive steps it would rarely have any: the extrapolation, which
    ! scales across steps of other sizes, there.
    if (mode == GUESS_AUTO) mode = merge(merge(GUESS_PROJECT, GUESS_EXTRAPOLATE, step_fixed(ctx%step)), GUESS_NONE, one_stage .and. &
                                         ctx%cfg%material%bending_code /= BEND_NONE .and. .not. (ctx%cfg%identify%active .or. ctx%cfg%control%active))
    if (.not. one_stage .or. direct) mode = GUESS_NONE
    call newton_set_inner_guess(ctx%newton, mode)
    ! (step_defaults put the extrapolated start of beuler in the options)
    PetscCall(PetscOptionsGetBool(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_theta_initial_guess_extrapolate', extrap, set, ierr))
    PetscCall(reduced_set_guess(ctx%red, mode, logical(set .and. extrap), ierr))
  end subroutine set_inner_guess

  !> The error tolerances of adaptive steps, as vectors for TS: positions
  !> atol_x alone [length], velocities atol_v + rtol |v| [length/time]
  !> (input/README.md, "Error tolerances"), with atol_x from
  !> -nuno_atol_position, else -ts_atol, else rtol times the cloth size
  !> max(lx, ly); -nuno_atol_velocity, else the position tolerance per unit
  !> of time (TOLERANCE_TIME). srcx, srcv say where each
  !> came from. Also what update_wrms weighs Newton's updates with. Collective.
  subroutine set_tolerances(ctx, srcx, srcv, ierr)
    type(app_ctx), intent(inout) :: ctx
    character(len=*), intent(out) :: srcx, srcv
    PetscErrorCode, intent(out) :: ierr
    PetscReal :: atol, rtol
    PetscBool :: atol_given
    PetscScalar, pointer :: va(:, :, :)
    type(tVec) :: vatol, vrtol
    real(c_double) :: ax, av
    integer(c_int) :: gx, gv
    character(len=64) :: tstype
    PetscInt :: order
    type(tTSAdapt) :: adapt
    PetscReal :: hmin, hmax

    PetscCall(TSGetTolerances(ctx%ts, atol, PETSC_NULL_VEC, rtol, PETSC_NULL_VEC, ierr))
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_atol', atol_given, ierr))
    if (atol_given) then
      ax = atol
      srcx = '-ts_atol'
    else
      ax = rtol * max(ctx%cfg%lattice%lx, ctx%cfg%lattice%ly)
      srcx = 'rtol x cloth size'
    end if
    av = ax / TOLERANCE_TIME
    ierr = nuno_tolerance_options_read(ctx%comm, ax, av, gx, gv)
    if (ierr /= 0) return
    if (.not. (ax > 0.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, '-nuno_atol_position '//real_g0(ax)//' must be > 0')
    end if
    if (.not. (av > 0.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, '-nuno_atol_velocity '//real_g0(av)//' must be > 0')
    end if
    if (gx /= 0) srcx = '-nuno_atol_position'
    srcv = 'position atol / 1 time unit'
    if (gv /= 0) srcv = '-nuno_atol_velocity'
    call step_set_tolerances(ctx%step, rtol=rtol, atol_x=ax, atol_v=av)
    ! with process models: adaptive steps' error estimate leaves out the
    ! nodes they make too stiff for the step, bdf2 takes impacts at order
    ! 1 (module step_errors)
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    order = 0
    if (tstype == 'bdf') then
      PetscCall(TSBDFGetOrder(ctx%ts, order, ierr))
    end if
    call step_errors_init(ctx%errw, pm_list_on(ctx%pms) .and. .not. step_fixed(ctx%step), &
                          pm_list_on(ctx%pms) .and. order == 2, ctx%lat%nx, ctx%lat%ys, ctx%lat%ye, rtol, ax, av)
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    PetscCall(TSAdaptGetStepLimits(adapt, hmin, hmax, ierr))
    call step_errors_set_min_step(ctx%errw, hmin, step_dt(ctx%step), hmax)
    PetscCall(DMCreateGlobalVector(ctx%da, vatol, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, vatol, va, ierr))
    va(0:2, :, :) = ax
    va(3:5, :, :) = av
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, vatol, va, ierr))
    ! No relative tolerance on positions: |x| depends on where the origin
    ! is, the cloth size does not. Velocities: atol_v + rtol |v|.
    PetscCall(DMCreateGlobalVector(ctx%da, vrtol, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, vrtol, va, ierr))
    va(0:2, :, :) = 0.0_rp
    va(3:5, :, :) = rtol
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, vrtol, va, ierr))
    PetscCall(TSSetTolerances(ctx%ts, atol, vatol, rtol, vrtol, ierr))
    PetscCall(VecDestroy(vatol, ierr))             ! the TS keeps its references
    PetscCall(VecDestroy(vrtol, ierr))
  end subroutine set_tolerances

  !> Report the options nothing read (after the run, when every object has
  !> read its options), then destroy the PETSc objects, in reverse order of
  !> creation.
  subroutine solver_destroy(ctx, ierr)
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    integer(c_int) :: nunused
    ierr = nuno_options_report_unused(ctx%comm, nunused)
    if (ierr /= 0) return
    PetscCall(newton_start_free(ctx%start, ierr))
    PetscCall(TSDestroy(ctx%ts, ierr))
    if (ctx%use_reduced) then
      PetscCall(reduced_destroy(ctx%red, ierr))
    else
      PetscCall(assembly_free(ctx%asm, ierr))
    end if
    PetscCall(VecDestroy(ctx%u, ierr))
    PetscCall(energy_integrals_free(ctx%energy, ierr))
    PetscCall(DMDestroy(ctx%da, ierr))
    call model_state_free(ctx%model)
    call step_errors_free(ctx%errw)
    call pm_list_destroy(ctx%pms)
  end subroutine solver_destroy

end module solver_setup
