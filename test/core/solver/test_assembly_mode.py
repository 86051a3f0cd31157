"""Targets keep the assembly mode (issue 19): a target reachable only in the other mode used to
switch the mode of every later command silently (four_bar: target B = -1.2 then crank = 1.0
gave the rocker at -2.3488 rad where a fresh node gives 1.6896). The oracle for the positions
is the 50-digit four-bar of test/oracles.py, written apart from the core."""

from __future__ import annotations

import json
import math
import random

import numpy as np
import pytest
from oracles import fourbar as oracle
from scenes import CONFIG, KNUCKLE_BOOM, load

from linkage_ros.engine import Engine, EngineSettings

L = (0.3, 0.1, 0.25, 0.2)  # config/four_bar.yaml: ground, crank, coupler, rocker


def engine(stem='four_bar', branch='continuous'):
    return Engine(load(stem), EngineSettings('auto', 1e-12, 50, branch))


def rocker_oracle(theta2, branch):
    return float(oracle(*L, theta2, branch=branch)['theta4'])


def close_angle(a, b, tol=1e-12):
    return abs(math.remainder(a - b, 2 * math.pi)) < tol


def test_a_target_only_the_other_mode_reaches_is_refused_and_changes_nothing():
    e = engine()
    assert e.last.branch == '+'
    t = e.target({'B': -1.2})
    assert not t.success
    # a crank-rocker's other sign is its other curve: 'you can never go from one curve to the
    # other' (seed 000); the refusal said a motion through a toggle could change its mode
    assert t.reason.startswith(
        'target is reachable only in another circuit of the mechanism (signs -, a loop its '
        'actuator does not reach'
    )
    assert 'the mechanism is in mode +' in t.reason
    assert 'only taking the mechanism apart moves it to another circuit' in t.reason
    assert 'toggle' not in t.reason
    c = e.command({'crank': 1.0})
    assert c.success and c.branch == '+'
    assert close_angle(c.links['rocker'], rocker_oracle(1.0, +1))


def test_an_explicit_mode_change_is_allowed_and_reported():
    e = engine()
    t = e.target({'B': -1.2}, allow_mode_change=True)
    assert t.success and t.mode_change == '+ -> - (another circuit)'
    assert close_angle(t.joints['B'], -1.2)
    c = e.command({'crank': 1.0})
    assert c.success and c.branch == '-'
    assert close_angle(c.links['rocker'], rocker_oracle(1.0, -1))


def test_a_target_with_a_solution_in_the_current_mode_gets_that_one():
    """A rocker angle is reached by two crank angles, one in each mode: the one in the current
    mode is returned, whichever the inverse solve found first."""
    for start_branch in (+1, -1):
        e = engine()
        if start_branch < 0:
            assert e.target({'B': -1.2}, allow_mode_change=True).success
        for theta2 in (0.3, 1.0, 2.0, 3.0, -2.5, -1.0):
            want = rocker_oracle(theta2, start_branch)
            t = e.target({'rocker': want})
            assert t.success and not t.mode_change, t.reason
            c = e.command({'crank': t.inputs['crank']})
            assert c.branch == ('+' if start_branch > 0 else '-')
            assert close_angle(c.links['rocker'], want, 1e-9)


