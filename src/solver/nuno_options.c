// SPDX-License-Identifier: BSD-2-Clause
/* nuno's own solver options, read inside PETSc options blocks so that they
 * appear in -help with their defaults and current values: PETSc 3.18 has no
 * Fortran interface to PetscOptionsBegin/End and the PetscOptions* readers
 * (only C *_Private symbols; ../shared/STYLE.md), nor to
 * PetscOptionsLeftGet (the end-of-run report of options that nothing read).
 * Each function reads one block and hands the values back; what they mean,
 * their checks and defaults are Fortran's (modules solver_setup,
 * newton_policy, newton_start, reduced). The choice lists come from Fortran
 * (module solver_choices) as arguments: a choice's position is its code
 * there.
 * Called through bind(C); collective. */
#include <petscts.h>
#include <string.h>

#define NUNO_CHOICES_MAX 8
#define NUNO_CHOICE_LEN  32

/* A choice list of module solver_choices: n names of len characters each,
 * blank-padded, in the order of their codes. */
typedef struct {
  char        buf[NUNO_CHOICES_MAX][NUNO_CHOICE_LEN];
  const char *name[NUNO_CHOICES_MAX];
  PetscInt    n;
} Choices;

static PetscErrorCode choices_from_fortran(const char *names, int n, int len, Choices *c)
{
  PetscFunctionBeginUser;
  PetscCheck(n >= 1 && n <= NUNO_CHOICES_MAX && len >= 1 && len < NUNO_CHOICE_LEN, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
             "nuno: a choice list of %d names of %d characters", n, len);
  for (int k = 0; k < n; k++) {
    int l = len;
    while (l > 0 && names[k * len + l - 1] == ' ') l--;
    memcpy(c->buf[k], names + k * len, (size_t)l);
    c->buf[k][l] = '\0';
    c->name[k]   = c->buf[k];
  }
  c->n = n;
  PetscFunctionReturn(0);
}

/* jacobian, mg_interp, guess: in/out codes of the lists jac_names, interp_names,
 * guess_names (n names of len characters each); pc_lag, pc_growth, snes_floor,
 * fail_newton: in/out (checked by the caller); gauss_newton, clamp, forcing:
 * in/out 0/1; mattype: in/out NUL-terminated, mattype_len bytes;
 * *guess_given 1 when -nuno_inner_guess is set. Returns a PETSc error code. */
