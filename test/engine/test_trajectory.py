"""Trajectories and paths solved as one request (issue 17; linkage_ros/trajectory.py).

Oracles: the 50-digit four-bar of test/oracles.py (a crank turn), forward solves of the throws
an inverse path returns (they must reproduce the path), and fresh engines for the state checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracles import fourbar as oracle
from scenes import load

from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.trajectory import MAX_TRAJECTORY_POINTS, path_targets, solve_trajectory

L = (0.3, 0.1, 0.25, 0.2)  # config/four_bar.yaml: ground, crank, coupler, rocker


def engine(stem='four_bar', hold=()):
    return Engine(load(stem), EngineSettings('auto', 1e-12, 50, 'continuous', tuple(hold)))


def test_a_crank_turn_is_the_oracle_at_every_point_and_leaves_the_state():
    e = engine()
    before = e.last
    thetas = [1.0 + 2 * math.pi * k / 72 for k in range(73)]
    ans = solve_trajectory(e, ['crank'], [[t] for t in thetas], [[2.0]] * 73, list(range(73)))
    assert ans.success, ans.reason
    assert len(ans.results) == 73 and not ans.inverse
    for t, r in zip(thetas, ans.results):
        want = oracle(*L, t, branch=1)
        assert abs(math.remainder(r.links['rocker'] - float(want['theta4']), 2 * math.pi)) < 1e-12
        assert r.velocity is not None and r.velocity.success
    assert e.last is before  # a trajectory is a plan: the state is unchanged
    rocker = e.command({'crank': 1.0}).links['rocker']
    assert (
        abs(math.remainder(rocker - float(oracle(*L, 1.0, branch=1)['theta4']), 2 * math.pi))
        < 1e-12
    )


def test_an_excavator_throw_sweep_equals_one_command_after_another():
    e = engine('excavator')
    mech = e.mech
    acts = list(mech.actuators)
    rows = []
    for k in range(40):
        s = k / 39
        rows.append(
            [act.min + (act.max - act.min) * (0.2 + 0.6 * s) for act in mech.actuators.values()]
        )
    ans = solve_trajectory(e, acts, rows, (), list(range(40)))
    assert ans.success, ans.reason
    ref = engine('excavator')
    for row, r in zip(rows, ans.results):
        want = ref.command(dict(zip(acts, row)))
        for j in mech.joint_names:
            assert abs(math.remainder(r.joints[j] - want.joints[j], 2 * math.pi)) < 1e-9, j


def test_an_unreachable_point_refuses_the_whole_trajectory_naming_its_index():
    e = engine()
    before = e.last
    targets = [[1.70], [1.75], [1.2], [1.8]]  # the rocker swings from 1.633 to 2.681 rad
    ans = solve_trajectory(e, ['rocker'], targets, (), [0, 1, 2, 3])
    assert not ans.success and ans.failed_index == 2 and ans.reason.startswith('point 2: ')
    assert ans.results == [] and e.last is before
    # a point only the other assembly mode reaches is refused the same way: the motion to it
    # changes mode
    ans = solve_trajectory(e, ['B'], [[1.2], [-1.2]], (), [0, 1])
    assert (
        not ans.success
        and ans.failed_index == 1
        and 'the assembly mode changes from + to -' in ans.reason
    )
    assert e.last is before


def test_a_bin_path_comes_back_as_throws_that_reproduce_it():
    """Seed 002: successive positions of the bin -> the coordinated actuator motion."""
    e = engine('excavator', hold=('bucket',))
    mech = e.mech
    lip = e.last.points['L']
    path = [(lip[0] + 0.3 * s, lip[1] - 0.2 * s + 0.1 * s * s) for s in np.linspace(0, 1, 25)]
    targets = path_targets(e, 'L', path)
    assert not isinstance(targets, str)
    names, rows = targets
    assert names == ['L.x', 'L.y', 'bucket']
    ans = solve_trajectory(e, names, rows)
    assert ans.success, ans.reason
    fwd = engine('excavator')
    for (x, y), r in zip(path, ans.results):
        again = fwd.command({a: r.inputs[a] for a in mech.actuators})
        assert math.dist(again.points['L'], (x, y)) < 1e-9 * mech.length_scale
        assert (
            abs(math.remainder(again.links['bucket'] - e.last.links['bucket'], 2 * math.pi)) < 1e-9
        )
    assert path_targets(engine('excavator'), 'L', path).startswith('a path of ')  # no hold


@pytest.mark.parametrize(
    'names, rows, vel, times, why, index',
    [
        (['crank'], [], (), [], 'empty trajectory', None),
        (['crank'], [[0.1]] * (MAX_TRAJECTORY_POINTS + 1), (), None, 'at most', None),
        (['crank'], [[0.1], [0.2, 0.3]], (), [0, 1], 'point 1 has 2 position(s)', 1),
        (['crank'], [[0.1], [0.2]], [[], [1.0, 2.0]], [0, 1], 'point 1 has 2 velocities', 1),
        (['crank'], [[0.1], [0.2], [0.3]], (), [0, 5, 5], 'point 2: time_from_start', 2),
        (['crank'], [[0.1], [math.nan]], (), [0, 1], 'point 1: crank: value must be finite', 1),
        (['crank'], [[0.1], [0.2]], [[0.0], [math.inf]], [0, 1], 'point 1: velocity', 1),
        # an inverse trajectory refuses a NaN velocity as a forward one does (it was dropped)
        (['rocker'], [[1.9], [1.91]], [[0.0], [math.nan]], [0, 1], 'point 1: velocity', 1),
        # in the trajectory's words (it said 'joint_names: JointState names ...')
        (
            ['crank', 'crank'],
            [[0.1, 0.1]],
            (),
            [0],
            "JointTrajectory joint_names ['crank'] more",
            None,
        ),
        (['crank', ''], [[0.1, 0.1]], (), [0], 'JointTrajectory joint_names[1] is', None),
        (['wrench'], [[0.1]], (), [0], "point 0: unknown name 'wrench'", 0),
        # a solved trajectory's time_from_start is a Duration: int32 seconds
        (['crank'], [[0.1]], (), [(2**31 - 1) * 10**9 + 4 * 10**9], 'outside what a Duration', 0),
        (['crank'], [[0.1]], (), [-(2**31) * 10**9 - 1], 'outside what a Duration', 0),
    ],
)
def test_bad_trajectories_get_one_clear_reason_and_change_nothing(
    names, rows, vel, times, why, index
):
    e = engine()
    before = e.last
    if times is None:
        times = list(range(len(rows)))
    ans = solve_trajectory(e, names, rows, vel, times)
    assert not ans.success and why in ans.reason, ans.reason
    assert ans.failed_index == index
    assert e.last is before


def test_a_trajectory_of_point_coordinates_in_another_frame_is_refused():
    """As a path is: the node has no tf lookup. Joint and actuator values have no frame; point
    coordinates and link angles have."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from linkage_ros.engine import Engine, EngineSettings
    from linkage_ros.trajectory import answer_trajectory_msg

    mech = load('four_bar')
    engine = Engine(mech, EngineSettings())

    def trajectory(names, values, frame):
        msg = JointTrajectory(joint_names=names)
        msg.header.frame_id = frame
        msg.points = [
            JointTrajectoryPoint(positions=[v], time_from_start=Duration(sec=k + 1))
            for k, v in enumerate(values)
        ]
        return msg

    answer, _ = answer_trajectory_msg(engine, trajectory(['P.x'], [0.1], 'map'), 'base_link')
    assert not answer.success and "in frame 'map'" in answer.reason
    # a link's angle is absolute (from the frame's +x): it has a frame too
    answer, _ = answer_trajectory_msg(engine, trajectory(['coupler'], [0.1], 'map'), 'base_link')
    assert not answer.success and "in frame 'map'" in answer.reason
    answer, _ = answer_trajectory_msg(engine, trajectory(['crank'], [0.1, 0.2], 'map'), 'base_link')
    assert answer.success, answer.reason


