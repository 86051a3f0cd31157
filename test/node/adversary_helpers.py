"""Helpers of the adversarial node tests (test_node_adversarial_*.py, test_node_plans.py): a
:class:`~linkage_ros.node.LinkageNode` inside the test process, spun by the test harness's
executor and talked to over real DDS (its own namespace, on the module's random domain), an
independent four-bar oracle, and message builders.

Answers are awaited, never slept for: after each bad request the test waits for its status,
then sends a good *probe* with a unique stamp and waits for the probe's joint_states.
joint_states and status each come from one writer, in order, so everything the bad request
published has arrived by then and is checked.
"""

from __future__ import annotations

import math
import os
import random
from itertools import count

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import RosHarness
from sensor_msgs.msg import JointState

from linkage_ros.node import NODE_NAME, LinkageNode

TIMEOUT = 10.0  # s: an answer that takes longer is a failure
OK, ERROR = DiagnosticStatus.OK, DiagnosticStatus.ERROR
DEEP = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
    depth=200,
    durability=DurabilityPolicy.VOLATILE,
)

_stamps = count(1000)


def stamp_next() -> tuple[int, int]:
    return (next(_stamps), 123)


def joint_state(names, positions, stamp=(0, 0), velocity=(), effort=()) -> JointState:
    msg = JointState(
        name=list(names),
        position=[float(p) for p in positions],
        velocity=[float(v) for v in velocity],
        effort=[float(e) for e in effort],
    )
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    return msg


def in_frame(msg: JointState, frame_id: str) -> JointState:
    msg.header.frame_id = frame_id
    return msg


def point_stamped(x, y, z=0.0, stamp=(0, 0), frame_id='') -> PointStamped:
    msg = PointStamped()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.header.frame_id = frame_id
    msg.point.x, msg.point.y, msg.point.z = float(x), float(y), float(z)
    return msg


def stamp_of(msg) -> tuple[int, int]:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


# ---- an independent four-bar oracle (circle intersection) -----------------------------------


class FourBar:
    """The packaged four_bar: O2 = 0, O4 = (0.3, 0), crank 0.1, coupler 0.25, rocker 0.2, B left
    of A -> O4. Joint values as docs/TOPICS.md defines them (ground along +x)."""

    O4, L2, L3, L4 = (0.30, 0.0), 0.10, 0.25, 0.20

    @classmethod
    def joints(cls, theta2: float) -> list[float]:
        ax, ay = cls.L2 * math.cos(theta2), cls.L2 * math.sin(theta2)
        dx, dy = cls.O4[0] - ax, cls.O4[1] - ay
        d = math.hypot(dx, dy)
        along = (cls.L3**2 - cls.L4**2 + d * d) / (2 * d)
        h = math.sqrt(cls.L3**2 - along**2)
        bx, by = ax + (along * dx - h * dy) / d, ay + (along * dy + h * dx) / d
        t3 = math.atan2(by - ay, bx - ax)
        t4 = math.atan2(by - cls.O4[1], bx - cls.O4[0])
        w = lambda a: math.atan2(math.sin(a), math.cos(a))  # noqa: E731
        return [w(theta2), w(t3 - theta2), w(t4 - t3), w(t4)]  # O2, A, B, O4


def assert_close_angles(got, want, tol=1e-12):
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert abs(math.atan2(math.sin(g - w), math.cos(g - w))) < tol, (list(got), want)


# ---- a node in this process, over DDS -------------------------------------------------------


