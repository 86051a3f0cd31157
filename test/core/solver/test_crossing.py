"""The closed form's continuity rule near and at a change point (core.solver.crossing): a
crank-rocker a hair inside the Grashof limit passes near folding flat but cannot leave its
circuit, however coarse the commands; one exactly at the limit passes through the fold, and
continuity may take the other branch there. Oracles: the 50-digit four-bar (oracles.fourbar)
on one fixed branch, and its margin at the fold."""

from __future__ import annotations

import math

import numpy as np
import oracles as orc
import pytest
from scenes import four_bar

from linkage_ros.core.execute import CROSSING_MARGIN
from linkage_ros.core.scalar_plan import program
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.crossing import lowest_margins

#: s + l = p + q - eps: the crank-rocker's dyad margin dips to ~0.55 sqrt(eps) at crank 0
NEAR = [1e-4, 1e-6, 1e-8, 1e-10]


def lengths(eps: float) -> tuple[float, float, float, float]:
    return (4.0, 1.5, 5.5 - eps, 3.0)  # 1.5 + 5.5 = 4 + 3: the change point at eps = 0


def oracle_branch(L, t: float, point: tuple[float, float]) -> int:
    """The oracle's branch (+1 / -1) whose B is ``point`` at crank t."""
    return min((1, -1), key=lambda b: _gap(orc.fourbar(*L, t, b)['B'], point))


def _gap(p, q) -> float:
    return math.hypot(float(p[0]) - q[0], float(p[1]) - q[1])


@pytest.mark.parametrize('method', ['closed_form', 'auto'])
@pytest.mark.parametrize('steps', [241, 61, 13])
@pytest.mark.parametrize('eps', NEAR)
def test_near_a_change_point_the_circuit_is_kept(eps, steps, method):
    """Twice round in steps of 1.5 to 30 deg, continuous: every B is the oracle's on the
    first answer's branch (the closed form took the other circuit at every crank from 1e-4 in,
    240 of 480 answers, before the crossing test)."""
    L = lengths(eps)
    s = Solver(four_bar(L), method=method)
    ts = list(np.linspace(-math.pi, math.pi, steps))[:-1] * 2
    first = s.solve({'crank': ts[0]})
    assert first.success
    b = oracle_branch(L, ts[0], first.points['B'])
    low = 1.0
    for t in ts:
        r = s.solve({'crank': t})
        assert r.success, (t, r.reason)
        assert r.branch == first.branch, (t, r.branch)
        want = orc.fourbar(*L, t, b)['B']
        assert _gap(want, r.points['B']) <= 1e-9 * 5.5 / max(r.margin, 1e-6), (t, r.margin)
        low = min(low, r.margin)
    if steps == 241:  # (the finest sweep lands beside crank 0, where the dyad folds nearest)
        assert low < 10 * math.sqrt(eps)


def test_at_the_change_point_continuity_passes_through_the_fold():
    """eps = 0: the dyad folds flat at crank 0 and both continuations are motions; continuity
    takes the one the motion's direction predicts, so the sweep crosses to the other branch
    there (the test above would fail), with B moving in steps of the crank's size."""
    L = lengths(0.0)
    s = Solver(four_bar(L), method='closed_form')
    ts = np.linspace(-0.6, 0.6, 25)
    got = [s.solve({'crank': float(t)}) for t in ts]
    assert all(r.success for r in got)
    assert got[0].branch != got[-1].branch
    step = float(ts[1] - ts[0])
    for a, r in zip(got, got[1:]):
        assert _gap(a.points['B'], r.points['B']) <= 10 * step  # (|dB/dcrank| ~ 1.5-3 m/rad)


@pytest.mark.parametrize('eps', NEAR + [0.0])
def test_lowest_margin_between_two_commands_is_the_oracles_at_the_fold(eps):
    """The margin followed between crank -0.05 and 0.3 on one branch: its lowest is the
    oracle's at crank 0 (its minimum: A nearest O4's far circle), to the rounding of a margin
    near 0 (~sqrt(ulp))."""
    L = lengths(eps)
    s = Solver(four_bar(L), method='closed_form', branch='+')
    c = s.compiled
    start, end = c.parse({'crank': -0.05}), c.parse({'crank': 0.3})
    low = lowest_margins(program(c.plan), c, start, end, (1,), [0])[0]
    want = float(orc.fourbar(*L, 0.0, 1)['margin'])
    assert abs(low - want) <= 1e-7, (low, want)
    assert (low <= CROSSING_MARGIN) == (eps == 0.0)
