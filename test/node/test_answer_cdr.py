"""The node's answers written as bytes (answer_cdr) against two serialisers written by others:
the bytes are those rosbags writes for the same message (up to zero padding after the last
field; rclpy's own serialiser leaves uninitialised padding, so it cannot be compared byte for
byte), and rclpy reads them as the message conversions.py builds for the same answer."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

rclpy = pytest.importorskip('rclpy')

from builtin_interfaces.msg import Time  # noqa: E402
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from geometry_msgs.msg import PointStamped  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from linkage_ros.answer_cdr import (  # noqa: E402
    AnswerBytes,
    JointStateBytes,
    PointStampedBytes,
    StatusBytes,
)
from linkage_ros.conversions import (  # noqa: E402
    error_status,
    result_to_joint_state,
    result_to_points,
    result_to_status,
)
from linkage_ros.core.model import Scene  # noqa: E402
from linkage_ros.core.solver import Result  # noqa: E402
from linkage_ros.engine import Engine, EngineSettings  # noqa: E402
from linkage_ros.request_checks import status_text  # noqa: E402
from linkage_ros.resources import scene_path  # noqa: E402

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
T = TYPESTORE.types


def same_bytes(ours: bytes, msg, typename: str) -> None:
    """``ours`` is rosbags' serialisation of ``msg``, with at most 3 zero bytes after it."""
    theirs = TYPESTORE.serialize_cdr(msg, typename)
    assert ours[: len(theirs)] == theirs
    assert len(ours) - len(theirs) < 4 and not any(ours[len(theirs) :])


def header(stamp, frame):
    return T['std_msgs/msg/Header'](
        stamp=T['builtin_interfaces/msg/Time'](sec=stamp[0], nanosec=stamp[1]), frame_id=frame
    )


texts = st.text(min_size=0, max_size=12).filter(lambda s: '\x00' not in s)
finite = st.floats(allow_nan=False, allow_infinity=False)
stamps = st.tuples(st.integers(0, 2**31 - 1), st.integers(0, 999_999_999))


@settings(max_examples=60, deadline=None)
@given(
    frame=texts,
    names=st.lists(texts.filter(bool), max_size=6, unique=True),
    data=st.data(),
    stamp=stamps,
)
def test_joint_state_bytes_are_rclpys(frame, names, data, stamp):
    positions = data.draw(st.lists(finite, min_size=len(names), max_size=len(names)))
    rates = data.draw(st.sampled_from([[], positions[::-1]]))
    ours = JointStateBytes(frame, names).write(*stamp, positions, rates)
    msg = JointState()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.header.frame_id = frame
    msg.name = names
    msg.position = positions
    msg.velocity = rates
    assert deserialize_message(ours, JointState) == msg
    theirs = T['sensor_msgs/msg/JointState'](
        header=header(stamp, frame),
        name=names,
        position=np.array(positions, float),
        velocity=np.array(rates, float),
        effort=np.array([], float),
    )
    same_bytes(ours, theirs, 'sensor_msgs/msg/JointState')


@settings(max_examples=60, deadline=None)
@given(frame=texts, xyz=st.tuples(finite, finite, finite), stamp=stamps)
def test_point_bytes_are_rclpys(frame, xyz, stamp):
    ours = PointStampedBytes(frame).write(*stamp, *xyz)
    msg = PointStamped()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.header.frame_id = frame
    msg.point.x, msg.point.y, msg.point.z = xyz
    assert deserialize_message(ours, PointStamped) == msg
    theirs = T['geometry_msgs/msg/PointStamped'](
        header=header(stamp, frame), point=T['geometry_msgs/msg/Point'](*xyz)
    )
    same_bytes(ours, theirs, 'geometry_msgs/msg/PointStamped')


@settings(max_examples=60, deadline=None)
@given(
    name=texts,
    hardware_id=texts,
    message=texts,
    level=st.sampled_from([0, 1, 2, 3]),
    pairs=st.lists(st.tuples(texts, texts), max_size=8),
)
def test_status_bytes_are_rclpys(name, hardware_id, message, level, pairs):
    from diagnostic_msgs.msg import KeyValue

    values = dict(pairs)
    writer = StatusBytes(name, hardware_id)
    for _ in range(2):  # the second time from the writer's kept blocks
        ours = writer.write(level, message, values)
        msg = DiagnosticStatus(
            level=bytes([level]), name=name, message=message, hardware_id=hardware_id
        )
        msg.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        assert deserialize_message(ours, DiagnosticStatus) == msg
        theirs = T['diagnostic_msgs/msg/DiagnosticStatus'](
            level=level,
            name=name,
            message=message,
            hardware_id=hardware_id,
            values=[T['diagnostic_msgs/msg/KeyValue'](key=k, value=v) for k, v in values.items()],
        )
        same_bytes(ours, theirs, 'diagnostic_msgs/msg/DiagnosticStatus')


