"""linkage_node's state completion (``joint_states_in``) on real robot descriptions, over real
DDS: a 'hardware' publisher on the node's own joint_states topic sends the actuated joints; the
node answers with the passive joints only (velocities too), which close the loop with the
hardware's values (Pinocchio's forward kinematics of the URDF), and never reads its own output
back; with ``publish_inputs`` it publishes every joint. Also the picking of the wanted names
out of a JointState.

Each node is a subprocess (node_description_helpers) in its own namespace on this module's random
ROS domain; every node of the module is started at once and stopped at the end, each checked
for a clean exit.
"""

from __future__ import annotations

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from node_description_helpers import (
    ANSWER_TIMEOUT,
    CASES,
    CLOSURE_TOL,
    QUIET,
    ROBOTIQ_PINS,
    Node,
    fixture,
    joint_state,
    pinocchio_closure_misses,
    start_nodes,
    stop_nodes,
    text_of,
    wrap,
)
from ros_harness import random_domain_id
from sensor_msgs.msg import JointState

from linkage_ros.core.loading import load_scene

DOMAIN_ID = random_domain_id()
HARNESS_NAME = 'descriptions_test'


def completion_params() -> dict:
    # the hardware publishes on the node's own joint_states topic, as joint_state_broadcaster
    # and the node share /joint_states on a robot
    return {'scene': fixture('grbda_six_bar.urdf'), 'joint_states_in': 'joint_states'}


@pytest.fixture(scope='module')
def procs(tmp_path_factory):
    """Every node of the module (state completion: into joint_states, for the Robotiq, and
    with publish_inputs), started at once; stopped (and checked) at the end."""
    params = {
        'completion': completion_params(),
        'completion_robotiq': dict(
            CASES['robotiq_2f_85']['params'], joint_states_in='joint_states'
        ),
        'completion_all': dict(
            completion_params(), joint_states_in='hw_joint_states', publish_inputs=True
        ),
    }
    started = start_nodes(tmp_path_factory.mktemp('descriptions'), DOMAIN_ID, params)
    yield started
    stop_nodes(started)


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
        assert answer.velocity[i] == pytest.approx(slope, rel=1e-7, abs=1e-8), name

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
    # the repeated name alone (every input found was named)
    with pytest.raises(CommandError, match=r"^JointState names \['joint1'\] more than once$"):
        repeated = JointState(name=['joint1', 'joint2', 'joint1'], position=[1.0, 2.0, 3.0])
        joint_state_pick(repeated, wanted)


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
