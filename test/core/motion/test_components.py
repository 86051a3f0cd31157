"""Big scenes (issue 27): each actuator's range is scanned on the independent part of the scene
it moves (core.motion.components). Checked against the cosine rule written here: a scene of
three independent four-bars on one ground, one a crank-rocker (its crank turns fully), two
with a crank that stops where coupler and rocker stretch out (|A O4| = coupler + rocker), one of
those two also limited by the scene."""

from __future__ import annotations

import math

import pytest
from scenes import load

from linkage_ros.core import motion
from linkage_ros.core.model import Scene
from linkage_ros.core.motion.components import actuator_parts

# (ground, crank, coupler, rocker) m: Grashof crank-rocker, and a non-Grashof chain whose
# crank reaches |A O4| = coupler + rocker at cos(theta) = (g^2 + c^2 - (q + r)^2) / (2 g c)
CRANK_ROCKER = (0.30, 0.10, 0.25, 0.20)
STOPPING = (0.30, 0.20, 0.15, 0.22)


def _four_bar(k: int, lengths, theta: float) -> tuple[dict, dict, dict]:
    """Points, links and actuator of four-bar ``k`` drawn at crank angle ``theta``, 1 m above
    the previous one; B on the left of A -> O4."""
    g, c, q, r = lengths
    y0 = float(k)
    ax, ay = c * math.cos(theta), y0 + c * math.sin(theta)
    dx, dy = g - ax, y0 - ay
    d = math.hypot(dx, dy)
    along = (q * q - r * r + d * d) / (2 * d)
    off = math.sqrt(q * q - along * along)
    b = [ax + (along * dx - off * dy) / d, ay + (along * dy + off * dx) / d]
    pts = {f'O2_{k}': [0.0, y0], f'O4_{k}': [g, y0], f'A_{k}': [ax, ay], f'B_{k}': b}
    links = {
        f'crank_{k}': [f'O2_{k}', f'A_{k}'],
        f'coupler_{k}': [f'A_{k}', f'B_{k}'],
        f'rocker_{k}': [f'O4_{k}', f'B_{k}'],
    }
    act = {'type': 'angle', 'link': f'crank_{k}', 'pivot': f'O2_{k}', 'toward': f'A_{k}'}
    return pts, links, act


def three_parts() -> Scene:
    points: dict = {}
    links: dict = {'ground': []}
    actuators: dict = {}
    for k, (lengths, theta, lim) in enumerate(
        [(CRANK_ROCKER, 1.0, {}), (STOPPING, 0.5, {}), (STOPPING, -0.2, {'min': -1.0})]
    ):
        pts, lk, act = _four_bar(k, lengths, theta)
        points.update(pts)
        links['ground'] += [f'O2_{k}', f'O4_{k}']
        links.update(lk)
        actuators[f'crank_{k}'] = act | lim
    return Scene.from_dict(
        {
            'name': 'three',
            'points': points,
            'ground': 'ground',
            'links': links,
            'actuators': actuators,
        }
    )


def test_each_part_is_its_own_four_bar():
    mech = three_parts().mechanism
    parts = actuator_parts(mech)
    for k in range(3):
        part = parts[f'crank_{k}']
        assert set(part.links) == {'ground', f'crank_{k}', f'coupler_{k}', f'rocker_{k}'}
        assert list(part.actuators) == [f'crank_{k}']
        assert part.length_scale == mech.length_scale  # tolerances as on the whole scene
    # a connected scene is one part: the mechanism itself
    exc = load('excavator')
    assert all(p is exc for p in actuator_parts(exc).values())


def test_ranges_of_a_split_scene_against_the_cosine_rule():
    mech = three_parts().mechanism
    g, c, q, r = STOPPING
    stop = math.acos((g * g + c * c - (q + r) ** 2) / (2 * g * c))
    got = motion.actuator_ranges(mech)
    assert got['crank_0']['full_turn'] and (got['crank_0']['min'], got['crank_0']['max']) == (
        None,
        None,
    )
    one, two = got['crank_1'], got['crank_2']
    assert one['min'] == pytest.approx(-stop, abs=1e-12)
    assert one['max'] == pytest.approx(stop, abs=1e-12)
    assert one['min_source'] == one['max_source'] == 'toggle'
    assert two['min'] == -1.0 and two['min_source'] == 'limit'
    assert two['max'] == pytest.approx(stop, abs=1e-12) and two['max_source'] == 'toggle'
    # the split changes nothing: the whole scene scanned per actuator gives the same report
    for name, info in got.items():
        assert motion.actuator_range(mech, name) == info
    assert motion.input_ranges(mech) == {n: (i['min'], i['max']) for n, i in got.items()}
