#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Configure and build nuno and its tests in build/ (Release). Quiet on success.
set -euo pipefail
source "$(dirname "$0")/env.sh"
cd "$NUNO_ROOT"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! cmake -S . -B build -DCMAKE_BUILD_TYPE="${NUNO_BUILD_TYPE:-Release}" >"$log" 2>&1; then
  cat "$log" >&2; echo "build.sh: cmake configure failed" >&2; exit 1
fi
if ! cmake --build build -j "$(nproc)" >"$log" 2>&1; then
  grep -E -B2 -A6 "Error|error:" "$log" >&2 || cat "$log" >&2
  echo "build.sh: build failed" >&2; exit 1
fi
