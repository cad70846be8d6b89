// SPDX-License-Identifier: BSD-2-Clause
/* SIGTERM and SIGINT (what batch schedulers send before SIGKILL, and
 * Ctrl-C) end a run cleanly: the handler only records the signal; after
 * every time step a TS post-step agrees on it over the ranks (one 2-integer
 * allreduce, shared with the wall-clock checkpoints) and stops TSSolve
 * with TS_CONVERGED_USER, so that every rank
 * finishes the same step, writes the last state and marks the file
 * 'interrupted: ...' (module timestepping). A second signal while the
 * first is being handled ends the process at once (default action).
 * The same post-step ends TSSolve after the step that reaches the next
 * output time between stops (nuno_output_arm), for the run driver to write
 * it; nuno_ts_interpolates says for which methods it can.
 * C because the Fortran interface has no sigaction, and TSSetPostStep's
 * Fortran stub takes no context. */
#include <petscts.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <signal.h>
#include <string.h>
#include <unistd.h>

static volatile sig_atomic_t caught = 0; /* the signal received, 0 if none */
static int agreed = 0;                   /* the signal every rank has agreed on */
static int devnull = -1;                 /* /dev/null, opened at install */

/* Open MPI's mpirun, sent SIGTERM or SIGINT, stops reading the ranks'
 * stdout at once, forwards the signal after odls_base_sigkill_timeout
 * (1 s by default) and sends SIGKILL as long after that (strace of
 * mpirun). A rank's stdout there is a pty that holds about 16 kB: a rank
 * that writes more before the signal comes blocks in write(), and the
 * forwarded signal only restarts the write, so the rank never ends its
 * step and SIGKILL leaves no checkpoint (hang 33 x 33 on 2 ranks, a line
 * every 5 steps: about 17 kB a second, lost about one try in four). So:
 *  - a signal from the launcher that started this rank (Open MPI's mpirun
 *    or orted, found by name at install) points stdout at /dev/null at
 *    once: nobody reads it any more, and a rank short of a full pty would
 *    block on the lines it writes while it ends its step;
 *  - any other signal does so to stdout and stderr only where the stream
 *    cannot take a byte now (a stream that is being read, the signal sent
 *    to the ranks as Slurm does, keeps every line).
 * The write in progress then ends, and what is written on the stream
 * after it is dropped. The status line on stderr (a pipe, which mpirun
 * empties at the end) and the file's status say the run was interrupted.
 * poll and dup2 are async-signal-safe. */
static pid_t launcher = 0; /* the parent, if it is Open MPI's mpirun or orted (0 if not) */

static void unblock(int fd)
{
  struct pollfd p = {fd, POLLOUT, 0};

  if (devnull < 0) return;
  if (poll(&p, 1, 0) != 1 || !(p.revents & POLLOUT) || (p.revents & (POLLERR | POLLHUP))) dup2(devnull, fd);
}

static void on_signal(int sig, siginfo_t *info, void *uctx)
{
  int saved;

  (void)uctx;
  if (caught) {
    signal(sig, SIG_DFL);
    raise(sig);
    return;
  }
  saved  = errno; /* the interrupted code may read it */
  caught = sig;
  if (launcher > 0 && devnull >= 0 && info && info->si_pid == launcher) dup2(devnull, STDOUT_FILENO);
  else unblock(STDOUT_FILENO);
  unblock(STDERR_FILENO);
  errno = saved;
}

/* The parent's pid if its name is one of Open MPI's launchers (see above). */
static pid_t open_mpi_launcher(void)
{
  static const char *names[] = {"mpirun", "mpiexec", "orterun", "orted", "prted", "prterun"};
  char  path[64], comm[64] = "";
  pid_t parent = getppid();
  FILE *f;

  snprintf(path, sizeof(path), "/proc/%d/comm", (int)parent);
  f = fopen(path, "r");
  if (!f) return 0;
  if (!fgets(comm, sizeof(comm), f)) comm[0] = 0;
  fclose(f);
  comm[strcspn(comm, "\n")] = 0;
  for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++)
    if (!strcmp(comm, names[i])) return parent;
  return 0;
}