PetscErrorCode nuno_options_read(MPI_Fint fcomm, const char *jac_names, int jac_n, int jac_len, int *jacobian, int *pc_lag, double *pc_growth,
                                 const char *interp_names, int interp_n, int interp_len, int *mg_interp, double *snes_floor,
                                 int *gauss_newton, int *clamp, char *mattype, int mattype_len, int *fail_newton, int *forcing,
                                 const char *guess_names, int guess_n, int guess_len, int *guess, int *guess_given)
{
  Choices   jacobians, interps, guesses;
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  jac = *jacobian, lag = *pc_lag, nfail = *fail_newton, interp = *mg_interp, gs = *guess;
  PetscBool gset = PETSC_FALSE;
  PetscReal floor = *snes_floor, growth = *pc_growth;
  PetscBool gn = *gauss_newton ? PETSC_TRUE : PETSC_FALSE, cl = *clamp ? PETSC_TRUE : PETSC_FALSE;
  PetscBool fc = *forcing ? PETSC_TRUE : PETSC_FALSE;
  char      mt[64];

  PetscFunctionBeginUser;
  PetscCall(choices_from_fortran(jac_names, jac_n, jac_len, &jacobians));
  PetscCall(choices_from_fortran(interp_names, interp_n, interp_len, &interps));
  PetscCall(choices_from_fortran(guess_names, guess_n, guess_len, &guesses));
  PetscCall(PetscStrncpy(mt, mattype, sizeof(mt)));
  PetscOptionsBegin(comm, NULL, "nuno: the Newton step (docs/design.md, input/README.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_jacobian", "reduced: assemble only the 3-dof velocity system and eliminate around it; full: the 6-dof Jacobian",
                              "nuno", jacobians.name, jacobians.n, jacobians.name[jac], &jac, NULL));
  PetscCall(PetscOptionsInt("-nuno_pc_lag", "rebuild the inner (reduced_) preconditioner every N assemblies (0: with the default multigrid 3, or 20 with cubic interpolation; 1 otherwise; at most 3 while self-contact's pair blocks are in S)", "nuno", lag, &lag, NULL));
  PetscCall(PetscOptionsReal("-nuno_pc_rebuild_growth", "also rebuild a reused inner preconditioner at the next assembly when a solve's cycles per decade of residual reduction pass this factor times those of the first solve after its last rebuild (0: only every -nuno_pc_lag assemblies)",
                             "nuno", growth, &growth, NULL));
  PetscCall(PetscOptionsEList("-nuno_mg_interpolation", "interpolation of the inner multigrid: auto (coarse_cubic with bending, linear without), linear, cubic (every level), coarse_cubic (every level but the finest; nuno's multigrid interpolates the finest level's correction cubic too)",
                              "nuno", interps.name, interps.n, interps.name[interp], &interp, NULL));
  PetscCall(PetscOptionsReal("-nuno_snes_floor", "Newton: converged when a residual below this fraction of its start or below the round-off floor estimated from the assembled matrix (S or the 6-dof Jacobian) stops decreasing or finds no decrease in the line search, or is below half that floor (0: off)",
                             "nuno", floor, &floor, NULL));
  PetscCall(PetscOptionsBool("-nuno_newton_forcing", "reduced Newton: solve each inner system only as far as the step needs (its Newton remainder, or half the residual at which Newton stops); off: always -reduced_ksp_rtol (default on; with obstacles guarded: -reduced_ksp_rtol where a step limit cut or an obstacle moved the start or an update)",
                             "nuno", fc, &fc, NULL));
  PetscCall(PetscOptionsEList("-nuno_inner_guess", "reduced, one-stage methods (beuler, theta, cn): the inner solve's initial guess: auto (project with bending at fixed steps, extrapolate at adaptive ones, none without bending), none (zero), previous (at a step's first Newton iteration the last step's first correction, rescaled to this step), extrapolate (the last two steps' first corrections extrapolated linearly in time), project (at every Newton iteration the least-squares combination of the last 8 inner solves)",
                              "nuno", guesses.name, guesses.n, guesses.name[gs], &gs, &gset));
  PetscCall(PetscOptionsBool("-nuno_gauss_newton", "energy bending: assemble only the Gauss-Newton part -k_b J^T J", "nuno", gn, &gn, NULL));
  PetscCall(PetscOptionsBool("-nuno_clamp_compression", "drop the indefinite compression term of the springs from the assembled matrix",
                             "nuno", cl, &cl, NULL));
  /* Read here rather than by DMSetFromOptions: that would also take
   * -da_grid_x and friends, which would resize the lattice behind the namelist. */
  PetscCall(PetscOptionsString("-dm_mat_type", "storage of the assembled 6-dof Jacobian (-nuno_jacobian full): baij, aij, ...", "DMSetMatType",
                               mt, mt, sizeof(mt), NULL));
  PetscCall(PetscOptionsInt("-nuno_fail_newton", "testing: declare the first N Newton solves failed, so that their steps are retried with a smaller dt",
                            "nuno", nfail, &nfail, NULL));
  PetscOptionsEnd();
  *jacobian = (int)jac;
  *pc_lag = (int)lag;
  *pc_growth = growth;
  *mg_interp = (int)interp;
  *snes_floor = floor;
  *gauss_newton = gn ? 1 : 0;
  *clamp = cl ? 1 : 0;
  *fail_newton = (int)nfail;
  *forcing = fc ? 1 : 0;
  *guess = (int)gs;
  *guess_given = gset ? 1 : 0;
  PetscCall(PetscStrncpy(mattype, mt, (size_t)mattype_len));
  PetscFunctionReturn(0);
}

