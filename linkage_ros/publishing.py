"""What the node publishes, and when: answers on the request path, the rest on timers.

* On the request path (one answer per request): ``joint_states``, ``~/points/<p>`` (only those
  someone subscribes to) and one ``~/status``.
* ``publish_rate``: the last good state again on ``joint_states``, stamped now, when no answer
  went out for a period (from start-up: the reference pose), like joint_state_publisher.
* ``marker_rate``: ``~/markers`` (transient-local, depth 1: a late RViz gets the latest) from a
  timer, only when the state changed and someone subscribes: a display's needs never slow the
  command path.
* ``/diagnostics`` at 1 Hz: the node's health (scene, solver, requests answered and refused,
  the last error, the smallest margin seen).
"""

from __future__ import annotations

import math
import time

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from .answer_cdr import AnswerBytes
from .conversions import error_status, result_to_markers
from .core.solver import Result
from .engine import Engine
from .marker_cdr import MarkerBytes
from .params import NodeConfig
from .stamps import NSEC_PER_SEC, OwnStamps, stamp_ns

#: /diagnostics period (s): the diagnostic_updater convention
DIAGNOSTICS_PERIOD_S = 1.0
#: how long a publisher found with subscribers is taken to still have them before rmw is
#: asked again (s): asking costs about a tenth of a publish, on every answer of every topic
LISTENED_RECHECK_S = 0.05


class Listened:
    """Whether ``pub`` has subscribers: asked of rmw on every call while it has none (a new
    subscriber gets the next answer), at most every LISTENED_RECHECK_S while it has (one that
    left gets answers for that long more: a publish nobody takes, nothing else). ``now``:
    time.monotonic() (s), read once per answer for all its outputs."""

    def __init__(self, pub: Publisher):
        self.pub = pub
        self._until = -math.inf

    def __call__(self, now: float) -> bool:
        if now < self._until:
            return True
        if self.pub.get_subscription_count():
            self._until = now + LISTENED_RECHECK_S
            return True
        return False


def topic_qos(depth: int) -> QoSProfile:
    """Reliable, keep last ``depth``, volatile: commands and outputs alike."""
    return QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        durability=DurabilityPolicy.VOLATILE,
    )


def latched_qos() -> QoSProfile:
    """Reliable, keep last 1, transient local: a late subscriber gets the latest message."""
    return QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        history=HistoryPolicy.KEEP_LAST,
        depth=1,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )


class Channels:
    """The publishers that outlive a mechanism: ``joint_states``, ``~/status``, ``~/markers``,
    ``~/solved_trajectory`` and ``/diagnostics``. A robot description that replaces the
    mechanism keeps them (its subscribers, robot_state_publisher among them, never see the
    endpoint go away and come back); they also answer while the node waits for its first
    description."""

    def __init__(self, node: Node, config: NodeConfig):
        self.node = node
        # Each QoS-event handler is one more waitable that the executor polls on every wakeup,
        # which costs the same order as the solve itself: the outputs carry none (the other end
        # reports an incompatible QoS or type on its side).
        # the answers keep output_depth for a subscriber that falls behind (a writer drops what
        # a reader has not taken beyond its depth); a solved trajectory can be MBs: queue_depth
        qos = topic_qos(config.output_depth)
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self.quiet = quiet
        self.joints = node.create_publisher(JointState, 'joint_states', qos, event_callbacks=quiet)
        self.markers = node.create_publisher(
            MarkerArray, '~/markers', latched_qos(), event_callbacks=quiet
        )
        self.status = node.create_publisher(
            DiagnosticStatus, '~/status', qos, event_callbacks=quiet
        )
        self.trajectory = node.create_publisher(
            JointTrajectory,
            '~/solved_trajectory',
            topic_qos(config.queue_depth),
            event_callbacks=quiet,
        )
        self.diagnostics = node.create_publisher(
            DiagnosticArray, '/diagnostics', topic_qos(10), event_callbacks=quiet
        )

    def now(self) -> Time:
        return self.node.get_clock().now().to_msg()

    def diagnose(
        self, level: bytes, message: str, name: str, hardware_id: str, values: dict[str, object]
    ) -> None:
        """Publish one /diagnostics status."""
        status = DiagnosticStatus(level=level, name=name, message=message, hardware_id=hardware_id)
        status.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        msg = DiagnosticArray()
        msg.header = Header(stamp=self.now())
        msg.status = [status]
        self.diagnostics.publish(msg)


