#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The scale-out model of one bw step on strips of whole rows (issue 46).

One step of the Baraff-Witkin mode (one linearised solve a step, FGMRES
preconditioned by nuno's kaskade multigrid) on P ranks, each a strip of
whole rows of an N x N lattice (DMDA 1 x P), as src/solver/stencil_mg.F90
distributes it:

  t_step = cycles a step x (compute of a cycle on the rank's rows of the
           distributed levels + halo exchanges x (latency + bytes / bandwidth)
           + reductions x allreduce(P) + the coarsest level's replicated
           right-hand side sum and banded LU solve)
           + assembly (compute, its halo and reductions)
           + the coarsest level's banded LU factorisation and operator sum,
             once a rebuild interval.

Measured on the project's machine (defaults; docs/performance.md,
"Scaling"): a cycle's time a level node (nunoMGCycle over the nodes of
all levels), the Krylov method's time a node and iteration (KSPSolve
less nunoMGCycle: products, orthogonalisation), the rest of a step a node (TSStep less KSPSolve), the
cycles a step. Assumed (a typical cluster, options): latency, link
bandwidth, allreduce as 2 log2(P) latencies plus 2 (P-1)/P of the bytes
(reduce-scatter and allgather), a core's memory bandwidth and flop rate
for the banded LU. The distribution of the levels follows mg_create
exactly: PETSc's split of N rows (N/P, the first N mod P ranks one more),
coarse row J on the rank of fine row 2 J, a level distributed while every
rank owns at least its halo hc (2-3 rows: coarse_halo) of it; the first
one that fails is, with --telescope (nuno's default, -nuno_mg_gather
auto), on more than 4 ranks gathered on fewer (module mg_gather) and so on
down to 5 x 5, else replicated on every rank; the last level is replicated
and solved by LAPACK's banded LU (dgbtrf/dgbtrs, 3 nx ny unknowns,
kl = ku = 3 (r nx + r) + 2).

  python3 bench/scaling_model.py                    # table, docs/figures/scaling-model.png
  python3 bench/scaling_model.py --json out.json    # the numbers too
  python3 bench/scaling_model.py --no-figure --sizes 1025 --ranks 64 128