/* -nuno_checkpoint_walltime: a checkpoint after each `interval` seconds of
 * wall-clock time, agreed after a step like the signals (the same
 * allreduce). TSSolve ends after that step (its monitor, which adds the
 * step's energy integrals, runs as TSSolve's last call) and the run driver
 * writes the checkpoint and calls TSSolve again in the same window
 * (advance_window in module timestepping): a second TSSolve with steps
 * taken resets no counter and no multistep history, and the monitor that
 * opens it repeats the last one's work on the same state, so the
 * integration goes on exactly as without the checkpoint. */
static double interval = 0.0, deadline = 0.0;
/* every rank agreed that a checkpoint is due after this step: 1, or 2 when
 * the post-step ended TSSolve for it (the window goes on after it) */
static int due = 0;

/* The next output time inside the current window (module timestepping),
 * armed by the run driver less its tolerance: the post-step ends TSSolve
 * after the step that reaches or passes it, the driver writes that output
 * step from the step's own state or from TSInterpolate and calls TSSolve
 * again in the same window, as for a wall-clock checkpoint, so that the
 * output changes nothing in the integration. The TS's time is the same on
 * every rank: nothing to agree on. */
static int    output_armed = 0;
static double output_at    = 0.0;

/* A stop asked for by the monitor (nuno_ts_stop), applied after the next
 * step: TSStep sets the TS's reason back to "iterating" before it steps,
 * so a reason set in the monitor, which TSSolve calls before TSStep, is
 * lost, and TSSolve went on. */
static int stop_pending = 0;

static PetscErrorCode poststep(TS ts)
{
  int      mine[2], all[2] = {0, 0};
  MPI_Comm comm;

  PetscFunctionBeginUser;
  mine[0] = (int)caught;
  mine[1] = interval > 0.0 && MPI_Wtime() >= deadline;
  PetscCall(PetscObjectGetComm((PetscObject)ts, &comm));
  PetscCallMPI(MPI_Allreduce(mine, all, 2, MPI_INT, MPI_MAX, comm));
  if (stop_pending) {
    /* the monitor's ranks all asked (it decides on global values) */
    stop_pending = 0;
    PetscCall(TSSetConvergedReason(ts, TS_CONVERGED_USER));
  }
  if (all[0]) {
    agreed = all[0];
    PetscCall(TSSetConvergedReason(ts, TS_CONVERGED_USER));
  } else if (all[1]) {
    TSConvergedReason reason;
    deadline = MPI_Wtime() + interval;
    due      = 1;
    /* A step that ended the window, failed or reached -ts_max_steps ends
     * TSSolve anyway; any other ends it now, for the driver to write.
     * Except where the step the TS chose ends within round-off of the
     * window's end: TSSolve, entered again, would clip it to max_time - t
     * (PETSc 3.18's TSSolve under matchstep), where the adaptor kept it
     * when t + dt == max_time (hang 21 x 21: the window's last step then
     * differed in its last bits). There the checkpoint waits for the
     * window's end, one step later. */
    PetscCall(TSGetConvergedReason(ts, &reason));
    if (reason == TS_CONVERGED_ITERATING) {
      PetscReal t, dt, tmax;
      PetscCall(TSGetTime(ts, &t));
      PetscCall(TSGetTimeStep(ts, &dt));
      PetscCall(TSGetMaxTime(ts, &tmax));
      if (dt < tmax - t && !PetscIsCloseAtTol(dt, tmax - t, 10 * PETSC_MACHINE_EPSILON, 0)) {
        due = 2;
        PetscCall(TSSetConvergedReason(ts, TS_CONVERGED_USER));
      }
    }
  }
  if (output_armed) {
    TSConvergedReason reason;
    PetscReal         t;
    PetscCall(TSGetConvergedReason(ts, &reason));
    PetscCall(TSGetTime(ts, &t));
    if (reason == TS_CONVERGED_ITERATING && t >= output_at) PetscCall(TSSetConvergedReason(ts, TS_CONVERGED_USER));
  }
  PetscFunctionReturn(0);
}

/* End TSSolve after the step that reaches time t (an output time less its
 * tolerance); armed: 0 for none. */
void nuno_output_arm(int armed, double t)
{
  output_armed = armed;
  output_at    = t;
}

