"""The one-command dyad kernels (core.scalar_dyads) against the batch kernels they twin
(core.dyads on the numpy backend), over a hypothesis-drawn space of dyads: scales from 1e-300
to 1e300, centres far apart and nearly coincident, and lengths within a few ulps of a tangency
on either side (the toggle band, where the Kahan area and the band decide).

RRR and RRP use only +, -, *, /, sqrt, hypot, frexp and ldexp, which numpy and Python round the
same way on every CPU: their answers must be equal float for float (the sign of a zero aside).
RPR's direction also goes through atan2, where numpy may take a SIMD path that is not libm's:
within 1 ulp there; its other outputs equal.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from linkage_ros.core import dyads
from linkage_ros.core.ops import BATCH, CArray
from linkage_ros.core.scalar_dyads import (
    rpr_angle,
    rrp_point,
    rrr_fallback,
    rrr_point,
    solve_rpr,
    solve_rrp,
    solve_rrr,
)


def _row(v):
    """Row 0 of a batch value as a Python number (complex for a CArray)."""
    if isinstance(v, CArray):
        return complex(
            float(np.asarray(v.re).reshape(-1)[0]), float(np.asarray(v.im).reshape(-1)[0])
        )
    a = np.asarray(v).reshape(-1)[0]
    return bool(a) if a.dtype == bool else float(a)


def _one(z):
    return CArray(np.array([z.real]), np.array([z.imag]))


def _same(a, b):
    """Equal floats (or complex): == (so +0 and -0 are equal), or both NaN."""
    if isinstance(a, complex) or isinstance(b, complex):
        a, b = complex(a), complex(b)
        return _same(a.real, b.real) and _same(a.imag, b.imag)
    return a == b or (a != a and b != b)


scales = st.sampled_from([1e-300, 1e-150, 2.0**-60, 1e-3, 0.3, 1.0, 7.0, 1e3, 1e150, 1e300])
unit = st.floats(-1.0, 1.0, allow_nan=False)
ulps = st.integers(-6, 6)


@st.composite
def rrr_dyads(draw):
    """(c1, r1, c2, r2): general ones, and ones a few ulps from a tangency (outer: r1 + r2 = d,
    inner: |r1 - r2| = d) or with nearly coincident centres."""
    s = draw(scales)
    c1 = complex(draw(unit), draw(unit)) * s
    kind = draw(st.sampled_from(['general', 'outer', 'inner', 'coincident']))
    if kind == 'coincident':
        c2 = c1 + complex(draw(unit), draw(unit)) * s * 2.0**-50
    else:
        c2 = c1 + complex(draw(unit), draw(unit)) * s
    d = abs(c2 - c1)
    r1 = abs(draw(unit)) * s + s * 1e-3
    if kind == 'general':
        r2 = abs(draw(unit)) * s * 2 + s * 1e-3
    elif kind == 'outer':
        r2 = d - r1
    elif kind == 'inner':
        r2 = d + r1
    else:
        r2 = r1
    r2 = abs(r2)
    for _ in range(abs(draw(ulps))):  # nudge by ulps: either side of the tangency
        r2 = math.nextafter(r2, math.inf if draw(st.booleans()) else 0.0)
    return c1, r1, c2, r2


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rrr_dyads(), st.sampled_from([1e-12, 0.0]))
@example((0j, 1.0, 2 + 0j, 1.0), 1e-12)  # an exact toggle
@example((0j, 1.0, 0j, 1.0), 1e-12)  # coincident circles
@example((complex(math.inf, 0), 1.0, 1 + 0j, 1.0), 1e-12)  # non-finite input
@example((1e308 + 0j, 1e308, -1e308 + 0j, 1e308), 1e-12)  # centres 2e308 apart
@example((0j, 5e-324, 1e-323 + 0j, 5e-324), 1e-12)  # subnormal lengths
def test_rrr_equals_the_batch_kernel(dyad, tol):
    c1, r1, c2, r2 = dyad
    with np.errstate(all='ignore'):
        want = dyads.solve_rrr_dyad(BATCH, _one(c1), np.array([r1]), _one(c2), np.array([r2]), tol)
        got = solve_rrr(c1, r1, c2, r2, tol)
        base, u, along, h, S, margin, ok, violation, finite = got
        assert ok == _row(want.ok)
        assert _same(margin, _row(want.margin))
        assert _same(violation, _row(want.violation))
        assert _same(h * S if ok else 0.0, _row(want.height))
        for sign in (1, -1):
            z, z_ok = rrr_point(got, sign)
            wz, w_ok = dyads.dyad_point(BATCH, want, np.array([float(sign)]))
            assert z_ok == _row(w_ok), sign
            placed = z if z_ok else rrr_fallback(got, c1)
            assert _same(placed, _row(wz)), (sign, placed, _row(wz))


@st.composite
def rrp_dyads(draw):
    """(c, r, p0, u): a circle and a line, general or a few ulps from tangency (a dead centre:
    the link perpendicular to the line)."""
    s = draw(scales)
    c = complex(draw(unit), draw(unit)) * s
    p0 = complex(draw(unit), draw(unit)) * s
    a = draw(st.floats(-math.pi, math.pi))
    u = complex(math.cos(a), math.sin(a))
    w = c - p0
    dist = abs(u.real * w.imag - u.imag * w.real)
    r = dist if draw(st.booleans()) else abs(draw(unit)) * s * 2
    for _ in range(abs(draw(ulps))):
        r = math.nextafter(r, math.inf if draw(st.booleans()) else 0.0)
    return c, r, p0, u


@settings(max_examples=400, deadline=None)
@given(rrp_dyads())
def test_rrp_equals_the_batch_kernel(dyad):
    c, r, p0, u = dyad
    with np.errstate(all='ignore'):
        want = dyads.solve_rrp_dyad(BATCH, _one(c), np.array([r]), _one(p0), _one(u))
        got = solve_rrp(c, r, p0, u)
        assert got[5] == _row(want.ok)
        assert _same(got[4], _row(want.margin))
        assert _same(got[6], _row(want.violation))
        for sign in (1, -1):
            z, z_ok = rrp_point(got, sign)
            wz, w_ok = dyads.dyad_point(BATCH, want, np.array([float(sign)]))
            assert z_ok == _row(w_ok)
            assert _same(z, _row(wz))


@settings(max_examples=400, deadline=None)
@given(scales, unit, unit, unit, unit, unit, ulps, st.booleans())
@example(
    8.673617379884035e-19,
    0.7595073388875284,
    0.0,
    0.55,
    0.7345478962337775,
    0.547854049522734,
    0,
    False,
)
def test_rpr_equals_the_batch_kernel(s, px, py, xx, xy, e, nudge, up):
    p, x = complex(px, py) * s, complex(xx, xy) * s
    offset = e * s
    if nudge:  # a few ulps from the line through the pivot's foot (|offset| = |x - p|)
        offset = abs(x - p)
        for _ in range(abs(nudge)):
            offset = math.nextafter(offset, math.inf if up else 0.0)
    with np.errstate(all='ignore'):
        want = dyads.solve_rpr_dyad(BATCH, _one(p), _one(x), np.array([offset]))
        got = solve_rpr(p, x, offset)
        assert got[4] == _row(want.ok)
        for i, name in ((1, 'along'), (2, 'offset'), (3, 'margin'), (5, 'violation')):
            assert _same(got[i], _row(getattr(want, name))), name
        # the direction is beta - atan2(offset, sign along), beta itself an atan2: numpy's may
        # be a SIMD one, within an ulp of libm's for each of the two (values up to pi), and the
        # difference rounds once more. (2 ulps of 1.0 was too tight: beta 1.85 and the other
        # atan2 2.34 rad each an ulp off read 3 ulps of 1.0 apart, hypothesis found.)
        bound = 2 * (2 * math.ulp(math.pi)) + math.ulp(math.pi)
        for sign in (1, -1):
            a = rpr_angle(got, sign)
            b = _row(dyads.rpr_direction(BATCH, want, np.array([float(sign)])))
            assert abs(a - b) <= bound, (sign, a, b)
