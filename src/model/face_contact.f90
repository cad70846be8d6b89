! SPDX-License-Identifier: BSD-2-Clause
!> Contact of the cloth's triangles and edges with the rigid obstacles as
!> a process model of its own (issue 47 item 3; module process_model;
!> docs/design.md, "Contact", faces and edges): beside the node contact
!> (module contact_model), each lattice quad's two triangles, its diagonal
!> and the x- and y-links stay outside every obstacle that has features
!> between the nodes (sphere, capsule, box; a plane has none): the
!> obstacle's points (sphere centre, capsule ends, box corners) against
!> the triangles and its edges (capsule axis, box edges) against the
!> cloth's edges, through the kernels contact_faces and contact_ccd over
!> the strip's elements (module face_elements). The barrier is the node
!> contact's (contact_dhat, contact_stiffness, contact_thickness), and
!> friction on these pairs lagged as the nodes' (module face_lags).
!> Obstacles' poses are a pure function of time (module obstacle_set), as
!> in contact_model. The model is in the list only when an obstacle other
!> than a plane exists (solver_setup), so a scene of planes is as before.
module face_contact
  use mpi
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t
  use node_blocks, only: node_blocks_t
  use pair_blocks, only: pair_blocks_t
  use checkpoint_record, only: named_value_t, named_value
  use contact, only: obstacle_t, contact_params_t
  use contact_ccd, only: ACCD_S
  use obstacle_set, only: obstacle_set_t, obstacle_set_init, obstacle_set_count, obstacle_set_pose, obstacle_set_moves, &
                          obstacle_set_pair
  use face_lags, only: face_lag_list_t, lags_clear, lags_take, lags_walk, lags_power, lags_with_friction, lags_turn
  use face_elements, only: WALK_FORCES, WALK_BLOCKS, WALK_STATS, has_features, elements_walk, elements_gap, elements_ccd, &
                           elements_mark, elements_correct
  use process_model, only: process_model_t, pm_hints_t, pm_series_t, pm_group_t, pm_energy_t, PM_FEASIBLE, &
                           PM_INFEASIBLE
  use strings, only: real_brief
  implicit none
  private
  public :: face_contact_t

  !> The acceptance floor as a fraction of contact_dhat: contact_model's
  !> FLOOR_FRACTION (docs/contact.md, "Acceptance"), the same for faces.
  real(rp), parameter :: FLOOR_FRACTION = 1.0e-6_rp
  !> The fraction of a pair's gap that the swept check of a step (the
  !> path from the step's start, the obstacle moving) must keep: only a
  !> path that crosses the obstacle, or nearly, is refused [1].
  real(rp), parameter :: SWEPT_S = 1.0e-6_rp
  !> The lift of a carried quad's start off the obstacle, as a fraction of
  !> contact_dhat (at most the obstacle's move over the step; faces_start).
  real(rp), parameter :: LIFT_FRACTION = 0.5_rp

  !> Faces and edges against the obstacles on a rank's strip; written by
  !> this module's procedures alone.
  type, extends(process_model_t) :: face_contact_t
    private
    type(obstacle_set_t) :: obstacles           !< the obstacles of &contact (shapes, poses, keyframes)
    type(contact_params_t) :: cp
    real(rp) :: floor = 0.0_rp                  !< the acceptance floor of a gap [length]
    integer :: rank_up = MPI_PROC_NULL          !< the rank owning row ye+1 (none at the top)
    integer :: rank_down = MPI_PROC_NULL        !< the rank owning row ys-1 (none at the bottom)
    integer :: comm = MPI_COMM_NULL             !< the strips' communicator (the start hook's row exchange)
    ! the last accepted state's record (the accepted hook alone writes it)
    real(rp) :: t_seen = -huge(1.0_rp)          !< its time [time]
    real(rp) :: min_gap = huge(1.0_rp)          !< smallest gap of a triangle or edge [length]
    real(rp) :: energy = 0.0_rp                 !< barrier energy of the face and edge pairs [energy]
    integer :: active = 0                       !< pairs within contact_dhat
    real(rp) :: force(3) = 0.0_rp               !< total force of these pairs on the cloth, barrier and friction [force]
    type(face_lag_list_t) :: lags               !< friction's lag: the pairs of the last accepted state
    real(rp) :: friction_work = 0.0_rp          !< friction work of these pairs since the start [energy]
    real(rp) :: pfric_last = 0.0_rp             !< friction power at the last state with its own lag [energy/time]
    !> the moving obstacles' work on the cloth through these pairs since
    !> the start (trapezoid rule over each step) [energy]
    real(rp) :: obstacle_work = 0.0_rp
    real(rp) :: pstart_last = 0.0_rp            !< their power at the last state, the next step's velocities [energy/time]
    logical :: have_last = .false.              !< t_seen, pstart_last hold the last accepted state's
    !> some rank's lag has a pair with friction: the Newton update's guard
    !> where a pair's slip turns is on (limit_turns; the same on every rank)
    logical :: turn_guard = .false.
  contains
    procedure :: name => faces_name
    procedure :: hints => faces_hints
    procedure :: setup => faces_setup
    procedure :: forces => faces_forces
    procedure :: jacobian => faces_jacobian
    procedure :: start => faces_start
    procedure :: correct => faces_correct
    procedure :: step_limit => faces_step_limit
    procedure :: accept => faces_accept
    procedure :: accepted => faces_accepted
    procedure :: output => faces_output
    procedure :: checkpoint => faces_checkpoint
    procedure :: restore => faces_restore
  end type face_contact_t

