! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the file lifecycle (open, claim, commit, close, the
!> library's refresh) and its safety rules (one writer per file,
!> <file>.partial until committed, free space checked before a collective
!> write).
submodule (output) output_files
  implicit none

contains

  !> Lock the file, create `<filename>.partial` (an earlier `filename` is left
  !> alone), write root attributes and the lattice, create the time series. Collective.
  module procedure output_open
    integer :: mpierr, rows
    logical :: made, replace
    character(len=256) :: detail
    character(len=:), allocatable :: program_version
#ifdef NUNO_VERSION
    character(len=*), parameter :: default_version = NUNO_VERSION
#else
    character(len=*), parameter :: default_version = '0.1.0'
#endif

    replace = .false.
    if (present(overwrite)) replace = overwrite
    call handle_init(out, 'output_open', filename, comm, nx, ny, ys, ym, write_velocity, replace, ierr, errmsg)
    if (ierr /= 0) return
    ! Shape checks, then a reduction so that every rank takes the same branch.
    if (nx < 1 .or. ny < 1 .or. ys < 0 .or. ym < 0 .or. ys + ym > ny) then
      ierr = 1
      errmsg = 'output_open: bad lattice strip (nx, ny, ys, ym) for '//filename
    else if (size(rest, 1) /= 3 .or. size(rest, 2) /= nx .or. size(rest, 3) /= ym) then
      ierr = 1
      errmsg = 'output_open: rest must be (3, nx, ym) for /lattice/rest_position'
    else if (size(mass, 1) /= nx .or. size(mass, 2) /= ym) then
      ierr = 1
      errmsg = 'output_open: mass must be (nx, ym) for /lattice/mass'
    end if
    call MPI_Allreduce(ym, rows, 1, MPI_INTEGER, MPI_SUM, comm, mpierr)
    if (ierr == 0 .and. rows /= ny) then
      ierr = 1
      errmsg = 'output_open: the ranks'' rows do not add up to ny'
    end if
    call agree(comm, 'output_open', ierr, errmsg)
    if (ierr /= 0) return

    out%series%nt = 0
    call sidecar_names(filename, out%safe%xmf_path, out%safe%h5_base, out%safe%obst_path)
    if (allocated(out%series%times)) deallocate(out%series%times)
    allocate(out%series%times(16))
    out%safe%final_path = filename
    out%safe%work_path = filename//'.partial'
    out%safe%lock_path = filename//'.lock'
    out%safe%committed = .false.
    out%ckpt%reopened = .false.
    out%safe%stepped = .false.

    ! Before anything is written: not the input file, no other writer, and
    ! only nuno's own files under the names this run writes.
    if (out%rank == 0) then
      if (present(protect)) then
        call claim_files(out, protect, ierr, errmsg)
      else
        call claim_files(out, '', ierr, errmsg)
      end if
    end if
    call agree(comm, 'output_open', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
      return
    end if
    call MPI_Bcast(out%safe%had_earlier, 1, MPI_LOGICAL, 0, comm, mpierr)

    ! The file, the lattice and a first step must fit (check_space).
    call check_space(out, 32.0_rp * nx * ny + step_bytes(out) + 2.0_rp * (len(attrs_namelist) + len(attrs_petsc_options)), &
                     'a new output file', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
      return
    end if
    program_version = default_version
    if (present(version)) program_version = version
    call open_local(out, out%safe%work_path, rest, mass, attrs_namelist, attrs_petsc_options, program_version, ierr, errmsg)
    call agree(comm, 'output_open', ierr, errmsg)
    ! Made by this run (created: the file is open here): an error exit
    ! before it holds a result removes it (errors: cleanup_run), and so
    ! does a failure here; a name this run did not create is left alone.
    made = out%is_open
    if (out%rank == 0 .and. made) call cleanup_add(out%safe%work_path, cleanup_file)
    if (ierr /= 0) then
      call close_ids(out, ierr, errmsg)   ! best effort; ierr/errmsg keep the first error
      out%is_open = .false.
      if (out%rank == 0 .and. made) then
        call remove_file(out%safe%work_path, made, detail)
        call cleanup_drop(out%safe%work_path)
      end if
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
    end if
  end procedure output_open

  !> The start of output_open and output_reopen (who, for the message): a
  !> handle that is not open, this rank in comm, the lattice strip, the
  !> series' velocity and -nuno_overwrite. Local.
  module procedure handle_init
    integer :: mpierr

    ierr = 0
    errmsg = ''
    if (out%is_open) then
      ierr = 1
      errmsg = who//': handle already open ('//filename//')'
      return
    end if
    call MPI_Comm_rank(comm, out%rank, mpierr)
    call MPI_Comm_size(comm, out%n_ranks, mpierr)
    out%comm = comm
    out%nx = nx
    out%ny = ny
    out%ys = ys
    out%ym = ym
    out%series%write_velocity = write_velocity
    out%safe%overwrite = overwrite
  end procedure handle_init

  !> ierr = 0 and errmsg = '' when the file is open; otherwise ierr = 1
  !> and a line saying who found it closed.
  module procedure require_open
    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = who//': the output file is not open'
    end if
  end procedure require_open

  !> Rank 0: refuse to write over `protect` (by any of the names this run
  !> writes), then take the lock, then check the names under it. The lock
  !> file is made beside the output, so a missing or unwritable directory is
  !> reported here, with its cause.
  module procedure claim_files
    if (len(protect) > 0) then
      if (same_file(protect, out%safe%final_path) .or. same_file(protect, out%safe%work_path) .or. &
          same_file(protect, out%safe%lock_path) .or. same_file(protect, out%safe%xmf_path) .or. &
          same_file(protect, out%safe%obst_path)) then
        ierr = 1
        errmsg = "input: &output: output_file = '"//out%safe%final_path//"' would overwrite the input file "// &
                 protect//': choose another output_file'
        return
      end if
    end if
    call take_lock(out, ierr, errmsg)
    if (ierr == 0) call claim_names(out, ierr, errmsg)
  end procedure claim_files

  !> Rank 0: the lock file <final>.lock, flock'd for the life of the run.
  subroutine take_lock(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=256) :: detail
    integer :: code

    call lock_acquire(out%safe%lock_path, out%safe%lock_fd, code, detail)
    if (code == 1) then
      ierr = 1
      errmsg = 'output: '//out%safe%final_path//' is being written by another run ('//trim(detail)// &
               ', lock '//out%safe%lock_path//'): wait for it to end or choose another output_file'
    else if (code == 3) then
      ierr = 1
      errmsg = 'output: nuno''s lock file '//out%safe%lock_path//' cannot be made: '//trim(detail)// &
               '; nuno never writes through or over what it did not make: move it away or choose another output_file'
    else if (code /= 0) then
      ierr = 1
      errmsg = 'output: cannot create '//out%safe%lock_path//' beside the output file: '//trim(detail)
    end if
  end subroutine take_lock

  !> Rank 0, under the lock: the names this run writes must each be free or
  !> a regular file that nuno wrote (an earlier result, a killed run's
  !> attempt, a sidecar), never a link, a directory or a user's file; a
  !> killed run's attempt is removed. A file continued by -nuno_restart
  !> must be nuno's own.
  subroutine claim_names(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=256) :: detail
    logical :: stale, ok

    out%safe%had_earlier = .false.
    if (out%safe%work_path /= out%safe%final_path) then
      call own_or_free(out%safe%final_path, 'output file', .false., out%safe%had_earlier, ierr, errmsg)
      if (ierr == 0 .and. .not. out%ckpt%reopened) then
        call own_or_free(out%safe%work_path, 'working file', .false., stale, ierr, errmsg)
        ! A killed run's attempt (nuno's, under this lock): replaced.
        if (ierr == 0 .and. stale) then
          call remove_file(out%safe%work_path, ok, detail)
          if (.not. ok) then
            ierr = 1
            errmsg = 'output: cannot remove the earlier attempt '//out%safe%work_path//': '//trim(detail)
          end if
        end if
      end if
    end if
    if (ierr == 0 .and. out%ckpt%reopened) then
      ! Opened for writing only when it is nuno's (an HDF5 file of another
      ! program could be changed by the mere open and close).
      if (path_kind(out%safe%work_path, detail) /= kind_file) then
        ierr = 1
        errmsg = '-nuno_restart '//out%safe%work_path//': not a regular file (a symbolic link, a directory or '// &
                 'another kind of file): nuno continues only its own output files'
      else if (.not. is_nuno_output(out%safe%work_path)) then
        ierr = 1
        errmsg = '-nuno_restart '//out%safe%work_path//': not a nuno output file: nuno continues only its own output files'
      end if
    end if
    if (ierr == 0) call own_or_free(out%safe%xmf_path, 'XDMF sidecar', .true., stale, ierr, errmsg)
    ! written with obstacles, removed without them (an earlier run's):
    ! either way nuno's, or free
    if (ierr == 0) call own_or_free(out%safe%obst_path, 'XDMF sidecar of the obstacles', .true., stale, ierr, errmsg)
  end subroutine claim_names

  !> ierr = 1 unless path is free or a regular file of nuno's (exists: it
  !> is): an output file, or an XDMF sidecar (sidecar).
  subroutine own_or_free(path, what, sidecar, exists, ierr, errmsg)
    character(*), intent(in) :: path, what
    logical, intent(in) :: sidecar
    logical, intent(out) :: exists
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=256) :: why
    integer :: k
    logical :: own

    exists = .false.
    k = path_kind(path, why)
    if (k == kind_none) return
    exists = k == kind_file
    if (k == kind_file) then
      if (sidecar) then
        own = is_nuno_sidecar(path)
      else
        own = is_nuno_output(path)
      end if
      if (own) return
      why = 'it exists and is not '//merge('an XDMF sidecar written by nuno', 'an output file of nuno         ', sidecar)
    else if (k == kind_link) then
      why = 'it is a symbolic link'
    else if (k == kind_dir) then
      why = 'it is a directory'
    else if (k /= kind_unknown) then
      why = 'it is not a regular file'
    end if
    ierr = 1
    errmsg = 'output: '//path//' (this run''s '//what//'): '//trim(why)// &
             '; nuno replaces only its own files, never through a link: move it away or choose another output_file'
  end subroutine own_or_free

  !> Rename `<file>.partial` onto `<file>` (rank 0), then write the XDMF
  !> sidecar, which names `<file>` (and the obstacles' sidecar; without
  !> obstacles, an earlier run's is removed: it would name what `<file>`
  !> no longer has). Collective; from here on an earlier `<file>` is
  !> replaced, atomically.
  module procedure commit
    character(len=256) :: detail
    logical :: ok

    if (out%safe%committed .or. ierr /= 0) return
    if (out%rank == 0) then
      call rename_file(out%safe%work_path, out%safe%final_path, ok, detail)
      if (.not. ok) then
        ierr = 1
        errmsg = 'output: cannot rename '//out%safe%work_path//' to '//out%safe%final_path//': '//trim(detail)
      else
        call cleanup_drop(out%safe%work_path)
      end if
    end if
    call agree(out%comm, 'output: rename', ierr, errmsg)
    if (ierr /= 0) return
    out%safe%committed = .true.
    if (out%rank == 0 .and. out%obst%n == 0) call drop_obstacles_sidecar(out, ierr, errmsg)
    if (out%rank == 0) call write_xdmf(out, ierr, errmsg)
  end procedure commit

  !> The file's name now: <file>.partial until committed, then <file>.
  function file_path(out) result(path)
    type(output_file), intent(in) :: out
    character(len=:), allocatable :: path
    path = out%safe%work_path
    if (out%safe%committed) path = out%safe%final_path
  end function file_path

  !> Bytes of one output step in the file (the strips and a margin for the
  !> scalars and metadata).
  module procedure step_bytes
    step_bytes = 24.0_rp * out%nx * out%ny * merge(2, 1, out%series%write_velocity) + 65536.0_rp
  end procedure step_bytes

  !> Refuse a write of about `bytes` before any HDF5 call when the file
  !> system does not have twice that free: a full disk found inside a
  !> collective HDF5 call fails on some ranks only, and parallel HDF5 1.10
  !> then leaves the others waiting (a hang). Rank 0 asks (statvfs), every
  !> rank gets the answer. Collective.
  module procedure check_space
    real(rp) :: free
    character(len=24) :: fb, nb
    character(len=:), allocatable :: path

    if (out%rank == 0) then
      path = file_path(out)
      free = free_bytes(path)
      if (free >= 0.0_rp .and. free < 2.0_rp * bytes) then
        write(fb, '(es10.3e2)') free
        write(nb, '(es10.3e2)') 2.0_rp * bytes
        ierr = 1
        errmsg = 'output: no space left for '//what//' in '//path//' ('//trim(adjustl(fb))//' bytes free, '// &
                 trim(adjustl(nb))//' needed)'
        if (out%is_open) errmsg = trim(errmsg)//': the file holds the '//itoa(out%series%nt)//' output steps before it'
      end if
    end if
    call agree(out%comm, 'output', ierr, errmsg)
  end procedure check_space

  !> A failed write says nothing of its cause through HDF5: rank 0 adds
  !> what the file system says (a full disk, or free space: then quota,
  !> permissions or an I/O error), the same text on every rank. Collective.
  module procedure add_cause
    real(rp) :: free
    character(len=32) :: buf
    integer :: mpierr
    character(len=:), allocatable :: path

    if (out%rank == 0) then
      path = file_path(out)
      free = free_bytes(path)
      write(buf, '(es10.3e2)') free
      if (free < 0.0_rp) then
        continue
      else if (free < 2.0_rp * step_bytes(out)) then
        errmsg = trim(errmsg)//' in '//path//': no space left on its file system ('//trim(adjustl(buf))//' bytes free)'
      else
        errmsg = trim(errmsg)//' in '//path//' (its file system has '//trim(adjustl(buf))// &
                 ' bytes free: a quota, permissions or an I/O error)'
      end if
    end if
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, 0, out%comm, mpierr)
  end procedure add_cause

  !> Write the XDMF file, then the root attribute status (last), then close every id and the file. Collective.
  module procedure output_close
    integer :: e2, mpierr
    character(len=len(errmsg)) :: msg2
    logical :: keep

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) return   ! never opened, failed open, or closed already
    ! Not committed: no time step succeeded (or none was written). A complete
    ! run, or one with no earlier file to protect, takes the name now; a
    ! failed one leaves an earlier file as it was and its own as .partial.
    if (.not. out%safe%committed) then
      keep = .false.
      if (out%rank == 0) keep = status /= 'complete' .and. file_exists(out%safe%final_path)
      call MPI_Bcast(keep, 1, MPI_LOGICAL, 0, out%comm, mpierr)
      if (keep) then
        if (out%rank == 0) write(*, '(a)') 'output: the earlier '//out%safe%final_path// &
          ' is kept as it was; this run''s file is '//out%safe%work_path//' (-nuno_restart '//out%safe%final_path// &
          ' continues it from its checkpoint, if it has one)'
        if (out%rank == 0) call cleanup_drop(out%safe%work_path)   ! the record of the failure
      else
        call commit(out, ierr, errmsg)   ! writes the XDMF sidecar
      end if
    else
      if (out%rank == 0) call write_xdmf(out, ierr, errmsg)
    end if
    ! status after everything else, so that 'complete' means complete.
    e2 = 0
    call set_attr_str(out%file, 'status', status, '/', e2, msg2)
    if (e2 == 0) then
      call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, e2)
      if (e2 < 0) call fail('h5fflush_f', '/', e2, msg2)
    end if
    call keep_first(ierr, errmsg, e2, msg2)
    call close_ids(out, ierr, errmsg)
    out%is_open = .false.
    if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
    call agree(out%comm, 'output_close', ierr, errmsg)
  end procedure output_close

  ! ---------------------------------------------------------------------------
  ! Open: file, root attributes, lattice, time series.

  module procedure open_local
    integer(hid_t) :: fapl, grp
    integer :: i, h
    character(len=12), parameter :: groups(3) = [character(len=12) :: 'lattice', 'energy', 'diagnostics']

    ! The file, with the MPI-IO driver and its collective transfer list.
    call library_open(filename, ierr, errmsg)
    if (ierr /= 0) return
    call mpio_access_list(out%comm, filename, fapl, ierr, errmsg)
    if (ierr == 0) call set_format_bounds(fapl, filename, ierr, errmsg)
    if (ierr == 0) then
      ! EXCL: a new file (O_EXCL), never one that took the name meanwhile
      ! nor the target of a symbolic link (claim_files cleared the name).
      call h5fcreate_f(filename, H5F_ACC_EXCL_F, out%file, h, access_prp=fapl)
      if (h < 0) call fail('h5fcreate_f', filename, ierr, errmsg)
    end if
    call close_access_list(fapl, filename, ierr, errmsg)
    if (ierr /= 0) return
    out%is_open = .true.
    call collective_transfer(filename, out%dxpl, ierr, errmsg)
    if (ierr /= 0) return

    ! Root attributes (metadata: every rank makes the same calls with the same values).
    call set_attr_str(out%file, 'program_version', version, '/', ierr, errmsg)
    call set_attr_int(out%file, 'nx', out%nx, '/', ierr, errmsg)
    call set_attr_int(out%file, 'ny', out%ny, '/', ierr, errmsg)
    call set_attr_int(out%file, 'n_ranks', out%n_ranks, '/', ierr, errmsg)
    call set_attr_str(out%file, 'namelist', namelist, '/', ierr, errmsg)
    call set_attr_str(out%file, 'petsc_options', petsc_options, '/', ierr, errmsg)
    call set_attr_str(out%file, 'status', 'running', '/', ierr, errmsg)
    call set_attr_int(out%file, 'n_output_steps', 0, '/', ierr, errmsg)
    do i = 1, 3
      call open_or_create_group(out%file, '/'//trim(groups(i)), grp, ierr, errmsg)
      call close_group(grp, '/'//trim(groups(i)), ierr, errmsg)
    end do
    if (ierr /= 0) return

    call write_lattice(out, rest, mass, ierr, errmsg)
    if (ierr /= 0) return
    call lattice_views(out, ierr, errmsg)
    if (ierr /= 0) return
    call create_all_series(out, ierr, errmsg)
    call netcdf_dims(out, ierr, errmsg)
    if (ierr /= 0) return
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', filename, ierr, errmsg)
  end procedure open_local

  !> The time series of a new file, empty (/wall_time and the process
  !> models' come with output_write_run_info).
  subroutine create_all_series(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: i

    do i = d_time, d_linear_iterations
      if (i == d_velocity .and. .not. out%series%write_velocity) cycle
      if (ierr == 0) call create_series(out, i, ierr, errmsg)
    end do
  end subroutine create_all_series

  !> Close the file and the HDF5 library and open both again, with the
  !> series as they were (every REFRESH_STEPS output steps, from
  !> output_write_step). Parallel HDF5 1.10.8 keeps memory for every object
  !> created in a file opened with the MPI-IO driver until the library
  !> closes (about 20 kB a rank for each /xdmf view, 6 kB for a plain
  !> dataset; closing the file alone does not release it): without this a
  !> run grew by 10-25 kB a rank for each output step (docs/stability.md,
  !> "Memory over a long run"). Nothing else in nuno holds an HDF5 object
  !> while a run writes its output. Collective.
  module procedure refresh_library
    character(len=:), allocatable :: path, name
    integer(hid_t) :: fapl
    integer :: h, i
    logical :: exists

    if (ierr /= 0) return
    path = file_path(out)
    call close_ids(out, ierr, errmsg)
    call h5close_f(h)
    if (h < 0) call fail('h5close_f', path, ierr, errmsg)
    call library_open(path, ierr, errmsg)
    fapl = -1
    if (ierr == 0) call mpio_access_list(out%comm, path, fapl, ierr, errmsg)
    if (ierr == 0) call set_format_bounds(fapl, path, ierr, errmsg)
    if (ierr == 0) then
      call h5fopen_f(path, H5F_ACC_RDWR_F, out%file, h, access_prp=fapl)
      if (h < 0) then
        out%file = -1
        call fail('h5fopen_f (reopening)', path, ierr, errmsg)
      end if
    end if
    call close_access_list(fapl, path, ierr, errmsg)
    if (ierr == 0) call collective_transfer(path, out%dxpl, ierr, errmsg)
    do i = 1, n_dsets
      if (ierr /= 0) exit
      if (i == d_velocity .and. .not. out%series%write_velocity) cycle
      name = trim(dset_names(i))
      call has_link(out%file, name, name, exists, ierr, errmsg)
      if (exists) call open_dset(out%file, name, out%series%dset(i), ierr, errmsg)
    end do
    call pm_series_reopen(out, ierr, errmsg)
    if (ierr /= 0) out%is_open = out%file >= 0
  end procedure refresh_library

  ! ---------------------------------------------------------------------------
  ! Closing, errors, file names.

  !> Close every id that is open (datasets, transfer list, file); keeps the first error.
  module procedure close_ids
    integer :: i, h

    do i = 1, n_dsets
      if (out%series%dset(i) >= 0) call close_dset(out%series%dset(i), trim(dset_names(i)), ierr, errmsg)
      out%series%dset(i) = -1
    end do
    call pm_series_close(out, ierr, errmsg)
    if (out%dxpl >= 0) then
      call h5pclose_f(out%dxpl, h)
      if (h < 0) call fail('h5pclose_f(dataset transfer)', 'the output file', ierr, errmsg)
      out%dxpl = -1
    end if
    if (out%file >= 0) then
      call h5fclose_f(out%file, h)
      if (h < 0) call fail('h5fclose_f', 'the output file', ierr, errmsg)
      out%file = -1
    end if
  end procedure close_ids

  !> run.h5 -> run.xdmf and run-obstacles.xdmf beside it (safe_files'
  !> sidecar_path, obstacles_sidecar_path); the sidecars name the h5 file by
  !> its base name.
  module procedure sidecar_names
    integer :: n, slash

    n = len_trim(filename)
    xmf_path = sidecar_path(filename(1:n))
    obst_path = obstacles_sidecar_path(filename(1:n))
    slash = index(filename(1:n), '/', back=.true.)
    h5_base = filename(slash+1:n)
  end procedure sidecar_names

  module procedure flush_file
    integer :: h
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', out%safe%final_path, ierr, errmsg)
  end procedure flush_file

end submodule output_files
