"""linkage_node on real robot descriptions, over real DDS.

Each node is a subprocess (test/ros_harness.py) in its own namespace on one random ROS domain
with discovery limited to this host; every node of the module is started at once (they start
in parallel) and stopped at the end, each checked for a clean exit.

* The fixtures of test/fixtures/robot_descriptions served by their description (the
  ``scene`` parameter with its ``closures`` side file, or the ``robot_description`` parameter's
  text): a ``~/command`` in the description's own joint names is answered by joint_states in
  the description's chain joints, and an independent consumer closes every loop with them:
  Pinocchio's forward kinematics of the URDF (the closure's two points coincide), or for the
  SDF (which Pinocchio does not read) the planar chain written out here from the file's frames.
* ``robot_description_topic``: the node waits (requests refused, a /diagnostics WARN), serves
  the description published transient-local, is replaced whole by a second one, and refuses a
  malformed one while the previous mechanism keeps answering.
* ``joint_states_in`` (state completion): a 'hardware' publisher on the node's own joint_states
  topic sends the actuated joints; the node answers with the passive joints only (velocities
  too), which close the loop with the hardware's values, and never reads its own output back.
"""

from __future__ import annotations

import math
import re
import signal
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import NodeProcess, RosHarness, random_domain_id
from scenes import REPO
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from linkage_ros.core.loading import load_scene

DOMAIN_ID = random_domain_id()
FIXTURES = REPO / 'test' / 'fixtures' / 'robot_descriptions'
START_TIMEOUT = 90.0  # s: every node of the module starts at once, on however few cores
ANSWER_TIMEOUT = 10.0  # s: an answer that takes longer is a failure
ACK_TIMEOUT = 10.0  # s: a reliable sample acknowledged (Fast DDS heartbeats every 3 s)
QUIET = 0.5  # s: a bounded window proving nothing more arrives
CLOSURE_TOL = 1e-9  # of the mechanism's length scale
ACKED = Duration(seconds=ACK_TIMEOUT)
LATCHED = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


def fixture(name: str) -> str:
    return str(FIXTURES / name)


def text_of(name: str) -> str:
    return (FIXTURES / name).read_text()


# ---- the cases: a description, its side file, a command and the closures it must close -------

#: (link, point in the link's frame) pairs that coincide when the loop is closed
ROBOTIQ_PINS = [
    (
        ('robotiq_85_left_inner_knuckle_link', (0.0371575, 0.0, 0.04342168)),
        ('robotiq_85_left_finger_tip_link', (-0.01790114, 0.0, 0.00651548)),
    ),
    (  # the right finger follows the left knuckle by its <mimic> and closes too
        ('robotiq_85_right_inner_knuckle_link', (-0.0371575, 0.0, 0.04342168)),
        ('robotiq_85_right_finger_tip_link', (0.01790114, 0.0, 0.00651548)),
    ),
]
CASES = {
    # the robot_description parameter: the URDF text itself
    'grbda_four_bar': dict(
        description='grbda_four_bar.urdf',
        params={'robot_description': text_of('grbda_four_bar.urdf')},
        command={'joint1': 0.4},
        closures=[(('link2', (1.0, 0.0, 0.0)), ('link3', (0.5, 0.0, 0.0)))],
    ),
    'grbda_six_bar': dict(
        description='grbda_six_bar.urdf',
        params={'scene': fixture('grbda_six_bar.urdf')},
        command={'joint1': 0.3, 'joint2': -0.2, 'joint3': 0.25},
        closures=[(('link3', (0.3, 0.0, 0.0)), ('link5', (0.5, 0.0, 0.0)))],
    ),
    'gepetto_5bar': dict(
        description='gepetto_5bar_linkage/robot.urdf',
        params={
            'scene': fixture('gepetto_5bar_linkage/robot.urdf'),
            'closures': fixture('gepetto_5bar_linkage/robot.yaml'),
        },
        command={'mot1': 0.1, 'mot2': -0.15},
        closures=[(('sphere', (0.0, 0.0, 0.0)), ('sphere_2', (0.0, 0.0, 0.0)))],
    ),
    'robotiq_2f_85': dict(
        description='picknik_robotiq_2f_85.expanded.urdf',
        params={
            'scene': fixture('picknik_robotiq_2f_85.expanded.urdf'),
            'closures': fixture('picknik_robotiq_2f_85.closures.yaml'),
        },
        command={'robotiq_85_left_knuckle_joint': 0.4},
        closures=ROBOTIQ_PINS,
    ),
    'drake_four_bar': dict(
        description='drake_four_bar_loop.sdf',
        params={
            'scene': fixture('drake_four_bar_loop.sdf'),
            'closures': fixture('drake_four_bar_loop.closures.yaml'),
        },
        command={'world_driver': 0.5},
        closures=[],  # checked by the SDF's own planar chain (Pinocchio reads no SDF)
    ),
}
URDF_CASES = [name for name, case in CASES.items() if case['closures']]


