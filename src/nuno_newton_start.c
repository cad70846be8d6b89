// SPDX-License-Identifier: BSD-2-Clause
/* The Newton start of backward Euler from the last accepted states
 * (-nuno_newton_start; docs/design.md, "the cubic start").
 *
 * PETSc's beuler starts Newton from x_n + dt xdot_n, the last two states
 * extrapolated linearly (-ts_theta_initial_guess_extrapolate). With the
 * cubic start Newton starts from the polynomial through the last four
 * accepted states at t_n, t_n - dt, t_n - 2 dt, t_n - 3 dt, evaluated at
 * t_n + dt: 4 x_n - 6 x_{n-1} + 4 x_{n-2} - x_{n-3} (quadratic,
 * 3 x_n - 3 x_{n-1} + x_{n-2}, and linear, 2 x_n - x_{n-1}, while fewer
 * equally spaced states are at hand). On hang 257 x 257 (dt = 1 ms) the
 * first residual of a step is then 100-150 times smaller than from the
 * linear start, and Newton takes one iteration a step instead of two
 * (measured with commit 9f1bf04; docs/design.md, "the cubic start").
 *
 * In C because PETSc 3.18's Fortran interface has no
 * SNESSetComputeInitialGuess (a function pointer). The history lives in a
 * PetscContainer composed on the TS, destroyed with it (no globals).
 * module timestepping pushes every accepted state (its TSMonitor), and
 * empties the history at an output window's start where the state jumps
 * (a keyframe's start); across the other windows' starts the history goes
 * on, and a checkpoint keeps it (nuno_newton_start_count, _get; a restart
 * puts it back with _put), so that a restarted run repeats the one it
 * continues. Emptied at every window's start instead, it cost 12 % of
 * hang's 1 s at 257 x 257 (1100 instead of 1005 Newton iterations). Where the linear start's residual
 * is the smaller the step takes that one (start_guess). A step whose dt is
 * not the spacing of the kept states (a retry at dt/4, a sliver before a
 * stop time) starts from the last two accepted states extrapolated to it. */
#include <petscts.h>

#define NUNO_START_KEPT 4

typedef struct {
  TS        ts;                     /* no reference taken: the container lives on it */
  PetscInt  n;                      /* states kept, newest first */
  Vec       h[NUNO_START_KEPT];     /* 6-dof states x_n, x_{n-1}, ... */
  PetscReal t[NUNO_START_KEPT];     /* their times */
  Vec       xl, fl, fc;             /* the linear start, its residual; the other start's residual */
  PetscBool compare;                /* evaluate the linear start too (below) */
  PetscReal nc_prev;                /* the residual of the last polynomial start */
} NunoStart;

static PetscErrorCode start_destroy(void *ctx)
{
  NunoStart *s = (NunoStart *)ctx;
  PetscFunctionBeginUser;
  for (PetscInt k = 0; k < NUNO_START_KEPT; k++) PetscCall(VecDestroy(&s->h[k]));
  PetscCall(VecDestroy(&s->xl));
  PetscCall(VecDestroy(&s->fl));
  PetscCall(VecDestroy(&s->fc));
  PetscCall(PetscFree(s));
  PetscFunctionReturn(0);
}

static PetscErrorCode start_get(TS ts, NunoStart **s)
{
  PetscContainer c;
  PetscFunctionBeginUser;
  *s = NULL;
  PetscCall(PetscObjectQuery((PetscObject)ts, "nuno_newton_start", (PetscObject *)&c));
  if (c) PetscCall(PetscContainerGetPointer(c, (void **)s));
  PetscFunctionReturn(0);
}

/* The number of kept states equally spaced by dt, newest first (1: the
 * newest alone). */
static PetscInt start_spaced(const NunoStart *s, PetscReal dt)
{
  PetscReal tol = 1e-9 * PetscAbsReal(dt);
  PetscInt  m;
  for (m = 1; m < s->n; m++)
    if (PetscAbsReal(s->t[m - 1] - s->t[m] - dt) > tol) break;
  return m;
}

/* x = the polynomial of order p (1, 2 or 3) through the newest p + 1
 * kept states, equally spaced, at one spacing beyond the newest. */
static PetscErrorCode start_predict(const NunoStart *s, PetscInt p, Vec x)
{
  PetscFunctionBeginUser;
  switch (p) {
  case 1: /* 2 x_n - x_{n-1} */
    PetscCall(VecAXPBYPCZ(x, 2.0, -1.0, 0.0, s->h[0], s->h[1]));
    break;
  case 2: /* 3 x_n - 3 x_{n-1} + x_{n-2} */
    PetscCall(VecAXPBYPCZ(x, 3.0, -3.0, 0.0, s->h[0], s->h[1]));
    PetscCall(VecAXPY(x, 1.0, s->h[2]));
    break;
  default: /* 4 x_n - 6 x_{n-1} + 4 x_{n-2} - x_{n-3} */
    PetscCall(VecAXPBYPCZ(x, 4.0, -6.0, 0.0, s->h[0], s->h[1]));
    PetscCall(VecAXPBYPCZ(x, 4.0, -1.0, 1.0, s->h[2], s->h[3]));
    break;
  }
  PetscFunctionReturn(0);
}

