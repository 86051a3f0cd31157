"""core.execute's two-point step (a body placed from two of its known points) against a 50-digit
oracle, and its one-command twin (core.scalar_plan) against it (float for float where numpy's
sin, cos and arctan2 round as libm's).

The step's rotation (e^{i phi}, phi the angle from the two points' reference direction to
their placed one) must be of unit length to a few ulps and turn the reference direction onto
the placed one to a few ulps, on mechanisms drawn at any scale of the float range (2**-1000 to
2**1000 m: the step scales the points' difference by its larger part, and its products must
neither overflow nor underflow). Where the two points coincide (a row that did not close
upstream) the rotation is e^{i phi} of atan2's angle of the zero vector, finite, and the row
is refused as one command is.
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import oracles
import scenes
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from linkage_ros.core.errors import PlanError, SceneError
from linkage_ros.core.execute import executor
from linkage_ros.core.scalar_plan import program
from linkage_ros.core.solver import Solver
from linkage_ros.core.steps import StepKind

#: |rot| - 1 and the rotation's miss of the placed direction, in units of the double epsilon
#: (the scaled point pairs each a half-ulp off, their dot and cross products a rounding
#: more, atan2, cos and sin one each; measured: 0.34 and 1.3)
ULPS = 4


def _cplx(z, i):
    return complex(float(z.re[i]), float(z.im[i]))


def _two_point_links(plan):
    """(first point, second point, link) of each two-point step that places a one-link body."""
    return [
        (s.args.first, s.args.second, plan.bodies[s.body].links[0])
        for s in plan.steps
        if s.op is StepKind.TWO_POINTS and len(plan.bodies[s.body].links) == 1
    ]


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    crank=st.floats(0.1, 0.4),
    coupler=st.floats(0.9, 1.3),
    rocker=st.floats(0.9, 1.3),
    exponent=st.integers(-1000, 1000),
    angles=st.lists(st.floats(-math.pi, math.pi), min_size=1, max_size=6),
)
def test_two_point_rotation_is_the_unit_placed_direction(crank, coupler, rocker, exponent, angles):
    scale = 2.0**exponent  # exact: the same geometry at every scale
    try:
        mech = scenes.four_bar(scale, crank * scale, coupler * scale, rocker * scale)
        solver = Solver(mech, method='closed_form', branch='reference')
    except (SceneError, PlanError):
        assume(False)
    plan = solver.compiled.full_plan
    links = _two_point_links(plan)
    assert links  # the coupler and the rocker
    n = len(angles)
    run = executor(plan).run([np.array(angles)], n, plan.reference_signs)
    for i in range(n):
        assert bool(np.asarray(run.ok)[i])  # a Grashof crank-rocker closes everywhere
        one = program(plan).run([angles[i]], plan.reference_signs)
        for first, second, link in links:
            rot = _cplx(run.poses.rot[link], i)
            # the twin: the same floats where numpy's trigonometry rounds as libm's here
            phi = float(run.poses.phi[link][i])
            twin = one.poses.rot[link]
            assert twin == rot or not oracles.trig_is_libm(np.array([phi])), link
            assert abs(twin - rot) <= 2 * oracles.EPS, link
            p, q = _cplx(run.points[first], i), _cplx(run.points[second], i)
            ref = mech.points[second] - mech.points[first]
            with mp.workdps(oracles.DPS):
                d = mp.mpc(q.real, q.imag) - mp.mpc(p.real, p.imag)  # exact: floats as given
                r = mp.mpc(float(ref[0]), float(ref[1]))
                want = (d / abs(d)) * mp.conj(r / abs(r))
                got = mp.mpc(rot.real, rot.imag)
                length_miss = float(abs(abs(got) - 1))
                direction_miss = float(abs(got - want))
            assert length_miss <= ULPS * oracles.EPS, (link, length_miss / oracles.EPS)
            assert direction_miss <= ULPS * oracles.EPS, (link, direction_miss / oracles.EPS)


def test_coincident_points_keep_a_unit_rotation_and_the_refusal():
    """The plagiograph with its point B commanded onto the ground pivot O2: the RRR dyad for A
    does not close, and the two-point steps after it see their two points coincide (the
    row's finite placeholders). Each such link's rotation is e^{i phi}, phi = atan2 of the
    zero vector (0 or +-pi), exactly; the batch refuses the row as one command is refused,
    and the rows around it (the reference command, a NaN and an infinite one) as one command
    each."""
    mech = scenes.load('plagiograph')
    solver = Solver(mech, knowns=['point:B'], method='closed_form', branch='reference')
    plan = solver.compiled.full_plan
    commands = np.array(
        [mech.points['O2'], mech.points['B'], [math.nan, 0.0], [math.inf, 0.1]], dtype=float
    )
    run = executor(plan).run([commands], len(commands), plan.reference_signs)
    coincident = 0
    for first, second, link in _two_point_links(plan):
        if _cplx(run.points[first], 0) != _cplx(run.points[second], 0):
            continue
        coincident += 1
        phi = float(run.poses.phi[link][0])
        assert phi in (0.0, math.pi, -math.pi)
        assert _cplx(run.poses.rot[link], 0) == complex(math.cos(phi), math.sin(phi))
    assert coincident  # the case under test is reached
    got = solver.solve_batch({'point:B': commands})
    assert got.ok.tolist() == [False, True, False, False]
    for i, command in enumerate(commands[:2]):
        one = solver.solve({'point:B': tuple(command)}, commit=False)
        assert bool(got.ok[i]) == one.success, i
        assert got.reason[i] == (None if one.success else one.reason), i
    # (the non-finite rows are refused before any step runs, in words of the batch's own)
    assert all('finite' in got.reason[i] for i in (2, 3))
