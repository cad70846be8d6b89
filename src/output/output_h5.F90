! SPDX-License-Identifier: BSD-2-Clause
!> HDF5 helpers of module output: attribute and dataset writers and readers,
!> hyperslab selection, the property lists of a parallel file, and the error
!> rules (every h5*_f code checked, a one-line message naming the call and
!> the object; agree makes the ranks' error flags one). Private to the
!> output submodules and checkpoint_check.
module output_h5
  use, intrinsic :: iso_c_binding, only: c_ptr, c_loc
  use hdf5
  use mpi
  use kinds, only: rp
  implicit none
  private

  public :: select_spaces, close_spaces, set_attr_str, set_attr_int, set_attr_reals
  public :: open_dset, close_dset, fail, keep_first, agree, get_attr_int, get_attr_str, get_attr_reals
  public :: open_or_create_group, close_group, put_doubles, write_rows, create_dataset, create_extendable
  public :: has_link, new_space, dset_dims, attr_text, create_doubles, all_agree
  public :: library_open, mpio_access_list, set_format_bounds, close_access_list, collective_transfer

contains

  ! ---------------------------------------------------------------------------
  ! The file: library, property lists.

  !> Open the HDF5 library (again after h5close_f) with its error printing
  !> off: a failure comes back as one line of ours. what: for messages.
  subroutine library_open(what, ierr, errmsg)
    character(*), intent(in) :: what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5open_f(h)
    if (h < 0) call fail('h5open_f', what, ierr, errmsg)
    call h5eset_auto_f(0, h)
  end subroutine library_open

  !> A file access property list of the MPI-IO driver on comm (fapl: -1
  !> unless made; close_access_list closes it). what: the file, for messages.
  subroutine mpio_access_list(comm, what, fapl, ierr, errmsg)
    integer, intent(in) :: comm
    character(*), intent(in) :: what
    integer(hid_t), intent(out) :: fapl
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
    if (h < 0) then
      fapl = -1
      call fail('h5pcreate_f(file access)', what, ierr, errmsg); return
    end if
    call h5pset_fapl_mpio_f(fapl, comm, MPI_INFO_NULL, h)
    if (h < 0) call fail('h5pset_fapl_mpio_f', what, ierr, errmsg)
  end subroutine mpio_access_list

  !> The format bounds of nuno's files on fapl. The 1.8 file format:
  !> attributes over 64 KiB (long namelists) are allowed, and a file left
  !> open by a crash still opens without h5clear (superblock version 2).
  !> Objects up to the 1.10 format are allowed, for the virtual datasets of
  !> /xdmf (layout message version 4; HDF5 refuses them with the bound at
  !> 1.8); everything else is written as with 1.8 bounds.
  subroutine set_format_bounds(fapl, what, ierr, errmsg)
    integer(hid_t), intent(in) :: fapl
    character(*), intent(in) :: what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V110_F, h)
    if (h < 0) call fail('h5pset_libver_bounds_f', what, ierr, errmsg)
  end subroutine set_format_bounds

  subroutine close_access_list(fapl, what, ierr, errmsg)
    integer(hid_t), intent(in) :: fapl
    character(*), intent(in) :: what
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    if (fapl < 0) return
    call h5pclose_f(fapl, h)
    if (h < 0) call fail('h5pclose_f(file access)', what, ierr, errmsg)
  end subroutine close_access_list

  !> The transfer property list of collective MPI-IO (dxpl: -1 unless made).
  subroutine collective_transfer(what, dxpl, ierr, errmsg)
    character(*), intent(in) :: what
    integer(hid_t), intent(out) :: dxpl
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5pcreate_f(H5P_DATASET_XFER_F, dxpl, h)
    if (h < 0) then
      dxpl = -1
      call fail('h5pcreate_f(dataset transfer)', what, ierr, errmsg); return
    end if
    call h5pset_dxpl_mpio_f(dxpl, H5FD_MPIO_COLLECTIVE_F, h)
    if (h < 0) call fail('h5pset_dxpl_mpio_f', what, ierr, errmsg)
  end subroutine collective_transfer

  ! ---------------------------------------------------------------------------
  ! Links, groups, dataspaces and datasets.

  !> Whether the link `name` of loc exists (.false. when the call fails);
  !> what: its path, for messages.
  subroutine has_link(loc, name, what, exists, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, what
    logical, intent(out) :: exists
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    call h5lexists_f(loc, name, exists, h)
    if (h < 0) then
      exists = .false.
      call fail('h5lexists_f', what, ierr, errmsg)
    end if
  end subroutine has_link

  !> Open the group path (absolute, one level below an existing group), or
  !> create it; grp must be closed by the caller (-1 unless opened); nothing
  !> when ierr /= 0 already.
  subroutine open_or_create_group(file, path, grp, ierr, errmsg)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: path
    integer(hid_t), intent(out) :: grp
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    grp = -1
    if (ierr /= 0) return
    call has_link(file, path, path, exists, ierr, errmsg)
    if (ierr /= 0) return
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

  !> A simple dataspace of Fortran dims (C order reversed); space: -1
  !> unless made; nothing when ierr /= 0 already.
  subroutine new_space(dims, what, space, ierr, errmsg)
    integer(hsize_t), intent(in) :: dims(:)
    character(*), intent(in) :: what
    integer(hid_t), intent(out) :: space
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h
    space = -1
    if (ierr /= 0) return
    call h5screate_simple_f(size(dims), dims, space, h)
    if (h < 0) then
      space = -1
      call fail('h5screate_simple_f', what, ierr, errmsg)
    end if
  end subroutine new_space

  !> The rank r and Fortran dims (1:r) of the dataset dset (r <= 4); nothing
  !> (r = 0) when ierr /= 0 already.
  subroutine dset_dims(dset, what, r, dims, ierr, errmsg)
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: what
    integer, intent(out) :: r
    integer(hsize_t), intent(out) :: dims(4)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer(hsize_t) :: maxdims(4)
    integer :: h, e

    r = 0
    dims = 0
    if (ierr /= 0) return
    call h5dget_space_f(dset, space, h)
    if (h < 0) then
      call fail('h5dget_space_f', what, ierr, errmsg); return
    end if
    call h5sget_simple_extent_ndims_f(space, r, h)
    if (h < 0 .or. r < 1 .or. r > 4) then
      r = 0
      call fail('h5sget_simple_extent_ndims_f', what, ierr, errmsg)
    else
      call h5sget_simple_extent_dims_f(space, dims(1:r), maxdims(1:r), h)
      if (h < 0) call fail('h5sget_simple_extent_dims_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, e)
  end subroutine dset_dims

  !> A float64 dataset `name` of shape dims (Fortran order: C order reversed)
  !> in grp (at path gpath, for messages), written whole by every rank alike;
  !> nothing when ierr /= 0 already.
  subroutine put_doubles(grp, gpath, name, v, dims, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: gpath, name
    real(rp), intent(in) :: v(:)
    integer(hsize_t), intent(in) :: dims(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: ds
    integer :: h
    call create_doubles(grp, name, gpath//'/'//name, dims, ds, ierr, errmsg)
    if (ierr /= 0) return
    call h5dwrite_f(ds, H5T_NATIVE_DOUBLE, v, dims, h)
    if (h < 0) call fail('h5dwrite_f', gpath//'/'//name, ierr, errmsg)
    call h5dclose_f(ds, h)
  end subroutine put_doubles

  !> A new float64 dataset `name` of loc (what: its path, for messages) of
  !> Fortran shape dims, with HDF5's default properties (contiguous, filled
  !> when allocated); dset: -1 unless made; nothing when ierr /= 0 already.
  subroutine create_doubles(loc, name, what, dims, dset, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, what
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer :: h
    dset = -1
    call new_space(dims, what, space, ierr, errmsg)
    if (ierr /= 0) return
    call h5dcreate_f(loc, name, H5T_NATIVE_DOUBLE, space, dset, h)
    if (h < 0) then
      dset = -1
      call fail('h5dcreate_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
  end subroutine create_doubles

  !> A new dataset `name` in loc of type dtype and Fortran shape dims (C
  !> order reversed), never filled (parallel HDF5 would otherwise write fill
  !> values, a second write of all of it). dset: -1 unless made; nothing
  !> when ierr /= 0 already.
  subroutine create_dataset(loc, name, dtype, dims, dset, ierr, errmsg)
    integer(hid_t), intent(in) :: loc, dtype
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space

    dset = -1
    call new_space(dims, name, space, ierr, errmsg)
    if (ierr /= 0) return
    call create_unfilled(loc, name, dtype, space, [integer(hsize_t) ::], dset, ierr, errmsg)
  end subroutine create_dataset

  !> create_dataset's dataset, extendable up to maxdims and chunked by chunk.
  subroutine create_extendable(loc, name, dtype, dims, maxdims, chunk, dset, ierr, errmsg)
    integer(hid_t), intent(in) :: loc, dtype
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: dims(:), maxdims(:), chunk(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer :: h

    dset = -1
    if (ierr /= 0) return
    call h5screate_simple_f(size(dims), dims, space, h, maxdims)
    if (h < 0) then
      call fail('h5screate_simple_f', name, ierr, errmsg); return
    end if
    call create_unfilled(loc, name, dtype, space, chunk, dset, ierr, errmsg)
  end subroutine create_extendable

  !> The dataset of create_dataset on space (closed here); chunked when
  !> chunk has a size for each dimension, contiguous when it is empty.
  subroutine create_unfilled(loc, name, dtype, space, chunk, dset, ierr, errmsg)
    integer(hid_t), intent(in) :: loc, dtype, space
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: chunk(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dcpl
    integer :: h

    dset = -1
    call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, h)
    if (h < 0) then
      call fail('h5pcreate_f(dataset create)', name, ierr, errmsg)
    else
      if (size(chunk) > 0) then
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
  end subroutine create_unfilled

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
      call new_space([1_hsize_t], name, mspace, ierr, errmsg)
      if (ierr /= 0) return
      call h5sselect_none_f(mspace, h)
      if (h < 0) call fail('h5sselect_none_f', name, ierr, errmsg)
    else
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, start, count, h)
      if (h < 0) then
        call fail('h5sselect_hyperslab_f', name, ierr, errmsg); return
      end if
      call new_space(count, name, mspace, ierr, errmsg)
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

  ! ---------------------------------------------------------------------------
  ! Attributes (an existing one is deleted and re-created). The setters do
  ! nothing when ierr /= 0 already, so that a sequence of them is a chain.

  subroutine set_attr_str(loc, name, value, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, value, where   ! where: the object, for messages
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: stype
    integer :: h
    character(len=:), allocatable :: what
    character(len=:), allocatable, target :: text

    if (ierr /= 0) return
    what = 'attribute '//name//' of '//where
    ! A zero-size string type is not allowed: store an empty value as one NUL.
    if (len(value) == 0) then
      text = achar(0)
    else
      text = value
    end if
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
    if (ierr == 0) call new_attr(loc, name, 1, stype, c_loc(text), what, ierr, errmsg)
    call h5tclose_f(stype, h)
    if (h < 0) call fail('h5tclose_f', what, ierr, errmsg)
  end subroutine set_attr_str

  subroutine set_attr_int(loc, name, value, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    integer, intent(in) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer, target :: buf

    if (ierr /= 0) return
    buf = value
    call new_attr(loc, name, 1, H5T_NATIVE_INTEGER, c_loc(buf), 'attribute '//name//' of '//where, ierr, errmsg)
  end subroutine set_attr_int

  !> Real attribute: a scalar for one value, a 1-D array otherwise.
  subroutine set_attr_reals(loc, name, values, where, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    real(rp), intent(in), contiguous, target :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg

    if (ierr /= 0) return
    call new_attr(loc, name, size(values), H5T_NATIVE_DOUBLE, c_loc(values), 'attribute '//name//' of '//where, &
                  ierr, errmsg)
  end subroutine set_attr_reals

  !> The attribute `name` of loc, replaced: n values of type dtype at buf
  !> (n = 1: a scalar attribute, otherwise 1-D). what: for messages.
  subroutine new_attr(loc, name, n, dtype, buf, what, ierr, errmsg)
    integer(hid_t), intent(in) :: loc, dtype
    character(*), intent(in) :: name, what
    integer, intent(in) :: n
    type(c_ptr), intent(in) :: buf
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space, attr
    integer :: h
    logical :: exists

    call h5aexists_f(loc, name, exists, h)
    if (h < 0) then
      call fail('h5aexists_f', what, ierr, errmsg); return
    end if
    if (exists) then
      call h5adelete_f(loc, name, h)
      if (h < 0) then
        call fail('h5adelete_f', what, ierr, errmsg); return
      end if
    end if
    if (n == 1) then
      call h5screate_f(H5S_SCALAR_F, space, h)
    else
      call h5screate_simple_f(1, [int(n, hsize_t)], space, h)
    end if
    if (h < 0) then
      call fail('h5screate_f', what, ierr, errmsg); return
    end if
    call h5acreate_f(loc, name, dtype, space, attr, h)
    if (h < 0) then
      call fail('h5acreate_f', what, ierr, errmsg)
    else
      call h5awrite_f(attr, dtype, buf, h)
      if (h < 0) call fail('h5awrite_f', what, ierr, errmsg)
      call h5aclose_f(attr, h)
      if (h < 0) call fail('h5aclose_f', what, ierr, errmsg)
    end if
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', what, ierr, errmsg)
  end subroutine new_attr

  subroutine get_attr_int(loc, name, where, value, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    integer, intent(out) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer, target :: buf

    value = 0
    buf = 0
    call read_attr(loc, name, where, H5T_NATIVE_INTEGER, c_loc(buf), ierr, errmsg)
    value = buf
  end subroutine get_attr_int

  subroutine get_attr_reals(loc, name, where, values, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    real(rp), intent(out), contiguous, target :: values(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg

    values = 0
    call read_attr(loc, name, where, H5T_NATIVE_DOUBLE, c_loc(values), ierr, errmsg)
  end subroutine get_attr_reals

  !> The attribute `name` of loc (object `where`, for messages) read as
  !> dtype into buf; nothing when ierr /= 0 already.
  subroutine read_attr(loc, name, where, dtype, buf, ierr, errmsg)
    integer(hid_t), intent(in) :: loc, dtype
    character(*), intent(in) :: name, where
    type(c_ptr), intent(in) :: buf
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: h
    type(c_ptr) :: at   ! h5aread_f's buffer address is intent(inout)

    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    at = buf
    call h5aread_f(attr, dtype, at, h)
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    call h5aclose_f(attr, h)
  end subroutine read_attr

  !> A fixed-length string attribute into value (cut to its length).
  subroutine get_attr_str(loc, name, where, value, ierr, errmsg)
    integer(hid_t), intent(in) :: loc
    character(*), intent(in) :: name, where
    character(*), intent(out) :: value
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: h, e
    character(len=:), allocatable :: text

    value = ''
    if (ierr /= 0) return
    call h5aopen_f(loc, name, attr, h)
    if (h < 0) then
      call fail('h5aopen_f', 'attribute '//name//' of '//where, ierr, errmsg); return
    end if
    call attr_text(attr, text, h)
    value = text
    if (h < 0) call fail('h5aread_f', 'attribute '//name//' of '//where, ierr, errmsg)
    call h5aclose_f(attr, e)
  end subroutine get_attr_str

  !> The text of the open fixed-length string attribute attr, cut at a NUL
  !> ('' and h < 0 when a call failed).
  subroutine attr_text(attr, text, h)
    integer(hid_t), intent(in) :: attr
    character(len=:), allocatable, intent(out) :: text
    integer, intent(out) :: h
    integer(hid_t) :: ftype, mtype
    integer(size_t) :: n
    integer :: e, k
    character(len=:), allocatable :: buf

    text = ''
    call h5aget_type_f(attr, ftype, h)
    if (h < 0) return
    call h5tget_size_f(ftype, n, h)
    call h5tclose_f(ftype, e)
    if (h < 0) return
    allocate(character(len=n) :: buf)
    call h5tcopy_f(H5T_NATIVE_CHARACTER, mtype, h)
    if (h < 0) return
    call h5tset_size_f(mtype, n, h)
    if (h >= 0) call h5aread_f(attr, mtype, buf, [1_hsize_t], h)
    call h5tclose_f(mtype, e)
    if (h < 0) return
    k = index(buf, achar(0))
    if (k > 0) buf = buf(1:k - 1)
    text = buf
  end subroutine attr_text

  ! ---------------------------------------------------------------------------
  ! Errors.

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

  !> agree, then whether every rank is without error: the test between two
  !> collective calls that may fail on some ranks only.
  logical function all_agree(comm, where, ierr, errmsg)
    integer, intent(in) :: comm
    character(*), intent(in) :: where
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    call agree(comm, where, ierr, errmsg)
    all_agree = ierr == 0
  end function all_agree

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

end module output_h5
