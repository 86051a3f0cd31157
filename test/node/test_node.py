"""Launch-free tests of ``linkage_node`` over real DDS.

Each node is a subprocess (``python -m linkage_ros.node``) started once per module, in its own
namespace, on a random ROS domain in [1, 200] with discovery limited to this host. The test side
is a plain rclpy node that publishes requests (reliable, waiting for the match and for the
acknowledgement) and collects joint_states, points, markers and status, always with timeouts.

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

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped, PoseStamped
from nav_msgs.msg import Path as NavPath
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from ros_harness import NodeProcess, RosHarness, random_domain_id
from scenes import CONFIG
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from linkage_ros.conversions import joint_state_to_command, result_to_joint_state
from linkage_ros.core.errors import CommandError
from linkage_ros.core.model import AngleActuator, Scene
from linkage_ros.core.solver import Result
from linkage_ros.node import NODE_NAME, PARAMETERS, ConfigError, make_config

DOMAIN_ID = random_domain_id()
ANSWER_TIMEOUT = 10.0  # s: an answer that takes longer is a failure
QUIET = 0.4  # s: bounded window after an error proving nothing else arrives
SETTLE = 0.15  # s: the same after a success (only a second status could come)
ANGLE_TOL = 1e-9
LENGTH_TOL = 1e-9

# ---- scenes: the shipped files, plus a test-only triple rocker ------------------------------

# non-Grashof (s + l = 0.25 + 0.5 > p + q = 0.4 + 0.3: a triple rocker): the crank reaches only
# |theta| <= 1.2986 rad (|A O4| <= coupler + rocker) while its limits allow [-2, 2], so 1.6 rad is
# within the limits but does not assemble.
ROCKER_FIXTURE = """\
name: triple_rocker
frame_id: world
four_bar:
  ground: 0.5
  crank: 0.4
  coupler: 0.25
  rocker: 0.3
  branch: 1
  crank_limits: {min: -2.0, max: 2.0}
"""
ROCKER_REACH = math.acos((0.5**2 + 0.4**2 - (0.25 + 0.3) ** 2) / (2 * 0.5 * 0.4))

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


@pytest.fixture(scope='module')
def ros():
    harness = RosHarness(DOMAIN_ID)
    yield harness
    harness.close()


@pytest.fixture(scope='module')
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp('linkage_node')


def _serve(ros, workdir, name, scene, warmup, params=None):
    proc = NodeProcess(workdir / name, DOMAIN_ID, dict(params or {}, scene=str(scene))).start()
    try:
        served = Served(ros, proc, scene).ready(warmup)
    except BaseException:
        proc.stop()
        raise
    return served, proc


def _finish(proc):
    code = proc.stop(signal.SIGINT)
    assert code == 0, f'unclean exit {code}:\n{proc.output()[-3000:]}'
    assert 'Traceback' not in proc.output(), proc.output()[-3000:]


@pytest.fixture(scope='module')
def four_bar(ros, workdir):
    scene = CONFIG / 'four_bar.yaml'
    served, proc = _serve(ros, workdir, 'four_bar', scene, joint_state(['crank'], [1.2]))
    served.oracle = FourBarOracle(scene)
    yield served
    _finish(proc)


@pytest.fixture(scope='module')
def rocker(ros, workdir):
    scene = workdir / 'triple_rocker.yaml'
    scene.write_text(ROCKER_FIXTURE)
    served, proc = _serve(ros, workdir, 'rocker', scene, joint_state(['crank'], [0.9]))
    yield served
    _finish(proc)


def _mid_command(mech):
    """Every actuator at the middle of its limits."""
    return {a: 0.5 * (act.min + act.max) for a, act in mech.actuators.items()}


def _mid_joint_state(scene: Path) -> JointState:
    mid = _mid_command(Scene.from_yaml(scene).mechanism)
    return joint_state(list(mid), list(mid.values()))


@pytest.fixture(scope='module')
def two_dof(ros, workdir):
    scene = CONFIG / 'plagiograph.yaml'
    served, proc = _serve(ros, workdir, 'two_dof', scene, _mid_joint_state(scene))
    yield served
    _finish(proc)


@pytest.fixture(scope='module')
def three_dof(ros, workdir):
    scene = CONFIG / 'excavator.yaml'
    served, proc = _serve(
        ros,
        workdir,
        'three_dof',
        scene,
        _mid_joint_state(scene),
        params={'target_point_hold': ['bucket']},
    )
    yield served
    _finish(proc)


# ---- the four-bar: forward, inverse, bad commands -------------------------------------------


def test_forward_command_matches_closed_form_four_bar(four_bar):
    theta2 = 1.0
    status = four_bar.request(joint_state(['crank'], [theta2], stamp=(1234, 567_000_000)))
    joints = four_bar.assert_single_ok(status)
    want = four_bar.oracle.solve(theta2)
    assert set(joints) == {'O2', 'A', 'B', 'O4'}
    for name, value in want['joints'].items():
        assert angle_diff(joints[name], value) < ANGLE_TOL, (name, joints[name], value)
    assert abs(four_bar.oracle.freudenstein(theta2, want['theta4'])) < 1e-12
    assert stamp_of(four_bar.joints.last) == (1234, 567_000_000)
    # the coupler point
    p = four_bar.points['P'].last
    assert stamp_of(p) == (1234, 567_000_000) and p.header.frame_id == four_bar.frame_id
    assert math.dist((p.point.x, p.point.y), want['P']) < LENGTH_TOL
    # status: one OK with the solve report
    vals = status_values(status)
    assert {'residual', 'branch', 'margin', 'solver', 'iterations'} <= set(vals)
    assert float(vals['residual']) < 1e-9
    assert vals['branch'] == '+' and 0 < float(vals['margin']) <= 1
    # markers: the crank strip runs from O2 to the oracle's A
    links = marker_points(four_bar.markers.last, four_bar.mech)
    assert math.dist(links['crank']['A'], want['A']) < LENGTH_TOL
    assert math.dist(links['rocker']['B'], want['B']) < LENGTH_TOL
    kinds = [m.type for m in four_bar.markers.last.markers]
    assert Marker.SPHERE_LIST in kinds and kinds.count(Marker.LINE_STRIP) == 4


def test_zero_stamp_is_replaced_by_now(four_bar):
    before = time.time()
    status = four_bar.request(joint_state(['crank'], [1.1]))
    four_bar.assert_single_ok(status)
    sec, nsec = stamp_of(four_bar.joints.last)
    assert (sec, nsec) != (0, 0)
    assert abs(sec + 1e-9 * nsec - before) < 30.0
    assert stamp_of(four_bar.points['P'].last) == (sec, nsec)


def rosbags_joint_state(names, positions, stamp, frame='', effort=(), little_endian=True) -> bytes:
    """A JointState serialised by rosbags (another writer than rclpy: it can write a NUL
    inside a name, either byte order)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    t = store.types
    msg = t['sensor_msgs/msg/JointState'](
        header=t['std_msgs/msg/Header'](
            stamp=t['builtin_interfaces/msg/Time'](sec=stamp[0], nanosec=stamp[1]),
            frame_id=frame,
        ),
        name=list(names),
        position=np.array(positions, float),
        velocity=np.zeros(0),
        effort=np.array(effort, float),
    )
    return bytes(
        store.serialize_cdr(msg, 'sensor_msgs/msg/JointState', little_endian=little_endian)
    )


