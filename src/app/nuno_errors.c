// SPDX-License-Identifier: BSD-2-Clause
/* PETSc errors as one line of ours. PETSc's default handler prints a
 * 30-line report (configure options included) on every rank that fails; a
 * usage error such as -ts_type no_such then reads as a crash. This handler
 * prints nothing and keeps the first error's text (generic text, the
 * specific message, the function and the place), which module errors puts
 * into its one error line. Installed by main after PetscInitialize. */
#include <string.h>
#include <unistd.h>
#include <petscsys.h>

static char nuno_petsc_error[512] = "";

static PetscErrorCode nuno_quiet_handler(MPI_Comm comm, int line, const char *func, const char *file,
                                         PetscErrorCode n, PetscErrorType p, const char *mess, void *ctx)
{
  (void)comm;
  (void)ctx;
  if (p == PETSC_ERROR_INITIAL) {
    const char *generic = NULL;
    PetscErrorMessage(n, &generic, NULL);
    snprintf(nuno_petsc_error, sizeof(nuno_petsc_error), "%s%s%s (%s at %s:%d)",
             mess && mess[0] ? mess : "", mess && mess[0] && generic ? ": " : "", generic ? generic : "",
             func ? func : "?", file ? file : "?", line);
    for (char *c = nuno_petsc_error; *c; c++)
      if (*c == '\n' || *c == '\r') *c = ' ';
  }
  return n;
}

/* Install the handler (collective only in that every rank calls it). */
PetscErrorCode nuno_quiet_petsc_errors(void)
{
  return PetscPushErrorHandler(nuno_quiet_handler, NULL);
}

/* The first PETSc error's text ("" when none), NUL-terminated in buf. */
void nuno_petsc_error_text(char *buf, int len)
{
  snprintf(buf, (size_t)len, "%s", nuno_petsc_error);
}

/* Sleep ms milliseconds. */
void nuno_pause_ms(int ms)
{
  usleep((useconds_t)ms * 1000u);
}
