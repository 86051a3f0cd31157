"""Message types, the node's name and the bag tool's error."""

from __future__ import annotations

import re
from enum import StrEnum

from ..core.errors import LinkageError

JOINT_STATE = 'sensor_msgs/msg/JointState'
POINT_STAMPED = 'geometry_msgs/msg/PointStamped'
DIAGNOSTIC_STATUS = 'diagnostic_msgs/msg/DiagnosticStatus'

#: the storage of a result bag --out writes where --out-format is not given
DEFAULT_OUT_FORMAT = 'mcap'

#: the node's name: its status messages are named '<NODE_NAME>: <scene name>'
NODE_NAME = 'linkage_node'

#: rows solved per vectorised chunk (adapted between these bounds)
#: commands solved one by one after a row the batch could not vouch for
#: a batch row is kept when the other assembly mode is farther from the node's prediction by at
#: least this fraction of the length scale (or this many radians for a guide orientation)
#: runs shorter than this are solved one by one (a batch has a fixed cost)
#: batch rows this close to a dyad tangency are left to the single-command solver


def node_topic(name: str) -> str:
    """The topic the node publishes ``~/<name>`` on (its default name and namespace)."""
    return f'/{NODE_NAME}/{name}'


def output_topics(outputs: list[str], plans: bool) -> list[str]:
    """The topics of a result bag under the node's own names: ``/joint_states`` (the node's
    is relative: /joint_states without a namespace), ``/linkage_node/points/<p>``,
    ``/linkage_node/status`` and, with recorded trajectories or paths,
    ``/linkage_node/solved_trajectory``."""
    return (
        ['/joint_states']
        + [node_topic(f'points/{p}') for p in outputs]
        + [node_topic('status')]
        + ([node_topic('solved_trajectory')] if plans else [])
    )


#: a fully qualified ROS 2 topic name: '/' then tokens of letters, digits and _ (none starting
#: with a digit) joined by single '/' (rmw's rules: a result bag is replayed into ROS)
ABSOLUTE_TOPIC = re.compile(r'(/[A-Za-z_][A-Za-z0-9_]*)+')
#: the longest topic name rmw takes (255 less 8 for the DDS prefix: rclpy's
#: validate_full_topic_name)
MAX_TOPIC_CHARS = 247


def parse_remaps(items: list[str], topics: list[str]) -> dict[str, str]:
    """--remap FROM:=TO items -> {FROM: TO}; BagError for a malformed item, a FROM that is not
    one of ``topics``, a TO that is not an absolute ROS 2 topic name (ABSOLUTE_TOPIC) or that
    two topics share."""
    remap: dict[str, str] = {}
    for item in items:
        old, sep, new = item.partition(':=')
        if not sep or not old or not new:
            raise BagError(f'--remap {item!r}: write FROM:=TO (e.g. /linkage_node/status:=/status)')
        if old not in topics:
            raise BagError(
                f'--remap {item!r}: {old} is not an output topic; the output topics are '
                + ', '.join(topics)
            )
        if not ABSOLUTE_TOPIC.fullmatch(new):
            raise BagError(
                f"--remap {item!r}: {new!r} is not an absolute topic name ('/' then names of "
                "letters, digits and _, none starting with a digit, joined by single '/': "
                '/a/b)'
            )
        if len(new) > MAX_TOPIC_CHARS:
            raise BagError(
                f'--remap {old}:=...: the new name has {len(new)} characters; a ROS 2 topic '
                f'name has at most {MAX_TOPIC_CHARS}'
            )
        remap[old] = new
    final = [remap.get(t, t) for t in topics]
    if len(set(final)) != len(final):
        raise BagError('--remap: two output topics would share one name')
    return remap


class BagError(LinkageError):
    """The input bag or an output path cannot be used; one message, exit status 2."""


class OutputKind(StrEnum):
    """What a bag run writes: a table (CSV, Parquet), a plot, or a result bag."""

    CSV = 'csv'
    PARQUET = 'parquet'
    PLOT = 'plot'
    BAG = 'bag'
