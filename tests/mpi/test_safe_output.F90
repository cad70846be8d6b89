! SPDX-License-Identifier: BSD-2-Clause
!> MPI test of the safe output files of module output (input/README.md,
!> "Output files"), below the solver: an earlier file keeps its bytes while
!> a new file has only its step-0 record, and after a close as 'failed';
!> the first record after a successful step (steps > 0) replaces it; a
!> second open of the same name (a second writer) is refused while the
!> first is open, and allowed after; the input file is never written.
program test_safe_output
  use mpi
  use kinds, only: rp
  use output, only: output_file, output_record, output_open, output_write_step, output_close
  use check, only: check_true, check_report
  implicit none
  integer :: mpierr, rank, n_ranks, ys, ym, ierr
  integer, parameter :: nx = 3, ny = 4
  real(rp), allocatable :: rest(:, :, :), mass(:, :)
  character(len=64) :: name
  character(len=256) :: errmsg
  character(len=:), allocatable :: old_bytes
  type(output_file) :: out, out2
  type(output_record) :: rec
  logical :: exists

  call MPI_Init(mpierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, mpierr)
  call MPI_Comm_size(MPI_COMM_WORLD, n_ranks, mpierr)
  ! Names per rank count: CTest may run the np1 and np3 tests at the same time.
  write(name, '(a,i0,a)') 'test_safe_output_np', n_ranks, '.h5'
  ym = ny/n_ranks + merge(1, 0, rank < mod(ny, n_ranks))
  ys = rank*(ny/n_ranks) + min(rank, mod(ny, n_ranks))
  allocate(rest(3, nx, ym), mass(nx, ym))
  rest = 1
  mass = 1

  ! An earlier, complete result.
  call one_run(trim(name), 2, 'complete')
  call MPI_Barrier(MPI_COMM_WORLD, mpierr)
  if (rank == 0) old_bytes = file_bytes(trim(name))

  ! A run that writes its step-0 record and fails: the earlier file is kept.
  call output_open(out, trim(name), MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, .false., '', '', ierr, errmsg)
  call check_true(ierr == 0, 'open over an earlier file: '//trim(errmsg))
  rec%steps = 0
  call output_write_step(out, rec, rest, ierr, errmsg)
  call check_true(ierr == 0, 'step-0 record: '//trim(errmsg))
  if (rank == 0) call check_true(file_bytes(trim(name)) == old_bytes, 'earlier file untouched after step 0')

  ! A second writer of the same name is refused while the first is open,
  ! on every rank, before it writes anything.
  call output_open(out2, trim(name), MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, .false., '', '', ierr, errmsg)
  call check_true(ierr /= 0, 'second writer refused')
  if (rank == 0) call check_true(index(errmsg, 'another run') > 0, 'second writer message: '//trim(errmsg))

  call output_close(out, 'failed: first step diverged', ierr, errmsg)
  call check_true(ierr == 0, 'close failed run: '//trim(errmsg))
  call MPI_Barrier(MPI_COMM_WORLD, mpierr)
  if (rank == 0) then
    call check_true(file_bytes(trim(name)) == old_bytes, 'earlier file untouched after a failed run')
    inquire(file=trim(name)//'.partial', exist=exists)
    call check_true(exists, 'the failed run is kept aside as .partial')
    inquire(file=trim(name)//'.lock', exist=exists)
    call check_true(.not. exists, 'lock file removed at close')
  end if

  ! A run keeps an earlier result until it completes (input/README.md,
  ! Output files): after a successful step the earlier file is unchanged,
  ! the run's record is in the .partial, and the close as complete renames it.
  call output_open(out, trim(name), MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, .false., '', '', ierr, errmsg)
  call check_true(ierr == 0, 'open after the close (lock free again): '//trim(errmsg))
  rec%steps = 0
  call output_write_step(out, rec, rest, ierr, errmsg)
  rec%steps = 5
  rec%time = 1
  call output_write_step(out, rec, rest, ierr, errmsg)
  call check_true(ierr == 0, 'record after a step: '//trim(errmsg))
  call MPI_Barrier(MPI_COMM_WORLD, mpierr)
  if (rank == 0) then
    call check_true(file_bytes(trim(name)) == old_bytes, 'earlier file kept until the run completes')
    inquire(file=trim(name)//'.partial', exist=exists)
    call check_true(exists, 'the running result is the .partial')
  end if
  call output_close(out, 'complete', ierr, errmsg)
  call check_true(ierr == 0, 'close: '//trim(errmsg))
  call MPI_Barrier(MPI_COMM_WORLD, mpierr)
  if (rank == 0) then
    call check_true(file_bytes(trim(name)) /= old_bytes, 'file replaced once the run completes')
    inquire(file=trim(name)//'.partial', exist=exists)
    call check_true(.not. exists, 'no .partial after a complete close')
    old_bytes = file_bytes(trim(name))
  end if

  ! -nuno_overwrite: the earlier file is replaced at the first successful step.
  call output_open(out, trim(name), MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, .false., '', '', ierr, errmsg, &
                   overwrite=.true.)
  call check_true(ierr == 0, 'open with overwrite: '//trim(errmsg))
  rec%steps = 0
  rec%time = 0
  call output_write_step(out, rec, rest, ierr, errmsg)
  rec%steps = 5
  rec%time = 2
  call output_write_step(out, rec, rest, ierr, errmsg)
  call check_true(ierr == 0, 'record after a step (overwrite): '//trim(errmsg))
  call MPI_Barrier(MPI_COMM_WORLD, mpierr)
  if (rank == 0) then
    call check_true(file_bytes(trim(name)) /= old_bytes, 'overwrite: file replaced after the first successful step')
    inquire(file=trim(name)//'.partial', exist=exists)
    call check_true(.not. exists, 'overwrite: no .partial once replaced')
  end if
  call output_close(out, 'complete', ierr, errmsg)
  call check_true(ierr == 0, 'close (overwrite): '//trim(errmsg))

  ! The protected (input) file is refused under any name this run writes.
  call output_open(out, trim(name), MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, .false., '', '', ierr, errmsg, &
                   protect='./'//trim(name))
  call check_true(ierr /= 0, 'output = protected file refused')
  if (rank == 0) call check_true(index(errmsg, 'input file') > 0, 'protect message: '//trim(errmsg))

  call check_report()
  call MPI_Finalize(mpierr)

contains

  subroutine one_run(filename, n_steps, status)
    character(*), intent(in) :: filename, status
    integer, intent(in) :: n_steps
    type(output_file) :: o
    type(output_record) :: r
    integer :: k, e
    character(len=256) :: m
    call output_open(o, filename, MPI_COMM_WORLD, nx, ny, ys, ym, rest, mass, .false., '', '', e, m)
    call check_true(e == 0, 'first run open: '//trim(m))
    do k = 0, n_steps - 1
      r%steps = 10*k
      r%time = k
      call output_write_step(o, r, rest, e, m)
      call check_true(e == 0, 'first run step: '//trim(m))
    end do
    call output_close(o, status, e, m)
    call check_true(e == 0, 'first run close: '//trim(m))
  end subroutine one_run

  !> The whole file as a string (rank 0).
  function file_bytes(path) result(s)
    character(*), intent(in) :: path
    character(len=:), allocatable :: s
    integer :: u, n, ios
    open(newunit=u, file=path, access='stream', form='unformatted', action='read', status='old', iostat=ios)
    if (ios /= 0) then
      s = ''
      return
    end if
    inquire(unit=u, size=n)
    allocate(character(n) :: s)
    read(u, iostat=ios) s
    close(u)
  end function file_bytes

end program test_safe_output
