# SPDX-License-Identifier: BSD-2-Clause
"""Acceptance of contact states (issue 47 item 5; docs/contact.md,
"Acceptance"): no state is accepted with a gap below the floor, 1e-6
contact_dhat, and so no pair's barrier force above the barrier's force at
the floor. A drop whose impact step ends below the floor (a soft barrier:
backward Euler stops the sheet within one step, at a gap of about
kappa dhat^2 dt / (m v)) was accepted before (main e3c7ad0: a smallest
gap of 6e-10 m against a floor of 1e-9 m); now its end states are
rejected and the step retried smaller, and the run either completes with
every accepted state above the floor or ends with one line that says so.
A drop with the default barrier stays above the floor and its contact
force below the bound. drop_table's cloth on a 7 x 7 lattice, 2 ranks."""
import math
import re

import numpy as np

from nunorun import contact_sheet, plane_below, run, read_run

DHAT = 1e-3
FLOOR = 1e-6 * DHAT      # the acceptance floor [m]


def barrier_force_at_floor(kappa, dhat=DHAT):
    """kappa |b'(floor)| of the IPC barrier b(s) = -(s - dhat)^2 log(s / dhat) [N]."""
    s = 1e-6 * dhat
    return kappa * abs(-2.0 * (s - dhat) * math.log(s / dhat) - (s - dhat) ** 2 / s)


def drop(kappa, h=0.45, t_end=0.4):
    g = contact_sheet(plane_below(h, 0.0, dhat=DHAT, kappa=kappa), t_end, 0.1, n=7, units="SI")
    return g


def test_no_state_below_the_floor_is_accepted(tmp_path):
    """kappa = 3e-3 N/m (its rest gap, 1e-7 m, is far above the floor; the
    impact's is not): the run retries the impact's steps smaller and either
    completes above the floor or ends with one error line naming the
    acceptance floor; every state the file holds is above the floor."""
    proc, h5 = run(tmp_path, "soft", nranks=2, check=False, **drop(3e-3))
    text = proc.stdout + proc.stderr
    gaps = [float(m) for m in re.findall(r"min gap of all accepted states = ([^,\s]+)", proc.stdout)]
    assert gaps and min(gaps) >= FLOOR, (min(gaps) if gaps else None, text[-2000:])
    if proc.returncode != 0:
        errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
        assert len(errors) == 1, proc.stderr[-3000:]
        assert "acceptance floor" in errors[0], errors[0]
        assert re.search(r"\d+ rejected", text)
    with read_run(str(h5)) as r:
        c = r.contact
        assert np.all(c["min_gap_run"] >= FLOOR), c["min_gap_run"]


def test_accepted_contact_force_is_bounded(tmp_path):
    """The default barrier (kappa = 1 N/m): the drop completes, every
    accepted state's gap is at least the floor and every output state's
    normal force at most the bound, the barrier's force at the floor times
    the node-obstacle pairs (49)."""
    proc, h5 = run(tmp_path, "stiff", nranks=2, **drop(1.0))
    with read_run(str(h5)) as r:
        assert r.complete
        c = r.contact
        assert np.all(c["min_gap_run"] >= FLOOR)
        assert c["min_gap_run"][-1] < 1e-4                      # it has landed
        bound = 49 * barrier_force_at_floor(1.0)
        assert np.all(np.linalg.norm(c["normal_force"], axis=1) <= bound)
