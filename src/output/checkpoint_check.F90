! SPDX-License-Identifier: BSD-2-Clause
!> The checks a restart
!> (-nuno_restart) makes before it changes anything in the file it
!> continues (module output, output_reopen):
!>
!> - scene_refusal: the input's scene, lattice geometry and material (every
!>   model constant, /config/lattice, /config/material, /config/scene) must
!>   be the file's; a restart continues the motion the file began, so a
!>   namelist of another scene on the same lattice is refused by name;
!>   and the number of obstacles (/config/contact n_obstacles, none
!>   without that group): the /contact series and the checkpoint's contact
!>   diagnostics go on only with the obstacles they began with.
!> - checkpoint_refusal: the checkpoint it continues must be sound: finite
!>   time, step and state, a time within the file's series (at or after
!>   its last output step, before the next one), counters that are counts
!>   and not behind the series'. A corrupted checkpoint (a NaN time, a NaN
!>   state) otherwise ran on into a false 'complete' or relabelled a
!>   complete file 'failed'.
!>
!> Both only read; output_reopen refuses before it cuts the series, so a
!> refused restart leaves the file byte for byte as it was.
module checkpoint_check
  use hdf5
  use mpi
  use kinds, only: rp
  use config, only: nuno_config
  use checkpoint_record, only: checkpoint_t
  use strings, only: itoa, real_g0, real_list
  use output_h5, only: attr_text, open_dset, close_dset, dset_dims, select_spaces, close_spaces
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private
  public :: checkpoint_refusal, scene_refusal

