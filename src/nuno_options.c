// SPDX-License-Identifier: BSD-2-Clause
/* nuno's own solver options, read inside a PETSc options block so that they
 * appear in -help with their defaults and current values (PETSc 3.18 has no
 * Fortran interface to PetscOptionsBegin/End: ../shared/STYLE.md). Called
 * once from Fortran (module timestepping) through bind(C); collective.
 * Also the end-of-run report of options that nothing read. */
#include <petscts.h>
#include <string.h>

/* The integrator of adaptive runs when -ts_type is not given: the method
 * that won the work-precision measurement at moderate tolerance
 * (docs/workprecision.md, "The default of adaptive runs"). PETSc's rosw
 * is Rosenbrock-W ra34pw2 unless -ts_rosw_type says otherwise. */
#define NUNO_ADAPTIVE_TS_TYPE TSROSW

/* jacobian: in/out 0 = reduced, 1 = full; pc_lag: in/out >= 0 (0: default);
 * mg_interp: in/out 0 = auto, 1 = linear, 2 = cubic, 3 = coarse_cubic (module reduced's INTERP_*);
 * snes_floor: in/out >= 0; gauss_newton, clamp: in/out 0/1;
 * mattype: in/out NUL-terminated, mattype_len bytes; fail_newton: in/out >= 0;
 * forcing: in/out 0/1; guess: in/out 0 = auto, 1 = none, 2 = previous, 3 = extrapolate, 4 = project
 * (module inner_guess's GUESS_*), *guess_given 1 when set. Returns a PETSc error code (0 on success). */
PetscErrorCode nuno_options_read(MPI_Fint fcomm, int *jacobian, int *pc_lag, int *mg_interp, double *snes_floor,
                                 int *gauss_newton, int *clamp, char *mattype, int mattype_len, int *fail_newton, int *forcing,
                                 int *guess, int *guess_given)
{
  static const char *const jacobians[] = {"reduced", "full"};
  static const char *const interps[]   = {"auto", "linear", "cubic", "coarse_cubic"};
  static const char *const guesses[]   = {"auto", "none", "previous", "extrapolate", "project"};
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  jac = *jacobian, lag = *pc_lag, nfail = *fail_newton, interp = *mg_interp, gs = *guess;
  PetscBool gset = PETSC_FALSE;
  PetscReal floor = *snes_floor;
  PetscBool gn = *gauss_newton ? PETSC_TRUE : PETSC_FALSE, cl = *clamp ? PETSC_TRUE : PETSC_FALSE;
  PetscBool fc = *forcing ? PETSC_TRUE : PETSC_FALSE;
  char      mt[64];

  PetscFunctionBeginUser;
  PetscCall(PetscStrncpy(mt, mattype, sizeof(mt)));
  PetscOptionsBegin(comm, NULL, "nuno: the Newton step (docs/design.md, input/README.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_jacobian", "reduced: assemble only the 3-dof velocity system and eliminate around it; full: the 6-dof Jacobian",
                              "nuno", jacobians, 2, jacobians[jac], &jac, NULL));
  PetscCall(PetscOptionsInt("-nuno_pc_lag", "rebuild the inner (reduced_) preconditioner every N assemblies (0: with the default multigrid 3, or 20 with cubic interpolation; 1 otherwise)", "nuno", lag, &lag, NULL));
  PetscCall(PetscOptionsEList("-nuno_mg_interpolation", "interpolation of the inner multigrid: auto (coarse_cubic with bending, linear without), linear, cubic (every level), coarse_cubic (every level but the finest; nuno's multigrid interpolates the finest level's correction cubic too)",
                              "nuno", interps, 4, interps[interp], &interp, NULL));
  PetscCall(PetscOptionsReal("-nuno_snes_floor", "Newton: converged when a residual below this fraction of its start or below the round-off floor estimated from the assembled matrix (S or the 6-dof Jacobian) stops decreasing or finds no decrease in the line search, or is below half that floor (0: off)",
                             "nuno", floor, &floor, NULL));
  PetscCall(PetscOptionsBool("-nuno_newton_forcing", "reduced Newton: solve each inner system only as far as the step needs (its Newton remainder, or half the residual at which Newton stops); off: always -reduced_ksp_rtol",
                             "nuno", fc, &fc, NULL));
  PetscCall(PetscOptionsEList("-nuno_inner_guess", "reduced, one-stage methods (beuler, theta, cn): the inner solve's initial guess: auto (project with bending at fixed steps, extrapolate at adaptive ones, none without bending), none (zero), previous (at a step's first Newton iteration the last step's first correction, rescaled to this step), extrapolate (the last two steps' first corrections extrapolated linearly in time), project (at every Newton iteration the least-squares combination of the last 8 inner solves)",
                              "nuno", guesses, 5, guesses[gs], &gs, &gset));
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
  PetscCheck(lag >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_pc_lag %" PetscInt_FMT " must be >= 1 (or 0: the default)", lag);
  PetscCheck(floor >= 0.0 && floor < 1.0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_snes_floor %g must be in [0, 1)", (double)floor);
  PetscCheck(nfail >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_fail_newton %" PetscInt_FMT " must be >= 0", nfail);
  *jacobian = (int)jac;
  *pc_lag = (int)lag;
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
 * whose default is full steps; module timestepping): fallback in/out 0 =
 * none, 1 = bt, 2 = l2 (-nuno_linesearch_fallback); *given 1 when it is
 * set, *ls_given 1 when -snes_linesearch_type is (the user's line search
 * then holds for the whole run). Collective. */
PetscErrorCode nuno_linesearch_options_read(MPI_Fint fcomm, int *fallback, int *given, int *ls_given)
{
  static const char *const fallbacks[] = {"none", "bt", "l2"};
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  fb   = *fallback;
  PetscBool set = PETSC_FALSE, lset = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: the Newton step's line search (input/README.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_linesearch_fallback", "reduced path: once a Newton solve has failed (its step retried smaller), the rest of the run takes this line search instead of full steps: bt (backtracking), l2 or none",
                              "nuno", fallbacks, 3, fallbacks[fb], &fb, &set));
  PetscOptionsEnd();
  PetscCall(PetscOptionsHasName(NULL, NULL, "-snes_linesearch_type", &lset));
  *fallback = (int)fb;
  *given    = set ? 1 : 0;
  *ls_given = lset ? 1 : 0;
  PetscFunctionReturn(0);
}

