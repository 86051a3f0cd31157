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


#: how far (ns) a client's stamp may lie ahead of the node's clock and still be followed by
#: the node's own stamps (OwnStamps): clock skew between machines, not a clock error
MAX_LEAD_NS = 10 * NSEC_PER_SEC


class OwnStamps:
    """The stamps the node chooses itself (a zero-stamped request's answer, a republication):
    strictly after its own last one and after the last joint_states, unless that lies more
    than MAX_LEAD_NS ahead of the clock. A client's clock a little ahead (skew between
    machines) is followed, so the newest pose keeps the newest stamp for tf (which keeps the
    first transform of a stamp); one far ahead is a clock error of the client's, echoed on its
    own answers only: following it would stamp the node's answers an hour (or, for the
    largest stamp, until 2038) ahead and stop republication as long, and 1 ns after the
    largest stamp no longer fits the message. The node's outputs and linkage bag's result bag
    keep one each."""

    __slots__ = ('own_ns', 'stamped_ns')

    def __init__(self) -> None:
        self.stamped_ns = -1  # the latest stamp of any joint_states, a client's included
        self.own_ns = -1  # the latest stamp chosen here

    def floor(self, now_ns: int) -> int:
        """The stamp (ns) one chosen at clock time ``now_ns`` must exceed."""
        latest = self.stamped_ns if self.stamped_ns <= now_ns + MAX_LEAD_NS else -1
        return max(self.own_ns, latest)

    def choose(self, now_ns: int) -> int:
        """The stamp (ns) for an answer at clock time ``now_ns``: now, or 1 ns after the
        floor where now is not later (a paused sim clock, a client's clock a little ahead)."""
        floor = self.floor(now_ns)
        self.own_ns = now_ns if now_ns > floor else floor + 1
        return self.own_ns

    def published(self, ns: int) -> None:
        """A joint_states went out stamped ``ns`` (a client's stamp in the past does not bring
        the latest back)."""
        if ns > self.stamped_ns:
            self.stamped_ns = ns


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
