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
* Batches run block by block through fast kernels (see "fast block kernels" below) that keep
  their work arrays in cache; elements with a length or centre distance outside 2**+-200 or
  non-finite input (and calls with a negative or NaN tolerance) take the general whole-array
  formulas instead.  Both give the same results to rounding.  The general formulas first divide
  every length by a power of four (exact, per element) that brings the longest to [1, 4), so
  lengths near 1e308 or 5e-324 are solved like any other scale; a result that is itself beyond
  the float range (a slider position x > 1.8e308) is refused (ok False).  Angles of exactly
  -pi (signed zeros) are returned as +pi.  The kernels measure the closure
  residual along the solved link directions (unit vectors of B - A and B - O4) instead of
  through cos/sin of the returned angles, and take |sin(mu)| of the four-bar from the Kahan
  triangle area (2 * area / (l3 * l4)).
"""

from __future__ import annotations

import math
import threading
from typing import NamedTuple

import numpy as np

from .dyads import TANGENCY_TOL, circle_circle, kahan_four_area, pow2_scale

# Residual reported for non-finite inputs, where no misclosure can be measured: one full
# link length, i.e. "completely wrong", while keeping every output finite.
_NONFINITE_RESIDUAL = 1.0


class FourBarSolution(NamedTuple):
    """Result of :func:`fourbar_forward` (arrays broadcast from the inputs)."""

    theta3: np.ndarray  #: coupler angle [rad], in (-pi, pi]; 0 where not ok
    theta4: np.ndarray  #: rocker angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray  #: bool, the linkage assembles at this input
    #: |sin(mu)|, mu = angle at B between coupler and rocker; 0 where not ok
    transmission_sin: np.ndarray
    residual: np.ndarray  #: loop-closure error / longest link [-]


class FourBarInverseSolution(NamedTuple):
    """Result of :func:`fourbar_inverse`."""

    theta2: np.ndarray  #: crank angle [rad], in (-pi, pi]; 0 where not ok
    theta3: np.ndarray  #: coupler angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray  #: bool
    transmission_sin: np.ndarray  #: |sin(mu)| at B (coupler vs rocker); 0 where not ok
    residual: np.ndarray  #: loop-closure error / longest link [-]


class SliderCrankSolution(NamedTuple):
    """Result of :func:`slider_crank_forward`."""

    #: slider position B_x [length]; A_x (foot of A on the slide line) where not ok
    x: np.ndarray
    theta3: np.ndarray  #: rod angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray  #: bool
    residual: np.ndarray  #: loop-closure error / max(r, l, |e|) [-]


class SliderCrankInverseSolution(NamedTuple):
    """Result of :func:`slider_crank_inverse`."""

    theta2: np.ndarray  #: crank angle [rad], in (-pi, pi]; 0 where not ok
    theta3: np.ndarray  #: rod angle [rad], in (-pi, pi]; 0 where not ok
    ok: np.ndarray  #: bool
    residual: np.ndarray  #: loop-closure error / max(r, l, |e|) [-]


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


# --------------------------------------------------------------------------- fast block kernels
#
# Each public function below runs a fast kernel over blocks of _BLOCK elements and hands the
# elements the kernel cannot vouch for to its general form (the plain whole-array formulas,
# written for any input).  Both give the same answer to rounding; an element's path and result
# depend on its own inputs only (never on the rest of its block), so a scalar call and the
# same element in a batch go through the same formulas.
#
# Why the kernels look the way they do: whole-array numpy streams every temporary of a large
# batch through memory, and each fresh temporary page-faults again; a block's arrays stay in
# cache, are written in place (ufunc ``out=``) and come from a _Work that outlives the call.
# Every ufunc call also costs about a microsecond however short its array, so x and y
# components travel together as the rows of one (2, m) array (one call for both) and checks
# that rarely fire are block-level reductions.

#: Elements per block: large enough to amortise the per-call cost, small enough that a block's
#: work arrays stay in cache (best of 2048 .. 32768 measured).
_BLOCK = 16384
#: While every length and centre distance lies in [_LO, _HI], no square or product of the
#: kernels (the Kahan product of four factors included) can overflow or become subnormal, so
#: they need neither the power-of-two scaling nor hypot of the general form.
_LO, _HI = 2.0**-200, 2.0**200
_LO2 = _LO * _LO


class _Work:
    """Named work arrays shared by the blocks of a call (``m`` = the current block length)."""

    def __init__(self, size):
        self.size = self.m = size
        self._arrays = {}

    _full = threading.local()

    @classmethod
    def get(cls, n):
        """The work arrays for a call over n elements.  Full-size ones are kept per thread for
        the next call: allocating them afresh page-faults a few MB again on every call."""
        if n < _BLOCK:
            return cls(n)
        ws = getattr(cls._full, 'ws', None)
        if ws is None or ws.size != _BLOCK:
            ws = cls._full.ws = cls(_BLOCK)
        ws.m = ws.size
        return ws

    def __call__(self, name, *lead, dtype=float):
        """The array ``name`` of shape lead + (m,); its contents are whatever was left there."""
        a = self._arrays.get((name, lead, dtype))
        if a is None:
            a = self._arrays[(name, lead, dtype)] = np.empty(lead + (self.size,), dtype)
        return a if self.m == self.size else a[..., : self.m]


def _atan2(y, x, out, ws):
    """arctan2 into ``out``, as atan(y / x) plus the quadrant: half the cost of np.arctan2
    (glibc), within about an ulp of it (the rounding of y / x and of the added +-pi).  Signed
    zeros and x = +-0 follow atan2, except that -pi comes out as +pi (the range is (-pi, pi]);
    y = x = 0 gives NaN, which the kernels' finiteness test sends to the general form."""
    lead = out.shape[:-1]
    np.divide(y, x, out=out)
    np.arctan(out, out=out)
    c = ws('q', 2, *lead)[0]  # scratch: 'q' is free between stages
    np.copysign(np.pi, y, out=c)
    c *= np.signbit(x, out=ws('atan_b', *lead, dtype=bool))
    out += c
    # -pi (y = -0 or a tiny negative y, x < 0) is the direction +pi: (-pi, pi] as documented.
    # fmin skips the NaNs of elements bound for the general form (min would return NaN)
    if np.fmin.reduce(out, axis=None) == -np.pi:
        np.copyto(out, np.pi, where=out == -np.pi)


