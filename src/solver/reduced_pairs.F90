! SPDX-License-Identifier: BSD-2-Clause
!> S with the process models' pair blocks where S is a PETSc matrix
!> (-reduced_pc_type other than nuno's multigrid; module reduced_storage):
!> the inner KSP's operator is a MATSHELL whose product is the matrix's
!> plus the pair blocks' part (module process_models'
!> pm_list_pair_product: the blocks of nodes that are not stencil
!> neighbours, the Krylov vector's rows they reach gathered by the model
!> that gave them), and the preconditioner is made from the matrix alone.
!> The pair blocks are not written into the matrix: its preallocation is
!> the lattice's stencil, and they change with every Jacobian. (Nuno's
!> multigrid's MATSHELL adds them itself: module reduced_mg.) Its record
!> (pair_op_t, the MATSHELL's context) has private components: only this
!> module writes it.
module reduced_pairs
#include "petsc/finclude/petscksp.h"
#include "petsc/finclude/petscdmda.h"
  use petscksp
  use petscdmda
  use, intrinsic :: iso_c_binding, only: c_ptr, c_f_pointer
  use kinds, only: rp
  use lattice, only: lattice_t
  use process_models, only: pm_list_t, pm_list_pairs_on, pm_list_pair_product
  use shell_context, only: MatShellSetContext, MatShellGetContext
  implicit none
  private
  public :: pair_op_t, pair_op_create, pair_op_set_shift, pair_op_destroy, pair_product_add, pair_op_set_operators

  !> The MATSHELL S + pair blocks over the PETSc matrix s.
  type :: pair_op_t
    private
    type(tMat) :: s                        !< S without the pair blocks (not owned)
    type(tDM) :: da3                       !< dof 3 (not owned)
    type(lattice_t), pointer :: lat => null()
    type(pm_list_t), pointer :: pms => null()
    real(rp) :: a = 0.0_rp                 !< shift of the assembled S [1/time]
    type(tMat) :: op                       !< the MATSHELL (made by pair_op_create)
    logical :: made = .false.
  end type pair_op_t

contains

  !> The MATSHELL over s (same sizes) adding the pair blocks of pms, made
  !> the operator of ksp, s its preconditioner's matrix; refused with PETSc's PCMG. Collective.
  subroutine pair_op_create(po, s, da3, lat, pms, ksp, ierr)
    type(pair_op_t), intent(inout), target :: po
    type(tMat), intent(in) :: s
    type(tDM), intent(in) :: da3
    type(lattice_t), intent(in), target :: lat
    type(pm_list_t), intent(in), target :: pms
    type(tKSP), intent(in) :: ksp
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: m, n, mg, ng
    MPI_Comm :: comm
    character(len=32) :: pctype             !< -reduced_pc_type (default_preconditioner's 'mg' with -nuno_mg petsc)
    PetscBool :: set
    ! PETSc's PCMG: its Galerkin 'pmat' levels are left without operators
    ! beside this MATSHELL, refused here, not a failure at the first solve
    PetscCall(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-reduced_pc_type', pctype, set, ierr))
    if (set .and. trim(pctype) == 'mg') then
      PetscCall(PetscObjectGetComm(da3, comm, ierr))
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, 'nuno: self_contact''s pair blocks need nuno''s multigrid (-nuno_mg stencil, the default) or a one-level -reduced_pc_type: PETSc''s PCMG (-nuno_mg petsc, -reduced_pc_type mg) cannot take them')
    end if
    po%s = s
    po%da3 = da3
    po%lat => lat
    po%pms => pms
    PetscCall(PetscObjectGetComm(da3, comm, ierr))
    PetscCall(MatGetLocalSize(s, m, n, ierr))
    PetscCall(MatGetSize(s, mg, ng, ierr))
    PetscCall(MatCreateShell(comm, m, n, mg, ng, PETSC_NULL_INTEGER, po%op, ierr))
    PetscCall(MatShellSetContext(po%op, po, ierr))
    PetscCall(MatShellSetOperation(po%op, MATOP_MULT, pair_op_mult, ierr))
    po%made = .true.
    PetscCall(pair_op_set_operators(po, s, ksp, ierr))
  end subroutine pair_op_create

  !> The inner KSP's operators set again (the preconditioner rebuilt from s
  !> at the next solve): the MATSHELL with the pair blocks where made, else
  !> s itself. Collective.
  subroutine pair_op_set_operators(po, s, ksp, ierr)
    type(pair_op_t), intent(in) :: po
    type(tMat), intent(in) :: s
    type(tKSP), intent(in) :: ksp
    PetscErrorCode, intent(out) :: ierr
    if (po%made) then
      PetscCall(KSPSetOperators(ksp, po%op, s, ierr))
    else
      PetscCall(KSPSetOperators(ksp, s, s, ierr))
    end if
  end subroutine pair_op_set_operators

  !> The shift of the S just assembled.
  subroutine pair_op_set_shift(po, a)
    type(pair_op_t), intent(inout) :: po
    real(rp), intent(in) :: a
    po%a = a
  end subroutine pair_op_set_shift

  !> Destroy the MATSHELL, if made (the matrix and the list are the caller's).
  subroutine pair_op_destroy(po, ierr)
    type(pair_op_t), intent(inout) :: po
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    if (.not. po%made) return
    PetscCall(MatDestroy(po%op, ierr))
    po%made = .false.
    po%lat => null()
    po%pms => null()
  end subroutine pair_op_destroy

  !> MATSHELL mult: y = s x + the pair blocks' part of S x. Collective.
  subroutine pair_op_mult(mat, x, y, ierr)
    type(tMat) :: mat
    type(tVec) :: x, y
    PetscErrorCode :: ierr
    type(pair_op_t), pointer :: po
    type(c_ptr) :: ctx                     !< the shell's context: the record's address
    PetscCall(MatShellGetContext(mat, ctx, ierr))
    call c_f_pointer(ctx, po)
    PetscCall(MatMult(po%s, x, y, ierr))
    if (.not. pm_list_pairs_on(po%pms)) return
    PetscCall(pair_product_add(po%pms, po%lat, po%da3, po%a, x, y, ierr))
  end subroutine pair_op_mult

  !> y += the pair blocks' part of S x at shift a (module process_models'
  !> pm_list_pair_product: x's rows that the blocks reach gathered by the
  !> model that gave them); x, y 3-dof vectors of da3. Both products with
  !> pair blocks end here: this MATSHELL's and nuno's multigrid's (module
  !> reduced_mg). Collective.
  subroutine pair_product_add(pms, lat, da3, a, x, y, ierr)
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    type(tDM), intent(in) :: da3
    real(rp), intent(in) :: a
    type(tVec) :: x, y
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: xa(:, :, :), ya(:, :, :)
    MPI_Comm :: comm
    integer :: err
    PetscCall(PetscObjectGetComm(da3, comm, ierr))
    PetscCall(DMDAVecGetArrayReadF90(da3, x, xa, ierr))
    PetscCall(DMDAVecGetArrayF90(da3, y, ya, ierr))
    call pm_list_pair_product(pms, lat, comm, a, xa(:, :, lat%ys:lat%ye), ya(:, :, lat%ys:lat%ye), err)
    PetscCall(DMDAVecRestoreArrayF90(da3, y, ya, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(da3, x, xa, ierr))
    if (err /= 0) then
      ierr = PETSC_ERR_PLIB
      SETERRQ(comm, ierr, 'nuno: the pair blocks'' rows could not be gathered for S''s product (their plan changed since the Jacobian)')
    end if
  end subroutine pair_product_add

end module reduced_pairs
