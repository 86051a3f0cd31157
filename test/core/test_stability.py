"""Numerical stability at the extremes: toggles, theta = pi, change points, link-length scale
1e-6 .. 1e6, huge and subnormal inputs, Newton's failure modes, and no NaN/inf ever.

Oracles: ``oracles`` (50-digit mpmath, float inputs taken exactly). The toggle angles are exact
(cosine rule at 50 digits), so the distance of a float input from its toggle is known exactly.
"""

import math

import mpmath as mp
import numpy as np
import oracles as orc
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from scenes import four_bar, slider_crank

from linkage_ros.core.solver import Solver, branch_undefined_below

EPS = 2.0**-52
TIGHT = 1e-12
AGREE = 1e-9

DOUBLE_ROCKER = (4.0, 3.0, 1.5, 4.5)  # Grashof, shortest is the coupler: input in two arcs
TRIPLE_ROCKER = (4.0, 3.0, 5.0, 2.5)  # non-Grashof, input range symmetric about pi
CRANK_ROCKER = (4.0, 1.5, 4.5, 3.0)
METHODS = ['closed_form', 'newton']
DISTANCES = [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3]


def assert_finite(result):
    """Every float anywhere in Result.to_dict() is finite (None is allowed)."""
    bad = []

    def walk(obj, path):
        if isinstance(obj, dict):
            for k, v in obj.items():
                walk(v, f'{path}.{k}')
        elif isinstance(obj, (list, tuple)):
            for i, v in enumerate(obj):
                walk(v, f'{path}[{i}]')
        elif (isinstance(obj, float) and not math.isfinite(obj)) or (
            isinstance(obj, (np.floating, np.ndarray)) and not np.all(np.isfinite(obj))
        ):
            bad.append(path)

    walk(result.to_dict(), '')
    assert not bad, (bad, result)
    if not result.success:
        assert isinstance(result.reason, str) and result.reason.strip()


def angle_errors(res, want):
    return max(
        orc.angle_error(res.links['coupler'], want['theta3']),
        orc.angle_error(res.links['rocker'], want['theta4']),
    )


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


# =============================================================================================
# scale invariance: all lengths times k, k = 1e-6 .. 1e6
# =============================================================================================

SCALE_FACTORS = [10.0**e for e in range(-6, 7)]
SCALE_MECHS = {
    'crank_rocker': lambda k: four_bar(
        tuple(k * v for v in CRANK_ROCKER), coupler_point={'distance': 2.0 * k, 'angle': 0.4}
    ),
    'triple_rocker': lambda k: four_bar(tuple(k * v for v in TRIPLE_ROCKER)),
    'slider_crank': lambda k: slider_crank(1.0 * k, 3.0 * k, 0.5 * k, 0.3),
}
SCALE_INPUTS = {
    'crank_rocker': list(np.linspace(-3.1, 3.1, 12)),
    'triple_rocker': list(np.linspace(1.0, 5.2, 12)),
    'slider_crank': list(np.linspace(-3.1, 3.1, 12)),
}


def _run_scaled(name, k, method):
    mech = SCALE_MECHS[name](k)
    s = Solver(mech, method=method)
    out = []
    for t in SCALE_INPUTS[name]:
        r = s.solve({'crank': float(t)})
        assert_finite(r)
        assert r.success, (name, k, t, r.reason)
        assert r.residual <= TIGHT, (name, k, t, r.residual)
        out.append(r)
    return mech, out


@pytest.mark.parametrize('name', sorted(SCALE_MECHS))
@pytest.mark.parametrize('method', METHODS)
def test_scaling_all_lengths_changes_no_angle(name, method):
    """Same angles (links and joints) to 1e-12 and same points / k to 1e-12 of the scale, and
    residual <= 1e-12, for k = 1e-6 .. 1e6."""
    _, ref = _run_scaled(name, 1.0, method)
    for k in SCALE_FACTORS:
        mech, got = _run_scaled(name, k, method)
        for a, b in zip(ref, got):
            assert a.branch == b.branch
            for link in a.links:
                assert abs(math.remainder(a.links[link] - b.links[link], 2 * math.pi)) <= TIGHT, (
                    k,
                    link,
                )
            for j in a.joints:
                if j == 'slider':
                    assert abs(a.joints[j] - b.joints[j] / k) <= TIGHT * 3.5, (k, j)
                else:
                    assert abs(math.remainder(a.joints[j] - b.joints[j], 2 * math.pi)) <= TIGHT
            for p in a.points:
                assert (
                    math.hypot(
                        a.points[p][0] - b.points[p][0] / k, a.points[p][1] - b.points[p][1] / k
                    )
                    <= TIGHT * 5
                ), (k, p)