/* SNESSetComputeInitialGuess callback: x is the start TS set (x_n, or
 * x_n + dt xdot_n). When the kept states end at this step's start and are
 * spaced by its dt, x becomes the polynomial through them (cubic when
 * four are kept), whose residual is handed to SNES (SNESSetInitialFunction:
 * no evaluation more). Where the motion is smooth that residual is
 * 100-150 times smaller than the linear start's (hang 257 x 257); but in the
 * fast transients of a membrane without bending just after a release from
 * rest the polynomial's larger weights (4, 6, 4, 1 against 2, 1) amplify
 * the steps' wiggles (hang 1025 x 1025 without bending: the cubic started
 * steps 3-6 from residuals 2-3 times the linear start's, and Newton
 * diverged at the sixth). So the linear start's residual is evaluated too,
 * and the smaller one taken, until the polynomial has won by a factor 2,
 * and again from a step whose polynomial start's residual is more than
 * twice the last one's, or when the linear one won. A step of another dt
 * (a retry after a failed solve, a sliver before a stop time) starts from
 * the last two accepted states extrapolated linearly to it (TS's xdot may
 * then be a failed iterate's). */
static PetscErrorCode start_guess(SNES snes, Vec x, void *ctx)
{
  NunoStart *s = (NunoStart *)ctx;
  PetscReal  t, dt, nc, nl;
  PetscInt   m, p;

  PetscFunctionBeginUser;
  PetscCall(TSGetTime(s->ts, &t));
  PetscCall(TSGetTimeStep(s->ts, &dt));
  if (s->n < 2 || PetscAbsReal(s->t[0] - t) > 1e-9 * PetscAbsReal(dt)) PetscFunctionReturn(0);
  m = start_spaced(s, dt);
  if (m == 1) {
    PetscCall(VecAXPBYPCZ(x, 1.0 + dt / (s->t[0] - s->t[1]), -dt / (s->t[0] - s->t[1]), 0.0, s->h[0], s->h[1]));
    PetscFunctionReturn(0);
  }
  p = m - 1; /* at most 3: four states are kept */
  if (p == 1) {
    PetscCall(start_predict(s, 1, x));
    PetscFunctionReturn(0);
  }
  if (!s->xl) {
    PetscCall(VecDuplicate(x, &s->xl));
    PetscCall(VecDuplicate(x, &s->fl));
    PetscCall(VecDuplicate(x, &s->fc));
  }
  PetscCall(start_predict(s, p, x));
  PetscCall(SNESComputeFunction(snes, x, s->fc));
  PetscCall(VecNorm(s->fc, NORM_2, &nc));
  if (s->compare || !(nc <= 2.0 * s->nc_prev)) {
    PetscCall(start_predict(s, 1, s->xl));
    PetscCall(SNESComputeFunction(snes, s->xl, s->fl));
    PetscCall(VecNorm(s->fl, NORM_2, &nl));
    s->compare = PETSC_TRUE;
    if (PetscIsInfOrNanReal(nc) || nl < nc) {
      PetscCall(VecCopy(s->xl, x));
      PetscCall(SNESSetInitialFunction(snes, s->fl));
    } else {
      /* TS's Jacobian takes xdot from the last residual evaluated, which
       * must be the start's (from the other start's, the elimination's
       * predicted products missed, and every inner solve took a pass
       * over the elements more: +30 ms a step at 257 x 257): SNES
       * evaluates this one again */
      if (2.0 * nc < nl) s->compare = PETSC_FALSE;
    }
  } else {
    PetscCall(SNESSetInitialFunction(snes, s->fc));
  }
  s->nc_prev = nc;
  PetscFunctionReturn(0);
}

/* Read -nuno_newton_start (auto, linear, cubic) in an options block and,
 * for cubic, attach the history and the callback to the TS's SNES.
 * auto_cubic: what auto means for this run (module timestepping: cubic
 * for Newton with beuler at fixed steps). *order out: 1 (linear) or 3.
 * Refuses cubic with a TS other than beuler, whose stage solved by Newton
 * is then not the state at t_n + dt. Collective. */
