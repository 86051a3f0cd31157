"""linkage_node serving real robot descriptions, over real DDS.

* The fixtures of test/fixtures/robot_descriptions served by their description (the
  ``scene`` parameter with its ``closures`` side file, or the ``robot_description`` parameter's
  text): a ``~/command`` in the description's own joint names is answered by joint_states in
  the description's chain joints, and an independent consumer closes every loop with them:
  Pinocchio's forward kinematics of the URDF (the closure's two points coincide), or for the
  SDF (which Pinocchio does not read) the planar chain written out here from the file's frames.
* ``robot_description_topic``: the node waits (requests refused, a /diagnostics WARN), serves
  the description published transient-local, is replaced whole by a second one, and refuses a
  malformed one while the previous mechanism keeps answering.

Each node is a subprocess (node_description_helpers) in its own namespace on this module's random
ROS domain; every node of the module is started at once and stopped at the end, each checked
for a clean exit.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from node_description_helpers import (
    ANSWER_TIMEOUT,
    CASES,
    CLOSURE_TOL,
    START_TIMEOUT,
    Node,
    joint_state,
    mechanism_of,
    pinocchio_closure_misses,
    start_nodes,
    stop_nodes,
    text_of,
    wrap,
)
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import random_domain_id
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from linkage_ros.core.loading import load_scene

DOMAIN_ID = random_domain_id()
HARNESS_NAME = 'descriptions_test'
ACK_TIMEOUT = 10.0  # s: a reliable sample acknowledged (Fast DDS heartbeats every 3 s)
ACKED = Duration(seconds=ACK_TIMEOUT)
LATCHED = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)

URDF_CASES = [name for name, case in CASES.items() if case['closures']]


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


def topic_node_params() -> dict:
    return {'robot_description_topic': 'robot_description'}


@pytest.fixture(scope='module')
def procs(tmp_path_factory):
    """Every node of the module (a node per case, and the topic node), started at once; stopped
    (and checked) at the end."""
    params = {name: case['params'] for name, case in CASES.items()}
    params['topic'] = topic_node_params()
    started = start_nodes(tmp_path_factory.mktemp('descriptions'), DOMAIN_ID, params)
    yield started
    stop_nodes(started)


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
