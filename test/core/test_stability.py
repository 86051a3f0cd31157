"""Numerical stability near singular positions: toggles, theta = pi and change points
(s + l = p + q). Scale, huge / subnormal inputs and NaN / inf: test_stability_inputs.py; Newton's
failure modes: test_stability_newton.py.

Oracles: ``oracles`` (50-digit mpmath, float inputs taken exactly). The toggle angles are exact
(cosine rule at 50 digits), so the distance of a float input from its toggle is known exactly.
"""

import math

import mpmath as mp
import numpy as np
import oracles as orc
import pytest
from scenes import four_bar
from stability_helpers import (
    CRANK_ROCKER,
    DOUBLE_ROCKER,
    EPS,
    METHODS,
    TIGHT,
    TRIPLE_ROCKER,
    angle_errors,
    assert_finite,
)

from linkage_ros.core.solver import Solver, branch_undefined_below

DISTANCES = [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3]


def newton_near(mech, t_start, branch_sign):
    """A Newton solver (branch 'continuous') whose previous configuration is the closed-form one
    at t_start on the given branch: how Newton is used near a toggle (driven in order)."""
    cf = Solver(mech, method='closed_form', branch='+' if branch_sign > 0 else '-')
    start = cf.solve({'crank': t_start})
    assert start.success, start.reason
    nw = Solver(mech, method='newton')
    assert nw.adopt(start)
    return nw


# =============================================================================================
# toggles
# =============================================================================================


def _toggle_cases():
    """(linkage, exact toggle angle, direction into the reachable range) for every toggle."""
    out = []
    for name, L in (('double_rocker', DOUBLE_ROCKER), ('triple_rocker', TRIPLE_ROCKER)):
        for tau, kind in orc.fourbar_toggles(*L):
            for side in (1, -1):
                probe = orc.fourbar(*L, float(tau + side * mp.mpf('1e-3')), 1)
                if probe['ok']:
                    out.append(pytest.param(L, tau, side, id=f'{name}-{kind}-{float(tau):+.3f}'))
    return out


TOGGLES = _toggle_cases()


def test_every_toggle_was_found():
    """2 toggles each side of zero for the double rocker, 2 for the triple rocker."""
    assert len(TOGGLES) == 6


@pytest.mark.parametrize('L, tau, side', TOGGLES)
@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('branch', [1, -1])
def test_near_toggle_closes_and_follows_the_sqrt_law(L, tau, side, method, branch):
    """At and within 1e-15 .. 1e-3 rad of a toggle: residual <= 1e-12 of the scale, angles within
    the square-root law of the 50-digit answer.

    Why a square-root law: at distance delta (rad of input) from the toggle the RRR dyad's height
    is h ~ sqrt(delta), so an error rho in the data (eps ~ 2.2e-16 for the closed form; the
    converged residual for Newton, whose tolerance is on the residual) moves the solution by
    ~ rho / sqrt(delta), and by at most ~ sqrt(rho) at the toggle itself:
    err <= C rho / sqrt(delta + rho) (oracles.sqrt_law_bound, C = 8). Away from the toggle
    (delta = 1e-3) that is ~5e-14 for the closed form; at the toggle ~1e-7.
    """
    mech = four_bar(L)
    for delta in DISTANCES:
        with mp.workdps(50):
            t = float(tau + side * mp.mpf(delta))
            dist = float(abs(mp.mpf(t) - tau))  # the float's exact distance
        if method == 'closed_form':
            s = Solver(mech, method='closed_form', branch='+' if branch > 0 else '-')
        else:
            s = newton_near(mech, float(tau + side * mp.mpf('0.05')), branch)
        r = s.solve({'crank': t})
        assert_finite(r)
        assert r.success, (delta, r.reason)
        assert r.residual <= TIGHT, (delta, r.residual)
        want = orc.fourbar(*L, t, branch)
        if not want['ok']:
            # the float lies (by < 1 ulp) just past the toggle and the tangency clamp assembles
            # it: the right answer is the exact toggle configuration (dist accounts for the ulp)
            assert float(want['miss']) <= 1e-15 * mech.length_scale
            want = orc.fourbar(*L, tau, branch)
        rho = EPS if method == 'closed_form' else max(EPS, r.residual)
        err = angle_errors(r, want)
        assert err <= orc.sqrt_law_bound(dist, rho), (delta, dist, err)
        if delta >= 1e-3:
            assert err <= (1e-12 if method == 'closed_form' else 1e-9)


