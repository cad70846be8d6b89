! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the result groups /run, /config, /identify and /control.
submodule (output) output_results
  implicit none

contains

  !> The group /run (provenance: versions, git commit, solver as used, date,
  !> host), the root attribute units (and each dataset's), the /wall_time
  !> series and the process models' (info%pm_series). Call once,
  !> after output_open and before the first output_write_step. Collective.
  module procedure output_write_run_info
    ! git_commit: the build's commit (cmake/git_commit.cmake, rewritten at every build)
    include 'nuno_git_commit.inc'
    integer(hid_t) :: grp
    integer :: h, major, minor, release
    character(len=32) :: hdf5_version
    character(len=:), allocatable :: where

    call require_open(out, 'output_write_run_info', ierr, errmsg)
    if (ierr /= 0) return
    if (out%series%nt /= 0 .and. .not. out%ckpt%reopened) then
      ierr = 1
      errmsg = 'output_write_run_info: must come before the first output step (/wall_time)'
    end if
    ! The library actually linked, not the headers compiled against.
    if (ierr == 0) then
      call h5get_libversion_f(major, minor, release, h)
      if (h < 0) call fail('h5get_libversion_f', '/run', ierr, errmsg)
      write(hdf5_version, '(i0,a,i0,a,i0)') major, '.', minor, '.', release
    end if
    call set_attr_str(out%file, 'units', trim(info%units), '/', ierr, errmsg)
    ! A continued run (output_reopen) keeps the first run's /run and
    ! describes itself in /run/restart_<k>.
    if (out%ckpt%reopened) then
      where = '/run/restart_'//itoa(out%ckpt%restarts)
    else
      where = '/run'
    end if
    if (ierr == 0) then
      call open_or_create_group(out%file, where, grp, ierr, errmsg)
      call set_attr_str(grp, 'git_commit', git_commit, where, ierr, errmsg)
      call set_attr_str(grp, 'petsc_version', trim(info%petsc_version), where, ierr, errmsg)
      call set_attr_str(grp, 'hdf5_version', trim(hdf5_version), where, ierr, errmsg)
      call set_attr_str(grp, 'ts_type', trim(info%ts_type), where, ierr, errmsg)
      call set_attr_str(grp, 'ts_adapt_type', trim(info%ts_adapt_type), where, ierr, errmsg)
      call set_attr_reals(grp, 'dt', [info%dt], where, ierr, errmsg)
      call set_attr_reals(grp, 't_end', [info%t_end], where, ierr, errmsg)
      call set_attr_int(grp, 'max_steps', info%max_steps, where, ierr, errmsg)
      call set_attr_reals(grp, 'rtol', [info%rtol], where, ierr, errmsg)
      call set_attr_reals(grp, 'atol_position', [info%atol_position], where, ierr, errmsg)
      call set_attr_reals(grp, 'atol_velocity', [info%atol_velocity], where, ierr, errmsg)
      call set_attr_str(grp, 'start_date', trim(info%start_date), where, ierr, errmsg)
      call set_attr_str(grp, 'host', trim(info%host), where, ierr, errmsg)
      call set_attr_int(grp, 'n_ranks', out%n_ranks, where, ierr, errmsg)
      call close_group(grp, where, ierr, errmsg)
    end if
    if (ierr == 0 .and. out%series%dset(d_wall_time) < 0) &
      call create_series(out, d_wall_time, ierr, errmsg)
    ! the process models' series (contact's /energy/barrier and /contact:
    ! scenes with obstacles only)
    if (allocated(info%pm_series) .and. allocated(info%pm_groups)) then
      call pm_series_register(out, info%pm_series, info%pm_groups, ierr, errmsg)
    end if
    ! /wall_time's axis, and those of a file continued from an earlier version.
    call netcdf_dims(out, ierr, errmsg)
    call write_units(out, trim(info%units), ierr, errmsg)
    if (ierr == 0) then
      call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
      if (h < 0) call fail('h5fflush_f', '/', ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_run_info', ierr, errmsg)
  end procedure output_write_run_info

  !> /identify of an identification run (docs/identification.md): names
  !> [np] (strings), values, uncertainty, initial [np], objective (scalar),
  !> history [n_iterations][np+1] (objective, then the values, per TAO
  !> iteration). Small datasets: every rank writes the same values. Collective.
  module procedure output_write_identify
    integer(hid_t) :: grp, strtype, space, dset
    integer :: h

    ierr = 0
    errmsg = ''
    call open_or_create_group(out%file, '/identify', grp, ierr, errmsg)
    if (ierr /= 0) goto 900
    call put_doubles(grp, '/identify', 'values', values, [int(size(values), hsize_t)], ierr, errmsg)
    call put_doubles(grp, '/identify', 'uncertainty', unc, [int(size(unc), hsize_t)], ierr, errmsg)
    call put_doubles(grp, '/identify', 'initial', initial, [int(size(initial), hsize_t)], ierr, errmsg)
    call put_doubles(grp, '/identify', 'objective', [objective], [1_hsize_t], ierr, errmsg)
    call put_doubles(grp, '/identify', 'history', reshape(hist, [size(hist)]), &
                     [int(size(hist, 1), hsize_t), int(size(hist, 2), hsize_t)], ierr, errmsg)
    call new_space([int(size(names), hsize_t)], '/identify/names', space, ierr, errmsg)
    if (ierr == 0) then
      call h5tcopy_f(H5T_FORTRAN_S1, strtype, h)
      call h5tset_size_f(strtype, int(len(names), size_t), h)
      call h5dcreate_f(grp, 'names', strtype, space, dset, h)
      if (h < 0) then
        call fail('h5dcreate_f', '/identify/names', ierr, errmsg)
      else
        call h5dwrite_f(dset, strtype, names, [int(size(names), hsize_t)], h)
        if (h < 0) call fail('h5dwrite_f', '/identify/names', ierr, errmsg)
        call h5dclose_f(dset, h)
      end if
      call h5sclose_f(space, h)
      call h5tclose_f(strtype, h)
    end if
    call close_and_flush(out, grp, '/identify', ierr, errmsg)
900 call agree(out%comm, 'output_write_identify', ierr, errmsg)
  end procedure output_write_identify

  !> /control of a deformation-control run (docs/identification.md):
  !> keyframe_time [nk], keyframe_offset and initial_offset [nk][3] (the
  !> optimised and the initial offsets of the driven nodes from rest),
  !> objective [1] (at the optimum), objective_history [nit] and
  !> keyframe_history [nit][nk][3] (per TAO iteration), max_speed [1] (the
  !> bound; +Infinity: none), attribute components. Small datasets: every
  !> rank writes the same values. Collective.
  module procedure output_write_control
    integer(hid_t) :: grp
    integer(hsize_t) :: nk, nit

    ierr = 0
    errmsg = ''
    nk = int(size(times), hsize_t)
    nit = int(size(objective_hist), hsize_t)
    call open_or_create_group(out%file, '/control', grp, ierr, errmsg)
    if (ierr /= 0) goto 900
    call put_doubles(grp, '/control', 'keyframe_time', times, [nk], ierr, errmsg)
    call put_doubles(grp, '/control', 'keyframe_offset', reshape(offsets, [size(offsets)]), [3_hsize_t, nk], &
                     ierr, errmsg)
    call put_doubles(grp, '/control', 'initial_offset', reshape(initial, [size(initial)]), [3_hsize_t, nk], &
                     ierr, errmsg)
    call put_doubles(grp, '/control', 'objective', [objective], [1_hsize_t], ierr, errmsg)
    call put_doubles(grp, '/control', 'objective_history', objective_hist, [nit], ierr, errmsg)
    call put_doubles(grp, '/control', 'keyframe_history', reshape(offset_hist, [size(offset_hist)]), &
                     [3_hsize_t, nk, nit], ierr, errmsg)
    call put_doubles(grp, '/control', 'max_speed', [max_speed], [1_hsize_t], ierr, errmsg)
    call set_attr_str(grp, 'components', trim(components), '/control', ierr, errmsg)
    call close_and_flush(out, grp, '/control', ierr, errmsg)
900 call agree(out%comm, 'output_write_control', ierr, errmsg)
  end procedure output_write_control

  !> Close the group grp (at gpath, for messages) and flush the file, so
  !> that what was written survives a later failure.
  subroutine close_and_flush(out, grp, gpath, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: gpath
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5gclose_f(grp, h)
    if (ierr /= 0) return
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', gpath, ierr, errmsg)
  end subroutine close_and_flush

  !> /config/<group>, created on first use; grp must be closed by the caller.
  subroutine config_group(out, group, grp, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: group
    integer(hid_t), intent(out) :: grp
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: top

    grp = -1
    if (ierr /= 0) return
    call require_open(out, 'output_config_key', ierr, errmsg)
    if (ierr /= 0) return
    call open_or_create_group(out%file, '/config', top, ierr, errmsg)
    if (ierr /= 0) return
    call open_or_create_group(out%file, '/config/'//group, grp, ierr, errmsg)
    call close_group(top, '/config', ierr, errmsg)
  end subroutine config_group

  !> A string key of /config/<group>. Collective (same values on all ranks);
  !> keeps the first error in ierr/errmsg, so that calls can be chained.
  module procedure config_key_str
    integer(hid_t) :: grp
    call config_group(out, group, grp, ierr, errmsg)
    call set_attr_str(grp, key, value, '/config/'//group, ierr, errmsg)
    call close_group(grp, '/config/'//group, ierr, errmsg)
  end procedure config_key_str

  module procedure config_key_int
    integer(hid_t) :: grp
    call config_group(out, group, grp, ierr, errmsg)
    call set_attr_int(grp, key, value, '/config/'//group, ierr, errmsg)
    call close_group(grp, '/config/'//group, ierr, errmsg)
  end procedure config_key_int

  !> A real key (one value: a scalar attribute; several: a 1-D one).
  module procedure config_key_reals
    integer(hid_t) :: grp

    call config_group(out, group, grp, ierr, errmsg)
    call set_attr_reals(grp, key, values, '/config/'//group, ierr, errmsg)
    call close_group(grp, '/config/'//group, ierr, errmsg)
  end procedure config_key_reals

  !> The attribute /run/wall_time [s], the wall time of the whole run; the
  !> same value on every rank (attributes are collective). Collective.
  module procedure output_write_wall_time
    integer(hid_t) :: grp
    integer :: h

    call require_open(out, 'output_write_wall_time', ierr, errmsg)
    if (ierr /= 0) return
    call h5gopen_f(out%file, 'run', grp, h)
    if (h < 0) then
      call fail('h5gopen_f (output_write_run_info first)', '/run', ierr, errmsg)
    else
      call set_attr_reals(grp, 'wall_time', [seconds], '/run', ierr, errmsg)
      call h5gclose_f(grp, h)
      if (h < 0) call fail('h5gclose_f', '/run', ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_wall_time', ierr, errmsg)
  end procedure output_write_wall_time

  !> The attribute /run/retried_steps: the steps the run rejected and
  !> retried with a smaller step (a failed Newton solve, a stage outside
  !> the domain, the error control), since t = 0 (a restart's included);
  !> with fixed steps, each is a step that was not dt (input/README.md,
  !> "Retried steps"). Written at the end of the run. Collective.
  module procedure output_write_retried_steps
    integer(hid_t) :: grp
    integer :: h

    call require_open(out, 'output_write_retried_steps', ierr, errmsg)
    if (ierr /= 0) return
    call h5gopen_f(out%file, 'run', grp, h)
    if (h < 0) then
      call fail('h5gopen_f (output_write_run_info first)', '/run', ierr, errmsg)
    else
      call set_attr_int(grp, 'retried_steps', steps, '/run', ierr, errmsg)
      call h5gclose_f(grp, h)
      if (h < 0) call fail('h5gclose_f', '/run', ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_retried_steps', ierr, errmsg)
  end procedure output_write_retried_steps

end submodule output_results
