! SPDX-License-Identifier: BSD-2-Clause
!> The contact model's record of the run (docs/design.md, "Contact",
!> output and energy): the last accepted state's statistics over all
!> ranks, the run's smallest gap, the counts, the friction work and the
!> moving obstacles' work (the trapezoid rule over each accepted step);
!> the series and energy terms its output hook hands the output file,
!> the named values of a checkpoint and their restore, and the `contact:`
!> line. No MPI: the values come reduced. contact_record_t's components
!> are private: only this module's procedures write it.
module contact_record
  use kinds, only: rp
  use checkpoint_record, only: named_value_t, named_value
  use process_model, only: pm_series_t, pm_group_t, pm_energy_t
  use strings, only: itoa, real_es
  implicit none
  private
  public :: contact_record_t, record_state, record_limited, record_seen, record_min_gap_run
  public :: record_series, record_checkpoint, record_restore, record_line

  !> The contact diagnostics of the last accepted state and of the run so
  !> far, over all ranks.
  type :: contact_record_t
    private
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
    logical :: have_last = .false.                  !< t_last, pfric_last hold the last accepted state's
    !> the next state recorded is a checkpoint's, recorded already by the
    !> run that wrote it (restore): not counted again
    logical :: resumed = .false.
    real(rp) :: t_last = 0.0_rp                     !< time of the last accepted state [time]
    real(rp) :: pfric_last = 0.0_rp                 !< friction power there with the next step's lag [energy/time]
    real(rp) :: pobs_last = 0.0_rp                  !< obstacles' power there with the next step's lag [energy/time]
  end type contact_record_t

contains

  !> The state at t was recorded last (TSSolve calls its monitors at every
  !> window's start too, with the state its last step accepted).
  pure logical function record_seen(r, t)
    type(contact_record_t), intent(in) :: r
    real(rp), intent(in) :: t
    record_seen = r%have_last .and. t == r%t_last
  end function record_seen

  !> The smallest gap over every accepted state so far [length].
  pure real(rp) function record_min_gap_run(r)
    type(contact_record_t), intent(in) :: r
    record_min_gap_run = r%min_gap_run
  end function record_min_gap_run

  !> A Newton update scaled by the step limit.
  subroutine record_limited(r)
    type(contact_record_t), intent(inout) :: r
    r%limited_steps = r%limited_steps + 1
  end subroutine record_limited

  !> Record an accepted state at t, its statistics reduced over all ranks:
  !> the smallest gap gmin, the active pairs, the total and normal forces,
  !> the barrier energy; pend the friction power at t with the lag of the
  !> step that ended there, pstart with the next step's [energy/time];
  !> oend and ostart the same of the moving obstacles' power on the cloth.
  !> The friction work and the obstacle work grow by the trapezoid rule
  !> over the step, both ends with the step's own lag.
  subroutine record_state(r, t, gmin, nact, ftot, fnrm, ebar, pend, pstart, oend, ostart)
    type(contact_record_t), intent(inout) :: r
    real(rp), intent(in) :: t, gmin, ftot(3), fnrm(3), ebar, pend, pstart, oend, ostart
    integer, intent(in) :: nact
    if (r%have_last) then
      r%friction_work = r%friction_work + 0.5_rp * (t - r%t_last) * (r%pfric_last + pend)
      r%obstacle_work = r%obstacle_work + 0.5_rp * (t - r%t_last) * (r%pobs_last + oend)
    end if
    if (.not. r%resumed) r%states_checked = r%states_checked + 1
    r%min_gap_run = min(r%min_gap_run, gmin)
    r%active = nact
    r%force = ftot
    r%normal_force = fnrm
    r%energy = ebar
    r%min_gap = gmin
    r%resumed = .false.
    r%have_last = .true.
    r%t_last = t
    r%pfric_last = pstart
    r%pobs_last = ostart
  end subroutine record_state

  !> The `contact:` line of the last state recorded, at t (rank 0 prints it
  !> at each output time; tests/python/nunorun.py reads it).
  function record_line(r, t) result(s)
    type(contact_record_t), intent(in) :: r
    real(rp), intent(in) :: t
    character(len=:), allocatable :: s
    s = 'contact: t = '//real_es(t)//', active = '//itoa(r%active)//', force = '// &
        real_es(r%force(1))//' '//real_es(r%force(2))//' '//real_es(r%force(3))//', min gap = '//real_es(r%min_gap)// &
        ', min gap of all accepted states = '//real_es(r%min_gap_run)//', states checked = '// &
        itoa(r%states_checked)//', limited Newton steps = '//itoa(r%limited_steps)// &
        ', barrier energy = '//real_es(r%energy)//', friction work = '//real_es(r%friction_work)
  end function record_line

  !> The series of the last accepted state (docs/model.md sections 9 and
  !> 10): /energy/barrier and the group /contact; the barrier energy a
  !> potential energy of the balance, the friction work a dissipation,
  !> the moving obstacles' work an external work.
  subroutine record_series(c, series, groups, energy)
    type(contact_record_t), intent(in) :: c
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
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
  end subroutine record_series

  !> The run's diagnostics that go on across a restart: the friction work,
  !> the obstacle work [energy], the smallest gap so far [length], the
  !> states checked and the limited Newton updates (the checkpoint
  !> attributes of files written before the process models).
  subroutine record_checkpoint(r, values)
    type(contact_record_t), intent(in) :: r
    type(named_value_t), allocatable, intent(out) :: values(:)
    values = [named_value('contact_friction_work', [r%friction_work], .false.), &
              named_value('contact_obstacle_work', [r%obstacle_work], .false.), &
              named_value('contact_min_gap_run', [r%min_gap_run], .false.), &
              named_value('contact_states_checked', [real(r%states_checked, rp)], .true.), &
              named_value('contact_limited_steps', [real(r%limited_steps, rp)], .true.)]
  end subroutine record_checkpoint

  !> A restart's run diagnostics from its checkpoint's named values (none
  !> without contact_friction_work: a file of a run without obstacles; no
  !> contact_obstacle_work in files written before it: 0). The
  !> checkpoint's own state, recorded again at the restart's first
  !> accepted hook, is not counted twice.
  subroutine record_restore(r, values)
    type(contact_record_t), intent(inout) :: r
    type(named_value_t), intent(in) :: values(:)
    real(rp) :: v
    if (.not. find(values, 'contact_friction_work', v)) return
    r%friction_work = v
    r%obstacle_work = 0.0_rp
    if (find(values, 'contact_obstacle_work', v)) r%obstacle_work = v
    if (find(values, 'contact_min_gap_run', v)) r%min_gap_run = v
    if (find(values, 'contact_states_checked', v)) r%states_checked = nint(v)
    if (find(values, 'contact_limited_steps', v)) r%limited_steps = nint(v)
    r%have_last = .false.
    r%resumed = r%states_checked > 0
  end subroutine record_restore

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

end module contact_record
