"""Closed-form dyad primitives, batched over (..., 2) arrays.

Each primitive returns the solved quantity, a ``margin`` (a normalised distance to the
singular configuration of that dyad: 1 is far, 0 is at the singularity), an ``ok`` mask and the
constraint ``violation`` (length units, > 0 means the dyad cannot close by that much).
Nothing returned is ever NaN or inf: where ``ok`` is False the values are finite placeholders.

Stability choices (why): heights come from Kahan's sorted-sides triangle area, which stays
accurate for needle-like triangles near tangency; angles come from atan2, never from the
tan-half-angle quotient (which divides by zero at theta = pi); tangency is clamped relative to
the dyad's own length scale so results are scale-invariant.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

#: Relative tolerance (of the dyad's length scale) within which a tangency still assembles.
TANGENCY_TOL = 1e-12


def perp(v: np.ndarray) -> np.ndarray:
    """Rotate (..., 2) vectors by +90 degrees."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the cross product of (..., 2) vectors."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _safe_unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.hypot(v[..., 0], v[..., 1])
    safe = np.where(n > 0, n, 1.0)
    return v / safe[..., None], n


def kahan_four_area(a, b, c):
    """Normalised Kahan area of the triangle with sides a, b, c (any order), batched.

    The sides are divided by ``scale``, the power of two just above the longest side: an exact
    operation (so the needle-triangle accuracy is kept) that makes every intermediate O(1), with
    no overflow for lengths near 1e300. Returns ``(four_area_n, violation_n, longest_n, scale)``:
    ``four_area_n = 4 * area / scale**2`` (0 when no triangle exists), ``violation_n`` =
    (longest - sum of the other two) / scale (> 0: no triangle) and ``longest_n`` = longest /
    scale, in [0.5, 1).
    """
    a, b, c = np.asarray(a, float), np.asarray(b, float), np.asarray(c, float)
    # sorted by a min/max network (exact, and cheaper than stacking and np.sort)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    big, small = np.maximum(hi, c), np.minimum(lo, c)
    mid = np.maximum(lo, np.minimum(hi, c))
    _, expo = np.frexp(np.where(np.isfinite(big), big, 1.0))
    scale = np.ldexp(1.0, expo)
    big, mid, small = big / scale, mid / scale, small / scale
    # The parenthesisation is the point: each factor is computed without cancellation when
    # big >= mid >= small (Kahan, "Miscalculating area and angles of a needle-like triangle").
    neg_factor = small - (big - mid)  # the only factor that can be negative
    # Square roots taken factor by factor: the plain product underflows for needle triangles
    # (a side of 1e-200 next to sides of 1 squares to 0).
    four_area_n = (
        np.sqrt(big + (mid + small))
        * np.sqrt(np.maximum(neg_factor, 0.0))
        * np.sqrt(small + (big - mid))
        * np.sqrt(big + (mid - small))
    )
    return four_area_n, -neg_factor, big, scale


class DyadSolution(NamedTuple):
    point: np.ndarray  # (..., 2) the solved point (finite fill where not ok)
    margin: np.ndarray  # (...) distance to the dyad's singularity, 1 far .. 0 at it
    ok: np.ndarray  # (...) bool, the dyad closes (within the tangency clamp)
    violation: np.ndarray  # (...) by how much it misses (length units, 0 when ok)
    height: np.ndarray  # (...) distance of the point from the centre line (length units)


def pow2_scale(m):
    """Per element the even power of two S = 4**k with m / S in [1, 4) (1 where m is 0,
    negative or not finite).  Dividing lengths by S is exact and commutes with square roots
    (sqrt(S) = 2**k), so a result formed from the normalised values and multiplied back by S is
    the one the unscaled formulas would give, except that no intermediate overflows (lengths
    near 1e308) or loses its digits to subnormals (5e-324)."""
    m = np.asarray(m, float)
    _, expo = np.frexp(np.where(np.isfinite(m) & (m > 0), m, 1.0))
    # m in [2**(expo-1), 2**expo); the even exponent 2 * floor((expo - 1) / 2) lies in
    # [-1074, 1022]: S itself neither overflows nor underflows
    return np.ldexp(1.0, ((expo - 1) >> 1) << 1)


