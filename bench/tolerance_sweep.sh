#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Adaptive bdf at -ts_rtol = -ts_atol = 1e-2 .. 1e-10 on every scene of
# input/ (t = 0.5 s, 2 ranks): each run must complete. One line per run on
# stdout (scene_rtol, exit code, the program's closing line).
#   bash bench/tolerance_sweep.sh > bench/results/tolerance-sweep.txt   # cited by docs/design.md
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/tools/env.sh"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
for f in "$root"/input/*.nml; do
  for r in 1e-2 1e-4 1e-6 1e-8 1e-10; do
    n=$(basename "$f" .nml)_$r
    timeout 900 mpiexec -n 2 "$root/build/nuno" "$f" -ts_type bdf -ts_adapt_type basic \
      -ts_rtol $r -ts_atol $r -ts_max_time 0.5 > "$n.out" 2>&1
    rc=$?
    echo "$n rc=$rc $(grep '^nuno: ' "$n.out" | grep -v warning | tail -1)"
  done
done
