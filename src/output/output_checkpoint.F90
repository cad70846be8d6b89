! SPDX-License-Identifier: BSD-2-Clause
!> Module output: checkpoint write, reopen of an earlier run's file and
!> checkpoint read (the checks on what is read are module checkpoint_check's).
submodule (output) output_checkpoint
  implicit none

contains

  ! ---------------------------------------------------------------------------
  ! Checkpoints in the run's own file, and the reopening of that file to
  ! continue the run (-nuno_restart).
  !
  ! Layout (docs/model.md section 9, docs/design.md "Checkpoints"):
  ! /checkpoint/slot_0 and /checkpoint/slot_1, each with the datasets
  ! position and velocity [ny][nx][3] (float64, the exact state) and the
  ! attributes of checkpoint_t. A checkpoint goes into the slot that does not
  ! hold the last valid one: its attribute sequence is set to 0 (invalid)
  ! and flushed, then the state and attributes are written and flushed, then
  ! sequence = the next number is written and flushed, last. A kill at any
  ! moment leaves the other slot valid; a reader takes the slot with the
  ! largest sequence > 0.


  !> Write a checkpoint: the state strips x, v (3, 0:nx-1, ys:ys+ym-1) and
  !> ck, into the slot that does not hold the last valid one; its
  !> sequence attribute, written last, makes it valid. Collective.
  module subroutine output_write_checkpoint(out, ck, x, v, ierr, errmsg)
    type(output_file), intent(inout) :: out
    type(checkpoint_t), intent(inout) :: ck
    real(rp), intent(in) :: x(:, :, :), v(:, :, :)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: grp, dset
    integer(hsize_t) :: nx, ny, ys, ym
    integer :: slot, k
    character(len=:), allocatable :: where
    character(len=*), parameter :: fields(2) = [character(len=8) :: 'position', 'velocity']

    ierr = 0
    errmsg = ''
    if (.not. out%is_open) then
      ierr = 1
      errmsg = 'output_write_checkpoint: the output file is not open'
      return
    end if
    nx = out%nx; ny = out%ny; ys = out%ys; ym = out%ym
    if (size(x, 1) /= 3 .or. size(x, 2) /= out%nx .or. size(x, 3) /= out%ym .or. &
        any(shape(v) /= shape(x))) then
      ierr = 1
      errmsg = 'output_write_checkpoint: x and v must be (3, nx, ym)'
    end if
    call agree(out%comm, 'output_write_checkpoint', ierr, errmsg)
    if (ierr /= 0) return

    ! (a restart point, kept at an earlier output step, holds its own count)
    if (ck%n_output_steps <= 0) ck%n_output_steps = out%series%nt
    call check_space(out, 48.0_rp * (1 + ck%start_count) * out%nx * out%ny + 65536.0_rp, 'a checkpoint', ierr, errmsg)
    if (ierr /= 0) then
      errmsg = 'checkpoint not written: '//trim(errmsg)
      return
    end if
    slot = merge(0, 1 - out%ckpt%ck_slot, out%ckpt%ck_slot < 0)
    where = trim(slot_names(slot))
    grp = -1
    call open_or_create_group(out%file, '/checkpoint', grp, ierr, errmsg)
    if (grp >= 0) call close_group(grp, '/checkpoint', ierr, errmsg)
    grp = -1
    if (all_ok()) call open_or_create_group(out%file, where, grp, ierr, errmsg)
    ! Invalid while it is being written, and that on disk before anything else.
    if (all_ok()) call set_attr_int(grp, 'sequence', 0, where, ierr, errmsg)
    if (all_ok()) call flush_file(out, ierr, errmsg)
    do k = 1, 2
      if (.not. all_ok()) exit
      call open_or_create_state(out, grp, where//'/'//trim(fields(k)), trim(fields(k)), dset, ierr, errmsg)
      if (.not. all_ok()) exit
      if (k == 1) then
        call write_rows(out%dxpl, dset, where//'/position', [0_hsize_t, 0_hsize_t, ys], &
                        [3_hsize_t, nx, ym], x, ierr, errmsg)
      else
        call write_rows(out%dxpl, dset, where//'/velocity', [0_hsize_t, 0_hsize_t, ys], &
                        [3_hsize_t, nx, ym], v, ierr, errmsg)
      end if
      call close_dset(dset, where//'/'//trim(fields(k)), ierr, errmsg)
    end do
    ! The Newton start's earlier states (start_position_1.., start_velocity_1..)
    do k = 1, ck%start_count
      if (.not. all_ok()) exit
      call write_state(where//'/start_position_'//itoa(k), 'start_position_'//itoa(k), ck%start_x(:, :, :, k))
      if (.not. all_ok()) exit
      call write_state(where//'/start_velocity_'//itoa(k), 'start_velocity_'//itoa(k), ck%start_v(:, :, :, k))
    end do
    ! Attributes: metadata, written at the flush (which is agreed on).
    if (all_ok()) then
      call set_attr_reals(grp, 'time', [ck%time], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'dt_next', [ck%dt_next], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'wall_time', [ck%wall_time], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'dissipated', [ck%dissipated], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'work_constraints', [ck%work_constraints], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'mgx0', [ck%mgx0], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 't_written', [ck%t_written], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'counters', ck%counters, where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'n_output_steps', ck%n_output_steps, where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'stretch_warned', ck%stretch_warned, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'reason', trim(ck%reason), where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'ts_type', trim(ck%ts_type), where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'start_count', ck%start_count, where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'start_times', ck%start_t, where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'start_compare', ck%start_compare, where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'start_nc_prev', [ck%start_nc_prev], where, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'newton_floor', [ck%newton_floor], where, ierr, errmsg)
      if (ierr == 0 .and. ck%contact /= 0) then
        call set_attr_reals(grp, 'contact_friction_work', [ck%friction_work], where, ierr, errmsg)
        if (ierr == 0) call set_attr_reals(grp, 'contact_obstacle_work', [ck%obstacle_work], where, ierr, errmsg)
        if (ierr == 0) call set_attr_reals(grp, 'contact_min_gap_run', [ck%min_gap_run], where, ierr, errmsg)
        if (ierr == 0) call set_attr_int(grp, 'contact_states_checked', ck%states_checked, where, ierr, errmsg)
        if (ierr == 0) call set_attr_int(grp, 'contact_limited_steps', ck%limited_steps, where, ierr, errmsg)
      end if
    end if
    if (all_ok()) call flush_file(out, ierr, errmsg)
    ! Valid from here on.
    if (all_ok()) call set_attr_int(grp, 'sequence', out%ckpt%ck_seq + 1, where, ierr, errmsg)
    if (all_ok()) call flush_file(out, ierr, errmsg)
    if (grp >= 0) call close_group(grp, where, ierr, errmsg)
    call agree(out%comm, 'output_write_checkpoint', ierr, errmsg)
    if (ierr /= 0) then
      call add_cause(out, errmsg)
      errmsg = 'checkpoint not written: '//trim(errmsg)
      return
    end if
    out%ckpt%ck_seq = out%ckpt%ck_seq + 1
    out%ckpt%ck_slot = slot
    ck%sequence = out%ckpt%ck_seq
  contains
    logical function all_ok()
      call agree(out%comm, 'output_write_checkpoint', ierr, errmsg)
      all_ok = ierr == 0
    end function all_ok
    subroutine write_state(path, name, a)
      character(*), intent(in) :: path, name
      real(rp), intent(in) :: a(:, :, :)
      call open_or_create_state(out, grp, path, name, dset, ierr, errmsg)
      if (ierr /= 0) return
      call write_rows(out%dxpl, dset, path, [0_hsize_t, 0_hsize_t, ys], [3_hsize_t, nx, ym], a, ierr, errmsg)
      call close_dset(dset, path, ierr, errmsg)
    end subroutine write_state
  end subroutine output_write_checkpoint

  !> Close the file and the HDF5 library and open both again, with the
  !> series as they were (every REFRESH_STEPS output steps, from
  !> output_write_step). Parallel HDF5 1.10.8 keeps memory for every object
  !> created in a file opened with the MPI-IO driver until the library
  !> closes (about 20 kB a rank for each /xdmf view, 6 kB for a plain
  !> dataset; closing the file alone does not release it): without this a
  !> run grew by 10-25 kB a rank for each output step (docs/stability.md,
  !> "Memory over a long run"). Nothing else in nuno holds an HDF5 object
  !> while a run writes its output. Collective.
  module subroutine refresh_library(out, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=:), allocatable :: path
    integer(hid_t) :: fapl
    integer :: h, i
    logical :: exists_

    if (ierr /= 0) return
    path = out%safe%work_path
    if (out%safe%committed) path = out%safe%final_path
    call close_ids(out, ierr, errmsg)
    call h5close_f(h)
    if (h < 0) call fail('h5close_f', path, ierr, errmsg)
    call h5open_f(h)
    if (h < 0) call fail('h5open_f', path, ierr, errmsg)
    call h5eset_auto_f(0, h)
    fapl = -1
    if (ierr == 0) then
      call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
      if (h < 0) call fail('h5pcreate_f(file access)', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5pset_fapl_mpio_f(fapl, out%comm, MPI_INFO_NULL, h)
      if (h < 0) call fail('h5pset_fapl_mpio_f', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      ! (the bounds of open_local: the views need the 1.10 format)
      call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V110_F, h)
      if (h < 0) call fail('h5pset_libver_bounds_f', path, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5fopen_f(path, H5F_ACC_RDWR_F, out%file, h, access_prp=fapl)
      if (h < 0) then
        out%file = -1
        call fail('h5fopen_f (reopening)', path, ierr, errmsg)
      end if
    end if
    if (fapl >= 0) call h5pclose_f(fapl, h)
    if (ierr == 0) then
      call h5pcreate_f(H5P_DATASET_XFER_F, out%dxpl, h)
      if (h < 0) then
        out%dxpl = -1
        call fail('h5pcreate_f(dataset transfer)', path, ierr, errmsg)
      end if
    end if
    if (ierr == 0) then
      call h5pset_dxpl_mpio_f(out%dxpl, H5FD_MPIO_COLLECTIVE_F, h)
      if (h < 0) call fail('h5pset_dxpl_mpio_f', path, ierr, errmsg)
    end if
    do i = 1, n_dsets
      if (ierr /= 0) exit
      if (i == d_velocity .and. .not. out%series%write_velocity) cycle
      if (i >= d_contact_first .and. .not. out%series%contact) cycle
      call h5lexists_f(out%file, trim(dset_names(i)), exists_, h)
      if (h < 0) call fail('h5lexists_f', trim(dset_names(i)), ierr, errmsg)
      if (ierr /= 0 .or. .not. exists_) cycle
      call h5dopen_f(out%file, trim(dset_names(i)), out%series%dset(i), h)
      if (h < 0) then
        out%series%dset(i) = -1
        call fail('h5dopen_f', trim(dset_names(i)), ierr, errmsg)
      end if
    end do
    if (ierr /= 0) out%is_open = out%file >= 0
  end subroutine refresh_library

  !> The output steps completely written so far.
  integer module function output_steps(out)
    type(output_file), intent(in) :: out
    output_steps = out%series%nt
  end function output_steps

  !> Open an earlier run's file to continue it from its last valid
  !> checkpoint: lock it, check the lattice and that the checkpoint is
  !> before t_end, read ck and the state strips, cut the series back to the
  !> checkpoint's output steps, mark it running. Nothing is changed in the
  !> file when a check fails. Collective.
  module procedure output_reopen
    integer(hid_t) :: fapl, grp
    integer :: h, mpierr, fnx, fny, slot, seq(0:1), k, restarts, extent, n
    logical :: exists, has_velocity, attempt
    character(len=:), allocatable :: where
    character(len=256) :: why

    ierr = 0
    errmsg = ''
    if (out%is_open) then
      ierr = 1
      errmsg = 'output_reopen: handle already open ('//filename//')'
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
    ! A run that has not yet given its file the output's name (killed
    ! before its first output step, or one that keeps an earlier result
    ! until it completes) left OUTPUT.partial: the restart continues that,
    ! named either way, and gives it the name OUTPUT as a run would.
    n = len(filename)
    attempt = .false.
    if (n > 8) attempt = filename(n - 7:n) == '.partial'
    if (attempt) then
      out%safe%final_path = filename(1:n - 8)
      out%safe%work_path = filename
    else
      if (out%rank == 0) attempt = path_kind(filename//'.partial', why) == kind_file
      call MPI_Bcast(attempt, 1, MPI_LOGICAL, 0, comm, mpierr)
      out%safe%final_path = filename
      out%safe%work_path = filename
      if (attempt) out%safe%work_path = filename//'.partial'
    end if
    call sidecar_names(out%safe%final_path, out%safe%xmf_path, out%safe%h5_base)
    out%safe%lock_path = out%safe%final_path//'.lock'
    ! In place: the checkpoint is in it already.
    out%safe%committed = out%safe%work_path == out%safe%final_path
    out%ckpt%reopened = .true.
    out%safe%stepped = .true.          ! a result already: never removed
    out%safe%overwrite = .false.
    if (present(overwrite)) out%safe%overwrite = overwrite

    if (out%rank == 0) then
      if (.not. file_exists(out%safe%work_path)) then
        ierr = 1
        errmsg = '-nuno_restart '//filename//': no such file'
      else
        call claim_files(out, ierr, errmsg, protect)
        if (ierr == 0 .and. .not. out%safe%committed) write(*, '(a)') 'nuno: -nuno_restart: continuing '// &
          out%safe%work_path//', the last run''s file; it becomes '//out%safe%final_path//' as a run''s file does'
      end if
    end if
    call MPI_Bcast(out%safe%had_earlier, 1, MPI_LOGICAL, 0, comm, mpierr)
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
      return
    end if

    call h5open_f(h)
    call h5eset_auto_f(0, h)
    call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, h)
    if (h < 0) call fail('h5pcreate_f(file access)', filename, ierr, errmsg)
    if (ierr == 0) then
      call h5pset_fapl_mpio_f(fapl, comm, MPI_INFO_NULL, h)
      if (h < 0) call fail('h5pset_fapl_mpio_f', filename, ierr, errmsg)
    end if
    if (ierr == 0) then
      call h5fopen_f(out%safe%work_path, H5F_ACC_RDWR_F, out%file, h, access_prp=fapl)
      if (h < 0) then
        ierr = 1
        errmsg = '-nuno_restart '//out%safe%work_path//': not an HDF5 file that can be opened for writing'
      end if
      call h5pclose_f(fapl, h)
    end if
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
      return
    end if
    out%is_open = .true.
    call h5pcreate_f(H5P_DATASET_XFER_F, out%dxpl, h)
    if (h < 0) call fail('h5pcreate_f(dataset transfer)', filename, ierr, errmsg)
    if (ierr == 0) then
      call h5pset_dxpl_mpio_f(out%dxpl, H5FD_MPIO_COLLECTIVE_F, h)
      if (h < 0) call fail('h5pset_dxpl_mpio_f', filename, ierr, errmsg)
    end if

    ! The same lattice and series; a valid checkpoint.
    fnx = -1
    fny = -1
    if (ierr == 0) call get_attr_int(out%file, 'nx', '/', fnx, ierr, errmsg)
    if (ierr == 0) call get_attr_int(out%file, 'ny', '/', fny, ierr, errmsg)
    if (ierr /= 0) then
      errmsg = '-nuno_restart '//filename//': not a nuno output file ('//trim(errmsg)//')'
    else if (fnx /= nx .or. fny /= ny) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': its lattice is nx = '//itoa(fnx)//', ny = '//itoa(fny)// &
               ', the input''s nx = '//itoa(nx)//', ny = '//itoa(ny)
    end if
    if (ierr == 0) then
      call h5lexists_f(out%file, 'velocity', has_velocity, h)
      if (h < 0) call fail('h5lexists_f', '/velocity', ierr, errmsg)
      if (ierr == 0 .and. (has_velocity .neqv. write_velocity)) then
        ierr = 1
        errmsg = '-nuno_restart '//filename//': &output: write_velocity = '// &
                 trim(merge('.true. ', '.false.', write_velocity))//' but the file was written with '// &
                 trim(merge('.true. ', '.false.', has_velocity))//': the series must go on as it began'
      end if
    end if
    ! the same scene and model constants (module checkpoint_check)
    if (ierr == 0 .and. present(cfg)) call scene_refusal(out%file, filename, cfg, ierr, errmsg)
    seq = 0
    do k = 0, 1
      if (ierr /= 0) exit
      call h5lexists_f(out%file, 'checkpoint', exists, h)
      if (h < 0) call fail('h5lexists_f', '/checkpoint', ierr, errmsg)
      if (.not. exists .or. ierr /= 0) exit
      call h5lexists_f(out%file, trim(slot_names(k)), exists, h)
      if (h < 0) call fail('h5lexists_f', trim(slot_names(k)), ierr, errmsg)
      if (exists .and. ierr == 0) then
        call h5gopen_f(out%file, trim(slot_names(k)), grp, h)
        if (h < 0) then
          call fail('h5gopen_f', trim(slot_names(k)), ierr, errmsg)
        else
          call h5aexists_f(grp, 'sequence', exists, h)
          if (exists) call get_attr_int(grp, 'sequence', trim(slot_names(k)), seq(k), ierr, errmsg)
          call close_group(grp, trim(slot_names(k)), ierr, errmsg)
        end if
      end if
    end do
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr == 0 .and. maxval(seq) <= 0) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': no valid checkpoint in it (one is written at the end of a run, '// &
               'on SIGTERM/SIGINT, every checkpoint_interval and every -nuno_checkpoint_walltime)'
    end if
    if (ierr == 0) then
      slot = maxloc(seq, 1) - 1
      where = trim(slot_names(slot))
      call read_checkpoint(out, where, ck, x, v, ierr, errmsg)
      ck%sequence = seq(slot)
      out%ckpt%ck_seq = seq(slot)
      out%ckpt%ck_slot = slot
      ! a sound checkpoint, checked before anything in the file changes
      call agree(comm, '-nuno_restart', ierr, errmsg)
      if (ierr == 0) call checkpoint_refusal(out%file, filename, where, ck, x, v, comm, ierr, errmsg)
      if (ierr == 0 .and. ck%time >= t_end - 1.0e-12_rp * max(1.0_rp, t_end)) then
        ierr = 1
        write(errmsg, '(a,es12.5e2,a,es12.5e2,a)') '-nuno_restart '//filename//': its last checkpoint is at t =', &
          ck%time, ', not before t_end =', t_end, ': nothing to continue (a later t_end: -nuno_set t_end=...)'
      end if
    end if

    ! The series, cut back to the checkpoint's output steps: what a run
    ! wrote after its last checkpoint is computed again (the same way).
    ! So are the XDMF views: those of later steps are deleted, those of the
    ! kept steps (and of the lattice) made where the file lacks them (a file
    ! of an earlier version). All ranks take part (collective calls).
    call agree(comm, '-nuno_restart', ierr, errmsg)
    extent = 0
    if (ierr == 0) call open_series(out, ck%n_output_steps, extent, ierr, errmsg)
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr == 0) call sync_views(out, extent, ierr, errmsg)
    if (ierr == 0) then
      restarts = 0
      call h5aexists_by_name_f(out%file, 'run', 'restarts', exists, h)
      if (h >= 0 .and. exists) then
        call h5gopen_f(out%file, 'run', grp, h)
        if (h >= 0) then
          call get_attr_int(grp, 'restarts', '/run', restarts, ierr, errmsg)
          call close_group(grp, '/run', ierr, errmsg)
        end if
      end if
      out%ckpt%restarts = restarts + 1
      call open_or_create_group(out%file, '/run', grp, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'restarts', out%ckpt%restarts, '/run', ierr, errmsg)
      if (grp >= 0) call close_group(grp, '/run', ierr, errmsg)
      where = '/run/restart_'//itoa(out%ckpt%restarts)
      if (ierr == 0) call open_or_create_group(out%file, where, grp, ierr, errmsg)
      if (ierr == 0) call set_attr_reals(grp, 'from_time', [ck%time], where, ierr, errmsg)
      if (ierr == 0) call set_attr_int(grp, 'from_checkpoint', ck%sequence, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'namelist', attrs_namelist, where, ierr, errmsg)
      if (ierr == 0) call set_attr_str(grp, 'petsc_options', attrs_petsc_options, where, ierr, errmsg)
      if (grp >= 0) call close_group(grp, where, ierr, errmsg)
    end if
    if (ierr == 0) call set_attr_str(out%file, 'status', 'running', '/', ierr, errmsg)
    if (ierr == 0) call set_attr_int(out%file, 'n_ranks', out%n_ranks, '/', ierr, errmsg)
    if (ierr == 0) call flush_file(out, ierr, errmsg)
    call agree(comm, '-nuno_restart', ierr, errmsg)
    if (ierr /= 0) then
      call close_ids(out, ierr, errmsg)
      out%is_open = .false.
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
    end if
  end procedure output_reopen

  ! ---------------------------------------------------------------------------

  !> The attributes and state strips of the checkpoint slot `where`.
  subroutine read_checkpoint(out, where, ck, x, v, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: where
    type(checkpoint_t), intent(out) :: ck
    real(rp), intent(out) :: x(:, :, :), v(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    integer :: h, k
    real(rp) :: r(1)
    logical :: exists

    call h5gopen_f(out%file, where, grp, h)
    if (h < 0) then
      call fail('h5gopen_f', where, ierr, errmsg); return
    end if
    call get_attr_reals(grp, 'time', where, r, ierr, errmsg); ck%time = r(1)
    call get_attr_reals(grp, 'dt_next', where, r, ierr, errmsg); ck%dt_next = r(1)
    call get_attr_reals(grp, 'wall_time', where, r, ierr, errmsg); ck%wall_time = r(1)
    call get_attr_reals(grp, 'dissipated', where, r, ierr, errmsg); ck%dissipated = r(1)
    call get_attr_reals(grp, 'work_constraints', where, r, ierr, errmsg); ck%work_constraints = r(1)
    call get_attr_reals(grp, 'mgx0', where, r, ierr, errmsg); ck%mgx0 = r(1)
    call get_attr_reals(grp, 't_written', where, r, ierr, errmsg); ck%t_written = r(1)
    call get_attr_reals(grp, 'counters', where, ck%counters, ierr, errmsg)
    call get_attr_int(grp, 'n_output_steps', where, ck%n_output_steps, ierr, errmsg)
    call get_attr_int(grp, 'stretch_warned', where, ck%stretch_warned, ierr, errmsg)
    call get_attr_str(grp, 'reason', where, ck%reason, ierr, errmsg)
    call get_attr_str(grp, 'ts_type', where, ck%ts_type, ierr, errmsg)
    ! the Newton start's earlier states: not in files written before 4 Dec 2026
    call h5aexists_f(grp, 'start_count', exists, h)
    if (h < 0) call fail('h5aexists_f', where//' start_count', ierr, errmsg)
    ck%start_count = 0
    if (ierr == 0 .and. exists) then
      call get_attr_int(grp, 'start_count', where, ck%start_count, ierr, errmsg)
      call get_attr_reals(grp, 'start_times', where, ck%start_t, ierr, errmsg)
      call get_attr_int(grp, 'start_compare', where, ck%start_compare, ierr, errmsg)
      call get_attr_reals(grp, 'start_nc_prev', where, r, ierr, errmsg); ck%start_nc_prev = r(1)
      if (ck%start_count < 0 .or. ck%start_count > 3) then
        ierr = 1
        errmsg = where//': start_count '//itoa(ck%start_count)//' is not 0..3'
      end if
    end if
    ! the Newton floor: not in files written before 5 Dec 2026
    call h5aexists_f(grp, 'newton_floor', exists, h)
    if (h < 0) call fail('h5aexists_f', where//' newton_floor', ierr, errmsg)
    ck%newton_floor = 0
    if (ierr == 0 .and. exists) then
      call get_attr_reals(grp, 'newton_floor', where, r, ierr, errmsg); ck%newton_floor = r(1)
    end if
    ! contact's run diagnostics: scenes with obstacles (none in files written before /contact)
    call h5aexists_f(grp, 'contact_friction_work', exists, h)
    if (h < 0) call fail('h5aexists_f', where//' contact_friction_work', ierr, errmsg)
    ck%contact = 0
    if (ierr == 0 .and. exists) then
      ck%contact = 1
      call get_attr_reals(grp, 'contact_friction_work', where, r, ierr, errmsg); ck%friction_work = r(1)
      call get_attr_reals(grp, 'contact_min_gap_run', where, r, ierr, errmsg); ck%min_gap_run = r(1)
      call get_attr_int(grp, 'contact_states_checked', where, ck%states_checked, ierr, errmsg)
      call get_attr_int(grp, 'contact_limited_steps', where, ck%limited_steps, ierr, errmsg)
    end if
    ! the moving obstacles' work: not in files written before it (static obstacles: 0)
    ck%obstacle_work = 0
    if (ierr == 0 .and. ck%contact /= 0) then
      call h5aexists_f(grp, 'contact_obstacle_work', exists, h)
      if (h < 0) call fail('h5aexists_f', where//' contact_obstacle_work', ierr, errmsg)
      if (ierr == 0 .and. exists) then
        call get_attr_reals(grp, 'contact_obstacle_work', where, r, ierr, errmsg); ck%obstacle_work = r(1)
      end if
    end if
    call close_group(grp, where, ierr, errmsg)
    if (ierr /= 0) return
    call read_rows3(out, where//'/position', x, ierr, errmsg)
    call read_rows3(out, where//'/velocity', v, ierr, errmsg)
    allocate(ck%start_x(size(x, 1), size(x, 2), size(x, 3), ck%start_count), &
             ck%start_v(size(x, 1), size(x, 2), size(x, 3), ck%start_count))
    do k = 1, ck%start_count
      call read_rows3(out, where//'/start_position_'//itoa(k), ck%start_x(:, :, :, k), ierr, errmsg)
      call read_rows3(out, where//'/start_velocity_'//itoa(k), ck%start_v(:, :, :, k), ierr, errmsg)
    end do
  end subroutine read_checkpoint

  !> A fixed [ny][nx][3] state dataset of a checkpoint slot, created on first use.
  subroutine open_or_create_state(out, grp, path, name, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: path, name
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    logical :: exists
    integer :: h

    dset = -1
    call h5lexists_f(grp, name, exists, h)
    if (h < 0) then
      call fail('h5lexists_f', path, ierr, errmsg); return
    end if
    if (exists) then
      call h5dopen_f(grp, name, dset, h)
      if (h < 0) call fail('h5dopen_f', path, ierr, errmsg)
      return
    end if
    call h5screate_simple_f(3, [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], space, h)
    if (h < 0) then
      call fail('h5screate_simple_f', path, ierr, errmsg); return
    end if
    call h5dcreate_f(grp, name, H5T_NATIVE_DOUBLE, space, dset, h)
    if (h < 0) call fail('h5dcreate_f', path, ierr, errmsg)
    call h5sclose_f(space, h)
    if (ierr /= 0) dset = -1
  end subroutine open_or_create_state

  !> Collective read of this rank's rows of a [ny][nx][3] dataset into a(3, nx, ym).
  subroutine read_rows3(out, path, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: path
    real(rp), intent(out) :: a(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dset, fspace, mspace
    integer(hsize_t) :: count(3)
    integer :: h
    real(rp) :: empty(1)

    a = 0
    if (ierr /= 0) return
    call h5dopen_f(out%file, path, dset, h)
    if (h < 0) then
      call fail('h5dopen_f', path, ierr, errmsg); return
    end if
    count = [3_hsize_t, int(out%nx, hsize_t), int(out%ym, hsize_t)]
    call select_spaces(dset, path, [0_hsize_t, 0_hsize_t, int(out%ys, hsize_t)], count, product(count) == 0, &
                       fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      if (product(count) == 0) then
        call h5dread_f(dset, H5T_NATIVE_DOUBLE, empty, [1_hsize_t], h, mem_space_id=mspace, file_space_id=fspace, &
                       xfer_prp=out%dxpl)
      else
        call h5dread_f(dset, H5T_NATIVE_DOUBLE, a, count, h, mem_space_id=mspace, file_space_id=fspace, &
                       xfer_prp=out%dxpl)
      end if
      if (h < 0) call fail('h5dread_f', path, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, path, ierr, errmsg)
    call close_dset(dset, path, ierr, errmsg)
  end subroutine read_rows3

end submodule output_checkpoint
