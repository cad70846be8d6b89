!> Time integration with PETSc TS on a DMDA of 1 x P strips (docs/model.md
!> sections 5 and 6): the solver context, the IFunction and the assembled
!> IJacobian callbacks, the monitor that integrates dissipated power and
!> constraint work, and the loop over time windows that stops exactly at
!> output, keyframe and release times.
!>
!> State: DMDA dof 6 per node, u(0:2) position, u(3:5) velocity;
!> F = [ xdot - v ; vdot - f(x, v)/m - g ] on free nodes and
!> F = [ xdot - vbar ; vdot ] on constrained nodes.
!> The rows are those of docs/model.md section 5 divided by the mass, so that
!> dF/dUdot = I: PETSc's ARKIMEX (explicit first stage) takes
!> Udot = -F(t, U, 0) and is wrong for any other form. A constrained node is
!> put on its path at the start of each time window (enter_window), where
!> its prescribed velocity is constant, so xdot = vbar keeps x = xbar(t)
!> exactly under every consistent integrator.
module timestepping
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_null_char, c_intptr_t
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: rp
  use config, only: nuno_config, SPRING_LINEAR, BEND_NONE, BEND_ENERGY, SCENE_HANG, unset_real
  use lattice, only: lattice_t, lattice_init, halo_width, link_dir
  use forces, only: internal_forces, link_stretch_extremes, dissipated_power, jac_buffer_t, jac_buffer_init, jac_buffer_row, &
                    slot_of, first_anchor_row
  use constraints, only: constraint_set_t, constraints_set_window, constraint_target, constraint_events
  use scenes, only: scene_setup
  use diagnostics, only: state_diagnostics_t, state_diagnostics
  use output, only: output_file, output_record, output_write_step, run_info, output_write_run_info, &
                    output_write_wall_time, output_config_key, checkpoint_t, output_write_checkpoint, output_steps
  use newton_forcing, only: forcing_term, quadratic_constant
  use newton_control, only: FLOOR_FACTOR, NEWTON_CONVERGED, NEWTON_DIVERGED, floor_node_add, floor_estimate, floor_verdict
  use inner_guess, only: GUESS_AUTO, GUESS_NONE, GUESS_EXTRAPOLATE, GUESS_PROJECT
  use reduced, only: reduced_t, reduced_create, reduced_destroy, reduced_assemble, reduced_set_fixed, reduced_attach, &
                     reduced_set_guess, reduced_step_accepted, &
                     reduced_describe, &
                     set_block_row
  implicit none
  private
  public :: app_ctx, solver_create, solver_destroy, solver_run, check_decomposition, solver_restore
  public :: enter_window            ! module identify: the constraint state of a time window

  !> Adaptive steps: Newton has converged when its estimated remaining error
  !> is below this fraction of the time integrator's tolerance (the
  !> weighted RMS norm of TSAdapt, in which a step is accepted at <= 1).
  real(rp), parameter :: NEWTON_TS_FRACTION = 0.01_rp
  !> SNESLineSearchReason's SNES_LINESEARCH_SUCCEEDED and _FAILED_REDUCT
  !> (no decrease found; petscsnes.h: PETSc 3.18 gives Fortran no names)
  integer, parameter :: LS_SUCCEEDED = 0, LS_FAILED_REDUCT = 3
  !> Wall seconds without a line on stdout after which the monitor prints one.
  real(rp), parameter :: HEARTBEAT_S = 10.0_rp
  !> The default velocity tolerance is the position tolerance over this
  !> [time]: one time unit (1 s in every scene), a constant, so that the
  !> tolerances, and so the steps, do not depend on t_end (a run to 2 s
  !> takes the steps of a run to 1 s over its first second, and a restart
  !> to a later t_end keeps them; docs/workprecision.md, "Tolerances").
  real(rp), parameter :: TOLERANCE_TIME = 1.0_rp
  !> Gauss-Legendre points (on [0, 1]) and weights, 3 points.
  real(rp), parameter :: GAUSS_X(3) = [0.5_rp - sqrt(0.15_rp), 0.5_rp, 0.5_rp + sqrt(0.15_rp)]
  real(rp), parameter :: GAUSS_W(3) = [5.0_rp / 18.0_rp, 8.0_rp / 18.0_rp, 5.0_rp / 18.0_rp]

  interface
    !> src/nuno_signals.c: SIGTERM/SIGINT end the run after the current step.
    integer(c_int) function nuno_signals_install(ts) bind(C, name='nuno_signals_install')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
    end function nuno_signals_install
    !> src/nuno_newton_start.c: -nuno_newton_start, the cubic start of beuler's Newton solve.
    integer(c_int) function nuno_newton_start_setup(ts, auto_cubic, order) bind(C, name='nuno_newton_start_setup')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
      integer(c_int) :: auto_cubic          !< 1: auto means cubic for this run
      integer(c_int) :: order               !< out: 1 (linear) or 3 (cubic)
    end function nuno_newton_start_setup
    integer(c_int) function nuno_newton_start_push(ts, u, t) bind(C, name='nuno_newton_start_push')
      import :: c_int, c_intptr_t, c_double
      integer(c_intptr_t) :: ts, u          !< TS*, Vec*
      real(c_double) :: t
    end function nuno_newton_start_push
    integer(c_int) function nuno_newton_start_reset(ts) bind(C, name='nuno_newton_start_reset')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts
    end function nuno_newton_start_reset
    integer(c_int) function nuno_newton_start_count(ts, n, compare, nc_prev) bind(C, name='nuno_newton_start_count')
      import :: c_int, c_intptr_t, c_double
      integer(c_intptr_t) :: ts
      integer(c_int) :: n, compare
      real(c_double) :: nc_prev
    end function nuno_newton_start_count
    integer(c_int) function nuno_newton_start_get(ts, k, v, t) bind(C, name='nuno_newton_start_get')
      import :: c_int, c_intptr_t, c_double
      integer(c_intptr_t) :: ts, v          !< TS*, Vec*
      integer(c_int) :: k
      real(c_double) :: t
    end function nuno_newton_start_get
    integer(c_int) function nuno_newton_start_put(ts, k, v, t, n, compare, nc_prev) bind(C, name='nuno_newton_start_put')
      import :: c_int, c_intptr_t, c_double
      integer(c_intptr_t) :: ts, v          !< TS*, Vec*
      integer(c_int) :: k, n, compare
      real(c_double) :: t, nc_prev
    end function nuno_newton_start_put
    integer(c_int) function nuno_signal_agreed() bind(C, name='nuno_signal_agreed')
      import :: c_int
    end function nuno_signal_agreed
    !> src/nuno_signals.c: -nuno_checkpoint_walltime, agreed after each step.
    !> Due after a step: the monitor of that step writes the checkpoint.
    subroutine nuno_walltime_arm(seconds) bind(C, name='nuno_walltime_arm')
      import :: c_double
      real(c_double), value :: seconds
    end subroutine nuno_walltime_arm
    integer(c_int) function nuno_checkpoint_due() bind(C, name='nuno_checkpoint_due')
      import :: c_int
    end function nuno_checkpoint_due
    !> Stop TSSolve after this step (TS_CONVERGED_USER).
    integer(c_int) function nuno_ts_stop(ts) bind(C, name='nuno_ts_stop')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
    end function nuno_ts_stop
    !> src/nuno_options.c: nuno's options in a PETSc options block.
    integer(c_int) function nuno_options_read(fcomm, jacobian, pc_lag, mg_interp, snes_floor, gauss_newton, clamp, &
                                              mattype, mattype_len, fail_newton, forcing, guess, guess_given) &
                                              bind(C, name='nuno_options_read')
      import :: c_int, c_double, c_char
      integer(c_int), value :: fcomm
      integer(c_int), intent(inout) :: jacobian, pc_lag, mg_interp, gauss_newton, clamp, fail_newton, forcing, guess
      integer(c_int), intent(out) :: guess_given
      real(c_double), intent(inout) :: snes_floor
      character(kind=c_char), intent(inout) :: mattype(*)
      integer(c_int), value :: mattype_len
    end function nuno_options_read
    !> src/nuno_petsc_habits.c: PETSc's -ksp_*/-pc_* options on the path in use.
    integer(c_int) function nuno_petsc_habits(fcomm, reduced, mattype, mattype_len) bind(C, name='nuno_petsc_habits')
      import :: c_int, c_char
      integer(c_int), value :: fcomm, reduced
      character(kind=c_char), intent(inout) :: mattype(*)
      integer(c_int), value :: mattype_len
    end function nuno_petsc_habits
    !> src/nuno_options.c: -nuno_linesearch_fallback, and whether -snes_linesearch_type is given.
    integer(c_int) function nuno_linesearch_options_read(fcomm, fallback, given, ls_given) &
        bind(C, name='nuno_linesearch_options_read')
      import :: c_int
      integer(c_int), value :: fcomm
      integer(c_int), intent(inout) :: fallback
      integer(c_int), intent(out) :: given, ls_given
    end function nuno_linesearch_options_read
    !> src/nuno_options.c: -nuno_atol_position, -nuno_atol_velocity (after TSSetFromOptions).
    integer(c_int) function nuno_tolerance_options_read(fcomm, atol_x, atol_v, given_x, given_v) &
        bind(C, name='nuno_tolerance_options_read')
      import :: c_int, c_double
      integer(c_int), value :: fcomm
      real(c_double), intent(inout) :: atol_x, atol_v
      integer(c_int), intent(out) :: given_x, given_v
    end function nuno_tolerance_options_read
    !> src/nuno_options.c: -nuno_adaptive_ts_type, the integrator of an
    !> adaptive run without -ts_type (before TSSetFromOptions).
    integer(c_int) function nuno_adaptive_default(fcomm, ts, applied) bind(C, name='nuno_adaptive_default')
      import :: c_int, c_intptr_t
      integer(c_int), value :: fcomm
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
      integer(c_int), intent(out) :: applied
    end function nuno_adaptive_default
    !> src/nuno_options.c: the Newton solve's defaults (extrapolated start for beuler, lagged S).
    integer(c_int) function nuno_step_defaults(ts, reduced) bind(C, name='nuno_step_defaults')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
      integer(c_int), value :: reduced      !< 1 on the reduced path
    end function nuno_step_defaults
    !> src/nuno_options.c: "rosw ra34pw2", "bdf order 4", ...: the TS type with its scheme.
    integer(c_int) function nuno_ts_scheme(ts, buf, len) bind(C, name='nuno_ts_scheme')
      import :: c_int, c_intptr_t, c_char
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_int), value :: len
    end function nuno_ts_scheme
    !> src/nuno_options.c: warn about options that nothing read.
    integer(c_int) function nuno_options_report_unused(fcomm, nunused) bind(C, name='nuno_options_report_unused')
      import :: c_int
      integer(c_int), value :: fcomm
      integer(c_int), intent(out) :: nunused
    end function nuno_options_report_unused
  end interface

  !> Everything the callbacks need; passed to PETSc as the user context.
  type :: app_ctx
    type(nuno_config) :: cfg
    type(lattice_t) :: lat
    type(constraint_set_t) :: cs
    type(jac_buffer_t) :: jbuf
    type(tDM) :: da
    type(tTS) :: ts
    type(tVec) :: u                             !< global state
    type(tMat) :: p                             !< assembled 6-dof Jacobian (-nuno_jacobian full only)
    logical :: use_reduced = .true.             !< the reduced 3-dof solve (module reduced), the default
    type(reduced_t) :: red                      !< its matrices and inner solver
    integer :: comm = MPI_COMM_NULL, rank = 0, size = 1
    real(rp), allocatable :: f(:, :, :)         !< (3, 0:nx-1, gys:gye) force work array
    logical, allocatable :: fixed(:, :)         !< (0:nx-1, ys:ye) constrained in the current window
    real(rp), allocatable :: xout(:, :, :)      !< (3, 0:nx-1, ys:ye) output buffer
    real(rp), allocatable :: vout(:, :, :)      !< (3, 0:nx-1, ys:ye) output buffer
    real(rp), allocatable :: vals(:, :, :)      !< (6, 6, ncol) one block row of the Jacobian
    integer, allocatable :: cols(:)             !< (ncol) its local block columns
    real(rp) :: gravity(3) = 0
    logical :: clamp = .false.                  !< drop indefinite spring compression terms in P
    logical :: gauss_newton = .false.           !< Gauss-Newton energy-bending blocks in P
    logical :: moving_constraints = .false.     !< a constrained node moves in this window
    ! Newton's round-off floor (snes_converged)
    real(rp) :: snes_floor = 1.0e-6_rp          !< -nuno_snes_floor: stagnation below this relative residual is convergence
    real(rp) :: fnorm0 = 0, fnorm_prev = 0
    real(rp) :: floor_est = 0                   !< round-off floor of ||F||_2 at the last 6-dof assembly (module newton_control)
    real(rp) :: snorm_prev = 0                  !< ||update|| of the previous Newton iteration
    ! inexact Newton (module newton_forcing, -nuno_newton_forcing)
    logical :: newton_forcing = .true.          !< inner tolerance from the step's needs (reduced path)
    integer(c_int) :: guess = GUESS_AUTO        !< -nuno_inner_guess (module inner_guess)
    integer(c_int) :: guess_given = 0           !< 1: set on the command line
    real(rp) :: cquad = 0                       !< estimate of C in ||F_k+1|| ~ C ||F_k||^2; 0 at every window start
    ! singular element seen by the last residual evaluation
    integer :: nbad = 0, bad(2) = -1
    real(rp) :: t_bad = 0
    ! time integrals, advanced by the monitor over each accepted step so
    ! that they close at the method's order: Gauss-Legendre on the
    ! interpolant of bdf (order up to 6), the trapezoid rule otherwise
    logical :: gauss = .false.
    type(tVec) :: uq                            !< interpolated state (Gauss points)
    real(rp) :: t_prev = 0, pdiss_prev = 0, pcon_prev = 0
    logical :: monitor_seen = .false.           !< ts_monitor has run (its stall check)
    PetscInt :: monitor_step = 0                !< the step number it saw last
    integer :: stalled_steps = 0                !< accepted steps in a row that did not advance t
    real(rp) :: dissipated = 0                  !< dissipated energy [energy]
    real(rp) :: work_constraints = 0            !< work of the constraint reactions [energy]
    real(rp) :: mgx0 = 0                        !< sum m g . x at t = 0
    ! the time integration as used: the namelist's values after the PETSc options
    real(rp) :: dt = 0                          !< fixed (or initial) step [time]: -ts_dt, else the namelist's
    real(rp) :: t_end = 0                       !< end time [time]: -ts_max_time, else the namelist's
    logical :: fixed_step = .true.              !< -ts_adapt_type none: every step is dt unless retried
    integer :: start_order = 1                  !< Newton start of beuler: 1 linear, 3 cubic (-nuno_newton_start)
    logical :: adaptive_default = .false.       !< the TS type is -nuno_adaptive_ts_type's (no -ts_type given)
    PetscInt :: max_steps = 0                   !< -ts_max_steps: a clean end after this many steps
    ! error tolerances of adaptive steps (TSSetTolerances: scalar rtol, vector atol)
    real(rp) :: rtol = 0                        !< -ts_rtol [1]
    real(rp) :: atol_x = 0                      !< absolute tolerance of positions [length]
    real(rp) :: atol_v = 0                      !< absolute tolerance of velocities [length/time]
    real(rp) :: tstop = 0                       !< end of the current time window [time]
    PetscInt :: rejects_seen = 0                !< step rejections already answered by the monitor
    integer :: fail_newton = 0                  !< -nuno_fail_newton: Newton solves still to be declared failed
    !> -nuno_linesearch_fallback: 0 none, 1 bt, 2 l2 (the line search once a
    !> Newton solve has failed); ls_switched once it has been put in place
    integer :: ls_fallback = 0
    logical :: ls_switched = .false.
    ! progress
    real(rp) :: wall0 = 0                       !< MPI_Wtime at the start of solver_run [s]
    real(rp) :: t_written = -1                  !< time of the last output step [time]
    real(rp) :: wall_said = 0                   !< MPI_Wtime of the last line on stdout (rank 0) [s]
    logical :: stretch_warned = .false.         !< the stretch_limit warning was given
    ! checkpoints and restarts (docs/design.md, "Checkpoints")
    real(rp) :: checkpoint_walltime = 0         !< -nuno_checkpoint_walltime: a checkpoint after each [s]; 0: none
    !> time of the last checkpoint written or restarted from [time]; the
    !> run's start at first, so that the first checkpoint_interval
    !> checkpoint comes one interval after it
    real(rp) :: t_checkpoint = 0
    logical :: restarted = .false.              !< continues a checkpoint (solver_restore)
    logical :: checkpoint_current = .false.     !< the last checkpoint was written after the last output step
    real(rp) :: t_restart = 0, h_restart = 0    !< its time and next step [time]
    real(rp) :: wall_before = 0                 !< wall-clock seconds of the runs before this one [s]
    !> The restart point: the state at the last output step and what a
    !> checkpoint of it holds (keep_restart_point), written by the
    !> checkpoints that come between output steps (SIGTERM, SIGINT, the wall
    !> clock), so that their restarts repeat the run bit for bit.
    logical :: rp_valid = .false.
    type(checkpoint_t) :: rp_ck
    real(rp), allocatable :: rp_x(:, :, :), rp_v(:, :, :)  !< (3, 0:nx-1, ys:ye) [length], [length/time]
    !> rejected steps, Newton and linear iterations and retries of the runs
    !> before this one (the step count goes on in the TS itself)
    real(rp) :: counts_before(5) = 0
    !> the (collective) output error that ended the run, '' if none
    character(len=512) :: io_error = ''
    type(output_file), pointer :: out => null() !< the output file, for the wall-clock checkpoints (solver_run)
  end type app_ctx

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
    if (cfg%ny / nranks < w) then
      ierr = 1
      write(errmsg, '(a,i0,a,i0,a,i0,a,i0,a)') '&lattice: ny = ', cfg%ny, ' is too small for ', nranks, &
        ' ranks: each rank owns whole rows and needs at least ', w, ' (the halo width) of them; use at most ', &
        cfg%ny / w, ' ranks'
    end if
  end subroutine check_decomposition

  !> Create the DMDA, the lattice strip, the initial state, the Jacobian
  !> matrix and the TS. Collective.
  subroutine solver_create(ctx, cfg, ierr)
    type(app_ctx), intent(inout), target :: ctx
    type(nuno_config), intent(in) :: cfg
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: xs, ys, zs, xm, ym, zm, gxs, gys, gzs, gxm, gym, gzm, w, nc, nxp, nyp
    PetscInt, parameter :: one = 1, two = 2, six = 6, eight = 8
    type(tSNES) :: snes
    type(tTSAdapt) :: adapt
    SNESLineSearch :: linesearch
    PetscScalar, pointer :: ua(:, :, :)
    character(len=64) :: mattype
    character(len=64, kind=c_char) :: cmattype
    integer(c_int) :: jac_full, pc_lag, gn, cl, nfail, mg_interp, applied, forcing, ls_fallback, ls_given, ls_type_given
    logical :: symmetric, constant, damping

    ctx%cfg = cfg
    ctx%comm = PETSC_COMM_WORLD
    call MPI_Comm_rank(ctx%comm, ctx%rank, ierr)
    call MPI_Comm_size(ctx%comm, ctx%size, ierr)
    w = halo_width(cfg)
    nxp = cfg%nx
    nyp = cfg%ny

    ! 1 x P processes: each rank owns whole rows, ghost width 2 with bending.
    PetscCall(DMDACreate2d(ctx%comm, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DMDA_STENCIL_BOX, nxp, nyp, one, PETSC_DECIDE, six, w, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, ctx%da, ierr))
    ! nuno's own options, in an options block (so in -help): the Newton
    ! step, reduced 3-dof elimination (default) or the assembled 6-dof
    ! Jacobian (the reference for -snes_test_jacobian and small scenes),
    ! and the storage of that Jacobian: BAIJ (6 x 6 blocks) assembles and
    ! multiplies fastest; -dm_mat_type aij for field splits.
    jac_full = 0
    pc_lag = 0                     ! the default: 3 with the multigrid, 1 otherwise (module reduced)
    mg_interp = 0                  ! auto: cubic with bending, linear without (module reduced)
    gn = 0
    cl = 0
    nfail = 0
    cmattype = MATBAIJ//c_null_char
    forcing = 1
    ctx%guess = GUESS_AUTO
    ierr = nuno_options_read(ctx%comm, jac_full, pc_lag, mg_interp, ctx%snes_floor, gn, cl, cmattype, len(cmattype), nfail, forcing, &
                             ctx%guess, ctx%guess_given)
    if (ierr /= 0) return
    ctx%newton_forcing = forcing /= 0
    ctx%use_reduced = jac_full == 0
    ! -pc_type lu and friends on the path in use (before anything reads them)
    ierr = nuno_petsc_habits(ctx%comm, merge(1_c_int, 0_c_int, ctx%use_reduced), cmattype, len(cmattype))
    if (ierr /= 0) return
    if (.not. ctx%use_reduced .and. mg_interp > 0) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_mg_interpolation is for the reduced solve, not -nuno_jacobian full')
    end if
    ctx%gauss_newton = gn /= 0
    ctx%clamp = cl /= 0
    ctx%fail_newton = nfail
    ls_fallback = 1
    ierr = nuno_linesearch_options_read(ctx%comm, ls_fallback, ls_given, ls_type_given)
    if (ierr /= 0) return
    if (ls_given /= 0 .and. .not. ctx%use_reduced) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_linesearch_fallback is for the reduced path; with -nuno_jacobian full Newton backtracks (bt) from the start')
    end if
    if (ls_given /= 0 .and. ls_type_given /= 0) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(ctx%comm, ierr, 'nuno: -nuno_linesearch_fallback and -snes_linesearch_type: give one (the first changes the line search after a failed Newton solve, the second sets it for the whole run)')
    end if
    ctx%ls_fallback = 0
    if (ctx%use_reduced .and. ls_type_given == 0) ctx%ls_fallback = ls_fallback
    mattype = cmattype(1:index(cmattype, c_null_char) - 1)
    PetscCall(DMSetMatType(ctx%da, mattype, ierr))
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
    if (xs /= 0 .or. xm /= cfg%nx .or. gys /= ctx%lat%gys .or. gys + gym - 1 /= ctx%lat%gye) then
      ierr = PETSC_ERR_PLIB
      SETERRQ(ctx%comm, ierr, 'nuno: the DMDA is not split into strips of whole rows')
    end if
    allocate(ctx%f(3, 0:cfg%nx - 1, ctx%lat%gys:ctx%lat%gye))
    allocate(ctx%fixed(0:cfg%nx - 1, ys:ys + ym - 1))
    allocate(ctx%xout(3, 0:cfg%nx - 1, ys:ys + ym - 1), ctx%vout(3, 0:cfg%nx - 1, ys:ys + ym - 1))
    ctx%gravity = merge(cfg%gravity, [0.0_rp, 0.0_rp, 0.0_rp], cfg%has_gravity)
    ctx%fixed = .false.

    ! Initial state and constraints of the scene.
    PetscCall(DMCreateGlobalVector(ctx%da, ctx%u, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, ctx%u, ua, ierr))
    call scene_setup(cfg, ctx%lat, ua, ctx%cs)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, ctx%u, ua, ierr))

    if (ctx%use_reduced) then
      ! S is symmetric when K and C are: no moving dampers (linear springs
      ! have constant ones), no paper bending, no bending damping.
      damping = cfg%has_damping .or. (cfg%bending_code == BEND_ENERGY .and. cfg%eta_b /= 0.0_rp)
      symmetric = (cfg%spring_code == SPRING_LINEAR .or. .not. cfg%has_damping) .and. &
                  (cfg%bending_code == BEND_NONE .or. (cfg%bending_code == BEND_ENERGY .and. &
                   (cfg%eta_b == 0.0_rp .or. ctx%gauss_newton)))
      constant = cfg%spring_code == SPRING_LINEAR .and. cfg%bending_code == BEND_NONE
      PetscCall(reduced_create(ctx%red, ctx%da, ctx%lat, symmetric, constant, damping, ctx%clamp, ctx%gauss_newton, pc_lag, ierr, mg_interpolation=mg_interp))
    else
      ! Jacobian with the DMDA's exact box-stencil preallocation.
      PetscCall(DMCreateMatrix(ctx%da, ctx%p, ierr))
      PetscCall(MatSetOption(ctx%p, MAT_ROW_ORIENTED, PETSC_FALSE, ierr))
      call jac_buffer_init(ctx%jbuf, ctx%lat)
      nc = (2 * w + 1)**2
      allocate(ctx%vals(6, 6, nc), ctx%cols(nc))
    end if

    ! The report's scheme by default: backward Euler with the namelist's
    ! fixed step; any implicit TS type and adaptivity through the options.
    PetscCall(TSCreate(ctx%comm, ctx%ts, ierr))
    PetscCall(TSSetDM(ctx%ts, ctx%da, ierr))
    PetscCall(TSSetProblemType(ctx%ts, TS_NONLINEAR, ierr))
    PetscCall(TSSetType(ctx%ts, TSBEULER, ierr))
    PetscCall(TSSetIFunction(ctx%ts, PETSC_NULL_VEC, form_ifunction, ctx, ierr))
    if (ctx%use_reduced) then
      PetscCall(TSSetIJacobian(ctx%ts, ctx%red%jac, ctx%red%jac, form_ijacobian, ctx, ierr))
    else
      PetscCall(TSSetIJacobian(ctx%ts, ctx%p, ctx%p, form_ijacobian, ctx, ierr))
    end if
    PetscCall(TSSetTime(ctx%ts, 0.0_rp, ierr))
    PetscCall(TSSetTimeStep(ctx%ts, cfg%dt, ierr))
    PetscCall(TSSetMaxTime(ctx%ts, cfg%t_end, ierr))
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
    if (ctx%use_reduced) then
      PetscCall(reduced_attach(ctx%red, snes, ierr))
      ! The full step is exact in x and Newton-exact in v: no backtracking by
      ! default (bt needs a Jacobian product, an extra pass over the
      ! elements, for every Newton iteration); -snes_linesearch_type bt works.
      PetscCall(SNESGetLineSearch(snes, linesearch, ierr))
      PetscCall(SNESLineSearchSetType(linesearch, SNESLINESEARCHBASIC, ierr))
    end if
    ! An adaptive run without -ts_type: the method that won the
    ! work-precision measurement at moderate tolerance (nuno_options.c). The
    ! identification and the control keep beuler: their adjoint needs a theta method.
    ctx%adaptive_default = .false.
    if (.not. (cfg%identify .or. cfg%control)) then
      ierr = nuno_adaptive_default(ctx%comm, ctx%ts%v, applied)
      if (ierr /= 0) return
      ctx%adaptive_default = applied /= 0
    end if
    ierr = nuno_step_defaults(ctx%ts%v, merge(1_c_int, 0_c_int, ctx%use_reduced))
    if (ierr /= 0) return
    PetscCall(TSSetFromOptions(ctx%ts, ierr))
    PetscCall(effective_time_integration(ctx, ierr))
  end subroutine solver_create

  !> Read back what the options made of the time integration, so that the
  !> run, the start-up line and the output file use the values actually in
  !> force: -ts_dt overrides the namelist's dt, -ts_max_time its t_end,
  !> -ts_max_steps ends the run early (complete). Options the time loop
  !> cannot honour are refused here. Collective.
  subroutine effective_time_integration(ctx, ierr)
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    type(tTSAdapt) :: adapt
    TSExactFinalTimeOption :: eft
    PetscBool :: match
    character(len=64) :: tstype, adtype
    character(len=64, kind=c_char) :: scheme
    character(len=512) :: line, inner
    character(len=64) :: sntype
    type(tSNES) :: snes
    character(len=40) :: srcx, srcv
    real(rp) :: dt_namelist, t_end_namelist

    dt_namelist = ctx%cfg%dt
    t_end_namelist = ctx%cfg%t_end
    PetscCall(TSGetTimeStep(ctx%ts, ctx%dt, ierr))
    PetscCall(TSGetMaxTime(ctx%ts, ctx%t_end, ierr))
    PetscCall(TSGetMaxSteps(ctx%ts, ctx%max_steps, ierr))
    PetscCall(TSGetExactFinalTime(ctx%ts, eft, ierr))
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    PetscCall(PetscObjectTypeCompare(adapt, TSADAPTNONE, match, ierr))
    ctx%fixed_step = match
    ! The time loop stops exactly at output, keyframe and release times.
    if (eft /= TS_EXACTFINALTIME_MATCHSTEP) then
      ierr = PETSC_ERR_ARG_WRONG
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_exact_final_time must be matchstep: the run stops exactly at every output, keyframe and release time')
    end if
    if (.not. (ctx%dt > 0.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_dt must be > 0')
    end if
    if (.not. (ctx%t_end > 0.0_rp) .or. ctx%t_end > huge(1.0_rp)) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_max_time must be > 0 and finite')
    end if
    if (ctx%max_steps < 0) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(ctx%comm, ierr, 'nuno: -ts_max_steps must be >= 0')
    end if
    ! From here on the effective values are the run's configuration.
    ctx%cfg%dt = ctx%dt
    ctx%cfg%t_end = ctx%t_end
    ! The energy integrals close at the method's order: the trapezoid rule
    ! over each step (one power pass a step) is second order, enough for
    ! beuler, theta and cn (order <= 2); bdf (up to order 6) gets three
    ! Gauss-Legendre points on its interpolant, the Lagrange polynomial of
    ! its history (three passes a step). arkimex and rosw tableaus may lack
    ! an interpolant: trapezoid.
    PetscCall(TSGetType(ctx%ts, tstype, ierr))
    ctx%gauss = trim(tstype) == 'bdf'
    PetscCall(set_inner_guess(ctx, tstype, ierr))
    PetscCall(set_newton_start(ctx, ierr))
    PetscCall(VecDuplicate(ctx%u, ctx%uq, ierr))
    PetscCall(set_tolerances(ctx, srcx, srcv, ierr))

    ierr = nuno_ts_scheme(ctx%ts%v, scheme, len(scheme))
    if (ierr /= 0) return
    inner = ''
    if (ctx%use_reduced) then
      PetscCall(reduced_describe(ctx%red, inner, ierr))
      PetscCall(TSGetSNES(ctx%ts, snes, ierr))
      PetscCall(SNESGetType(snes, sntype, ierr))
      if (trim(sntype) == SNESNEWTONLS .and. ctx%newton_forcing .and. ctx%red%forward_ew) &
        inner = trim(inner)//'; Newton: inner rtol from the step''s needs (-nuno_newton_forcing)'
    end if
    if (ctx%rank == 0) then
      PetscCall(TSAdaptGetType(adapt, adtype, ierr))
      line = 'solver    : TS '//scheme(1:index(scheme, c_null_char) - 1)
      if (ctx%adaptive_default) line = trim(line)//' (the default of adaptive runs, -nuno_adaptive_ts_type)'
      line = trim(line)//', adapt '//trim(adtype)
      if (ctx%fixed_step) then
        line = trim(line)//', dt = '//num(ctx%dt)
      else
        line = trim(line)//', initial dt = '//num(ctx%dt)
      end if
      if (ctx%dt /= dt_namelist) line = trim(line)//' (-ts_dt; namelist '//num(dt_namelist)//')'
      line = trim(line)//', t_end = '//num(ctx%t_end)
      if (ctx%t_end /= t_end_namelist) &
        line = trim(line)//' (-ts_max_time; namelist '//num(t_end_namelist)//')'
      if (ctx%max_steps < huge(ctx%max_steps)) &
        line = trim(line)//', at most '//inum(ctx%max_steps)//' steps (-ts_max_steps)'
      if (.not. ctx%fixed_step) line = trim(line)//', rtol '//num(ctx%rtol)//', atol position '// &
        num(ctx%atol_x)//' ('//trim(srcx)//'), velocity '//num(ctx%atol_v)//' ('//trim(srcv)//')'
      line = trim(line)//', Newton step '//trim(merge('reduced', 'full   ', ctx%use_reduced))
      if (ctx%start_order == 3) line = trim(line)//', started cubic (-nuno_newton_start)'
      write(output_unit, '(a)') trim(line)
      if (ctx%use_reduced) write(output_unit, '(a)') 'inner     : '//trim(inner)
      flush(output_unit)
    end if
  end subroutine effective_time_integration

  !> Newton's start (-nuno_newton_start, src/nuno_newton_start.c): auto
  !> is the cubic start for Newton with beuler at fixed steps (hang 257 x
  !> 257: one Newton iteration a step instead of two, commit 9f1bf04;
  !> the linear start where its residual is the
  !> smaller, as in a membrane's transient), the linear one of PETSc (x_n + dt xdot_n)
  !> elsewhere: in the Baraff-Witkin mode (-snes_type ksponly) the start
  !> is the point of the one linearisation and its residual the scale of
  !> the solve's tolerance (163 -> 189 inner iterations over 30 steps
  !> there), adaptive steps change dt, and identification and control
  !> runs keep their trajectories as they were.
  subroutine set_newton_start(ctx, ierr)
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    character(len=64) :: sntype
    integer(c_int) :: auto_cubic, order
    PetscCall(TSGetSNES(ctx%ts, snes, ierr))
    PetscCall(SNESGetType(snes, sntype, ierr))
    auto_cubic = merge(1_c_int, 0_c_int, ctx%fixed_step .and. trim(sntype) /= SNESKSPONLY .and. &
                       .not. (ctx%cfg%identify .or. ctx%cfg%control))
    ierr = nuno_newton_start_setup(ctx%ts%v, auto_cubic, order)
    ctx%start_order = order
  end subroutine set_newton_start

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
      PetscCall(KSPGetType(ctx%red%ksp, ktype, ierr))
      direct = ktype == KSPPREONLY
    end if
    if (ctx%guess_given /= 0 .and. ctx%guess /= GUESS_NONE .and. ctx%guess /= GUESS_AUTO) then
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
    mode = ctx%guess
    ! (auto leaves the fits alone: their finite-difference checks compare
    ! runs whose inexact solves would otherwise start from other guesses)
    ! The projection drops its kept solves whenever dt changes, so with
    ! adaptive steps it would rarely have any: the extrapolation, which
    ! scales across steps of other sizes, there.
    if (mode == GUESS_AUTO) mode = merge(merge(GUESS_PROJECT, GUESS_EXTRAPOLATE, ctx%fixed_step), GUESS_NONE, one_stage .and. &
                                         ctx%cfg%bending_code /= BEND_NONE .and. .not. (ctx%cfg%identify .or. ctx%cfg%control))
    if (.not. one_stage .or. direct) mode = GUESS_NONE
    ctx%guess = mode
    ! (nuno_step_defaults put the extrapolated start of beuler in the options)
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

    PetscCall(TSGetTolerances(ctx%ts, atol, PETSC_NULL_VEC, rtol, PETSC_NULL_VEC, ierr))
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_atol', atol_given, ierr))
    if (atol_given) then
      ax = atol
      srcx = '-ts_atol'
    else
      ax = rtol * max(ctx%cfg%lx, ctx%cfg%ly)
      srcx = 'rtol x cloth size'
    end if
    av = ax / TOLERANCE_TIME
    ierr = nuno_tolerance_options_read(ctx%comm, ax, av, gx, gv)
    if (ierr /= 0) return
    if (gx /= 0) srcx = '-nuno_atol_position'
    srcv = 'position atol / 1 time unit'
    if (gv /= 0) srcv = '-nuno_atol_velocity'
    ctx%rtol = rtol
    ctx%atol_x = ax
    ctx%atol_v = av
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
    PetscCall(TSDestroy(ctx%ts, ierr))
    if (ctx%use_reduced) then
      PetscCall(reduced_destroy(ctx%red, ierr))
    else
      PetscCall(MatDestroy(ctx%p, ierr))
    end if
    PetscCall(VecDestroy(ctx%u, ierr))
    PetscCall(VecDestroy(ctx%uq, ierr))
    PetscCall(DMDestroy(ctx%da, ierr))
  end subroutine solver_destroy

  ! ---------------------------------------------------------------- callbacks

  !> F(t, U, Udot) (see the module header).
  subroutine form_ifunction(ts, t, uvec, udotvec, fvec, ctx, ierr)
    type(tTS) :: ts
    PetscReal :: t
    type(tVec) :: uvec, udotvec, fvec
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :), ud(:, :, :), fv(:, :, :)

    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, udotvec, ud, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, fvec, fv, ierr))
    call residual(ctx, t, u, ud, fv)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, fvec, fv, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, udotvec, ud, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
  end subroutine form_ifunction

  !> The residual on plain arrays. A singular element (zero-length link,
  !> bending triple at pi) makes the residual NaN, so that SNES fails the
  !> step collectively; ctx%nbad says why.
  subroutine residual(ctx, t, u, ud, fv)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:5, 0:ctx%lat%nx - 1, ctx%lat%gys:ctx%lat%gye)
    real(rp), intent(in) :: ud(0:5, 0:ctx%lat%nx - 1, ctx%lat%ys:ctx%lat%ye)
    real(rp), intent(out) :: fv(0:5, 0:ctx%lat%nx - 1, ctx%lat%ys:ctx%lat%ye)
    integer :: i, j, k, nbad, bad(2)
    real(rp) :: xb(3), vb(3)

    call internal_forces(ctx%lat, u, ctx%f, nbad, bad)
    do j = ctx%lat%ys, ctx%lat%ye
      do i = 0, ctx%lat%nx - 1
        fv(0:2, i, j) = ud(0:2, i, j) - u(3:5, i, j)
        fv(3:5, i, j) = ud(3:5, i, j) - ctx%f(:, i, j) / ctx%lat%mass(i, j) - ctx%gravity
      end do
    end do
    if (ctx%cs%active) then
      do k = 1, ctx%cs%n
        call constraint_target(ctx%cs, k, t, xb, vb)
        i = ctx%cs%node(1, k)
        j = ctx%cs%node(2, k)
        fv(0:2, i, j) = ud(0:2, i, j) - vb
        fv(3:5, i, j) = ud(3:5, i, j)
      end do
    end if
    if (nbad > 0) then
      ctx%nbad = nbad
      ctx%bad = bad
      ctx%t_bad = t
      fv(0, 0, ctx%lat%ys) = ieee_nan()
    end if
  end subroutine residual

  !> dF/dU + a dF/dUdot (v-rows: -K/m and a I - C/m), assembled row by row from the rolling buffer of
  !> element blocks: one MatSetValuesBlockedLocal per node, INSERT_VALUES
  !> over the whole preallocated stencil (so no MatZeroEntries is needed).
  subroutine form_ijacobian(ts, t, uvec, udotvec, a, jmat, pmat, ctx, ierr)
    type(tTS) :: ts
    PetscReal :: t, a
    type(tVec) :: uvec, udotvec
    type(tMat) :: jmat, pmat
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    type(tVec) :: uloc, udloc
    PetscScalar, pointer :: u(:, :, :), ud(:, :, :)
    integer :: ja, i, q
    real(rp) :: kd(3), sums(2), gsums(2)

    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    if (ctx%use_reduced) then
      PetscCall(DMGetLocalVector(ctx%da, udloc, ierr))
      PetscCall(DMGlobalToLocalBegin(ctx%da, udotvec, INSERT_VALUES, udloc, ierr))
      PetscCall(DMGlobalToLocalEnd(ctx%da, udotvec, INSERT_VALUES, udloc, ierr))
      PetscCall(DMDAVecGetArrayReadF90(ctx%da, udloc, ud, ierr))
      PetscCall(reduced_assemble(ctx%red, u, ud, a, ierr))
      PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, udloc, ud, ierr))
      PetscCall(DMRestoreLocalVector(ctx%da, udloc, ierr))
      PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
      PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
      PetscCall(MatAssemblyBegin(jmat, MAT_FINAL_ASSEMBLY, ierr))
      PetscCall(MatAssemblyEnd(jmat, MAT_FINAL_ASSEMBLY, ierr))
      return
    end if
    ctx%jbuf%k = 0.0_rp
    ctx%jbuf%c = 0.0_rp
    sums = 0.0_rp
    do ja = first_anchor_row(ctx%lat), ctx%lat%ye
      call jac_buffer_row(ctx%jbuf, ctx%lat, u, ja, ctx%clamp, ctx%gauss_newton)
      if (ja >= ctx%lat%ys) then
        PetscCall(insert_row(ctx, pmat, ja, a, ierr))
        ! the round-off floor of F from this assembly, as the reduced path
        ! takes it from S (module newton_control)
        do i = 0, ctx%lat%nx - 1
          if (ctx%fixed(i, ja)) cycle
          do q = 1, 3
            kd(q) = ctx%jbuf%k(q, q, 0, 0, i, slot_of(ja))
          end do
          call floor_node_add(kd, ctx%lat%mass(i, ja), u(0:2, i, ja), a, sums)
        end do
      end if
      ctx%jbuf%k(:, :, :, :, :, slot_of(ja)) = 0.0_rp
      ctx%jbuf%c(:, :, :, :, :, slot_of(ja)) = 0.0_rp
    end do
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
    call MPI_Allreduce(sums(1), gsums(1), 1, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    call MPI_Allreduce(sums(2), gsums(2), 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    ctx%floor_est = floor_estimate(gsums)
    PetscCall(MatAssemblyBegin(pmat, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatAssemblyEnd(pmat, MAT_FINAL_ASSEMBLY, ierr))
    if (jmat%v /= pmat%v) then
      PetscCall(MatAssemblyBegin(jmat, MAT_FINAL_ASSEMBLY, ierr))
      PetscCall(MatAssemblyEnd(jmat, MAT_FINAL_ASSEMBLY, ierr))
    end if
  end subroutine form_ijacobian

  !> Insert the complete block rows of node row j.
  subroutine insert_row(ctx, pmat, j, a, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tMat) :: pmat
    integer, intent(in) :: j
    real(rp), intent(in) :: a
    PetscErrorCode, intent(out) :: ierr
    integer :: i, di, dj, w, nc, s, q
    PetscInt :: row(1), ncol
    real(rp) :: minv

    w = ctx%jbuf%w
    s = slot_of(j)
    ierr = 0
    do i = 0, ctx%lat%nx - 1
      minv = 1.0_rp / ctx%lat%mass(i, j)
      nc = 0
      do dj = -w, w
        if (j + dj < 0 .or. j + dj >= ctx%lat%ny) cycle
        do di = -w, w
          if (i + di < 0 .or. i + di >= ctx%lat%nx) cycle
          nc = nc + 1
          ctx%cols(nc) = (i + di) + (j + dj - ctx%lat%gys) * ctx%lat%nx
          ctx%vals(:, :, nc) = 0.0_rp
          if (ctx%fixed(i, j)) then
            if (di == 0 .and. dj == 0) then
              do q = 1, 6
                ctx%vals(q, q, nc) = a
              end do
            end if
            cycle
          end if
          ctx%vals(4:6, 1:3, nc) = ctx%jbuf%k(:, :, di, dj, i, s) * minv
          ctx%vals(4:6, 4:6, nc) = ctx%jbuf%c(:, :, di, dj, i, s) * minv
          if (di == 0 .and. dj == 0) then
            do q = 1, 3
              ctx%vals(q, q, nc) = a
              ctx%vals(q, q + 3, nc) = -1.0_rp
              ctx%vals(q + 3, q + 3, nc) = ctx%vals(q + 3, q + 3, nc) + a
            end do
          end if
        end do
      end do
      row(1) = i + (j - ctx%lat%gys) * ctx%lat%nx
      ncol = nc
      PetscCall(set_block_row(pmat, row, ncol, ctx%cols, ctx%vals, 36 * nc, ierr))
    end do
  end subroutine insert_row

  !> PETSc's residual test, plus the round-off floor of the residual, which
  !> grows with stiffness over mass (like N^5 for hang refined: 1.3e-5 at
  !> 129 x 129, 1.2e-2 at 513 x 513 against initial residuals of 1e3):
  !> Newton cannot go below it, and snes_rtol = 1e-8 would fail good steps.
  !> The same rule on both paths (module newton_control's floor_verdict),
  !> with the floor estimated at the last assembly of S (reduced; measured
  !> 14 times the actual floor at 129..513) or of the 6-dof Jacobian (full):
  !> converged is (a) a residual below snes_floor times its initial value
  !> or below the floor estimate that an iteration no longer reduces by
  !> 10 %, (b) a residual below FLOOR_FACTOR times the floor estimate, which
  !> saves the iteration that (a) needs, or (a') a line search that found
  !> no decrease (bt, the 6-dof path's default, or the reduced path's
  !> fallback) from a residual where (a) would stop: at the floor no step
  !> decreases ||F||. Any other failed line search diverges, as in PETSc.
  !> With adaptive steps also (c): the Newton error estimated from the
  !> update and the convergence rate, |du_k| rate/(1 - rate) in the time
  !> integrator's weighted norm (atol + rtol |u|), is below
  !> NEWTON_TS_FRACTION of the tolerance (the test of CVODE and IDA). Tight
  !> -ts_rtol shrinks the step, and with it the floor of F's x-rows
  !> (eps a |x|, a = 1/dt) grows past any residual test: (c) ties Newton to
  !> what the integrator asks for. It needs two iterations (a rate) and a
  !> rate below 0.9, so a stalled solve (a weak preconditioner, small but
  !> not shrinking updates) is not mistaken for a converged one.
  subroutine snes_converged(snes, it, xnorm, snorm, fnorm, reason, ctx, ierr)
    type(tSNES) :: snes
    PetscInt :: it
    PetscReal :: xnorm, snorm, fnorm
    SNESConvergedReason :: reason
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    real(rp) :: rate, wnorm, floor_est
    integer :: verdict
    SNESLineSearchReason :: lsreason
    call SNESConvergedDefault(snes, it, xnorm, snorm, fnorm, reason, PETSC_NULL_INTEGER, ierr)
    if (ierr /= 0) return
    if (it == 0 .and. ctx%fail_newton > 0) then
      ! -nuno_fail_newton (tests): the same decision on every rank.
      ctx%fail_newton = ctx%fail_newton - 1
      reason = SNES_DIVERGED_FUNCTION_DOMAIN
    else if (it == 0) then
      ctx%fnorm0 = fnorm
    else if (reason == SNES_CONVERGED_ITERATING) then
      PetscCall(line_search_reason(snes, lsreason, ierr))
      if (lsreason /= LS_SUCCEEDED .and. lsreason /= LS_FAILED_REDUCT) then
        reason = SNES_DIVERGED_LINE_SEARCH        ! NaN, domain error: PETSc's own verdict
      else
        floor_est = merge(ctx%red%floor_est, ctx%floor_est, ctx%use_reduced)
        verdict = floor_verdict(fnorm, ctx%fnorm_prev, ctx%fnorm0, ctx%snes_floor, floor_est, &
                                lsreason == LS_FAILED_REDUCT)
        if (verdict == NEWTON_CONVERGED) then
          reason = SNES_CONVERGED_FNORM_ABS
        else if (verdict == NEWTON_DIVERGED) then
          reason = SNES_DIVERGED_LINE_SEARCH
        end if
      end if
    end if
    if (it >= 2 .and. reason == SNES_CONVERGED_ITERATING .and. .not. ctx%fixed_step .and. ctx%snorm_prev > 0.0_rp) then
      rate = snorm / ctx%snorm_prev
      if (rate < 0.9_rp) then
        call update_wrms(snes, ctx, wnorm, ierr)
        if (ierr /= 0) return
        if (wnorm * rate / (1.0_rp - rate) <= NEWTON_TS_FRACTION) reason = SNES_CONVERGED_SNORM_RELATIVE
      end if
    end if
    if (reason == SNES_CONVERGED_ITERATING .and. ctx%use_reduced .and. ctx%newton_forcing) then
      PetscCall(set_newton_forcing(snes, it, fnorm, ctx, ierr))
    end if
    ctx%fnorm_prev = fnorm
    ctx%snorm_prev = snorm
  end subroutine snes_converged

  !> The reason of this Newton iteration's line search (LS_SUCCEEDED for a
  !> SNES without one). PETSc's Newton hands the convergence test an
  !> iteration whose search failed only while fewer than -snes_max_fail
  !> searches have failed (solver_create sets 2), with the residual from
  !> before the search.
  subroutine line_search_reason(snes, lsreason, ierr)
    type(tSNES) :: snes
    SNESLineSearchReason, intent(out) :: lsreason
    PetscErrorCode, intent(out) :: ierr
    SNESLineSearch :: ls
    character(len=64) :: sntype
    lsreason = LS_SUCCEEDED
    PetscCall(SNESGetType(snes, sntype, ierr))
    if (sntype /= SNESNEWTONLS) return
    PetscCall(SNESGetLineSearch(snes, ls, ierr))
    PetscCall(SNESLineSearchGetReason(ls, lsreason, ierr))
  end subroutine line_search_reason

  !> The inner tolerance of the coming Newton iteration's solve (module
  !> newton_forcing): no tighter than the Newton remainder C ||F||^2 that
  !> the step leaves anyway, nor than half the residual at which
  !> snes_converged stops: max(snes_atol, snes_rtol ||F_0||, and on this
  !> path FLOOR_FACTOR times the round-off floor of the last assembly). C
  !> comes from the iterations before that did not converge (at the floor
  !> ||F|| says nothing about it), in this window; the bounds are the inner
  !> solver's own rtol (never tighter than without this) and 0.1. The
  !> reduced solve uses it unless -snes_ksp_ew or -reduced_ksp_rtol is given.
  subroutine set_newton_forcing(snes, it, fnorm, ctx, ierr)
    type(tSNES) :: snes
    PetscInt, intent(in) :: it
    PetscReal, intent(in) :: fnorm
    type(app_ctx), intent(inout) :: ctx
    PetscErrorCode, intent(out) :: ierr
    real(rp), parameter :: ETA_MAX = 0.1_rp
    PetscReal :: atol, rtol, stol
    PetscInt :: maxit, maxf
    real(rp) :: target

    PetscCall(SNESGetTolerances(snes, atol, rtol, stol, maxit, maxf, ierr))
    if (it >= 1) ctx%cquad = quadratic_constant(ctx%fnorm_prev, fnorm, ctx%red%lin_rel)
    target = max(atol, rtol * ctx%fnorm0)
    if (ctx%snes_floor > 0.0_rp) target = max(target, FLOOR_FACTOR * ctx%red%floor_est)
    ctx%red%eta = forcing_term(fnorm, target, ctx%cquad, ctx%red%rtol0, ETA_MAX)
  end subroutine set_newton_forcing

  !> The last Newton update in the weighted RMS norm of the time integrator:
  !> sqrt(mean((du_i / (atol_i + rtol_i |u_i|))^2)) over all unknowns: the
  !> tolerances of set_tolerances, atol_x alone on positions, atol_v +
  !> rtol |v| on velocities.
  subroutine update_wrms(snes, ctx, wnorm, ierr)
    type(tSNES) :: snes
    type(app_ctx) :: ctx
    real(rp), intent(out) :: wnorm
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: x, y
    PetscScalar, pointer :: xa(:), ya(:)
    real(rp) :: loc(2), glob(2)
    integer :: mpierr, k

    wnorm = huge(1.0_rp)
    PetscCall(SNESGetSolution(snes, x, ierr))
    PetscCall(SNESGetSolutionUpdate(snes, y, ierr))
    PetscCall(VecGetArrayReadF90(x, xa, ierr))
    PetscCall(VecGetArrayReadF90(y, ya, ierr))
    ! The vector atol of set_tolerances: the 6 dofs of a node are stored
    ! together, positions first.
    loc(1) = 0.0_rp
    do k = 1, size(xa)
      if (mod(k - 1, 6) < 3) then
        loc(1) = loc(1) + (ya(k) / ctx%atol_x)**2
      else
        loc(1) = loc(1) + (ya(k) / (ctx%atol_v + ctx%rtol * abs(xa(k))))**2
      end if
    end do
    loc(2) = real(size(xa), rp)
    PetscCall(VecRestoreArrayReadF90(y, ya, ierr))
    PetscCall(VecRestoreArrayReadF90(x, xa, ierr))
    call MPI_Allreduce(loc, glob, 2, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, mpierr)
    if (glob(2) > 0.0_rp) wnorm = sqrt(glob(1) / glob(2))
  end subroutine update_wrms

  !> After every accepted step (and at the start of each TSSolve): keep its
  !> first Newton correction for the inner guesses, advance the integrals
  !> of dissipated power and constraint power, and after a retried step go
  !> back to the fixed step.
  subroutine ts_monitor(ts, step, t, uvec, ctx, ierr)
    type(tTS) :: ts
    PetscInt :: step
    PetscReal :: t
    type(tVec) :: uvec
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    real(rp) :: p(2), h, hmax, tq, pq(2)
    PetscInt :: rejects, nfails
    integer :: q
    real(c_double) :: tc

    ! A failed Newton solve makes the TS retry the step with dt/4, and with
    ! -ts_adapt_type none it keeps that step: a fixed step would silently
    ! stay 4 times smaller. Once the retried step is accepted, return to dt,
    ! clipped to the window end as PETSc's matchstep does (no sliver step).
    ! Accepted steps that do not advance t (retries shrank them below t's
    ! resolution next to a stop time) could repeat forever: after ten in a
    ! row, stop and say so (one alone, after many retries, is harmless).
    if (ctx%monitor_seen .and. step > ctx%monitor_step) then
      if (t > ctx%t_prev) then
        ctx%stalled_steps = 0
      else
        ctx%stalled_steps = ctx%stalled_steps + 1
      end if
      if (ctx%stalled_steps >= 10) then
        if (len_trim(ctx%io_error) == 0) then
          PetscCall(TSGetTimeStep(ts, h, ierr))
          ctx%io_error = 'ten accepted steps at t = '//num(t)//' did not advance t: the step, '//num(h)// &
            ', is below the resolution of t there ('//num(spacing(t))//'); the run cannot advance (a larger -ts_dt;'// &
            ' after failed solves, adaptive steps: -ts_adapt_type basic)'
          if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(ctx%io_error)
        end if
        ierr = nuno_ts_stop(ts%v)
        return
      end if
    end if
    ctx%monitor_seen = .true.
    ctx%monitor_step = step
    ! After a failed Newton solve (its step retried smaller and now
    ! accepted) the run's remaining steps take -nuno_linesearch_fallback
    ! instead of full steps: a membrane without bending that buckles at the
    ! lattice's scale can make full Newton steps overshoot again and again
    ! (hang 257 x 257, dt = 1 ms: eight failures and the run stopped at
    ! t = 0.21 s). It costs nothing until then (bt: a product with the
    ! 6-dof Jacobian an iteration, for its slope). A run restarted from a
    ! checkpoint after such a failure (counts_before) backtracks from its
    ! first step, as the run it continues did.
    if (ctx%ls_fallback > 0 .and. .not. ctx%ls_switched) then
      PetscCall(TSGetSNESFailures(ts, nfails, ierr))
      if (nfails + nint(ctx%counts_before(5)) > 0) then
        PetscCall(linesearch_fallback(ts, ctx, t, ierr))
      end if
    end if
    ! the accepted step's first Newton correction, for the next inner guesses
    if (ctx%use_reduced) call reduced_step_accepted(ctx%red)
    ! and its state, for the next Newton start
    tc = t
    ierr = nuno_newton_start_push(ts%v, uvec%v, tc)
    if (ierr /= 0) return
    PetscCall(TSGetStepRejections(ts, rejects, ierr))
    if (rejects > ctx%rejects_seen) then
      ctx%rejects_seen = rejects
      if (ctx%fixed_step) then
        PetscCall(TSGetTimeStep(ts, h, ierr))
        hmax = ctx%tstop - t
        if (h < ctx%dt .and. hmax > 0.0_rp) then
          h = ctx%dt
          if (t + 1.01_rp * h >= ctx%tstop) then
            h = hmax
          else if (2.0_rp * h > hmax) then
            h = 0.5_rp * hmax
          end if
          PetscCall(TSSetTimeStep(ts, h, ierr))
        end if
      end if
    end if

    if (ctx%gauss) then
      ! Three Gauss-Legendre points on [t_prev, t] (exact to degree 5): the
      ! error is that of the interpolant, the method's order. (The end
      ! point's power is not needed.)
      if (t > ctx%t_prev .and. step > 0) then
        h = t - ctx%t_prev
        do q = 1, 3
          tq = ctx%t_prev + h * GAUSS_X(q)
          PetscCall(TSInterpolate(ts, tq, ctx%uq, ierr))
          call powers(ctx, ctx%uq, tq, pq, ierr)
          if (ierr /= 0) return
          ctx%dissipated = ctx%dissipated + h * GAUSS_W(q) * pq(1)
          ctx%work_constraints = ctx%work_constraints + h * GAUSS_W(q) * pq(2)
        end do
      end if
    else
      call powers(ctx, uvec, t, p, ierr)
      if (ierr /= 0) return
      if (t > ctx%t_prev) then
        ctx%dissipated = ctx%dissipated + 0.5_rp * (ctx%pdiss_prev + p(1)) * (t - ctx%t_prev)
        ctx%work_constraints = ctx%work_constraints + 0.5_rp * (ctx%pcon_prev + p(2)) * (t - ctx%t_prev)
      end if
      ctx%pdiss_prev = p(1)
      ctx%pcon_prev = p(2)
    end if
    ctx%t_prev = t
    ! A long output interval (tiny adaptive steps on a stiff scene) must not
    ! look like a hang: rank 0 says where it is every HEARTBEAT_S of wall
    ! time (TS values only, so nothing collective).
    if (ctx%rank == 0 .and. step > 0) then
      if (MPI_Wtime() - ctx%wall_said >= HEARTBEAT_S) then
        PetscCall(TSGetTimeStep(ts, h, ierr))
        write(output_unit, '(a,es12.5e2,a,i9,a,es10.3e2,a,es10.3e2,a)') '  ... t =', t, '  steps', step, &
          '  dt', h, '  wall_s', MPI_Wtime() - ctx%wall0, '  (between output steps)'
        flush(output_unit)
        ctx%wall_said = MPI_Wtime()
      end if
    end if
    ! -nuno_checkpoint_walltime: due after this step (agreed by the
    ! post-step, which runs before the monitor); written here without
    ! stopping TSSolve, so that the run goes on exactly as without it: the
    ! restart point of the last output step (keep_restart_point; this
    ! step's state, with its energy integrals, before the first one). A
    ! failed write stops the run.
    if (nuno_checkpoint_due() /= 0) then
      PetscCall(TSGetTimeStep(ts, h, ierr))
      call take_checkpoint(ctx, ctx%out, t, h, 'wall time', ierr, restart_point=.true.)
      if (ierr /= 0) then
        ierr = 0
        if (len_trim(ctx%io_error) == 0) ctx%io_error = 'the wall-clock checkpoint at t = '//num(t)//' failed'
        ierr = nuno_ts_stop(ts%v)
      end if
    end if
  end subroutine ts_monitor

  !> Put -nuno_linesearch_fallback's line search in place of full steps
  !> (the user's other -snes_linesearch_* options apply to it) and say so
  !> once, on rank 0.
  subroutine linesearch_fallback(ts, ctx, t, ierr)
    type(tTS) :: ts
    type(app_ctx) :: ctx
    real(rp), intent(in) :: t
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    SNESLineSearch :: linesearch
    character(len=2) :: kind
    kind = merge('bt', 'l2', ctx%ls_fallback == 1)
    PetscCall(TSGetSNES(ts, snes, ierr))
    PetscCall(SNESGetLineSearch(snes, linesearch, ierr))
    PetscCall(SNESLineSearchSetType(linesearch, kind, ierr))
    PetscCall(SNESLineSearchSetFromOptions(linesearch, ierr))
    ctx%ls_switched = .true.
    if (ctx%rank == 0) write(output_unit, '(a)') 'nuno: after a failed Newton solve (its step retried smaller), line search '// &
      kind//' from t = '//num(t)//' on (-nuno_linesearch_fallback)'
  end subroutine linesearch_fallback

  !> Global dissipated power p(1) and power of the constraint reactions p(2)
  !> = -sum over moving constrained nodes of (f_internal + m g) . vbar.
  subroutine powers(ctx, uvec, t, p, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tVec) :: uvec
    real(rp), intent(in) :: t
    real(rp), intent(out) :: p(2)
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    real(rp) :: loc(2), xb(3), vb(3)
    integer :: k, i, j, nbad, bad(2)

    loc = 0.0_rp
    p = 0.0_rp
    ierr = 0
    if (.not. ctx%cfg%has_damping .and. ctx%cfg%eta_b == 0.0_rp .and. .not. ctx%moving_constraints) return
    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    call dissipated_power(ctx%lat, u, loc(1))
    if (ctx%moving_constraints) then
      call internal_forces(ctx%lat, u, ctx%f, nbad, bad)
      do k = 1, ctx%cs%n
        call constraint_target(ctx%cs, k, t, xb, vb)
        i = ctx%cs%node(1, k)
        j = ctx%cs%node(2, k)
        loc(2) = loc(2) - dot_product(ctx%f(:, i, j) + ctx%lat%mass(i, j) * ctx%gravity, vb)
      end do
    end if
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
    call MPI_Allreduce(loc, p, 2, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
  end subroutine powers

  ! ------------------------------------------------------------- time loop

  !> Set the constraints of the window [ta, tb] and move the constrained
  !> nodes onto their prescribed path; returns the jump of their kinetic
  !> energy (the work of the impulse at a keyframe). Collective.
  subroutine enter_window(ctx, ta, tb, dke, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: ta, tb
    real(rp), intent(out) :: dke
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: ua(:, :, :)
    real(rp) :: xb(3), vb(3), loc(3), m
    integer :: k, i, j

    call constraints_set_window(ctx%cs, ta, tb)
    ! The Newton remainder is learnt anew in each window, so that a run
    ! restarted at a window's start takes the same iterations as the run
    ! that went through it.
    ctx%cquad = 0.0_rp
    ctx%fixed = .false.
    loc = 0.0_rp
    PetscCall(DMDAVecGetArrayF90(ctx%da, ctx%u, ua, ierr))
    if (ctx%cs%active) then
      do k = 1, ctx%cs%n
        i = ctx%cs%node(1, k)
        j = ctx%cs%node(2, k)
        call constraint_target(ctx%cs, k, ta, xb, vb)
        m = ctx%lat%mass(i, j)
        loc(1) = loc(1) + 0.5_rp * m * (dot_product(vb, vb) - dot_product(ua(3:5, i, j), ua(3:5, i, j)))
        if (any(vb /= 0.0_rp)) loc(2) = 1.0_rp
        if (any(ua(0:2, i, j) /= xb) .or. any(ua(3:5, i, j) /= vb)) loc(3) = 1.0_rp
        ua(0:2, i, j) = xb
        ua(3:5, i, j) = vb
        ctx%fixed(i, j) = .true.
      end do
    end if
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, ctx%u, ua, ierr))
    call MPI_Allreduce(MPI_IN_PLACE, loc, 3, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    if (ctx%use_reduced) then
      PetscCall(reduced_set_fixed(ctx%red, ctx%fixed, ierr))
    end if
    ! The Newton start's kept states end here where the state jumps (a
    ! keyframe's start, a constraint's target moved); elsewhere they go on
    ! across the window's start (a checkpoint keeps them for a restart:
    ! take_checkpoint, solver_restore). Forgetting them at every window
    ! cost 12 % of hang's 1 s at 257 x 257 (1100 instead of 1005 Newton
    ! iterations, 4697 instead of 4001 inner ones).
    if (loc(3) > 0.0_rp) then
      ierr = nuno_newton_start_reset(ctx%ts%v)
      if (ierr /= 0) return
    end if
    dke = loc(1)
    ctx%moving_constraints = loc(2) > 0.0_rp
  end subroutine enter_window

  !> Integrate from t = 0 (or from the checkpoint of solver_restore) to
  !> t_end, writing every output step and the checkpoints (every
  !> checkpoint_interval at an output step, every -nuno_checkpoint_walltime
  !> after a step, on SIGTERM/SIGINT, and at the end). On a failed step,
  !> status says why and ierr = 0 (the output so far is kept); ierr /= 0
  !> is left for PETSc or HDF5 errors. -ts_max_steps ends the run early but
  !> complete, with the state of its last step written. Collective.
  subroutine solver_run(ctx, out, status, ierr)
    type(app_ctx), intent(inout), target :: ctx
    type(output_file), intent(inout), target :: out
    character(len=*), intent(out) :: status
    PetscErrorCode, intent(out) :: ierr
    real(rp), allocatable :: events(:)
    real(rp) :: t, tstop, h, dke, eps, unorm, wall
    integer :: iout, ie
    logical :: at_max_steps
    TSConvergedReason :: reason
    character(len=900) :: msg
    character(len=256) :: reasonname
    character(len=512) :: errmsg

    status = 'complete'
    ctx%wall0 = MPI_Wtime() - ctx%wall_before
    ctx%wall_said = MPI_Wtime()
    call write_run_info(ctx, out, ierr)
    if (io_failed()) return
    ctx%out => out
    call nuno_walltime_arm(real(ctx%checkpoint_walltime, c_double))
    events = constraint_events(ctx%cs, ctx%t_end)
    eps = 1.0e-12_rp * max(1.0_rp, ctx%t_end)
    h = ctx%dt
    t = 0.0_rp
    ie = 1
    iout = 0
    at_max_steps = .false.
    if (ctx%restarted) then
      ! Go on from the checkpoint: its state, time and step number are in
      ! the TS (solver_restore); the next output step is the first after t.
      t = ctx%t_restart
      if (.not. ctx%fixed_step) h = ctx%h_restart
      ! The next output step is the first after the last one written.
      iout = 1
      do while (output_time(iout) <= ctx%t_written + eps .and. real(iout, rp) * ctx%cfg%output_interval < ctx%t_end)
        iout = iout + 1
      end do
      ctx%t_prev = t
      ! A wall-clock checkpoint after a window's last step is at the
      ! window's end, before solver_run wrote that output step: as the run
      ! did next, put t onto it and write it.
      tstop = next_stop(t - 1.0e3_rp * eps)
      if (abs(t - tstop) <= 1.0e3_rp * eps) then
        t = tstop
        ctx%t_prev = t
        PetscCall(TSSetTime(ctx%ts, t, ierr))
        if (abs(t - output_time(iout)) <= eps) then
          call write_output(ctx, out, t, ierr)
          if (io_failed()) return
          iout = iout + 1
        end if
      end if
    else
      tstop = next_stop(t)
      call enter_window(ctx, t, tstop, dke, ierr)
      if (ierr /= 0) return
      ctx%t_prev = 0.0_rp
      call write_output(ctx, out, t, ierr)
      if (io_failed()) return
      iout = 1
    end if

    do while (t < ctx%t_end - eps .and. .not. at_max_steps)
      tstop = next_stop(t)
      ctx%tstop = tstop
      if (t > 0.0_rp) then
        call enter_window(ctx, t, tstop, dke, ierr)
        if (ierr /= 0) return
        ctx%work_constraints = ctx%work_constraints + dke
        PetscCall(TSRestartStep(ctx%ts, ierr))
      end if
      PetscCall(TSSetMaxTime(ctx%ts, tstop, ierr))
      if (ctx%fixed_step) h = ctx%dt
      if (t + 1.01_rp * h >= tstop) h = tstop - t
      PetscCall(TSSetTimeStep(ctx%ts, h, ierr))
      PetscCall(TSSolve(ctx%ts, ctx%u, ierr))
      if (len_trim(ctx%io_error) > 0) then
        ! A wall-clock checkpoint could not be written (wall_checkpoint).
        status = 'failed: '//trim(ctx%io_error)
        exit
      end if
      PetscCall(TSGetConvergedReason(ctx%ts, reason, ierr))
      PetscCall(TSGetTime(ctx%ts, t, ierr))
      PetscCall(VecNorm(ctx%u, NORM_INFINITY, unorm, ierr))
      if (reason >= 0 .and. nuno_signal_agreed() /= 0) then
        ! SIGTERM/SIGINT: every rank finished the same step; keep its state
        ! and a checkpoint to continue from (the restart point of the last
        ! output step: keep_restart_point).
        if (t > ctx%t_written) then
          call write_output(ctx, out, t, ierr)
          if (io_failed()) return
        end if
        PetscCall(TSGetTimeStep(ctx%ts, h, ierr))
        call take_checkpoint(ctx, out, t, h, trim(signal_name(nuno_signal_agreed())), ierr, restart_point=.true.)
        if (io_failed()) return
        write(msg, '(a,es12.5,a)') trim(signal_name(nuno_signal_agreed()))//' at t = ', t, &
          ': the run stopped after that step, with its state and a checkpoint written (continue it with'// &
          ' -nuno_restart '//trim(ctx%cfg%output_file)//')'
        status = 'interrupted: '//trim(msg)
        if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: interrupted: '//trim(msg)
        exit
      end if
      if (reason < 0 .or. unorm /= unorm .or. unorm > huge(1.0_rp)) then
        call failure_reason(ctx, reason, t, msg)
        status = 'failed: '//trim(msg)
        if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(msg)
        exit
      end if
      ! -ts_max_steps: PETSc counts steps over all TSSolve calls and stops
      ! with TS_CONVERGED_ITS, possibly inside a window: a clean end.
      at_max_steps = reason == TS_CONVERGED_ITS
      if (abs(t - tstop) > 1.0e3_rp * eps .and. .not. at_max_steps) then
        write(reasonname, '(a,es12.5,a,es12.5)') 'time integration stopped at t = ', t, ' before ', tstop
        status = 'failed: '//trim(reasonname)
        if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(reasonname)
        exit
      end if
      if (abs(t - tstop) <= 1.0e3_rp * eps) then
        t = tstop
        PetscCall(TSSetTime(ctx%ts, t, ierr))
        PetscCall(TSGetTimeStep(ctx%ts, h, ierr))
      end if
      if (abs(t - output_time(iout)) <= eps) then
        call write_output(ctx, out, t, ierr)
        if (io_failed()) return
        iout = iout + 1
        if (t < ctx%t_end - eps) then
          call keep_restart_point(ctx, out, t, h, ierr)
          if (ierr /= 0) return
        end if
        if (ctx%cfg%checkpoint_interval > 0.0_rp .and. t < ctx%t_end - eps .and. &
            t >= ctx%t_checkpoint + ctx%cfg%checkpoint_interval - eps) then
          call take_checkpoint(ctx, out, t, h, 'checkpoint_interval', ierr)
          if (io_failed()) return
        end if
      else if (at_max_steps .and. t > ctx%t_written) then
        ! Off the output grid (inside a window, or at a keyframe): the last state.
        call write_output(ctx, out, t, ierr)
        if (io_failed()) return
      end if
      if (at_max_steps .and. t < ctx%t_end - eps .and. ctx%rank == 0) &
        write(output_unit, '(a,es13.5e2,a)') 'nuno: -ts_max_steps '//inum(ctx%max_steps)// &
          ' reached at t =', t, ': the run ends here, complete, with this state written'
    end do
    ! The end of a complete run: a checkpoint, so that it can be continued
    ! to a later t_end.
    if (status == 'complete' .and. .not. ctx%checkpoint_current) then
      call take_checkpoint(ctx, out, t, h, 'end', ierr)
      if (io_failed()) return
    end if

    ! The run's wall time, the same value on every rank (an attribute).
    wall = MPI_Wtime() - ctx%wall0
    call MPI_Allreduce(MPI_IN_PLACE, wall, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call output_write_wall_time(out, wall, ierr, errmsg)
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      if (io_failed()) return
    end if
    call final_summary(ctx, status, wall, ierr)

  contains

    !> An output or checkpoint write failed on some rank (a full disk):
    !> agreed by every rank and reported in one line already, so the run
    !> ends collectively as failed (ierr = 0); other errors stay errors.
    logical function io_failed()
      io_failed = ierr /= 0
      if (io_failed .and. len_trim(ctx%io_error) > 0) then
        status = 'failed: '//trim(ctx%io_error)
        ierr = 0
      end if
    end function io_failed

    !> Output times: multiples of output_interval, and t_end.
    real(rp) function output_time(k)
      integer, intent(in) :: k
      output_time = min(real(k, rp) * ctx%cfg%output_interval, ctx%t_end)
    end function output_time

    !> Next time at which the integrator must stop after t.
    real(rp) function next_stop(tt)
      real(rp), intent(in) :: tt
      integer :: m
      next_stop = output_time(iout)
      do m = 1, size(events)
        if (events(m) > tt + eps) next_stop = min(next_stop, events(m))
      end do
    end function next_stop

  end subroutine solver_run

  !> One closing line on rank 0 (stdout; a failure's reason is already on
  !> stderr) with the totals, the retries and the wall time.
  subroutine final_summary(ctx, status, wall, ierr)
    type(app_ctx), intent(inout) :: ctx
    character(len=*), intent(in) :: status
    real(rp), intent(in) :: wall
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: steps, rejects, fails
    real(rp) :: t, c(5)
    integer :: kw

    call run_counts(ctx, c, ierr)
    if (ierr /= 0) return
    steps = int(c(1), kind(steps))
    rejects = int(c(2), kind(rejects))
    fails = int(c(5), kind(fails))
    PetscCall(TSGetTime(ctx%ts, t, ierr))
    ! the status's first word: complete, failed or interrupted (its
    ! reason, after the colon, is on stderr already)
    kw = index(status, ':') - 1
    if (kw < 1) kw = len_trim(status)
    if (ctx%rank == 0) then
      write(output_unit, '(a,es13.5e2,a,i0,a,i0,a,i0,a,es11.3e2,a)') 'nuno: '// &
        status(1:kw)//' at t =', t, ': ', steps, ' steps, ', rejects, ' rejected (', fails, &
        ' retried after a failed Newton solve), wall time', wall, ' s'
      flush(output_unit)
    end if
  end subroutine final_summary

  !> The provenance of the run (/run in the output file): the time
  !> integration as used after the options, versions, date and host.
  subroutine write_run_info(ctx, out, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(output_file), intent(inout) :: out
    PetscErrorCode, intent(out) :: ierr
    type(run_info) :: info
    type(tTSAdapt) :: adapt
    character(len=512) :: errmsg
    character(len=8) :: date
    character(len=10) :: clock
    character(len=5) :: zone
    integer :: hlen

    PetscCall(TSGetType(ctx%ts, info%ts_type, ierr))
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    PetscCall(TSAdaptGetType(adapt, info%ts_adapt_type, ierr))
    PetscCall(PetscGetVersion(info%petsc_version, ierr))
    info%dt = ctx%dt
    info%t_end = ctx%t_end
    info%max_steps = int(min(ctx%max_steps, int(huge(1), kind(ctx%max_steps))))
    info%rtol = ctx%rtol
    info%atol_position = ctx%atol_x
    info%atol_velocity = ctx%atol_v
    info%units = scene_units(ctx%cfg%scene_code)
    ! Rank 0's host and clock, broadcast: attributes must be equal on all ranks.
    if (ctx%rank == 0) then
      PetscCall(PetscGetHostName(info%host, ierr))
      call date_and_time(date, clock, zone)
      info%start_date = date(1:4)//'-'//date(5:6)//'-'//date(7:8)//'T'//clock(1:2)//':'//clock(3:4)//':'// &
                        clock(5:6)//zone(1:3)//':'//zone(4:5)
    end if
    hlen = len(info%host)
    call MPI_Bcast(info%host, hlen, MPI_CHARACTER, 0, ctx%comm, ierr)
    hlen = len(info%start_date)
    call MPI_Bcast(info%start_date, hlen, MPI_CHARACTER, 0, ctx%comm, ierr)
    call output_write_run_info(out, info, ierr, errmsg)
    if (ierr == 0) call write_config(ctx%cfg, ctx%comm, out, ierr, errmsg)
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
    end if
  end subroutine write_run_info

  !> The resolved configuration, /config/<group> with one attribute per key:
  !> every key after scene defaults, derived defaults and overrides
  !> (dt and t_end as in force after -ts_dt and -ts_max_time), so that a run
  !> can be repeated without knowing the defaults of the version that made
  !> it. Logicals are 0/1. Collective.
  subroutine write_config(cfg, comm, out, ierr, errmsg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: comm
    type(output_file), intent(inout) :: out
    PetscErrorCode, intent(out) :: ierr
    character(len=*), intent(inout) :: errmsg
    integer :: e, nk

    e = 0
    call output_config_key(out, 'lattice', 'nx', cfg%nx, e, errmsg)
    call output_config_key(out, 'lattice', 'ny', cfg%ny, e, errmsg)
    call output_config_key(out, 'lattice', 'lx', [cfg%lx], e, errmsg)
    call output_config_key(out, 'lattice', 'ly', [cfg%ly], e, errmsg)
    call output_config_key(out, 'lattice', 'total_mass', [cfg%total_mass], e, errmsg)
    call output_config_key(out, 'lattice', 'mass_distribution', trim(cfg%mass_distribution), e, errmsg)
    call output_config_key(out, 'lattice', 'lattice_scaling', trim(cfg%lattice_scaling), e, errmsg)
    call output_config_key(out, 'material', 'spring_model', trim(cfg%spring_model), e, errmsg)
    call output_config_key(out, 'material', 'e_s', [cfg%e_s], e, errmsg)
    call output_config_key(out, 'material', 'eta_s', [cfg%eta_s], e, errmsg)
    call output_config_key(out, 'material', 'e_d', [cfg%e_d], e, errmsg)
    call output_config_key(out, 'material', 'eta_d', [cfg%eta_d], e, errmsg)
    call output_config_key(out, 'material', 'bending_model', trim(cfg%bending_model), e, errmsg)
    call output_config_key(out, 'material', 'k_b', [cfg%k_b], e, errmsg)
    call output_config_key(out, 'material', 'eta_b', [cfg%eta_b], e, errmsg)
    call output_config_key(out, 'scene', 'scene', trim(cfg%scene), e, errmsg)
    call output_config_key(out, 'scene', 'gravity', cfg%gravity, e, errmsg)
    call output_config_key(out, 'scene', 'lift_length', [cfg%lift_length], e, errmsg)
    call output_config_key(out, 'scene', 'lift_height', [cfg%lift_height], e, errmsg)
    call output_config_key(out, 'scene', 'bend_angle', [cfg%bend_angle], e, errmsg)
    call output_config_key(out, 'scene', 'n_keyframes', cfg%n_keyframes, e, errmsg)
    ! The keyframes in use only (n_keyframes of them; none: not written).
    nk = max(0, min(cfg%n_keyframes, size(cfg%keyframe_time)))
    if (nk > 0) then
      call output_config_key(out, 'scene', 'keyframe_time', cfg%keyframe_time(1:nk), e, errmsg)
      call output_config_key(out, 'scene', 'keyframe_dx', cfg%keyframe_dx(1:nk), e, errmsg)
      call output_config_key(out, 'scene', 'keyframe_dy', cfg%keyframe_dy(1:nk), e, errmsg)
      call output_config_key(out, 'scene', 'keyframe_dz', cfg%keyframe_dz(1:nk), e, errmsg)
    end if
    call output_config_key(out, 'scene', 'wave_nodes', trim(cfg%wave_nodes), e, errmsg)
    call output_config_key(out, 'scene', 'release_time', [cfg%release_time], e, errmsg)
    call output_config_key(out, 'scene', 'initial_omega', cfg%initial_omega, e, errmsg)
    call output_config_key(out, 'time', 't_end', [cfg%t_end], e, errmsg)
    call output_config_key(out, 'time', 'dt', [cfg%dt], e, errmsg)
    call output_config_key(out, 'output', 'output_interval', [cfg%output_interval], e, errmsg)
    call output_config_key(out, 'output', 'write_velocity', merge(1, 0, cfg%write_velocity), e, errmsg)
    call output_config_key(out, 'output', 'output_file', trim(cfg%output_file), e, errmsg)
    call output_config_key(out, 'output', 'petsc_options', trim(cfg%petsc_options), e, errmsg)
    call output_config_key(out, 'output', 'stretch_limit', [cfg%stretch_limit], e, errmsg)
    call output_config_key(out, 'output', 'checkpoint_interval', [cfg%checkpoint_interval], e, errmsg)
    if (cfg%identify) then
      ! /config/material holds the fitted values (those of the run written); the initial guess is /identify/initial.
      call output_config_key(out, 'identify', 'observed_file', trim(cfg%observed_file), e, errmsg)
      call output_config_key(out, 'identify', 'fit', trim(cfg%fit), e, errmsg)
      call output_config_key(out, 'identify', 'fit_lower', cfg%fit_lower(1:cfg%n_fit), e, errmsg)
      call output_config_key(out, 'identify', 'fit_upper', cfg%fit_upper(1:cfg%n_fit), e, errmsg)
      call output_config_key(out, 'identify', 'tikhonov', [cfg%tikhonov], e, errmsg)
    end if
    if (cfg%control) then
      ! /config/scene holds the optimised keyframes (those of the run written); the initial guess is /control/initial_offset.
      call output_config_key(out, 'control', 'target_file', trim(cfg%target_file), e, errmsg)
      call output_config_key(out, 'control', 'components', trim(cfg%components), e, errmsg)
      if (cfg%max_speed /= unset_real) call output_config_key(out, 'control', 'max_speed', [cfg%max_speed], e, errmsg)
      call output_config_key(out, 'control', 'velocity_weight', [cfg%velocity_weight], e, errmsg)
      call output_config_key(out, 'control', 'keyframe_tikhonov', [cfg%keyframe_tikhonov], e, errmsg)
    end if
    ! One error flag for all ranks (each call above is local HDF5 metadata).
    call MPI_Allreduce(MPI_IN_PLACE, e, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    ierr = e
    if (e /= 0 .and. len_trim(errmsg) == 0) errmsg = 'output: writing /config failed on another rank'
  end subroutine write_config

  !> The unit system of a scene's defaults (input/README.md, Scenes): the
  !> report scenes and flat use mm, g, s; hang uses SI. The program itself
  !> is unit-agnostic: these are the units the scene's constants are in.
  function scene_units(scene_code) result(units)
    integer, intent(in) :: scene_code
    character(len=8) :: units
    if (scene_code == SCENE_HANG) then
      units = 'SI'
    else
      units = 'mm g s'
    end if
  end function scene_units

  !> What is known to help a failed Newton solve, leaving out what the user
  !> has already set: a smaller fixed step or adaptivity, more retries, a
  !> stronger inner preconditioner or the full Jacobian, and the monitors.
  function failure_hints(ctx) result(h)
    type(app_ctx), intent(in) :: ctx
    character(len=512) :: h
    character(len=32) :: dtq
    character(len=64) :: pctype
    type(tPC) :: pc
    type(tKSP) :: ksp
    type(tSNES) :: snes
    PetscErrorCode :: ierr
    h = 'try'
    if (ctx%fixed_step) then
      write(dtq, '(es10.3)') 0.25_rp * ctx%dt
      h = trim(h)//' a smaller step (-ts_dt '//trim(adjustl(dtq))//'), adaptive steps (-ts_adapt_type basic),'
    else if (.not. given('-ts_max_snes_failures')) then
      h = trim(h)//' more retries (-ts_max_snes_failures -1),'
    end if
    ! Each path names its own linear solve: the inner 3-dof one (reduced_
    ! prefix) or the 6-dof Krylov solve (no prefix).
    if (ctx%use_reduced) then
      ! (-reduced_pc_type is always in the options: nuno sets its default.)
      call KSPGetPC(ctx%red%ksp, pc, ierr)
      if (ierr == 0) call PCGetType(pc, pctype, ierr)
      if (ierr == 0 .and. pctype /= PCLU .and. pctype /= PCCHOLESKY) &
        h = trim(h)//' a stronger inner preconditioner (-reduced_pc_type lu on small lattices),'
      h = trim(h)//' the assembled 6-dof Jacobian (-nuno_jacobian full),'
    else
      call TSGetSNES(ctx%ts, snes, ierr)
      if (ierr == 0) call SNESGetKSP(snes, ksp, ierr)
      if (ierr == 0) call KSPGetPC(ksp, pc, ierr)
      if (ierr == 0) call PCGetType(pc, pctype, ierr)
      if (ierr == 0 .and. pctype /= PCLU .and. pctype /= PCCHOLESKY) &
        h = trim(h)//' an exact linear solve (-ksp_type preonly -pc_type lu on small lattices),'
      h = trim(h)//' the default reduced Newton step (without -nuno_jacobian full),'
    end if
    if (given('-snes_monitor')) then
      h = trim(h)//' and the monitor output above'
    else if (ctx%use_reduced) then
      h = trim(h)//' and -snes_monitor -reduced_ksp_converged_reason to see where it stalls'
    else
      h = trim(h)//' and -snes_monitor -ksp_converged_reason -snes_linesearch_monitor to see where it stalls'
    end if
  contains
    logical function given(name)
      character(len=*), intent(in) :: name
      PetscBool :: set
      PetscErrorCode :: ierr
      call PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, name, set, ierr)
      given = set .and. ierr == 0
    end function given
  end function failure_hints

  !> SIGTERM, SIGINT or the signal's number.
  function signal_name(sig) result(name)
    integer(c_int), intent(in) :: sig
    character(len=16) :: name
    select case (sig)
    case (15)
      name = 'SIGTERM'
    case (2)
      name = 'SIGINT'
    case default
      write(name, '(a,i0)') 'signal ', sig
    end select
  end function signal_name

  !> One line saying why the run stopped.
  subroutine failure_reason(ctx, reason, t, msg)
    type(app_ctx), intent(in) :: ctx
    TSConvergedReason, intent(in) :: reason
    real(rp), intent(in) :: t
    character(len=*), intent(out) :: msg
    integer :: nbad(1), gbad(1), ierr, loc(3), glob(3)

    nbad(1) = ctx%nbad
    call MPI_Allreduce(nbad, gbad, 1, MPI_INTEGER, MPI_MAX, ctx%comm, ierr)
    if (gbad(1) > 0) then
      loc = -1
      if (ctx%nbad > 0) loc = [ctx%bad(1), ctx%bad(2), 1]
      call MPI_Allreduce(loc, glob, 3, MPI_INTEGER, MPI_MAX, ctx%comm, ierr)
      write(msg, '(a,es12.5,a,i0,a,i0,a)') 'singular element at t = ', ctx%t_bad, &
        ' (zero-length link or bending triple folded back to theta = pi) anchored at node (', &
        glob(1), ', ', glob(2), ')'
    else if (reason == TS_DIVERGED_NONLINEAR_SOLVE) then
      write(msg, '(a,es12.5,a)') 'time step from t = ', t, ' failed: nonlinear solve diverged '// &
        '(TS_DIVERGED_NONLINEAR_SOLVE): the run''s failed Newton solves reached -ts_max_snes_failures '// &
        '(each retried with a smaller step); '//trim(failure_hints(ctx))
    else if (reason < 0) then
      write(msg, '(a,es12.5,a,i0,a)') 'time step from t = ', t, ' failed (TSConvergedReason ', reason, &
        ', e.g. -2 = step rejected too often by the error controller)'
    else
      write(msg, '(a,es12.5)') 'state became NaN or infinite at t = ', t
    end if
  end subroutine failure_reason

  !> Accepted steps, rejected steps, Newton iterations, linear iterations
  !> and retried Newton solves since t = 0, a restart's earlier runs
  !> included (the same on every rank).
  subroutine run_counts(ctx, c, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(out) :: c(5)
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: steps, rejects, nits, lits, fails

    PetscCall(TSGetStepNumber(ctx%ts, steps, ierr))
    PetscCall(TSGetStepRejections(ctx%ts, rejects, ierr))
    PetscCall(TSGetSNESIterations(ctx%ts, nits, ierr))
    PetscCall(TSGetKSPIterations(ctx%ts, lits, ierr))
    PetscCall(TSGetSNESFailures(ctx%ts, fails, ierr))
    if (ctx%use_reduced) lits = ctx%red%its        ! the outer KSP is preonly: count the inner iterations
    c = [real(steps, rp), real(rejects, rp), real(nits, rp), real(lits, rp), real(fails, rp)] + ctx%counts_before
    c(1) = real(steps, rp)                         ! the TS goes on counting from the checkpoint's step
  end subroutine run_counts

  !> Continue from a checkpoint: the state strips x, v (3, 0:nx-1, ys:ye)
  !> into the state vector, the TS's time and step number, the integrals
  !> and counters into the context. solver_run then goes on from ck%time.
  !> Collective.
  subroutine solver_restore(ctx, ck, x, v, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(checkpoint_t), intent(in) :: ck
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: step

    PetscCall(strips_to_state(ctx, x, v, ctx%u, ierr))
    step = int(ck%counters(1), kind(step))
    PetscCall(TSSetStepNumber(ctx%ts, step, ierr))
    PetscCall(TSSetTime(ctx%ts, ck%time, ierr))
    ctx%restarted = .true.
    ctx%t_restart = ck%time
    ctx%h_restart = ck%dt_next
    ctx%t_checkpoint = ck%time
    ctx%wall_before = ck%wall_time
    ctx%counts_before = [0.0_rp, ck%counters(2:5)]
    ctx%dissipated = ck%dissipated
    ctx%work_constraints = ck%work_constraints
    ctx%mgx0 = ck%mgx0
    ctx%t_written = ck%t_written
    ctx%stretch_warned = ck%stretch_warned /= 0
    ! The first Newton iteration's inner tolerance takes the round-off floor
    ! of the last step's assembly (set_newton_forcing): without it the
    ! restart's first step solved to another tolerance and the run
    ! differed from the one it continues by 1e-13 m (hang 65 x 65).
    if (ctx%use_reduced) ctx%red%floor_est = ck%newton_floor
    ! A checkpoint at an output step is the restart point until the next one.
    if (ck%time == ck%t_written) then
      ctx%rp_ck = ck
      ctx%rp_x = x
      ctx%rp_v = v
      ctx%rp_valid = .true.
    end if
    ! The Newton start's states: the checkpoint's, then the ones before it
    if (ck%start_count > 0) then
      block
        type(tVec) :: w
        integer(c_int) :: kk, nk, cmp
        real(c_double) :: tk, ncp
        PetscErrorCode :: err
        nk = int(ck%start_count + 1, c_int)
        cmp = int(ck%start_compare, c_int)
        ncp = real(ck%start_nc_prev, c_double)
        tk = real(ck%time, c_double)
        kk = 0
        ierr = nuno_newton_start_put(ctx%ts%v, kk, ctx%u%v, tk, nk, cmp, ncp)
        if (ierr /= 0) return
        PetscCall(DMGetGlobalVector(ctx%da, w, ierr))
        do kk = 1, nk - 1
          PetscCall(strips_to_state(ctx, ck%start_x(:, :, :, kk), ck%start_v(:, :, :, kk), w, ierr))
          tk = real(ck%start_t(kk), c_double)
          ierr = nuno_newton_start_put(ctx%ts%v, kk, w%v, tk, nk, cmp, ncp)
          if (ierr /= 0) exit
        end do
        ! (a failed put's error code, not the restore's, is the answer)
        call DMRestoreGlobalVector(ctx%da, w, err)
        if (ierr == 0) ierr = err
      end block
    end if
  end subroutine solver_restore

  !> Write a checkpoint of the state at t, h being the step the run takes
  !> next (module output, output_write_checkpoint), and say so on stdout.
  !> restart_point: the checkpoint of the last output step instead
  !> (keep_restart_point; the state at t where there is none yet). Collective.
  subroutine take_checkpoint(ctx, out, t, h, reason, ierr, restart_point)
    type(app_ctx), intent(inout) :: ctx
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t, h
    character(*), intent(in) :: reason
    PetscErrorCode, intent(out) :: ierr
    logical, intent(in), optional :: restart_point
    type(checkpoint_t) :: ck
    character(len=512) :: errmsg
    logical :: point

    point = .false.
    if (present(restart_point)) point = restart_point .and. ctx%rp_valid
    if (point) then
      ck = ctx%rp_ck
    else
      PetscCall(state_to_strips(ctx, ctx%u, ctx%xout, ctx%vout, ierr))
      call fill_checkpoint(ctx, t, h, ck, ierr)
      if (ierr /= 0) return
    end if
    ! Attributes must be equal on all ranks: the slowest rank's clock.
    ck%wall_time = MPI_Wtime() - ctx%wall0
    call MPI_Allreduce(MPI_IN_PLACE, ck%wall_time, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    ck%reason = reason
    if (point) then
      call output_write_checkpoint(out, ck, ctx%rp_x, ctx%rp_v, ierr, errmsg)
    else
      call output_write_checkpoint(out, ck, ctx%xout, ctx%vout, ierr, errmsg)
    end if
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      return
    end if
    ctx%t_checkpoint = ck%time
    ! (a restart point is older than the output steps written since)
    ctx%checkpoint_current = .not. point .or. ck%time >= ctx%t_written
    if (ctx%rank == 0) then
      write(output_unit, '(a,i0,a,es12.5e2,a)') 'nuno: checkpoint ', ck%sequence, ' at t =', ck%time, &
        ' ('//trim(reason)//'), '//inum(int(ck%n_output_steps, kind(ctx%max_steps)))//' output steps'
      flush(output_unit)
    end if
  end subroutine take_checkpoint

  !> ck of the state at t (in ctx%u), h being the next step: everything
  !> but the wall time, the reason and (unless set: the output file's count
  !> at the write) the output steps. Collective.
  subroutine fill_checkpoint(ctx, t, h, ck, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t, h
    type(checkpoint_t), intent(inout) :: ck
    PetscErrorCode, intent(out) :: ierr

    ck%time = t
    ck%dt_next = h
    ck%dissipated = ctx%dissipated
    ck%work_constraints = ctx%work_constraints
    ck%mgx0 = ctx%mgx0
    ck%t_written = ctx%t_written
    call run_counts(ctx, ck%counters, ierr)
    if (ierr /= 0) return
    ck%stretch_warned = merge(1, 0, ctx%stretch_warned)
    ! the next step's first inner tolerance depends on it (set_newton_forcing)
    if (ctx%use_reduced) ck%newton_floor = ctx%red%floor_est
    PetscCall(TSGetType(ctx%ts, ck%ts_type, ierr))
    PetscCall(checkpoint_start_states(ctx, t, ck, ierr))
  end subroutine fill_checkpoint

  !> Keep the restart point: the state at the output step just written
  !> (t, h the next step) and its checkpoint, for the checkpoints written
  !> between output steps. Between output steps the reduced solve carries
  !> state a checkpoint cannot hold (a preconditioner kept for pc_lag
  !> assemblies, the inner guesses' last solves); at an output step the
  !> next window starts them afresh (enter_window), in the run and in its
  !> restart alike, so a restart from this point repeats the run bit for
  !> bit. Costs a copy of the state and the Newton start's kept states an
  !> output step. Collective.
  subroutine keep_restart_point(ctx, out, t, h, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(output_file), intent(in) :: out
    real(rp), intent(in) :: t, h
    PetscErrorCode, intent(out) :: ierr

    ctx%rp_valid = .false.
    if (.not. allocated(ctx%rp_x)) allocate(ctx%rp_x, mold=ctx%xout)
    if (.not. allocated(ctx%rp_v)) allocate(ctx%rp_v, mold=ctx%vout)
    PetscCall(state_to_strips(ctx, ctx%u, ctx%rp_x, ctx%rp_v, ierr))
    call fill_checkpoint(ctx, t, h, ctx%rp_ck, ierr)
    if (ierr /= 0) return
    ctx%rp_ck%n_output_steps = output_steps(out)
    ctx%rp_valid = .true.
  end subroutine keep_restart_point


  !> The Newton start's kept states before t (at most three, newest first)
  !> into ck, for a restart to start its next steps as this run does
  !> (src/nuno_newton_start.c). Collective.
  subroutine checkpoint_start_states(ctx, t, ck, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    type(checkpoint_t), intent(inout) :: ck
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: w
    integer(c_int) :: n, compare, k
    real(c_double) :: nc_prev, tk
    PetscErrorCode :: err
    integer :: m

    ierr = nuno_newton_start_count(ctx%ts%v, n, compare, nc_prev)
    if (ierr /= 0) return
    ck%start_count = 0
    ck%start_compare = int(compare)
    ck%start_nc_prev = real(nc_prev, rp)
    if (allocated(ck%start_x)) deallocate(ck%start_x)
    if (allocated(ck%start_v)) deallocate(ck%start_v)
    allocate(ck%start_x(3, ctx%lat%nx, ctx%lat%ye - ctx%lat%ys + 1, 3), ck%start_v(3, ctx%lat%nx, ctx%lat%ye - ctx%lat%ys + 1, 3))
    if (n == 0) return
    PetscCall(DMGetGlobalVector(ctx%da, w, ierr))
    do k = 0, n - 1
      if (ck%start_count == 3) exit
      ierr = nuno_newton_start_get(ctx%ts%v, k, w%v, tk)
      if (ierr /= 0) exit
      ! (the step's own state, if pushed already, is the checkpoint's state)
      if (real(tk, rp) >= t) cycle
      m = ck%start_count + 1
      ck%start_count = m
      ck%start_t(m) = real(tk, rp)
      PetscCall(state_to_strips(ctx, w, ck%start_x(:, :, :, m), ck%start_v(:, :, :, m), ierr))
    end do
    ! (a failed get's error code, not the restore's, is the answer)
    call DMRestoreGlobalVector(ctx%da, w, err)
    if (ierr == 0) ierr = err
  end subroutine checkpoint_start_states

  !> The owned rows of a global state vector (ctx%da) into strips
  !> x, v (3, nx, ym) [length], [length/time], as module output writes them.
  subroutine state_to_strips(ctx, u, x, v, ierr)
    type(app_ctx), intent(in) :: ctx
    type(tVec), intent(in) :: u
    real(rp), intent(out) :: x(:, :, :), v(:, :, :)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: ua(:, :, :)
    integer :: j

    PetscCall(DMDAVecGetArrayReadF90(ctx%da, u, ua, ierr))
    do j = ctx%lat%ys, ctx%lat%ye
      x(:, :, j - ctx%lat%ys + 1) = ua(0:2, :, j)
      v(:, :, j - ctx%lat%ys + 1) = ua(3:5, :, j)
    end do
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, u, ua, ierr))
  end subroutine state_to_strips

  !> The reverse of state_to_strips: strips x, v (3, nx, ym) into the owned
  !> rows of the global state vector u.
  subroutine strips_to_state(ctx, x, v, u, ierr)
    type(app_ctx), intent(in) :: ctx
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    type(tVec), intent(inout) :: u
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: ua(:, :, :)
    integer :: j

    PetscCall(DMDAVecGetArrayF90(ctx%da, u, ua, ierr))
    do j = ctx%lat%ys, ctx%lat%ye
      ua(0:2, :, j) = x(:, :, j - ctx%lat%ys + 1)
      ua(3:5, :, j) = v(:, :, j - ctx%lat%ys + 1)
    end do
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, u, ua, ierr))
  end subroutine strips_to_state

  !> An output write failed (agreed by every rank): its one line on stderr
  !> (rank 0), and the reason kept, so that solver_run ends the run as failed.
  subroutine report_io_error(ctx, errmsg)
    type(app_ctx), intent(inout) :: ctx
    character(*), intent(in) :: errmsg
    if (ctx%rank == 0) write(error_unit, '(a)') 'nuno: error: '//trim(errmsg)
    ctx%io_error = errmsg
  end subroutine report_io_error

  !> Diagnostics and one output step; a one-line summary on rank 0.
  subroutine write_output(ctx, out, t, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)
    type(state_diagnostics_t) :: d
    type(output_record) :: rec
    PetscInt :: steps, rejects, nits, lits, fails
    character(len=512) :: errmsg
    integer :: j
    real(rp) :: wall, rate, eta, c(5)

    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, ctx%u, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, ctx%u, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    call state_diagnostics(ctx%lat, u, ctx%gravity, ctx%comm, d, ierr)
    if (.not. ctx%stretch_warned .and. ctx%cfg%stretch_limit > 0.0_rp) call check_stretch(ctx, u, t)
    do j = ctx%lat%ys, ctx%lat%ye
      ctx%xout(:, :, j) = u(0:2, :, j)
      ctx%vout(:, :, j) = u(3:5, :, j)
    end do
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
    if (t == 0.0_rp) ctx%mgx0 = d%mgx

    call run_counts(ctx, c, ierr)
    if (ierr /= 0) return
    steps = int(c(1), kind(steps))
    rejects = int(c(2), kind(rejects))
    nits = int(c(3), kind(nits))
    lits = int(c(4), kind(lits))
    fails = int(c(5), kind(fails))
    rec%time = t
    rec%kinetic = d%kinetic
    rec%stretch = d%stretch
    rec%bend = d%bend
    rec%dissipated = ctx%dissipated
    rec%external_work = ctx%work_constraints + (d%mgx - ctx%mgx0)
    rec%momentum = d%momentum
    rec%angular_momentum = d%angular_momentum
    rec%length = d%length
    rec%flatness = d%flatness
    rec%steps = steps
    rec%rejected_steps = rejects
    rec%newton_iterations = nits
    rec%linear_iterations = lits
    wall = MPI_Wtime() - ctx%wall0
    rec%wall_time = wall
    if (ctx%cfg%write_velocity) then
      call output_write_step(out, rec, ctx%xout, ierr, errmsg, v=ctx%vout)
    else
      call output_write_step(out, rec, ctx%xout, ierr, errmsg)
    end if
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      return
    end if
    ctx%t_written = t
    ctx%checkpoint_current = .false.
    ! Progress for a person and for awk: every field has a blank before it
    ! (es13.5e2 of a negative value still starts with one; the integer
    ! widths hold 10^8 steps), rates from the start of the run. Flushed: a
    ! redirected run shows its progress and keeps it when killed. The order
    ! up to 'linear' is the one bench/solver.py parses.
    if (t > 0.0_rp .and. wall > 0.0_rp) then
      rate = t / wall
      eta = (ctx%t_end - t) / rate
    else
      rate = 0.0_rp
      eta = ieee_nan()
    end if
    if (ctx%rank == 0) then
      write(output_unit, '(a,es12.5e2, a,i9, a,i6, a,i9, a,i11, a,i6, 2(a,es13.5e2), 3(a,es10.3e2))') &
        't =', t, '  steps', steps, '  rejected', rejects, '  newton', nits, '  linear', lits, &
        '  retries', fails, '  E_kin', d%kinetic, &
        '  E_total', d%kinetic + d%stretch + d%bend + ctx%dissipated - rec%external_work, &
        '  wall_s', wall, '  sim_per_wall_s', rate, '  eta_s', eta
      flush(output_unit)
      ctx%wall_said = MPI_Wtime()
    end if
  end subroutine write_output

  !> Warn once (stderr, rank 0) when a link has stretched or shrunk beyond
  !> stretch_limit times its rest length: a model far outside its regime
  !> (a spun sheet, a step too large) that would otherwise complete silently.
  !> At output steps only. Collective.
  subroutine check_stretch(ctx, u, t)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: u(0:, 0:, ctx%lat%gys:)
    real(rp), intent(in) :: t
    real(rp) :: r(2), g(2), lim
    integer :: atmax(3), atmin(3), loc(3), glob(3), mpierr, iq, jq
    character(len=16) :: what

    call link_stretch_extremes(ctx%lat, u, r(1), atmax, r(2), atmin)
    r(2) = 1.0_rp / max(r(2), tiny(1.0_rp))      ! shrink as a factor > 1
    call MPI_Allreduce(r, g, 2, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, mpierr)
    lim = ctx%cfg%stretch_limit
    if (g(1) <= lim .and. g(2) <= lim) return
    ctx%stretch_warned = .true.
    loc = -1
    if (g(1) > lim) then
      if (r(1) == g(1)) loc = atmax
      what = 'stretched'
    else
      if (r(2) == g(2)) loc = atmin
      what = 'compressed'
    end if
    call MPI_Allreduce(loc, glob, 3, MPI_INTEGER, MPI_MAX, ctx%comm, mpierr)
    iq = glob(1) + link_dir(1, glob(3))
    jq = glob(2) + link_dir(2, glob(3))
    if (ctx%rank == 0) then
      write(error_unit, '(a)') 'nuno: warning: at t = '//num(t)//' the link from node ('//inum(glob(1))//', '// &
        inum(glob(2))//') to ('//inum(iq)//', '//inum(jq)//') is '//trim(what)//' by a factor '// &
        num(merge(g(1), g(2), g(1) > lim))//', beyond stretch_limit = '//num(lim)// &
        ' (&output); the model is far outside its regime: check dt and the scene (warned once)'
      flush(error_unit)
    end if
  end subroutine check_stretch

  !> A real for a one-line message: short, and never glued to the text before it.
  function num(x) result(s)
    real(rp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    write(buf, '(es13.5e2)') x
    s = trim(adjustl(buf))
  end function num

  function inum(i) result(s)
    PetscInt, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write(buf, '(i0)') i
    s = trim(buf)
  end function inum

  !> A quiet NaN.
  real(rp) function ieee_nan()
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    ieee_nan = ieee_value(1.0_rp, ieee_quiet_nan)
  end function ieee_nan

end module timestepping
