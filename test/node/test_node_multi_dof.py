"""Multi-DOF scenes served by ``linkage_node`` over real DDS: the 2-DOF plagiograph and the
3-DOF excavator (cylinder commands, limits, held actuators, point, two-hinge and pose
targets), checked on rigid-body invariants of the published geometry."""

from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import PointStamped, PoseStamped
from node_helpers import (
    angle_diff,
    finish,
    joint_state,
    marker_points,
    mid_command,
    mid_joint_state,
    point_stamped,
    stamp_of,
    start_served,
)
from ros_harness import random_domain_id
from scenes import CONFIG

from linkage_ros.core.model import AngleActuator

DOMAIN_ID = random_domain_id()


@pytest.fixture(scope='module')
def two_dof(ros, workdir):
    scene = CONFIG / 'plagiograph.yaml'
    served, proc = start_served(ros, workdir, 'two_dof', scene, mid_joint_state(scene))
    yield served
    finish(proc)


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
    mid = mid_command(mech)
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
    command = mid_command(mech)
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
    command = mid_command(three_dof.mech)
    command[a] = act.max + 0.1
    three_dof.assert_single_error(
        three_dof.request(joint_state(list(command), list(command.values()))), 'maximum'
    )


def test_three_dof_target_point_holds_bucket(three_dof):
    mech = three_dof.mech
    command = mid_command(mech)
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
    command = mid_command(mech)
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
    mid = mid_command(mech)
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
    mid = mid_command(mech)
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
