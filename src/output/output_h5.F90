! SPDX-License-Identifier: BSD-2-Clause
!> HDF5 helpers of module output: attribute and dataset writers and readers,
!> hyperslab selection, and the error rules (every h5*_f code checked, a
!> one-line message naming the call and the object; agree makes the ranks'
!> error flags one). Private to the output submodules.
module output_h5
  use, intrinsic :: iso_fortran_env, only: int64
  use hdf5
  use mpi
  use kinds, only: rp
  implicit none
  private

  public :: select_spaces, close_spaces, set_attr_str, set_attr_int, set_attr_reals, delete_attr
  public :: open_dset, close_dset, fail, keep_first, agree, get_attr_int, get_attr_str, get_attr_reals
  public :: open_or_create_group, close_group, put_doubles, write_rows, create_dataset

contains

  !> A float64 dataset `name` of shape dims (Fortran order: C order reversed)
  !> in grp (at path gpath, for messages); nothing when ierr /= 0 already.
  subroutine put_doubles(grp, gpath, name, v, dims, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: gpath, name
    real(rp), intent(in) :: v(:)
    integer(hsize_t), intent(in) :: dims(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: sp, ds
    integer :: h
    if (ierr /= 0) return
    call h5screate_simple_f(size(dims), dims, sp, h)
    call h5dcreate_f(grp, name, H5T_NATIVE_DOUBLE, sp, ds, h)
    if (h < 0) then
      call fail('h5dcreate_f', gpath//'/'//name, ierr, errmsg)
    else
      call h5dwrite_f(ds, H5T_NATIVE_DOUBLE, v, dims, h)
      if (h < 0) call fail('h5dwrite_f', gpath//'/'//name, ierr, errmsg)
      call h5dclose_f(ds, h)
    end if
    call h5sclose_f(sp, h)
  end subroutine put_doubles

  !> A new dataset `name` in loc of type dtype and Fortran shape dims (C
  !> order reversed), never filled: parallel HDF5 would otherwise write
  !> fill values, a second write of all of it; with maxdims and chunk
  !> (both or neither), extendable and chunked. dset: -1 unless made;
  !> nothing when ierr /= 0 already.
  subroutine create_dataset(loc, name, dtype, dims, dset, ierr, errmsg, maxdims, chunk)
    integer(hid_t), intent(in) :: loc, dtype
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hsize_t), intent(in), optional :: maxdims(:), chunk(:)
    integer(hid_t) :: space, dcpl
    integer :: h

    dset = -1
    if (ierr /= 0) return
    call h5screate_simple_f(size(dims), dims, space, h, maxdims)
    if (h < 0) then
      call fail('h5screate_simple_f', name, ierr, errmsg); return
    end if
    call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, h)
    if (h < 0) then
      call fail('h5pcreate_f(dataset create)', name, ierr, errmsg)
    else
      if (present(chunk)) then
        call h5pset_chunk_f(dcpl, size(chunk), chunk, h)
        if (h < 0) call fail('h5pset_chunk_f', name, ierr, errmsg)
      end if
      ! Chunked: parallel HDF5 allocates a chunk when the extent grows, and
      ! would write fill values into it there, a second write of every
      ! output step (and, on a full disk, a write that fails inside the
      ! collective H5Dset_extent on some ranks only, which hangs the others).
      if (ierr == 0) then
        call h5pset_fill_time_f(dcpl, H5D_FILL_TIME_NEVER_F, h)
        if (h < 0) call fail('h5pset_fill_time_f', name, ierr, errmsg)
      end if
      if (ierr == 0) then
        call h5dcreate_f(loc, name, dtype, space, dset, h, dcpl_id=dcpl)
        if (h < 0) then
          dset = -1
          call fail('h5dcreate_f', name, ierr, errmsg)
        end if
      end if
      call h5pclose_f(dcpl, h)
      if (h < 0) call fail('h5pclose_f(dataset create)', name, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
  end subroutine create_dataset

  !> Open the group path (absolute, one level below an existing group), or
  !> create it; grp must be closed by the caller.
  subroutine open_or_create_group(file, path, grp, ierr, errmsg)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: path
    integer(hid_t), intent(out) :: grp
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    grp = -1
    call h5lexists_f(file, path, exists, h)
    if (h < 0) then
      call fail('h5lexists_f', path, ierr, errmsg); return
    end if
    if (exists) then
      call h5gopen_f(file, path, grp, h)
      if (h < 0) call fail('h5gopen_f', path, ierr, errmsg)
    else
      call h5gcreate_f(file, path, grp, h)
      if (h < 0) call fail('h5gcreate_f', path, ierr, errmsg)
    end if
    if (ierr /= 0) grp = -1
  end subroutine open_or_create_group

  subroutine close_group(grp, where, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: where
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    if (grp < 0) return
    call h5gclose_f(grp, h)
    if (h < 0) call fail('h5gclose_f', where, ierr, errmsg)
  end subroutine close_group

  !> Collective write of a strip a(count) at start(:) with the transfer
  !> property list dxpl; a is rank 2 or 3 (count(1:rank(a)) its shape).
  subroutine write_rows(dxpl, dset, name, start, count, a, ierr, errmsg)
    integer(hid_t), intent(in) :: dxpl, dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    real(rp), intent(in) :: a(..)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer :: h
    real(rp) :: empty(1) = 0

    call select_spaces(dset, name, start, count, product(count) == 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      h = 0
      if (product(count) == 0) then
        call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, empty, [1_hsize_t], h, &
                        mem_space_id=mspace, file_space_id=fspace, xfer_prp=dxpl)
      else
        select rank (a)
        rank (2)
          call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, a, count(1:2), h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=dxpl)
        rank (3)
          call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, a, count(1:3), h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=dxpl)
        rank default
          h = -1
        end select
      end if
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_rows

  !> File space with the hyperslab (start, count) selected, and a matching memory
  !> space; with empty, both select nothing (this rank joins the collective call only).
  subroutine select_spaces(dset, name, start, count, empty, fspace, mspace, ierr, errmsg)
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    logical, intent(in) :: empty
    integer(hid_t), intent(out) :: fspace, mspace
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    fspace = -1
    mspace = -1
    call h5dget_space_f(dset, fspace, h)
    if (h < 0) then
      fspace = -1
      call fail('h5dget_space_f', name, ierr, errmsg); return
    end if
    if (empty) then
      call h5sselect_none_f(fspace, h)
      if (h < 0) then
        call fail('h5sselect_none_f', name, ierr, errmsg); return
      end if
      call h5screate_simple_f(1, [1_hsize_t], mspace, h)
      if (h < 0) then
        mspace = -1
        call fail('h5screate_simple_f', name, ierr, errmsg); return
      end if
      call h5sselect_none_f(mspace, h)
      if (h < 0) call fail('h5sselect_none_f', name, ierr, errmsg)
    else
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, start, count, h)
      if (h < 0) then
        call fail('h5sselect_hyperslab_f', name, ierr, errmsg); return
      end if
      call h5screate_simple_f(size(count), count, mspace, h)
      if (h < 0) then
        mspace = -1
        call fail('h5screate_simple_f', name, ierr, errmsg)
      end if
    end if
  end subroutine select_spaces

  subroutine close_spaces(fspace, mspace, name, ierr, errmsg)
    integer(hid_t), intent(in) :: fspace, mspace
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    if (mspace >= 0) then
      call h5sclose_f(mspace, h)
      if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    end if
    if (fspace >= 0) then
      call h5sclose_f(fspace, h)
      if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    end if
  end subroutine close_spaces

  ! ---------------------------------------------------------------------------
  ! Attributes (scalar; an existing one is deleted and re-created).

  subroutine set_attr_str(loc, name, value, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, value, where   ! where: the object, for messages
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: stype, space, attr
    integer :: h
    character(len=:), allocatable :: what, text

    what = 'attribute '//name//' of '//where
    ! A zero-size string type is not allowed: store an empty value as one NUL.
    if (len(value) == 0) then
      text = achar(0)
    else
      text = value
    end if
    call delete_attr(loc, name, what, ierr, errmsg)
    if (ierr /= 0) return
    call h5tcopy_f(H5T_NATIVE_CHARACTER, stype, h)
    if (h < 0) then
      call fail('h5tcopy_f', what, ierr, errmsg); return
    end if
    call h5tset_size_f(stype, int(len(text), size_t), h)
    if (h < 0) call fail('h5tset_size_f', what, ierr, errmsg)
    if (ierr == 0) then
      call h5tset_strpad_f(stype, H5T_STR_NULLPAD_F, h)
      if (h < 0) call fail('h5tset_strpad_f', what, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5screate_f(H5S_SCALAR_F, space, h)
      if (h < 0) then
        call fail('h5screate_f', what, ierr, errmsg)
      else
        call h5acreate_f(loc, name, stype, space, attr, h)
        if (h < 0) then
          call fail('h5acreate_f', what, ierr, errmsg)
        else
          call h5awrite_f(attr, stype, text, [1_hsize_t], h)
          if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
          call h5aclose_f(attr, h)
          if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
        end if
        call h5sclose_f(space, h)
        if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
      end if
    end if
    call h5tclose_f(stype, h)
    if (h < 0) call fail('h5tclose_f', what, ierr, errmsg)
  end subroutine set_attr_str

  subroutine set_attr_int(loc, name, value, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    integer, intent(in) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space, attr
    integer :: h
    character(len=:), allocatable :: what

    what = 'attribute '//name//' of '//where
    call delete_attr(loc, name, what, ierr, errmsg)
    if (ierr /= 0) return
    call h5screate_f(H5S_SCALAR_F, space, h)
    if (h < 0) then
      call fail('h5screate_f', what, ierr, errmsg); return
    end if
    call h5acreate_f(loc, name, H5T_NATIVE_INTEGER, space, attr, h)
    if (h < 0) then
      call fail('h5acreate_f', what, ierr, errmsg)
    else
      call h5awrite_f(attr, H5T_NATIVE_INTEGER, value, [1_hsize_t], h)
      if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
      call h5aclose_f(attr, h)
      if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
  end subroutine set_attr_int

  !> Real attribute: a scalar for one value, a 1-D array otherwise.
  subroutine set_attr_reals(loc, name, values, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    real(rp), intent(in) :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space, attr
    integer :: h
    character(len=:), allocatable :: what

    what = 'attribute '//name//' of '//where
    call delete_attr(loc, name, what, ierr, errmsg)
    if (ierr /= 0) return
    if (size(values) == 1) then
      call h5screate_f(H5S_SCALAR_F, space, h)
    else
      call h5screate_simple_f(1, [int(size(values), hsize_t)], space, h)
    end if
    if (h < 0) then
      call fail('h5screate_f', what, ierr, errmsg); return
    end if
    call h5acreate_f(loc, name, H5T_NATIVE_DOUBLE, space, attr, h)
    if (h < 0) then
      call fail('h5acreate_f', what, ierr, errmsg)
    else
      call h5awrite_f(attr, H5T_NATIVE_DOUBLE, values, [int(size(values), hsize_t)], h)
      if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
      call h5aclose_f(attr, h)
      if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
  end subroutine set_attr_reals

  subroutine delete_attr(loc, name, what, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    call h5aexists_f(loc, name, exists, h)
    if (h < 0) then
      call fail('h5aexists_f', what, ierr, errmsg); return
    end if
    if (exists) then
      call h5adelete_f(loc, name, h)
      if (h < 0) call fail('h5adelete_f', what, ierr, errmsg)
    end if
  end subroutine delete_attr

  !> Open the dataset `name` of loc; dset: -1 unless opened; nothing when
  !> ierr /= 0 already.
  subroutine open_dset(loc, name, dset, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    dset = -1
    if (ierr /= 0) return
    call h5dopen_f(loc, name, dset, h)
    if (h < 0) then
      dset = -1
      call fail('h5dopen_f', name, ierr, errmsg)
    end if
  end subroutine open_dset

  subroutine close_dset(dset, name, ierr, errmsg)
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    if (dset < 0) return
    call h5dclose_f(dset, h)
    if (h < 0) call fail('h5dclose_f', name, ierr, errmsg)
  end subroutine close_dset

  !> Record a failed call unless an earlier error is already recorded.
  subroutine fail(call_name, what, ierr, errmsg)
    character(*), intent(in) :: call_name, what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    if (ierr /= 0) return
    ierr = 1
    errmsg = 'output: '//call_name//' failed for '//what
  end subroutine fail

  subroutine keep_first(ierr, errmsg, e2, msg2)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer, intent(in) :: e2
    character(*), intent(in) :: msg2
    if (ierr == 0 .and. e2 /= 0) then
      ierr = e2
      errmsg = msg2
    end if
  end subroutine keep_first

  !> Make the error flag collective: every rank returns non-zero if any rank
  !> failed, and every rank gets the message of the first rank that failed
  !> (so that rank 0's one error line names the cause, wherever it arose).
  subroutine agree(comm, where, ierr, errmsg)
    integer, intent(in) :: comm
    character(*), intent(in) :: where
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: local, global, mpierr, rank, first, size_

    local = merge(1, 0, ierr /= 0)
    call MPI_Allreduce(local, global, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    if (mpierr /= MPI_SUCCESS) then
      if (ierr == 0) then
        ierr = 1
        errmsg = where//': MPI_Allreduce of the error flag failed'
      end if
      return
    end if
    if (global == 0) return
    call MPI_Comm_rank(comm, rank, mpierr)
    call MPI_Comm_size(comm, size_, mpierr)
    local = merge(rank, size_, ierr /= 0)
    call MPI_Allreduce(local, first, 1, MPI_INTEGER, MPI_MIN, comm, mpierr)
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, first, comm, mpierr)
    if (ierr == 0) ierr = 1
  end subroutine agree

  subroutine get_attr_int(loc, name, where, value, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    integer, intent(out) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: h, buf(1)

    value = 0
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call h5aread_f(attr, H5T_NATIVE_INTEGER, buf, [1_hsize_t], h)
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    value = buf(1)
    call h5aclose_f(attr, h)
  end subroutine get_attr_int

  !> A fixed-length string attribute into value (cut to its length).
  subroutine get_attr_str(loc, name, where, value, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    character(*), intent(out) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr, ftype, mtype
    integer(size_t) :: n
    integer :: h, k
    character(len=:), allocatable :: buf

    value = ''
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call h5aget_type_f(attr, ftype, h)
    if (h >= 0) call h5tget_size_f(ftype, n, h)
    if (h >= 0) then
      allocate(character(len=n) :: buf)
      call h5tcopy_f(H5T_NATIVE_CHARACTER, mtype, h)
      if (h >= 0) call h5tset_size_f(mtype, n, h)
      if (h >= 0) call h5aread_f(attr, mtype, buf, [1_hsize_t], h)
      call h5tclose_f(mtype, k)
      k = index(buf, achar(0))
      if (k > 0) buf = buf(1:k - 1)
      value = buf
    end if
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    call h5tclose_f(ftype, k)
    call h5aclose_f(attr, k)
  end subroutine get_attr_str

  subroutine get_attr_reals(loc, name, where, values, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    real(rp), intent(out) :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: h

    values = 0
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call h5aread_f(attr, H5T_NATIVE_DOUBLE, values, [int(size(values), hsize_t)], h)
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    call h5aclose_f(attr, h)
  end subroutine get_attr_reals

end module output_h5
