#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Where the assembly of S goes, in CPU time a node: perf's on-CPU samples
# (cpu-clock, so the time a rank waits for a core on a shared machine is
# not in it, as it is in -log_view's wall-clock events) of hang N x N on
# one rank, the functions under the finest level's assembly (module
# reduced_mg's mg_glue_assemble, the event nunoAssembleS; the coarse
# levels' rebuilds not in it), each in ns a node and assembly, and their
# sum. Builds alternated REPS times. Needs perf.
#   bench/assembly_cpu.sh OLD_EXE NEW_EXE N BENDING MODE STEPS REPS
#   bench/assembly_cpu.sh /work/main/build/nuno build/nuno 257 energy bw 20 3
# BENDING: energy | none; MODE: bw (ksponly, rtol 1e-3, dt 1/600; one
# assembly a step) | newton (dt 1e-3; one assembly a Newton iteration).
set -euo pipefail
old=$(realpath "$1"); new=$(realpath "$2"); N=$3; bend=$4; mode=$5; steps=$6; reps=$7
source "$(dirname "$0")/../tools/env.sh"
source "$(dirname "$0")/hang_case.sh"
hang_case "$N" "$bend" "$mode" "$steps"
for r in $(seq "$reps"); do
  for b in "$old" "$new"; do
    perf record -q -g -F 4000 -o p.data -- mpiexec -n 1 "$b" m.nml "${mo[@]}" -log_view > run.txt 2>&1
    nas=$(awk '/^nunoAssembleS / {print $2}' run.txt)
    perf report -i p.data --no-children --stdio --sort=sym -p mg_glue_assemble -x 2>/dev/null | grep -E '^ +[0-9]' > sym.txt
    total=$(perf report -i p.data --stdio 2>/dev/null | awk '/Event count/ {print $NF}')
    echo "$N $bend $mode $b assemblies $nas"
    python3 - "$total" "$N" "$nas" sym.txt <<'PY'
import sys
total, n, nas = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
s = 0.0
for line in open(sys.argv[4]):
    f = line.split()
    ns = total * float(f[0].rstrip('%')) / 100 / (n * n) / nas
    s += ns
    if ns >= 2.0:
        print(f"  {f[2][:56]:56s} {ns:7.1f} ns a node")
print(f"  the assembly (all its callees) {s:.1f} ns a node")
PY
  done
done