@pytest.mark.parametrize('scene', ['four_bar', 'excavator', 'slider_crank'])
def test_answers_are_the_messages_conversions_build(scene):
    """Every answer of a sweep, with and without rates, and a refusal: the bytes read back as
    the messages conversions.py builds for the same result."""
    mech = Scene.from_yaml(scene_path(scene)).mechanism
    engine = Engine(mech, EngineSettings())
    answers = AnswerBytes(mech, 'f', 'node: x', prefix='p/')
    lo = {a: engine.last.inputs[a] for a in mech.actuators}
    stamp = Time(sec=7, nanosec=11)
    for k in range(5):
        values = {a: v + 0.01 * k for a, v in lo.items()}
        rates = {a: 0.5 for a in mech.actuators} if k % 2 else None
        result = engine.command(values, rates)
        assert result.success, result.reason
        if rates is not None:
            assert result.velocity is not None and result.velocity.success
        want = result_to_joint_state(result, mech, stamp, 'f', prefix='p/')
        got = deserialize_message(answers.joint_state(result, 7, 11), JointState)
        assert got == want
        points = result_to_points(result, mech.outputs, stamp, 'f', mech=mech)
        for p in mech.outputs:
            assert deserialize_message(answers.point(result, p, 7, 11), PointStamped) == points[p]
        status = result_to_status(result, 'node: x', 'command', mech.name)
        assert deserialize_message(answers.status(result, 'command'), DiagnosticStatus) == status
    refused = Result(False, 'no such actuator')
    want_err = result_to_status(refused, 'node: x', 'target', mech.name)
    got_err = deserialize_message(answers.status(refused, 'target'), DiagnosticStatus)
    assert got_err == want_err == error_status('no such actuator', 'node: x', 'target', mech.name)


def test_a_plan_status_is_the_diagnostic_status_of_its_values():
    """A trajectory's or path's one status (OK with its fields, or ERROR with the reason and
    failed_index), as trajectory.trajectory_status_values gives them, reads back as the
    DiagnosticStatus built field by field."""
    from diagnostic_msgs.msg import KeyValue

    from linkage_ros.trajectory import TrajectoryAnswer, trajectory_status_values

    mech = Scene.from_yaml(scene_path('four_bar')).mechanism
    engine = Engine(mech, EngineSettings())
    answers = AnswerBytes(mech, 'f', 'node: x')
    ok_answer = TrajectoryAnswer(True, 'ok', results=[engine.last, engine.last])
    refused = TrajectoryAnswer(False, 'point 3 does not close', failed_index=3)
    for answer, level in ((ok_answer, 0), (refused, 2)):
        ok, message, values = trajectory_status_values(answer, 'trajectory')
        want = DiagnosticStatus(
            level=bytes([level]), name='node: x', message=message, hardware_id=mech.name
        )
        want.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        got = deserialize_message(answers.plan_status(ok, message, values), DiagnosticStatus)
        assert got == want
    assert dict((v.key, v.value) for v in got.values) == {
        'failed_index': '3',
        'request': 'trajectory',
    }


def test_omitted_joints_are_left_out():
    mech = Scene.from_yaml(scene_path('four_bar')).mechanism
    engine = Engine(mech, EngineSettings())
    omit = frozenset(list(mech.actuators)[:1]) | frozenset(mech.joint_names[:1])
    result = engine.last
    want = result_to_joint_state(result, mech, Time(), 'w', omit=omit)
    got = deserialize_message(
        AnswerBytes(mech, 'w', 'n', omit=omit).joint_state(result, 0, 0), JointState
    )
    assert got == want and not omit & set(got.name)
    assert all(math.isfinite(v) for v in got.position)


def test_a_joint_state_of_the_wrong_size_is_refused():
    writer = JointStateBytes('w', ['a', 'b'])
    with pytest.raises(ValueError, match='2 names given 1 positions'):
        writer.write(0, 0, [1.0])


#: status values as request_checks.status_values gives them, with the equal-but-different ones
#: (0, 0.0, False; 1, 1.0, True) that a cache keyed by value alone mixes up
status_value = st.one_of(
    st.sampled_from([0, 0.0, -0.0, False, 1, 1.0, True, None, '', 'ok', 'newton']),
    st.integers(-5, 5),
    st.floats(allow_nan=True, allow_infinity=True),
    texts,
)


@settings(max_examples=80, deadline=None)
@given(
    answers=st.lists(
        st.dictionaries(
            st.sampled_from(['residual', 'branch', 'iterations', 'held']), status_value
        ),
        min_size=1,
        max_size=6,
    )
)
def test_an_ok_status_of_values_is_the_status_of_their_texts(answers):
    """write_ok (the OK answer's fast path, with repeating key/values kept) writes, answer
    after answer on one writer, the bytes rclpy gives the status of request_checks.status_text's
    texts: a value kept for one answer never answers for an equal one of another type."""
    from diagnostic_msgs.msg import KeyValue

    writer = StatusBytes('node: x', 'four_bar')
    for values in answers:
        msg = DiagnosticStatus(
            level=bytes([0]), name='node: x', message='ok', hardware_id='four_bar'
        )
        msg.values = [KeyValue(key=k, value=status_text(v)) for k, v in values.items()]
        assert deserialize_message(writer.write_ok(values), DiagnosticStatus) == msg
