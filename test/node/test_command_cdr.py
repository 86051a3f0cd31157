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

from linkage_ros.command_cdr import NamesMemo, joint_state_peek, read_joint_state  # noqa: E402

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


def check(raw: bytes, m, memo: NamesMemo | None = None) -> None:
    fields = read_joint_state(raw, memo=memo)
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


@pytest.mark.parametrize('little_endian', [True, False])
def test_a_name_with_a_nul_is_read_whole_as_the_bag_reads_it(little_endian):
    """`crank\\x00x` is one name, as rosbags (and so `linkage bag`) and the plan topics read
    it: an unknown name the request checks refuse, not `crank` (rclpy's deserialiser ends a
    name at its first NUL)."""
    m = dict(
        sec=1,
        nanosec=2,
        frame='',
        names=['crank\x00x', 'b'],
        positions=[0.5, 0.25],
        velocities=[],
        efforts=[],
    )
    raw = rosbags_bytes(m, little_endian)
    got = read_joint_state(raw)
    assert got is not None
    want = TYPESTORE.deserialize_cdr(raw, 'sensor_msgs/msg/JointState')
    assert list(got.names) == list(want.name) == ['crank\x00x', 'b']


@settings(max_examples=60, deadline=None)
@given(m=joint_states(), little_endian=st.booleans())
def test_the_peek_reads_the_stamp_and_name_count_of_any_joint_state(m, little_endian):
    """joint_state_peek (what a request is refused on before it is read): the stamp and the
    number of names of rosbags' bytes, either byte order; None for bytes cut inside them."""
    raw = rosbags_bytes(m, little_endian)
    peek = joint_state_peek(raw)
    assert peek is not None
    assert (peek.sec, peek.nanosec, peek.count) == (m['sec'], m['nanosec'], len(m['names']))
    assert joint_state_peek(raw[:15]) is None
    assert joint_state_peek(b'\x00\x07' + raw[2:]) is None  # another encapsulation


def _empty_name_message(little_endian: bool) -> bytes:
    """A JointState whose one name is written as length 0 with no NUL (as some serialisers
    write an empty string): stamp (1, 2), frame '', position [0.5], no velocity or effort."""
    import struct

    e = '<' if little_endian else '>'
    head = b'\x00\x01\x00\x00' if little_endian else b'\x00\x00\x00\x00'
    return (
        head
        + struct.pack(e + 'iI', 1, 2)
        + struct.pack(e + 'I', 1)
        + b'\x00\x00\x00\x00'  # the frame id's NUL and padding
        + struct.pack(e + 'II', 1, 0)  # one name, of length 0
        + struct.pack(e + 'I', 1)
        + b'\x00' * 4  # padding to 8
        + struct.pack(e + 'd', 0.5)
        + struct.pack(e + 'II', 0, 0)
    )


@pytest.mark.parametrize('little_endian', [True, False])
def test_an_empty_name_without_its_nul_is_read_as_rclpy_and_the_plan_topics_read_it(
    little_endian,
):
    """One rule for a string of length 0 in every request reader: '' (rclpy's deserialiser
    reads it so, and plan_cdr a trajectory's names; rosbags refuses such a message)."""
    from rclpy.serialization import deserialize_message

    raw = _empty_name_message(little_endian)
    want = deserialize_message(raw, JointState)
    got = read_joint_state(raw)
    assert got is not None
    assert list(got.names) == list(want.name) == ['']
    assert got.positions == (0.5,) and got.velocities == ()
    assert (got.sec, got.nanosec) == (1, 2)


@st.composite
def streams(draw):
    """Commands as one client or several send them: names repeat, change, share a prefix or
    a count; frame ids of different lengths shift where the names start."""
    pool = draw(st.lists(st.lists(texts, max_size=4), min_size=1, max_size=3))
    out = []
    for _ in range(draw(st.integers(1, 8))):
        m = draw(joint_states())
        m['names'] = draw(st.sampled_from(pool))
        n = len(m['names'])
        m['positions'] = draw(st.lists(doubles, min_size=n, max_size=n))
        if m['sec'] < 0:  # rclpy's Time refuses a negative sec (and -(-2**31) is no int32)
            m['sec'] = -m['sec'] - 1
        out.append(m)
    return out


@settings(max_examples=100, deadline=None)
@given(stream=streams(), little_endian=st.booleans())
def test_names_remembered_from_the_last_message_read_as_each_message_says(stream, little_endian):
    """One NamesMemo over a stream of commands (rclpy's and rosbags' bytes mixed): every
    message reads as itself, whether its names are the last one's or not."""
    memo = NamesMemo()
    for k, m in enumerate(stream):
        raw = rclpy_bytes(m) if k % 2 else rosbags_bytes(m, little_endian)
        check(raw, m, memo)
