"""The closed-form dyads of :mod:`linkage_ros.core.dyads` for one command, on plain floats.

A twin, kept on purpose: :func:`~linkage_ros.core.dyads.solve_rrr_dyad` and its siblings are
written once against the number backends of :mod:`linkage_ros.core.ops`, and on the one-command
backend every ``ops.where`` / ``ops.maximum`` / ``ops.clip`` is a Python call and every result a
NamedTuple. Measured in one process (four-bar RRR dyad of the packaged scene, 2-core machine
at load ~8, best of 5 x 20000 calls): the generic kernel on ``SCALAR`` plus ``dyad_point``
took 6.9 us per dyad, these kernels 1.3 us -- the generic form alone was 40% of a whole
warm ``Solver.solve`` of the four-bar budget the issue sets (8x a hand-written math four-bar).

The formulas are the batch kernels', operation for operation and in the same order (the
branches below are the ``where`` of the batch form, taken once): on finite input every float
returned equals the batch kernel's row (test/core/test_scalar_dyads.py proves it over a
hypothesis-drawn space of dyads, tangent ones included). The Kahan-stable area, the power-of-two
scaling and the toggle band are the batch kernels' (see there for why).

Each solver returns a plain tuple (no object built per command):

* RRR ``(base, u, along, h, S, margin, ok, violation, finite)``: branch ``s`` is the point
  ``(base + (along + s * (0 h + i h)) * u) * S`` (:func:`rrr_point`);
* RRP ``(p0, u, along, k, margin, ok, violation)``: branch ``s`` is ``(p0 + (along + s k) u)``;
* RPR ``(beta, along, offset, margin, ok, violation)``: direction ``beta - atan2(offset, s
  along)`` (rad).
"""

from __future__ import annotations

import math
import sys
from cmath import isfinite as _cfinite
from math import frexp, ldexp, sqrt

from .dyads import TANGENCY_TOL, TOGGLE_BAND
from .ops import _max, _min

_FLOAT_MAX = sys.float_info.max

#: see the module docstring
RrrPair = tuple[complex, complex, float, float, float, float, bool, float, bool]
RrpPair = tuple[complex, complex, float, float, float, bool, float]
RprPair = tuple[float, float, float, float, bool, float]


def solve_rrr(c1: complex, r1: float, c2: complex, r2: float, tol: float = TANGENCY_TOL) -> RrrPair:
    """:func:`~linkage_ros.core.dyads.solve_rrr_dyad` on one command (circles (c1, r1) and
    (c2, r2); branch +1 left of c1 -> c2)."""
    x, y = abs(c1.real), abs(c1.imag)
    big = x if (x >= y or x != x) else y
    x, y = abs(c2.real), abs(c2.imag)
    m = x if (x >= y or x != x) else y
    big = big if (big >= m or big != big) else m
    x, y = abs(r1), abs(r2)
    m = x if (x >= y or x != x) else y
    big = big if (big >= m or big != big) else m
    # ops.pow2_scale: the even power of two with big / S in [1, 4)
    _, expo = frexp(big if (big - big == 0.0 and big > 0) else 1.0)
    S = ldexp(1.0, ((expo - 1) >> 1) << 1)
    c1n, c2n = c1 / S, c2 / S
    r1n, r2n = r1 / S, r2 / S
    dv = c2n - c1n
    d = abs(dv)
    finite = (
        _cfinite(dv) and r1n - r1n == 0.0 and r2n - r2n == 0.0 and _cfinite(c1) and _cfinite(c2)
    )
    # kahan_four_area_of (dyads): the sides finite and >= 0 here, so max / min are plain
    a, b, c = (d, r1n, r2n) if finite else (0.0, 0.0, 0.0)
    lo, hi = (a if a <= b else b), (a if a >= b else b)
    longest, small = (hi if hi >= c else c), (lo if lo <= c else c)
    m = hi if hi <= c else c
    mid = lo if lo >= m else m
    _, expo = frexp(longest)
    scale = ldexp(1.0, expo)
    longest, mid, small = longest / scale, mid / scale, small / scale
    neg_factor = small - (longest - mid)
    four_area_n = (
        sqrt(longest + (mid + small))
        * sqrt(neg_factor if neg_factor >= 0.0 else 0.0)
        * sqrt(small + (longest - mid))
        * sqrt(longest + (mid - small))
    )
    violation_n = -neg_factor
    dn = d / scale
    ok = finite and dn > 0 and r1n > 0 and r2n > 0 and violation_n <= tol * longest
    dsafe = d if (finite and d > 0) else 1.0
    u = (dv if finite else 0.0) / dsafe
    if finite and d > 0:
        along = 0.5 * (d + ((r1n - r2n) / dsafe) * (r1n + r2n))
        along = _min(_max(along, -abs(r1n)), abs(r1n))  # NaN-propagating, as ops.clip
    else:
        along = 0.0
    h = margin = violation = 0.0
    if ok:
        m = r1n / scale
        smallest = dn if dn <= m else m
        m = r2n / scale
        smallest = smallest if smallest <= m else m
        if not (violation_n >= -TOGGLE_BAND * longest and -violation_n < 0.5 * smallest):
            h = 0.5 * scale * (four_area_n / dn)
        margin = (h / r1n) * (d / r2n)
        margin = margin if margin == margin else 0.0
        margin = margin if margin >= 0.0 else 0.0
        margin = margin if margin <= 1.0 else 1.0
    else:  # the batch form's where(finite, ...) chain, NaN-propagating max / min included
        violation = _max(violation_n * (scale * S), 0.0) if finite else _FLOAT_MAX
        violation = _min(violation, _FLOAT_MAX)
    return (c1n if finite else 0j), u, along, h, S, margin, ok, violation, finite