class Outputs:
    """One mechanism's outputs: its ``~/points/<p>`` publishers and timers on the node's
    :class:`Channels`, and the counters /diagnostics reports. :meth:`destroy` ends them (a
    robot description replaced the mechanism); the channels stay."""

    def __init__(
        self,
        node: Node,
        engine: Engine,
        config: NodeConfig,
        frame_id: str,
        channels: Channels | None = None,
        source: str = '',
        clear_markers: bool = False,
    ):
        mech = engine.mech
        self.node, self.engine, self.mech = node, engine, mech
        self.config, self.frame_id = config, frame_id
        #: where the mechanism came from (/diagnostics' scene_file): the scene file by default
        self.source = source or config.scene_path
        #: joints left out of joint_states: in state completion, those the hardware publishes
        self.omit_joints: frozenset[str] = frozenset()
        #: statuses are named after the node as it runs (remapped name, namespace)
        self.status_name = f'{node.get_fully_qualified_name().lstrip("/")}: {mech.name}'
        #: a robot description refused while this mechanism runs: /diagnostics says ERROR
        self.description_error = ''
        self.channels = channels = channels or Channels(node, config)
        self.pub_joints = channels.joints
        self.pub_markers = channels.markers
        self.pub_status = channels.status
        self.pub_trajectory = channels.trajectory
        self.pub_diagnostics = channels.diagnostics
        qos = topic_qos(config.output_depth)
        #: the answers written as bytes (answer_cdr): no message objects on the request path
        self.answers = AnswerBytes(mech, frame_id, self.status_name, config.prefix)
        self.pub_points = {
            p: node.create_publisher(
                PointStamped, f'~/points/{p}', qos, event_callbacks=channels.quiet
            )
            for p in mech.outputs
        }
        self._points_listened = [(n, pub, Listened(pub)) for n, pub in self.pub_points.items()]
        self._status_listened = Listened(self.pub_status)
        # health counters for /diagnostics
        self.answered = 0
        self.refused = 0
        self.last_error = ''
        self.last_ok = True
        self.smallest_margin: float | None = None
        self._answered_since_tick = False
        #: the stamps the node chooses itself (stamps.OwnStamps)
        self.stamps = OwnStamps()
        #: the clock (ns) at the last republication tick: a clock that has not moved since is
        #: paused (a sim clock)
        self._tick_clock_ns: int | None = None
        #: the newest state not drawn yet: at start-up the reference pose
        self._marker_state: tuple[Result, Time] | None = (
            None if engine.last is None else (engine.last, self.now())
        )
        #: a replaced mechanism's drawing is cleared by the first one of this (other links)
        self._clear_markers = clear_markers
        #: the markers written as bytes (marker_cdr): a template patched per drawing
        self.marker_bytes = MarkerBytes(mech, frame_id) if config.marker_rate > 0 else None
        self.timers = []
        if config.publish_rate > 0:
            self.timers.append(node.create_timer(1.0 / config.publish_rate, self._republish))
        if config.marker_rate > 0:
            self.timers.append(node.create_timer(1.0 / config.marker_rate, self._draw))
        self.timers.append(node.create_timer(DIAGNOSTICS_PERIOD_S, self.diagnose))

    def destroy(self) -> None:
        """End this mechanism's timers and point publishers (the channels stay)."""
        for timer in self.timers:
            timer.cancel()
            self.node.destroy_timer(timer)
        self.timers = []
        for pub in self.pub_points.values():
            self.node.destroy_publisher(pub)
        self.pub_points = {}
        self._points_listened = []

    def set_omit_joints(self, names: frozenset[str]) -> None:
        """Leave ``names`` out of joint_states from now on (state completion)."""
        if names != self.omit_joints:
            self.omit_joints = names
            self.answers = AnswerBytes(
                self.mech, self.frame_id, self.status_name, self.config.prefix, names
            )

    def now(self) -> Time:
        return self.node.get_clock().now().to_msg()

    # -- the request path -------------------------------------------------------------------------
    def answer(self, result: Result, stamp: Time, request: str) -> None:
        """Publish the answer to one request: on success joint_states, the subscribed points
        and an OK status; on failure only an ERROR status."""
        self.last_ok = result.success
        now = time.monotonic()
        if result.success:
            self.answered += 1
            sec, nanosec = stamp.sec, stamp.nanosec
            answers = self.answers
            self._publish_state(result, sec, nanosec)
            for name, pub, listened in self._points_listened:
                if listened(now):
                    pub.publish(answers.point(result, name, sec, nanosec))
            self._marker_state = (result, stamp)
            m = result.margin
            if (
                m is not None
                and math.isfinite(m)
                and (self.smallest_margin is None or m < self.smallest_margin)
            ):
                self.smallest_margin = m
        else:
            self.refused += 1
            self.last_error = f'{request}: {result.reason}'
        if self._status_listened(now):
            self.pub_status.publish(self.answers.status(result, request))

    def answer_trajectory(
        self,
        ok: bool,
        message: str,
        values: dict[str, str],
        request: str,
        solved: bytes | None = None,
    ) -> None:
        """A trajectory or path (its status: trajectory.trajectory_status_values): when ok
        ~/solved_trajectory (``solved``, serialised by the plan worker), then one status
        either way."""
        self.last_ok = ok
        if ok:
            assert solved is not None
            self.answered += 1
            self.pub_trajectory.publish(solved)
        else:
            self.refused += 1
            self.last_error = f'{request}: {message}'
        self.pub_status.publish(self.answers.plan_status(ok, message, values))

    def internal_error(self, reason: str, request: str) -> None:
        self.refused += 1
        self.last_ok = False
        self.last_error = f'{request}: {reason}'
        self.pub_status.publish(self.answers.error(reason, request))

    def _publish_state(self, result: Result, sec: int, nanosec: int) -> None:
        self.pub_joints.publish(self.answers.joint_state(result, sec, nanosec))
        self._answered_since_tick = True
        self.stamps.published(stamp_ns(sec, nanosec))

    def after_last(self, stamp: Time) -> Time:
        """``stamp`` (the clock's now, for a request left unstamped), or 1 ns after the last
        joint_states if that is not earlier (stamps.OwnStamps): a paused sim clock would give
        an answer the stamp of the republished pose before it, and tf keeps the first
        transform of a stamp (TF_REPEATED_DATA), so robot_state_publisher would show the old
        pose."""
        now = stamp_ns(stamp.sec, stamp.nanosec)
        chosen = self.stamps.choose(now)
        if chosen == now:
            return stamp
        return Time(sec=chosen // NSEC_PER_SEC, nanosec=chosen % NSEC_PER_SEC)

    # -- timers -----------------------------------------------------------------------------------
    def _republish(self) -> None:
        """The last good state, stamped now (OwnStamps: 1 ns after a client's stamp a little
        ahead of the clock, as an answer is), unless an answer went out this period or the
        clock is paused at a time the state went out at."""
        now = self.now()
        now_ns = stamp_ns(now.sec, now.nanosec)
        paused = now_ns == self._tick_clock_ns
        self._tick_clock_ns = now_ns
        if self._answered_since_tick:
            self._answered_since_tick = False
            return
        last = self.engine.last
        if last is None:
            return
        if last.velocity is not None:  # the rates of a past command are not the state's now
            last = Result(True, joints=last.joints)
        if paused and now_ns <= self.stamps.floor(now_ns):
            # a paused (sim) clock: the state went out at this time already (a clock that runs
            # behind a client's stamps republishes after them: the client's skew is followed)
            return
        chosen = self.stamps.choose(now_ns)
        self._publish_state(last, chosen // NSEC_PER_SEC, chosen % NSEC_PER_SEC)
        self._answered_since_tick = False

    def _draw(self) -> None:
        """Markers of the newest state, if it changed since the last drawing (whether anyone
        subscribes or not: the latched topic keeps it for a late RViz). The first drawing of a
        mechanism that replaced another starts by deleting the old one's markers."""
        state, self._marker_state = self._marker_state, None
        if state is not None:
            result, stamp = state
            if not self._clear_markers:
                assert self.marker_bytes is not None
                self.pub_markers.publish(self.marker_bytes.write(result, stamp.sec, stamp.nanosec))
                return
            markers = result_to_markers(result, self.mech, stamp, self.frame_id)
            self._clear_markers = False
            clear = Marker(action=Marker.DELETEALL)
            clear.header = Header(stamp=stamp, frame_id=self.frame_id)
            markers.markers.insert(0, clear)
            self.pub_markers.publish(markers)

    def diagnose(self) -> None:
        """Publish the health status on /diagnostics (the 1 Hz timer, or at once)."""
        engine = self.engine
        if self.description_error:
            level, message = DiagnosticStatus.ERROR, self.description_error
        elif engine.last is None:
            level, message = DiagnosticStatus.ERROR, 'no good state'
        elif not self.last_ok:
            level, message = DiagnosticStatus.WARN, 'last request refused'
        else:
            level, message = DiagnosticStatus.OK, 'ok'
        values = {
            'scene': self.mech.name,
            'scene_file': self.source,
            'solver': engine.forward.mode,
            'branch': self.config.branch,
            'answered': self.answered,
            'refused': self.refused,
            'last_error': self.last_error,
            'smallest_margin': '' if self.smallest_margin is None else self.smallest_margin,
        }
        self.channels.diagnose(level, message, self.status_name, self.mech.name, values)


class Waiting:
    """Before the first robot description arrives on ``topic``: /diagnostics WARN at 1 Hz
    (ERROR while the last one that arrived was refused), and every request answered by an ERROR
    status saying so. Nothing else is published."""

    def __init__(self, node: Node, channels: Channels, topic: str):
        self.node, self.channels = node, channels
        self.message = f'waiting for a robot description on {topic}'
        self.status_name = node.get_fully_qualified_name().lstrip('/')
        #: why the last description that arrived was refused ('' if none was)
        self.refused_description = ''
        self.refused = 0
        self.timer = node.create_timer(DIAGNOSTICS_PERIOD_S, self.diagnose)

    def reason(self) -> str:
        if self.refused_description:
            return f'{self.message} (the last one was refused: {self.refused_description})'
        return self.message

    def answer(self, request: str) -> None:
        self.refused += 1
        self.channels.status.publish(error_status(self.reason(), self.status_name, request))

    def diagnose(self) -> None:
        if self.refused_description:
            level, message = DiagnosticStatus.ERROR, self.reason()
        else:
            level, message = DiagnosticStatus.WARN, self.message
        values = {
            'scene': '',
            'refused': self.refused,
            'last_error': self.refused_description,
        }
        self.channels.diagnose(level, message, self.status_name, '', values)

    def destroy(self) -> None:
        self.timer.cancel()
        self.node.destroy_timer(self.timer)
