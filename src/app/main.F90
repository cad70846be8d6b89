! SPDX-License-Identifier: BSD-2-Clause
!> nuno (布, "cloth"): implicit mass-spring cloth dynamics.
!>   mpirun -n P nuno INPUT.nml [PETSc options]
!> Reads the namelist, builds the DMDA strips and the PETSc TS, integrates
!> the scene and writes one HDF5 file (+ XDMF sidecar). See input/README.md.
program nuno
#include "petsc/finclude/petscts.h"
  use petscts
  use mpi
  use config, only: nuno_config
  use lattice, only: rest_strip
  use strings, only: itoa
  use, intrinsic :: iso_fortran_env, only: int64
  use, intrinsic :: iso_c_binding, only: c_int
  use input, only: input_read, input_summary, input_check_run
  use input_usage, only: usage_text, list_keys
  use timestepping, only: app_ctx, solver_create, solver_destroy, solver_run, check_decomposition, solver_restore, &
                          restart_state_t, restart_state_init, restart_state_free, restart_judge_t, restart_judge, &
                          checkpoint_pm_names
  use output, only: output_file, output_open, output_close, output_reopen, checkpoint_t, output_write_identify, &
                    output_write_control, named_value_t
  use identify, only: ident_t, identify_prepare_options, identify_run, identify_result, control_result, &
                      identify_scratch_remove
  use config, only: unset_real
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
  use safe_files, only: same_file, check_output_name, sidecar_path, obstacles_sidecar_path
  use kinds, only: rp
  use step_settings, only: step_t_end
  use run_error, only: run_error_any
  use input_text, only: command_line_overrides
  use build_info, only: nuno_version, nuno_commit
  use option_check, only: help_before_petsc, option_names_begin, options_before_run
  use errors, only: help_requested, version_requested, list_keys_requested, fatal_collective, fatal_local, input_path_argument, apply_namelist_options, &
                    petsc_options_text, quiet_exit, &
                    read_input_options, quiet_petsc_errors, stray_argument, options_file_refusal, petsc_help_given
  implicit none

  type(nuno_config), target :: cfg     !< the input's configuration (the solver's ctx%cfg points to it, or to identify's trial copy)
  type(app_ctx), target :: ctx
  type(restart_state_t) :: restart       !< the run's checkpoints (module run_checkpoint)
  type(output_file), target :: out
  type(checkpoint_t) :: ck
  type(restart_judge_t) :: judge         !< a restart's check of the checkpoint's state (the process models')
  type(named_value_t), allocatable :: pm_names(:)   !< the process models' named values in a checkpoint
  character(len=512) :: refusal
  type(ident_t), target :: id
  logical :: id_done
  character(len=16), allocatable :: id_names(:)
  real(rp), allocatable :: id_values(:), id_unc(:), id_initial(:), id_hist(:, :)
  real(rp) :: id_objective
  real(rp), allocatable :: kf_time(:), kf_offset(:, :), kf_initial(:, :), kf_fhist(:), kf_hist(:, :, :)
  PetscErrorCode :: ierr
  integer :: rank, nranks
  character(len=512) :: path, errmsg
  character(len=1024) :: status
  character(len=:), allocatable :: petsc_opts
  logical :: allow_long, ts_dt_set, petsc_help
  character(len=4096) :: petsc_set
  character(len=:), allocatable :: overrides
  integer :: n_set
  character(len=1024) :: restart_file
  character(len=512) :: bad_option
  real(rp) :: walltime
  PetscBool :: have_set, have_max_time
  PetscReal :: ts_max_time
  PetscInt :: pint
  PetscReal :: ts_dt
  integer(c_int) :: overwrite
  character(len=:), allocatable :: wname
  character(len=1024) :: inputs(3)       ! the input files: namelist, observed, target
  character(len=1100) :: derived(4)      ! the side files of the name written
  interface
    !> src/app/nuno_file_options.c: -nuno_overwrite (in -help).
    integer(c_int) function nuno_file_options_read(fcomm, overwrite) bind(C, name='nuno_file_options_read')
      import :: c_int
      integer(c_int), value :: fcomm
      integer(c_int), intent(out) :: overwrite
    end function nuno_file_options_read
  end interface

  ! 1. --help, --version and --list-keys need no input and no PETSc; the
  !    command line's words and options files are checked before PETSc
  !    reads them (MPI first, so PETSc leaves its finalisation to us).
  call MPI_Init(ierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, ierr)
  if (help_requested() .or. version_requested() .or. list_keys_requested()) then
    if (rank == 0) then
      if (help_requested()) then
        call usage_text(6)
      else if (list_keys_requested()) then
        call list_keys(6)
      else
        write(*, '(a)') 'nuno '//nuno_version//' (git '//nuno_commit//')'
      end if
    end if
    call MPI_Finalize(ierr)
    stop
  end if
  call stray_argument(errmsg)
  if (len_trim(errmsg) > 0) call fatal_collective(errmsg)
  call options_file_refusal(MPI_COMM_WORLD, errmsg)
  if (len_trim(errmsg) > 0) call fatal_collective(errmsg)
  if (petsc_help_given()) call help_before_petsc(ierr)

  ! 2. PETSc, then the namelist (read on rank 0, parsed by every rank alike).
  PetscCallA(PetscInitialize(ierr))
  ! PETSc errors become part of our one error line (module errors), not a
  ! 30-line report from every rank.
  call quiet_petsc_errors(ierr)
  ! The names of the options the set-up reads, for their check before the
  ! first step (module option_check); with -help, PETSc prints them.
  call option_names_begin(petsc_help, ierr)
  if (ierr /= 0) call fatal_local('could not start the option check')
  call MPI_Comm_rank(PETSC_COMM_WORLD, rank, ierr)
  call MPI_Comm_size(PETSC_COMM_WORLD, nranks, ierr)
  if (.not. input_path_argument(path)) &
    call fatal_collective('usage: mpirun -n P nuno INPUT.nml [PETSc options]  (nuno --help for more)')
  ! -nuno_set key=value,...: namelist keys from the command line, over the
  ! file's; every -nuno_set of the command line, in order (module
  ! input_text). One given only in PETSC_OPTIONS or an options file comes
  ! from PETSc's database, which keeps its value up to the first blank.
  call command_line_overrides(overrides, n_set)
  if (n_set == 0) then
    call PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-nuno_set', petsc_set, have_set, ierr)
    if (ierr /= 0) call fatal_local('could not read the -nuno_set option')
    if (have_set) then
      overrides = trim(petsc_set)
      n_set = 1
    end if
  end if
  call input_read(trim(path), PETSC_COMM_WORLD, overrides, n_set, cfg, ierr, errmsg)
  if (ierr /= 0) call fatal_collective(errmsg)
  call apply_namelist_options(cfg%output%petsc_options, ierr, errmsg)
  if (ierr /= 0) call fatal_collective(errmsg)
  ! Step/output counts, index space and memory, before anything is allocated.
  ! Indices: PETSc's and the default integers of the Fortran code.
  call read_input_options(PETSC_COMM_WORLD, cfg%time%dt, allow_long, ts_dt, ts_dt_set, restart_file, walltime, &
                          bad_option, ierr)
  if (ierr /= 0) call fatal_local('could not read the -nuno_allow_long, -nuno_restart or -nuno_checkpoint_walltime option')
  if (len_trim(bad_option) > 0) call fatal_collective(trim(bad_option))
  call input_check_run(cfg, PETSC_COMM_WORLD, allow_long, min(int(huge(pint), int64), int(huge(0), int64)), &
                       ts_dt, ts_dt_set, ierr, errmsg)
  if (ierr /= 0) call fatal_collective(errmsg)
  ierr = nuno_file_options_read(int(PETSC_COMM_WORLD, c_int), overwrite)
  if (ierr /= 0) call fatal_local('could not read the -nuno_overwrite option')
  ! The name the run writes (the output file, or the file it continues):
  ! no control character, not too long for MPI-IO, no input file by any
  ! of the names written with it (input/README.md, Output files).
  inputs(1) = path
  inputs(2) = cfg%identify%observed_file
  inputs(3) = cfg%control%target_file
  if (len_trim(restart_file) > 0) then
    wname = trim(restart_file)
  else
    wname = trim(cfg%output%output_file)
  end if
  derived(1) = wname//'.partial'
  derived(2) = wname//'.lock'
  derived(3) = sidecar_path(wname)
  derived(4) = obstacles_sidecar_path(wname)
  if (len_trim(restart_file) > 0) then
    call check_output_name(PETSC_COMM_WORLD, '-nuno_restart', wname, len_trim(restart_file) >= len(restart_file) - 1, &
                           inputs, derived, ierr, errmsg)
  else
    call check_output_name(PETSC_COMM_WORLD, '&output: output_file', wname, &
                           len_trim(cfg%output%output_file) >= len(cfg%output%output_file), inputs, derived, ierr, errmsg)
  end if
  if (ierr /= 0) call fatal_collective(errmsg)
  if (rank == 0) then
    write(*, '(a,i0,a)') 'nuno '//nuno_version//' on ', nranks, ' rank(s): '//trim(path)
    call PetscOptionsGetReal(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ts_max_time', ts_max_time, have_max_time, ierr)
    call input_summary(cfg, 6, ts_dt, ts_dt_set, ts_max_time, have_max_time)
  end if

  ! 3. Lattice strips, scene, Jacobian, TS. A PETSc error here may have been
  !    seen by some ranks only (a bad option, a failed allocation): abort.
  call check_decomposition(cfg, nranks, ierr, errmsg)
  if (ierr /= 0) call fatal_collective(errmsg)
  ! An &identify group: fit the parameters to the observed motion first; a
  ! &control group: optimise the keyframes for the target first (module
  ! identify); the run below then writes the resulting motion and
  ! /identify or /control.
  if (cfg%identify%active .or. cfg%control%active) then
    if (len_trim(restart_file) > 0) &
      call fatal_collective('-nuno_restart cannot continue an identification or a control run (&identify, &control)')
    call identify_prepare_options(PETSC_COMM_WORLD, petsc_help, ierr)
    if (ierr /= 0) call fatal_local('could not set the options of the identification or control')
  end if
  ! A process model's refusal of the scene (an obstacle containing the
  ! cloth; one line, found by every rank alike) before any output exists.
  call solver_create(ctx, cfg, ierr, refusal)
  if (ierr /= 0) call fatal_local('could not set up the solver')
  if (len_trim(refusal) > 0) call fatal_collective(refusal)
  ! Options nothing read, integers out of range, a TS type nuno cannot run:
  ! refused before the first step; -help ends the run here.
  call options_before_run(ctx%ts, PETSC_COMM_WORLD, cfg%identify%active .or. cfg%control%active, petsc_help, ierr, errmsg)
  if (ierr == 1) call fatal_collective(errmsg)
  if (ierr /= 0) call fatal_local('could not check the options')
  if (cfg%identify%active .or. cfg%control%active) then
    call identify_run(id, ctx, id_done, ierr, errmsg)
    if (ierr == 1) call fatal_collective(errmsg)
    if (ierr /= 0) call fatal_local('PETSc error during the identification or control')
    if (id_done) then
      call solver_destroy(ctx, ierr)
      call identify_scratch_remove(id)
      PetscCallA(PetscFinalize(ierr))
      call MPI_Finalize(ierr)
      stop
    end if
    ! ctx%cfg is identify's trial configuration now, with the fitted parameters
    ! or the optimised keyframes; cfg stays the input's
  end if

  ! 4. Output file, the time loop, and the completion mark written last. The
  !    run writes OUTPUT.partial under a lock and renames it onto the output
  !    file after its first successful step (module output): a run that fails
  !    before that leaves an earlier output file as it was. -nuno_restart
  !    continues an earlier run's file in place from its last checkpoint.
  petsc_opts = petsc_options_text()
  if (len_trim(cfg%output%petsc_options) > 0) &
    petsc_opts = trim(petsc_opts//' [namelist, overridden by the above: '//trim(cfg%output%petsc_options)//']')
  call restart_state_init(restart, output_file=wname, checkpoint_walltime=walltime)
  if (len_trim(restart_file) > 0) then
    if (len_trim(restart_file) > len(cfg%output%output_file)) &
      call fatal_collective('-nuno_restart: the file name is longer than '//trim(adjustl(itoa(len(cfg%output%output_file))))// &
                            ' characters')
    ! the process models judge the checkpoint's state before the file changes
    judge = restart_judge(ctx)
    call checkpoint_pm_names(ctx, pm_names)
    call output_reopen(out, trim(restart_file), PETSC_COMM_WORLD, cfg%lattice%nx, cfg%lattice%ny, ctx%lat%ys, &
                       ctx%lat%ye - ctx%lat%ys + 1, cfg%output%write_velocity, step_t_end(ctx%step), cfg%namelist_text, petsc_opts, &
                       ck, ctx%xout, ctx%vout, ierr, errmsg, protect=trim(path), overwrite=overwrite /= 0, cfg=cfg, &
                       pm_names=pm_names, judge=judge)
    if (ierr /= 0) call fatal_collective(errmsg)
    if (rank == 0 .and. trim(restart_file) /= trim(cfg%output%output_file) .and. &
        trim(restart_file) /= trim(cfg%output%output_file)//'.partial' .and. &
        .not. same_file(trim(restart_file), trim(cfg%output%output_file))) &
      write(*, '(a)') 'nuno: -nuno_restart: the run goes on in '//trim(restart_file)//"; the input's output_file = '"// &
                      trim(cfg%output%output_file)//"' is not used"
    call solver_restore(ctx, restart, ck, ctx%xout, ctx%vout, ierr)
    if (ierr /= 0) call fatal_local('could not restore the checkpoint')
    if (rank == 0) write(*, '(a,i0,a,es12.5e2,a)') 'nuno: restart from checkpoint ', ck%sequence, ' at t =', ck%time, &
      ' ('//trim(ck%reason)//') in '//trim(restart_file)
  else
    call output_open(out, trim(cfg%output%output_file), PETSC_COMM_WORLD, cfg%lattice%nx, cfg%lattice%ny, ctx%lat%ys, &
                     ctx%lat%ye - ctx%lat%ys + 1, rest_strip(ctx%lat), ctx%lat%mass(:, ctx%lat%ys:ctx%lat%ye), &
                     cfg%output%write_velocity, cfg%namelist_text, petsc_opts, ierr, errmsg, protect=trim(path), &
                     overwrite=overwrite /= 0)
    if (ierr /= 0) call fatal_collective(errmsg)
  end if
  ! A failed step ends the run collectively (status 'failed: ...', ierr = 0);
  ! a PETSc or HDF5 error (ierr /= 0) may be local to some ranks: abort,
  ! leaving the file marked 'running', never 'complete'.
  call solver_run(ctx, restart, out, status, ierr)
  if (ierr /= 0) call fatal_local('PETSc or HDF5 error during the run; output not marked complete')
  if (cfg%identify%active .and. status == 'complete') then
    call identify_result(id, id_names, id_values, id_unc, id_initial, id_objective, id_hist)
    call output_write_identify(out, id_names, id_values, id_unc, id_initial, id_objective, id_hist, ierr, errmsg)
    if (ierr /= 0) call fatal_collective(errmsg)
  end if
  if (cfg%control%active .and. status == 'complete') then
    call control_result(id, kf_time, kf_offset, kf_initial, id_objective, kf_fhist, kf_hist)
    call output_write_control(out, kf_time, kf_offset, kf_initial, id_objective, kf_fhist, kf_hist, &
                              merge(ieee_value(1.0_rp, ieee_positive_inf), cfg%control%max_speed, cfg%control%max_speed == unset_real), &
                              cfg%control%components, ierr, errmsg)
    if (ierr /= 0) call fatal_collective(errmsg)
  end if
  call output_close(out, trim(status), ierr, errmsg)
  ! After a failed write (a full disk) the close fails too: that was said.
  if (ierr /= 0) call fatal_collective(errmsg, reported=status /= 'complete' .and. run_error_any(ctx%error))

  ! 5. Clean up; a failed run exits non-zero on every rank.
  call solver_destroy(ctx, ierr)
  call restart_state_free(restart)
  if (cfg%identify%active .or. cfg%control%active) call identify_scratch_remove(id)
  PetscCallA(PetscFinalize(ierr))
  call MPI_Finalize(ierr)
  ! Quiet: the failure was reported in one line already (no ERROR STOP, no backtrace).
  if (status /= 'complete') call quiet_exit(1)
end program nuno