/* nuno's structured multigrid, the default inner preconditioner (module
 * stencil_mg): impl in/out 0 = stencil (nuno's), 1 = petsc (PETSc's PCMG
 * with Galerkin operators and SOR, the earlier default); cycle in/out 1 =
 * v (multiplicative), 2 = kaskade; sweeps in/out >= 1 symmetric
 * Gauss-Seidel sweeps per smoothing; levels in/out >= 0 (0: as many as
 * fit); *given: 1 when -nuno_mg_cycle, -nuno_mg_sweeps or -nuno_mg_levels
 * is set (they are refused where nuno's multigrid is not used); product
 * in/out 0 = mixed, 1 = double, 2 = fused: the Krylov method's product with S
 * (module reduced), *given too when -nuno_mg_product is set. Collective. */
PetscErrorCode nuno_mg_options_read(MPI_Fint fcomm, int *impl, int *cycle, int *sweeps, int *levels, int *product, int *given)
{
  static const char *const impls[]    = {"stencil", "petsc"};
  static const char *const cycles[]   = {"none", "v", "kaskade"};
  static const char *const products[] = {"mixed", "double", "fused"};
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  PetscInt  im = *impl, cy = *cycle, sw = *sweeps, lv = *levels, pr = *product;
  PetscBool s1 = PETSC_FALSE, s2 = PETSC_FALSE, s3 = PETSC_FALSE, s4 = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "nuno: the inner multigrid (docs/design.md, docs/performance.md)", "nuno");
  PetscCall(PetscOptionsEList("-nuno_mg", "inner multigrid where 3 levels fit and -reduced_pc_type is not given: stencil (nuno's, single precision, no index arrays) or petsc (PCMG, Galerkin, SOR)",
                              "nuno", impls, 2, impls[im], &im, NULL));
  PetscCall(PetscOptionsEList("-nuno_mg_cycle", "cycle of nuno's multigrid: v (smooth, restrict the residual, correct, smooth) or kaskade (restrict the right-hand side, then only upwards)",
                              "nuno", cycles + 1, 2, cycles[cy], &cy, &s1));
  if (s1) cy += 1;
  PetscCall(PetscOptionsInt("-nuno_mg_sweeps", "symmetric Gauss-Seidel sweeps of nuno's multigrid per smoothing", "nuno", sw, &sw, &s2));
  PetscCall(PetscOptionsInt("-nuno_mg_levels", "levels of nuno's multigrid (0: as many as fit, down to 5 nodes a side)", "nuno", lv, &lv, &s3));
  PetscCall(PetscOptionsEList("-nuno_mg_product", "the Krylov method's product with S where nuno's multigrid is used: mixed (from the multigrid's single-precision copy of S in difference form, double-precision vectors, each offset's products in single and their sum in double; half the bytes), fused (mixed, and the product of each cycle's output formed in the cycle's last sweep, from the rows it has just finished: the Krylov method's product of that output is a copy; right preconditioning only, else mixed) or double (S in double precision)",
                              "nuno", products, 3, products[pr], &pr, &s4));
  PetscOptionsEnd();
  PetscCheck(sw >= 1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_mg_sweeps %" PetscInt_FMT " must be >= 1", sw);
  PetscCheck(lv >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_mg_levels %" PetscInt_FMT " must be >= 1 (or 0: as many as fit)", lv);
  *impl = (int)im;
  *cycle = (int)cy;
  *sweeps = (int)sw;
  *levels = (int)lv;
  *product = (int)pr;
  *given = (s1 || s2 || s3 || s4) ? 1 : 0;
  PetscFunctionReturn(0);
}

/* The absolute error tolerances of adaptive steps, per field (input/README.md,
 * "Error tolerances"): positions in the scene's length unit, velocities in
 * length/time; together they become TS's vector atol. Read after
 * TSSetFromOptions, in their own options block, so that -help shows the
 * defaults derived from -ts_rtol/-ts_atol and the cloth (atol_x, atol_v
 * in/out, > 0). *given_x, *given_v: set on the command line. Collective. */
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
  PetscCheck(ax > 0.0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_atol_position %g must be > 0", (double)ax);
  PetscCheck(av > 0.0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-nuno_atol_velocity %g must be > 0", (double)av);
  *atol_x = ax;
  *atol_v = av;
  *given_x = sx ? 1 : 0;
  *given_v = sv ? 1 : 0;
  PetscFunctionReturn(0);
}

/* The integrator of an adaptive run whose -ts_type is not given: nuno's
 * default is backward Euler with the namelist's fixed step (the report's
 * scheme); with -ts_adapt_type other than none and no -ts_type it is
 * -nuno_adaptive_ts_type (default NUNO_ADAPTIVE_TS_TYPE), so that a user
 * who only asks for adaptive steps gets the fastest method at moderate
 * tolerance. An explicit -ts_type always wins. Call after TSSetType(ts,
 * beuler) and before TSSetFromOptions (which still applies -ts_rosw_type
 * and the like). *applied: 1 when it set the type. Collective. */
PetscErrorCode nuno_adaptive_default(MPI_Fint fcomm, TS *ts, int *applied)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  char      type[64] = NUNO_ADAPTIVE_TS_TYPE, adapt[64] = TSADAPTNONE;
  PetscBool has_adapt, has_type;

  PetscFunctionBeginUser;
  *applied = 0;
  PetscOptionsBegin(comm, NULL, "nuno: the integrator of adaptive runs (docs/workprecision.md)", "nuno");
  PetscCall(PetscOptionsString("-nuno_adaptive_ts_type", "TS type of an adaptive run (-ts_adapt_type not none) whose -ts_type is not given; fixed steps stay beuler",
                               "TSSetType", type, type, sizeof(type), NULL));
  PetscOptionsEnd();
  PetscCall(PetscOptionsGetString(NULL, NULL, "-ts_adapt_type", adapt, sizeof(adapt), &has_adapt));
  PetscCall(PetscOptionsHasName(NULL, NULL, "-ts_type", &has_type));
  if (has_adapt && strcmp(adapt, TSADAPTNONE) != 0 && !has_type) {
    PetscCall(TSSetType(*ts, type));
    *applied = 1;
  }
  PetscFunctionReturn(0);
}

/* Defaults of the time step's Newton solve that the options may override
 * (set in the options database before TSSetFromOptions, after the type is
 * set; measured with the structured multigrid's introduction, commit
 * cdb1ad4). Collective.
 * - Backward Euler starts each Newton solve from the state extrapolated
 *   along the last step (x + dt xdot, PETSc's
 *   -ts_theta_initial_guess_extrapolate) rather than from the last state:
 *   its residual is 20-50 times smaller on hang 257 x 257, and Newton's
 *   remainder after one iteration, quadratic in it, some 400-2500 times.
 *   Only for beuler: theta < 1 (cn) keeps its stiff modes oscillating from
 *   step to step, and extrapolating them doubles their error. The first
 *   step of a window (TSRestartStep) is not extrapolated. Only on the
 *   reduced path: the 6-dof path's GMRES + ILU(0) failed earlier from the
 *   extrapolated start on hang 65 x 65 (t = 2 ms against 15 ms).
 * - On the reduced path (reduced != 0) S is assembled at every other
 *   Newton iteration (-snes_lag_jacobian 2): the second iteration of a
 *   step, which starts from a residual some 1e-4 of the first, converges
 *   to the round-off floor with the first one's S (a chord step), and an
 *   assembly is most of an iteration's cost outside the inner solve. A
 *   third iteration, if one is needed, assembles S again. */
PetscErrorCode nuno_step_defaults(TS *ts, int reduced)
{
  char      type[64] = "";
  PetscBool has_type, given, beuler;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsHasName(NULL, NULL, "-ts_theta_initial_guess_extrapolate", &given));
  if (reduced && !given) {
    PetscCall(PetscOptionsGetString(NULL, NULL, "-ts_type", type, sizeof(type), &has_type));
    if (has_type) {
      PetscCall(PetscStrcmp(type, TSBEULER, &beuler));
    } else {
      PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSBEULER, &beuler));
    }
    if (beuler) PetscCall(PetscOptionsSetValue(NULL, "-ts_theta_initial_guess_extrapolate", "true"));
  }
  PetscCall(PetscOptionsHasName(NULL, NULL, "-snes_lag_jacobian", &given));
  if (reduced && !given) PetscCall(PetscOptionsSetValue(NULL, "-snes_lag_jacobian", "2"));
  PetscFunctionReturn(0);
}

