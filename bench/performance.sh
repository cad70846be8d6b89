#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# The benchmark behind docs/performance.md, in one run of one build:
#   1. bench/solver.py: hang N x N, N = 65 .. 1025, 1 and 2 ranks, modes bw
#      and newton, with and without bending (about 5 minutes on 2 idle cores);
#   2. the done-when run: hang 257 x 257, 1 s of simulated time, 2 ranks, no
#      options (about 1.5 minutes), under /usr/bin/time -v for its memory;
#   3. docs/performance-data.json, docs/figures/performance.png and the table
#      between docs/performance.md's markers, all from these two logs.
# The logs go to bench/results/performance-bench-COMMIT.log and
# performance-donewhen-COMMIT.log; git rm the older performance-*.log files
# after a run so that bench/results holds only the logs behind the docs.
# Run on an otherwise idle machine: its speed is the measurement.
#
#   bash bench/performance.sh                            # build, run, write
#   bash bench/performance.sh --replot                   # no runs: the logs behind today's table
#   bash bench/performance.sh --replot BENCH_LOG... DONEWHEN_LOG
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
replot=0
if [ "${1:-}" = "--replot" ]; then
  replot=1
  shift
fi

commit=$(git rev-parse --short HEAD)
res=bench/results
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
  cpu=$(lscpu | sed -n 's/^Model name:[[:space:]]*//p' | head -1)
  {
    echo "# bash bench/performance.sh: python3 bench/solver.py --modes bw newton --bending both"
    echo "# build of commit $commit, $(date -u '+%Y-%m-%d %H:%M UTC'), $cpu, $(nproc) cores"
    python3 bench/solver.py --modes bw newton --bending both
  } 2>&1 | tee "$bench_log"

  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  sed -e 's/^\( *\)nx = 21, ny = 21/\1nx = 257, ny = 257/' \
      -e 's/^\( *\)t_end = 2.0 /\1t_end = 1.0 /' \
      -e "s/output_file *= *'hang.h5'/output_file = 'dw.h5'/" input/hang.nml > "$work/dw.nml"
  grep -q "nx = 257, ny = 257" "$work/dw.nml" && grep -q "t_end = 1.0" "$work/dw.nml" || {
    echo "bench/performance.sh: input/hang.nml changed; update the done-when edits" >&2
    exit 1
  }
  {
    echo "# bash bench/performance.sh: the done-when run, input/hang.nml at nx = ny = 257, t_end = 1.0;"
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
  bench_logs=("$res/performance-bench-93a0689.log")
  dw_log=$res/performance-donewhen-93a0689.log
fi

python3 bench/solver.py --replot "${bench_logs[@]}" --donewhen "$dw_log" \
  --output docs/performance-data.json --plot docs/figures/performance.png --doc docs/performance.md
echo "bench/performance.sh: docs/performance-data.json, docs/figures/performance.png and docs/performance.md's table from ${bench_logs[*]} and $dw_log"
