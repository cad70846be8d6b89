// SPDX-License-Identifier: BSD-2-Clause
/* The C half of contact's step limit in the Baraff-Witkin mode
 * (-snes_type ksponly; module contact_solver): that SNES has no line search,
 * so no pre-check, and PETSc 3.18's Fortran interface has no
 * KSPSetPostSolve (it takes a C function pointer). The post-solve of the
 * SNES's KSP sees the update Y before SNES KSPONLY steps X - Y; the
 * trampoline calls the Fortran callback with the context Fortran
 * registered (its app_ctx). */
#include <petscts.h>

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

/* The TS's check of a stage in that mode with moving obstacles: a state
 * made NaN by the limit (no halving kept a node from crossing a moving
 * obstacle) is rejected, and the step retried smaller, as a failed Newton
 * solve is in the other modes. Collective (VecNorm). */
static PetscErrorCode contact_domain(TS ts, PetscReal t, Vec y, PetscBool *accept)
{
  PetscReal ynorm;
  PetscFunctionBeginUser;
  (void)ts;
  (void)t;
  PetscCall(VecNorm(y, NORM_INFINITY, &ynorm));
  *accept = (ynorm == ynorm) ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(0);
}

/* TSSetFunctionDomainError(*ts, contact_domain): PETSc 3.18's Fortran
 * binding of it crashed here (SEGV at the first step). Logically
 * collective. */
PetscErrorCode nuno_ts_set_contact_domain(TS *ts)
{
  PetscFunctionBeginUser;
  PetscCall(TSSetFunctionDomainError(*ts, contact_domain));
  PetscFunctionReturn(0);
}
