"""Plan requests as bytes (ROS-free): size bounds, a cheap look at the first bytes, the whole
message read, and the solved trajectory written.

The node takes ``~/trajectory`` (trajectory_msgs/JointTrajectory) and ``~/target_path/<point>``
(nav_msgs/Path) serialised (CDR, as rmw hands them over) so that:

* a message longer than any request the scene can make is refused from its length alone
  (:func:`trajectory_bytes_bound`, :func:`path_bytes_bound`, :func:`joint_state_bytes_bound`),
  before a byte of it is read;
* one with too many names or points is refused from its first bytes (:func:`peek_plan`);
* the rest is read here in Python, off the command path (plan_worker.py): rclpy's C
  deserialiser holds the interpreter lock for the whole message (0.6 s for 10^4 points on this
  machine), while this reader lets the command thread in every switch interval;
* strings are read whole, as rosbags (hence ``linkage bag``) reads them: a joint name
  ``crank\\x00x`` is that name, not ``crank`` (rclpy's reader stops at the first NUL).

Up to :data:`SLACK_BYTES` after the message are accepted, as rclpy leaves a few of them (its
size estimate); more are refused (:func:`trailing_error`, the bag's reader too).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from .cdr import CDR_LE, write_doubles, write_string
from .core.model import Mechanism
from .request_checks import max_request_names

#: the most bytes of a header.frame_id a plan request may carry (a ROS frame id is a short
#: name; TF refuses none, so the bound is generous)
MAX_FRAME_ID_BYTES = 1024
#: bytes a serialiser may leave after a message (rclpy's size estimate leaves a few dozen)
SLACK_BYTES = 256
#: and per point or pose: rclpy's estimate counts 8 bytes of padding for each empty array of a
#: trajectory point (16 bytes a point measured; a point has 4 arrays)
SLACK_PER_ITEM_BYTES = 32


class CdrError(ValueError):
    """The bytes are not a message of the expected type (the text says where they fail)."""


def trailing_error(extra: int, items: int) -> str | None:
    """Why ``extra`` bytes after a plan message of ``items`` points or poses make it no
    message of its type, or None (a serialiser's slack: SLACK_BYTES and SLACK_PER_ITEM_BYTES
    an item)."""
    most = SLACK_BYTES + SLACK_PER_ITEM_BYTES * items
    if extra <= most:
        return None
    return (
        f'{extra} bytes follow the message (a serialiser leaves at most {most} after one of '
        f'{items} points or poses)'
    )


@dataclass(frozen=True, slots=True)
class Stamp:
    """builtin_interfaces/Time or Duration."""

    sec: int
    nanosec: int


@dataclass(frozen=True, slots=True)
class Header:
    stamp: Stamp
    frame_id: str


@dataclass(frozen=True, slots=True)
class TrajectoryPoint:
    """trajectory_msgs/JointTrajectoryPoint (rad, m; their rates; time from the start)."""

    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    accelerations: tuple[float, ...]
    effort: tuple[float, ...]
    time_from_start: Stamp


@dataclass(frozen=True, slots=True)
class JointTrajectoryRequest:
    header: Header
    joint_names: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]


@dataclass(frozen=True, slots=True)
class Position:
    x: float
    y: float
    z: float


@dataclass(frozen=True, slots=True)
class Pose:
    position: Position


@dataclass(frozen=True, slots=True)
class PoseStamped:
    header: Header
    pose: Pose


@dataclass(frozen=True, slots=True)
class PathRequest:
    header: Header
    poses: tuple[PoseStamped, ...]


@dataclass(frozen=True, slots=True)
class PlanPeek:
    """What the first bytes of a plan request say: its stamp and how many points it has."""

    stamp: Stamp
    count: int


# ---- size bounds from the scene -----------------------------------------------------------------


def _longest_name_bytes(mech: Mechanism) -> int:
    """The longest name a request to ``mech`` can carry (bytes; a point as ``<point>.x``)."""
    names = [
        *mech.actuators,
        *mech.joint_names,
        *mech.output_joint_names,
        *mech.links,
        *(f'{p}.x' for p in mech.points),
    ]
    return max((len(n.encode()) for n in names), default=0)


def _string_bytes(nbytes: int) -> int:
    """A CDR string of ``nbytes`` at most, its length word and padding included."""
    return 4 + nbytes + 1 + 3


def _header_bytes(frame_bytes: int) -> int:
    return 8 + _string_bytes(frame_bytes)


def joint_state_bytes_bound(mech: Mechanism) -> int:
    """The most bytes a sensor_msgs/JointState request to ``mech`` can take: every name the
    scene has (request_checks.max_request_names), each as long as its longest, with a position,
    velocity and effort each."""
    n = max_request_names(mech)
    names = 4 + n * _string_bytes(_longest_name_bytes(mech))
    return 4 + _header_bytes(MAX_FRAME_ID_BYTES) + names + 3 * (8 + 8 * n) + SLACK_BYTES


def trajectory_bytes_bound(mech: Mechanism, max_points: int) -> int:
    """The most bytes a trajectory_msgs/JointTrajectory request to ``mech`` can take:
    ``max_points`` points, each with positions, velocities, accelerations and effort for
    every name the scene has."""
    n = max_request_names(mech)
    names = 4 + n * _string_bytes(_longest_name_bytes(mech))
    point = 4 * (8 + 8 * n) + 8
    return 4 + _header_bytes(MAX_FRAME_ID_BYTES) + names + 4 + max_points * point + SLACK_BYTES


def path_bytes_bound(frame_id: str, max_points: int) -> int:
    """The most bytes a nav_msgs/Path request can take: ``max_points`` poses, each stamped in
    the node's frame (or none: a pose in another frame is refused anyway)."""
    pose = _header_bytes(len(frame_id.encode())) + 4 + 7 * 8
    return 4 + _header_bytes(MAX_FRAME_ID_BYTES) + 4 + max_points * pose + SLACK_BYTES


