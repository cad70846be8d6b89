#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# The whole test suite: install (idempotent), build, then every CTest test
# (Fortran unit tests, MPI tests on 1 and 3 ranks, pytest suites that run
# the program on 1-4 ranks).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bash "$here/install.sh"
bash "$here/build.sh"
source "$here/env.sh"
cd "$NUNO_ROOT"
ctest --test-dir build --output-on-failure --timeout 900 -j 2 "$@"
