"""The fast block kernels: in-place numpy over blocks of 16384 elements, the general form where
they do not hold. Measured 5.6x faster than the general dyad kernel (core.dyads) on 1e6
four-bar rows: the vectorised four-bar throughput rests on them."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from enum import Enum
from typing import Literal, TypeVar

import numpy as np

from .common import scalar_out

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
# cache, are written in place (ufunc ``out=``) and come from a BlockWork that outlives the call.
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

#: a kernel's argument: a float (a scalar argument stays one: no per-element work) or an array
Num = float | np.ndarray
#: what a fast kernel vouches for: True (every element of the block) or the mask of them
Good = Literal[True] | np.ndarray
#: the solution tuple a public function returns (FourBarSolution, ...)
_Solution = TypeVar('_Solution')


class BlockWork:
    """Named work arrays shared by the blocks of a call (``m`` = the current block length)."""

    def __init__(self, size: int):
        self.size = self.m = size
        self._arrays: dict[tuple[str, tuple[int, ...], type], np.ndarray] = {}

    _full = threading.local()

    @classmethod
    def get(cls, n: int) -> BlockWork:
        """The work arrays for a call over n elements.  Full-size ones are kept per thread for
        the next call: allocating them afresh page-faults a few MB again on every call."""
        if n < _BLOCK:
            return cls(n)
        ws: BlockWork | None = getattr(cls._full, 'ws', None)
        if ws is None or ws.size != _BLOCK:
            ws = cls._full.ws = cls(_BLOCK)
        ws.m = ws.size
        return ws

    def __call__(self, name: str, *lead: int, dtype: type = float) -> np.ndarray:
        """The array ``name`` of shape lead + (m,); its contents are whatever was left there."""
        a = self._arrays.get((name, lead, dtype))
        if a is None:
            a = self._arrays[(name, lead, dtype)] = np.empty(lead + (self.size,), dtype)
        return a if self.m == self.size else a[..., : self.m]


def fast_atan2(y: np.ndarray, x: np.ndarray, out: np.ndarray, ws: BlockWork) -> None:
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


def rrr_block(
    w: np.ndarray, r1: Num, r2: Num, sgn: Num, tol: float, ok: np.ndarray, ws: BlockWork
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Good]:
    """Circle (c1, r1) and circle (c2, r2), w = c2 - c1 as a (2, m) array, on one block.

    The same Kahan height and relative tangency clamp as :func:`dyads.circle_circle`, without
    its scaling (valid in the [_LO, _HI] range).  Writes ``ok`` and returns ``(v, area4, mis,
    good)``: v (2, 2, m) holds v[0] = X - c1 and v[1] = X - c2, X on the ``sgn`` side (where not
    ok the point of circle 1 nearest circle 2 on the centre line); area4 = 4 * area of the
    triangle (d, r1, r2), 0 where not ok or clamped; mis = |r1 v1/|v1| - r2 v2/|v2| - w|, the
    misclosure of the loop c1 -> X -> c2 drawn with the exact radii along the solved
    directions; ``good`` as :func:`good_mask`.
    """
    p, d2, d = ws('p', 2), ws('d2'), ws('d')
    np.multiply(w, w, out=p)
    np.add(p[0], p[1], out=d2)
    np.sqrt(d2, out=d)
    # Kahan's sides sorted, big >= mid >= small: bm = big - mid, s = big + mid
    big, bm, s = ws('big'), ws('bm'), ws('s')
    hi: Num
    lo: Num
    small: Num
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
    return v, area4, mis, good_mask(mis, d2, ws)


def good_mask(res: np.ndarray, d2: np.ndarray | None, ws: BlockWork) -> Good:
    """True, or the mask of the elements the fast formulas hold for: ``res`` finite (NaN or inf
    anywhere upstream reaches it) and, if given, d2 = |w|^2 >= _LO2.  Block-level reductions
    first: the per-element mask is only formed for a block that needs it."""
    if math.isfinite(res.sum()) and (d2 is None or d2.min() >= _LO2):
        return True
    good: np.ndarray = np.isfinite(res, out=ws('good', dtype=bool))
    if d2 is not None:
        good &= np.greater_equal(d2, _LO2, out=ws('b', dtype=bool))
    return good


def zero_where_not(ok: np.ndarray, *arrays: np.ndarray) -> None:
    """The placeholders: 0 where not ok (in place, along the last axis)."""
    if not ok.all():
        bad = ~ok
        for a in arrays:
            np.copyto(a, 0.0, where=bad)  # (a[..., bad] = 0 costs 4x more)


class FastRange(Enum):
    """Where an argument of a blocked kernel is safe for the fast (unscaled) formulas."""

    LENGTH = 'length'  # [_LO, _HI]: squares neither underflow nor overflow
    COORDINATE = 'coordinate'  # [-_HI, _HI]


def _in_range(a: np.ndarray, kind: FastRange) -> Good:
    """True, or the mask of the elements of ``a`` inside the fast range of its ``kind``
    (NaN is outside)."""
    lo = _LO if kind is FastRange.LENGTH else -_HI
    if lo <= a.min() and a.max() <= _HI:
        return True
    return (a >= lo) & (a <= _HI)


def run_blocked(
    fast: Callable[..., Good],
    general: Callable[..., Sequence[np.ndarray]],
    args: Sequence[np.ndarray],
    kinds: Sequence[FastRange | None],
    nout: int,
    tol: float,
) -> tuple[list[np.ndarray], tuple[int, ...]]:
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
    flat: list[Num] = []
    checks: list[tuple[np.ndarray, FastRange]] = []
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
    ws = BlockWork.get(n)
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


def shaped_solution(
    cls: Callable[..., _Solution], outs: Sequence[np.ndarray], shape: tuple[int, ...]
) -> _Solution:
    return cls(*(scalar_out(o.reshape(shape)) for o in outs))