class Served:
    """A LinkageNode in this process (its own namespace), the harness's executor spinning it, and
    the test-side endpoints: collectors of joint_states and status, publishers made on demand."""

    def __init__(self, ros: RosHarness, params: dict):
        self.ros = ros
        self.ns = f'/adv{os.getpid()}_{random.randrange(1 << 30)}'
        self.node = LinkageNode(
            context=ros.context,
            namespace=self.ns,
            # answers only: these tests count the messages each request causes
            parameter_overrides=[
                Parameter(k, value=v) for k, v in {'publish_rate': 0.0, **params}.items()
            ],
        )
        ros.executor.add_node(self.node)
        self.mech = self.node.mech
        self.joints = ros.collector(JointState, f'{self.ns}/joint_states')
        self.status = ros.collector(DiagnosticStatus, f'{self.ns}/{NODE_NAME}/status')
        self._pubs = {}
        # both ends matched: our readers see the node's writers and the node's writers see ours
        # (the node publishes a status only while someone subscribes)
        assert ros.spin_until(
            lambda: (
                self.joints.sub.get_publisher_count() > 0
                and self.status.sub.get_publisher_count() > 0
                and self.node.outputs.pub_joints.get_subscription_count() > 0
                and self.node.outputs.pub_status.get_subscription_count() > 0
            ),
            TIMEOUT,
        )

    def close(self):
        self.ros.executor.remove_node(self.node)
        self.node.destroy_node()

    def pub(self, topic: str, msg_type=JointState):
        if topic not in self._pubs:
            pub = self.ros.publisher(msg_type, f'{self.ns}/{NODE_NAME}/{topic}')
            assert self.ros.spin_until(lambda: pub.get_subscription_count() > 0, TIMEOUT)
            self._pubs[topic] = pub
        return self._pubs[topic]

    def clear(self):
        self.joints.clear()
        self.status.clear()

    def send(self, topic: str, msg) -> DiagnosticStatus:
        """Publish one request and wait for its (first) status."""
        self.clear()
        self.pub(topic, PointStamped if topic.startswith('target_point/') else JointState).publish(
            msg
        )
        assert self.ros.spin_until(lambda: len(self.status) >= 1, TIMEOUT), f'no status: {topic}'
        return self.status.messages[0]

    def good(self, topic: str, msg) -> list[float]:
        """Send a request that must succeed (msg must carry a unique, non-zero stamp); wait for
        its joint_states; return the positions. Exactly one OK status and one joint_states."""
        want = stamp_of(msg)
        assert want != (0, 0)
        status = self.send(topic, msg)
        assert status.level == OK, status.message
        assert self.ros.spin_until(
            lambda: any(stamp_of(j) == want for j in self.joints.messages), TIMEOUT
        )
        assert len(self.joints) == 1 and len(self.status) == 1, (
            [stamp_of(j) for j in self.joints.messages],
            [s.message for s in self.status.messages],
        )
        js = self.joints.last
        assert list(js.name) == self.mech.joint_names
        assert all(math.isfinite(v) for v in js.position), list(js.position)
        return list(js.position)

    def bad(self, topic: str, msg, fragments, probe: tuple[str, JointState]) -> str:
        """Send a request that must be refused: one ERROR status naming every fragment, then the
        probe (a good request with a unique stamp) and its answer; nothing else may come: no
        joint_states and no second status for the bad request."""
        status = self.send(topic, msg)
        assert status.level == ERROR, f'accepted: {topic} {msg}'
        assert status.name == f'{self.ns.lstrip("/")}/{NODE_NAME}: {self.mech.name}'
        for f in fragments:
            assert f in status.message, (f, status.message)
        assert {kv.key: kv.value for kv in status.values}.get('request') == topic
        want = stamp_of(probe[1])
        self.pub(probe[0])  # matched before we publish
        self.ros.publish(self.pub(probe[0]), probe[1])
        assert self.ros.spin_until(
            lambda: any(stamp_of(j) == want for j in self.joints.messages), TIMEOUT
        ), 'the probe after a bad request was not answered'
        assert self.ros.spin_until(lambda: len(self.status) >= 2, TIMEOUT)
        assert [stamp_of(j) for j in self.joints.messages] == [want], (
            'a refused request published joint_states'
        )
        assert [s.level for s in self.status.messages] == [ERROR, OK], [
            s.message for s in self.status.messages
        ]
        return status.message
