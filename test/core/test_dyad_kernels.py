"""The dyad kernels (core.dyads) against 50-digit mpmath: circle-circle, circle-line and
line-through-point at scales 1e-6 .. 1e6, near and beyond tangency, degenerate inputs, and the
one-command backend against the batch backend."""

import cmath
import math

import mpmath as mp
import numpy as np
import oracles as orc
import pytest

from linkage_ros.core import dyads
from linkage_ros.core.ops import SCALAR

EPS = 2.0**-52


# =============================================================================================
# dyad primitives against mpmath
# =============================================================================================

SCALES = [1e-6, 1e-3, 1.0, 1e3, 1e6]


def _rrr_cases(rng, scale, n=40):
    """Random circle pairs that intersect with a margin well away from tangency."""
    out = []
    while len(out) < n:
        c1 = rng.uniform(-2, 2, 2) * scale
        ang = rng.uniform(-math.pi, math.pi)
        d = rng.uniform(0.2, 2.0) * scale
        c2 = c1 + d * np.array([math.cos(ang), math.sin(ang)])
        r1 = rng.uniform(0.2, 2.0) * scale
        r2 = rng.uniform(0.2, 2.0) * scale
        if abs(r1 - r2) + 0.05 * scale < d < r1 + r2 - 0.05 * scale:
            out.append((c1, r1, c2, r2))
    return out


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
def test_circle_circle_matches_mpmath(scale, sign):
    """Both intersections, at scales 1e-6 .. 1e6, to a few ulps of the scale (well away from
    tangency: margin >= ~0.05 so the conditioning is O(1/margin))."""
    rng = np.random.default_rng(17)
    for c1, r1, c2, r2 in _rrr_cases(rng, scale):
        X, margin, ok, viol = dyads.circle_circle(c1, r1, c2, r2, sign)[:4]
        want = orc.circle_circle(c1, r1, c2, r2, sign)
        assert bool(ok) and float(viol) == 0.0
        err = orc.point_error(X, want.point)
        assert err <= 1e-14 * scale / float(want.margin), (c1, r1, c2, r2, err)
        assert abs(float(margin) - float(want.margin)) <= 1e-12
        # the sign convention: +1 is left of c1 -> c2
        side = float(orc.cross(np.subtract(c2, c1), np.subtract(X, c1)))
        assert side * sign > 0


@pytest.mark.parametrize('scale', SCALES)
def test_circle_circle_near_tangency_sqrt_law(scale):
    """d = r1 + r2 - eps * scale (external) and d = |r1 - r2| + eps * scale (internal): the
    height is ~sqrt(eps) and its error obeys the square-root law (see oracles.sqrt_law_bound)."""
    r1, r2 = 1.3 * scale, 0.7 * scale
    for external in (True, False):
        for eps_rel in (0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3):
            with mp.workdps(50):
                d = (
                    (mp.mpf(r1) + mp.mpf(r2) - eps_rel * scale)
                    if external
                    else (mp.mpf(r1) - mp.mpf(r2) + eps_rel * scale)
                )
            c1 = np.array([0.3, -0.2]) * scale
            u = np.array([math.cos(0.7), math.sin(0.7)])
            c2 = c1 + float(d) * u
            for sign in (1, -1):
                X, margin, ok, viol = dyads.circle_circle(c1, r1, c2, r2, sign)[:4]
                want = orc.circle_circle(c1, r1, c2, r2, sign)
                assert bool(ok), (external, eps_rel)
                if want.point is None:  # rounding of c2 put it just outside: the clamp
                    assert float(want.miss) <= dyads.TANGENCY_TOL * 2 * scale
                    continue
                err = orc.point_error(X, want.point)
                distance = max(float(-want.miss) / scale, 0.0)
                assert err <= scale * (1e-15 + orc.sqrt_law_bound(distance, EPS)), (
                    external,
                    eps_rel,
                    err,
                )


