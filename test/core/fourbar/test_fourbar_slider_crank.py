"""Tests of linkage_ros.core.fourbar's slider-crank forward, inverse and stroke against
independent oracles: the rod length, 50-digit mpmath near the reach limit and sweeps of the
crank for the stroke's extremes.
"""

import math

import mpmath as mp
import numpy as np
import pytest
from fourbar_helpers import DPS, wrap

from linkage_ros.core.fourbar import slider_crank_forward, slider_crank_inverse, slider_crank_stroke

# ----------------------------------------------------------------------------- slider-crank


SLIDERS = [(1.0, 3.0, 0.5), (1.0, 3.0, -0.7), (2.0, 2.5, 0.5), (1.0, 4.0, 0.0), (0.5, 1.0, 0.5)]


@pytest.mark.parametrize('r,l,e', SLIDERS)
def test_slider_forward_satisfies_rod_length(r, l, e):
    t2 = np.linspace(-np.pi, np.pi, 721)
    scale = max(r, l, abs(e))
    for branch in (1, -1):
        sol = slider_crank_forward(r, l, e, t2, branch)
        ax, ay = r * np.cos(t2), r * np.sin(t2)
        expected_ok = np.abs(e - ay) <= l
        clear = np.abs(np.abs(e - ay) - l) > 1e-9
        assert np.array_equal(sol.ok[clear], expected_ok[clear])
        ok = sol.ok
        assert np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.theta3))
        # (x - r cos t2)^2 + (e - r sin t2)^2 = l^2
        assert np.max(np.abs(np.hypot(sol.x - ax, e - ay) - l)[ok]) <= 1e-12 * scale
        # branch +1: B ahead of A; -1 behind
        assert np.all(branch * (sol.x - ax)[ok] >= 0)
        # rod angle consistent with the positions
        assert np.max(np.abs(ax + l * np.cos(sol.theta3) - sol.x)[ok]) <= 1e-12 * scale
        assert np.max(np.abs(ay + l * np.sin(sol.theta3) - e)[ok]) <= 1e-12 * scale
        assert np.all(sol.residual[ok] <= 1e-12)


def test_slider_forward_matches_mpmath_near_reach_limit():
    # r = l, e = 0: at theta2 = pi/2 the rod is perpendicular to the slide line and
    # x - A_x = sqrt((l - dy)(l + dy)) ~ |theta2 - pi/2| is small.  The factored form keeps the
    # error at ~eps/|theta2 - pi/2| (dy itself is rounded), i.e. <= 1e-12 for offsets >= 1e-3.
    r, l, e = 1.0, 1.0, 0.0
    for dt in (0.0, 1e-3, -1e-3, 1e-2, 1e-1):
        t2 = np.pi / 2 + dt
        for branch in (1, -1):
            sol = slider_crank_forward(r, l, e, t2, branch)
            assert sol.ok
            with mp.workdps(DPS):
                tt = mp.mpf(t2)
                dy = e - r * mp.sin(tt)
                want = r * mp.cos(tt) + branch * mp.sqrt(max(l**2 - dy**2, 0))
            assert abs(sol.x - float(want)) <= 1e-12 * max(r, l)


def test_slider_forward_tangency_clamp():
    # e = 2, r = l = 1: the rod reaches the line only at theta2 = pi/2, perpendicular to it
    r, l, e = 1.0, 1.0, 2.0
    sol = slider_crank_forward(r, l, e, np.pi / 2, 1, tangency_tol=0.0)
    assert sol.ok and abs(sol.x) <= 1e-15 and sol.theta3 == pytest.approx(np.pi / 2, abs=1e-15)
    # missing the line by 1e-13 (< 1e-12 of the scale 2) is clamped; by 1e-9 it is not
    assert slider_crank_forward(r, l, e + 1e-13, np.pi / 2).ok
    assert not slider_crank_forward(r, l, e + 1e-13, np.pi / 2, tangency_tol=0.0).ok
    sol = slider_crank_forward(r, l, e + 1e-9, np.pi / 2)
    assert not sol.ok and np.isfinite(sol.x) and sol.theta3 == 0.0
    assert sol.residual == pytest.approx(1e-9 / (e + 1e-9), rel=1e-6)  # the gap / max(r, l, |e|)


