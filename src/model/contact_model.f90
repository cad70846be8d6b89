! SPDX-License-Identifier: BSD-2-Clause
!> Contact with rigid obstacles as a process model (module process_model;
!> docs/design.md, "Process models" and "Contact"): its hooks, plain
!> arrays and MPI reductions, no PETSc. The hooks are here; the parts are
!> modules of their own, each owning its record: the obstacles, their
!> poses as a pure function of time and the swept check of a step
!> (obstacle_set; nothing caches a "current" pose); the barrier and
!> lagged friction of each free owned node against each obstacle, their
!> node blocks and friction's lag (contact_nodes, over the kernel
!> contact's contact_node); the run's record, its series and checkpoint
!> values (contact_record); the refusals of a scene it cannot start from
!> (contact_checks). The step limit checks a whole step's path against
!> the obstacles' motion over [t0, t1].
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
  use constraints, only: constraint_set_t, constraint_release_time
  use node_blocks, only: node_blocks_t
  use pair_blocks, only: pair_blocks_t
  use checkpoint_record, only: named_value_t
  use contact, only: contact_params_t
  use obstacle_set, only: obstacle_set_t, obstacle_set_init, obstacle_set_count, obstacle_set_moves, obstacle_set_swept, &
                          obstacle_set_carry
  use contact_nodes, only: contact_lag_t, lag_init, lag_free, lag_take, strip_forces, strip_blocks, strip_toi, &
                           strip_slip_limit, strip_smallest_gap, strip_stats, strip_unresolved
  use contact_record, only: contact_record_t, record_state, record_limited, record_seen, &
                            record_series, record_checkpoint, record_restore, record_line
  use contact_checks, only: check_nodes, check_paths
  use process_model, only: process_model_t, pm_hints_t, pm_series_t, pm_group_t, pm_energy_t, PM_FEASIBLE, &
                           PM_INFEASIBLE
  use strings, only: real_es, real_brief
  implicit none
  private
  public :: contact_model_t, contact_init, FLOOR_FRACTION

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

  !> Contact as a process model: its state on a rank's strip, written by
  !> this module's procedures alone (private components), each part by
  !> its own module: the obstacles (obstacle_set), friction's lag
  !> (contact_nodes), the run's record (contact_record).
  type, extends(process_model_t) :: contact_model_t
    private
    type(obstacle_set_t) :: obstacles               !< the obstacles' shapes, base poses and keyframes
    type(contact_params_t) :: cp
    real(rp) :: floor = 0.0_rp                      !< the acceptance floor of the gap [length]
    real(rp) :: output_interval = 0.0_rp            !< the contact line's times: its multiples [time]
    type(contact_lag_t) :: lag                      !< friction's lag: normal forces and normals of t_n
    ! The run's diagnostics, over all ranks: written by the accepted hook,
    ! the step limit (its count) and restore only.
    type(contact_record_t) :: rec
  contains
    procedure :: name => contact_name
    procedure :: hints => contact_hints
    procedure :: setup => contact_setup
    procedure :: forces => contact_forces
    procedure :: jacobian => contact_jacobian
    procedure :: start => contact_start
    procedure :: step_limit => contact_step_limit
    procedure :: accept => contact_accept
    procedure :: unresolved => contact_unresolved
    procedure :: accepted => contact_accepted
    procedure :: output => contact_output
    procedure :: checkpoint => contact_checkpoint
    procedure :: restore => contact_restore
    procedure :: check_state => contact_check_state
    procedure :: destroy => contact_destroy
  end type contact_model_t

