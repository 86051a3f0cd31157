"""Message types, the node's name and the bag tool's error."""

from __future__ import annotations

from ..core.errors import LinkageError

JOINT_STATE = 'sensor_msgs/msg/JointState'
POINT_STAMPED = 'geometry_msgs/msg/PointStamped'
DIAGNOSTIC_STATUS = 'diagnostic_msgs/msg/DiagnosticStatus'

#: the node's name: its status messages are named '<NODE_NAME>: <scene name>'
NODE_NAME = 'linkage_node'

#: rows solved per vectorised chunk (adapted between these bounds)
#: commands solved one by one after a row the batch could not vouch for
#: a batch row is kept when the other assembly mode is farther from the node's prediction by at
#: least this fraction of the length scale (or this many radians for a guide orientation)
#: runs shorter than this are solved one by one (a batch has a fixed cost)
#: batch rows this close to a dyad tangency are left to the single-command solver


class BagError(LinkageError):
    """The input bag or an output path cannot be used; one message, exit status 2."""
