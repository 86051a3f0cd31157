"""Newton follows the smooth motion through a change point, as the closed form does.

At a change point (s + l = p + q: seed 000's parallelogram and its kin) the dyad's two
solutions cross, and the mechanism moves on smoothly in the other sign (SCENES.md). A Newton
sweep of the four-bar 0.5 / 0.2 / 0.6 / 0.3 through crank 0 stayed in its sign and turned back
onto the other solution curve, every row OK (rocker +0.0915 at crank 0.111, where the motion
has -0.2385): the det J guard held it there (det J changes sign across the crossing), and at a
sample exactly on the crossing its predictor is blind (J singular). Near a toggle, where the
plan is complete, Newton now answers in the sign the closed form's continuity takes.

Oracle: the 50-digit four-bar (oracles.fourbar) on each side, the side switched at every
change point (crank a multiple of pi for the parallelogram, of 2 pi for the other)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracles import fourbar
from scenes import four_bar

from linkage_ros.core.solver import Solver

CASES = {
    # (lengths: ground, crank, coupler, rocker; the crank values where the sides swap)
    'change_point': ((0.5, 0.2, 0.6, 0.3), 2 * math.pi),
    'parallelogram': ((0.3, 0.1, 0.3, 0.1), math.pi),
}


def _side_flips(t0: float, t: float, period: float) -> int:
    """How many change points (multiples of ``period``) lie in (t0, t]."""
    return math.floor(t / period) - math.floor(t0 / period)


@pytest.mark.parametrize(
    ('name', 'samples'),
    [
        ('change_point', 10),
        ('change_point', 50),
        ('change_point', 97),
        ('change_point', 700),
        ('parallelogram', 50),
        ('parallelogram', 97),  # (a sample on crank pi: Newton's predictor is blind there)
        ('parallelogram', 700),
    ],
)
def test_newton_moves_on_through_a_change_point_as_the_motion_does(name, samples):
    """(A step that lands on neither side within the dyad's near-toggle zone may land on the
    other curve: the parallelogram's ten steps from -1 to 1 take it from the anti-parallelogram
    onto the parallelogram at crank 0. SCENES.md says so: steps through a change point must be
    fine.)"""
    lengths, period = CASES[name]
    t0 = math.pi / 3 if samples > 10 else -1.0
    t1 = t0 + (4 * math.pi if samples > 10 else 2.0)
    mech = four_bar(*lengths, input=t0)
    newton = Solver(mech, method='newton')
    first = newton.solve({'crank': t0})
    assert first.success
    side0 = next(
        b
        for b in (1, -1)
        if abs(
            math.remainder(
                float(fourbar(*lengths, t0, b)['theta4']) - first.links['rocker'], 2 * math.pi
            )
        )
        < 1e-9
    )
    for t in np.linspace(t0, t1, samples)[1:]:
        r = newton.solve({'crank': float(t)})
        assert r.success, (t, r.reason)
        side = side0 * (-1) ** _side_flips(t0, float(t), period)
        want = float(fourbar(*lengths, float(t), side)['theta4'])
        # (on a crossing itself J is singular: Newton's answer there is good to sqrt(tol))
        on = abs(math.remainder(float(t), period)) < 1e-9
        tol = 1e-5 if on else 1e-9
        assert abs(math.remainder(r.links['rocker'] - want, 2 * math.pi)) < tol, (t, side)
