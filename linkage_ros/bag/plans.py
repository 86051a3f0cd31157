"""Recorded trajectories and paths (``~/trajectory``: trajectory_msgs/JointTrajectory,
``~/target_path/<point>``: nav_msgs/Path), answered as the node answers them.

They are read beside the command topics and answered at their place in bag time: the commands
before them set the state they start from, and (a trajectory being a plan) they leave it as it
was. The solving is trajectory.py's, the node's own; only the stamp rule is the bag's, as for
commands (a zero stamp is the bag receive time).

Memory: the bag is read twice for them. The first read places each message (bag time, topic,
size) without decoding it; the second decodes each when its turn comes, and once its outputs
have its answer only its outcome is kept (bag/run_outputs.py), so one plan is held at a time.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..core.errors import echo
from ..engine import Engine
from ..plan_cdr import (
    CdrError,
    path_bytes_bound,
    peek_plan,
    size_refusal,
    trailing_error,
    trajectory_bytes_bound,
)
from ..request_checks import max_request_names
from ..stamps import stamp_error
from ..trajectory import (
    MAX_TRAJECTORY_POINTS,
    TrajectoryAnswer,
    answer_path_msg,
    answer_trajectory_msg,
    too_many_points,
)
from .common import BagError
from .reading import check_log_time, exc_text, open_reader, shortfall, topic_connections

TRAJECTORY = 'trajectory_msgs/msg/JointTrajectory'
PATH = 'nav_msgs/msg/Path'


@dataclass(frozen=True)
class PlanOutcome:
    """What is kept of an answered plan once its outputs have it: success, the reason and the
    first failing point of a refusal, the number of points solved."""

    success: bool
    reason: str = ''
    failed_index: int | None = None
    points: int = 0


@dataclass
class PlanRequest:
    """One recorded trajectory or path: its place in the bag (read first, without decoding),
    then while it is answered its message and answer, and once its outputs have it only its
    :class:`PlanOutcome` (a 10^4-point answer is tens of MB: one plan at a time is held)."""

    log_ns: int  # bag receive time
    topic: str
    #: the path's point (a ~/target_path/<point> message); None for a trajectory
    point: str | None
    msg: Any  # the decoded message while it is answered; None before, after, and when refused
    answer: TrajectoryAnswer | None = None
    #: why the message was refused before it was decoded (its size, its point count)
    refused: str = ''
    times_ns: list[int] = field(default_factory=list)
    stamp: tuple[int, int] = (0, 0)
    #: its message number on its topic (1, 2, ...) and its index in the bag's reading order
    number: int = 0
    ordinal: int = 0
    outcome: PlanOutcome | None = None

    @property
    def request(self) -> str:
        """The status's request key: 'trajectory' or 'target_path/<point>'."""
        return 'trajectory' if self.point is None else f'target_path/{self.point}'

    @property
    def succeeded(self) -> bool:
        """Answered with success (from the answer, or the outcome kept after it)."""
        if self.answer is not None:
            return self.answer.success
        return self.outcome is not None and self.outcome.success

    @property
    def reason(self) -> str:
        if self.answer is not None:
            return self.answer.reason
        return '' if self.outcome is None else self.outcome.reason

    def shed(self) -> None:
        """Keep only the outcome: the message and the answer's points go."""
        ans = self.answer
        if ans is not None:
            self.outcome = PlanOutcome(ans.success, ans.reason, ans.failed_index, len(ans.results))
        self.msg, self.answer, self.times_ns = None, None, []


def path_point(topic: str) -> str:
    """The point a ``.../target_path/<point>`` topic is for: its last name."""
    return topic.rstrip('/').rsplit('/', 1)[-1]


def decode_plan(raw: bytes | memoryview, typename: str, typestore: Any) -> Any:
    """CDR -> a rosbags message, accepting the slack bytes rclpy's serialiser leaves after a
    message (rosbags' deserialize_cdr refuses them: every recorded bag), and no more than the
    node takes (plan_cdr.trailing_error)."""
    data = memoryview(raw)
    if len(data) < 4 or bytes(data[:2]) not in (b'\x00\x00', b'\x00\x01'):
        raise ValueError('not a CDR message (unknown encapsulation)')
    msgdef = typestore.get_msgdef(typename)
    func = msgdef.deserialize_cdr_le if data[1] else msgdef.deserialize_cdr_be
    msg, pos = func(data[4:], 0, msgdef.cls, typestore)
    if pos > len(data) - 4:
        raise ValueError('the message is cut short')
    items = len(msg.points) if typename == TRAJECTORY else len(msg.poses)
    too_long = trailing_error(len(data) - 4 - pos, items)
    if too_long:
        raise ValueError(too_long)
    return msg