def test_malformed_accelerations_or_effort_are_refused_not_ignored():
    """... naming the point by failed_index as every point-wise refusal does (TOPICS.md; an
    outside integrator found only a malformed velocity's and a point that does not solve's)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from linkage_ros.engine import Engine, EngineSettings
    from linkage_ros.trajectory import answer_trajectory_msg

    engine = Engine(load('four_bar'), EngineSettings())
    for field, values, why in (
        ('accelerations', [0.0, 1.0], 'point 2 has 2 accelerations for 1 joint_names'),
        ('effort', [math.nan], 'point 2: effort are not all finite'),
    ):
        points = [
            JointTrajectoryPoint(positions=[0.2 + k / 10], time_from_start=Duration(sec=k + 1))
            for k in range(4)
        ]
        setattr(points[2], field, values)
        answer, _ = answer_trajectory_msg(
            engine, JointTrajectory(joint_names=['crank'], points=points)
        )
        assert not answer.success and why in answer.reason, answer.reason
        assert answer.failed_index == 2
    # the first failing point is named, whatever fails there: point 1's positions before point
    # 2's accelerations (an adversary's find: 2 was named)
    points = [
        JointTrajectoryPoint(positions=p, time_from_start=Duration(sec=k + 1))
        for k, p in enumerate(([0.5], [0.6, 0.7], [0.7]))
    ]
    points[2].accelerations = [1.0, 2.0]
    answer, _ = answer_trajectory_msg(engine, JointTrajectory(joint_names=['crank'], points=points))
    assert answer.failed_index == 1 and answer.reason.startswith('point 1 has 2 position(s)')
    point = JointTrajectoryPoint(positions=[0.2], time_from_start=Duration(sec=1))
    point.accelerations = [0.5]  # well formed: accepted (not used)
    answer, _ = answer_trajectory_msg(
        engine, JointTrajectory(joint_names=['crank'], points=[point])
    )
    assert answer.success, answer.reason


def test_a_path_whose_stamps_span_more_than_a_duration_is_refused():
    """A path's times are its stamps less the first's; they become the solved trajectory's
    time_from_start (int32 seconds), so a span beyond that is refused, not a crash."""
    from builtin_interfaces.msg import Time
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Path

    from linkage_ros.core.errors import CommandError
    from linkage_ros.trajectory import path_request

    def path(secs):
        msg = Path()
        for s in secs:
            pose = PoseStamped()
            pose.header.stamp = Time(sec=s)
            pose.pose.position.x = 0.1
            msg.poses.append(pose)
        return msg

    with pytest.raises(CommandError, match='beyond what a time_from_start can hold') as exc:
        path_request(path([-(2**31), 2**31 - 1]), 'P', '')
    assert getattr(exc.value, 'index', None) == 1  # the pose named: failed_index
    # the first pose beyond the span, not the last (an adversary's find)
    with pytest.raises(CommandError, match='pose 1: its stamp') as exc:
        path_request(path([-(2**31), 2**31 - 1, 2**31 - 1 + 5]), 'P', '')
    assert getattr(exc.value, 'index', None) == 1
    xy, times = path_request(path([-(2**30), 2**30 - 1]), 'P', '')
    assert times == [0, (2**31 - 1) * 10**9]  # the longest span a Duration holds


def test_a_trajectory_through_the_fold_of_a_coordinate_never_jumps():
    """The loader's bin given by [D.x, bin] along a smooth in-limit throw path that takes the
    boom through horizontal (the fold of D.x). Past the fold the continuous answer follows the
    other root until it needs Z2 below its minimum; the answer was a jump of 0.13 m of throw
    back to the path's root in one step, with status OK. A trajectory either follows without
    a jump or is refused."""
    from linkage_ros.core.solver import Solver

    e = engine('front_loader')
    fwd = Solver(e.mech, method='closed_form', branch='reference')
    z1, z2 = np.linspace(2.2, 1.5, 400), np.linspace(2.0, 1.58, 400)
    src = [fwd.solve({'Z1': a, 'Z2': b}, commit=False) for a, b in zip(z1, z2)]
    assert all(r.success for r in src)
    rows = [[r.points['D'][0], r.links['bin']] for r in src]
    ans = solve_trajectory(e, ['D.x', 'bin'], rows)
    source_step = max(abs(z1[1] - z1[0]), abs(z2[1] - z2[0]))
    if ans.success:
        for a, b in zip(ans.results, ans.results[1:]):
            step = max(abs(a.inputs[k] - b.inputs[k]) for k in ('Z1', 'Z2'))
            assert step < 20 * source_step
    else:
        assert 'below its minimum 1.53' in ans.reason and ans.failed_index > 300, ans.reason


@pytest.mark.parametrize('names', [['D.x', 'bin'], ['D.x', 'D.y']])
def test_point_coordinate_velocities_give_the_throw_rates(names):
    """A trajectory of point coordinates with velocities answers every joint's rate, as a
    command's (it dropped them: '.' names had no rates). Oracle: the throw path Z1 = 1.9 + s,
    Z2 = 1.85 + s / 2, its targets' rates by central differences in s."""
    from linkage_ros.core.solver import Solver

    e = engine('front_loader')
    fwd = Solver(e.mech, method='closed_form', branch='reference')

    def targets(s):
        r = fwd.solve({'Z1': 1.9 + s, 'Z2': 1.85 + s / 2}, commit=False)
        return np.array([r.points['D'][0] if n == 'D.x' else r.points['D'][1] if n == 'D.y'
                         else r.links[n] for n in names])  # fmt: skip

    h = 1e-6
    rate = (targets(h) - targets(-h)) / (2 * h)
    ans = solve_trajectory(e, names, [list(targets(0.0))], [list(rate)])
    assert ans.success, ans.reason
    v = ans.results[0].velocity
    assert v is not None and v.success, v
    assert v.joints['Z1'] == pytest.approx(1.0, abs=1e-6)
    assert v.joints['Z2'] == pytest.approx(0.5, abs=1e-6)