/* The Newton step's line search after a failed Newton solve (reduced path,
 * whose default is full steps; module newton_policy): fallback in/out, a
 * code of the list names (-nuno_linesearch_fallback); *given 1 when it is
 * set. Collective. */
PetscErrorCode nuno_linesearch_options_read(MPI_Fint fcomm, const char *names, int n, int len, int *fallback, int *given)
{
  Choices   fallbacks;
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  fb   = *fallback;
  PetscBool set = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(choices_from_fortran(names, n, len, &fallbacks));
  PetscOptionsBegin(comm, NULL, "nuno: the Newton step's line search (input/README.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_linesearch_fallback", "reduced path: once a Newton solve has failed (its step retried smaller), the rest of the run takes this line search instead of full steps: bt (backtracking), l2 or none",
                              "nuno", fallbacks.name, fallbacks.n, fallbacks.name[fb], &fb, &set));
  PetscOptionsEnd();
  *fallback = (int)fb;
  *given    = set ? 1 : 0;
  PetscFunctionReturn(0);
}

/* nuno's structured multigrid, the default inner preconditioner (module
 * stencil_mg; module reduced checks the values): impl, cycle, product
 * in/out codes of the lists impl_names (-nuno_mg), cycle_names
 * (-nuno_mg_cycle) and product_names (-nuno_mg_product: the Krylov
 * method's product with S); sweeps in/out symmetric Gauss-Seidel sweeps
 * per smoothing; levels in/out (0: as many as fit); coarse in/out code
 * of coarse_names (-nuno_mg_coarse: how the coarse levels are made);
 * *given: 1 when -nuno_mg_cycle, -nuno_mg_sweeps, -nuno_mg_levels,
 * -nuno_mg_product or -nuno_mg_coarse is set (they are refused where
 * nuno's multigrid is not used). Collective. */
PetscErrorCode nuno_mg_options_read(MPI_Fint fcomm, const char *impl_names, int impl_n, int impl_len, int *impl,
                                    const char *cycle_names, int cycle_n, int cycle_len, int *cycle, int *sweeps, int *levels,
                                    const char *product_names, int product_n, int product_len, int *product,
                                    const char *coarse_names, int coarse_n, int coarse_len, int *coarse, int *given)
{
  Choices   impls, cycles, products, coarses;
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  im = *impl, cy = *cycle, sw = *sweeps, lv = *levels, pr = *product, co = *coarse;
  PetscBool s1 = PETSC_FALSE, s2 = PETSC_FALSE, s3 = PETSC_FALSE, s4 = PETSC_FALSE, s5 = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(choices_from_fortran(impl_names, impl_n, impl_len, &impls));
  PetscCall(choices_from_fortran(cycle_names, cycle_n, cycle_len, &cycles));
  PetscCall(choices_from_fortran(product_names, product_n, product_len, &products));
  PetscCall(choices_from_fortran(coarse_names, coarse_n, coarse_len, &coarses));
  PetscOptionsBegin(comm, NULL, "nuno: the inner multigrid (docs/design.md, docs/performance.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_mg", "inner multigrid where 3 levels fit and -reduced_pc_type is not given: stencil (nuno's, single precision, no index arrays) or petsc (PCMG, Galerkin, SOR)",
                              "nuno", impls.name, impls.n, impls.name[im], &im, NULL));
  PetscCall(PetscOptionsEList("-nuno_mg_cycle", "cycle of nuno's multigrid: kaskade (restrict the right-hand side, then only upwards: the least time a step), v (smooth, restrict the residual, correct, smooth) or w (the same with two cycles on each coarser level: the fewest cycles, 3.9x a kaskade cycle's bytes)",
                              "nuno", cycles.name, cycles.n, cycles.name[cy], &cy, &s1));
  PetscCall(PetscOptionsInt("-nuno_mg_sweeps", "symmetric Gauss-Seidel sweeps of nuno's multigrid per smoothing", "nuno", sw, &sw, &s2));
  PetscCall(PetscOptionsInt("-nuno_mg_levels", "levels of nuno's multigrid (0: as many as fit, down to 5 nodes a side)", "nuno", lv, &lv, &s3));
  PetscCall(PetscOptionsEList("-nuno_mg_product", "the Krylov method's product with S where nuno's multigrid is used: mixed (from the multigrid's single-precision copy of S in difference form, double-precision vectors, each offset's products in single and their sum in double; half the bytes), fused (mixed, and the product of each cycle's output formed in the cycle's last sweep, from the rows it has just finished: the Krylov method's product of that output is a copy; right preconditioning only, else mixed) or double (S in double precision)",
                              "nuno", products.name, products.n, products.name[pr], &pr, &s4));
  PetscCall(PetscOptionsEList("-nuno_mg_coarse", "coarse levels of nuno's multigrid: auto (rediscretize with bending, galerkin without: the least time a step of each), rediscretize (the same cloth on the lattice coarsened by 2, assembled by the same element kernels at the injected state: the finest level's reach, a consistent bending) or galerkin (P^T A P)",
                              "nuno", coarses.name, coarses.n, coarses.name[co], &co, &s5));
  PetscOptionsEnd();
  *impl = (int)im;
  *cycle = (int)cy;
  *sweeps = (int)sw;
  *levels = (int)lv;
  *product = (int)pr;
  *coarse = (int)co;
  *given = (s1 || s2 || s3 || s4 || s5) ? 1 : 0;
  PetscFunctionReturn(0);
}

