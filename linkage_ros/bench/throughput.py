"""Vectorised four-bar throughput against a plain numpy baseline, and pruned outputs."""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .settings import Sizes
from .tradeoff import (
    SolverStepper,
    batch_columns,
    load_scene,
    run_interleaved,
    sweep_inputs,
    time_batches,
)

# =============================================================================================
# (a) vectorised four-bar throughput vs a plain numpy circle intersection
# =============================================================================================


def numpy_circle_baseline(l1, l2, l3, l4, theta2, branch=1.0):
    """The textbook four-bar in plain numpy: A on the crank circle, B the intersection of the
    circles (A, l3) and (O4, l4) with a = (d^2 + r1^2 - r2^2) / (2d), h = sqrt(r1^2 - a^2);
    returns theta3, theta4 (NaN where the circles miss)."""
    ax, ay = l2 * np.cos(theta2), l2 * np.sin(theta2)
    dx, dy = l1 - ax, -ay
    d = np.sqrt(dx * dx + dy * dy)
    a = (d * d + l3 * l3 - l4 * l4) / (2 * d)
    h = branch * np.sqrt(l3 * l3 - a * a)
    ux, uy = dx / d, dy / d
    bx = ax + a * ux - h * uy
    by = ay + a * uy + h * ux
    return np.arctan2(by - ay, bx - ax), np.arctan2(by, bx - l1)


def bench_throughput(sizes: Sizes) -> list[dict]:
    from ..core import fourbar
    from ..core.solver import Solver

    mech = load_scene('four_bar')
    sc = mech.shortcut
    l1, l2, l3, l4, br = sc['ground'], sc['crank'], sc['coupler'], sc['rocker'], sc['branch']
    solver = Solver(mech, method='closed_form')
    rng = np.random.default_rng(5)
    out = []
    for n in sizes.throughput:
        theta = rng.uniform(-math.pi, math.pi, n)
        fns = {
            'numpy baseline': lambda: numpy_circle_baseline(l1, l2, l3, l4, theta, br),
            'fourbar_forward': lambda: fourbar.fourbar_forward(l1, l2, l3, l4, theta, br),
            'Solver.solve_batch': lambda: solver.solve_batch({'crank': theta}),
        }
        times: dict[str, list[float]] = {k: [] for k in fns}
        # interleaved, so drift hits all alike; small batches repeat more (the same inputs in
        # all, ~1e6 per function per repeat at full size), or one disturbed call sways the median
        repeats = max(
            sizes.throughput_repeats, min(50, math.ceil(sizes.throughput_repeats * 1e6 / n))
        )
        for _ in range(repeats):
            for k, fn in fns.items():
                t0 = time.perf_counter_ns()
                fn()
                times[k].append(time.perf_counter_ns() - t0)
        med = {k: float(np.median(v)) / 1e9 for k, v in times.items()}
        t3b, t4b = numpy_circle_baseline(l1, l2, l3, l4, theta, br)
        ff = fourbar.fourbar_forward(l1, l2, l3, l4, theta, br)
        bb = solver.solve_batch({'crank': theta})

        def adiff(a, b):
            return float(np.max(np.abs(np.arctan2(np.sin(a - b), np.cos(a - b)))))

        pa, pb = bb.points['A'], bb.points['B']
        t3s = np.arctan2(pb[:, 1] - pa[:, 1], pb[:, 0] - pa[:, 0])
        t4s = np.arctan2(pb[:, 1], pb[:, 0] - l1)
        row = {
            'n': n,
            'repeats': repeats,
            'seconds': med,
            'rate': {k: n / v for k, v in med.items()},
            'ratio_vs_baseline': {k: med['numpy baseline'] / v for k, v in med.items()},
            'max_angle_diff_vs_baseline': {
                'fourbar_forward': max(adiff(ff.theta3, t3b), adiff(ff.theta4, t4b)),
                'Solver.solve_batch': max(adiff(t3s, t3b), adiff(t4s, t4b)),
            },
            'all_ok': bool(np.all(ff.ok) and np.all(bb.ok)),
        }
        out.append(row)
    return out


# =============================================================================================
# cost against what the scene asks: the excavator with one output vs all
# =============================================================================================


def bench_outputs(sizes: Sizes) -> list[dict]:
    from ..core.solver import Solver

    mech = load_scene('excavator')
    cmds = sweep_inputs(mech, sizes.sweep)
    cols = batch_columns(cmds, sizes.batch)
    cases = [
        (['Z1_rod'], 'Z1_rod (boom cylinder rod link)'),
        (['A'], 'A (boom cylinder pin, near the base)'),
        (['L'], 'L (bucket lip: needs every loop)'),
        (None, 'all outputs (default)'),
    ]
    out: list[dict[str, Any]] = []
    steppers: list[SolverStepper] = []
    batches: dict[str, Callable[[], Any]] = {}
    for k, (outputs, label) in enumerate(cases):
        cf = Solver(mech, outputs=outputs, method='closed_form')
        nw = Solver(mech, outputs=outputs, method='newton')
        steppers += [SolverStepper(cf, len(cmds)), SolverStepper(nw, len(cmds))]
        batches[str(k)] = functools.partial(
            Solver(mech, outputs=outputs, method='closed_form').solve_batch, cols
        )
        out.append(
            {
                'outputs': outputs,
                'label': label,
                'plan_steps': len(cf.plan.steps),
                'links_placed': len(cf.plan.placed_links),
                'newton_unknowns': nw.system.n,
            }
        )
    run_interleaved(steppers, cmds, sizes.repeats)
    per = time_batches(batches, sizes.batch, sizes.batch_repeats)
    for k, row in enumerate(out):
        cf_step, nw_step = steppers[2 * k], steppers[2 * k + 1]
        row.update(
            {
                'closed_form_scalar_us': cf_step.median_us(),
                'closed_form_failures': cf_step.fails,
                'newton_scalar_us': nw_step.median_us(),
                'newton_failures': nw_step.fails,
                'closed_form_batch_us': per[str(k)],
            }
        )
    return out