# ---- reading ------------------------------------------------------------------------------------


class _Reader:
    """A CDR (XCDR1, either byte order) reader over one serialised message."""

    def __init__(self, raw: bytes | memoryview):
        self.raw = raw
        self.n = len(raw)
        if self.n < 4 or raw[0] != 0 or raw[1] not in (0, 1):
            raise CdrError('not a CDR message (unknown encapsulation header)')
        self.e = '<' if raw[1] == 1 else '>'
        self.pos = 4

    def align(self, k: int) -> None:
        self.pos += (-(self.pos - 4)) % k

    def need(self, k: int, what: str) -> None:
        if self.pos + k > self.n:
            raise CdrError(f'the message is cut short in {what} ({self.n} bytes)')

    def u32(self, what: str) -> int:
        self.align(4)
        self.need(4, what)
        (v,) = struct.unpack_from(self.e + 'I', self.raw, self.pos)
        self.pos += 4
        return int(v)

    def stamp(self, what: str) -> Stamp:
        self.align(4)
        self.need(8, what)
        sec, nanosec = struct.unpack_from(self.e + 'iI', self.raw, self.pos)
        self.pos += 8
        return Stamp(int(sec), int(nanosec))

    def string(self, what: str) -> str:
        k = self.u32(what)
        if k == 0:  # some serialisers write an empty string without its NUL
            return ''
        self.need(k, what)
        b = bytes(self.raw[self.pos : self.pos + k])
        self.pos += k
        if b[-1] != 0:
            raise CdrError(f'{what} is not a NUL-terminated string')
        try:
            return b[:-1].decode('utf-8')
        except UnicodeDecodeError as exc:
            raise CdrError(f'{what} is not UTF-8 ({exc.reason} at byte {exc.start})') from None

    def doubles(self, what: str) -> tuple[float, ...]:
        k = self.u32(what)
        if k == 0:  # an empty sequence has no padding (Fast-CDR, rosbags alike)
            return ()
        self.align(8)
        self.need(8 * k, what)
        v = struct.unpack_from(f'{self.e}{k}d', self.raw, self.pos)
        self.pos += 8 * k
        return v

    def fixed_doubles(self, k: int, what: str) -> tuple[float, ...]:
        self.align(8)
        self.need(8 * k, what)
        v = struct.unpack_from(f'{self.e}{k}d', self.raw, self.pos)
        self.pos += 8 * k
        return v

    def end(self, items: int) -> None:
        """The message of ``items`` points or poses is read: CdrError where more bytes follow
        than a serialiser leaves."""
        why = trailing_error(self.n - self.pos, items)
        if why:
            raise CdrError(why)

    def header(self, what: str) -> Header:
        stamp = self.stamp(f'{what}.stamp')
        return Header(stamp, self.string(f'{what}.frame_id'))

    def count(self, what: str, limit: int) -> int:
        """A sequence length, CdrError when it is more than the bytes left could hold."""
        k = self.u32(what)
        if k > limit:
            raise CdrError(f'{what} says {k} elements; the {self.n} bytes cannot hold them')
        return k