/* The TS type with its scheme, for the start-up line: "rosw ra34pw2",
 * "arkimex 5", "bdf order 4", "theta 0.5", else the type alone. NUL-terminated
 * in buf (len bytes). Collective. */
PetscErrorCode nuno_ts_scheme(TS *ts, char *buf, int len)
{
  TSType    type;
  PetscBool is;

  PetscFunctionBeginUser;
  PetscCall(TSGetType(*ts, &type));
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSROSW, &is));
  if (is) {
    TSRosWType sub;
    PetscCall(TSRosWGetType(*ts, &sub));
    PetscCall(PetscSNPrintf(buf, (size_t)len, "%s %s", type, sub));
    PetscFunctionReturn(0);
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSARKIMEX, &is));
  if (is) {
    TSARKIMEXType sub;
    PetscBool     implicit;
    PetscCall(TSARKIMEXGetType(*ts, &sub));
    PetscCall(TSARKIMEXGetFullyImplicit(*ts, &implicit));
    PetscCall(PetscSNPrintf(buf, (size_t)len, "%s %s%s", type, sub, implicit ? " fully implicit" : ""));
    PetscFunctionReturn(0);
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSBDF, &is));
  if (is) {
    PetscInt order;
    PetscCall(TSBDFGetOrder(*ts, &order));
    PetscCall(PetscSNPrintf(buf, (size_t)len, "%s order %" PetscInt_FMT, type, order));
    PetscFunctionReturn(0);
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)*ts, TSTHETA, &is));
  if (is) {
    PetscReal theta;
    PetscCall(TSThetaGetTheta(*ts, &theta));
    PetscCall(PetscSNPrintf(buf, (size_t)len, "%s %g", type, (double)theta));
    PetscFunctionReturn(0);
  }
  PetscCall(PetscStrncpy(buf, type, (size_t)len));
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
