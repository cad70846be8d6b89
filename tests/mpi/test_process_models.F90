! SPDX-License-Identifier: BSD-2-Clause
!> The process-model interface carries a force that is not contact (issue
!> 47 item 1; docs/design.md, "Process models"): two tiny models written
!> here, handed to solver_create (its `extra` list) and run by the real
!> stepper, through the same hooks as contact, with nothing changed
!> elsewhere:
!>   body_force_t  f = m a on every free node (forces; no blocks); its
!>                 step-limit, accepted, output and checkpoint hooks count
!>                 their calls, and the counts come back through the
!>                 output file (its series /body/..., its checkpoint value);
!>   tether_t      f = -k (x - X) to the rest position X (forces and 3 x 3
!>                 node blocks -k I: the Jacobian hook).
!> Checks: a sheet under gravity a (&scene) and the same sheet without
!> gravity but with body_force_t(a) end at the same positions (1e-12);
!> the body model's hooks were called (the pre-check, the accepted states,
!> the output series at every output step, the checkpoint's value); on a
!> linear sheet (linear springs, no bending) with a tether and an exact
!> inner solve each step takes one Newton iteration (the tether's blocks
!> are in the Jacobian), and without its blocks more (they matter).
module test_pm_models
  use mpi
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t, rest_position
  use constraints, only: constraint_set_t
  use node_blocks, only: node_blocks_t, node_blocks_add
  use pair_blocks, only: pair_blocks_t
  use checkpoint_record, only: named_value_t, named_value
  use process_model, only: process_model_t, pm_series_t, pm_group_t, pm_energy_t, PM_FEASIBLE
  implicit none
  private
  public :: body_force_t, tether_t

  !> A uniform acceleration a of every free node, f = m a.
  type, extends(process_model_t) :: body_force_t
    real(rp) :: a(3) = 0
    integer :: limit_calls = 0, accepted_calls = 0
  contains
    procedure :: name => body_name
    procedure :: setup => body_setup
    procedure :: forces => body_forces
    procedure :: jacobian => body_jacobian
    procedure :: step_limit => body_limit
    procedure :: accepted => body_accepted
    procedure :: output => body_output
    procedure :: checkpoint => body_checkpoint
  end type body_force_t

  !> A spring of stiffness k from every free node to its rest position.
  type, extends(process_model_t) :: tether_t
    real(rp) :: k = 0
    logical :: blocks = .true.      !< give the Jacobian blocks (false: leave them out)
  contains
    procedure :: name => tether_name
    procedure :: setup => tether_setup
    procedure :: forces => tether_forces
    procedure :: jacobian => tether_jacobian
  end type tether_t

