"""The node's state keeps flowing for a robot stack, over real DDS: joint_states from start-up
at publish_rate (the reference pose before any command), prefixed names, statuses named after
the node as it runs (remapped name, namespace), velocities in joint_states, latched markers
for a late RViz, and /diagnostics at 1 Hz with the node's health."""

from __future__ import annotations

import math
import signal
import time

import pytest
import scenes
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from node_helpers import FourBarOracle
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import NodeProcess, RosHarness, random_domain_id
from sensor_msgs.msg import JointState
from visualization_msgs.msg import Marker, MarkerArray

from linkage_ros.engine import Engine, EngineSettings

DOMAIN_ID = random_domain_id()
TIMEOUT = 20.0
LATCHED = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


@pytest.fixture(scope='module')
def ros():
    harness = RosHarness(DOMAIN_ID, name='outputs_test')
    yield harness
    harness.close()


class Renamed:
    """A four_bar node started as ``arm`` (remapped) in its own namespace, prefix ``left_``,
    publish_rate 20 Hz, marker_rate 10 Hz."""

    def __init__(self, ros, tmp_path, extra=()):
        self.ros = ros
        self.proc = NodeProcess(
            tmp_path,
            DOMAIN_ID,
            params={},  # keyed by the default name, which this node does not have
            args=[
                '-r',
                '__node:=arm',
                '-p',
                'scene:=four_bar',
                '-p',
                'prefix:=left_',
                '-p',
                'publish_rate:=20.0',
                *extra,
            ],
        ).start()
        ns = self.proc.namespace
        self.ns = ns
        self.joints = ros.collector(JointState, f'{ns}/joint_states')
        self.status = ros.collector(DiagnosticStatus, f'{ns}/arm/status')
        self.diagnostics = ros.collector(DiagnosticArray, '/diagnostics')
        self.command = ros.publisher(JointState, f'{ns}/arm/command')
        self.mech = scenes.load('four_bar')

    def close(self):
        code = self.proc.stop(signal.SIGTERM)
        assert code == 0 and 'Traceback' not in self.proc.output(), self.proc.output()[-2000:]

    def ours(self):
        """Our node's /diagnostics statuses (other nodes on the domain publish there too)."""
        return [
            s
            for a in self.diagnostics.messages
            for s in a.status
            if s.name == f'{self.ns.lstrip("/")}/arm: four_bar'
        ]

    def answer(self, msg):
        """Send ``msg`` until its status arrives (the node's writers may match late); the
        status."""
        self.ros.wait_for_discovery([self.command], [self.status], TIMEOUT, self.proc)
        end = time.monotonic() + TIMEOUT
        while time.monotonic() < end:
            self.status.clear()
            self.ros.publish(self.command, msg)
            if self.ros.spin_until(lambda: len(self.status) > 0, 3.5, self.proc):
                return self.status.last
        raise TimeoutError('no status')


@pytest.fixture
def node(ros, tmp_path):
    n = Renamed(ros, tmp_path)
    yield n
    n.close()


def test_reference_pose_flows_from_start_up_and_the_answers_replace_it(ros, node):
    mech = node.mech
    ref = Engine(mech, EngineSettings()).last
    # no command yet: the reference pose, republished at publish_rate with the current time
    assert ros.spin_until(lambda: len(node.joints) >= 5, TIMEOUT, node.proc)
    first = node.joints.messages[0]
    assert list(first.name) == ['left_' + j for j in mech.joint_names]
    assert first.position.tolist() == [ref.joints[j] for j in mech.joint_names]
    assert len(first.velocity) == 0
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in node.joints.messages]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    assert abs(stamps[-1] - time.time()) < 30.0
    # an answer (rates given): its state is what flows afterwards, without the rates
    status = node.answer(JointState(name=['crank'], position=[2.0], velocity=[1.5]))
    assert status.level == DiagnosticStatus.OK, status.message
    assert status.name == f'{node.ns.lstrip("/")}/arm: four_bar'
    assert status.hardware_id == 'four_bar'
    values = {kv.key: kv.value for kv in status.values}
    assert values['velocity'].startswith('ok (cond ')
    engine = Engine(mech, EngineSettings())
    want = engine.command({'crank': 2.0}, {'crank': 1.5})
    answered = [m for m in node.joints.messages if len(m.velocity)]
    assert answered, 'the answer carries velocities'
    got = answered[-1]
    assert got.position.tolist() == [want.joints[j] for j in mech.joint_names]
    for j, v in zip(mech.joint_names, got.velocity):
        assert v == pytest.approx(want.velocity.joints[j], rel=1e-12, abs=1e-15)
    node.joints.clear()
    assert ros.spin_until(lambda: len(node.joints) >= 3, TIMEOUT, node.proc)
    for m in node.joints.messages:
        assert m.position.tolist() == [want.joints[j] for j in mech.joint_names]
        assert len(m.velocity) == 0  # a republished state is not moving at the old rate