def _rrr(w, r1, r2, sgn, tol, ok, ws):
    """Circle (c1, r1) and circle (c2, r2), w = c2 - c1 as a (2, m) array, on one block.

    The same Kahan height and relative tangency clamp as :func:`dyads.circle_circle`, without
    its scaling (valid in the [_LO, _HI] range).  Writes ``ok`` and returns ``(v, area4, mis,
    good)``: v (2, 2, m) holds v[0] = X - c1 and v[1] = X - c2, X on the ``sgn`` side (where not
    ok the point of circle 1 nearest circle 2 on the centre line); area4 = 4 * area of the
    triangle (d, r1, r2), 0 where not ok or clamped; mis = |r1 v1/|v1| - r2 v2/|v2| - w|, the
    misclosure of the loop c1 -> X -> c2 drawn with the exact radii along the solved
    directions; ``good`` as :func:`_good`.
    """
    p, d2, d = ws('p', 2), ws('d2'), ws('d')
    np.multiply(w, w, out=p)
    np.add(p[0], p[1], out=d2)
    np.sqrt(d2, out=d)
    # Kahan's sides sorted, big >= mid >= small: bm = big - mid, s = big + mid
    big, bm, s = ws('big'), ws('bm'), ws('s')
    if isinstance(r1, float) and isinstance(r2, float):
        hi, lo = max(r1, r2), min(r1, r2)
    else:
        hi, lo = np.maximum(r1, r2), np.minimum(r1, r2)
    np.maximum(d, hi, out=big)
    if isinstance(lo, float) and d.min() >= lo:
        small = lo  # d >= lo: mid = min(d, hi), bm = |d - hi|, same values
        np.subtract(d, hi, out=bm)
        np.abs(bm, out=bm)
        np.add(d, hi, out=s)
    else:
        small, mid = ws('small'), ws('mid')
        np.minimum(d, lo, out=small)
        np.maximum(d, lo, out=mid)
        np.minimum(mid, hi, out=mid)
        np.subtract(big, mid, out=bm)
        np.add(big, mid, out=s)
    area4, a, h = ws('area4'), ws('a'), ws('h')
    np.add(small, bm, out=area4)  # Kahan's small + (big - mid)
    neg = np.subtract(small, bm, out=bm)  # the only Kahan factor that can be < 0
    np.greater_equal(neg, np.multiply(big, -tol, out=h), out=ok)
    # Elements not ok or within the tangency clamp (neg < 0) get height 0 and a foot clamped
    # to circle 1; the others need neither, so a block without any skips both.
    clamped = None if neg.min() >= 0 else np.less(neg, 0.0, out=ws('clamped', dtype=bool))
    if clamped is not None:  # (a NaN min looks closer too)
        np.maximum(neg, 0.0, out=neg)
    # Kahan's 4 * area, one root of the product of the four factors (no under/overflow in
    # range).  The two factors that cannot cancel are formed from big + mid: same accuracy.
    area4 *= neg
    f = np.add(s, small, out=a)
    s -= small
    f *= s
    area4 *= f
    np.sqrt(area4, out=area4)
    # X - c1 = (foot * w + height * w_perp) / d for the foot of X on the centre line and its
    # signed height, both divided by d here: a = foot / d = 1/2 + (r1 - r2)(r1 + r2) / (2 d^2)
    # (no cancellation of r1**2 - r2**2), h = height / d = +-2 area / d^2
    np.divide(0.5 * ((r1 - r2) * (r1 + r2)), d2, out=a)
    a += 0.5
    if clamped is not None:  # the foot clamped to circle 1: |foot| <= r1
        bound, t = np.divide(r1, d, out=s), ws('t')
        np.minimum(a, bound, out=t)
        np.negative(bound, out=bound)
        np.maximum(t, bound, out=t)
        np.copyto(a, t, where=clamped)
    np.divide(area4, d2, out=h)
    h *= 0.5 * sgn
    v = ws('v', 2, 2)
    np.multiply(a, w, out=v[0])
    np.multiply(h, w, out=p)
    v[0, 0] -= p[1]
    v[0, 1] += p[0]
    np.subtract(v[0], w, out=v[1])  # X - c2 = (X - c1) - (c2 - c1)
    q, k = ws('q', 2, 2), p
    np.multiply(v, v, out=q)
    np.add(q[:, 0], q[:, 1], out=k)
    np.sqrt(k, out=k)  # |v1|, |v2|
    np.divide(r1, k[0], out=k[0])
    np.divide(r2, k[1], out=k[1])
    np.multiply(k[:, None], v, out=q)
    r = np.subtract(q[0], q[1], out=q[0])
    r -= w
    r *= r
    mis = np.add(r[0], r[1], out=big)
    np.sqrt(mis, out=mis)
    return v, area4, mis, _good(mis, d2, ws)


