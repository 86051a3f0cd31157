"""plan_cdr: the node's reader of serialised plan requests and writer of solved trajectories,
against rclpy's own serialiser and deserialiser (the oracle: what goes over the wire)."""

from __future__ import annotations

import math

import pytest
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import PoseStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Path
from rclpy.serialization import deserialize_message, serialize_message
from scenes import load
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from linkage_ros.plan_cdr import (
    CdrError,
    Stamp,
    joint_trajectory_bytes,
    path_bytes_bound,
    peek_plan,
    read_joint_trajectory,
    read_path,
    trajectory_bytes_bound,
)
from linkage_ros.request_checks import max_request_names

names = st.text(st.characters(blacklist_characters='\x00', codec='utf-8'), max_size=12)
floats = st.floats(allow_nan=False, width=64)
arrays = st.lists(floats, max_size=4)
stamps = st.tuples(st.integers(-(2**31), 2**31 - 1), st.integers(0, 2**32 - 1))


@st.composite
def trajectories(draw) -> JointTrajectory:
    msg = JointTrajectory()
    msg.header.stamp = Time(sec=draw(stamps)[0], nanosec=draw(stamps)[1])
    msg.header.frame_id = draw(names)
    msg.joint_names = draw(st.lists(names, max_size=4))
    for _ in range(draw(st.integers(0, 6))):
        sec, nanosec = draw(stamps)
        msg.points.append(
            JointTrajectoryPoint(
                positions=draw(arrays),
                velocities=draw(arrays),
                accelerations=draw(arrays),
                effort=draw(arrays),
                time_from_start=Duration(sec=sec, nanosec=nanosec),
            )
        )
    return msg


@settings(max_examples=150, deadline=None)
@given(trajectories())
def test_a_trajectory_reads_as_rclpy_wrote_it(msg):
    raw = serialize_message(msg)
    got = read_joint_trajectory(raw)
    assert (got.header.stamp.sec, got.header.stamp.nanosec) == (
        msg.header.stamp.sec,
        msg.header.stamp.nanosec,
    )
    assert got.header.frame_id == msg.header.frame_id
    assert list(got.joint_names) == list(msg.joint_names)
    assert len(got.points) == len(msg.points)
    for g, w in zip(got.points, msg.points):
        for field in ('positions', 'velocities', 'accelerations', 'effort'):
            assert list(getattr(g, field)) == list(getattr(w, field)), field
        assert (g.time_from_start.sec, g.time_from_start.nanosec) == (
            w.time_from_start.sec,
            w.time_from_start.nanosec,
        )
    peek = peek_plan(raw, False, max_names=len(msg.joint_names))
    assert peek.count == len(msg.points)
    assert (peek.stamp.sec, peek.stamp.nanosec) == (msg.header.stamp.sec, msg.header.stamp.nanosec)
    if msg.joint_names:
        with pytest.raises(CdrError, match='joint_names has'):
            peek_plan(raw, False, max_names=len(msg.joint_names) - 1)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.tuples(floats, floats, floats, names, stamps), max_size=6),
    names,
    stamps,
)
def test_a_path_reads_as_rclpy_wrote_it(poses, frame, stamp):
    msg = Path()
    msg.header.frame_id = frame
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    for x, y, z, f, (sec, nanosec) in poses:
        p = PoseStamped()
        p.header.frame_id = f
        p.header.stamp = Time(sec=sec, nanosec=nanosec)
        p.pose.position.x, p.pose.position.y, p.pose.position.z = x, y, z
        p.pose.orientation.w = 1.0
        msg.poses.append(p)
    raw = serialize_message(msg)
    got = read_path(raw)
    assert got.header.frame_id == frame and len(got.poses) == len(poses)
    for g, (x, y, z, f, (sec, nanosec)) in zip(got.poses, poses):
        assert (g.pose.position.x, g.pose.position.y, g.pose.position.z) == (x, y, z)
        assert g.header.frame_id == f
        assert (g.header.stamp.sec, g.header.stamp.nanosec) == (sec, nanosec)
    assert peek_plan(raw, True, max_names=0).count == len(poses)


@settings(max_examples=150, deadline=None)
@given(
    st.lists(names, min_size=1, max_size=5),
    st.integers(0, 5),
    st.booleans(),
    stamps,
    names,
    st.data(),
)
def test_a_solved_trajectory_written_reads_back_in_rclpy(joints, n, rates, stamp, frame, data):
    rows = []
    for _ in range(n):
        positions = data.draw(st.lists(floats, min_size=len(joints), max_size=len(joints)))
        velocities = (
            data.draw(st.lists(floats, min_size=len(joints), max_size=len(joints))) if rates else []
        )
        sec, nanosec = data.draw(st.tuples(st.integers(0, 2**31 - 1), st.integers(0, 10**9 - 1)))
        rows.append((positions, velocities, sec, nanosec))
    raw = joint_trajectory_bytes(Stamp(stamp[0], stamp[1] % 10**9), frame, joints, rows)
    msg = deserialize_message(raw, JointTrajectory)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (stamp[0], stamp[1] % 10**9)
    assert msg.header.frame_id == frame and list(msg.joint_names) == joints
    assert len(msg.points) == n
    for p, (positions, velocities, sec, nanosec) in zip(msg.points, rows):
        assert list(p.positions) == positions and list(p.velocities) == velocities
        assert len(p.accelerations) == 0 and len(p.effort) == 0
        assert (p.time_from_start.sec, p.time_from_start.nanosec) == (sec, nanosec)


