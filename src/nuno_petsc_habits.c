// SPDX-License-Identifier: BSD-2-Clause
/* PETSc's linear-solver options as users type them (input/README.md,
 * "Linear solvers: PETSc options as you know them"). Called once from
 * module timestepping's solver_create, after nuno_options_read (which
 * knows the path) and before anything reads -ksp_* or -pc_*; in C because
 * the options block that puts this in -help and the listing of the options
 * database have no Fortran interface in PETSc 3.18 (../shared/STYLE.md).
 *
 * The default (reduced) path's outer linear solve is nuno's elimination
 * around the 3-dof system S (a shell preconditioner under KSP preonly): a
 * PETSc -pc_type there replaced the elimination and failed ("Could not
 * locate a solver type for factorization type LU and matrix type shell").
 * The linear solve a user means is the inner one, so on that path every
 * option of the prefix-less solver, -ksp_*, -pc_*, and those of its
 * sub-solvers -sub_*, -mg_levels_*, -mg_coarse_*, is read as the same
 * option of the inner solve, -reduced_ksp_*, -reduced_pc_*, ... (-pc_type
 * lu: an exact inner solve). Refused there, one line each with what to
 * use: -pc_type fieldsplit and shell, -dm_mat_type, and an option given
 * both ways with different values. On the 6-dof path (-nuno_jacobian full)
 * PETSc's options act as usual; -dm_mat_type is checked against PETSc's
 * matrix types and -pc_type fieldsplit, which cannot split baij's 6 x 6
 * blocks, gets aij storage unless -dm_mat_type says otherwise. */
#include <petscts.h>
#include <string.h>
#include <strings.h>

/* The prefix-less solver's options and those of its sub-solvers. */
static const char *const outer_prefixes[] = {"ksp_", "pc_", "sub_", "mg_levels_", "mg_coarse_"};
#define NPREFIX (sizeof(outer_prefixes) / sizeof(outer_prefixes[0]))
/* Option names are short; values (a file name for a viewer) a bit longer. */
#define NAME_LEN  256
#define VALUE_LEN PETSC_MAX_PATH_LEN

static PetscBool is_outer_option(const char *name)
{
  for (size_t k = 0; k < NPREFIX; k++)
    if (strncasecmp(name, outer_prefixes[k], strlen(outer_prefixes[k])) == 0) return PETSC_TRUE;
  return PETSC_FALSE;
}

/* reduced: 1 on the default path; mattype in/out (NUL-terminated,
 * mattype_len bytes): the 6-dof Jacobian's storage from -dm_mat_type or
 * its default. Returns a PETSc error code; a refusal is an error whose
 * message is the one line. Collective (the options are the same on every
 * rank, so is every decision). */
