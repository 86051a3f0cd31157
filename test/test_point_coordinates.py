"""Pose targets of links that turn about a ground pivot (~/target_pose/<link>).

The pose of a link whose first point is a ground pivot is the pivot's position and the link's
angle: the target is the angle alone. The topic existed for such links and could never be
answered: the four-bar's crank was refused by a count naming 'point:O2' (a name the client
never sent), the excavator's boom as "known point 'O4' is fixed by the ground" (an outside
adversary on the node). Oracle: the forward solve at the same crank angle."""

from __future__ import annotations

import pytest
from scenes import load

from linkage_ros.core.errors import CommandError
from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.point_coordinates import pose_target


def test_a_crank_pose_at_its_pivot_is_its_angle():
    mech = load('four_bar')
    engine = Engine(mech, EngineSettings())
    o2 = tuple(float(v) for v in mech.points['O2'])
    r = engine.target(pose_target(mech, 'crank', o2, 0.7))
    assert r.success, r.reason
    want = Engine(mech, EngineSettings()).command({'crank': 0.7})
    for p, xy in want.points.items():
        assert r.points[p] == pytest.approx(xy, abs=1e-12), p


def test_a_pose_off_the_pivot_is_refused_naming_it():
    mech = load('four_bar')
    with pytest.raises(CommandError, match=r'ground pivot O2: its first point O2 is at \(0, 0\) m'):
        pose_target(mech, 'crank', (0.0, 0.5), 0.7)


def test_a_pinned_link_of_a_three_dof_arm_is_refused_by_its_own_count():
    mech = load('excavator')
    o4 = tuple(float(v) for v in mech.points['O4'])
    r = Engine(mech, EngineSettings()).target(pose_target(mech, 'boom', o4, -1.2))
    assert not r.success
    assert "the knowns ['link:boom'] give 1 value(s)" in r.reason, r.reason


def test_a_link_whose_ground_pivot_is_not_its_first_point_is_its_angle():
    """Hart's link AD carries A, O, D with O on the ground: its pose at the current state is
    answered as its angle (it was refused by a count naming 'point:A'), and a pose whose
    position is not where that angle puts A is refused naming it. Oracle: the state itself."""
    mech = load('hart')
    engine = Engine(mech, EngineSettings())
    here = engine.last
    a_now = tuple(float(v) for v in here.points['A'])
    r = engine.target(pose_target(mech, 'AD', a_now, here.links['AD']))
    assert r.success, r.reason
    assert r.points['A'] == pytest.approx(a_now, abs=1e-12)
    with pytest.raises(CommandError, match='where that angle puts it'):
        pose_target(mech, 'AD', (a_now[0] + 0.01, a_now[1]), here.links['AD'])