def _good(res, d2, ws):
    """True, or the mask of the elements the fast formulas hold for: ``res`` finite (NaN or inf
    anywhere upstream reaches it) and, if given, d2 = |w|^2 >= _LO2.  Block-level reductions
    first: the per-element mask is only formed for a block that needs it."""
    if math.isfinite(res.sum()) and (d2 is None or d2.min() >= _LO2):
        return True
    good = np.isfinite(res, out=ws('good', dtype=bool))
    if d2 is not None:
        good &= np.greater_equal(d2, _LO2, out=ws('b', dtype=bool))
    return good


def _zero_where_not(ok, *arrays):
    """The placeholders: 0 where not ok (in place, along the last axis)."""
    if not ok.all():
        bad = ~ok
        for a in arrays:
            np.copyto(a, 0.0, where=bad)  # (a[..., bad] = 0 costs 4x more)


def _in_range(a, kind):
    """True, or the mask of the elements of ``a`` inside the fast range of its ``kind``: 'len'
    [_LO, _HI], 'coord' [-_HI, _HI] (NaN is outside)."""
    lo = _LO if kind == 'len' else -_HI
    if lo <= a.min() and a.max() <= _HI:
        return True
    return (a >= lo) & (a <= _HI)


def _blocked(fast, general, args, kinds, nout, tol):
    """Evaluate ``fast(*block_args, tol, block_outputs, work) -> good`` (True or a mask) block
    by block over the broadcast ``args``, and ``general(*args, tol) -> outputs`` wherever
    ``good`` is False or an argument is outside its fast range (``kinds``: see
    :func:`_in_range`; None leaves it to the kernel's finiteness test).

    The outputs are two angles (one (2, n) array for the kernel), the ok mask, then ``nout``
    more float arrays.  Returns them as flat arrays, and the broadcast shape.
    """
    shape = np.broadcast_shapes(*(a.shape for a in args))
    n = math.prod(shape)
    fast_ok = math.isfinite(tol) and tol >= 0
    flat, checks = [], []
    for a, kind in zip(args, kinds):
        if a.size == 1 and (n > 1 or kind is not None):
            v = float(a.reshape(-1)[0])  # scalars stay scalars: no per-element work for them
            flat.append(v)
            if kind is not None:
                fast_ok &= _in_range(np.asarray(v), kind) is True
        else:
            if a.shape != shape:
                a = np.broadcast_to(a, shape)
            a = a.reshape(-1)  # copies only for repeating broadcasts
            flat.append(a)
            if kind is not None:
                checks.append((a, kind))
    if not fast_ok or n == 0:
        return [np.asarray(o).reshape(-1) for o in general(*flat, tol)], shape
    outs = [np.empty((2, n)), np.empty(n, bool)] + [np.empty(n) for _ in range(nout)]
    ws = _Work.get(n)
    for s in range(0, n, ws.size):
        ws.m = min(ws.size, n - s)
        sl = slice(s, s + ws.m)
        good = fast(
            *[v[sl] if isinstance(v, np.ndarray) else v for v in flat],
            tol,
            [o[..., sl] for o in outs],
            ws,
        )
        for a, kind in checks:
            inside = _in_range(a[sl], kind)
            if inside is not True:
                good = inside if good is True else good & inside
        if good is not True and not good.all():
            idx = np.flatnonzero(~good) + s
            sub = [v[idx] if isinstance(v, np.ndarray) else v for v in flat]
            r = general(*sub, tol)
            outs[0][:, idx] = r[:2]
            for o, ro in zip(outs[1:], r[2:]):
                o[idx] = ro
    return [outs[0][0], outs[0][1]] + outs[1:], shape


