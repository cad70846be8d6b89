// SPDX-License-Identifier: BSD-2-Clause
/* The C half of backward Euler's Newton start (module newton_start, which
 * holds the algorithm and its states): PETSc 3.18's Fortran interface has
 * no SNESSetComputeInitialGuess (it takes a C function pointer) and no
 * SNESSetInitialFunction. The trampoline calls the Fortran callback with
 * the context Fortran registered (its newton_start_t). */
#include <petscsnes.h>

/* module newton_start's callback: snes, x by reference, its record, *ierr out */
extern void nuno_newton_start_guess(SNES *snes, Vec *x, void *ctx, PetscErrorCode *ierr);

static PetscErrorCode start_trampoline(SNES snes, Vec x, void *ctx)
{
  PetscErrorCode ierr = 0;
  PetscFunctionBeginUser;
  nuno_newton_start_guess(&snes, &x, ctx, &ierr);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* SNESSetComputeInitialGuess(*snes, the trampoline, ctx). Logically collective. */
PetscErrorCode nuno_snes_set_initial_guess(SNES *snes, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(SNESSetComputeInitialGuess(*snes, start_trampoline, ctx));
  PetscFunctionReturn(0);
}

/* SNESSetInitialFunction(*snes, *f): f is the residual at the start just
 * set, so SNES does not evaluate it again. Logically collective. */
PetscErrorCode nuno_snes_set_initial_function(SNES *snes, Vec *f)
{
  PetscFunctionBeginUser;
  PetscCall(SNESSetInitialFunction(*snes, *f));
  PetscFunctionReturn(0);
}
