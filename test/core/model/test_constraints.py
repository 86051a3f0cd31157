"""Constraints as designers state them (issue 18): a point on a line of another link at a fixed
angle (a pin in a slot), a circle tangent to a line (a roller on a flat face), and a fixed
distance between points of different links.

Oracles, written apart from the core (test/oracles.py, 50 digits): the line through the pin
whose offset from the lever's pivot is fixed (``line_through_point``: tangency to the circle of
that radius about the pivot), and the four-bar's two-circle construction. Both assembly modes,
zero offset, tangency at and near its degenerate position, scales 1e-6..1e6."""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import oracles
import pytest

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

SCALES = [1e-6, 1.0, 1e6]


def solve(mech, thetas):
    s = Solver(mech, knowns=['crank'], outputs=list(mech.points), branch='reference')
    out = []
    for t in thetas:
        r = s.solve({'crank': float(t)})
        assert r.success, (t, r.reason)
        out.append(r)
    return out


def slotted_lever(scale, offset, angle, sign, theta0=1.0, radius=None, face_offset=None):
    """A crank O2-A whose pin A runs in a line of the lever O4-C: the line is fixed in the lever
    at ``angle`` from its axis and passes ``offset`` from the pivot O4 (through Q, a lever
    point). ``sign``: which way along the line A lies from the foot of O4 (the two modes).
    With ``radius``, A is a roller's centre and Q is on the face, ``face_offset`` from O4."""
    o4 = (0.0, -0.3 * scale)
    a = (0.1 * scale * math.cos(theta0), 0.1 * scale * math.sin(theta0))
    e = offset * scale
    line = float(oracles.line_through_point(o4, a, e, sign))  # the line's direction
    axis = line - angle
    c = (o4[0] + 0.5 * scale * math.cos(axis), o4[1] + 0.5 * scale * math.sin(axis))
    # Q on the line (or the face), level with O4 along the normal
    face = (offset if face_offset is None else face_offset) * scale
    q = (o4[0] - face * math.sin(line), o4[1] + face * math.cos(line))
    # zero offset: the line through the pivot itself (the degenerate case: no Q to draw)
    through = 'Q' if face else 'O4'
    slot = {'name': 'slot', 'point': 'A', 'link': 'lever', 'through': through, 'angle': angle}
    if radius is not None:
        slot['radius'] = radius * scale
    points = {'O2': [0.0, 0.0], 'A': list(a), 'O4': list(o4), 'C': list(c)}
    if face:
        points['Q'] = list(q)
    return {
        'name': 'slotted',
        'points': points,
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'lever': ['O4', 'C'] + ['Q'] * bool(face),
        },
        'slots': [slot],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }


def lever_direction_error(res, scale, offset, angle, sign):
    """|lever axis angle - the oracle's|, the oracle: the line through A at the offset."""
    a, o4, c = res.points['A'], res.points['O4'], res.points['C']
    want = oracles.line_through_point(o4, a, offset * scale, sign) - angle
    got = math.atan2(c[1] - o4[1], c[0] - o4[0])
    return abs(math.remainder(float(mp.mpf(got) - want), 2 * math.pi))


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
@pytest.mark.parametrize(('offset', 'angle'), [(0.0, 0.0), (0.0, 0.4), (0.05, -0.3)])
def test_pin_in_slot_against_the_line_construction(scale, sign, offset, angle):
    mech = Scene.from_dict(slotted_lever(scale, offset, angle, sign)).mechanism
    assert 'slot' in mech.prismatics and 'slot_pin' in mech.links
    thetas = np.linspace(0.0, 2 * math.pi, 13)
    for res in solve(mech, thetas):
        assert lever_direction_error(res, scale, offset, angle, sign) <= 1e-12
        # A on the line: its distance from the line through Q along the lever's line
        assert res.residual <= 1e-12


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('side', [1, -1])
def test_roller_on_a_flat_face_against_the_tangent_construction(scale, side):
    # the roller centre A stays `radius` off the face through Q: A on the line `offset` from O4
    # where offset = face offset + radius (the roller on the face's left) or - radius (right)
    r, face = 0.02, 0.03
    data = slotted_lever(scale, face + side * r, 0.2, 1, radius=r, face_offset=face)
    mech = Scene.from_dict(data).mechanism
    assert mech.stated == {'slot.offset': pytest.approx(side * r * scale, rel=1e-15)}
    for res in solve(mech, np.linspace(0.0, 2 * math.pi, 9)):
        assert lever_direction_error(res, scale, face + side * r, 0.2, 1) <= 1e-12
        # the distance of the roller centre from the face is the radius, exactly
        a, q, o4, c = (np.array(res.points[k]) for k in ('A', 'Q', 'O4', 'C'))
        u = (c - o4) / np.hypot(*(c - o4))
        u = np.array(
            [
                u[0] * math.cos(0.2) - u[1] * math.sin(0.2),
                u[0] * math.sin(0.2) + u[1] * math.cos(0.2),
            ]
        )
        dist = u[0] * (a - q)[1] - u[1] * (a - q)[0]
        assert abs(abs(dist) - r * scale) <= 1e-13 * scale