@pytest.mark.parametrize('scale', SCALES)
def test_circle_circle_beyond_tangency(scale):
    """Missing by 1e-9 of the scale: refused, with the violation equal to the miss; within the
    1e-12 clamp: assembled on the centre line (margin 0)."""
    r1, r2 = 1.3 * scale, 0.7 * scale
    c1 = np.array([0.1, 0.2]) * scale
    u = np.array([math.cos(-2.0), math.sin(-2.0)])
    for miss_rel, should_close in ((1e-9, False), (1e-6, False), (3e-14, True)):
        c2 = c1 + (r1 + r2 + miss_rel * scale) * u
        X, margin, ok, viol = dyads.circle_circle(c1, r1, c2, r2, 1)[:4]
        want = orc.circle_circle(c1, r1, c2, r2, 1)
        assert bool(ok) == should_close, miss_rel
        assert np.all(np.isfinite(X)) and np.isfinite(margin) and np.isfinite(viol)
        if should_close:
            assert float(margin) <= 1e-6
            assert orc.point_error(X, (c1 + r1 * u)) <= 1e-6 * scale
        else:
            assert float(viol) == pytest.approx(float(want.miss), rel=1e-5)
            assert float(margin) == 0.0


def test_circle_circle_degenerate_inputs_stay_finite():
    """Concentric circles, zero radius, NaN and inf: ok False and finite placeholders."""
    cases = [
        ((0, 0), 1.0, (0, 0), 1.0),
        ((0, 0), 0.0, (1, 0), 1.0),
        ((0, 0), 1.0, (np.nan, 0), 1.0),
        ((0, 0), np.inf, (1, 0), 1.0),
        ((np.inf, 0), 1.0, (1, 0), 1.0),
        ((0, 0), -1.0, (1, 0), 1.0),
    ]
    for c1, r1, c2, r2 in cases:
        X, margin, ok, viol = dyads.circle_circle(
            np.array(c1, float), r1, np.array(c2, float), r2, 1
        )[:4]
        assert not bool(ok), (c1, r1, c2, r2)
        assert np.all(np.isfinite(X)) and np.isfinite(margin) and np.isfinite(viol)


def test_circle_circle_batched_broadcasts_signs():
    """One call over a batch with mixed signs equals the per-row calls."""
    rng = np.random.default_rng(5)
    cases = _rrr_cases(rng, 1.0, 12)
    c1 = np.array([c[0] for c in cases])
    r1 = np.array([c[1] for c in cases])
    c2 = np.array([c[2] for c in cases])
    r2 = np.array([c[3] for c in cases])
    sign = np.where(np.arange(len(cases)) % 2 == 0, 1, -1)
    X = dyads.circle_circle(c1, r1, c2, r2, sign)[0]
    for i in range(len(cases)):
        xi = dyads.circle_circle(c1[i], r1[i], c2[i], r2[i], sign[i])[0]
        assert np.array_equal(X[i], xi)


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
def test_circle_line_matches_mpmath(scale, sign):
    rng = np.random.default_rng(3)
    for _ in range(40):
        c = rng.uniform(-2, 2, 2) * scale
        ang = rng.uniform(-math.pi, math.pi)
        u = np.array([math.cos(ang), math.sin(ang)])
        r = rng.uniform(0.3, 2.0) * scale
        dist = rng.uniform(-0.9, 0.9) * r
        p0 = c + dist * np.array([-u[1], u[0]]) + rng.uniform(-3, 3) * scale * u
        X, margin, ok, viol = dyads.circle_line(c, r, p0, u, sign)
        want = orc.circle_line(c, r, p0, u, sign)
        assert bool(ok)
        err = orc.point_error(X, want.point)
        assert err <= 1e-14 * scale / float(want.margin)
        assert abs(float(margin) - float(want.margin)) <= 1e-12
        # +1 is further along +u than the foot of the centre
        along = float(np.dot(np.subtract(X, c), u))
        assert along * sign > 0