def test_markers_are_latched_for_a_late_subscriber(ros, node):
    status = node.answer(JointState(name=['crank'], position=[0.7]))
    assert status.level == DiagnosticStatus.OK
    want = Engine(node.mech, EngineSettings()).command({'crank': 0.7})
    ros.spin_for(0.5)  # a few marker periods: the drawing of this answer went out
    late: list[MarkerArray] = []
    ros.node.create_subscription(MarkerArray, f'{node.ns}/arm/markers', late.append, LATCHED)
    assert ros.spin_until(lambda: len(late) >= 1, TIMEOUT, node.proc)
    strips = [m for m in late[-1].markers if m.type == Marker.LINE_STRIP]
    crank = next(m for m in strips if m.id == list(node.mech.links).index('crank'))
    ax, ay = want.points['A']
    assert math.dist((crank.points[1].x, crank.points[1].y), (ax, ay)) < 1e-12


def test_diagnostics_report_health_at_1_hz(ros, node):
    assert node.answer(JointState(name=['crank'], position=[1.0])).level == DiagnosticStatus.OK
    bad = node.answer(JointState(name=['crank'], position=[math.nan]))
    assert bad.level == DiagnosticStatus.ERROR
    node.diagnostics.clear()
    assert ros.spin_until(lambda: len(node.ours()) >= 2, TIMEOUT, node.proc)
    last = node.ours()[-1]
    values = {kv.key: kv.value for kv in last.values}
    assert last.hardware_id == 'four_bar' and last.level == DiagnosticStatus.WARN
    assert values['scene'] == 'four_bar' and values['solver'] == 'closed_form'
    assert int(values['answered']) >= 1 and int(values['refused']) >= 1
    assert 'crank' in values['last_error'] and 'command' in values['last_error']
    assert 0 < float(values['smallest_margin']) <= 1
    # back to OK after a good request
    assert node.answer(JointState(name=['crank'], position=[1.1])).level == DiagnosticStatus.OK
    node.diagnostics.clear()
    assert ros.spin_until(lambda: len(node.ours()) >= 1, TIMEOUT, node.proc)
    assert node.ours()[-1].level == DiagnosticStatus.OK


def test_answers_only_publishes_nothing_between_requests(ros, tmp_path):
    proc = NodeProcess(tmp_path, DOMAIN_ID, {'scene': 'four_bar', 'publish_rate': 0.0}).start()
    try:
        joints = ros.collector(JointState, proc.topic('joint_states'))
        ros.wait_for_discovery([], [joints], TIMEOUT, proc)
        ros.spin_for(1.0)
        assert len(joints) == 0
    finally:
        assert proc.stop(signal.SIGINT) == 0


@pytest.mark.parametrize('executor', ['events', 'single_threaded'])
def test_each_executor_serves_commands_and_stops_cleanly(ros, tmp_path, executor):
    """The executor parameter picks the executor (events by default); both answer a command
    and stop on SIGTERM with exit 0 and no traceback."""
    params = {'scene': 'four_bar', 'publish_rate': 0.0, 'executor': executor}
    proc = NodeProcess(tmp_path, DOMAIN_ID, params).start()
    try:
        joints = ros.collector(JointState, proc.topic('joint_states'))
        cmd = ros.publisher(JointState, proc.topic('~/command'))
        ros.wait_for_discovery([cmd], [joints], TIMEOUT, proc)
        # the same command again each second until answered: discovery is seen from our side
        # first, and an answer sent before the node's writer matched our reader is gone
        end = time.monotonic() + TIMEOUT
        while not joints and time.monotonic() < end:
            ros.publish(cmd, JointState(name=['crank'], position=[1.0]))
            ros.spin_until(lambda: len(joints) >= 1, 1.0, proc)
        assert joints, proc.output()[-2000:]
        got = dict(zip(joints.last.name, joints.last.position))
        want = FourBarOracle(scenes.CONFIG / 'four_bar.yaml').solve(1.0)['joints']['O4']
        assert abs(math.remainder(got['O4'] - want, 2 * math.pi)) < 1e-12
    finally:
        assert proc.stop(signal.SIGTERM) == 0
    assert 'Traceback' not in proc.output()


def test_dimensions_parameter_redraws_the_scene(ros, tmp_path):
    """-p dimensions:=[crank.O2-A=0.12]: the node publishes the four-bar with that crank from
    start-up (the reference pose, crank angle held) and says so in its first log line; the
    pose is the one `Scene.from_yaml(..., dimensions=)` gives (the CLI's)."""
    from linkage_ros.core.model import Scene
    from linkage_ros.core.solver import Solver

    over = Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml', {'crank.O2-A': 0.12}).mechanism
    ref = Solver(over, knowns=['crank'], branch='reference')
    want = ref.solve(ref.reference_values()).joints
    params = {'scene': 'four_bar', 'dimensions': ['crank.O2-A=0.12'], 'publish_rate': 10.0}
    proc = NodeProcess(tmp_path, DOMAIN_ID, params).start()
    try:
        joints = ros.collector(JointState, proc.topic('joint_states'))
        ros.wait_for_discovery([], [joints], TIMEOUT, proc)
        assert ros.spin_until(lambda: len(joints) >= 1, TIMEOUT, proc)
        got = dict(zip(joints.last.name, joints.last.position))
        for name, value in want.items():
            assert abs(got[name] - value) <= 1e-12, name
        drawn = Solver(scenes.load('four_bar'), knowns=['crank'], branch='reference')
        assert abs(got['B'] - drawn.solve(drawn.reference_values()).joints['B']) > 1e-3
        assert 'dimensions crank.O2-A=0.12' in proc.output()
    finally:
        assert proc.stop(signal.SIGTERM) == 0
