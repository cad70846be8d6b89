! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the file lifecycle (open, claim, commit, close) and its safety
!> rules (one writer per file, <file>.partial until committed, free space
!> checked before a collective write).
submodule (output) output_files
  implicit none

contains

  !> Lock the file, create `<filename>.partial` (an earlier `filename` is left
  !> alone), write root attributes and the lattice, create the time series. Collective.
  module procedure output_open
    integer :: mpierr, rows
    logical :: made
    character(len=256) :: detail

    ierr = 0
    errmsg = ''
    if (out%is_open) then
      ierr = 1
      errmsg = 'output_open: handle already open ('//filename//')'
      return
    end if
    call MPI_Comm_rank(comm, out%rank, mpierr)
    call MPI_Comm_size(comm, out%n_ranks, mpierr)
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

    out%comm = comm
    out%nx = nx
    out%ny = ny
    out%ys = ys
    out%ym = ym
    out%series%nt = 0
    out%series%write_velocity = write_velocity
    call sidecar_names(filename, out%safe%xmf_path, out%safe%h5_base)
    if (allocated(out%series%times)) deallocate(out%series%times)
    allocate(out%series%times(16))
    out%safe%final_path = filename
    out%safe%work_path = filename//'.partial'
    out%safe%lock_path = filename//'.lock'
    out%safe%committed = .false.
    out%ckpt%reopened = .false.
    out%safe%stepped = .false.
    out%safe%overwrite = .false.
    if (present(overwrite)) out%safe%overwrite = overwrite

    ! Before anything is written: not the input file, no other writer, and
    ! only nuno's own files under the names this run writes.
    if (out%rank == 0) call claim_files(out, ierr, errmsg, protect)
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
    call open_local(out, out%safe%work_path, rest, mass, attrs_namelist, attrs_petsc_options, ierr, errmsg, version)
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

  !> Rank 0: refuse to write over `protect` (by any of the names this run
  !> writes), then take the lock. The lock file is made beside the output,
  !> so a missing or unwritable directory is reported here, with its cause.
  module procedure claim_files
    character(len=256) :: detail
    integer :: code
    logical :: stale, ok

    if (present(protect)) then
      if (same_file(protect, out%safe%final_path) .or. same_file(protect, out%safe%work_path) .or. &
          same_file(protect, out%safe%lock_path) .or. same_file(protect, out%safe%xmf_path)) then
        ierr = 1
        errmsg = "input: &output: output_file = '"//out%safe%final_path//"' would overwrite the input file "// &
                 protect//': choose another output_file'
        return
      end if
    end if
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
    if (ierr /= 0) return
    ! Under the lock, the names this run writes: each must be free or a
    ! regular file that nuno wrote (an earlier result, a killed run's
    ! attempt, a sidecar), never a link, a directory or a user's file.
    out%safe%had_earlier = .false.
    if (out%safe%work_path /= out%safe%final_path) then
      call own_or_free(out%safe%final_path, 'output file', out%safe%had_earlier)
      if (ierr == 0 .and. .not. out%ckpt%reopened) then
        call own_or_free(out%safe%work_path, 'working file', stale)
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
    if (ierr == 0) call own_or_free(out%safe%xmf_path, 'XDMF sidecar', stale, sidecar=.true.)
  contains
    !> ierr = 1 unless path is free or a regular file of nuno's (exists: it is).
    subroutine own_or_free(path, what, exists, sidecar)
      character(*), intent(in) :: path, what
      logical, intent(out) :: exists
      logical, intent(in), optional :: sidecar
      character(len=256) :: why
      integer :: k
      logical :: own
      exists = .false.
      k = path_kind(path, why)
      if (k == kind_none) return
      exists = k == kind_file
      if (k == kind_file) then
        if (present(sidecar)) then
          own = is_nuno_sidecar(path)
        else
          own = is_nuno_output(path)
        end if
        if (own) return
        why = 'it exists and is not '//merge('an XDMF sidecar written by nuno', 'an output file of nuno         ', &
                                           present(sidecar))
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
  end procedure claim_files

  !> Rename `<file>.partial` onto `<file>` (rank 0), then write the XDMF
  !> sidecar, which names `<file>`. Collective; from here on an earlier
  !> `<file>` is replaced, atomically.
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
    if (out%rank == 0) call write_xdmf(out, ierr, errmsg)
  end procedure commit

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
      path = out%safe%work_path
      if (out%safe%committed) path = out%safe%final_path
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
      path = out%safe%work_path
      if (out%safe%committed) path = out%safe%final_path
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
    integer :: h, i
    integer(hsize_t) :: chunk_rows
#ifdef NUNO_VERSION
    character(len=*), parameter :: default_version = NUNO_VERSION
#else
    character(len=*), parameter :: default_version = '0.1.0'
