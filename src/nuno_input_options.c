/* nuno's input-safety options, read in their own PETSc options block so that
 * they appear in -help with their defaults. A file of its own (not
 * nuno_options.c): these are read in main before the solver exists, and the
 * solver's option block stays untouched. Called once from Fortran (module
 * errors) through bind(C); collective. */
#include <petscsys.h>

/* allow_long: out 0/1; ts_dt, ts_dt_set: the -ts_dt that will override the
 * namelist's dt (out; ts_dt_set 0/1), so that the step bound checks the step
 * the run will take. Returns a PETSc error code (0 on success). */
PetscErrorCode nuno_input_options_read(MPI_Fint fcomm, int *allow_long, double *ts_dt, int *ts_dt_set)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscBool al   = PETSC_FALSE, set = PETSC_FALSE;
  PetscReal dt   = 0.0;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: input checks (input/README.md)", "nuno");
  PetscCall(PetscOptionsBool("-nuno_allow_long", "run even when t_end/dt exceeds 1e8 steps or t_end/output_interval exceeds 1e5 output steps",
                             "nuno", al, &al, NULL));
  {
    /* Read by main before the namelist (PetscOptionsGetString); declared
     * here so that it appears in -help. */
    char      buf[4096] = "";
    PetscBool given;
    PetscCall(PetscOptionsString("-nuno_set", "namelist keys over the input file's: key=value[,key=value...] (group%key where needed; strings quoted)",
                                 "nuno", buf, buf, sizeof(buf), &given));
  }
  PetscOptionsEnd();
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-ts_dt", &dt, &set));
  *allow_long = al ? 1 : 0;
  *ts_dt = (double)dt;
  *ts_dt_set = set ? 1 : 0;
  PetscFunctionReturn(0);
}
