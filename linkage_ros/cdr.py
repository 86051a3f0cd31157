"""CDR writing primitives (ROS-free): the little-endian XCDR1 encoding rmw hands over, shared
by the solved trajectory (plan_cdr.py) and the node's answers (answer_cdr.py).

Alignment counts from after the 4-byte encapsulation header; an empty sequence of doubles has
no padding (Fast-CDR and rosbags alike).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

#: the encapsulation header of a little-endian CDR message
CDR_LE = b'\x00\x01\x00\x00'


def padding(offset: int, align: int) -> int:
    """Zero bytes to add at ``offset`` (bytes into the message, header included) so the next
    field starts ``align``-aligned."""
    return (-(offset - 4)) % align


def encoded_string(s: str) -> bytes:
    """A CDR string without its leading padding: length (NUL counted), UTF-8 bytes, NUL."""
    b = s.encode()
    return struct.pack('<I', len(b) + 1) + b + b'\x00'


def write_encoded(buf: bytearray, encoded: bytes) -> None:
    """Append an :func:`encoded_string` (or a uint32-led field) at 4-byte alignment."""
    buf += b'\x00' * padding(len(buf), 4)
    buf += encoded


#: a little-endian uint32 (a string's or a sequence's length)
_UINT32 = struct.Struct('<I')
#: the NUL and the padding after a string of each length modulo 4 (index: bytes + 1, mod 4)
_STRING_ENDS = tuple(b'\x00' * (1 + (-k) % 4) for k in range(4))


def string_block(s: str) -> bytes:
    """A CDR string that starts 4-aligned, padded so that what follows starts 4-aligned too:
    a message of such blocks (and 4-byte words) needs no offset bookkeeping."""
    b = s.encode()
    k = len(b) + 1
    return _UINT32.pack(k) + b + _STRING_ENDS[k % 4]


def write_string(buf: bytearray, s: str) -> None:
    write_encoded(buf, encoded_string(s))


def write_doubles(buf: bytearray, values: Sequence[float]) -> None:
    """A float64[] sequence: its length, then (8-aligned) the values."""
    buf += b'\x00' * padding(len(buf), 4)
    buf += struct.pack('<I', len(values))
    if values:
        buf += b'\x00' * padding(len(buf), 8)
        buf += struct.pack(f'<{len(values)}d', *values)
