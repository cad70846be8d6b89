! SPDX-License-Identifier: BSD-2-Clause
!> A global vector of the DMDA read with its halo: its local copy (the
!> ghost rows of the neighbouring strips updated) and that copy's array,
!> read only, for the plain-array kernels (the residual, the Jacobian's
!> assembly, the monitor's powers, contact's check, the output step, the
!> reduced solve's right-hand side, 6-dof product and constrained marks,
!> identification's dF/dp), and their release. The one place of the four
!> calls each such read takes.
module ghosted_state
#include "petsc/finclude/petscdmda.h"
  use petscdmda
  implicit none
  private
  public :: ghosted_get, ghosted_restore

contains

  !> u: the array (0:dof-1, 0:nx-1, gys:gye) of the global vector g of da
  !> with its halo, read only, through the local vector loc
  !> (DMGetLocalVector; the ghosts updated). Release it with
  !> ghosted_restore. Collective.
  subroutine ghosted_get(da, g, loc, u, ierr)
    type(tDM), intent(in) :: da
    type(tVec), intent(in) :: g
    type(tVec), intent(inout) :: loc
    PetscScalar, pointer, intent(inout) :: u(:, :, :)
    PetscErrorCode, intent(out) :: ierr
    PetscCall(DMGetLocalVector(da, loc, ierr))
    PetscCall(DMGlobalToLocalBegin(da, g, INSERT_VALUES, loc, ierr))
    PetscCall(DMGlobalToLocalEnd(da, g, INSERT_VALUES, loc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(da, loc, u, ierr))
  end subroutine ghosted_get

  !> Release the array u of the local vector loc (ghosted_get).
  subroutine ghosted_restore(da, loc, u, ierr)
    type(tDM), intent(in) :: da
    type(tVec), intent(inout) :: loc
    PetscScalar, pointer, intent(inout) :: u(:, :, :)
    PetscErrorCode, intent(out) :: ierr
    PetscCall(DMDAVecRestoreArrayReadF90(da, loc, u, ierr))
    PetscCall(DMRestoreLocalVector(da, loc, ierr))
  end subroutine ghosted_restore

end module ghosted_state