@pytest.mark.parametrize('little_endian', [True, False])
def test_command_bytes_of_another_writer_are_read_as_the_message(four_bar, little_endian):
    """~/command is read off its bytes: a command serialised by rosbags (either byte order,
    with a frame id and efforts the node skips) is answered as the same message would be."""
    raw = rosbags_joint_state(
        ['crank'], [0.9], (4321, 765), 'odd frame', [1.0, 2.0, 3.0], little_endian
    )
    joints = four_bar.assert_single_ok(four_bar.request(raw))
    for name, value in four_bar.oracle.solve(0.9)['joints'].items():
        assert angle_diff(joints[name], value) < ANGLE_TOL
    assert stamp_of(four_bar.joints.last) == (4321, 765)
    assert status_values(four_bar.status.last)['request'] == 'command'


def test_inverse_target_on_rocker_returns_crank(four_bar):
    four_bar.assert_single_ok(four_bar.request(joint_state(['crank'], [1.0])))
    theta2 = 1.1
    want = four_bar.oracle.solve(theta2)
    status = four_bar.request(
        joint_state(['rocker'], [want['theta4']], stamp=(77, 1)), topic='~/target'
    )
    joints = four_bar.assert_single_ok(status)
    assert angle_diff(joints['O2'], want['joints']['O2']) < 1e-8
    assert angle_diff(joints['O4'], want['joints']['O4']) < 1e-8
    assert stamp_of(four_bar.joints.last) == (77, 1)
    assert (
        math.dist((four_bar.points['P'].last.point.x, four_bar.points['P'].last.point.y), want['P'])
        < 1e-8
    )
    # the state the target left is where the next command continues from: the crank's rocker
    # position of the other assembly (crank mirrored about O4 B) is never chosen
    theta2b = 1.15
    wantb = four_bar.oracle.solve(theta2b)
    joints = four_bar.assert_single_ok(
        four_bar.request(joint_state(['O4'], [wantb['joints']['O4']]), topic='~/target')
    )
    assert angle_diff(joints['O2'], wantb['joints']['O2']) < 1e-8


def test_target_with_wrong_number_of_values_is_rejected(four_bar):
    status = four_bar.request(joint_state(['O4', 'A'], [1.0, 0.5]), topic='~/target')
    four_bar.assert_single_error(status, 'degree')


def test_a_target_name_is_read_whole_as_a_command_name_is(four_bar):
    """`rocker\x00x` is one (unknown) name on ~/target as on ~/command and in `linkage bag`
    (TOPICS); rclpy's deserialiser ended it at the NUL and the node answered it as `rocker`.
    The message is the bytes rosbags serialises (rclpy's own serialiser cannot write the NUL)."""
    raw = rosbags_joint_state(['rocker\x00x'], [2.0], (5, 0))
    status = four_bar.request(raw, topic='~/target')
    four_bar.assert_single_error(status, 'unknown name', 'rocker')
    assert 'x00x' in status.message


BAD_COMMANDS = {
    'nan': (['crank'], [math.nan], 'finite'),
    'inf': (['crank'], [math.inf], 'finite'),
    'minus_inf': (['crank'], [-math.inf], 'finite'),
    'unknown_name': (['wrench'], [1.0], 'unknown'),
    'passive_joint': (['B'], [0.3], 'use ~/target for joints'),
    'missing_name': ([], [], 'empty'),
    'more_positions': (['crank'], [1.0, 2.0], 'position'),
    'more_names': (['crank', 'other'], [1.0], 'position'),
    'duplicate_name': (['crank', 'crank'], [1.0, 1.0], 'more than once'),
}


@pytest.mark.parametrize('case', list(BAD_COMMANDS))
def test_bad_command_gets_exactly_one_error_and_nothing_else(four_bar, case):
    names, positions, fragment = BAD_COMMANDS[case]
    msg = JointState(name=names, position=positions)
    four_bar.assert_single_error(four_bar.request(msg), fragment)
    # the node is alive and the next good command works
    joints = four_bar.assert_single_ok(four_bar.request(joint_state(['crank'], [0.8])))
    for name, value in four_bar.oracle.solve(0.8)['joints'].items():
        assert angle_diff(joints[name], value) < ANGLE_TOL


