"""A roller on a flat face (a slot with a ``radius``): its side of the face is an assembly
choice like a dyad's sign (issue 27). Every mode lists both sides, says which is drawn, and
continuity never moves a roller through its face.

The nut-cracker: a handle (the input, pivot O2) drives an arm A-B to a lever O4-B-R whose roller
of radius r about R presses on the flat face of a jaw pivoted at O6 (the face through O6 along
the jaw's axis). Its modes: the two sides of the RRR dyad at B, then for each, the two lines
through O6 tangent to the roller on each side of it (2 x 2 x 2 = 8, and no more: B has two
places, and from each the jaw has two tangent lines per side).

Oracles (test/oracles.py, 50 digits, nothing from linkage_ros): B from the circle-circle
construction, R carried with the lever, the jaw's direction from ``line_through_point`` (the
line whose signed offset from R is +-r), written apart from the core; and the constraint
geometry read off each answer directly (every link length, the roller centre r off the face on
the side its mode states).
"""

from __future__ import annotations

import itertools
import math

import mpmath as mp
import numpy as np
import oracles
import pytest
import scenes
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.core.velocity import velocities
from linkage_ros.engine import Engine, EngineSettings

RADIUS, JAW, DRAWN, _jaw_point, nut_cracker = (
    scenes.NUT_RADIUS,
    scenes.NUT_JAW,
    scenes.NUT_DRAWN,
    scenes.nut_cracker_jaw_point,
    scenes.nut_cracker,
)


def _dist(p, q) -> float:
    return math.hypot(p[0] - q[0], p[1] - q[1])


def oracle_modes(theta: float) -> list[dict]:
    """The nut-cracker's configurations at handle angle ``theta`` (50 digits): each a dict of
    points and the roller's side (+1 left of the face's direction O6 -> F, -1 right)."""
    d = {**DRAWN, 'F': _jaw_point()}
    out = []
    with mp.workdps(oracles.DPS):
        l_handle, l_arm = _dist(d['O2'], d['A']), _dist(d['A'], d['B'])
        l_rocker = _dist(d['O4'], d['B'])
        a = (l_handle * mp.cos(theta), l_handle * mp.sin(theta))
        for b_sign, side, along in itertools.product((1, -1), repeat=3):
            b = oracles.circle_circle(a, l_arm, d['O4'], l_rocker, b_sign).point
            if b is None:
                continue
            # the lever turned about O4 so that B is where it is: R goes with it
            turn = mp.atan2(b[1] - d['O4'][1], b[0] - d['O4'][0]) - mp.atan2(
                mp.mpf(d['B'][1]) - d['O4'][1], mp.mpf(d['B'][0]) - d['O4'][0]
            )
            rx, ry = mp.mpf(d['R'][0]) - d['O4'][0], mp.mpf(d['R'][1]) - d['O4'][1]
            r = (
                d['O4'][0] + rx * mp.cos(turn) - ry * mp.sin(turn),
                d['O4'][1] + rx * mp.sin(turn) + ry * mp.cos(turn),
            )
            # the face through O6 along psi keeps R at the signed offset side * radius
            psi = oracles.line_through_point(r, d['O6'], -side * RADIUS, along)
            if psi is None:
                continue
            f = (d['O6'][0] + JAW * mp.cos(psi), d['O6'][1] + JAW * mp.sin(psi))
            out.append({'points': {'A': a, 'B': b, 'R': r, 'F': f}, 'side': side})
    return out


def check_constraints(res, side: int, radius: float = RADIUS) -> None:
    """The constraint geometry of one answer, read off its points: every link length as
    drawn, the ground where drawn, the roller centre ``radius`` off the jaw's face on
    ``side``."""
    p = {k: tuple(v) for k, v in res.points.items()}
    d = {**DRAWN, 'F': _jaw_point(radius)}
    tol = 1e-12 * 0.2
    for a, b in [('O2', 'A'), ('A', 'B'), ('O4', 'B'), ('O4', 'R'), ('B', 'R'), ('O6', 'F')]:
        assert abs(_dist(p[a], p[b]) - _dist(d[a], d[b])) <= tol, (a, b)
    for g in ('O2', 'O4', 'O6'):
        assert _dist(p[g], d[g]) <= tol
    u = np.subtract(p['F'], p['O6']) / _dist(p['F'], p['O6'])
    w = np.subtract(p['R'], p['O6'])
    offset = u[0] * w[1] - u[1] * w[0]  # > 0: R left of the face's direction
    assert abs(offset - side * radius) <= tol


@pytest.fixture(scope='module')
def mech():
    return Scene.from_dict(nut_cracker()).mechanism


