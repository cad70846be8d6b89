! SPDX-License-Identifier: BSD-2-Clause
!> The reduced (Baraff-Witkin) Newton solve: the 6-dof Newton step of the
!> first-order system solved exactly by block elimination around a 3-dof
!> velocity system, S = a M - C - K/a, which is the only matrix assembled
!> (docs/design.md). This module sets it up and holds the glue: S's
!> storage (module reduced_storage) or nuno's multigrid (module reduced_mg),
!> the inner KSP (options prefix -reduced_) and its preconditioner's reuse,
!> the assembly, the constraints and the inner guesses (module
!> reduced_guess). The elimination itself, the PCSHELL and the 6-dof
!> MATSHELL product, is in submodule reduced_elim. Its record (reduced_t)
!> and sub-records have private components: only this module and its
!> submodule write them; others call its routines and read accessors.
module reduced
#include "petsc/finclude/petscsnes.h"
#include "petsc/finclude/petscdmda.h"
  use petscsnes
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_ptr, c_f_pointer
  use kinds, only: rp
  use lattice, only: lattice_t
  use node_blocks, only: node_blocks_t
  use config, only: BEND_NONE
  use reduced_assembly, only: kc_products, assemble_stencil
  use mg_kernels, only: stencil_t
  use reduced_storage, only: s_store_t, store_init, store_matrix, store_assemble, check_direct, set_block_row, &
                             store_use_buffer, store_direct
  use newton_control, only: floor_node_add, floor_estimate
  use pc_reuse, only: pc_reuse_t, default_pc_lag, reuse_init, reuse_due, reuse_rebuilt, reuse_force, reuse_watch
  use inner_guess, only: GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, GUESS_PROJECT, PROJECT_PAIRS
  use reduced_guess, only: guess_t, guess_use, guess_free, guess_restart, guess_set, guess_keep, guess_push, &
                           guess_accepted, guess_mode
  use solver_choices, only: MG_STENCIL, GATHER_AUTO
  use reduced_mg, only: mg_glue_t, mg_glue_matrix, mg_glue_pc, mg_glue_free, mg_glue_assemble, mg_glue_built, &
                        mg_glue_describe, mg_coarse_levels, levels_that_fit, default_preconditioner, mg_interpolations, &
                        true_residual_defaults, mg_options_t, mg_options_read, &
                        INTERP_LINEAR, INTERP_CUBIC, INTERP_COARSE_CUBIC
  use shell_context, only: PCShellSetContext, PCShellGetContext, MatShellSetContext, MatShellGetContext
  use process_models, only: pm_list_t, pm_list_pairs_on, pm_list_pair_rhs
  use reduced_mg, only: mg_glue_set_pairs
  use reduced_pairs, only: pair_op_t, pair_op_create, pair_op_set_shift, pair_op_destroy, pair_op_set_operators
  use ghosted_state, only: ghosted_get, ghosted_restore
  implicit none
  private
  public :: reduced_t, reduced_create, reduced_destroy, reduced_assemble, reduced_set_fixed, reduced_attach, reduced_describe
  public :: set_block_row, reduced_set_guess, reduced_step_accepted
  public :: reduced_set_forcing, reduced_restore_floor, reduced_set_pairs
  ! read accessors
  public :: reduced_inner_ksp, reduced_jacobian, reduced_forward_ew, reduced_its, reduced_floor_est, reduced_lin_rel, &
            reduced_rtol0
  ! for tests/mpi/test_reduced.F90: S, its DMDA, the two fillings of an AIJ S, S by stencil offset
  public :: reduced_matrix, reduced_dm, reduced_writes_directly, reduced_use_buffer, reduced_offset_assembly, &
            reduced_products
  public :: INTERP_LINEAR, INTERP_CUBIC, INTERP_COARSE_CUBIC

  !> The element model's flags and the element products of the reduced
  !> solve: the state of the last assembly, the constrained nodes and the
  !> products K w_x + C w_v (module reduced_assembly). Newton solves
  !> J du = F(u) at the state of the assembly: the products for that
  !> right-hand side are formed during the assembly, in the same pass over
  !> the elements (wpred, gpred); any other right-hand side is recognised
  !> and gets its own pass.
  type :: elements_t
    private
    logical :: constant = .false.          !< K and C do not depend on the state (linear springs, no bending)
    logical :: damping = .true.            !< some element has a damper (C /= 0)
    logical :: clamp = .false., gauss_newton = .false.
    logical, allocatable :: fixedg(:, :)   !< (0:nx-1, gys:gye) constrained nodes, with ghosts
    real(rp), allocatable :: ujac(:, :, :) !< (0:5, 0:nx-1, gys:gye) state at the last assembly
    real(rp), allocatable :: w(:, :, :)    !< (0:5, 0:nx-1, gys:gye) work
    real(rp), allocatable :: g(:, :, :)    !< (3, 0:nx-1, ys:ye) element products
    real(rp), allocatable :: wpred(:, :, :) !< (0:5, 0:nx-1, gys:gye) w of b = F(u)
    real(rp), allocatable :: gpred(:, :, :) !< (3, 0:nx-1, ys:ye) its products
    real(rp), allocatable :: kd(:, :, :)    !< (3, 0:nx-1, ys:ye) diagonal of -df/dx at the assembly (round-off floor)
    real(rp), allocatable :: lb(:, :, :, :, :) !< (0:nx-1, 3, 3, 4, 0:1) link blocks of two rows (direct assembly)
    logical :: have_pred = .false.
  end type elements_t

  !> The inner preconditioner in use and its reuse.
  type :: inner_pc_t
    private
    type(tVec) :: coords                   !< 3-dof node positions (GAMG near-null space)
    logical :: use_nullspace = .false.     !< inner PC is GAMG: give it the rigid-body modes
    logical :: use_mg = .false.            !< inner PC is nuno's structured multigrid (module stencil_mg)
    logical :: overlap = .false.           !< S has stiff blocks across strips: overlapping strips, not block Jacobi
    integer :: interp = 1                  !< multigrid interpolation: INTERP_LINEAR, _CUBIC, _COARSE_CUBIC
    type(pc_reuse_t) :: reuse              !< when to rebuild it (module pc_reuse)
  end type inner_pc_t

  !> Context of the reduced solve (PCSHELL and MATSHELL context).
  type :: reduced_t
    private
    type(elements_t) :: el                 !< the element model and its products (this module)
    type(inner_pc_t) :: pcc                !< the inner preconditioner in use and its reuse (this module)
    type(lattice_t), pointer :: lat => null()
    type(node_blocks_t), pointer :: nodal => null()  !< forces on single nodes (contact), written by the process models' Jacobian hooks
    type(tDM) :: da6                       !< the state's DMDA (dof 6; not owned)
    type(tDM) :: da3                       !< dof 3, same strips and halo
    type(tMat) :: s                        !< S = a M - C - K/a, block size 3 (AIJ for multigrid, else BAIJ)
    type(tMat) :: jac                      !< 6-dof Jacobian action (MATSHELL)
    type(tKSP) :: ksp                      !< inner solver, prefix reduced_
    type(tKSP) :: outer                    !< the SNES's KSP (for Eisenstat-Walker forcing)
    type(tSNES) :: snes                    !< the TS's SNES
    type(tVec) :: rhs, dv                  !< 3-dof global work vectors
    type(s_store_t) :: sto                 !< S in a PETSc matrix (without use_mg; module reduced_storage)
    real(rp) :: a = 0                      !< shift of the assembled S [1/time]
    logical :: assembled = .false.
    logical :: dirty = .true.              !< constraints changed since the last assembly
    type(mg_glue_t) :: mgg                 !< nuno's multigrid and S by stencil offset (with use_mg; module reduced_mg)
    ! -log_view events of the reduced solve's own work
    PetscLogEvent :: ev_assemble = 0       !< S assembled (and the multigrid's finest level from it)
    logical :: forward_ew = .true.         !< pass the outer KSP's rtol (Eisenstat-Walker) to the inner one
    real(rp) :: floor_est = 0              !< round-off floor of ||F||_2 at the last assembly (see reduced_assemble)
    integer :: its = 0                     !< inner Krylov iterations, cumulative
    ! Inexact Newton (eta set by newton_policy's convergence test, from module newton_forcing)
    real(rp) :: rtol0 = 1.0e-6_rp          !< the inner rtol of the options (-reduced_ksp_rtol, default 1e-6)
    real(rp) :: eta = 0                    !< inner rtol of the next Newton solve; 0: rtol0
    real(rp) :: lin_rel = 0                !< relative residual the last inner solve left
    type(guess_t) :: gs                    !< the inner initial guesses (module reduced_guess)
    ! the process models' pair blocks (self-contact), which S's product and the right-hand side add
    type(pm_list_t), pointer :: pms => null()  !< the run's process models (null: no pair blocks)
    type(pair_op_t) :: pop                 !< with S a PETSc matrix: S + pair blocks, the inner KSP's operator (module reduced_pairs)
  end type reduced_t

  ! The elimination (submodule reduced_elim)
  interface
    !> PCSHELL apply: du = J^{-1} b by elimination.
    module subroutine reduced_pc_apply(pc, b, du, ierr)
      type(tPC) :: pc
      type(tVec) :: b, du
      PetscErrorCode :: ierr
    end subroutine reduced_pc_apply
    !> MATSHELL mult: y = J du, the exact 6-dof Jacobian.
    module subroutine reduced_jac_mult(mat, du, yv, ierr)
      type(tMat) :: mat
      type(tVec) :: du, yv
      PetscErrorCode :: ierr
    end subroutine reduced_jac_mult
  end interface

contains

  !> Build the 3-dof DMDA on the strips of da6, the inner KSP (prefix
  !> reduced_) with its preconditioner, S with its exact box-stencil
  !> preallocation (or by stencil offset for nuno's multigrid), the 6-dof
  !> MATSHELL and the element model's arrays. symmetric selects the
  !> default inner Krylov method (CG or GMRES); overlap, that the default
  !> block Jacobi of small lattices overlaps the strips (a process model's
  !> stiff blocks between neighbours). Collective.
  subroutine reduced_create(red, da6, lat, nodal, symmetric, overlap, constant, damping, clamp, gauss_newton, pc_lag, pc_growth, &
                            mg_interpolation, ierr)
    type(reduced_t), intent(inout), target :: red
    type(tDM), intent(in) :: da6
    type(lattice_t), intent(in), target :: lat
    type(node_blocks_t), intent(in), target :: nodal   !< the node blocks every assembly adds (app_ctx's)
    logical, intent(in) :: symmetric, overlap, constant, damping, clamp, gauss_newton
    integer, intent(in) :: pc_lag                  !< rebuild the inner preconditioner every pc_lag assemblies (>= 1; 0: default)
    real(rp), intent(in) :: pc_growth              !< and when a solve's cycles a decade grow past pc_growth x (0: never; module pc_reuse)
    integer, intent(in) :: mg_interpolation        !< multigrid interpolation: 0 auto, else an INTERP_ code
    PetscErrorCode, intent(out) :: ierr
    type(mg_options_t) :: mgo
    PetscLogEvent :: ev_galerkin, ev_cycle
    PetscInt :: nx, ny, w, nranks
    character(len=64) :: pctype
    PetscBool :: found
    MPI_Comm :: comm

    red%lat => lat
    red%nodal => nodal
    red%pcc%overlap = overlap
    red%da6 = da6
    PetscCall(register_events(red, ev_galerkin, ev_cycle, ierr))
    PetscCall(PetscObjectGetComm(da6, comm, ierr))
    PetscCall(create_da3(red, comm, nx, ny, w, nranks, ierr))
    PetscCall(inner_ksp_create(red, comm, symmetric, nx, ny, w, nranks, mgo, pctype, ierr))
    PetscCall(s_create(red, symmetric, pctype, mgo%product, nx, ny, w, ev_galerkin, ev_cycle, ierr))
    if (mg_interpolation > 0 .and. pctype /= PCMG .and. .not. red%pcc%use_mg) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, 'nuno: -nuno_mg_interpolation needs an inner multigrid: nuno''s (the default from 3 levels on) or -reduced_pc_type mg')
    end if
    if (pctype == PCMG .or. red%pcc%use_mg) then
      PetscCall(inner_multigrid(red, mgo, mg_interpolation, nx, ny, w, ierr))
    end if
    PetscCall(DMCreateGlobalVector(red%da3, red%rhs, ierr))
    PetscCall(VecDuplicate(red%rhs, red%dv, ierr))
    PetscCall(VecDuplicate(red%rhs, red%pcc%coords, ierr))
    PetscCall(jacobian_create(red, comm, nx, ny, ierr))
    call store_init(red%sto, lat)
    call elements_init(red%el, lat, constant, damping, clamp, gauss_newton)
    if (.not. red%pcc%use_mg) then
      PetscCall(check_direct(red%sto, red%s, red%da3, red%el%fixedg, red%el%damping, ierr))
    end if
    ! An explicit -reduced_ksp_rtol wins over the outer forcing term.
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-reduced_ksp_rtol', found, ierr))
    red%forward_ew = .not. found
    call reuse_init(red%pcc%reuse, default_pc_lag(pc_lag, pctype == PCMG .or. red%pcc%use_mg, red%pcc%interp), pc_growth)
  end subroutine reduced_create

  !> The -log_view events of the reduced solve's own work (class nuno):
  !> the assembly of S (red's), the multigrid's coarse levels and its cycle
  !> (for module reduced_mg).
  subroutine register_events(red, ev_galerkin, ev_cycle, ierr)
    type(reduced_t), intent(inout) :: red
    PetscLogEvent, intent(out) :: ev_galerkin, ev_cycle
    PetscErrorCode, intent(out) :: ierr
    PetscClassId :: classid
    PetscCall(PetscClassIdRegister('nuno', classid, ierr))
    PetscCall(PetscLogEventRegister('nunoAssembleS', classid, red%ev_assemble, ierr))
    PetscCall(PetscLogEventRegister('nunoMGGalerkin', classid, ev_galerkin, ierr))
    PetscCall(PetscLogEventRegister('nunoMGCycle', classid, ev_cycle, ierr))
  end subroutine register_events

  !> The 3-dof DMDA (prefix reduced_) on the strips and halo of the state's:
  !> its nx x ny lattice, halo w, over nranks ranks (1 x P). Collective.
  subroutine create_da3(red, comm, nx, ny, w, nranks, ierr)
    type(reduced_t), intent(inout) :: red
    MPI_Comm, intent(in) :: comm
    PetscInt, intent(out) :: nx, ny, w, nranks
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: dummy(1)
    PetscInt, allocatable :: ly(:)
    PetscInt, parameter :: one = 1, three = 3
    integer :: mpierr
    call MPI_Comm_size(comm, nranks, mpierr)
    allocate(ly(nranks))
    PetscCall(DMDAGetInfo(red%da6, PETSC_NULL_INTEGER, nx, ny, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, w, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, ierr))
    PetscCall(DMDAGetOwnershipRanges(red%da6, dummy, ly, PETSC_NULL_INTEGER, ierr))
    dummy(1) = nx
    PetscCall(DMDACreate2d(comm, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DMDA_STENCIL_BOX, nx, ny, one, nranks, three, w, dummy, ly, red%da3, ierr))
    PetscCall(DMSetOptionsPrefix(red%da3, 'reduced_', ierr))
  end subroutine create_da3

  !> The inner solver (prefix reduced_): FGMRES with nuno's multigrid by
  !> default; with another preconditioner CG on a symmetric S, FGMRES
  !> otherwise; all stop on the true residual (true_residual_defaults).
  !> FGMRES rather than right-preconditioned GMRES: the same iterates, but
  !> it keeps the preconditioned directions, so the solution needs no
  !> further V-cycle at the end (with 1-2 iterations a step in the bw
  !> mode that cycle was a third of the smoothing; docs/performance.md).
  !> Gives the multigrid's options mgo and the preconditioner's type.
  !> Collective.
  subroutine inner_ksp_create(red, comm, symmetric, nx, ny, w, nranks, mgo, pctype, ierr)
    type(reduced_t), intent(inout) :: red
    MPI_Comm, intent(in) :: comm
    logical, intent(in) :: symmetric
    PetscInt, intent(in) :: nx, ny, w, nranks
    type(mg_options_t), intent(out) :: mgo
    character(len=*), intent(out) :: pctype
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: maxit0
    PetscReal :: atol0, dtol0
    type(tPC) :: pc
    PetscCall(KSPCreate(comm, red%ksp, ierr))
    PetscCall(KSPSetOptionsPrefix(red%ksp, 'reduced_', ierr))
    PetscCall(KSPSetType(red%ksp, KSPFGMRES, ierr))
    PetscCall(mg_options_read(comm, mgo, ierr))
    PetscCall(inner_pc_choose(red, comm, symmetric, nx, ny, w, nranks, mgo, ierr))
    PetscCall(KSPSetTolerances(red%ksp, 1.0e-6_rp, 1.0e-50_rp, PETSC_DEFAULT_REAL, 500, ierr))
    PetscCall(KSPSetFromOptions(red%ksp, ierr))
    PetscCall(true_residual_defaults(red%ksp, ierr))
    PetscCall(KSPGetTolerances(red%ksp, red%rtol0, atol0, dtol0, maxit0, ierr))
    PetscCall(KSPGetPC(red%ksp, pc, ierr))
    PetscCall(PCGetType(pc, pctype, ierr))
    red%pcc%use_nullspace = pctype == PCGAMG
  end subroutine inner_ksp_create

  !> The inner preconditioner: nuno's structured multigrid where three
  !> levels fit and -reduced_pc_type is not given (-nuno_mg petsc: PETSc's
  !> PCMG with Galerkin operators instead), else what default_preconditioner
  !> puts in the options. nuno's multigrid replicates its coarsest level
  !> where strips get too thin, so only the lattice's size limits its
  !> levels; PETSc's needs the halo's rows in every coarse strip.
  !> Collective.
  subroutine inner_pc_choose(red, comm, symmetric, nx, ny, w, nranks, mgo, ierr)
    type(reduced_t), intent(inout) :: red
    MPI_Comm, intent(in) :: comm
    logical, intent(in) :: symmetric
    PetscInt, intent(in) :: nx, ny, w, nranks
    type(mg_options_t), intent(in) :: mgo
    PetscErrorCode, intent(out) :: ierr
    PetscInt, parameter :: izero = 0, ione = 1
    PetscBool :: found
    type(tPC) :: pc
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-reduced_pc_type', found, ierr))
    red%pcc%use_mg = levels_that_fit(nx, ny, izero, ione) >= 3 .and. .not. found .and. mgo%impl == MG_STENCIL
    if (mgo%given .and. .not. red%pcc%use_mg) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, 'nuno: -nuno_mg_cycle, -nuno_mg_sweeps, -nuno_mg_levels, -nuno_mg_product, -nuno_mg_coarse and -nuno_mg_gather are for nuno''s multigrid (-nuno_mg stencil, the default from 3 levels on, no -reduced_pc_type)')
    end if
    if (red%pcc%use_mg) then
      ! FGMRES even where S is symmetric: the kaskade cycle is not, and
      ! FGMRES + kaskade beat CG + V-cycles by 1.4x on a symmetric hang
      ! (measured with commit cdb1ad4).
      PetscCall(KSPGetPC(red%ksp, pc, ierr))
      PetscCall(PCSetType(pc, PCSHELL, ierr))
    else
      if (symmetric) then
        PetscCall(KSPSetType(red%ksp, KSPCG, ierr))
      end if
      PetscCall(default_preconditioner(levels_that_fit(nx, ny, w, nranks), red%pcc%overlap .and. nranks > 1, symmetric, ierr))
    end if
  end subroutine inner_pc_choose

  !> S and the inner KSP's operators: by stencil offset, its product a
  !> MATSHELL (module reduced_mg), with nuno's multigrid; else in a PETSc
  !> matrix for the preconditioner pctype (module reduced_storage).
  !> product: the multigrid's product with S (-nuno_mg_product). Collective.
  subroutine s_create(red, symmetric, pctype, product, nx, ny, w, ev_galerkin, ev_cycle, ierr)
    type(reduced_t), intent(inout) :: red
    logical, intent(in) :: symmetric
    character(len=*), intent(in) :: pctype
    integer, intent(in) :: product
    PetscInt, intent(in) :: nx, ny, w
    PetscLogEvent, intent(in) :: ev_galerkin, ev_cycle
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: xs, ys, zs, m, n, zm
    if (red%pcc%use_mg) then
      PetscCall(DMSetUp(red%da3, ierr))
      PetscCall(DMDAGetCorners(red%da6, xs, ys, zs, m, n, zm, ierr))
      PetscCall(mg_glue_matrix(red%mgg, red%lat, red%da3, red%ksp, nx, ny, n, w, product, ev_galerkin, ev_cycle, red%s, ierr))
    else
      PetscCall(store_matrix(red%da3, pctype, symmetric, red%s, ierr))
    end if
    PetscCall(KSPSetOperators(red%ksp, red%s, red%s, ierr))
    ! The DM gives -reduced_pc_type mg its grid hierarchy; the operators stay ours.
    PetscCall(KSPSetDM(red%ksp, red%da3, ierr))
    PetscCall(KSPSetDMActive(red%ksp, PETSC_FALSE, ierr))
  end subroutine s_create

  !> An inner multigrid's interpolation (mg_interpolation: 0 auto, else an
  !> INTERP_ code) and set-up: nuno's as the inner PCSHELL with the
  !> options mgo, or PETSc's PCMG given the DMDA's interpolations.
  !> Collective.
  subroutine inner_multigrid(red, mgo, mg_interpolation, nx, ny, w, ierr)
    type(reduced_t), intent(inout) :: red
    type(mg_options_t), intent(in) :: mgo
    integer, intent(in) :: mg_interpolation
    PetscInt, intent(in) :: nx, ny, w
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: xs, ys, zs, m, n, zm
    type(tPC) :: pc
    ! auto: with bending, cubic on every level but the finest (measured
    ! with commit 458d4d3: as fast as cubic everywhere, and the parallel
    ! Galerkin product of the finest level with a cubic P doubled the
    ! peak memory at 1025 x 1025 on 2 ranks; with commit e284754: cubic
    ! everywhere still as fast, 30 % fewer iterations for
    ! cycles 1.6 times as long), the finest level's correction cubic in
    ! nuno's multigrid (10 % fewer iterations for the same cycle).
    red%pcc%interp = INTERP_LINEAR
    if (red%lat%bending_model /= BEND_NONE) red%pcc%interp = INTERP_COARSE_CUBIC
    if (mg_interpolation > 0) red%pcc%interp = mg_interpolation
    PetscCall(KSPGetPC(red%ksp, pc, ierr))
    if (red%pcc%use_mg) then
      PetscCall(DMDAGetCorners(red%da6, xs, ys, zs, m, n, zm, ierr))
      ! without bending every element of S is a link, so S(p, q) = S(q, p)
      ! block for block (mg_stencil's stencil_t, paired): the sweeps and
      ! products read the blocks to the row below from that row
      PetscCall(mg_glue_pc(red%mgg, pc, nx, ny, ys, n, w, red%pcc%interp, merge(mgo%levels, 10, mgo%levels > 0), mgo%cycle, mgo%sweeps, mgo%coarse, red%lat%bending_model == BEND_NONE, mgo%gather == GATHER_AUTO, ierr))
    else
      PetscCall(mg_interpolations(red%da3, red%pcc%interp, pc, ierr))
    end if
  end subroutine inner_multigrid

  !> The 6-dof Jacobian: only its action, from the element blocks (a
  !> MATSHELL on the state's rows of the nx x ny lattice). Collective.
  subroutine jacobian_create(red, comm, nx, ny, ierr)
    type(reduced_t), intent(inout), target :: red
    MPI_Comm, intent(in) :: comm
    PetscInt, intent(in) :: nx, ny
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: xs, ys, zs, m, n, zm, mg
    PetscCall(DMDAGetCorners(red%da6, xs, ys, zs, m, n, zm, ierr))
    m = 6 * m * n
    mg = 6 * nx * ny
    PetscCall(MatCreateShell(comm, m, m, mg, mg, PETSC_NULL_INTEGER, red%jac, ierr))
    PetscCall(MatShellSetContext(red%jac, red, ierr))
    PetscCall(MatShellSetOperation(red%jac, MATOP_MULT, reduced_jac_mult, ierr))
  end subroutine jacobian_create

  !> The element model's flags and arrays on lat's strip: no constrained
  !> node, no state yet.
  subroutine elements_init(el, lat, constant, damping, clamp, gauss_newton)
    type(elements_t), intent(inout) :: el
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: constant, damping, clamp, gauss_newton
    el%constant = constant
    el%damping = damping
    el%clamp = clamp
    el%gauss_newton = gauss_newton
    allocate(el%fixedg(0:lat%nx - 1, lat%gys:lat%gye))
    allocate(el%ujac(0:5, 0:lat%nx - 1, lat%gys:lat%gye), el%w(0:5, 0:lat%nx - 1, lat%gys:lat%gye))
    allocate(el%g(3, 0:lat%nx - 1, lat%ys:lat%ye), el%gpred(3, 0:lat%nx - 1, lat%ys:lat%ye))
    allocate(el%wpred(0:5, 0:lat%nx - 1, lat%gys:lat%gye), el%kd(3, 0:lat%nx - 1, lat%ys:lat%ye))
    allocate(el%lb(0:lat%nx - 1, 3, 3, 4, 0:1))
    el%fixedg = .false.
    el%ujac = 0.0_rp
  end subroutine elements_init

  !> One line on the inner solver for the start-up summary: Krylov method,
  !> tolerance, preconditioner; for nuno's multigrid its levels, cycle and
  !> the bytes a cycle reads. Collective.
  subroutine reduced_describe(red, line, ierr)
    type(reduced_t), intent(inout) :: red
    character(len=*), intent(out) :: line
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: ktype, ptype
    character(len=16) :: rt
    type(tPC) :: pc
    PetscCall(KSPGetType(red%ksp, ktype, ierr))
    PetscCall(KSPGetPC(red%ksp, pc, ierr))
    PetscCall(PCGetType(pc, ptype, ierr))
    write(rt, '(es8.1)') red%rtol0
    line = trim(ktype)//', rtol '//trim(adjustl(rt))
    if (red%pcc%use_mg) then
      call mg_glue_describe(red%mgg, line)
    else
      line = trim(line)//' + '//trim(ptype)
    end if
    if (guess_mode(red%gs) == GUESS_PROJECT) then
      write(line, '(a, i0, a)') trim(line)//'; initial guess projected on the last ', PROJECT_PAIRS, &
        ' inner solves (-nuno_inner_guess)'
    else if (guess_mode(red%gs) == GUESS_EXTRAPOLATE) then
      line = trim(line)//'; initial guess extrapolated, at the second Newton iteration the previous step''s (-nuno_inner_guess)'
    else if (guess_mode(red%gs) == GUESS_PREVIOUS) then
      line = trim(line)//'; initial guess the previous step''s, at the second Newton iteration too (-nuno_inner_guess)'
    end if
  end subroutine reduced_describe

  !> Make the SNES's KSP preonly with the eliminating PCSHELL. Call before
  !> TSSetFromOptions, so that options may still change it.
  subroutine reduced_attach(red, snes, ierr)
    type(reduced_t), intent(inout), target :: red
    type(tSNES), intent(in) :: snes
    PetscErrorCode, intent(out) :: ierr
    type(tPC) :: pc
    red%snes = snes
    PetscCall(SNESGetKSP(snes, red%outer, ierr))
    PetscCall(KSPSetType(red%outer, KSPPREONLY, ierr))
    PetscCall(KSPGetPC(red%outer, pc, ierr))
    PetscCall(PCSetType(pc, PCSHELL, ierr))
    PetscCall(PCShellSetContext(pc, red, ierr))
    PetscCall(PCShellSetApply(pc, reduced_pc_apply, ierr))
    PetscCall(PCShellSetName(pc, 'nuno reduced elimination (inner solver: -reduced_ksp_view)', ierr))
  end subroutine reduced_attach

  !> The process models pms give pair blocks (hint pair_blocks): S's
  !> product and the right-hand side add them. Collective.
  subroutine reduced_set_pairs(red, pms, ierr)
    type(reduced_t), intent(inout), target :: red
    type(pm_list_t), intent(in), target :: pms
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    red%pms => pms
    if (red%pcc%use_mg) then
      call mg_glue_set_pairs(red%mgg, pms)
      return
    end if
    PetscCall(pair_op_create(red%pop, red%s, red%da3, red%lat, pms, red%ksp, ierr))
  end subroutine reduced_set_pairs

  !> Destroy what reduced_create made (the DMDA dof 6 and the lattice are
  !> the caller's). Collective.
  subroutine reduced_destroy(red, ierr)
    type(reduced_t), intent(inout) :: red
    PetscErrorCode, intent(out) :: ierr
    PetscCall(KSPDestroy(red%ksp, ierr))
    if (red%pcc%use_mg) then
      PetscCall(mg_glue_free(red%mgg, ierr))
    end if
    PetscCall(MatDestroy(red%jac, ierr))
    PetscCall(pair_op_destroy(red%pop, ierr))
    PetscCall(VecDestroy(red%pcc%coords, ierr))
    PetscCall(VecDestroy(red%dv, ierr))
    PetscCall(guess_free(red%gs, ierr))
    PetscCall(VecDestroy(red%rhs, ierr))
    PetscCall(MatDestroy(red%s, ierr))
    PetscCall(DMDestroy(red%da3, ierr))
  end subroutine reduced_destroy

  !> Mark the constrained nodes (owned rows: fixed(0:nx-1, ys:ye)) and
  !> exchange the marks of the ghost rows. Collective; once per time window.
  subroutine reduced_set_fixed(red, fixed, ierr)
    type(reduced_t), intent(inout) :: red
    logical, intent(in) :: fixed(0:, red%lat%ys:)
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: loc
    PetscScalar, pointer :: fa(:, :, :), fl(:, :, :)
    integer :: i, j
    PetscCall(DMDAVecGetArrayF90(red%da3, red%dv, fa, ierr))
    do j = red%lat%ys, red%lat%ye
      do i = 0, red%lat%nx - 1
        fa(0, i, j) = merge(1.0_rp, 0.0_rp, fixed(i, j))
      end do
    end do
    PetscCall(DMDAVecRestoreArrayF90(red%da3, red%dv, fa, ierr))
    PetscCall(ghosted_get(red%da3, red%dv, loc, fl, ierr))
    red%el%fixedg = fl(0, :, :) > 0.5_rp
    PetscCall(ghosted_restore(red%da3, loc, fl, ierr))
    red%dirty = .true.
    ! The preconditioner is built afresh at the window's first assembly, so
    ! that a run restarted at a window's start (a checkpoint) takes the same
    ! iterations as the run that went through it.
    call reuse_force(red%pcc%reuse)
    ! and the inner guesses too start afresh (module inner_guess)
    call guess_restart(red%gs)
  end subroutine reduced_set_fixed

  !> Assemble S at the ghosted state u(0:5, 0:nx-1, gys:gye) (with its time
  !> derivative ud, same shape) and shift a, and keep the state for the
  !> matrix-free products. A constant Jacobian (linear springs, no bending)
  !> is assembled again only when a or the constraints change. Collective.
  subroutine reduced_assemble(red, u, ud, a, ierr)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: u(0:, 0:, red%lat%gys:)
    real(rp), intent(in) :: ud(0:, 0:, red%lat%gys:)
    real(rp), intent(in) :: a
    PetscErrorCode, intent(out) :: ierr

    ierr = 0
    red%el%ujac = u
    ! A constant S is kept; the PC apply then forms the products itself
    ! (one pass over the elements, none when they vanish).
    red%el%have_pred = .not. (red%el%constant .and. red%assembled .and. .not. red%dirty .and. a == red%a)
    if (.not. red%el%have_pred) return
    call newton_rhs_w(red%el, red%lat, u, ud, a)
    PetscCall(PetscLogEventBegin(red%ev_assemble, ierr))
    if (red%pcc%use_mg) then
      ! By stencil offset (module reduced_assembly), for nuno's multigrid,
      ! whose finest level is made from it row by row on the way (every
      ! assembly: its smoother and residual use the current S, as PETSc's
      ! PCMG does with a reused hierarchy).
      call mg_glue_assemble(red%mgg, red%nodal, u, red%el%fixedg, a, red%el%damping, red%el%clamp, red%el%gauss_newton, red%el%wpred, &
                            red%el%lb, red%el%gpred, red%el%kd)
    else
      ! S in a PETSc matrix (module reduced_storage)
      PetscCall(store_assemble(red%sto, red%s, red%nodal, u, red%el%fixedg, a, red%el%damping, red%el%clamp, red%el%gauss_newton, red%el%wpred, red%el%lb, red%el%gpred, red%el%kd, ierr))
    end if
    PetscCall(MatAssemblyBegin(red%s, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatAssemblyEnd(red%s, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(PetscLogEventEnd(red%ev_assemble, ierr))
    PetscCall(estimate_floor(red, u, a, ierr))
    call pair_op_set_shift(red%pop, a)
    red%a = a
    red%assembled = .true.
    red%dirty = .false.
    PetscCall(reuse_or_rebuild_pc(red, u, ierr))
  end subroutine reduced_assemble

  !> w of the Newton step's right-hand side b = F(u), whose element
  !> products the assembly forms on the way: F_x = xdot - v, F_v = vdot on
  !> constrained nodes (whose v is their prescribed velocity); u and ud as
  !> in reduced_assemble, a the shift.
  subroutine newton_rhs_w(el, lat, u, ud, a)
    type(elements_t), intent(inout) :: el
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(in) :: ud(0:, 0:, lat%gys:)
    real(rp), intent(in) :: a
    integer :: i, j
    do j = lat%gys, lat%gye
      do i = 0, lat%nx - 1
        el%wpred(0:2, i, j) = (ud(0:2, i, j) - u(3:5, i, j)) / a
        if (el%fixedg(i, j)) then
          el%wpred(3:5, i, j) = ud(3:5, i, j) / a
        else
          el%wpred(3:5, i, j) = 0.0_rp
        end if
      end do
    end do
  end subroutine newton_rhs_w

  !> Round-off floor of the residual at the assembled state u and shift a:
  !> a position is known to eps |x|, and
  !> the v-rows amplify that by the stiffness over the mass, K_ii/m_i (the
  !> stiffest, bending, grows like N^4 on a refined lattice), the x-rows
  !> (xdot - v = a (x - x_n) - v) by the shift a, so that ||F||_2 cannot go
  !> below about eps max|x| (sum K_ii^2/m_i^2 + a^2)^(1/2). (The a^2 term
  !> matters on soft lattices, where K_ii/m_i is not far above a: with a
  !> start at 3e-5, wave_point's edge wave stalled at 2.9e-11 for 50
  !> Newton iterations, just above 1e-6 of the start, with the estimate
  !> from K alone below it.) Collective.
  subroutine estimate_floor(red, u, a, ierr)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: u(0:, 0:, red%lat%gys:)
    real(rp), intent(in) :: a
    PetscErrorCode, intent(out) :: ierr
    integer :: ja, i
    real(rp) :: loc(2), glob(2)
    MPI_Comm :: comm
    loc = 0.0_rp
    do ja = red%lat%ys, red%lat%ye
      do i = 0, red%lat%nx - 1
        if (red%el%fixedg(i, ja)) cycle
        call floor_node_add(red%el%kd(:, i, ja), red%lat%mass(i, ja), u(0:2, i, ja), a, loc)
      end do
    end do
    PetscCall(PetscObjectGetComm(red%da3, comm, ierr))
    call MPI_Allreduce(loc(1), glob(1), 1, MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    call MPI_Allreduce(loc(2), glob(2), 1, MPI_DOUBLE_PRECISION, MPI_MAX, comm, ierr)
    red%floor_est = floor_estimate(glob)
  end subroutine estimate_floor

  !> Preconditioner reuse after an assembly at the state u: rebuild every
  !> pc_lag assemblies (at most PAIRS_PC_LAG while S has pair blocks), when a solve's cycles a decade grew (module
  !> pc_reuse; watched in solve_s) and after a failed inner solve (see
  !> reduced_pc_apply), nuno's multigrid's coarse levels and GAMG's
  !> rigid-body modes with it; else keep it (the coarse levels made if they
  !> do not exist yet). Collective.
  subroutine reuse_or_rebuild_pc(red, u, ierr)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: u(0:, 0:, red%lat%gys:)
    PetscErrorCode, intent(out) :: ierr
    logical :: due, pairs
    pairs = .false.
    if (associated(red%pms)) pairs = pm_list_pairs_on(red%pms)
    call reuse_due(red%pcc%reuse, pairs, due)
    if (due) then
      call reuse_rebuilt(red%pcc%reuse)
      PetscCall(KSPSetReusePreconditioner(red%ksp, PETSC_FALSE, ierr))
      if (red%pcc%use_mg) then
        PetscCall(mg_coarse_levels(red%mgg, red%nodal, u, red%el%fixedg, red%a, red%el%damping, red%el%clamp, red%el%gauss_newton, ierr))
      end if
      if (red%pcc%use_nullspace) then
        PetscCall(set_rigid_body_modes(red, u, ierr))
      end if
    else
      PetscCall(KSPSetReusePreconditioner(red%ksp, PETSC_TRUE, ierr))
      if (red%pcc%use_mg .and. .not. mg_glue_built(red%mgg)) then
        PetscCall(mg_coarse_levels(red%mgg, red%nodal, u, red%el%fixedg, red%a, red%el%damping, red%el%clamp, red%el%gauss_newton, ierr))
      end if
    end if
  end subroutine reuse_or_rebuild_pc

  !> GAMG's near-null space: the six rigid-body modes of the current shape.
  subroutine set_rigid_body_modes(red, u, ierr)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: u(0:, 0:, red%lat%gys:)
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: c(:, :, :)
    type(tMatNullSpace) :: nsp
    PetscCall(DMDAVecGetArrayF90(red%da3, red%pcc%coords, c, ierr))
    c(0:2, :, red%lat%ys:red%lat%ye) = u(0:2, :, red%lat%ys:red%lat%ye)
    PetscCall(DMDAVecRestoreArrayF90(red%da3, red%pcc%coords, c, ierr))
    PetscCall(MatNullSpaceCreateRigidBody(red%pcc%coords, nsp, ierr))
    PetscCall(MatSetNearNullSpace(red%s, nsp, ierr))
    PetscCall(MatNullSpaceDestroy(nsp, ierr))
  end subroutine set_rigid_body_modes

  !> Use the inner initial guess mode (GUESS_NONE, _PREVIOUS, _EXTRAPOLATE;
  !> solver_setup decides, from -nuno_inner_guess and the TS type). Its two
  !> kept first corrections and the step under way's, and the kept second
  !> correction and the step under way's, are five 3-dof vectors, made here
  !> when needed. Collective.
  subroutine reduced_set_guess(red, mode, extrapolated_start, ierr)
    type(reduced_t), intent(inout) :: red
    integer, intent(in) :: mode
    logical, intent(in) :: extrapolated_start      !< the TS starts Newton from x + dt xdot (but at a window's first step)
    PetscErrorCode, intent(out) :: ierr
    PetscCall(guess_use(red%gs, mode, extrapolated_start, red%rhs, ierr))
  end subroutine reduced_set_guess

  !> A step was accepted (module step_monitor): its first correction
  !> joins the two kept for the next guesses, and its second, where it
  !> took a second Newton iteration, replaces the one kept. Only accepted steps count: a
  !> rejected attempt's correction starts at the same time as its retry's,
  !> so extrapolating through it would be nonsense. A window's first step,
  !> which TS starts from the last state rather than extrapolated, gives
  !> another quantity: not kept.
  subroutine reduced_step_accepted(red)
    type(reduced_t), intent(inout) :: red
    call guess_accepted(red%gs)
  end subroutine reduced_step_accepted

  !> Inexact Newton: the inner rtol of the coming Newton iteration's solve
  !> (module newton_policy, from module newton_forcing); the elimination
  !> takes it once and clears it (0: the options' rtol0).
  subroutine reduced_set_forcing(red, eta)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: eta
    red%eta = eta
  end subroutine reduced_set_forcing

  !> A restart's round-off floor of ||F||_2 [residual], that of the last
  !> assembly before its checkpoint (module run_checkpoint): the first
  !> Newton iteration's inner tolerance depends on it.
  subroutine reduced_restore_floor(red, floor_est)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: floor_est
    red%floor_est = floor_est
  end subroutine reduced_restore_floor

  ! Read accessors: what other modules need of the record.

  !> The inner solver (KSP, options prefix -reduced_).
  type(tKSP) function reduced_inner_ksp(red)
    type(reduced_t), intent(in) :: red
    reduced_inner_ksp = red%ksp
  end function reduced_inner_ksp

  !> The TS's Jacobian: the exact 6-dof action (MATSHELL).
  type(tMat) function reduced_jacobian(red)
    type(reduced_t), intent(in) :: red
    reduced_jacobian = red%jac
  end function reduced_jacobian

  !> The outer KSP's rtol (Eisenstat-Walker) is passed to the inner solve
  !> (no -reduced_ksp_rtol given).
  pure logical function reduced_forward_ew(red)
    type(reduced_t), intent(in) :: red
    reduced_forward_ew = red%forward_ew
  end function reduced_forward_ew

  !> Inner Krylov iterations since the start, all solves together.
  pure integer function reduced_its(red)
    type(reduced_t), intent(in) :: red
    reduced_its = red%its
  end function reduced_its

  !> The round-off floor of ||F||_2 [residual] at the last assembly.
  pure real(rp) function reduced_floor_est(red)
    type(reduced_t), intent(in) :: red
    reduced_floor_est = red%floor_est
  end function reduced_floor_est

  !> The relative residual the last inner solve left.
  pure real(rp) function reduced_lin_rel(red)
    type(reduced_t), intent(in) :: red
    reduced_lin_rel = red%lin_rel
  end function reduced_lin_rel

  !> The inner rtol of the options (-reduced_ksp_rtol, default 1e-6).
  pure real(rp) function reduced_rtol0(red)
    type(reduced_t), intent(in) :: red
    reduced_rtol0 = red%rtol0
  end function reduced_rtol0

  ! For tests/mpi/test_reduced.F90.

  !> S: a PETSc matrix, or nuno's multigrid's MATSHELL.
  type(tMat) function reduced_matrix(red)
    type(reduced_t), intent(in) :: red
    reduced_matrix = red%s
  end function reduced_matrix

  !> S's DMDA (dof 3, the state's strips and halo).
  type(tDM) function reduced_dm(red)
    type(reduced_t), intent(in) :: red
    reduced_dm = red%da3
  end function reduced_dm

  !> An AIJ S is written straight into its arrays (module reduced_storage).
  logical function reduced_writes_directly(red)
    type(reduced_t), intent(in) :: red
    reduced_writes_directly = store_direct(red%sto)
  end function reduced_writes_directly

  !> Fill S block row by block row even where its values could be written
  !> directly (the test compares the two).
  subroutine reduced_use_buffer(red)
    type(reduced_t), intent(inout) :: red
    call store_use_buffer(red%sto)
  end subroutine reduced_use_buffer

  !> S by stencil offset as nuno's multigrid path writes it (module
  !> reduced_assembly's assemble_stencil) at the ghosted state u with the
  !> constraints, shift and Newton right-hand side of the last assembly,
  !> into st (0:nx-1, 3, 3, offset_count(halo), 0:ye-ys), with the
  !> element products g and diagonal kd (3, 0:nx-1, ys:ye) on the way.
  subroutine reduced_offset_assembly(red, u, st, fine, g, kd)
    type(reduced_t), intent(in) :: red
    real(rp), intent(in) :: u(0:, 0:, red%lat%gys:)
    real(rp), intent(inout), contiguous :: st(0:, :, :, :, 0:)
    type(stencil_t), intent(inout) :: fine           !< a level the rows are converted into (the test's own)
    real(rp), intent(out) :: g(:, 0:, red%lat%ys:), kd(:, 0:, red%lat%ys:)
    real(rp), allocatable :: lb(:, :, :, :, :)
    allocate(lb, mold=red%el%lb)
    lb = 0.0_rp
    call assemble_stencil(red%lat, red%nodal, u, red%el%fixedg, red%a, red%el%damping, red%el%clamp, &
                          red%el%gauss_newton, red%el%wpred, lb, g, kd, st, fine)
  end subroutine reduced_offset_assembly

  !> The last assembly's element products of the Newton right-hand side
  !> and diagonal of -df/dx, both (3, 0:nx-1, ys:ye).
  subroutine reduced_products(red, g, kd)
    type(reduced_t), intent(in) :: red
    real(rp), intent(out) :: g(:, 0:, red%lat%ys:), kd(:, 0:, red%lat%ys:)
    g = red%el%gpred
    kd = red%el%kd
  end subroutine reduced_products

end module reduced
