! SPDX-License-Identifier: BSD-2-Clause
!> The cloth against itself as a process model (issue 49; module
!> process_model; docs/self-contact.md, "The wiring"): the lattice's
!> point-triangle and edge-edge pairs (module self_broad) kept apart by
!> the barrier of module self_barrier, on any number of ranks without
!> gathering the cloth (module self_exchange fetches the rows of the other
!> ranks' strips whose patches come within reach). On when &contact's
!> self_contact is (module solver_setup adds it to the list); off, it is
!> not in the list: nothing allocated, nothing run.
!>
!> Pairs and ranks: self_broad's OWN_TOUCH, each rank finds every pair
!> with an owned node and adds the forces and blocks of its own nodes
!> (nothing goes back); counts and energies are those of the pairs whose
!> lowest node it owns, so sums over ranks count each pair once.
!> The candidate list (and the plan of rows to fetch) is a Verlet list
!> with the reach dhat + xi + skin (skin = dhat, capped below the
!> lattice's own rest gaps: SKIN_SHARE), valid while no node has
!> moved skin/2 from where it was made apart from the mean translation
!> (relative_move: a pair's distance depends on differences of
!> positions). An update that leaves it makes it again in the step limit
!> from the update's paths looked ahead, x -> x + LOOKAHEAD dx (swept
!> candidates: every pair that comes within the reach anywhere along
!> them), which also serves that update's CCD and, where the motion is
!> steady, the next steps' (relative_move measures the nodes against the
!> nearest point of the paths); the accepted hook keeps a list that still holds
!> (the residual is the same function of the state whichever list is
!> current: every pair within dhat + xi is in it). The distance of zero gap is xi = 2 contact_thickness (two
!> surfaces, each contact_thickness from its mid-surface), the barrier's
!> dhat and kappa those of &contact.
!>
!> The step guarantee (submodule self_contact_step; &contact's
!> self_step) is flavour (a) of docs/self-contact.md by default: every
!> Newton update (and every predictor) is scaled by the smallest ACCD
!> alpha over the candidates of its swept paths on all ranks; with 'ogc',
!> flavour (b): each node's update shortened to its own bound (hook
!> limit_nodes). Either way no gap closes along an accepted path; the accept hook checks the end state's
!> smallest gap once more, naming the pair where it is <= 0. The Jacobian
!> gives each pair's diagonal blocks df_a/dx_a as node blocks and the
!> blocks between its different nodes df_a/dx_b as pair blocks, which
!> S's product adds with the Krylov vector's rows gathered by the list's
!> plan (pair_gather: the plan does not change between a Jacobian and the
!> solves with it; the step limit, which may make it again, runs after).
!> No allocation in the time loop: the kernels' tables (the broad phase's
!> in its pair lists, the block list, the exchange's plans and message
!> buffers) and the hooks' work arrays are kept in the record, made at
!> set-up (the block list with an estimate: a quarter of the strip's nodes
!> in contact) and reallocated only when too small; /self_contact/regrown
!> counts the reallocations after set-up.
module self_contact
  use mpi
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t
  use node_blocks, only: node_blocks_t, node_blocks_add
  use pair_blocks, only: pair_blocks_t, pair_blocks_add
  use checkpoint_record, only: named_value_t, named_value
  use contact, only: contact_params_t
  use contact_ccd, only: ACCD_S
  use contact_faces, only: SPLIT_MAIN
  use self_broad, only: self_lattice_t, self_pairs_t, OWN_TOUCH, self_candidates, self_candidates_swept, &
                        self_row_slots, self_pair_positions, self_pair_owner_row, self_pairs_regrown, self_rest_gap
  use self_barrier, only: self_blocks_t, self_barrier_forces, self_pair_gap, self_blocks_reserve, self_blocks_regrown
  use self_step, only: self_alpha_ccd, self_path_sums, self_path_far
  use self_lags, only: self_lags_t, self_lags_setup, self_lags_on, self_lags_forces, self_lags_step, self_lags_work, &
                       self_lags_restore, self_lags_regrown
  use self_exchange, only: self_exchange_t, self_exchange_plan, self_exchange_plan_swept, self_exchange_nrows, &
                           self_exchange_rows_copy, self_exchange_gather, self_exchange_counts, self_exchange_regrown, &
                           self_exchange_free
  use process_model, only: process_model_t, pm_hints_t, pm_series_t, pm_group_t, pm_energy_t, PM_FEASIBLE, &
                           PM_INFEASIBLE
  use strings, only: real_brief, itoa
  use work_arrays, only: grow
  implicit none
  private
  public :: self_contact_model_t

  !> Anchor rows of a patch of module self_exchange: its boxes are a few
  !> rows tall, so a fold fetches the rows near it, not whole strips.
  integer, parameter :: PATCH_ROWS = 4
  !> The Verlet list's skin: dhat, at most this share of the room between
  !> the reach dhat + xi and the lattice's smallest rest gap g0 between
  !> primitives that share no node (self_rest_gap: 0.707 spacings on a
  !> square lattice). A list at rest then holds none of the lattice's own
  !> pairs (at 257 x 257 with skin = dhat every node's were in it and the
  !> narrow phase ran on them at every residual), and a sheet may shorten
  !> them by the other half of the room before they enter it. Any skin > 0
  !> keeps the list's guarantee; a smaller one only makes it more often.
  real(rp), parameter :: SKIN_SHARE = 0.5_rp
  !> A list made from an update's paths x -> x + dx covers x -> x +
  !> LOOKAHEAD dx: where the motion is steady (a swing) the next step's
  !> predictor and update lie along that path (relative_move's tau), so
  !> the list serves LOOKAHEAD steps instead of one.
  real(rp), parameter :: LOOKAHEAD = 3.0_rp

  !> The hooks' messages and scratch, kept from call to call (grown only
  !> when too small). Reached through a pointer: the forces, Jacobian,
  !> gather and accept hooks have `this` intent(in) (the residual is one
  !> function of the state), yet their messages and scratch are written.
  type :: self_work_t
    type(self_exchange_t) :: xch                !< the list's plan of rows and its message buffers
    type(self_blocks_t) :: blocks               !< the narrow phase's blocks
    type(self_blocks_t) :: fblocks              !< friction's blocks df_a/dv_b [force*time/length]
    !> (6, 0:nx-1, nrows+) present rows' positions [length] and update [length] or velocities [length/time]
    real(rp), allocatable :: xall(:, :, :)
    real(rp), allocatable :: fall(:, :, :)      !< (3, 0:nx-1, nrows+) forces on them [force]; (1, ...) masks
    real(rp), allocatable :: mask(:, :, :)      !< (1, 0:nx-1, ys:ye) 1 on a constrained node
    real(rp), allocatable :: xd(:, :, :)        !< (6, 0:nx-1, max(ys-1,0):min(ye+1,ny-1)) positions, update [length]
    real(rp), allocatable :: dmin(:, :)         !< (nx, nrows+) 'ogc': each present node's nearest pair [length]
    integer :: regrown = 0                      !< reallocations of xall, fall, dmin, rows
  end type self_work_t

  !> The step guarantee (docs/self-contact.md, "The step guarantee: two
  !> flavours"): which, and its counts since the start (checkpointed).
  type :: self_guard_t
    logical :: ogc = .false.           !< &contact self_step = 'ogc': per-node bounds (flavour (b))
    logical :: accd_needed = .false.   !< 'ogc': a constrained node's update passed its bound: (a)'s alpha too
    logical :: clamped_now = .false.   !< 'ogc': this update had nodes clamped (counted once in limited)
    integer :: limited = 0             !< updates and predictors shortened (alpha < 1, or nodes clamped)
    integer :: clamped = 0             !< 'ogc': node updates shortened to their bounds, summed over ranks
  end type self_guard_t

  !> The cloth's self-contact on a rank's strip; written by this module's
  !> procedures alone.
  type, extends(process_model_t) :: self_contact_model_t
    private
    type(self_work_t), pointer :: w => null()   !< messages and scratch (made at set-up, freed by destroy)
    type(self_lattice_t) :: sl                  !< the lattice as the kernels number it
    type(contact_params_t) :: cp                !< thickness = xi, dhat, kappa
    real(rp) :: rest_reach = 0.0_rp             !< pairs nearer at rest are left out: dhat + xi [length]
    real(rp) :: skin = 0.0_rp                   !< the Verlet list's margin beyond dhat + xi (SKIN_SHARE) [length]
    integer :: rank_up = MPI_PROC_NULL          !< the rank owning row ye+1 (none at the top)
    integer :: rank_down = MPI_PROC_NULL        !< the rank owning row ys-1 (none at the bottom)
    ! the candidate list: written at set-up, after an accepted step where
    ! it no longer holds, and by the step limit for an update that leaves it (its
    ! plan of rows, w%xch, is in the work arrays: the gathers write buffers)
    integer, allocatable :: rows(:)             !< (nrows+) the present rows, ascending (owned and fetched)
    integer :: nrows = 0                        !< their number
    type(self_pairs_t) :: pairs                 !< candidates within dhat + xi + skin (OWN_TOUCH)
    type(self_lags_t) :: lags                   !< friction between layers: the lag of the active pairs, the work
    real(rp), allocatable :: x_list(:, :, :)    !< (3, 0:nx-1, ys:ye) positions the list was made at [length]
    real(rp), allocatable :: dx_list(:, :, :)   !< (3, 0:nx-1, ys:ye) and its paths x_list + tau dx_list (0: static) [length]
    ! the last accepted state's record, over all ranks (the accepted hook)
    real(rp) :: t_seen = -huge(1.0_rp)          !< its time [time]
    logical :: have_last = .false.
    real(rp) :: min_gap = huge(1.0_rp)          !< smallest gap of a candidate pair [length]
    real(rp) :: energy = 0.0_rp                 !< barrier energy of the pairs [energy]
    integer :: active = 0                       !< pairs with a gap below dhat
    integer :: candidates = 0                   !< pairs in the list, each once (its lowest node's owner)
    integer :: fetched = 0                      !< rows fetched from other ranks, summed over ranks
    ! counts since the start (checkpointed)
    type(self_guard_t) :: g                     !< the step guarantee's flavour and counts (limited, clamped)
    integer :: rebuilt = 0                      !< lists made again within a step (a node moved skin/2)
    integer :: searches = 0                     !< broad-phase searches since set-up (lists and swept candidates)
    integer :: regrown_setup = 0                !< work arrays' reallocations at set-up (this rank)
    integer :: regrown = 0                      !< and since, summed over ranks (the accepted hook)
  contains
    procedure :: name => self_name
    procedure :: hints => self_hints
    procedure :: setup => self_setup
    procedure :: forces => self_forces
    procedure :: jacobian => self_jacobian
    procedure :: pair_rows => self_pair_rows
    procedure :: pair_gather => self_pair_gather
    procedure :: limit_nodes => self_limit_nodes
    procedure :: step_limit => self_step_limit
    procedure :: accept => self_accept
    procedure :: accepted => self_accepted
    procedure :: output => self_output
    procedure :: checkpoint => self_checkpoint
    procedure :: restore => self_restore
    procedure :: destroy => self_destroy
  end type self_contact_model_t

  ! The step guarantee, both flavours, and the list's test (submodule self_contact_step)
  interface
    !> The fraction of the update x -> x + dx from x0 that the cloth allows
    !> (flavour (a): the ACCD alpha; with 'ogc', 1 unless a constrained node
    !> moves past its bound). Collective.
    module subroutine self_step_limit(this, lat, fixed, t0, t1, x0, x, dx, comm, alpha, status)
      class(self_contact_model_t), intent(inout) :: this
      type(lattice_t), intent(in) :: lat
      logical, intent(in) :: fixed(0:, lat%ys:)
      real(rp), intent(in) :: t0, t1
      real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
      integer, intent(in) :: comm
      real(rp), intent(out) :: alpha
      integer, intent(out) :: status
    end subroutine self_step_limit
    !> How far the nodes at xd(1:3) + alpha xd(4:6) have moved from the
    !> list's paths apart from a common translation [length]. Collective.
    module function relative_move(this, lat, comm, xd, alpha) result(gfar)
      class(self_contact_model_t), intent(in) :: this
      type(lattice_t), intent(in) :: lat
      integer, intent(in) :: comm
      real(rp), intent(in) :: xd(:, 0:, :)       ! (6, 0:nx-1, ys:ye) positions, update [length]
      real(rp), intent(in) :: alpha              ! [1]
      real(rp) :: gfar
    end function relative_move
    !> The rows the exchange plan just made present, n of them, taken.
    module subroutine take_plan_rows(this, nx, n)
      class(self_contact_model_t), intent(inout) :: this
      integer, intent(in) :: nx
      integer, intent(out) :: n
    end subroutine take_plan_rows
    !> With 'ogc' (flavour (b)): each free node's update shortened to its
    !> bound; changed the same on every rank. Collective.
    module subroutine self_limit_nodes(this, lat, fixed, t0, t1, x, dx, comm, changed)
      class(self_contact_model_t), intent(inout) :: this
      type(lattice_t), intent(in) :: lat
      logical, intent(in) :: fixed(0:, lat%ys:)
      real(rp), intent(in) :: t0, t1
      real(rp), intent(in) :: x(0:, 0:, lat%ys:)
      real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
      integer, intent(in) :: comm
      logical, intent(out) :: changed
    end subroutine self_limit_nodes
  end interface

contains

  function self_name(this) result(s)
    class(self_contact_model_t), intent(in) :: this
    character(len=:), allocatable :: s
    s = 'self_contact'
  end function self_name

  !> As the obstacles' barrier (contact_model's hints): a feasible start,
  !> limited updates, the Jacobian at every iteration, backward Euler;
  !> and pair blocks.
  pure function self_hints(this) result(h)
    class(self_contact_model_t), intent(in) :: this
    type(pm_hints_t) :: h
    h = pm_hints_t(jacobian_every_iteration=.true., forcing_guarded=.true., basic_line_search=.true., &
                   feasible_start=.true., state_blocks=.true., pair_blocks=.true., ts_types='beuler')
  end function self_hints

  !> Set-up: the barrier from &contact (xi = 2 contact_thickness), the
  !> ranks above and below, the first candidate list from the initial
  !> state, and a refusal naming the pair where a gap is <= 0. Collective.
  subroutine self_setup(this, cfg, lat, comm, u, cs, ierr, errmsg)
    class(self_contact_model_t), intent(inout) :: this
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: nrank, r, mpierr, node(4)
    integer, allocatable :: strips(:, :)
    real(rp) :: g
    this%sl = self_lattice_t(nx=lat%nx, ny=lat%ny, split=SPLIT_MAIN, ax=lat%ax, ay=lat%ay)
    this%cp = contact_params_t(thickness=2.0_rp * cfg%contact%thickness, dhat=cfg%contact%dhat, &
                               kappa=cfg%contact%stiffness, eps_v=cfg%contact%eps_v)
    this%rest_reach = this%cp%dhat + this%cp%thickness
    this%g%ogc = trim(cfg%contact%self_step) == 'ogc'
    ! the skin below the lattice's own rest gaps: a list at rest holds none of them
    this%skin = min(this%cp%dhat, SKIN_SHARE * (self_rest_gap(this%sl, this%rest_reach) - this%rest_reach))
    call MPI_Comm_size(comm, nrank, mpierr)
    allocate(strips(2, 0:nrank - 1))
    call MPI_Allgather([lat%ys, lat%ye], 2, MPI_INTEGER, strips, 2, MPI_INTEGER, comm, mpierr)
    do r = 0, nrank - 1
      if (strips(1, r) <= strips(2, r) .and. strips(1, r) == lat%ye + 1) this%rank_up = r
      if (strips(1, r) <= strips(2, r) .and. strips(2, r) == lat%ys - 1) this%rank_down = r
    end do
    allocate(this%x_list(3, 0:lat%nx - 1, lat%ys:lat%ye), this%dx_list(3, 0:lat%nx - 1, lat%ys:lat%ye))
    if (associated(this%w)) deallocate(this%w)
    allocate(this%w)
    allocate(this%w%mask(1, 0:lat%nx - 1, lat%ys:lat%ye))
    allocate(this%w%xd(6, 0:lat%nx - 1, max(lat%ys - 1, 0):min(lat%ye + 1, lat%ny - 1)))
    this%w%xd = 0.0_rp
    call self_blocks_reserve(this%w%blocks, 16 * max(lat%nx * (lat%ye - lat%ys + 1) / 4, 1))
    call self_lags_setup(this%lags, cfg%contact%self_mu, cfg%contact%eps_v)
    if (self_lags_on(this%lags)) &
      call self_blocks_reserve(this%w%fblocks, 16 * max(lat%nx * (lat%ye - lat%ys + 1) / 4, 1))
    call make_list(this, lat, comm, u(0:2, :, max(lat%ys - 1, 0):min(lat%ye + 1, lat%ny - 1)), ierr)
    errmsg = ''
    if (ierr /= 0) then
      errmsg = 'nuno: self_contact: the exchange of rows between ranks failed at set-up'
      return
    end if
    ! The list's message buffers for the most values a node it sends (6: the step limit's)
    call self_exchange_gather(this%w%xch, this%w%xd(:, :, lat%ys:lat%ye), this%w%xall(:, :, 1:this%nrows), ierr)
    call smallest_gap(this, lat, comm, u, g, node, ierr)
    this%regrown_setup = regrown_count(this)
    if (ierr /= 0 .or. g > 0.0_rp) return
    ierr = 1
    errmsg = 'input: &contact: self_contact: the initial state has the cloth at a gap of '//real_brief(g)// &
             ' <= 0 between '//pair_text(this, node)//': it starts self-intersecting (or within 2 contact_thickness); '// &
             'move the cloth apart or lower contact_thickness'
  end subroutine self_setup

  !> f += the barrier forces of the candidate pairs on the free owned
  !> nodes at u (positions of the fetched rows gathered); PM_INFEASIBLE
  !> where a pair that this rank counts has a gap <= 0. Collective.
  subroutine self_forces(this, lat, fixed, t, u, f, status)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: status
    real(rp) :: e
    integer :: nact, ierr, i, j, off
    call narrow_phase(this, lat, u, .false., e, nact, ierr)
    status = merge(PM_INFEASIBLE, PM_FEASIBLE, ierr /= 0 .or. e >= huge(1.0_rp))
    off = row_offset(this, lat)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (.not. fixed(i, j)) f(1:3, i, j) = f(1:3, i, j) + this%w%fall(1:3, i, j - lat%ys + 1 + off)
      end do
    end do
  end subroutine self_forces

  !> The slot of row ys in the present rows, less one (the owned rows are
  !> consecutive there: slot(j) = j - ys + 1 + row_offset).
  pure integer function row_offset(this, lat)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer :: k
    row_offset = 0
    do k = 1, this%nrows
      if (this%rows(k) == lat%ys) then
        row_offset = k - 1
        return
      end if
    end do
  end function row_offset

  !> The candidates' barrier at the ghosted state u, into the work
  !> arrays: positions of the present rows w%xall(1:3) (the fetched rows
  !> gathered; with friction their velocities too, w%xall(4:6)), the
  !> forces w%fall on them, the blocks w%blocks (projected: minus the PSD
  !> part) and friction's w%fblocks (project: the Jacobian); the energy e
  !> of the pairs counted here (huge: a gap <= 0) and the active pairs
  !> counted here. Collective (the gather).
  subroutine narrow_phase(this, lat, u, project, e, nact, ierr)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(in) :: project
    real(rp), intent(out) :: e
    integer, intent(out) :: nact, ierr
    integer :: nv
    nv = merge(6, 3, self_lags_on(this%lags))
    associate (w => this%w, n => this%nrows)
      call self_exchange_gather(w%xch, u(0:nv - 1, :, lat%ys:lat%ye), w%xall(1:nv, :, 1:n), ierr)
      w%fall(:, :, 1:n) = 0.0_rp
      e = 0.0_rp
      nact = 0
      w%blocks%n = 0
      w%fblocks%n = 0
      if (ierr /= 0) return
      call self_barrier_forces(this%sl, this%rows(1:n), w%xall(1:3, :, 1:n), this%pairs, lat%ys, lat%ye, this%cp, &
                               project, e, w%fall(:, :, 1:n), w%blocks, nact)
      if (nv < 6) return
      if (project) then
        call self_lags_forces(this%lags, this%sl, this%rows(1:n), w%xall(:, :, 1:n), this%cp, lat%ys, lat%ye, &
                              w%fall(:, :, 1:n), w%fblocks)
      else
        call self_lags_forces(this%lags, this%sl, this%rows(1:n), w%xall(:, :, 1:n), this%cp, lat%ys, lat%ye, &
                              w%fall(:, :, 1:n))
      end if
    end associate
  end subroutine narrow_phase

  !> The blocks of each active pair on its free owned nodes a (the
  !> projected Hessian's): df_a/dx_a into nodal, df_a/dx_b of its other
  !> nodes b into pairs (b anywhere; whether b is constrained from the
  !> fetched rows' masks), which S's product adds with the Krylov vector's
  !> rows gathered by this list's plan (pair_gather). Collective.
  subroutine self_jacobian(this, lat, fixed, t, u, nodal, pairs)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nodal
    type(pair_blocks_t), intent(inout) :: pairs
    real(rp) :: e, zero(3, 3)
    integer :: nact, ierr, m, i, j, ib, jb, slot(0:lat%ny - 1)
    call narrow_phase(this, lat, u, .true., e, nact, ierr)
    ! 1 on a constrained node, owned rows (mask) and present ones (mall: fall's first row, the forces done)
    associate (blocks => this%w%blocks, mask => this%w%mask, mall => this%w%fall(1:1, :, 1:this%nrows))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        mask(1, i, j) = merge(1.0_rp, 0.0_rp, fixed(i, j))
      end do
    end do
    call self_exchange_gather(this%w%xch, mask, mall, ierr)
    call self_row_slots(this%sl, this%rows(1:this%nrows), slot)
    zero = 0.0_rp
    do m = 1, blocks%n
      i = mod(blocks%a(m), lat%nx)
      j = blocks%a(m) / lat%nx
      if (j < lat%ys .or. j > lat%ye) cycle
      if (fixed(i, j)) cycle
      if (blocks%a(m) == blocks%b(m)) then
        call node_blocks_add(nodal, i, j, blocks%k(:, :, m), zero)
      else
        ib = mod(blocks%b(m), lat%nx)
        jb = blocks%b(m) / lat%nx
        call pair_blocks_add(pairs, i, j, ib, jb, mall(1, ib, slot(jb)) > 0.0_rp, blocks%k(:, :, m), zero)
      end if
    end do
    end associate
    ! friction's blocks df_a/dv_b (a owned)
    associate (blocks => this%w%fblocks, mall => this%w%fall(1:1, :, 1:this%nrows))
    do m = 1, blocks%n
      i = mod(blocks%a(m), lat%nx)
      j = blocks%a(m) / lat%nx
      if (fixed(i, j)) cycle
      if (blocks%a(m) == blocks%b(m)) then
        call node_blocks_add(nodal, i, j, zero, blocks%k(:, :, m))
      else
        ib = mod(blocks%b(m), lat%nx)
        jb = blocks%b(m) / lat%nx
        call pair_blocks_add(pairs, i, j, ib, jb, mall(1, ib, slot(jb)) > 0.0_rp, zero, blocks%k(:, :, m))
      end if
    end do
    end associate
  end subroutine self_jacobian

  !> The rows the pair blocks reach: the list's present rows, ascending
  !> (slot(j): row j's position among them, 0 where absent; n of them).
  subroutine self_pair_rows(this, slot, n)
    class(self_contact_model_t), intent(in) :: this
    integer, intent(out) :: slot(0:)
    integer, intent(out) :: n
    integer :: k
    n = this%nrows
    slot = 0
    do k = 1, n
      slot(this%rows(k)) = k
    end do
  end subroutine self_pair_rows

  !> A vector's present rows vall (nv, 0:nx-1, size(rows)) from its owned
  !> rows v (nv, 0:nx-1, ys:ye), by the list's plan. Collective.
  subroutine self_pair_gather(this, lat, comm, v, vall, ierr)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: v(:, 0:, lat%ys:)
    real(rp), intent(inout) :: vall(:, 0:, :)
    integer, intent(out) :: ierr
    ierr = 0
    if (size(vall, 3) /= this%nrows) then
      ierr = 1
      return
    end if
    call self_exchange_gather(this%w%xch, v, vall, ierr)
  end subroutine self_pair_gather

  !> The plan of rows and the candidate list at positions x (3, 0:nx-1,
  !> max(ys-1,0):min(ye+1,ny-1)) with the reach dhat + xi + skin, and
  !> the positions it was made at. Collective.
  subroutine make_list(this, lat, comm, x, ierr)
    class(self_contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: x(:, 0:, max(lat%ys - 1, 0):)
    integer, intent(out) :: ierr
    integer :: n
    associate (w => this%w)
    call self_exchange_plan(w%xch, comm, lat%nx, lat%ny, lat%ys, lat%ye, x, this%rest_reach + this%skin, &
                            PATCH_ROWS, ierr)
    if (ierr /= 0) return
    call take_plan_rows(this, lat%nx, n)
    call self_exchange_gather(w%xch, x(1:3, :, lat%ys:lat%ye), w%xall(1:3, :, 1:n), ierr)
    if (ierr /= 0) return
    call self_candidates(this%sl, this%rows(1:n), w%xall(1:3, :, 1:n), lat%ys, lat%ye, OWN_TOUCH, &
                         this%rest_reach + this%skin, this%rest_reach, this%pairs)
    this%searches = this%searches + 1
    this%x_list = x(1:3, :, lat%ys:lat%ye)
    this%dx_list = 0.0_rp
    end associate
  end subroutine make_list

  !> The smallest gap g over the candidate pairs at u, the same on every
  !> rank, and that pair's nodes (global numbers; huge and 0 where there
  !> is none). Collective.
  subroutine smallest_gap(this, lat, comm, u, g, node, ierr)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: g
    integer, intent(out) :: node(4), ierr
    real(rp) :: gm, loc(2), glob(2)
    integer :: slot(0:lat%ny - 1), m, mpierr
    associate (xall => this%w%xall(1:3, :, 1:this%nrows))
    call self_exchange_gather(this%w%xch, u(0:2, :, lat%ys:lat%ye), xall, ierr)
    call self_row_slots(this%sl, this%rows(1:this%nrows), slot)
    g = huge(1.0_rp)
    node = 0
    do m = 1, this%pairs%n
      gm = self_pair_gap(this%pairs%kind(m), self_pair_positions(this%sl, slot, xall, this%pairs%node(:, m)), &
                         this%cp%thickness)
      if (gm < g) then
        g = gm
        node = this%pairs%node(:, m)
      end if
    end do
    end associate
    loc = [g, 0.0_rp]
    call MPI_Comm_rank(comm, m, mpierr)
    loc(2) = real(m, rp)
    call MPI_Allreduce(loc, glob, 1, MPI_2DOUBLE_PRECISION, MPI_MINLOC, comm, mpierr)
    g = glob(1)
    call MPI_Bcast(node, 4, MPI_INTEGER, nint(glob(2)), comm, mpierr)
  end subroutine smallest_gap

  !> A pair's nodes as text: (i, j) of each of its 4 global numbers.
  function pair_text(this, node) result(s)
    class(self_contact_model_t), intent(in) :: this
    integer, intent(in) :: node(4)
    character(len=:), allocatable :: s
    integer :: k
    s = 'nodes'
    do k = 1, 4
      s = s//' ('//itoa(mod(node(k), this%sl%nx))//', '//itoa(node(k) / this%sl%nx)//')'
    end do
  end function pair_text

  !> A step's end state u at t: its smallest gap over the candidates must
  !> be > 0; else PM_INFEASIBLE and why, naming the pair. Collective.
  subroutine self_accept(this, lat, fixed, t, u, comm, status, why)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: status
    character(*), intent(out) :: why
    real(rp) :: g
    integer :: node(4), ierr
    call smallest_gap(this, lat, comm, u, g, node, ierr)
    status = merge(PM_FEASIBLE, PM_INFEASIBLE, g > 0.0_rp .and. ierr == 0)
    why = ''
    if (status == PM_FEASIBLE) return
    why = 'the state at t = '//real_brief(t)//' has the cloth at a gap of '//real_brief(g)//' <= 0 between '// &
          pair_text(this, node)
  end subroutine self_accept

  !> An accepted state u at t: the skin from the step's largest node
  !> motion, a new list, and the record (active pairs, energy, smallest
  !> gap, rows fetched) over all ranks. A state recorded already is left
  !> alone. Collective.
  subroutine self_accepted(this, lat, fixed, t, u, comm, ierr, errmsg)
    class(self_contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: gmoved, e, ge, g
    integer :: nact, counts(4), gcounts(4), nsrc, npatch, node(4), mpierr, j, m
    ierr = 0
    errmsg = ''
    if (this%have_last .and. t == this%t_seen) return
    gmoved = huge(1.0_rp)
    if (this%have_last) then
      associate (xd => this%w%xd(:, :, lat%ys:lat%ye))
        do j = lat%ys, lat%ye
          xd(1:3, :, j - lat%ys + 1) = u(0:2, :, j)
        end do
        xd(4:6, :, :) = 0.0_rp
        gmoved = relative_move(this, lat, comm, xd, 0.0_rp)
      end associate
    end if
    ! a list that still holds at u is kept (the step limit made it over the step's paths)
    if (gmoved > 0.5_rp * this%skin) then
      call make_list(this, lat, comm, u(0:2, :, max(lat%ys - 1, 0):min(lat%ye + 1, lat%ny - 1)), ierr)
    end if
    if (ierr /= 0) then
      errmsg = 'nuno: self_contact: the exchange of rows between ranks failed at t = '//real_brief(t)
      return
    end if
    call narrow_phase(this, lat, u, .false., e, nact, ierr)
    if (self_lags_on(this%lags)) call self_lags_step(this%lags, this%sl, this%rows(1:this%nrows), &
                                                     this%w%xall(:, :, 1:this%nrows), this%pairs, this%cp, lat%ys, &
                                                     lat%ye, t, comm)
    call self_exchange_counts(this%w%xch, counts(2), nsrc, npatch)
    counts(1) = nact
    counts(3) = regrown_count(this) - this%regrown_setup
    counts(4) = 0
    do m = 1, this%pairs%n
      j = self_pair_owner_row(this%sl, this%pairs%node(:, m))
      if (j >= lat%ys .and. j <= lat%ye) counts(4) = counts(4) + 1
    end do
    call MPI_Allreduce(e, ge, 1, MPI_DOUBLE_PRECISION, MPI_SUM, comm, mpierr)
    call MPI_Allreduce(counts, gcounts, 4, MPI_INTEGER, MPI_SUM, comm, mpierr)
    call smallest_gap(this, lat, comm, u, g, node, ierr)
    this%t_seen = t
    this%have_last = .true.
    this%energy = ge
    this%active = gcounts(1)
    this%fetched = gcounts(2)
    this%regrown = gcounts(3)
    this%candidates = gcounts(4)
    this%min_gap = g
    if (g > 0.0_rp) return
    ierr = 1
    errmsg = 'nuno: self_contact: an accepted state has the cloth at a gap of '//real_brief(g)//' <= 0 at t = '// &
             real_brief(t)//' between '//pair_text(this, node)
  end subroutine self_accepted

  !> The series of the last accepted state (/self_contact) and the
  !> barrier energy (/energy/barrier_self, a potential energy of the
  !> balance).
  subroutine self_output(this, series, groups, energy)
    class(self_contact_model_t), intent(in) :: this
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
    real(rp) :: g
    g = min(this%min_gap, this%rest_reach + this%skin)
    series = [ &
      pm_series_t(name='/self_contact/active', description='point-triangle and edge-edge pairs of the cloth with '// &
                  'a gap below contact_dhat', is_count=.true., count=this%active), &
      pm_series_t(name='/self_contact/candidates', description='candidate pairs of the cloth in the Verlet '// &
                  'list at the state (within dhat + 2 contact_thickness + the skin when it was made), each once', &
                  is_count=.true., count=this%candidates), &
      pm_series_t(name='/self_contact/min_gap', description='smallest gap (distance - 2 contact_thickness) of a '// &
                  'candidate pair of the cloth (the candidates'' reach where none is nearer)', units='length', &
                  values=[g, 0.0_rp, 0.0_rp]), &
      pm_series_t(name='/self_contact/rows_fetched', description='lattice rows fetched from other ranks for the '// &
                  'broad phase, summed over the ranks', is_count=.true., count=this%fetched), &
      pm_series_t(name='/self_contact/limited', description='Newton updates and predictors shortened by the '// &
                  'self-contact step limit since the start', is_count=.true., count=this%g%limited), &
      pm_series_t(name='/self_contact/searches', description='broad-phase searches of the self-contact since '// &
                  'set-up (candidate lists and the step limit''s swept candidates; the same on every rank)', &
                  is_count=.true., count=this%searches), &
      pm_series_t(name='/self_contact/regrown', description='work arrays of the self-contact (candidate and '// &
                  'block lists, hash tables, message buffers) reallocated larger since set-up, summed over the '// &
                  'ranks', is_count=.true., count=this%regrown), &
      pm_series_t(name='/energy/barrier_self', description='barrier energy of the cloth''s self-contact pairs '// &
                  '(a potential energy of the balance)', units='energy', values=[this%energy, 0.0_rp, 0.0_rp])]
    if (self_lags_on(this%lags)) series = [series, &
      pm_series_t(name='/self_contact/friction_work', description='work of the friction between layers since the '// &
                  'start (&contact''s self_mu; dissipated, >= 0; part of /energy/dissipated)', units='energy', &
                  values=[self_lags_work(this%lags), 0.0_rp, 0.0_rp])]
    if (this%g%ogc) series = [series, &
      pm_series_t(name='/self_contact/clamped', description='node updates shortened to their OGC bounds since '// &
                  'the start (&contact''s self_step = ''ogc''), summed over the ranks', is_count=.true., &
                  count=this%g%clamped)]
    groups = [pm_group_t(name='/self_contact', description='the cloth''s contact with itself (&contact''s '// &
                         'self_contact), per output step')]
    energy = pm_energy_t(potential=this%energy, dissipated=self_lags_work(this%lags))
  end subroutine self_output

  !> The counts and the friction work that go on across a restart (the
  !> list and friction's lag are made again from the restart's state).
  subroutine self_checkpoint(this, values)
    class(self_contact_model_t), intent(in) :: this
    type(named_value_t), allocatable, intent(out) :: values(:)
    values = [named_value('self_contact_limited', [real(this%g%limited, rp)], .true.), &
              named_value('self_contact_rebuilt', [real(this%rebuilt, rp)], .true.), &
              named_value('self_contact_friction_work', [self_lags_work(this%lags)], .false.)]
    if (this%g%ogc) values = [values, named_value('self_contact_clamped', [real(this%g%clamped, rp)], .true.)]
  end subroutine self_checkpoint

  !> A restart's counts and friction work from its checkpoint (0 in a
  !> file without them).
  subroutine self_restore(this, values)
    class(self_contact_model_t), intent(inout) :: this
    type(named_value_t), intent(in) :: values(:)
    integer :: k
    real(rp) :: work
    this%g%limited = 0
    this%g%clamped = 0
    this%rebuilt = 0
    work = 0.0_rp
    do k = 1, size(values)
      if (size(values(k)%v) < 1) cycle
      if (trim(values(k)%name) == 'self_contact_limited') this%g%limited = nint(values(k)%v(1))
      if (trim(values(k)%name) == 'self_contact_rebuilt') this%rebuilt = nint(values(k)%v(1))
      if (trim(values(k)%name) == 'self_contact_clamped') this%g%clamped = nint(values(k)%v(1))
      if (trim(values(k)%name) == 'self_contact_friction_work') work = values(k)%v(1)
    end do
    call self_lags_restore(this%lags, work)
    this%have_last = .false.
  end subroutine self_restore

  !> The work arrays freed.
  subroutine self_destroy(this)
    class(self_contact_model_t), intent(inout) :: this
    if (.not. associated(this%w)) return
    call self_exchange_free(this%w%xch)
    deallocate(this%w)
  end subroutine self_destroy

  !> This rank's reallocations of work arrays since the model was made
  !> (the lists', the plans', the hooks').
  integer function regrown_count(this) result(n)
    class(self_contact_model_t), intent(in) :: this
    n = self_pairs_regrown(this%pairs) + self_blocks_regrown(this%w%blocks) + self_exchange_regrown(this%w%xch) + &
        this%w%regrown + self_blocks_regrown(this%w%fblocks) + self_lags_regrown(this%lags)
  end function regrown_count

end module self_contact