@pytest.mark.parametrize('theta', [-1.2, 0.3, 1.0303, 1.6])
def test_every_nut_cracker_mode_against_the_oracle(mech, theta):
    want = oracle_modes(theta)
    assert len(want) == 8  # the most there can be (see the module docstring): all close here
    modes = Solver(mech).modes({'handle': theta})
    assert modes.complete and len(modes.results) == 8
    sides = {'left': 1, 'right': -1}
    matched = set()
    for res in modes.results:
        assert res.success
        side = sides[modes.roller_sides(res)['face']]
        check_constraints(res, side)
        near = [
            i
            for i, o in enumerate(want)
            if o['side'] == side
            and all(
                oracles.point_error(res.points[k], v) <= 1e-12 * 0.2 for k, v in o['points'].items()
            )
        ]
        assert len(near) == 1, res.branch
        matched.add(near[0])
    assert len(matched) == 8  # eight distinct configurations, one per oracle mode
    # four on each side, and the drawn mode is one of them: the reference signs
    assert (
        sorted(modes.roller_sides(r)['face'] for r in modes.results) == ['left'] * 4 + ['right'] * 4
    )
    assert [c.drawn for c in modes.rollers] == ['left']
    assert sum(r.branch == modes.drawn for r in modes.results) == 1


def test_the_drawn_mode_is_the_drawing(mech):
    theta = math.atan2(DRAWN['A'][1], DRAWN['A'][0])
    modes = Solver(mech).modes({'handle': theta})
    (drawn,) = [r for r in modes.results if r.branch == modes.drawn]
    for k, v in mech.points.items():
        assert _dist(drawn.points[k], v) <= 1e-12
    assert modes.roller_sides(drawn) == {'face': 'left'}


@pytest.mark.parametrize('branch', ['++-', '+-+', '-+-', '---'])
def test_a_branch_with_either_side_is_kept_over_a_sweep(mech, branch):
    solver = Solver(mech, branch=branch)
    side = 1 if branch[1] == '+' else -1
    for theta in np.linspace(-1.6, 1.6, 33):
        res = solver.solve({'handle': float(theta)})
        assert res.success and res.branch == branch, (theta, res.reason)
        check_constraints(res, side)


def test_continuity_never_moves_the_roller_through_its_face(mech):
    # start on the side not drawn (a mode adopted from the list), then sweep the handle to and
    # fro, across the arm's toggles where the dyad signs may change: the side stays
    solver = Solver(mech)
    start = next(
        r
        for r in solver.modes({'handle': 1.0}).results
        if r.branch[1] == '-' and r.branch[0] == '+'
    )
    assert solver.adopt(start)
    # the arm reaches for handle angles within about +-1.69 rad (its toggles at the ends)
    thetas = np.concatenate([np.linspace(1.0, 2.0, 100), np.linspace(2.0, -2.0, 400)])
    solved = 0
    for theta in thetas:
        res = solver.solve({'handle': float(theta)})
        if res.success:
            solved += 1
            assert res.branch[1] == '-', theta
            check_constraints(res, -1)
    assert solved > 300


def test_newton_refuses_to_move_a_roller_through_its_face(mech):
    # Newton's loop equations hold the roller on its drawn side: from the other side it says
    # so instead of flipping the roller (or grinding)
    closed = Solver(mech)
    flipped = next(r for r in closed.modes({'handle': 1.0}).results if r.branch == '+-+')
    newton = Solver(mech, method='newton')
    assert newton.adopt(flipped)
    res = newton.solve({'handle': 1.01})
    assert not res.success and "roller of slot 'face'" in res.reason
    # on the drawn side it solves as before
    newton = Solver(mech, method='newton')
    res = newton.solve({'handle': 1.01})
    assert res.success
    check_constraints(res, 1)


def test_a_roller_drawn_on_the_right_lists_left_as_the_other_side():
    data = nut_cracker()
    # the same drawing mirrored top to bottom: the roller on the face's right
    data['points'] = {k: [x, -y] for k, (x, y) in data['points'].items()}
    mech = Scene.from_dict(data).mechanism
    modes = Solver(mech).modes({'handle': -1.0})
    assert len(modes.results) == 8
    assert [c.drawn for c in modes.rollers] == ['right']
    (drawn,) = [r for r in modes.results if r.branch == modes.drawn]
    assert modes.roller_sides(drawn) == {'face': 'right'}


# ---- the roller's other dyad: a roller on a ground face (RRP) ---------------------------------


roller_crank = scenes.roller_crank


@pytest.mark.parametrize('drawn_side', [1, -1])
@pytest.mark.parametrize('theta', [0.3, 2.0, 4.0])
def test_a_roller_on_a_ground_face_has_both_sides(drawn_side, theta):
    mech = Scene.from_dict(roller_crank(drawn_side)).mechanism
    modes = Solver(mech).modes({'crank': theta})
    assert len(modes.results) == 4
    a = (0.1 * math.cos(theta), 0.1 * math.sin(theta))
    got = set()
    for res in modes.results:
        side = 1 if modes.roller_sides(res)['floor'] == 'left' else -1
        # oracle: R on the circle of 0.3 about A and on the line y = side * r
        for sign in (1, -1):
            want = oracles.circle_line(a, 0.3, (0.0, side * 0.02), (1.0, 0.0), sign).point
            if oracles.point_error(res.points['R'], want) <= 1e-13:
                got.add((side, sign))
        assert res.residual <= 1e-14
    assert len(got) == 4
    assert [c.drawn for c in modes.rollers] == ['left' if drawn_side > 0 else 'right']


