! SPDX-License-Identifier: BSD-2-Clause
!> Contact with rigid obstacles as a process model (module process_model;
!> docs/design.md, "Process models" and "Contact"): its hooks on a rank's
!> strip, plain arrays and MPI reductions, no PETSc. The kernel of one
!> node against one obstacle is module contact. Each free owned node
!> meets each obstacle through contact_node: an IPC barrier on the gap
!> plus smoothed Coulomb friction whose normal force lam and normal nlag
!> are lagged: taken at the last accepted state (the step's start, t_n;
!> the accepted hook) and frozen during the step's Newton solve, so that
!> friction is implicit in the velocity with a fixed magnitude (IPC's
!> lagged friction). Constrained nodes take no contact force (their rows
!> are replaced).
!>
!> Obstacle poses are a pure function of time: every hook that needs them
!> evaluates them at its own time t from the keyframes (poses_at, kernel
!> obstacle_motion; a static obstacle is its base pose), nothing caches a
!> "current" pose. The step limit checks a whole step's path against the
!> obstacles' motion over [t0, t1].
!>
!> Acceptance (issue 47 item 5): no state is accepted with a gap below
!> the floor FLOOR_FRACTION * contact_dhat (the accept hook rejects it,
!> and the step is retried smaller); the barrier force of a node-obstacle
!> pair of an accepted state is then at most kappa |b'(floor)|, the
!> barrier's force at the floor (about 1e6 kappa dhat), and friction's at
!> most mu times that.
module contact_model
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, contact_config
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t, constraint_count, constraint_node, constraint_path, constraint_base, &
                         constraint_keyframes, constraint_release_time, PATH_KEYFRAMES
  use node_blocks, only: node_blocks_t, node_blocks_add
  use pair_blocks, only: pair_blocks_t
  use checkpoint_record, only: named_value_t, named_value
  use contact, only: obstacle_t, contact_params_t, contact_node, time_of_impact, signed_distance, friction_power, &
                     time_of_impact_moving, SHAPE_BOX, SHAPE_CAPSULE
  use obstacle_motion, only: obstacle_at
  use process_model, only: process_model_t, pm_hints_t, pm_series_t, pm_group_t, pm_energy_t, PM_FEASIBLE, &
                           PM_INFEASIBLE
  use strings, only: itoa, real_es, real_brief
  implicit none
  private
  public :: contact_model_t, contact_init, obstacle_from_config, FLOOR_FRACTION
  public :: contact_obstacle_at, contact_swept

  !> The acceptance floor of the gap, as a fraction of contact_dhat: a
  !> state with a gap below FLOOR_FRACTION * dhat is never accepted
  !> (docs/contact.md, "Acceptance"). At the floor the barrier's force,
  !> about kappa dhat^2 / gap, is a million times its scale kappa dhat, and
  !> the gap (1 nm with dhat = 1 mm) still some 4e6 rounding units of a
  !> coordinate of 1 m, so the force is known to six digits; a gap of
  !> 1.7e-17 m, accepted before, was less than one. Not higher: backward
  !> Euler stops a node that hits an obstacle within one step, at a gap of
  !> about kappa dhat^2 dt / (m v), which is 1e-4 dhat for a sheet of
  !> 2.8 g nodes dropped 0.45 m at dt = 1 ms (kappa = 1 N/m, dhat = 1 mm),
  !> and a smaller step only makes it smaller.
  real(rp), parameter :: FLOOR_FRACTION = 1.0e-6_rp

  !> The keyframes of the obstacles (&contact's obstacle_time,
  !> obstacle_offset, obstacle_close): poses_at evaluates them.
  type :: obstacle_keys_t
    type(obstacle_t), allocatable :: base(:)        !< (n_obs) poses with zero keyframe offset
    integer, allocatable :: nk(:)                   !< (n_obs) keyframes of each obstacle; 0: static
    real(rp), allocatable :: tk(:, :)               !< (max nk, n_obs) keyframe times [time]
    real(rp), allocatable :: off(:, :, :)           !< (3, max nk, n_obs) translations at the keyframes [length]
    real(rp), allocatable :: close(:, :)            !< (max nk, n_obs) closing offsets at the keyframes [length]
    real(rp), allocatable :: cdir(:, :)             !< (3, n_obs) unit closing directions [1]
  end type obstacle_keys_t

  !> The contact diagnostics of the last accepted state and of the run so
  !> far, over all ranks (the record of the accepted hook, which its
  !> output and checkpoint hooks read).
  type :: contact_summary_t
    real(rp) :: min_gap_run = huge(1.0_rp)          !< smallest gap over every accepted state [length]
    integer :: states_checked = 0                   !< accepted states checked (the start included)
    integer :: limited_steps = 0                    !< Newton updates scaled by the step limit
    ! the last accepted state's
    integer :: active = 0                           !< node-obstacle pairs with gap < dhat
    real(rp) :: force(3) = 0.0_rp                   !< total contact force, barrier and friction [force]
    real(rp) :: normal_force(3) = 0.0_rp            !< the barrier's part of it, sum of f_n g [force]
    real(rp) :: energy = 0.0_rp                     !< barrier energy [energy]
    real(rp) :: min_gap = huge(1.0_rp)              !< smallest gap [length]
    !> friction work since the start [energy]: the trapezoid rule over each
    !> accepted step on the friction power with the step's own lag at both
    !> ends (the lag taken at its start), dissipated (>= 0)
    real(rp) :: friction_work = 0.0_rp
    !> work of the contact forces of moving obstacles on the cloth since the
    !> start [energy]: sum over obstacles of (their contact force on the
    !> cloth) . (their velocity), by the same trapezoid rule (an external
    !> work of the energy balance; 0 with static obstacles)
    real(rp) :: obstacle_work = 0.0_rp
  end type contact_summary_t

  !> Contact as a process model: its state on a rank's strip, written by
  !> this module's procedures alone (private components).
  type, extends(process_model_t) :: contact_model_t
    private
    integer :: n_obs = 0
    type(obstacle_keys_t) :: keys                   !< the obstacles' base poses and keyframes
    logical :: moving = .false.                     !< some obstacle has keyframes
    type(contact_params_t) :: cp
    real(rp) :: floor = 0.0_rp                      !< the acceptance floor of the gap [length]
    real(rp) :: output_interval = 0.0_rp            !< the contact line's times: its multiples [time]
    real(rp), allocatable :: lam(:, :, :)           !< (n_obs, 0:nx-1, ys:ye) lagged normal force [force]
    real(rp), allocatable :: nlag(:, :, :, :)       !< (3, n_obs, 0:nx-1, ys:ye) lagged normal [1]
    ! The run's diagnostics, over all ranks: written by the accepted hook,
    ! the step limit (its count) and restore only.
    type(contact_summary_t) :: rec
    logical :: have_last = .false.                  !< t_last, pfric_last hold the last accepted state's
    !> the next state recorded is a checkpoint's, recorded already by the
    !> run that wrote it (restore): not counted again
    logical :: resumed = .false.
    real(rp) :: t_last = 0.0_rp                     !< time of the last accepted state [time]
    real(rp) :: pfric_last = 0.0_rp                 !< friction power there with the next step's lag [energy/time]
    real(rp) :: pobs_last = 0.0_rp                  !< obstacles' power there with the next step's lag [energy/time]
  contains
    procedure :: name => contact_name
    procedure :: hints => contact_hints
    procedure :: setup => contact_setup
    procedure :: forces => contact_forces
    procedure :: jacobian => contact_jacobian
    procedure :: step_limit => contact_step_limit
    procedure :: accept => contact_accept
    procedure :: accepted => contact_accepted
    procedure :: output => contact_output
    procedure :: checkpoint => contact_checkpoint
    procedure :: restore => contact_restore
    procedure :: check_state => contact_check_state
    procedure :: destroy => contact_destroy
  end type contact_model_t

  character(len=*), parameter :: SHAPE_NAMES(4) = [character(len=8) :: 'plane', 'sphere', 'box', 'capsule']

