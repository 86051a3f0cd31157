"""Helpers of the node tests that serve a scene from a ``linkage_node`` subprocess over real DDS
(test_node_four_bar, test_node_multi_dof, test_node_trajectories, test_node_startup; their
fixtures are in conftest.py).

Each node is a subprocess (``python -m linkage_ros.node``) started once per test module, in its
own namespace, on the module's random ROS domain (its DOMAIN_ID) with discovery limited to this
host. The test side is a plain rclpy node that publishes requests (reliable, waiting for the
match and for the acknowledgement) and collects joint_states, points, markers and status,
always with timeouts.

Oracles are independent of the core: the four-bar is solved here by circle intersection (and
checked on the Freudenstein equation); multi-DOF scenes are checked on rigid-body invariants of
the published geometry (every link keeps its reference point distances, commanded cylinder
throws and crank angles appear as given, a point target is met exactly).
"""

from __future__ import annotations

import math
import signal
import time
from pathlib import Path

import yaml
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped
from ros_harness import NodeProcess, RosHarness
from sensor_msgs.msg import JointState
from visualization_msgs.msg import Marker, MarkerArray

from linkage_ros.core.model import Scene

ANSWER_TIMEOUT = 10.0  # s: an answer that takes longer is a failure
QUIET = 0.4  # s: bounded window after an error proving nothing else arrives
SETTLE = 0.15  # s: the same after a success (only a second status could come)
ANGLE_TOL = 1e-12  # rad: the node against the float oracle measured <= 2e-15
LENGTH_TOL = 1e-12  # m (the four-bars here are ~0.3 m; measured <= 2e-16)

# ---- independent four-bar oracle ------------------------------------------------------------


def wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def angle_diff(a: float, b: float) -> float:
    return abs(wrap(a - b))


class FourBarOracle:
    """Closed-form four-bar written out here: A on the crank circle, B = intersection of the
    coupler circle about A and the rocker circle about O4 on the scene's side of A -> O4
    (branch +1 = left), the coupler point by its polar offset from A relative to A -> B."""

    def __init__(self, scene_path: Path):
        fb = yaml.safe_load(scene_path.read_text())['four_bar']
        self.l2, self.l3, self.l4 = fb['crank'], fb['coupler'], fb['rocker']
        if 'pivots' in fb:
            self.o2, self.o4 = tuple(fb['pivots']['O2']), tuple(fb['pivots']['O4'])
        else:
            g = fb.get('ground_angle', 0.0)
            self.o2 = (0.0, 0.0)
            self.o4 = (fb['ground'] * math.cos(g), fb['ground'] * math.sin(g))
        self.l1 = math.dist(self.o2, self.o4)
        self.g = math.atan2(self.o4[1] - self.o2[1], self.o4[0] - self.o2[0])
        self.branch = 1 if fb.get('branch', 1) in (1, '+', '+1') else -1
        cp = fb.get('coupler_point')
        self.cp = (cp.get('name', 'P'), cp['distance'], cp.get('angle', 0.0)) if cp else None

    def solve(self, theta2: float) -> dict:
        ax = self.o2[0] + self.l2 * math.cos(theta2)
        ay = self.o2[1] + self.l2 * math.sin(theta2)
        dx, dy = self.o4[0] - ax, self.o4[1] - ay
        d = math.hypot(dx, dy)
        along = (self.l3**2 - self.l4**2 + d**2) / (2 * d)
        h = math.sqrt(self.l3**2 - along**2)
        ux, uy = dx / d, dy / d
        bx = ax + along * ux - self.branch * h * uy
        by = ay + along * uy + self.branch * h * ux
        t3 = math.atan2(by - ay, bx - ax)
        t4 = math.atan2(by - self.o4[1], bx - self.o4[0])
        out = {
            'theta3': t3,
            'theta4': t4,
            'A': (ax, ay),
            'B': (bx, by),
            'joints': {
                'O2': wrap(theta2 - self.g),
                'A': wrap(t3 - theta2),
                'B': wrap(t4 - t3),
                'O4': wrap(t4 - self.g),
            },
        }
        if self.cp:
            name, dist, ang = self.cp
            out[name] = (ax + dist * math.cos(t3 + ang), ay + dist * math.sin(t3 + ang))
        return out

    def freudenstein(self, theta2: float, theta4: float) -> float:
        """K1 cos t4 - K2 cos t2 + K3 - cos(t2 - t4), angles from the ground line."""
        a, b, c, d = self.l2, self.l3, self.l4, self.l1
        t2, t4 = theta2 - self.g, theta4 - self.g
        k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
        return k1 * math.cos(t4) - k2 * math.cos(t2) + k3 - math.cos(t2 - t4)


# ---- message helpers ------------------------------------------------------------------------


def joint_state(names, positions, stamp=(0, 0), velocity=()) -> JointState:
    msg = JointState()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.name = list(names)
    msg.position = [float(p) for p in positions]
    msg.velocity = [float(v) for v in velocity]
    return msg


def point_stamped(x, y, stamp=(0, 0), frame_id='') -> PointStamped:
    msg = PointStamped()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.header.frame_id = frame_id
    msg.point.x, msg.point.y = float(x), float(y)
    return msg


def stamp_of(msg) -> tuple[int, int]:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


