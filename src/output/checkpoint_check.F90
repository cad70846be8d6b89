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
    character(len=*), parameter :: names(4) = [character(len=20) :: 'steps', 'rejected_steps', &
                                                'newton_iterations', 'linear_iterations']
    character(len=512) :: why
    real(rp) :: tw(1), interval(1), t_end(1), series(1), tol
    integer :: k, n_file, extent, bad, mpierr
    logical :: ok

    ierr = 0
    errmsg = ''
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
    ! Within the file's series: its output steps are in the file, the last
    ! of them at t_written, and its time before the next output step.
    if (len_trim(why) == 0) then
      call read_attr_int(file, '/', 'n_output_steps', n_file, ok)
      call series_extent(file, '/time', extent)
      if (.not. ok .or. ck%n_output_steps < 1 .or. ck%n_output_steps > n_file .or. ck%n_output_steps > extent) then
        why = 'it counts '//itoa(ck%n_output_steps)//' output steps, the file holds '//itoa(n_file)
      else
        call read_series_value(file, '/time', ck%n_output_steps, tw, ok)
        if (.not. ok .or. .not. (tw(1) == ck%t_written)) then
          why = 'its last output time t_written = '//real_g0(ck%t_written)//' is not the time of output step '// &
                itoa(ck%n_output_steps)//' in /time, '//real_g0(tw(1))
        end if
      end if
    end if
    if (len_trim(why) == 0) then
      call read_attr_reals(file, '/config/output', 'output_interval', interval, ok)
      if (ok .and. interval(1) > 0.0_rp .and. ck%time > ck%t_written + interval(1) * (1.0_rp + 1.0e-9_rp) + tol) &
        why = 'its time '//real_g0(ck%time)//' is past the output step after t_written = '//real_g0(ck%t_written)// &
              ' (output_interval '//real_g0(interval(1))//')'
    end if
    if (len_trim(why) == 0) then
      call read_attr_reals(file, '/config/time', 't_end', t_end, ok)
      if (ok .and. ck%time > t_end(1) + tol) &
        why = 'its time '//real_g0(ck%time)//' is past the t_end '//real_g0(t_end(1))//' of the run that wrote it'
    end if
    if (len_trim(why) == 0) then
      do k = 1, 4
        call read_series_value(file, '/diagnostics/'//trim(names(k)), ck%n_output_steps, series, ok)
        if (ok .and. ck%counters(k) < series(1)) then
          why = 'its count of '//trim(names(k))//', '//real_g0(ck%counters(k))//', is below the file''s '// &
                real_g0(series(1))//' at its last output step'
          exit
        end if
      end do
    end if
    ! The state: finite on every rank's rows.
    bad = 0
    if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(v)))) bad = 1
    if (allocated(ck%start_x)) then
      if (.not. all(ieee_is_finite(ck%start_x))) bad = max(bad, 2)
    end if
    if (allocated(ck%start_v)) then
      if (.not. all(ieee_is_finite(ck%start_v))) bad = max(bad, 2)
    end if
    call MPI_Allreduce(MPI_IN_PLACE, bad, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    if (len_trim(why) == 0 .and. bad == 1) why = 'its state (position or velocity) is not finite'
    if (len_trim(why) == 0 .and. bad == 2) why = 'a Newton start state in it is not finite'
    if (len_trim(why) > 0) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': checkpoint '//where//' (sequence '//itoa(ck%sequence)// &
               ') is not valid: '//trim(why)//'; refused, the file is unchanged'
    end if
  end subroutine checkpoint_refusal

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
    integer :: nk

    ierr = 0
    errmsg = ''
    call str_key('lattice', 'mass_distribution', cfg%lattice%mass_distribution)
    call str_key('lattice', 'lattice_scaling', cfg%lattice%lattice_scaling)
    call real_key('lattice', 'lx', [cfg%lattice%lx])
    call real_key('lattice', 'ly', [cfg%lattice%ly])
    call real_key('lattice', 'total_mass', [cfg%lattice%total_mass])
    call str_key('material', 'spring_model', cfg%material%spring_model)
    call real_key('material', 'e_s', [cfg%material%e_s])
    call real_key('material', 'eta_s', [cfg%material%eta_s])
    call real_key('material', 'e_d', [cfg%material%e_d])
    call real_key('material', 'eta_d', [cfg%material%eta_d])
    call str_key('material', 'bending_model', cfg%material%bending_model)
    call real_key('material', 'k_b', [cfg%material%k_b])
    call real_key('material', 'eta_b', [cfg%material%eta_b])
    call str_key('scene', 'scene', cfg%scene%name)
    call real_key('scene', 'gravity', cfg%scene%gravity)
    call real_key('scene', 'lift_length', [cfg%scene%lift_length])
    call real_key('scene', 'lift_height', [cfg%scene%lift_height])
    call real_key('scene', 'bend_angle', [cfg%scene%bend_angle])
    call real_key('scene', 'n_keyframes', [real(cfg%scene%n_keyframes, rp)])
    nk = max(0, min(cfg%scene%n_keyframes, size(cfg%scene%keyframe_time)))
    if (nk > 0) then
      call real_key('scene', 'keyframe_time', cfg%scene%keyframe_time(1:nk))
      call real_key('scene', 'keyframe_dx', cfg%scene%keyframe_dx(1:nk))
      call real_key('scene', 'keyframe_dy', cfg%scene%keyframe_dy(1:nk))
      call real_key('scene', 'keyframe_dz', cfg%scene%keyframe_dz(1:nk))
    end if
    call str_key('scene', 'wave_nodes', cfg%scene%wave_nodes)
    call real_key('scene', 'release_time', [cfg%scene%release_time])
    call real_key('scene', 'initial_omega', cfg%scene%initial_omega)
    call obstacle_count(cfg%contact%n_obstacles)
  contains
    !> The file's obstacles: /config/contact n_obstacles, written by runs
    !> with obstacles only (none: 0). A restart with another count would
    !> write the /contact series of other obstacles, or none, after them.
    subroutine obstacle_count(mine)
      integer, intent(in) :: mine
      real(rp), allocatable :: theirs(:)
      logical :: exists, ok
      integer :: h, n
      if (ierr /= 0) return
      call h5lexists_f(file, '/config/contact', exists, h)
      if (h < 0) then
        call missing('contact', 'n_obstacles')
        return
      end if
      n = 0
      if (exists) then
        call read_attr_any(file, '/config/contact', 'n_obstacles', theirs, ok)
        if (.not. ok .or. size(theirs) /= 1) then
          call missing('contact', 'n_obstacles')
          return
        end if
        n = nint(theirs(1))
      end if
      if (n /= mine) call differs('contact', 'n_obstacles', itoa(mine), itoa(n))
    end subroutine obstacle_count

    subroutine real_key(group, key, mine)
      character(*), intent(in) :: group, key
      real(rp), intent(in) :: mine(:)
      real(rp), allocatable :: theirs(:)
      logical :: ok
      if (ierr /= 0) return
      call read_attr_any(file, '/config/'//group, key, theirs, ok)
      if (.not. ok) then
        call missing(group, key)
      else if (size(theirs) /= size(mine)) then
        call differs(group, key, real_list(mine), real_list(theirs))
      else if (any(theirs /= mine)) then
        call differs(group, key, real_list(mine), real_list(theirs))
      end if
    end subroutine real_key
    subroutine str_key(group, key, mine)
      character(*), intent(in) :: group, key, mine
      character(len=256) :: theirs
      logical :: ok
      if (ierr /= 0) return
      call read_attr_str(file, '/config/'//group, key, theirs, ok)
      if (.not. ok) then
        call missing(group, key)
      else if (trim(theirs) /= trim(mine)) then
        call differs(group, key, "'"//trim(mine)//"'", "'"//trim(theirs)//"'")
      end if
    end subroutine str_key
    subroutine differs(group, key, mine, theirs)
      character(*), intent(in) :: group, key, mine, theirs
      ierr = 1
      errmsg = '-nuno_restart '//filename//': the input''s &'//group//' '//key//' = '//mine// &
               ' is not the file''s '//theirs//' (a restart continues the scene and model the file was made with)'
    end subroutine differs
    subroutine missing(group, key)
      character(*), intent(in) :: group, key
      ierr = 1
      errmsg = '-nuno_restart '//filename//': the file has no /config/'//group//' '//key// &
               ': cannot check that the input''s scene and model are the file''s'
    end subroutine missing
  end subroutine scene_refusal

  ! ---------------------------------------------------------------------------
  ! Reading helpers (every return code checked; a failure is ok = .false.)

  !> A numeric attribute of any shape and numeric type, as doubles.
  subroutine read_attr_any(file, group, name, values, ok)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: group, name
    real(rp), allocatable, intent(out) :: values(:)
    logical, intent(out) :: ok
    integer(hid_t) :: attr, space, ftype
    integer(hsize_t) :: npts
    integer :: h, e, cls
    logical :: exists

    ok = .false.
    allocate(values(0))
    call h5aexists_by_name_f(file, group, name, exists, h)
    if (h < 0 .or. .not. exists) return
    call h5aopen_by_name_f(file, group, name, attr, h)
    if (h < 0) return
    call h5aget_type_f(attr, ftype, h)
    if (h >= 0) then
      call h5tget_class_f(ftype, cls, h)
      call h5tclose_f(ftype, e)
    end if
    if (h >= 0 .and. (cls == H5T_FLOAT_F .or. cls == H5T_INTEGER_F)) then
      call h5aget_space_f(attr, space, h)
      if (h >= 0) then
        call h5sget_simple_extent_npoints_f(space, npts, h)
        call h5sclose_f(space, e)
      end if
      if (h >= 0) then
        deallocate(values)
        allocate(values(npts))
        call h5aread_f(attr, H5T_NATIVE_DOUBLE, values, [npts], h)
        ok = h >= 0
      end if
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
    integer(hid_t) :: attr, ftype, mtype
    integer(size_t) :: n
    integer :: h, e, k, cls
    logical :: exists
    character(len=:), allocatable :: buf

    ok = .false.
    value = ''
    call h5aexists_by_name_f(file, group, name, exists, h)
    if (h < 0 .or. .not. exists) return
    call h5aopen_by_name_f(file, group, name, attr, h)
    if (h < 0) return
    call h5aget_type_f(attr, ftype, h)
    if (h >= 0) call h5tget_class_f(ftype, cls, h)
    if (h >= 0 .and. cls == H5T_STRING_F) then
      call h5tget_size_f(ftype, n, h)
      if (h >= 0) then
        allocate(character(len=n) :: buf)
        call h5tcopy_f(H5T_NATIVE_CHARACTER, mtype, h)
        if (h >= 0) call h5tset_size_f(mtype, n, h)
        if (h >= 0) call h5aread_f(attr, mtype, buf, [1_hsize_t], h)
        call h5tclose_f(mtype, e)
        if (h >= 0) then
          k = index(buf, achar(0))
          if (k > 0) buf = buf(1:k - 1)
          value = buf
          ok = len(buf) <= len(value)
        end if
      end if
    end if
    call h5tclose_f(ftype, e)
    call h5aclose_f(attr, e)
  end subroutine read_attr_str

  !> The extent of the last (time) dimension of a series (0 when absent).
  subroutine series_extent(file, path, extent)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: path
    integer, intent(out) :: extent
    integer(hid_t) :: dset, space
    integer(hsize_t) :: dims(4), maxdims(4)
    integer :: h, e, r

    extent = 0
    call h5dopen_f(file, path, dset, h)
    if (h < 0) return
    call h5dget_space_f(dset, space, h)
    if (h >= 0) then
      call h5sget_simple_extent_ndims_f(space, r, h)
      if (h >= 0 .and. r >= 1 .and. r <= 4) then
        call h5sget_simple_extent_dims_f(space, dims(1:r), maxdims(1:r), h)
        if (h >= 0) extent = int(dims(r))
      end if
      call h5sclose_f(space, e)
    end if
    call h5dclose_f(dset, e)
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

    ok = .false.
    value = 0
    call h5dopen_f(file, path, dset, h)
    if (h < 0) return
    call h5dget_space_f(dset, fspace, h)
    if (h >= 0) then
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, [int(k - 1, hsize_t)], [1_hsize_t], h)
      if (h >= 0) then
        call h5screate_simple_f(1, [1_hsize_t], mspace, h)
        if (h >= 0) then
          call h5dread_f(dset, H5T_NATIVE_DOUBLE, value, [1_hsize_t], h, mem_space_id=mspace, file_space_id=fspace)
          ok = h >= 0
          call h5sclose_f(mspace, e)
        end if
      end if
      call h5sclose_f(fspace, e)
    end if
    call h5dclose_f(dset, e)
  end subroutine read_series_value

end module checkpoint_check