def _sweep_extremes(r, l, e, n=100_001):
    """Stroke oracle: dense sweep of branch +1, x(t) = r cos t + sqrt(l^2 - (e - r sin t)^2).

    The sweep only locates the extremes; they are then refined at 40 digits (x has a
    square-root singularity at the limits of assembly, so no float evaluation near them is
    good to better than ~1e-8): golden-section search around interior extremes and bisection
    on the assembly condition for the limits.
    """
    with mp.workdps(40):
        R, L, E = mp.mpf(r), mp.mpf(l), mp.mpf(e)

        def slack(t):
            return L**2 - (E - R * mp.sin(t)) ** 2

        def x_of(t):
            return R * mp.cos(t) + mp.sqrt(max(slack(t), 0))

        t = np.linspace(-np.pi, np.pi, n)
        dy = e - r * np.sin(t)
        feas = np.abs(dy) <= l
        x = np.where(feas, r * np.cos(t) + np.sqrt(np.clip(l * l - dy * dy, 0, None)), np.nan)
        cands = []
        for sgn in (1, -1):
            i = int(np.nanargmax(sgn * x))
            a, b = mp.mpf(t[max(i - 1, 0)]), mp.mpf(t[min(i + 1, n - 1)])
            if slack(a) >= 0 and slack(b) >= 0:
                g = (mp.sqrt(5) - 1) / 2
                for _ in range(160):
                    c, d = b - g * (b - a), a + g * (b - a)
                    if sgn * x_of(c) > sgn * x_of(d):
                        b = d
                    else:
                        a = c
                cands.append(x_of((a + b) / 2))
            if slack(mp.mpf(t[i])) >= 0:
                cands.append(x_of(mp.mpf(t[i])))
        for i in np.nonzero(feas[:-1] != feas[1:])[0]:
            a, b = mp.mpf(t[i]), mp.mpf(t[i + 1])
            inside_a = bool(feas[i])
            for _ in range(130):
                m = (a + b) / 2
                if (slack(m) >= 0) == inside_a:
                    a = m
                else:
                    b = m
            cands.append(x_of(a if inside_a else b))
        return float(min(cands)), float(max(cands))


@pytest.mark.parametrize('r,l,e', SLIDERS + [(2.0, 1.0, 0.0), (2.0, 1.5, 1.0)])
def test_slider_stroke_equals_sweep_extremes(r, l, e):
    lo, hi = slider_crank_stroke(r, l, e)
    want_lo, want_hi = _sweep_extremes(r, l, e)
    assert abs(lo - want_lo) <= 1e-9 * max(r, l) and abs(hi - want_hi) <= 1e-9 * max(r, l)
    if abs(e) + r <= l:  # full rotation: the dead-centre formulas
        assert hi == pytest.approx(math.sqrt((l + r) ** 2 - e**2), rel=1e-14)
        assert lo == pytest.approx(math.sqrt((l - r) ** 2 - e**2), rel=1e-14, abs=1e-15)


def test_slider_stroke_rejects_impossible():
    with pytest.raises(ValueError):
        slider_crank_stroke(1.0, 1.0, 3.0)
    with pytest.raises(ValueError):
        slider_crank_stroke(-1.0, 1.0, 0.0)


@pytest.mark.parametrize('r,l,e', SLIDERS)
def test_slider_inverse_of_forward(r, l, e):
    t2 = np.random.default_rng(3).uniform(-np.pi, np.pi, 3000)
    for branch in (1, -1):
        fwd = slider_crank_forward(r, l, e, t2, branch)
        ax, ay = r * np.cos(t2), r * np.sin(t2)
        # side of A relative to the vector O2 -> B, computed here
        cross = fwd.x * ay - e * ax
        well = fwd.ok & (np.abs(cross) > 1e-3 * r * np.hypot(fwd.x, e))
        inv = slider_crank_inverse(r, l, e, fwd.x, np.sign(cross))
        assert inv.ok[well].all()
        assert np.max(np.abs(wrap(inv.theta2 - t2))[well]) <= 1e-12
        assert np.max(np.abs(wrap(inv.theta3 - fwd.theta3))[well]) <= 1e-12
        assert np.all(inv.residual[well] <= 1e-12)
    # documented side: e = 0, x > 0 -> branch +1 gives theta2 in (0, pi)
    inv = slider_crank_inverse(1.0, 3.0, 0.0, np.array([2.5, 3.5]), 1)
    assert np.all((inv.theta2 > 0) & (inv.theta2 < np.pi))
    # out of reach: flagged, finite
    bad = slider_crank_inverse(1.0, 3.0, 0.0, np.array([4.5, 1.5, np.nan]))
    assert not bad.ok.any() and all(np.all(np.isfinite(v)) for v in bad)
