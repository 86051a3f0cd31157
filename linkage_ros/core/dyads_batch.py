"""The RRR dyad of :mod:`linkage_ros.core.dyads` over a batch, in fewer numpy passes.

:func:`solve_rrr_dyad_batch` gives bit for bit what ``dyads.solve_rrr_dyad(BATCH, ...)`` gives
(the same float operations in the same order, Kahan's needle-triangle area included); it only
skips the passes that change nothing: ``where`` on a mask that holds for every row (every row
finite, every dyad closed: the common batch) and the generic backend's dispatch. Powers of two
are built from their exponent bits where they are normal numbers (``np.ldexp`` costs ~15
times as much), ``np.ldexp`` elsewhere.

:func:`rrr_point_batch` is what the plan executor calls: the dyad and the point of one branch
in one go, for the common batch (every centre and radius finite, every row closing, every
point representable), the same float operations again but written into arrays it owns (each
new 160 kB array of a 20,000-row batch costs page faults as well as its pass), and without the
placeholders no row needs; any other batch takes the general kernel and ``dyad_point``.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .dyads import TOGGLE_BAND, DyadPair, dyad_point
from .ops import BATCH, CArray

_FLOAT_MAX = float(np.finfo(float).max)
_MIN_NORMAL_EXP, _MAX_EXP = -1022, 1023


def pow2(k: np.ndarray) -> np.ndarray:
    """2.0 ** k for integer arrays k, exactly ``np.ldexp(1.0, k)``."""
    k = np.asarray(k)
    if k.size and (k.min() < _MIN_NORMAL_EXP or k.max() > _MAX_EXP):
        out: np.ndarray = np.ldexp(1.0, k)  # subnormal or overflowing powers
        return out
    return ((k.astype(np.int64) + 1023) << 52).view(np.float64)


def _pow2_scale(m: np.ndarray) -> np.ndarray:
    """ops._pow2_scale on the batch backend (the even power of two S with m / S in [1, 4))."""
    _, expo = np.frexp(np.where(np.isfinite(m) & (m > 0), m, 1.0))
    return pow2(((expo - 1) >> 1) << 1)


def _kahan(a: Any, b: Any, c: Any) -> tuple[Any, Any, Any, Any]:
    """dyads.kahan_four_area_of on the batch backend (see there for why each step)."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    big, small = np.maximum(hi, c), np.minimum(lo, c)
    mid = np.maximum(lo, np.minimum(hi, c))
    fin = np.isfinite(big)
    _, expo = np.frexp(big if fin.all() else np.where(fin, big, 1.0))
    scale = pow2(expo)
    big, mid, small = big / scale, mid / scale, small / scale
    neg_factor = small - (big - mid)
    four_area_n = (
        np.sqrt(big + (mid + small))
        * np.sqrt(np.maximum(neg_factor, 0.0))
        * np.sqrt(small + (big - mid))
        * np.sqrt(big + (mid - small))
    )
    return four_area_n, -neg_factor, big, scale


def _isfinite(x: Any) -> Any:
    return np.isfinite(x)