def test_roller_drawn_off_its_face_is_redrawn_to_touch_it():
    # the drawing puts the roller 1 mm off tangency: the stated radius wins, the pose is
    # redrawn with the crank held
    data = slotted_lever(1.0, 0.05, 0.2, 1, radius=0.02, face_offset=0.03)
    data['slots'][0]['radius'] = 0.021
    mech = Scene.from_dict(data).mechanism
    res = solve(mech, [1.0])[0]
    assert lever_direction_error(res, 1.0, 0.051, 0.2, 1) <= 1e-12


def test_tangency_at_and_near_its_degenerate_position():
    # the line must pass |offset| from O4 through A: at |A O4| = |offset| it is tangent to the
    # circle about O4 (one line); just inside it, none. Here the crank passes that position.
    o4 = (0.0, -0.3)
    data = slotted_lever(1.0, 0.25, 0.0, 1, theta0=-0.5)
    mech = Scene.from_dict(data).mechanism
    s = Solver(mech, knowns=['crank'], outputs=list(mech.points), branch='reference')
    # crank angles where |A - O4| = 0.25 exactly (circle of 0.1 about O2 meets 0.25 about O4)
    edge = oracles.circle_circle((0.0, 0.0), 0.1, o4, 0.25, 1).point
    t_edge = math.atan2(float(edge[1]), float(edge[0]))
    for gap in (1e-3, 1e-6, 1e-9):
        near = [s.solve({'crank': t_edge + d}, commit=False) for d in (-gap, gap)]
        assert [r.success for r in near].count(True) == 1, gap  # one side closes, not the other
        res = next(r for r in near if r.success)
        # the line's direction is sqrt-sensitive at the tangency: the error bound grows as
        # eps / sqrt(gap), never a constant tuned here
        assert lever_direction_error(res, 1.0, 0.25, 0.0, 1) <= 1e-13 / math.sqrt(gap)
        refused = next(r for r in near if not r.success)
        assert refused.reason


def four_bar_points(scale, branch):
    o = oracles.fourbar(0.3 * scale, 0.1 * scale, 0.25 * scale, 0.2 * scale, 1.0, branch)
    return {k: [float(v) for v in o[k]] for k in ('O2', 'A', 'B', 'O4')}


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('branch', [1, -1])
def test_distance_constraint_is_the_coupler(scale, branch):
    pts = four_bar_points(scale, branch)
    # drawn with the coupler 1% long: the stated length wins
    b = np.array(pts['B'])
    pts['B'] = list(np.array(pts['O4']) + (b - pts['O4']))
    data = {
        'points': pts,
        'links': {'ground': ['O2', 'O4'], 'crank': ['O2', 'A'], 'rocker': ['O4', 'B']},
        'distances': [{'name': 'tie', 'between': ['A', 'B'], 'length': 0.25 * scale}],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }
    mech = Scene.from_dict(data).mechanism
    assert mech.dimensions[('tie', 'A', 'B')] == 0.25 * scale
    thetas = np.linspace(0.0, 2 * math.pi, 13)
    for t, res in zip(thetas, solve(mech, thetas)):
        o = oracles.fourbar(0.3 * scale, 0.1 * scale, 0.25 * scale, 0.2 * scale, t, branch)
        if not o['ok']:
            continue
        assert oracles.point_error(res.points['B'], o['B']) <= 1e-12 * scale


def test_distance_constraint_drawn_length_and_override():
    pts = four_bar_points(1.0, 1)
    data = {
        'points': pts,
        'links': {'ground': ['O2', 'O4'], 'crank': ['O2', 'A'], 'rocker': ['O4', 'B']},
        'distances': [{'name': 'tie', 'between': ['A', 'B']}],  # as drawn
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }
    mech = Scene.from_dict(data).mechanism
    assert mech.stated == {}
    over = Scene.from_dict(data, dimensions={'tie.A-B': 0.26}).mechanism
    res = solve(over, [0.7])[0]
    o = oracles.fourbar(0.3, 0.1, 0.26, 0.2, 0.7, 1)
    assert oracles.point_error(res.points['B'], o['B']) <= 1e-13