def _shaped(cls, outs, shape):
    return cls(*(_out(o.reshape(shape)) for o in outs))


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
    # NaN (0 * inf) only for a link ~1e-308 times the others, accepted by a tangency clamp of
    # order 1: a degenerate configuration, reported as the singularity (0)
    return np.clip(np.nan_to_num(np.abs(cross), nan=0.0), 0.0, 1.0)


def _atan2_general(y, x):
    """np.arctan2 with -pi (y = -0 or a tiny negative y, x < 0) returned as +pi: (-pi, pi]."""
    a = np.arctan2(y, x)
    return np.where(a == -np.pi, np.pi, a)


def _normalised(*lengths):
    """The lengths divided by the power of four S (per element, exact) that brings the longest
    to [1, 4), and S.  The general forms solve the normalised linkage: angles and the relative
    residual do not depend on the scale, and no intermediate overflows (lengths or coordinates
    near 1e308) or loses its digits to subnormals (lengths near 5e-324)."""
    m = np.abs(lengths[0])
    for v in lengths[1:]:
        m = np.maximum(m, np.abs(v))
    S = pow2_scale(m)
    return [v / S for v in lengths], S


def _general_inputs(args, scaled: int):
    """The general forms' arguments (the branch last) broadcast to one shape, the mask of the
    elements whose other arguments are all finite, and the first ``scaled`` of them (the
    lengths) divided by the power of four S of :func:`_normalised`: (args, finite, S)."""
    args = np.broadcast_arrays(*(_f(a) for a in args))
    finite = np.isfinite(args[0])
    for a in args[1:-1]:
        finite = finite & np.isfinite(a)
    with np.errstate(invalid='ignore', over='ignore'):
        lengths, S = _normalised(*args[:scaled])
    return [*lengths, *args[scaled:]], finite, S


