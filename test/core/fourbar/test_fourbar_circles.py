"""Tests of linkage_ros.core.fourbar's circle_intersection against 50-digit mpmath circle
intersections: the side convention, needle triangles, extreme scales, tangency clamps and
failures, broadcasting.
"""

import mpmath as mp
import numpy as np
import pytest
from fourbar_helpers import DPS

from linkage_ros.core.fourbar import circle_intersection

# ----------------------------------------------------------------------------- circle_intersection


def mp_circle_intersection(c1, r1, c2, r2, sign):
    with mp.workdps(DPS):
        x1, y1, x2, y2 = (mp.mpf(float(v)) for v in (*c1, *c2))
        r1, r2 = mp.mpf(float(r1)), mp.mpf(float(r2))
        dx, dy = x2 - x1, y2 - y1
        d = mp.sqrt(dx**2 + dy**2)
        a = (d**2 + r1**2 - r2**2) / (2 * d)
        h = mp.sqrt(r1**2 - a**2)
        px = x1 + a * dx / d - sign * h * dy / d
        py = y1 + a * dy / d + sign * h * dx / d
        return float(px), float(py), float(h)


def test_circle_intersection_matches_mpmath_and_side_convention():
    rng = np.random.default_rng(1)
    n = 300
    c1 = rng.uniform(-5, 5, (n, 2))
    c2 = rng.uniform(-5, 5, (n, 2))
    d = np.hypot(*(c2 - c1).T)
    r1 = rng.uniform(0.1, 1.0, n) * (d + 1)
    # choose r2 strictly inside the intersecting band so every case is a proper crossing
    lo, hi = np.abs(d - r1), d + r1
    r2 = lo + rng.uniform(0.05, 0.95, n) * (hi - lo)
    sign = rng.choice([-1.0, 1.0], n)
    p, h, ok = circle_intersection(c1, r1, c2, r2, sign)
    assert p.shape == (n, 2) and h.shape == (n,) and ok.all()
    for i in range(n):
        px, py, hm = mp_circle_intersection(c1[i], r1[i], c2[i], r2[i], sign[i])
        scale = max(d[i], r1[i], r2[i])
        assert abs(p[i, 0] - px) <= 1e-13 * scale and abs(p[i, 1] - py) <= 1e-13 * scale
        assert abs(h[i] - hm) <= 1e-13 * scale
    # sign +1 is the left (counter-clockwise) side of c1 -> c2: positive cross product
    cross = (c2 - c1)[:, 0] * (p - c1)[:, 1] - (c2 - c1)[:, 1] * (p - c1)[:, 0]
    assert np.all(np.sign(cross) == sign)


def test_circle_intersection_needle_triangle_keeps_relative_accuracy():
    # d = 2 - 1e-10 with r1 = r2 = 1: h ~ 1e-5.  sqrt(r1^2 - a^2) would lose ~10 digits here.
    for gap in (1e-6, 1e-10, 1e-14):
        d = 2.0 - gap
        _, h, ok = circle_intersection([0.0, 0.0], 1.0, [d, 0.0], 1.0, 1)
        _, _, hm = mp_circle_intersection((0.0, 0.0), 1.0, (d, 0.0), 1.0, 1)
        assert ok and h > 0
        assert abs(h - hm) <= 1e-13 * hm


@pytest.mark.parametrize('k', [1e-200, 2.0**-600, 1.0, 3e150, 1e300])
def test_circle_intersection_extreme_scales(k):
    # needle triangle and ordinary triangle, both scaled by k: no under/overflow, same digits
    for c2x, r1, r2 in ((2.0 - 1e-10, 1.0, 1.0), (1.3, 0.9, 0.7), (1e-100, 1.0, 1.0)):
        p, h, ok = circle_intersection([0.0, 0.0], k * r1, [k * c2x, 0.0], k * r2, 1)
        px, py, hm = mp_circle_intersection((0.0, 0.0), k * r1, (k * c2x, 0.0), k * r2, 1)
        assert ok and np.all(np.isfinite(p))
        assert abs(h - hm) <= 1e-13 * hm
        assert abs(p[0] - px) <= 1e-13 * k and abs(p[1] - py) <= 1e-13 * k


def test_circle_intersection_tangency_clamp_and_failures_are_finite():
    # external tangency: d = r1 + r2 exactly
    p, h, ok = circle_intersection([0.0, 0.0], 1.0, [3.0, 0.0], 2.0, 1)
    assert ok and h == 0.0 and np.allclose(p, [1.0, 0.0], atol=1e-15)
    # internal tangency: d = r1 - r2
    p, h, ok = circle_intersection([0.0, 0.0], 3.0, [1.0, 0.0], 2.0, -1)
    assert ok and h == 0.0 and np.allclose(p, [3.0, 0.0], atol=1e-15)
    # violated by 0.5e-12 of the scale (3.0): still tangent; by 1e-9: no intersection
    _, h, ok = circle_intersection([0.0, 0.0], 1.0, [3.0 + 1.5e-12, 0.0], 2.0, 1)
    assert ok and h == 0.0
    p, h, ok = circle_intersection([0.0, 0.0], 1.0, [3.0 + 1e-9, 0.0], 2.0, 1)
    assert not ok and h == 0.0
    assert np.array_equal(p, [1.0, 0.0])  # fill: the point of circle 1 nearest to circle 2
    # nested, far apart, concentric, zero distance, negative radius, non-finite input
    c1 = np.array([[0, 0], [0, 0], [0, 0], [1, 1], [0, 0], [np.nan, 0], [0, 0]], float)
    c2 = np.array([[0.5, 0], [10, 0], [0, 0], [1, 1], [1, 0], [1, 0], [np.inf, 0]], float)
    r1 = np.array([3, 1, 1, 1, -1, 1, 1], float)
    r2 = np.array([1, 1, 1, 1, 1, 1, 1], float)
    with np.errstate(all='raise'):  # no floating-point warnings leak out either
        p, h, ok = circle_intersection(c1, r1, c2, r2, np.ones(7))
    assert not ok.any()
    assert np.all(np.isfinite(p)) and np.all(np.isfinite(h)) and np.all(h == 0)


def test_circle_intersection_broadcasts():
    c1 = np.zeros((3, 1, 2))
    c2 = np.stack([np.linspace(1, 2, 4), np.zeros(4)], -1)  # (4, 2)
    p, h, ok = circle_intersection(c1, np.array([1.0, 1.5, 2.0])[:, None], c2, 1.0, 1)
    assert p.shape == (3, 4, 2) and h.shape == (3, 4) and ok.shape == (3, 4)
    assert ok.all()
    # every point lies on both circles
    assert np.allclose(np.hypot(*np.moveaxis(p, -1, 0)), np.array([1.0, 1.5, 2.0])[:, None])
    assert np.allclose(np.hypot(*np.moveaxis(p - c2, -1, 0)), 1.0)