def circle_circle(c1, r1, c2, r2, sign, tol: float = TANGENCY_TOL) -> DyadSolution:
    """Intersection X of circle (c1, r1) and circle (c2, r2) -- the RRR dyad.

    ``sign`` = +1 puts X to the left of the vector c1 -> c2 (counter-clockwise side), -1 to the
    right. The margin is |sin| of the angle at X between X-c1 and X-c2 (the dyad's transmission
    angle; 0 at the toggle). Where not ok the point is that of circle 1 nearest to circle 2 on
    the centre line (c1 itself when the centres coincide or that point is beyond the float
    range, zeros for non-finite input).  Centres and radii are first divided by a power of two
    (exact) that brings the largest to [1, 4): centres ~1e308 apart, whose distance overflows,
    and subnormal radii are solved like any other scale.  A solution point beyond the float
    range (centres near +-1.8e308) is not representable: ok is False there.
    """
    c1 = np.asarray(c1, float)
    c2 = np.asarray(c2, float)
    r1 = np.asarray(r1, float)
    r2 = np.asarray(r2, float)
    sgn = np.where(np.asarray(sign, float) < 0, -1.0, 1.0)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore', under='ignore'):
        big = np.maximum(
            np.maximum(np.max(np.abs(c1), axis=-1), np.max(np.abs(c2), axis=-1)),
            np.maximum(np.abs(r1), np.abs(r2)),
        )
        S = pow2_scale(big)
        c1n, c2n = c1 / S[..., None], c2 / S[..., None]
        r1n, r2n = r1 / S, r2 / S
        dx = c2n[..., 0] - c1n[..., 0]
        dy = c2n[..., 1] - c1n[..., 1]
        d = np.hypot(dx, dy)
        dx, dy, d, r1n, r2n, sgn, S = np.broadcast_arrays(dx, dy, d, r1n, r2n, sgn, S)
        finite = (
            np.isfinite(dx)
            & np.isfinite(dy)
            & np.isfinite(r1n)
            & np.isfinite(r2n)
            & np.all(np.isfinite(c1), axis=-1)
            & np.all(np.isfinite(c2), axis=-1)
        )
        four_area_n, violation_n, longest_n, scale = kahan_four_area(d, r1n, r2n)
        dn = d / scale  # 0 only if d == 0 or d / scale underflows
        ok = finite & (dn > 0) & (r1n > 0) & (r2n > 0) & (violation_n <= tol * longest_n)
        dsafe = np.where(d > 0, d, 1.0)
        ux, uy = dx / dsafe, dy / dsafe
        # foot of X on the centre line from c1; (r1 - r2)(r1 + r2) / d avoids the cancellation
        # of r1**2 - r2**2 and cannot overflow (|r1 - r2| / d <= 1 where the circles meet)
        along = 0.5 * (d + ((r1n - r2n) / dsafe) * (r1n + r2n))
        along = np.clip(along, -np.abs(r1n), np.abs(r1n))
        along = np.where(finite & (d > 0), along, 0.0)
        # h = 2 * area / d = (scale / 2) * four_area_n / dn: no overflow
        h = np.where(ok, 0.5 * scale * (four_area_n / np.where(dn > 0, dn, 1.0)), 0.0)
        px = (c1n[..., 0] + along * ux - sgn * h * uy) * S
        py = (c1n[..., 1] + along * uy + sgn * h * ux) * S
        # beyond the float range (only possible for centres near +-1.8e308): not representable
        inside = np.isfinite(px) & np.isfinite(py)
        ok &= inside
        px = np.where(finite, np.where(inside, px, c1[..., 0]), 0.0)
        py = np.where(finite, np.where(inside, py, c1[..., 1]), 0.0)
        # margin = h d / (r1 r2) = |sin| of the angle at X, formed without overflow
        margin = np.where(
            ok, (h / np.where(r1n > 0, r1n, 1.0)) * (d / np.where(r2n > 0, r2n, 1.0)), 0.0
        )
        h = np.where(ok, h * S, 0.0)  # h <= r1: no overflow
        violation = np.where(finite, np.maximum(violation_n * (scale * S), 0.0), np.inf)
    margin = np.clip(np.nan_to_num(margin), 0.0, 1.0)
    violation = np.where(ok, 0.0, np.nan_to_num(violation, posinf=np.finfo(float).max))
    return DyadSolution(np.stack([px, py], axis=-1), margin, ok, violation, h)


