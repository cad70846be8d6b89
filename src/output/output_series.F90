! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the lattice, the time series of every output step and the
!> XDMF views (virtual datasets) onto them.
submodule (output) output_series
  implicit none

contains

  !> Append one output step: extend all datasets, write this rank's strip and rank 0's scalars, flush. Collective.
  module procedure output_write_step

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_write_step: the output file is not open'
      return
    end if
    if (size(x, 1) /= 3 .or. size(x, 2) /= out%nx .or. size(x, 3) /= out%ym) then
      ierr = 1
      errmsg = 'output_write_step: x must be (3, nx, ym) for /position'
    else if (out%series%write_velocity .and. .not. present(v)) then
      ierr = 1
      errmsg = 'output_write_step: v is required for /velocity'
    else if (out%series%write_velocity) then
      if (size(v, 1) /= 3 .or. size(v, 2) /= out%nx .or. size(v, 3) /= out%ym) then
        ierr = 1
        errmsg = 'output_write_step: v must be (3, nx, ym) for /velocity'
      end if
    end if
    call agree(out%comm, 'output_write_step', ierr, errmsg)
    if (ierr /= 0) return
    call check_space(out, step_bytes(out), 'output step '//itoa(out%series%nt), ierr, errmsg)
    if (ierr /= 0) return

    if (out%series%write_velocity) then
      call write_step_local(out, rec, x, ierr, errmsg, v)
    else
      call write_step_local(out, rec, x, ierr, errmsg)
    end if
    call agree(out%comm, 'output_write_step', ierr, errmsg)
    if (ierr /= 0) call add_cause(out, errmsg)
    ! rec%steps > 0: a time step succeeded and its result is on disk: the
    ! file is a result now (an error exit keeps it), and takes the output's
    ! name unless that would replace an earlier result before this run
    ! completes (output_close; -nuno_overwrite: now).
    if (ierr == 0 .and. rec%steps > 0) then
      if (.not. out%safe%stepped .and. out%rank == 0) call cleanup_drop(out%safe%work_path)
      out%safe%stepped = .true.
      if (.not. out%safe%had_earlier .or. out%safe%overwrite) call commit(out, ierr, errmsg)
    end if
    ! The memory parallel HDF5 keeps for the objects made so far (the views)
    if (ierr == 0 .and. mod(out%series%nt, REFRESH_STEPS) == 0) then
      call refresh_library(out, ierr, errmsg)
      call agree(out%comm, 'output_write_step', ierr, errmsg)
    end if
  end procedure output_write_step

  !> /lattice/rest_position (3, nx, ny) and /lattice/mass (nx, ny), each rank its rows.
  module procedure write_lattice
    integer(hid_t) :: dset
    integer(hsize_t) :: nx, ny, ys, ym

    nx = out%nx; ny = out%ny; ys = out%ys; ym = out%ym
    call create_fixed(out, '/lattice/rest_position', [3_hsize_t, nx, ny], &
                      'rest positions of the nodes [j][i][xyz]', dset, ierr, errmsg)
    if (ierr /= 0) return
    call write_rows(out%dxpl, dset, '/lattice/rest_position', [0_hsize_t, 0_hsize_t, ys], &
                     [3_hsize_t, nx, ym], rest, ierr, errmsg)
    call close_dset(dset, '/lattice/rest_position', ierr, errmsg)
    if (ierr /= 0) return

    call create_fixed(out, '/lattice/mass', [nx, ny], 'nodal masses [j][i]', dset, ierr, errmsg)
    if (ierr /= 0) return
    call write_rows(out%dxpl, dset, '/lattice/mass', [0_hsize_t, ys], [nx, ym], mass, ierr, errmsg)
    call close_dset(dset, '/lattice/mass', ierr, errmsg)
  end procedure write_lattice

  subroutine create_fixed(out, name, dims, description, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name, description
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer :: h

    dset = -1
    call h5screate_simple_f(size(dims), dims, space, h)
    if (h < 0) then
      call fail('h5screate_simple_f', name, ierr, errmsg); return
    end if
    call h5dcreate_f(out%file, name, H5T_NATIVE_DOUBLE, space, dset, h)
    if (h < 0) call fail('h5dcreate_f', name, ierr, errmsg)
    call h5sclose_f(space, h)
    if (h < 0) call fail('h5sclose_f', name, ierr, errmsg)
    if (ierr == 0) call set_attr_str(dset, 'description', description, name, ierr, errmsg)
  end subroutine create_fixed

  ! ---------------------------------------------------------------------------
  ! XDMF views: HDF5 virtual datasets in /xdmf that map a part of a dataset
  ! of the same file (source file '.', so a renamed or moved file keeps
  ! them). Shapes have a leading 1 (one layer of points, the sidecar's
  ! 3DSMesh "1 ny nx"): /xdmf/position_<k>, /xdmf/velocity_<k> [1][ny][nx][3]
  ! (step k, 0-based), /xdmf/rest_position [1][ny][nx][3], /xdmf/mass
  ! [1][ny][nx]. Creating or deleting one is metadata only; every rank
  ! makes the same calls.

  !> The group /xdmf and its views of the lattice, made when missing.
  module procedure lattice_views
    integer(hid_t) :: grp
    integer(hsize_t) :: nx, ny
    logical :: exists
    integer :: h

    nx = out%nx; ny = out%ny
    call open_or_create_group(out%file, '/xdmf', grp, ierr, errmsg)
    if (ierr == 0) call set_attr_str(grp, 'description', 'views for the XDMF sidecar NAME.xdmf: '// &
      'HDF5 virtual datasets (no data of their own) of /lattice and of step k of /position and /velocity, '// &
      'shaped [1][ny][nx](3); only the first n_output_steps steps are complete', '/xdmf', ierr, errmsg)
    call close_group(grp, '/xdmf', ierr, errmsg)
    if (ierr /= 0) return
    call h5lexists_f(out%file, '/xdmf/rest_position', exists, h)
    if (h < 0) then
      call fail('h5lexists_f', '/xdmf/rest_position', ierr, errmsg); return
    end if
    if (.not. exists) call make_view(out, 'rest_position', '/lattice/rest_position', [0_hsize_t, 0_hsize_t, 0_hsize_t], &
                                     [3_hsize_t, nx, ny], ierr, errmsg)
    if (ierr /= 0) return
    call h5lexists_f(out%file, '/xdmf/mass', exists, h)
    if (h < 0) then
      call fail('h5lexists_f', '/xdmf/mass', ierr, errmsg); return
    end if
    if (.not. exists) call make_view(out, 'mass', '/lattice/mass', [0_hsize_t, 0_hsize_t], [nx, ny], ierr, errmsg)
  end procedure lattice_views

  !> /xdmf/<name>: a virtual dataset of Fortran dims (count..., 1) (C order
  !> [1][...]) that maps the hyperslab (start, count) of the dataset src of
  !> this file, counted the source's way (a t index stays in count as 1).
  module procedure make_view
    integer(hid_t) :: sdset, sspace, vspace, dcpl, dset
    integer(hsize_t) :: vdims(4)
    integer :: h, r
    character(len=:), allocatable :: path

    if (ierr /= 0) return
    path = '/xdmf/'//name
    ! The view's dims: the source's selection without its t index, then 1.
    r = size(count)
    if (size(count) == 4) r = 3
    vdims(1:r) = count(1:r)
    vdims(r + 1) = 1
    sdset = -1; sspace = -1; vspace = -1; dcpl = -1
    call h5dopen_f(out%file, src, sdset, h)
    if (h < 0) then
      call fail('h5dopen_f', src, ierr, errmsg); return
    end if
    call h5dget_space_f(sdset, sspace, h)
    if (h < 0) then
      sspace = -1
      call fail('h5dget_space_f', src, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5sselect_hyperslab_f(sspace, H5S_SELECT_SET_F, start, count, h)
      if (h < 0) call fail('h5sselect_hyperslab_f', src//' for '//path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5screate_simple_f(r + 1, vdims(1:r + 1), vspace, h)
      if (h < 0) then
        vspace = -1
        call fail('h5screate_simple_f', path, ierr, errmsg)
      end if
    end if
    if (ierr == 0) then
      call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, h)
      if (h < 0) then
        dcpl = -1
        call fail('h5pcreate_f(dataset create)', path, ierr, errmsg)
      end if
    end if
    if (ierr == 0) then
      call h5pset_virtual_f(dcpl, vspace, '.', src, sspace, h)
      if (h < 0) call fail('h5pset_virtual_f', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5dcreate_f(out%file, path, H5T_NATIVE_DOUBLE, vspace, dset, h, dcpl_id=dcpl)
      if (h < 0) then
        call fail('h5dcreate_f(virtual)', path, ierr, errmsg)
      else
        call close_dset(dset, path, ierr, errmsg)
      end if
    end if
    if (dcpl >= 0) then
      call h5pclose_f(dcpl, h)
      if (h < 0) call fail('h5pclose_f(dataset create)', path, ierr, errmsg)
    end if
    call close_spaces(sspace, vspace, path, ierr, errmsg)
    call close_dset(sdset, src, ierr, errmsg)
  end procedure make_view

  !> Delete /xdmf/<name> if it is there (its link; the few bytes of its
  !> header stay in the file).
  subroutine drop_view(out, name, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h

    if (ierr /= 0) return
    call h5lexists_f(out%file, '/xdmf/'//name, exists, h)
    if (h < 0) then
      call fail('h5lexists_f', '/xdmf/'//name, ierr, errmsg); return
    end if
    if (exists) then
      call h5ldelete_f(out%file, '/xdmf/'//name, h)
      if (h < 0) call fail('h5ldelete_f', '/xdmf/'//name, ierr, errmsg)
    end if
  end subroutine drop_view

  !> The name in /xdmf of the view of step k (0-based) of /position or /velocity.
  module procedure step_view
    name = trim(dset_names(idx)(2:))//'_'//itoa(k)
  end procedure step_view

  !> An extendable dataset: Fortran dims (fixed..., 0), unlimited along t, chunked.
  module procedure create_series
    integer(hsize_t) :: dims(4), maxdims(4)
    integer :: r
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    r = size(fixed) + 1
    dims(1:r) = [fixed, 0_hsize_t]
    maxdims(1:r) = [fixed, H5S_UNLIMITED_F]
    out%series%drank(idx) = r
    out%series%ddims(1:r, idx) = dims(1:r)
    call create_dataset(out%file, name, ftype, dims(1:r), out%series%dset(idx), ierr, errmsg, maxdims(1:r), chunk)
    if (ierr == 0) call set_attr_str(out%series%dset(idx), 'description', trim(dset_descriptions(idx)), name, ierr, errmsg)
  end procedure create_series

  ! ---------------------------------------------------------------------------
  ! One output step.

  !> Every collective call is followed by an agreement on its error
  !> (agree): a rank whose write failed (a full disk shows on the MPI-IO
  !> aggregators only) must not leave the others waiting in the next
  !> collective call. So all ranks stop at the same call, with the message of
  !> the first rank that failed.
  subroutine write_step_local(out, rec, x, ierr, errmsg, v)
    type(output_file), intent(inout) :: out
    type(output_record), intent(in) :: rec
    real(rp), intent(in) :: x(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp), intent(in), optional :: v(:, :, :)
    integer(hsize_t) :: t, nx, ys, ym
    integer :: i, h
    real(rp), allocatable :: grown(:)

    t = out%series%nt   ! 0-based index of the new step
    nx = out%nx; ys = out%ys; ym = out%ym

    ! Extend every dataset by one step (collective).
    do i = 1, n_dsets
      if (out%series%dset(i) < 0) cycle
      out%series%ddims(out%series%drank(i), i) = t + 1
      call h5dset_extent_f(out%series%dset(i), out%series%ddims(1:out%series%drank(i), i), h)
      if (h < 0) call fail('h5dset_extent_f', trim(dset_names(i)), ierr, errmsg)
      if (.not. all_ok()) return
    end do

    ! Strips, each rank its rows.
    call write_rows(out%dxpl, out%series%dset(d_position), '/position', [0_hsize_t, 0_hsize_t, ys, t], &
                     [3_hsize_t, nx, ym, 1_hsize_t], x, ierr, errmsg)
    if (.not. all_ok()) return
    if (out%series%write_velocity) then
      call write_rows(out%dxpl, out%series%dset(d_velocity), '/velocity', [0_hsize_t, 0_hsize_t, ys, t], &
                       [3_hsize_t, nx, ym, 1_hsize_t], v, ierr, errmsg)
      if (.not. all_ok()) return
    end if

    ! Scalars: rank 0 writes, the others join with an empty selection.
    call write_reals(out, d_time, [rec%time], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_kinetic, [rec%kinetic], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_stretch, [rec%stretch], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_bend, [rec%bend], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_dissipated, [rec%dissipated], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_external_work, [rec%external_work], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_momentum, rec%momentum, ierr, errmsg)
    if (all_ok()) call write_reals(out, d_angular_momentum, rec%angular_momentum, ierr, errmsg)
    if (all_ok()) call write_reals(out, d_length, [rec%length], ierr, errmsg)
    if (all_ok()) call write_reals(out, d_flatness, [rec%flatness], ierr, errmsg)
    if (all_ok()) call write_int(out, d_steps, rec%steps, ierr, errmsg)
    if (all_ok()) call write_int(out, d_rejected_steps, rec%rejected_steps, ierr, errmsg)
    if (all_ok()) call write_int(out, d_newton_iterations, rec%newton_iterations, ierr, errmsg)
    if (all_ok()) call write_int(out, d_linear_iterations, rec%linear_iterations, ierr, errmsg)
    ! Created by output_write_run_info; absent for callers that never call it.
    if (all_ok() .and. out%series%dset(d_wall_time) >= 0) call write_reals(out, d_wall_time, [rec%wall_time], ierr, errmsg)
    if (.not. all_ok()) return
    ! Contact: scenes with obstacles only (output_contact).
    if (out%series%contact) then
      call write_reals(out, d_barrier, [rec%barrier], ierr, errmsg)
      if (all_ok()) call write_int(out, d_contact_active, rec%contact_active, ierr, errmsg)
      if (all_ok()) call write_reals(out, d_contact_force, rec%contact_force, ierr, errmsg)
      if (all_ok()) call write_reals(out, d_normal_force, rec%normal_force, ierr, errmsg)
      if (all_ok()) call write_reals(out, d_friction_work, [rec%friction_work], ierr, errmsg)
      if (all_ok()) call write_reals(out, d_barrier_energy, [rec%barrier], ierr, errmsg)
      if (all_ok()) call write_reals(out, d_min_gap, [rec%min_gap], ierr, errmsg)
      if (all_ok()) call write_reals(out, d_min_gap_run, [rec%min_gap_run], ierr, errmsg)
      if (all_ok()) call write_int(out, d_states_checked, rec%states_checked, ierr, errmsg)
      if (.not. all_ok()) return
    end if

    ! The step's views for the XDMF sidecar (metadata only). None of this
    ! step is there: a new file has none, output_reopen deleted those of the
    ! steps it cut off (sync_views); were one there, h5dcreate_f would fail.
    do i = d_position, d_velocity
      if (out%series%dset(i) < 0) cycle
      call make_view(out, step_view(i, out%series%nt), trim(dset_names(i)), [0_hsize_t, 0_hsize_t, 0_hsize_t, t], &
                     [3_hsize_t, nx, int(out%ny, hsize_t), 1_hsize_t], ierr, errmsg)
      if (.not. all_ok()) return
    end do

    ! The step is complete: count it, then flush so that a later crash keeps it.
    call set_attr_int(out%file, 'n_output_steps', out%series%nt + 1, '/', ierr, errmsg)
    if (.not. all_ok()) return
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', '/', ierr, errmsg)
    if (.not. all_ok()) return
    out%series%nt = out%series%nt + 1
    if (out%series%nt > size(out%series%times)) then
      allocate(grown(2*size(out%series%times)))
      grown(1:size(out%series%times)) = out%series%times
      call move_alloc(grown, out%series%times)
    end if
    out%series%times(out%series%nt) = rec%time
    if (out%rank == 0 .and. out%safe%committed) call write_xdmf(out, ierr, errmsg)
  contains
    logical function all_ok()
      call agree(out%comm, 'output', ierr, errmsg)
      all_ok = ierr == 0
    end function all_ok
  end subroutine write_step_local

  !> Step t of a real series ([t] or [t][k]): rank 0 writes vals, the others nothing.
  subroutine write_reals(out, idx, vals, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: idx
    real(rp), intent(in) :: vals(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer(hsize_t) :: start(2), count(2)
    integer :: r, h
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    r = out%series%drank(idx)
    start(1:r) = 0
    start(r) = out%series%nt
    count(1:r) = out%series%ddims(1:r, idx)
    count(r) = 1
    call select_spaces(out%series%dset(idx), name, start(1:r), count(1:r), out%rank /= 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dwrite_f(out%series%dset(idx), H5T_NATIVE_DOUBLE, vals, [int(size(vals), hsize_t)], h, &
                      mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_reals

  !> Step t of an integer series [t], stored as 64-bit integers.
  subroutine write_int(out, idx, val, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: idx, val
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer(int64) :: buf(1)
    integer :: h
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    buf(1) = val
    call select_spaces(out%series%dset(idx), name, [int(out%series%nt, hsize_t)], [1_hsize_t], out%rank /= 0, &
                       fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dwrite_f(out%series%dset(idx), h5kind_to_type(int64, H5_INTEGER_KIND), buf, [1_hsize_t], h, &
                      mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine write_int

  !> Open the time series of an existing file and cut them to nt steps;
  !> extent: the steps /position had before (a killed run: n_output_steps + 1).
  module procedure open_series
    integer(hid_t) :: space
    integer(hsize_t) :: dims(4), maxdims(4)
    integer :: i, h, r, have
    logical :: exists
    integer(hid_t) :: fspace, mspace

    extent = 0
    call get_attr_int(out%file, 'n_output_steps', '/', have, ierr, errmsg)
    if (ierr /= 0) return
    ! the contact series, where the file has them (a scene with obstacles)
    call h5lexists_f(out%file, '/contact', out%series%contact, h)
    if (h < 0) then
      call fail('h5lexists_f', '/contact', ierr, errmsg); return
    end if
    if (nt > have .or. nt < 1) then
      ierr = 1
      errmsg = '-nuno_restart: the checkpoint counts '//itoa(nt)//' output steps, the file holds '//itoa(have)
      return
    end if
    do i = 1, n_dsets
      if (i == d_velocity .and. .not. out%series%write_velocity) cycle
      if (i >= d_contact_first .and. .not. out%series%contact) cycle
      call h5lexists_f(out%file, trim(dset_names(i)), exists, h)
      if (h < 0) then
        call fail('h5lexists_f', trim(dset_names(i)), ierr, errmsg); return
      end if
      if (.not. exists) then
        if (i == d_wall_time) cycle   ! files of callers that never wrote /run
        if (i >= d_contact_first) cycle   ! made by contact_series (output_write_run_info)
        ierr = 1
        errmsg = '-nuno_restart: the file has no '//trim(dset_names(i))
        return
      end if
      call h5dopen_f(out%file, trim(dset_names(i)), out%series%dset(i), h)
      if (h < 0) then
        call fail('h5dopen_f', trim(dset_names(i)), ierr, errmsg); return
      end if
      call h5dget_space_f(out%series%dset(i), space, h)
      if (h < 0) then
        call fail('h5dget_space_f', trim(dset_names(i)), ierr, errmsg); return
      end if
      call h5sget_simple_extent_ndims_f(space, r, h)
      if (h >= 0) call h5sget_simple_extent_dims_f(space, dims(1:r), maxdims(1:r), h)
      call h5sclose_f(space, h)
      if (i == d_position) extent = int(dims(r))
      out%series%drank(i) = r
      out%series%ddims(1:r, i) = dims(1:r)
      out%series%ddims(r, i) = int(nt, hsize_t)
      call h5dset_extent_f(out%series%dset(i), out%series%ddims(1:r, i), h)
      if (h < 0) then
        call fail('h5dset_extent_f', trim(dset_names(i)), ierr, errmsg); return
      end if
    end do
    out%series%nt = nt
    if (allocated(out%series%times)) deallocate(out%series%times)
    allocate(out%series%times(max(16, 2 * nt)))
    call select_spaces(out%series%dset(d_time), '/time', [0_hsize_t], [int(nt, hsize_t)], .false., fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dread_f(out%series%dset(d_time), H5T_NATIVE_DOUBLE, out%series%times(1:nt), [int(nt, hsize_t)], h, &
                     mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dread_f', '/time', ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, '/time', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_output_steps', nt, '/', ierr, errmsg)
  end procedure open_series

  !> After open_series cut the series to out%nt steps: delete the views of
  !> steps out%nt .. extent-1 (and any later ones), make those of the kept steps and of the
  !> lattice where missing. Collective; every call that changes the file is
  !> agreed on before the next.
  module procedure sync_views
    integer :: i, k, h
    logical :: exists

    call lattice_views(out, ierr, errmsg)
    if (.not. all_ok()) return
    do i = d_position, d_velocity
      if (out%series%dset(i) < 0) cycle
      ! Views are made in step order: delete up to the extent, and on
      ! while there are more (left by an earlier cut that did not finish).
      k = out%series%nt
      do
        call h5lexists_f(out%file, '/xdmf/'//step_view(i, k), exists, h)
        if (h < 0) call fail('h5lexists_f', '/xdmf/'//step_view(i, k), ierr, errmsg)
        if (ierr == 0 .and. .not. exists .and. k >= extent) exit
        if (ierr == 0 .and. exists) call drop_view(out, step_view(i, k), ierr, errmsg)
        if (.not. all_ok()) return
        k = k + 1
      end do
      do k = 0, out%series%nt - 1
        call h5lexists_f(out%file, '/xdmf/'//step_view(i, k), exists, h)
        if (h < 0) call fail('h5lexists_f', '/xdmf/'//step_view(i, k), ierr, errmsg)
        if (ierr == 0 .and. .not. exists) &
          call make_view(out, step_view(i, k), trim(dset_names(i)), [0_hsize_t, 0_hsize_t, 0_hsize_t, int(k, hsize_t)], &
                         [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t), 1_hsize_t], ierr, errmsg)
        if (.not. all_ok()) return
      end do
    end do
  contains
    logical function all_ok()
      call agree(out%comm, '-nuno_restart', ierr, errmsg)
      all_ok = ierr == 0
    end function all_ok
  end procedure sync_views

end submodule output_series
