"""The four-bar served by ``linkage_node`` over real DDS: forward commands against the
closed-form oracle (node_helpers.FourBarOracle), stamps, command bytes of another writer, inverse
targets, and bad commands (exactly one error and nothing else), on the shipped four-bar and on
a test-only triple rocker whose crank cannot turn all the way."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from node_helpers import (
    ANGLE_TOL,
    LENGTH_TOL,
    angle_diff,
    finish,
    joint_state,
    marker_points,
    stamp_of,
    start_served,
    status_values,
)
from ros_harness import random_domain_id
from sensor_msgs.msg import JointState
from visualization_msgs.msg import Marker

DOMAIN_ID = random_domain_id()

# non-Grashof (s + l = 0.25 + 0.5 > p + q = 0.4 + 0.3: a triple rocker): the crank reaches only
# |theta| <= 1.2986 rad (|A O4| <= coupler + rocker) while its limits allow [-2, 2], so 1.6 rad is
# within the limits but does not assemble.
ROCKER_FIXTURE = """\
name: triple_rocker
frame_id: world
four_bar:
  ground: 0.5
  crank: 0.4
  coupler: 0.25
  rocker: 0.3
  branch: 1
  crank_limits: {min: -2.0, max: 2.0}
"""
ROCKER_REACH = math.acos((0.5**2 + 0.4**2 - (0.25 + 0.3) ** 2) / (2 * 0.5 * 0.4))


@pytest.fixture(scope='module')
def rocker(ros, workdir):
    scene = workdir / 'triple_rocker.yaml'
    scene.write_text(ROCKER_FIXTURE)
    served, proc = start_served(ros, workdir, 'rocker', scene, joint_state(['crank'], [0.9]))
    yield served
    finish(proc)


# ---- the four-bar: forward, inverse, bad commands -------------------------------------------


def test_forward_command_matches_closed_form_four_bar(four_bar):
    theta2 = 1.0
    status = four_bar.request(joint_state(['crank'], [theta2], stamp=(1234, 567_000_000)))
    joints = four_bar.assert_single_ok(status)
    want = four_bar.oracle.solve(theta2)
    assert set(joints) == {'O2', 'A', 'B', 'O4'}
    for name, value in want['joints'].items():
        assert angle_diff(joints[name], value) < ANGLE_TOL, (name, joints[name], value)
    # the node's rocker (its O4 joint counts from the ground line) closes Freudenstein's equation
    assert abs(four_bar.oracle.freudenstein(theta2, joints['O4'] + four_bar.oracle.g)) < 1e-12
    assert stamp_of(four_bar.joints.last) == (1234, 567_000_000)
    # the coupler point
    p = four_bar.points['P'].last
    assert stamp_of(p) == (1234, 567_000_000) and p.header.frame_id == four_bar.frame_id
    assert math.dist((p.point.x, p.point.y), want['P']) < LENGTH_TOL
    # status: one OK with the solve report
    vals = status_values(status)
    assert {'residual', 'branch', 'margin', 'solver', 'iterations'} <= set(vals)
    assert float(vals['residual']) < 1e-9
    assert vals['branch'] == '+' and 0 < float(vals['margin']) <= 1
    # markers: the crank strip runs from O2 to the oracle's A
    links = marker_points(four_bar.markers.last, four_bar.mech)
    assert math.dist(links['crank']['A'], want['A']) < LENGTH_TOL
    assert math.dist(links['rocker']['B'], want['B']) < LENGTH_TOL
    kinds = [m.type for m in four_bar.markers.last.markers]
    assert Marker.SPHERE_LIST in kinds and kinds.count(Marker.LINE_STRIP) == 4


def test_zero_stamp_is_replaced_by_now(four_bar):
    before = time.time()
    status = four_bar.request(joint_state(['crank'], [1.1]))
    four_bar.assert_single_ok(status)
    sec, nsec = stamp_of(four_bar.joints.last)
    assert (sec, nsec) != (0, 0)
    assert abs(sec + 1e-9 * nsec - before) < 30.0
    assert stamp_of(four_bar.points['P'].last) == (sec, nsec)


def rosbags_joint_state(names, positions, stamp, frame='', effort=(), little_endian=True) -> bytes:
    """A JointState serialised by rosbags (another writer than rclpy: it can write a NUL
    inside a name, either byte order)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    t = store.types
    msg = t['sensor_msgs/msg/JointState'](
        header=t['std_msgs/msg/Header'](
            stamp=t['builtin_interfaces/msg/Time'](sec=stamp[0], nanosec=stamp[1]),
            frame_id=frame,
        ),
        name=list(names),
        position=np.array(positions, float),
        velocity=np.zeros(0),
        effort=np.array(effort, float),
    )
    return bytes(
        store.serialize_cdr(msg, 'sensor_msgs/msg/JointState', little_endian=little_endian)
    )


