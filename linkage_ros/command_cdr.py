"""A sensor_msgs/JointState command read straight from its CDR bytes (ROS-free).

rclpy turns a message into Python objects field by field (a JointState, a Header, a Time, each
through its generated setters' checks, and array.arrays for the numbers): with every output
subscribed that cost the node about as much as the answer's solve. ``~/command`` is therefore
taken serialised and only the fields a command uses are read here: the stamp, the names, the
positions and the velocities (the frame id and the efforts are skipped, as the message path
ignores them). Whatever this reader does not take for a plain XCDR1 JointState (another
encoding, a cut message, a name that is not UTF-8) it leaves to rclpy's deserialiser. A name
is read whole, up to its length: ``crank\x00x`` is one (unknown) name, as rosbags, ``linkage
bag`` and the plan topics read it, where rclpy's deserialiser ends a name at its first NUL (so
in a message of another encoding it would read ``crank``).

The layout is checked against rclpy's own serialiser in test/node/test_command_cdr.py.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

#: the two XCDR1 plain encapsulations (big- and little-endian) and their struct byte orders
_ORDER = {0: '>', 1: '<'}
_STAMP = {e: struct.Struct(e + 'iI') for e in _ORDER.values()}
_WORD = {e: struct.Struct(e + 'I') for e in _ORDER.values()}


@dataclass(frozen=True, slots=True)
class JointStateFields:
    """What a command reads of a JointState: ``header.stamp`` (s, ns), ``name``, ``position``
    and ``velocity`` (rad or m, rad/s or m/s; empty when the message has none)."""

    sec: int
    nanosec: int
    names: tuple[str, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class JointStateHead:
    """The first fields of a CDR-serialised JointState: ``header.stamp`` (s, ns) and the number
    of names; ``order`` its struct byte order and ``names_at`` the offset of its first name
    (offsets count from after the 4-byte encapsulation header, as CDR aligns)."""

    order: str
    sec: int
    nanosec: int
    count: int
    names_at: int


def joint_state_peek(raw: bytes) -> JointStateHead | None:
    """The stamp and the number of names of a CDR-serialised JointState, read off its first
    bytes without reading the names (a 10^5-name message costs the node ~10 ms to turn into
    Python objects: refused on its count, it is never read); None if the bytes are too short
    or not plain XCDR1."""
    if len(raw) < 8 or raw[0] != 0 or raw[1] not in _ORDER:
        return None
    e = _ORDER[raw[1]]
    word = _WORD[e].unpack_from
    try:
        sec, nanosec = _STAMP[e].unpack_from(raw, 4)
        (flen,) = word(raw, 12)
        pos = 16 + flen  # the frame id: not read
        pos += -(pos - 4) % 4
        (count,) = word(raw, pos)
    except struct.error:
        return None
    return JointStateHead(e, sec, nanosec, count, pos + 4)


class NamesMemo:
    """The names of the last JointState read and their bytes: a client names the same
    actuators in every command, so their bytes recur and need not be decoded again. The names
    start 4-aligned in every message (after the stamp, the frame id and the count), so equal
    bytes there, in the same byte order, are equal names and end at the same place."""

    __slots__ = ('order', 'count', 'block', 'names')

    def __init__(self) -> None:
        self.order = ''  # the struct byte order they were read in
        self.count = -1
        self.block = b''
        self.names: tuple[str, ...] = ()


def read_joint_state(
    raw: bytes, head: JointStateHead | None = None, memo: NamesMemo | None = None
) -> JointStateFields | None:
    """The command fields of a CDR-serialised JointState (``head``: its joint_state_peek, where
    the caller has it; ``memo``: the names of the last message read by the caller, updated
    here), or None where this reader does not take the bytes (rclpy's deserialiser then says
    what they are). An empty float64 sequence has no padding; an empty string may come without
    its NUL (length 0), as plan_cdr reads it."""
    if head is None:
        head = joint_state_peek(raw)
        if head is None:
            return None
    e, pos = head.order, head.names_at
    word = _WORD[e].unpack_from
    try:
        if (
            memo is not None
            and memo.count == head.count
            and memo.order == head.order
            and memo.block
            and raw.startswith(memo.block, pos)
        ):
            names, pos = memo.names, pos + len(memo.block)
        else:
            read = _read_names(raw, head)
            if read is None:
                return None
            names, end = read
            if memo is not None:
                memo.order, memo.count = head.order, head.count
                memo.block, memo.names = raw[pos:end], names
            pos = end
        sequences = []
        for _ in range(2):  # position, velocity
            pos += -(pos - 4) % 4
            (n,) = word(raw, pos)
            pos += 4
            if n:
                pos += -(pos - 4) % 8
                if pos + 8 * n > len(raw):
                    return None
                sequences.append(struct.unpack_from(f'{e}{n}d', raw, pos))
                pos += 8 * n
            else:
                sequences.append(())
        pos += -(pos - 4) % 4
        (n,) = word(raw, pos)  # effort: not read, but there
        if n and pos + 4 + -(pos) % 8 + 8 * n > len(raw):
            return None
    except (struct.error, UnicodeDecodeError):
        return None
    return JointStateFields(head.sec, head.nanosec, names, sequences[0], sequences[1])


def joint_state_names(raw: bytes, head: JointStateHead) -> tuple[str, ...] | None:
    """The names of a CDR-serialised JointState read whole (a NUL inside a name kept, where
    rclpy's deserialiser ends the name there), or None where they are not plain names."""
    try:
        read = _read_names(raw, head)
    except (struct.error, UnicodeDecodeError):
        return None
    return None if read is None else read[0]


def _read_names(raw: bytes, head: JointStateHead) -> tuple[tuple[str, ...], int] | None:
    """The names of a JointState (from ``head.names_at``) and the offset just after the last
    one, or None where they run past the end or one lacks its NUL. Raises struct.error or
    UnicodeDecodeError on bytes that are no names."""
    pos = head.names_at
    word = _WORD[head.order].unpack_from
    names = []
    for _ in range(head.count):
        pos += -(pos - 4) % 4
        (k,) = word(raw, pos)
        if k == 0:  # some serialisers write an empty string without its NUL
            names.append('')
            pos += 4
            continue
        end = pos + 4 + k
        if end > len(raw) or raw[end - 1] != 0:
            return None
        names.append(raw[pos + 4 : end - 1].decode())
        pos = end
    return tuple(names), pos
