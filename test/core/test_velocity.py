"""Velocities from the loop-closure Jacobian (core.velocity), against independent oracles:
central differences of position solves on every shipped scene, the classical four-bar
velocity formulas, and the growth without bound near a toggle."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scenes
from oracles import central_difference_rates

from linkage_ros.core.analysis import fourbar_toggle_angles
from linkage_ros.core.model import AngleActuator
from linkage_ros.core.solver import Solver
from linkage_ros.core.velocity import velocities
from linkage_ros.engine import Engine, EngineSettings

SHIPPED = scenes.SHIPPED


@pytest.mark.parametrize('stem', SHIPPED)
def test_velocities_match_central_differences(stem):
    mech = scenes.load(stem)
    solver = Solver(mech, knowns=list(mech.actuators), branch='reference')
    ref = solver.reference_values()
    rng = np.random.default_rng(3)
    L = mech.length_scale
    checked = 0
    for _ in range(12):
        values = {
            a: ref[a]
            + rng.standard_normal()
            * (0.05 if isinstance(mech.actuators[a], AngleActuator) else 0.01 * L)
            for a in ref
        }
        result = solver.solve(values, commit=False)
        if not result.success or result.margin is not None and result.margin < 0.05:
            continue
        rates = {
            a: float(rng.uniform(-2, 2))
            * (1 if isinstance(mech.actuators[a], AngleActuator) else L)
            for a in ref
        }
        vel = velocities(solver, result, values, rates)
        assert vel.success, vel.reason
        fd_joints, fd_points = central_difference_rates(solver, values, rates, 1e-6)
        scale = max(1.0, max(abs(v) for v in vel.joints.values()))
        for j in mech.joint_names:
            unit = L if j in mech.prismatics else 1.0
            assert abs(vel.joints[j] - fd_joints[j]) <= 1e-6 * scale * unit, (stem, j)
        for p in mech.points:
            for k in (0, 1):
                assert abs(vel.points[p][k] - fd_points[p][k]) <= 1e-6 * scale * L, (stem, p)
        checked += 1
    assert checked >= 3


def test_four_bar_matches_the_classical_formulas():
    """Norton's four-bar velocity equations, written from the textbook, not from the core:
    w3 = a w2 sin(t4 - t2) / (b sin(t3 - t4)), w4 = a w2 sin(t2 - t3) / (c sin(t4 - t3))."""
    mech = scenes.four_bar(0.3, 0.1, 0.25, 0.2)
    a, b, c = 0.1, 0.25, 0.2
    solver = Solver(mech, knowns=['crank'])
    for theta in np.linspace(0.1, 2 * math.pi - 0.1, 25):
        r = solver.solve({'crank': theta})
        assert r.success
        w2 = 1.7
        vel = velocities(solver, r, {'crank': theta}, {'crank': w2})
        t2, t3, t4 = r.links['crank'], r.links['coupler'], r.links['rocker']
        w3 = a * w2 * math.sin(t4 - t2) / (b * math.sin(t3 - t4))
        w4 = a * w2 * math.sin(t2 - t3) / (c * math.sin(t4 - t3))
        assert vel.links['crank'] == pytest.approx(w2, abs=1e-12)
        assert vel.links['coupler'] == pytest.approx(w3, rel=1e-9, abs=1e-12)
        assert vel.links['rocker'] == pytest.approx(w4, rel=1e-9, abs=1e-12)
        # the coupler point B: rocker tip velocity c w4 perpendicular to O4 -> B
        vb = vel.points['B']
        assert vb[0] == pytest.approx(-c * w4 * math.sin(t4), abs=1e-10)
        assert vb[1] == pytest.approx(c * w4 * math.cos(t4), abs=1e-10)


def test_velocity_grows_without_bound_near_a_toggle_and_stays_exact():
    lengths = (0.3, 0.2, 0.15, 0.2)  # non-Grashof: the crank rocks between two toggles
    mech = scenes.four_bar(*lengths)
    toggle = fourbar_toggle_angles(*lengths)[0]
    solver = Solver(mech, knowns=['crank'], branch='reference')
    ref = solver.reference_values()['crank']
    inside = 1.0 if ref > toggle else -1.0
    last_speed, last_cond = 0.0, 0.0
    for delta in (1e-2, 1e-4, 1e-6, 1e-8):
        theta = toggle + inside * delta
        r = solver.solve({'crank': theta}, commit=False)
        assert r.success, r.reason
        vel = velocities(solver, r, {'crank': theta}, {'crank': 1.0})
        assert vel.success
        speed = abs(vel.links['rocker']) + abs(vel.links['coupler'])
        assert speed > last_speed and vel.cond > last_cond
        # like 1 / sqrt(delta): exact against differences far smaller than the distance
        fd, _ = central_difference_rates(solver, {'crank': theta}, {'crank': 1.0}, delta * 1e-3)
        for j in mech.joint_names:
            assert vel.joints[j] == pytest.approx(fd[j], rel=1e-4, abs=1e-9)
        last_speed, last_cond = speed, vel.cond
    assert last_speed > 1e3  # grows without bound: ~ 1 / sqrt(1e-8)
    assert r.margin < 1e-3  # the margin said how near


def test_engine_fills_velocity_and_refuses_non_finite_rates():
    mech = scenes.load('excavator')
    engine = Engine(mech, EngineSettings())
    r = engine.command({'Z1': 1.5, 'Z2': 1.8, 'Z3': 1.3}, {'Z1': 0.1, 'Z2': 0.0, 'Z3': -0.05})
    assert r.success and r.velocity.success
    assert set(r.velocity.joints) == set(mech.joint_names)
    assert r.velocity.joints['Z1'] == pytest.approx(0.1, abs=1e-12)
    assert r.velocity.joints['Z3'] == pytest.approx(-0.05, abs=1e-12)
    before = engine.last
    bad = engine.command({'Z1': 1.6, 'Z2': 1.8, 'Z3': 1.3}, {'Z1': math.nan, 'Z2': 0, 'Z3': 0})
    assert not bad.success and "['Z1']" in bad.reason and 'not finite' in bad.reason
    assert engine.last is before  # nothing changed
    plain = engine.command({'Z1': 1.6, 'Z2': 1.8, 'Z3': 1.3})
    assert plain.success and plain.velocity is None


def test_a_jacobian_singular_to_rounding_has_no_velocity():
    # a parallelogram at its change point (crank along the ground): J is singular to rounding
    # (cond ~1e16), and a finite answer there is on neither branch (the parallelogram's rocker
    # turns at 1 rad/s, the anti-parallelogram's at -3; rounding gave 0 with OK)
    mech = scenes.four_bar(2.0, 1.0, 2.0, 1.0, input=1.0)
    solver = Solver(mech, knowns=['crank'])
    r = solver.solve({'crank': 0.0}, commit=False)
    assert r.success, r.reason
    vel = velocities(solver, r, {'crank': 0.0}, {'crank': 1.0})
    assert not vel.success and 'singular' in vel.reason and vel.cond > 1e10, vel
    # the Grashof double-rocker's crank at the float nearest its toggle (7.6e-18 rad inside):
    # the exact rocker rate there is -2.17e7 rad/s, rounding gave +2.28e15 with OK
    mech = scenes.load('four_bar_grashof_double_rocker')
    solver = Solver(mech, knowns=['crank'])
    theta = 1.508255564998405
    r = solver.solve({'crank': theta}, commit=False)
    assert r.success, r.reason
    vel = velocities(solver, r, {'crank': theta}, {'crank': 1.0})
    assert not vel.success and 'singular' in vel.reason and vel.cond > 1e10, vel


def test_rates_beyond_the_float_range_are_refused_for_what_they_are():
    # a regular configuration (cond ~5 to ~100): an answer beyond the float range is not a
    # toggle, and no answer carries an inf with success
    for stem, command, rates in (
        ('four_bar', {'crank': 1.0}, {'crank': 1.7e308}),
        ('excavator', None, {'Z1': 1e308, 'Z2': 0.0, 'Z3': 0.0}),
    ):
        mech = scenes.load(stem)
        engine = Engine(mech, EngineSettings())
        values = command or dict(engine.forward.reference_values())
        r = engine.command(values, rates)
        assert r.success and not r.velocity.success, (stem, r.velocity)
        assert 'float range' in r.velocity.reason and 'singular' not in r.velocity.reason
        assert r.velocity.cond < 1e3
    # the core function names a rate that is not finite (the engine refuses it before)
    mech = scenes.load('four_bar')
    solver = Solver(mech, knowns=['crank'])
    ref = solver.reference_values()
    r = solver.solve(ref, commit=False)
    for bad in (math.nan, math.inf, -math.inf):
        vel = velocities(solver, r, ref, {'crank': bad})
        assert not vel.success and "['crank']" in vel.reason and 'not finite' in vel.reason


def test_a_rate_for_a_name_the_command_does_not_give_is_refused():
    # (the Python engine: a JointState's velocities come one per name) a rate for a held
    # actuator, or for a name that is nowhere, was dropped silently
    engine = Engine(scenes.load('excavator'), EngineSettings())
    before = engine.last
    for rates in ({'Z1': 0.1, 'Z2': 5.0}, {'Z1': 0.1, 'bogus': 1.0}):
        r = engine.command({'Z1': 1.5}, rates)
        assert not r.success and 'without a value' in r.reason, r.reason
        assert repr(next(n for n in rates if n != 'Z1')) in r.reason
    assert engine.last is before
    ok = engine.command({'Z1': 1.5}, {'Z1': 0.1})
    assert ok.success and ok.velocity.success
    assert ok.velocity.joints['Z2'] == pytest.approx(0.0, abs=1e-12)  # held: rate 0


def test_the_rounding_of_rates_near_a_toggle_is_within_the_documented_cond_squared_bound():
    """core.velocity and TOPICS.md: against the exact mechanism a rate's rounding error is about
    cond^2 * 2e-17 of its size (the pose near a toggle carries its data's rounding amplified by
    cond; the docstring once said cond * 1e-16, which an input 1.4e-15 rad before the toggle
    misses by 8 %, at cond 8e7). Oracle: the rocker angle by circle intersection from the
    scene's double lengths and the double input, differentiated at 60 digits (mpmath). The
    bound asserted is ten times the documented size, for every CPU's last bits."""
    import mpmath as mp

    mech = scenes.load('four_bar_non_grashof')
    g, a, b, c = (0.30, 0.20, 0.25, 0.22)  # config/four_bar_non_grashof.yaml: l1 l2 l3 l4
    solver = Solver(mech, method='closed_form', branch='+')
    assert solver.solve({'crank': 2.0}).links['rocker'] == pytest.approx(
        math.atan2(*_rocker_xy(g, a, b, c, 2.0)[::-1]), abs=1e-12
    )  # the premise: the oracle's branch and lengths are the scene's
    with mp.workdps(60):
        G, A, B, C = (mp.mpf(v) for v in (g, a, b, c))
        toggle = mp.acos((G * G + A * A - (B + C) ** 2) / (2 * G * A))

        def rocker(t):
            pa = A * mp.expj(t)
            d = abs(G - pa)
            x = (B * B - C * C + d * d) / (2 * d)
            u = (G - pa) / d
            return mp.arg(pa + u * (x + 1j * mp.sqrt(B * B - x * x)) - G)

        checked = 0
        for before in (1e-3, 1e-6, 1e-9, 1e-11, 1e-13, 3e-15):
            theta = float(toggle - mp.mpf(before))
            r = solver.solve({'crank': theta}, commit=False)
            vel = velocities(solver, r, {'crank': theta}, {'crank': 1.0})
            if not (r.success and vel.success):
                continue
            exact = float(mp.diff(rocker, mp.mpf(theta)))
            err = abs(vel.links['rocker'] - exact) / abs(exact)
            assert err <= 10 * (vel.cond**2 * 2e-17 + vel.cond * 1e-16), (before, vel.cond, err)
            checked += 1
        assert checked >= 5