def mechanism_of(case: dict):
    """The mechanism as the core loads it (the names it must publish, its length scale)."""
    params = case['params']
    if 'robot_description' in params:
        return load_scene(params['robot_description'], text=True).mechanism
    return load_scene(params['scene'], closures=params.get('closures')).mechanism


# ---- independent consumers --------------------------------------------------------------------


def wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def pinocchio_closure_misses(urdf: str, joints: dict[str, float], closures) -> list[float]:
    """Pinocchio's forward kinematics of ``urdf`` at ``joints`` (every joint of its tree must
    be given; a continuous joint is (cos, sin)): how far apart each closure's two points are."""
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    q = pin.neutral(model)
    tree = [model.names[i] for i in range(1, model.njoints)]
    assert set(tree) <= set(joints), f'joint_states lacks {sorted(set(tree) - set(joints))}'
    for jid in range(1, model.njoints):
        joint, value = model.joints[jid], joints[model.names[jid]]
        if joint.nq == 2:
            q[joint.idx_q : joint.idx_q + 2] = [math.cos(value), math.sin(value)]
        else:
            q[joint.idx_q] = value
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)

    def world(link, xyz):
        return data.oMf[model.getFrameId(link)].act(np.array(xyz, dtype=float))

    return [float(np.linalg.norm(world(*a) - world(*b))) for a, b in closures]


def pinocchio_joint_names(urdf: str) -> set[str]:
    model = pin.buildModelFromXML(urdf)
    return {model.names[i] for i in range(1, model.njoints)}


def sdf_model(sdf: str) -> ET.Element:
    """The SDF's <model>. Drake's file draws its links in a comment with '--' in it, which XML
    forbids (ElementTree refuses the file): comments go first."""
    return ET.fromstring(re.sub(r'<!--.*?-->', '', sdf, flags=re.DOTALL)).find('model')