def size_refusal(kind: str, nbytes: int, scene: str, bound: int, max_points: int) -> str:
    """Why a plan message longer than any request to the scene can be is refused (the node's
    and the bag's words)."""
    return (
        f'the {kind} message is {nbytes} bytes; one to scene {scene!r} is at most {bound} bytes '
        f'({max_points} points, every name the scene has): send it in parts'
    )


def peek_plan(raw: bytes | memoryview, path: bool, max_names: int) -> PlanPeek:
    """The stamp and the number of points (poses) of a serialised JointTrajectory (``path``
    false) or Path, read from its first bytes (a trajectory's joint names read past, at most
    ``max_names`` of them); CdrError if they do not make one, or name too many joints."""
    r = _Reader(raw)
    header = r.header('header')
    if not path:
        names = r.u32('joint_names')
        if names > max_names:
            raise CdrError(
                f'joint_names has {names} names; the scene has only {max_names} names to give '
                'values for'
            )
        for i in range(names):
            r.string(f'joint_names[{i}]')
    return PlanPeek(header.stamp, r.u32('points' if not path else 'poses'))


def read_joint_trajectory(
    raw: bytes | memoryview, pace: Callable[[], None] | None = None
) -> JointTrajectoryRequest:
    """A serialised trajectory_msgs/JointTrajectory; CdrError where it is not one. ``pace`` is
    called after every point (the plan worker's Pacer)."""
    r = _Reader(raw)
    header = r.header('header')
    names = tuple(r.string(f'joint_names[{i}]') for i in range(r.count('joint_names', r.n // 4)))
    points = []
    for i in range(r.count('points', r.n // 24)):
        what = f'points[{i}]'
        points.append(
            TrajectoryPoint(
                r.doubles(f'{what}.positions'),
                r.doubles(f'{what}.velocities'),
                r.doubles(f'{what}.accelerations'),
                r.doubles(f'{what}.effort'),
                r.stamp(f'{what}.time_from_start'),
            )
        )
        if pace is not None:
            pace()
    r.end(len(points))
    return JointTrajectoryRequest(header, names, tuple(points))


def read_path(raw: bytes | memoryview, pace: Callable[[], None] | None = None) -> PathRequest:
    """A serialised nav_msgs/Path; CdrError where it is not one. ``pace`` is called after
    every pose (the plan worker's Pacer)."""
    r = _Reader(raw)
    header = r.header('header')
    poses = []
    for i in range(r.count('poses', r.n // 68)):
        what = f'poses[{i}]'
        pose_header = r.header(f'{what}.header')
        x, y, z = r.fixed_doubles(3, f'{what}.pose.position')
        r.fixed_doubles(4, f'{what}.pose.orientation')  # a path point's position is its target
        poses.append(PoseStamped(pose_header, Pose(Position(x, y, z))))
        if pace is not None:
            pace()
    r.end(len(poses))
    return PathRequest(header, tuple(poses))


# ---- writing the solved trajectory ------------------------------------------------------------


def joint_trajectory_bytes(
    stamp: Stamp,
    frame_id: str,
    joint_names: Sequence[str],
    rows: Sequence[tuple[Sequence[float], Sequence[float], int, int]],
    pace: Callable[[], None] | None = None,
) -> bytes:
    """A trajectory_msgs/JointTrajectory serialised (CDR, little-endian) from its rows
    (positions, velocities, time_from_start sec, nanosec; TrajectoryAnswer.rows); ``pace`` is
    called after every row (the plan worker's Pacer)."""
    buf = bytearray(CDR_LE)
    buf += struct.pack('<iI', stamp.sec, stamp.nanosec)
    write_string(buf, frame_id)
    buf += b'\x00' * ((-(len(buf) - 4)) % 4)
    buf += struct.pack('<I', len(joint_names))
    for name in joint_names:
        write_string(buf, name)
    buf += b'\x00' * ((-(len(buf) - 4)) % 4)
    buf += struct.pack('<I', len(rows))
    for positions, velocities, sec, nanosec in rows:
        write_doubles(buf, positions)
        write_doubles(buf, velocities)
        buf += b'\x00' * ((-(len(buf) - 4)) % 4)
        buf += struct.pack('<IIiI', 0, 0, sec, nanosec)  # no accelerations, no effort
        if pace is not None:
            pace()
    return bytes(buf)