@pytest.mark.parametrize('method', METHODS)
def test_extreme_link_ratios_against_mpmath(method):
    """Links differing by 1e6 within one mechanism: a 1e-6 crank on a unit four-bar, a 1e6
    crank and coupler on a unit ground, a 1e-6 crank on a unit slider-crank. The answer is as
    good as the data allow: a link of length l read from points known to rho * L (L the length
    scale, rho = eps for the closed form, the residual tolerance for Newton) has its angle known
    to ~rho * L / l."""
    cases = [
        ((1.0, 1e-6, 1.0, 1.0), list(np.linspace(-3, 3, 9))),
        ((1.0, 1e6, 1e6, 2.0), list(np.linspace(-3, 3, 9))),
        ((1e6, 1.0, 1e6, 1e6 - 0.5), list(np.linspace(-3, 3, 9))),
    ]
    for L, inputs in cases:
        mech = four_bar(L)
        s = Solver(mech, method=method)
        rho = 32 * EPS if method == 'closed_form' else 8 * 1e-12
        for t in inputs:
            r = s.solve({'crank': float(t)})
            assert_finite(r)
            assert r.success and r.residual <= TIGHT, (L, t, r.reason, r.residual)
            want = orc.fourbar(*L, float(t), 1 if r.branch == '+' else -1)
            scale = mech.length_scale
            assert (
                orc.angle_error(r.links['coupler'], want['theta3']) <= 1e-13 + rho * scale / L[2]
            ), (L, t)
            assert (
                orc.angle_error(r.links['rocker'], want['theta4']) <= 1e-13 + rho * scale / L[3]
            ), (L, t)
    mech = slider_crank(1e-6, 1.0, 0.0)
    s = Solver(mech, method=method)
    for t in np.linspace(-3, 3, 9):
        r = s.solve({'crank': float(t)})
        assert r.success and r.residual <= TIGHT
        want = orc.slider_crank(1e-6, 1.0, 0.0, 0.0, float(t), 1)
        assert abs(r.joints['slider'] - float(want['x'])) <= 1e-12
        assert orc.angle_error(r.links['rod'], want['theta3']) <= 1e-12


# =============================================================================================
# huge, tiny and subnormal inputs
# =============================================================================================

BIG_ANGLES = [1e6, -1e6, 1e6 + math.pi, -1e6 - math.pi, 123456.789]


@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('t', BIG_ANGLES)
def test_large_input_angles_reduce_exactly(method, t):
    """An input of 1e6 rad means the float 1e6 itself: the answer equals the one at its exact
    reduction (mpmath cos/sin of the float) to 1e-12, and the loop closes to 1e-12."""
    mech = four_bar(CRANK_ROCKER)
    reduced = orc.reduce_angle(t)
    r = Solver(mech, method=method).solve({'crank': t})
    assert_finite(r)
    assert r.success, r.reason
    want = orc.fourbar(*CRANK_ROCKER, t, 1 if r.branch == '+' else -1)
    assert orc.angle_error(r.links['crank'], reduced) <= 1e-15
    assert orc.angle_error(r.joints['O2'], reduced) <= 1e-15
    assert angle_errors(r, want) <= TIGHT
    r2 = Solver(mech, method=method).solve({'crank': float(reduced)})
    assert r2.success and r2.branch == r.branch
    assert (
        max(
            math.hypot(r.points[p][0] - r2.points[p][0], r.points[p][1] - r2.points[p][1])
            for p in r.points
        )
        <= TIGHT * mech.length_scale
    )
    assert r.residual <= TIGHT, r.residual


@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('t', [1e-310, -5e-324, 1e300, -1e300, 1e22, 1.7976931348623157e308])
def test_subnormal_and_huge_angles(method, t):
    """Never NaN/inf: either the right answer (the exact reduction of the float) or a refusal
    with a reason."""
    mech = four_bar(CRANK_ROCKER)
    r = Solver(mech, method=method).solve({'crank': t})
    assert_finite(r)
    if r.success:
        want = orc.fourbar(*CRANK_ROCKER, t, 1 if r.branch == '+' else -1)
        assert angle_errors(r, want) <= TIGHT
        assert r.residual <= TIGHT, r.residual