def test_a_paths_malformed_pose_is_named_by_failed_index():
    """A pose that is not finite, or stamped in a frame of its own, was refused with the
    reason alone (an outside integrator: TOPICS.md's ~/target_path is "answered like a
    trajectory", whose status names the first failing point by failed_index); a path whose
    header is in another frame is the whole request's fault: no index."""
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Path

    from linkage_ros.engine import Engine, EngineSettings
    from linkage_ros.trajectory import answer_path_msg

    mech = load('plagiograph')  # two inputs: D's path is theirs
    engine = Engine(mech, EngineSettings())
    assert engine.last is not None  # the drawing, as the node starts
    x0, y0 = engine.last.points['D']

    def path(n=4):
        msg = Path()
        msg.header.frame_id = 'base_link'
        for k in range(n):
            pose = PoseStamped()
            pose.pose.position.x, pose.pose.position.y = x0 + 0.001 * k, y0
            msg.poses.append(pose)
        return msg

    good, _ = answer_path_msg(engine, 'D', path(), 'base_link')
    assert good.success, good.reason
    bad = path()
    bad.poses[2].pose.position.z = math.inf
    answer, _ = answer_path_msg(engine, 'D', bad, 'base_link')
    assert answer.reason.startswith('pose 2: position.z = inf') and answer.failed_index == 2
    bad = path()
    bad.poses[3].header.frame_id = 'map'
    answer, _ = answer_path_msg(engine, 'D', bad, 'base_link')
    assert answer.reason.startswith("pose 3: path of 'D' is in frame 'map'"), answer.reason
    assert answer.failed_index == 3
    bad = path()  # a pose not finite before one in another frame: the first is named
    bad.poses[0].pose.position.x = math.nan
    bad.poses[2].header.frame_id = 'odom'
    answer, _ = answer_path_msg(engine, 'D', bad, 'base_link')
    assert answer.failed_index == 0 and answer.reason.startswith('pose 0: position.x = nan')
    bad = path()
    bad.header.frame_id = 'map'
    answer, _ = answer_path_msg(engine, 'D', bad, 'base_link')
    assert answer.reason.startswith("path of 'D' is in frame 'map'") and answer.failed_index is None
