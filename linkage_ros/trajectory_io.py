"""ROS messages of trajectory answers (the node's ``~/solved_trajectory`` and the status); reading
the requests and solving them is trajectory.py's (ROS-free, shared with the bag tool)."""

from __future__ import annotations

from collections.abc import Sequence

from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from std_msgs.msg import Header
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .trajectory import TrajectoryAnswer, trajectory_status_values


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
    """One status for a whole trajectory (trajectory.trajectory_status_values)."""
    ok, message, values = trajectory_status_values(answer, request)
    return DiagnosticStatus(
        level=DiagnosticStatus.OK if ok else DiagnosticStatus.ERROR,
        name=name,
        message=message,
        hardware_id=hardware_id,
        values=[KeyValue(key=k, value=v) for k, v in values.items()],
    )
