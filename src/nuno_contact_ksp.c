// SPDX-License-Identifier: BSD-2-Clause
/* The C half of contact's step limit in the Baraff-Witkin mode
 * (-snes_type ksponly; module contact_solver): that SNES has no line search,
 * so no pre-check, and PETSc 3.18's Fortran interface has no
 * KSPSetPostSolve (it takes a C function pointer). The post-solve of the
 * SNES's KSP sees the update Y before SNES KSPONLY steps X - Y; the
 * trampoline calls the Fortran callback with the context Fortran
 * registered (its app_ctx). */
#include <petscksp.h>

/* module contact_solver's callback: the update y by reference, the
 * app_ctx, *ierr out */
extern void nuno_contact_limit_update(Vec *y, void *ctx, PetscErrorCode *ierr);

static PetscErrorCode post_solve_trampoline(KSP ksp, Vec b, Vec y, void *ctx)
{
  PetscErrorCode ierr = 0;
  PetscFunctionBeginUser;
  (void)ksp;
  (void)b;
  nuno_contact_limit_update(&y, ctx, &ierr);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* KSPSetPostSolve(*ksp, the trampoline, ctx). Logically collective. */
PetscErrorCode nuno_ksp_set_contact_post_solve(KSP *ksp, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(KSPSetPostSolve(*ksp, post_solve_trampoline, ctx));
  PetscFunctionReturn(0);
}