/* -nuno_mg_gather (module stencil_mg, mg_create; module mg_gather): gather
 * in/out code of names (auto: a level too thin for the strips of more than
 * 4 ranks gathered on fewer; never: it is the replicated coarsest); *given:
 * 1 when set (refused where nuno's multigrid is not used). Collective. */
PetscErrorCode nuno_mg_gather_read(MPI_Fint fcomm, const char *names, int n, int len, int *gather, int *given)
{
  Choices   gathers;
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  g = *gather;
  PetscBool set = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(choices_from_fortran(names, n, len, &gathers));
  PetscOptionsBegin(comm, NULL, "nuno: the inner multigrid's coarse levels on many ranks (docs/performance.md, \"Scaling\")", "nuno");
  PetscCall(PetscOptionsEList("-nuno_mg_gather", "nuno's multigrid on more than 4 ranks: auto (a level too thin for the ranks' strips is gathered on fewer ranks, 2 rows each at least, down to the coarsest level, replicated) or never (the first such level is the coarsest, replicated on every rank: its banded LU grows as the ranks cubed)",
                              "nuno", gathers.name, gathers.n, gathers.name[g], &g, &set));
  PetscOptionsEnd();
  *gather = (int)g;
  *given = set ? 1 : 0;
  PetscFunctionReturn(0);
}

/* The absolute error tolerances of adaptive steps, per field (input/README.md,
 * "Error tolerances"): positions in the scene's length unit, velocities in
 * length/time; together they become TS's vector atol. Read after
 * TSSetFromOptions, in their own options block, so that -help shows the
 * defaults derived from -ts_rtol/-ts_atol and the cloth (atol_x, atol_v
 * in/out; checked by the caller). *given_x, *given_v: set on the command line. Collective. */
PetscErrorCode nuno_tolerance_options_read(MPI_Fint fcomm, double *atol_x, double *atol_v, int *given_x, int *given_v)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscReal ax = *atol_x, av = *atol_v;
  PetscBool sx = PETSC_FALSE, sv = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: error tolerances of adaptive steps (input/README.md, \"Error tolerances\")", "nuno");
  PetscCall(PetscOptionsReal("-nuno_atol_position", "absolute tolerance of positions [length] (default: -ts_atol, else -ts_rtol times the cloth size max(lx, ly))",
                             "TSSetTolerances", ax, &ax, &sx));
  PetscCall(PetscOptionsReal("-nuno_atol_velocity", "absolute tolerance of velocities [length/time] (default: the position tolerance per unit of time, docs/workprecision.md)",
                             "TSSetTolerances", av, &av, &sv));
  PetscOptionsEnd();
  *atol_x = ax;
  *atol_v = av;
  *given_x = sx ? 1 : 0;
  *given_v = sv ? 1 : 0;
  PetscFunctionReturn(0);
}

