! SPDX-License-Identifier: BSD-2-Clause
!> The list of process models of a run (module process_model; app_ctx's
!> pms) and the loops the stepper calls, one a hook, in the fixed order
!> of docs/design.md, "Process models". The stepper knows these loops,
!> never a model's physics. With no model (a scene without obstacles) the
!> list is empty: nothing is allocated, and the callers test
!> pm_list_on before they touch a state (no cost).
!>
!> The list also holds what the hooks fill for the solver: the node
!> blocks of the last Jacobian (node_blocks_t, which every assembly adds:
!> module reduced keeps a pointer to it), the pair blocks (S's product
!> and the reduced right-hand side add them: pm_list_pair_product,
!> pm_list_pair_rhs, on the rows the model that gave them gathers), and the stage's feasibility: a step limit that found no
!> feasible update makes the next residual infeasible (pm_list_forces),
!> and a residual's or a limit's infeasibility is the stage's
!> (pm_list_infeasible), which the solver turns into PETSc's domain error
!> (module process_solver). Its components are private: only this
!> module's procedures write them.
module process_models
  use mpi
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t
  use node_blocks, only: node_blocks_t, node_blocks_begin, node_blocks_end
  use pair_blocks, only: pair_blocks_t, pair_blocks_begin, pair_blocks_end, pair_blocks_count, pair_blocks_apply
  use checkpoint_record, only: named_value_t
  use process_model, only: process_model_t, pm_hints_t, pm_series_t, pm_group_t, pm_energy_t, PM_FEASIBLE, &
                           PM_INFEASIBLE
  implicit none
  private
  public :: pm_list_t, pm_list_add, pm_list_on, pm_list_count, pm_list_name, pm_list_hints, pm_list_ts_refusal
  public :: pm_list_setup, pm_list_forces, pm_list_infeasible, pm_list_jacobian, pm_list_step_limit, pm_list_accept
  public :: pm_list_correct, pm_list_limit_nodes
  public :: pm_list_unresolved, pm_list_start_limit
  public :: pm_list_accepted, pm_list_output, pm_list_checkpoint, pm_list_restore, pm_list_check_state, pm_list_destroy
  public :: pm_list_nodal, pm_list_rejection, pm_list_take, pm_list_start
  public :: pm_list_pairs_on, pm_list_pair_product, pm_list_pair_rhs

  !> One process model of the list.
  type :: pm_slot_t
    class(process_model_t), allocatable :: pm
  end type pm_slot_t

  !> The run's process models and what their hooks fill for the solver.
  type :: pm_list_t
    private
    integer :: n = 0
    type(pm_slot_t), allocatable :: m(:)
    !> the diagonal blocks of single nodes at the last Jacobian's state
    type(node_blocks_t) :: nodal
    !> blocks of node pairs at the last Jacobian's state (one model gives them)
    type(pair_blocks_t) :: pairs
    logical :: pairs_on = .false.          !< some rank has pair blocks: the products gather (every rank)
    integer :: pair_model = 0              !< the model that gave them, whose pair_gather serves
    integer, allocatable :: pair_slot(:)   !< (0:ny-1) position of row j in that model's pair rows (0: absent)
    integer :: pair_nrows = 0              !< how many pair rows
    !> (6, 0:nx-1, capacity) a vector on the pair rows (grown, never shrunk)
    real(rp), allocatable :: pair_v(:, :, :)
    !> a step limit found no feasible update: the next residual (at the
    !> candidate it left) is infeasible
    logical :: limit_failed = .false.
    !> the current stage's last candidate is infeasible (a residual's or
    !> a step limit's verdict), the same on every rank
    logical :: infeasible = .false.
    !> why a model rejected a step's end state last (its accept hook; ''
    !> when none) and that state's time: the run's failure message quotes it
    character(len=512) :: rejection = ''
    real(rp) :: t_rejection = -huge(1.0_rp)
  end type pm_list_t

