"""ROS messages of trajectory requests and answers (the node's ``~/trajectory``,
``~/target_path/<point>`` and ``~/solved_trajectory``); the solving is trajectory.py's."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from nav_msgs.msg import Path
from std_msgs.msg import Header
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .core.errors import CommandError
from .trajectory import MAX_TRAJECTORY_POINTS, TrajectoryAnswer


def duration_ns(d: Duration) -> int:
    return int(d.sec) * 1_000_000_000 + int(d.nanosec)


def joint_trajectory_request(
    msg: JointTrajectory,
) -> tuple[list[str], list[Sequence[float]], list[Sequence[float]], list[int]]:
    """(joint_names, positions per point, velocities per point, time_from_start ns per point);
    CommandError for more points than one request may have (checked before any copy)."""
    if len(msg.points) > MAX_TRAJECTORY_POINTS:
        raise CommandError(
            f'trajectory has {len(msg.points)} points; at most {MAX_TRAJECTORY_POINTS} are '
            'solved in one request (send it in parts)'
        )
    names = list(msg.joint_names)
    pts = msg.points
    return (
        names,
        [p.positions for p in pts],
        [p.velocities for p in pts],
        [duration_ns(p.time_from_start) for p in pts],
    )


def path_request(
    msg: Path, point: str, frame_id: str
) -> tuple[list[tuple[float, float]], list[int]]:
    """The (x, y) of every pose (m) and each pose's time from the first (ns: its stamp less the
    first's when the stamps increase strictly, else 0: a path has no timing); CommandError for a
    frame other than the node's or a non-finite coordinate."""
    if len(msg.poses) > MAX_TRAJECTORY_POINTS:
        raise CommandError(
            f'path has {len(msg.poses)} poses; at most {MAX_TRAJECTORY_POINTS} are solved in one '
            'request (send it in parts)'
        )
    frames = {msg.header.frame_id} | {p.header.frame_id for p in msg.poses}
    foreign = sorted(f for f in frames if f and f != frame_id)
    if foreign:
        raise CommandError(
            f'path of {point!r} is in frame {foreign[0]!r} but this node works in {frame_id!r}; '
            'transform it first (or leave frame_id empty to mean the node frame)'
        )
    xy = []
    for i, pose in enumerate(msg.poses):
        p = pose.pose.position
        for axis, v in (('x', p.x), ('y', p.y), ('z', p.z)):
            if not math.isfinite(v):
                raise CommandError(f'pose {i}: position.{axis} = {v} is not finite')
        xy.append((float(p.x), float(p.y)))
    stamps = [
        int(p.header.stamp.sec) * 1_000_000_000 + int(p.header.stamp.nanosec) for p in msg.poses
    ]
    timed = all(b > a for a, b in zip(stamps, stamps[1:]))
    times = [s - stamps[0] for s in stamps] if stamps and timed else [0] * len(stamps)
    return xy, times


def answer_to_joint_trajectory(
    answer: TrajectoryAnswer,
    joint_names: Sequence[str],
    prefix: str,
    stamp: Time,
    frame_id: str,
    times_ns: Sequence[int],
) -> JointTrajectory:
    """Every joint of the scene at every point (rad, m), time_from_start as requested,
    velocities when every point has them."""
    msg = JointTrajectory()
    msg.header = Header(stamp=stamp, frame_id=frame_id)
    msg.joint_names = [prefix + j for j in joint_names]
    with_rates = all(r.velocity is not None and r.velocity.success for r in answer.results)
    points = []
    for r, t in zip(answer.results, times_ns):
        pt = JointTrajectoryPoint()
        pt.positions = [float(r.joints[j]) for j in joint_names]
        if with_rates:
            pt.velocities = [float(r.velocity.joints[j]) for j in joint_names]
        pt.time_from_start = Duration(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000)
        points.append(pt)
    msg.points = points
    return msg


def trajectory_status(
    answer: TrajectoryAnswer, name: str, request: str, hardware_id: str
) -> DiagnosticStatus:
    """One status for a whole trajectory: OK with points, largest residual, smallest margin
    and velocity; or ERROR with the reason (naming the first failing point)."""
    if not answer.success:
        values: dict[str, Any] = {'request': request}
        if answer.failed_index is not None:
            values = {'failed_index': answer.failed_index, **values}
        level, message = DiagnosticStatus.ERROR, answer.reason
    else:
        with_rates = all(r.velocity is not None and r.velocity.success for r in answer.results)
        values = {
            'points': len(answer.results),
            'residual': answer.largest_residual,
            'margin': answer.smallest_margin,
            'solver': answer.results[-1].solver,
            'velocity': 'ok' if with_rates else 'none',
            'request': request,
        }
        level, message = DiagnosticStatus.OK, 'ok'
    return DiagnosticStatus(
        level=level,
        name=name,
        message=message,
        hardware_id=hardware_id,
        values=[KeyValue(key=k, value='' if v is None else str(v)) for k, v in values.items()],
    )
