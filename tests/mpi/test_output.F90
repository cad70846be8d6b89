! SPDX-License-Identifier: BSD-2-Clause
!> MPI test of the parallel HDF5 output: strips of rows as a DMDA would give
!> them, known values written collectively, read back on rank 0 with the
!> serial HDF5 API (shapes, values, attributes, the XDMF views). Three files:
!>   a: 5 x 7 lattice with velocity, 3 steps, closed 'complete';
!>   b: 5 x 7 lattice, 2 steps, read back while still open (as after a crash);
!>   c: 4 x 2 lattice: on 3 ranks one rank has no rows.
program test_output
  use, intrinsic :: iso_fortran_env, only: int64
  use mpi
  use hdf5
  use kinds, only: rp
  use output, only: output_file, output_record, output_open, output_write_step, output_close
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  integer :: mpierr, rank, n_ranks
  character(len=64) :: tag

  call MPI_Init(mpierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, mpierr)
  call MPI_Comm_size(MPI_COMM_WORLD, n_ranks, mpierr)

  ! Names per rank count: CTest may run the np1 and np3 tests at the same time.
  write(tag, '(a,i0,a)') 'test_output_np', n_ranks, '_'
  call run_case(trim(tag)//'a.h5', 5, 7, .true., 3, .true.)
  call run_case(trim(tag)//'b.h5', 5, 7, .false., 2, .false.)
  call run_case(trim(tag)//'c.h5', 4, 2, .true., 2, .true.)
  call error_paths(trim(tag)//'d.h5')

  call check_report()
  call MPI_Finalize(mpierr)

contains

  !> Known values: node (i, j) at output step k (0-based).
  pure function x_expected(c, i, j, k) result(x)
    integer, intent(in) :: c, i, j, k
    real(rp) :: x
    select case (c)
    case (1); x = i
    case (2); x = j
    case default; x = 100.0_rp*k + i + 10.0_rp*j
    end select
  end function x_expected

  pure function mass_expected(i, j, nx) result(m)
    integer, intent(in) :: i, j, nx
    real(rp) :: m
    m = 1.0_rp + i + nx*j
  end function mass_expected

  subroutine run_case(filename, nx, ny, with_velocity, n_steps, do_close)
    character(*), intent(in) :: filename
    integer, intent(in) :: nx, ny, n_steps
    logical, intent(in) :: with_velocity, do_close
    type(output_file) :: out
    type(output_record) :: rec
    real(rp), allocatable :: rest(:, :, :), mass(:, :), x(:, :, :)
    integer :: ys, ym, i, j, k, ierr
    character(len=256) :: errmsg
    character(len=*), parameter :: nml = "&scene name='test' /"//new_line('a')//"&time t_end=1.0 /"

    ! Rows as PETSC_DECIDE distributes them: the first mod(ny, n_ranks) ranks get one more.
    ym = ny/n_ranks + merge(1, 0, rank < mod(ny, n_ranks))
    ys = rank*(ny/n_ranks) + min(rank, mod(ny, n_ranks))
    allocate(rest(3, 0:nx-1, ys:ys+ym-1), mass(0:nx-1, ys:ys+ym-1), x(3, 0:nx-1, ys:ys+ym-1))
    do j = ys, ys + ym - 1
      do i = 0, nx - 1
        rest(:, i, j) = [real(rp) :: i, j, 0]
        mass(i, j) = mass_expected(i, j, nx)
      end do
    end do

    ! A fresh start: an earlier run of this test left its files here, and
    ! nuno keeps an earlier result until a run completes (the case left
    ! open would then read the earlier file).
    if (rank == 0) then
      call remove_if_there(filename)
      call remove_if_there(filename//'.partial')
      call remove_if_there(filename//'.lock')
    end if
    call MPI_Barrier(MPI_COMM_WORLD, mpierr)
    call output_open(out, filename, MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, with_velocity, &
                     nml, '-ts_type alpha2 -snes_rtol 1e-10', ierr, errmsg)
    call check_true(ierr == 0, filename//': output_open: '//trim(errmsg))
    if (ierr /= 0) return

    do k = 0, n_steps - 1
      do j = ys, ys + ym - 1
        do i = 0, nx - 1
          x(:, i, j) = [x_expected(1, i, j, k), x_expected(2, i, j, k), x_expected(3, i, j, k)]
        end do
      end do
      rec%time = 0.5_rp*k
      rec%kinetic = 1.0_rp + k
      rec%external_work = -2.0_rp*k
      rec%momentum = [1.0_rp, 2.0_rp, 3.0_rp]*k
      rec%flatness = 0.25_rp*k
      rec%steps = 10*k
      rec%linear_iterations = 1000000*k
      if (with_velocity) then
        call output_write_step(out, rec, x, ierr, errmsg, v=-x)
      else
        call output_write_step(out, rec, x, ierr, errmsg)
      end if
      call check_true(ierr == 0, filename//': output_write_step: '//trim(errmsg))
      if (ierr /= 0) return
    end do

    if (do_close) then
      call output_close(out, 'complete', ierr, errmsg)
      call check_true(ierr == 0, filename//': output_close: '//trim(errmsg))
      ! A second close is a no-op.
      call output_close(out, 'complete', ierr, errmsg)
      call check_true(ierr == 0, filename//': second output_close')
      if (rank == 0) call check_file(filename, nx, ny, n_steps, with_velocity, 'complete')
    else
      ! Still open (as if the run died here): the flushed steps must be readable.
      if (rank == 0) call check_file(filename, nx, ny, n_steps, with_velocity, 'running')
      call MPI_Barrier(MPI_COMM_WORLD, mpierr)   ! keep the reader before the close below
      call output_close(out, 'failed: left open by the test', ierr, errmsg)
      call check_true(ierr == 0, filename//': output_close after the open-file check')
    end if
    call MPI_Barrier(MPI_COMM_WORLD, mpierr)     ! rank 0 reads before the next case
  end subroutine run_case

  subroutine remove_if_there(path)
    character(*), intent(in) :: path
    integer :: u, ios
    logical :: there
    inquire(file=path, exist=there)
    if (.not. there) return
    open(newunit=u, file=path, status='old', iostat=ios)
    if (ios == 0) close(u, status='delete')
  end subroutine remove_if_there

  !> Errors come back as ierr /= 0 with a message on every rank, never a stop.
  subroutine error_paths(filename)
    character(*), intent(in) :: filename
    type(output_file) :: out
    type(output_record) :: rec
    real(rp), allocatable :: rest(:, :, :), mass(:, :)
    integer :: ys, ym, ierr
    character(len=256) :: errmsg

    ym = 3/n_ranks + merge(1, 0, rank < mod(3, n_ranks))
    ys = rank*(3/n_ranks) + min(rank, mod(3, n_ranks))
    allocate(rest(3, 2, ym), mass(2, ym))
    rest = 0
    mass = 1
    ! Wrong row count on every rank: caught before any file is created.
    call output_open(out, filename, MPI_COMM_WORLD, 2, 3, ys, ym + 1, rest, mass, .false., '', '', ierr, errmsg)
    call check_true(ierr /= 0 .and. len_trim(errmsg) > 0, 'output_open with bad rows must fail')
    ! Write to a closed handle.
    call output_write_step(out, rec, rest, ierr, errmsg)
    call check_true(ierr /= 0, 'output_write_step on a closed handle must fail')
    ! A good open, then a step with the wrong shape, then a close that still works.
    call output_open(out, filename, MPI_COMM_WORLD, 2, 3, ys, ym, rest, mass, .false., '', '', ierr, errmsg)
    call check_true(ierr == 0, 'output_open: '//trim(errmsg))
    if (ierr /= 0) return
    call output_write_step(out, rec, rest(:, 1:1, :), ierr, errmsg)
    call check_true(ierr /= 0 .and. index(errmsg, '/position') > 0, 'output_write_step with a bad shape must fail')
    call output_close(out, 'failed: bad shape', ierr, errmsg)
    call check_true(ierr == 0, 'output_close after a failed step: '//trim(errmsg))
    call MPI_Barrier(MPI_COMM_WORLD, mpierr)
  end subroutine error_paths

  !> Serial read-back (rank 0 only).
  subroutine check_file(filename, nx, ny, nt, with_velocity, status)
    character(*), intent(in) :: filename, status
    integer, intent(in) :: nx, ny, nt
    logical, intent(in) :: with_velocity
    integer(hid_t) :: file
    integer :: h, i, j, k, c, ival
    integer(hsize_t), allocatable :: dims(:)
    real(rp), allocatable :: got(:), want(:)
    integer(int64), allocatable :: igot(:)
    character(len=64) :: sval
    logical :: exists

    call h5fopen_f(filename, H5F_ACC_RDONLY_F, file, h)
    call check_true(h == 0, filename//': h5fopen_f read-only')
    if (h /= 0) return

    call read_attr_str(file, 'status', sval)
    call check_true(sval == status, filename//': status = "'//trim(sval)//'", expected "'//status//'"')
    call read_attr_int(file, 'n_output_steps', ival)
    call check_true(ival == nt, filename//': n_output_steps')
    call read_attr_int(file, 'nx', ival)
    call check_true(ival == nx, filename//': attribute nx')
    call read_attr_int(file, 'ny', ival)
    call check_true(ival == ny, filename//': attribute ny')
    call read_attr_int(file, 'n_ranks', ival)
    call check_true(ival == n_ranks, filename//': attribute n_ranks')
    call read_attr_str(file, 'program_version', sval)
    call check_true(len_trim(sval) > 0, filename//': program_version')
    call read_attr_str(file, 'petsc_options', sval)
    call check_true(sval == '-ts_type alpha2 -snes_rtol 1e-10', filename//': petsc_options')

    ! /position: Fortran dims (3, nx, ny, nt) = C [nt][ny][nx][3].
    call read_real(file, '/position', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: 3, nx, ny, nt]), filename//': /position shape')
    allocate(want(3*nx*ny*nt))
    do k = 0, nt - 1
      do j = 0, ny - 1
        do i = 0, nx - 1
          do c = 1, 3
            want(1 + (c - 1) + 3*(i + nx*(j + ny*k))) = x_expected(c, i, j, k)
          end do
        end do
      end do
    end do
    if (size(got) == size(want)) call check_close_array(got, want, 0.0_rp, 0.0_rp, filename//': /position values')

    call h5lexists_f(file, 'velocity', exists, h)
    call check_true(h == 0 .and. (exists .eqv. with_velocity), filename//': /velocity present iff asked')
    if (with_velocity .and. exists) then
      call read_real(file, '/velocity', dims, got)
      call check_true(all(dims == [integer(hsize_t) :: 3, nx, ny, nt]), filename//': /velocity shape')
      if (size(got) == size(want)) call check_close_array(got, -want, 0.0_rp, 0.0_rp, filename//': /velocity values')
    end if

    ! The XDMF views (virtual datasets, C [1][ny][nx][3]) read as step k.
    do k = 0, nt - 1
      call read_real(file, '/xdmf/position_'//itoa(k), dims, got)
      call check_true(all(dims == [integer(hsize_t) :: 3, nx, ny, 1]), filename//': /xdmf/position_k shape')
      if (size(got) == 3*nx*ny) call check_close_array(got, want(1 + 3*nx*ny*k:3*nx*ny*(k + 1)), 0.0_rp, 0.0_rp, &
                                                       filename//': /xdmf/position_'//itoa(k)//' values')
      call h5lexists_f(file, '/xdmf/velocity_'//itoa(k), exists, h)
      call check_true(h == 0 .and. (exists .eqv. with_velocity), filename//': /xdmf/velocity_k present iff asked')
      if (with_velocity .and. exists) then
        call read_real(file, '/xdmf/velocity_'//itoa(k), dims, got)
        call check_true(all(dims == [integer(hsize_t) :: 3, nx, ny, 1]), filename//': /xdmf/velocity_k shape')
        if (size(got) == 3*nx*ny) call check_close_array(got, -want(1 + 3*nx*ny*k:3*nx*ny*(k + 1)), 0.0_rp, 0.0_rp, &
                                                         filename//': /xdmf/velocity_'//itoa(k)//' values')
      end if
    end do
    call h5lexists_f(file, '/xdmf/position_'//itoa(nt), exists, h)
    call check_true(h == 0 .and. .not. exists, filename//': no view of a step not written')
    call read_real(file, '/xdmf/mass', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: nx, ny, 1]), filename//': /xdmf/mass shape')
    if (size(got) == nx*ny) call check_close_array(got, [((mass_expected(i, j, nx), i = 0, nx - 1), j = 0, ny - 1)], &
                                                   0.0_rp, 0.0_rp, filename//': /xdmf/mass values')
    call read_real(file, '/xdmf/rest_position', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: 3, nx, ny, 1]), filename//': /xdmf/rest_position shape')

    call read_real(file, '/time', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: nt]), filename//': /time shape')
    if (size(got) == nt) call check_close_array(got, [(0.5_rp*k, k = 0, nt - 1)], 0.0_rp, 0.0_rp, filename//': /time values')

    call read_real(file, '/energy/kinetic', dims, got)
    if (size(got) == nt) call check_close_array(got, [(1.0_rp + k, k = 0, nt - 1)], 0.0_rp, 0.0_rp, filename//': kinetic')
    call read_real(file, '/energy/external_work', dims, got)
    if (size(got) == nt) call check_close_array(got, [(-2.0_rp*k, k = 0, nt - 1)], 0.0_rp, 0.0_rp, filename//': external_work')
    call read_real(file, '/diagnostics/flatness', dims, got)
    if (size(got) == nt) call check_close_array(got, [(0.25_rp*k, k = 0, nt - 1)], 0.0_rp, 0.0_rp, filename//': flatness')
    call read_real(file, '/diagnostics/momentum', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: 3, nt]), filename//': /diagnostics/momentum shape')
    if (size(got) == 3*nt) call check_close_array(got, [((c*1.0_rp*k, c = 1, 3), k = 0, nt - 1)], 0.0_rp, 0.0_rp, &
                                                  filename//': momentum')
    call read_real(file, '/energy/bend', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: nt]), filename//': /energy/bend shape')

    call read_int64(file, '/diagnostics/steps', igot)
    call check_true(size(igot) == nt, filename//': /diagnostics/steps shape')
    if (size(igot) == nt) call check_true(all(igot == [(10_int64*k, k = 0, nt - 1)]), filename//': steps values')
    call read_int64(file, '/diagnostics/linear_iterations', igot)
    if (size(igot) == nt) call check_true(all(igot == [(1000000_int64*k, k = 0, nt - 1)]), filename//': linear_iterations')

    call read_real(file, '/lattice/mass', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: nx, ny]), filename//': /lattice/mass shape')
    if (size(got) == nx*ny) call check_close_array(got, [((mass_expected(i, j, nx), i = 0, nx - 1), j = 0, ny - 1)], &
                                                   0.0_rp, 0.0_rp, filename//': /lattice/mass values')
    call read_real(file, '/lattice/rest_position', dims, got)
    call check_true(all(dims == [integer(hsize_t) :: 3, nx, ny]), filename//': /lattice/rest_position shape')
    if (size(got) == 3*nx*ny) call check_close_array(got, &
      [(((real(merge(i, j, c == 1), rp)*merge(1, 0, c < 3), c = 1, 3), i = 0, nx - 1), j = 0, ny - 1)], &
      0.0_rp, 0.0_rp, filename//': /lattice/rest_position values')

    call h5fclose_f(file, h)
    call check_true(h == 0, filename//': h5fclose_f')
    inquire(file=filename(1:len(filename)-3)//'.xdmf', exist=exists)
    call check_true(exists, filename//': XDMF sidecar exists')
  end subroutine check_file

  pure function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=16) :: buf
    write(buf, '(i0)') i
    s = trim(buf)
  end function itoa

  subroutine read_real(file, name, dims, buf)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: name
    integer(hsize_t), allocatable, intent(out) :: dims(:)
    real(rp), allocatable, intent(out) :: buf(:)
    integer(hid_t) :: dset, space
    integer(hsize_t) :: d(8), maxd(8)
    integer :: h, r

    allocate(dims(0), buf(0))
    call h5dopen_f(file, name, dset, h)
    call check_true(h == 0, 'h5dopen_f '//name)
    if (h /= 0) return
    call h5dget_space_f(dset, space, h)
    call h5sget_simple_extent_ndims_f(space, r, h)
    call h5sget_simple_extent_dims_f(space, d(1:r), maxd(1:r), h)
    call check_true(h == r, 'h5sget_simple_extent_dims_f '//name)
    dims = d(1:r)
    deallocate(buf)
    allocate(buf(product(dims)))
    call h5dread_f(dset, H5T_NATIVE_DOUBLE, buf, [size(buf, kind=hsize_t)], h)
    call check_true(h == 0, 'h5dread_f '//name)
    call h5sclose_f(space, h)
    call h5dclose_f(dset, h)
  end subroutine read_real

  subroutine read_int64(file, name, buf)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: name
    integer(int64), allocatable, intent(out) :: buf(:)
    integer(hsize_t), allocatable :: dims(:)
    real(rp), allocatable :: unused(:)
    integer(hid_t) :: dset
    integer :: h

    call read_real(file, name, dims, unused)   ! shape only (converted values unused)
    allocate(buf(product(dims)))
    call h5dopen_f(file, name, dset, h)
    if (h /= 0) return
    call h5dread_f(dset, h5kind_to_type(int64, H5_INTEGER_KIND), buf, [size(buf, kind=hsize_t)], h)
    call check_true(h == 0, 'h5dread_f '//name)
    call h5dclose_f(dset, h)
  end subroutine read_int64

  subroutine read_attr_str(file, name, val)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: name
    character(len=*), intent(out) :: val
    integer(hid_t) :: attr, stype
    integer :: h

    val = ''
    call h5aopen_f(file, name, attr, h)
    call check_true(h == 0, 'h5aopen_f '//name)
    if (h /= 0) return
    call h5tcopy_f(H5T_NATIVE_CHARACTER, stype, h)
    call h5tset_size_f(stype, int(len(val), size_t), h)
    call h5aread_f(attr, stype, val, [1_hsize_t], h)
    call check_true(h == 0, 'h5aread_f '//name)
    ! NUL padding from the file's NULLPAD strings, if any, becomes blanks.
    val = translate_nul(val)
    call h5tclose_f(stype, h)
    call h5aclose_f(attr, h)
  end subroutine read_attr_str

  pure function translate_nul(s) result(t)
    character(*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: i
    t = s
    do i = 1, len(t)
      if (t(i:i) == achar(0)) t(i:i) = ' '
    end do
  end function translate_nul

  subroutine read_attr_int(file, name, val)
    integer(hid_t), intent(in) :: file
    character(*), intent(in) :: name
    integer, intent(out) :: val
    integer(hid_t) :: attr
    integer :: h

    val = -huge(1)
    call h5aopen_f(file, name, attr, h)
    call check_true(h == 0, 'h5aopen_f '//name)
    if (h /= 0) return
    call h5aread_f(attr, H5T_NATIVE_INTEGER, val, [1_hsize_t], h)
    call check_true(h == 0, 'h5aread_f '//name)
    call h5aclose_f(attr, h)
  end subroutine read_attr_int

end program test_output