contains

  ! ----------------------------------------------------------- the hooks

  function contact_name(this) result(s)
    class(contact_model_t), intent(in) :: this
    character(len=:), allocatable :: s
    s = 'contact'
  end function contact_name

  !> What contact needs of the solver (docs/design.md, "Contact"): the
  !> Jacobian at every Newton iteration (a lagged one's friction blocks
  !> belong to the iterate before: a two-cycle across the smoothing band),
  !> no inexact-Newton forcing (its loose inner solves failed a drop's
  !> impact), full steps on the 6-dof path too (the update is limited
  !> already; bt's model of ||F||^2 does not hold across the barrier's
  !> log), Newton from the last accepted, feasible state, blocks with
  !> velocity parts (friction) that change with the state, and beuler
  !> alone (its Newton solve starts from the accepted state).
  pure function contact_hints(this) result(h)
    class(contact_model_t), intent(in) :: this
    type(pm_hints_t) :: h
    h = pm_hints_t(jacobian_every_iteration=.true., forcing_off=.true., basic_line_search=.true., &
                   feasible_start=.true., velocity_blocks=.true., state_blocks=.true., ts_types='beuler')
  end function contact_hints

  !> Set-up: the obstacles and parameters (contact_init), the contact
  !> line's times (multiples of output_interval); then the scene's start
  !> (issue 47 item 7), collectively: no node of the initial state u
  !> inside an obstacle or within its contact_thickness (a gap below the
  !> acceptance floor), and no prescribed node's path (pinned or
  !> keyframed, until its release or t_end) entering one, each obstacle
  !> along its own keyframes.
  subroutine contact_setup(this, cfg, lat, comm, u, cs, ierr, errmsg)
    class(contact_model_t), intent(inout) :: this
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    call contact_init(this, cfg%contact, lat)
    this%output_interval = cfg%output%output_interval
    call check_nodes(this, lat, 0.0_rp, u(0:2, :, lat%ys:lat%ye), comm, 'input: &contact: ', 'the initial state', &
                     ': move the cloth, the obstacle or contact_thickness', ierr, errmsg)
    if (ierr /= 0) return
    call check_paths(this, lat, cs, min(cfg%time%t_end, constraint_release_time(cs)), comm, ierr, errmsg)
  end subroutine contact_setup

  !> f += contact forces on the free owned nodes, the obstacles at t;
  !> status PM_INFEASIBLE where a node has a gap <= 0 (then f is not used).
  subroutine contact_forces(this, lat, fixed, t, u, f, status)
    class(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: status
    integer :: i, j, k, nbad
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(this%n_obs)
    logical :: act
    call poses_at(this, t, obs)
    nbad = 0
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, this%n_obs
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          if (.not. (d - this%cp%thickness > 0.0_rp)) then
            nbad = nbad + 1
            cycle
          end if
          call contact_node(obs(k), this%cp, u(0:2, i, j), u(3:5, i, j), this%lam(k, i, j), this%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          f(:, i, j) = f(:, i, j) + fc
        end do
      end do
    end do
    status = merge(PM_INFEASIBLE, PM_FEASIBLE, nbad > 0)
  end subroutine contact_forces

  !> The diagonal blocks df/dx, df/dv of the nodes in contact (or with
  !> friction) at state u, the obstacles at t, into nodal (no pairs).
  subroutine contact_jacobian(this, lat, fixed, t, u, nodal, pairs)
    class(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nodal
    type(pair_blocks_t), intent(inout) :: pairs
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, bx(3, 3), bv(3, 3)
    type(obstacle_t) :: obs(this%n_obs)
    logical :: act, any_blk
    call poses_at(this, t, obs)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        bx = 0.0_rp
        bv = 0.0_rp
        any_blk = .false.
        do k = 1, this%n_obs
          ! project: the barrier's stiffness with the negative eigenvalues of
          ! its energy Hessian set to zero (curved shapes), so that S stays SPD.
          call contact_node(obs(k), this%cp, u(0:2, i, j), u(3:5, i, j), this%lam(k, i, j), this%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act, project=.true.)
          if (.not. (act .or. this%lam(k, i, j) > 0.0_rp)) cycle
          any_blk = .true.
          bx = bx + kx
          bv = bv + kv
        end do
        if (any_blk) call node_blocks_add(nodal, i, j, bx, bv)
      end do
    end do
  end subroutine contact_jacobian

  !> The Newton update from x toward x + dx limited (IPC): where a free node
  !> would reach an obstacle (its pose at t1, the step's end) along dx,
  !> alpha = 0.8 times the first time of impact over all nodes and
  !> obstacles; where obstacles move over [t0, t1], alpha is halved (at
  !> most 10 times) until no node's path from x0 (the step's start) to
  !> x + alpha dx crosses them (contact_swept), and status PM_INFEASIBLE
  !> when halving does not help (the step is retried smaller). A limited
  !> update is counted. Collective.
  subroutine contact_step_limit(this, lat, fixed, t0, t1, x0, x, dx, comm, alpha, status)
    class(contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    integer, intent(out) :: status
    integer :: i, j, k, try, ncross, gcross, mpierr
    real(rp) :: a, ga, s
    type(obstacle_t) :: obs(this%n_obs)
    logical :: moving
    call poses_at(this, t1, obs)
    a = 1.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, this%n_obs
          a = min(a, time_of_impact(obs(k), this%cp%thickness, x(0:2, i, j), dx(0:2, i, j)))
        end do
      end do
    end do
    call MPI_Allreduce(a, ga, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    s = 1.0_rp
    if (ga < 1.0_rp) s = 0.8_rp * ga
    gcross = 0
    moving = obstacles_move(this, t0, t1)
    if (moving) then
      do try = 0, 10
        ncross = contact_swept(this, lat, fixed, t0, t1, x0, x, s * dx)
        call MPI_Allreduce(ncross, gcross, 1, MPI_INTEGER, MPI_SUM, comm, mpierr)
        if (gcross == 0) exit
        s = 0.5_rp * s
      end do
    end if
    alpha = s
    status = PM_FEASIBLE
    if (gcross > 0) then
      status = PM_INFEASIBLE
    else if (s < 1.0_rp) then
      this%rec%limited_steps = this%rec%limited_steps + 1
    end if
  end subroutine contact_step_limit

  !> The acceptance of a step's end state u at t (issue 47 item 5): its
  !> smallest gap over the free nodes and the obstacles at t must be at
  !> least the floor (FLOOR_FRACTION contact_dhat); else PM_INFEASIBLE (the
  !> step is retried smaller) and why. Collective.
  subroutine contact_accept(this, lat, fixed, t, u, comm, status, why)
    class(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: status
    character(*), intent(out) :: why
    real(rp) :: gmin, g
    integer :: mpierr
    gmin = smallest_gap(this, lat, fixed, t, u)
    call MPI_Allreduce(gmin, g, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    status = merge(PM_FEASIBLE, PM_INFEASIBLE, g >= this%floor)
    why = ''
    if (status == PM_FEASIBLE) return
    why = 'the state at t = '//real_brief(t)//' has a gap of '//real_brief(g)//', below the acceptance floor '// &
          real_brief(this%floor)//' (1e-6 contact_dhat; docs/contact.md, "Acceptance"): backward Euler stops an '// &
          'impact within one step at a gap of about kappa dhat^2 dt / (m v), smaller with a smaller step; '// &
          'a stiffer barrier (contact_stiffness) or a larger contact_dhat keeps it above the floor'
  end subroutine contact_accept

  !> An accepted state u at t (after each accepted step and at each
  !> TSSolve's start, and at t = 0 before the first step): the smallest
  !> gap over every free node and obstacle (collective); a gap <= 0 is an
  !> error (it cannot pass the accept hook: a safety net). Then the
  !> friction lag for the next step, the state's record (the /contact
  !> series, the friction work and the moving obstacles' work), and a line
  !> at each output time. A state recorded already is left alone. Collective.
  subroutine contact_accepted(this, lat, fixed, t, u, comm, ierr, errmsg)
    class(contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: gmin, ftot(3), fnrm(3), ebar, pfric, pstart, pobs, ostart, loc(11), glob(11), r
    integer :: nact, gnact, rank, mpierr
    ierr = 0
    errmsg = ''
    ! TSSolve calls its monitors at every window's start too, with the state
    ! its last step accepted: checked already
    if (this%have_last .and. t == this%t_last) return
    call contact_stats(this, lat, fixed, t, u, gmin, nact, ftot, fnrm, ebar, pfric, pobs)
    call contact_lag(this, lat, fixed, t, u, pstart, ostart)
    call MPI_Allreduce(gmin, r, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    gmin = r
    loc = [ftot, fnrm, ebar, pfric, pstart, pobs, ostart]
    call MPI_Allreduce(loc, glob, 11, MPI_DOUBLE_PRECISION, MPI_SUM, comm, mpierr)
    call MPI_Allreduce(nact, gnact, 1, MPI_INTEGER, MPI_SUM, comm, mpierr)
    call contact_record(this, t, gmin, gnact, glob(1:3), glob(4:6), glob(7), glob(8), glob(9), glob(10), glob(11))
    if (.not. (gmin > 0.0_rp)) then
      ierr = 1
      errmsg = 'nuno: contact: an accepted state penetrates an obstacle at t = '//real_es(t)//': smallest gap '// &
               real_es(gmin)
      return
    end if
    call MPI_Comm_rank(comm, rank, mpierr)
    r = t / this%output_interval
    if (rank == 0 .and. abs(r - anint(r)) <= 1.0e-9_rp * max(1.0_rp, r)) then
      associate (c => this%rec)
        write(*, '(a)') 'contact: t = '//real_es(t)//', active = '//itoa(gnact)//', force = '// &
          real_es(glob(1))//' '//real_es(glob(2))//' '//real_es(glob(3))//', min gap = '//real_es(gmin)// &
          ', min gap of all accepted states = '//real_es(c%min_gap_run)//', states checked = '// &
          itoa(c%states_checked)//', limited Newton steps = '//itoa(c%limited_steps)// &
          ', barrier energy = '//real_es(glob(7))//', friction work = '//real_es(c%friction_work)
      end associate
    end if
  end subroutine contact_accepted

  !> The series of the last accepted state (docs/model.md sections 9 and
  !> 10): /energy/barrier and the group /contact; the barrier energy a
  !> potential energy of the balance, the friction work a dissipation,
  !> the moving obstacles' work an external work.
  subroutine contact_output(this, series, groups, energy)
    class(contact_model_t), intent(in) :: this
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
    associate (c => this%rec)
      series = [ &
        real_series('/energy/barrier', 'barrier (contact) energy, sum of kappa b(gap) over node-obstacle pairs', &
                    'energy', [c%energy]), &
        count_series('/contact/active', 'node-obstacle pairs with a gap below contact_dhat', c%active), &
        real_series('/contact/force', 'total contact force on the cloth, barrier and friction, sum over nodes, [t][xyz]', &
                    'force', c%force), &
        real_series('/contact/normal_force', 'normal (barrier) contact force on the cloth, sum of f_n n over nodes, [t][xyz]', &
                    'force', c%normal_force), &
        real_series('/contact/friction_work', 'friction work since the start (dissipated, >= 0; part of /energy/dissipated)', &
                    'energy', [c%friction_work]), &
        real_series('/contact/barrier_energy', &
                    'barrier energy, sum of kappa b(gap) over node-obstacle pairs (the same as /energy/barrier)', &
                    'energy', [c%energy]), &
        real_series('/contact/min_gap', 'smallest gap (signed distance - contact_thickness) over free nodes and obstacles', &
                    'length', [c%min_gap]), &
        real_series('/contact/min_gap_run', 'smallest gap over every accepted state since the start', 'length', &
                    [c%min_gap_run]), &
        count_series('/contact/states_checked', &
                     'accepted states checked for penetration since the start (the initial state included)', c%states_checked)]
      groups = [pm_group_t(name='/contact', description='contact with the obstacles of &contact, per output step')]
      energy = pm_energy_t(potential=c%energy, dissipated=c%friction_work, external_work=c%obstacle_work)
    end associate
  end subroutine contact_output

  !> The run's diagnostics that go on across a restart: the friction work,
  !> the obstacle work [energy], the smallest gap so far [length], the
  !> states checked and the limited Newton updates (the checkpoint
  !> attributes of files written before the process models).
  subroutine contact_checkpoint(this, values)
    class(contact_model_t), intent(in) :: this
    type(named_value_t), allocatable, intent(out) :: values(:)
    values = [named_value('contact_friction_work', [this%rec%friction_work], .false.), &
              named_value('contact_obstacle_work', [this%rec%obstacle_work], .false.), &
              named_value('contact_min_gap_run', [this%rec%min_gap_run], .false.), &
              named_value('contact_states_checked', [real(this%rec%states_checked, rp)], .true.), &
              named_value('contact_limited_steps', [real(this%rec%limited_steps, rp)], .true.)]
  end subroutine contact_checkpoint

  !> A restart's run diagnostics from its checkpoint's named values (none
  !> without contact_friction_work: a file of a run without obstacles; no
  !> contact_obstacle_work in files written before it: 0). The
  !> checkpoint's own state, recorded again at the restart's first
  !> accepted hook, is not counted twice.
  subroutine contact_restore(this, values)
    class(contact_model_t), intent(inout) :: this
    type(named_value_t), intent(in) :: values(:)
    real(rp) :: v
    if (.not. find(values, 'contact_friction_work', v)) return
    this%rec%friction_work = v
    this%rec%obstacle_work = 0.0_rp
    if (find(values, 'contact_obstacle_work', v)) this%rec%obstacle_work = v
    if (find(values, 'contact_min_gap_run', v)) this%rec%min_gap_run = v
    if (find(values, 'contact_states_checked', v)) this%rec%states_checked = nint(v)
    if (find(values, 'contact_limited_steps', v)) this%rec%limited_steps = nint(v)
    this%have_last = .false.
    this%resumed = this%rec%states_checked > 0
  end subroutine contact_restore

  !> A restart's state, positions x(3, 0:nx-1, ys:ye) at t: no node inside
  !> an obstacle or within its contact_thickness (the obstacles may have
  !> changed since the run that wrote it). Collective.
  subroutine contact_check_state(this, lat, t, x, comm, ierr, errmsg)
    class(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(:, 0:, lat%ys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    call check_nodes(this, lat, t, x, comm, '-nuno_restart: &contact: ', 'the checkpoint''s state at t = '//real_brief(t), &
                     ': the obstacles are not those of the run that wrote it', ierr, errmsg)
  end subroutine contact_check_state

  subroutine contact_destroy(this)
    class(contact_model_t), intent(inout) :: this
    if (allocated(this%lam)) deallocate(this%lam)
    if (allocated(this%nlag)) deallocate(this%nlag)
  end subroutine contact_destroy

  ! ------------------------------------------------------- the obstacles

  !> Obstacles and parameters from &contact (cc) for the strip of lat;
  !> lags zero (no friction at the first step). No communication (the
  !> set-up hook's checks follow it).
  subroutine contact_init(this, cc, lat)
    type(contact_model_t), intent(inout) :: this
    type(contact_config), intent(in) :: cc
    type(lattice_t), intent(in) :: lat
    integer :: k, m
    this%n_obs = cc%n_obstacles
    allocate(this%keys%base(this%n_obs))
    do k = 1, this%n_obs
      this%keys%base(k) = obstacle_from_config(cc, k)
    end do
    this%keys%nk = cc%n_keyframes(1:this%n_obs)
    this%moving = any(this%keys%nk > 0)
    m = max(1, maxval(this%keys%nk))
    this%keys%tk = cc%key_time(1:m, 1:this%n_obs)
    this%keys%off = cc%key_offset(:, 1:m, 1:this%n_obs)
    this%keys%close = cc%key_close(1:m, 1:this%n_obs)
    this%keys%cdir = cc%close_dir(:, 1:this%n_obs)
    this%cp = contact_params_t(thickness=cc%thickness, dhat=cc%dhat, kappa=cc%stiffness, eps_v=cc%eps_v)
    this%floor = FLOOR_FRACTION * this%cp%dhat
    allocate(this%lam(this%n_obs, 0:lat%nx - 1, lat%ys:lat%ye), this%nlag(3, this%n_obs, 0:lat%nx - 1, lat%ys:lat%ye))
    this%lam = 0.0_rp
    this%nlag = 0.0_rp
  end subroutine contact_init

  !> Obstacle k of &contact (checked: unit normal and box axis) at zero
  !> keyframe offset. A box's local z is the normal, its local x the axis
  !> (orthogonal to the normal), its local y = z x x.
  pure function obstacle_from_config(cc, k) result(o)
    type(contact_config), intent(in) :: cc
    integer, intent(in) :: k
    type(obstacle_t) :: o
    real(rp) :: ex(3), ez(3)
    o%shape = cc%shape_code(k)
    o%p = cc%point(:, k)
    o%n = cc%normal(:, k)
    o%r = cc%radius(k)
    o%mu = cc%mu(k)
    if (o%shape == SHAPE_BOX) then
      ez = cc%normal(:, k)
      ex = cc%axis(:, k)
      o%h = cc%half_size(:, k)
      o%axes(:, 1) = ex
      o%axes(:, 2) = [ez(2) * ex(3) - ez(3) * ex(2), ez(3) * ex(1) - ez(1) * ex(3), ez(1) * ex(2) - ez(2) * ex(1)]
      o%axes(:, 3) = ez
    else if (o%shape == SHAPE_CAPSULE) then
      o%q = cc%end_pt(:, k)
    end if
  end function obstacle_from_config

  !> Every obstacle's pose at t (and its velocity, the slope of the
  !> keyframe segment that ends at t; with right, of the one that starts
  !> there): a static obstacle is its base pose.
  pure subroutine poses_at(this, t, obs, right)
    type(contact_model_t), intent(in) :: this
    real(rp), intent(in) :: t
    type(obstacle_t), intent(out) :: obs(:)
    logical, intent(in), optional :: right
    integer :: k
    do k = 1, this%n_obs
      obs(k) = obstacle_at_time(this, k, t, right)
    end do
  end subroutine poses_at

  !> Obstacle k's pose at t (poses_at).
  pure function obstacle_at_time(this, k, t, right) result(o)
    type(contact_model_t), intent(in) :: this
    integer, intent(in) :: k
    real(rp), intent(in) :: t
    logical, intent(in), optional :: right
    type(obstacle_t) :: o
    integer :: m
    m = this%keys%nk(k)
    if (m == 0) then
      o = this%keys%base(k)
    else
      call obstacle_at(this%keys%base(k), this%keys%tk(1:m, k), this%keys%off(:, 1:m, k), this%keys%close(1:m, k), &
                       this%keys%cdir(:, k), t, o, right)
    end if
  end function obstacle_at_time

  !> Obstacle k at time t (for tests and the figures' checks).
  pure function contact_obstacle_at(this, k, t) result(o)
    type(contact_model_t), intent(in) :: this
    integer, intent(in) :: k
    real(rp), intent(in) :: t
    type(obstacle_t) :: o
    o = obstacle_at_time(this, k, t)
  end function contact_obstacle_at

  !> Whether some obstacle moves between t0 and t1.
  pure logical function obstacles_move(this, t0, t1) result(mv)
    type(contact_model_t), intent(in) :: this
    real(rp), intent(in) :: t0, t1
    integer :: k
    real(rp) :: d(3)
    type(obstacle_t) :: o0, o1
    mv = .false.
    if (.not. this%moving) return
    do k = 1, this%n_obs
      if (this%keys%nk(k) < 2) cycle
      call pose_pair(this, k, t0, t1, o0, o1, d)
      if (any(d /= 0.0_rp)) mv = .true.
    end do
  end function obstacles_move

  !> Obstacle k at t0 and t1 and its translation d over [t0, t1].
  pure subroutine pose_pair(this, k, t0, t1, o0, o1, d)
    type(contact_model_t), intent(in) :: this
    integer, intent(in) :: k
    real(rp), intent(in) :: t0, t1
    type(obstacle_t), intent(out) :: o0, o1
    real(rp), intent(out) :: d(3)
    o0 = obstacle_at_time(this, k, t0)
    o1 = obstacle_at_time(this, k, t1)
    d = o1%p - o0%p
  end subroutine pose_pair

  !> Free owned nodes whose path over the step, from x0 (the accepted
  !> state at t0) to x + dx (a Newton candidate at t1), meets an obstacle
  !> that moves over the step (continuous collision detection of the
  !> motion relative to the obstacle, time_of_impact_moving: exact for a
  !> translation linear over the step). A candidate outside every obstacle
  !> at t1 can still have crossed a thin or fast one on the way: this
  !> counts such nodes (this rank; the caller sums).
  integer function contact_swept(this, lat, fixed, t0, t1, x0, x, dx) result(n)
    type(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer :: i, j, k
    real(rp) :: d(3)
    type(obstacle_t) :: o0, o1
    n = 0
    if (.not. this%moving) return
    do k = 1, this%n_obs
      if (this%keys%nk(k) < 2) cycle
      call pose_pair(this, k, t0, t1, o0, o1, d)
      if (all(d == 0.0_rp)) cycle
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          if (fixed(i, j)) cycle
          if (time_of_impact_moving(o0, this%cp%thickness, x0(0:2, i, j), &
                                    x(0:2, i, j) + dx(0:2, i, j) - x0(0:2, i, j), d) < 1.0_rp) n = n + 1
        end do
      end do
    end do
  end function contact_swept

  ! -------------------------------------------------- the accepted states

  !> This rank's smallest gap over the free nodes of u and the obstacles at t.
  real(rp) function smallest_gap(this, lat, fixed, t, u) result(gmin)
    type(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer :: i, j, k
    real(rp) :: d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(this%n_obs)
    call poses_at(this, t, obs)
    gmin = huge(1.0_rp)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, this%n_obs
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          gmin = min(gmin, d - this%cp%thickness)
        end do
      end do
    end do
  end function smallest_gap

  !> Friction's lag from an accepted state u at t (the next step's start):
  !> lam = the barrier's normal force, nlag = the surface normal; pstart,
  !> this rank's friction power at u with the new lag [energy/time] (the
  !> start of the next step's friction work), and pobs, the power of the
  !> moving obstacles' contact forces on the cloth there [energy/time] (the
  !> start of the next step's obstacle work). Both take the obstacles'
  !> velocities over the next step (at a keyframe, the segment after it).
  subroutine contact_lag(this, lat, fixed, t, u, pstart, pobs)
    type(contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: pstart, pobs
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3), zero3(3)
    type(obstacle_t) :: obs(this%n_obs), onext(this%n_obs)
    logical :: act
    zero3 = 0.0_rp
    call poses_at(this, t, obs)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, this%n_obs
          this%lam(k, i, j) = 0.0_rp
          this%nlag(:, k, i, j) = 0.0_rp
          if (fixed(i, j) .or. obs(k)%mu <= 0.0_rp) cycle
          call contact_node(obs(k), this%cp, u(0:2, i, j), u(3:5, i, j), 0.0_rp, zero3, fc, kx, kv, e, fn, act)
          if (.not. act) cycle
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          this%lam(k, i, j) = fn
          this%nlag(:, k, i, j) = g
        end do
      end do
    end do
    ! the poses at t with the velocities of the step that starts there
    onext = obs
    if (this%moving) call poses_at(this, t, onext, right=.true.)
    pstart = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, this%n_obs
          if (this%lam(k, i, j) > 0.0_rp) pstart = pstart + &
            friction_power(onext(k), this%cp, u(3:5, i, j), this%lam(k, i, j), this%nlag(:, k, i, j))
        end do
      end do
    end do
    pobs = 0.0_rp
    if (.not. this%moving) return
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, this%n_obs
          if (all(onext(k)%vel == 0.0_rp)) cycle
          call signed_distance(onext(k), u(0:2, i, j), d, g, hd)
          if (.not. (d - this%cp%thickness > 0.0_rp)) cycle
          call contact_node(onext(k), this%cp, u(0:2, i, j), u(3:5, i, j), this%lam(k, i, j), this%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          pobs = pobs + dot_product(fc, onext(k)%vel)
        end do
      end do
    end do
  end subroutine contact_lag

  !> This rank's contact statistics at state u, the obstacles at t: the
  !> smallest gap (free nodes), the active contacts (gap < dhat), the total
  !> contact force (3) and its barrier part fnrm (3, sum of f_n g), the
  !> barrier energy, the friction power (with the lag of the step that
  !> ended at u) and the power of the obstacles' contact forces on the
  !> cloth, sum of f . v_obs (with that lag and the obstacles' velocities
  !> over that step).
  subroutine contact_stats(this, lat, fixed, t, u, gmin, nact, ftot, fnrm, ebar, pfric, pobs)
    type(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: gmin, ftot(3), fnrm(3), ebar, pfric, pobs
    integer, intent(out) :: nact
    integer :: i, j, k
    real(rp) :: fc(3), kx(3, 3), kv(3, 3), e, fn, d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(this%n_obs)
    logical :: act
    call poses_at(this, t, obs)
    gmin = huge(1.0_rp)
    nact = 0
    ftot = 0.0_rp
    fnrm = 0.0_rp
    ebar = 0.0_rp
    pfric = 0.0_rp
    pobs = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) cycle
        do k = 1, this%n_obs
          call signed_distance(obs(k), u(0:2, i, j), d, g, hd)
          gmin = min(gmin, d - this%cp%thickness)
          if (.not. (d - this%cp%thickness > 0.0_rp)) cycle
          call contact_node(obs(k), this%cp, u(0:2, i, j), u(3:5, i, j), this%lam(k, i, j), this%nlag(:, k, i, j), &
                            fc, kx, kv, e, fn, act)
          if (act) nact = nact + 1
          ftot = ftot + fc
          fnrm = fnrm + fn * g
          ebar = ebar + e
          pfric = pfric + friction_power(obs(k), this%cp, u(3:5, i, j), this%lam(k, i, j), this%nlag(:, k, i, j))
          pobs = pobs + dot_product(fc, obs(k)%vel)
        end do
      end do
    end do
  end subroutine contact_stats

  !> Record an accepted state at t, its statistics reduced over all ranks:
  !> the smallest gap gmin, the active pairs, the total and normal forces,
  !> the barrier energy; pend the friction power at t with the lag of the
  !> step that ended there, pstart with the next step's [energy/time];
  !> oend and ostart the same of the moving obstacles' power on the cloth.
  !> The friction work and the obstacle work grow by the trapezoid rule
  !> over the step, both ends with the step's own lag.
  subroutine contact_record(this, t, gmin, nact, ftot, fnrm, ebar, pend, pstart, oend, ostart)
    type(contact_model_t), intent(inout) :: this
    real(rp), intent(in) :: t, gmin, ftot(3), fnrm(3), ebar, pend, pstart, oend, ostart
    integer, intent(in) :: nact
    associate (r => this%rec)
      if (this%have_last) then
        r%friction_work = r%friction_work + 0.5_rp * (t - this%t_last) * (this%pfric_last + pend)
        r%obstacle_work = r%obstacle_work + 0.5_rp * (t - this%t_last) * (this%pobs_last + oend)
      end if
      if (.not. this%resumed) r%states_checked = r%states_checked + 1
      r%min_gap_run = min(r%min_gap_run, gmin)
      r%active = nact
      r%force = ftot
      r%normal_force = fnrm
      r%energy = ebar
      r%min_gap = gmin
    end associate
    this%resumed = .false.
    this%have_last = .true.
    this%t_last = t
    this%pfric_last = pstart
    this%pobs_last = ostart
  end subroutine contact_record


  ! ------------------------------------------- the scene's start (item 7)

  !> No node of x(3, 0:nx-1, ys:ye) (every node, constrained or not) with a
  !> gap below the acceptance floor to an obstacle at t: else, on every
  !> rank, one line naming the first such obstacle, its nodes' count and
  !> the first of them (lowest j, then i); head: the line's start, what:
  !> the state's name, hint: the line's end. Collective.
  subroutine check_nodes(this, lat, t, x, comm, head, what, hint, ierr, errmsg)
    type(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(:, 0:, lat%ys:)
    integer, intent(in) :: comm
    character(*), intent(in) :: head, what, hint
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: i, j, k
    integer :: cnt(this%n_obs), first(this%n_obs)
    real(rp) :: d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(this%n_obs)
    call poses_at(this, t, obs)
    cnt = 0
    first = huge(1)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, this%n_obs
          call signed_distance(obs(k), x(1:3, i, j), d, g, hd)
          if (d - this%cp%thickness >= this%floor) cycle
          cnt(k) = cnt(k) + 1
          first(k) = min(first(k), j * lat%nx + i)
        end do
      end do
    end do
    call refusal(this, lat, comm, cnt, first, .false., [(0.0_rp, k = 1, this%n_obs)], head//what//': ', &
                 ' nodes lie inside obstacle ', ' or within its contact_thickness (a gap below '//real_brief(this%floor)// &
                 ', the acceptance floor 1e-6 contact_dhat), the first node ', hint, ierr, errmsg)
  end subroutine check_nodes

  !> No prescribed node's path (each owned constrained node of cs, pinned
  !> or on the keyframes, from t = 0 to t_stop) enters an obstacle or
  !> comes within its contact_thickness (plus the acceptance floor): the
  !> node and the obstacles move linearly between the union of their
  !> keyframe times, where time_of_impact_moving is exact. Else, on every
  !> rank, one line naming the first such obstacle, the nodes' count, the
  !> first node and when it enters. Collective.
  subroutine check_paths(this, lat, cs, t_stop, comm, ierr, errmsg)
    type(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    type(constraint_set_t), intent(in) :: cs
    real(rp), intent(in) :: t_stop
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: c, i, j, k, q, nk, node
    integer :: cnt(this%n_obs), first(this%n_obs)
    real(rp) :: t_first(this%n_obs), xa(3), xb(3), d(3), a, ta
    real(rp), allocatable :: kt(:), koff(:, :), tev(:)
    type(obstacle_t) :: o0, o1
    logical :: keyed
    call constraint_keyframes(cs, nk, kt, koff)
    cnt = 0
    first = huge(1)
    t_first = huge(1.0_rp)
    tev = event_times(this, kt(1:nk), t_stop)
    do c = 1, constraint_count(cs)
      call constraint_node(cs, c, i, j)
      node = j * lat%nx + i
      keyed = constraint_path(cs, c) == PATH_KEYFRAMES .and. nk > 0
      do k = 1, this%n_obs
        do q = 1, size(tev) - 1
          ta = tev(q)
          xa = constraint_base(cs, c)
          xb = xa
          if (keyed) then
            xa = xa + path_offset(kt(1:nk), koff(:, 1:nk), tev(q))
            xb = xb + path_offset(kt(1:nk), koff(:, 1:nk), tev(q + 1))
          end if
          call pose_pair(this, k, tev(q), tev(q + 1), o0, o1, d)
          a = time_of_impact_moving(o0, this%cp%thickness + this%floor, xa, xb - xa, d)
          if (a >= 1.0_rp) cycle
          cnt(k) = cnt(k) + 1
          if (node < first(k)) then
            first(k) = node
            t_first(k) = ta + a * (tev(q + 1) - ta)
          end if
          exit
        end do
      end do
    end do
    call refusal(this, lat, comm, cnt, first, .true., t_first, 'input: &contact: ', &
                 ' prescribed nodes'' paths (pinned or on keyframes) enter obstacle ', &
                 ' or come within its contact_thickness, the first node ', &
                 ': change the keyframes, the constraints or the obstacle', ierr, errmsg)
  end subroutine check_paths

  !> The times from 0 to t_stop at which a prescribed node's keyframe
  !> segment (kt) or an obstacle's ends, in order, without repeats.
  function event_times(this, kt, t_stop) result(tev)
    type(contact_model_t), intent(in) :: this
    real(rp), intent(in) :: kt(:), t_stop
    real(rp), allocatable :: tev(:)
    real(rp), allocatable :: ts(:)
    real(rp) :: tmp
    integer :: k, a, b, n
    ts = [0.0_rp, t_stop, kt]
    do k = 1, this%n_obs
      ts = [ts, this%keys%tk(1:this%keys%nk(k), k)]
    end do
    ts = pack(ts, ts >= 0.0_rp .and. ts <= t_stop)
    do a = 2, size(ts)          ! a few dozen times: insertion sort
      tmp = ts(a)
      b = a - 1
      do while (b >= 1)
        if (ts(b) <= tmp) exit
        ts(b + 1) = ts(b)
        b = b - 1
      end do
      ts(b + 1) = tmp
    end do
    n = 0
    allocate(tev(size(ts)))
    do a = 1, size(ts)
      if (n > 0) then
        if (ts(a) == tev(n)) cycle
      end if
      n = n + 1
      tev(n) = ts(a)
    end do
    tev = tev(1:n)
  end function event_times

  !> The offset of the keyframe path (kt, koff) at t: linear between the
  !> keyframes, the first one's before and the last one's after (module
  !> constraints' constraint_target).
  pure function path_offset(kt, koff, t) result(off)
    real(rp), intent(in) :: kt(:), koff(:, :), t
    real(rp) :: off(3)
    integer :: m, n
    n = size(kt)
    if (t <= kt(1)) then
      off = koff(:, 1)
    else if (t >= kt(n)) then
      off = koff(:, n)
    else
      m = 1
      do while (kt(m + 1) <= t)
        m = m + 1
      end do
      off = koff(:, m) + (t - kt(m)) * (koff(:, m + 1) - koff(:, m)) / (kt(m + 1) - kt(m))
    end if
  end function path_offset

  !> The refusal of check_nodes and check_paths: cnt(k) nodes of this rank
  !> at obstacle k, the first of them (j nx + i) and, when timed, when
  !> (t_first(k)). The counts summed, the firsts' minimum over the ranks;
  !> the first obstacle with nodes named in one line: head, count, what1,
  !> obstacle, what2, node (i, j), [at t = ...], tail. ierr = 0 when there
  !> is none. Collective.
  subroutine refusal(this, lat, comm, cnt, first, timed, t_first, head, what1, what2, tail, ierr, errmsg)
    type(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm, cnt(:), first(:)
    logical, intent(in) :: timed
    real(rp), intent(in) :: t_first(:)
    character(*), intent(in) :: head, what1, what2, tail
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: gcnt(size(cnt)), gfirst(size(cnt)), k, mpierr
    real(rp) :: tl(size(cnt)), tg(size(cnt))
    ierr = 0
    errmsg = ''
    call MPI_Allreduce(cnt, gcnt, size(cnt), MPI_INTEGER, MPI_SUM, comm, mpierr)
    call MPI_Allreduce(first, gfirst, size(cnt), MPI_INTEGER, MPI_MIN, comm, mpierr)
    if (all(gcnt == 0)) return
    tg = 0.0_rp
    if (timed) then
      tl = merge(t_first, huge(1.0_rp), first == gfirst .and. cnt > 0)
      call MPI_Allreduce(tl, tg, size(cnt), MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    end if
    do k = 1, size(cnt)
      if (gcnt(k) == 0) cycle
      ierr = 1
      errmsg = head//itoa(gcnt(k))//what1//itoa(k)//' ('''// &
               trim(SHAPE_NAMES(this%keys%base(k)%shape))//''')'//what2//'('//itoa(mod(gfirst(k), lat%nx))//', '// &
               itoa(gfirst(k) / lat%nx)//')'
      if (timed) errmsg = trim(errmsg)//' at t = '//real_brief(tg(k))
      errmsg = trim(errmsg)//tail
      return
    end do
  end subroutine refusal

  ! --------------------------------------------------------------- helpers


  !> A float64 series of a process model.
  pure function real_series(name, description, units, v) result(s)
    character(*), intent(in) :: name, description, units
    real(rp), intent(in) :: v(:)
    type(pm_series_t) :: s
    s%name = name
    s%description = description
    s%units = units
    s%ncomp = size(v)
    s%values(1:size(v)) = v
  end function real_series

  !> A count series of a process model (int64).
  pure function count_series(name, description, c) result(s)
    character(*), intent(in) :: name, description
    integer, intent(in) :: c
    type(pm_series_t) :: s
    s%name = name
    s%description = description
    s%units = '1'
    s%is_count = .true.
    s%count = c
  end function count_series

  !> The named value `name` of values: found, and its first value in v.
  logical function find(values, name, v) result(found)
    type(named_value_t), intent(in) :: values(:)
    character(*), intent(in) :: name
    real(rp), intent(out) :: v
    integer :: k
    found = .false.
    v = 0.0_rp
    do k = 1, size(values)
      if (trim(values(k)%name) /= name) cycle
      if (size(values(k)%v) < 1) cycle
      v = values(k)%v(1)
      found = .true.
      return
    end do
  end function find

end module contact_model
