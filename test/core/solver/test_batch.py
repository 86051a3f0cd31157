"""Solver.solve_batch(start=): the rows the vectorised Newton path declines.

Oracle: the bench's 50-digit loop-closure solution (bench.reference.MpReference: point
positions as unknowns, mpmath Newton from the dyad plan's answer), a different formulation in
other arithmetic.

Would fail if: a declined row were solved from its start without the start's Jacobian
factorisation (the careful path alone stops at max|F| / L <= tol = 1e-12, which left the
excavator's points 3.7e-13 of its length scale off; the fast path from the predicted answer
goes on to 1e-14, as a scalar sweep does).
"""

from __future__ import annotations

import numpy as np

from linkage_ros.bench import sweep_inputs
from linkage_ros.bench.reference import MpReference, point_errors, reference_points
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.resources import scene_path

#: the fast path leaves max|F| / L <= FAST_MARGIN * tol = 1e-14; with cond(J) ~ 500 on these
#: rows the points sit within ~1e-15 of the length scale (measured 1.3e-15): a 7x margin for
#: other CPUs and BLAS kernels, and 25x below what the careful path alone left (3.7e-13)
DECLINED_ROW_ERROR = 1e-14


def test_declined_rows_are_as_exact_as_a_warm_sweep():
    """The excavator's closed sweep as 200 instances, each warm-started from its answer at the
    input before it (as `linkage bench` times it): the rows the vectorised path declines (a
    first Newton step that does not cut max|F| tenfold) are answered by solve_one from their
    start, to the reference within DECLINED_ROW_ERROR of the length scale."""
    mech = Scene.from_yaml(scene_path('excavator')).mechanism
    cmds = sweep_inputs(mech, 200)
    solver = Solver(mech, method='newton')
    cols = {a: np.array([c[a] for c in cmds], float) for a in mech.actuators}
    start = solver.solve_batch({a: np.roll(v, 1) for a, v in cols.items()})
    got = solver.solve_batch(cols, start=start)
    assert got.ok.all() and got.careful is not None
    rows = np.flatnonzero(got.careful)
    assert 4 <= len(rows) <= 40, len(rows)  # the case this test is about occurs, and is rare
    closed = Solver(mech, method='closed_form')
    starts = [closed.solve(cmds[i]).points for i in rows]
    hi, lo, worst = reference_points(MpReference(mech), [cmds[i] for i in rows], starts)
    assert worst < 1e-40
    names = list(mech.points)
    pts = np.stack([got.points[p] for p in names], axis=1)[rows]
    err = point_errors(pts, hi, lo, mech.length_scale)
    assert np.all(err <= DECLINED_ROW_ERROR), err.max()