@pytest.mark.parametrize('method', METHODS)
def test_consecutive_extreme_angles_never_raise(method):
    """-1e300 then 1.8e308: the continuity prediction (closed form) and the continuation
    (Newton) work with the difference of successive inputs, which overflows to inf; solve must
    still answer with a Result, never raise."""
    s = Solver(four_bar(CRANK_ROCKER), method=method)
    for t in (-1e300, 1.7976931348623157e308, -1.7976931348623157e308, 1.0):
        r = s.solve({'crank': t})
        assert_finite(r)


EXTREME_SCALES = [1e-300, 1e-200, 1e-150, 1e150, 1e200, 1e300]


@pytest.mark.parametrize('k', EXTREME_SCALES)
@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('form', ['four_bar', 'slider_crank'])
def test_extreme_length_scales(k, method, form):
    """Scenes with lengths ~1e-300 .. 1e300: if they load, every solve is either right (same
    angles as at unit scale, residual <= 1e-12) or refused with a reason; never NaN/inf."""
    from linkage_ros.core.errors import SceneError

    try:
        if form == 'four_bar':
            mech = four_bar(tuple(k * v for v in CRANK_ROCKER))
            unit = four_bar(CRANK_ROCKER)
        else:
            mech = slider_crank(k, 3 * k, 0.5 * k)
            unit = slider_crank(1.0, 3.0, 0.5)
    except SceneError as exc:  # refusing to load is allowed; it must say why
        assert str(exc)
        return
    s, su = Solver(mech, method=method), Solver(unit, method='closed_form')
    for t in (1.0, 2.5, -2.0, 1e-310):  # (huge angles: test_subnormal_and_huge_angles)
        r = s.solve({'crank': t})
        assert_finite(r)
        if not r.success:
            continue
        ru = su.solve({'crank': t})
        assert r.residual <= TIGHT, (t, r.residual)
        for link in ru.links:
            assert abs(math.remainder(r.links[link] - ru.links[link], 2 * math.pi)) <= 1e-9, (
                t,
                link,
                r.links[link],
                ru.links[link],
            )


# =============================================================================================
# Newton: converges or says why; never silently another branch
# =============================================================================================

LINKAGES = {
    'crank_rocker': CRANK_ROCKER,
    'triple_rocker': TRIPLE_ROCKER,
    'double_rocker': DOUBLE_ROCKER,
}
_MECHS = {n: four_bar(L) for n, L in LINKAGES.items()}
_SC = slider_crank(1.0, 3.0, 0.5, 0.3)

angles = st.one_of(
    st.floats(-7.0, 7.0, allow_nan=False),
    st.sampled_from(
        [
            0.0,
            math.pi,
            -math.pi,
            0.6741305066673152,
            -0.6741305066673152,
            2.046915387706693,
            0.8410686705679302,
        ]
    ),
)


def _agree_tol(a, b):
    """Closed form vs Newton agreement (fraction of the scale) allowing for the square-root law
    near a toggle (margin ~ sqrt(distance)): AGREE away from it."""
    rho = max(EPS, a.residual or 0.0, b.residual or 0.0)
    m = min(a.margin or 0.0, b.margin or 0.0)
    return AGREE + 8 * rho / math.sqrt(m * m + rho)