PetscErrorCode nuno_newton_start_setup(TS *ts, int *auto_cubic, int *order)
{
  static const char *const starts[] = {"auto", "linear", "cubic"};
  PetscInt       st = 0;
  PetscBool      beuler;
  MPI_Comm       comm;
  SNES           snes;
  PetscContainer c;
  NunoStart     *s;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectGetComm((PetscObject)*ts, &comm));
  PetscOptionsBegin(comm, NULL, "nuno: the Newton start (docs/design.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_newton_start",
                              "beuler: Newton's start, auto (cubic for Newton at fixed steps, linear in the Baraff-Witkin mode -snes_type ksponly, in adaptive, identification and control runs), linear (x_n + dt xdot_n: -ts_theta_initial_guess_extrapolate), cubic (the polynomial through the last four accepted states, or the linear start where its residual is the smaller)",
                              "nuno", starts, 3, starts[st], &st, NULL));
  PetscOptionsEnd();
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSBEULER, &beuler));
  PetscCheck(st != 2 || beuler, comm, PETSC_ERR_ARG_INCOMP, "-nuno_newton_start cubic needs -ts_type beuler (its Newton solve is for the state at t + dt)");
  *order = 1;
  if (st == 1 || (st == 0 && !(*auto_cubic && beuler))) PetscFunctionReturn(0);
  PetscCall(PetscNew(&s));
  s->ts      = *ts;
  s->compare = PETSC_TRUE;
  PetscCall(PetscContainerCreate(comm, &c));
  PetscCall(PetscContainerSetPointer(c, s));
  PetscCall(PetscContainerSetUserDestroy(c, start_destroy));
  PetscCall(PetscObjectCompose((PetscObject)*ts, "nuno_newton_start", (PetscObject)c));
  PetscCall(PetscContainerDestroy(&c));
  PetscCall(TSGetSNES(*ts, &snes));
  PetscCall(SNESSetComputeInitialGuess(snes, start_guess, s));
  *order = 3;
  PetscFunctionReturn(0);
}

/* Keep the accepted state u at time t (module timestepping's TSMonitor;
 * nothing without the cubic start). Collective. */
PetscErrorCode nuno_newton_start_push(TS *ts, Vec *u, double *t)
{
  NunoStart *s;
  Vec        oldest;
  PetscFunctionBeginUser;
  PetscCall(start_get(*ts, &s));
  if (!s) PetscFunctionReturn(0);
  if (s->n > 0 && *t == s->t[0]) PetscFunctionReturn(0); /* the same state again */
  if (!s->h[0])
    for (PetscInt k = 0; k < NUNO_START_KEPT; k++) PetscCall(VecDuplicate(*u, &s->h[k]));
  /* the vectors change places, the oldest is overwritten */
  oldest = s->h[NUNO_START_KEPT - 1];
  for (PetscInt k = NUNO_START_KEPT - 1; k > 0; k--) {
    s->h[k] = s->h[k - 1];
    s->t[k] = s->t[k - 1];
  }
  s->h[0] = oldest;
  s->t[0] = (PetscReal)*t;
  PetscCall(VecCopy(*u, s->h[0]));
  s->n = PetscMin(s->n + 1, NUNO_START_KEPT);
  PetscFunctionReturn(0);
}

/* Forget the kept states (an output window's start where the state jumps). */
PetscErrorCode nuno_newton_start_reset(TS *ts)
{
  NunoStart *s;
  PetscFunctionBeginUser;
  PetscCall(start_get(*ts, &s));
  if (s) {
    s->n       = 0;
    s->compare = PETSC_TRUE;
  }
  PetscFunctionReturn(0);
}

/* For a checkpoint (module timestepping): *n, the number of kept states
 * (0 without the cubic start), and the start's comparison state. */
PetscErrorCode nuno_newton_start_count(TS *ts, int *n, int *compare, double *nc_prev)
{
  NunoStart *s;
  PetscFunctionBeginUser;
  PetscCall(start_get(*ts, &s));
  *n       = s ? (int)s->n : 0;
  *compare = s ? (int)s->compare : 1;
  *nc_prev = s ? (double)s->nc_prev : 0.0;
  PetscFunctionReturn(0);
}

/* For a checkpoint: *v = the kept state *k (0: the newest), *t its time.
 * Collective. */
PetscErrorCode nuno_newton_start_get(TS *ts, int *k, Vec *v, double *t)
{
  NunoStart *s;
  PetscFunctionBeginUser;
  PetscCall(start_get(*ts, &s));
  PetscCheck(s && *k >= 0 && *k < s->n, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "nuno_newton_start_get: no kept state %d", *k);
  PetscCall(VecCopy(s->h[*k], *v));
  *t = (double)s->t[*k];
  PetscFunctionReturn(0);
}

/* From a checkpoint (a restart): kept state *k (0: the newest) becomes
 * *v at time *t, *n states are kept, and the comparison state is put back,
 * so that the next steps start as in the run that wrote the checkpoint.
 * Nothing without the cubic start. Collective. */
PetscErrorCode nuno_newton_start_put(TS *ts, int *k, Vec *v, double *t, int *n, int *compare, double *nc_prev)
{
  NunoStart *s;
  PetscFunctionBeginUser;
  PetscCall(start_get(*ts, &s));
  if (!s) PetscFunctionReturn(0);
  PetscCheck(*k >= 0 && *k < NUNO_START_KEPT && *n >= 1 && *n <= NUNO_START_KEPT, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE,
             "nuno_newton_start_put: state %d of %d", *k, *n);
  if (!s->h[0])
    for (PetscInt j = 0; j < NUNO_START_KEPT; j++) PetscCall(VecDuplicate(*v, &s->h[j]));
  PetscCall(VecCopy(*v, s->h[*k]));
  s->t[*k]    = (PetscReal)*t;
  s->n        = *n;
  s->compare  = *compare ? PETSC_TRUE : PETSC_FALSE;
  s->nc_prev  = (PetscReal)*nc_prev;
  PetscFunctionReturn(0);
}