def _finish(values, ok, finite, residual):
    """Zero the placeholders where not ok and make the residual finite."""
    vals = [np.where(ok, v, 0.0) for v in values]
    res = np.where(finite & np.isfinite(residual), residual, _NONFINITE_RESIDUAL)
    return vals, res


def _longest(*lengths):
    if all(isinstance(v, float) for v in lengths):
        return max(lengths)  # scalars: no ufunc call per block
    m = lengths[0]
    for v in lengths[1:]:
        m = np.maximum(m, v)
    return m


def _fourbar_forward_fast(l1, l2, l3, l4, t2, sgn, tol, out, ws):
    angles, ok, tsin, res = out  # angles = (theta3, theta4)
    w = ws('w', 2)  # w = O4 - A
    np.cos(t2, out=w[0])
    np.sin(t2, out=w[1])
    w *= -l2
    w[0] += l1
    # B from circle (A, l3) and circle (O4, l4): v = (B - A, B - O4)
    v, area4, mis, good = _rrr(w, l3, l4, sgn, tol, ok, ws)
    _atan2(v[:, 1], v[:, 0], angles, ws)
    # |sin mu| = 2 * area(A, B, O4) / (l3 l4), the Kahan area: accurate near the toggles too
    np.multiply(area4, 0.5 / (l3 * l4), out=tsin)
    np.minimum(tsin, 1.0, out=tsin)
    np.divide(mis, _longest(l1, l2, l3, l4), out=res)
    _zero_where_not(ok, angles)
    return good


def _fourbar_forward_general(l1, l2, l3, l4, t2, br, tangency_tol):
    (l1, l2, l3, l4, t2, br), finite, _ = _general_inputs((l1, l2, l3, l4, t2, br), 4)
    with np.errstate(invalid='ignore', over='ignore'):
        ax, ay = l2 * np.cos(t2), l2 * np.sin(t2)
        o4x, o4y = l1, np.zeros_like(l1)
        b, _, ok = circle_intersection(
            np.stack([ax, ay], -1), l3, np.stack([o4x, o4y], -1), l4, br, tangency_tol
        )
        ok = np.asarray(ok) & finite & (l1 >= 0) & (l2 >= 0)
        bx, by = b[..., 0], b[..., 1]
        t3 = _atan2_general(by - ay, bx - ax)
        t4 = _atan2_general(by - o4y, bx - o4x)
        tsin = _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4)
        residual = _closure_residual(l1, l2, l3, l4, t2, t3, t4)
    (t3, t4, tsin), residual = _finish((t3, t4, tsin), ok, finite, residual)
    return t3, t4, ok, tsin, residual


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
    args = (_f(l1), _f(l2), _f(l3), _f(l4), _f(theta2), _sign(branch))
    with np.errstate(all='ignore'):
        outs, shape = _blocked(
            _fourbar_forward_fast,
            _fourbar_forward_general,
            args,
            ('len', 'len', 'len', 'len', None, None),
            2,
            float(tangency_tol),
        )
    return _shaped(FourBarSolution, outs, shape)