def circle_line(c, r, p0, u, sign, tol: float = TANGENCY_TOL):
    """Intersection X of circle (c, r) and the line p0 + s*u (|u| = 1) -- the RRP dyad.

    ``sign`` = +1 takes the intersection further along +u. Returns ``(X, margin, ok, violation)``;
    margin = half-chord / r (0 when the link is perpendicular to the line: a dead-centre).
    """
    c = np.asarray(c, float)
    p0 = np.asarray(p0, float)
    u = np.asarray(u, float)
    r = np.asarray(r, float)
    w = c - p0
    s0 = np.sum(w * u, axis=-1)
    dist = np.abs(cross2(u, w))
    violation = dist - r
    scale = np.maximum(r, dist)
    ok = (violation <= tol * np.where(scale > 0, scale, 1.0)) & (r > 0)
    # roots factor by factor: the product underflows / overflows for lengths near 1e-300 / 1e300
    k = np.where(ok, np.sqrt(np.maximum(r - dist, 0.0)) * np.sqrt(r + dist), 0.0)
    s = s0 + np.asarray(sign, float) * k
    x = p0 + s[..., None] * u
    margin = np.where(ok, np.clip(k / np.where(r > 0, r, 1.0), 0.0, 1.0), 0.0)
    return x, margin, ok, np.maximum(violation, 0.0)


def line_through_point(p, x, offset, sign, tol: float = TANGENCY_TOL):
    """Direction angle psi of a line, rigid with a body pivoting at p, that must pass through x.

    The line keeps the signed perpendicular distance ``offset`` = cross(dir, x - p) from the
    pivot (the RPR dyad: inverted slider-crank, or a cylinder's axis when offset = 0).
    ``sign`` = +1 chooses x ahead of the foot of p along the line's direction.
    Returns ``(psi, margin, ok, violation)``; margin = along-line component / |x - p|.
    """
    p = np.asarray(p, float)
    x = np.asarray(x, float)
    e = np.asarray(offset, float)
    w = x - p
    rho = np.hypot(w[..., 0], w[..., 1])
    ae = np.abs(e)
    violation = ae - rho
    scale = np.maximum(rho, ae)
    ok = (rho > 0) & (violation <= tol * np.where(scale > 0, scale, 1.0))
    along = np.where(ok, np.sqrt(np.maximum(rho - ae, 0.0)) * np.sqrt(rho + ae), 1.0)
    beta = np.arctan2(w[..., 1], w[..., 0])
    psi = beta - np.arctan2(np.where(ok, e, 0.0), np.asarray(sign, float) * along)
    margin = np.where(ok, np.clip(along / np.where(rho > 0, rho, 1.0), 0.0, 1.0), 0.0)
    return psi, margin, ok, np.maximum(violation, 0.0)


def rotation_between(v_ref, v_now):
    """Angle (rad) that rotates vector v_ref onto the direction of v_now (atan2 form)."""
    a, _ = _safe_unit(np.asarray(v_ref, float))  # unit first: products of 1e-300 underflow
    b, _ = _safe_unit(np.asarray(v_now, float))
    return np.arctan2(cross2(a, b), np.sum(a * b, axis=-1))


