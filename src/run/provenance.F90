! SPDX-License-Identifier: BSD-2-Clause
!> Provenance of a run in its output file: the run information, the
!> configuration as used, and the input's unit system (&scene units).
module provenance
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, unset_real
  use output, only: output_file, run_info, output_write_run_info, output_config_key, output_write_obstacles
  use app_context, only: app_ctx
  use process_model, only: pm_energy_t
  use process_models, only: pm_list_output
  use step_settings, only: step_dt, step_t_end, step_max_steps, step_tolerances
  use failure_text, only: report_io_error
  implicit none
  private
  public :: write_run_info

contains

  !> The provenance of the run (/run in the output file): the time
  !> integration as used after the options, versions, date and host; the
  !> configuration as used (/config), file_name the file the run writes
  !> (the one a restart continues); and its obstacles (/obstacles).
  subroutine write_run_info(ctx, out, file_name, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(output_file), intent(inout) :: out
    character(len=*), intent(in) :: file_name
    PetscErrorCode, intent(out) :: ierr
    type(run_info) :: info
    type(tTSAdapt) :: adapt
    character(len=512) :: errmsg
    character(len=8) :: date
    character(len=10) :: clock
    character(len=5) :: zone
    integer :: hlen
    type(pm_energy_t) :: energy

    PetscCall(TSGetType(ctx%ts, info%ts_type, ierr))
    PetscCall(TSGetAdapt(ctx%ts, adapt, ierr))
    PetscCall(TSAdaptGetType(adapt, info%ts_adapt_type, ierr))
    PetscCall(PetscGetVersion(info%petsc_version, ierr))
    info%dt = step_dt(ctx%step)
    info%t_end = step_t_end(ctx%step)
    info%max_steps = int(min(step_max_steps(ctx%step), int(huge(1), kind(step_max_steps(ctx%step)))))
    call step_tolerances(ctx%step, info%rtol, info%atol_position, info%atol_velocity)
    info%units = ctx%cfg%scene%units
    ! the process models' series (headers: their values do not matter here)
    call pm_list_output(ctx%pms, info%pm_series, info%pm_groups, energy)
    ! Rank 0's host and clock, broadcast: attributes must be equal on all ranks.
    if (ctx%rank == 0) then
      PetscCall(PetscGetHostName(info%host, ierr))
      call date_and_time(date, clock, zone)
      info%start_date = date(1:4)//'-'//date(5:6)//'-'//date(7:8)//'T'//clock(1:2)//':'//clock(3:4)//':'// &
                        clock(5:6)//zone(1:3)//':'//zone(4:5)
    end if
    hlen = len(info%host)
    call MPI_Bcast(info%host, hlen, MPI_CHARACTER, 0, ctx%comm, ierr)
    hlen = len(info%start_date)
    call MPI_Bcast(info%start_date, hlen, MPI_CHARACTER, 0, ctx%comm, ierr)
    call output_write_run_info(out, info, ierr, errmsg)
    if (ierr == 0) call write_config(ctx%cfg, step_dt(ctx%step), step_t_end(ctx%step), file_name, ctx%comm, out, ierr, errmsg)
    ! the obstacles' surfaces and their sidecar (a scene with &contact; none: nothing)
    if (ierr == 0) call output_write_obstacles(out, ctx%cfg, ierr, errmsg)
    if (ierr /= 0) then
      call report_io_error(ctx, errmsg)
    end if
  end subroutine write_run_info

  !> The resolved configuration, /config/<group> with one attribute per key:
  !> every key after scene defaults, derived defaults and overrides, with
  !> dt and t_end as in force after -ts_dt and -ts_max_time [time] and
  !> file_name the file written (a restart's: the one it continues), so
  !> that a run can be repeated without knowing the defaults of the version
  !> that made it. Logicals are 0/1. Collective.
  subroutine write_config(cfg, dt, t_end, file_name, comm, out, ierr, errmsg)
    type(nuno_config), intent(in) :: cfg
    real(rp), intent(in) :: dt, t_end
    character(len=*), intent(in) :: file_name
    integer, intent(in) :: comm
    type(output_file), intent(inout) :: out
    PetscErrorCode, intent(out) :: ierr
    character(len=*), intent(inout) :: errmsg
    integer :: e

    e = 0
    call config_model(cfg, out, e, errmsg)
    call output_config_key(out, 'time', 't_end', [t_end], e, errmsg)
    call output_config_key(out, 'time', 'dt', [dt], e, errmsg)
    call output_config_key(out, 'output', 'output_interval', [cfg%output%output_interval], e, errmsg)
    call output_config_key(out, 'output', 'write_velocity', merge(1, 0, cfg%output%write_velocity), e, errmsg)
    call output_config_key(out, 'output', 'output_file', trim(file_name), e, errmsg)
    call output_config_key(out, 'output', 'petsc_options', trim(cfg%output%petsc_options), e, errmsg)
    call output_config_key(out, 'output', 'stretch_limit', [cfg%output%stretch_limit], e, errmsg)
    call output_config_key(out, 'output', 'checkpoint_interval', [cfg%output%checkpoint_interval], e, errmsg)
    if (cfg%identify%active) then
      ! /config/material holds the fitted values (those of the run written); the initial guess is /identify/initial.
      call output_config_key(out, 'identify', 'observed_file', trim(cfg%identify%observed_file), e, errmsg)
      call output_config_key(out, 'identify', 'fit', trim(cfg%identify%fit), e, errmsg)
      call output_config_key(out, 'identify', 'fit_lower', cfg%identify%fit_lower(1:cfg%identify%n_fit), e, errmsg)
      call output_config_key(out, 'identify', 'fit_upper', cfg%identify%fit_upper(1:cfg%identify%n_fit), e, errmsg)
      call output_config_key(out, 'identify', 'tikhonov', [cfg%identify%tikhonov], e, errmsg)
    end if
    if (cfg%control%active) then
      ! /config/scene holds the optimised keyframes (those of the run written); the initial guess is /control/initial_offset.
      call output_config_key(out, 'control', 'target_file', trim(cfg%control%target_file), e, errmsg)
      call output_config_key(out, 'control', 'components', trim(cfg%control%components), e, errmsg)
      if (cfg%control%max_speed /= unset_real) call output_config_key(out, 'control', 'max_speed', [cfg%control%max_speed], e, errmsg)
      call output_config_key(out, 'control', 'velocity_weight', [cfg%control%velocity_weight], e, errmsg)
      call output_config_key(out, 'control', 'keyframe_tikhonov', [cfg%control%keyframe_tikhonov], e, errmsg)
    end if
    if (cfg%contact%n_obstacles > 0) call config_contact(cfg, out, e, errmsg)
    if (cfg%contact%self_contact) call config_self_contact(cfg, out, e, errmsg)
    ! One error flag for all ranks (each call above is local HDF5 metadata).
    call MPI_Allreduce(MPI_IN_PLACE, e, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    ierr = e
    if (e /= 0 .and. len_trim(errmsg) == 0) errmsg = 'output: writing /config failed on another rank'
  end subroutine write_config

  !> /config's lattice, material and scene groups (write_config; e: the
  !> error flag, errmsg its message, both kept from the first error).
  subroutine config_model(cfg, out, e, errmsg)
    type(nuno_config), intent(in) :: cfg
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: e
    character(len=*), intent(inout) :: errmsg
    integer :: nk

    call output_config_key(out, 'lattice', 'nx', cfg%lattice%nx, e, errmsg)
    call output_config_key(out, 'lattice', 'ny', cfg%lattice%ny, e, errmsg)
    call output_config_key(out, 'lattice', 'lx', [cfg%lattice%lx], e, errmsg)
    call output_config_key(out, 'lattice', 'ly', [cfg%lattice%ly], e, errmsg)
    call output_config_key(out, 'lattice', 'total_mass', [cfg%lattice%total_mass], e, errmsg)
    call output_config_key(out, 'lattice', 'mass_distribution', trim(cfg%lattice%mass_distribution), e, errmsg)
    call output_config_key(out, 'lattice', 'lattice_scaling', trim(cfg%lattice%lattice_scaling), e, errmsg)
    call output_config_key(out, 'material', 'spring_model', trim(cfg%material%spring_model), e, errmsg)
    call output_config_key(out, 'material', 'e_s', [cfg%material%e_s], e, errmsg)
    call output_config_key(out, 'material', 'eta_s', [cfg%material%eta_s], e, errmsg)
    call output_config_key(out, 'material', 'e_d', [cfg%material%e_d], e, errmsg)
    call output_config_key(out, 'material', 'eta_d', [cfg%material%eta_d], e, errmsg)
    call output_config_key(out, 'material', 'bending_model', trim(cfg%material%bending_model), e, errmsg)
    call output_config_key(out, 'material', 'k_b', [cfg%material%k_b], e, errmsg)
    call output_config_key(out, 'material', 'eta_b', [cfg%material%eta_b], e, errmsg)
    call output_config_key(out, 'scene', 'scene', trim(cfg%scene%name), e, errmsg)
    call output_config_key(out, 'scene', 'gravity', cfg%scene%gravity, e, errmsg)
    call output_config_key(out, 'scene', 'lift_length', [cfg%scene%lift_length], e, errmsg)
    call output_config_key(out, 'scene', 'lift_height', [cfg%scene%lift_height], e, errmsg)
    call output_config_key(out, 'scene', 'bend_angle', [cfg%scene%bend_angle], e, errmsg)
    call output_config_key(out, 'scene', 'n_keyframes', cfg%scene%n_keyframes, e, errmsg)
    ! The keyframes in use only (n_keyframes of them; none: not written).
    nk = max(0, min(cfg%scene%n_keyframes, size(cfg%scene%keyframe_time)))
    if (nk > 0) then
      call output_config_key(out, 'scene', 'keyframe_time', cfg%scene%keyframe_time(1:nk), e, errmsg)
      call output_config_key(out, 'scene', 'keyframe_dx', cfg%scene%keyframe_dx(1:nk), e, errmsg)
      call output_config_key(out, 'scene', 'keyframe_dy', cfg%scene%keyframe_dy(1:nk), e, errmsg)
      call output_config_key(out, 'scene', 'keyframe_dz', cfg%scene%keyframe_dz(1:nk), e, errmsg)
    end if
    call output_config_key(out, 'scene', 'wave_nodes', trim(cfg%scene%wave_nodes), e, errmsg)
    call output_config_key(out, 'scene', 'release_time', [cfg%scene%release_time], e, errmsg)
    call output_config_key(out, 'scene', 'initial_omega', cfg%scene%initial_omega, e, errmsg)
    call output_config_key(out, 'scene', 'units', trim(cfg%scene%units), e, errmsg)
  end subroutine config_model

  !> /config's contact group (write_config; e, errmsg as there).
  subroutine config_contact(cfg, out, e, errmsg)
    type(nuno_config), intent(in) :: cfg
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: e
    character(len=*), intent(inout) :: errmsg
    integer :: k

    associate (c => cfg%contact, n => cfg%contact%n_obstacles)
      call output_config_key(out, 'contact', 'n_obstacles', n, e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_shape', contact_shapes(c%shape(1:n)), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_point', reshape(c%point(:, 1:n), [3 * n]), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_normal', reshape(c%normal(:, 1:n), [3 * n]), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_radius', c%radius(1:n), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_mu', c%mu(1:n), e, errmsg)
      call output_config_key(out, 'contact', 'contact_thickness', [c%thickness], e, errmsg)
      call output_config_key(out, 'contact', 'contact_dhat', [c%dhat], e, errmsg)
      call output_config_key(out, 'contact', 'contact_stiffness', [c%stiffness], e, errmsg)
      call output_config_key(out, 'contact', 'friction_eps_v', [c%eps_v], e, errmsg)
      call output_config_key(out, 'contact', 'contact_faces', merge(1, 0, c%faces), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_half_size', reshape(c%half_size(:, 1:n), [3 * n]), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_axis', reshape(c%axis(:, 1:n), [3 * n]), e, errmsg)
      call output_config_key(out, 'contact', 'obstacle_end', reshape(c%end_pt(:, 1:n), [3 * n]), e, errmsg)
      ! keyframes: the n_keyframes(k) in use of each obstacle, one after the other
      call output_config_key(out, 'contact', 'obstacle_n_keyframes', dble(c%n_keyframes(1:n)), e, errmsg)
      if (any(c%n_keyframes(1:n) > 0)) then
        call output_config_key(out, 'contact', 'obstacle_time', &
                               [(c%key_time(1:c%n_keyframes(k), k), k = 1, n)], e, errmsg)
        call output_config_key(out, 'contact', 'obstacle_offset', &
                               [(reshape(c%key_offset(:, 1:c%n_keyframes(k), k), [3 * c%n_keyframes(k)]), k = 1, n)], &
                               e, errmsg)
        call output_config_key(out, 'contact', 'obstacle_close', &
                               [(c%key_close(1:c%n_keyframes(k), k), k = 1, n)], e, errmsg)
        call output_config_key(out, 'contact', 'obstacle_close_dir', reshape(c%close_dir(:, 1:n), [3 * n]), e, errmsg)
      end if
    end associate
  end subroutine config_contact

  !> /config's contact group with self_contact on (write_config; e, errmsg
  !> as there): the key, and the barrier's keys where no obstacle wrote them.
  subroutine config_self_contact(cfg, out, e, errmsg)
    type(nuno_config), intent(in) :: cfg
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: e
    character(len=*), intent(inout) :: errmsg
    call output_config_key(out, 'contact', 'self_contact', 1, e, errmsg)
    call output_config_key(out, 'contact', 'self_step', trim(cfg%contact%self_step), e, errmsg)
    if (cfg%contact%n_obstacles > 0) return
    call output_config_key(out, 'contact', 'n_obstacles', 0, e, errmsg)
    call output_config_key(out, 'contact', 'contact_thickness', [cfg%contact%thickness], e, errmsg)
    call output_config_key(out, 'contact', 'contact_dhat', [cfg%contact%dhat], e, errmsg)
    call output_config_key(out, 'contact', 'contact_stiffness', [cfg%contact%stiffness], e, errmsg)
  end subroutine config_self_contact

  !> The obstacles' shapes (at least one) as one comma-separated string
  !> ('plane, sphere').
  function contact_shapes(shapes) result(t)
    character(*), intent(in) :: shapes(:)
    character(:), allocatable :: t
    integer :: k
    t = trim(shapes(1))
    do k = 2, size(shapes)
      t = t//', '//trim(shapes(k))
    end do
  end function contact_shapes

end module provenance