def test_unreachable_and_out_of_limit_crank_on_triple_rocker(rocker):
    assert 1.2 < ROCKER_REACH < 1.6 < 2.0
    rocker.assert_single_ok(rocker.request(joint_state(['crank'], [1.0])))
    for value, fragment in ((1.6, ''), (2.5, 'maximum'), (-2.5, 'minimum')):
        status = rocker.request(joint_state(['crank'], [value]))
        rocker.assert_single_error(status, fragment)
        assert status.message
    joints = rocker.assert_single_ok(rocker.request(joint_state(['crank'], [1.05])))
    assert abs(joints['O2'] - 1.05) < 1e-12


# ---- multi-DOF scenes -----------------------------------------------------------------------


def check_rigid_geometry(served, command):
    """Every link keeps its reference point distances; every shared point is one point; angle
    actuators point where commanded; the published points are those of the geometry."""
    mech = served.mech
    links = marker_points(served.markers.last, mech)
    where = {}
    for lname, pts in links.items():
        ref = mech.links[lname].points
        for i, p in enumerate(ref):
            for q in ref[i + 1 :]:
                assert (
                    abs(math.dist(pts[p], pts[q]) - math.dist(mech.points[p], mech.points[q]))
                    < 1e-9 * mech.length_scale
                ), (lname, p, q)
            if p in where:
                assert math.dist(where[p], pts[p]) < 1e-9 * mech.length_scale, p
            where[p] = pts[p]
    for a, act in mech.actuators.items():
        if isinstance(act, AngleActuator) and act.reference == mech.ground and a in command:
            (px, py), (tx, ty) = where[act.pivot], where[act.toward]
            assert angle_diff(math.atan2(ty - py, tx - px), command[a]) < 1e-9
    for name, col in served.points.items():
        q = col.last.point
        assert math.dist((q.x, q.y), where[name]) < 1e-12 * mech.length_scale
        assert col.last.header.frame_id == served.frame_id
    return where


def test_two_dof_scene_serves_commands(two_dof):
    mech = two_dof.mech
    assert mech.dof == 2
    command = {a: 0.5 * (act.min + act.max) + 0.05 for a, act in mech.actuators.items()}
    status = two_dof.request(joint_state(list(command), list(command.values()), stamp=(5, 6)))
    joints = two_dof.assert_single_ok(status)
    assert set(joints) == set(mech.joint_names)
    assert stamp_of(two_dof.joints.last) == (5, 6)
    for col in two_dof.points.values():
        assert stamp_of(col.last) == (5, 6)
    check_rigid_geometry(two_dof, command)


def test_two_dof_partial_command_holds_the_other_actuator(two_dof):
    """A command naming some actuators keeps the others at their last good values and says so
    in the status (`held`); an unknown name beside them is still an error."""
    mech = two_dof.mech
    first, second = list(mech.actuators)
    mid = _mid_command(mech)
    two_dof.assert_single_ok(two_dof.request(joint_state(list(mid), list(mid.values()))))
    full = dict(mid, **{first: mid[first] + 0.05})
    want = two_dof.assert_single_ok(two_dof.request(joint_state(list(full), list(full.values()))))
    two_dof.assert_single_ok(two_dof.request(joint_state(list(mid), list(mid.values()))))
    status = two_dof.request(joint_state([first], [full[first]], velocity=[0.2]))
    joints = two_dof.assert_single_ok(status)
    kv = {k.key: k.value for k in status.values}
    assert kv['held'] == second, kv
    for name, v in want.items():  # the same answer as the full command
        assert abs(math.remainder(joints[name] - v, 2 * math.pi)) < 1e-12, name
    js = two_dof.joints.last
    assert len(js.velocity) == len(js.name) and kv['velocity'].startswith('ok')
    status = two_dof.request(joint_state([first, 'wrench'], [0.3, 0.1]))
    two_dof.assert_single_error(status, 'unknown', 'wrench')


def _pure_point_output(mech):
    for p in mech.outputs:
        if p not in mech.joint_names and p not in mech.links and p not in mech.actuators:
            return p
    pytest.fail(f'{mech.name} has no output point usable as a point target')


def test_two_dof_target_point(two_dof):
    mech = two_dof.mech
    command = _mid_command(mech)
    two_dof.assert_single_ok(two_dof.request(joint_state(list(command), list(command.values()))))
    name = _pure_point_output(mech)
    p = two_dof.points[name].last.point
    goal = (p.x + 0.01 * mech.length_scale, p.y - 0.01 * mech.length_scale)
    status = two_dof.request(
        point_stamped(*goal, stamp=(9, 10), frame_id=two_dof.frame_id),
        topic=f'~/target_point/{name}',
        msg_type=PointStamped,
    )
    two_dof.assert_single_ok(status)
    q = two_dof.points[name].last
    assert math.dist((q.point.x, q.point.y), goal) < 1e-9 * mech.length_scale
    assert stamp_of(q) == (9, 10) and stamp_of(two_dof.joints.last) == (9, 10)
    check_rigid_geometry(two_dof, {})
    # an empty frame_id means the node's frame
    goal2 = (goal[0], goal[1] + 0.005 * mech.length_scale)
    two_dof.assert_single_ok(
        two_dof.request(point_stamped(*goal2), f'~/target_point/{name}', PointStamped)
    )
    q = two_dof.points[name].last.point
    assert math.dist((q.x, q.y), goal2) < 1e-9 * mech.length_scale


def test_target_point_in_another_frame_is_rejected(two_dof):
    name = _pure_point_output(two_dof.mech)
    status = two_dof.request(
        point_stamped(0.1, 0.1, frame_id='elsewhere'), f'~/target_point/{name}', PointStamped
    )
    two_dof.assert_single_error(status, 'elsewhere', two_dof.frame_id)