contains

  ! ----------------------------------------------------------- the hooks

  function contact_name(this) result(s)
    class(contact_model_t), intent(in) :: this
    character(len=:), allocatable :: s
    s = 'contact'
  end function contact_name

  !> What contact needs of the solver (docs/design.md, "Contact"): the
  !> Jacobian at every Newton iteration (a lagged one's friction blocks
  !> belong to the iterate before: a two-cycle across the smoothing band;
  !> lagged only after an iteration that contracted ||F|| tenfold, Newton
  !> took 21-40 % more iterations on drop_table and drape_sphere at
  !> 65 x 65) until the solve has settled (jacobian_settled: ||F|| down
  !> 100-fold to within 100 times the convergence test's residual with no
  !> update cut; what is left is round-off and the first inexact solve's,
  !> and the kept Jacobian takes it to the floor: at 129 and 257, 19-33 %
  !> fewer assemblies, the same Newton iterations), the inexact-Newton forcing guarded (tight wherever the
  !> step limit cut the start or an update, or a moving obstacle carried
  !> the start, and in the next solve's first iteration: its loose inner
  !> solves failed a drop's impact; loose only after iterations that
  !> halved ||F||, they still failed steps of a sphere pushing at 5 m/s,
  !> dt = 10 ms), full
  !> steps on the 6-dof path too (the update is limited already; bt's
  !> model of ||F||^2 does not hold across the barrier's
  !> log), Newton starts outside the obstacles (the solver limits every
  !> predictor by the step limit), blocks with velocity parts (friction)
  !> that change with the state, and an L-stable integrator every state of
  !> which is a Newton iterate the step limit kept outside the obstacles:
  !> beuler or bdf of order 1 or 2 (issue 47 item 4; theta's end state is
  !> extrapolated from its stage, unchecked, cn and bdf3-6 are not
  !> L-stable: an impact's unresolved barrier mode rings instead of being
  !> damped).
  pure function contact_hints(this) result(h)
    class(contact_model_t), intent(in) :: this
    type(pm_hints_t) :: h
    h = pm_hints_t(jacobian_every_iteration=.true., jacobian_settled=.true., forcing_guarded=.true., &
                   basic_line_search=.true., &
                   feasible_start=.true., smooth_start=.true., velocity_blocks=.true., state_blocks=.true., ts_types='beuler,bdf1,bdf2', &
                   ts_why='beuler, or bdf with -ts_bdf_order 1 or 2 (L-stable, and every state they evaluate is a '// &
                   'Newton iterate the step limit keeps outside the obstacles; docs/contact.md, "Adaptive and '// &
                   'second-order steps")')
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
    call check_nodes(this%obstacles, this%cp%thickness, this%floor, lat, 0.0_rp, u(0:2, :, lat%ys:lat%ye), comm, &
                     'input: &contact: ', 'the initial state', ': move the cloth, the obstacle or contact_thickness', &
                     ierr, errmsg)
    if (ierr /= 0) return
    call check_paths(this%obstacles, this%cp%thickness, this%floor, lat, cs, &
                     min(cfg%time%t_end, constraint_release_time(cs)), comm, ierr, errmsg)
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
    integer :: nbad
    call strip_forces(this%obstacles, this%cp, this%lag, lat, fixed, t, u, f, nbad)
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
    call strip_blocks(this%obstacles, this%cp, this%lag, lat, fixed, t, u, nodal)
  end subroutine contact_jacobian

  !> Newton's start x of a step from the accepted state x0 at t0 to t1,
  !> carried by the obstacles that move into the cloth (obstacle_set's
  !> obstacle_set_carry: a node an obstacle reaches within its barrier's
  !> reach, or sweeps over, starts where it sat relative to the obstacle at
  !> t0, with its velocity), so that Newton starts feasible where the
  !> obstacle's pose at t1 contains the node's last position (docs/design.md,
  !> "Contact", moving obstacles). Nothing with static obstacles.
  subroutine contact_start(this, lat, fixed, t0, t1, x0, x, moved)
    class(contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: x(0:, 0:, lat%ys:)
    integer, intent(out) :: moved
    moved = obstacle_set_carry(this%obstacles, this%cp%thickness, this%cp%dhat, lat, fixed, t0, t1, x0, x)
  end subroutine contact_start

  !> The Newton update from x toward x + dx limited (IPC): where a free node
  !> would reach an obstacle (its pose at t1, the step's end) along dx,
  !> alpha = 0.8 times the first time of impact over all nodes and
  !> obstacles; where it would reverse a node's sliding through friction's
  !> sticking band, at most the fraction that ends in the band
  !> (strip_slip_limit); where obstacles move over [t0, t1], alpha is halved (at
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
    integer :: try, ncross, gcross, mpierr
    real(rp) :: a(2), ga(2), s
    a(1) = strip_toi(this%obstacles, this%cp%thickness, lat, fixed, t1, x, dx)
    a(2) = strip_slip_limit(this%obstacles, this%cp, this%lag, lat, fixed, t1, x, dx)
    call MPI_Allreduce(a, ga, 2, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    s = 1.0_rp
    if (ga(1) < 1.0_rp) s = 0.8_rp * ga(1)
    s = min(s, ga(2))
    gcross = 0
    if (obstacle_set_moves(this%obstacles, t0, t1)) then
      do try = 0, 10
        ncross = obstacle_set_swept(this%obstacles, this%cp%thickness, lat, fixed, t0, t1, x0, x, s * dx)
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
      call record_limited(this%rec)
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
    gmin = strip_smallest_gap(this%obstacles, this%cp, lat, fixed, t, u)
    call MPI_Allreduce(gmin, g, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    status = merge(PM_FEASIBLE, PM_INFEASIBLE, g >= this%floor)
    why = ''
    if (status == PM_FEASIBLE) return
    why = 'the state at t = '//real_brief(t)//' has a gap of '//real_brief(g)//', below the acceptance floor '// &
          real_brief(this%floor)//' (1e-6 contact_dhat; docs/contact.md, "Acceptance"): backward Euler stops an '// &
          'impact within one step at a gap of about kappa dhat^2 dt / (m v), smaller with a smaller step; '// &
          'a stiffer barrier (contact_stiffness) or a larger contact_dhat keeps it above the floor'
  end subroutine contact_accept

  !> Adaptive steps and bdf2 (issue 47 item 4): the free nodes whose
  !> barrier a step of dt does not resolve at u, the obstacles at t: a
  !> node in the barrier's reach that closes its gap within dt (relative
  !> normal speed times dt above the gap: it hits within the step), or
  !> whose normal stiffness k (|K_c|, the projected block of the Jacobian
  !> hook) has k dt^2 > m, the node's mass (omega dt > 1). Such a node is
  !> in an impact: the exact motion stops it at a gap far below what any
  !> step resolves (docs/contact.md, "Where the impact's energy goes"), and
  !> an error estimate of it only shrinks the step, until the impact's
  !> gap, about kappa dhat^2 dt / (m v), falls below the acceptance floor
  !> (drape_sphere at -ts_rtol 1e-6 so went down to dt = 1e-15 s); the
  !> estimate leaves it out (module step_errors) and weighs the rest.
  subroutine contact_unresolved(this, lat, fixed, t, u, dt, mask)
    class(contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t, dt
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(inout) :: mask(0:, lat%ys:)
    call strip_unresolved(this%obstacles, this%cp, this%lag, lat, fixed, t, u, dt, mask)
  end subroutine contact_unresolved

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
    if (record_seen(this%rec, t)) return
    call strip_stats(this%obstacles, this%cp, this%lag, lat, fixed, t, u, gmin, nact, ftot, fnrm, ebar, pfric, pobs)
    call lag_take(this%lag, this%obstacles, this%cp, lat, fixed, t, u, pstart, ostart)
    call MPI_Allreduce(gmin, r, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    gmin = r
    loc = [ftot, fnrm, ebar, pfric, pstart, pobs, ostart]
    call MPI_Allreduce(loc, glob, 11, MPI_DOUBLE_PRECISION, MPI_SUM, comm, mpierr)
    call MPI_Allreduce(nact, gnact, 1, MPI_INTEGER, MPI_SUM, comm, mpierr)
    call record_state(this%rec, t, gmin, gnact, glob(1:3), glob(4:6), glob(7), glob(8), glob(9), glob(10), glob(11))
    if (.not. (gmin > 0.0_rp)) then
      ierr = 1
      errmsg = 'nuno: contact: an accepted state penetrates an obstacle at t = '//real_es(t)//': smallest gap '// &
               real_es(gmin)
      return
    end if
    call MPI_Comm_rank(comm, rank, mpierr)
    r = t / this%output_interval
    if (rank == 0 .and. abs(r - anint(r)) <= 1.0e-9_rp * max(1.0_rp, r)) write(*, '(a)') record_line(this%rec, t)
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
    call record_series(this%rec, series, groups, energy)
  end subroutine contact_output

  !> The run's diagnostics that go on across a restart: the friction work,
  !> the obstacle work [energy], the smallest gap so far [length], the
  !> states checked and the limited Newton updates (the checkpoint
  !> attributes of files written before the process models).
  subroutine contact_checkpoint(this, values)
    class(contact_model_t), intent(in) :: this
    type(named_value_t), allocatable, intent(out) :: values(:)
    call record_checkpoint(this%rec, values)
  end subroutine contact_checkpoint

  !> A restart's run diagnostics from its checkpoint's named values (none
  !> without contact_friction_work: a file of a run without obstacles; no
  !> contact_obstacle_work in files written before it: 0). The
  !> checkpoint's own state, recorded again at the restart's first
  !> accepted hook, is not counted twice.
  subroutine contact_restore(this, values)
    class(contact_model_t), intent(inout) :: this
    type(named_value_t), intent(in) :: values(:)
    call record_restore(this%rec, values)
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
    call check_nodes(this%obstacles, this%cp%thickness, this%floor, lat, t, x, comm, '-nuno_restart: &contact: ', &
                     'the checkpoint''s state at t = '//real_brief(t), ': the obstacles are not those of the run that wrote it', &
                     ierr, errmsg)
  end subroutine contact_check_state

  subroutine contact_destroy(this)
    class(contact_model_t), intent(inout) :: this
    call lag_free(this%lag)
  end subroutine contact_destroy

  !> Obstacles and parameters from &contact (cc) for the strip of lat;
  !> lags zero (no friction at the first step). No communication (the
  !> set-up hook's checks follow it).
  subroutine contact_init(this, cc, lat)
    type(contact_model_t), intent(inout) :: this
    type(contact_config), intent(in) :: cc
    type(lattice_t), intent(in) :: lat
    call obstacle_set_init(this%obstacles, cc)
    this%cp = contact_params_t(thickness=cc%thickness, dhat=cc%dhat, kappa=cc%stiffness, eps_v=cc%eps_v)
    this%floor = FLOOR_FRACTION * this%cp%dhat
    call lag_init(this%lag, obstacle_set_count(this%obstacles), lat)
  end subroutine contact_init

end module contact_model