@pytest.mark.parametrize(
    ('change', 'key', 'words'),
    [
        (
            {'slots': [{'name': 'lever', 'point': 'A', 'link': 'lever', 'angle': 0}]},
            'slots[0].name',
            'already the name',
        ),
        (
            {'slots': [{'name': 's', 'point': 'Z', 'link': 'lever', 'angle': 0}]},
            'slots.s.point',
            'must name a point',
        ),
        (
            {'slots': [{'name': 's', 'point': 'A', 'link': 'crank', 'angle': 0}]},
            'slots.s.link',
            'carries',
        ),
        (
            {'slots': [{'name': 's', 'point': 'A', 'link': 'lever', 'through': 'O2', 'angle': 0}]},
            'slots.s.through',
            'must name a point of link',
        ),
        (
            {'slots': [{'name': 's', 'point': 'A', 'link': 'lever', 'radius': 0.1, 'angle': 0}]},
            'slots.s.through',
            'a face needs',
        ),
        (
            {'slots': [{'name': 's', 'point': 'A', 'link': 'lever'}]},
            'slots.s.angle',
            "give the line's angle",
        ),
        (
            {
                'slots': [
                    {
                        'name': 's',
                        'point': 'A',
                        'link': 'lever',
                        'through': 'Q',
                        'angle': 0,
                        'radius': -1,
                    }
                ]
            },
            'slots.s.radius',
            '>= 0',
        ),
        (
            {'distances': [{'name': 'd', 'between': ['O4', 'C']}]},
            'distances.d.between',
            'both on link',
        ),
        (
            {'distances': [{'name': 'd', 'between': ['A', 'A']}]},
            'distances.d.between',
            'two different points',
        ),
        (
            {'distances': [{'name': 'd', 'between': ['A', 'C'], 'length': 0}]},
            'distances.d.length',
            '> 0',
        ),
        ({'distances': 'x'}, 'distances', 'must be a list'),
    ],
)
def test_bad_constraints_are_refused_naming_the_key(change, key, words):
    data = slotted_lever(1.0, 0.05, 0.0, 1)
    data.pop('slots')
    data.update(change)
    with pytest.raises(SceneError) as err:
        Scene.from_dict(data)
    assert key in str(err.value) and words in str(err.value), str(err.value)


def test_a_slot_whose_pin_block_name_is_a_link_names_that_link():
    data = slotted_lever(1.0, 0.05, 0.0, 1)
    data['points']['X'] = [0.5, 0.5]
    data['links']['slot_pin'] = ['O4', 'X']
    with pytest.raises(SceneError) as err:
        Scene.from_dict(data)
    assert str(err.value) == (
        "<scene>: slots[0].name: link name 'slot_pin' (made for the slot's pin block) is "
        "already used; give the slot another name (got 'slot')"
    )


def test_a_distance_beside_a_link_named_like_a_pin_block_loads():
    """A distance makes no pin block: a link NAME_pin beside distance NAME is no clash."""
    data = {
        'points': four_bar_points(1.0, 1),
        'links': {'ground': ['O2', 'O4'], 'crank': ['O2', 'A'], 'tie_pin': ['O4', 'B']},
        'distances': [{'name': 'tie', 'between': ['A', 'B']}],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }
    mech = Scene.from_dict(data).mechanism
    assert mech.links['tie'].points == ('A', 'B') and 'tie_pin' in mech.links


def test_constraints_refused_beside_a_shortcut():
    with pytest.raises(SceneError, match='general-form key'):
        Scene.from_dict(
            {'four_bar': {'ground': 3, 'crank': 1, 'coupler': 2.5, 'rocker': 2}, 'slots': []}
        )


def doc_scene(name):
    """A scene of docs/SCENES.md by its name."""
    import re

    import yaml
    from scenes import REPO

    text = (REPO / 'docs' / 'SCENES.md').read_text(encoding='utf-8')
    for block in re.findall(r'^```yaml\n(.*?)^```', text, flags=re.S | re.M):
        data = yaml.safe_load(block)
        if data.get('name') == name:
            return Scene.from_dict(data, source='docs/SCENES.md').mechanism
    raise KeyError(name)


@pytest.mark.parametrize('name', ['slotted_lever', 'roller_follower', 'four_bar_dimensioned'])
def test_velocities_of_the_new_joints_match_central_differences(name):
    from oracles import central_difference_rates as _central

    from linkage_ros.core.velocity import velocities

    mech = doc_scene(name)
    solver = Solver(mech, knowns=['crank'], outputs=list(mech.points), branch='reference')
    L = mech.length_scale
    checked = 0
    for theta in np.linspace(-1.2, 1.2, 9):
        res = solver.solve({'crank': float(theta)}, commit=False)
        if not res.success or res.margin < 0.05:
            continue
        vel = velocities(solver, res, {'crank': float(theta)}, {'crank': 1.3})
        assert vel.success, vel.reason
        fd_joints, fd_points = _central(solver, {'crank': float(theta)}, {'crank': 1.3}, 1e-6)
        scale = max(1.0, max(abs(v) for v in vel.joints.values()))
        for j in mech.joint_names:
            unit = L if j in mech.prismatics else 1.0
            assert abs(vel.joints[j] - fd_joints[j]) <= 1e-6 * scale * unit, (name, j)
        for p in mech.points:
            for k in (0, 1):
                assert abs(vel.points[p][k] - fd_points[p][k]) <= 1e-6 * scale * L, (name, p)
        checked += 1
    assert checked >= 4