@pytest.mark.parametrize('stem', sorted(p.stem for p in CONFIG.glob('*.yaml')))
def test_random_target_sequences_answer_in_mode_or_say_why(stem):
    """Property test over sequences: targets taken from forward solves near the current state
    (joint, link, actuator and point names, mixed) are answered OK in the current mode, closing
    the loops (and mostly at the configuration they came from, see below), or refused with a named
    reason; never an internal error, never a silent mode change."""
    mech = load(stem)
    rng = random.Random(f'{stem}-modes')
    e = engine(stem)
    ref0 = e.last
    fwd = e.forward
    acts = list(mech.actuators)
    every = list(mech.joint_names) + list(mech.links) + acts
    names = [n for n in dict.fromkeys(every) if n != mech.ground]  # a cylinder is both
    ground_points = set(mech.links[mech.ground].points)
    moving_points = [p for p in mech.points if p not in ground_points]
    matched = refused = in_mode = 0
    for _ in range(60):
        ref = e.last
        cmd = {}  # a forward configuration near the current one, within limits
        for a in acts:
            s = next(sp for sp in fwd.specs if sp.name == a)
            lo = s.minimum if s.minimum is not None else ref.inputs[a] - 0.5
            hi = s.maximum if s.maximum is not None else ref.inputs[a] + 0.5
            mid = min(max(ref.inputs[a], lo), hi)
            span = 0.002 * (hi - lo)  # small steps: the source is the nearest solution
            cmd[a] = min(max(mid + rng.uniform(-span, span), lo), hi)
        f = fwd.solve(cmd, commit=False)
        if not f.success:
            continue
        values = {}
        points = {}  # point targets (<point>.x, <point>.y): 2 values each
        for n in rng.sample(names + [f'point:{p}' for p in moving_points], len(names)):
            room = mech.dof - len(values) - 2 * len(points)
            if n.startswith('point:'):
                if room >= 2:
                    points[n[6:]] = f.points[n[6:]]
            elif room >= 1:
                values[n] = (
                    f.links[n] if n in mech.links else (f.inputs[n] if n in acts else f.joints[n])
                )
        request = dict(values)
        for p, (x, y) in points.items():
            request[f'{p}.x'], request[f'{p}.y'] = x, y
        before = e.mode(e.last)
        r = e.target(request)
        if not r.success:
            assert r.reason and 'internal' not in r.reason, r.reason
            assert e.mode(e.last)[0] == before[0]
            # the source configuration is a solution within limits: when it is in the current
            # mode, a refusal may only say that the names do not fix the mechanism
            # (a link that never turns, such as a slider block, is left out: its angle fixes
            # nothing)
            still = [
                n
                for n in values
                if n in mech.links
                and abs(math.remainder(f.links[n] - ref0.links[n], 2 * math.pi)) < 1e-12
            ]
            if e.mode(f)[0] == before[0] and not still:
                about_names = (
                    'determine',
                    'over-constrains',
                    'degree(s) of freedom',
                    'cannot be a target',  # a point the other knowns fix already
                )
                assert any(t in r.reason for t in about_names), (values, r.reason)
            refused += 1
            continue
        assert not r.mode_change
        assert r.residual < 1e-9, r.residual
        for n, v in values.items():  # the answer is at the target values
            got = r.links[n] if n in mech.links else (r.inputs[n] if n in acts else r.joints[n])
            assert abs(math.remainder(got - v, 2 * math.pi)) < 1e-9 * max(1.0, abs(v)), (n, got, v)
        for p, xy in points.items():
            assert math.dist(r.points[p], xy) < 1e-9 * mech.length_scale, (p, r.points[p], xy)
        after = e.mode(r)
        for sb, sa, mb, ma in zip(before[0], after[0], before[1], after[1]):
            assert sb == sa or min(mb, ma) <= 1e-9, (before, after)
        if r.cond is not None and r.cond > 1e10:
            # an inverse toggle (a double root): the answer is the root, not the source
            # (name sets that fix no configuration at all are refused when their solver is made)
            continue
        if e.mode(f)[0] == before[0]:  # the configuration the target came from is in mode
            miss = max(math.dist(r.points[p], f.points[p]) for p in mech.points)
            matched += miss < 1e-6 * mech.length_scale
            in_mode += 1
    # The target values need not single out one configuration of the mode (a slider-crank's
    # rod angle is reached at crank angles t and pi - t alike): the answer is the solution
    # nearest the last good state, which for these small steps is almost always the source.
    assert in_mode >= 10 and matched >= 0.9 * in_mode, (matched, in_mode, refused)


PEAUCELLIER_CELL = """
name: peaucellier_cell
points:
  O: [0.0, 0.0]
  A: [0.08794443942928294, 0.12151450766665346]
  B: [0.13543566474467272, -0.0644762027043204]
  P: [0.08449121528506677, 0.021574149237189134]
  Q: [0.1388888888888889, 0.03546415572514393]
ground: ground
links: {ground: [O], OA: [O, A], OB: [O, B], PA: [P, A], BP: [B, P], AQ: [A, Q], QB: [Q, B]}
actuators:
  a1: {type: angle, link: OA, pivot: O}
  a2: {type: angle, link: OB, pivot: O}
outputs: [Q, P]
"""