def test_bytes_that_are_not_a_plan_are_refused_saying_where():
    msg = JointTrajectory(joint_names=['crank'])
    msg.points = [JointTrajectoryPoint(positions=[0.1, 0.2])] * 3
    raw = serialize_message(msg)
    for cut in (3, 10, len(raw) // 2):
        with pytest.raises(CdrError):
            read_joint_trajectory(raw[:cut])
    with pytest.raises(CdrError, match='encapsulation'):
        read_joint_trajectory(b'\x07' + raw[1:])
    bad = raw.replace(b'crank\x00', b'cr\xffnk\x00')
    with pytest.raises(CdrError, match='not UTF-8'):
        read_joint_trajectory(bad)
    # a name with a NUL inside is that name, whole (rclpy's reader stops at the NUL)
    msg = JointTrajectory(joint_names=['crankQx'])
    raw = serialize_message(msg).replace(b'crankQx', b'crank\x00x')
    assert read_joint_trajectory(raw).joint_names == ('crank\x00x',)
    assert deserialize_message(raw, JointTrajectory).joint_names == ['crank']


def test_more_bytes_after_a_plan_than_a_serialiser_leaves_are_refused():
    """rclpy leaves bytes after a message (its size estimate: 16 a trajectory point with
    empty arrays); 1 MB after a one-point trajectory or path is no such message, in the node's
    reader and the bag's alike. What rclpy leaves after 3000 points is taken."""
    from rosbags.typesys import Stores, get_typestore

    from linkage_ros.bag.plans import decode_plan
    from linkage_ros.plan_cdr import SLACK_BYTES, read_path

    store = get_typestore(Stores.ROS2_JAZZY)
    trajectory = JointTrajectory(joint_names=['crank'])
    trajectory.points = [JointTrajectoryPoint(positions=[0.1])]
    path = Path()
    path.poses = [PoseStamped()]
    for msg, read, typename in (
        (trajectory, read_joint_trajectory, 'trajectory_msgs/msg/JointTrajectory'),
        (path, read_path, 'nav_msgs/msg/Path'),
    ):
        raw = serialize_message(msg)  # (with rclpy's own slack after the message)
        assert read(raw + bytes(SLACK_BYTES // 2))
        decode_plan(raw + bytes(SLACK_BYTES // 2), typename, store)
        with pytest.raises(CdrError, match='bytes follow the message'):
            read(raw + b'\xff' * 2**20)
        with pytest.raises(ValueError, match='bytes follow the message'):
            decode_plan(raw + b'\xff' * 2**20, typename, store)
    trajectory.points = [JointTrajectoryPoint(positions=[0.1])] * 3000
    raw = serialize_message(trajectory)
    assert len(read_joint_trajectory(raw).points) == 3000
    assert len(decode_plan(raw, 'trajectory_msgs/msg/JointTrajectory', store).points) == 3000


def test_size_bounds_hold_the_largest_request_a_scene_takes():
    """The largest well-formed trajectory for the scene (every name it has, as long as its
    longest, 10^4 points with every array full) fits its bound, with few bytes to spare."""
    mech = load('four_bar')
    n = max_request_names(mech)
    longest = max(
        [*mech.actuators, *mech.joint_names, *mech.links, *(f'{p}.x' for p in mech.points)],
        key=len,
    )
    msg = JointTrajectory(joint_names=[longest] * n)
    msg.header.frame_id = 'f' * 1024
    pt = JointTrajectoryPoint(
        positions=[0.1] * n, velocities=[0.1] * n, accelerations=[0.1] * n, effort=[0.1] * n
    )
    msg.points = [pt] * 10_000
    raw = serialize_message(msg)
    bound = trajectory_bytes_bound(mech, 10_000)
    assert len(raw) <= bound <= len(raw) + 100_000
    path = Path()
    pose = PoseStamped()
    pose.header.frame_id = 'world'
    path.header.frame_id = 'w' * 1024
    path.poses = [pose] * 10_000
    raw = serialize_message(path)
    assert len(raw) <= path_bytes_bound('world', 10_000) <= len(raw) + 100_000
    assert math.isfinite(bound)
