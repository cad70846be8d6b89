! SPDX-License-Identifier: BSD-2-Clause
!> The output steps of a run (docs/model.md section 10, input/README.md
!> &output): the state's diagnostics, the energy integrals and the process
!> models' series into one output record, the step written (module
!> output), the one-line progress summary on rank 0 and the stretch check.
!> The run driver (module timestepping) decides when; this module what an
!> output step holds.
module output_steps
#include "petsc/finclude/petscts.h"
  use petscts
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: rp
  use ghosted_state, only: ghosted_get, ghosted_restore
  use lattice, only: link_dir
  use forces, only: link_stretch_extremes
  use diagnostics, only: state_diagnostics_t, state_diagnostics
  use output, only: output_file, output_record, output_write_step
  use app_context, only: app_ctx
  use step_settings, only: step_t_end
  use energy_integrals, only: energy_set_mgx0, energy_totals
  use run_progress, only: progress_output_written, progress_said, progress_warn_stretch, progress_wall, &
                          progress_stretch_warned
  use model_state, only: model_gravity
  use process_model, only: pm_energy_t, pm_group_t
  use process_models, only: pm_list_on, pm_list_output
  use process_solver, only: pm_observe
  use failure_text, only: report_io_error
  use strings, only: num => real_brief, inum => itoa
  use run_checkpoint, only: restart_state_t, run_counts, restart_output_written, state_to_strips
  implicit none
  private
  public :: write_output, write_state, AT_STEP

  !> No energy integrals to take off an output step's (the solver's own state).
  real(rp), parameter :: AT_STEP(2) = 0.0_rp

