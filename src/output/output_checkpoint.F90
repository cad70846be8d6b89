! SPDX-License-Identifier: BSD-2-Clause
!> Module output: checkpoint write, reopen of an earlier run's file and
!> checkpoint read (the checks on what is read are module checkpoint_check's).
submodule (output) output_checkpoint
  implicit none

  character(len=*), parameter :: WRITER = 'output_write_checkpoint'   ! agree's name of the checkpoint write
  character(len=*), parameter :: RESTART = '-nuno_restart'            ! agree's name of the reopening

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
  module procedure output_write_checkpoint
    integer(hid_t) :: grp
    integer :: slot, k
    character(len=:), allocatable :: where

    call require_open(out, 'output_write_checkpoint', ierr, errmsg)
    if (ierr /= 0) return
    if (size(x, 1) /= 3 .or. size(x, 2) /= out%nx .or. size(x, 3) /= out%ym .or. &
        any(shape(v) /= shape(x))) then
      ierr = 1
      errmsg = 'output_write_checkpoint: x and v must be (3, nx, ym)'
    end if
    call agree(out%comm, WRITER, ierr, errmsg)
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
    call open_or_create_group(out%file, '/checkpoint', grp, ierr, errmsg)
    call close_group(grp, '/checkpoint', ierr, errmsg)
    grp = -1
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call open_or_create_group(out%file, where, grp, ierr, errmsg)
    ! Invalid while it is being written, and that on disk before anything else.
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call set_attr_int(grp, 'sequence', 0, where, ierr, errmsg)
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call flush_file(out, ierr, errmsg)
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call write_state(out, where, 'position', x, ierr, errmsg)
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call write_state(out, where, 'velocity', v, ierr, errmsg)
    ! The Newton start's earlier states (start_position_1.., start_velocity_1..)
    do k = 1, ck%start_count
      if (all_agree(out%comm, WRITER, ierr, errmsg)) &
        call write_state(out, where, 'start_position_'//itoa(k), ck%start_x(:, :, :, k), ierr, errmsg)
      if (all_agree(out%comm, WRITER, ierr, errmsg)) &
        call write_state(out, where, 'start_velocity_'//itoa(k), ck%start_v(:, :, :, k), ierr, errmsg)
    end do
    ! Attributes: metadata, written at the flush (which is agreed on).
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call write_checkpoint_attrs(grp, where, ck, ierr, errmsg)
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call flush_file(out, ierr, errmsg)
    ! Valid from here on.
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call set_attr_int(grp, 'sequence', out%ckpt%ck_seq + 1, where, ierr, errmsg)
    if (all_agree(out%comm, WRITER, ierr, errmsg)) call flush_file(out, ierr, errmsg)
    call close_group(grp, where, ierr, errmsg)
    call agree(out%comm, WRITER, ierr, errmsg)
    if (ierr /= 0) then
      call add_cause(out, errmsg)
      errmsg = 'checkpoint not written: '//trim(errmsg)
      return
    end if
    out%ckpt%ck_seq = out%ckpt%ck_seq + 1
    out%ckpt%ck_slot = slot
    ck%sequence = out%ckpt%ck_seq
  end procedure output_write_checkpoint

  !> The state a(3, nx, ym) of this rank into the dataset `name` of the
  !> checkpoint slot `where` (made on first use). Collective.
  subroutine write_state(out, where, name, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: where, name
    real(rp), intent(in) :: a(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: dset
    character(len=:), allocatable :: path

    path = where//'/'//name
    call open_or_create_state(out, path, dset, ierr, errmsg)
    if (.not. all_agree(out%comm, WRITER, ierr, errmsg)) return
    call write_rows(out%dxpl, dset, path, [0_hsize_t, 0_hsize_t, int(out%ys, hsize_t)], &
                    [3_hsize_t, int(out%nx, hsize_t), int(out%ym, hsize_t)], a, ierr, errmsg)
    call close_dset(dset, path, ierr, errmsg)
  end subroutine write_state

  !> The attributes of checkpoint_t on the slot's group grp (at where).
  subroutine write_checkpoint_attrs(grp, where, ck, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: where
    type(checkpoint_t), intent(in) :: ck
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: k

    call set_attr_reals(grp, 'time', [ck%time], where, ierr, errmsg)
    call set_attr_reals(grp, 'dt_next', [ck%dt_next], where, ierr, errmsg)
    call set_attr_reals(grp, 'wall_time', [ck%wall_time], where, ierr, errmsg)
    call set_attr_reals(grp, 'dissipated', [ck%dissipated], where, ierr, errmsg)
    call set_attr_reals(grp, 'work_constraints', [ck%work_constraints], where, ierr, errmsg)
    call set_attr_reals(grp, 'mgx0', [ck%mgx0], where, ierr, errmsg)
    call set_attr_reals(grp, 't_written', [ck%t_written], where, ierr, errmsg)
    call set_attr_reals(grp, 'counters', ck%counters, where, ierr, errmsg)
    call set_attr_int(grp, 'n_output_steps', ck%n_output_steps, where, ierr, errmsg)
    call set_attr_int(grp, 'stretch_warned', ck%stretch_warned, where, ierr, errmsg)
    call set_attr_str(grp, 'reason', trim(ck%reason), where, ierr, errmsg)
    call set_attr_str(grp, 'ts_type', trim(ck%ts_type), where, ierr, errmsg)
    call set_attr_int(grp, 'start_count', ck%start_count, where, ierr, errmsg)
    call set_attr_reals(grp, 'start_times', ck%start_t, where, ierr, errmsg)
    call set_attr_int(grp, 'start_compare', ck%start_compare, where, ierr, errmsg)
    call set_attr_reals(grp, 'start_nc_prev', [ck%start_nc_prev], where, ierr, errmsg)
    call set_attr_reals(grp, 'newton_floor', [ck%newton_floor], where, ierr, errmsg)
    ! the process models' state: each named value an attribute of its name
    if (allocated(ck%pm_values)) then
      do k = 1, size(ck%pm_values)
        associate (nv => ck%pm_values(k))
          if (nv%is_int) then
            call set_attr_int(grp, trim(nv%name), nint(nv%v(1)), where, ierr, errmsg)
          else
            call set_attr_reals(grp, trim(nv%name), nv%v, where, ierr, errmsg)
          end if
        end associate
      end do
    end if
  end subroutine write_checkpoint_attrs

  !> The output steps completely written so far.
  integer module function output_steps(out)
    type(output_file), intent(in) :: out
    output_steps = out%series%nt
  end function output_steps

  ! ---------------------------------------------------------------------------
  ! Reopening.

  !> Open an earlier run's file to continue it from its last valid
  !> checkpoint: lock it, check the lattice and that the checkpoint is
  !> before t_end, read ck and the state strips, let the run judge the
  !> state (judge: the process models' check), cut the series back to the
  !> checkpoint's output steps, mark it running. Nothing is changed in the
  !> file when a check fails. Collective.
  module procedure output_reopen
    integer :: seq(0:1), extent

    call handle_init(out, 'output_reopen', filename, comm, nx, ny, ys, ym, write_velocity, overwrite, ierr, errmsg)
    if (ierr /= 0) return
    call reopen_names(out, filename)
    call reopen_claim(out, filename, protect, ierr, errmsg)
    if (ierr == 0) call reopen_file(out, filename, ierr, errmsg)
    if (ierr /= 0) then
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
      return
    end if
    call collective_transfer(filename, out%dxpl, ierr, errmsg)

    ! The same lattice and series; a valid checkpoint.
    call refuse_other_run(out, filename, write_velocity, cfg, ierr, errmsg)
    call slot_sequences(out, seq, ierr, errmsg)
    call agree(comm, RESTART, ierr, errmsg)
    if (ierr == 0 .and. maxval(seq) <= 0) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': no valid checkpoint in it (one is written at the end of a run, '// &
               'on SIGTERM/SIGINT, every checkpoint_interval and every -nuno_checkpoint_walltime)'
    end if
    if (ierr == 0) then
      if (present(pm_names)) then
        call load_checkpoint(out, filename, seq, t_end, pm_names, ck, x, v, ierr, errmsg)
      else
        call load_checkpoint(out, filename, seq, t_end, [named_value_t ::], ck, x, v, ierr, errmsg)
      end if
    end if
    ! the run's judgement of the checkpoint's state (the process models'),
    ! before anything in the file changes
    call agree(comm, RESTART, ierr, errmsg)
    if (ierr == 0 .and. present(judge)) call judge%judge(ck%time, x, v, ierr, errmsg)

    ! The series, cut back to the checkpoint's output steps: what a run
    ! wrote after its last checkpoint is computed again (the same way).
    ! So are the XDMF views: those of later steps are deleted, those of the
    ! kept steps (and of the lattice) made where the file lacks them (a file
    ! of an earlier version). All ranks take part (collective calls).
    call agree(comm, RESTART, ierr, errmsg)
    extent = 0
    if (ierr == 0) call open_series(out, ck%n_output_steps, extent, ierr, errmsg)
    call agree(comm, RESTART, ierr, errmsg)
    if (ierr == 0) call sync_views(out, extent, ierr, errmsg)
    if (ierr == 0) call record_restart(out, ck, attrs_namelist, attrs_petsc_options, ierr, errmsg)
    call set_attr_str(out%file, 'status', 'running', '/', ierr, errmsg)
    call set_attr_int(out%file, 'n_ranks', out%n_ranks, '/', ierr, errmsg)
    if (ierr == 0) call flush_file(out, ierr, errmsg)
    call agree(comm, RESTART, ierr, errmsg)
    if (ierr /= 0) then
      call close_ids(out, ierr, errmsg)
      out%is_open = .false.
      if (out%rank == 0) call lock_release(out%safe%lock_path, out%safe%lock_fd)
    end if
  end procedure output_reopen

  !> The handle's names for `filename` and the state of a continued file. A
  !> run that has not yet given its file the output's name (killed before
  !> its first output step, or one that keeps an earlier result until it
  !> completes) left OUTPUT.partial: the restart continues that, named
  !> either way, and gives it the name OUTPUT as a run would. Collective
  !> (rank 0 looks for OUTPUT.partial).
  subroutine reopen_names(out, filename)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: filename
    character(len=256) :: why
    integer :: n, mpierr
    logical :: attempt

    n = len(filename)
    attempt = .false.
    if (n > 8) attempt = filename(n - 7:n) == '.partial'
    if (attempt) then
      out%safe%final_path = filename(1:n - 8)
      out%safe%work_path = filename
    else
      if (out%rank == 0) attempt = path_kind(filename//'.partial', why) == kind_file
      call MPI_Bcast(attempt, 1, MPI_LOGICAL, 0, out%comm, mpierr)
      out%safe%final_path = filename
      out%safe%work_path = filename
      if (attempt) out%safe%work_path = filename//'.partial'
    end if
    call sidecar_names(out%safe%final_path, out%safe%xmf_path, out%safe%h5_base, out%safe%obst_path)
    out%safe%lock_path = out%safe%final_path//'.lock'
    ! In place: the checkpoint is in it already.
    out%safe%committed = out%safe%work_path == out%safe%final_path
    out%ckpt%reopened = .true.
    out%safe%stepped = .true.          ! a result already: never removed
  end subroutine reopen_names

  !> Rank 0 claims the file (claim_files) and says which file goes on;
  !> every rank gets the answer. Collective.
  subroutine reopen_claim(out, filename, protect, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: filename, protect
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: mpierr

    if (out%rank == 0) then
      if (.not. file_exists(out%safe%work_path)) then
        ierr = 1
        errmsg = '-nuno_restart '//filename//': no such file'
      else
        call claim_files(out, protect, ierr, errmsg)
        if (ierr == 0 .and. .not. out%safe%committed) write(*, '(a)') 'nuno: -nuno_restart: continuing '// &
          out%safe%work_path//', the last run''s file; it becomes '//out%safe%final_path//' as a run''s file does'
      end if
    end if
    call MPI_Bcast(out%safe%had_earlier, 1, MPI_LOGICAL, 0, out%comm, mpierr)
    call agree(out%comm, RESTART, ierr, errmsg)
  end subroutine reopen_claim

  !> Open the claimed file for writing with the MPI-IO driver. Collective.
  subroutine reopen_file(out, filename, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: filename
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fapl
    integer :: h

    fapl = -1
    call library_open(filename, ierr, errmsg)
    if (ierr == 0) call mpio_access_list(out%comm, filename, fapl, ierr, errmsg)
    if (ierr == 0) then
      call h5fopen_f(out%safe%work_path, H5F_ACC_RDWR_F, out%file, h, access_prp=fapl)
      if (h < 0) then
        ierr = 1
        errmsg = '-nuno_restart '//out%safe%work_path//': not an HDF5 file that can be opened for writing'
      end if
    end if
    call close_access_list(fapl, filename, ierr, errmsg)
    call agree(out%comm, RESTART, ierr, errmsg)
    out%is_open = ierr == 0
  end subroutine reopen_file

  !> ierr = 1 unless the file is of the run the input describes: its
  !> lattice, its velocity series and (module checkpoint_check) its scene
  !> and model constants.
  subroutine refuse_other_run(out, filename, write_velocity, cfg, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: filename
    logical, intent(in) :: write_velocity
    type(nuno_config), intent(in) :: cfg
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: fnx, fny
    logical :: has_velocity

    call get_attr_int(out%file, 'nx', '/', fnx, ierr, errmsg)
    call get_attr_int(out%file, 'ny', '/', fny, ierr, errmsg)
    if (ierr /= 0) then
      errmsg = '-nuno_restart '//filename//': not a nuno output file ('//trim(errmsg)//')'
    else if (fnx /= out%nx .or. fny /= out%ny) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': its lattice is nx = '//itoa(fnx)//', ny = '//itoa(fny)// &
               ', the input''s nx = '//itoa(out%nx)//', ny = '//itoa(out%ny)
    end if
    if (ierr /= 0) return
    call has_link(out%file, 'velocity', '/velocity', has_velocity, ierr, errmsg)
    if (ierr == 0 .and. (has_velocity .neqv. write_velocity)) then
      ierr = 1
      errmsg = '-nuno_restart '//filename//': &output: write_velocity = '// &
               trim(merge('.true. ', '.false.', write_velocity))//' but the file was written with '// &
               trim(merge('.true. ', '.false.', has_velocity))//': the series must go on as it began'
    end if
    if (ierr == 0) call scene_refusal(out%file, filename, cfg, ierr, errmsg)
  end subroutine refuse_other_run

  !> The sequence attribute of each checkpoint slot (0: none, or invalid).
  subroutine slot_sequences(out, seq, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(out) :: seq(0:1)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    integer :: h, k
    logical :: exists

    seq = 0
    if (ierr /= 0) return
    call has_link(out%file, 'checkpoint', '/checkpoint', exists, ierr, errmsg)
    if (.not. exists) return
    do k = 0, 1
      call has_link(out%file, trim(slot_names(k)), trim(slot_names(k)), exists, ierr, errmsg)
      if (ierr /= 0) return
      if (.not. exists) cycle
      call h5gopen_f(out%file, trim(slot_names(k)), grp, h)
      if (h < 0) then
        call fail('h5gopen_f', trim(slot_names(k)), ierr, errmsg); return
      end if
      call h5aexists_f(grp, 'sequence', exists, h)
      if (h >= 0 .and. exists) call get_attr_int(grp, 'sequence', trim(slot_names(k)), seq(k), ierr, errmsg)
      call close_group(grp, trim(slot_names(k)), ierr, errmsg)
      if (ierr /= 0) return
    end do
  end subroutine slot_sequences

  !> Read the checkpoint of the slot with the largest sequence seq (with
  !> the process models' named values of pm_names) and refuse it unless it
  !> is sound (checkpoint_check) and before t_end. Collective.
  subroutine load_checkpoint(out, filename, seq, t_end, pm_names, ck, x, v, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: filename
    integer, intent(in) :: seq(0:1)
    real(rp), intent(in) :: t_end
    type(named_value_t), intent(in) :: pm_names(:)
    type(checkpoint_t), intent(out) :: ck
    real(rp), intent(out) :: x(:, :, :), v(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: slot
    character(len=:), allocatable :: where

    slot = maxloc(seq, 1) - 1
    where = trim(slot_names(slot))
    call read_checkpoint(out, where, pm_names, ck, x, v, ierr, errmsg)
    ck%sequence = seq(slot)
    out%ckpt%ck_seq = seq(slot)
    out%ckpt%ck_slot = slot
    ! a sound checkpoint, checked before anything in the file changes
    call agree(out%comm, RESTART, ierr, errmsg)
    if (ierr == 0) call checkpoint_refusal(out%file, filename, where, ck, x, v, out%comm, ierr, errmsg)
    if (ierr == 0 .and. ck%time >= t_end - 1.0e-12_rp * max(1.0_rp, t_end)) then
      ierr = 1
      write(errmsg, '(a,es12.5e2,a,es12.5e2,a)') '-nuno_restart '//filename//': its last checkpoint is at t =', &
        ck%time, ', not before t_end =', t_end, ': nothing to continue (a later t_end: -nuno_set t_end=...)'
    end if
  end subroutine load_checkpoint

  !> /run's count of restarts, and /run/restart_<k> of this one: the
  !> checkpoint it starts from and its input.
  subroutine record_restart(out, ck, attrs_namelist, attrs_petsc_options, ierr, errmsg)
    type(output_file), intent(inout) :: out
    type(checkpoint_t), intent(in) :: ck
    character(*), intent(in) :: attrs_namelist, attrs_petsc_options
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    integer :: h, restarts
    logical :: exists
    character(len=:), allocatable :: where

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
    call set_attr_int(grp, 'restarts', out%ckpt%restarts, '/run', ierr, errmsg)
    call close_group(grp, '/run', ierr, errmsg)
    where = '/run/restart_'//itoa(out%ckpt%restarts)
    call open_or_create_group(out%file, where, grp, ierr, errmsg)
    call set_attr_reals(grp, 'from_time', [ck%time], where, ierr, errmsg)
    call set_attr_int(grp, 'from_checkpoint', ck%sequence, where, ierr, errmsg)
    call set_attr_str(grp, 'namelist', attrs_namelist, where, ierr, errmsg)
    call set_attr_str(grp, 'petsc_options', attrs_petsc_options, where, ierr, errmsg)
    call close_group(grp, where, ierr, errmsg)
  end subroutine record_restart

  ! ---------------------------------------------------------------------------
  ! Checkpoint read.

  !> The attributes and state strips of the checkpoint slot `where` (the
  !> process models' values of pm_names that it has).
  subroutine read_checkpoint(out, where, pm_names, ck, x, v, ierr, errmsg)
    type(output_file), intent(inout) :: out
    character(*), intent(in) :: where
    type(named_value_t), intent(in) :: pm_names(:)
    type(checkpoint_t), intent(out) :: ck
    real(rp), intent(out) :: x(:, :, :), v(:, :, :)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp
    integer :: h, k

    call h5gopen_f(out%file, where, grp, h)
    if (h < 0) then
      call fail('h5gopen_f', where, ierr, errmsg); return
    end if
    call read_checkpoint_attrs(grp, where, pm_names, ck, ierr, errmsg)
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

  !> checkpoint_t from the attributes of the slot's group grp (at where);
  !> those that files of earlier versions lack take their neutral values;
  !> the process models' named values of pm_names that the slot has (with
  !> the sizes pm_names gives) into ck%pm_values.
  subroutine read_checkpoint_attrs(grp, where, pm_names, ck, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: where
    type(named_value_t), intent(in) :: pm_names(:)     !< the process models' values, their names and kinds
    type(checkpoint_t), intent(inout) :: ck
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp) :: r(1)
    integer :: k, iv
    type(named_value_t) :: nv

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
    ck%start_count = 0
    if (has_attr(grp, 'start_count', where, ierr, errmsg)) then
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
    ck%newton_floor = 0
    if (has_attr(grp, 'newton_floor', where, ierr, errmsg)) then
      call get_attr_reals(grp, 'newton_floor', where, r, ierr, errmsg); ck%newton_floor = r(1)
    end if
    ! the process models' named values: those of pm_names the slot has
    ! (a model restores what it finds: files of earlier versions lack some)
    allocate(ck%pm_values(0))
    do k = 1, size(pm_names)
      if (.not. has_attr(grp, trim(pm_names(k)%name), where, ierr, errmsg)) cycle
      nv = pm_names(k)
      if (nv%is_int) then
        call get_attr_int(grp, trim(nv%name), where, iv, ierr, errmsg)
        nv%v = [real(iv, rp)]
      else
        call get_attr_reals(grp, trim(nv%name), where, nv%v, ierr, errmsg)
      end if
      ck%pm_values = [ck%pm_values, nv]
    end do
  end subroutine read_checkpoint_attrs

  !> Whether grp (at where) has the attribute `name`: .false. when it has
  !> not, when the question fails (ierr set) or when ierr /= 0 already.
  logical function has_attr(grp, name, where, ierr, errmsg)
    integer(hid_t), intent(in) :: grp
    character(*), intent(in) :: name, where
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: h

    call h5aexists_f(grp, name, has_attr, h)
    if (h < 0) call fail('h5aexists_f', where//' '//name, ierr, errmsg)
    has_attr = has_attr .and. ierr == 0
  end function has_attr

  !> A fixed [ny][nx][3] state dataset (at the absolute path), created on first use.
  subroutine open_or_create_state(out, path, dset, ierr, errmsg)
    type(output_file), intent(in) :: out
    character(*), intent(in) :: path
    integer(hid_t), intent(out) :: dset
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    logical :: exists

    dset = -1
    call has_link(out%file, path, path, exists, ierr, errmsg)
    if (ierr /= 0) return
    if (exists) then
      call open_dset(out%file, path, dset, ierr, errmsg)
    else
      call create_doubles(out%file, path, path, [3_hsize_t, int(out%nx, hsize_t), int(out%ny, hsize_t)], dset, &
                          ierr, errmsg)
    end if
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
    call open_dset(out%file, path, dset, ierr, errmsg)
    if (ierr /= 0) return
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