@pytest.mark.parametrize('L, tau, side', TOGGLES)
@pytest.mark.parametrize('method', METHODS)
def test_beyond_toggle_is_refused(L, tau, side, method):
    """1e-9 rad beyond the toggle (outside the range): refused with a reason; the tangency clamp
    (1e-12 of the scale) is far smaller than the 1e-9 rad miss."""
    mech = four_bar(L)
    with mp.workdps(50):
        t = float(tau - side * mp.mpf('1e-9'))
    assert not orc.fourbar(*L, t, 1)['ok']
    for branch in (1, -1):
        if method == 'closed_form':
            s = Solver(mech, method='closed_form', branch='+' if branch > 0 else '-')
        else:
            s = newton_near(mech, float(tau + side * mp.mpf('0.05')), branch)
        r = s.solve({'crank': t})
        assert_finite(r)
        assert not r.success
        assert r.reason


@pytest.mark.parametrize('L, tau, side', TOGGLES)
@pytest.mark.parametrize('method', METHODS)
def test_exactly_at_toggle_branch_is_undefined(L, tau, side, method):
    """The float nearest the exact toggle assembles and says its branch identity is undefined
    (the two assembly modes coincide there)."""
    mech = four_bar(L)
    t = float(tau)
    for branch in (1, -1):
        if method == 'closed_form':
            s = Solver(mech, method='closed_form', branch='+' if branch > 0 else '-')
        else:
            s = newton_near(mech, float(tau + side * mp.mpf('0.05')), branch)
        r = s.solve({'crank': t})
        assert_finite(r)
        assert r.success, r.reason
        assert r.branch_defined is False, (r.margin, r.residual)


@pytest.mark.parametrize('L, tau, side', TOGGLES)
@pytest.mark.parametrize('method', METHODS)
def test_near_toggle_branch_is_defined(L, tau, side, method):
    """1e-9 rad inside the toggle the two modes are apart by a dyad height ~sqrt(2e-9) of the
    link (the 50-digit oracle's transmission angle says so): the branch identity is defined, and
    the undefined-branch bound stays far below that margin (it must not swallow real modes)."""
    mech = four_bar(L)
    with mp.workdps(50):
        t = float(tau + side * mp.mpf('1e-9'))
    for branch in (1, -1):
        want = orc.fourbar(*L, t, branch)
        assert want['ok']
        if method == 'closed_form':
            s = Solver(mech, method='closed_form', branch='+' if branch > 0 else '-')
        else:
            s = newton_near(mech, float(tau + side * mp.mpf('0.05')), branch)
        r = s.solve({'crank': t})
        assert r.success, r.reason
        assert r.branch_defined is True, (r.margin, r.residual)
        assert branch_undefined_below(r.residual) < 0.1 * r.margin


def test_undefined_branch_bound_is_an_error_bound():
    """The bound is the square-root law of a relative perturbation (input and dyad rounding,
    32 eps, plus the closure residual), independent of any machine constant: it grows like
    sqrt(residual) and is ~5e-7 for an exact answer."""
    assert math.isclose(branch_undefined_below(0.0), 4 * math.sqrt(64 * EPS))
    assert math.isclose(branch_undefined_below(1e-12), 4 * math.sqrt(2 * (1e-12 + 32 * EPS)))
    arr = branch_undefined_below(np.array([0.0, 1e-14, 1e-10]))
    assert arr.shape == (3,) and np.all(np.diff(arr) > 0)


# =============================================================================================
# theta = pi
# =============================================================================================


def _pi_cases():
    """Crank angles that put theta2, theta3 or theta4 at pi (exactly, up to the float)."""
    cases = [(TRIPLE_ROCKER, math.pi, 'theta2'), (CRANK_ROCKER, math.pi, 'theta2')]
    # theta4 = pi: B = O4 - (l4, 0); A from circles about O2 (l2) and B (l3)
    L = (3.0, 2.0, 2.5, 1.0)
    b = (L[0] - L[3], 0.0)
    for s in (1, -1):
        a = orc.circle_circle((0, 0), L[1], b, L[2], s).point
        cases.append((L, float(orc.direction((0, 0), a)), 'theta4'))
    # theta3 = pi: B = A - (l3, 0) on the rocker circle, so A is on the circle about
    # O4 + (l3, 0) of radius l4
    L = (2.0, 2.0, 1.0, 2.0)
    for s in (1, -1):
        a = orc.circle_circle((0, 0), L[1], (L[0] + L[2], 0.0), L[3], s).point
        cases.append((L, float(orc.direction((0, 0), a)), 'theta3'))
    return cases


