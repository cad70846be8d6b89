// SPDX-License-Identifier: BSD-2-Clause
/* nuno's input-safety options, read in their own PETSc options block so that
 * they appear in -help with their defaults. A file of its own (not
 * nuno_options.c): these are read in main before the solver exists, and the
 * solver's option block stays untouched. Called once from Fortran (module
 * errors) through bind(C); collective. */
#include <petscsys.h>
#include <stdlib.h>
#include <string.h>

/* A wall-clock duration: seconds, or a number with s, m, h or d, or
 * H:MM:SS (as batch schedulers write limits). *sec > 0 on success;
 * returns 0 on success, 1 if text is not such a duration. */
static int parse_duration(const char *text, double *sec)
{
  char  *end;
  double h, m, s;

  *sec = 0.0;
  if (strchr(text, ':')) {
    h = strtod(text, &end);
    if (end == text || *end != ':') return 1;
    text = end + 1;
    m = strtod(text, &end);
    if (end == text || *end != ':') return 1;
    text = end + 1;
    s = strtod(text, &end);
    if (end == text || *end != '\0' || h < 0 || m < 0 || m >= 60 || s < 0 || s >= 60) return 1;
    *sec = 3600.0 * h + 60.0 * m + s;
  } else {
    double v = strtod(text, &end), unit = 1.0;
    if (end == text) return 1;
    if (*end == 's') unit = 1.0, end++;
    else if (*end == 'm') unit = 60.0, end++;
    else if (*end == 'h') unit = 3600.0, end++;
    else if (*end == 'd') unit = 86400.0, end++;
    if (*end != '\0') return 1;
    *sec = v * unit;
  }
  return (*sec > 0.0 && *sec < 1e12) ? 0 : 1;
}

/* allow_long: out 0/1; ts_dt, ts_dt_set: the -ts_dt that will override the
 * namelist's dt (out; ts_dt_set 0/1), so that the step bound checks the step
 * the run will take. restart: out, the -nuno_restart file ('' if none),
 * NUL-terminated in restart_len bytes; walltime: out, the
 * -nuno_checkpoint_walltime interval in seconds (0 if none); bad: out, the
 * option whose value was refused (NUL-terminated, '' if none), so that the
 * caller reports it in its one error line. Returns a PETSc error code. */
PetscErrorCode nuno_input_options_read(MPI_Fint fcomm, int *allow_long, double *ts_dt, int *ts_dt_set, char *restart,
                                       int restart_len, double *walltime, char *bad, int bad_len)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscBool al   = PETSC_FALSE, set = PETSC_FALSE;
  PetscReal dt   = 0.0;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: input checks (input/README.md)", "nuno");
  PetscCall(PetscOptionsBool("-nuno_allow_long", "run even when t_end/dt exceeds 1e8 steps or t_end/output_interval exceeds 1e5 output steps",
                             "nuno", al, &al, NULL));
  {
    /* Read by main before the namelist, from the command line itself
     * (module input_text: this database keeps one -nuno_set only, cut at
     * its first blank); declared here so that it appears in -help. */
    char      buf[4096] = "";
    PetscBool given;
    PetscCall(PetscOptionsString("-nuno_set", "namelist keys over the input file's: key=value[,key=value...] (commas or blanks between keys; group%key where needed; strings quoted; several -nuno_set read in order; a key at most once)",
                                 "nuno", buf, buf, sizeof(buf), &given));
  }
  restart[0] = '\0';
  bad[0]     = '\0';
  {
    /* Without its file (-nuno_restart last, or before another option) it
     * would read as no restart at all: the run would start afresh and, at
     * its first output step, replace the file it was meant to continue. */
    PetscBool given;
    PetscCall(PetscOptionsString("-nuno_restart", "continue the run from the last checkpoint in this output file, appending to it (input/README.md, Checkpoints)",
                                 "nuno", restart, restart, (size_t)restart_len, &given));
    if (given && !restart[0]) PetscCall(PetscSNPrintf(bad, (size_t)bad_len, "-nuno_restart needs the file to continue: -nuno_restart FILE (the output file of the run that wrote the checkpoint)"));
  }
  {
    char      wt[256] = "";
    PetscBool given;
    *walltime = 0.0;
    PetscCall(PetscOptionsString("-nuno_checkpoint_walltime", "write a checkpoint after each such wall-clock time: seconds, or 90m, 23h, 1d, or H:MM:SS",
                                 "nuno", wt, wt, sizeof(wt), &given));
    if (given && parse_duration(wt, walltime) && !bad[0]) {
      PetscCall(PetscSNPrintf(bad, (size_t)bad_len, "-nuno_checkpoint_walltime %s: not a wall-clock duration > 0 (seconds, or 90m, 23h, 1d, or H:MM:SS)", wt));
      *walltime = 0.0;
    }
  }
  PetscOptionsEnd();
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-ts_dt", &dt, &set));
  *allow_long = al ? 1 : 0;
  *ts_dt = (double)dt;
  *ts_dt_set = set ? 1 : 0;
  PetscFunctionReturn(0);
}
