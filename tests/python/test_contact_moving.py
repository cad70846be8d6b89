# SPDX-License-Identifier: BSD-2-Clause
"""Obstacles that push (issue 47 item 2; docs/design.md, "Contact", moving
obstacles): a keyframed sphere, box, capsule or plane rising at 0.1, 0.5, 2
and 5 m/s into a free 11 x 11 cloth at rest, or into one falling onto it,
at dt = 1 ms and 10 ms. Each run completes with no retried step
(/run retried_steps = 0), every output step's smallest gap is above the
acceptance floor (1e-6 contact_dhat) and the run's smallest gap positive,
and at the end the obstacle has pushed the cloth: the node over its top's
centre is above the top and moves up at about the obstacle's speed (at
least 0.75 v: the cloth bounces on the barrier, more with the box, whose
top throws the stiff sheet ahead and lets it fall back). The whole matrix on
one rank, the fastest obstacles on two.

On e3c7ad0 the obstacle's pose at the step's end contained the nodes it
had reached (it moves more than their gap in a step) and Newton, starting
from the last state, had no feasible start: the runs failed at first
touch (a sphere at 0.1 m/s after 8 failed Newton solves)."""
import numpy as np
import pytest

from nunorun import contact_lines, contact_sheet, run
from postprocess.reader import read_run

DHAT = 1e-3
SHAPES = ["sphere", "capsule", "box", "plane"]
SPEEDS = [0.1, 0.5, 2.0, 5.0]
STEPS = [1e-3, 1e-2]


def obstacle(shape, z_top):
    """&contact keys of obstacle 1 under the cloth's centre, its top at z_top."""
    if shape == "sphere":
        return (f"obstacle_shape(1)='sphere' obstacle_point(:,1)=0.5,0.5,{z_top - 0.05!r} "
                "obstacle_radius(1)=0.05")
    if shape == "capsule":           # a bar along y under the node column x = 0.5
        return (f"obstacle_shape(1)='capsule' obstacle_point(:,1)=0.5,-0.1,{z_top - 0.02!r} "
                f"obstacle_end(:,1)=0.5,1.1,{z_top - 0.02!r} obstacle_radius(1)=0.02")
    if shape == "box":               # a paddle 30 cm square, its sides between node columns
        return (f"obstacle_shape(1)='box' obstacle_point(:,1)=0.5,0.5,{z_top - 0.05!r} "
                "obstacle_half_size(:,1)=0.15,0.15,0.05")
    return f"obstacle_shape(1)='plane' obstacle_point(:,1)=0.0,0.0,{z_top!r} obstacle_normal(:,1)=0.0,0.0,1.0"


def scene(shape, v, dt, falling, gap0=2e-3, travel=1e-2):
    """The groups of one run and the obstacle's top at its end. The obstacle
    starts gap0 below the cloth and rises at v until it has gone travel
    beyond the cloth's plane (at least 10 steps). Falling: the cloth falls
    under gravity for 50 ms first (to 0.49 m/s), the obstacle waiting
    gap0 below where it then is."""
    t_wait = 0.05 if falling else 0.0
    rise = max(round((gap0 + travel) / v / dt), 10) * dt
    t_end = t_wait + rise
    z_top = -gap0 - (0.5 * 9.81 * t_wait ** 2 if falling else 0.0)
    if falling:
        keys = (f"obstacle_n_keyframes(1)=3 obstacle_time(1:3,1)=0.0,{t_wait!r},{t_end!r} "
                f"obstacle_offset(:,3,1)=0.0,0.0,{v * rise!r}")
    else:
        keys = (f"obstacle_n_keyframes(1)=2 obstacle_time(1:2,1)=0.0,{t_end!r} "
                f"obstacle_offset(:,2,1)=0.0,0.0,{v * rise!r}")
    contact = f"n_obstacles=1 {obstacle(shape, z_top)} {keys} contact_dhat={DHAT} contact_stiffness=1.0"
    steps = round(t_end / dt)
    out_dt = dt * max(1, steps // 8)
    g = contact_sheet(contact, t_end, out_dt, n=11, dt=dt, gravity=(0.0, 0.0, -9.81 if falling else 0.0))
    return g, z_top + v * rise


def check(tmp_path, shape, v, dt, falling, nranks):
    g, top = scene(shape, v, dt, falling)
    proc, h5 = run(tmp_path, "push", nranks=nranks, timeout=300, **g)
    with read_run(str(h5)) as r:
        retried = r.run_info["retried_steps"]
        gaps = np.asarray(r.contact["min_gap"])
        t = np.asarray(r.time)
        z = np.asarray(r.position)[-2:, 5, 5, 2]                    # the centre node at the last two outputs
    rows = contact_lines(proc.stdout)
    assert retried == 0, proc.stdout[-2000:]
    assert rows and rows[-1][6] > 0.0, rows[-1:]                     # the run's smallest gap
    assert np.all(gaps >= 1e-6 * DHAT), gaps                        # every output step above the floor
    ride = z[-1] - top
    rise = (z[-1] - z[-2]) / (t[-1] - t[-2])
    assert 0.0 < ride < 0.02, ride                                  # on the obstacle's top, not left behind
    assert rise > 0.75 * v, rise / v                                # and moving up with it


@pytest.mark.parametrize("falling", [False, True], ids=["resting", "falling"])
@pytest.mark.parametrize("dt", STEPS)
@pytest.mark.parametrize("v", SPEEDS)
@pytest.mark.parametrize("shape", SHAPES)
def test_obstacle_pushes_the_cloth(tmp_path, shape, v, dt, falling):
    check(tmp_path, shape, v, dt, falling, 1)


@pytest.mark.parametrize("falling", [False, True], ids=["resting", "falling"])
@pytest.mark.parametrize("dt", STEPS)
@pytest.mark.parametrize("shape", SHAPES)
def test_fast_obstacle_pushes_the_cloth_on_two_ranks(tmp_path, shape, dt, falling):
    check(tmp_path, shape, 5.0, dt, falling, 2)
