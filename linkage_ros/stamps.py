"""The header rules of a request: which stamps the node can echo on its answers, and which frames
it answers in (ROS-free: the node and the offline bag analysis share them, so a recorded request
is refused for the same reason the node refused it)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from .core.errors import echo
from .core.model import Mechanism
from .core.model.names import depends_on_frame

#: a builtin_interfaces/Time nanosec field is valid in [0, 1e9)
NSEC_PER_SEC = 1_000_000_000


def stamp_ns(sec: int, nanosec: int) -> int:
    """A stamp (or duration) as nanoseconds: the order of stamps, a duration's length."""
    return sec * NSEC_PER_SEC + nanosec


def stamp_valid(sec: Any, nanosec: Any) -> Any:
    """Can a request stamp (sec, nanosec) be echoed: a ROS time, 0 <= sec, 0 <= nanosec < 1e9?
    Works on ints and on numpy arrays (elementwise); nanosec is unsigned in the message."""
    return (sec >= 0) & (nanosec < NSEC_PER_SEC)


def stamp_error(sec: int, nanosec: int) -> str | None:
    """Why a request's ``header.stamp`` (sec, nanosec) cannot be echoed on the answers, or None.

    builtin_interfaces/Time wants 0 <= nanosec < 1e9, and a ROS time is never negative
    (rclpy's ``Time.from_msg`` and ``rclcpp::Time`` both refuse a negative ``sec``), so a consumer
    of an answer carrying such a stamp would fail on it.
    """
    if sec < 0:
        return (
            f'header.stamp is negative (sec = {sec}, nanosec = {nanosec}): a ROS '
            'time cannot be before 0; stamp the request with the clock, or leave it 0 and '
            "the node uses its clock's now"
        )
    if nanosec >= NSEC_PER_SEC:
        return (
            f'header.stamp.nanosec = {nanosec} must be below 1000000000 (carry whole '
            f'seconds into sec = {sec})'
        )
    return None


def frame_error(
    what: str, frame: str, node_frame: str, field: str = 'header.frame_id'
) -> str | None:
    """Why a request in ``frame`` cannot be answered by a node working in ``node_frame`` (there
    is no tf lookup), or None; an empty frame means the node's."""
    if not frame or frame == node_frame:
        return None
    return (
        f'{what} is in frame {echo(frame)} but this node works in {node_frame!r}; transform it '
        f'first (or leave {field} empty to mean the node frame)'
    )


def names_frame_error(
    what: str, mech: Mechanism, names: Iterable[str], frame: str, node_frame: str
) -> str | None:
    """:func:`frame_error` for a request of ``names``: only point coordinates and link angles
    have a frame (core.model.names.depends_on_frame); joint and actuator values are the same
    in every frame."""
    if not frame or not any(depends_on_frame(mech, n) for n in names):
        return None
    return frame_error(f'{what} of point coordinates or link angles', frame, node_frame)
