"""The redraw closes its loops with the Newton module's solve (issue 25, every rule once): the
redrawn pose meets the Newton tolerance, 1e-12 of the length scale, in every joint, stated length
and held actuator, each checked here by plain distances and angles of the redrawn points; and
no second closure solver (scipy's least squares) is used on the way."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from linkage_ros.bench.scaling import LENGTHS, four_bars_scene
from linkage_ros.core.model import redraw
from linkage_ros.core.model.scene import Scene
from linkage_ros.core.newton import scalar

TOL = 1e-12  # of the length scale: the Newton solves' closure tolerance, per residual row
#: a joint's miss as a distance: its x and y rows each within TOL
JOINT_TOL = math.sqrt(2) * TOL


@pytest.fixture
def newton_only(monkeypatch):
    """Counts the Newton module's solves; scipy's least squares refuses to run."""
    import scipy.optimize

    calls = [0]
    solve = scalar.solve

    def counted(*args, **kwargs):
        calls[0] += 1
        return solve(*args, **kwargs)

    def refused(*args, **kwargs):
        raise AssertionError('a redraw closed its loops with scipy least_squares')

    assert redraw.solve is scalar.solve  # the Newton module's own, as the redraw calls it
    monkeypatch.setattr(redraw, 'solve', counted)
    monkeypatch.setattr(scipy.optimize, 'least_squares', refused)
    return calls


def _dist(mech, p, q):
    (px, py), (qx, qy) = mech.points[p], mech.points[q]
    return math.hypot(float(px) - float(qx), float(py) - float(qy))


def _angle(mech, p, q):
    (px, py), (qx, qy) = mech.points[p], mech.points[q]
    return math.atan2(float(qy) - float(py), float(qx) - float(px))


# the fixture's patches hold for every example; each example counts its own solves
@settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    coupler=st.floats(0.22, 0.32),
    rocker=st.floats(0.17, 0.26),
    crank=st.floats(0.08, 0.12),
)
def test_a_redrawn_four_bar_closes_to_the_newton_tolerance(newton_only, coupler, rocker, crank):
    # three independent four-bars (the 2nd and 3rd unchanged): every point is read off the
    # first link carrying it, so a joint's miss shows as a distance off its link's length
    scene = four_bars_scene(3)
    drawn = Scene.from_dict(four_bars_scene(3)).mechanism
    stated = {'coupler_0.A_0-B_0': coupler, 'rocker_0.O4_0-B_0': rocker, 'crank_0.O2_0-A_0': crank}
    before = newton_only[0]
    mech = Scene.from_dict(scene, dimensions=stated).mechanism
    assert newton_only[0] > before
    L = mech.length_scale
    want = dict(zip(('O2_0-O4_0', 'O2_0-A_0', 'A_0-B_0', 'O4_0-B_0'), LENGTHS))
    want.update({'O2_0-A_0': crank, 'A_0-B_0': coupler, 'O4_0-B_0': rocker})
    for pair, length in want.items():
        assert abs(_dist(mech, *pair.split('-')) - length) <= JOINT_TOL * L, pair
    for k in (1, 2):  # untouched four-bars keep their drawn pose
        for p in ('A', 'B'):
            (x, y), (x0, y0) = mech.points[f'{p}_{k}'], drawn.points[f'{p}_{k}']
            assert math.hypot(x - x0, y - y0) <= JOINT_TOL * L
    # the crank held at its drawn angle, the rocker on its drawn side of A O4
    assert abs(math.remainder(_angle(mech, 'O2_0', 'A_0') - 0.3, math.tau)) <= TOL
    ax, ay = mech.points['A_0']
    ox, oy = mech.points['O4_0']
    bx, by = mech.points['B_0']
    side = (ox - ax) * (by - ay) - (oy - ay) * (bx - ax)
    dax, day = drawn.points['A_0']
    dbx, dby = drawn.points['B_0']
    drawn_side = (ox - dax) * (dby - day) - (oy - day) * (dbx - dax)
    assert side * drawn_side > 0


def test_a_redrawn_offset_slider_closes_to_the_newton_tolerance(newton_only):
    # the general-form slider-crank: new rod length and line offset; the slider point on its
    # new line (distance from the line through O2 along +x), the rod at its length, the crank
    # at its drawn angle and length
    th, r, rod0, rod1, e1 = 1.1, 0.1, 0.3, 0.32, 0.05
    ax, ay = r * math.cos(th), r * math.sin(th)
    gen = {
        'points': {'O2': [0.0, 0.0], 'A': [ax, ay], 'B': [ax + math.sqrt(rod0**2 - ay**2), 0.0]},
        'links': {'ground': ['O2'], 'crank': ['O2', 'A'], 'rod': ['A', 'B'], 'block': ['B']},
        'sliders': [
            {
                'name': 'slide',
                'guide': 'ground',
                'slider': 'block',
                'point': 'B',
                'direction': 0.0,
                'origin': 'O2',
            }
        ],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }
    mech = Scene.from_dict(gen, dimensions={'slide.offset': e1, 'rod.A-B': rod1}).mechanism
    assert newton_only[0] > 0
    L = mech.length_scale
    # B is read off the rod: its joint with the block's B, then the block's B off the line
    assert abs(float(mech.points['B'][1]) - e1) <= (JOINT_TOL + TOL) * L
    assert abs(_dist(mech, 'A', 'B') - rod1) <= JOINT_TOL * L
    assert abs(_dist(mech, 'O2', 'A') - r) <= JOINT_TOL * L
    assert abs(math.remainder(_angle(mech, 'O2', 'A') - th, math.tau)) <= TOL
    assert float(mech.points['B'][0]) > float(mech.points['A'][0])  # the drawn side
