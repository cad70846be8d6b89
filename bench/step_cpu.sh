#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Where a whole step's CPU goes: perf's on-CPU samples (cpu-clock, with
# DWARF call stacks) of hang N x N on one rank, a run of STEPS steps less
# one of 2 (so steps 3..STEPS: the start-up and the first two steps from
# rest cancel), each sample put in the group of its nearest caller below,
# in ns a node and step: the finest level's assembly (mg_glue_assemble),
# the coarse levels' rebuilds (reduced_assemble's rest), the multigrid's
# cycles (mg_pc_apply), FGMRES's products with S (stencil_mult), the
# residual (model_residual), the elimination, FGMRES's vector work, the
# guesses, the monitor (the energy balance's powers), the rest of TSStep;
# under each group its functions from 4 ns a node. Needs perf.
#   bench/step_cpu.sh EXE N BENDING MODE STEPS
#   bench/step_cpu.sh build/nuno 257 energy bw 30
# BENDING: energy | none; MODE: bw | newton (bench/hang_case.sh).
set -euo pipefail
exe=$(realpath "$1"); N=$2; bend=$3; mode=$4; steps=$5
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../tools/env.sh"
source "$here/hang_case.sh"
w=$(mktemp -d); trap 'rm -rf "$w"' EXIT
for s in 2 "$steps"; do
  # a subshell: hang_case's folder goes when it ends
  ( hang_case "$N" "$bend" "$mode" "$s"
    perf record -q --call-graph dwarf,16384 -F 1500 -o p.data -- mpiexec -n 1 "$exe" m.nml "${mo[@]}" > run.txt 2>&1
    perf script -i p.data -F comm,period,ip,sym 2>/dev/null > "$w/s$s.txt"
    grep '^t = ' run.txt | tail -1 | awk '{print $11}' > "$w/lin$s.txt" )
done
cd "$w"
python3 - "$N" "$steps" <<'PY'
import sys, collections
# the first of these met going up a sample's stack names its group
KEYS = [('mg_glue_assemble', 'assembly (finest level)'), ('reduced_assemble', 'assembly (coarse levels)'),
        ('mg_pc_apply', 'cycles'), ('stencil_mult', 'products with S (FGMRES)'),
        ('model_residual', 'residual'), ('form_ifunction', 'residual'),
        ('reduced_rhs', 'elimination'), ('back_substitute', 'elimination'),
        ('KSPSolve_FGMRES', 'vectors (FGMRES)'), ('_guess_MOD', 'guesses'), ('guess_', 'guesses'),
        ('TSMonitor', 'monitor (energy balance)'), ('TSStep', 'other in TSStep')]
# energy_triple_row's frame is larger than perf's 16 KB copy of the stack:
# its samples do not unwind; only the assembly calls these
NOUNWIND = ('energy_triple_row', 'energy_jacobian_lanes', '_MOD_ring_triple_edges ')
def groups(fn):
    g, f = collections.Counter(), collections.Counter()
    for blk in open(fn).read().split('\n\n'):
        lines = blk.strip().split('\n')
        head = lines[0].split() if lines else []
        if not head or head[0] != 'nuno':
            continue
        syms = [l.strip().split(None, 1)[1] if len(l.strip().split(None, 1)) > 1 else '?' for l in lines[1:]]
        grp = next((n for s in syms for k, n in KEYS if k in s), 'not unwound (copies, faults) or outside TSStep')
        if grp.startswith('not unwound') and syms and any(k in syms[0] + ' ' for k in NOUNWIND):
            grp = KEYS[0][1]
        g[grp] += float(head[-1])
        f[grp, syms[0] if syms else '?'] += float(head[-1])
    return g, f
n, steps = int(sys.argv[1]), int(sys.argv[2])
(g0, f0), (g1, f1) = groups('s2.txt'), groups(f's{steps}.txt')
per = (steps - 2) * n * n                      # ns of cpu-clock -> ns a node and step
cyc = (int(open(f'lin{steps}.txt').read()) - int(open('lin2.txt').read())) / (steps - 2)
print(f"steps 3..{steps}: {(sum(g1.values()) - sum(g0.values())) / per:.0f} ns a node a step, {cyc:.2f} cycles a step")
for grp in sorted(g1, key=lambda x: g0[x] - g1[x]):
    print(f"{(g1[grp] - g0[grp]) / per:7.0f}  {grp}")
    for v, s in sorted((((f1[k] - f0[k]) / per, k[1]) for k in f1 if k[0] == grp), reverse=True):
        if v >= 4:
            print(f"         {v:5.0f}  {s[:70]}")
PY