def solve_rrr_dyad_batch(c1: Any, r1: Any, c2: Any, r2: Any, tol: float) -> DyadPair:
    """``dyads.solve_rrr_dyad(BATCH, c1, r1, c2, r2, tol)``, bit for bit (see the module):
    centres (n,) CArray points, radii floats or (n,) arrays."""
    x1, y1 = c1.re, c1.im
    x2, y2 = c2.re, c2.im
    cm1 = np.maximum(np.abs(x1), np.abs(y1))
    cm2 = np.maximum(np.abs(x2), np.abs(y2))
    big = np.maximum(np.maximum(cm1, cm2), np.maximum(abs(r1), abs(r2)))
    S = _pow2_scale(np.asarray(big, float))
    x1n, y1n, x2n, y2n = x1 / S, y1 / S, x2 / S, y2 / S
    r1n, r2n = r1 / S, r2 / S
    dx, dy = x2n - x1n, y2n - y1n
    d = np.hypot(dx, dy)
    finite = (
        _isfinite(dx)
        & _isfinite(dy)
        & _isfinite(r1n)
        & _isfinite(r2n)
        & (_isfinite(x1) & _isfinite(y1))
        & (_isfinite(x2) & _isfinite(y2))
    )
    all_finite = bool(np.all(finite))
    if all_finite:
        four_area_n, violation_n, longest_n, scale = _kahan(d, r1n, r2n)
    else:
        four_area_n, violation_n, longest_n, scale = _kahan(
            np.where(finite, d, 0.0), np.where(finite, r1n, 0.0), np.where(finite, r2n, 0.0)
        )
    dn = d / scale
    ok = finite & (dn > 0) & (r1n > 0) & (r2n > 0) & (violation_n <= tol * longest_n)
    all_ok = bool(np.all(ok))
    placed = finite & (d > 0)
    all_placed = all_ok or bool(np.all(placed))
    dsafe = d if all_placed else np.where(placed, d, 1.0)
    if all_finite:
        ux, uy = dx / dsafe, dy / dsafe
    else:
        ux, uy = np.where(finite, dx, 0.0) / dsafe, np.where(finite, dy, 0.0) / dsafe
    along = 0.5 * (d + ((r1n - r2n) / dsafe) * (r1n + r2n))
    ar1 = abs(r1n)
    along = np.clip(along, -ar1, ar1)
    if not all_placed:
        along = np.where(placed, along, 0.0)
    smallest_n = np.minimum(np.minimum(dn, r1n / scale), r2n / scale)
    on_toggle = (violation_n >= -TOGGLE_BAND * longest_n) & (-violation_n < 0.5 * smallest_n)
    if all_ok:  # dn, r1n and r2n > 0 in every row
        h = 0.5 * scale * (four_area_n / dn)
        if on_toggle.any():
            h = np.where(~on_toggle, h, 0.0)
        margin = (h / r1n) * (d / r2n)
    else:
        h = np.where(ok & ~on_toggle, 0.5 * scale * (four_area_n / np.where(dn > 0, dn, 1.0)), 0.0)
        margin = np.where(
            ok, (h / np.where(r1n > 0, r1n, 1.0)) * (d / np.where(r2n > 0, r2n, 1.0)), 0.0
        )
    if not bool(np.all(margin == margin)):  # NaN as 0
        margin = np.where(margin == margin, margin, 0.0)
    margin = np.clip(margin, 0.0, 1.0)
    if all_ok:
        violation = np.zeros(np.shape(ok))
    else:
        violation = np.where(finite, np.maximum(violation_n * (scale * S), 0.0), _FLOAT_MAX)
        violation = np.where(ok, 0.0, np.minimum(violation, _FLOAT_MAX))
    # the not-ok placeholder: circle 1's point nearest circle 2 (c1 if not representable)
    nx, ny = (x1n + along * ux) * S, (y1n + along * uy) * S
    near_ok = np.isfinite(nx) & np.isfinite(ny)
    if all_finite and bool(np.all(near_ok)):
        fx, fy = nx, ny
        bx, by = x1n, y1n
    elif all_finite:
        fx, fy = np.where(near_ok, nx, x1), np.where(near_ok, ny, y1)
        bx, by = x1n, y1n
    else:
        fx = np.where(finite, np.where(near_ok, nx, x1), 0.0)
        fy = np.where(finite, np.where(near_ok, ny, y1), 0.0)
        bx, by = np.where(finite, x1n, 0.0), np.where(finite, y1n, 0.0)
    hs = h * S if all_ok else np.where(ok, h * S, 0.0)
    return DyadPair(
        CArray(bx, by),
        CArray(ux, uy),
        along,
        CArray(*np.broadcast_arrays(np.asarray(0.0 * h, float), np.asarray(h, float))),
        S,
        margin,
        ok,
        violation,
        hs,
        CArray(fx, fy),
    )


class RrrPoint(NamedTuple):
    """One branch of an RRR dyad over a batch: the point (CArray), where it closes (bool (n,)),
    the dyad's margin and violation ((n,)), as ``dyad_point`` and :class:`DyadPair` give them;
    ``all_ok``: ``ok`` holds in every row."""

    point: Any  # CArray
    ok: Any
    margin: Any
    violation: Any
    all_ok: bool


def rrr_point_batch(c1: Any, r1: Any, c2: Any, r2: Any, tol: float, sign: Any) -> RrrPoint:
    """``dyad_point(BATCH, solve_rrr_dyad_batch(c1, r1, c2, r2, tol), sign)`` with the pair's
    margin and violation, bit for bit, in fewer passes where every row closes (module)."""
    got = _rrr_point_common(c1, r1, c2, r2, tol, sign) if isinstance(sign, int) else None
    if got is not None:
        return got
    pair = solve_rrr_dyad_batch(c1, r1, c2, r2, tol)
    z, ok = dyad_point(BATCH, pair, sign)
    return RrrPoint(z, ok, pair.margin, pair.violation, bool(np.all(ok)))