contains

  !> Append the model pm (moved into the list: pm is deallocated).
  subroutine pm_list_add(list, pm)
    type(pm_list_t), intent(inout) :: list
    class(process_model_t), allocatable, intent(inout) :: pm
    type(pm_slot_t), allocatable :: grown(:)
    integer :: k
    allocate(grown(list%n + 1))
    do k = 1, list%n
      call move_alloc(list%m(k)%pm, grown(k)%pm)
    end do
    call move_alloc(pm, grown(list%n + 1)%pm)
    call move_alloc(grown, list%m)
    list%n = list%n + 1
  end subroutine pm_list_add

  !> Every model of src appended to list, in src's order (src is left empty).
  subroutine pm_list_take(list, src)
    type(pm_list_t), intent(inout) :: list, src
    integer :: k
    do k = 1, src%n
      call pm_list_add(list, src%m(k)%pm)
    end do
    if (allocated(src%m)) deallocate(src%m)
    src%n = 0
  end subroutine pm_list_take

  !> Some process model is in the list.
  pure logical function pm_list_on(list)
    type(pm_list_t), intent(in) :: list
    pm_list_on = list%n > 0
  end function pm_list_on

  !> The models in the list.
  pure integer function pm_list_count(list)
    type(pm_list_t), intent(in) :: list
    pm_list_count = list%n
  end function pm_list_count

  !> Model k's name.
  function pm_list_name(list, k) result(s)
    type(pm_list_t), intent(in) :: list
    integer, intent(in) :: k
    character(len=:), allocatable :: s
    s = list%m(k)%pm%name()
  end function pm_list_name

  !> What the models need of the solver, together: a hint that one model
  !> gives holds (module process_model's pm_hints_t; ts_types is left
  !> empty: pm_list_ts_refusal asks each model), except smooth_start,
  !> which holds where every model with feasible_start gives it, and
  !> jacobian_settled, where every model with jacobian_every_iteration
  !> gives it.
  function pm_list_hints(list) result(h)
    type(pm_list_t), intent(in) :: list
    type(pm_hints_t) :: h
    type(pm_hints_t) :: e
    integer :: k
    h = pm_hints_t()
    h%smooth_start = .true.
    h%jacobian_settled = .true.
    do k = 1, list%n
      e = list%m(k)%pm%hints()
      h%jacobian_every_iteration = h%jacobian_every_iteration .or. e%jacobian_every_iteration
      h%jacobian_settled = h%jacobian_settled .and. (e%jacobian_settled .or. .not. e%jacobian_every_iteration)
      h%forcing_guarded = h%forcing_guarded .or. e%forcing_guarded
      h%basic_line_search = h%basic_line_search .or. e%basic_line_search
      h%feasible_start = h%feasible_start .or. e%feasible_start
      h%smooth_start = h%smooth_start .and. (e%smooth_start .or. .not. e%feasible_start)
      h%velocity_blocks = h%velocity_blocks .or. e%velocity_blocks
      h%state_blocks = h%state_blocks .or. e%state_blocks
      h%pair_blocks = h%pair_blocks .or. e%pair_blocks
      h%stiff_neighbour_blocks = h%stiff_neighbour_blocks .or. e%stiff_neighbour_blocks
    end do
  end function pm_list_hints

  !> The first model that does not allow the TS scheme ts_type (a TS
  !> type, or 'bdf' and its order: 'bdf2'; its hints' ts_types), and what
  !> it allows in words (its ts_why, else its list); k = 0: every model
  !> allows it.
  subroutine pm_list_ts_refusal(list, ts_type, k, allowed)
    type(pm_list_t), intent(in) :: list
    character(*), intent(in) :: ts_type
    integer, intent(out) :: k
    character(len=:), allocatable, intent(out) :: allowed
    type(pm_hints_t) :: e
    allowed = ''
    do k = 1, list%n
      e = list%m(k)%pm%hints()
      if (len_trim(e%ts_types) == 0) cycle
      if (index(','//trim(e%ts_types)//',', ','//trim(ts_type)//',') == 0) then
        allowed = trim(e%ts_types)
        if (len_trim(e%ts_why) > 0) allowed = trim(e%ts_why)
        return
      end if
    end do
    k = 0
  end subroutine pm_list_ts_refusal

  !> Each model's set-up (module process_model's setup hook), in the
  !> list's order; the first refusal (the same on every rank) ends it.
  !> Collective.
  subroutine pm_list_setup(list, cfg, lat, comm, u, cs, ierr, errmsg)
    type(pm_list_t), intent(inout) :: list
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: k
    ierr = 0
    errmsg = ''
    do k = 1, list%n
      call list%m(k)%pm%setup(cfg, lat, comm, u, cs, ierr, errmsg)
      if (ierr /= 0) return
    end do
  end subroutine pm_list_setup

  !> f += every model's forces at the ghosted state u at time t (the
  !> residual); the stage's feasibility from their statuses, or false
  !> after a step limit that found no feasible update (that residual is
  !> the candidate it left): agreed on every rank (one allreduce).
  !> Collective.
  subroutine pm_list_forces(list, lat, fixed, t, u, f, comm)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(in) :: comm
    integer :: k, status, bad, gbad, mpierr
    bad = 0
    do k = 1, list%n
      call list%m(k)%pm%forces(lat, fixed, t, u, f, status)
      if (status /= PM_FEASIBLE) bad = 1
    end do
    if (list%limit_failed) bad = 1
    call MPI_Allreduce(bad, gbad, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    list%infeasible = gbad /= 0
    list%limit_failed = .false.
  end subroutine pm_list_forces

  !> The stage's last candidate is infeasible (pm_list_forces,
  !> pm_list_step_limit): the same on every rank.
  pure logical function pm_list_infeasible(list)
    type(pm_list_t), intent(in) :: list
    pm_list_infeasible = list%infeasible
  end function pm_list_infeasible

  !> Every model's blocks at u, t into the list's node blocks (which the
  !> assemblies add) and pair blocks (which S's product and the reduced
  !> right-hand side add); then, where some rank has pair blocks, the rows
  !> they reach (the model's pair_rows). two_models: more than one model
  !> gave pair blocks (not handled: the caller refuses the run).
  !> Collective over comm.
  subroutine pm_list_jacobian(list, lat, fixed, t, u, comm, two_models)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    logical, intent(out) :: two_models
    integer :: k, n0, loc(2), glob(2), mpierr
    call node_blocks_begin(list%nodal, lat%ys, lat%ye)
    call pair_blocks_begin(list%pairs)
    two_models = .false.
    loc = 0
    do k = 1, list%n
      n0 = pair_blocks_count(list%pairs)
      call list%m(k)%pm%jacobian(lat, fixed, t, u, list%nodal, list%pairs)
      if (pair_blocks_count(list%pairs) == n0) cycle
      if (loc(1) /= 0) two_models = .true.
      loc(1) = k
    end do
    call node_blocks_end(list%nodal)
    call pair_blocks_end(list%pairs)
    loc(2) = merge(1, 0, two_models)
    call MPI_Allreduce(loc, glob, 2, MPI_INTEGER, MPI_MAX, comm, mpierr)
    two_models = glob(2) > 0
    list%pair_model = glob(1)
    list%pairs_on = glob(1) > 0
    if (.not. list%pairs_on) return
    if (.not. allocated(list%pair_slot)) allocate(list%pair_slot(0:lat%ny - 1))
    call list%m(list%pair_model)%pm%pair_rows(list%pair_slot, list%pair_nrows)
    if (allocated(list%pair_v)) then
      if (size(list%pair_v, 3) < list%pair_nrows) deallocate(list%pair_v)
    end if
    if (.not. allocated(list%pair_v)) allocate(list%pair_v(6, 0:lat%nx - 1, max(list%pair_nrows, 1)))
  end subroutine pm_list_jacobian

  !> Some rank has pair blocks at the last Jacobian: pm_list_pair_product
  !> and pm_list_pair_rhs gather (the same on every rank).
  pure logical function pm_list_pairs_on(list)
    type(pm_list_t), intent(in) :: list
    pm_list_pairs_on = list%pairs_on
  end function pm_list_pairs_on

  !> y += the pair blocks' part of S = a M - C - K/a times x, -(K_ab/a +
  !> C_ab) x_b over the entries whose node b is free (S has no constrained
  !> columns); x, y (3, 0:nx-1, ys:ye) owned rows, x's rows that the
  !> blocks reach gathered by the model that gave them. ierr /= 0: the
  !> gather failed, or a row is missing (its plan changed since the
  !> Jacobian). Collective (with pm_list_pairs_on).
  subroutine pm_list_pair_product(list, lat, comm, a, x, y, ierr)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: a
    real(rp), intent(in) :: x(:, 0:, lat%ys:)
    real(rp), intent(inout) :: y(:, 0:, lat%ys:)
    integer, intent(out) :: ierr
    integer :: err, gerr, mpierr
    associate (v => list%pair_v(1:3, :, 1:list%pair_nrows))
      call list%m(list%pair_model)%pm%pair_gather(lat, comm, x, v, ierr)
      call pair_blocks_apply(list%pairs, list%pair_slot, v, v, -1.0_rp / a, -1.0_rp, .true., lat%ys, y, err)
    end associate
    err = max(err, abs(ierr))
    call MPI_Allreduce(err, gerr, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    ierr = gerr
  end subroutine pm_list_pair_product

  !> g += -(K_ab w_x,b + C_ab w_v,b) over every entry (the reduced
  !> right-hand side's products, module reduced's g = -(K w_x + C w_v):
  !> constrained nodes b included); w (0:5, 0:nx-1, ys:ye) and g (3,
  !> 0:nx-1, ys:ye) owned rows. ierr as pm_list_pair_product. Collective.
  subroutine pm_list_pair_rhs(list, lat, comm, w, g, ierr)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: w(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: g(:, 0:, lat%ys:)
    integer, intent(out) :: ierr
    integer :: err, gerr, mpierr
    associate (v => list%pair_v(:, :, 1:list%pair_nrows))
      call list%m(list%pair_model)%pm%pair_gather(lat, comm, w, v, ierr)
      call pair_blocks_apply(list%pairs, list%pair_slot, v(1:3, :, :), v(4:6, :, :), -1.0_rp, -1.0_rp, .false., &
                             lat%ys, g, err)
    end associate
    err = max(err, abs(ierr))
    call MPI_Allreduce(err, gerr, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    ierr = gerr
  end subroutine pm_list_pair_rhs

  !> Newton's start x (owned rows) of a step from the accepted state x0 at
  !> t0 to t1, moved by each model in the list's order (its start hook: a
  !> model moves it into its domain); moved: the nodes moved on this rank.
  subroutine pm_list_start(list, lat, fixed, t0, t1, x0, x, moved)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: x(0:, 0:, lat%ys:)
    integer, intent(out) :: moved
    integer :: k, m
    moved = 0
    do k = 1, list%n
      call list%m(k)%pm%start(lat, fixed, t0, t1, x0, x, m)
      moved = moved + m
    end do
  end subroutine pm_list_start

  !> The fraction alpha of the update x -> x + dx (from x0 at t0 to a
  !> candidate at t1) that every model allows (the smallest of their
  !> limits), and infeasible: some model allows none (then the next
  !> residual is infeasible, and the stage too). Collective.
  subroutine pm_list_step_limit(list, lat, fixed, t0, t1, x0, x, dx, comm, alpha, infeasible)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    logical, intent(out) :: infeasible
    call limit_all(list, lat, fixed, t0, t1, x0, x, dx, comm, alpha, infeasible)
    if (infeasible) then
      list%limit_failed = .true.
      list%infeasible = .true.
    end if
  end subroutine pm_list_step_limit

  !> Every model's second-order correction of the Newton update dx at x
  !> (from the step's start at t0 to the stage at t1), in the list's
  !> order, before the step limits; changed: some model altered dx (the
  !> same on every rank). Collective.
  subroutine pm_list_correct(list, lat, fixed, t0, t1, x, dx, comm, changed)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    integer :: k
    logical :: ch
    changed = .false.
    do k = 1, list%n
      call list%m(k)%pm%correct(lat, fixed, t0, t1, x, dx, comm, ch)
      changed = changed .or. ch
    end do
  end subroutine pm_list_correct

  !> Every model's per-node limit of the update dx from x (a Newton
  !> update, or a predictor from the step's start), in the list's order,
  !> after the corrections and before the step limits; changed: some model
  !> shortened a node's update (the same on every rank). A model that
  !> does not write the hook costs a call. Collective.
  subroutine pm_list_limit_nodes(list, lat, fixed, t0, t1, x, dx, comm, changed)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    integer :: k
    logical :: ch
    changed = .false.
    do k = 1, list%n
      call list%m(k)%pm%limit_nodes(lat, fixed, t0, t1, x, dx, comm, ch)
      changed = changed .or. ch
    end do
  end subroutine pm_list_limit_nodes

  !> The fraction alpha of the move from the step's start x0 to a Newton
  !> start x0 + dx (a predictor) that every model allows, and infeasible:
  !> some model allows none (the caller starts from x0). Unlike
  !> pm_list_step_limit it leaves the stage's feasibility alone: no
  !> residual has been evaluated at the start yet. Collective.
  subroutine pm_list_start_limit(list, lat, fixed, t0, t1, x0, dx, comm, alpha, infeasible)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    logical, intent(out) :: infeasible
    call limit_all(list, lat, fixed, t0, t1, x0, x0, dx, comm, alpha, infeasible)
  end subroutine pm_list_start_limit

  !> Every model's step limit of the update dx at x: the smallest fraction
  !> alpha, and infeasible where some model allows none. Collective.
  subroutine limit_all(list, lat, fixed, t0, t1, x0, x, dx, comm, alpha, infeasible)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    logical, intent(out) :: infeasible
    integer :: k, status
    real(rp) :: a
    alpha = 1.0_rp
    infeasible = .false.
    do k = 1, list%n
      call list%m(k)%pm%step_limit(lat, fixed, t0, t1, x0, x, dx, comm, a, status)
      alpha = min(alpha, a)
      if (status /= PM_FEASIBLE) infeasible = .true.
    end do
  end subroutine limit_all

  !> A step's end state u at t, before the integrator accepts it: ok false
  !> when the stage's last candidate was infeasible or a model rejects it
  !> (the step is retried smaller; the model's reason kept for the run's
  !> failure message, pm_list_rejection). Collective.
  subroutine pm_list_accept(list, lat, fixed, t, u, comm, ok)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    logical, intent(out) :: ok
    integer :: k, status
    character(len=512) :: why
    ok = .not. list%infeasible
    if (.not. ok) return
    do k = 1, list%n
      call list%m(k)%pm%accept(lat, fixed, t, u, comm, status, why)
      if (status /= PM_FEASIBLE) then
        ok = .false.
        list%rejection = list%m(k)%pm%name()//': '//trim(why)
        list%t_rejection = t
        return
      end if
    end do
  end subroutine pm_list_accept

  !> The free owned nodes whose forces some model's step of dt does not
  !> resolve at the ghosted state u at t (mask(0:nx-1, ys:ye) .true.: the
  !> adaptive steps' error estimate leaves them out, module step_errors).
  subroutine pm_list_unresolved(list, lat, fixed, t, u, dt, mask)
    type(pm_list_t), intent(in) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t, dt
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(out) :: mask(0:, lat%ys:)
    integer :: k
    mask = .false.
    do k = 1, list%n
      call list%m(k)%pm%unresolved(lat, fixed, t, u, dt, mask)
    end do
  end subroutine pm_list_unresolved

  !> Why a model last rejected a step's end state, if that state's time is
  !> after t_after ('' otherwise): the same on every rank.
  function pm_list_rejection(list, t_after) result(s)
    type(pm_list_t), intent(in) :: list
    real(rp), intent(in) :: t_after
    character(len=:), allocatable :: s
    s = ''
    if (list%t_rejection > t_after) s = trim(list%rejection)
  end function pm_list_rejection

  !> After an accepted step (and at the run's start): each model's
  !> accepted hook; the first error (the same on every rank) ends it.
  !> Collective.
  subroutine pm_list_accepted(list, lat, fixed, t, u, comm, ierr, errmsg)
    type(pm_list_t), intent(inout) :: list
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: k
    ierr = 0
    errmsg = ''
    do k = 1, list%n
      call list%m(k)%pm%accepted(lat, fixed, t, u, comm, ierr, errmsg)
      if (ierr /= 0) return
    end do
  end subroutine pm_list_accepted

  !> Every model's output series and groups, in the list's order, and the
  !> sum of their terms of the energy balance.
  subroutine pm_list_output(list, series, groups, energy)
    type(pm_list_t), intent(in) :: list
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
    type(pm_series_t), allocatable :: s(:)
    type(pm_group_t), allocatable :: g(:)
    type(pm_energy_t) :: e
    integer :: k
    allocate(series(0), groups(0))
    energy = pm_energy_t()
    do k = 1, list%n
      call list%m(k)%pm%output(s, g, e)
      series = [series, s]
      groups = [groups, g]
      energy%potential = energy%potential + e%potential
      energy%dissipated = energy%dissipated + e%dissipated
      energy%external_work = energy%external_work + e%external_work
    end do
  end subroutine pm_list_output

  !> Every model's state as named values, in the list's order.
  subroutine pm_list_checkpoint(list, values)
    type(pm_list_t), intent(in) :: list
    type(named_value_t), allocatable, intent(out) :: values(:)
    type(named_value_t), allocatable :: v(:)
    integer :: k
    allocate(values(0))
    do k = 1, list%n
      call list%m(k)%pm%checkpoint(v)
      values = [values, v]
    end do
  end subroutine pm_list_checkpoint

  !> Every model's state from a checkpoint's named values (each model
  !> takes its own names).
  subroutine pm_list_restore(list, values)
    type(pm_list_t), intent(inout) :: list
    type(named_value_t), intent(in) :: values(:)
    integer :: k
    do k = 1, list%n
      call list%m(k)%pm%restore(values)
    end do
  end subroutine pm_list_restore

  !> A restart's state, positions x(3, 0:nx-1, ys:ye) at t, before the file
  !> changes: the first model's refusal (the same on every rank).
  !> Collective.
  subroutine pm_list_check_state(list, lat, t, x, comm, ierr, errmsg)
    type(pm_list_t), intent(in) :: list
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(:, 0:, lat%ys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: k
    ierr = 0
    errmsg = ''
    do k = 1, list%n
      call list%m(k)%pm%check_state(lat, t, x, comm, ierr, errmsg)
      if (ierr /= 0) return
    end do
  end subroutine pm_list_check_state

  !> Every model destroyed, the list emptied.
  subroutine pm_list_destroy(list)
    type(pm_list_t), intent(inout) :: list
    integer :: k
    do k = 1, list%n
      call list%m(k)%pm%destroy()
    end do
    if (allocated(list%m)) deallocate(list%m)
    list%n = 0
  end subroutine pm_list_destroy

  !> The node blocks the Jacobian hooks filled last (every assembly adds
  !> them: module reduced keeps this pointer).
  function pm_list_nodal(list) result(p)
    type(pm_list_t), intent(in), target :: list
    type(node_blocks_t), pointer :: p
    p => list%nodal
  end function pm_list_nodal

end module process_models
