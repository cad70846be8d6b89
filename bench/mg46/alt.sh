#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Issue 46: option variants of ONE build alternated within minutes (as
# bench/ab.sh alternates two builds): hang at N x N from rest, dt = 1/600 s,
# 20 steps, one rank; CASE bw_yes, bw_no, newton_yes or newton_no (bw:
# -snes_type ksponly -reduced_ksp_rtol 1e-3; _no: without bending). Prints
# one line a run: the variant, TSStep seconds, Newton/linear iterations,
# and uptime's load before and after. EXE picks the build (default
# build/nuno).
#   source tools/env.sh
#   bash bench/mg46/alt.sh 257 3 bw_yes "-nuno_mg_coarse galerkin" "-nuno_mg_coarse rediscretize"
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
exe=$(realpath "${EXE:-$root/build/nuno}")
n=$1 rep=$2 case=$3; shift 3
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT; cd "$work"
bend=""; [[ $case == *_no ]] && bend="bending_model = 'none'"
opts=(); [[ $case == bw_* ]] && opts=(-snes_type ksponly -reduced_ksp_rtol 1e-3)
dt=$(python3 -c 'print(repr(1/600))'); t_end=$(python3 -c 'print(repr(20/600))')
printf "&scene scene = 'hang' /\n&lattice nx = %s, ny = %s /\n&material %s /\n&time t_end = %s, dt = %s /\n&output output_interval = %s, output_file = 'c.h5' /\n" \
  "$n" "$n" "$bend" "$t_end" "$dt" "$t_end" > c.nml
echo "== $case N=$n $(uptime | sed 's/.*load/load/')"
for ((r = 0; r < rep; r++)); do
  for v in "$@"; do
    # shellcheck disable=SC2086  # a variant is several options
    mpiexec -n 1 "$exe" c.nml "${opts[@]}" $v -log_view < /dev/null > run.log 2>&1
    echo "$case [$v] TSStep=$(grep -E '^TSStep ' run.log | awk '{print $4}') newton/linear=$(grep -E '^t =' run.log | tail -1 | awk '{print $9 "/" $11}')"
  done
done
echo "== end $(uptime | sed 's/.*load/load/')"
