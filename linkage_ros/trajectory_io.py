"""The status message of a trajectory answer; reading the requests and solving them is
trajectory.py's (ROS-free, shared with the bag tool), the solved trajectory's bytes
plan_cdr.py's, the status values trajectory.trajectory_status_values'."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue


def trajectory_status(
    ok: bool, message: str, values: dict[str, str], name: str, hardware_id: str
) -> DiagnosticStatus:
    """One status for a whole trajectory (its ok, message and key-values:
    trajectory.trajectory_status_values)."""
    return DiagnosticStatus(
        level=DiagnosticStatus.OK if ok else DiagnosticStatus.ERROR,
        name=name,
        message=message,
        hardware_id=hardware_id,
        values=[KeyValue(key=k, value=v) for k, v in values.items()],
    )
