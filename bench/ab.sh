#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# A/B of two nuno builds at equal conditions (this machine's speed wanders
# by 20-30 % from hour to hour, and by 3x from day to day: only runs
# alternated within minutes compare). hang at N x N (default 257) on one
# rank, the four cases of bench/solver.py: bw and Newton, with and without
# bending; each pair alternated REPEAT times (default 2). Prints, per run,
# the iteration counts and the -log_view events (time/count), and the
# one-core triad before and after.
#
#   source tools/env.sh
#   bash bench/ab.sh OLD/build/nuno build/nuno [N] [REPEAT] > ab.txt   # quote it in the commit message
#   CASES="bw_yes" bash bench/ab.sh OLD/build/nuno build/nuno 257 5   # one case, five pairs
#   RANKS=2 CASES="bw_no newton_no" bash bench/ab.sh OLD/build/nuno build/nuno 1025 3
# Ends with one line per case: the median TSStep time [s] of each build and
# their ratio new/old.
set -euo pipefail
old=$(realpath "$1") new=$(realpath "$2") n=${3:-257} repeat=${4:-2} ranks=${RANKS:-1}
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cc -O3 -march=native -o "$work/triad" "$root/bench/triad.c"
cd "$work"
write() {   # name bending dt steps
  local bend=""
  [ "$2" = no ] && bend="bending_model = 'none'"
  local dt t_end
  dt=$(python3 -c "print(repr($3))")
  t_end=$(python3 -c "print(repr($3 * $4))")
  printf "&scene scene = 'hang' /\n&lattice nx = %s, ny = %s /\n&material %s /\n&time t_end = %s, dt = %s /\n&output output_interval = %s, output_file = 'ab.h5' /\n" \
    "$n" "$n" "$bend" "$t_end" "$dt" "$t_end" > "$1.nml"
}
write bw_yes yes "1.0/600" 30
write bw_no no "1.0/600" 30
write newton_yes yes 0.001 10
write newton_no no 0.001 10
echo "triad [GB/s, one core]: $(./triad)"
for case in ${CASES:-bw_yes bw_no newton_yes newton_no}; do
  [ -f "$case.nml" ] || { echo "bench/ab.sh: unknown case '$case' (bw_yes bw_no newton_yes newton_no)" >&2; exit 2; }
  opts=()
  [[ $case == bw_* ]] && opts=(-snes_type ksponly -reduced_ksp_rtol 1e-3)
  echo "== $case (hang $n x $n, $ranks rank(s) ${opts[*]})"
  for ((r = 0; r < repeat; r++)); do
    for exe in "$old" "$new"; do
      mpiexec -n "$ranks" --oversubscribe "$exe" "$case.nml" "${opts[@]}" -log_view > run.log 2>&1
      tag=$([ "$exe" = "$old" ] && echo old || echo new)
      counts=$(grep -E "^t =" run.log | tail -1 | awk '{print "steps", $5, "newton", $9, "linear", $11}')
      events=$(grep -E "^(TSStep|MatMult|nunoAssembleS|nunoMGCycle|nunoMGGalerkin|SNESFunctionEval) " run.log \
               | awk '{printf "%s=%s/%s ", $1, $4, $2}')
      echo "$tag $counts $events"
      echo "$case $tag $(grep -E '^TSStep ' run.log | awk '{print $4}')" >> summary.txt
    done
  done
done
echo "triad [GB/s, one core]: $(./triad)"
python3 - summary.txt <<'PY'
import statistics, sys
t = {}
for line in open(sys.argv[1]):
    case, tag, sec = line.split()
    t.setdefault(case, {}).setdefault(tag, []).append(float(sec))
for case, d in t.items():
    o, n = statistics.median(d["old"]), statistics.median(d["new"])
    print(f"median TSStep {case}: old {o:.3f} s, new {n:.3f} s, new/old {n / o:.3f} ({len(d['new'])} pairs)")
PY