contains

  function faces_name(this) result(s)
    class(face_contact_t), intent(in) :: this
    character(len=:), allocatable :: s
    s = 'contact_faces'
  end function faces_name

  !> What the node contact asks (contact_model's contact_hints): a barrier
  !> needs a feasible start, limited updates and the Jacobian at every
  !> iteration, whichever of the two models holds a node. Unlike the
  !> node contact's diagonal blocks, an element's barrier couples its nodes
  !> (a link across a box's rim: the barrier's stiffness times the two
  !> nodes' weights), across a strip boundary too (docs/contact.md, "Faces
  !> and edges").
  pure function faces_hints(this) result(h)
    class(face_contact_t), intent(in) :: this
    type(pm_hints_t) :: h
    h = pm_hints_t(jacobian_every_iteration=.true., forcing_guarded=.true., basic_line_search=.true., &
                   feasible_start=.true., smooth_start=.true., velocity_blocks=.true., state_blocks=.true., &
                   stiff_neighbour_blocks=.true., ts_types='beuler')
  end function faces_hints

  !> Set-up: the obstacles and the barrier's parameters from &contact, the
  !> ranks of the strips above and below (the step limit's row ye+1), and
  !> the initial state's triangles outside every obstacle (a gap of at
  !> least the floor: else one line naming the obstacle). Collective.
  subroutine faces_setup(this, cfg, lat, comm, u, cs, ierr, errmsg)
    class(face_contact_t), intent(inout) :: this
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: nrank, r, mpierr, k
    integer, allocatable :: rows(:, :)
    real(rp) :: g, gk
    call obstacle_set_init(this%obstacles, cfg%contact)
    this%cp = contact_params_t(thickness=cfg%contact%thickness, dhat=cfg%contact%dhat, kappa=cfg%contact%stiffness, &
                               eps_v=cfg%contact%eps_v)
    this%floor = FLOOR_FRACTION * this%cp%dhat
    this%comm = comm
    call MPI_Comm_size(comm, nrank, mpierr)
    allocate(rows(2, 0:nrank - 1))
    call MPI_Allgather([lat%ys, lat%ye], 2, MPI_INTEGER, rows, 2, MPI_INTEGER, comm, mpierr)
    do r = 0, nrank - 1
      if (rows(1, r) <= rows(2, r) .and. rows(1, r) == lat%ye + 1) this%rank_up = r
      if (rows(1, r) <= rows(2, r) .and. rows(2, r) == lat%ys - 1) this%rank_down = r
    end do
    ierr = 0
    errmsg = ''
    do k = 1, obstacle_set_count(this%obstacles)
      gk = smallest_gap(this, lat, 0.0_rp, k, u(0:2, :, :))
      call MPI_Allreduce(gk, g, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
      if (g >= this%floor) cycle
      ierr = 1
      write(errmsg, '(a,i0,a)') 'input: &contact: the initial state: a cloth triangle or edge lies inside obstacle ', k, &
        ' or within its contact_thickness (a gap of '//real_brief(g)//', below the acceptance floor '// &
        real_brief(this%floor)//'): move the cloth, the obstacle or contact_thickness'
      return
    end do
  end subroutine faces_setup

  !> f += the barrier forces of the triangles and edges on the free owned
  !> nodes, the obstacles at t; PM_INFEASIBLE where a pair has gap <= 0.
  subroutine faces_forces(this, lat, fixed, t, u, f, status)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: status
    integer :: k, nbad
    type(obstacle_t) :: obs(obstacle_set_count(this%obstacles))
    type(node_blocks_t) :: none               ! (the walks' blocks: untouched here)
    real(rp) :: unused                        ! (the walk's energy: untouched here)
    nbad = 0
    do k = 1, size(obs)
      obs(k) = obstacle_set_pose(this%obstacles, k, t)
      if (has_features(obs(k))) call elements_walk(WALK_FORCES, obs(k), this%cp, lat, fixed, u, f, none, nbad, unused)
    end do
    call lags_walk(WALK_FORCES, this%lags, obs, this%cp, lat, fixed, u, 0, f, none)
    status = merge(PM_INFEASIBLE, PM_FEASIBLE, nbad > 0)
  end subroutine faces_forces

  !> The blocks df/dx of the triangles' and edges' barrier and df/dv of
  !> their lagged friction at u, t into nodal: each node's own and those
  !> to its stencil neighbours in the element (node_blocks_add_pair; no
  !> pair blocks).
  subroutine faces_jacobian(this, lat, fixed, t, u, nodal, pairs)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nodal
    type(pair_blocks_t), intent(inout) :: pairs
    integer :: k, unused_count
    type(obstacle_t) :: obs(obstacle_set_count(this%obstacles))
    real(rp) :: none(3, 0, 0), unused         ! (the walks' forces and energy: untouched here)
    unused_count = 0
    do k = 1, size(obs)
      obs(k) = obstacle_set_pose(this%obstacles, k, t)
      if (has_features(obs(k))) call elements_walk(WALK_BLOCKS, obs(k), this%cp, lat, fixed, u, none, nodal, unused_count, unused)
    end do
    call lags_walk(WALK_BLOCKS, this%lags, obs, this%cp, lat, fixed, u, 0, none, nodal)
  end subroutine faces_jacobian

  !> Newton's start of a step from x0 at t0 to t1: the free nodes of the
  !> quads that a moving obstacle reaches (a triangle's gap to its pose at
  !> t1 below contact_dhat and below the gap at t0) start where they sat
  !> relative to it, raised off it by a lift: x0 + d + l d/|d| with
  !> velocity (d + l d/|d|)/(t1 - t0) (d: its translation over the step;
  !> l = min(|d|, LIFT_FRACTION contact_dhat), shortened where another
  !> obstacle lies along d: carried_lift), as contact_model carries
  !> single nodes: a thin obstacle between two node columns reaches the
  !> edges but no node. Carried along with the obstacle, a quad keeps the
  !> gap of the state before, the barrier's equilibrium under the push
  !> (a tenth of a micrometre at metres a second); the lift lets Newton
  !> approach it from outside, where a cut update keeps a tenth of a gap
  !> that is still large, instead of from a start already at it, where
  !> the quad's other corners, carried too far, come back only as far as
  !> the tiny gap lets them each iteration (docs/contact.md, "Faces and
  !> edges"). The quads around the strip come from the ranks beside it
  !> (rows ys-1 and ye+1), so a quad that straddles two strips is carried
  !> on both, as on one rank.
  !> Collective.
  subroutine faces_start(this, lat, fixed, t0, t1, x0, x, moved)
    class(face_contact_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: x(0:, 0:, lat%ys:)
    integer, intent(out) :: moved
    integer :: k, i, j
    real(rp) :: d(3), dl(3)
    ! positions of the owned rows and the rows around them at t0 [length]
    real(rp) :: x0a(3, 0:lat%nx - 1, lat%ys - 1:lat%ye + 1)
    type(obstacle_t) :: o0, o1
    logical :: mark(0:lat%nx - 1, lat%ys:lat%ye)
    moved = 0
    if (.not. obstacle_set_moves(this%obstacles, t0, t1) .or. t1 <= t0) return
    call rows_around(this, lat, x0, x0a)
    do k = 1, obstacle_set_count(this%obstacles)
      call obstacle_set_pair(this%obstacles, k, t0, t1, o0, o1, d)
      if (.not. has_features(o1) .or. all(d == 0.0_rp)) cycle
      mark = .false.
      call elements_mark(o0, o1, core(o0), d, this%cp, lat, lat%ys - 1, x0a, lat%ys - 1, lat%ye, mark)
      dl = d + carried_lift(this, lat, fixed, k, t1, x0, x, d, mark, min(norm2(d), LIFT_FRACTION * this%cp%dhat)) &
               * d / norm2(d)
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          if (.not. mark(i, j) .or. fixed(i, j)) cycle
          x(0:2, i, j) = x0(0:2, i, j) + dl
          x(3:5, i, j) = dl / (t1 - t0)
          moved = moved + 1
        end do
      end do
    end do
  end subroutine faces_start

  !> The lift of the quads that obstacle k carries over a step to t1
  !> (faces_start; the free nodes of mark moved by d, the obstacle's
  !> translation): the full lift where it keeps at least half the gap
  !> that the carry alone (x0 + d on those nodes, x elsewhere) leaves
  !> their quads to the other obstacles at t1; else the lift shortened to
  !> half that gap, which moving nodes by it cannot close (a point of a
  !> triangle moves no more than its nodes), and 0 where the carry alone
  !> leaves none. The lift goes along d, and another obstacle may lie that
  !> way: gripper_lift's lower finger, rising, carried the pinched quads
  !> up by its move and lifted them by as much again into the upper
  !> finger, a tenth of a millimetre above them and rising with it, so
  !> every start of the step was infeasible and the run failed at t =
  !> 0.5004 s (docs/contact.md, "Faces and edges"). The same on every rank
  !> (each quad's gap on the rank of its anchor row). Collective.
  real(rp) function carried_lift(this, lat, fixed, k, t1, x0, x, d, mark, lift) result(l)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    integer, intent(in) :: k
    real(rp), intent(in) :: t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:)
    real(rp), intent(in) :: d(3)                ! obstacle k's translation over the step [length]
    logical, intent(in) :: mark(0:, lat%ys:)
    real(rp), intent(in) :: lift                ! the full lift [length]
    ! the start carried without the lift, and its carried flags, on the owned rows and those around [length], [1]
    real(rp) :: xc(4, 0:lat%nx - 1, lat%ys - 1:lat%ye + 1)
    logical :: moved(0:lat%nx - 1, lat%ys - 1:lat%ye + 1)
    real(rp) :: g(2), gg(2)                     ! smallest gap without and with the lift [length]
    type(obstacle_t) :: o
    integer :: i, j, m, c, mpierr
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        xc(4, i, j) = merge(1.0_rp, 0.0_rp, mark(i, j) .and. .not. fixed(i, j))
        xc(1:3, i, j) = merge(x0(0:2, i, j) + d, x(0:2, i, j), xc(4, i, j) > 0.5_rp)
      end do
    end do
    call exchange_rows(this, lat, this%comm, xc)
    moved = xc(4, :, :) > 0.5_rp
    g = huge(1.0_rp)
    do c = 1, 2
      if (c == 2) then
        do j = lat%ys - 1, lat%ye + 1
          do i = 0, lat%nx - 1
            if (moved(i, j)) xc(1:3, i, j) = xc(1:3, i, j) + lift * d / norm2(d)
          end do
        end do
      end if
      do m = 1, obstacle_set_count(this%obstacles)
        if (m == k) cycle
        o = obstacle_set_pose(this%obstacles, m, t1)
        g(c) = min(g(c), elements_gap(o, this%cp, lat, lat%ys - 1, xc, lat%ys, lat%ye, moved))
      end do
    end do
    call MPI_Allreduce(g, gg, 2, MPI_DOUBLE_PRECISION, MPI_MIN, this%comm, mpierr)
    l = lift
    if (gg(2) < 0.5_rp * gg(1)) l = max(0.0_rp, min(lift, 0.5_rp * gg(1)))
  end function carried_lift

  !> The positions of x0 (0:5, 0:nx-1, ys:ye) on the owned rows and the
  !> rows ys-1 and ye+1 of the ranks beside (zero beyond the lattice,
  !> where no quad reads them). Collective.
  subroutine rows_around(this, lat, x0, x0a)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(out) :: x0a(:, 0:, lat%ys - 1:)
    x0a(:, :, lat%ys:lat%ye) = x0(0:2, :, lat%ys:lat%ye)
    call exchange_rows(this, lat, this%comm, x0a)
  end subroutine rows_around

  !> The Newton update dx at x (the stage at t1 = t0 + dt) corrected at
  !> second order for the faces' and edges' pairs (module face_elements'
  !> elements_correct, the obstacles at t1): where a pair's gap at x + dx
  !> falls below its linear prediction, the pair's free nodes are moved
  !> the least that lifts it back (SQP's second-order correction), each
  !> node by its largest such move, and their velocities by the same over
  !> dt (backward Euler's x = x_n + dt v holds as before). Newton's
  !> quadratic model cannot see a triangle's tilt about a node on the
  !> obstacle closing its gap at second order, far more than the gap:
  !> uncorrected, the step limit cut each update to a few per cent and
  !> Newton stalled (docs/contact.md, "Faces and edges"). The correction
  !> is of the update's second order, so Newton's convergence is kept.
  !> Collective: the rows around the strip come from the ranks beside.
  subroutine faces_correct(this, lat, fixed, t0, t1, x, dx, comm, changed)
    class(face_contact_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    ! positions, updates and free flags of the owned rows and those around [length]
    real(rp) :: xa(7, 0:lat%nx - 1, lat%ys - 1:lat%ye + 1), da(3, 0:lat%nx - 1, lat%ys - 1:lat%ye + 1)
    real(rp) :: c(3, 0:lat%nx - 1, lat%ys - 1:lat%ye + 1)
    logical :: free(0:lat%nx - 1, lat%ys - 1:lat%ye + 1), any_c
    type(obstacle_t) :: o
    integer :: k, i, j, mpierr
    changed = .false.
    if (t1 <= t0) return
    if (this%turn_guard) call limit_turns(this, lat, fixed, t1, x, dx, comm, changed)
    xa(1:3, :, lat%ys:lat%ye) = x(0:2, :, lat%ys:lat%ye)
    xa(4:6, :, lat%ys:lat%ye) = dx(0:2, :, lat%ys:lat%ye)
    xa(7, :, lat%ys:lat%ye) = merge(0.0_rp, 1.0_rp, fixed)
    call exchange_rows(this, lat, comm, xa)
    da = xa(4:6, :, :)
    free = xa(7, :, :) > 0.5_rp
    c = 0.0_rp
    do k = 1, obstacle_set_count(this%obstacles)
      o = obstacle_set_pose(this%obstacles, k, t1)
      if (has_features(o)) call elements_correct(o, this%cp, lat, lat%ys - 1, xa(1:3, :, :), da, free, c)
    end do
    any_c = .false.
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j) .or. all(c(:, i, j) == 0.0_rp)) cycle
        dx(0:2, i, j) = dx(0:2, i, j) + c(:, i, j)
        dx(3:5, i, j) = dx(3:5, i, j) + c(:, i, j) / (t1 - t0)
        any_c = .true.
      end do
    end do
    call MPI_Allreduce(MPI_IN_PLACE, any_c, 1, MPI_LOGICAL, MPI_LOR, comm, mpierr)
    changed = changed .or. any_c
  end subroutine faces_correct

  !> The guard on the Newton update dx at x (the stage at t1) where a face
  !> or edge pair's slip turns (module face_lags' lags_turn, the obstacles'
  !> velocities at t1): where the update turns a pair's slip from at
  !> least friction_eps_v / 2 at x to at least friction_eps_v the other
  !> way at x + dx through the sticking band, the whole update is scaled
  !> to the fraction where that pair's slip is least (in the band), the
  !> least such fraction over the pairs, as the node contact's step limit
  !> scales it for its nodes (the same kernel, coulomb_turn). Sliding, the
  !> smoothed law's force has a constant magnitude and no stiffness along
  !> the slip, so Newton's model does not see it turn: full updates
  !> carried a pair through the band and back at every iteration
  !> (drape_sphere with the faces: ||F|| cycling for 50 iterations, the
  !> step retried; docs/contact.md, "Faces and edges"); in the band the law
  !> is stiff and Newton converges. Scaling only the pair's own nodes
  !> instead (the rest of the cloth kept at the full update) made the
  !> residual grow 10-fold an iteration (the same landing: 3e4 to 1.5e8 in
  !> 4 iterations), the neighbours' update having been solved for with
  !> those nodes moving. changed: dx was scaled (the same on every rank).
  !> Collective: the rows around the strip come from the ranks beside.
  subroutine limit_turns(this, lat, fixed, t1, x, dx, comm, changed)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    ! velocities, their update and the free flags of the owned rows and those around
    real(rp) :: vd(7, 0:lat%nx - 1, lat%ys - 1:lat%ye + 1)   ! [length/time], [1]
    real(rp) :: fac(0:lat%nx - 1, lat%ys - 1:lat%ye + 1)     ! each node's fraction of the update [1]
    real(rp) :: a
    type(obstacle_t) :: obs(obstacle_set_count(this%obstacles))
    integer :: k, mpierr
    vd(1:3, :, lat%ys:lat%ye) = x(3:5, :, lat%ys:lat%ye)
    vd(4:6, :, lat%ys:lat%ye) = dx(3:5, :, lat%ys:lat%ye)
    vd(7, :, lat%ys:lat%ye) = merge(0.0_rp, 1.0_rp, fixed)
    call exchange_rows(this, lat, comm, vd)
    do k = 1, size(obs)
      obs(k) = obstacle_set_pose(this%obstacles, k, t1)
    end do
    fac = 1.0_rp
    call lags_turn(this%lags, obs, this%cp, lat, vd(1:6, :, :), vd(7, :, :) > 0.5_rp, fac)
    call MPI_Allreduce(minval(fac(:, lat%ys:lat%ye)), a, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    changed = a < 1.0_rp
    if (changed) dx = a * dx
  end subroutine limit_turns

  !> The rows ys-1 and ye+1 of v(:, 0:nx-1, ys-1:ye+1) from the ranks
  !> beside (zero beyond the lattice, where no element reads them), its
  !> owned rows given. Collective.
  subroutine exchange_rows(this, lat, comm, v)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(inout) :: v(:, 0:, lat%ys - 1:)
    real(rp) :: snd(size(v, 1), 0:lat%nx - 1), rcv(size(v, 1), 0:lat%nx - 1)
    integer :: mpierr
    snd = v(:, :, lat%ys)
    rcv = 0.0_rp
    call MPI_Sendrecv(snd, size(snd), MPI_DOUBLE_PRECISION, this%rank_down, 50, rcv, size(rcv), MPI_DOUBLE_PRECISION, &
                      this%rank_up, 50, comm, MPI_STATUS_IGNORE, mpierr)
    v(:, :, lat%ye + 1) = rcv
    snd = v(:, :, lat%ye)
    rcv = 0.0_rp
    call MPI_Sendrecv(snd, size(snd), MPI_DOUBLE_PRECISION, this%rank_up, 51, rcv, size(rcv), MPI_DOUBLE_PRECISION, &
                      this%rank_down, 51, comm, MPI_STATUS_IGNORE, mpierr)
    v(:, :, lat%ys - 1) = rcv
  end subroutine exchange_rows

  !> The Newton update x -> x + dx limited so that no triangle or edge
  !> reaches an obstacle at its pose at t1 (ACCD, keeping a tenth of each
  !> pair's gap: IPC's CCD); where obstacles move over [t0, t1], alpha is
  !> halved (at most 10 times) until no element's path from x0 to the
  !> candidate, the obstacle translating, comes within SWEPT_S of its
  !> start's gap to the obstacle's core (core), and PM_INFEASIBLE when
  !> halving does not help.
  !> Collective: the row above the strip comes from the rank above.
  subroutine faces_step_limit(this, lat, fixed, t0, t1, x0, x, dx, comm, alpha, status)
    class(face_contact_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    integer, intent(out) :: status
    ! positions and updates of the owned rows and the row above [length]
    real(rp) :: xa(3, 0:lat%nx - 1, lat%ys:lat%ye + 1), da(3, 0:lat%nx - 1, lat%ys:lat%ye + 1)
    real(rp) :: x0a(3, 0:lat%nx - 1, lat%ys:lat%ye + 1), path(3, 0:lat%nx - 1, lat%ys:lat%ye + 1)
    real(rp) :: a, ga, s, d(3), zero(3)
    integer :: k, try, mpierr
    type(obstacle_t) :: o0, o1
    logical :: moving
    call with_row_above(this, lat, comm, x0, x, dx, x0a, xa, da)
    zero = 0.0_rp
    a = 1.0_rp
    do k = 1, obstacle_set_count(this%obstacles)
      o1 = obstacle_set_pose(this%obstacles, k, t1)
      if (has_features(o1)) a = min(a, elements_ccd(o1, this%cp%thickness, lat, xa, da, zero, ACCD_S))
    end do
    call MPI_Allreduce(a, ga, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    s = ga
    status = PM_FEASIBLE
    moving = obstacle_set_moves(this%obstacles, t0, t1)
    do try = 0, 10
      if (.not. moving) exit
      path = xa + s * da - x0a
      a = 1.0_rp
      do k = 1, obstacle_set_count(this%obstacles)
        call obstacle_set_pair(this%obstacles, k, t0, t1, o0, o1, d)
        if (has_features(o0)) a = min(a, elements_ccd(core(o0), 0.0_rp, lat, x0a, path, d, SWEPT_S))
      end do
      call MPI_Allreduce(a, ga, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
      if (ga >= 1.0_rp) exit
      s = 0.5_rp * s
      if (try == 10) status = PM_INFEASIBLE
    end do
    alpha = s
  end subroutine faces_step_limit

  !> The obstacle's core, the shape shrunk by half its smallest radius or
  !> half-extent (as the node contact's swept check, module obstacle_set):
  !> an element carried along a curved surface over a step slides on it,
  !> and its relative path, a chord, cuts the surface's cap though it never
  !> was inside; an obstacle that passes through the cloth crosses the core.
  pure function core(o) result(c)
    type(obstacle_t), intent(in) :: o
    type(obstacle_t) :: c
    c = o
    c%r = 0.5_rp * o%r
    c%h = o%h - 0.5_rp * minval(o%h)
  end function core

  !> The positions of x0, x and the update dx (0:5, 0:nx-1, ys:ye) on the
  !> owned rows and the row ye+1 (the rank above's first row; zero at the
  !> lattice's top, where no element reads it). Collective.
  subroutine with_row_above(this, lat, comm, x0, x, dx, x0a, xa, da)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    real(rp), intent(out) :: x0a(:, 0:, lat%ys:), xa(:, 0:, lat%ys:), da(:, 0:, lat%ys:)
    real(rp) :: snd(9, 0:lat%nx - 1), rcv(9, 0:lat%nx - 1)
    integer :: mpierr
    x0a(:, :, lat%ys:lat%ye) = x0(0:2, :, lat%ys:lat%ye)
    xa(:, :, lat%ys:lat%ye) = x(0:2, :, lat%ys:lat%ye)
    da(:, :, lat%ys:lat%ye) = dx(0:2, :, lat%ys:lat%ye)
    snd(1:3, :) = x0(0:2, :, lat%ys)
    snd(4:6, :) = x(0:2, :, lat%ys)
    snd(7:9, :) = dx(0:2, :, lat%ys)
    rcv = 0.0_rp
    call MPI_Sendrecv(snd, size(snd), MPI_DOUBLE_PRECISION, this%rank_down, 47, rcv, size(rcv), MPI_DOUBLE_PRECISION, &
                      this%rank_up, 47, comm, MPI_STATUS_IGNORE, mpierr)
    x0a(:, :, lat%ye + 1) = rcv(1:3, :)
    xa(:, :, lat%ye + 1) = rcv(4:6, :)
    da(:, :, lat%ye + 1) = rcv(7:9, :)
  end subroutine with_row_above

  !> A step's end state u at t: the smallest gap of the triangles and
  !> edges (the nodes included) must be at least the floor; else
  !> PM_INFEASIBLE and why (the step is retried smaller). Collective.
  subroutine faces_accept(this, lat, fixed, t, u, comm, status, why)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: status
    character(*), intent(out) :: why
    real(rp) :: g, gmin
    integer :: k, mpierr
    gmin = huge(1.0_rp)
    do k = 1, obstacle_set_count(this%obstacles)
      gmin = min(gmin, smallest_gap(this, lat, t, k, u(0:2, :, :)))
    end do
    call MPI_Allreduce(gmin, g, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    status = merge(PM_FEASIBLE, PM_INFEASIBLE, g >= this%floor)
    why = ''
    if (status == PM_FEASIBLE) return
    why = 'the state at t = '//real_brief(t)//' has a cloth triangle or edge at a gap of '//real_brief(g)// &
          ', below the acceptance floor '//real_brief(this%floor)//' (1e-6 contact_dhat; docs/contact.md, '// &
          '"Acceptance"): a stiffer barrier (contact_stiffness) or a larger contact_dhat keeps it above the floor'
  end subroutine faces_accept

  !> The smallest gap of the triangles (their edges and nodes included)
  !> of the quads anchored on the owned rows to obstacle k at t, from the
  !> ghosted positions x(3, 0:nx-1, gys:gye) [length] (huge: none near).
  real(rp) function smallest_gap(this, lat, t, k, x) result(g)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    integer, intent(in) :: k
    real(rp), intent(in) :: x(:, 0:, lat%gys:)
    type(obstacle_t) :: o
    g = huge(1.0_rp)
    o = obstacle_set_pose(this%obstacles, k, t)
    if (has_features(o)) g = elements_gap(o, this%cp, lat, lat%gys, x, lat%ys, lat%ye)
  end function smallest_gap

  !> An accepted state u at t: the smallest gap of a triangle or edge,
  !> the face and edge pairs within contact_dhat and their barrier energy
  !> (each element once: by its anchor row's rank), and the moving
  !> obstacles' work through them (trapezoid rule over the step), for the
  !> output; a gap <= 0 is an error (the accept hook lets none through).
  !> A state recorded already is left alone. Collective.
  subroutine faces_accepted(this, lat, fixed, t, u, comm, ierr, errmsg)
    class(face_contact_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: gmin, g, e, ge, loc(8), glob(8), pend, pstart
    integer :: k, nact, gnact, gn(2), mpierr
    type(obstacle_t) :: obs(obstacle_set_count(this%obstacles))
    real(rp) :: unused_f(3, 0, 0)             ! (the walk's forces and blocks: untouched here)
    type(node_blocks_t) :: unused_blocks
    ierr = 0
    errmsg = ''
    if (this%have_last .and. t == this%t_seen) return
    gmin = huge(1.0_rp)
    e = 0.0_rp
    nact = 0
    do k = 1, size(obs)
      obs(k) = obstacle_set_pose(this%obstacles, k, t)
      if (.not. has_features(obs(k))) cycle
      gmin = min(gmin, elements_gap(obs(k), this%cp, lat, lat%gys, u(0:2, :, :), lat%ys, lat%ye))
      call elements_walk(WALK_STATS, obs(k), this%cp, lat, fixed, u, unused_f, unused_blocks, nact, e)
    end do
    ! the step's end with the step's own lag (friction power, forces), then
    ! the lag of this state for the next step and its power here
    loc(1:2) = [e, lags_power(this%lags, obs, this%cp, lat, u)]
    call forces_and_power(this, lat, fixed, t, u, loc(3:5), loc(6:7))
    call lags_clear(this%lags)
    do k = 1, size(obs)
      if (has_features(obs(k))) call lags_take(this%lags, k, obs(k), this%cp, lat, u)
    end do
    loc(8) = lags_power(this%lags, obs, this%cp, lat, u)
    call MPI_Allreduce(gmin, g, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    call MPI_Allreduce(loc, glob, 8, MPI_DOUBLE_PRECISION, MPI_SUM, comm, mpierr)
    call MPI_Allreduce([nact, lags_with_friction(this%lags, obs)], gn, 2, MPI_INTEGER, MPI_SUM, comm, mpierr)
    gnact = gn(1)
    this%turn_guard = gn(2) > 0
    ge = glob(1)
    pend = glob(2)
    pstart = glob(8)
    if (this%have_last) then
      this%friction_work = this%friction_work + 0.5_rp * (t - this%t_seen) * (this%pfric_last + pend)
      this%obstacle_work = this%obstacle_work + 0.5_rp * (t - this%t_seen) * (this%pstart_last + glob(6))
    end if
    this%pfric_last = pstart
    this%pstart_last = glob(7)
    this%have_last = .true.
    this%t_seen = t
    this%min_gap = g
    this%energy = ge
    this%active = gnact
    this%force = glob(3:5)
    if (g > 0.0_rp) return
    ierr = 1
    errmsg = 'nuno: contact_faces: an accepted state has a cloth triangle or edge inside an obstacle at t = '// &
             real_brief(t)//': smallest gap '//real_brief(g)
  end subroutine faces_accepted

  !> The forces of the faces' and edges' pairs (barrier and lagged
  !> friction) on the free owned nodes at u, t: their sum ftot [force] and
  !> the moving obstacles' power through them, with each obstacle's
  !> velocity of the keyframe segment that ends at t (the step before:
  !> p(1)) and of the one that starts there (the step after: p(2))
  !> [energy/time].
  subroutine forces_and_power(this, lat, fixed, t, u, ftot, p)
    class(face_contact_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(out) :: ftot(3), p(2)
    real(rp) :: f(3, 0:lat%nx - 1, lat%ys:lat%ye), fk(3)
    integer :: k, nbad
    type(obstacle_t) :: obs(obstacle_set_count(this%obstacles)), onext
    type(node_blocks_t) :: none               ! (the walks' blocks: untouched here)
    real(rp) :: unused                        ! (the walk's energy: untouched here)
    p = 0.0_rp
    ftot = 0.0_rp
    do k = 1, size(obs)
      obs(k) = obstacle_set_pose(this%obstacles, k, t)
    end do
    do k = 1, size(obs)
      if (.not. has_features(obs(k))) cycle
      onext = obstacle_set_pose(this%obstacles, k, t, right=.true.)
      f = 0.0_rp
      nbad = 0
      call elements_walk(WALK_FORCES, obs(k), this%cp, lat, fixed, u, f, none, nbad, unused)
      call lags_walk(WALK_FORCES, this%lags, obs, this%cp, lat, fixed, u, k, f, none)
      fk = sum(sum(f, dim=3), dim=2)
      ftot = ftot + fk
      p = p + [dot_product(fk, obs(k)%vel), dot_product(fk, onext%vel)]
    end do
  end subroutine forces_and_power

  !> The run's state that goes on across a restart: the moving obstacles'
  !> work through these pairs and their friction work [energy].
  subroutine faces_checkpoint(this, values)
    class(face_contact_t), intent(in) :: this
    type(named_value_t), allocatable, intent(out) :: values(:)
    values = [named_value('contact_faces_obstacle_work', [this%obstacle_work], .false.), &
              named_value('contact_faces_friction_work', [this%friction_work], .false.)]
  end subroutine faces_checkpoint

  !> A restart's obstacle work from its checkpoint (0 in a file written
  !> before it); the checkpoint's state, recorded again at the restart's
  !> first accepted hook, adds no work.
  subroutine faces_restore(this, values)
    class(face_contact_t), intent(inout) :: this
    type(named_value_t), intent(in) :: values(:)
    integer :: k
    this%obstacle_work = 0.0_rp
    this%friction_work = 0.0_rp
    do k = 1, size(values)
      if (size(values(k)%v) < 1) cycle
      if (trim(values(k)%name) == 'contact_faces_obstacle_work') this%obstacle_work = values(k)%v(1)
      if (trim(values(k)%name) == 'contact_faces_friction_work') this%friction_work = values(k)%v(1)
    end do
    this%have_last = .false.
  end subroutine faces_restore

  !> The series of the last accepted state: /contact_faces and
  !> /energy/barrier_faces, the face and edge pairs' barrier energy, a
  !> potential energy of the balance; the moving obstacles' work through
  !> them an external work.
  subroutine faces_output(this, series, groups, energy)
    class(face_contact_t), intent(in) :: this
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
    real(rp) :: g
    g = min(this%min_gap, this%cp%dhat)
    series = [ &
      pm_series_t(name='/contact_faces/active', description='triangle- and edge-obstacle pairs with a gap below contact_dhat', &
                  is_count=.true., count=this%active), &
      pm_series_t(name='/contact_faces/min_gap', description='smallest gap of a cloth triangle or edge (its nodes '// &
                  'included) to an obstacle with features (not a plane; contact_dhat where none is within it)', units='length', &
                  values=[g, 0.0_rp, 0.0_rp]), &
      pm_series_t(name='/contact_faces/force', description='total force of the triangle- and edge-obstacle pairs '// &
                  'on the cloth, barrier and friction, [t][xyz]', units='force', ncomp=3, values=this%force), &
      pm_series_t(name='/contact_faces/friction_work', description='friction work of these pairs since the start '// &
                  '(dissipated, >= 0; part of /energy/dissipated)', units='energy', values=[this%friction_work, 0.0_rp, 0.0_rp]), &
      pm_series_t(name='/energy/barrier_faces', description='barrier energy of the triangle- and edge-obstacle '// &
                  'pairs (a potential energy of the balance, beside /energy/barrier)', units='energy', &
                  values=[this%energy, 0.0_rp, 0.0_rp])]
    groups = [pm_group_t(name='/contact_faces', description='contact of the cloth''s triangles and edges with the '// &
                         'obstacles of &contact, per output step')]
    energy = pm_energy_t(potential=this%energy, dissipated=this%friction_work, external_work=this%obstacle_work)
  end subroutine faces_output

end module face_contact
