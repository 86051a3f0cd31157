"""Link oscillation ranges (``linkage range --links``) at their edges, from an adversary's
findings: a link that turns fully through the input's toggles (its angle there read to the
square root of the toggle's rounding: 2e-8 rad short of a full turn), and an extreme just inside
a limit of the input (the value at the limit was reported). Oracles: Grashof's rule, and a
four-bar written here (the rocker of O2 = 0, O4 = (ground, 0)), its extreme found on a fine grid
and refined by scipy's bounded minimiser on this closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from linkage_ros.core.model import Scene
from linkage_ros.core.motion import oscillation_range


def four_bar(**spec):
    return Scene.from_dict({'four_bar': spec}).mechanism


@pytest.mark.parametrize(
    ('lengths', 'turning'),
    [
        ((0.3, 0.25, 0.2, 0.1), 'rocker'),  # rocker shortest: it turns fully (rocker-crank)
        ((1.0, 0.9, 0.2, 0.8), 'coupler'),  # coupler shortest: Grashof double-rocker
    ],
)
def test_the_shortest_link_of_a_grashof_chain_turns_fully_through_the_toggles(lengths, turning):
    ground, crank, coupler, rocker = lengths
    mech = four_bar(ground=ground, crank=crank, coupler=coupler, rocker=rocker)
    assert oscillation_range(mech, turning) == (None, None)
    other = 'coupler' if turning == 'rocker' else 'rocker'
    lo, hi = oscillation_range(mech, other)  # its neighbour through the crank's toggles rocks
    assert lo is not None and hi is not None and 0 < hi - lo < 2 * math.pi - 1e-3


def _rocker(theta2: float, ground: float, crank: float, coupler: float, rocker: float, s: float):
    """The rocker's angle (O4 -> B) with B on side ``s`` of A -> O4 (cosine rule)."""
    ax, ay = crank * math.cos(theta2), crank * math.sin(theta2)
    dx, dy = ground - ax, -ay
    d = math.hypot(dx, dy)
    along = (d * d + coupler * coupler - rocker * rocker) / (2 * d)
    h = s * math.sqrt(max(coupler * coupler - along * along, 0.0))
    bx, by = ax + (along * dx - h * dy) / d, ay + (along * dy + h * dx) / d
    return math.atan2(by, bx - ground)


def test_an_extreme_just_inside_a_limit_is_found():
    ground, crank, coupler, rocker = 0.3, 0.1, 0.25, 0.2
    lo_lim, hi_lim = 0.5, 0.61
    mech = four_bar(ground=ground, crank=crank, coupler=coupler, rocker=rocker, input=0.55,
                    crank_limits={'min': lo_lim, 'max': hi_lim})  # fmt: skip
    got_lo, got_hi = oscillation_range(mech, 'rocker')
    # the drawn side: the one whose rocker matches the drawing's at the drawn crank angle
    drawn = math.atan2(*(np.array(mech.points['B']) - np.array(mech.points['O4']))[::-1])
    side = min((1.0, -1.0), key=lambda s: abs(_rocker(0.55, ground, crank, coupler, rocker, s) -
                                             drawn))  # fmt: skip

    def f(t: float) -> float:
        return _rocker(t, ground, crank, coupler, rocker, side)

    grid = np.linspace(lo_lim, hi_lim, 20001)
    k = int(np.argmin([f(t) for t in grid]))
    assert 0 < k < grid.size - 1  # the minimum is inside the limits
    best = minimize_scalar(f, bounds=(grid[k - 1], grid[k + 1]), method='bounded',
                           options={'xatol': 1e-12}).fun  # fmt: skip
    assert best < min(f(lo_lim), f(hi_lim)) - 1e-7  # below the value at either limit
    assert got_lo == pytest.approx(best, abs=1e-11)
    assert got_hi == pytest.approx(max(f(lo_lim), f(hi_lim), *map(f, grid)), abs=1e-9)
