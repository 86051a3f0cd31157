"""A JointState command read off its CDR bytes (command_cdr) against two serialisers written by
others: rclpy's and rosbags' (little- and big-endian) bytes of any JointState read as the
message's own stamp, names, positions and velocities; bytes it does not take (cut short, a
name that is not UTF-8, another encoding) are left to rclpy (None)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

rclpy = pytest.importorskip('rclpy')

from builtin_interfaces.msg import Time  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Header  # noqa: E402

from linkage_ros.command_cdr import read_joint_state  # noqa: E402

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
T = TYPESTORE.types

texts = st.text(min_size=0, max_size=12).filter(lambda s: '\x00' not in s)
doubles = st.floats(allow_nan=True, allow_infinity=True)


@st.composite
def joint_states(draw):
    names = draw(st.lists(texts, max_size=6))
    n = len(names)
    # a command's sequences need not pair up: that is the request checks' call, not the reader's
    sizes = st.sampled_from([0, n, n + 1]) if n else st.sampled_from([0, 1])
    return dict(
        sec=draw(st.integers(-(2**31), 2**31 - 1)),
        nanosec=draw(st.integers(0, 2**32 - 1)),
        frame=draw(texts),
        names=names,
        positions=draw(st.lists(doubles, min_size=draw(sizes), max_size=n + 1)),
        velocities=draw(st.lists(doubles, min_size=draw(sizes), max_size=n + 1)),
        efforts=draw(st.lists(doubles, max_size=3)),
    )


def rclpy_bytes(m) -> bytes:
    msg = JointState(
        header=Header(stamp=Time(sec=m['sec'], nanosec=m['nanosec']), frame_id=m['frame']),
        name=m['names'],
        position=m['positions'],
        velocity=m['velocities'],
        effort=m['efforts'],
    )
    return serialize_message(msg)


def rosbags_bytes(m, little_endian: bool) -> bytes:
    import numpy as np

    msg = T['sensor_msgs/msg/JointState'](
        header=T['std_msgs/msg/Header'](
            stamp=T['builtin_interfaces/msg/Time'](sec=m['sec'], nanosec=m['nanosec']),
            frame_id=m['frame'],
        ),
        name=m['names'],
        position=np.array(m['positions'], dtype=float),
        velocity=np.array(m['velocities'], dtype=float),
        effort=np.array(m['efforts'], dtype=float),
    )
    return bytes(
        TYPESTORE.serialize_cdr(msg, 'sensor_msgs/msg/JointState', little_endian=little_endian)
    )


def same_floats(got, want) -> bool:
    """Equal bit for bit (NaN included)."""
    import struct

    return len(got) == len(want) and all(
        struct.pack('<d', a) == struct.pack('<d', b) for a, b in zip(got, want, strict=True)
    )


def check(raw: bytes, m) -> None:
    fields = read_joint_state(raw)
    assert fields is not None
    assert (fields.sec, fields.nanosec) == (m['sec'], m['nanosec'])
    assert fields.names == tuple(m['names'])
    assert same_floats(fields.positions, m['positions'])
    assert same_floats(fields.velocities, m['velocities'])


@settings(max_examples=150, deadline=None)
@given(m=joint_states())
def test_rclpys_bytes_read_as_the_message(m):
    if m['sec'] < 0:  # rclpy's Time refuses a negative sec: rosbags' bytes carry those
        m['sec'] = -m['sec'] - 1
    check(rclpy_bytes(m), m)


@settings(max_examples=150, deadline=None)
@given(m=joint_states(), little_endian=st.booleans())
def test_rosbags_bytes_read_as_the_message(m, little_endian):
    check(rosbags_bytes(m, little_endian), m)


@settings(max_examples=60, deadline=None)
@given(m=joint_states(), data=st.data())
def test_a_message_cut_short_is_left_to_rclpy(m, data):
    raw = rosbags_bytes(m, True)
    cut = data.draw(st.integers(0, len(raw) - 1))
    assert read_joint_state(raw[:cut]) is None


def test_a_name_that_is_not_utf8_is_left_to_rclpy():
    raw = bytearray(
        rosbags_bytes(
            dict(
                sec=1, nanosec=2, frame='', names=['ab'], positions=[1.0], velocities=[], efforts=[]
            ),
            True,
        )
    )
    at = raw.index(b'ab\x00')
    raw[at] = 0xFF
    assert read_joint_state(bytes(raw)) is None


@pytest.mark.parametrize('head', [b'\x00\x02', b'\x00\x07', b'\x01\x01', b'\x00\x03'])
def test_another_encoding_is_left_to_rclpy(head):
    """Another encapsulation (PL_CDR, XCDR2) or not one at all: not read here; nor is nothing."""
    m = dict(sec=1, nanosec=2, frame='w', names=['a'], positions=[1.0], velocities=[], efforts=[])
    raw = rosbags_bytes(m, True)
    assert read_joint_state(raw) is not None
    assert read_joint_state(head + raw[2:]) is None
    assert read_joint_state(b'') is None
