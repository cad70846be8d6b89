/* nuno's own solver options, read inside a PETSc options block so that they
 * appear in -help with their defaults and current values (PETSc 3.18 has no
 * Fortran interface to PetscOptionsBegin/End: ../shared/STYLE.md). Called
 * once from Fortran (module timestepping) through bind(C); collective. */
#include <petscsys.h>

/* jacobian: in/out 0 = reduced, 1 = full; pc_lag: in/out >= 1;
 * snes_floor: in/out >= 0; gauss_newton, clamp: in/out 0/1.
 * Returns a PETSc error code (0 on success). */
PetscErrorCode nuno_options_read(MPI_Fint fcomm, int *jacobian, int *pc_lag, double *snes_floor,
                                 int *gauss_newton, int *clamp)
{
  static const char *const jacobians[] = {"reduced", "full"};
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  jac = *jacobian, lag = *pc_lag;
  PetscReal floor = *snes_floor;
  PetscBool gn = *gauss_newton ? PETSC_TRUE : PETSC_FALSE, cl = *clamp ? PETSC_TRUE : PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: the Newton step (docs/design.md, input/README.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_jacobian", "reduced: assemble only the 3-dof velocity system and eliminate around it; full: the 6-dof Jacobian",
                              "nuno", jacobians, 2, jacobians[jac], &jac, NULL));
  PetscCall(PetscOptionsInt("-nuno_pc_lag", "rebuild the inner (reduced_) preconditioner every N assemblies", "nuno", lag, &lag, NULL));
  PetscCall(PetscOptionsReal("-nuno_snes_floor", "Newton: converged when a residual below this fraction of its start stops decreasing, or (reduced) is at the round-off floor estimated from S (0: off)",
                             "nuno", floor, &floor, NULL));
  PetscCall(PetscOptionsBool("-nuno_gauss_newton", "energy bending: assemble only the Gauss-Newton part -k_b J^T J", "nuno", gn, &gn, NULL));
  PetscCall(PetscOptionsBool("-nuno_clamp_compression", "drop the indefinite compression term of the springs from the assembled matrix",
                             "nuno", cl, &cl, NULL));
  PetscOptionsEnd();
  PetscCheck(lag >= 1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_pc_lag %" PetscInt_FMT " must be >= 1", lag);
  PetscCheck(floor >= 0.0 && floor < 1.0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_snes_floor %g must be in [0, 1)", (double)floor);
  *jacobian = (int)jac;
  *pc_lag = (int)lag;
  *snes_floor = floor;
  *gauss_newton = gn ? 1 : 0;
  *clamp = cl ? 1 : 0;
  PetscFunctionReturn(0);
}
