"""The pure conversions between ROS messages and the core (no node, no graph): a JointState
read as a command, a Result written as joint_states and points, reused messages refilled."""

from __future__ import annotations

import pytest
from builtin_interfaces.msg import Time
from node_helpers import stamp_of
from sensor_msgs.msg import JointState

from linkage_ros.conversions import joint_state_to_command, result_to_joint_state
from linkage_ros.core.errors import CommandError
from linkage_ros.core.solver import Result


def test_joint_state_to_command_checks_shape():
    assert joint_state_to_command(JointState(name=['a', 'b'], position=[1.0, 2.0])) == {
        'a': 1.0,
        'b': 2.0,
    }
    for msg in (
        JointState(),
        JointState(name=['a'], position=[]),
        JointState(name=['a', 'a'], position=[1.0, 2.0]),
        JointState(name=[''], position=[1.0]),
    ):
        with pytest.raises(CommandError):
            joint_state_to_command(msg)


def _four_bar_mech():
    from linkage_ros.core.model import Scene
    from linkage_ros.resources import scene_path

    return Scene.from_yaml(scene_path('four_bar')).mechanism


def test_result_to_joint_state_keeps_order_and_stamp():
    mech = _four_bar_mech()
    names = mech.joint_names
    res = Result(True, joints={n: float(i) for i, n in reversed(list(enumerate(names)))})
    msg = result_to_joint_state(res, mech, Time(sec=1, nanosec=2), 'f')
    assert list(msg.name) == names and list(msg.position) == [float(i) for i in range(len(names))]
    assert stamp_of(msg) == (1, 2) and msg.header.frame_id == 'f'
    assert not msg.velocity and not msg.effort


def test_result_to_joint_state_refills_a_reused_message():
    mech = _four_bar_mech()
    names = mech.joint_names
    first = result_to_joint_state(
        Result(True, joints=dict.fromkeys(names, 1.0)), mech, Time(sec=1, nanosec=2), 'f'
    )
    again = result_to_joint_state(
        Result(True, joints={n: -3.0 - i for i, n in enumerate(names)}),
        mech,
        Time(sec=7, nanosec=8),
        'f',
        reuse=first,
    )
    assert again is first
    assert list(again.name) == names
    assert list(again.position) == [-3.0 - i for i in range(len(names))]
    assert stamp_of(again) == (7, 8) and again.header.frame_id == 'f'


def test_result_to_points_refills_reused_messages():
    from linkage_ros.conversions import result_to_points

    cache: dict = {}
    first = result_to_points(
        Result(True, points={'P': (1.0, 2.0), 'Q': (3.0, 4.0)}), ['P'], Time(sec=1), 'f', cache
    )
    assert set(cache) == {'P'} and first['P'] is cache['P']
    again = result_to_points(
        Result(True, points={'P': (-1.5, 0.25), 'Q': (5.0, 6.0)}),
        ['P', 'Q'],
        Time(sec=7, nanosec=8),
        'f',
        cache,
    )
    assert again['P'] is first['P'] and set(cache) == {'P', 'Q'}
    p, q = again['P'], again['Q']
    assert (p.point.x, p.point.y, p.point.z) == (-1.5, 0.25, 0.0) and stamp_of(p) == (7, 8)
    assert (q.point.x, q.point.y) == (5.0, 6.0) and q.header.frame_id == p.header.frame_id == 'f'
