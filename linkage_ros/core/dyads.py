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

from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from .ops import BATCH, SCALAR, to_complex, to_xy

#: Relative tolerance (of the dyad's length scale) within which a tangency still assembles.
TANGENCY_TOL = 1e-12
#: Within this relative distance of a tangency on either side (a hair too long or a hair too
#: short: the rounding of the given lengths and of the arithmetic), a dyad lands exactly on it
#: (height 0), so an exact toggle comes out as one whichever way the last bits fell.
TOGGLE_BAND = 2.0**-52


def perp(v: np.ndarray) -> np.ndarray:
    """Rotate (..., 2) vectors by +90 degrees."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the cross product of (..., 2) vectors."""
    z: np.ndarray = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return z


def _safe_unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.hypot(v[..., 0], v[..., 1])
    safe = np.where(n > 0, n, 1.0)
    return v / safe[..., None], n


def kahan_four_area(
    a: npt.ArrayLike, b: npt.ArrayLike, c: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Normalised Kahan area of the triangle with sides a, b, c (any order), batched (numpy):
    :func:`kahan_four_area_of` on the array backend."""
    a, b, c = (np.asarray(v, float) for v in (a, b, c))
    return kahan_four_area_of(BATCH, a, b, c)


def kahan_four_area_of(ops: Any, a: Any, b: Any, c: Any) -> tuple[Any, Any, Any, Any]:
    """Normalised Kahan area of the triangle with sides a, b, c (any order), on ``ops``.

    The sides are divided by ``scale``, the power of two just above the longest side: an exact
    operation (so the needle-triangle accuracy is kept) that makes every intermediate O(1), with
    no overflow for lengths near 1e300. Returns ``(four_area_n, violation_n, longest_n, scale)``:
    ``four_area_n = 4 * area / scale**2`` (0 when no triangle exists), ``violation_n`` =
    (longest - sum of the other two) / scale (> 0: no triangle) and ``longest_n`` = longest /
    scale, in [0.5, 1).
    """
    # sorted by a min/max network (exact, and cheaper than stacking and sorting)
    lo, hi = ops.minimum(a, b), ops.maximum(a, b)
    big, small = ops.maximum(hi, c), ops.minimum(lo, c)
    mid = ops.maximum(lo, ops.minimum(hi, c))
    _, expo = ops.frexp(ops.where(ops.isfinite(big), big, 1.0))
    scale = ops.ldexp(1.0, expo)
    big, mid, small = big / scale, mid / scale, small / scale
    # The parenthesisation is the point: each factor is computed without cancellation when
    # big >= mid >= small (Kahan, "Miscalculating area and angles of a needle-like triangle").
    neg_factor = small - (big - mid)  # the only factor that can be negative
    # Square roots taken factor by factor: the plain product underflows for needle triangles
    # (a side of 1e-200 next to sides of 1 squares to 0).
    four_area_n = (
        ops.sqrt(big + (mid + small))
        * ops.sqrt(ops.maximum(neg_factor, 0.0))
        * ops.sqrt(small + (big - mid))
        * ops.sqrt(big + (mid - small))
    )
    return four_area_n, -neg_factor, big, scale


class DyadSolution(NamedTuple):
    point: np.ndarray  # (..., 2) the solved point (finite fill where not ok)
    margin: np.ndarray  # (...) distance to the dyad's singularity, 1 far .. 0 at it
    ok: np.ndarray  # (...) bool, the dyad closes (within the tangency clamp)
    violation: np.ndarray  # (...) by how much it misses (length units, 0 when ok)
    height: np.ndarray  # (...) distance of the point from the centre line (length units)


def pow2_scale(m: npt.ArrayLike) -> np.ndarray:
    """Per element the even power of two S = 4**k with m / S in [1, 4) (see ops): numpy."""
    scale: np.ndarray = BATCH.pow2_scale(m)
    return scale


class DyadPair(NamedTuple):
    """Both solutions of a dyad, on either backend (points complex): the solution of branch
    sign s is ``(base + (along + s * spread) * direction) * scale`` (see :func:`dyad_point`).
    ``scale`` is a power of two (exact); ``fallback`` is the finite placeholder point where the
    dyad does not close."""

    base: Any
    direction: Any
    along: Any
    spread: Any
    scale: Any
    margin: Any  # distance to the dyad's singularity, 1 far .. 0 at it
    ok: Any  # the dyad closes (within the tangency clamp)
    violation: Any  # by how much it misses (length units, 0 when ok)
    height: Any  # distance of the solutions from the centre line (length units)
    fallback: Any


def dyad_point(ops: Any, pair: DyadPair, sign: Any) -> tuple[Any, Any]:
    """The solution of branch ``sign`` (+1 / -1) of a dyad and its ok mask: a point beyond the
    float range (centres near +-1.8e308) is not representable, so it is not ok, and where the
    dyad does not close the point is ``pair.fallback``."""
    z = (pair.base + (pair.along + sign * pair.spread) * pair.direction) * pair.scale
    inside = ops.isfinite(z)
    ok = pair.ok & inside
    if ops.batch and np.all(ok):  # no placeholder to put in: skip the where pass
        return z, ok
    return ops.where(ok, z, pair.fallback), ok


def solve_rrr_dyad(
    ops: Any, c1: Any, r1: Any, c2: Any, r2: Any, tol: float = TANGENCY_TOL
) -> DyadPair:
    """Intersections of circle (c1, r1) and circle (c2, r2), centres complex -- the RRR dyad.

    Branch sign +1 puts the point to the left of the vector c1 -> c2 (counter-clockwise side),
    -1 to the right. The margin is |sin| of the angle at the point between X-c1 and X-c2 (the
    dyad's transmission angle; 0 at the toggle). Centres and radii are first divided by a power
    of two (exact) that brings the largest to [1, 4): centres ~1e308 apart, whose distance
    overflows, and subnormal radii are solved like any other scale. Where the dyad does not
    close, the placeholder is the point of circle 1 nearest to circle 2 on the centre line
    (c1 itself when the centres coincide or that point is beyond the float range, 0 for
    non-finite input). Returns a :class:`DyadPair`.
    """
    big = ops.maximum(ops.maximum(ops.cmax(c1), ops.cmax(c2)), ops.maximum(abs(r1), abs(r2)))
    S = ops.pow2_scale(big)
    c1n, c2n = c1 / S, c2 / S
    r1n, r2n = r1 / S, r2 / S
    dv = c2n - c1n
    d = abs(dv)  # hypot: no overflow
    finite = (
        ops.isfinite(dv)
        & ops.isfinite(r1n)
        & ops.isfinite(r2n)
        & ops.isfinite(c1)
        & ops.isfinite(c2)
    )
    four_area_n, violation_n, longest_n, scale = kahan_four_area_of(
        ops, ops.where(finite, d, 0.0), ops.where(finite, r1n, 0.0), ops.where(finite, r2n, 0.0)
    )
    dn = d / scale  # 0 only if d == 0 or d / scale underflows
    ok = finite & (dn > 0) & (r1n > 0) & (r2n > 0) & (violation_n <= tol * longest_n)
    dsafe = ops.where(finite & (d > 0), d, 1.0)
    u = ops.where(finite, dv, 0.0) / dsafe
    # foot of the solutions on the centre line from c1; (r1 - r2)(r1 + r2) / d avoids the
    # cancellation of r1**2 - r2**2 and cannot overflow (|r1 - r2| / d <= 1 where they meet)
    along = 0.5 * (d + ((r1n - r2n) / dsafe) * (r1n + r2n))
    along = ops.clip(along, -abs(r1n), abs(r1n))
    along = ops.where(finite & (d > 0), along, 0.0)
    # h = 2 * area / d = (scale / 2) * four_area_n / dn: no overflow; 0 within the toggle band
    # (not where the smallest side is the whole of that distance: nearly coincident circles,
    # a needle whose height is not small at all)
    smallest_n = ops.minimum(ops.minimum(dn, r1n / scale), r2n / scale)
    on_toggle = (violation_n >= -TOGGLE_BAND * longest_n) & (-violation_n < 0.5 * smallest_n)
    h = ops.where(
        ok & ops.not_(on_toggle), 0.5 * scale * (four_area_n / ops.where(dn > 0, dn, 1.0)), 0.0
    )
    # margin = h d / (r1 r2) = |sin| of the angle at the solution, formed without overflow
    margin = ops.where(
        ok, (h / ops.where(r1n > 0, r1n, 1.0)) * (d / ops.where(r2n > 0, r2n, 1.0)), 0.0
    )
    margin = ops.clip(ops.where(margin == margin, margin, 0.0), 0.0, 1.0)
    violation = ops.where(finite, ops.maximum(violation_n * (scale * S), 0.0), _FLOAT_MAX)
    violation = ops.where(ok, 0.0, ops.minimum(violation, _FLOAT_MAX))
    # the not-ok placeholder: circle 1's point nearest circle 2 (c1 if not representable)
    near = (c1n + along * u) * S
    fallback = ops.where(finite, ops.where(ops.isfinite(near), near, c1), 0j)
    return DyadPair(
        ops.where(finite, c1n, 0j),
        u,
        along,
        ops.cplx(0.0 * h, h),
        S,
        margin,
        ok,
        violation,
        ops.where(ok, h * S, 0.0),
        fallback,
    )


_FLOAT_MAX = float(np.finfo(float).max)


def circle_circle(
    c1: npt.ArrayLike,
    r1: npt.ArrayLike,
    c2: npt.ArrayLike,
    r2: npt.ArrayLike,
    sign: npt.ArrayLike,
    tol: float = TANGENCY_TOL,
) -> DyadSolution:
    """:func:`solve_rrr_dyad` on (..., 2) coordinate arrays for one branch ``sign``: the batched
    numpy form (points as (..., 2) arrays; ``sign`` broadcasts)."""
    with np.errstate(invalid='ignore', divide='ignore', over='ignore', under='ignore'):
        c1, c2 = np.asarray(c1, float), np.asarray(c2, float)
        r1a, r2a = np.asarray(r1, float), np.asarray(r2, float)
        sgn = np.where(np.asarray(sign, float) < 0, -1.0, 1.0)
        shape = np.broadcast_shapes(c1.shape[:-1], c2.shape[:-1], r1a.shape, r2a.shape, sgn.shape)
        c1z = to_complex(np.broadcast_to(c1, shape + (2,)))
        c2z = to_complex(np.broadcast_to(c2, shape + (2,)))
        r1a, r2a, sgn = (np.broadcast_to(a, shape) for a in (r1a, r2a, sgn))
        pair = solve_rrr_dyad(BATCH, c1z, r1a, c2z, r2a, tol)
        z, ok = dyad_point(BATCH, pair, sgn)
    return DyadSolution(
        to_xy(z),
        np.where(ok, pair.margin, 0.0),
        np.asarray(ok),
        np.asarray(np.where(ok, 0.0, pair.violation)),
        np.where(ok, pair.height, 0.0),
    )


def solve_rrp_dyad(
    ops: Any, c: Any, r: Any, p0: Any, u: Any, tol: float = TANGENCY_TOL
) -> DyadPair:
    """Intersections of circle (c, r) and the line p0 + s u (|u| = 1), points complex -- the RRP
    dyad. Branch sign +1 takes the intersection further along +u. margin = half-chord / r (0
    when the link is perpendicular to the line: a dead-centre). Returns a :class:`DyadPair`."""
    w = c - p0
    s0 = w.real * u.real + w.imag * u.imag
    dist = abs(u.real * w.imag - u.imag * w.real)
    violation = dist - r
    scale = ops.maximum(r, dist)
    ok = (violation <= tol * ops.where(scale > 0, scale, 1.0)) & (r > 0)
    # roots factor by factor: the product underflows / overflows for lengths near 1e-300 / 1e300;
    # 0 within the toggle band (a dead centre whichever way the last bits fell)
    off = ops.where(r - dist > TOGGLE_BAND * scale, r - dist, 0.0)
    k = ops.where(ok, ops.sqrt(off) * ops.sqrt(r + dist), 0.0)
    margin = ops.where(ok, ops.clip(k / ops.where(r > 0, r, 1.0), 0.0, 1.0), 0.0)
    return DyadPair(p0, u, s0, k, 1.0, margin, ok, ops.maximum(violation, 0.0), k, p0 + s0 * u)


def circle_line(
    c: npt.ArrayLike,
    r: npt.ArrayLike,
    p0: npt.ArrayLike,
    u: npt.ArrayLike,
    sign: npt.ArrayLike,
    tol: float = TANGENCY_TOL,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`solve_rrp_dyad` on (..., 2) coordinate arrays for one branch ``sign``. Returns
    ``(X, margin, ok, violation)``."""
    with np.errstate(invalid='ignore', over='ignore', under='ignore'):
        cz, pz, uz = to_complex(c), to_complex(p0), to_complex(u)
        r = np.asarray(r, float)
        pair = solve_rrp_dyad(BATCH, cz, r, pz, uz, tol)
        z = pair.base + (pair.along + np.asarray(sign, float) * pair.spread) * pair.direction
    return to_xy(z), pair.margin, pair.ok, pair.violation


class RprDyad(NamedTuple):
    """A line through a known point x, rigid with a body pivoting at p (the RPR dyad): its
    direction for branch sign s is ``beta - atan2(offset, s * along)``."""

    beta: Any
    along: Any
    offset: Any
    margin: Any
    ok: Any
    violation: Any


def solve_rpr_dyad(ops: Any, p: Any, x: Any, offset: Any, tol: float = TANGENCY_TOL) -> RprDyad:
    """Direction of a line, rigid with a body pivoting at p (complex), that must pass through x
    (complex) while keeping the signed perpendicular distance ``offset`` = cross(dir, x - p) from
    the pivot (inverted slider-crank, or a cylinder's axis when offset = 0). Sign +1 chooses x
    ahead of the foot of p along the line's direction. margin = along-line component / |x - p|.
    """
    w = x - p
    rho = abs(w)
    ae = abs(offset)
    violation = ae - rho
    scale = ops.maximum(rho, ae)
    ok = (rho > 0) & (violation <= tol * ops.where(scale > 0, scale, 1.0))
    # 0 within the toggle band (the line through the pivot's foot whichever way the bits fell)
    off = ops.where(rho - ae > TOGGLE_BAND * scale, rho - ae, 0.0)
    along = ops.where(ok, ops.sqrt(off) * ops.sqrt(rho + ae), 1.0)
    beta = ops.atan2(w.imag, w.real)
    margin = ops.where(ok, ops.clip(along / ops.where(rho > 0, rho, 1.0), 0.0, 1.0), 0.0)
    return RprDyad(beta, along, ops.where(ok, offset, 0.0), margin, ok, ops.maximum(violation, 0.0))


def rpr_direction(ops: Any, dyad: RprDyad, sign: Any) -> Any:
    """The line direction (rad) of branch ``sign`` of an RPR dyad."""
    return dyad.beta - ops.atan2(dyad.offset, sign * dyad.along)


def line_through_point(
    p: npt.ArrayLike,
    x: npt.ArrayLike,
    offset: npt.ArrayLike,
    sign: npt.ArrayLike,
    tol: float = TANGENCY_TOL,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`solve_rpr_dyad` on (..., 2) coordinate arrays for one branch ``sign``. Returns
    ``(psi, margin, ok, violation)``."""
    with np.errstate(invalid='ignore', over='ignore', under='ignore'):
        dyad = solve_rpr_dyad(BATCH, to_complex(p), to_complex(x), np.asarray(offset, float), tol)
        psi = rpr_direction(BATCH, dyad, np.asarray(sign, float))
    return psi, dyad.margin, dyad.ok, dyad.violation


# ---- which side: the branch sign of a dyad, read off positions -----------------------------


def unit_vector(ops: Any, z: Any) -> Any:
    """z / |z| (hypot: no overflow at 1e200; a zero vector stays 0)."""
    r = ops.cabs(z)
    return z / ops.where(r > 0, r, 1.0)


def circle_side(ops: Any, c1: Any, c2: Any, x: Any, unit_c1_x: Any = None) -> Any:
    """Which side of the line c1 -> c2 the point x lies (complex points): the cross product of
    the unit vectors c1 -> c2 and c1 -> x, > 0 on the left (an RRR dyad's branch +1).
    ``unit_c1_x``: ``unit_vector(ops, x - c1)`` where the caller has it already."""
    ab = unit_vector(ops, c2 - c1)  # units: products of 1e200 overflow
    ax = unit_vector(ops, x - c1) if unit_c1_x is None else unit_c1_x
    return ab.real * ax.imag - ab.imag * ax.real


def line_side(ops: Any, anchor: Any, x: Any, u: Any) -> Any:
    """How far along the direction u (unit, complex) x lies from ``anchor``: the dot product
    of u and the unit vector anchor -> x, > 0 ahead (an RRP/RPR dyad's branch +1)."""
    v = unit_vector(ops, x - anchor)
    return v.real * u.real + v.imag * u.imag


def side_sign(side: float) -> int:
    """The branch sign of a side (+1 where side >= 0: a point on the line takes +1)."""
    return 1 if side >= 0 else -1


def rotation_between(v_ref: npt.ArrayLike, v_now: npt.ArrayLike) -> np.ndarray:
    """Angle (rad) that rotates vector v_ref onto the direction of v_now (atan2 form)."""
    a, _ = _safe_unit(np.asarray(v_ref, float))  # unit first: products of 1e-300 underflow
    b, _ = _safe_unit(np.asarray(v_now, float))
    angle: np.ndarray = np.arctan2(cross2(a, b), np.sum(a * b, axis=-1))
    return angle


def rotate(v: np.ndarray, phi: npt.ArrayLike) -> np.ndarray:
    """Rotate (..., 2) vectors by phi (rad, broadcast over leading dims)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def wrap_angle(a: float) -> float:
    """Wrap one angle to (-pi, pi] (see ops.ScalarOps.wrap)."""
    return SCALAR.wrap(a)
