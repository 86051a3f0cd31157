"""Shared by the batched Newton kernel tests (test_newton_batch*.py): the point-known systems,
the tolerance, cond as LoopSystem.cond reports it, a shipped scene's mechanism, per-spec value
arrays from rows, the scalar Solver's warm-started sweeps and the check of a batch against them.
"""

import functools

import numpy as np
import pytest

from linkage_ros.bench import sweep_inputs
from linkage_ros.core.model import Scene
from linkage_ros.core.newton import COND_EXACT, NEAR_SINGULAR_COND
from linkage_ros.core.quantities import PointSpec
from linkage_ros.core.solver import Solver
from linkage_ros.resources import scene_path

#: Newton-mode systems with point specs (knowns), none of which the actuators give
#: (a point on a moving link: 'point:A' would be singular, A's owner being a crank)
POINT_KNOWNS = [
    ('excavator', ('O2', 'point:J')),
    ('front_loader', ('point:E',)),
    ('plagiograph', ('point:D',)),
]

TOL = 1e-12


def reported_cond(sy, Js):
    """cond as LoopSystem.cond reports it, computed independently: the exact 1-norm condition
    number of the scale-free J (numpy) below COND_EXACT, else the exact scaled 2-norm one."""
    c1 = np.linalg.cond(Js, 1)
    return c1 if c1 < COND_EXACT else sy.scaled_cond(Js)


def scene(name):
    return Scene.from_yaml(scene_path(name)).mechanism


def stack(sy, rows):
    """Per-spec value arrays ((N,) or (N, 2)) from per-row value lists."""
    out = []
    for i, s in enumerate(sy.specs):
        col = [np.asarray(r[i], float) for r in rows]
        out.append(
            np.array(col, float).reshape(len(rows), *((2,) if isinstance(s, PointSpec) else ()))
        )
    return out


def pick(values, idx):
    """Rows idx of per-spec value arrays."""
    return [np.asarray(v)[idx] for v in values]


@functools.cache
def scalar_sweep(name, n):
    """The Solver (newton) warm-started one command at a time over the bench's closed path:
    (system, x_k (K, n), det_sign_k (K,), values_k per row)."""
    s = Solver(scene(name), method='newton')
    xs, signs, vals = [], [], []
    for cmd in sweep_inputs(s.mech, n):
        r = s.solve(cmd)
        assert r.success, r.reason
        xs.append(s.continuity.history[-1].x_all.copy())
        signs.append(s.continuity.history[-1].det_sign)
        vals.append(s.parse(cmd))
    return s.system, np.array(xs), np.array(signs), vals


def check_against_sweep(sy, xs, signs, vals, b, rows):
    """Each ok row among ``rows`` (indices of the step k - 1 -> k) is the scalar x_k on the
    same det J side, at its residual, with the slogdet sign and scaled_cond of the scalar
    Jacobian there."""
    k = np.asarray(rows) + 1
    ok = b.ok
    gap = np.abs(b.x[ok] - xs[k][ok]) / sy.step_scale
    assert gap.max(initial=0.0) <= 1e-10, gap.max()
    assert np.all(b.residual[ok] <= TOL)
    assert np.array_equal(b.det_sign[ok], signs[k][ok])
    for i in np.flatnonzero(ok):
        vk = vals[k[i]]
        _, Js, rs = sy.evaluate_scaled(b.x[i], vk, None)
        # a few ulps apart at the rounding floor: wrap and atan2 are vectorised separately
        assert b.residual[i] == pytest.approx(rs, rel=1e-12, abs=2e-15)
        assert b.det_sign[i] == int(np.linalg.slogdet(Js)[0])
        assert b.cond[i] == pytest.approx(reported_cond(sy, Js), rel=1e-10)
        assert b.cond[i] < NEAR_SINGULAR_COND
