! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the process models' series (module process_model's
!> output hook; docs/model.md sections 9 and 10), which output writes
!> without knowing the physics: each a named dataset with its
!> description, its units' quantity and its shape ([t] or [t][xyz],
!> float64 or int64 counts), in the groups the models name (contact's:
!> /energy/barrier and the group /contact). Made by output_write_run_info
!> (pm_series_register), extended and written with every output step
!> after the series every file has. A scene without process models has
!> none of them and writes nothing more per output step.
submodule (output) output_pm
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  implicit none

  character(len=*), parameter :: STEP = 'output'   ! agree's name of an output step's writes
  character(len=*), parameter :: WHO = 'pm_series_register'

contains

  !> The groups (with their descriptions) and the series of the process
  !> models, made where missing; a file continued by -nuno_restart keeps
  !> those it has, cut back to its out%series%nt steps, and gets those it
  !> lacks (written by a version without them) at that length with the
  !> steps before the restart unknown: NaN, and -1 for the counts.
  !> Collective: every rank makes the same calls.
  module procedure pm_series_register
    integer(hid_t) :: grp
    integer :: k, n, h
    logical :: exists
    integer(hsize_t) :: dims(4)
    character(len=:), allocatable :: name

    if (ierr /= 0) return
    do k = 1, size(groups)
      name = trim(groups(k)%name)
      call open_or_create_group(out%file, name, grp, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'description', trim(groups(k)%description), name, ierr, errmsg)
      call close_group(grp, name, ierr, errmsg)
      call agree(out%comm, WHO, ierr, errmsg)
    end do
    n = size(series)
    out%series%pm = series
    allocate(out%series%pm_dset(n), out%series%pm_rank(n), out%series%pm_dims(2, n))
    out%series%pm_dset = -1
    out%series%pm_rank = 0
    out%series%pm_dims = 0
    do k = 1, n
      if (ierr /= 0) exit
      name = trim(series(k)%name)
      call has_link(out%file, name, name, exists, ierr, errmsg)
      if (ierr == 0 .and. exists) then
        call open_dset(out%file, name, out%series%pm_dset(k), ierr, errmsg)
        call dset_dims(out%series%pm_dset(k), name, out%series%pm_rank(k), dims, ierr, errmsg)
        if (ierr == 0) then
          out%series%pm_dims(1:out%series%pm_rank(k), k) = dims(1:out%series%pm_rank(k))
          out%series%pm_dims(out%series%pm_rank(k), k) = int(out%series%nt, hsize_t)
          call h5dset_extent_f(out%series%pm_dset(k), out%series%pm_dims(1:out%series%pm_rank(k), k), h)
          if (h < 0) call fail('h5dset_extent_f', name, ierr, errmsg)
        end if
      else if (ierr == 0) then
        call create_pm_series(out, k, ierr, errmsg)
        if (ierr == 0 .and. out%series%nt > 0) call pad(k)
      end if
      call agree(out%comm, WHO, ierr, errmsg)
    end do
  contains
    !> Extend series k to the out%series%nt steps already in the file and fill them
    !> with "unknown" (rank 0 writes; the others join with nothing).
    subroutine pad(k)
      integer, intent(in) :: k
      integer(hid_t) :: fspace, mspace
      integer(hsize_t) :: start(2), count(2)
      integer :: r, h
      real(rp), allocatable :: nan(:)
      integer(int64), allocatable :: minus(:)
      character(len=:), allocatable :: name

      name = trim(out%series%pm(k)%name)
      r = out%series%pm_rank(k)
      out%series%pm_dims(r, k) = int(out%series%nt, hsize_t)
      call h5dset_extent_f(out%series%pm_dset(k), out%series%pm_dims(1:r, k), h)
      if (h < 0) call fail('h5dset_extent_f', name, ierr, errmsg)
      call agree(out%comm, WHO, ierr, errmsg)
      if (ierr /= 0) return
      start(1:r) = 0
      count(1:r) = out%series%pm_dims(1:r, k)
      call select_spaces(out%series%pm_dset(k), name, start(1:r), count(1:r), out%rank /= 0, fspace, mspace, ierr, errmsg)
      if (ierr == 0) then
        if (out%series%pm(k)%is_count) then
          allocate(minus(product(count(1:r))))
          minus = -1
          call h5dwrite_f(out%series%pm_dset(k), h5kind_to_type(int64, H5_INTEGER_KIND), minus, [int(size(minus), hsize_t)], h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
        else
          allocate(nan(product(count(1:r))))
          nan = ieee_value(1.0_rp, ieee_quiet_nan)
          call h5dwrite_f(out%series%pm_dset(k), H5T_NATIVE_DOUBLE, nan, [int(size(nan), hsize_t)], h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
        end if
        if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
      end if
      call close_spaces(fspace, mspace, name, ierr, errmsg)
    end subroutine pad
  end procedure pm_series_register

  !> Process model series k, empty and extendable along t: [t] or [t][xyz]
  !> (ncomp 3), int64 counts or float64, chunked as the other series, with
  !> its description.
  subroutine create_pm_series(out, k, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(in) :: k
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hsize_t) :: dims(2), maxdims(2), chunk(2)
    integer(hid_t) :: ftype
    integer :: r
    character(len=:), allocatable :: name

    name = trim(out%series%pm(k)%name)
    if (out%series%pm(k)%ncomp > 1) then
      r = 2
      dims = [int(out%series%pm(k)%ncomp, hsize_t), 0_hsize_t]
      chunk = [int(out%series%pm(k)%ncomp, hsize_t), scalar_chunk]
    else
      r = 1
      dims(1) = 0
      chunk(1) = scalar_chunk
    end if
    maxdims(1:r) = dims(1:r)
    maxdims(r) = H5S_UNLIMITED_F
    ftype = H5T_NATIVE_DOUBLE
    if (out%series%pm(k)%is_count) ftype = H5T_STD_I64LE
    out%series%pm_rank(k) = r
    out%series%pm_dims(1:r, k) = dims(1:r)
    call create_extendable(out%file, name, ftype, dims(1:r), maxdims(1:r), chunk(1:r), out%series%pm_dset(k), ierr, errmsg)
    call set_attr_str(out%series%pm_dset(k), 'description', trim(out%series%pm(k)%description), name, ierr, errmsg)
  end subroutine create_pm_series

  !> Extend every process model series to t + 1 steps (an output step; collective).
  module procedure pm_series_extend
    integer :: k, h, r

    if (.not. allocated(out%series%pm_dset)) return
    do k = 1, size(out%series%pm_dset)
      if (out%series%pm_dset(k) < 0) cycle
      r = out%series%pm_rank(k)
      out%series%pm_dims(r, k) = t + 1
      call h5dset_extent_f(out%series%pm_dset(k), out%series%pm_dims(1:r, k), h)
      if (h < 0) call fail('h5dset_extent_f', trim(out%series%pm(k)%name), ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end do
  end procedure pm_series_extend

  !> The step's values of the process models' series (rank 0 writes, the
  !> others join with an empty selection; each write agreed on): series
  !> must be those registered, in their order.
  module procedure pm_series_write
    integer(hid_t) :: fspace, mspace
    integer(hsize_t) :: start(2), count(2)
    integer(int64) :: buf(1)
    integer :: k, r, h
    character(len=:), allocatable :: name

    if (.not. allocated(out%series%pm_dset)) return
    if (size(series) /= size(out%series%pm_dset)) then
      ierr = 1
      errmsg = 'output_write_step: '//itoa(size(series))//' process model series given, '// &
               itoa(size(out%series%pm_dset))//' made by output_write_run_info'
      return
    end if
    do k = 1, size(series)
      if (out%series%pm_dset(k) < 0) cycle
      name = trim(out%series%pm(k)%name)
      if (trim(series(k)%name) /= name) then
        ierr = 1
        errmsg = 'output_write_step: the process model series '//trim(series(k)%name)//' is not '//name
        return
      end if
      r = out%series%pm_rank(k)
      start(1:r) = 0
      start(r) = out%series%nt
      count(1:r) = out%series%pm_dims(1:r, k)
      count(r) = 1
      call select_spaces(out%series%pm_dset(k), name, start(1:r), count(1:r), out%rank /= 0, fspace, mspace, ierr, errmsg)
      if (ierr == 0) then
        if (out%series%pm(k)%is_count) then
          buf(1) = series(k)%count
          call h5dwrite_f(out%series%pm_dset(k), h5kind_to_type(int64, H5_INTEGER_KIND), buf, [1_hsize_t], h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
        else
          call h5dwrite_f(out%series%pm_dset(k), H5T_NATIVE_DOUBLE, series(k)%values(1:out%series%pm(k)%ncomp), &
                          [int(out%series%pm(k)%ncomp, hsize_t)], h, mem_space_id=mspace, file_space_id=fspace, &
                          xfer_prp=out%dxpl)
        end if
        if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
      end if
      call close_spaces(fspace, mspace, name, ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end do
  end procedure pm_series_write

  !> Close the process models' datasets (close_ids); keeps the first error.
  module procedure pm_series_close
    integer :: k

    if (.not. allocated(out%series%pm_dset)) return
    do k = 1, size(out%series%pm_dset)
      if (out%series%pm_dset(k) >= 0) call close_dset(out%series%pm_dset(k), trim(out%series%pm(k)%name), ierr, errmsg)
      out%series%pm_dset(k) = -1
    end do
  end procedure pm_series_close

  !> Open the process models' datasets again (refresh_library), as they were.
  module procedure pm_series_reopen
    integer :: k
    logical :: exists
    character(len=:), allocatable :: name

    if (.not. allocated(out%series%pm_dset)) return
    do k = 1, size(out%series%pm_dset)
      if (ierr /= 0) exit
      name = trim(out%series%pm(k)%name)
      call has_link(out%file, name, name, exists, ierr, errmsg)
      if (exists) call open_dset(out%file, name, out%series%pm_dset(k), ierr, errmsg)
    end do
  end procedure pm_series_reopen

end submodule output_pm
