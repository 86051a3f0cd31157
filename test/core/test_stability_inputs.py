"""Numerical stability at the extremes of the inputs: link-length scale 1e-6 .. 1e6, extreme
link ratios, huge and subnormal input angles, and no NaN / inf ever leaving a solver.

Oracles: ``oracles`` (50-digit mpmath, float inputs taken exactly).
"""

import math

import numpy as np
import oracles as orc
import pytest
from scenes import four_bar, slider_crank
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

from linkage_ros.core.solver import Solver

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
    """Scenes with lengths ~1e-300 .. 1e300: if they load, every solve is right (the same
    angles as at unit scale, residual <= 1e-12; each input is inside the mechanism's range),
    never NaN/inf."""
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
    compared = 0
    for t in (1.0, 2.5, -2.0, 1e-310):  # (huge angles: test_subnormal_and_huge_angles)
        r = s.solve({'crank': t})
        assert_finite(r)
        if not r.success:
            continue
        compared += 1
        ru = su.solve({'crank': t})
        assert r.residual <= TIGHT, (t, r.residual)
        for link in ru.links:
            assert abs(math.remainder(r.links[link] - ru.links[link], 2 * math.pi)) <= 1e-9, (
                t,
                link,
                r.links[link],
                ru.links[link],
            )
    # a scene that loads is solved at these scales, not refused at every input (each of these
    # inputs is inside the unit-scale mechanism's range)
    assert compared == 4, compared


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