"""
import argparse
import json
import math
import sys

# Measured on the project's machine: hang 257 x 257 with energy bending,
# bw (-snes_type ksponly -reduced_ksp_rtol 1e-3, dt = 1/600 s), 30 steps
# from rest, one rank, -log_view, build of main dd5bf49 (docs/performance.md,
# "Scaling", has the run and the machine's load).
MEASURED = {
    "n": 257,
    "steps": 30,
    "cycles": 148,          # nunoMGCycle count (= FGMRES iterations)
    "t_cycles": 2.4741,     # nunoMGCycle [s]
    "t_ksp": 3.1043,        # KSPSolve [s]
    "t_step": 5.1802,       # TSStep [s]
}

REACH = 2          # stencil reach of every level (with bending; rediscretised levels)
HALO = 2           # the finest level's halo rows (the reach), the strips' limit N/P >= 2
MIN_SIDE = 5       # coarsening stops at 5 points a side
GATHER_ABOVE = 4   # -nuno_mg_gather auto gathers a level too thin for more than this many ranks


def level_sides(n):
    """Sides of the multigrid's levels of an n x n lattice down to 5 (mg_create)."""
    sides = [n]
    while (sides[-1] - 1) % 2 == 0 and (sides[-1] - 1) // 2 + 1 >= MIN_SIDE:
        sides.append((sides[-1] - 1) // 2 + 1)
    return sides


def strip_rows(n, p):
    """(ys, ye) of every rank: PETSc's split of n rows over p ranks."""
    out, start = [], 0
    for k in range(p):
        m = n // p + (1 if k < n % p else 0)
        out.append((start, start + m - 1))
        start += m
    return out


def parents(k, nc):
    """Coarse rows of fine row k: the bilinear restriction's and the cubic
    interpolation's (src/kernels/interpolation.f90; linear below 4 coarse
    points), the transfers of the rediscretised levels with bending."""
    if k % 2 == 0:
        return [k // 2]
    c0 = (k - 1) // 2
    lin = [c0, c0 + 1]
    if nc < 4:
        return lin
    s = 0 if c0 == 0 else (c0 - 2 if c0 + 1 == nc - 1 else c0 - 1)
    return lin + [s, s + 3]


def coarse_halo(nc, rows):
    """mg_create's hc: the stencil reach, or how far the transfers of a
    rank's fine rows reach beyond its natural coarse rows, the most of any
    rank (rows: the (ys, ye) of the ranks that hold fine rows)."""
    hc = REACH
    for ys, ye in rows:
        ysc, yec = (ys + 1) // 2, ye // 2
        for k in {ys, min(ys + 1, ye), max(ye - 1, ys), ye}:
            c = parents(k, nc)
            hc = max(hc, ysc - min(c), max(c) - yec)
    return hc


def hierarchy(n, p, telescope=False):
    """The levels as mg_create makes them on p ranks: a list of
    (side, rows of the rank with the most, distributed, ranks that hold
    rows), the last replicated. A level is distributed while every rank
    of the level above owns at least its halo hc (coarse_halo) of it;
    telescope (-nuno_mg_gather auto, src/solver/mg_gather.F90): a level
    that fails, on more than GATHER_ABOVE ranks and not the last, goes on
    the first min(ranks of the level above, side // hc) ranks (PETSc's
    split), and so on down; else it is the coarsest, replicated."""
    sides = level_sides(n)
    rows = strip_rows(n, p)
    levels = [(n, max(ye - ys + 1 for ys, ye in rows), p > 1, p)]
    for side in sides[1:]:
        hc = coarse_halo(side, rows)
        rows = [((ys + 1) // 2, ye // 2) for ys, ye in rows]
        fewest = min(ye - ys + 1 for ys, ye in rows)
        short = side == sides[-1]
        gathered = telescope and fewest < hc and not short and p > GATHER_ABOVE
        if gathered:
            rows = strip_rows(side, min(len(rows), side // hc))
        last = short or (fewest < hc and not gathered)
        if last or p == 1:
            levels.append((side, side, False, p))
        else:
            levels.append((side, max(ye - ys + 1 for ys, ye in rows), True, len(rows)))
        if last:
            break
    return levels


def allreduce(p, nbytes, a):
    """Allreduce of nbytes on p ranks: 2 log2(p) latencies plus 2 (p-1)/p of the bytes."""
    if p == 1:
        return 0.0
    return 2.0 * math.log2(p) * a.latency + 2.0 * (p - 1) / p * nbytes / a.bandwidth


def message(nbytes, a):
    return a.latency + nbytes / a.bandwidth


def cycles_a_step(n, a):
    """Measured (docs/performance.md, bw with bending): 5.55, 7.3, 11.2 at
    257, 513, 1025; beyond, extrapolated by the last doubling's growth."""
    if a.cycles is not None:
        return a.cycles
    known = {257: 5.55, 513: 7.3, 1025: 11.2}
    if n in known:
        return known[n]
    if n < 1025:
        return known[257] if n < 257 else known[513]
    return known[1025] + (known[1025] - known[513]) * math.log2((n - 1) / 1024)


def model(n, p, a):
    """One bw step's time [s] on p ranks, by component, and the hierarchy."""
    m = a.measured
    nodes_1 = sum(s * s for s in level_sides(m["n"]))   # all levels' nodes of the measured run
    t_level_node = m["t_cycles"] / m["cycles"] / nodes_1 * a.compute_scale   # a cycle, a level node [s]
    # the inner solve less its cycles (FGMRES's products and orthogonalisation), an iteration, a node [s]
    t_krylov_node = (m["t_ksp"] - m["t_cycles"]) / m["cycles"] / m["n"] ** 2 * a.compute_scale
    t_other_node = (m["t_step"] - m["t_ksp"]) / m["steps"] / m["n"] ** 2 * a.compute_scale   # a step, a node [s]
    levels = hierarchy(n, p, a.telescope)
    cyc = cycles_a_step(n, a)
    fine_rows = levels[0][1]
    # compute a cycle: the rank's rows of every level kept distributed (all on one rank)
    compute = sum(side * rows for side, rows, dist, _ in levels[:-1]) * t_level_node
    krylov = n * fine_rows * t_krylov_node
    halo = 0.0
    halo_fine = 0.0
    halo_msgs = 0
    coarse = 0.0
    coarse_side = levels[-1][0]
    unknowns = 3 * coarse_side ** 2
    kl = 3 * (REACH * coarse_side + REACH) + 2
    lu_bytes = (3 * kl + 1) * unknowns * 8      # dgbtrf's band, double precision [B]
    if p == 1:
        compute += coarse_side ** 2 * t_level_node   # the coarsest level is in the measurement
    else:
        row_b = 3 * 4 * HALO                       # single-precision 3-dof x, a halo row's node [B]
        for l, (side, rows, dist, ranks) in enumerate(levels):
            if not dist:
                continue
            # restriction into this level (finish_sums_w) and the exchange
            # before interpolating from it: 2 sendrecvs each (below, above)
            into = 2 if l > 0 else 0
            out = 2 if l + 1 < len(levels) and levels[l + 1][2] else 0
            # one symmetric sweep: 2 exchanges; the finest's last forms A x: 3
            sweeps = 3 if l == 0 else 2
            k = into + out + 2 * sweeps
            if l > 0 and ranks < levels[l - 1][3]:
                k += 2                             # gathered onto fewer ranks and scattered back
            halo_msgs += k
            halo += k * message(row_b * side, a)
            if l == 0:
                halo_fine = k * message(row_b * side, a)
        # the Krylov product of the unfused start and FGMRES: one double exchange
        halo_msgs += 2
        halo += 2 * message(3 * 8 * HALO * n, a)
        # the coarsest level: its right-hand side summed over all ranks, solved on each
        coarse = allreduce(p, 12 * coarse_side ** 2, a) + lu_bytes / a.core_bandwidth
    reductions = a.reductions_cycle * allreduce(p, 8 * 31, a)
    per_cycle = compute + krylov + halo + reductions + coarse
    assembly = n * fine_rows * t_other_node
    assembly_comm = 0.0
    factor = 0.0
    if p > 1:
        assembly_comm = 2 * message(6 * 8 * HALO * n, a) + a.reductions_step * allreduce(p, 8, a)
        # the coarsest level rebuilt every rebuild-interval steps: its operator
        # summed over all ranks (16 blocks of 9 doubles a node) and factored
        factor = (allreduce(p, 16 * 9 * 8 * coarse_side ** 2, a)
                  + 4.0 * unknowns * kl ** 2 / a.flops) / a.rebuild
    total = cyc * per_cycle + assembly + assembly_comm + factor
    return {
        "n": n, "p": p, "rows": fine_rows, "cycles": cyc,
        "levels_distributed": len(levels) - 1, "coarse_side": coarse_side,
        "coarse_unknowns": unknowns, "coarse_lu_bytes": lu_bytes,
        "compute": cyc * (compute + krylov) + assembly,
        "halo": cyc * halo + (2 * message(6 * 8 * HALO * n, a) if p > 1 else 0.0),
        "halo_msgs_cycle": halo_msgs,
        "halo_fine": cyc * halo_fine,   # the finest level's strip halo a step, a rank [s]
        "reductions": cyc * reductions + (a.reductions_step * allreduce(p, 8, a) if p > 1 else 0.0),
        "coarse": cyc * coarse + factor,
        "total": total,
        # halo and reductions over the compute of the distributed rows: below 1, strips keep compute ahead
        "comm_over_compute": (cyc * (halo + reductions)) / (cyc * (compute + krylov)),
    }


def strips_allow(n, p):
    return n // p >= HALO


def parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1025, 2049, 4097, 8193], help="lattice sides N")
    ap.add_argument("--ranks", type=int, nargs="+", default=[2 ** k for k in range(6, 13)], help="rank counts P")
    ap.add_argument("--latency", type=float, default=1.5e-6, help="point-to-point latency [s] (assumed: InfiniBand HDR)")
    ap.add_argument("--bandwidth", type=float, default=12e9, help="link bandwidth [B/s] (assumed: InfiniBand HDR, 100 Gb/s)")
    ap.add_argument("--core-bandwidth", type=float, default=10e9,
                    help="memory bandwidth of one core while all cores of a node run [B/s] (assumed), bounds the banded LU solve")
    ap.add_argument("--flops", type=float, default=10e9, help="flop rate of one core in dgbtrf [flop/s] (assumed)")
    ap.add_argument("--compute-scale", type=float, default=1.0,
                    help="a cluster core's compute time a node over this machine's (1: as measured here)")
    ap.add_argument("--cycles", type=float, default=None,
                    help="cycles a step at every N (default: measured 5.55, 7.3, 11.2 at 257, 513, 1025, extrapolated)")
    ap.add_argument("--reductions-cycle", type=int, default=2,
                    help="allreduces a cycle: FGMRES's classical Gram-Schmidt (VecMDot) and its norm (VecNorm)")
    ap.add_argument("--reductions-step", type=int, default=8,
                    help="allreduces a step outside the cycles (residual norms, the guesses' projection, energy balance)")
    ap.add_argument("--rebuild", type=float, default=20, help="steps between rebuilds of the coarse levels")
    ap.add_argument("--telescope", action="store_true",
                    help="-nuno_mg_gather auto (nuno's default): levels too thin for the strips of more than 4 ranks gathered on fewer (hc rows each) down to 5 x 5; without: -nuno_mg_gather never")
    ap.add_argument("--figure", default="docs/figures/scaling-model.png", help="the figure's file")
    ap.add_argument("--no-figure", action="store_true", help="no figure (no matplotlib needed)")
    ap.add_argument("--json", default=None, help="write every row as JSON to this file")
    a = ap.parse_args(argv)
    a.measured = MEASURED
    return a


def table(a):
    rows = []
    for n in a.sizes:
        base = model(n, 1, a)["total"]
        for p in a.ranks:
            if not strips_allow(n, p):
                rows.append({"n": n, "p": p, "allowed": False})
                continue
            r = model(n, p, a)
            r["allowed"] = True
            r["efficiency"] = base / (p * r["total"])
            r["t1"] = base
            rows.append(r)
    return rows


def print_table(rows, out=sys.stdout):
    print("| N | P | rows a rank | coarsest (replicated) | LU band a rank | t a step [ms] | compute | halo | reductions | coarsest | efficiency | (halo + reductions) / compute |",
          file=out)
    print("|---|---|---|---|---|---|---|---|---|---|---|---|", file=out)
    for r in rows:
        if not r["allowed"]:
            print(f"| {r['n']} | {r['p']} | {r['n'] / r['p']:.2g} | strips cannot: N/P < 2 | | | | | | | | |", file=out)
            continue
        t = r["total"]
        print(f"| {r['n']} | {r['p']} | {r['rows']} | {r['coarse_side']} x {r['coarse_side']} | {r['coarse_lu_bytes'] / 1e9:.3g} GB "
              f"| {1e3 * t:.4g} | {100 * r['compute'] / t:.0f} % | {100 * r['halo'] / t:.1f} % "
              f"| {100 * r['reductions'] / t:.1f} % | {100 * r['coarse'] / t:.0f} % | {r['efficiency']:.3g} | {r['comm_over_compute']:.2g} |", file=out)


def figure(rows, remedy, a):
    """Time a step and efficiency against P (remedy: the --telescope rows,
    dashed), and the breakdown at the largest P strips allow."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    for n in a.sizes:
        ok = [r for r in rows if r["n"] == n and r["allowed"]]
        if not ok:
            continue
        ps = [r["p"] for r in ok]
        line, = ax[0].loglog(ps, [1e3 * r["total"] for r in ok], "o-", label=f"N = {n}")
        ax[0].loglog(ps, [1e3 * r["t1"] / r["p"] for r in ok], ":", color=line.get_color())
        ax[1].semilogx(ps, [r["efficiency"] for r in ok], "o-", color=line.get_color(), label=f"N = {n}")
        tel = [r for r in remedy if r["n"] == n and r["allowed"]]
        ax[1].semilogx([r["p"] for r in tel], [r["efficiency"] for r in tel], "--", color=line.get_color())
    ax[0].set(xlabel="ranks P", ylabel="time a bw step [ms]", title="time a step (dotted: perfect scaling)")
    ax[1].set(xlabel="ranks P", ylabel="parallel efficiency", title="efficiency T(1) / (P T(P))\n(dashed: coarse levels gathered on fewer ranks, -nuno_mg_gather auto)",
              ylim=(0, 1.05))
    for x in ax[:2]:
        x.legend()
        x.grid(True, which="both", alpha=0.3)
    # the breakdown at the largest P strips allow, each N
    parts = ["compute", "halo", "reductions", "coarse"]
    names = ["compute", "halo", "reductions", "coarsest level (replicated LU)"]
    def largest(rs, n):
        return max((r for r in rs if r["n"] == n and r["allowed"]), key=lambda r: r["p"])
    ns = [n for n in a.sizes if any(r["n"] == n and r["allowed"] for r in rows)]
    last = [x for n in ns for x in (largest(rows, n), largest(remedy, n))]
    bottom = [0.0] * len(last)
    labels = [f"{r['n']}\nP={r['p']}\n{'built' if k % 2 == 0 else 'remedy'}\n{1e3 * r['total']:.3g} ms"
              for k, r in enumerate(last)]
    for part, name in zip(parts, names):
        vals = [100 * r[part] / r["total"] for r in last]
        ax[2].bar(labels, vals, bottom=bottom, label=name)
        bottom = [b + v for b, v in zip(bottom, vals)]
    ax[2].tick_params(axis="x", labelsize=6)
    ax[2].set(ylabel="share of a bw step [%]", title="breakdown at the largest P strips allow (N, P)", ylim=(0, 100))
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.figure, dpi=110)


def main(argv=None):
    a = parse(argv)
    rows = table(a)
    print_table(rows)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    if not a.no_figure:
        remedy = table(argparse.Namespace(**{**vars(a), "telescope": True}))
        figure(rows, remedy, a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
