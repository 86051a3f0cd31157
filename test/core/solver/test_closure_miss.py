"""Refusals report the closure miss at the input asked for (issue 18): a Newton walk that stops
part-way to an unreachable input used to report the residual of the last input it tried on the
way (a few 1e-5 of the length scale just past the edge of reach), however far beyond reach the
input was.

The case: the non-Grashof four-bar commanded by its coupler's angle theta3, which the dyad plan
does not place (a hybrid solve: Newton for the loop). Oracle, written here: with theta3 fixed,
A must lie on the crank circle (O2, l2) and on the rocker circle moved by the coupler,
(O4 - l3 e^(i theta3), l4); they miss by g = max(|c| - (l2 + l4), |l2 - l4| - |c|). Any
configuration must open the loop by g in total over at most five error sources (the joints at
O2, A, B and O4, and the coupler's own angle row, which moves the circle by at most l3 <= L per
radian), each at most sqrt(2) times the largest row: the least miss's largest row lies in
[g / (5 sqrt 2), g]."""

from __future__ import annotations

import cmath
import math
import re

import numpy as np
import pytest
from scenes import load

from linkage_ros.core.solver import Solver

L1, L2, L3, L4 = 0.30, 0.20, 0.25, 0.22  # config/four_bar_non_grashof.yaml


def gap(theta3: float) -> float:
    c = L1 - L3 * cmath.exp(1j * theta3)
    return max(abs(c) - (L2 + L4), abs(L2 - L4) - abs(c))


def reported_miss(reason: str) -> float:
    m = re.search(r'misses closing by ([0-9.e+-]+) m', reason)
    assert m, reason
    return float(m.group(1))


def solver():
    s = Solver(load('four_bar_non_grashof'), knowns=['coupler'])
    assert s.mode == 'hybrid' and not s.full_plan.complete  # the case this is about
    return s


@pytest.mark.parametrize('theta3', [1.8, 2.0, 2.5, 3.0, -2.5])
def test_refusal_reports_the_miss_at_the_input(theta3):
    res = solver().solve({'coupler': theta3}, commit=False)
    assert not res.success
    g = gap(theta3)
    assert g > 0
    got = reported_miss(res.reason)
    assert g / (5 * math.sqrt(2)) <= got <= g * (1 + 1e-9), (g, got, res.reason)
    # what stopped the walk is still said, after the miss
    assert 'continuation from the current configuration stopped' in res.reason


def test_the_miss_grows_with_the_distance_beyond_reach():
    s = solver()
    thetas = np.linspace(1.9, 3.1, 5)
    assert all(np.diff([gap(t) for t in thetas]) > 0)
    misses = [reported_miss(s.solve({'coupler': t}, commit=False).reason) for t in thetas]
    assert all(b > a for a, b in zip(misses, misses[1:])), misses