def status_values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def marker_points(markers: MarkerArray, mech) -> dict[str, dict[str, tuple[float, float]]]:
    """{link: {point: (x, y)}} from the link LINE_STRIPs (ids = link order in the scene)."""
    names = list(mech.links)
    out = {}
    for m in markers.markers:
        if m.ns.endswith('/links') and m.type == Marker.LINE_STRIP:
            link = mech.links[names[m.id]]
            out[link.name] = {p: (q.x, q.y) for p, q in zip(link.points, m.points)}
    return out


# ---- served nodes ---------------------------------------------------------------------------


class Served:
    """A started node and the test-side endpoints that talk to it."""

    def __init__(self, ros: RosHarness, proc: NodeProcess, scene_path: Path):
        self.ros, self.proc = ros, proc
        self.mech = Scene.from_yaml(scene_path).mechanism
        self.frame_id = self.mech.frame_id
        self.command = ros.publisher(JointState, proc.topic('~/command'))
        self.joints = ros.collector(JointState, proc.topic('joint_states'))
        self.status = ros.collector(DiagnosticStatus, proc.topic('~/status'))
        self.markers = ros.collector(MarkerArray, proc.topic('~/markers'))
        self.points = {
            p: ros.collector(PointStamped, proc.topic(f'~/points/{p}')) for p in self.mech.outputs
        }
        self._pubs = {}

    @property
    def collectors(self):
        return [self.joints, self.status, self.markers, *self.points.values()]

    def publisher(self, msg_type, topic: str):
        """A publisher on one of the node's topics, matched before it is returned."""
        if topic not in self._pubs:
            pub = self.ros.publisher(msg_type, self.proc.topic(topic))
            self.ros.wait_for_discovery([pub], process=self.proc)
            self._pubs[topic] = pub
        return self._pubs[topic]

    def ready(self, warmup: JointState, timeout: float = 30.0):
        """Wait for discovery (matched counts on both sides), then send a good command until
        every output answered once: the node's writers have matched our readers too (a sample
        written before that match is lost for a volatile reader). Then forget those answers."""
        self.ros.wait_for_discovery([self.command], self.collectors, timeout, self.proc)
        end = time.monotonic() + timeout
        retried = False
        while True:
            self.ros.publish(self.command, warmup)
            # 3.5 s: one Fast DDS heartbeat period, in which a lost sample is repaired
            if self.ros.spin_until(lambda: all(len(c) for c in self.collectors), 3.5, self.proc):
                break
            if time.monotonic() > end:
                raise TimeoutError(f'no answer on {[c.topic for c in self.collectors if not c]}')
            retried = True
        self.ros.spin_for(3.5 if retried else SETTLE)  # late repeats of a retried warm-up
        self.clear()
        return self

    def clear(self):
        for c in self.collectors:
            c.clear()

    def request(self, msg, topic: str = '~/command', msg_type=JointState) -> DiagnosticStatus:
        """Send one request and return its status (after a bounded quiet window, so anything
        else it caused has arrived too)."""
        pub = self.command if topic == '~/command' else self.publisher(msg_type, topic)
        self.clear()
        self.ros.publish(pub, msg)
        assert self.ros.spin_until(lambda: len(self.status) >= 1, ANSWER_TIMEOUT, self.proc), (
            f'no status within {ANSWER_TIMEOUT} s'
        )
        if self.status.last.level == DiagnosticStatus.OK:
            # every output of a success is published before its status: wait for them all
            assert self.ros.spin_until(
                lambda: all(len(c) for c in self.collectors), ANSWER_TIMEOUT, self.proc
            )
            self.ros.spin_for(SETTLE)
        else:
            self.ros.spin_for(QUIET)
        return self.status.last

    def assert_single_error(self, status, *fragments):
        assert len(self.status) == 1, [s.message for s in self.status.messages]
        assert status.level == DiagnosticStatus.ERROR
        assert status.name == f'{self.proc.namespace.lstrip("/")}/linkage_node: {self.mech.name}'
        for f in fragments:
            assert f.lower() in status.message.lower(), status.message
        assert len(self.joints) == 0, 'a rejected request must not publish joint_states'
        assert len(self.markers) == 0
        assert all(len(c) == 0 for c in self.points.values())

    def assert_single_ok(self, status):
        assert len(self.status) == 1, [s.message for s in self.status.messages]
        assert status.level == DiagnosticStatus.OK, status.message
        assert status.message == 'ok'
        assert len(self.joints) == 1
        js = self.joints.last
        assert list(js.name) == self.mech.joint_names
        assert all(math.isfinite(v) for v in js.position)
        assert js.header.frame_id == self.frame_id
        return dict(zip(js.name, js.position))


def start_served(ros, workdir, name, scene, warmup, params=None):
    """A node serving ``scene`` on the harness's domain, ready (``warmup`` answered once)."""
    proc = NodeProcess(workdir / name, ros.domain_id, dict(params or {}, scene=str(scene))).start()
    try:
        served = Served(ros, proc, scene).ready(warmup)
    except BaseException:
        proc.stop()
        raise
    return served, proc


def finish(proc):
    """Stop a node with SIGINT: a clean exit (code 0, no traceback)."""
    code = proc.stop(signal.SIGINT)
    assert code == 0, f'unclean exit {code}:\n{proc.output()[-3000:]}'
    assert 'Traceback' not in proc.output(), proc.output()[-3000:]


def mid_command(mech):
    """Every actuator at the middle of its limits."""
    return {a: 0.5 * (act.min + act.max) for a, act in mech.actuators.items()}


def mid_joint_state(scene: Path) -> JointState:
    mid = mid_command(Scene.from_yaml(scene).mechanism)
    return joint_state(list(mid), list(mid.values()))