contains

  function body_name(this) result(s)
    class(body_force_t), intent(in) :: this
    character(len=:), allocatable :: s
    s = 'body force'
  end function body_name

  subroutine body_setup(this, cfg, lat, comm, u, cs, ierr, errmsg)
    class(body_force_t), intent(inout) :: this
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    ierr = 0
    errmsg = ''
  end subroutine body_setup

  subroutine body_forces(this, lat, fixed, t, u, f, status)
    class(body_force_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: status
    integer :: i, j
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (.not. fixed(i, j)) f(:, i, j) = f(:, i, j) + lat%mass(i, j) * this%a
      end do
    end do
    status = PM_FEASIBLE
  end subroutine body_forces

  subroutine body_jacobian(this, lat, fixed, t, u, nodal, pairs)
    class(body_force_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nodal
    type(pair_blocks_t), intent(inout) :: pairs
  end subroutine body_jacobian

  subroutine body_limit(this, lat, fixed, t0, t1, x0, x, dx, comm, alpha, status)
    class(body_force_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    integer, intent(out) :: status
    this%limit_calls = this%limit_calls + 1
    alpha = 1.0_rp
    status = PM_FEASIBLE
  end subroutine body_limit

  subroutine body_accepted(this, lat, fixed, t, u, comm, ierr, errmsg)
    class(body_force_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    this%accepted_calls = this%accepted_calls + 1
    ierr = 0
    errmsg = ''
  end subroutine body_accepted

  subroutine body_output(this, series, groups, energy)
    class(body_force_t), intent(in) :: this
    type(pm_series_t), allocatable, intent(out) :: series(:)
    type(pm_group_t), allocatable, intent(out) :: groups(:)
    type(pm_energy_t), intent(out) :: energy
    series = [pm_series_t(name='/body/accepted_calls', description='accepted states seen', units='1', &
                          is_count=.true., count=this%accepted_calls), &
              pm_series_t(name='/body/acceleration', description='the body force per mass [t][xyz]', units='1', &
                          ncomp=3, values=this%a)]
    groups = [pm_group_t(name='/body', description='a uniform body force (tests/mpi/test_process_models.F90)')]
    energy = pm_energy_t()
  end subroutine body_output

  subroutine body_checkpoint(this, values)
    class(body_force_t), intent(in) :: this
    type(named_value_t), allocatable, intent(out) :: values(:)
    values = [named_value('body_limit_calls', [real(this%limit_calls, rp)], .true.)]
  end subroutine body_checkpoint

  function tether_name(this) result(s)
    class(tether_t), intent(in) :: this
    character(len=:), allocatable :: s
    s = 'tether'
  end function tether_name

  subroutine tether_setup(this, cfg, lat, comm, u, cs, ierr, errmsg)
    class(tether_t), intent(inout) :: this
    type(nuno_config), intent(in) :: cfg
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(constraint_set_t), intent(in) :: cs
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    ierr = 0
    errmsg = ''
  end subroutine tether_setup

  subroutine tether_forces(this, lat, fixed, t, u, f, status)
    class(tether_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    integer, intent(out) :: status
    integer :: i, j
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (.not. fixed(i, j)) f(:, i, j) = f(:, i, j) - this%k * (u(0:2, i, j) - rest_position(lat, i, j))
      end do
    end do
    status = PM_FEASIBLE
  end subroutine tether_forces

  subroutine tether_jacobian(this, lat, fixed, t, u, nodal, pairs)
    class(tether_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    type(node_blocks_t), intent(inout) :: nodal
    type(pair_blocks_t), intent(inout) :: pairs
    real(rp) :: kx(3, 3), kv(3, 3)
    integer :: i, j, q
    if (.not. this%blocks) return
    kx = 0.0_rp
    kv = 0.0_rp
    do q = 1, 3
      kx(q, q) = -this%k
    end do
    ! the rows from the last to the first: node_blocks orders them
    do j = lat%ye, lat%ys, -1
      do i = 0, lat%nx - 1
        if (.not. fixed(i, j)) call node_blocks_add(nodal, i, j, kx, kv)
      end do
    end do
  end subroutine tether_jacobian

end module test_pm_models

program test_process_models
#include "petsc/finclude/petscts.h"
  use petscts
  use mpi
  use hdf5
  use, intrinsic :: iso_fortran_env, only: int64
  use kinds, only: rp
  use config, only: nuno_config
  use input, only: input_parse
  use lattice, only: rest_strip
  use output, only: output_file, output_open, output_close
  use process_model, only: process_model_t
  use process_models, only: pm_list_t, pm_list_add
  use timestepping, only: app_ctx, solver_create, solver_destroy, solver_run, restart_state_t, restart_state_init, &
                          restart_state_free
  use test_pm_models, only: body_force_t, tether_t
  use check, only: check_true, check_close, check_report
  implicit none
  PetscErrorCode :: ierr
  integer :: rank, nranks, mpierr
  character(len=64) :: tag
  real(rp), allocatable :: xa(:, :, :), xb(:, :, :)
  integer :: its, steps, mcount
  real(rp) :: diff, gdiff
  type(pm_list_t) :: extra
  class(process_model_t), allocatable :: pm
  character(len=*), parameter :: SHEET = &
    "&scene scene='flat' GRAVITY / &lattice nx=11 ny=11 lx=1.0 ly=1.0 total_mass=0.1 mass_distribution='area' / " // &
    "&material spring_model='SPRING' e_s=100.0 eta_s=0.1 e_d=100.0 eta_d=0.1 bending_model='BENDING' k_b=0.1 " // &
    "eta_b=0.0 / &time t_end=0.02 dt=1.0e-3 / &output output_interval=0.01 write_velocity=.true. OUTFILE /"

  PetscCallA(PetscInitialize(ierr))
  call MPI_Comm_rank(PETSC_COMM_WORLD, rank, mpierr)
  call MPI_Comm_size(PETSC_COMM_WORLD, nranks, mpierr)
  write(tag, '(a,i0,a)') 'test_pm_np', nranks, '_'

  ! 1. gravity from &scene, and the same by a process model: the same motion
  call one_run(sheet_text('gravity=0.0,0.0,-9.81', 'axial', 'energy', trim(tag)//'a.h5'), xa, its, steps)
  allocate(pm, source=body_force_t(a=[0.0_rp, 0.0_rp, -9.81_rp]))
  call pm_list_add(extra, pm)
  call one_run(sheet_text('gravity=0.0,0.0,0.0', 'axial', 'energy', trim(tag)//'b.h5'), xb, its, steps, extra)
  diff = maxval(abs(xa - xb))
  call MPI_Allreduce(diff, gdiff, 1, MPI_DOUBLE_PRECISION, MPI_MAX, PETSC_COMM_WORLD, mpierr)
  call check_true(maxval(abs(xa(3, :, :))) > 1.0e-4_rp, 'the sheet fell')
  call check_close(gdiff, 0.0_rp, 0.0_rp, 1.0e-12_rp, 'gravity by a process model: the same positions')
  call check_body_file(trim(tag)//'b.h5', steps)

  ! 2. a tether on a linear sheet, with an exact inner solve: one Newton
  !    iteration a step with its blocks in the Jacobian, more without
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_ksp_type', 'preonly', ierr))
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_type', 'lu', ierr))
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_factor_mat_solver_type', 'mumps', ierr))
  allocate(pm, source=body_force_t(a=[0.0_rp, 0.0_rp, -9.81_rp]))
  call pm_list_add(extra, pm)
  allocate(pm, source=tether_t(k=50.0_rp))
  call pm_list_add(extra, pm)
  call one_run(sheet_text('gravity=0.0,0.0,0.0', 'linear', 'none', trim(tag)//'c.h5'), xa, its, steps, extra)
  call check_true(steps == 20, 'tether: 20 steps')
  call check_true(its == steps, 'tether: one Newton iteration a step with its blocks ('//itoa(its)//' in '// &
                  itoa(steps)//' steps)')
  allocate(pm, source=body_force_t(a=[0.0_rp, 0.0_rp, -9.81_rp]))
  call pm_list_add(extra, pm)
  allocate(pm, source=tether_t(k=50.0_rp, blocks=.false.))
  call pm_list_add(extra, pm)
  call one_run(sheet_text('gravity=0.0,0.0,0.0', 'linear', 'none', trim(tag)//'d.h5'), xb, mcount, steps, extra)
  call check_true(mcount > its, 'tether without its blocks: more Newton iterations ('//itoa(mcount)//')')
  diff = maxval(abs(xa - xb))
  call MPI_Allreduce(diff, gdiff, 1, MPI_DOUBLE_PRECISION, MPI_MAX, PETSC_COMM_WORLD, mpierr)
  call check_close(gdiff, 0.0_rp, 0.0_rp, 1.0e-9_rp, 'tether with and without its blocks: the same motion')

  call check_report()
  PetscCallA(PetscFinalize(ierr))

contains

  !> The sheet's namelist: gravity, spring and bending models, output file.
  function sheet_text(gravity, spring, bending, file) result(text)
    character(*), intent(in) :: gravity, spring, bending, file
    character(len=:), allocatable :: text
    text = replace(replace(replace(replace(SHEET, 'GRAVITY', gravity), 'SPRING', spring), 'BENDING', bending), &
                   'OUTFILE', "output_file='"//file//"'")
  end function sheet_text

  pure function replace(s, a, b) result(r)
    character(*), intent(in) :: s, a, b
    character(len=:), allocatable :: r
    integer :: k
    k = index(s, a)
    r = s(1:k - 1)//b//s(k + len(a):)
  end function replace

  pure function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=16) :: b
    write(b, '(i0)') i
    s = trim(b)
  end function itoa

  !> One run of the namelist text with the caller's process models (extra,
  !> emptied): this rank's final positions x (3, nx, ym), the run's Newton
  !> iterations and steps.
  subroutine one_run(text, x, newton_its, nsteps, models)
    character(*), intent(in) :: text
    real(rp), allocatable, intent(out) :: x(:, :, :)
    integer, intent(out) :: newton_its, nsteps
    type(pm_list_t), intent(inout), optional :: models
    type(nuno_config), target :: cfg
    type(app_ctx), target :: ctx
    type(restart_state_t) :: restart
    type(output_file) :: out
    character(len=512) :: errmsg, refusal
    character(len=1024) :: status
    integer :: err
    PetscInt :: n

    call input_parse(text, cfg, err, errmsg)
    call check_true(err == 0, 'input: '//trim(errmsg))
    if (present(models)) then
      call solver_create(ctx, cfg, ierr, refusal, models)
    else
      call solver_create(ctx, cfg, ierr, refusal)
    end if
    call check_true(ierr == 0 .and. len_trim(refusal) == 0, 'solver_create '//trim(refusal))
    call restart_state_init(restart, output_file=trim(cfg%output%output_file), checkpoint_walltime=0.0_rp)
    call output_open(out, trim(cfg%output%output_file), PETSC_COMM_WORLD, cfg%lattice%nx, cfg%lattice%ny, ctx%lat%ys, &
                     ctx%lat%ye - ctx%lat%ys + 1, rest_strip(ctx%lat), ctx%lat%mass(:, ctx%lat%ys:ctx%lat%ye), &
                     cfg%output%write_velocity, text, '', err, errmsg, overwrite=.true.)
    call check_true(err == 0, 'output_open: '//trim(errmsg))
    call solver_run(ctx, restart, out, status, ierr)
    call check_true(ierr == 0 .and. trim(status) == 'complete', 'solver_run: '//trim(status))
    call output_close(out, trim(status), err, errmsg)
    x = ctx%xout
    PetscCallA(TSGetSNESIterations(ctx%ts, n, ierr))
    newton_its = int(n)
    PetscCallA(TSGetStepNumber(ctx%ts, n, ierr))
    nsteps = int(n)
    call solver_destroy(ctx, ierr)
    call restart_state_free(restart)
  end subroutine one_run

  !> The body model's series in the file (one entry an output step; its
  !> count of accepted states at the end at least the steps and the start)
  !> and its checkpoint value (the pre-check called it). Rank 0 reads.
  subroutine check_body_file(file, nsteps)
    character(*), intent(in) :: file
    integer, intent(in) :: nsteps
    integer(hid_t) :: f, d, space
    integer(hsize_t) :: dims(1), maxd(1)
    integer(int64) :: counts(8)
    integer :: h, nlimit, attr_h
    logical :: there
    integer(hid_t) :: grp, attr
    integer(hsize_t), parameter :: one(1) = [1]
    if (rank /= 0) return
    call h5open_f(h)
    call h5fopen_f(file, H5F_ACC_RDONLY_F, f, h)
    call check_true(h == 0, 'body: the file opens')
    call h5lexists_f(f, '/body', there, h)
    call check_true(there, 'body: its group')
    call h5dopen_f(f, '/body/accepted_calls', d, h)
    call check_true(h == 0, 'body: its series')
    call h5dget_space_f(d, space, h)
    call h5sget_simple_extent_dims_f(space, dims, maxd, h)
    call check_true(dims(1) == 3, 'body: one entry an output step (3)')
    call h5dread_f(d, h5kind_to_type(int64, H5_INTEGER_KIND), counts(1:3), dims, h)
    call check_true(counts(3) >= nsteps + 1, 'body: accepted hook at every step and the start')
    call h5sclose_f(space, h)
    call h5dclose_f(d, h)
    ! the run's one checkpoint (at its end) is in one of the two slots
    call h5aexists_by_name_f(f, '/checkpoint/slot_0', 'body_limit_calls', there, h)
    if (there) then
      call h5gopen_f(f, '/checkpoint/slot_0', grp, h)
    else
      call h5gopen_f(f, '/checkpoint/slot_1', grp, h)
    end if
    call h5aopen_f(grp, 'body_limit_calls', attr, attr_h)
    call check_true(attr_h == 0, 'body: its checkpoint value')
    call h5aread_f(attr, H5T_NATIVE_INTEGER, nlimit, one, h)
    call check_true(nlimit >= nsteps, 'body: the step limit hook at every Newton update')
    call h5aclose_f(attr, h)
    call h5gclose_f(grp, h)
    call h5fclose_f(f, h)
  end subroutine check_body_file

end program test_process_models
