// SPDX-License-Identifier: BSD-2-Clause
/* The names of the options this run knows, for the check of the options
 * before the first step (module option_check). PETSc 3.18 names the options
 * it reads only in -help's text, which each options block prints as it
 * reads its options; so during the run's set-up (from PetscInitialize to
 * the solver's creation) that text is collected here instead of printed:
 * -help is put in the options database, and the two printers of its text
 * point to collectors: PetscHelpPrintf (the blocks' option lines, on every
 * rank) and PetscVFPrintf (PetscFunctionListPrintTypes writes the lines of
 * type lists, -ts_type and the like, to stdout on rank 0 through it; any
 * other text passes on unchanged). In 3.18 -help changes nothing else
 * (src/sys/objects/aoptions.c, src/sys/classes/viewer/interface/viewreg.c:
 * only what is printed). A line "  -NAME <..." gives NAME; the format of
 * PetscOptionsInt's line marks an integer option, for the range check.
 * Also the options that nothing read (PetscOptionsLeftGet, which Fortran
 * lacks), and SIGPIPE left to its default for -help (PETSc's handler turned
 * `nuno IN.nml -help | head` into an error report and an abort).
 * Called through bind(C) from module option_check. */
#include <petscsys.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define NAMES_MAX 4096
#define NAME_LEN  128

static char       names[NAMES_MAX][NAME_LEN];
static int        is_int[NAMES_MAX];
static int        n_names = 0;
static int        collecting = 0, help_set = 0, in_list = 0;
static PetscErrorCode (*saved_help)(MPI_Comm, const char[], ...)     = NULL;
static PetscErrorCode (*saved_vf)(FILE *, const char[], va_list) = NULL;

/* The option name at the start of a help line (after blanks): "-" and the
 * characters up to a blank, '<', ':' or the end; added once. */
static void take_name(const char *line, int integer)
{
  const char *p = line;
  size_t      n;

  while (*p == ' ') p++;
  if (p[0] != '-' || !p[1] || p[1] == '-' || p[1] == ' ') return;
  n = strcspn(p, " <:\n\t");
  if (n < 2 || n >= NAME_LEN) return;
  for (int k = 0; k < n_names; k++) {
    if (strlen(names[k]) == n && !strncmp(names[k], p, n)) {
      if (integer) is_int[k] = 1;
      return;
    }
  }
  if (n_names >= NAMES_MAX) return;
  memcpy(names[n_names], p, n);
  names[n_names][n] = '\0';
  is_int[n_names]   = integer;
  n_names++;
}

static PetscErrorCode collect_help(MPI_Comm comm, const char format[], ...)
{
  char    line[1024];
  va_list ap;

  (void)comm;
  va_start(ap, format);
  vsnprintf(line, sizeof(line), format, ap);
  va_end(ap);
  /* PetscOptionsInt's line; its first bytes ("  -%s%s <now %") are
   * those of other options' lines */
  take_name(line, strstr(format, "<now %" PetscInt_FMT " : formerly %" PetscInt_FMT ">") != NULL);
  return 0;
}

static PetscErrorCode collect_vf(FILE *fd, const char format[], va_list ap)
{
  char    text[1024];
  va_list copy;
  size_t  n;

  if (fd != PETSC_STDOUT) return saved_vf(fd, format, ap);
  va_copy(copy, ap);
  vsnprintf(text, sizeof(text), format, copy);
  va_end(copy);
  if (!in_list && strncmp(text, "  -", 3)) return saved_vf(fd, format, ap);
  /* a type list's line, written in pieces up to its line end */
  if (!in_list) take_name(text, 0);
  n       = strlen(text);
  in_list = !(n > 0 && text[n - 1] == '\n');
  return 0;
}

/* Before PetscInitialize, when the command line has -help: no PETSc
 * signal handlers (-no_signal_handler, which PETSc reads at its start and
 * may be set before it, src/sys/tutorials/ex16.c), so that a closed pipe
 * (`nuno IN.nml -help | head`, its first lines already read) ends the
 * process by SIGPIPE, quietly, wherever it is, PetscInitialize's own help
 * text included. Returns a PETSc error code. */
PetscErrorCode nuno_help_before_petsc(void)
{
  signal(SIGPIPE, SIG_DFL);
  return PetscOptionsSetValue(NULL, "-no_signal_handler", NULL);
}

/* Start collecting (after PetscInitialize, before any options are read).
 * *help: 1 when the user gave -help (then PETSc prints as usual and nothing
 * is collected). */
PetscErrorCode nuno_option_names_begin(int *help)
{
  PetscBool given;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsHasHelp(NULL, &given));
  *help = given ? 1 : 0;
  if (given) PetscFunctionReturn(0);
  saved_help      = PetscHelpPrintf;
  saved_vf        = PetscVFPrintf;
  PetscHelpPrintf = collect_help;
  PetscVFPrintf   = collect_vf;
  collecting      = 1;
  PetscCall(PetscOptionsSetValue(NULL, "-help", NULL));
  help_set = 1;
  PetscFunctionReturn(0);
}

/* Stop collecting (the set-up is done): the printers and the database as
 * they were. */
PetscErrorCode nuno_option_names_end(void)
{
  PetscFunctionBeginUser;
  if (collecting) {
    PetscHelpPrintf = saved_help;
    PetscVFPrintf   = saved_vf;
    collecting      = 0;
  }
  if (help_set) {
    PetscCall(PetscOptionsClearValue(NULL, "-help"));
    help_set = 0;
  }
  PetscFunctionReturn(0);
}

/* How many names were collected. */
int nuno_option_names_count(void)
{
  return n_names;
}

/* Name i (0-based), NUL-terminated in len bytes; *integer 1 for an
 * integer option. */
void nuno_option_name(int i, char *buf, int len, int *integer)
{
  buf[0]   = '\0';
  *integer = 0;
  if (i < 0 || i >= n_names) return;
  snprintf(buf, (size_t)len, "%s", names[i]);
  *integer = is_int[i];
}

/* The options of the database that nothing read: *n of them; entry i
 * (0-based) as "-name" in name and its value in value (NUL-terminated;
 * *has_value 0 for an option without one). Collective only in that every
 * rank holds the same database. */
PetscErrorCode nuno_option_left(int i, char *name, int nlen, char *value, int vlen, int *has_value, int *n)
{
  PetscInt n_left;
  char   **names_left, **values_left;

  PetscFunctionBeginUser;
  name[0]    = '\0';
  value[0]   = '\0';
  *has_value = 0;
  PetscCall(PetscOptionsLeftGet(NULL, &n_left, &names_left, &values_left));
  *n = (int)n_left;
  if (i >= 0 && i < n_left) {
    snprintf(name, (size_t)nlen, "-%s", names_left[i]);
    if (values_left[i]) {
      snprintf(value, (size_t)vlen, "%s", values_left[i]);
      *has_value = 1;
    }
  }
  PetscCall(PetscOptionsLeftRestore(NULL, &n_left, &names_left, &values_left));
  PetscFunctionReturn(0);
}
