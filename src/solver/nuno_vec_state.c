// SPDX-License-Identifier: BSD-2-Clause
/* PETSc 3.18 has no Fortran stub for PetscObjectStateGet. Module reduced
 * uses an object's state to know that a vector is unchanged since it last
 * saw it: the multigrid's output, whose product with S the cycle has
 * already formed (every change through PETSc, VecGetArray/RestoreArray
 * included, increases the state). */
#include <petsc/private/petscimpl.h>

/* *state = the state of the object *obj (a Vec, Mat, ... handle, passed as
 * Fortran passes PETSc objects: the address of the handle). */
PetscErrorCode nuno_object_state(PetscObject *obj, PetscInt64 *state)
{
  PetscFunctionBeginUser;
  PetscCall(PetscObjectStateGet(*obj, (PetscObjectState *)state));
  PetscFunctionReturn(0);
}
