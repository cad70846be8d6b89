! SPDX-License-Identifier: BSD-2-Clause
!> The user context of PETSc's shell objects (PCSHELL, MATSHELL) from
!> Fortran. PETSc 3.18 gives PCShellSetContext, PCShellGetContext,
!> MatShellSetContext and MatShellGetContext no Fortran interface, and
!> their context is any record: declared once here for every record type.
!> The Set routines keep the address of the record passed (assumed type:
!> any record, by reference, so it must outlive the object and have the
!> target attribute); the Get routines hand that address back as a C
!> pointer, which the callback turns into a pointer to its own record with
!> c_f_pointer.
module shell_context
#include "petsc/finclude/petscksp.h"
  use petscksp
  use, intrinsic :: iso_c_binding, only: c_ptr
  implicit none
  private
  public :: PCShellSetContext, PCShellGetContext, MatShellSetContext, MatShellGetContext

  interface
    subroutine PCShellSetContext(pc, ctx, ierr)
      import :: tPC
      type(tPC) :: pc
      type(*) :: ctx                       !< the record (its address is kept)
      PetscErrorCode :: ierr
    end subroutine PCShellSetContext
    subroutine PCShellGetContext(pc, ctx, ierr)
      import :: tPC, c_ptr
      type(tPC) :: pc
      type(c_ptr), intent(out) :: ctx      !< the record's address
      PetscErrorCode :: ierr
    end subroutine PCShellGetContext
    subroutine MatShellSetContext(mat, ctx, ierr)
      import :: tMat
      type(tMat) :: mat
      type(*) :: ctx                       !< the record (its address is kept)
      PetscErrorCode :: ierr
    end subroutine MatShellSetContext
    subroutine MatShellGetContext(mat, ctx, ierr)
      import :: tMat, c_ptr
      type(tMat) :: mat
      type(c_ptr), intent(out) :: ctx      !< the record's address
      PetscErrorCode :: ierr
    end subroutine MatShellGetContext
  end interface

end module shell_context
