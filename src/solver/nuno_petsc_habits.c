// SPDX-License-Identifier: BSD-2-Clause
/* PETSc's linear-solver options as users type them (input/README.md,
 * "Linear solvers: PETSc options as you know them"): the C calls of module
 * solver_options' petsc_habits, which holds the policy (called once from
 * solver_create, after nuno_options_read, which knows the path, and before
 * anything reads -ksp_* or -pc_*). In C because PETSc 3.18 has no Fortran
 * interface to the options block that puts -pc_type and -ksp_type in -help,
 * to the listing of the options database (PetscOptionsGetAll), nor to the
 * list of matrix types (MatList) (../shared/STYLE.md).
 * What is moved, refused or defaulted, and why: petsc_habits. */
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

/* The options block: -pc_type into pctype (NUL-terminated, len bytes),
 * *pcset 1 when given; -ksp_type only for -help (its value is read where
 * it acts). Collective. */
PetscErrorCode nuno_petsc_habits_options(MPI_Fint fcomm, char *pctype, int len, int *pcset)
{
  MPI_Comm  comm = MPI_Comm_f2c(fcomm);
  char      pc[64] = "", ksptype[64] = "";
  PetscBool set = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL,
                    "nuno: PETSc's linear-solver options; on the default (reduced) path -ksp_*, -pc_*, -sub_*, -mg_levels_*, "
                    "-mg_coarse_* act on the inner 3-dof solve, as -reduced_ksp_*, -reduced_pc_*, ... (input/README.md)",
                    "nuno");
  PetscCall(PetscOptionsString("-pc_type",
                               "default path: the inner 3-dof solve's preconditioner, as -reduced_pc_type (lu, cholesky: an exact inner solve; "
                               "gamg, hypre, ilu, jacobi, sor, bjacobi, asm, none); fieldsplit and shell refused; "
                               "-nuno_jacobian full: the 6-dof solve's, as in PETSc",
                               "PCSetType", pc, pc, sizeof(pc), &set));
  PetscCall(PetscOptionsString("-ksp_type",
                               "default path: the inner 3-dof solve's Krylov method, as -reduced_ksp_type (preonly with -pc_type lu: a direct solve); "
                               "-nuno_jacobian full: the 6-dof solve's, as in PETSc",
                               "KSPSetType", ksptype, ksptype, sizeof(ksptype), NULL));
  PetscOptionsEnd();
  PetscCall(PetscStrncpy(pctype, pc, (size_t)len));
  *pcset = set ? 1 : 0;
  PetscFunctionReturn(0);
}

/* *exists 1 when mt (NUL-terminated) names a PETSc matrix type, or a root
 * name standing for seq and mpi ones (aij). */
PetscErrorCode nuno_mat_type_exists(const char *mt, int *exists)
{
  PetscErrorCode (*create)(Mat) = NULL;
  char seq[80], mpi[80];

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(seq, sizeof(seq), "seq%s", mt));
  PetscCall(PetscSNPrintf(mpi, sizeof(mpi), "mpi%s", mt));
  PetscCall(MatInitializePackage());
  PetscCall(PetscFunctionListFind(MatList, mt, &create));
  if (!create) PetscCall(PetscFunctionListFind(MatList, seq, &create));
  if (!create) PetscCall(PetscFunctionListFind(MatList, mpi, &create));
  *exists = create ? 1 : 0;
  PetscFunctionReturn(0);
}

/* The default (reduced) path: every option of the prefix-less solver
 * becomes the inner solve's, -reduced_...; an option given both ways with
 * different values is refused. Says what it moved (rank 0). Collective
 * (the options are the same on every rank, so is every decision). */
PetscErrorCode nuno_petsc_habits_move(MPI_Fint fcomm)
{
  MPI_Comm comm = MPI_Comm_f2c(fcomm);

  PetscFunctionBeginUser;
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