def test_three_dof_scene_serves_cylinder_commands(three_dof):
    mech = three_dof.mech
    assert mech.dof == 3
    command = {a: act.min + 0.3 * (act.max - act.min) for a, act in mech.actuators.items()}
    status = three_dof.request(joint_state(list(command), list(command.values()), stamp=(3, 4)))
    joints = three_dof.assert_single_ok(status)
    for a, v in command.items():
        assert abs(joints[mech.actuators[a].joint] - v) < 1e-9  # cylinder = pin-to-pin length
    assert set(three_dof.points) == set(mech.outputs) and len(mech.outputs) >= 1
    for col in three_dof.points.values():
        assert stamp_of(col.last) == (3, 4)
    where = check_rigid_geometry(three_dof, command)
    for a, v in command.items():  # the cylinder pins are the commanded length apart
        pj = mech.prismatics[mech.actuators[a].joint]
        pin = mech.links[pj.guide].points[0]
        assert abs(math.dist(where[pin], where[pj.point]) - v) < 1e-9


def test_three_dof_limit_violation_is_rejected(three_dof):
    a, act = next(iter(three_dof.mech.actuators.items()))
    command = _mid_command(three_dof.mech)
    command[a] = act.max + 0.1
    three_dof.assert_single_error(
        three_dof.request(joint_state(list(command), list(command.values()))), 'maximum'
    )


def test_three_dof_target_point_holds_bucket(three_dof):
    mech = three_dof.mech
    command = _mid_command(mech)
    three_dof.assert_single_ok(
        three_dof.request(joint_state(list(command), list(command.values())))
    )
    bucket = list(mech.links['bucket'].points)
    before = marker_points(three_dof.markers.last, mech)['bucket']
    name = next(
        p for p in ('L',) + tuple(mech.outputs) if p in mech.outputs and p not in mech.joint_names
    )
    p = three_dof.points[name].last.point
    goal = (p.x + 0.02 * mech.length_scale, p.y + 0.01 * mech.length_scale)
    status = three_dof.request(point_stamped(*goal), f'~/target_point/{name}', PointStamped)
    three_dof.assert_single_ok(status)
    q = three_dof.points[name].last.point
    assert math.dist((q.x, q.y), goal) < 1e-9 * mech.length_scale
    after = marker_points(three_dof.markers.last, mech)['bucket']

    def heading(pts):
        (x0, y0), (x1, y1) = pts[bucket[0]], pts[bucket[1]]
        return math.atan2(y1 - y0, x1 - x0)

    assert angle_diff(heading(after), heading(before)) < 1e-9


def test_three_dof_target_point_on_a_joint_point(three_dof):
    """K is both a point and the revolute joint stick-bucket: it can still be a point target."""
    mech = three_dof.mech
    assert 'K' in mech.joint_names and 'K' in mech.points
    command = _mid_command(mech)
    three_dof.assert_single_ok(
        three_dof.request(joint_state(list(command), list(command.values())))
    )
    k = marker_points(three_dof.markers.last, mech)['bucket']['K']
    goal = (k[0] + 0.01 * mech.length_scale, k[1] - 0.01 * mech.length_scale)
    three_dof.assert_single_ok(
        three_dof.request(point_stamped(*goal), '~/target_point/K', PointStamped)
    )
    k = marker_points(three_dof.markers.last, mech)['bucket']['K']
    assert math.dist(k, goal) < 1e-9 * mech.length_scale


def test_three_dof_target_by_two_bin_hinges(three_dof):
    """Seed 003, example 6: the bin given by its hinges J and K (`J.x, J.y, K.x, K.y` on
    ~/target) is solved exactly; a pair whose distance is not the bin's is refused with both
    distances, and changes nothing."""
    mech = three_dof.mech
    command = {a: act.min + 0.35 * (act.max - act.min) for a, act in mech.actuators.items()}
    source = three_dof.assert_single_ok(
        three_dof.request(joint_state(list(command), list(command.values())))
    )
    bin_pts = marker_points(three_dof.markers.last, mech)['bucket']
    (jx, jy), (kx, ky) = bin_pts['J'], bin_pts['K']
    mid = _mid_command(mech)
    three_dof.assert_single_ok(three_dof.request(joint_state(list(mid), list(mid.values()))))
    names = ['J.x', 'J.y', 'K.x', 'K.y']
    joints = three_dof.assert_single_ok(
        three_dof.request(joint_state(names, [jx, jy, kx, ky]), topic='~/target')
    )
    for name, v in source.items():  # the configuration the hinges came from
        assert abs(math.remainder(joints[name] - v, 2 * math.pi)) < 1e-9, (name, joints[name], v)
    status = three_dof.request(joint_state(names, [jx, jy, kx + 0.01, ky]), topic='~/target')
    three_dof.assert_single_error(status, 'both on link', 'm apart', 'the target puts them')
    # one coordinate is a known of its own: J.x and K place the bin (J.y decided)
    joints = three_dof.assert_single_ok(
        three_dof.request(joint_state(['J.x', 'K.x', 'K.y'], [jx, kx, ky]), topic='~/target')
    )
    for name, v in source.items():
        assert abs(math.remainder(joints[name] - v, 2 * math.pi)) < 1e-9, (name, joints[name], v)


def _pose(x, y, yaw, tilt=0.0):
    msg = PoseStamped()
    msg.pose.position.x, msg.pose.position.y = x, y
    # yaw about z, then a tilt about x (0: planar)
    cz, sz, cx, sx = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(tilt / 2), math.sin(tilt / 2)
    q = msg.pose.orientation
    q.w, q.x, q.y, q.z = cz * cx, cz * sx, sz * sx, sz * cx
    return msg


