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


def circle_circle(c1, r1, c2, r2, sign, tol: float = TANGENCY_TOL):
    """Intersection X of circle (c1, r1) and circle (c2, r2) -- the RRR dyad.

    ``sign`` = +1 puts X to the left of the vector c1 -> c2 (counter-clockwise side), -1 to the right.
    Returns ``(X, margin, ok, violation)`` where margin = |sin| of the angle at X between X-c1 and
    X-c2 (the dyad's transmission angle; 0 at the toggle).
    """
    c1 = np.asarray(c1, float)
    c2 = np.asarray(c2, float)
    r1 = np.asarray(r1, float)
    r2 = np.asarray(r2, float)
    u, d = _safe_unit(c2 - c1)
    # Kahan: sides sorted a >= b >= c, area = sqrt((a+(b+c))(c-(a-b))(c+(a-b))(a+(b-c)))/4
    sides = np.sort(np.stack(np.broadcast_arrays(d, r1, r2), axis=-1), axis=-1)
    a, b, c = sides[..., 2], sides[..., 1], sides[..., 0]
    prod = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c))
    scale = a
    violation = np.maximum(d - (r1 + r2), np.abs(r1 - r2) - d)
    ok = (d > 0) & (violation <= tol * scale) & (r1 > 0) & (r2 > 0)
    dsafe = np.where(d > 0, d, 1.0)
    h = np.where(ok, np.sqrt(np.maximum(prod, 0.0)) / (2.0 * dsafe), 0.0)
    # distance from c1 to the foot of X on the centre line, written to avoid cancellation
    along = 0.5 * (d + (r1 - r2) * (r1 + r2) / dsafe)
    along = np.where(ok, np.clip(along, -r1, r1), 0.0)
    x = c1 + along[..., None] * u + (np.asarray(sign, float) * h)[..., None] * perp(u)
    denom = np.where(ok, r1 * r2, 1.0)
    margin = np.where(ok, np.clip(h * d / denom, 0.0, 1.0), 0.0)
    return x, margin, ok, np.maximum(violation, 0.0)


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
    k = np.where(ok, np.sqrt(np.maximum((r - dist) * (r + dist), 0.0)), 0.0)
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
    along = np.where(ok, np.sqrt(np.maximum((rho - ae) * (rho + ae), 0.0)), 1.0)
    beta = np.arctan2(w[..., 1], w[..., 0])
    psi = beta - np.arctan2(np.where(ok, e, 0.0), np.asarray(sign, float) * along)
    margin = np.where(ok, np.clip(along / np.where(rho > 0, rho, 1.0), 0.0, 1.0), 0.0)
    return psi, margin, ok, np.maximum(violation, 0.0)


def rotation_between(v_ref, v_now):
    """Angle (rad) that rotates vector v_ref onto the direction of v_now (atan2 form)."""
    return np.arctan2(cross2(v_ref, v_now), np.sum(v_ref * v_now, axis=-1))


def rotate(v, phi):
    """Rotate (..., 2) vectors by phi (rad, broadcast over leading dims)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def wrap_angle(a):
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a, float) + np.pi) % (2.0 * np.pi) - np.pi


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
    if not (d > 0 and r1 > 0 and r2 > 0 and violation <= tol * a):
        return c1, 0j, 0.0, False, max(violation, 0.0)
    prod = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c))
    h = math.sqrt(prod) / (2.0 * d) if prod > 0 else 0.0
    u = dv / d
    along = min(max(0.5 * (d + (r1 - r2) * (r1 + r2) / d), -r1), r1)
    margin = min(max(h * d / (r1 * r2), 0.0), 1.0)
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
    k2 = (r - dist) * (r + dist)
    k = math.sqrt(k2) if k2 > 0 else 0.0
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
    a2 = (rho - ae) * (rho + ae)
    along = math.sqrt(a2) if a2 > 0 else 0.0
    return math.atan2(w.imag, w.real), along, min(max(along / rho, 0.0), 1.0), True, \
        max(violation, 0.0)
