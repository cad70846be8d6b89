# SPDX-License-Identifier: BSD-2-Clause
# Sourced by the tools/ scripts and by users (README.md, "Running a scene"):
# build/ on PATH, and an environment that lets Open MPI run as root
# and with more ranks than cores (CI machines have 2 cores), and not slowly.
export OMPI_ALLOW_RUN_AS_ROOT=1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
# Ranks that wait for a message yield the core instead of spinning: with more
# ranks than cores (oversubscribed), two ranks on one core ran 30x slower
# without it, which reads as a hang (issue 8).
export OMPI_MCA_mpi_yield_when_idle=1
export PYTHONDONTWRITEBYTECODE=1
export MPLBACKEND=Agg
NUNO_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export NUNO_ROOT
# The checkout's build/ first on PATH: `nuno` is build/nuno, as every command
# line in the docs and the namelist headers writes it (an installed nuno is
# shadowed while this is sourced). Once only, however often it is sourced.
case ":$PATH:" in
  *":$NUNO_ROOT/build:"*) ;;
  *) export PATH="$NUNO_ROOT/build:$PATH" ;;
esac