def test_three_dof_target_pose_of_the_bin(three_dof):
    """~/target_pose/bucket (PoseStamped): the bin's first point K at the position, the bin's
    angle from the yaw; the configuration it came from is solved; a tilted orientation or a
    NaN is refused with the reason."""
    mech = three_dof.mech
    command = {a: act.min + 0.6 * (act.max - act.min) for a, act in mech.actuators.items()}
    source = three_dof.assert_single_ok(
        three_dof.request(joint_state(list(command), list(command.values())))
    )
    first = mech.links['bucket'].points[0]
    bin_pts = marker_points(three_dof.markers.last, mech)['bucket']
    (x0, y0), (x1, y1) = bin_pts[first], bin_pts[mech.links['bucket'].points[1]]
    yaw = math.atan2(y1 - y0, x1 - x0)  # the bin's reported angle: its axis direction
    mid = _mid_command(mech)
    three_dof.assert_single_ok(three_dof.request(joint_state(list(mid), list(mid.values()))))
    topic = '~/target_pose/bucket'
    joints = three_dof.assert_single_ok(
        three_dof.request(_pose(x0, y0, yaw), topic=topic, msg_type=PoseStamped)
    )
    for name, v in source.items():
        assert abs(math.remainder(joints[name] - v, 2 * math.pi)) < 1e-9, (name, joints[name], v)
    status = three_dof.request(_pose(x0, y0, yaw, tilt=0.01), topic=topic, msg_type=PoseStamped)
    three_dof.assert_single_error(status, 'not a rotation about z')
    status = three_dof.request(_pose(math.nan, y0, yaw), topic=topic, msg_type=PoseStamped)
    three_dof.assert_single_error(status, 'position.x = nan is not finite')


def _trajectory_request(served, msg, topic):
    """Publish one trajectory or path; return (status, solved trajectory or None). Nothing
    else may answer it: no joint_states, no points."""
    solved = served.__dict__.setdefault(
        '_solved', served.ros.collector(JointTrajectory, served.proc.topic('~/solved_trajectory'))
    )
    served.ros.wait_for_discovery([], [solved], process=served.proc)
    pub = served.publisher(type(msg), topic)
    served.clear()
    solved.clear()
    served.ros.publish(pub, msg)
    assert served.ros.spin_until(lambda: len(served.status) >= 1, ANSWER_TIMEOUT, served.proc)
    status = served.status.last
    if status.level == DiagnosticStatus.OK:
        assert served.ros.spin_until(lambda: len(solved) >= 1, ANSWER_TIMEOUT, served.proc)
    served.ros.spin_for(QUIET)
    assert len(served.status) == 1 and len(served.joints) == 0
    assert len(solved) == (1 if status.level == DiagnosticStatus.OK else 0)
    return status, (solved.last if len(solved) else None)