def test_a_peaucellier_cell_target_inside_the_fold_is_the_inversion_not_the_fold(tmp_path):
    """Seed 001: 'however Q moves, O, P and Q remain on one line and OP * OQ is constant'
    (l^2 - s^2). Q taken along a line that passes |OQ| = sqrt(l^2 - s^2): the dyad placing A
    folded onto B there, and the answers after it were A on B with P anywhere on its circle,
    status OK (margin 0, OP * OQ 0.0071-0.0084). The rule now prefers the regular solution in
    the mode over a fold, where there is one."""
    from linkage_ros.core.model import Scene
    from linkage_ros.engine import Engine, EngineSettings

    path = tmp_path / 'cell.yaml'
    path.write_text(PEAUCELLIER_CELL)
    mech = Scene.from_yaml(path).mechanism
    e = Engine(mech, EngineSettings())
    l, s = 0.15, 0.10
    for t in np.linspace(0.0, 1.0, 15):
        q = (0.13 - 0.07 * t, 0.06 - 0.11 * t)
        r = e.target({'Q.x': q[0], 'Q.y': q[1]})
        assert r.success, r.reason
        (px, py), (qx, qy) = r.points['P'], r.points['Q']
        assert math.dist((qx, qy), q) <= 1e-12
        assert math.hypot(px, py) * math.hypot(qx, qy) == pytest.approx(l * l - s * s, abs=1e-12)
        assert abs(px * qy - py * qx) <= 1e-12  # O, P, Q on one line
        assert r.margin > 1e-6


def test_a_non_grashof_four_bar_has_one_mode_through_its_toggles():
    """Seed 000: for a non-Grashof linkage 'there is only one curve, because there is only one
    mode of assembly ... the mirror image configuration can be taken up by the same assembly';
    seed 002: its two solutions 'are not two distinct assembly modes'. A target the mechanism
    reaches by moving its crank through a toggle was refused as 'reachable only in assembly
    mode -'. Oracle: the mpmath four-bar in the dyad's other sign at crank 60 deg. The
    crank-rocker's two signs are two circuits: still refused."""
    from oracles import fourbar, fourbar_toggles

    mech = load('four_bar_non_grashof')
    e = Engine(mech, EngineSettings())
    want = fourbar(0.30, 0.20, 0.25, 0.22, math.radians(60), branch=-1)
    r = e.target({'rocker': float(want['theta4'])})
    assert r.success, r.reason
    assert r.inputs['crank'] == pytest.approx(math.radians(60), abs=1e-9)
    assert r.branch == '-'
    # and a trajectory of commands through the toggle at 2.43 rad and back is one motion
    from linkage_ros.trajectory import solve_trajectory

    e = Engine(mech, EngineSettings())
    toggle = float(fourbar_toggles(0.30, 0.20, 0.25, 0.22)[0][0])  # 2.43027 rad
    rows = [[c] for c in np.linspace(1.0, toggle, 40)] + [[c] for c in np.linspace(toggle, 1.0, 40)]
    ans = solve_trajectory(e, ['crank'], rows)
    assert ans.success, ans.reason
    assert {x.branch for x in ans.results} == {'+', '-'}
    # the crank-rocker: its two signs are two circuits
    r = Engine(load('four_bar'), EngineSettings()).target({'B': -1.2})
    assert not r.success and 'reachable only in another circuit of the mechanism (signs -' in (
        r.reason
    )


def test_a_grashof_double_rocker_loop_holds_both_signs():
    """Seed 000: the Grashof double-rocker has 'two loops', each through both signs of its
    dyad (the crank swings between two toggles). A target on the drawing's loop in the other
    sign was refused as another assembly mode. Oracle: the mpmath four-bar at crank 1.0."""
    from oracles import fourbar

    want = fourbar(0.30, 0.20, 0.10, 0.25, 1.0, branch=-1)
    e = Engine(load('four_bar_grashof_double_rocker'), EngineSettings())
    r = e.target({'rocker': float(want['theta4'])})
    assert r.success, r.reason
    assert r.inputs['crank'] == pytest.approx(1.0, abs=1e-9) and r.branch == '-'


def test_the_double_rockers_mirror_loop_is_another_circuit_with_the_same_signs(tmp_path):
    """Seed 000: a Grashof double-rocker has two loops, 'you can never pass on from one ... to
    the other'. Without crank limits, a target only the mirror loop reaches (crank -0.80) was
    answered in the same signs with no mode change. Now refused as another circuit; allowed on
    request, the change says so. Oracle: the mpmath four-bar at crank -0.80."""
    from oracles import fourbar

    from linkage_ros.core.model import Scene

    text = (CONFIG / 'four_bar_grashof_double_rocker.yaml').read_text()
    path = tmp_path / 'dr.yaml'
    path.write_text('\n'.join(ln for ln in text.splitlines() if 'crank_limits' not in ln))
    mech = Scene.from_yaml(path).mechanism
    mirror = fourbar(0.30, 0.20, 0.10, 0.25, -0.80, branch=1)
    e = Engine(mech, EngineSettings())
    r = e.target({'rocker': float(mirror['theta4'])})
    assert not r.success and 'reachable only in another circuit' in r.reason, r.reason
    # (no motion reaches another circuit: a toggle is not named as a way)
    assert 'only taking the mechanism apart moves it to another circuit' in r.reason
    assert 'toggle' not in r.reason
    r = e.target({'rocker': float(mirror['theta4'])}, allow_mode_change=True)
    assert r.success and r.mode_change.endswith('(another circuit)')
    assert r.inputs['crank'] == pytest.approx(-0.80, abs=1e-9)


