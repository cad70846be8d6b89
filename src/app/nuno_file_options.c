// SPDX-License-Identifier: BSD-2-Clause
/* nuno's option for output files, in its own PETSc options block so that it
 * appears in -help with its default (PETSc 3.18 has no Fortran
 * PetscOptionsBegin: ../shared/STYLE.md). Called once from main through
 * bind(C); collective. */
#include <petscsys.h>

/* overwrite: out 0/1, -nuno_overwrite. Returns a PETSc error code. */
PetscErrorCode nuno_file_options_read(MPI_Fint fcomm, int *overwrite)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscBool ow   = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: output files (input/README.md, Output files)", "nuno");
  PetscCall(PetscOptionsBool("-nuno_overwrite",
                             "an earlier output file is replaced at the run's first output step, not only when the run completes (it is lost if the run then fails)",
                             "nuno", ow, &ow, NULL));
  PetscOptionsEnd();
  *overwrite = ow ? 1 : 0;
  PetscFunctionReturn(0);
}
