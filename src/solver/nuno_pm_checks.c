// SPDX-License-Identifier: BSD-2-Clause
/* The C half of the process models' checks of a step (module
 * process_solver), for the calls PETSc 3.18's Fortran interface lacks:
 *
 * - the step limit in the Baraff-Witkin mode (-snes_type ksponly): that
 *   SNES has no line search, so no pre-check, and there is no Fortran
 *   KSPSetPostSolve (it takes a C function pointer). The post-solve of the
 *   SNES's KSP sees the update Y before SNES KSPONLY steps X - Y;
 * - the TS's stage check (TSSetFunctionDomainError; its Fortran binding
 *   crashed at the first step here): a stage the process models reject is
 *   a failed step, retried smaller. The context goes with the TS as its
 *   application context.
 *
 * Each trampoline calls the Fortran callback with the context Fortran
 * registered (its app_ctx). */
#include <petscts.h>

/* module process_solver's callbacks: the update y by reference, the
 * app_ctx, *ierr out; the stage's time, its state, the app_ctx, *accept
 * (1: accepted) and *ierr out */
extern void nuno_pm_limit_update(Vec *y, void *ctx, PetscErrorCode *ierr);
extern void nuno_pm_stage_check(PetscReal t, Vec *y, void *ctx, int *accept, PetscErrorCode *ierr);

static PetscErrorCode post_solve_trampoline(KSP ksp, Vec b, Vec y, void *ctx)
{
  PetscErrorCode ierr = 0;
  PetscFunctionBeginUser;
  (void)ksp;
  (void)b;
  nuno_pm_limit_update(&y, ctx, &ierr);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* KSPSetPostSolve(*ksp, the trampoline, ctx). Logically collective. */
PetscErrorCode nuno_ksp_set_pm_post_solve(KSP *ksp, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(KSPSetPostSolve(*ksp, post_solve_trampoline, ctx));
  PetscFunctionReturn(0);
}

/* The TS's check of a stage: the process models' verdict on the state y
 * at t (module process_solver's stage check). Collective. */
static PetscErrorCode stage_check(TS ts, PetscReal t, Vec y, PetscBool *accept)
{
  void          *ctx = NULL;
  int            ok  = 1;
  PetscErrorCode ierr = 0;
  PetscFunctionBeginUser;
  PetscCall(TSGetApplicationContext(ts, &ctx));
  nuno_pm_stage_check(t, &y, ctx, &ok, &ierr);
  PetscCall(ierr);
  *accept = ok ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(0);
}

/* TSSetFunctionDomainError(*ts, stage_check), the context ctx on the TS
 * (its application context, which nothing else in nuno sets). Logically
 * collective. */
PetscErrorCode nuno_ts_set_pm_stage_check(TS *ts, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(TSSetApplicationContext(*ts, ctx));
  PetscCall(TSSetFunctionDomainError(*ts, stage_check));
  PetscFunctionReturn(0);
}
