// SPDX-License-Identifier: BSD-2-Clause
/* PETSc 3.18 gaps for the adjoint (module identify): TSSetIJacobianP has no
 * Fortran stub (the C symbol exists), and TSTrajectorySetType none either.
 * The Fortran callback is stored on the TS with PetscObjectSetFortranCallback,
 * the pattern of PETSc's own src/ts/interface/ftn-custom/ztsf.c, and called
 * from a C trampoline with Fortran's by-reference arguments. */
#include <petsc/private/petscimpl.h>
#include <petscts.h>
#include <string.h>

typedef void (*nuno_ijacp_f)(TS *, PetscReal *, Vec *, Vec *, PetscReal *, Mat *, void *, PetscErrorCode *);

static PetscFortranCallbackId cb_ijacobianp = 0;

static PetscErrorCode nuno_ijacobianp_trampoline(TS ts, PetscReal t, Vec U, Vec Udot, PetscReal shift, Mat A, void *unused)
{
  nuno_ijacp_f   f;
  void          *fctx;
  PetscErrorCode ierr = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectGetFortranCallback((PetscObject)ts, PETSC_FORTRAN_CALLBACK_CLASS, cb_ijacobianp, (void (**)(void)) & f, &fctx));
  (*f)(&ts, &t, &U, &Udot, &shift, &A, fctx, &ierr);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* Fortran: call nuno_ts_set_ijacobianp(ts, A, func, ctx, ierr), func as for
 * TSSetIJacobian but (ts, t, u, udot, shift, A, ctx, ierr): A = dF/dp. */
void nuno_ts_set_ijacobianp_(TS *ts, Mat *A, nuno_ijacp_f func, void *ctx, PetscErrorCode *ierr)
{
  *ierr = PetscObjectSetFortranCallback((PetscObject)*ts, PETSC_FORTRAN_CALLBACK_CLASS, &cb_ijacobianp, (void (*)(void))func, ctx);
  if (*ierr) return;
  *ierr = TSSetIJacobianP(*ts, *A, nuno_ijacobianp_trampoline, NULL);
}

/* A fresh trajectory for the next forward run. The identification runs one
 * TSSolve per time window (module identify); PETSc 3.18's memory trajectory
 * does not survive that (TSSolve saves a window's first state while the TS
 * is still marked converged from the window before, the checkpoint is
 * skipped, and the adjoint of that window pops the wrong one: a crash), so
 * the default is `basic`, one file a step in the directory `dirname`
 * (removed at the end; inside a private directory of this run), and -ts_trajectory_type memory is refused when
 * there is more than one window. Its set-up sizes it for the whole run,
 * `horizon` [time] at step `dt`. Fortran: call
 * nuno_ts_trajectory_fresh(ts, horizon, dt, nwindows, dirname, ierr), dirname
 * NUL-terminated. ierr = -1: memory with several windows. */
void nuno_ts_trajectory_fresh_(TS *ts, PetscReal *horizon, PetscReal *dt, PetscInt *nwindows, const char *dirname, PetscErrorCode *ierr)
{
  TSTrajectory tj;
  PetscBool    set, ismemory;
  PetscReal    tmax, h;
  char         type[64];

  *ierr = TSSetSaveTrajectory(*ts);
  if (*ierr) return;
  *ierr = TSResetTrajectory(*ts);
  if (*ierr) return;
  *ierr = TSGetTrajectory(*ts, &tj);
  if (*ierr) return;
  *ierr = PetscOptionsGetString(NULL, NULL, "-ts_trajectory_type", type, sizeof(type), &set);
  if (*ierr) return;
  ismemory = set && !strcmp(type, TSTRAJECTORYMEMORY);
  if (ismemory && *nwindows > 1) {
    *ierr = -1;
    return;
  }
  if (!set) {
    *ierr = TSTrajectorySetType(tj, *ts, TSTRAJECTORYBASIC);
    if (*ierr) return;
  }
  {
    /* The basic trajectory refuses a directory that exists: one left by
     * an earlier forward run of this process goes. dirname is inside the
     * private directory this run made with mkdtemp (module identify,
     * make_scratch), so nothing here is anyone else's. */
    PetscMPIInt rank;
    PetscBool   exists;
    MPI_Comm    comm;
    *ierr = PetscObjectGetComm((PetscObject)*ts, &comm);
    if (*ierr) return;
    *ierr = MPI_Comm_rank(comm, &rank);
    if (*ierr) return;
    if (!rank) {
      *ierr = PetscTestDirectory(dirname, 'w', &exists);
      if (*ierr) return;
      if (exists) *ierr = PetscRMTree(dirname);
      if (*ierr) return;
    }
    *ierr = MPI_Barrier(comm);
    if (*ierr) return;
  }
  *ierr = TSTrajectorySetDirname(tj, dirname);
  if (*ierr) return;
  *ierr = TSTrajectorySetFromOptions(tj, *ts);
  if (*ierr) return;
  *ierr = TSGetMaxTime(*ts, &tmax);
  if (*ierr) return;
  *ierr = TSGetTimeStep(*ts, &h);
  if (*ierr) return;
  *ierr = TSSetMaxTime(*ts, *horizon);
  if (*ierr) return;
  *ierr = TSSetTimeStep(*ts, *dt);
  if (*ierr) return;
  *ierr = TSTrajectorySetUp(tj, *ts);
  if (*ierr) return;
  *ierr = TSSetMaxTime(*ts, tmax);
  if (*ierr) return;
  *ierr = TSSetTimeStep(*ts, h);
}

/* The options of the identification and the control, in an options block so
 * that they appear in -help (PETSc 3.18 has no Fortran PetscOptionsBegin:
 * ../shared/STYLE.md). check_identify, check_control: out 0/1. Called once
 * from module identify through bind(C); collective. */
PetscErrorCode nuno_adjoint_options_read(MPI_Fint fcomm, int *check_identify, int *check_control)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscBool ci = PETSC_FALSE, cc = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: identification (&identify) and deformation control (&control), docs/identification.md", "nuno");
  PetscCall(PetscOptionsBool("-identify_check_gradient", "&identify: print the adjoint gradient at the initial guess against central differences of the objective, the cost of a gradient, and stop",
                             "nuno", ci, &ci, NULL));
  PetscCall(PetscOptionsBool("-control_check_gradient", "&control: print the adjoint gradient with respect to the keyframe positions against central differences, the cost of a gradient, and stop",
                             "nuno", cc, &cc, NULL));
  PetscOptionsEnd();
  *check_identify = ci ? 1 : 0;
  *check_control  = cc ? 1 : 0;
  PetscFunctionReturn(0);
}
