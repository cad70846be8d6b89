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
  public :: checkpoint_t

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
    !> Contact's run diagnostics (module contact_forces; scenes with
    !> obstacles: contact = 1, else 0, as in files written before them):
    !> the friction work and the moving obstacles' work so far [energy],
    !> the smallest gap over every accepted state [length], the states
    !> checked, the limited Newton updates
    integer :: contact = 0
    real(rp) :: friction_work = 0
    real(rp) :: obstacle_work = 0
    real(rp) :: min_gap_run = huge(1.0_rp)
    integer :: states_checked = 0, limited_steps = 0
  end type checkpoint_t

end module checkpoint_record