@pytest.mark.parametrize('little_endian', [True, False])
def test_command_bytes_of_another_writer_are_read_as_the_message(four_bar, little_endian):
    """~/command is read off its bytes: a command serialised by rosbags (either byte order,
    with a frame id and efforts the node skips) is answered as the same message would be."""
    raw = rosbags_joint_state(
        ['crank'], [0.9], (4321, 765), 'odd frame', [1.0, 2.0, 3.0], little_endian
    )
    joints = four_bar.assert_single_ok(four_bar.request(raw))
    for name, value in four_bar.oracle.solve(0.9)['joints'].items():
        assert angle_diff(joints[name], value) < ANGLE_TOL
    assert stamp_of(four_bar.joints.last) == (4321, 765)
    assert status_values(four_bar.status.last)['request'] == 'command'


def test_inverse_target_on_rocker_returns_crank(four_bar):
    four_bar.assert_single_ok(four_bar.request(joint_state(['crank'], [1.0])))
    theta2 = 1.1
    want = four_bar.oracle.solve(theta2)
    status = four_bar.request(
        joint_state(['rocker'], [want['theta4']], stamp=(77, 1)), topic='~/target'
    )
    joints = four_bar.assert_single_ok(status)
    assert angle_diff(joints['O2'], want['joints']['O2']) < 1e-12
    assert angle_diff(joints['O4'], want['joints']['O4']) < 1e-12
    assert stamp_of(four_bar.joints.last) == (77, 1)
    assert (
        math.dist((four_bar.points['P'].last.point.x, four_bar.points['P'].last.point.y), want['P'])
        < 1e-12
    )
    # the state the target left is where the next command continues from: the crank's rocker
    # position of the other assembly (crank mirrored about O4 B) is never chosen
    theta2b = 1.15
    wantb = four_bar.oracle.solve(theta2b)
    joints = four_bar.assert_single_ok(
        four_bar.request(joint_state(['O4'], [wantb['joints']['O4']]), topic='~/target')
    )
    assert angle_diff(joints['O2'], wantb['joints']['O2']) < 1e-12


def test_target_with_wrong_number_of_values_is_rejected(four_bar):
    status = four_bar.request(joint_state(['O4', 'A'], [1.0, 0.5]), topic='~/target')
    four_bar.assert_single_error(status, 'degree')


def test_a_target_name_is_read_whole_as_a_command_name_is(four_bar):
    """`rocker\x00x` is one (unknown) name on ~/target as on ~/command and in `linkage bag`
    (TOPICS); rclpy's deserialiser ended it at the NUL and the node answered it as `rocker`.
    The message is the bytes rosbags serialises (rclpy's own serialiser cannot write the NUL)."""
    raw = rosbags_joint_state(['rocker\x00x'], [2.0], (5, 0))
    status = four_bar.request(raw, topic='~/target')
    four_bar.assert_single_error(status, 'unknown name', 'rocker')
    assert 'x00x' in status.message


BAD_COMMANDS = {
    'nan': (['crank'], [math.nan], 'finite'),
    'inf': (['crank'], [math.inf], 'finite'),
    'minus_inf': (['crank'], [-math.inf], 'finite'),
    'unknown_name': (['wrench'], [1.0], 'unknown'),
    'passive_joint': (['B'], [0.3], 'use ~/target for joints'),
    'missing_name': ([], [], 'empty'),
    'more_positions': (['crank'], [1.0, 2.0], 'position'),
    'more_names': (['crank', 'other'], [1.0], 'position'),
    'duplicate_name': (['crank', 'crank'], [1.0, 1.0], 'more than once'),
}


@pytest.mark.parametrize('case', list(BAD_COMMANDS))
def test_bad_command_gets_exactly_one_error_and_nothing_else(four_bar, case):
    names, positions, fragment = BAD_COMMANDS[case]
    msg = JointState(name=names, position=positions)
    four_bar.assert_single_error(four_bar.request(msg), fragment)
    # the node is alive and the next good command works
    joints = four_bar.assert_single_ok(four_bar.request(joint_state(['crank'], [0.8])))
    for name, value in four_bar.oracle.solve(0.8)['joints'].items():
        assert angle_diff(joints[name], value) < ANGLE_TOL


def test_unreachable_and_out_of_limit_crank_on_triple_rocker(rocker):
    assert 1.2 < ROCKER_REACH < 1.6 < 2.0
    rocker.assert_single_ok(rocker.request(joint_state(['crank'], [1.0])))
    for value, fragment in ((1.6, 'cannot assemble'), (2.5, 'maximum'), (-2.5, 'minimum')):
        status = rocker.request(joint_state(['crank'], [value]))
        rocker.assert_single_error(status, fragment)
        assert status.message
    joints = rocker.assert_single_ok(rocker.request(joint_state(['crank'], [1.05])))
    assert abs(joints['O2'] - 1.05) < 1e-12