/* Whether TSInterpolate of ts's method gives its solution between the last
 * two steps: *yes = 1, else 0. Measured on PETSc 3.18.5 by a probe on
 * y' = -y (TSInterpolate at both ends of the last step and in between):
 * the theta methods (beuler, cn, theta: linear between the step's ends),
 * bdf (the Lagrange polynomial of its order), rosw ra34pw2, ra3pw,
 * assp3p3s1c, theta1 and theta2, arkimex a2, ars122, 2c, 2d, 2e, 3, 4 and
 * 5 meet both ends and the solution. The others have none (rosw rodas3,
 * grk4t, shamp4, veldd4, 4l; arkimex prssp2, bpr3, ars443: PETSC_ERR_SUP),
 * one that misses the step's end by up to 16 % of the change in the step
 * (rosw 2p, 2m, sandu3; arkimex 1bee, l2), or one that is wrong by factors
 * of 1e2 to 1e11 (rosw lassp3p4s2c, llssp3p4s2c, ark3): their output times
 * stay stops of the integrator (module timestepping). */
PetscErrorCode nuno_ts_interpolates(TS *ts, int *yes)
{
  static const char *rosw[]    = {TSROSWRA34PW2, TSROSWRA3PW, TSROSWASSP3P3S1C, TSROSWTHETA1, TSROSWTHETA2};
  static const char *arkimex[] = {TSARKIMEXA2, TSARKIMEXARS122, TSARKIMEX2C, TSARKIMEX2D,
                                  TSARKIMEX2E, TSARKIMEX3,      TSARKIMEX4,  TSARKIMEX5};
  PetscBool          match;
  const char        *name;

  PetscFunctionBeginUser;
  *yes = 0;
  PetscCall(PetscObjectTypeCompareAny((PetscObject)*ts, &match, TSBEULER, TSCN, TSTHETA, TSBDF, ""));
  if (match) {
    *yes = 1;
    PetscFunctionReturn(0);
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSROSW, &match));
  if (match) {
    PetscCall(TSRosWGetType(*ts, &name));
    for (size_t i = 0; i < sizeof(rosw) / sizeof(rosw[0]); i++)
      if (!strcmp(name, rosw[i])) *yes = 1;
    PetscFunctionReturn(0);
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSARKIMEX, &match));
  if (match) {
    PetscCall(TSARKIMEXGetType(*ts, &name));
    for (size_t i = 0; i < sizeof(arkimex) / sizeof(arkimex[0]); i++)
      if (!strcmp(name, arkimex[i])) *yes = 1;
  }
  PetscFunctionReturn(0);
}

/* A checkpoint after every `seconds` of wall-clock time from now (0: none). */
void nuno_walltime_arm(double seconds)
{
  interval = seconds > 0.0 ? seconds : 0.0;
  deadline = MPI_Wtime() + interval;
  due      = 0;
}

/* Once after the step at which all ranks agreed a checkpoint is due: 2
 * when TSSolve ended for it (the window is not done), 1 when TSSolve ended
 * there anyway; else 0. */
int nuno_checkpoint_due(void)
{
  int d = due;
  due   = 0;
  return d;
}

/* Install the handlers and the post-step on ts. Returns a PETSc error code. */
PetscErrorCode nuno_signals_install(TS *ts)
{
  struct sigaction sa;

  PetscFunctionBeginUser;
  if (devnull < 0) devnull = open("/dev/null", O_WRONLY | O_CLOEXEC);
  launcher = open_mpi_launcher();
  memset(&sa, 0, sizeof(sa));
  sa.sa_sigaction = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART | SA_SIGINFO;
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGINT, &sa, NULL);
  PetscCall(TSSetPostStep(*ts, poststep));
  PetscFunctionReturn(0);
}

/* Back to the default actions: on an error exit, the SIGTERM that mpirun
 * sends the other ranks after one rank's MPI_Abort must end them, not be
 * taken for a request to finish the step (and cut their pause short). */
void nuno_signals_default(void)
{
  signal(SIGTERM, SIG_DFL);
  signal(SIGINT, SIG_DFL);
}

/* The signal all ranks agreed on after the last step (0: none). */
int nuno_signal_agreed(void)
{
  return agreed;
}

/* Stop TSSolve (TS_CONVERGED_USER, which the Fortran interface of PETSc
 * 3.18 does not define), called from the TS monitor on every rank: at once
 * when the monitor is TSSolve's last call, else after the step TSSolve
 * takes next (the post-step applies it; see stop_pending). Returns a PETSc
 * error code. */
PetscErrorCode nuno_ts_stop(TS *ts)
{
  PetscFunctionBeginUser;
  stop_pending = 1;
  PetscCall(TSSetConvergedReason(*ts, TS_CONVERGED_USER));
  PetscFunctionReturn(0);
}
