"""Closed-form position analysis of the planar 4R four-bar and the offset slider-crank.

Conventions (lengths in any consistent unit, angles in radians, counter-clockwise from +x):

* Four-bar O2-A-B-O4: ground pivot O2 at the origin, O4 at (l1, 0).  Crank l2 = |O2A| at
  ``theta2``, coupler l3 = |AB| at ``theta3``, rocker l4 = |O4B| at ``theta4``.
* Slider-crank: crank r = |O2A| at ``theta2``, rod l = |AB| at ``theta3``; the slider pin B moves
  on the line y = e (offset ``e``, sliding along +x); the slider position is x = B_x.

Every function is vectorised (numpy broadcasting over all arguments) and never returns NaN or
inf: where a configuration cannot be assembled ``ok`` is False and finite placeholders are
returned (angles 0).  Scalar inputs give 0-d numpy scalars.

Why the formulation looks the way it does:

* Positions come from intersecting two circles with the triangle height taken from Kahan's
  sorted-sides area formula, which stays accurate for needle-like triangles (near toggle /
  tangency) where the textbook ``sqrt(r1**2 - a**2)`` loses half of its digits.
* Angles come from ``atan2`` of position differences, never from the tan-half-angle quotient of
  the Freudenstein equation, which divides by zero when an angle reaches pi.
* Tangency is accepted within a tolerance *relative to the length scale of the triangle*, so
  results do not change when every length is multiplied by the same factor.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .dyads import TANGENCY_TOL, circle_circle, kahan_four_area


# Residual reported for non-finite inputs, where no misclosure can be measured: one full
# link length, i.e. "completely wrong", while keeping every output finite.
_NONFINITE_RESIDUAL = 1.0


class FourBarSolution(NamedTuple):
    """Result of :func:`fourbar_forward` (arrays broadcast from the inputs)."""

    theta3: np.ndarray           #: coupler angle [rad], in (-pi, pi]; 0 where not ok
    theta4: np.ndarray           #: rocker angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray               #: bool, the linkage assembles at this input
    #: |sin(mu)|, mu = angle at B between coupler and rocker; 0 where not ok
    transmission_sin: np.ndarray
    residual: np.ndarray         #: loop-closure error / longest link [-]


class FourBarInverseSolution(NamedTuple):
    """Result of :func:`fourbar_inverse`."""

    theta2: np.ndarray           #: crank angle [rad], in (-pi, pi]; 0 where not ok
    theta3: np.ndarray           #: coupler angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray               #: bool
    transmission_sin: np.ndarray  #: |sin(mu)| at B (coupler vs rocker); 0 where not ok
    residual: np.ndarray         #: loop-closure error / longest link [-]


class SliderCrankSolution(NamedTuple):
    """Result of :func:`slider_crank_forward`."""

    #: slider position B_x [length]; A_x (foot of A on the slide line) where not ok
    x: np.ndarray
    theta3: np.ndarray           #: rod angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray               #: bool
    residual: np.ndarray         #: loop-closure error / max(r, l, |e|) [-]


class SliderCrankInverseSolution(NamedTuple):
    """Result of :func:`slider_crank_inverse`."""

    theta2: np.ndarray           #: crank angle [rad], in (-pi, pi]; 0 where not ok
    theta3: np.ndarray           #: rod angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray               #: bool
    residual: np.ndarray         #: loop-closure error / max(r, l, |e|) [-]


# --------------------------------------------------------------------------- helpers

def _f(x) -> np.ndarray:
    return np.asarray(x, dtype=float)


def _out(x: np.ndarray):
    """Turn 0-d arrays into numpy scalars so scalar calls give scalar-like results."""
    return x[()] if isinstance(x, np.ndarray) and x.ndim == 0 else x


def _sign(s) -> np.ndarray:
    """Branch / sign argument -> exactly +1.0 or -1.0 (negative means -1, anything else +1)."""
    return np.where(_f(s) < 0, -1.0, 1.0)


def triangle_area(a, b, c) -> np.ndarray:
    """Area [length^2] of the triangle with sides a, b, c [length], by Kahan's stable formula.

    Side lengths that violate the triangle inequality (no triangle) give 0, so callers that care
    must check the inequality themselves (:func:`circle_intersection` does).
    """
    with np.errstate(invalid='ignore', over='ignore'):
        four_area_n, _, _, scale = kahan_four_area(a, b, c)
        return _out(0.25 * four_area_n * scale * scale)


def angle_opposite(side_a, side_b, opposite) -> np.ndarray:
    """Angle [rad, 0..pi] between sides a and b of a triangle, opposite the third side.

    Computed as atan2(4*area, a^2 + b^2 - opposite^2) on sides normalised by the longest (= the
    cosine rule, but accurate near 0 and pi where arccos loses half of its digits).
    Out-of-range sides give 0 or pi, i.e. the clipped cosine rule.
    """
    a, b, c = np.broadcast_arrays(_f(side_a), _f(side_b), _f(opposite))
    with np.errstate(invalid='ignore'):
        four_area_n, _, _, scale = kahan_four_area(a, b, c)
        an, bn, cn = a / scale, b / scale, c / scale
        return _out(np.arctan2(four_area_n, (an * an + bn * bn) - cn * cn))


# --------------------------------------------------------------------------- circle-circle

def circle_intersection(c1, r1, c2, r2, sign, tangency_tol: float = TANGENCY_TOL):
    """Intersection point of circle (c1, r1) and circle (c2, r2), batched.

    Parameters
    ----------
    c1, c2 : array (..., 2)
        Centres [length].
    r1, r2 : array (...)
        Radii [length], must be >= 0.
    sign : array (...)
        +1 puts the point to the LEFT of the vector c1 -> c2 (counter-clockwise side), -1 to the
        right (any negative value means -1).
    tangency_tol : float
        A triangle inequality between (d, r1, r2), d = |c2 - c1|, violated by at most
        ``tangency_tol * max(d, r1, r2)`` is treated as exact tangency (height 0, ok True).

    Returns
    -------
    point : array (..., 2)
        The intersection [length].  Where not ok it is the point of circle 1 on the centre line
        that is closest to circle 2 (``c1`` itself when d == 0, zeros for non-finite input).
    height : array (...)
        Distance of the point from the centre line [length] (0 at tangency and where not ok).
    ok : bool array (...)
        The circles intersect (within the tangency clamp).  d == 0 (concentric) is never ok: the
        intersection is then either empty or a whole circle.
    """
    sol = circle_circle(c1, r1, c2, r2, _sign(sign), tangency_tol)
    return sol.point, _out(sol.height), _out(sol.ok)


# --------------------------------------------------------------------------- four-bar

def _closure_residual(l1, l2, l3, l4, t2, t3, t4) -> np.ndarray:
    """|O2A + AB - O2O4 - O4B| / longest link, from angles."""
    rx = l2 * np.cos(t2) + l3 * np.cos(t3) - l1 - l4 * np.cos(t4)
    ry = l2 * np.sin(t2) + l3 * np.sin(t3) - l4 * np.sin(t4)
    scale = np.maximum(np.maximum(np.abs(l1), np.abs(l2)), np.maximum(np.abs(l3), np.abs(l4)))
    return np.hypot(rx, ry) / np.where(scale > 0, scale, 1.0)


def _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4) -> np.ndarray:
    """|sin| of the angle at B between B->A (coupler) and B->O4 (rocker)."""
    # normalise before multiplying so huge lengths cannot overflow the cross product
    s3 = np.where(l3 > 0, l3, 1.0)
    s4 = np.where(l4 > 0, l4, 1.0)
    cross = ((ax - bx) / s3) * ((o4y - by) / s4) - ((ay - by) / s3) * ((o4x - bx) / s4)
    return np.clip(np.abs(cross), 0.0, 1.0)


def _finish(values, ok, finite, residual):
    """Zero the placeholders where not ok and make the residual finite."""
    vals = [np.where(ok, v, 0.0) for v in values]
    res = np.where(finite & np.isfinite(residual), residual, _NONFINITE_RESIDUAL)
    return vals, res


def fourbar_forward(l1, l2, l3, l4, theta2, branch=1, tangency_tol: float = TANGENCY_TOL):
    """Four-bar position analysis: crank angle -> coupler and rocker angles.

    Parameters
    ----------
    l1, l2, l3, l4 : array_like
        Ground, crank, coupler, rocker lengths [length], >= 0.
    theta2 : array_like
        Crank angle [rad].
    branch : array_like of +-1
        Assembly: B is the intersection of circle (A, l3) and circle (O4, l4) to the left (+1) or
        right (-1) of the vector A -> O4.  For 0 < theta2 < pi, +1 puts B and O2 on opposite
        sides of the diagonal A-O4 (the usual "open" assembly).  A fixed branch follows one
        circuit continuously as long as no toggle (coupler and rocker collinear) is crossed.
    tangency_tol : float
        Relative tangency clamp, see :func:`circle_intersection`.

    Returns
    -------
    FourBarSolution(theta3, theta4, ok, transmission_sin, residual)
        Angles in (-pi, pi].  ``transmission_sin`` = |sin(mu)|, mu the transmission angle at B.
        ``residual`` = |O2A + AB - O2O4 - O4B| / longest link.  Where not ok, angles and
        transmission_sin are 0 and the residual is the misclosure of the closest-approach
        configuration (about the gap between the two circles / longest link, so > 0).
    """
    l1, l2, l3, l4, t2, br = np.broadcast_arrays(_f(l1), _f(l2), _f(l3), _f(l4), _f(theta2),
                                                 _sign(branch))
    with np.errstate(invalid='ignore', over='ignore'):
        finite = (np.isfinite(l1) & np.isfinite(l2) & np.isfinite(l3) & np.isfinite(l4)
                  & np.isfinite(t2))
        ax, ay = l2 * np.cos(t2), l2 * np.sin(t2)
        o4x, o4y = l1, np.zeros_like(l1)
        b, _, ok = circle_intersection(np.stack([ax, ay], -1), l3, np.stack([o4x, o4y], -1),
                                       l4, br, tangency_tol)
        ok = np.asarray(ok) & finite & (l1 >= 0) & (l2 >= 0)
        bx, by = b[..., 0], b[..., 1]
        t3 = np.arctan2(by - ay, bx - ax)
        t4 = np.arctan2(by - o4y, bx - o4x)
        tsin = _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4)
        residual = _closure_residual(l1, l2, l3, l4, t2, t3, t4)
    (t3, t4, tsin), residual = _finish((t3, t4, tsin), ok, finite, residual)
    return FourBarSolution(_out(t3), _out(t4), _out(ok), _out(tsin), _out(residual))


def fourbar_inverse(l1, l2, l3, l4, theta4, branch=1, tangency_tol: float = TANGENCY_TOL):
    """Four-bar inverse position analysis: rocker angle -> crank and coupler angles.

    B = O4 + l4*(cos theta4, sin theta4); A is the intersection of circle (B, l3) and circle
    (O2, l2) to the left (``branch`` = +1) or right (-1) of the vector B -> O2.

    Returns
    -------
    FourBarInverseSolution(theta2, theta3, ok, transmission_sin, residual)
        Same conventions as :func:`fourbar_forward` (transmission angle still taken at B,
        between coupler and rocker).
    """
    l1, l2, l3, l4, t4, br = np.broadcast_arrays(_f(l1), _f(l2), _f(l3), _f(l4), _f(theta4),
                                                 _sign(branch))
    with np.errstate(invalid='ignore', over='ignore'):
        finite = (np.isfinite(l1) & np.isfinite(l2) & np.isfinite(l3) & np.isfinite(l4)
                  & np.isfinite(t4))
        o4x, o4y = l1, np.zeros_like(l1)
        bx, by = o4x + l4 * np.cos(t4), o4y + l4 * np.sin(t4)
        a, _, ok = circle_intersection(np.stack([bx, by], -1), l3,
                                       np.zeros(bx.shape + (2,)), l2, br, tangency_tol)
        ok = np.asarray(ok) & finite & (l1 >= 0) & (l4 >= 0)
        ax, ay = a[..., 0], a[..., 1]
        t2 = np.arctan2(ay, ax)
        t3 = np.arctan2(by - ay, bx - ax)
        tsin = _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4)
        residual = _closure_residual(l1, l2, l3, l4, t2, t3, t4)
    (t2, t3, tsin), residual = _finish((t2, t3, tsin), ok, finite, residual)
    return FourBarInverseSolution(_out(t2), _out(t3), _out(ok), _out(tsin), _out(residual))


# --------------------------------------------------------------------------- slider-crank

def _slider_residual(r, l, e, t2, t3, x) -> np.ndarray:
    """|O2A + AB - (x, e)| / max(r, l, |e|)."""
    rx = r * np.cos(t2) + l * np.cos(t3) - x
    ry = r * np.sin(t2) + l * np.sin(t3) - e
    scale = np.maximum(np.maximum(np.abs(r), np.abs(l)), np.abs(e))
    return np.hypot(rx, ry) / np.where(scale > 0, scale, 1.0)


def slider_crank_forward(r, l, e, theta2, branch=1, tangency_tol: float = TANGENCY_TOL):
    """Offset slider-crank position analysis: crank angle -> slider position and rod angle.

    Parameters
    ----------
    r, l : array_like
        Crank and rod lengths [length], >= 0.
    e : array_like
        Offset of the slide line y = e [length] (signed).
    theta2 : array_like
        Crank angle [rad].
    branch : array_like of +-1
        +1: the solution with the larger x (B ahead of A along +x); -1: the smaller x.
    tangency_tol : float
        A rod that misses the slide line by at most ``tangency_tol * max(r, l, |e|)`` is taken
        as exactly perpendicular to it (dead-centre-like tangency, ok True).

    Returns
    -------
    SliderCrankSolution(x, theta3, ok, residual)
        x = B_x [length], theta3 in (-pi, pi].  Where not ok: x = A_x (the foot of A on the
        slide line), theta3 = 0 and the residual is the misclosure of the closest-approach
        configuration (rod pointing at the line).
    """
    r, l, e, t2, br = np.broadcast_arrays(_f(r), _f(l), _f(e), _f(theta2), _sign(branch))
    with np.errstate(invalid='ignore', over='ignore'):
        finite = np.isfinite(r) & np.isfinite(l) & np.isfinite(e) & np.isfinite(t2)
        ax, ay = r * np.cos(t2), r * np.sin(t2)
        dy = e - ay
        ady = np.abs(dy)
        gap = l - ady  # > 0: the rod reaches the line; factored to avoid l**2 - dy**2 cancellation
        scale = np.maximum(np.maximum(np.abs(r), np.abs(l)), np.abs(e))
        ok = finite & (r >= 0) & (l >= 0) & (gap >= -tangency_tol * scale)
        # |B_x - A_x| = sqrt((l - |dy|)(l + |dy|)), rooted factor by factor (no overflow)
        half = np.where(ok & (gap > 0), np.sqrt(np.maximum(gap, 0.0)) * np.sqrt(l + ady), 0.0)
        x = np.where(ok, ax + br * half, ax)
        # closest approach when not ok: rod pointing straight at the line (angle +-pi/2)
        t3 = np.where(ok, np.arctan2(dy, br * half), np.arctan2(dy, 0.0))
        residual = _slider_residual(r, l, e, t2, t3, x)
    (t3,), residual = _finish((t3,), ok, finite, residual)
    x = np.where(finite, x, 0.0)
    return SliderCrankSolution(_out(x), _out(t3), _out(ok), _out(residual))


def slider_crank_inverse(r, l, e, x, branch=1, tangency_tol: float = TANGENCY_TOL):
    """Offset slider-crank inverse: slider position -> crank and rod angles.

    A is the intersection of circle (O2, r) and circle (B = (x, e), l), taken with
    :func:`circle_intersection` (c1 = O2, c2 = B, sign = ``branch``): branch +1 puts the crank
    pin A to the LEFT of the vector O2 -> B (counter-clockwise from it), -1 to the right.  For
    e = 0 and x > 0 that is theta2 in (0, pi) for +1 and (-pi, 0) for -1.

    Returns
    -------
    SliderCrankInverseSolution(theta2, theta3, ok, residual)
        Angles in (-pi, pi], 0 where not ok; residual as in :func:`slider_crank_forward`.
    """
    r, l, e, x, br = np.broadcast_arrays(_f(r), _f(l), _f(e), _f(x), _sign(branch))
    with np.errstate(invalid='ignore', over='ignore'):
        finite = np.isfinite(r) & np.isfinite(l) & np.isfinite(e) & np.isfinite(x)
        a, _, ok = circle_intersection(np.zeros(x.shape + (2,)), r, np.stack([x, e], -1), l, br,
                                       tangency_tol)
        ok = np.asarray(ok) & finite
        ax, ay = a[..., 0], a[..., 1]
        t2 = np.arctan2(ay, ax)
        t3 = np.arctan2(e - ay, x - ax)
        residual = _slider_residual(r, l, e, t2, t3, x)
    (t2, t3), residual = _finish((t2, t3), ok, finite, residual)
    return SliderCrankInverseSolution(_out(t2), _out(t3), _out(ok), _out(residual))


def slider_crank_stroke(r: float, l: float, e: float) -> tuple[float, float]:
    """Extreme slider positions (x_min, x_max) [length] of branch +1.

    When the crank rotates fully (|e| + r <= l) these are the two dead-centre positions:
    x_max = sqrt((l + r)^2 - e^2) (crank and rod extended in line) and
    x_min = sqrt((l - r)^2 - e^2) (folded in line).

    Otherwise the crank only rocks, and the returned pair is the smallest and largest x that
    branch +1 reaches over all assemblable crank angles.  Candidates are the in-line positions
    that belong to branch +1 and the limits of assembly (rod perpendicular to the slide line,
    x = A_x).  Note that the reachable set may then be two disjoint pieces (e.g. e = 0, r > l:
    [-sqrt(r^2-l^2), l-r] and [sqrt(r^2-l^2), r+l]); this returns their hull.

    Raises ValueError if no crank angle assembles (r + l < |e|) or a length is negative.
    """
    r, l, e = float(r), float(l), float(e)
    if not (0 <= r < np.inf and 0 <= l < np.inf and np.isfinite(e)):
        raise ValueError(f'slider-crank lengths must be finite and >= 0 (r={r}, l={l}, e={e})')
    ae = abs(e)
    if ae + r <= l:
        # Factored differences of squares: accurate even when l - r is close to |e|.
        return (float(np.sqrt(((l - r) - ae) * ((l - r) + ae))),
                float(np.sqrt(((l + r) - ae) * ((l + r) + ae))))
    if r + l < ae:
        raise ValueError(f'slider-crank cannot be assembled: r + l < |e| ({r} + {l} < {ae})')
    cands = []
    # Extended in line, |B| = l + r: B - A = l*B/|B|, so it is branch +1 iff x >= 0.
    cands.append(np.sqrt(((l + r) - ae) * ((l + r) + ae)))
    # Folded in line, |B| = |l - r| >= |e|: branch +1 iff x >= 0 when l >= r, x <= 0 when r > l.
    if abs(l - r) >= ae:
        xf = np.sqrt((abs(l - r) - ae) * (abs(l - r) + ae))
        cands.append(xf if l >= r else -xf)
    # Assembly limits: |e - r sin t2| = l -> sin t2 = (e -+ l)/r, there x = A_x = +-r cos t2;
    # both branches meet there, so both signs of cos belong to branch +1.
    for s in ((e - l) / r, (e + l) / r):
        if abs(s) <= 1.0:
            c = np.sqrt((1.0 - s) * (1.0 + s))
            cands.extend((r * c, -r * c))
    return float(min(cands)), float(max(cands))