def _rocker_xy(g, a, b, c, t):
    """B - O4 of the + branch by circle intersection in floats (the premise check above)."""
    ax, ay = a * math.cos(t), a * math.sin(t)
    dx, dy = g - ax, -ay
    d = math.hypot(dx, dy)
    x = (b * b - c * c + d * d) / (2 * d)
    h = math.sqrt(b * b - x * x)
    ux, uy = dx / d, dy / d
    return ax + ux * x - uy * h - g, ay + uy * x + ux * h


@pytest.mark.parametrize(
    'rates, words',
    [
        ({'crank': 'x'}, "the rate of 'crank' must be a number (got 'x')"),
        ({'crank': None}, "the rate of 'crank' must be a number (got None)"),
        ({'crank': [2.0]}, "the rate of 'crank' must be a number (got [2.0])"),
        ({'crank': 2.0, 'typo': 1.0}, "a rate for ['typo'], which this solve does not take"),
    ],
)
def test_a_rate_that_is_no_number_or_for_no_known_is_refused_naming_it(rates, words):
    """A rate of 'x', None or [2.0] raised float()'s bare ValueError / TypeError; a rate for a
    name the solve does not take was ignored (solve refuses such a value)."""
    mech = scenes.load('four_bar')
    solver = Solver(mech)
    r = solver.solve({'crank': 1.0})
    vel = velocities(solver, r, {'crank': 1.0}, rates)
    assert not vel.success and words in vel.reason, vel.reason
