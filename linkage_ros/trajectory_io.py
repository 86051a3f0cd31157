"""ROS messages of trajectory answers (the node's ``~/solved_trajectory`` and the status); reading
the requests and solving them is trajectory.py's (ROS-free, shared with the bag tool)."""

from __future__ import annotations

from collections.abc import Sequence

from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from std_msgs.msg import Header
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .core.model import Mechanism
from .trajectory import TrajectoryAnswer, trajectory_status_values


def answer_to_joint_trajectory(
    answer: TrajectoryAnswer,
    mech: Mechanism,
    prefix: str,
    stamp: Time,
    frame_id: str,
    times_ns: Sequence[int],
) -> JointTrajectory:
    """Every published joint (mech.output_joint_names) at every point (rad, m),
    time_from_start as requested, velocities when every point has them."""
    msg = JointTrajectory()
    msg.header = Header(stamp=stamp, frame_id=frame_id)
    msg.joint_names = [prefix + j for j in mech.output_joint_names]
    msg.points = [
        JointTrajectoryPoint(
            positions=positions,
            velocities=velocities,
            time_from_start=Duration(sec=sec, nanosec=nanosec),
        )
        for positions, velocities, sec, nanosec in answer.rows(mech, times_ns)
    ]
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