def test_the_cli_sweeps_targets_in_the_drawings_mode_under_branch_reference(capsys):
    """`linkage sweep --branch reference` answers targets as a node with branch: reference
    does (the drawing's mode, every target); `linkage solve` from the drawing follows its
    circuit (a non-Grashof four-bar: both signs)."""
    from linkage_ros.cli.parser import main

    argv = ['sweep', 'four_bar_non_grashof', '--target', 'rocker=4.0', '--json']
    main([*argv, '--branch', 'reference'])
    d = json.loads(capsys.readouterr().out.splitlines()[0])
    assert d['status'] == 'error'
    assert "the branch setting 'reference' keeps the mechanism in mode +" in d['reason']
    main([*argv, '--branch', 'continuous'])
    assert json.loads(capsys.readouterr().out.splitlines()[0])['status'] == 'ok'
    assert main(['solve', 'four_bar_non_grashof', '--target', 'rocker=4.0']) == 0


def test_a_mode_a_cylinder_reaches_through_its_dead_centre_is_worded_so():
    """Where the actuators' motion passes a toggle inside the limits (the crane's fold cylinder
    through its dead centre: the jib from ++ to +-), the refusal says a motion through a
    toggle position changes the mode, not that the mechanism must be taken apart. Oracle: the
    dead centre's throw, |B2 T1| + |T1 J1| from the drawing, inside the fold's limits."""
    from linkage_ros.core.model import Scene

    pts = {k: complex(*v) for k, v in KNUCKLE_BOOM['points'].items()}
    dead_centre = abs(pts['T1'] - pts['B2']) + abs(pts['J1'] - pts['T1'])
    assert 1.30 < dead_centre < 1.95
    e = Engine(Scene.from_dict(KNUCKLE_BOOM).mechanism, EngineSettings())
    assert e.last.branch == '++'
    r = e.target({'jib': 0.5, 'lift': 1.3})
    assert not r.success
    assert r.reason.startswith('target is reachable only in assembly mode +- of the forward dyads')
    assert 'only a motion through a toggle position, or taking the mechanism apart, changes' in (
        r.reason
    )


def test_a_target_the_current_mode_reaches_just_past_a_limit_says_the_limit_first():
    """The loader's bin hinge D where Z1 = 1.9 m and Z2 = 2.08 m + 1e-6 m put it (Z2 just past
    its maximum) was refused as 'reachable only in assembly mode +++' though the current mode
    +-+ reaches it there (a numerics reviewer); the limit comes first now, then the mode that
    reaches it within the limits. Oracle: D of the limit-free loader at those throws, the
    throw asked for read back from the refusal."""
    from linkage_ros.core.motion.common import without_limits
    from linkage_ros.core.solver import Solver

    mech = load('front_loader')
    free = Solver(without_limits(mech))
    d = free.solve({'Z1': 1.9, 'Z2': 2.08 + 1e-6}).points['D']
    e = Engine(mech, EngineSettings())
    assert e.mode(e.last)[0] == (1, -1, 1)
    r = e.target_point('D', d)
    assert not r.success
    assert r.reason.startswith(
        'target needs Z2 = 2.080001 m is beyond its maximum 2.08 by 1e-06 m from the current '
        'configuration; within the limits it is reachable only in assembly mode +++'
    ), r.reason


def test_a_target_whose_way_stops_at_a_limit_names_every_limit_it_needs():
    """The loader's bucket tip T where Z1 = 2.35 m (max 2.3) and Z2 = 1.45 m (min 1.53) put it
    in the current mode was refused as 'cannot assemble: RRR dyad E ... misses by 0.0708 m'
    (the inverse plan's direct solve in the current signs), with the way's edge where Z2 met
    its limit; `--all-branches` alike (a hydraulics engineer). Both limits are named now, with
    the throws the target needs. Oracle: T of the limit-free loader at those throws."""
    from linkage_ros.core.motion.common import without_limits
    from linkage_ros.core.solver import Solver

    mech = load('front_loader')
    t = Solver(without_limits(mech)).solve({'Z1': 2.35, 'Z2': 1.45}).points['T']
    e = Engine(mech, EngineSettings())
    assert e.mode(e.last)[0] == (1, -1, 1)
    r = e.target_point('T', t)
    assert not r.success
    assert r.reason == (
        'target needs Z1 = 2.35 m is beyond its maximum 2.3 by 0.05 m; and Z2 = 1.45 m is below '
        'its minimum 1.53 by 0.08 m (its answer in the current assembly mode +-+, without the '
        'limits)'
    ), r.reason


