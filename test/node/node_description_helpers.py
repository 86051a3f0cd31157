"""Helpers of the node tests on real robot descriptions (test_node_descriptions.py,
test_node_state_completion.py, test_node_description_parameters.py): the fixture cases of
test/fixtures/robot_descriptions, Pinocchio as an independent consumer that closes their loops,
and node processes (test/ros_harness.py) with the test-side endpoints that talk to them.

Each node is a subprocess in its own namespace on the module's random ROS domain (its
DOMAIN_ID) with discovery limited to this host; every node of a module is started at once (they
start in parallel) and stopped at the end, each checked for a clean exit.
"""

from __future__ import annotations

import math
import signal

import numpy as np
import pinocchio as pin
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from ros_harness import NodeProcess, RosHarness
from scenes import REPO
from sensor_msgs.msg import JointState

from linkage_ros.core.loading import load_scene

FIXTURES = REPO / 'test' / 'fixtures' / 'robot_descriptions'
START_TIMEOUT = 90.0  # s: every node of the module starts at once, on however few cores
ANSWER_TIMEOUT = 10.0  # s: an answer that takes longer is a failure
QUIET = 0.5  # s: a bounded window proving nothing more arrives
CLOSURE_TOL = 1e-9  # of the mechanism's length scale


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


def start_nodes(workdir, domain_id: int, params: dict[str, dict]) -> dict[str, NodeProcess]:
    """A node process per entry of ``params`` (name: its parameters), all started at once."""
    return {name: NodeProcess(workdir / name, domain_id, p).start() for name, p in params.items()}


def stop_nodes(started: dict[str, NodeProcess]) -> None:
    """Stop every node; each must exit cleanly (code 0, no traceback)."""
    failures = []
    for name, proc in started.items():
        code = proc.stop(signal.SIGINT)
        out = proc.output()
        if code != 0 or 'Traceback' in out:
            failures.append(f'{name}: exit {code}\n{out[-2000:]}')
    assert not failures, '\n'.join(failures)
