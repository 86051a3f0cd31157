"""``~/markers`` as bytes: one mechanism's MarkerArray serialised once, then per drawing only
its stamps and point coordinates written in place.

What the markers show depends on the mechanism alone (conversions.marker_layout): the ids,
colours, scales and the points each marker is drawn through never change, only where those
points are. Building the MarkerArray anew (a dozen Marker objects through their generated
setters, a Point per vertex) and serialising it cost the node 0.4 ms (four-bar) to 0.9 ms
(excavator) per drawing; patching the template costs a few microseconds per point.

The template is serialised by rclpy with a placeholder stamp and a distinct placeholder
triple per vertex, whose offsets are then found in the bytes (each exactly where it must be,
or the template is refused); the bytes equal rclpy's serialisation of result_to_markers
(test/node/test_marker_cdr.py).
"""

from __future__ import annotations

import struct

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from rclpy.serialization import serialize_message

from .conversions import marker_layout
from .core.model import Mechanism
from .core.solver import Result

#: placeholder stamp of the template: found once per marker, nowhere else
_STAMP_SEC, _STAMP_NANOSEC = 0x5EED_CAFE, 0x3B9A_C9FE
#: placeholder coordinates: vertex k is (k + 1) * this, three times (no marker field is such a
#: tiny double)
_VERTEX_UNIT = 1.0e-300


class MarkerBytes:
    """The ``~/markers`` answers of one mechanism in one frame."""

    def __init__(self, mech: Mechanism, frame_id: str):
        self.mech = mech
        markers, drawn = marker_layout(mech, Time(sec=_STAMP_SEC, nanosec=_STAMP_NANOSEC), frame_id)
        #: (scene point, placeholder) of every vertex, in marker order
        vertices: list[tuple[str, float]] = []
        for marker, names in zip(markers.markers, drawn, strict=True):
            points = []
            for name in names:
                placeholder = (len(vertices) + 1) * _VERTEX_UNIT
                vertices.append((name, placeholder))
                points.append(Point(x=placeholder, y=placeholder, z=placeholder))
            marker.points = points
        template = serialize_message(markers)
        if template[:2] != b'\x00\x01':
            raise ValueError('rclpy serialised the markers big-endian: MarkerBytes writes <')
        self._stamp = struct.Struct('<iI')
        self._xyz = struct.Struct('<3d')
        self.stamp_offsets = _offsets(template, self._stamp.pack(_STAMP_SEC, _STAMP_NANOSEC))
        if len(self.stamp_offsets) != len(markers.markers):
            raise ValueError(
                f'marker template: {len(self.stamp_offsets)} placeholder stamps found for '
                f'{len(markers.markers)} markers'
            )
        #: (byte offset, scene point) of every vertex's x, y, z
        self.vertex_offsets: list[tuple[int, str]] = []
        for name, placeholder in vertices:
            found = _offsets(template, self._xyz.pack(placeholder, placeholder, placeholder))
            if len(found) != 1:
                raise ValueError(f'marker template: vertex of {name!r} found {len(found)} times')
            self.vertex_offsets.append((found[0], name))
        self._template = template

    def write(self, result: Result, sec: int, nanosec: int) -> bytes:
        """The markers of a successful ``result`` stamped (sec, nanosec)."""
        buf = bytearray(self._template)
        pack_stamp, pack_xyz = self._stamp.pack_into, self._xyz.pack_into
        for offset in self.stamp_offsets:
            pack_stamp(buf, offset, sec, nanosec)
        points, point_3d = result.points, self.mech.point_3d
        for offset, name in self.vertex_offsets:
            pack_xyz(buf, offset, *point_3d(name, *points[name]))
        return bytes(buf)


def _offsets(data: bytes, pattern: bytes) -> list[int]:
    """Every offset at which ``pattern`` starts in ``data``."""
    found = []
    at = data.find(pattern)
    while at >= 0:
        found.append(at)
        at = data.find(pattern, at + 1)
    return found
