"""Newton's continuation turns an angle input the long way round where the short way crosses
inputs at which the mechanism does not assemble: a non-Grashof crank rocks within (-2.43, 2.43)
rad, so from -2.2 to 2.0 it turns through 0, not past +-pi. The step was refused as "assembles,
but not from the current configuration on its branch" (solve_batch refused 17 of 1021 such
rows). Oracle: the closed form on the same branch (an independent algorithm: circle
intersections), and a step that must cross a toggle either way is still refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scenes

from linkage_ros.core.analysis import fourbar_toggle_angles
from linkage_ros.core.solver import Solver

NON_GRASHOF = (
    0.30,
    0.20,
    0.25,
    0.22,
)  # config/four_bar_non_grashof.yaml: ground crank coupler rocker


@pytest.mark.parametrize('branch', ['+', '-'])
@pytest.mark.parametrize('start, end', [(-2.2, 2.0), (2.3, -2.35), (-1.0, 2.42), (2.0, -2.0)])
def test_a_crank_that_cannot_pass_pi_turns_the_long_way_on_its_branch(branch, start, end):
    mech = scenes.load('four_bar_non_grashof')
    toggle = fourbar_toggle_angles(*NON_GRASHOF)[0]  # the circuit: (-toggle, toggle)
    assert abs(toggle - 2.4303) < 1e-4
    assert max(abs(start), abs(end)) < toggle  # the premise: both on the circuit
    assert abs(end - start) > math.pi  # and the short way round crosses +-pi, outside it
    newton = Solver(mech, method='newton', branch=branch)
    closed = Solver(mech, method='closed_form', branch=branch)
    assert newton.solve({'crank': start}).success
    got = newton.solve({'crank': end})
    want = closed.solve({'crank': end})
    assert got.success, got.reason
    assert got.branch == want.branch == branch
    for p, xy in want.points.items():
        assert math.dist(got.points[p], xy) <= 1e-9 * mech.length_scale, p  # (2.42: near a toggle)


def test_the_same_rows_in_a_batch_are_answered():
    mech = scenes.load('four_bar_non_grashof')
    newton = Solver(mech, method='newton', branch='+')
    closed = Solver(mech, method='closed_form', branch='+')
    rng = np.random.default_rng(27)
    a, b = rng.uniform(-2.3, 2.3, 400), rng.uniform(-2.3, 2.3, 400)
    start = newton.solve_batch({'crank': a})
    got = newton.solve_batch({'crank': b}, start=start)
    want = closed.solve_batch({'crank': b})
    assert start.ok.all() and want.ok.all()
    assert got.ok.all(), [r for r in got.reason if r][:2]
    assert np.max(np.abs(got.points['B'] - want.points['B'])) <= 1e-11


def test_a_step_that_crosses_a_toggle_either_way_is_still_refused():
    """A crank-rocker driven past a toggle: a triple rocker (all-rocker, non-Grashof) from its
    circuit's one side to an input where it does not assemble at all."""
    mech = scenes.load('four_bar_non_grashof')
    newton = Solver(mech, method='newton', branch='+')
    assert newton.solve({'crank': 2.0}).success
    r = newton.solve({'crank': math.pi})  # beyond the toggles: no assembly at all
    assert not r.success and 'assemble' in r.reason