def rotate(v, phi):
    """Rotate (..., 2) vectors by phi (rad, broadcast over leading dims)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def wrap_angle(a: float) -> float:
    """Wrap one angle to (-pi, pi] by atan2 of its sine and cosine: exact argument reduction,
    so 1e6 rad or 1e300 rad keep full precision (a modulo by 2*pi would not). An angle already
    in range is returned as it is (exact, and the common case: three calls fewer)."""
    if -math.pi < a <= math.pi:
        return a
    return math.atan2(math.sin(a), math.cos(a))


# ---- scalar forms (Python complex numbers) ---------------------------------------------------
# One command at a time (the node's hot path) is ~20x faster in plain Python than in numpy on
# length-1 arrays. Same formulas as above; both candidates come back so a continuity choice
# costs one evaluation. test_solver_core checks these agree with the batched forms.


def circle_circle_pair(c1: complex, r1: float, c2: complex, r2: float, tol: float = TANGENCY_TOL):
    """RRR dyad on complex points: returns (foot, hvec, margin, ok, violation); the solutions are
    foot + hvec (sign +1, left of c1 -> c2) and foot - hvec."""
    dv = c2 - c1
    d = abs(dv)
    a, b, c = sorted((d, r1, r2), reverse=True)
    violation = max(d - (r1 + r2), abs(r1 - r2) - d)
    if not (d > 0 and r1 > 0 and r2 > 0 and violation <= tol * a and math.isfinite(a)):
        return c1, 0j, 0.0, False, max(violation, 0.0) if math.isfinite(violation) else 1e308
    # sides scaled by a power of two (exact) so nothing overflows or underflows; roots taken
    # factor by factor as in kahan_four_area
    scale = math.ldexp(1.0, math.frexp(a)[1])
    a, b, c = a / scale, b / scale, c / scale
    neg = c - (a - b)
    four_area_n = (
        math.sqrt(a + (b + c))
        * math.sqrt(max(neg, 0.0))
        * math.sqrt(c + (a - b))
        * math.sqrt(a + (b - c))
    )
    h = 0.5 * scale * (four_area_n / (d / scale))
    u = dv / d
    along = min(max(0.5 * (d + ((r1 - r2) / d) * (r1 + r2)), -r1), r1)
    margin = min(max((h / r1) * (d / r2), 0.0), 1.0)
    return c1 + along * u, 1j * h * u, margin, True, max(violation, 0.0)


def circle_line_pair(c: complex, r: float, p0: complex, u: complex, tol: float = TANGENCY_TOL):
    """RRP dyad on complex points (|u| = 1): returns (foot, kvec, margin, ok, violation); the
    solutions are foot + kvec (further along +u) and foot - kvec."""
    w = c - p0
    s0 = w.real * u.real + w.imag * u.imag
    dist = abs(u.real * w.imag - u.imag * w.real)
    violation = dist - r
    scale = max(r, dist)
    if not (r > 0 and violation <= tol * (scale if scale > 0 else 1.0)):
        return p0, 0j, 0.0, False, max(violation, 0.0)
    k = math.sqrt(max(r - dist, 0.0)) * math.sqrt(r + dist)  # no under/overflow at 1e+-300
    return p0 + s0 * u, k * u, min(max(k / r, 0.0), 1.0), True, max(violation, 0.0)


def line_through_pair(p: complex, x: complex, offset: float, tol: float = TANGENCY_TOL):
    """RPR dyad on complex points: returns (beta, along, margin, ok, violation); the line
    direction is psi = beta - atan2(offset, sign * along) for sign = +1 / -1."""
    w = x - p
    rho = abs(w)
    ae = abs(offset)
    violation = ae - rho
    scale = max(rho, ae)
    if not (rho > 0 and violation <= tol * (scale if scale > 0 else 1.0)):
        return 0.0, 1.0, 0.0, False, max(violation, 0.0)
    along = math.sqrt(max(rho - ae, 0.0)) * math.sqrt(rho + ae)
    return (
        math.atan2(w.imag, w.real),
        along,
        min(max(along / rho, 0.0), 1.0),
        True,
        max(violation, 0.0),
    )