@pytest.mark.parametrize('branch', ['+++', '+-+', '--+', '+--'])
def test_velocities_on_either_side_match_central_differences(mech, branch):
    # the loop Jacobian does not depend on which side's line the roller runs on (the line moves
    # across itself): the exact rates hold on the side not drawn as on the drawn one
    solver = Solver(mech, branch=branch)
    for theta in (-1.0, 0.4, 1.3):
        values, rates = {'handle': theta}, {'handle': 1.0}
        res = solver.solve(values)
        assert res.success and res.branch == branch
        vel = velocities(solver, res, values, rates)
        assert vel.success, vel.reason
        fd_joints, fd_points = oracles.central_difference_rates(solver, values, rates, 1e-6)
        scale = max(1.0, max(abs(v) for v in vel.joints.values()))
        for j in mech.joint_names:
            assert abs(vel.joints[j] - fd_joints[j]) <= 1e-6 * scale, j
        for p in mech.points:
            for k in (0, 1):
                assert abs(vel.points[p][k] - fd_points[p][k]) <= 1e-6 * scale, p


@pytest.mark.parametrize('branch', ['+-+', '-+-'])
def test_a_batch_takes_the_side_its_branch_says(mech, branch):
    # the vectorised plan run places the roller on the side of its branch, as one command does
    thetas = np.linspace(-1.5, 1.5, 41)
    batch = Solver(mech, branch=branch).solve_batch({'handle': thetas})
    assert np.all(batch.ok) and np.all(batch.residual <= 1e-14)
    side = 1 if branch[1] == '+' else -1
    assert np.all(batch.signs[:, 1] == side)
    for i in range(0, 41, 8):
        check_constraints(batch.row(i), side)


def test_a_target_answers_in_the_mode_roller_side_included(mech):
    # the target rule reads the roller's side as one of the mode's signs: a jaw angle reached
    # here only in another mode is refused, naming both; allowed on request, later commands
    # keep the new mode, roller side included. (The drawing's circuit passes the first
    # dyad's toggles, so its jaw angles are those of +++ and -++: 1.88 .. 3.10 rad; +-+
    # reaches none beyond them, +-- reaches -0.61 rad at handle -1.5.)
    modes = Solver(mech).modes({'handle': -1.5})
    flipped = next(r for r in modes.results if r.branch == '+--')
    e = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    t = e.target({'O6': flipped.joints['O6']})
    assert not t.success and 'the mechanism is in mode +++' in t.reason
    t = e.target({'O6': flipped.joints['O6']}, allow_mode_change=True)
    assert t.success and t.mode_change.startswith('+++ -> ')
    # the roller's other side is another circuit of the drawing's (its actuator passes the
    # first dyad's toggles only), and the change says so
    after, circuit = t.mode_change.split(' -> ')[1].split(' ', 1)
    assert len(after) == 3 and circuit == '(another circuit)'
    for theta in (-1.0, 0.0, 1.0):
        c = e.command({'handle': theta})
        assert c.success and c.branch == after
        check_constraints(c, 1 if after[1] == '+' else -1)


def test_newton_refuses_a_branch_with_the_side_not_drawn(mech):
    res = Solver(mech, method='newton', branch='+-+').solve({'handle': 1.0})
    assert not res.success and "roller of slot 'face' is asked to be on the side" in res.reason
    res = Solver(mech, method='newton', branch='-++').solve({'handle': 1.0})
    assert res.success and res.branch == '-++'
    check_constraints(res, 1)


@settings(max_examples=40, deadline=None)
@given(
    theta=st.floats(-1.65, 1.65),
    radius=st.floats(1e-4, 0.05),
)
def test_every_mode_closes_on_its_side_for_any_radius_and_input(theta, radius):
    # every mode listed is a configuration of the nut-cracker with the roller on the side its
    # branch says, the modes are distinct, and as many close on one side as on the other
    mech = Scene.from_dict(nut_cracker(radius)).mechanism
    modes = Solver(mech).modes({'handle': theta})
    ok = [r for r in modes.results if r.success]
    assume(ok)
    for r in ok:
        check_constraints(r, 1 if modes.roller_sides(r)['face'] == 'left' else -1, radius)
    for i, a in enumerate(ok):
        for b in ok[i + 1 :]:
            assert max(_dist(a.points[k], b.points[k]) for k in a.points) > 1e-9
    sides = [modes.roller_sides(r)['face'] for r in ok]
    assert sides.count('left') == sides.count('right')  # the mirror line closes as the drawn
    assert len(ok) <= 8