def rrr_point(pair: RrrPair, sign: int) -> tuple[complex, bool]:
    """The point of branch ``sign`` of an RRR dyad and whether it is one (``dyad_point``: a
    point beyond the float range is not)."""
    base, u, along, h, S, _, ok, _, _ = pair
    z = (base + (along + sign * complex(0.0 * h, h)) * u) * S
    return z, ok and _cfinite(z)


def rrr_fallback(pair: RrrPair, c1: complex) -> complex:
    """The placeholder of a dyad that does not close: circle 1's point nearest circle 2 on
    the centre line (c1 where that is not representable, 0 for non-finite input)."""
    base, u, along, _, S, _, _, _, finite = pair
    if not finite:
        return 0j
    near = (base + along * u) * S
    return near if _cfinite(near) else c1


def solve_rrp(c: complex, r: float, p0: complex, u: complex, tol: float = TANGENCY_TOL) -> RrpPair:
    """:func:`~linkage_ros.core.dyads.solve_rrp_dyad` on one command (circle (c, r) and the
    line p0 + s u, |u| = 1; branch +1 further along +u)."""
    w = c - p0
    s0 = w.real * u.real + w.imag * u.imag
    dist = abs(u.real * w.imag - u.imag * w.real)
    violation = dist - r
    scale = _max(r, dist)
    ok = (violation <= tol * (scale if scale > 0 else 1.0)) and r > 0
    off = r - dist if r - dist > TOGGLE_BAND * scale else 0.0
    k = margin = 0.0
    if ok:
        k = sqrt(off) * sqrt(r + dist)
        margin = _min(_max(k / r, 0.0), 1.0)
    return p0, u, s0, k, margin, ok, _max(violation, 0.0)


def rrp_point(pair: RrpPair, sign: int) -> tuple[complex, bool]:
    """The point of branch ``sign`` of an RRP dyad (``dyad_point``, scale 1)."""
    p0, u, along, k, _, ok, _ = pair
    z = (p0 + (along + sign * k) * u) * 1.0
    if ok and _cfinite(z):
        return z, True
    return p0 + along * u, False


def solve_rpr(p: complex, x: complex, offset: float, tol: float = TANGENCY_TOL) -> RprPair:
    """:func:`~linkage_ros.core.dyads.solve_rpr_dyad` on one command: the direction of a line
    rigid with a body pivoting at p that passes x at the signed offset ``offset``."""
    w = x - p
    rho = abs(w)
    ae = abs(offset)
    violation = ae - rho
    scale = _max(rho, ae)
    ok = rho > 0 and (violation <= tol * (scale if scale > 0 else 1.0))
    off = rho - ae if rho - ae > TOGGLE_BAND * scale else 0.0
    along, margin = 1.0, 0.0
    if ok:
        along = sqrt(off) * sqrt(rho + ae)
        margin = _min(_max(along / rho, 0.0), 1.0)
    beta = math.atan2(w.imag, w.real)
    return beta, along, (offset if ok else 0.0), margin, ok, _max(violation, 0.0)


def rpr_angle(pair: RprPair, sign: int) -> float:
    """The line direction (rad) of branch ``sign`` of an RPR dyad."""
    return pair[0] - math.atan2(pair[2], sign * pair[1])
