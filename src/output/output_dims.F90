! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the file as netCDF-4 readers see it. HDF5 dimension scales
!> (H5DS) name every axis of the time series and of /lattice, /time is the
!> coordinate of the time axis, and each dataset carries a `units`
!> attribute, so that xarray (engine h5netcdf) and other netCDF-4 readers
!> open the file with the dimensions time, j, i, xyz instead of anonymous
!> ones.
!>
!> Layout (C order, as readers see it): /position and /velocity
!> (time, j, i, xyz), /lattice/rest_position (j, i, xyz), /lattice/mass
!> (j, i), /diagnostics/momentum and angular_momentum and the process
!> models' 3-vectors (contact's /contact/force and normal_force) (time,
!> xyz), every other series (time). /time is the scale "time"; /j, /i and /xyz are scales
!> without values, marked as netCDF-4 marks a dimension that is not a
!> variable (its NAME attribute), so readers list them as dimensions only.
!> All of it is metadata written once, at the open (or at a restart of a
!> file written before it existed): nothing is added per output step.
submodule (output) output_dims
  use h5ds, only: h5dsset_scale_f, h5dsattach_scale_f, h5dsis_attached_f, h5dsis_scale_f
  implicit none

  !> netCDF-4's NAME of a dimension scale that is not a variable (the C
  !> library's NOT_A_VARIABLE text; the length follows in 10 columns).
  character(len=*), parameter :: NOT_A_VARIABLE = 'This is a netCDF dimension but not a netCDF variable.'