/* -nuno_adaptive_ts_type: the TS type of an adaptive run whose -ts_type is
 * not given (module solver_setup's adaptive_default decides and sets it).
 * type in/out: NUL-terminated, len bytes. Collective. */
PetscErrorCode nuno_adaptive_ts_type_option(MPI_Fint fcomm, char *type, int len)
{
  MPI_Comm comm = MPI_Comm_f2c(fcomm);
  char     tt[64];

  PetscFunctionBeginUser;
  PetscCall(PetscStrncpy(tt, type, sizeof(tt)));
  PetscOptionsBegin(comm, NULL, "nuno: the integrator of adaptive runs (docs/workprecision.md)", "nuno");
  PetscCall(PetscOptionsString("-nuno_adaptive_ts_type", "TS type of an adaptive run (-ts_adapt_type not none) whose -ts_type is not given; fixed steps stay beuler",
                               "TSSetType", tt, tt, sizeof(tt), NULL));
  PetscOptionsEnd();
  PetscCall(PetscStrncpy(type, tt, (size_t)len));
  PetscFunctionReturn(0);
}

/* -nuno_newton_start (module newton_start): choice in/out, a code of the
 * list names. Collective. */
PetscErrorCode nuno_newton_start_option(MPI_Fint fcomm, const char *names, int n, int len, int *choice)
{
  Choices  starts;
  MPI_Comm comm = MPI_Comm_f2c(fcomm);
  PetscInt st   = *choice;

  PetscFunctionBeginUser;
  PetscCall(choices_from_fortran(names, n, len, &starts));
  PetscOptionsBegin(comm, NULL, "nuno: the Newton start (docs/design.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_newton_start",
                              "beuler: Newton's start, auto (consistent for Newton at fixed steps, linear in the Baraff-Witkin mode -snes_type ksponly, in adaptive, identification and control runs and with self-contact), linear (x_n + dt xdot_n: -ts_theta_initial_guess_extrapolate), cubic (the polynomial through the last four accepted states, or the linear start where its residual is the smaller), consistent (cubic with its positions x_n + dt v, as backward Euler takes them)",
                              "nuno", starts.name, starts.n, starts.name[st], &st, NULL));
  PetscOptionsEnd();
  *choice = (int)st;
  PetscFunctionReturn(0);
}

/* Warn on stderr (rank 0, one line each) about every option that nothing
 * read: a misspelt option (-ts_tpye) must not pass silently. PETSc itself
 * only reports them with -options_left, so this runs unless the user chose:
 * with -options_left (true) PETSc prints its own report at PetscFinalize,
 * with -options_left no the user asked for silence. Call it after the run,
 * before PetscFinalize. *nunused: how many were reported. Collective. */
PetscErrorCode nuno_options_report_unused(MPI_Fint fcomm, int *nunused)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscBool chosen, left = PETSC_FALSE;
  PetscInt  n, i;
  char    **names, **values;

  PetscFunctionBeginUser;
  *nunused = 0;
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-options_left", &left, &chosen));
  if (chosen) PetscFunctionReturn(0);
  PetscCall(PetscOptionsLeftGet(NULL, &n, &names, &values));
  for (i = 0; i < n; i++) {
    if (values[i]) {
      PetscCall(PetscFPrintf(comm, PETSC_STDERR, "nuno: warning: option -%s (value %s) was not used: misspelt, or not for this solver\n", names[i], values[i]));
    } else {
      PetscCall(PetscFPrintf(comm, PETSC_STDERR, "nuno: warning: option -%s was not used: misspelt, or not for this solver\n", names[i]));
    }
  }
  *nunused = (int)n;
  PetscCall(PetscOptionsLeftRestore(NULL, &n, &names, &values));
  PetscFunctionReturn(0);
}