def _fourbar_inverse_fast(l1, l2, l3, l4, t4, sgn, tol, out, ws):
    angles, ok, tsin, res = out  # angles = (theta2, theta3)
    cs, w = ws('cs', 2), ws('w', 2)
    np.cos(t4, out=cs[0])
    np.sin(t4, out=cs[1])
    np.multiply(cs, -l4, out=w)  # w = O2 - B = -(O4 + l4 (c4, s4))
    w[0] -= l1
    # A from circle (B, l3) and circle (O2, l2): v = (A - B, A - O2)
    v, _, mis, good = _rrr(w, l3, l2, sgn, tol, ok, ws)
    np.negative(v[0], out=v[0])  # B - A
    v = v[::-1]  # (A - O2, B - A): theta2, theta3
    _atan2(v[:, 1], v[:, 0], angles, ws)
    # |sin mu| = |cross(B - A, B - O4)| / (l3 l4), B - O4 = l4 (c4, s4)
    ba = v[1]
    ba *= cs[::-1]
    np.subtract(ba[0], ba[1], out=tsin)
    np.abs(tsin, out=tsin)
    tsin /= l3
    np.minimum(tsin, 1.0, out=tsin)
    np.divide(mis, _longest(l1, l2, l3, l4), out=res)
    _zero_where_not(ok, angles, tsin)
    return good


def _fourbar_inverse_general(l1, l2, l3, l4, t4, br, tangency_tol):
    (l1, l2, l3, l4, t4, br), finite, _ = _general_inputs((l1, l2, l3, l4, t4, br), 4)
    with np.errstate(invalid='ignore', over='ignore'):
        o4x, o4y = l1, np.zeros_like(l1)
        bx, by = o4x + l4 * np.cos(t4), o4y + l4 * np.sin(t4)
        a, _, ok = circle_intersection(
            np.stack([bx, by], -1), l3, np.zeros(bx.shape + (2,)), l2, br, tangency_tol
        )
        ok = np.asarray(ok) & finite & (l1 >= 0) & (l4 >= 0)
        ax, ay = a[..., 0], a[..., 1]
        t2 = _atan2_general(ay, ax)
        t3 = _atan2_general(by - ay, bx - ax)
        tsin = _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4)
        residual = _closure_residual(l1, l2, l3, l4, t2, t3, t4)
    (t2, t3, tsin), residual = _finish((t2, t3, tsin), ok, finite, residual)
    return t2, t3, ok, tsin, residual


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
    args = (_f(l1), _f(l2), _f(l3), _f(l4), _f(theta4), _sign(branch))
    with np.errstate(all='ignore'):
        outs, shape = _blocked(
            _fourbar_inverse_fast,
            _fourbar_inverse_general,
            args,
            ('len', 'len', 'len', 'len', None, None),
            2,
            float(tangency_tol),
        )
    return _shaped(FourBarInverseSolution, outs, shape)


# --------------------------------------------------------------------------- slider-crank


def _slider_residual(r, l, e, t2, t3, x) -> np.ndarray:
    """|O2A + AB - (x, e)| / max(r, l, |e|)."""
    rx = r * np.cos(t2) + l * np.cos(t3) - x
    ry = r * np.sin(t2) + l * np.sin(t3) - e
    scale = np.maximum(np.maximum(np.abs(r), np.abs(l)), np.abs(e))
    return np.hypot(rx, ry) / np.where(scale > 0, scale, 1.0)


def _slider_forward_fast(r, l, e, t2, sgn, tol, out, ws):
    xt3, ok, res = out  # xt3 = (x, theta3)
    x, t3 = xt3
    a, rod = ws('a', 2), ws('rod', 2)  # A, and the rod B - A = (hx, dy)
    np.cos(t2, out=a[0])
    np.sin(t2, out=a[1])
    a *= r
    hx, dy = rod
    np.subtract(e, a[1], out=dy)
    ady, gap = ws('ady'), ws('gap')
    np.abs(dy, out=ady)
    np.subtract(l, ady, out=gap)  # > 0: the rod reaches the line; factored, no l**2 - dy**2
    scale = _longest(r, l, np.abs(e))
    np.greater_equal(gap, np.multiply(scale, -tol), out=ok)
    # |B_x - A_x| = sqrt((l - |dy|)(l + |dy|)); 0 where clamped or not ok (gap <= 0 there)
    np.maximum(gap, 0.0, out=gap)
    ady += l
    gap *= ady
    np.sqrt(gap, out=hx)
    hx *= sgn
    np.add(a[0], hx, out=x)
    _atan2(dy, hx, t3, ws)  # where not ok: the rod pointing straight at the line (+-pi/2)
    # misclosure of the rod drawn with length l along its solved direction
    q, k = ws('q', 2), ws('k')
    np.multiply(rod, rod, out=q)
    np.add(q[0], q[1], out=k)
    np.sqrt(k, out=k)
    np.divide(l, k, out=k)
    rod *= k
    rod += a
    rod[0] -= x
    rod[1] -= e
    rod *= rod
    np.add(rod[0], rod[1], out=k)
    np.sqrt(k, out=k)
    np.divide(k, scale, out=res)
    _zero_where_not(ok, t3)
    return _good(res, None, ws)