contains

  !> Scales and their attachments, made where missing (idempotent: the open,
  !> output_write_run_info's /wall_time, a restart). Collective: every rank
  !> makes the same metadata calls.
  module procedure netcdf_dims
    integer(hid_t) :: sj, si, sxyz, time
    integer :: k, h
    logical :: is_scale
    character(len=:), allocatable :: name

    time = out%series%dset(d_time)
    if (ierr /= 0 .or. time < 0) return
    call h5dsis_scale_f(time, is_scale, h)
    if (h < 0) call fail('h5dsis_scale_f', '/time', ierr, errmsg)
    if (ierr == 0 .and. .not. is_scale) then
      call h5dsset_scale_f(time, h, 'time')
      if (h < 0) call fail('h5dsset_scale_f', '/time', ierr, errmsg)
    end if
    call axis_scale(out, '/j', out%ny, sj, ierr, errmsg)
    call axis_scale(out, '/i', out%nx, si, ierr, errmsg)
    call axis_scale(out, '/xyz', 3, sxyz, ierr, errmsg)
    do k = 1, n_dsets
      if (ierr /= 0) exit
      if (k == d_time .or. out%series%dset(k) < 0) cycle
      name = trim(dset_names(k))
      call attach(out%series%dset(k), time, 1, name, ierr, errmsg)
      select case (k)
      case (d_position, d_velocity)
        call attach(out%series%dset(k), sj, 2, name, ierr, errmsg)
        call attach(out%series%dset(k), si, 3, name, ierr, errmsg)
        call attach(out%series%dset(k), sxyz, 4, name, ierr, errmsg)
      case (d_momentum, d_angular_momentum)
        call attach(out%series%dset(k), sxyz, 2, name, ierr, errmsg)
      end select
    end do
    if (allocated(out%series%pm_dset)) then
      do k = 1, size(out%series%pm_dset)
        if (ierr /= 0) exit
        if (out%series%pm_dset(k) < 0) cycle
        name = trim(out%series%pm(k)%name)
        call attach(out%series%pm_dset(k), time, 1, name, ierr, errmsg)
        if (out%series%pm_rank(k) == 2) call attach(out%series%pm_dset(k), sxyz, 2, name, ierr, errmsg)
      end do
    end if
    call attach_static(out, '/lattice/rest_position', [sj, si, sxyz], ierr, errmsg)
    call attach_static(out, '/lattice/mass', [sj, si], ierr, errmsg)
    call close_dset(sj, '/j', ierr, errmsg)
    call close_dset(si, '/i', ierr, errmsg)
    call close_dset(sxyz, '/xyz', ierr, errmsg)
  end procedure netcdf_dims

  !> The scales of a dataset written once at the open (dimension d gets
  !> scales(d)), attached where missing.
  subroutine attach_static(out, name, scales, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name
    integer(hid_t), intent(in) :: scales(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dset
    integer :: d

    call open_dset(out%file, name, dset, ierr, errmsg)
    if (ierr /= 0) return
    do d = 1, size(scales)
      call attach(dset, scales(d), d, name, ierr, errmsg)
    end do
    call close_dset(dset, name, ierr, errmsg)
  end subroutine attach_static

  !> The value-less scale `name` of length n, opened (made when missing);
  !> dset: -1 unless opened; nothing when ierr /= 0 already.
  subroutine axis_scale(out, name, n, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name
    integer, intent(in) :: n
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h
    character(len=10) :: len_text

    dset = -1
    if (ierr /= 0) return
    call has_link(out%file, name, name, exists, ierr, errmsg)
    if (ierr /= 0) return
    if (exists) then
      call open_dset(out%file, name, dset, ierr, errmsg)
      return
    end if
    ! never written (no values), nor filled
    call create_dataset(out%file, name, H5T_NATIVE_REAL, [int(n, hsize_t)], dset, ierr, errmsg)
    if (ierr /= 0) return
    write(len_text, '(i10)') n
    call h5dsset_scale_f(dset, h, NOT_A_VARIABLE//len_text)
    if (h < 0) call fail('h5dsset_scale_f', name, ierr, errmsg)
  end subroutine axis_scale

  !> Scale `scale` on axis idx (1-based, C order: 1 is the slowest) of dset
  !> (name, for messages), unless there; nothing when ierr /= 0 already.
  subroutine attach(dset, scale, idx, name, ierr, errmsg)
    integer(hid_t), intent(in) :: dset, scale
    integer, intent(in) :: idx
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: there
    integer :: h

    if (ierr /= 0) return
    call h5dsis_attached_f(dset, scale, idx, there, h)
    if (h < 0) then
      call fail('h5dsis_attached_f', name, ierr, errmsg); return
    end if
    if (there) return
    call h5dsattach_scale_f(dset, scale, idx, h)
    if (h < 0) call fail('h5dsattach_scale_f', name, ierr, errmsg)
  end subroutine attach

  !> The attribute `units` of every series and of /lattice, in the scene's
  !> unit system ('SI' or 'mm g s'; another value: none written), as UDUNITS
  !> strings. Collective.
  module procedure write_units
    character(len=16) :: length, velocity, mass, energy, momentum, angular, force, unit
    integer :: k

    if (ierr /= 0) return
    select case (system)
    case ('SI')
      length = 'm'; velocity = 'm/s'; mass = 'kg'; energy = 'J'; momentum = 'kg m/s'; angular = 'kg m^2/s'
      force = 'N'
    case ('mm g s')
      length = 'mm'; velocity = 'mm/s'; mass = 'g'; energy = 'g mm^2/s^2'; momentum = 'g mm/s'; angular = 'g mm^2/s'
      force = 'g mm/s^2'
    case default
      return
    end select
    do k = 1, n_dsets
      if (out%series%dset(k) < 0 .or. ierr /= 0) cycle
      select case (k)
      case (d_time, d_wall_time)
        call put(out%series%dset(k), 's')
      case (d_position, d_length, d_flatness)
        call put(out%series%dset(k), length)
      case (d_velocity)
        call put(out%series%dset(k), velocity)
      case (d_kinetic, d_stretch, d_bend, d_dissipated, d_external_work)
        call put(out%series%dset(k), energy)
      case (d_momentum)
        call put(out%series%dset(k), momentum)
      case (d_angular_momentum)
        call put(out%series%dset(k), angular)
      case default
        call put(out%series%dset(k), '1')   ! counts
      end select
    end do
    ! the process models' series: their units' quantity in this system
    if (allocated(out%series%pm_dset)) then
      do k = 1, size(out%series%pm_dset)
        if (out%series%pm_dset(k) < 0 .or. ierr /= 0) cycle
        select case (trim(out%series%pm(k)%units))
        case ('length')
          unit = length
        case ('velocity')
          unit = velocity
        case ('energy')
          unit = energy
        case ('force')
          unit = force
        case default
          unit = '1'
        end select
        call set_attr_str(out%series%pm_dset(k), 'units', trim(unit), trim(out%series%pm(k)%name), ierr, errmsg)
      end do
    end if
    call put_lattice('/lattice/rest_position', length)
    call put_lattice('/lattice/mass', mass)
  contains
    subroutine put(dset, value)
      integer(hid_t), intent(in) :: dset
      character(*), intent(in) :: value
      call set_attr_str(dset, 'units', trim(value), trim(dset_names(k)), ierr, errmsg)
    end subroutine put

    !> The units of the /lattice dataset `name`, written once at the open.
    subroutine put_lattice(name, value)
      character(*), intent(in) :: name, value
      integer(hid_t) :: lat
      call open_dset(out%file, name, lat, ierr, errmsg)
      if (ierr /= 0) return
      call set_attr_str(lat, 'units', trim(value), name, ierr, errmsg)
      call close_dset(lat, name, ierr, errmsg)
    end subroutine put_lattice
  end procedure write_units

end submodule output_dims