@pytest.mark.parametrize('method', METHODS)
def test_theta_pi_to_1e12(method):
    """theta2, theta3 or theta4 at pi (where the tan-half-angle form divides by zero): angles
    within 1e-12 of the 50-digit answer, residual <= 1e-12; both branches."""
    n_hit = 0
    for L, t, which in _pi_cases():
        mech = four_bar(L)
        for branch in (1, -1):
            want = orc.fourbar(*L, t, branch)
            assert want['ok']
            if method == 'closed_form':
                s = Solver(mech, method=method, branch='+' if branch > 0 else '-')
            else:  # Newton driven in order: from a configuration 0.01 rad away
                near = next(t + d for d in (0.01, -0.01) if orc.fourbar(*L, t + d, branch)['ok'])
                s = newton_near(mech, near, branch)
            r = s.solve({'crank': t})
            assert_finite(r)
            assert r.success, (L, t, r.reason)
            assert r.residual <= TIGHT
            assert angle_errors(r, want) <= TIGHT, (L, t, which, branch, angle_errors(r, want))
            if which == 'theta2' or orc.angle_error(want[which], mp.pi) <= 1e-15:
                n_hit += 1
    assert n_hit >= 6


# =============================================================================================
# change points (s + l = p + q)
# =============================================================================================

CHANGE_POINT = [
    pytest.param((1.0, 1.0, 1.0, 1.0), 1.0, id='rhombus'),
    pytest.param((1.0, 1.0, 1.0, 1.0), 1e-3, id='rhombus*1e-3'),
    pytest.param((1.0, 1.0, 1.0, 1.0), 1e3, id='rhombus*1e3'),
    pytest.param((2.0, 1.0, 2.0, 1.0), 1.0, id='parallelogram'),
    pytest.param((1.0, 2.0, 1.0, 2.0), 1.0, id='parallelogram_long_crank'),
    pytest.param((2.0, 1.0, 1.0, 2.0), 1.0, id='deltoid'),
]

STEP_CONSTANT = 6.0


def _sweep_inputs():
    """-3.3 .. 3.3 rad in steps of ~0.02 rad, with the change points -pi, 0 and pi exactly
    (the grid's own 4.4e-16 next to 0.0 is kept: two inputs in a row at the singular point)."""
    base = list(np.linspace(-3.3, 3.3, 331))
    return sorted(set(float(v) for v in base) | {-math.pi, 0.0, math.pi})


@pytest.mark.parametrize('L, k', CHANGE_POINT)
@pytest.mark.parametrize('method', METHODS)
def test_change_point_sweep_never_jumps(L, k, method):
    """Sweeping the crank through the change points with branch 'continuous': every input
    assembles; successive configurations move by O(step) (max point displacement per step <=
    6 * step * scale); at the change points the result says the branch is undefined
    (branch_defined False, or a margin at the noise level of the answer). A flagged
    configuration may be arbitrary (a rhombus with A on O4 leaves B anywhere on its circle), so
    across it the neighbours on both sides are compared."""
    mech = four_bar(tuple(k * v for v in L))
    scale = mech.length_scale
    s = Solver(mech, method=method)
    ts = _sweep_inputs()
    results = []
    for t in ts:
        r = s.solve({'crank': t})
        assert_finite(r)
        assert r.success, (t, r.reason)
        assert r.residual <= TIGHT, (t, r.residual)
        results.append(r)

    def gap(a, b):
        return max(
            math.hypot(a.points[p][0] - b.points[p][0], a.points[p][1] - b.points[p][1])
            for p in a.points
        )

    for i in range(1, len(ts)):
        a, b = results[i - 1], results[i]
        if not (a.branch_defined and b.branch_defined):
            continue
        step = ts[i] - ts[i - 1]
        assert gap(a, b) <= STEP_CONSTANT * step * scale, (ts[i - 1], ts[i], gap(a, b))
    for i in range(1, len(ts) - 1):
        if not results[i].branch_defined:
            step = ts[i + 1] - ts[i - 1]
            assert gap(results[i - 1], results[i + 1]) <= STEP_CONSTANT * step * scale
    for cp in (-math.pi, 0.0, math.pi):
        # at the change point the dyad margin is at the noise level of the answer: ~sqrt(eps)
        # for the closed form, ~sqrt(residual) for Newton (square-root law, oracles.sqrt_law_bound)
        r = results[ts.index(cp)]
        noise = 8 * math.sqrt(max(r.residual, EPS))
        assert (not r.branch_defined) or r.margin <= noise, (cp, r.margin, r.residual)