def _trajectory(names, rows, dt_ns=10_000_000, velocities=None, stamp=(5, 6)):
    msg = JointTrajectory()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.joint_names = list(names)
    for k, row in enumerate(rows):
        pt = JointTrajectoryPoint()
        pt.positions = [float(v) for v in row]
        if velocities is not None:
            pt.velocities = [float(v) for v in velocities[k]]
        t = (k + 1) * dt_ns
        pt.time_from_start = Duration(sec=t // 10**9, nanosec=t % 10**9)
        msg.points.append(pt)
    return msg


def test_crank_turn_trajectory_over_dds(four_bar):
    """~/trajectory of a full crank turn: ~/solved_trajectory has every joint at every point
    (the 50-digit oracle), time_from_start and stamp kept, velocities when given, one status;
    an unreachable point refuses the whole trajectory naming its index, with nothing solved."""
    four_bar.assert_single_ok(four_bar.request(joint_state(['crank'], [1.0])))
    thetas = [1.0 + 2 * math.pi * k / 36 for k in range(37)]
    msg = _trajectory(['crank'], [[t] for t in thetas], velocities=[[1.5]] * 37)
    status, solved = _trajectory_request(four_bar, msg, '~/trajectory')
    assert status.level == DiagnosticStatus.OK, status.message
    kv = {v.key: v.value for v in status.values}
    assert kv['points'] == '37' and kv['request'] == 'trajectory' and kv['velocity'] == 'ok'
    assert list(solved.joint_names) == four_bar.mech.joint_names
    assert stamp_of(solved) == (5, 6) and solved.header.frame_id == four_bar.frame_id
    for k, (t, pt) in enumerate(zip(thetas, solved.points)):
        want = four_bar.oracle.solve(t)
        got = dict(zip(solved.joint_names, pt.positions))
        for j in ('O2', 'O4'):
            assert angle_diff(got[j], want['joints'][j]) < 1e-9, (k, j)
        assert (pt.time_from_start.sec, pt.time_from_start.nanosec) == divmod(
            (k + 1) * 10**7, 10**9
        )
        assert len(pt.velocities) == len(solved.joint_names)
    rocker = [[1.70], [1.75], [1.2], [1.8]]  # the rocker swings from 1.633 to 2.681 rad
    status, solved = _trajectory_request(four_bar, _trajectory(['rocker'], rocker), '~/trajectory')
    assert status.level == DiagnosticStatus.ERROR and status.message.startswith('point 2: ')
    assert {v.key: v.value for v in status.values}['failed_index'] == '2'
    # bad input: one clear ERROR each, nothing else
    bad = _trajectory(['crank'], [[0.1], [0.2]])
    bad.points[1].time_from_start = bad.points[0].time_from_start
    for msg, why in (
        (_trajectory(['crank'], []), 'empty trajectory'),
        (_trajectory(['crank'], [[0.1], [math.nan]]), 'point 1: crank: value must be finite'),
        (_trajectory(['crank'], [[0.1], [0.2, 0.3]]), 'point 1 has 2 position(s)'),
        (bad, 'point 1: time_from_start'),
        (_trajectory(['crank'], [[0.1], [0.2]], velocities=[[0.0], [math.nan]]), 'velocity'),
    ):
        status, solved = _trajectory_request(four_bar, msg, '~/trajectory')
        assert status.level == DiagnosticStatus.ERROR and why in status.message, status.message
    # the state is the one before the trajectories
    joints = four_bar.assert_single_ok(four_bar.request(joint_state(['crank'], [1.0])))
    assert angle_diff(joints['O4'], four_bar.oracle.solve(1.0)['joints']['O4']) < 1e-9


def test_throw_sweep_trajectory_over_dds_equals_the_cli(three_dof, capsys):
    """A trajectory of cylinder throws on the excavator equals `linkage solve` of the same
    throws one after another (--branch continuous) to 1e-9; 10^5 points get one clear ERROR and
    change nothing."""
    import json

    from linkage_ros.cli.parser import main as cli_main

    mech = three_dof.mech
    mid = _mid_command(mech)
    three_dof.assert_single_ok(three_dof.request(joint_state(list(mid), list(mid.values()))))
    acts = list(mech.actuators)
    lo = {a: act.min + 0.3 * (act.max - act.min) for a, act in mech.actuators.items()}
    hi = {a: act.min + 0.7 * (act.max - act.min) for a, act in mech.actuators.items()}
    n = 21
    rows = [[lo[a] + (hi[a] - lo[a]) * k / (n - 1) for a in acts] for k in range(n)]
    status, solved = _trajectory_request(three_dof, _trajectory(acts, rows), '~/trajectory')
    assert status.level == DiagnosticStatus.OK, status.message
    capsys.readouterr()
    for k, row in enumerate(rows):
        args = ['solve', 'excavator', '--json', '--branch', 'continuous']
        for a, v in zip(acts, row):
            args += ['--set', f'{a}={v!r}']
        assert cli_main(args) == 0
        d = json.loads(capsys.readouterr().out)
        got = dict(zip(solved.joint_names, solved.points[k].positions))
        for j in mech.joint_names:
            assert abs(math.remainder(got[j] - d['joints'][j], 2 * math.pi)) < 1e-9, (k, j)
    big = JointTrajectory(joint_names=acts)
    pt = JointTrajectoryPoint(positions=rows[0])
    big.points = [pt] * 100_000
    status, solved = _trajectory_request(three_dof, big, '~/trajectory')
    assert status.level == DiagnosticStatus.ERROR and 'at most 10000' in status.message
    joints = three_dof.assert_single_ok(
        three_dof.request(joint_state(list(mid), list(mid.values())))
    )
    assert all(math.isfinite(v) for v in joints.values())


def test_bin_path_over_dds_comes_back_as_throws(three_dof):
    """~/target_path/L (nav_msgs/Path) on the excavator, the bucket held: the solved
    trajectory's throws, solved forward, put L on the path."""
    mech = three_dof.mech
    mid = _mid_command(mech)
    three_dof.assert_single_ok(three_dof.request(joint_state(list(mid), list(mid.values()))))
    lip = three_dof.points['L'].last.point
    path = NavPath()
    xy = [(lip.x + 0.2 * s, lip.y - 0.1 * s) for s in np.linspace(0, 1, 15)]
    for x, y in xy:
        pose = PoseStamped()
        pose.pose.position.x, pose.pose.position.y = x, y
        path.poses.append(pose)
    status, solved = _trajectory_request(three_dof, path, '~/target_path/L')
    assert status.level == DiagnosticStatus.OK, status.message
    from linkage_ros.engine import Engine, EngineSettings

    fwd = Engine(mech, EngineSettings())
    for (x, y), pt in zip(xy, solved.points):
        got = dict(zip(solved.joint_names, pt.positions))
        r = fwd.command({a: got[mech.actuators[a].joint] for a in mech.actuators})
        assert math.dist(r.points['L'], (x, y)) < 1e-9 * mech.length_scale
    path.poses[7].pose.position.x = math.nan
    status, _ = _trajectory_request(three_dof, path, '~/target_path/L')
    assert status.level == DiagnosticStatus.ERROR and 'pose 7: position.x' in status.message


# ---- demo sweep, start-up errors, parameters ------------------------------------------------


def test_demo_sweep_publishes_without_commands(ros, workdir):
    """The packaged default scene (no scene parameter) with demo_sweep: joint states flow."""
    proc = NodeProcess(workdir / 'demo', DOMAIN_ID, {'demo_sweep': True, 'demo_rate': 25.0}).start()
    try:
        joints = ros.collector(JointState, proc.topic('joint_states'))
        ros.wait_for_discovery(collectors=[joints], process=proc)
        assert ros.spin_until(lambda: len(joints) >= 6, 15.0, proc), len(joints)
        msgs = list(joints.messages)
        assert all(stamp_of(m) != (0, 0) for m in msgs)
        first = [m.position[0] for m in msgs]
        assert len(set(first)) == len(first), 'the sweep moves the first joint every tick'
        assert all(len(m.name) == len(m.position) >= 1 for m in msgs)
        # the terminal shows compact joint lines
        assert ros.spin_until(lambda: ' | ' in proc.output(), 5.0, proc)
        # demo_sweep can be switched off at runtime; read-only parameters cannot change
        client = AsyncParameterClient(ros.node, f'{proc.namespace}/{NODE_NAME}')
        assert client.wait_for_services(timeout_sec=10.0)
        future = client.set_parameters(
            [Parameter('demo_sweep', value=False), Parameter('tolerance', value=1e-9)]
        )
        assert ros.spin_until(future.done, 10.0, proc)
        ok, read_only = future.result().results
        assert ok.successful and not read_only.successful
        ros.spin_for(SETTLE)
        joints.clear()
        ros.spin_for(3 * 1 / 25.0 + QUIET)
        assert len(joints) == 0, 'the sweep stops when demo_sweep is set false'
    finally:
        code = proc.stop(signal.SIGINT)
    assert code == 0, proc.output()[-3000:]
    assert 'Traceback' not in proc.output()


# case: (scene file text, or None for a missing file, or '' for the default scene; parameters;
#        what stderr must name)
BAD_STARTS = {
    'bad_scene_value': (
        'four_bar:\n  ground: 0.3\n  crank: -0.1\n  coupler: 0.25\n  rocker: 0.2\n',
        {},
        ['four_bar.crank', '-0.1'],
    ),
    'bad_scene_key': (
        'four_bar:\n  ground: 0.3\n  crank: 0.1\n  coupler: 0.25\n  rocker: 0.2\n  rockr: 0.2\n',
        {},
        ['four_bar.rockr', 'unknown key'],
    ),
    'bad_yaml': ('four_bar: {ground: 0.3\n', {}, ['invalid YAML']),
    'missing_scene': (None, {}, ['no_such_scene.yaml']),
    'bad_tolerance': ('', {'tolerance': -1.0}, ['tolerance', '-1.0']),
    'bad_solver': ('', {'solver': 'fastest'}, ['solver', 'fastest']),
    'bad_queue_depth': ('', {'queue_depth': 0}, ['queue_depth', '0']),
    'demo_of_a_structure': (
        'name: truss\npoints: {O1: [0, 0], O2: [0.4, 0], P: [0.15, 0.2]}\n'
        'links: {ground: [O1, O2], left: [O1, P], right: [O2, P]}\n',
        {'demo_sweep': True},
        ['demo_sweep', 'no actuator to sweep', '0 DOF'],
    ),
}


@pytest.mark.parametrize('case', list(BAD_STARTS))
def test_bad_scene_or_parameter_stops_startup(workdir, case):
    text, params, fragments = BAD_STARTS[case]
    d = workdir / f'start_{case}'
    params = dict(params)
    if text is None:
        params['scene'] = str(d / 'no_such_scene.yaml')
    elif text:
        d.mkdir()
        scene = d / 'scene.yaml'
        scene.write_text(text)
        params['scene'] = str(scene)
        fragments = fragments + [str(scene)]
    proc = NodeProcess(d, DOMAIN_ID, params).start()
    try:
        code = proc.wait(timeout=30)
    finally:
        proc.stop()
    err = proc.stderr()
    assert code != 0
    for f in fragments:
        assert f in err, err
    assert 'Traceback' not in err, err
    assert len(err.strip().splitlines()) <= 3, err


def test_startup_log_names_the_queue_depth_and_ignored_parameters(workdir):
    """A parameter the node does not have (a misspelling) is named in a warning, not silently
    dropped; the start-up line shows the queue depth in force."""
    proc = NodeProcess(
        workdir / 'misspelt', DOMAIN_ID, {'queue_depth': 33, 'output_depth': 44, 'queue_dept': 100}
    ).start()
    try:
        t_end = time.monotonic() + 30
        while 'listening on' not in proc.output() and proc.alive() and time.monotonic() < t_end:
            time.sleep(0.05)
        out = proc.output()
        assert 'listening on' in out, out
        assert '(reliable, keep last 44; commands keep last 33)' in out, out
        (warn,) = [ln for ln in out.splitlines() if 'ignoring parameter' in ln]
        assert 'WARN' in warn and "['queue_dept']" in warn and 'queue_depth' in warn, warn
    finally:
        _finish(proc)


def test_parameter_file_example_is_valid():
    data = yaml.safe_load((CONFIG / 'params' / 'linkage_node.yaml').read_text())
    params = data['linkage_node']['ros__parameters']
    assert set(params) <= {p.name for p in PARAMETERS}
    config = make_config(params)
    assert Scene.from_yaml(config.scene_path).mechanism.dof >= 1
    with pytest.raises(ConfigError, match='max_iterations'):
        make_config(dict(params, max_iterations=0))
    with pytest.raises(ConfigError, match='branch'):
        make_config(dict(params, branch='sideways'))
    assert make_config(params).queue_depth == 10
    assert make_config(params).output_depth == 100
    for bad in (0, 2.5, '100'):
        with pytest.raises(ConfigError, match=f"'output_depth'.*{bad!r}"):
            make_config(dict(params, output_depth=bad))
    assert make_config(dict(params, queue_depth=250)).queue_depth == 250
    for bad in (0, -5, 2.5, True, '100'):
        with pytest.raises(ConfigError, match=f"'queue_depth'.*{bad!r}"):
            make_config(dict(params, queue_depth=bad))
    assert make_config(params).executor == 'events'
    assert make_config(dict(params, executor='single_threaded')).executor == 'single_threaded'
    with pytest.raises(ConfigError, match="'executor'.*multi"):
        make_config(dict(params, executor='multi'))
    for name in ('publish_rate', 'marker_rate'):
        assert getattr(make_config(dict(params, **{name: 0.0})), name) == 0.0  # 0 = off
        assert getattr(make_config(dict(params, **{name: 250.0})), name) == 250.0
        for bad in (-1.0, 1e-4, 5000.0, math.nan, True, '10'):
            with pytest.raises(ConfigError, match=f"'{name}'.*must be 0 \\(off\\)"):
                make_config(dict(params, **{name: bad}))


def test_queue_depth_sets_the_history_of_every_topic(ros):
    """queue_depth is the keep-last depth of every subscription and of ~/solved_trajectory,
    output_depth that of joint_states, ~/points/<p> and ~/status (reliable, volatile); ~/markers
    is latched (depth 1) and /diagnostics the standard topic. Defaults 10 and 100."""
    answers = ('/joint_states', '/status') + tuple(f'/points/{p}' for p in 'LKJ')
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from linkage_ros.node import LinkageNode

    for depth, out_depth, overrides in (
        (10, 100, [Parameter('scene', value='excavator')]),
        (
            250,
            7,
            [
                Parameter('scene', value='excavator'),
                Parameter('queue_depth', Parameter.Type.INTEGER, 250),
                Parameter('output_depth', Parameter.Type.INTEGER, 7),
            ],
        ),
    ):
        node = LinkageNode(context=ros.context, parameter_overrides=overrides)
        try:
            ours = [
                e
                for e in list(node.publishers) + list(node.subscriptions)
                if 'parameter_events' not in e.topic_name
                and not e.topic_name.endswith(('/markers', '/diagnostics'))
            ]
            assert len(ours) >= 3 + 2 + 3  # outputs, command and target, 3 points
            assert len([e for e in ours if e.topic_name.endswith(answers)]) == 5
            for e in ours:
                q = e.qos_profile
                assert (q.depth, q.history, q.reliability, q.durability) == (
                    out_depth if e.topic_name.endswith(answers) else depth,
                    HistoryPolicy.KEEP_LAST,
                    ReliabilityPolicy.RELIABLE,
                    DurabilityPolicy.VOLATILE,
                ), e.topic_name
            # markers are latched (the latest for a late RViz); /diagnostics is the standard topic
            (markers,) = [p for p in node.publishers if p.topic_name.endswith('/markers')]
            q = markers.qos_profile
            assert (q.depth, q.durability) == (1, DurabilityPolicy.TRANSIENT_LOCAL)
            (diag,) = [p for p in node.publishers if p.topic_name == '/diagnostics']
            assert diag.qos_profile.reliability == ReliabilityPolicy.RELIABLE
        finally:
            node.destroy_node()


# ---- pure conversions -----------------------------------------------------------------------


def test_joint_state_to_command_checks_shape():
    assert joint_state_to_command(JointState(name=['a', 'b'], position=[1.0, 2.0])) == {
        'a': 1.0,
        'b': 2.0,
    }
    for msg in (
        JointState(),
        JointState(name=['a'], position=[]),
        JointState(name=['a', 'a'], position=[1.0, 2.0]),
        JointState(name=[''], position=[1.0]),
    ):
        with pytest.raises(CommandError):
            joint_state_to_command(msg)


def _four_bar_mech():
    from linkage_ros.core.model import Scene
    from linkage_ros.resources import scene_path

    return Scene.from_yaml(scene_path('four_bar')).mechanism


def test_result_to_joint_state_keeps_order_and_stamp():
    mech = _four_bar_mech()
    names = mech.joint_names
    res = Result(True, joints={n: float(i) for i, n in reversed(list(enumerate(names)))})
    msg = result_to_joint_state(res, mech, Time(sec=1, nanosec=2), 'f')
    assert list(msg.name) == names and list(msg.position) == [float(i) for i in range(len(names))]
    assert stamp_of(msg) == (1, 2) and msg.header.frame_id == 'f'
    assert not msg.velocity and not msg.effort


def test_result_to_joint_state_refills_a_reused_message():
    mech = _four_bar_mech()
    names = mech.joint_names
    first = result_to_joint_state(
        Result(True, joints=dict.fromkeys(names, 1.0)), mech, Time(sec=1, nanosec=2), 'f'
    )
    again = result_to_joint_state(
        Result(True, joints={n: -3.0 - i for i, n in enumerate(names)}),
        mech,
        Time(sec=7, nanosec=8),
        'f',
        reuse=first,
    )
    assert again is first
    assert list(again.name) == names
    assert list(again.position) == [-3.0 - i for i in range(len(names))]
    assert stamp_of(again) == (7, 8) and again.header.frame_id == 'f'


def test_result_to_points_refills_reused_messages():
    from linkage_ros.conversions import result_to_points

    cache: dict = {}
    first = result_to_points(
        Result(True, points={'P': (1.0, 2.0), 'Q': (3.0, 4.0)}), ['P'], Time(sec=1), 'f', cache
    )
    assert set(cache) == {'P'} and first['P'] is cache['P']
    again = result_to_points(
        Result(True, points={'P': (-1.5, 0.25), 'Q': (5.0, 6.0)}),
        ['P', 'Q'],
        Time(sec=7, nanosec=8),
        'f',
        cache,
    )
    assert again['P'] is first['P'] and set(cache) == {'P', 'Q'}
    p, q = again['P'], again['Q']
    assert (p.point.x, p.point.y, p.point.z) == (-1.5, 0.25, 0.0) and stamp_of(p) == (7, 8)
    assert (q.point.x, q.point.y) == (5.0, 6.0) and q.header.frame_id == p.header.frame_id == 'f'


def test_only_command_and_target_carry_qos_event_handlers(ros):
    """Each QoS-event handler is a waitable the executor polls on every message: outputs and
    per-point targets carry none, ~/command and ~/target keep rclpy's incompatibility warnings."""
    from linkage_ros.node import LinkageNode

    node = LinkageNode(
        context=ros.context,
        parameter_overrides=[Parameter('scene', Parameter.Type.STRING, 'four_bar')],
    )
    try:
        ours = [p for p in node.publishers if 'parameter_events' not in p.topic_name]
        assert {p.topic_name.rsplit('/', 1)[-1] for p in ours} >= {
            'joint_states',
            'markers',
            'status',
            'P',
        }
        assert all(p.event_handlers == [] for p in ours)
        handled = {s.topic_name.rsplit('/', 1)[-1] for s in node.subscriptions if s.event_handlers}
        assert handled == {'command', 'target'}
        assert sum(1 for s in node.subscriptions if 'target_point' in s.topic_name) == 3
    finally:
        node.destroy_node()
