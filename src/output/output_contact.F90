! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the series of contact with obstacles, made only for a
!> scene that has obstacles (docs/model.md sections 9 and 10): the barrier
!> energy /energy/barrier (a potential energy of the balance) and the group
!> /contact (active pairs, total and normal force, friction work, smallest
!> gap now and over the run, states checked). A scene without obstacles
!> has none of them and writes nothing more per output step.
submodule (output) output_contact
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  implicit none

contains

  !> Make the contact series where missing (output_write_run_info, with
  !> run_info%contact). A file continued by -nuno_restart that lacks them
  !> (written by a version without /contact) gets them at its length
  !> (out%nt steps) with the steps before the restart unknown: NaN, and -1
  !> for the counts. Collective: every rank makes the same calls.
  module procedure contact_series
    integer(hid_t) :: grp
    integer :: k

    if (ierr /= 0) return
    call open_or_create_group(out%file, '/contact', grp, ierr, errmsg)
    if (ierr == 0) call set_attr_str(grp, 'description', 'contact with the obstacles of &contact, per output step', &
                                     '/contact', ierr, errmsg)
    call close_group(grp, '/contact', ierr, errmsg)
    call agree(out%comm, 'contact_series', ierr, errmsg)
    do k = d_contact_first, n_dsets
      if (ierr /= 0) exit
      if (out%series%dset(k) >= 0) cycle
      call create_series(out, k, ierr, errmsg)
      if (ierr == 0 .and. out%series%nt > 0) call pad(k)
      call agree(out%comm, 'contact_series', ierr, errmsg)
    end do
    out%series%contact = ierr == 0
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

      name = trim(dset_names(k))
      r = out%series%drank(k)
      out%series%ddims(r, k) = int(out%series%nt, hsize_t)
      call h5dset_extent_f(out%series%dset(k), out%series%ddims(1:r, k), h)
      if (h < 0) call fail('h5dset_extent_f', name, ierr, errmsg)
      call agree(out%comm, 'contact_series', ierr, errmsg)
      if (ierr /= 0) return
      start(1:r) = 0
      count(1:r) = out%series%ddims(1:r, k)
      call select_spaces(out%series%dset(k), name, start(1:r), count(1:r), out%rank /= 0, fspace, mspace, ierr, errmsg)
      if (ierr == 0) then
        if (any(count_series == k)) then
          allocate(minus(product(count(1:r))))
          minus = -1
          call h5dwrite_f(out%series%dset(k), h5kind_to_type(int64, H5_INTEGER_KIND), minus, [int(size(minus), hsize_t)], h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
        else
          allocate(nan(product(count(1:r))))
          nan = ieee_value(1.0_rp, ieee_quiet_nan)
          call h5dwrite_f(out%series%dset(k), H5T_NATIVE_DOUBLE, nan, [int(size(nan), hsize_t)], h, &
                          mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
        end if
        if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
      end if
      call close_spaces(fspace, mspace, name, ierr, errmsg)
    end subroutine pad
  end procedure contact_series

end submodule output_contact