PetscErrorCode nuno_petsc_habits(MPI_Fint fcomm, int reduced, char *mattype, int mattype_len)
{
  MPI_Comm    comm = MPI_Comm_f2c(fcomm);
  char        pctype[64] = "", ksptype[64] = "", mt[64] = "";
  PetscBool   pcset = PETSC_FALSE, mtset = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL,
                    "nuno: PETSc's linear-solver options; on the default (reduced) path -ksp_*, -pc_*, -sub_*, -mg_levels_*, "
                    "-mg_coarse_* act on the inner 3-dof solve, as -reduced_ksp_*, -reduced_pc_*, ... (input/README.md)",
                    "nuno");
  PetscCall(PetscOptionsString("-pc_type",
                               "default path: the inner 3-dof solve's preconditioner, as -reduced_pc_type (lu, cholesky: an exact inner solve; "
                               "gamg, hypre, ilu, jacobi, sor, bjacobi, asm, none); fieldsplit and shell refused; "
                               "-nuno_jacobian full: the 6-dof solve's, as in PETSc",
                               "PCSetType", pctype, pctype, sizeof(pctype), &pcset));
  PetscCall(PetscOptionsString("-ksp_type",
                               "default path: the inner 3-dof solve's Krylov method, as -reduced_ksp_type (preonly with -pc_type lu: a direct solve); "
                               "-nuno_jacobian full: the 6-dof solve's, as in PETSc",
                               "KSPSetType", ksptype, ksptype, sizeof(ksptype), NULL));
  PetscOptionsEnd();
  PetscCall(PetscOptionsGetString(NULL, NULL, "-dm_mat_type", mt, sizeof(mt), &mtset));

  if (!reduced) {
    PetscErrorCode (*create)(Mat) = NULL;
    if (mtset) {
      /* a type (seqaij) or a root name standing for seq and mpi ones (aij) */
      char seq[80], mpi[80];
      PetscCall(PetscSNPrintf(seq, sizeof(seq), "seq%s", mt));
      PetscCall(PetscSNPrintf(mpi, sizeof(mpi), "mpi%s", mt));
      PetscCall(MatInitializePackage());
      PetscCall(PetscFunctionListFind(MatList, mt, &create));
      if (!create) PetscCall(PetscFunctionListFind(MatList, seq, &create));
      if (!create) PetscCall(PetscFunctionListFind(MatList, mpi, &create));
      PetscCheck(create, comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "-dm_mat_type %s is not a PETSc matrix type (baij: the default, 6 x 6 blocks; aij: for -pc_type fieldsplit)", mt);
    }
    if (pcset && strcasecmp(pctype, PCFIELDSPLIT) == 0) {
      if (!mtset) {
        PetscCall(PetscStrncpy(mattype, MATAIJ, (size_t)mattype_len));
      } else {
        PetscCheck(strcasecmp(mt, MATBAIJ) != 0 && strcasecmp(mt, MATSBAIJ) != 0, comm, PETSC_ERR_ARG_INCOMP,
                   "-pc_type fieldsplit with -dm_mat_type %s: PETSc's field split cannot split the 6 x 6 blocks of %s; leave -dm_mat_type out (aij then) or give aij", mt, mt);
      }
    }
    PetscFunctionReturn(0);
  }

  PetscCheck(!mtset, comm, PETSC_ERR_ARG_INCOMP,
             "-dm_mat_type %s is the storage of the 6-dof Jacobian, which the default (reduced) path does not assemble: "
             "-reduced_dm_mat_type sets that of S (with -reduced_pc_type), -nuno_jacobian full -dm_mat_type %s the 6-dof path", mt, mt);
  PetscCheck(!(pcset && strcasecmp(pctype, PCFIELDSPLIT) == 0), comm, PETSC_ERR_ARG_INCOMP,
             "-pc_type fieldsplit: the default (reduced) path already eliminates the positions and solves their Schur complement S; "
             "for PETSc's field split of the 6-dof Jacobian give -nuno_jacobian full -pc_type fieldsplit (input/README.md), "
             "for the inner solve of S -reduced_pc_type");
  PetscCheck(!(pcset && strcasecmp(pctype, PCSHELL) == 0), comm, PETSC_ERR_ARG_INCOMP,
             "-pc_type shell: nuno has no user preconditioner to call; the default path's own is its elimination (-reduced_pc_type for the inner solve)");

  /* Every option of the prefix-less solver becomes the inner solve's. */
  {
    char    *all, *copy, *tok, *save = NULL;
    char     moved[1024] = "", into[1024] = "";
    size_t   ncopy;
    PetscInt nmoved = 0;

    PetscCall(PetscOptionsGetAll(NULL, &all));
    PetscCall(PetscStrlen(all, &ncopy));
    PetscCall(PetscMalloc1(ncopy + 1, &copy));
    PetscCall(PetscStrncpy(copy, all, ncopy + 1));
    PetscCall(PetscFree(all));
    for (tok = strtok_r(copy, " ", &save); tok; tok = strtok_r(NULL, " ", &save)) {
      char      name[NAME_LEN], inner[NAME_LEN], value[VALUE_LEN] = "", ivalue[VALUE_LEN] = "";
      PetscBool set, iset;

      /* an option's name (a value may begin with '-' too, e.g. -1: only
       * names of the solver's options are taken, and each is looked up) */
      if (tok[0] != '-' || !is_outer_option(tok + 1)) continue;
      PetscCall(PetscSNPrintf(name, sizeof(name), "%s", tok));
      PetscCall(PetscOptionsGetString(NULL, NULL, name, value, sizeof(value), &set));
      if (!set) continue; /* moved already (the name twice in the list) */
      PetscCall(PetscSNPrintf(inner, sizeof(inner), "-reduced_%s", name + 1));
      PetscCall(PetscOptionsGetString(NULL, NULL, inner, ivalue, sizeof(ivalue), &iset));
      PetscCheck(!iset || strcmp(value, ivalue) == 0, comm, PETSC_ERR_ARG_INCOMP,
                 "%s %s and %s %s: on the default (reduced) path both set the inner 3-dof solve; give one", name, value, inner, ivalue);
      PetscCall(PetscOptionsSetValue(NULL, inner, value[0] ? value : NULL));
      PetscCall(PetscOptionsClearValue(NULL, name));
      nmoved++;
      if (strlen(moved) + strlen(name) + strlen(value) + 3 < sizeof(moved) && strlen(into) + strlen(inner) + strlen(value) + 3 < sizeof(into)) {
        PetscCall(PetscStrlcat(moved, " ", sizeof(moved)));
        PetscCall(PetscStrlcat(moved, name, sizeof(moved)));
        PetscCall(PetscStrlcat(into, " ", sizeof(into)));
        PetscCall(PetscStrlcat(into, inner, sizeof(into)));
        if (value[0]) {
          PetscCall(PetscStrlcat(moved, " ", sizeof(moved)));
          PetscCall(PetscStrlcat(moved, value, sizeof(moved)));
          PetscCall(PetscStrlcat(into, " ", sizeof(into)));
          PetscCall(PetscStrlcat(into, value, sizeof(into)));
        }
      }
    }
    PetscCall(PetscFree(copy));
    if (nmoved > 0)
      PetscCall(PetscPrintf(comm, "nuno: on the default (reduced) path%s %s read as%s, the inner 3-dof solve's (PETSc's solver of the 6-dof Jacobian: -nuno_jacobian full)\n",
                            moved, nmoved > 1 ? "are" : "is", into));
  }
  PetscFunctionReturn(0);
}
