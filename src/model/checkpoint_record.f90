! SPDX-License-Identifier: BSD-2-Clause
!> What a checkpoint holds besides the state (checkpoint_t): a plain
!> record that the run's checkpoints fill (module run_checkpoint) and the
!> output file writes and reads (module output, checkpoint_check), so that
!> the run driver keeps its restart point (run_checkpoint's
!> restart_state_t) without knowing HDF5.
module checkpoint_record
  use kinds, only: rp
  implicit none
  private
  public :: checkpoint_t, named_value_t, named_value

  !> One named value of a process model's state in a checkpoint (module
  !> process_model's checkpoint and restore hooks): written as the
  !> attribute `name` of the checkpoint's slot, an integer one when
  !> is_int (v holds whole numbers then), float64 otherwise.
  type :: named_value_t
    character(len=48) :: name = ''
    logical :: is_int = .false.
    real(rp), allocatable :: v(:)
  end type named_value_t

  !> Everything a run needs, besides its state (positions and velocities),
  !> to continue from a checkpoint (docs/design.md, "Checkpoints"). The
  !> same values on every rank (they become attributes).
  type :: checkpoint_t
    real(rp) :: time = 0                  !< [time]
    real(rp) :: dt_next = 0               !< the step the run takes next [time]
    real(rp) :: wall_time = 0             !< wall-clock seconds of the run up to here, restarts included [s]
    real(rp) :: dissipated = 0            !< dissipated energy so far [energy]
    real(rp) :: work_constraints = 0      !< work of the constraint reactions so far [energy]
    real(rp) :: mgx0 = 0                  !< sum m g . x at t = 0 [energy]
    real(rp) :: t_written = -1            !< time of the last output step [time]
    !> accepted steps, rejected steps, Newton iterations, linear iterations,
    !> retried Newton solves, all since t = 0 (float64: exact to 2^53)
    real(rp) :: counters(5) = 0
    integer :: n_output_steps = 0         !< output steps in the file at this checkpoint
    integer :: stretch_warned = 0         !< 1: the stretch_limit warning was given
    character(len=64) :: reason = ''      !< why it was written: interval, end, SIGTERM, SIGINT, wall time
    character(len=64) :: ts_type = ''     !< the integrator that wrote it
    integer :: sequence = 0               !< 1, 2, ... in the order written (set by output_write_checkpoint)
    !> The Newton start's kept states before this one (-nuno_newton_start
    !> cubic, module newton_start), newest first, so that a restart
    !> starts the next steps as the run that went through did: their
    !> number (0..3; 0 in files written before 4 Dec 2026), positions and
    !> velocities (3, nx, ym, start_count) [length], [length/time], times,
    !> and the start's comparison state (1: compare with the linear start)
    integer :: start_count = 0
    real(rp), allocatable :: start_x(:, :, :, :), start_v(:, :, :, :)
    real(rp) :: start_t(3) = 0
    integer :: start_compare = 1
    real(rp) :: start_nc_prev = 0
    !> The round-off floor of ||F|| estimated at the last assembly of the
    !> reduced solve (module reduced, floor_est) [residual]: the first
    !> Newton iteration of the next step takes its inner tolerance from it
    !> (set_newton_forcing), so a restart needs it to repeat that step bit
    !> for bit (0: unknown, files written before 5 Dec 2026)
    real(rp) :: newton_floor = 0
    !> The process models' state (module process_model's checkpoint hook),
    !> each value an attribute of the slot named as the value (contact's:
    !> contact_friction_work, contact_obstacle_work, contact_min_gap_run,
    !> contact_states_checked, contact_limited_steps, as files written
    !> before the process models have them); none without process models
    type(named_value_t), allocatable :: pm_values(:)
  end type checkpoint_t

contains

  !> A named value: name, the values v, is_int: stored as integers.
  pure function named_value(name, v, is_int) result(nv)
    character(*), intent(in) :: name
    real(rp), intent(in) :: v(:)
    logical, intent(in) :: is_int
    type(named_value_t) :: nv
    nv%name = name
    nv%v = v
    nv%is_int = is_int
  end function named_value

end module checkpoint_record