def _slider_forward_general(r, l, e, t2, br, tangency_tol):
    (r, l, e, t2, br), finite, S = _general_inputs((r, l, e, t2, br), 3)
    with np.errstate(invalid='ignore', over='ignore'):
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
        t3 = np.where(ok, _atan2_general(dy, br * half), np.arctan2(dy, 0.0))
        residual = _slider_residual(r, l, e, t2, t3, x)
        # back to length units; an x beyond the float range (r + l near 1.8e308) is not
        # representable: not ok, x = A_x (finite: |A_x| <= r) and the residual of a wrong answer
        x, ax = x * S, ax * S
        beyond = ok & ~np.isfinite(x)
        ok &= ~beyond
        x = np.where(beyond, ax, x)
        residual = np.where(beyond, _NONFINITE_RESIDUAL, residual)
    (t3,), residual = _finish((t3,), ok, finite, residual)
    x = np.where(finite, x, 0.0)
    return x, t3, ok, residual


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
        configuration (rod pointing at the line).  A slider position beyond the float range
        (r + l near 1.8e308) is not ok either, with x = A_x and residual 1.
    """
    args = (_f(r), _f(l), _f(e), _f(theta2), _sign(branch))
    with np.errstate(all='ignore'):
        outs, shape = _blocked(
            _slider_forward_fast,
            _slider_forward_general,
            args,
            ('len', 'len', 'coord', None, None),
            1,
            float(tangency_tol),
        )
    return _shaped(SliderCrankSolution, outs, shape)


def _slider_inverse_fast(r, l, e, x, sgn, tol, out, ws):
    angles, ok, res = out  # angles = (theta2, theta3)
    w = ws('w', 2)  # w = B - O2 = (x, e)
    np.copyto(w[0], x)
    np.copyto(w[1], e)
    # A from circle (O2, r) and circle (B, l): v = (A - O2, A - B)
    v, _, mis, good = _rrr(w, r, l, sgn, tol, ok, ws)
    np.negative(v[1], out=v[1])  # B - A
    _atan2(v[:, 1], v[:, 0], angles, ws)
    np.divide(mis, _longest(r, l, np.abs(e)), out=res)
    _zero_where_not(ok, angles)
    return good


def _slider_inverse_general(r, l, e, x, br, tangency_tol):
    (r, l, e, x, br), finite, _ = _general_inputs((r, l, e, x, br), 4)
    with np.errstate(invalid='ignore', over='ignore'):
        a, _, ok = circle_intersection(
            np.zeros(x.shape + (2,)), r, np.stack([x, e], -1), l, br, tangency_tol
        )
        ok = np.asarray(ok) & finite
        ax, ay = a[..., 0], a[..., 1]
        t2 = _atan2_general(ay, ax)
        t3 = _atan2_general(e - ay, x - ax)
        residual = _slider_residual(r, l, e, t2, t3, x)
    (t2, t3), residual = _finish((t2, t3), ok, finite, residual)
    return t2, t3, ok, residual


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
    args = (_f(r), _f(l), _f(e), _f(x), _sign(branch))
    with np.errstate(all='ignore'):
        outs, shape = _blocked(
            _slider_inverse_fast,
            _slider_inverse_general,
            args,
            ('len', 'len', 'coord', 'coord', None),
            1,
            float(tangency_tol),
        )
    return _shaped(SliderCrankInverseSolution, outs, shape)


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
        return (
            float(np.sqrt(((l - r) - ae) * ((l - r) + ae))),
            float(np.sqrt(((l + r) - ae) * ((l + r) + ae))),
        )
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