def read_plan_requests(
    path: str,
    trajectory_topics: Sequence[str],
    path_topics: Sequence[str],
    accept_missing: bool = False,
    mech: Any = None,
    frame_id: str = '',
) -> tuple[list[PlanRequest], dict[str, int]]:
    """Every message of the topics in bag time order, placed but not decoded (each is decoded
    when its turn comes: :func:`decoded_plans`), with the same checks as the command topics
    (receive times, counts against the bag's index); BagError naming the bag, the topic and the
    message otherwise. With ``mech``, a message longer than any request to the scene can be, or
    with more points than one request may have, is refused from its size or first bytes, as the
    node refuses it (a 10^6-point trajectory is never decoded)."""
    topics = plan_topics(trajectory_topics, path_topics)
    if not topics:
        return [], {}
    out: list[PlanRequest] = []
    with _plan_reader(path) as reader:
        conns = topic_connections(reader, path, topics)
        read: dict[int, int] = {}
        for i, (conn, t, raw) in enumerate(reader.messages([c for g in conns for c in g])):
            check_log_time(path, i, conn.topic, t)
            point = None if conn.msgtype == TRAJECTORY else path_point(conn.topic)
            refused = '' if mech is None else plan_refusal(raw, conn.msgtype, mech, frame_id)
            read[conn.id] = read.get(conn.id, 0) + 1
            out.append(
                PlanRequest(
                    t, conn.topic, point, None, refused=refused, number=read[conn.id], ordinal=i
                )
            )
        missing = shortfall(path, conns, read, accept_missing)
    out.sort(key=lambda r: r.log_ns)
    return out, missing


def plan_topics(
    trajectory_topics: Sequence[str], path_topics: Sequence[str]
) -> list[tuple[str, str]]:
    return [(t, TRAJECTORY) for t in trajectory_topics] + [(t, PATH) for t in path_topics]


@contextlib.contextmanager
def _plan_reader(path: str) -> Iterator[Any]:
    """The bag open for reading its plan topics, closed after; a failure to read it (not a
    BagError already) as a BagError saying the bag is truncated or corrupt."""
    reader = open_reader(path)
    try:
        yield reader
    except BagError:
        raise
    except Exception as exc:  # noqa: BLE001 - truncated chunk, corrupt database, ...
        raise BagError(
            f'input {path}: cannot read the trajectory topics ({exc_text(exc)}); the bag is '
            'truncated or corrupt'
        ) from None
    finally:
        with contextlib.suppress(Exception):
            reader.close()


def decoded_plans(
    path: str, topics: Sequence[tuple[str, str]], plans: Sequence[PlanRequest]
) -> Iterator[PlanRequest]:
    """``plans`` (read_plan_requests' list) one at a time in that order, each with its message
    decoded (``msg``; a refused one without): the bag is read a second time, and a message
    is held only from its reading to its turn (the reader gives them in time order: one at a
    time). BagError for a message that does not decode."""
    if not plans:
        return
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    with _plan_reader(path) as reader:
        conns = topic_connections(reader, path, list(topics))
        stream = enumerate(reader.messages([c for g in conns for c in g]))
        waiting: dict[int, tuple[Any, int, Any]] = {}  # read before their turn
        for req in plans:
            while req.ordinal not in waiting:
                try:
                    i, (conn, t, raw) = next(stream)
                except StopIteration:
                    raise BagError(
                        f'input {path}: message {req.number} on {req.topic} is gone (the bag '
                        'changed while it was read)'
                    ) from None
                waiting[i] = (conn, t, raw)
            conn, t, raw = waiting.pop(req.ordinal)
            if conn.topic != req.topic or t != req.log_ns:
                raise BagError(f'input {path}: the bag changed while it was read')
            if not req.refused:
                try:
                    req.msg = decode_plan(raw, conn.msgtype, ts)
                except Exception as exc:  # noqa: BLE001 - a damaged message
                    raise BagError(
                        f'input {path}: message {req.number} on {conn.topic} is not '
                        f'a {conn.msgtype} ({exc_text(exc)})'
                    ) from None
            del raw
            yield req


def plan_refusal(raw: bytes | memoryview, msgtype: str, mech: Any, frame_id: str) -> str:
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
    elif req.point is None:
        req.answer, req.times_ns = answer_trajectory_msg(engine, req.msg, frame_id)
    else:
        req.answer, req.times_ns = answer_path_msg(engine, req.point, req.msg, frame_id)


def plans_csv_path(csv_path: Any) -> str:
    """Where the trajectories' CSV goes beside a command CSV: ``out.csv`` ->
    ``out.trajectories.csv``."""
    p = str(csv_path)
    return (p[:-4] if p.lower().endswith('.csv') else p) + '.trajectories.csv'


def plans_summary(plans: Sequence[PlanRequest]) -> list[str]:
    if not plans:
        return []
    ok = sum(1 for p in plans if p.succeeded)
    lines = [f'  trajectories and paths: {len(plans)} read, solved {ok}, refused {len(plans) - ok}']
    per_topic: dict[str, int] = {}
    for p in plans:  # each plan topic's count, as the command topics' above
        per_topic[p.topic] = per_topic.get(p.topic, 0) + 1
    lines += [f'    {topic}: {count}' for topic, count in per_topic.items()]
    for p in plans:
        if not p.succeeded:
            lines.append(f'    {p.topic} at {p.log_ns}: {echo(p.reason)}')
            break
    return lines