contains
  !> The output step at t of the solver's state (the TS's, at its time,
  !> which t is or is within eps_on of): write_state; first the process
  !> models' record of the state at the TS's time (the monitor's after a
  !> step, so nothing is recorded twice; at t = 0, before any step, made
  !> here: contact's barrier energy of the start). Collective.
  subroutine write_output(ctx, r, out, t, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: t_ts

    PetscCall(TSGetTime(ctx%ts, t_ts, ierr))
    PetscCall(pm_observe(ctx, t_ts, ctx%u, ierr))
    call write_state(ctx, r, out, t, ctx%u, AT_STEP, ierr)
  end subroutine write_output

  !> Diagnostics and one output step at t of the state u, de the energy
  !> integrals [energy] from t to the last step's end, which the output
  !> step's leave out (integrals_after; AT_STEP for the solver's own
  !> state); a one-line summary on rank 0. The process models' columns
  !> (contact's) are the last accepted state's. Collective.
  subroutine write_state(ctx, r, out, t, u, de, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(restart_state_t), intent(inout) :: r
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: t, de(2)
    type(tVec), intent(in) :: u
    PetscErrorCode, intent(out) :: ierr
    type(state_diagnostics_t) :: d
    type(output_record) :: rec
    character(len=512) :: errmsg
    real(rp) :: c(5), potential

    PetscCall(output_state(ctx, t, u, d, ierr))
    if (t == 0.0_rp) call energy_set_mgx0(ctx%energy, d%mgx)
    call run_counts(ctx, r, c, ierr)
    if (ierr /= 0) return
    call fill_record(ctx, t, d, c, rec, potential)
    rec%dissipated = rec%dissipated - de(1)
    rec%external_work = rec%external_work - de(2)
    if (ctx%cfg%output%write_velocity) then
      call output_write_step(out, rec, ctx%xout, ierr, errmsg, v=ctx%vout)
    else
      call output_write_step(out, rec, ctx%xout, ierr, errmsg)
    end if
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
      return
    end if
    call progress_output_written(ctx%progress, t)
    call restart_output_written(r)
    if (ctx%rank == 0) call progress_line(ctx, rec, d, int(c(5)), potential)
  end subroutine write_state

  !> The state uvec at t for an output step: its diagnostics d
  !> (collective), the stretch check (warned once), its positions and
  !> velocities into the output buffers ctx%xout, ctx%vout. Collective.
  subroutine output_state(ctx, t, uvec, d, ierr)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    type(tVec), intent(in) :: uvec
    type(state_diagnostics_t), intent(out) :: d
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :)

    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    call state_diagnostics(ctx%lat, u, model_gravity(ctx%model), ctx%comm, d, ierr)
    if (.not. progress_stretch_warned(ctx%progress) .and. ctx%cfg%output%stretch_limit > 0.0_rp) call check_stretch(ctx, u, t)
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    PetscCall(state_to_strips(ctx, uvec, ctx%xout, ctx%vout, ierr))
  end subroutine output_state

  !> The output step's record at t: the state's diagnostics d, the energy
  !> integrals, the process models' series and terms of the energy balance
  !> (potential: their potential energy, for the progress line), the run's
  !> counts c (run_counts), the wall time.
  subroutine fill_record(ctx, t, d, c, rec, potential)
    type(app_ctx), intent(in) :: ctx
    real(rp), intent(in) :: t, c(5)
    type(state_diagnostics_t), intent(in) :: d
    type(output_record), intent(out) :: rec
    real(rp), intent(out) :: potential
    real(rp) :: dissipated, work_constraints, mgx0
    type(pm_energy_t) :: pe
    type(pm_group_t), allocatable :: groups(:)

    rec%time = t
    rec%kinetic = d%kinetic
    rec%stretch = d%stretch
    rec%bend = d%bend
    call energy_totals(ctx%energy, dissipated, work_constraints, mgx0)
    rec%dissipated = dissipated
    rec%external_work = work_constraints + (d%mgx - mgx0)
    rec%momentum = d%momentum
    rec%angular_momentum = d%angular_momentum
    rec%length = d%length
    rec%flatness = d%flatness
    ! The process models' series and their terms of the energy balance
    ! (docs/model.md section 10; contact's: the barrier energy a potential
    ! energy, the friction work a dissipation, the moving obstacles' work
    ! an external work), as their accepted hooks recorded the state.
    potential = 0.0_rp
    if (pm_list_on(ctx%pms)) then
      call pm_list_output(ctx%pms, rec%pm_series, groups, pe)
      potential = pe%potential
      rec%dissipated = rec%dissipated + pe%dissipated
      rec%external_work = rec%external_work + pe%external_work
    end if
    rec%steps = int(c(1), kind(rec%steps))
    rec%rejected_steps = int(c(2), kind(rec%rejected_steps))
    rec%newton_iterations = int(c(3), kind(rec%newton_iterations))
    rec%linear_iterations = int(c(4), kind(rec%linear_iterations))
    rec%wall_time = progress_wall(ctx%progress)
  end subroutine fill_record

  !> The output step's line on stdout (rank 0), for a person and for awk:
  !> every field has a blank before it (es13.5e2 of a negative value still
  !> starts with one; the integer widths hold 10^8 steps), rates from the
  !> start of the run. Flushed: a redirected run shows its progress and
  !> keeps it when killed. The order up to 'linear' is the one
  !> bench/solver.py parses. Before any step (t = 0) there is no rate yet:
  !> '-' for the rate and the ETA (same fields, so awk's columns stay).
  subroutine progress_line(ctx, rec, d, retries, potential)
    type(app_ctx), intent(inout) :: ctx
    type(output_record), intent(in) :: rec
    type(state_diagnostics_t), intent(in) :: d
    integer, intent(in) :: retries               !< Newton solves retried with a smaller step
    real(rp), intent(in) :: potential            !< the process models' potential energy [energy]
    real(rp) :: t, wall, rate, eta

    t = rec%time
    wall = rec%wall_time
    write(output_unit, '(a,es12.5e2, a,i9, a,i6, a,i9, a,i11, a,i6, 2(a,es13.5e2), a,es10.3e2)', advance='no') &
      't =', t, '  steps', rec%steps, '  rejected', rec%rejected_steps, '  newton', rec%newton_iterations, &
      '  linear', rec%linear_iterations, '  retries', retries, '  E_kin', d%kinetic, &
      '  E_total', d%kinetic + d%stretch + d%bend + potential + rec%dissipated - rec%external_work, &
      '  wall_s', wall
    if (t > 0.0_rp .and. wall > 0.0_rp) then
      rate = t / wall
      eta = (step_t_end(ctx%step) - t) / rate
      write(output_unit, '(2(a,es10.3e2))') '  sim_per_wall_s', rate, '  eta_s', eta
    else
      write(output_unit, '(a)') '  sim_per_wall_s -  eta_s -'
    end if
    flush(output_unit)
    call progress_said(ctx%progress)
  end subroutine progress_line

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
    lim = ctx%cfg%output%stretch_limit
    if (g(1) <= lim .and. g(2) <= lim) return
    call progress_warn_stretch(ctx%progress)
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

end module output_steps
