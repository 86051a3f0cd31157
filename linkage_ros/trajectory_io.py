"""The status message of a trajectory answer; reading the requests and solving them is
trajectory.py's (ROS-free, shared with the bag tool), the solved trajectory's bytes
plan_cdr.py's."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from .trajectory import TrajectoryAnswer, trajectory_status_values


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
