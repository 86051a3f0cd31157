"""Trajectories and paths served by ``linkage_node`` over real DDS: ~/trajectory of a crank
turn on the four-bar (against the closed-form oracle) and of cylinder throws on the excavator
(against ``linkage solve``), ~/target_path/<p> on the excavator, and the ERROR each bad one
gets, with nothing solved."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path as NavPath
from node_helpers import ANSWER_TIMEOUT, QUIET, angle_diff, joint_state, mid_command, stamp_of
from ros_harness import random_domain_id
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

DOMAIN_ID = random_domain_id()


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
    (the closed-form oracle; its rates: the oracle's central difference times the crank's
    rate), time_from_start and stamp kept, one status;
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
    assert len(solved.points) == len(thetas)
    h = 1e-5  # (central difference: truncation ~h^2, rounding ~1e-16 / h; both below 1e-8)
    for k, (t, pt) in enumerate(zip(thetas, solved.points)):
        want = four_bar.oracle.solve(t)['joints']
        ahead, behind = (four_bar.oracle.solve(t + s * h)['joints'] for s in (1, -1))
        got = dict(zip(solved.joint_names, pt.positions))
        rate = dict(zip(solved.joint_names, pt.velocities))
        assert set(got) == set(rate) == set(want)
        for j in want:
            assert angle_diff(got[j], want[j]) < 1e-12, (k, j)
            slope = math.remainder(ahead[j] - behind[j], 2 * math.pi) / (2 * h)
            assert abs(rate[j] - 1.5 * slope) < 1e-8, (k, j, rate[j], 1.5 * slope)
        assert (pt.time_from_start.sec, pt.time_from_start.nanosec) == divmod(
            (k + 1) * 10**7, 10**9
        )
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
    assert angle_diff(joints['O4'], four_bar.oracle.solve(1.0)['joints']['O4']) < 1e-12


def test_throw_sweep_trajectory_over_dds_equals_the_cli(three_dof, capsys):
    """A trajectory of cylinder throws on the excavator equals `linkage solve` of the same
    throws one after another (--branch continuous) to 1e-9; 10^5 points get one clear ERROR and
    change nothing."""
    import json

    from linkage_ros.cli.parser import main as cli_main

    mech = three_dof.mech
    mid = mid_command(mech)
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
        assert len(solved.points) == n
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
    mid = mid_command(mech)
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
    assert len(solved.points) == len(xy)
    for (x, y), pt in zip(xy, solved.points):
        got = dict(zip(solved.joint_names, pt.positions))
        r = fwd.command({a: got[mech.actuators[a].joint] for a in mech.actuators})
        assert math.dist(r.points['L'], (x, y)) < 1e-9 * mech.length_scale
    path.poses[7].pose.position.x = math.nan
    status, _ = _trajectory_request(three_dof, path, '~/target_path/L')
    assert status.level == DiagnosticStatus.ERROR and 'pose 7: position.x' in status.message