contains

  !> Empty errmsg when the checkpoint ck (slot `where`, state strips x, v
  !> of this rank) is sound; otherwise ierr = 1 and one line saying what is
  !> wrong. Reads /time, /diagnostics and /config of file; every rank
  !> takes part (the state's check is reduced over comm). Collective.
  subroutine checkpoint_refusal(file, filename, where, ck, x, v, comm, ierr, errmsg)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: filename, where
    type(checkpoint_t), intent(in) :: ck
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    character(len=512) :: why, state

    ierr = 0
    errmsg = ''
    why = record_fault(ck)
    if (len_trim(why) == 0) why = series_fault(file, ck)
    state = state_fault(ck, x, v, comm)   ! collective: every rank, whatever why says
    if (len_trim(why) == 0) why = state
    if (len_trim(why) > 0) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': checkpoint '//where//' (sequence '//itoa(ck%sequence)// &
               ') is not valid: '//trim(why)//'; refused, the file is unchanged'
    end if
  end subroutine checkpoint_refusal

  !> What is wrong with the checkpoint's own values ('' when nothing):
  !> finite time and step, counters that are counts, the Newton start's
  !> values.
  character(len=512) function record_fault(ck) result(why)
    type(checkpoint_t), intent(in) :: ck
    real(rp) :: tol

    why = ''
    tol = 1.0e-9_rp * max(1.0_rp, abs(ck%time))
    if (.not. ieee_is_finite(ck%time) .or. ck%time < 0.0_rp) then
      why = 'its time is '//real_g0(ck%time)
    else if (.not. ieee_is_finite(ck%dt_next) .or. .not. ck%dt_next > 0.0_rp) then
      why = 'its next step dt_next is '//real_g0(ck%dt_next)
    else if (.not. ieee_is_finite(ck%t_written) .or. ck%t_written > ck%time + tol) then
      why = 'its last output time t_written = '//real_g0(ck%t_written)//' is not at or before its time '//real_g0(ck%time)
    else if (.not. all(ieee_is_finite(ck%counters)) .or. any(ck%counters < 0.0_rp) .or. &
             any(ck%counters /= aint(ck%counters)) .or. any(ck%counters > 2.0_rp**53)) then
      why = 'its counters ('//real_list(ck%counters)//') are not counts'
    else if (ck%time > 0.0_rp .and. ck%counters(1) < 1.0_rp) then
      why = 'it counts no step to t = '//real_g0(ck%time)
    else if (.not. ieee_is_finite(ck%wall_time) .or. ck%wall_time < 0.0_rp .or. &
             .not. ieee_is_finite(ck%dissipated) .or. .not. ieee_is_finite(ck%work_constraints) .or. &
             .not. ieee_is_finite(ck%mgx0)) then
      why = 'its wall time, dissipated energy, constraint work or mgx0 is not finite'
    else if (.not. ieee_is_finite(ck%start_nc_prev) .or. ck%start_nc_prev < 0.0_rp .or. &
             .not. ieee_is_finite(ck%newton_floor) .or. ck%newton_floor < 0.0_rp .or. &
             (ck%start_compare /= 0 .and. ck%start_compare /= 1)) then
      why = 'its Newton start or Newton floor values are not valid'
    else if (ck%start_count > 0) then
      if (.not. all(ieee_is_finite(ck%start_t(1:ck%start_count)))) then
        why = 'its Newton start times ('//real_list(ck%start_t(1:ck%start_count))//') are not finite'
      else if (ck%start_t(1) >= ck%time .or. any(ck%start_t(2:ck%start_count) >= ck%start_t(1:ck%start_count - 1))) then
        why = 'its Newton start times ('//real_list(ck%start_t(1:ck%start_count))//') are not before '//real_g0(ck%time)// &
              ' and decreasing'
      end if
    end if
  end function record_fault

  !> What is wrong with the checkpoint within the file's series ('' when
  !> nothing): its output steps are in the file, the last of them at
  !> t_written, its time before the next output step and not past the
  !> run's t_end, its counters not behind the series'.
  character(len=512) function series_fault(file, ck) result(why)
    integer(hid_t), intent(in) :: file
    type(checkpoint_t), intent(in) :: ck
    character(len=*), parameter :: names(4) = [character(len=20) :: 'steps', 'rejected_steps', &
                                                'newton_iterations', 'linear_iterations']
    real(rp) :: tw(1), interval(1), t_end(1), series(1), tol
    integer :: k, n_file, extent
    logical :: ok

    why = ''
    tol = 1.0e-9_rp * max(1.0_rp, abs(ck%time))
    call read_attr_int(file, '/', 'n_output_steps', n_file, ok)
    call series_extent(file, '/time', extent)
    if (.not. ok .or. ck%n_output_steps < 1 .or. ck%n_output_steps > n_file .or. ck%n_output_steps > extent) then
      why = 'it counts '//itoa(ck%n_output_steps)//' output steps, the file holds '//itoa(n_file)
      return
    end if
    call read_series_value(file, '/time', ck%n_output_steps, tw, ok)
    if (.not. ok .or. .not. (tw(1) == ck%t_written)) then
      why = 'its last output time t_written = '//real_g0(ck%t_written)//' is not the time of output step '// &
            itoa(ck%n_output_steps)//' in /time, '//real_g0(tw(1))
      return
    end if
    call read_attr_reals(file, '/config/output', 'output_interval', interval, ok)
    if (ok .and. interval(1) > 0.0_rp .and. ck%time > ck%t_written + interval(1) * (1.0_rp + 1.0e-9_rp) + tol) then
      why = 'its time '//real_g0(ck%time)//' is past the output step after t_written = '//real_g0(ck%t_written)// &
            ' (output_interval '//real_g0(interval(1))//')'
      return
    end if
    call read_attr_reals(file, '/config/time', 't_end', t_end, ok)
    if (ok .and. ck%time > t_end(1) + tol) then
      why = 'its time '//real_g0(ck%time)//' is past the t_end '//real_g0(t_end(1))//' of the run that wrote it'
      return
    end if
    do k = 1, 4
      call read_series_value(file, '/diagnostics/'//trim(names(k)), ck%n_output_steps, series, ok)
      if (ok .and. ck%counters(k) < series(1)) then
        why = 'its count of '//trim(names(k))//', '//real_g0(ck%counters(k))//', is below the file''s '// &
              real_g0(series(1))//' at its last output step'
        return
      end if
    end do
  end function series_fault

  !> What is wrong with the checkpoint's state ('' when nothing): finite on
  !> every rank's rows, the Newton start's states too. Collective.
  character(len=512) function state_fault(ck, x, v, comm) result(why)
    type(checkpoint_t), intent(in) :: ck
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    integer, intent(in) :: comm
    integer :: bad, mpierr

    why = ''
    bad = 0
    if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(v)))) bad = 1
    if (allocated(ck%start_x)) then
      if (.not. all(ieee_is_finite(ck%start_x))) bad = max(bad, 2)
    end if
    if (allocated(ck%start_v)) then
      if (.not. all(ieee_is_finite(ck%start_v))) bad = max(bad, 2)
    end if
    call MPI_Allreduce(MPI_IN_PLACE, bad, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    if (bad == 1) why = 'its state (position or velocity) is not finite'
    if (bad == 2) why = 'a Newton start state in it is not finite'
  end function state_fault

  !> Empty errmsg when the scene, lattice geometry and material of cfg are
  !> those of the file's /config (as written by the run that made it);
  !> otherwise ierr = 1 and one line naming the first key that differs.
  !> Exact comparison: the same namelist gives the same doubles. Every
  !> rank reads alike (no communication).
  subroutine scene_refusal(file, filename, cfg, ierr, errmsg)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: filename
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    character(len=:), allocatable :: why
    integer :: nk

    why = ''
    call str_key(file, 'lattice', 'mass_distribution', cfg%lattice%mass_distribution, why)
    call str_key(file, 'lattice', 'lattice_scaling', cfg%lattice%lattice_scaling, why)
    call real_key(file, 'lattice', 'lx', [cfg%lattice%lx], why)
    call real_key(file, 'lattice', 'ly', [cfg%lattice%ly], why)
    call real_key(file, 'lattice', 'total_mass', [cfg%lattice%total_mass], why)
    call str_key(file, 'material', 'spring_model', cfg%material%spring_model, why)
    call real_key(file, 'material', 'e_s', [cfg%material%e_s], why)
    call real_key(file, 'material', 'eta_s', [cfg%material%eta_s], why)
    call real_key(file, 'material', 'e_d', [cfg%material%e_d], why)
    call real_key(file, 'material', 'eta_d', [cfg%material%eta_d], why)
    call str_key(file, 'material', 'bending_model', cfg%material%bending_model, why)
    call real_key(file, 'material', 'k_b', [cfg%material%k_b], why)
    call real_key(file, 'material', 'eta_b', [cfg%material%eta_b], why)
    call str_key(file, 'scene', 'scene', cfg%scene%name, why)
    call real_key(file, 'scene', 'gravity', cfg%scene%gravity, why)
    call real_key(file, 'scene', 'lift_length', [cfg%scene%lift_length], why)
    call real_key(file, 'scene', 'lift_height', [cfg%scene%lift_height], why)
    call real_key(file, 'scene', 'bend_angle', [cfg%scene%bend_angle], why)
    call real_key(file, 'scene', 'n_keyframes', [real(cfg%scene%n_keyframes, rp)], why)
    nk = max(0, min(cfg%scene%n_keyframes, size(cfg%scene%keyframe_time)))
    if (nk > 0) then
      call real_key(file, 'scene', 'keyframe_time', cfg%scene%keyframe_time(1:nk), why)
      call real_key(file, 'scene', 'keyframe_dx', cfg%scene%keyframe_dx(1:nk), why)
      call real_key(file, 'scene', 'keyframe_dy', cfg%scene%keyframe_dy(1:nk), why)
      call real_key(file, 'scene', 'keyframe_dz', cfg%scene%keyframe_dz(1:nk), why)
    end if
    call str_key(file, 'scene', 'wave_nodes', cfg%scene%wave_nodes, why)
    call real_key(file, 'scene', 'release_time', [cfg%scene%release_time], why)
    call real_key(file, 'scene', 'initial_omega', cfg%scene%initial_omega, why)
    call obstacle_count(file, cfg%contact%n_obstacles, why)
    ierr = merge(1, 0, len(why) > 0)
    errmsg = ''
    if (ierr /= 0) errmsg = '-nuno_restart '//filename//': '//why
  end subroutine scene_refusal

  ! ---------------------------------------------------------------------------
  ! scene_refusal's keys: each does nothing once why says what differs.

  !> A real key of /config/<group>: the values mine (as many).
  subroutine real_key(file, group, key, mine, why)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: mine(:)
    character(len=:), allocatable, intent(inout) :: why
    real(rp), allocatable :: theirs(:)
    logical :: ok, same

    if (len(why) > 0) return
    call read_attr_any(file, '/config/'//group, key, theirs, ok)
    same = .false.
    if (ok .and. size(theirs) == size(mine)) same = all(theirs == mine)
    call judge_key(group, key, ok, same, real_list(mine), real_list(theirs), why)
  end subroutine real_key

  !> A string key of /config/<group>: mine (trailing blanks aside).
  subroutine str_key(file, group, key, mine, why)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, key, mine
    character(len=:), allocatable, intent(inout) :: why
    character(len=256) :: theirs
    logical :: ok

    if (len(why) > 0) return
    call read_attr_str(file, '/config/'//group, key, theirs, ok)
    call judge_key(group, key, ok, trim(theirs) == trim(mine), "'"//trim(mine)//"'", "'"//trim(theirs)//"'", why)
  end subroutine str_key

  !> The file's obstacles: /config/contact n_obstacles, written by runs
  !> with obstacles only (none: 0). A restart with another count would
  !> write the /contact series of other obstacles, or none, after them.
  subroutine obstacle_count(file, mine, why)
    integer(hid_t), intent(in) :: file
    integer, intent(in) :: mine
    character(len=:), allocatable, intent(inout) :: why
    real(rp), allocatable :: theirs(:)
    logical :: exists, found
    integer :: h, n

    if (len(why) > 0) return
    call h5lexists_f(file, '/config/contact', exists, h)
    found = h >= 0
    n = 0
    if (found .and. exists) then
      call read_attr_any(file, '/config/contact', 'n_obstacles', theirs, found)
      found = found .and. size(theirs) == 1
      if (found) n = nint(theirs(1))
    end if
    call judge_key('contact', 'n_obstacles', found, n == mine, itoa(mine), itoa(n), why)
  end subroutine obstacle_count

  !> why for the key `key` of /config/<group>: the file lacks it (not
  !> found), or its value (theirs) is not the input's (mine); unchanged when same.
  subroutine judge_key(group, key, found, same, mine, theirs, why)
    character(*), intent(in) :: group, key, mine, theirs
    logical, intent(in) :: found, same
    character(len=:), allocatable, intent(inout) :: why

    if (.not. found) then
      why = 'the file has no /config/'//group//' '//key//': cannot check that the input''s scene and model are the file''s'
    else if (.not. same) then
      why = 'the input''s &'//group//' '//key//' = '//mine//' is not the file''s '//theirs// &
            ' (a restart continues the scene and model the file was made with)'
    end if
  end subroutine judge_key

  ! ---------------------------------------------------------------------------
  ! Reading helpers (every return code checked; a failure is ok = .false.)

  !> The attribute `name` of the object `group` of file, opened (attr, to
  !> be closed by the caller) with the class of its type (cls); ok =
  !> .false. (nothing open) when it is not there or a call failed.
  subroutine open_attr(file, group, name, attr, cls, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, name
    integer(hid_t), intent(out) :: attr
    integer, intent(out) :: cls
    logical, intent(out) :: ok
    integer(hid_t) :: ftype
    integer :: h, e
    logical :: exists

    ok = .false.
    attr = -1
    cls = -1
    call h5aexists_by_name_f(file, group, name, exists, h)
    if (h < 0 .or. .not. exists) return
    call h5aopen_by_name_f(file, group, name, attr, h)
    if (h < 0) return
    call h5aget_type_f(attr, ftype, h)
    if (h >= 0) then
      call h5tget_class_f(ftype, cls, h)
      call h5tclose_f(ftype, e)
    end if
    ok = h >= 0
    if (.not. ok) call h5aclose_f(attr, e)
  end subroutine open_attr

  !> A numeric attribute of any shape and numeric type, as doubles.
  subroutine read_attr_any(file, group, name, values, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, name
    real(rp), allocatable, intent(out) :: values(:)
    logical, intent(out) :: ok
    integer(hid_t) :: attr, space
    integer(hsize_t) :: npts
    integer :: h, e, cls

    allocate(values(0))
    call open_attr(file, group, name, attr, cls, ok)
    if (.not. ok) return
    ok = cls == H5T_FLOAT_F .or. cls == H5T_INTEGER_F
    if (ok) then
      call h5aget_space_f(attr, space, h)
      ok = h >= 0
    end if
    if (ok) then
      call h5sget_simple_extent_npoints_f(space, npts, h)
      call h5sclose_f(space, e)
      ok = h >= 0
    end if
    if (ok) then
      deallocate(values)
      allocate(values(npts))
      call h5aread_f(attr, H5T_NATIVE_DOUBLE, values, [npts], h)
      ok = h >= 0
    end if
    call h5aclose_f(attr, e)
  end subroutine read_attr_any

  subroutine read_attr_reals(file, group, name, values, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, name
    real(rp), intent(out) :: values(:)
    logical, intent(out) :: ok
    real(rp), allocatable :: all(:)
    values = 0
    call read_attr_any(file, group, name, all, ok)
    ok = ok .and. size(all) == size(values)
    if (ok) values = all
  end subroutine read_attr_reals

  subroutine read_attr_int(file, group, name, value, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, name
    integer, intent(out) :: value
    logical, intent(out) :: ok
    real(rp) :: r(1)
    call read_attr_reals(file, group, name, r, ok)
    value = -1
    if (ok) value = nint(r(1))
  end subroutine read_attr_int

  !> A fixed-length string attribute (cut at a NUL).
  subroutine read_attr_str(file, group, name, value, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, name
    character(*), intent(out) :: value
    logical, intent(out) :: ok
    integer(hid_t) :: attr
    integer :: h, e, cls
    character(len=:), allocatable :: text

    value = ''
    call open_attr(file, group, name, attr, cls, ok)
    if (.not. ok) return
    ok = cls == H5T_STRING_F
    if (ok) then
      call attr_text(attr, text, h)
      value = text
      ok = h >= 0 .and. len(text) <= len(value)
    end if
    call h5aclose_f(attr, e)
  end subroutine read_attr_str

  !> The extent of the last (time) dimension of a series (0 when absent).
  subroutine series_extent(file, path, extent)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: path
    integer, intent(out) :: extent
    integer(hid_t) :: dset
    integer(hsize_t) :: dims(4)
    integer :: r, e
    character(len=256) :: msg

    extent = 0
    e = 0
    call open_dset(file, path, dset, e, msg)
    call dset_dims(dset, path, r, dims, e, msg)
    if (e == 0) extent = int(dims(r))
    call close_dset(dset, path, e, msg)
  end subroutine series_extent

  !> Element k (1-based) of a one-dimensional series, as a double.
  subroutine read_series_value(file, path, k, value, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: path
    integer, intent(in) :: k
    real(rp), intent(out) :: value(1)
    logical, intent(out) :: ok
    integer(hid_t) :: dset, fspace, mspace
    integer :: h, e
    character(len=256) :: msg

    value = 0
    e = 0
    fspace = -1
    mspace = -1
    call open_dset(file, path, dset, e, msg)
    if (e == 0) call select_spaces(dset, path, [int(k - 1, hsize_t)], [1_hsize_t], .false., fspace, mspace, e, msg)
    if (e == 0) then
      call h5dread_f(dset, H5T_NATIVE_DOUBLE, value, [1_hsize_t], h, mem_space_id=mspace, file_space_id=fspace)
      if (h < 0) e = 1
    end if
    ok = e == 0
    call close_spaces(fspace, mspace, path, e, msg)
    call close_dset(dset, path, e, msg)
  end subroutine read_series_value

end module checkpoint_check