def _rrr_point_common(c1: Any, r1: Any, c2: Any, r2: Any, tol: float, sign: int) -> RrrPoint | None:
    """solve_rrr_dyad_batch's formulas where every row is finite and closes, then dyad_point's
    (same operations, same order: each comment names the expression it computes); None as
    soon as a row is not of that kind (the caller takes the general kernel). Arrays are let go
    (del) as soon as they are read for the last time: the batch's peak of fresh memory."""
    x1, y1, x2, y2 = c1.re, c1.im, c2.re, c2.im
    if not (isinstance(x1, np.ndarray) and x1.ndim == 1 and x1.size):
        return None
    # max(|x1|, |y1|, |x2|, |y2|, |r1|, |r2|): a centre the same in every row (a ground
    # point: a read-only view of one value) taken once (max of magnitudes: the order of its
    # arguments changes nothing but a NaN's payload, and a NaN row leaves below)
    cm1, cm2 = _cmax(x1, y1), _cmax(x2, y2)
    if np.ndim(cm1) == 0:
        cm1, cm2 = cm2, cm1
    radii = np.maximum(abs(r1), abs(r2))
    if np.ndim(cm1):
        big = cm1
        np.maximum(big, cm2, out=big)
        np.maximum(big, radii, out=big)
    else:  # both centres one value: the radii make the rows
        big = np.maximum(np.maximum(cm1, cm2), radii)
    del cm1, cm2, radii
    if np.ndim(big) == 0:  # one dyad in every row: the general kernel
        return None
    # every row finite and > 0 (max propagates NaN) and a normal number
    if not (big.max() < np.inf and big.min() >= _MIN_NORMAL):
        return None
    S = _even_pow2_below(big)  # _pow2_scale(big)
    del big
    # one scale in every row (the common batch: its lengths within a factor 4 of one
    # another): a 0-d divisor, the same division in each row; a scale of 1 divides nothing
    # (x / 1.0 and x * 1.0 are x to the bit: every value here is finite), so x1n, y1n, r1n and
    # r2n are the caller's values, read and never written
    if S.min() == S.max():
        S = S[0]
    unscaled = np.ndim(S) == 0 and S == 1.0
    r1n, r2n = (r1, r2) if unscaled else (r1 / S, r2 / S)
    if x1.strides == y1.strides == x2.strides == y2.strides == (0,) and np.ndim(S) == 0:
        # both centres one value in every row (two ground pivots): x1n, y1n, dx, dy and d
        # one value each, taken once (each row's float operations are these; numpy's hypot
        # is libm's, element by element: the same bits on one value)
        x1n, y1n = x1[0] / S, y1[0] / S
        dx0, dy0 = x2[0] / S - x1n, y2[0] / S - y1n
        n = x1.shape[0]
        dx, dy, d = np.full(n, dx0), np.full(n, dy0), np.full(n, np.hypot(dx0, dy0))
    elif unscaled:
        x1n, y1n = x1, y1
        dx, dy = np.subtract(x2, x1), np.subtract(y2, y1)
        d = np.hypot(dx, dy)
    else:
        x1n, y1n = x1 / S, y1 / S
        dx, dy = x2 / S, y2 / S
        dx -= x1n
        dy -= y1n
        d = np.hypot(dx, dy)
    # _kahan(d, r1n, r2n), every side finite
    lo, hi = np.minimum(d, r1n), np.maximum(d, r1n)
    longest, small = np.maximum(hi, r2n), np.minimum(lo, r2n)
    mid = np.maximum(lo, np.minimum(hi, r2n, out=hi), out=lo)
    del lo, hi
    if not longest.min() >= _MIN_NORMAL:
        return None
    scale = _pow2_above(longest)  # pow2(frexp(longest)[1])
    longest /= scale
    mid /= scale
    small /= scale
    big_mid = longest - mid
    neg_factor = small - big_mid
    four_area_n = mid + small
    four_area_n += longest
    np.sqrt(four_area_n, out=four_area_n)
    f = np.maximum(neg_factor, 0.0)
    four_area_n *= np.sqrt(f, out=f)
    del f
    np.add(small, big_mid, out=big_mid)
    four_area_n *= np.sqrt(big_mid, out=big_mid)
    del big_mid
    np.subtract(mid, small, out=mid)
    mid += longest
    four_area_n *= np.sqrt(mid, out=mid)
    del mid
    violation_n = np.negative(neg_factor, out=neg_factor)
    dn = d / scale
    # ok in every row: finite & (dn > 0) & (r1n > 0) & (r2n > 0) & (violation_n <= tol * longest_n)
    if not (dn.min() > 0 and _least(r1n) > 0 and _least(r2n) > 0):
        return None
    if not np.all(violation_n <= np.multiply(longest, tol, out=small)):
        return None
    del small
    ux, uy = np.divide(dx, d, out=dx), np.divide(dy, d, out=dy)
    along = r1n - r2n
    along /= d
    along *= r1n + r2n
    along += d
    along *= 0.5
    # np.clip(along, -|r1n|, |r1n|): r1n > 0, so no bound is a zero of either sign and the
    # maximum and minimum passes give clip's values
    np.maximum(along, -r1n, out=along)
    np.minimum(along, r1n, out=along)
    # on_toggle needs violation_n >= -TOGGLE_BAND * longest_n, longest_n < 1: none below
    toggle = None
    if not violation_n.max() < -TOGGLE_BAND:
        smallest_n = np.minimum(np.minimum(dn, r1n / scale), r2n / scale)
        toggle = (violation_n >= -TOGGLE_BAND * longest) & (-violation_n < 0.5 * smallest_n)
    del violation_n, longest
    # h = 0.5 * scale * (four_area_n / dn)
    h = np.multiply(scale, 0.5, out=scale)
    h *= np.divide(four_area_n, dn, out=four_area_n)
    del four_area_n, dn
    if toggle is not None and toggle.any():
        h = np.where(~toggle, h, 0.0)
    if not h.max() < np.inf:  # (0 * h below is then no zero)
        return None
    # margin = clip((h / r1n) * (d / r2n)), NaN as 0
    margin = h / r1n
    margin *= np.divide(d, r2n, out=d)
    del d
    if np.isnan(margin.max()):
        margin = np.where(margin == margin, margin, 0.0)
    np.clip(margin, 0.0, 1.0, out=margin)
    # dyad_point: (base + (along + sign * (0 h + i h)) * u) * S; 0.0 * (h * sign) is
    # (0.0 * h) * sign for a finite h, the zero of the same sign
    w_im = np.multiply(h, sign, out=h)
    w_re = np.multiply(w_im, 0.0)
    w_re += along
    px = w_re * ux
    t = np.multiply(w_im, uy, out=along)
    px -= t
    py = np.multiply(w_re, uy, out=w_re)
    py += np.multiply(w_im, ux, out=t)
    del w_im, t, ux, uy
    px += x1n
    py += y1n
    if not unscaled:
        px *= S
        py *= S
    if not (np.isfinite(px).all() and np.isfinite(py).all()):
        return None
    return RrrPoint(CArray(px, py), np.ones(px.shape, bool), margin, np.zeros(px.shape), True)