def drake_chain(sdf: str, joints: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The coupler's end Cr and the rocker's end Rc, in the world's xy, from the SDF's own
    frames: each link's frame sits on its joint, rotated by the joint's value about +z (every
    axis of the file is +z), the links lined up with the world at q = 0. The loop joint
    coupler_rocker pins Cr to Rc."""
    model = sdf_model(sdf)
    frames = {
        f.get('name'): np.array([float(v) for v in f.find('pose').text.split()[:2]])
        for f in model.findall('frame')
    }

    def turn(a):
        return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])

    driver = joints['world_driver']
    coupler = driver + joints['driver_coupler']
    dc = frames['Wd'] + turn(driver) @ frames['Dc']
    cr = dc + turn(coupler) @ frames['Cr']
    rc = frames['Wr'] + turn(joints['world_rocker']) @ frames['Rc']
    return cr, rc


# ---- nodes -------------------------------------------------------------------------------------


def joint_state(values: dict[str, float], velocity=(), stamp=(0, 0)) -> JointState:
    msg = JointState(name=list(values), position=[float(v) for v in values.values()])
    msg.velocity = [float(v) for v in velocity]
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    return msg


class Node:
    """One node process and the test-side endpoints that talk to it."""

    def __init__(self, ros: RosHarness, proc: NodeProcess):
        self.ros, self.proc = ros, proc
        self.command = ros.publisher(JointState, proc.topic('~/command'))
        self.joints = ros.collector(JointState, proc.topic('joint_states'))
        self.status = ros.collector(DiagnosticStatus, proc.topic('~/status'))
        self._pubs: dict[str, object] = {}

    @property
    def name(self) -> str:
        """The node's name as its statuses and diagnostics carry it."""
        return f'{self.proc.namespace.lstrip("/")}/linkage_node'

    def publisher(self, msg_type, topic: str):
        """A publisher on a topic of the node's, matched before it is returned."""
        if topic not in self._pubs:
            pub = self.ros.publisher(msg_type, self.proc.topic(topic))
            self.ros.wait_for_discovery([pub], timeout=START_TIMEOUT, process=self.proc)
            self._pubs[topic] = pub
        return self._pubs[topic]

    def ready(self, warmup: JointState | None = None) -> Node:
        """Discovery both ways; then, with ``warmup``, a command resent until it is answered
        (the node's writers may match our readers a little after our writer matched its
        reader: an answer written before that is lost for a volatile reader)."""
        self.ros.wait_for_discovery(
            [self.command], [self.joints, self.status], START_TIMEOUT, self.proc
        )
        if warmup is not None:
            for _ in range(int(START_TIMEOUT / 3.5)):
                self.clear()
                self.ros.publish(self.command, warmup)
                if self.ros.spin_until(lambda: len(self.status) > 0, 3.5, self.proc):
                    break
            else:
                raise TimeoutError(f'{self.name}: no answer to the warm-up command')
            assert self.status.last.level == DiagnosticStatus.OK, self.status.last.message
            self.ros.spin_for(QUIET)  # a late repeat of a resent warm-up
        self.clear()
        return self

    def clear(self):
        self.joints.clear()
        self.status.clear()

    def request(self, msg, topic: str = '~/command', msg_type=JointState) -> DiagnosticStatus:
        """Send one request; its one status (and, on success, its joint_states)."""
        pub = self.command if topic == '~/command' else self.publisher(msg_type, topic)
        self.clear()
        self.ros.publish(pub, msg)
        assert self.ros.spin_until(lambda: len(self.status) > 0, ANSWER_TIMEOUT, self.proc), (
            f'{self.name}: no status within {ANSWER_TIMEOUT} s'
        )
        ok = self.status.last.level == DiagnosticStatus.OK
        if ok:
            assert self.ros.spin_until(lambda: len(self.joints) > 0, ANSWER_TIMEOUT, self.proc)
        self.ros.spin_for(QUIET if not ok else 0.1)
        assert len(self.status) == 1, [s.message for s in self.status.messages]
        return self.status.last

    def answer(self, command: dict[str, float]) -> dict[str, float]:
        """A good command's joint_states, as {name: position}."""
        status = self.request(joint_state(command))
        assert status.level == DiagnosticStatus.OK, status.message
        assert len(self.joints) == 1
        js = self.joints.last
        return dict(zip(js.name, js.position))

    def wait_for_log(self, text: str, timeout: float = ANSWER_TIMEOUT, count: int = 1) -> None:
        assert self.ros.spin_until(
            lambda: self.proc.output().count(text) >= count, timeout, self.proc
        ), f'{text!r} not logged:\n{self.proc.output()[-3000:]}'


def topic_node_params() -> dict:
    return {'robot_description_topic': 'robot_description'}


def completion_params() -> dict:
    # the hardware publishes on the node's own joint_states topic, as joint_state_broadcaster
    # and the node share /joint_states on a robot
    return {'scene': fixture('grbda_six_bar.urdf'), 'joint_states_in': 'joint_states'}


@pytest.fixture(scope='module')
def ros():
    harness = RosHarness(DOMAIN_ID, name='descriptions_test')
    yield harness
    harness.close()


@pytest.fixture(scope='module')
def procs(tmp_path_factory):
    """Every node of the module, started at once; stopped (and checked) at the end."""
    workdir = tmp_path_factory.mktemp('descriptions')
    params = {name: case['params'] for name, case in CASES.items()}
    params['topic'] = topic_node_params()
    params['completion'] = completion_params()
    params['completion_robotiq'] = dict(
        CASES['robotiq_2f_85']['params'], joint_states_in='joint_states'
    )
    params['completion_all'] = dict(
        completion_params(), joint_states_in='hw_joint_states', publish_inputs=True
    )
    started = {
        name: NodeProcess(workdir / name, DOMAIN_ID, p).start() for name, p in params.items()
    }
    yield started
    failures = []
    for name, proc in started.items():
        code = proc.stop(signal.SIGINT)
        out = proc.output()
        if code != 0 or 'Traceback' in out:
            failures.append(f'{name}: exit {code}\n{out[-2000:]}')
    assert not failures, '\n'.join(failures)


@pytest.fixture(scope='module')
def nodes(ros, procs):
    """The fixture nodes, each ready (answered its command once)."""
    ready = {}
    for name, case in CASES.items():
        ready[name] = Node(ros, procs[name]).ready(joint_state(case['command']))
    return ready


# ---- the fixtures, served by their own description ---------------------------------------------


@pytest.mark.parametrize('name', URDF_CASES)
def test_a_command_in_the_descriptions_names_closes_its_loops_in_pinocchio(nodes, name):
    case, node = CASES[name], nodes[name]
    mech = mechanism_of(case)
    urdf = text_of(case['description'])
    # a second pose, not the warm-up's: every actuated joint moved
    command = {k: v + 0.05 for k, v in case['command'].items()}
    joints = node.answer(command)
    js = node.joints.last
    assert list(js.name) == mech.output_joint_names  # the description's chain joints, in order
    assert set(js.name) == pinocchio_joint_names(urdf)  # ... which are its whole tree
    assert all(math.isfinite(v) for v in js.position) and len(js.velocity) == 0
    for joint, value in command.items():
        assert abs(wrap(joints[joint] - value)) < 1e-12, (joint, joints[joint], value)
    misses = pinocchio_closure_misses(urdf, joints, case['closures'])
    assert max(misses) < CLOSURE_TOL * mech.length_scale, misses
    # the same pose without the closure solved is open: the check can fail
    opened = dict(joints, **{n: v + 0.1 for n, v in joints.items() if n not in command})
    assert min(pinocchio_closure_misses(urdf, opened, case['closures'])) > 1e-4


def test_the_sdf_four_bar_closes_its_loop_by_the_sdfs_own_chain(nodes):
    case, node = CASES['drake_four_bar'], nodes['drake_four_bar']
    mech = mechanism_of(case)
    sdf = text_of(case['description'])
    joints = node.answer({'world_driver': 0.7})
    js = node.joints.last
    assert list(js.name) == mech.output_joint_names
    # every joint of the file but the loop joint, whose pin closes the chain
    model = sdf_model(sdf)
    assert set(js.name) == {j.get('name') for j in model.findall('joint')} - {'coupler_rocker'}
    assert joints['world_driver'] == pytest.approx(0.7, abs=1e-12)
    cr, rc = drake_chain(sdf, joints)
    assert np.linalg.norm(cr - rc) < CLOSURE_TOL * mech.length_scale, (cr, rc)
    # the links keep the file's lengths (coupler 4.8 m from the driver's end, rocker 2 m)
    world_rocker = np.array([2.0, 0.0])
    assert np.linalg.norm(rc - world_rocker) == pytest.approx(2.0, abs=1e-12)
    cr_open, rc_open = drake_chain(sdf, dict(joints, world_rocker=joints['world_rocker'] + 0.1))
    assert np.linalg.norm(cr_open - rc_open) > 0.1


def test_a_mimic_follower_cannot_be_commanded_and_the_robotiq_logs_its_notes(nodes):
    node = nodes['robotiq_2f_85']
    status = node.request(joint_state({'robotiq_85_right_knuckle_joint': -0.3}))
    assert status.level == DiagnosticStatus.ERROR
    assert 'robotiq_85_left_knuckle_joint' in status.message and len(node.joints) == 0
    out = node.proc.output()
    # the scene's notes and the joint names it publishes, logged at start-up
    assert '<mimic> of robotiq_85_left_inner_knuckle_joint' in out
    mech = mechanism_of(CASES['robotiq_2f_85'])
    assert f'joint_states names: {mech.output_joint_names}' in out
    assert 'assembled (the loops closed)' in nodes['grbda_six_bar'].proc.output()


# ---- robot_description_topic ------------------------------------------------------------------


def our_diagnostics(diagnostics, node: Node) -> list[DiagnosticStatus]:
    return [s for a in diagnostics.messages for s in a.status if s.name.startswith(node.name)]


def test_robot_description_topic_waits_serves_replaces_and_refuses(ros, procs):
    proc = procs['topic']
    node = Node(ros, proc).ready()
    diagnostics = ros.collector(DiagnosticArray, '/diagnostics')
    markers = ros.collector(MarkerArray, proc.topic('~/markers'))
    topic = proc.topic('robot_description')
    waiting = f'waiting for a robot description on {topic}'
    # -- waiting: logged once, a WARN on /diagnostics, every request refused saying so
    node.wait_for_log(waiting)
    assert ros.spin_until(
        lambda: any(s.message == waiting for s in our_diagnostics(diagnostics, node)),
        ANSWER_TIMEOUT,
        proc,
    )
    warn = next(s for s in our_diagnostics(diagnostics, node) if s.message == waiting)
    assert warn.level == DiagnosticStatus.WARN
    for msg, where, kind in [
        (joint_state({'joint1': 0.2}), '~/command', JointState),
        (joint_state({'joint1': 0.2}), '~/target', JointState),
        (
            JointTrajectory(joint_names=['joint1'], points=[JointTrajectoryPoint(positions=[0.2])]),
            '~/trajectory',
            JointTrajectory,
        ),
    ]:
        status = node.request(msg, where, kind)
        assert status.level == DiagnosticStatus.ERROR and status.message == waiting, status
        assert len(node.joints) == 0  # nothing else published
    assert proc.output().count(waiting) == 1 and proc.alive()

    # -- a description arrives (published before the node's reader matched: transient local)
    description = ros.node.create_publisher(String, topic, LATCHED)
    four_bar = text_of('grbda_four_bar.urdf')
    description.publish(String(data=four_bar))
    ros.wait_for_discovery([description], timeout=START_TIMEOUT, process=proc)
    assert description.wait_for_all_acked(ACKED)
    node.wait_for_log(f"scene 'four_bar' from {topic}")
    mech = load_scene(four_bar, text=True).mechanism
    joints = node.answer({'joint1': 0.3})
    assert list(node.joints.last.name) == mech.output_joint_names
    closures = CASES['grbda_four_bar']['closures']
    assert max(pinocchio_closure_misses(four_bar, joints, closures)) < CLOSURE_TOL
    assert ros.spin_until(lambda: len(markers) > 0, ANSWER_TIMEOUT, proc)
    assert all(m.action != Marker.DELETEALL for a in markers.messages for m in a.markers)
    point_topic = proc.topic('~/target_point/loop1')  # a four-bar point's target topic
    assert ros.spin_until(lambda: ros.node.count_subscribers(point_topic) == 1, 10.0, proc)

    # -- a second description replaces the mechanism whole
    six_bar = text_of('grbda_six_bar.urdf')
    description.publish(String(data=six_bar))
    assert description.wait_for_all_acked(ACKED)
    node.wait_for_log("robot description replaced: scene 'six_bar'")
    mech6 = load_scene(six_bar, text=True).mechanism
    command = CASES['grbda_six_bar']['command']
    joints = node.answer(command)
    assert list(node.joints.last.name) == mech6.output_joint_names != mech.output_joint_names
    six_closures = CASES['grbda_six_bar']['closures']
    misses = pinocchio_closure_misses(six_bar, joints, six_closures)
    assert max(misses) < CLOSURE_TOL * mech6.length_scale

    # the four-bar's drawing is deleted before the six-bar's is drawn
    def cleared():
        return any(a.markers and a.markers[0].action == Marker.DELETEALL for a in markers.messages)

    assert ros.spin_until(cleared, ANSWER_TIMEOUT, proc)
    # the four-bar's per-point subscriptions are gone, the six-bar's are there
    assert ros.spin_until(lambda: ros.node.count_subscribers(point_topic) == 0, 10.0, proc)
    six_point = proc.topic('~/target_point/constraint1')
    assert ros.spin_until(lambda: ros.node.count_subscribers(six_point) == 1, 10.0, proc)
    status = node.request(joint_state({'loop1': 0.1}), '~/target')
    assert status.level == DiagnosticStatus.ERROR  # a four-bar name means nothing now

    # -- a malformed description is refused: ERROR status and diagnostic, the six-bar goes on
    diagnostics.clear()
    node.clear()
    description.publish(String(data='<robot name="broken"><link name="a"></robot'))
    assert description.wait_for_all_acked(ACKED)
    assert ros.spin_until(lambda: len(node.status) > 0, ANSWER_TIMEOUT, proc)
    refused = node.status.last
    assert refused.level == DiagnosticStatus.ERROR
    assert refused.message.startswith('robot description refused: '), refused.message
    assert {kv.key: kv.value for kv in refused.values}.get('request') == 'robot_description'
    assert ros.spin_until(
        lambda: any(s.level == DiagnosticStatus.ERROR for s in our_diagnostics(diagnostics, node)),
        ANSWER_TIMEOUT,
        proc,
    )
    diag = next(s for s in our_diagnostics(diagnostics, node) if s.level == DiagnosticStatus.ERROR)
    assert diag.message == refused.message and '\n' not in diag.message
    assert diag.hardware_id == 'six_bar'
    joints = node.answer({'joint1': 0.35})
    assert list(node.joints.last.name) == mech6.output_joint_names
    misses = pinocchio_closure_misses(six_bar, joints, six_closures)
    assert max(misses) < CLOSURE_TOL * mech6.length_scale
    assert 'still serving' in proc.output() and proc.alive()


# ---- state completion ------------------------------------------------------------------------


def test_state_completion_with_publish_inputs_publishes_every_joint(ros, procs):
    """publish_inputs: the hardware stream (another topic) goes to the node alone, and the
    node's joint_states carry the inputs too, for a robot_state_publisher that reads only the
    node (a chain faked by <mimic>, TOPICS). Oracle: Pinocchio closes the loops with the
    hardware's values as published by the node."""
    proc = procs['completion_all']
    node = Node(ros, proc).ready()
    mech = load_scene(fixture('grbda_six_bar.urdf')).mechanism
    hardware = node.publisher(JointState, 'hw_joint_states')
    q = {'joint1': 0.2, 'joint2': -0.1, 'joint3': 0.3}
    node.clear()
    ros.publish(hardware, joint_state(dict(q, arm_joint=1.0), (), (55, 7)))
    assert ros.spin_until(lambda: len(node.joints) > 0, ANSWER_TIMEOUT, proc)
    answer = node.joints.last
    assert list(answer.name) == mech.output_joint_names  # the inputs too
    assert (answer.header.stamp.sec, answer.header.stamp.nanosec) == (55, 7)
    joints = dict(zip(answer.name, answer.position))
    for k, v in q.items():
        assert joints[k] == pytest.approx(v, abs=1e-12)
    closures = CASES['grbda_six_bar']['closures']
    six_bar = text_of('grbda_six_bar.urdf')
    assert max(pinocchio_closure_misses(six_bar, joints, closures)) < 1e-9 * mech.length_scale


def test_state_completion_publishes_the_passive_joints_the_hardware_does_not(ros, procs):
    proc = procs['completion']
    node = Node(ros, proc).ready()
    six_bar = text_of('grbda_six_bar.urdf')
    mech = load_scene(fixture('grbda_six_bar.urdf')).mechanism
    inputs = ['joint1', 'joint2', 'joint3']
    passive = [j for j in mech.output_joint_names if j not in inputs]
    assert passive == ['joint4', 'joint5']
    hardware = node.publisher(JointState, 'joint_states')  # the node's own output topic
    closures = CASES['grbda_six_bar']['closures']

    def from_hardware(values, velocity=(), stamp=(0, 0), extra=None):
        """Publish one hardware JointState (plus ``extra`` joints of another robot); the
        node's joint_states answering it."""
        names = dict(values, **(extra or {}))
        vel = list(velocity) + [0.0] * (len(names) - len(values)) if velocity else ()
        node.clear()
        ros.publish(hardware, joint_state(names, vel, stamp))
        assert ros.spin_until(lambda: len(node.status) > 0, ANSWER_TIMEOUT, proc)
        ros.spin_for(QUIET)
        # one answer: the node reads its own joint_states on this topic too, and ignores them
        assert len(node.status) == 1, [s.message for s in node.status.messages]
        assert node.status.last.level == DiagnosticStatus.OK, node.status.last.message
        values_kv = {kv.key: kv.value for kv in node.status.last.values}
        assert values_kv.get('request') == 'joint_states_in'
        ours = [m for m in node.joints.messages if list(m.name) != list(names)]
        assert len(ours) == 1, [list(m.name) for m in node.joints.messages]
        return ours[0]

    q = {'joint1': 0.2, 'joint2': -0.1, 'joint3': 0.3}
    rates = [0.5, -0.25, 0.1]
    answer = from_hardware(q, rates, stamp=(321, 5), extra={'arm_joint': 1.0})
    assert list(answer.name) == passive
    assert (answer.header.stamp.sec, answer.header.stamp.nanosec) == (321, 5)
    assert len(answer.velocity) == len(passive)  # the hardware's rates give the passive ones
    joints = dict(q, **dict(zip(answer.name, answer.position)))
    assert max(pinocchio_closure_misses(six_bar, joints, closures)) < 1e-9 * mech.length_scale

    # the passive rates: the derivative of the passive joints along the hardware's rates
    h = 1e-6
    ahead = from_hardware({k: v + h * r for (k, v), r in zip(q.items(), rates)})
    behind = from_hardware({k: v - h * r for (k, v), r in zip(q.items(), rates)})
    assert len(ahead.velocity) == 0  # no velocity given, none published
    for i, name in enumerate(passive):
        slope = wrap(ahead.position[i] - behind.position[i]) / (2 * h)
        assert answer.velocity[i] == pytest.approx(slope, rel=1e-5, abs=1e-7), name

    # a partial set holds the others at their last values (the last message's: behind)
    held = {k: v - h * r for (k, v), r in zip(q.items(), rates)}
    answer = from_hardware({'joint2': 0.05})
    assert list(answer.name) == passive
    joints = dict(held, joint2=0.05, **dict(zip(answer.name, answer.position)))
    assert max(pinocchio_closure_misses(six_bar, joints, closures)) < 1e-9 * mech.length_scale

    # a JointState carrying none of the inputs (another robot's, or the node's own): ignored
    node.clear()
    ros.publish(hardware, joint_state({'joint4': 0.0, 'joint5': 0.0}))
    ros.publish(hardware, joint_state({'arm_joint': 0.3}))
    ros.spin_for(QUIET)
    assert len(node.status) == 0 and all(
        list(m.name) in (['joint4', 'joint5'], ['arm_joint']) for m in node.joints.messages
    )
    # ~/command answers carry the passive joints only too (the hardware publishes the rest)
    joints = node.answer(q)
    assert list(node.joints.last.name) == passive
    assert 'state completion from' in proc.output()


# ---- the parameters and the picking of inputs, without a graph --------------------------------


def test_description_parameters_are_checked_before_anything_loads(tmp_path):
    from linkage_ros.core.errors import SceneError
    from linkage_ros.params import ConfigError, load_engine, make_config

    six_bar = fixture('grbda_six_bar.urdf')
    config = make_config({'scene': six_bar, 'actuated': ['']})
    assert config.actuated == () and config.source == six_bar
    scene, engine = load_engine(config)
    assert (
        scene.mechanism.output_joint_names
        == mechanism_of(CASES['grbda_six_bar']).output_joint_names
    )
    text = make_config({'robot_description': text_of('grbda_four_bar.urdf')})
    assert text.source == 'the robot_description parameter'
    assert load_engine(text)[0].mechanism.name == 'four_bar'
    # the topic: the scene is not read (its default names a packaged scene anyway)
    assert make_config({'robot_description_topic': '/robot_description'}).source == (
        'robot_description_topic /robot_description'
    )
    bad = {
        'closures': ({'scene': six_bar, 'closures': str(tmp_path / 'none.yaml')}, 'no such file'),
        'actuated twice': ({'actuated': ['joint1', 'joint1']}, 'twice'),
        'actuated empty name': ({'actuated': ['joint1', '']}, 'joint names'),
        'both sources': (
            {'robot_description': '<robot/>', 'robot_description_topic': 'robot_description'},
            'set one of them',
        ),
        'topic name': ({'robot_description_topic': 'robot description'}, 'topic name'),
        'joint_states_in': ({'joint_states_in': '/joint_states/'}, 'topic name'),
        'publish_inputs alone': ({'publish_inputs': True}, 'set joint_states_in too'),
        'publish_inputs not a bool': (
            {'joint_states_in': 'hw', 'publish_inputs': 'yes'},
            'must be true or false',
        ),
    }
    for case, (params, fragment) in bad.items():
        with pytest.raises(ConfigError, match=fragment):
            make_config(params)
        assert case
    # a side file with a scene YAML: the loader refuses it, naming the file
    with pytest.raises(SceneError, match='closures applies to a robot description'):
        load_engine(
            make_config(
                {'scene': 'four_bar', 'closures': fixture('gepetto_5bar_linkage/robot.yaml')}
            )
        )


def test_joint_state_pick_reads_only_the_wanted_names():
    from linkage_ros.conversions import joint_state_pick
    from linkage_ros.core.errors import CommandError

    wanted = {'joint1', 'joint2'}
    msg = joint_state({'arm': 1.0, 'joint2': 0.5, 'joint1': -0.5}, velocity=[9.0, 0.1, 0.2])
    assert joint_state_pick(msg, wanted) == (
        {'joint2': 0.5, 'joint1': -0.5},
        {'joint2': 0.1, 'joint1': 0.2},
    )
    assert joint_state_pick(joint_state({'arm': 1.0, 'joint1': 0.3}), wanted) == (
        {'joint1': 0.3},
        None,
    )
    # velocities only with one per name
    partial = joint_state({'joint1': 0.3, 'joint2': 0.1}, velocity=[1.0])
    assert joint_state_pick(partial, wanted) == ({'joint1': 0.3, 'joint2': 0.1}, None)
    # none of them: nothing, whatever the message's shape
    broken = JointState(name=['arm', 'arm'], position=[1.0])
    assert joint_state_pick(broken, wanted) == ({}, None)
    with pytest.raises(CommandError, match='2 name'):
        joint_state_pick(JointState(name=['joint1', 'arm'], position=[1.0]), wanted)
    with pytest.raises(CommandError, match='more than once'):
        joint_state_pick(JointState(name=['joint1', 'joint1'], position=[1.0, 2.0]), wanted)


def test_state_completion_keeps_publishing_a_mimic_follower_it_reads_back(ros, procs):
    """The Robotiq's hardware publishes the left knuckle on /joint_states, where the node
    publishes too: the node's own messages carry the right knuckle (the left's mimic follower)
    and must not make it think the hardware publishes the follower (it stopped publishing it)."""
    proc = procs['completion_robotiq']
    node = Node(ros, proc).ready()
    hardware = node.publisher(JointState, 'joint_states')
    node.clear()
    ros.publish(hardware, joint_state({'robotiq_85_left_knuckle_joint': 0.4}))
    assert ros.spin_until(lambda: len(node.status) > 0, ANSWER_TIMEOUT, proc)
    assert node.status.last.level == DiagnosticStatus.OK, node.status.last.message
    ros.spin_for(1.0)  # the node reads its own answer (and republications) back
    node.clear()
    ros.publish(hardware, joint_state({'robotiq_85_left_knuckle_joint': 0.5}))
    assert ros.spin_until(lambda: len(node.status) > 0, ANSWER_TIMEOUT, proc)
    ros.spin_for(QUIET)
    ours = [m for m in node.joints.messages if 'robotiq_85_left_knuckle_joint' not in m.name]
    assert ours, [list(m.name) for m in node.joints.messages]
    last = dict(zip(ours[-1].name, ours[-1].position))
    assert last['robotiq_85_right_knuckle_joint'] == pytest.approx(-0.5, abs=1e-12)
    text = text_of('picknik_robotiq_2f_85.expanded.urdf')
    joints = dict(last, robotiq_85_left_knuckle_joint=0.5)
    misses = pinocchio_closure_misses(text, joints, ROBOTIQ_PINS)
    assert max(misses) < CLOSURE_TOL * 0.1


def test_points_in_and_out_of_a_description_are_3d_in_its_ground_frame():
    """~/points and the markers give a description's points in its ground link's 3-D frame;
    ~/target_point and path positions are projected back into its plane."""
    from geometry_msgs.msg import Point, PointStamped

    from linkage_ros.conversions import point_stamped_to_xy, result_to_points
    from linkage_ros.core.solver import Solver

    mech = load_scene(
        fixture('gepetto_5bar_linkage/robot.urdf'),
        closures=fixture('gepetto_5bar_linkage/robot.yaml'),
    ).mechanism
    r = Solver(mech).solve(mech.joint_coordinates.to_scene({'mot1': 0.2, 'mot2': -0.1}))
    msgs = result_to_points(r, ['free1'], Time(), 'built', mech=mech)
    p = msgs['free1'].point
    assert (p.x, p.y, p.z) == pytest.approx(mech.point_3d('free1', *r.points['free1']))
    assert p.x == pytest.approx(0.15)  # the pin's depth along x: the chain moves in yz
    back = point_stamped_to_xy(PointStamped(point=Point(x=p.x, y=p.y, z=p.z)), 'free1', mech)
    assert back == pytest.approx(r.points['free1'], abs=1e-15)