def test_an_answer_beyond_two_limits_names_both_in_the_scalar_and_the_batch_solve():
    """An inverse answer needing two cylinders past their limits named the first only (an
    operator who brings the boom back is refused again for the bucket: a hydraulics
    engineer); the batch's row gives the same words (one rule). Oracle: the throws the
    target was made from, read back from the refusal."""
    from linkage_ros.core.motion.common import without_limits
    from linkage_ros.core.solver import Solver

    mech = load('front_loader')
    d = Solver(without_limits(mech)).solve({'Z1': 2.32, 'Z2': 2.09}).points['D']
    inv = Solver(mech, knowns=['point:D'])
    r = inv.solve({'point:D': d})
    assert not r.success
    assert r.reason == (
        'target needs Z1 = 2.32 m is beyond its maximum 2.3 by 0.02 m; and Z2 = 2.09 m is '
        'beyond its maximum 2.08 by 0.01 m'
    ), r.reason
    batch = inv.solve_batch({'point:D': [d]})
    assert not batch.ok[0] and batch.reason[0] == r.reason


@pytest.mark.parametrize('drive', [3.65, 3.74, 3.2])
def test_each_jacobian_mode_is_answered_wherever_the_circuit_has_it(drive):
    """A Stephenson-III six-bar driven at its output has both loop-Jacobian modes at drive
    3.65 rad (its circuit passes four toggles of the drive), but `--branch J+` there was refused
    ('no assembly near the current configuration': the walk from the drawing stops at the
    drawing's toggle, 3.5462) while --all-branches listed it (a legged-linkage designer).
    Oracle: the drive as a function of the crank by circle intersections (test/oracles.py):
    each answer's crank gives the drive asked for, and the two modes' cranks differ."""
    from oracles import stephenson_drive
    from scenes import STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT as scene

    from linkage_ros.core.model import Scene
    from linkage_ros.core.solver import Solver

    mech = Scene.from_dict(scene).mechanism
    drive_of = stephenson_drive(scene['points'])
    cranks = []
    for mode in ('J+', 'J-'):
        r = Solver(mech, branch=mode).solve({'drive': drive})
        assert r.success and r.branch == mode, (mode, r.reason)
        crank = r.links['crank']
        assert abs(math.remainder(drive_of(crank) - drive, 2 * math.pi)) < 1e-9, (mode, crank)
        cranks.append(crank)
    assert abs(math.remainder(cranks[0] - cranks[1], 2 * math.pi)) > 0.1


def test_a_newton_placed_mechanisms_mode_search_names_its_mode_as_a_setting_does():
    """A Stephenson-III six-bar driven at its output (Newton places it, its modes J+ / J-):
    `--target coupler=0.3` was refused with 'branch '+' has 1 sign(s) but this solve has no
    branching dyad' (the mode search built its forward solver with the mode's sign as a dyad
    sign: an adversary). It is refused as out of reach, with the way's edge; a coupler angle
    inside its swing is answered, every loop closed at the drawing's lengths."""
    from scenes import STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT as scene

    from linkage_ros.core.model import Scene

    e = Engine(Scene.from_dict(scene).mechanism, EngineSettings())
    r = e.target({'coupler': 0.3})
    assert not r.success and r.reason.startswith('coupler = 0.3 rad is out of reach'), r.reason
    assert 'branching dyad' not in r.reason
    ok = e.target({'coupler': 0.45})
    assert ok.success and abs(ok.links['coupler'] - 0.45) < 1e-12, ok.reason
    P = {k: complex(*v) for k, v in scene['points'].items()}
    p = {k: complex(*v) for k, v in ok.points.items()}
    for a, b in (('O2', 'A'), ('A', 'B'), ('O4', 'B'), ('A', 'C'), ('B', 'C'), ('C', 'D')):
        assert abs(abs(p[a] - p[b]) - abs(P[a] - P[b])) < 1e-9, (a, b)
    assert abs(abs(p['O6'] - p['D']) - abs(P['O6'] - P['D'])) < 1e-9
