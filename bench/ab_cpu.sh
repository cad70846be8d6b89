#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Compare two nuno builds on hang, alternating runs, by the CPU time of the
# rank (user + sys, start-up included): on a shared machine that moves far
# less than wall time. One rank.
#   bench/ab_cpu.sh OLD_EXE NEW_EXE N BENDING MODE STEPS REPS
#   bench/ab_cpu.sh /work/wt-old/build/nuno build/nuno 257 none bw 24 2
# BENDING: energy | none; MODE: bw (ksponly, rtol 1e-3, dt 1/600) | newton (dt 1e-3)
set -euo pipefail
old=$(realpath "$1"); new=$(realpath "$2"); N=$3; bend=$4; mode=$5; steps=$6; reps=$7
source "$(dirname "$0")/../tools/env.sh"
source "$(dirname "$0")/hang_case.sh"
hang_case "$N" "$bend" "$mode" "$steps"
for r in $(seq "$reps"); do
  for b in "$old" "$new"; do
    mpiexec -n 1 /usr/bin/time -f "CPU %U %S" "$b" m.nml "${mo[@]}" > run.txt 2>&1
    cpu=$(awk '/^CPU/ {print $2 + $3}' run.txt)
    lin=$(grep '^t = ' run.txt | tail -1 | awk '{print $11}')
    echo "$N $bend $mode $b cpu_s $cpu linear $lin node-steps/cpu-s $(python3 -c "print('%.3g' % ($N*$N*$steps/$cpu))")"
  done
done
