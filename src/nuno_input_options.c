/* nuno's input-safety options, read in their own PETSc options block so that
 * they appear in -help with their defaults. A file of its own (not
 * nuno_options.c): these are read in main before the solver exists, and the
 * solver's option block stays untouched. Called once from Fortran (module
 * errors) through bind(C); collective. */
#include <petscsys.h>

/* allow_long: out 0/1. Returns a PETSc error code (0 on success). */
PetscErrorCode nuno_input_options_read(MPI_Fint fcomm, int *allow_long)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscBool al   = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: input checks (input/README.md)", "nuno");
  PetscCall(PetscOptionsBool("-nuno_allow_long", "run even when t_end/dt exceeds 1e8 steps or t_end/output_interval exceeds 1e5 output steps",
                             "nuno", al, &al, NULL));
  PetscOptionsEnd();
  *allow_long = al ? 1 : 0;
  PetscFunctionReturn(0);
}