@settings(
    max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(name=st.sampled_from(sorted(LINKAGES)), seq=st.lists(angles, min_size=1, max_size=6))
@example(name='crank_rocker', seq=[-0.673828125, 3.142578125])
@example(name='triple_rocker', seq=[4.0, -0.6741305066673152])
def test_newton_reference_branch_never_switches(name, seq):
    """Newton with branch 'reference' either fails with a reason, or returns the closed form's
    branch (same sign string) and the same points; it never reports success on another branch.
    Inputs are random, unreachable ones included, fed in order to one solver."""
    mech = _MECHS[name]
    nw = Solver(mech, method='newton', branch='reference')
    cf = Solver(mech, method='closed_form', branch='reference')
    for t in seq:
        r = nw.solve({'crank': t})
        c = cf.solve({'crank': t})
        assert_finite(r)
        assert_finite(c)
        if not r.success:
            assert 'Newton' in r.reason or 'assemble' in r.reason or 'reach' in r.reason, r.reason
            continue
        assert r.residual <= TIGHT
        assert c.success, (t, c.reason)
        assert r.branch == c.branch, (t, r.branch, c.branch)
        gap = (
            max(
                math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                for p in r.points
            )
            / mech.length_scale
        )
        assert gap <= _agree_tol(r, c), (t, gap)


@settings(
    max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    name=st.sampled_from(sorted(LINKAGES) + ['slider_crank']),
    seq=st.lists(angles, min_size=1, max_size=8),
)
@example(name='double_rocker', seq=[0.8410686705679302])
@example(name='triple_rocker', seq=[1.0, 0.0, 3.0, -0.6741305066673152])
def test_newton_continuous_converges_or_says_why(name, seq):
    """Newton with branch 'continuous' on random input sequences: every answer is a genuine
    configuration on the branch it names (the closed form with that explicit branch gives the
    same points), with residual <= 1e-12; every failure has a reason; the closed form agrees on
    reachability (Newton never assembles what the closed form finds unreachable)."""
    mech = _SC if name == 'slider_crank' else _MECHS[name]
    nw = Solver(mech, method='newton')
    for t in seq:
        r = nw.solve({'crank': t})
        assert_finite(r)
        if not r.success:
            assert r.reason
            continue
        assert r.residual <= TIGHT, (t, r.residual)
        c = Solver(mech, method='closed_form', branch=r.branch).solve({'crank': t})
        assert c.success, (t, c.reason)
        gap = (
            max(
                math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                for p in r.points
            )
            / mech.length_scale
        )
        assert gap <= _agree_tol(r, c), (t, gap, r.margin)


# =============================================================================================
# NaN / inf never leave a solver
# =============================================================================================

WILD = [
    0.0,
    1.0,
    -1.0,
    math.pi,
    1e-310,
    5e-324,
    1e300,
    -1e300,
    1.7976931348623157e308,
    float('nan'),
    float('inf'),
    -float('inf'),
    0.6741305066673152,
    2.046915387706693,
]


@pytest.mark.parametrize('method', METHODS)
def test_no_nan_or_inf_leaves_a_solver(method):
    """Every float of every Result.to_dict() is finite (or None), for wild inputs on several
    mechanisms, forward and inverse; and solve_batch arrays are finite too."""
    mechs = [
        four_bar(CRANK_ROCKER),
        four_bar(TRIPLE_ROCKER),
        four_bar(DOUBLE_ROCKER),
        four_bar((1.0, 1.0, 1.0, 1.0)),
        slider_crank(1.0, 3.0, 0.5, 0.3),
    ]
    for i, mech in enumerate(mechs):
        s = Solver(mech, method=method)
        for t in WILD:
            assert_finite(s.solve({'crank': t}))
        if method == 'newton' and i in (1, 2, 3):
            continue  # a refused Newton solve bisects its whole path (0.1-0.4 s): keep it short
        if method == 'newton' and i == 4:
            continue
        knowns = ['rocker'] if 'rocker' in mech.links else ['slider']
        si = Solver(mech, knowns=knowns, method=method)
        for v in WILD:
            assert_finite(si.solve({knowns[0]: v}))
        b = s.solve_batch({'crank': np.array(WILD)})
        for arr in (
            [b.residual, b.margin]
            + list(b.links.values())
            + list(b.joints.values())
            + list(b.points.values())
        ):
            assert np.all(np.isfinite(arr))
        assert not np.any(b.ok[np.isnan(WILD) | np.isinf(WILD)])


def test_an_exact_toggle_lands_on_the_toggle_in_any_drawing():
    """Ground 4, crank 1, coupler 3, rocker 2: at crank = ground angle + pi the coupler and
    rocker are collinear (|O4 A| = 5 = 3 + 2), an external toggle. Whichever way the drawing is
    turned, the given lengths are used exactly (not re-read from rounded coordinates) and a
    hair either side of the tangency lands on it: both assembly modes are one configuration,
    B on the line A-O4, margin 0 and branch undefined. (With lengths re-derived from the
    drawing, four of these ten drawings put B 5e-8 of the link off the line.)"""
    for g in np.linspace(0.0, 2 * math.pi, 10, endpoint=False):
        mech = four_bar((4.0, 1.0, 3.0, 2.0), ground_angle=float(g))
        for branch in ('+', '-'):
            r = Solver(mech, method='closed_form', branch=branch).solve(
                {'crank': float(g) + math.pi}
            )
            assert r.success, r.reason
            a, b = np.array(r.points['A']), np.array(r.points['B'])
            o4 = np.array(mech.points['O4'])
            u = (o4 - a) / np.hypot(*(o4 - a))
            off_line = abs(u[0] * (b - a)[1] - u[1] * (b - a)[0])
            assert off_line <= 8 * EPS * 5.0, (g, branch, off_line)
            assert r.margin == 0.0 and r.branch_defined is False, (g, branch, r.margin)
