"""A point given by its distances from two points (issue 18: designers give a coupler point by
two distances, not coordinates). Oracle: the two-circle construction at 50 digits (mpmath),
written here; both sides, exact tangency, just past it, scales 1e-6..1e6."""

from __future__ import annotations

import math

import mpmath as mp
import pytest

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver


def oracle(a, b, r1, r2, side):
    """The point r1 from a and r2 from b, left (+1) or right (-1) of a -> b, at 50 digits."""
    with mp.workdps(50):
        ax, ay, bx, by = (mp.mpf(v) for v in (*a, *b))
        r1, r2 = mp.mpf(r1), mp.mpf(r2)
        d = mp.sqrt((bx - ax) ** 2 + (by - ay) ** 2)
        x = (d * d + r1 * r1 - r2 * r2) / (2 * d)
        h = mp.sqrt(max(r1 * r1 - x * x, 0))
        ux, uy = (bx - ax) / d, (by - ay) / d
        return (float(ax + x * ux - side * h * uy), float(ay + x * uy + side * h * ux))


def four_bar(scale, p_spec):
    return {
        'name': 'fb',
        'points': {
            'O2': [0.0, 0.0],
            'A': [0.05 * scale, 0.0866 * scale],
            'B': [0.32 * scale, 0.19 * scale],
            'O4': [0.3 * scale, 0.0],
            'P': p_spec,
        },
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': ['A', 'B', 'P'],
            'rocker': ['O4', 'B'],
        },
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }


@pytest.mark.parametrize('scale', [1e-6, 1e-3, 1.0, 1e3, 1e6])
@pytest.mark.parametrize('side', ['left', 'right'])
def test_a_coupler_point_by_two_distances_is_the_two_circle_point(scale, side):
    r1, r2 = 0.2 * scale, 0.15 * scale
    spec = {'distances': {'A': r1, 'B': r2}, 'side': side}
    mech = Scene.from_dict(four_bar(scale, spec)).mechanism
    a, b = (0.05 * scale, 0.0866 * scale), (0.32 * scale, 0.19 * scale)
    want = oracle(a, b, r1, r2, 1 if side == 'left' else -1)
    got = tuple(float(v) for v in mech.points['P'])
    assert math.dist(got, want) <= 4e-16 * scale, (got, want)
    # the same scene drawn with those coordinates moves P alike
    drawn = Scene.from_dict(four_bar(scale, list(want))).mechanism
    s1, s2 = Solver(mech), Solver(drawn)
    for theta in (0.3, 1.2, 2.5, -1.0):
        p1, p2 = s1.solve({'crank': theta}).points['P'], s2.solve({'crank': theta}).points['P']
        assert math.dist(p1, p2) <= 1e-12 * mech.length_scale


def test_tangent_circles_give_their_one_point_and_circles_apart_are_refused():
    a, b = (0.05, 0.0866), (0.32, 0.19)
    d = math.dist(a, b)
    for side in ('left', 'right'):  # exactly tangent: on the line, either side
        spec = {'distances': {'A': 0.25 * d, 'B': 0.75 * d}, 'side': side}
        got = Scene.from_dict(four_bar(1.0, spec)).mechanism.points['P']
        want = oracle(a, b, 0.25 * d, 0.75 * d, 1)
        assert math.dist(tuple(got), want) <= 1e-15
    spec = {'distances': {'A': 0.25 * d, 'B': 0.75 * d * (1 - 1e-9)}}
    with pytest.raises(SceneError, match=r'points\.P\.distances: circles of .* do not meet'):
        Scene.from_dict(four_bar(1.0, spec))


@pytest.mark.parametrize(
    'a, b, r1, r2',
    [
        ((0.1, 0.7), (0.4, 1.1), 0.2, 0.3),  # 0.5 apart as written, 0.5000000000000001 in floats
        ((0.3, 0.4), (0.3, 0.55), 0.1, 0.05),  # 0.15 apart as written, 0.15000000000000002
    ],
)
def test_circles_tangent_as_written_in_decimals_give_their_one_point(a, b, r1, r2):
    """SCENES.md: a dyad within one unit of rounding of a tangency lands on it; decimal
    coordinates put these circles (r1 + r2 = their distance as written) a rounding apart, and
    they were refused as "do not meet". The point is the tangency's, on the line through the
    centres (50-digit oracle of the decimals as written)."""
    scene = {
        'name': 'tangent',
        'points': {'A': list(a), 'B': list(b), 'Q': {'distances': {'A': r1, 'B': r2}}},
        'links': {'ground': ['A', 'B', 'Q']},
    }
    got = Scene.from_dict(scene).mechanism.points['Q']
    with mp.workdps(50):
        ax, ay, bx, by, r = (mp.mpf(str(v)) for v in (*a, *b, r1))
        d = mp.sqrt((bx - ax) ** 2 + (by - ay) ** 2)
        want = (float(ax + r * (bx - ax) / d), float(ay + r * (by - ay) / d))
    assert math.dist(tuple(float(v) for v in got), want) <= 1e-15
    # a real miss, far beyond rounding, is still refused
    scene['points']['Q'] = {'distances': {'A': r1 * (1 - 1e-9), 'B': r2}}
    with pytest.raises(SceneError, match=r'points\.Q\.distances: circles of .* do not meet'):
        Scene.from_dict(scene)


@pytest.mark.parametrize(
    'spec, match',
    [
        (
            {'distances': {'A': 0.1, 'Q': 0.2}},
            r"points\.P\.distances: names unknown point\(s\) \['Q'\]",
        ),
        (
            {'distances': {'A': 0.1}},
            r'points\.P\.distances: must give the distances from exactly two',
        ),
        ({'distances': {'A': 0.1, 'B': -0.2}}, r'points\.P\.distances\.B: must be > 0'),
        (
            {'distances': {'A': 0.1, 'B': 0.2}, 'side': 'up'},
            r"points\.P\.side: must be 'left' or 'right'",
        ),
        ({'distances': {'A': 0.1, 'B': 0.2}, 'sid': 'left'}, r'points\.P\.sid: unknown key'),
        ({'distances': [0.1, 0.2]}, r'points\.P\.distances: must map two point names to m'),
    ],
)
def test_bad_distance_specs_are_refused_naming_the_key(spec, match):
    with pytest.raises(SceneError, match=match):
        Scene.from_dict(four_bar(1.0, spec))


def test_points_placed_from_each_other_are_a_cycle():
    data = four_bar(1.0, {'distances': {'A': 0.1, 'Q': 0.2}})
    data['points']['Q'] = {'distances': {'P': 0.1, 'B': 0.2}}
    data['links']['coupler'] = ['A', 'B', 'P', 'Q']
    with pytest.raises(SceneError, match=r'a cycle'):
        Scene.from_dict(data)
