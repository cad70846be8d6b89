#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# The benchmark behind docs/performance.md, in one run of one build, on
# issue 46's protocol (hang with energy bending, dt = 1/600 s, 60 steps
# from rest at 65 and 129, 30 at 257, 20 at 513, 10 at 1025):
#   1. bench/solver.py: hang N x N, N = 65 .. 1025, 1 and 2 ranks, modes bw
#      and newton, with and without bending, each case twice (about 7
#      minutes on 2 idle cores at the table's rates: bw with bending about
#      2.5, newton with bending about 2, without bending about 3), and in the
#      same run the peer (bench/peer_taichi.py) right after nuno's bw rows
#      with bending at its N: 257 x 257 on 1 thread, 30 steps, and
#      1025 x 1025 on 2 threads, 10 steps, each twice, the faster kept
#      (about 1 and 5.5 minutes: some 150 s a run at 1025);
#   2. the done-when run: hang 257 x 257, 1 s of simulated time, 2 ranks, no
#      options (under a minute), under /usr/bin/time -v for its memory;
#   3. docs/performance-data.json, docs/figures/performance.png and the table
#      between docs/performance.md's markers (with the peer's node-steps/s and
#      nuno/peer), all from these two logs.
# About 15 minutes in all, the build aside. The peer's virtual environment
# (runs/peer-venv, taichi from PyPI) is made first where it is missing.
# The logs go to bench/results/performance-bench-COMMIT.log (the peer's
# lines in it) and performance-donewhen-COMMIT.log; git rm the older
# performance-*.log files after a run so that bench/results holds only the
# logs behind the docs. Run on an otherwise idle machine: its speed is the
# measurement.
#
#   bash bench/performance.sh                            # build, run, write
#   bash bench/performance.sh --quick                    # a check of this script (~2 min): 65 and 129,
#                                                        # the peer at 65, done-when at 65 x 65 for 0.1 s;
#                                                        # logs and outputs in a temporary folder only
#   bash bench/performance.sh --replot                   # no runs: the logs behind today's table
#   bash bench/performance.sh --replot BENCH_LOG... DONEWHEN_LOG
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
replot=0 quick=0
case "${1:-}" in
  --replot) replot=1; shift ;;
  --quick) quick=1; shift ;;
esac

commit=$(git rev-parse --short HEAD)
res=bench/results
# the full run: every size, the peer where issue 46 puts it, the done-when run as the issue states it
solver_args=(--modes bw newton --bending both --peer 257:1 1025:2)
dw_n=257 dw_t=1.0
out_json=docs/performance-data.json out_png=docs/figures/performance.png out_doc=docs/performance.md
if [ $quick = 1 ]; then
  solver_args=(--modes bw newton --bending both --sizes 65 129 --peer 65:1 --repeat 1)
  dw_n=65 dw_t=0.1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ $quick = 1 ]; then
  res=$work
  out_json=$work/performance-data.json out_png=$work/performance.png out_doc=$work/performance.md
  cp docs/performance.md "$out_doc"
fi
bench_log=$res/performance-bench-$commit.log
dw_log=$res/performance-donewhen-$commit.log

if [ $replot = 0 ]; then
  if ! git diff --quiet HEAD -- src CMakeLists.txt; then
    echo "bench/performance.sh: src/ has uncommitted changes; commit them so the logs name the build" >&2
    exit 1
  fi
  bash tools/build.sh
  # shellcheck disable=SC1091
  source tools/env.sh
  python3 bench/peer_taichi.py --n 3 --steps 1 > /dev/null   # the peer's venv, once (bench/peer.sh's way)
  cpu=$(lscpu | sed -n 's/^Model name:[[:space:]]*//p' | head -1)
  {
    echo "# bash bench/performance.sh: python3 bench/solver.py ${solver_args[*]}"
    echo "# build of commit $commit, $(date -u '+%Y-%m-%d %H:%M UTC'), $cpu, $(nproc) cores, load: $(uptime | sed 's/.*load average: //')"
    python3 bench/solver.py "${solver_args[@]}"
  } 2>&1 | tee "$bench_log"

  sed -e "s/^\( *\)nx = 21, ny = 21/\1nx = $dw_n, ny = $dw_n/" \
      -e "s/^\( *\)t_end = 2.0 /\1t_end = $dw_t /" \
      -e "s/output_file *= *'hang.h5'/output_file = 'dw.h5'/" input/hang.nml > "$work/dw.nml"
  grep -q "nx = $dw_n, ny = $dw_n" "$work/dw.nml" && grep -q "t_end = $dw_t " "$work/dw.nml" || {
    echo "bench/performance.sh: input/hang.nml changed; update the done-when edits" >&2
    exit 1
  }
  {
    echo "# bash bench/performance.sh: the done-when run, input/hang.nml at nx = ny = $dw_n, t_end = $dw_t;"
    echo "# /usr/bin/time -v mpiexec -n 2 build/nuno dw.nml -log_view; build of commit $commit, $(date -u '+%Y-%m-%d %H:%M UTC')"
    start=$(date +%s.%N)
    (cd "$work" && /usr/bin/time -v "${NUNO_MPIEXEC:-mpiexec}" -n 2 "$repo/build/nuno" dw.nml -log_view)
    end=$(date +%s.%N)
    python3 -c "import sys; t = float(sys.argv[2]) - float(sys.argv[1]); print(f'real\t{int(t // 60)}m{t % 60:.3f}s')" "$start" "$end"
  } 2>&1 | tee "$dw_log"
  bench_logs=("$bench_log")
elif [ $# -ge 2 ]; then
  bench_logs=("${@:1:$#-1}")
  dw_log=${!#}
else
  # the logs behind docs/performance.md's table until the next full run
  bench_logs=("$res/performance-bench-9ba3bc6.log")
  dw_log=$res/performance-donewhen-9ba3bc6.log
fi

python3 bench/solver.py --replot "${bench_logs[@]}" --donewhen "$dw_log" \
  --output "$out_json" --plot "$out_png" --doc "$out_doc"
if [ $quick = 1 ]; then
  # a check only: print what the full run would write into docs/performance.md
  sed -n '/<!-- table begin (bench\/solver.py) -->/,/<!-- table end -->/p' "$out_doc"
  echo "bench/performance.sh --quick: the table above, the JSON and the figure written in a temporary folder (removed); docs/ untouched"
else
  echo "bench/performance.sh: $out_json, $out_png and $out_doc's table from ${bench_logs[*]} and $dw_log"
fi
