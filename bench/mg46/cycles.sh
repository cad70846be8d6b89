#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Issue 46: multigrid cycles a step of one build, hang with energy bending
# from rest at N x N, dt = 1/600 s, 20 steps (10 at 1025): bw mode
# (-snes_type ksponly -reduced_ksp_rtol 1e-3) and the default Newton mode;
# BENDING=no: without bending; one rank up to 513, RANKS1025 ranks
# (default 2) at 1025. Prints one line a
# run: mode, N, ranks, steps, Newton and linear iterations, linear a step,
# Newton x linear a step (= linear / steps), TSStep seconds.
#   source tools/env.sh
#   bash bench/mg46/cycles.sh build/nuno "65 129 257 513 1025" "bw newton" [EXTRA OPTIONS...]
set -euo pipefail
exe=$(realpath "$1"); sizes=${2:-"65 129 257 513"}; modes=${3:-"bw newton"}; shift 3 || true
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
for mode in $modes; do
  for n in $sizes; do
    dt="1.0/600"; steps=20; opts=()
    [ "$mode" = bw ] && opts=(-snes_type ksponly -reduced_ksp_rtol 1e-3)
    [ "$n" -ge 1025 ] && steps=10
    ranks=1; [ "$n" -ge 1025 ] && ranks=${RANKS1025:-2}
    t_end=$(python3 -c "print(repr($dt * $steps))"); dtv=$(python3 -c "print(repr($dt))")
    bend=""; [ "${BENDING:-yes}" = no ] && bend="bending_model = 'none'"
    printf "&scene scene = 'hang' /\n&lattice nx = %s, ny = %s /\n&material %s /\n&time t_end = %s, dt = %s /\n&output output_interval = %s, output_file = 'c.h5' /\n" \
      "$n" "$n" "$bend" "$t_end" "$dtv" "$t_end" > c.nml
    mpiexec -n "$ranks" --oversubscribe "$exe" c.nml "${opts[@]}" "$@" -log_view > run.log 2>&1 || { tail -20 run.log; exit 1; }
    grep -E "^t =" run.log | tail -1 | awk -v m="$mode" -v n="$n" -v r="$ranks" \
      -v ts="$(grep -E '^TSStep ' run.log | awk '{print $4}')" \
      '{printf "%-6s N=%-5s ranks=%s steps=%s newton=%s linear=%s lin/step=%.2f TSStep=%ss\n", m, n, r, $5, $9, $11, $11/$5, ts}'
  done
done
