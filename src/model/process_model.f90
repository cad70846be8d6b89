! SPDX-License-Identifier: BSD-2-Clause
!> A force as a process model (docs/design.md, "Process models"; the
!> pattern of PFLOTRAN's pm_base): one type whose hooks the time stepper
!> calls in a fixed order, on plain arrays, knowing no physics. Contact
!> with obstacles (module contact_model) is the first; a new force
!> extends process_model_t, is added to the list (module process_models)
!> where the solver is set up, and needs nothing else: the residual, the
!> assemblies, the step's checks, the monitor, the output and the
!> checkpoints loop over the list.
!>
!> The hooks, in the order the stepper calls them:
!>   hints       before the solver's options are resolved: what the model
!>               needs of Newton and the integrator (pm_hints_t)
!>   setup       once, with the configuration, the lattice strip, the
!>               initial state and the constraints; it refuses a scene it
!>               cannot start from (one line, the same on every rank)
!>   forces      f += its forces at the ghosted state u at time t (every
!>               residual evaluation); status PM_INFEASIBLE where the state
!>               is outside its domain (this rank's view: the list reduces)
!>   start       Newton's start of a step (x0 accepted at t0, the start x
!>               for the stage at t1): the model may move it into its
!>               domain (moving obstacles carry the nodes they reach)
!>   jacobian    its blocks at u, t: 3 x 3 diagonal blocks of single nodes
!>               (node_blocks) and blocks of node pairs that need not be
!>               stencil neighbours (pair_blocks: self-contact), S's
!>               product adds them on the rows the model gathers:
!>   pair_rows   after jacobian: the lattice rows its pair blocks reach
!>               (each row's position among them, into the caller's array)
!>   pair_gather each product with S (and each right-hand side): those
!>               rows of a vector, owned rows from their owners;
!>               collective
!>   correct     before the step limits: the model may add to a Newton
!>               update x -> x + dx a correction of the update's second
!>               order (a curved constraint's: SQP's second-order
!>               correction), or shorten the update of some nodes (a
!>               friction pair whose slip the update turns); changed,
!>               the same on every rank; collective
!>   limit_nodes after correct, before the step limits, on every Newton
!>               update and every predictor: the model may shorten the
!>               update of each node on its own (self-contact's per-node
!>               bounds, OGC); changed, the same on every rank; collective
!>   step_limit  the fraction alpha of a Newton update x -> x + dx (from
!>               the step's start x0 at t0 to a candidate at t1) that it
!>               allows, and a status: PM_FEASIBLE, or PM_INFEASIBLE when
!>               no fraction is (the step fails and is retried smaller);
!>               collective
!>   accept      the check of a step's end state before the integrator
!>               accepts it (the TS's stage check): PM_INFEASIBLE rejects
!>               it, and the step is retried smaller, with why (one line,
!>               which the run's failure message quotes); collective
!>   unresolved  (adaptive steps) at the same check, the free nodes whose
!>               forces of this model a step of dt does not resolve (a
!>               stiffness k with k dt^2 > m: an impact on a barrier),
!>               which the error estimate leaves out
!>   accepted    after an accepted step (and at the run's start): lags,
!>               statistics, records; collective
!>   output      its series (named, with units and values) and its terms
!>               of the energy balance at an output step
!>   checkpoint, restore
!>               its state as named values (checkpoint_record's
!>               named_value_t), the attributes of a checkpoint
!>   check_state a restart's state (positions at t) before the file
!>               changes; collective
!>   destroy     at the end
!> Only setup, forces and jacobian must be written; the others default to
!> "nothing" (no hints, the update kept, alpha = 1, feasible, no series,
!> no state).
!> Status flags, never NaN: an infeasible state is PM_INFEASIBLE, and the
!> solver (module process_solver) alone turns it into PETSc's domain
!> error.
module process_model
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t
  use node_blocks, only: node_blocks_t
  use pair_blocks, only: pair_blocks_t
  use checkpoint_record, only: named_value_t
  implicit none
  private
  public :: process_model_t, pm_hints_t, pm_series_t, pm_group_t, pm_energy_t
  public :: PM_FEASIBLE, PM_INFEASIBLE

  integer, parameter :: PM_FEASIBLE = 0, PM_INFEASIBLE = 1

  !> What a process model needs of the solver (hints): each true entry of
  !> any model in the list holds for the run (module solver_setup and
  !> process_solver apply them; options given explicitly win).
  type :: pm_hints_t
    !> the Jacobian at every Newton iteration (-snes_lag_jacobian 1)
    logical :: jacobian_every_iteration = .false.
    !> with jacobian_every_iteration: the Jacobian may be kept for the rest
    !> of a Newton solve once it has settled (no update or start cut by a
    !> step limit or carried, ||F|| down 100-fold and within 100 times the
    !> convergence test's residual: module newton_state's newton_settled);
    !> the solver keeps it only where every model that asks for the
    !> Jacobian at every iteration says so
    logical :: jacobian_settled = .false.
    !> the inexact-Newton forcing only where the model's state has settled:
    !> inner solves to -reduced_ksp_rtol in a Newton solve whose start or
    !> an update a step limit cut or a start hook moved, in the next
    !> solve's first iteration, and after an iteration that reduced ||F||
    !> by less than a tenth (module newton_state)
    logical :: forcing_guarded = .false.
    !> full Newton steps on the 6-dof path too (-snes_linesearch_type basic)
    logical :: basic_line_search = .false.
    !> every Newton start must lie in its domain: the solver limits any
    !> predictor (extrapolated, cubic, bdf's history) by the model's step
    !> limit from the last accepted state
    logical :: feasible_start = .false.
    !> its state moves smoothly from step to step, so that with
    !> feasible_start the limited cubic start fits it (module newton_start:
    !> the polynomial through the last accepted states, limited by the
    !> step limit); the solver takes it only where every model with
    !> feasible_start says so
    logical :: smooth_start = .false.
    !> its blocks have velocity parts (S is not free of damping)
    logical :: velocity_blocks = .false.
    !> its blocks change with the state (S is never constant)
    logical :: state_blocks = .false.
    !> it gives pair blocks (nodes that are not stencil neighbours): S's
    !> product and the reduced right-hand side add them (module reduced)
    logical :: pair_blocks = .false.
    !> its blocks between stencil neighbours are stiff (a barrier across an
    !> element: the faces' contact): where the strips' block Jacobi would be
    !> the inner preconditioner, on several ranks it drops those that cross
    !> a strip boundary and the inner solve stalls, so the strips overlap
    !> (additive Schwarz, module reduced_mg's default_preconditioner)
    logical :: stiff_neighbour_blocks = .false.
    !> the TS schemes it allows, separated by commas ('': any): a TS type,
    !> or bdf with its order ('bdf2': -ts_type bdf -ts_bdf_order 2)
    character(len=128) :: ts_types = ''
    !> the allowed schemes in words and why (the refusal's text)
    character(len=256) :: ts_why = ''
  end type pm_hints_t

  !> One time series of a process model in the output file: its path, a
  !> description, the quantity of its units ('length', 'energy', 'force',
  !> or '1'), its components (1, or 3: [t][xyz]), a count (int64) or a
  !> float64, and the value at the output step at hand.
  type :: pm_series_t
    character(len=48) :: name = ''
    character(len=128) :: description = ''
    character(len=16) :: units = '1'
    integer :: ncomp = 1
    logical :: is_count = .false.
    real(rp) :: values(3) = 0
    integer :: count = 0
  end type pm_series_t

  !> A group of the output file that a process model's series live in,
  !> with its description.
  type :: pm_group_t
    character(len=48) :: name = ''
    character(len=128) :: description = ''
  end type pm_group_t

  !> A process model's terms of the energy balance at an output step
  !> (docs/model.md section 10) [energy]: a potential energy, the energy
  !> it dissipated since the start and the work done on the cloth by
  !> what it prescribes (moving obstacles) since the start.
  type :: pm_energy_t
    real(rp) :: potential = 0
    real(rp) :: dissipated = 0
    real(rp) :: external_work = 0
  end type pm_energy_t

  !> A force as a process model: the hooks above. fixed(0:nx-1, ys:ye):
  !> the nodes constrained in the current time window (their rows are the
  !> constraints'; a force skips them). States: u(0:5, 0:nx-1, gys:gye)
  !> ghosted (position 0:2, velocity 3:5), f(3, 0:nx-1, ys:ye), the
  !> updates' x, x0, dx (0:5, 0:nx-1, ys:ye) owned rows.
  type, abstract :: process_model_t
  contains
    procedure(pm_name_i), deferred :: name
    procedure(pm_setup_i), deferred :: setup
    procedure(pm_forces_i), deferred :: forces
    procedure(pm_jacobian_i), deferred :: jacobian
    procedure :: hints => no_hints
    procedure :: pair_rows => no_pair_rows
    procedure :: pair_gather => no_pair_gather
    procedure :: start => keep_start
    procedure :: correct => keep_update
    procedure :: limit_nodes => keep_nodes
    procedure :: step_limit => no_limit
    procedure :: accept => accept_all
    procedure :: unresolved => all_resolved
    procedure :: accepted => nothing_after_step
    procedure :: output => no_output
    procedure :: checkpoint => no_state
    procedure :: restore => restore_nothing
    procedure :: check_state => state_ok
    procedure :: destroy => nothing_to_destroy
  end type process_model_t

  abstract interface
    !> The model's name, for messages ('contact').
    function pm_name_i(this) result(s)
      import :: process_model_t
      class(process_model_t), intent(in) :: this
      character(len=:), allocatable :: s
    end function pm_name_i

    !> Set-up from the configuration, the lattice strip lat, the initial
    !> ghosted state u and the constraints cs; collective over comm: a
    !> scene the model cannot start from gives ierr /= 0 and errmsg (one
    !> line) on every rank.
    subroutine pm_setup_i(this, cfg, lat, comm, u, cs, ierr, errmsg)
      import :: process_model_t, nuno_config, lattice_t, constraint_set_t, rp
      class(process_model_t), intent(inout) :: this
      type(nuno_config), intent(in) :: cfg
      type(lattice_t), intent(in) :: lat
      integer, intent(in) :: comm
      real(rp), intent(in) :: u(0:, 0:, lat%gys:)
      type(constraint_set_t), intent(in) :: cs
      integer, intent(out) :: ierr
      character(*), intent(out) :: errmsg
    end subroutine pm_setup_i

    !> f += the model's forces on the owned rows at the ghosted state u at
    !> time t; status PM_INFEASIBLE where u is outside its domain on this
    !> rank (f is then not to be used).
    subroutine pm_forces_i(this, lat, fixed, t, u, f, status)
      import :: process_model_t, lattice_t, rp
      class(process_model_t), intent(in) :: this
      type(lattice_t), intent(in) :: lat
      logical, intent(in) :: fixed(0:, lat%ys:)
      real(rp), intent(in) :: t
      real(rp), intent(in) :: u(0:, 0:, lat%gys:)
      real(rp), intent(inout) :: f(:, 0:, lat%ys:)
      integer, intent(out) :: status
    end subroutine pm_forces_i

    !> The blocks df/dx, df/dv of its forces at u, t: of single owned
    !> nodes into nodal (node_blocks_add), of node pairs into pairs
    !> (pair_blocks_add). The lists are opened and closed by the caller.
    subroutine pm_jacobian_i(this, lat, fixed, t, u, nodal, pairs)
      import :: process_model_t, lattice_t, node_blocks_t, pair_blocks_t, rp
      class(process_model_t), intent(in) :: this
      type(lattice_t), intent(in) :: lat
      logical, intent(in) :: fixed(0:, lat%ys:)
      real(rp), intent(in) :: t
      real(rp), intent(in) :: u(0:, 0:, lat%gys:)
      type(node_blocks_t), intent(inout) :: nodal
      type(pair_blocks_t), intent(inout) :: pairs
    end subroutine pm_jacobian_i
  end interface

contains

  !> No hints: the solver as without the model.
  pure function no_hints(this) result(h)
    class(process_model_t), intent(in) :: this
    type(pm_hints_t) :: h
    h = pm_hints_t()
  end function no_hints

  !> Newton's start x (0:5, 0:nx-1, ys:ye, owned rows) of a step from the
  !> accepted state x0 at t0 to t1 is kept as it is; moved = 0 (the nodes
  !> this rank's hook moved).
  subroutine keep_start(this, lat, fixed, t0, t1, x0, x, moved)
    class(process_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: x(0:, 0:, lat%ys:)
    integer, intent(out) :: moved
    moved = 0
  end subroutine keep_start

  !> The update is left as it is.
  subroutine keep_update(this, lat, fixed, t0, t1, x, dx, comm, changed)
    class(process_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    changed = .false.
  end subroutine keep_update

  !> No node's update is shortened (x: the update's start, dx (0:5,
  !> 0:nx-1, ys:ye) the update, positions and velocities).
  subroutine keep_nodes(this, lat, fixed, t0, t1, x, dx, comm, changed)
    class(process_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    changed = .false.
  end subroutine keep_nodes

  !> Any update is allowed in full.
  subroutine no_limit(this, lat, fixed, t0, t1, x0, x, dx, comm, alpha, status)
    class(process_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    integer, intent(out) :: status
    alpha = 1.0_rp
    status = PM_FEASIBLE
  end subroutine no_limit

  !> Every state is accepted.
  subroutine accept_all(this, lat, fixed, t, u, comm, status, why)
    class(process_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: status
    character(*), intent(out) :: why
    status = PM_FEASIBLE
    why = ''
  end subroutine accept_all

  !> Its forces are resolved by any step: no node marked.
  subroutine all_resolved(this, lat, fixed, t, u, dt, mask)
    class(process_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t, dt
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(inout) :: mask(0:, lat%ys:)    !< (0:nx-1, ys:ye) .true.: unresolved
  end subroutine all_resolved

  !> Nothing to do after an accepted step.
  subroutine nothing_after_step(this, lat, fixed, t, u, comm, ierr, errmsg)
    class(process_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    ierr = 0
    errmsg = ''
  end subroutine nothing_after_step

  !> No series, no group, no energy.
  subroutine no_output(this, series, groups, energy)
    class(process_model_t), intent(in) :: this
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
    allocate(series(0), groups(0))
    energy = pm_energy_t()
  end subroutine no_output

  !> No state in a checkpoint.
  subroutine no_state(this, values)
    class(process_model_t), intent(in) :: this
    type(named_value_t), allocatable, intent(out) :: values(:)
    allocate(values(0))
  end subroutine no_state

  !> Nothing to restore (values: a checkpoint's named values, every model's).
  subroutine restore_nothing(this, values)
    class(process_model_t), intent(inout) :: this
    type(named_value_t), intent(in) :: values(:)
  end subroutine restore_nothing

  !> Any state to restart from: positions x(3, 0:nx-1, ys:ye) at t.
  subroutine state_ok(this, lat, t, x, comm, ierr, errmsg)
    class(process_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(:, 0:, lat%ys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    ierr = 0
    errmsg = ''
  end subroutine state_ok

  !> No pair blocks: no rows. (The rows they reach: slot(j) the position
  !> of global row j among them, in ascending order, 0 where absent; n
  !> their number. An array of the caller's: nothing is allocated.)
  subroutine no_pair_rows(this, slot, n)
    class(process_model_t), intent(in) :: this
    integer, intent(out) :: slot(0:)
    integer, intent(out) :: n
    slot = 0
    n = 0
  end subroutine no_pair_rows

  !> No pair blocks: nothing to gather (v (nv, 0:nx-1, ys:ye) owned rows,
  !> vall (nv, 0:nx-1, :) the rows of pair_rows, in its order).
  subroutine no_pair_gather(this, lat, comm, v, vall, ierr)
    class(process_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: v(:, 0:, lat%ys:)
    real(rp), intent(inout) :: vall(:, 0:, :)
    integer, intent(out) :: ierr
    ierr = 0
  end subroutine no_pair_gather

  !> Nothing to free.
  subroutine nothing_to_destroy(this)
    class(process_model_t), intent(inout) :: this
  end subroutine nothing_to_destroy

end module process_model
