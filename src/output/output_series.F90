! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the lattice, the time series of every output step and the
!> XDMF views (virtual datasets) onto them.
submodule (output) output_series
  implicit none

  character(len=*), parameter :: STEP = 'output'   ! agree's name of an output step's writes

contains

  !> Append one output step: extend all datasets, write this rank's strip and rank 0's scalars, flush. Collective.
  module procedure output_write_step

    call require_open(out, 'output_write_step', ierr, errmsg)
    if (ierr /= 0) return
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

  !> A dataset of the lattice (float64, written once) with its description.
  subroutine create_fixed(out, name, dims, description, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: name, description
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg

    call create_doubles(out%file, name, name, dims, dset, ierr, errmsg)
    call set_attr_str(dset, 'description', description, name, ierr, errmsg)
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

    nx = out%nx; ny = out%ny
    call open_or_create_group(out%file, '/xdmf', grp, ierr, errmsg)
    call set_attr_str(grp, 'description', 'views for the XDMF sidecar NAME.xdmf: '// &
      'HDF5 virtual datasets (no data of their own) of /lattice and of step k of /position and /velocity, '// &
      'shaped [1][ny][nx](3); only the first n_output_steps steps are complete', '/xdmf', ierr, errmsg)
    call close_group(grp, '/xdmf', ierr, errmsg)
    if (ierr /= 0) return
    call has_link(out%file, '/xdmf/rest_position', '/xdmf/rest_position', exists, ierr, errmsg)
    if (ierr == 0 .and. .not. exists) call make_view(out, 'rest_position', '/lattice/rest_position', &
                                                     [0_hsize_t, 0_hsize_t, 0_hsize_t], [3_hsize_t, nx, ny], ierr, errmsg)
    if (ierr /= 0) return
    call has_link(out%file, '/xdmf/mass', '/xdmf/mass', exists, ierr, errmsg)
    if (ierr == 0 .and. .not. exists) call make_view(out, 'mass', '/lattice/mass', [0_hsize_t, 0_hsize_t], [nx, ny], &
                                                     ierr, errmsg)
  end procedure lattice_views

  !> /xdmf/<name>: a virtual dataset of Fortran dims (count..., 1) (C order
  !> [1][...]) that maps the hyperslab (start, count) of the dataset src of
  !> this file, counted the source's way (a t index stays in count as 1).
  module procedure make_view
    integer(hsize_t) :: vdims(4)
    integer :: r

    ! The view's dims: the source's selection without its t index, then 1.
    r = size(count)
    if (size(count) == 4) r = 3
    vdims(1:r) = count(1:r)
    vdims(r + 1) = 1
    call make_view_dims(out, name, src, start, count, vdims(1:r + 1), ierr, errmsg)
  end procedure make_view

  !> /xdmf/<name>: a virtual dataset of Fortran dims vdims that maps the
  !> hyperslab (start, count) of the dataset src of this file (as many
  !> values).
  module procedure make_view_dims
    integer(hid_t) :: sdset, sspace, vspace
    integer :: h
    character(len=:), allocatable :: path

    if (ierr /= 0) return
    path = '/xdmf/'//name
    sspace = -1
    call open_dset(out%file, src, sdset, ierr, errmsg)
    if (ierr /= 0) return
    call h5dget_space_f(sdset, sspace, h)
    if (h < 0) then
      sspace = -1
      call fail('h5dget_space_f', src, ierr, errmsg)
    else
      call h5sselect_hyperslab_f(sspace, H5S_SELECT_SET_F, start, count, h)
      if (h < 0) call fail('h5sselect_hyperslab_f', src//' for '//path, ierr, errmsg)
    end if
    call new_space(vdims, path, vspace, ierr, errmsg)
    if (ierr == 0) call create_virtual(out, path, vspace, src, sspace, ierr, errmsg)
    call close_spaces(sspace, vspace, path, ierr, errmsg)
    call close_dset(sdset, src, ierr, errmsg)
  end procedure make_view_dims

  !> The virtual dataset `path` of space vspace that maps the selection of
  !> sspace of the dataset src of this file (source file '.').
  subroutine create_virtual(out, path, vspace, src, sspace, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: path, src
    integer(hid_t), intent(in) :: vspace, sspace
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dcpl, dset
    integer :: h

    call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, h)
    if (h < 0) then
      call fail('h5pcreate_f(dataset create)', path, ierr, errmsg); return
    end if
    call h5pset_virtual_f(dcpl, vspace, '.', src, sspace, h)
    if (h < 0) call fail('h5pset_virtual_f', path, ierr, errmsg)
    if (ierr == 0) then
      call h5dcreate_f(out%file, path, H5T_NATIVE_DOUBLE, vspace, dset, h, dcpl_id=dcpl)
      if (h < 0) then
        call fail('h5dcreate_f(virtual)', path, ierr, errmsg)
      else
        call close_dset(dset, path, ierr, errmsg)
      end if
    end if
    call h5pclose_f(dcpl, h)
    if (h < 0) call fail('h5pclose_f(dataset create)', path, ierr, errmsg)
  end subroutine create_virtual

  !> Delete /xdmf/<name> if it is there (its link; the few bytes of its
  !> header stay in the file).
  module procedure drop_view
    logical :: exists
    integer :: h

    if (ierr /= 0) return
    call has_link(out%file, '/xdmf/'//name, '/xdmf/'//name, exists, ierr, errmsg)
    if (exists) then
      call h5ldelete_f(out%file, '/xdmf/'//name, h)
      if (h < 0) call fail('h5ldelete_f', '/xdmf/'//name, ierr, errmsg)
    end if
  end procedure drop_view

  !> The name in /xdmf of the view of step k (0-based) of /position or /velocity.
  module procedure step_view
    name = trim(dset_names(idx)(2:))//'_'//itoa(k)
  end procedure step_view

  !> The series idx, empty: Fortran dims (fixed..., 0), unlimited along t,
  !> chunked: a strip (3, nx, ny) in chunks of whole rows of one step (at
  !> most ~1 GiB), a 3-vector or a scalar in chunks of scalar_chunk steps;
  !> 64-bit integers for counts, float64 otherwise.
  module procedure create_series
    integer(hsize_t) :: dims(4), maxdims(4), chunk(4), rows
    integer(hid_t) :: ftype
    integer :: r
    character(len=:), allocatable :: name

    name = trim(dset_names(idx))
    if (idx == d_position .or. idx == d_velocity) then
      rows = max(1_hsize_t, min(int(out%ny, hsize_t), (2_hsize_t**30)/(24_hsize_t*out%nx)))
      r = 4
      dims = [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t), 0_hsize_t]
      chunk = [3_hsize_t, int(out%nx, hsize_t), rows, 1_hsize_t]
    else if (any(vector_series == idx)) then
      r = 2
      dims(1:2) = [3_hsize_t, 0_hsize_t]
      chunk(1:2) = [3_hsize_t, scalar_chunk]
    else
      r = 1
      dims(1) = 0
      chunk(1) = scalar_chunk
    end if
    maxdims(1:r) = dims(1:r)
    maxdims(r) = H5S_UNLIMITED_F
    ftype = H5T_NATIVE_DOUBLE
    if (any(count_series == idx)) ftype = H5T_STD_I64LE
    out%series%drank(idx) = r
    out%series%ddims(1:r, idx) = dims(1:r)
    call create_extendable(out%file, name, ftype, dims(1:r), maxdims(1:r), chunk(1:r), out%series%dset(idx), ierr, errmsg)
    call set_attr_str(out%series%dset(idx), 'description', trim(dset_descriptions(idx)), name, ierr, errmsg)
  end procedure create_series

  ! ---------------------------------------------------------------------------
  ! One output step.

  !> One output step's writes. Every collective call is followed by an
  !> agreement on its error (all_agree): a rank whose write failed (a full
  !> disk shows on the MPI-IO aggregators only) must not leave the others
  !> waiting in the next collective call. So all ranks stop at the same
  !> call, with the message of the first rank that failed.
  subroutine write_step_local(out, rec, x, ierr, errmsg, v)
    type(output_file), intent(inout) :: out
    type(output_record), intent(in) :: rec
    real(rp), intent(in) :: x(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp), intent(in), optional :: v(:, :, :)   ! present when the file has /velocity
    integer(hsize_t) :: t, at(4), strip(4)

    t = out%series%nt   ! 0-based index of the new step
    call extend_series(out, t, ierr, errmsg)
    if (ierr /= 0) return
    ! Strips, each rank its rows.
    at = [0_hsize_t, 0_hsize_t, int(out%ys, hsize_t), t]
    strip = [3_hsize_t, int(out%nx, hsize_t), int(out%ym, hsize_t), 1_hsize_t]
    call write_rows(out%dxpl, out%series%dset(d_position), '/position', at, strip, x, ierr, errmsg)
    if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    if (out%series%write_velocity) then
      call write_rows(out%dxpl, out%series%dset(d_velocity), '/velocity', at, strip, v, ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end if
    call write_scalars(out, rec, ierr, errmsg)
    if (ierr == 0) call write_step_views(out, t, ierr, errmsg)
    ! the moving obstacles' vertices at this step (none without obstacles)
    if (ierr == 0) call obstacles_step(out, rec%time, ierr, errmsg)
    if (ierr == 0) call count_step(out, rec%time, ierr, errmsg)
  end subroutine write_step_local

  !> Extend every series by one step, to t + 1 steps (collective).
  subroutine extend_series(out, t, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer(hsize_t), intent(in) :: t
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: i, h

    do i = 1, n_dsets
      if (out%series%dset(i) < 0) cycle
      out%series%ddims(out%series%drank(i), i) = t + 1
      call h5dset_extent_f(out%series%dset(i), out%series%ddims(1:out%series%drank(i), i), h)
      if (h < 0) call fail('h5dset_extent_f', trim(dset_names(i)), ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end do
    call pm_series_extend(out, t, ierr, errmsg)
  end subroutine extend_series

  !> The step's scalars, series by series in their order, then the
  !> process models' (output_pm): rank 0 writes, the others join with an
  !> empty selection; each write is agreed on.
  subroutine write_scalars(out, rec, ierr, errmsg)
    type(output_file), intent(in) :: out
    type(output_record), intent(in) :: rec
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp) :: v(3)
    integer :: i, n

    do i = d_time, n_dsets
      if (i == d_position .or. i == d_velocity) cycle
      ! Created by output_write_run_info; absent for callers that never call it.
      if (i == d_wall_time .and. out%series%dset(i) < 0) cycle
      if (any(count_series == i)) then
        call write_int(out, i, record_count(rec, i), ierr, errmsg)
      else
        call record_reals(rec, i, v, n)
        call write_reals(out, i, v(1:n), ierr, errmsg)
      end if
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end do
    if (allocated(rec%pm_series)) then
      call pm_series_write(out, rec%pm_series, ierr, errmsg)
    else
      call pm_series_write(out, [pm_series_t ::], ierr, errmsg)
    end if
  end subroutine write_scalars

  !> The record's values v(1:n) for the float64 series idx.
  subroutine record_reals(rec, idx, v, n)
    type(output_record), intent(in) :: rec
    integer, intent(in) :: idx
    real(rp), intent(out) :: v(3)
    integer, intent(out) :: n

    n = 1
    v = 0
    select case (idx)
    case (d_time); v(1) = rec%time
    case (d_kinetic); v(1) = rec%kinetic
    case (d_stretch); v(1) = rec%stretch
    case (d_bend); v(1) = rec%bend
    case (d_dissipated); v(1) = rec%dissipated
    case (d_external_work); v(1) = rec%external_work
    case (d_length); v(1) = rec%length
    case (d_flatness); v(1) = rec%flatness
    case (d_wall_time); v(1) = rec%wall_time
    case (d_momentum); n = 3; v = rec%momentum
    case (d_angular_momentum); n = 3; v = rec%angular_momentum
    end select
  end subroutine record_reals

  !> The record's count for the series idx (one of count_series).
  integer function record_count(rec, idx) result(c)
    type(output_record), intent(in) :: rec
    integer, intent(in) :: idx

    select case (idx)
    case (d_steps); c = rec%steps
    case (d_rejected_steps); c = rec%rejected_steps
    case (d_newton_iterations); c = rec%newton_iterations
    case default; c = rec%linear_iterations
    end select
  end function record_count

  !> The views of step t (0-based) for the XDMF sidecar (metadata only).
  !> None of this step is there: a new file has none, output_reopen deleted
  !> those of the steps it cut off (sync_views); were one there,
  !> h5dcreate_f would fail.
  subroutine write_step_views(out, t, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hsize_t), intent(in) :: t
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: i

    do i = d_position, d_velocity
      if (out%series%dset(i) < 0) cycle
      call make_view(out, step_view(i, out%series%nt), trim(dset_names(i)), [0_hsize_t, 0_hsize_t, 0_hsize_t, t], &
                     [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t), 1_hsize_t], ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end do
  end subroutine write_step_views

  !> The step is complete: count it, then flush so that a later crash keeps
  !> it; then its time for the sidecar, and the sidecar (once committed).
  subroutine count_step(out, time, ierr, errmsg)
    type(output_file), intent(inout) :: out
    real(rp), intent(in) :: time
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp), allocatable :: grown(:)
    integer :: h

    call set_attr_int(out%file, 'n_output_steps', out%series%nt + 1, '/', ierr, errmsg)
    if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', '/', ierr, errmsg)
    if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    out%series%nt = out%series%nt + 1
    if (out%series%nt > size(out%series%times)) then
      allocate(grown(2*size(out%series%times)))
      grown(1:size(out%series%times)) = out%series%times
      call move_alloc(grown, out%series%times)
    end if
    out%series%times(out%series%nt) = time
    if (out%rank == 0 .and. out%safe%committed) call write_xdmf(out, ierr, errmsg)
  end subroutine count_step

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
    integer(hsize_t) :: dims(4)
    integer :: i, r, h, have
    logical :: exists
    character(len=:), allocatable :: name

    extent = 0
    call get_attr_int(out%file, 'n_output_steps', '/', have, ierr, errmsg)
    if (ierr /= 0) return
    if (nt > have .or. nt < 1) then
      ierr = 1
      errmsg = '-nuno_restart: the checkpoint counts '//itoa(nt)//' output steps, the file holds '//itoa(have)
      return
    end if
    do i = 1, n_dsets
      if (i == d_velocity .and. .not. out%series%write_velocity) cycle
      name = trim(dset_names(i))
      call has_link(out%file, name, name, exists, ierr, errmsg)
      if (ierr /= 0) return
      if (.not. exists) then
        if (i == d_wall_time) cycle   ! files of callers that never wrote /run
        ierr = 1
        errmsg = '-nuno_restart: the file has no '//name
        return
      end if
      call open_dset(out%file, name, out%series%dset(i), ierr, errmsg)
      call dset_dims(out%series%dset(i), name, r, dims, ierr, errmsg)
      if (ierr /= 0) return
      if (i == d_position) extent = int(dims(r))
      out%series%drank(i) = r
      out%series%ddims(1:r, i) = dims(1:r)
      out%series%ddims(r, i) = int(nt, hsize_t)
      call h5dset_extent_f(out%series%dset(i), out%series%ddims(1:r, i), h)
      if (h < 0) then
        call fail('h5dset_extent_f', name, ierr, errmsg); return
      end if
    end do
    out%series%nt = nt
    call read_times(out, ierr, errmsg)
    call set_attr_int(out%file, 'n_output_steps', nt, '/', ierr, errmsg)
  end procedure open_series

  !> The output times of the series' nt steps (for the sidecar) from /time.
  subroutine read_times(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer :: nt, h

    nt = out%series%nt
    if (allocated(out%series%times)) deallocate(out%series%times)
    allocate(out%series%times(max(16, 2 * nt)))
    call select_spaces(out%series%dset(d_time), '/time', [0_hsize_t], [int(nt, hsize_t)], .false., fspace, mspace, &
                       ierr, errmsg)
    if (ierr == 0) then
      call h5dread_f(out%series%dset(d_time), H5T_NATIVE_DOUBLE, out%series%times(1:nt), [int(nt, hsize_t)], h, &
                     mem_space_id=mspace, file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dread_f', '/time', ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, '/time', ierr, errmsg)
  end subroutine read_times

  !> After open_series cut the series to out%nt steps: delete the views of
  !> steps out%nt .. extent-1 (and any later ones), make those of the kept steps and of the
  !> lattice where missing. Collective; every call that changes the file is
  !> agreed on before the next.
  module procedure sync_views
    integer :: i, k
    logical :: exists
    character(len=:), allocatable :: view

    call lattice_views(out, ierr, errmsg)
    if (.not. all_agree(out%comm, '-nuno_restart', ierr, errmsg)) return
    do i = d_position, d_velocity
      if (out%series%dset(i) < 0) cycle
      ! Views are made in step order: delete up to the extent, and on
      ! while there are more (left by an earlier cut that did not finish).
      k = out%series%nt
      do
        view = step_view(i, k)
        call has_link(out%file, '/xdmf/'//view, '/xdmf/'//view, exists, ierr, errmsg)
        if (ierr == 0 .and. .not. exists .and. k >= extent) exit
        if (exists) call drop_view(out, view, ierr, errmsg)
        if (.not. all_agree(out%comm, '-nuno_restart', ierr, errmsg)) return
        k = k + 1
      end do
      do k = 0, out%series%nt - 1
        view = step_view(i, k)
        call has_link(out%file, '/xdmf/'//view, '/xdmf/'//view, exists, ierr, errmsg)
        if (ierr == 0 .and. .not. exists) &
          call make_view(out, view, trim(dset_names(i)), [0_hsize_t, 0_hsize_t, 0_hsize_t, int(k, hsize_t)], &
                         [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t), 1_hsize_t], ierr, errmsg)
        if (.not. all_agree(out%comm, '-nuno_restart', ierr, errmsg)) return
      end do
    end do
  end procedure sync_views

end submodule output_series