#endif

    call h5open_f(h)
    if (h < 0) then
      call fail('h5open_f', filename, ierr, errmsg); return
    end if
    ! No HDF5 error stack on stderr: a failure comes back as one line of ours.
    call h5eset_auto_f(0, h)
    call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
    if (h < 0) then
      call fail('h5pcreate_f(file access)', filename, ierr, errmsg); return
    end if
    call h5pset_fapl_mpio_f(fapl, out%comm, MPI_INFO_NULL, h)
    if (h < 0) call fail('h5pset_fapl_mpio_f', filename, ierr, errmsg)
    ! The 1.8 file format: attributes over 64 KiB (long namelists) are allowed,
    ! and a file left open by a crash still opens without h5clear (superblock
    ! version 2). Objects up to the 1.10 format are allowed, for the virtual
    ! datasets of /xdmf (layout message version 4; HDF5 refuses them with
    ! the bound at 1.8); everything else is written as with 1.8 bounds.
    if (ierr == 0) then
      call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V110_F, h)
      if (h < 0) call fail('h5pset_libver_bounds_f', filename, ierr, errmsg)
    end if
    if (ierr == 0) then
      ! EXCL: a new file (O_EXCL), never one that took the name meanwhile
      ! nor the target of a symbolic link (claim_files cleared the name).
      call h5fcreate_f(filename, H5F_ACC_EXCL_F, out%file, h, access_prp=fapl)
      if (h < 0) call fail('h5fcreate_f', filename, ierr, errmsg)
    end if
    call h5pclose_f(fapl, h)
    if (h < 0) call fail('h5pclose_f(file access)', filename, ierr, errmsg)
    if (ierr /= 0) return
    out%is_open = .true.

    call h5pcreate_f(H5P_DATASET_XFER_F, out%dxpl, h)
    if (h < 0) then
      call fail('h5pcreate_f(dataset transfer)', filename, ierr, errmsg); return
    end if
    call h5pset_dxpl_mpio_f(out%dxpl, H5FD_MPIO_COLLECTIVE_F, h)
    if (h < 0) then
      call fail('h5pset_dxpl_mpio_f', filename, ierr, errmsg); return
    end if

    ! Root attributes (metadata: every rank makes the same calls with the same values).
    if (present(version)) then
      call set_attr_str(out%file, 'program_version', version, '/', ierr, errmsg)
    else
      call set_attr_str(out%file, 'program_version', default_version, '/', ierr, errmsg)
    end if
    if (ierr == 0) call set_attr_int(out%file, 'nx', out%nx, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'ny', out%ny, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_ranks', out%n_ranks, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%file, 'namelist', namelist, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%file, 'petsc_options', petsc_options, '/', ierr, errmsg)
    if (ierr == 0) call set_attr_str(out%file, 'status', 'running', '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_output_steps', 0, '/', ierr, errmsg)
    if (ierr /= 0) return

    ! Groups.
    do i = 1, 3
      block
        character(len=12), parameter :: groups(3) = [character(len=12) :: 'lattice', 'energy', 'diagnostics']
        call h5gcreate_f(out%file, trim(groups(i)), grp, h)
        if (h < 0) then
          call fail('h5gcreate_f', '/'//trim(groups(i)), ierr, errmsg); return
        end if
        call h5gclose_f(grp, h)
        if (h < 0) then
          call fail('h5gclose_f', '/'//trim(groups(i)), ierr, errmsg); return
        end if
      end block
    end do

    call write_lattice(out, rest, mass, ierr, errmsg)
    if (ierr /= 0) return
    call lattice_views(out, ierr, errmsg)
    if (ierr /= 0) return

    ! Time series. Position chunks hold one step (whole rows, at most ~1 GiB).
    chunk_rows = max(1_hsize_t, min(int(out%ny, hsize_t), (2_hsize_t**30)/(24_hsize_t*out%nx)))
    call create_series(out, d_time, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    if (ierr == 0) call create_series(out, d_position, [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], &
      [3_hsize_t, int(out%nx, hsize_t), chunk_rows, 1_hsize_t], H5T_NATIVE_DOUBLE, ierr, errmsg)
    if (ierr == 0 .and. out%series%write_velocity) call create_series(out, d_velocity, &
      [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], &
      [3_hsize_t, int(out%nx, hsize_t), chunk_rows, 1_hsize_t], H5T_NATIVE_DOUBLE, ierr, errmsg)
    do i = d_kinetic, d_external_work
      if (ierr == 0) call create_series(out, i, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    end do
    do i = d_momentum, d_angular_momentum
      if (ierr == 0) call create_series(out, i, [3_hsize_t], [3_hsize_t, scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    end do
    do i = d_length, d_flatness
      if (ierr == 0) call create_series(out, i, [integer(hsize_t) ::], [scalar_chunk], H5T_NATIVE_DOUBLE, ierr, errmsg)
    end do
    do i = d_steps, d_linear_iterations
      if (ierr == 0) call create_series(out, i, [integer(hsize_t) ::], [scalar_chunk], H5T_STD_I64LE, ierr, errmsg)
    end do
    call netcdf_dims(out, ierr, errmsg)
    if (ierr /= 0) return

    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', filename, ierr, errmsg)
  end procedure open_local

  ! ---------------------------------------------------------------------------
  ! Closing, errors, file names.

  !> Close every id that is open (datasets, transfer list, file); keeps the first error.
  module procedure close_ids
    integer :: i, h

    do i = 1, n_dsets
      if (out%series%dset(i) >= 0) call close_dset(out%series%dset(i), trim(dset_names(i)), ierr, errmsg)
      out%series%dset(i) = -1
    end do
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

  !> run.h5 -> run.xdmf beside it (safe_files' sidecar_path); the sidecar names the h5 file by its base name.
  module procedure sidecar_names
    integer :: n, slash

    n = len_trim(filename)
    xmf_path = sidecar_path(filename(1:n))
    slash = index(filename(1:n), '/', back=.true.)
    h5_base = filename(slash+1:n)
  end procedure sidecar_names

  module procedure flush_file
    integer :: h
    call h5fflush_f(out%file, H5F_SCOPE_GLOBAL_F, h)
    if (h < 0) call fail('h5fflush_f', out%safe%final_path, ierr, errmsg)
  end procedure flush_file

end submodule output_files
