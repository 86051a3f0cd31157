"""Newton continuation on four-bars next to a change point (an outside numerics reviewer's
random search): the oracle is the 50-digit four-bar of test/oracles.py (circle intersection, in
each assembly mode), written apart from the solver.

* Walking from an answer 1e-3 rad off a toggle to one 1e-6 rad off it, Newton crawled at a
  nearly singular Jacobian to its iteration cap and refused ('no assembly near the current
  configuration') an input the closed form, and a fresh Newton, assemble on the same branch.
* Two circles nearly concentric (the crank's pin ~1e-8 of the scale from the rocker's pivot)
  have a transmission margin near 0 though their two points lie far apart: an answer in mode -
  was reported as + (the fold rule's 'either mode'), its coupler pin 0.46 of the scale from
  the + answer."""

from __future__ import annotations

import math

import mpmath as mp
import pytest
from oracles import fourbar, point_error

from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.core.tolerances import NEWTON_TOL


def _four_bar(g, a, b, c):
    return Scene.from_dict(
        {'four_bar': {'ground': g, 'crank': a, 'coupler': b, 'rocker': c, 'branch': 1}}
    ).mechanism


@pytest.mark.parametrize('scale', [1.0, 175.7, 1e-4])
@pytest.mark.parametrize('off', ['1e-6', '1e-8'])
def test_a_walk_to_just_off_a_toggle_answers_what_the_closed_form_assembles(scale, off):
    g, a, b, c = (scale * v for v in (1.0, 1.0, 1.0, 1.001))
    mech = _four_bar(g, a, b, c)
    # the crank angle where |O4 A| = c - b (the toggle), from the cosine rule at 50 digits
    with mp.workdps(50):
        tau = mp.acos(1 - (mp.mpf(c) - mp.mpf(b)) ** 2 / (2 * mp.mpf(a) * mp.mpf(g)))
        before, at = float(tau + mp.mpf('1e-3')), float(tau + mp.mpf(off))
    want = fourbar(g, a, b, c, at, branch=1)
    assert want['ok']
    for branch in ('+', 'continuous'):
        solver = Solver(mech, method='newton', branch=branch)
        assert solver.solve({'crank': before}).success
        r = solver.solve({'crank': at})
        assert r.success, r.reason
        # Newton's answer: its tolerance of the scale, over the dyad's margin there
        bound = 10 * NEWTON_TOL * mech.length_scale / float(want['margin'])
        assert point_error(r.points['B'], want['B']) < bound, (branch, r.points['B'], want['B'])


def test_nearly_concentric_circles_are_no_fold_an_answer_is_in_the_mode_it_names():
    g, a, b, c = (
        0.0005923806749307536,
        0.0005923699181113655,
        0.0005930282653688682,
        0.0005930449191138532,
    )
    mech = _four_bar(g, a, b, c)
    t = 2.246223144052545e-05
    plus, minus = fourbar(g, a, b, c, t, branch=1), fourbar(g, a, b, c, t, branch=-1)
    apart = point_error(plus['B'], minus['B'])
    assert apart > 0.4 * mech.length_scale  # the two modes' pins: far apart
    for branch, want in (('+', plus), ('-', minus)):
        solver = Solver(mech, method='newton', branch=branch)
        assert solver.solve({'crank': 0.5}).success
        r = solver.solve({'crank': t})
        assert r.success, r.reason
        assert r.branch == branch
        err = point_error(r.points['B'], want['B'])
        assert err < 1e-6 * mech.length_scale, (branch, r.points['B'], want['B'], err)
        # (its side of the line O4 -> A: the mode's, read off the answer)
        ax, ay = r.points['A']
        ox, oy = r.points['O4']
        bx, by = r.points['B']
        side = (ox - ax) * (by - ay) - (oy - ay) * (bx - ax)
        assert math.copysign(1, side) == (1 if branch == '+' else -1) or abs(side) < 1e-30
