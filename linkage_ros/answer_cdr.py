"""The node's answers written as CDR bytes (ROS-free): joint_states, ``~/points/<p>`` and
``~/status``, published raw (rclpy's ``Publisher.publish`` takes bytes as they are).

With every output subscribed, building the message objects cost the node more than the solve
of a four-bar: each field assignment runs the generated setter's checks, and ``publish`` walks
the object again to convert it before serialising. What never changes for a mechanism (the
frame id, the joint names, the status's name and hardware id, the status keys) is written once
here; per answer only the stamp, the numbers and the status's texts are packed.

Layouts (sensor_msgs/JointState, geometry_msgs/PointStamped, diagnostic_msgs/DiagnosticStatus)
are checked against rclpy's own serialiser in test/node/test_answer_cdr.py.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from typing import Any

from .cdr import CDR_LE, encoded_string, padding, string_block, write_encoded
from .core.model import Mechanism
from .core.solver import Result
from .request_checks import status_text, status_texts, status_values

#: diagnostic_msgs/DiagnosticStatus levels (its byte constants)
STATUS_OK = 0
STATUS_ERROR = 2


def _header_head(frame_id: str) -> bytearray:
    """A message starting with a std_msgs/Header: encapsulation, a zero stamp, the frame id."""
    buf = bytearray(CDR_LE + bytes(8))
    write_encoded(buf, encoded_string(frame_id))
    return buf


class JointStateBytes:
    """sensor_msgs/JointState answers of one mechanism: ``frame_id`` and ``names`` fixed,
    positions (and velocities, when the answer has rates) per answer; effort empty."""

    def __init__(self, frame_id: str, names: Sequence[str]):
        buf = _header_head(frame_id)
        buf += b'\x00' * padding(len(buf), 4)
        buf += struct.pack('<I', len(names))
        for name in names:
            write_encoded(buf, encoded_string(name))
        self.names = tuple(names)
        self._after_stamp = bytes(buf[12:])
        start = len(buf)
        #: the whole message, without and with velocities, as one struct each, and the byte
        #: offsets of the position and velocity values in each
        (fmt, self.plain_offsets), (rates_fmt, self.rates_offsets) = (
            self._layout(start, rates=False),
            self._layout(start, rates=True),
        )
        self._plain, self._rates = struct.Struct(fmt), struct.Struct(rates_fmt)

    def _layout(self, offset: int, rates: bool) -> tuple[str, tuple[int, int]]:
        """The struct format of a message, and where its positions and velocities start
        (bytes from the message's start; where a sequence is empty, where it would be)."""
        n = len(self.names)
        fmt = f'<4siI{len(self._after_stamp)}s'
        starts: list[int] = []
        for filled in (True, rates, False):  # position, velocity, effort
            pad = padding(offset, 4)
            fmt += f'{pad}xI' if pad else 'I'
            offset += pad + 4
            if filled and n:
                pad = padding(offset, 8)
                fmt += f'{pad}x{n}d' if pad else f'{n}d'
                offset += pad
            starts.append(offset)
            if filled and n:
                offset += 8 * n
        return fmt, (starts[0], starts[1])

    def write(
        self, sec: int, nanosec: int, positions: Sequence[float], rates: Sequence[float] = ()
    ) -> bytes:
        """One answer (positions and rates in the order of ``names``; rad, m, rad/s, m/s)."""
        n = len(self.names)
        if len(positions) != n or (rates and len(rates) != n):
            raise ValueError(
                f'JointState of {n} names given {len(positions)} positions and {len(rates)} rates'
            )
        if rates:
            return self._rates.pack(
                CDR_LE, sec, nanosec, self._after_stamp, n, *positions, n, *rates, 0
            )
        return self._plain.pack(CDR_LE, sec, nanosec, self._after_stamp, n, *positions, 0, 0)


class PointStampedBytes:
    """geometry_msgs/PointStamped answers in one frame."""

    def __init__(self, frame_id: str):
        buf = _header_head(frame_id)
        buf += b'\x00' * padding(len(buf), 8)
        self._after_stamp = bytes(buf[12:])
        self._struct = struct.Struct(f'<4siI{len(self._after_stamp)}s3d')
        #: where x, y, z start (bytes from the message's start)
        self.xyz_offset = len(buf)

    def write(self, sec: int, nanosec: int, x: float, y: float, z: float) -> bytes:
        """One point (m)."""
        return self._struct.pack(CDR_LE, sec, nanosec, self._after_stamp, x, y, z)


#: a uint32 word (a sequence's length)
_COUNT = struct.Struct('<I')

#: status texts kept as blocks (the keys, and values that repeat: true, false, branch signs,
#: solver names, requests); at most this many, then texts are written anew each time
STATUS_BLOCK_CACHE = 256


class StatusBytes:
    """diagnostic_msgs/DiagnosticStatus answers with one ``name`` and ``hardware_id``: the
    level, the message and the key/values per answer. Every field after the level is a
    :func:`string_block` or a 4-byte word, so the message is their concatenation."""

    def __init__(self, name: str, hardware_id: str):
        self._name = string_block(name)  # at offset 8 (after the level and its padding)
        self._hardware_id = string_block(hardware_id)
        self._blocks: dict[str, bytes] = {}
        #: a key and its value's text as one block pair, by (key, value): what repeats from
        #: answer to answer (a branch, a solver, an iteration count, the request)
        self._pairs: dict[tuple[str, Any], tuple[type, bytes]] = {}
        #: everything before the key/values of an OK 'ok' status
        self._ok_head = b''.join(
            [
                CDR_LE,
                struct.pack('<B3x', STATUS_OK),
                self._name,
                string_block('ok'),
                self._hardware_id,
            ]
        )

    def _block(self, text: str, keep: bool) -> bytes:
        hit = self._blocks.get(text)
        if hit is None:
            hit = string_block(text)
            if keep and len(self._blocks) < STATUS_BLOCK_CACHE:
                self._blocks[text] = hit
        return hit

    def write_ok(self, values: Mapping[str, Any]) -> bytes:
        """An OK 'ok' status of ``values`` as request_checks.status_values gives them (each
        written as request_checks.status_text says): the same bytes as ``write`` of their
        texts, with a value that repeats (not a float: residual, margin, cond change with every
        answer) written once."""
        pairs = self._pairs
        parts = [self._ok_head, _COUNT.pack(len(values))]
        append = parts.append
        for item in values.items():
            key, value = item
            if isinstance(value, float):  # new with every answer: not looked up, not kept
                append(self._block(key, True))
                append(string_block(status_text(value)))
                continue
            hit = pairs.get(item)
            # (the value's type too: 0 == False, but each is written its own way)
            if hit is None or hit[0] is not type(value):
                block = self._block(key, True) + string_block(status_text(value))
                if len(pairs) < STATUS_BLOCK_CACHE:
                    pairs[item] = (type(value), block)
                append(block)
            else:
                append(hit[1])
        return b''.join(parts)

    def write(self, level: int, message: str, values: Mapping[str, str]) -> bytes:
        """One status (``level``: STATUS_OK, STATUS_ERROR or another DiagnosticStatus level)."""
        block = self._block
        parts = [
            CDR_LE,
            struct.pack('<B3x', level),
            self._name,
            block(message, message == 'ok'),
            self._hardware_id,
            struct.pack('<I', len(values)),
        ]
        for key, value in values.items():
            parts.append(block(key, True))
            # numbers (residual, margin) change with every answer: not kept
            parts.append(block(value, not value[:1].isdigit() and value[:1] != '-'))
        return b''.join(parts)


class AnswerBytes:
    """One mechanism's answers as bytes: joint_states (less the ``omit`` names, each published
    name with ``prefix``), a point, a status; what conversions.result_to_joint_state,
    result_to_points and result_to_status build as messages."""

    def __init__(
        self,
        mech: Mechanism,
        frame_id: str,
        status_name: str,
        prefix: str = '',
        omit: frozenset[str] = frozenset(),
    ):
        self.mech = mech
        names = mech.output_joint_names
        #: indices of the published joints kept (None: all)
        self._keep = [i for i, n in enumerate(names) if n not in omit] if omit else None
        kept = names if self._keep is None else [names[i] for i in self._keep]
        self.joint_writer = JointStateBytes(frame_id, [prefix + n for n in kept])
        #: a scene file's joints are its result's joints: read them by name, once listed
        self._scene_joints = mech.joint_names if mech.joint_coordinates is None else None
        self._planar = mech.joint_coordinates is None
        self.point_writer = PointStampedBytes(frame_id)
        self.status_writer = StatusBytes(status_name, mech.name)

    def _published(
        self, joints: Mapping[str, float], rates: bool, inputs: Mapping[str, float] | None = None
    ) -> list[float]:
        if self._scene_joints is not None:
            values = [joints[j] for j in self._scene_joints]
        elif rates:
            values = self.mech.output_joint_rates(joints)
        else:
            values = self.mech.output_joints(joints, inputs)
        return values if self._keep is None else [values[i] for i in self._keep]

    def joint_state(self, result: Result, sec: int, nanosec: int) -> bytes:
        """Every published joint's position, and velocity when the result carries rates."""
        vel = result.velocity
        rates = self._published(vel.joints, True) if vel is not None and vel.success else ()
        return self.joint_writer.write(
            sec, nanosec, self._published(result.joints, False, result.inputs), rates
        )

    def point(self, result: Result, name: str, sec: int, nanosec: int) -> bytes:
        """Point ``name`` of a successful result (z = 0 for a scene file; a description's
        point in its frame's 3-D coordinates)."""
        x, y = result.points[name]
        if self._planar:
            return self.point_writer.write(sec, nanosec, x, y, 0.0)
        return self.point_writer.write(sec, nanosec, *self.mech.point_3d(name, x, y))

    def status(self, result: Result, request: str) -> bytes:
        """The status answering one request: OK 'ok' and the answer's fields, or ERROR and
        the reason."""
        if not result.success:
            return self.error(result.reason or 'failed', request)
        return self.status_writer.write_ok(status_values(result, request))

    def error(self, reason: str, request: str) -> bytes:
        return self.status_writer.write(
            STATUS_ERROR, str(reason), status_texts(Result(False, reason), request)
        )

    def plan_status(self, ok: bool, message: str, values: Mapping[str, str]) -> bytes:
        """The one status answering a trajectory or path (OK or ERROR, its message and
        key/values: trajectory.trajectory_status_values)."""
        return self.status_writer.write(STATUS_OK if ok else STATUS_ERROR, message, values)
