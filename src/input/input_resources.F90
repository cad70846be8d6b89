! SPDX-License-Identifier: BSD-2-Clause
!> Checks of a parsed configuration against what the run can do, before
!> anything is allocated: step and output counts, the index space, and the
!> memory the lattice needs (module input_limits) against the memory the
!> ranks' hosts have available. Collective over the run's communicator.
module input_resources
  use, intrinsic :: iso_fortran_env, only: int64
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE
  use input_limits, only: max_steps, max_outputs, bytes_per_node_bending, bytes_per_node_plain
  use strings, only: real_short, count_text, bytes_text
  implicit none
  private
  public :: input_check_run

contains

  !> Checks of a parsed configuration against what the run can do, before
  !> anything is allocated: the step and output counts (unless allow_long),
  !> the index space (6 unknowns a node) against index_max (the largest
  !> PetscInt), and the memory estimate against the memory the ranks' hosts
  !> have available. Collective over comm; every rank returns the same result.
  subroutine input_check_run(cfg, comm, allow_long, index_max, ts_dt, ts_dt_set, ierr, errmsg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: comm                     !< MPI communicator of the run
    logical, intent(in) :: allow_long               !< -nuno_allow_long given
    integer(int64), intent(in) :: index_max         !< largest index (PetscInt, default integer)
    real(rp), intent(in) :: ts_dt                   !< -ts_dt, which overrides the namelist's dt where given [time]
    logical, intent(in) :: ts_dt_set                !< whether -ts_dt is given
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: nodes, need, per_node
    integer(int64) :: avail
    character(32) :: a, b, lim

    ierr = 0
    errmsg = ''
    ! Counts in reals: t_end/dt may exceed every integer kind.
    if (ts_dt_set) then
      if (.not. (ts_dt > 0.0_rp .and. ts_dt <= huge(ts_dt))) then
        ierr = 1
        errmsg = 'input: -ts_dt '//real_short(ts_dt)//' must be a finite number > 0'
        return
      end if
    end if
    if (.not. allow_long) then
      if (ts_dt_set) then
        if (cfg%time%t_end/ts_dt > max_steps) then
          ierr = 1
          errmsg = 'input: -ts_dt '//real_short(ts_dt)//' with &time t_end = '//real_short(cfg%time%t_end)//' is '// &
                   count_text(cfg%time%t_end/ts_dt)//' steps, more than '//count_text(max_steps)// &
                   ': give -nuno_allow_long to run it anyway'
          return
        end if
      else if (cfg%time%t_end/cfg%time%dt > max_steps) then
        ierr = 1
        errmsg = 'input: &time: t_end = '//real_short(cfg%time%t_end)//', dt = '//real_short(cfg%time%dt)//' is '// &
                 count_text(cfg%time%t_end/cfg%time%dt)//' steps, more than '//count_text(max_steps)// &
                 ': give -nuno_allow_long to run it anyway'
        return
      end if
      if (cfg%time%t_end/cfg%output%output_interval > max_outputs) then
        ierr = 1
        errmsg = 'input: &output: output_interval = '//real_short(cfg%output%output_interval)//' with t_end = '// &
                 real_short(cfg%time%t_end)//' is '//count_text(cfg%time%t_end/cfg%output%output_interval)// &
                 ' output steps, more than '//count_text(max_outputs)//': give -nuno_allow_long to run it anyway'
        return
      end if
    end if

    write(a, '(i0)') cfg%lattice%nx
    write(b, '(i0)') cfg%lattice%ny
    write(lim, '(i0)') index_max
    nodes = real(cfg%lattice%nx, rp)*real(cfg%lattice%ny, rp)
    if (6.0_rp*nodes > real(index_max, rp)) then
      ierr = 1
      errmsg = 'input: &lattice: nx = '//trim(a)//', ny = '//trim(b)//': 6 nx ny = '// &
               count_text(6.0_rp*nodes)//' unknowns exceed the index limit '//trim(lim)// &
               ' (largest PetscInt)'
      return
    end if
    per_node = merge(bytes_per_node_plain, bytes_per_node_bending, cfg%material%bending_code == BEND_NONE)
    need = nodes*per_node
    call memory_available(comm, avail)
    if (avail > 0) then
      if (need > real(avail, rp)) then
        ierr = 1
        errmsg = 'input: &lattice: nx = '//trim(a)//', ny = '//trim(b)//': the lattice needs about '// &
                 bytes_text(need)//' ('//real_short(per_node/1000.0_rp)//' KB a node, a lower bound) but the ranks'' '// &
                 'hosts have '//bytes_text(real(avail, rp))//' available'
      end if
    end if
  end subroutine input_check_run

  !> Bytes available to the run: MemAvailable of /proc/meminfo (capped by a
  !> cgroup memory limit) on each host, read by one rank per host and summed
  !> over the hosts. 0 when unknown on any host (then nothing is refused).
  subroutine memory_available(comm, avail)
    integer, intent(in) :: comm
    integer(int64), intent(out) :: avail
    integer :: node, node_rank, rank, mpierr
    integer(int64) :: mine, lo

    call MPI_Comm_rank(comm, rank, mpierr)
    call MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, rank, MPI_INFO_NULL, node, mpierr)
    call MPI_Comm_rank(node, node_rank, mpierr)
    call MPI_Comm_free(node, mpierr)
    mine = 0
    if (node_rank == 0) mine = host_memory_available()
    lo = mine
    if (node_rank /= 0) lo = huge(lo)
    call MPI_Allreduce(MPI_IN_PLACE, lo, 1, MPI_INTEGER8, MPI_MIN, comm, mpierr)
    call MPI_Allreduce(mine, avail, 1, MPI_INTEGER8, MPI_SUM, comm, mpierr)
    if (lo <= 0) avail = 0
  end subroutine memory_available

  !> This host's available memory in bytes; 0 when unknown.
  function host_memory_available() result(bytes)
    integer(int64) :: bytes
    integer(int64) :: limit, used
    character(256) :: line
    integer :: u, ios
    integer(int64) :: kb

    bytes = 0
    open(newunit=u, file='/proc/meminfo', action='read', status='old', iostat=ios)
    if (ios /= 0) return
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (line(1:13) == 'MemAvailable:') then
        read(line(14:), *, iostat=ios) kb
        if (ios == 0) bytes = kb*1024_int64
        exit
      end if
    end do
    close(u)
    ! A container's limit (cgroup v2, then v1) is what this run can use.
    if (read_int64('/sys/fs/cgroup/memory.max', limit) .and. read_int64('/sys/fs/cgroup/memory.current', used)) then
      if (bytes > 0) bytes = min(bytes, max(0_int64, limit - used))
    else if (read_int64('/sys/fs/cgroup/memory/memory.limit_in_bytes', limit) .and. &
             read_int64('/sys/fs/cgroup/memory/memory.usage_in_bytes', used)) then
      if (bytes > 0) bytes = min(bytes, max(0_int64, limit - used))
    end if
  end function host_memory_available

  !> The first integer in file `path` ('max' and unreadable files: .false.).
  logical function read_int64(path, val)
    character(*), intent(in) :: path
    integer(int64), intent(out) :: val
    integer :: u, ios
    val = 0
    read_int64 = .false.
    open(newunit=u, file=path, action='read', status='old', iostat=ios)
    if (ios /= 0) return
    read(u, *, iostat=ios) val
    close(u)
    read_int64 = ios == 0
  end function read_int64

end module input_resources
