"""Recorded trajectories and paths (``~/trajectory``: trajectory_msgs/JointTrajectory,
``~/target_path/<point>``: nav_msgs/Path), answered as the node answers them.

They are read beside the command topics and answered at their place in bag time: the commands
before them set the state they start from, and (a trajectory being a plan) they leave it as it
was. The solving is trajectory.py's, the node's own; only the stamp rule is the bag's, as for
commands (a zero stamp is the bag receive time).
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from ..core.errors import echo
from ..engine import Engine, max_request_names
from ..plan_cdr import (
    CdrError,
    path_bytes_bound,
    peek_plan,
    size_refusal,
    trajectory_bytes_bound,
)
from ..stamps import stamp_error
from ..trajectory import (
    MAX_TRAJECTORY_POINTS,
    TrajectoryAnswer,
    answer_path_msg,
    answer_trajectory_msg,
    too_many_points,
)
from .common import BagError
from .reading import _exc_text, _open_reader, _shortfall, check_log_time, topic_connections

TRAJECTORY = 'trajectory_msgs/msg/JointTrajectory'
PATH = 'nav_msgs/msg/Path'


@dataclass
class PlanRequest:
    """One recorded trajectory or path, and (once answered) its answer."""

    log_ns: int  # bag receive time
    topic: str
    request: str  # 'trajectory' or 'target_path/<point>' (the status's request key)
    msg: Any  # the decoded message; None when it was refused from its size or first bytes
    answer: TrajectoryAnswer | None = None
    #: why the message was refused before it was decoded (its size, its point count)
    refused: str = ''
    times_ns: list[int] = field(default_factory=list)
    stamp: tuple[int, int] = (0, 0)


def path_point(topic: str) -> str:
    """The point a ``.../target_path/<point>`` topic is for: its last name."""
    return topic.rstrip('/').rsplit('/', 1)[-1]


def _decode(raw: bytes | memoryview, typename: str, typestore: Any) -> Any:
    """CDR -> a rosbags message, accepting the slack bytes rclpy's serialiser leaves after a
    message (rosbags' deserialize_cdr refuses them: every recorded bag)."""
    data = memoryview(raw)
    if len(data) < 4 or bytes(data[:2]) not in (b'\x00\x00', b'\x00\x01'):
        raise ValueError('not a CDR message (unknown encapsulation)')
    msgdef = typestore.get_msgdef(typename)
    func = msgdef.deserialize_cdr_le if data[1] else msgdef.deserialize_cdr_be
    msg, pos = func(data[4:], 0, msgdef.cls, typestore)
    if pos > len(data) - 4:
        raise ValueError('the message is cut short')
    return msg


def read_plan_requests(
    path: str,
    trajectory_topics: Sequence[str],
    path_topics: Sequence[str],
    accept_missing: bool = False,
    mech: Any = None,
    frame_id: str = '',
) -> tuple[list[PlanRequest], dict[str, int]]:
    """Every message of the topics, decoded, in bag time order, with the same checks as the
    command topics (receive times, counts against the bag's index); BagError naming the bag,
    the topic and the message otherwise. With ``mech``, a message longer than any request to
    the scene can be, or with more points than one request may have, is refused from its size
    or first bytes before it is decoded, as the node refuses it (a 10^6-point trajectory is not
    read into memory to be refused)."""
    from rosbags.typesys import Stores, get_typestore

    topics = [(t, TRAJECTORY) for t in trajectory_topics] + [(t, PATH) for t in path_topics]
    if not topics:
        return [], {}
    ts = get_typestore(Stores.ROS2_JAZZY)
    reader = _open_reader(path)
    out: list[PlanRequest] = []
    try:
        conns = topic_connections(reader, path, topics)
        read: dict[int, int] = {}
        for i, (conn, t, raw) in enumerate(reader.messages([c for g in conns for c in g])):
            check_log_time(path, i, conn.topic, t)
            request = (
                'trajectory'
                if conn.msgtype == TRAJECTORY
                else f'target_path/{path_point(conn.topic)}'
            )
            refused = '' if mech is None else _refusal(raw, conn.msgtype, mech, frame_id)
            if refused:
                read[conn.id] = read.get(conn.id, 0) + 1
                out.append(PlanRequest(t, conn.topic, request, None, refused=refused))
                continue
            try:
                msg = _decode(raw, conn.msgtype, ts)
            except Exception as exc:  # noqa: BLE001 - a damaged message
                raise BagError(
                    f'input {path}: message {read.get(conn.id, 0) + 1} on {conn.topic} is not '
                    f'a {conn.msgtype} ({_exc_text(exc)})'
                ) from None
            read[conn.id] = read.get(conn.id, 0) + 1
            out.append(PlanRequest(t, conn.topic, request, msg))
        missing = _shortfall(path, conns, read, accept_missing)
    except BagError:
        raise
    except Exception as exc:  # noqa: BLE001 - truncated chunk, corrupt database, ...
        raise BagError(
            f'input {path}: cannot read the trajectory topics ({_exc_text(exc)}); the bag is '
            'truncated or corrupt'
        ) from None
    finally:
        with contextlib.suppress(Exception):
            reader.close()
    out.sort(key=lambda r: r.log_ns)
    return out, missing


def _refusal(raw: bytes | memoryview, msgtype: str, mech: Any, frame_id: str) -> str:
    """Why the node would refuse this plan message from its size or first bytes, or ''."""
    path = msgtype != TRAJECTORY
    kind = 'path' if path else 'trajectory'
    bound = (
        path_bytes_bound(frame_id, MAX_TRAJECTORY_POINTS)
        if path
        else trajectory_bytes_bound(mech, MAX_TRAJECTORY_POINTS)
    )
    if len(raw) > bound:
        return size_refusal(kind, len(raw), mech.name, bound, MAX_TRAJECTORY_POINTS)
    try:
        peek = peek_plan(raw, path, max_request_names(mech))
    except CdrError:
        return ''  # decoded whole below, which says what is wrong with it
    if peek.count > MAX_TRAJECTORY_POINTS:
        return too_many_points(kind, peek.count, 'poses' if path else 'points')
    return ''


def answer_plan(engine: Engine, req: PlanRequest, frame_id: str) -> None:
    """Answer one recorded trajectory or path as the node does (its stamp: the message's, a
    zero stamp the bag receive time; an invalid one refused)."""
    if req.msg is None:  # refused from its size or first bytes, as the node refuses it
        req.stamp = divmod(req.log_ns, 1_000_000_000)
        req.answer, req.times_ns = TrajectoryAnswer(False, req.refused), []
        return
    st = req.msg.header.stamp
    sec, nanosec = int(st.sec), int(st.nanosec)
    if sec == 0 and nanosec == 0:
        sec, nanosec = divmod(req.log_ns, 1_000_000_000)
    req.stamp = (sec, nanosec)
    bad = stamp_error(sec, nanosec)
    if bad:
        req.answer, req.times_ns = TrajectoryAnswer(False, bad), []
    elif req.request == 'trajectory':
        req.answer, req.times_ns = answer_trajectory_msg(engine, req.msg, frame_id)
    else:
        point = req.request.split('/', 1)[1]
        req.answer, req.times_ns = answer_path_msg(engine, point, req.msg, frame_id)


def plans_csv_path(csv_path: str) -> str:
    """Where the trajectories' CSV goes beside a command CSV: ``out.csv`` ->
    ``out.trajectories.csv``."""
    p = str(csv_path)
    return (p[:-4] if p.lower().endswith('.csv') else p) + '.trajectories.csv'


def write_plans_csv(path: str, plans: Sequence[PlanRequest], mech: Any) -> None:
    """One row per solved point (request index, topic, request, bag time, stamp, status,
    point index, time_from_start, every published joint: mech.output_joint_names), one row per
    refused request (its reason, failed_index), written whole or not at all."""
    joints = mech.output_joint_names
    import csv

    from ..outputs import written_whole

    head = ['request', 'topic', 'kind', 'log_ns', 'stamp_sec', 'stamp_nanosec', 'status']
    head += ['reason', 'failed_index', 'point', 'time_from_start_ns']
    head += [f'joint.{j}' for j in joints]
    with written_whole(path) as tmp, open(tmp, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(head)
        for k, req in enumerate(plans):
            ans = req.answer
            assert ans is not None
            base = [k, req.topic, req.request, req.log_ns, req.stamp[0], req.stamp[1]]
            if not ans.success:
                index = '' if ans.failed_index is None else ans.failed_index
                w.writerow(base + ['error', ans.reason, index, '', ''] + [''] * len(joints))
                continue
            for i, (r, t) in enumerate(zip(ans.results, req.times_ns)):
                values = [repr(float(v)) for v in mech.output_joints(r.joints)]
                w.writerow(base + ['ok', '', '', i, t] + values)


def plans_summary(plans: Sequence[PlanRequest]) -> list[str]:
    if not plans:
        return []
    ok = sum(1 for p in plans if p.answer is not None and p.answer.success)
    lines = [f'  trajectories and paths: {len(plans)} read, solved {ok}, refused {len(plans) - ok}']
    for p in plans:
        if p.answer is not None and not p.answer.success:
            lines.append(f'    {p.topic} at {p.log_ns}: {echo(p.answer.reason)}')
            break
    return lines