def _least(x: Any) -> Any:
    """np.min(x): a radius one value (a float) as it is (np.min's array call costs more than
    the comparison it feeds)."""
    return x if isinstance(x, float) else np.min(x)


def _cmax(x: np.ndarray, y: np.ndarray) -> Any:
    """max(|x|, |y|) elementwise into an array of its own; one value (0-d) where x and y are
    each one value in every row (stride-0 views)."""
    if x.strides == (0,) and y.strides == (0,):
        return np.maximum(np.abs(x[0]), np.abs(y[0]))
    m = np.abs(x)
    np.maximum(m, np.abs(y), out=m)
    return m


#: the smallest positive normal float (the exponent-bit forms below need normal numbers)
_MIN_NORMAL = float(np.finfo(float).tiny)


def _even_pow2_below(m: np.ndarray) -> np.ndarray:
    """_pow2_scale(m) for positive normal finite m, from m's exponent bits: 2**k with
    k = ((e - 1) >> 1) << 1, frexp's exponent e = biased - 1022 (k + 1023 in [1, 2045]).
    k = (biased - 1023) with its lowest bit cleared (floor to even), so k << 52 is m's bits
    less 1023 << 52 with the mantissa and the exponent's lowest bit cleared (the mantissa,
    below 2**52, never carries into the floor): three passes."""
    b = m.view(np.int64) - _EXP_ONE
    b &= _EVEN_EXP
    b += _EXP_ONE
    return b.view(np.float64)


def _pow2_above(m: np.ndarray) -> np.ndarray:
    """pow2(frexp(m)[1]) for positive normal m < 2**1023 (here < 16): 2**(biased - 1022),
    whose bits are m's exponent field plus one exponent step (two passes)."""
    b = m.view(np.int64) & _EXP_FIELD
    b += _EXP_STEP
    return b.view(np.float64)


#: exponent-field constants of a float64's bits: one step, the field, 1.0's, and the mask that
#: clears the mantissa and the exponent's lowest bit
_EXP_STEP = np.int64(1 << 52)
_EXP_FIELD = np.int64(0x7FF << 52)
_EXP_ONE = np.int64(1023 << 52)
_EVEN_EXP = np.int64(-2 << 52)
