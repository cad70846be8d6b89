#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# nuno against the peer (bench/peer_taichi.py, a matrix-free Baraff-Witkin
# PCG cloth in Taichi, float64), alternated within minutes on this machine
# (its speed wanders by 20-30 % from hour to hour: only alternated runs
# compare). nuno: hang N x N with energy bending, dt = 1/600 s, bw mode
# (-snes_type ksponly -reduced_ksp_rtol 1e-3), STEPS steps from rest,
# node-steps/s of its TSStep event; the peer: the same N, dt, CG to 1e-3,
# STEPS steps after one warm-up step. RANKS (default 1) is nuno's rank
# count and the peer's thread count. Prints each run, the ratio nuno/peer
# of each pair, their median, and the one-core triad before and after.
#
#   source tools/env.sh
#   bash bench/peer.sh 257 30 [PAIRS]            # one core, 3 pairs
#   RANKS=2 bash bench/peer.sh 1025 10           # 2 ranks against 2 threads
set -euo pipefail
n=${1:?usage: bench/peer.sh N STEPS [PAIRS]} steps=${2:?usage: bench/peer.sh N STEPS [PAIRS]}
pairs=${3:-3} ranks=${RANKS:-1}
root=$(cd "$(dirname "$0")/.." && pwd)
nuno=$(command -v nuno || echo "$root/build/nuno")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cc -O3 -march=native -o "$work/triad" "$root/bench/triad.c"
python3 "$root/bench/peer_taichi.py" --n 3 --steps 1 > /dev/null   # the venv, once
dt=$(python3 -c "print(repr(1.0/600))")
t_end=$(python3 -c "print(repr($steps/600))")
printf "&scene scene = 'hang' /\n&lattice nx = %s, ny = %s /\n&time t_end = %s, dt = %s /\n&output output_interval = %s, output_file = 'peer.h5' /\n" \
  "$n" "$n" "$t_end" "$dt" "$t_end" > "$work/hang.nml"
cd "$work"
echo "triad [GB/s, one core]: $(./triad)"
echo "load: $(uptime)"
echo "== hang $n x $n, energy bending, dt = 1/600 s, bw; nuno on $ranks rank(s), the peer on $ranks thread(s)"
for ((r = 0; r < pairs; r++)); do
  mpiexec -n "$ranks" --oversubscribe "$nuno" hang.nml -snes_type ksponly -reduced_ksp_rtol 1e-3 -log_view > run.log 2>&1
  ns=$(grep -E "^t =" run.log | tail -1 | awk '{print $5}')
  ts=$(grep -E "^TSStep " run.log | awk '{print $4}')
  kry=$(grep -E "^t =" run.log | tail -1 | awk '{print $11}')
  nuno_rate=$(python3 -c "print(f'{$n * $n * $ns / $ts:.4g}')")
  echo "nuno N=$n ranks=$ranks steps=$ns krylov_per_step=$(python3 -c "print(f'{$kry / $ns:.2f}')") node_steps_per_s=$nuno_rate"
  line=$(python3 "$root/bench/peer_taichi.py" --n "$n" --steps "$steps" --threads "$ranks" | grep '^peer ')
  echo "$line"
  peer_rate=${line##*node_steps_per_s=}
  echo "$nuno_rate $peer_rate" >> pairs.txt
done
echo "triad [GB/s, one core]: $(./triad)"
echo "load: $(uptime)"
python3 - pairs.txt <<'PY'
import statistics, sys
q = [float(a) / float(b) for a, b in (l.split() for l in open(sys.argv[1]))]
print("ratio nuno/peer per pair:", " ".join(f"{x:.2f}" for x in q))
print(f"median ratio nuno/peer: {statistics.median(q):.2f} ({len(q)} pairs)")
PY
