"""The closed-form dyads of :mod:`linkage_ros.core.dyads` for one command, on plain floats.

A twin, kept on purpose: :func:`~linkage_ros.core.dyads.solve_rrr_dyad` and its siblings are
written once against the number backends of :mod:`linkage_ros.core.ops`, and on the one-command
backend every ``ops.where`` / ``ops.maximum`` / ``ops.clip`` is a Python call and every result a
NamedTuple. Measured in one process (CPU time, best of 15 x 2000 calls, the packaged four-bar's
RRR dyad and one of its points; 2-core machine shared with other jobs, load ~10): the generic
kernel on ``SCALAR`` with ``dyad_point`` 7.9 us, these kernels 2.8 us, a hand-written ``math``
four-bar 1.6 us -- the generic form alone was 5x the arithmetic of the whole four-bar, most of
the 8x a warm ``Solver.solve`` may cost (issue 25).

The formulas are the batch kernels', operation for operation and in the same order (the
branches below are the ``where`` of the batch form, taken once; a non-finite RRR input skips to
the placeholders, which is all the batch form keeps of it): every float returned equals the
batch kernel's row, the sign of a zero aside (Python's complex arithmetic multiplies by
(x, +0)), and RPR's ``beta``, which goes through atan2 (numpy's may be a SIMD one: 1 ulp).
test/core/test_scalar_dyads.py checks it over a hypothesis-drawn space of dyads, tangent ones
included. The Kahan-stable area, the power-of-two scaling and the toggle band are the batch
kernels' (see there for why).

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
from .ops import nan_max, nan_min

_FLOAT_MAX = sys.float_info.max
#: ops.pow2_scale's power of two by the exponent frexp gives a positive finite float (its even
#: power with big / S in [1, 4)), and plain 2**e for the Kahan area's scale: the very floats
#: ldexp makes (a power of two is exact), looked up where ldexp is a call. Every exponent a
#: positive finite float has is there; the area's longest side is at most ~16 once scaled by S.
_EVEN_POW2 = {e: ldexp(1.0, ((e - 1) >> 1) << 1) for e in range(-1073, 1025)}
_POW2 = {e: ldexp(1.0, e) for e in range(-1074, 1024)}

#: see the module docstring
RrrPair = tuple[complex, complex, float, float, float, float, bool, float, bool]
RrpPair = tuple[complex, complex, float, float, float, bool, float]
RprPair = tuple[float, float, float, float, bool, float]


def solve_rrr(c1: complex, r1: float, c2: complex, r2: float, tol: float = TANGENCY_TOL) -> RrrPair:
    """:func:`~linkage_ros.core.dyads.solve_rrr_dyad` on one command (circles (c1, r1) and
    (c2, r2); branch +1 left of c1 -> c2)."""
    if not (_cfinite(c1) and _cfinite(c2) and r1 - r1 == 0.0 and r2 - r2 == 0.0):
        # the batch form's placeholders (its scale S is then never used: nothing closes)
        return 0j, 0.0, 0.0, 0.0, 1.0, 0.0, False, _FLOAT_MAX, False
    # ops.pow2_scale of the largest magnitude (finite here, so the plain max is the
    # NaN-propagating one): the even power of two S with big / S in [1, 4)
    # (the running max in comparisons, -x for abs(x): max() of six abs() calls costs about
    # twice as much; only big's exponent and whether it is > 0 are read: a -0.0 for 0.0 is
    # the same S, and every value is finite here)
    x = c1.real
    big = x if x >= 0.0 else -x
    x = c1.imag
    if x > big:
        big = x
    elif -x > big:
        big = -x
    x = c2.real
    if x > big:
        big = x
    elif -x > big:
        big = -x
    x = c2.imag
    if x > big:
        big = x
    elif -x > big:
        big = -x
    if r1 > big:
        big = r1
    elif -r1 > big:
        big = -r1
    if r2 > big:
        big = r2
    elif -r2 > big:
        big = -r2
    S = _EVEN_POW2[frexp(big)[1]] if big > 0.0 else 1.0
    c1n = c1 / S
    dv = c2 / S - c1n
    r1n, r2n = r1 / S, r2 / S
    d = abs(dv)
    # kahan_four_area_of (dyads) on the sides d, r1n, r2n: sorted by the same min/max network
    lo, hi = (d if d <= r1n else r1n), (d if d >= r1n else r1n)
    longest, small = (hi if hi >= r2n else r2n), (lo if lo <= r2n else r2n)
    m = hi if hi <= r2n else r2n
    mid = lo if lo >= m else m
    scale = _POW2[frexp(longest)[1]]
    longest, mid, small = longest / scale, mid / scale, small / scale
    neg_factor = small - (longest - mid)  # -violation_n
    dn = d / scale
    if not (dn > 0 and r1n > 0 and r2n > 0 and -neg_factor <= tol * longest):
        return _rrr_open(c1n, dv, d, r1n, r2n, -neg_factor, scale, S)
    u = dv / d
    # foot of the solutions on the centre line from c1 (see dyads), clipped to circle 1
    along = 0.5 * (d + ((r1n - r2n) / d) * (r1n + r2n))
    if along < -r1n:
        along = -r1n
    elif along > r1n:
        along = r1n
    # 0 within the toggle band (not where the smallest side is the whole of that distance;
    # the smallest side measured only within the band, where it is read)
    toggle = False
    if neg_factor <= TOGGLE_BAND * longest:
        m = r1n / scale
        smallest = dn if dn <= m else m
        m = r2n / scale
        smallest = smallest if smallest <= m else m
        toggle = neg_factor < 0.5 * smallest
    if toggle:
        h = 0.0
    else:
        four_area_n = (
            sqrt(longest + (mid + small))
            * sqrt(neg_factor if neg_factor >= 0.0 else 0.0)
            * sqrt(small + (longest - mid))
            * sqrt(longest + (mid - small))
        )
        h = 0.5 * scale * (four_area_n / dn)
    margin = (h / r1n) * (d / r2n)
    if not margin >= 0.0:  # NaN too
        margin = 0.0
    elif margin > 1.0:
        margin = 1.0
    return c1n, u, along, h, S, margin, True, 0.0, True


def _rrr_open(
    c1n: complex, dv: complex, d: float, r1n: float, r2n: float, violation_n: float,
    scale: float, S: float,
) -> RrrPair:  # fmt: skip
    """A finite RRR dyad that does not close: what the batch form keeps of it (the foot on
    the centre line for the placeholder, the violation in length units)."""
    dsafe = d if d > 0 else 1.0
    along = 0.0
    if d > 0:
        along = 0.5 * (d + ((r1n - r2n) / dsafe) * (r1n + r2n))
        along = nan_min(nan_max(along, -abs(r1n)), abs(r1n))  # NaN-propagating, as ops.clip
    violation = nan_min(nan_max(violation_n * (scale * S), 0.0), _FLOAT_MAX)
    return c1n, dv / dsafe, along, 0.0, S, 0.0, False, violation, True


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
    scale = nan_max(r, dist)
    ok = (violation <= tol * (scale if scale > 0 else 1.0)) and r > 0
    off = r - dist if r - dist > TOGGLE_BAND * scale else 0.0
    k = margin = 0.0
    if ok:
        k = sqrt(off) * sqrt(r + dist)
        margin = nan_min(nan_max(k / r, 0.0), 1.0)
    return p0, u, s0, k, margin, ok, nan_max(violation, 0.0)


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
    scale = nan_max(rho, ae)
    ok = rho > 0 and (violation <= tol * (scale if scale > 0 else 1.0))
    off = rho - ae if rho - ae > TOGGLE_BAND * scale else 0.0
    along, margin = 1.0, 0.0
    if ok:
        along = sqrt(off) * sqrt(rho + ae)
        margin = nan_min(nan_max(along / rho, 0.0), 1.0)
    beta = math.atan2(w.imag, w.real)
    return beta, along, (offset if ok else 0.0), margin, ok, nan_max(violation, 0.0)


def rpr_angle(pair: RprPair, sign: int) -> float:
    """The line direction (rad) of branch ``sign`` of an RPR dyad."""
    return pair[0] - math.atan2(pair[2], sign * pair[1])