@pytest.mark.parametrize('scale', SCALES)
def test_circle_line_refuses_a_miss_with_its_amount(scale):
    c = np.array([0.2, 0.1]) * scale
    u = np.array([0.6, 0.8])
    r = 1.0 * scale
    for miss_rel in (1e-9, 0.5):
        p0 = c + (r + miss_rel * scale) * np.array([-u[1], u[0]])
        X, margin, ok, viol = dyads.circle_line(c, r, p0, u, 1)
        assert not bool(ok) and np.all(np.isfinite(X))
        want = orc.circle_line(c, r, p0, u, 1)
        assert float(viol) == pytest.approx(float(want.miss), rel=1e-5)


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
def test_line_through_point_matches_mpmath(scale, sign):
    rng = np.random.default_rng(11)
    for _ in range(40):
        p = rng.uniform(-1, 1, 2) * scale
        x = p + rng.uniform(0.3, 2.0) * scale * np.array(
            [math.cos(a := rng.uniform(-math.pi, math.pi)), math.sin(a)]
        )
        rho = float(np.hypot(*(x - p)))
        e = rng.uniform(-0.9, 0.9) * rho
        psi, margin, ok, viol = dyads.line_through_point(p, x, e, sign)
        want = orc.line_through_point(p, x, e, sign)
        assert bool(ok)
        assert orc.angle_error(float(psi), want) <= 1e-14 / float(margin)
        # the defining properties, checked on the float answer
        d = np.array([math.cos(float(psi)), math.sin(float(psi))])
        assert float(orc.cross(d, x - p)) == pytest.approx(e, abs=1e-14 * scale / float(margin))
        assert float(np.dot(d, x - p)) * sign > 0


def test_one_command_backend_agrees_with_the_batch_backend():
    """Each dyad kernel is written once (core.dyads, on core.ops backends); run on Python
    numbers (one command) and on numpy arrays (a batch) it agrees to a few ulps, both signs, and
    on ok/violation."""
    rng = np.random.default_rng(23)
    for scale in SCALES:
        for c1, r1, c2, r2 in _rrr_cases(rng, scale, 15):
            pair = dyads.solve_rrr_dyad(SCALAR, complex(*c1), r1, complex(*c2), r2)
            for s in (1, -1):
                X, mb, okb, vb = dyads.circle_circle(c1, r1, c2, r2, s)[:4]
                z, ok = dyads.dyad_point(SCALAR, pair, s)
                assert abs(z - complex(*X)) <= 8 * EPS * scale / float(mb)
            assert ok == bool(okb) and abs(pair.margin - float(mb)) <= 1e-14
        # a miss
        pair = dyads.solve_rrr_dyad(SCALAR, 0j, 1.0 * scale, 3.0 * scale, 1.0 * scale)
        vb = dyads.circle_circle((0, 0), 1.0 * scale, (3.0 * scale, 0), 1.0 * scale, 1)[3]
        assert not pair.ok and pair.violation == pytest.approx(float(vb), rel=1e-12)
        # circle-line
        c = complex(0.2, -0.1) * scale
        u = cmath.exp(0.4j)
        p0 = c + 0.3 * scale * 1j * u
        pair = dyads.solve_rrp_dyad(SCALAR, c, 0.8 * scale, p0, u)
        for s in (1, -1):
            X = dyads.circle_line(
                (c.real, c.imag), 0.8 * scale, (p0.real, p0.imag), (u.real, u.imag), s
            )[0]
            assert abs(dyads.dyad_point(SCALAR, pair, s)[0] - complex(*X)) <= 8 * EPS * scale
        # line through a point
        p, x, e = complex(0.1, 0.2) * scale, complex(1.1, -0.4) * scale, 0.3 * scale
        dy = dyads.solve_rpr_dyad(SCALAR, p, x, e)
        for s in (1, -1):
            psi = dyads.line_through_point((p.real, p.imag), (x.real, x.imag), e, s)[0]
            assert orc.angle_error(dyads.rpr_direction(SCALAR, dy, s), float(psi)) <= 1e-15
