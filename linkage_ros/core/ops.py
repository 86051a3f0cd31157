"""The two number backends every kinematic kernel runs on: one command or a batch.

Each kernel of the core (dyads, plan execution, result assembly) is written once against this
small interface, with points as complex numbers (x + iy). :data:`SCALAR` runs it on Python
floats and complex numbers (the node's one-command path: ~50x cheaper per command than numpy on
arrays of one); :data:`BATCH` runs the same code on numpy arrays with a leading batch axis (the
bag tool, sweeps, ``Solver.solve_batch``). Arithmetic operators, comparisons, ``&``, ``|`` and
``abs`` are shared by both; everything else a kernel needs is an attribute here.

Rules a kernel follows so that both backends give the same answer: no ``~`` (use ``not_``), no
``if`` on a value (use ``where``; ``batch`` tells whether masks are arrays), no division by a
value that may be 0 and no root of one that may be negative (``where`` a safe value first:
Python raises where numpy returns inf/NaN).
"""

from __future__ import annotations

import cmath
import math
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

# ---- one angle wrap: (-pi, pi] ------------------------------------------------------------------

#: pi to 60 digits, for the split of 2 pi below (the float math.pi is 1.2e-16 short of it)
_PI_DIGITS = '3.14159265358979323846264338327950288419716939937510582097494459'


def _two_pi_parts(bits: tuple[int, ...] = (33, 33, 53)) -> tuple[float, ...]:
    """2 pi as a sum of floats of ``bits`` significant bits each (Cody-Waite): k * part is exact
    for the first ones while k has at most 53 - 34 bits, so v - k * 2 pi keeps ~113 bits."""
    rest = 2 * Fraction(Decimal(_PI_DIGITS))
    parts = []
    for b in bits:
        ulp = Fraction(2) ** (math.frexp(float(rest))[1] - b)
        part = round(rest / ulp) * ulp
        parts.append(float(part))  # exact: at most b + 1 significant bits
        rest -= part
    return tuple(parts)


_TWO_PI_HI, _TWO_PI_MID, _TWO_PI_LO = _two_pi_parts()
#: |a| up to this is reduced by the three-part 2 pi (k = round(a / 2 pi) < 2^19); larger finite
#: angles (rare) by atan2 of the sine and cosine (libm's exact argument reduction)
WRAP_REDUCE_LIMIT = 2.0**21


_PI = math.pi
_NEG_PI = -math.pi
_TWO_PI = 2 * math.pi
_NEG_WRAP_REDUCE_LIMIT = -WRAP_REDUCE_LIMIT
_atan2, _sin, _cos = math.atan2, math.sin, math.cos


def wrap_one(a: float) -> float:
    """The angle wrap, one float: (-pi, pi] as it is (exact, and the common case), others
    reduced exactly to within an ulp or so (Cody-Waite with a three-part 2 pi; atan2 of sin and
    cos beyond WRAP_REDUCE_LIMIT, so 1e300 rad keeps full precision too); NaN if not finite.
    The batch form runs exactly these float operations elementwise. (Module constants, and the
    reduction's range tested first: one chained comparison, False for NaN and inf.)"""
    if _NEG_PI < a <= _PI:
        return a
    if _NEG_WRAP_REDUCE_LIMIT <= a <= WRAP_REDUCE_LIMIT:
        k = float(round(a / _TWO_PI))
        r = ((a - k * _TWO_PI_HI) - k * _TWO_PI_MID) - k * _TWO_PI_LO
        # k rounded off by one at an odd multiple of pi: back into (-pi, pi] as floats compare
        # (math.pi, as callers test it): -math.pi is given as math.pi, the same angle to 2.4e-16
        # rad (math.pi lies that much below pi, -math.pi above -pi)
        if r > _PI:
            return r - _TWO_PI
        if r <= _NEG_PI:
            return r + _TWO_PI
        return r
    if not math.isfinite(a):  # (not a - a: a numpy inf would warn)
        return math.nan
    w = _atan2(_sin(a), _cos(a))  # in [-pi, pi]
    return _PI if w == _NEG_PI else w


def _reduce_many(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, a - k 2 pi) elementwise, k = round(a / 2 pi): wrap_one's three-part reduction."""
    k = np.rint(a / (2 * math.pi))
    return k, ((a - k * _TWO_PI_HI) - k * _TWO_PI_MID) - k * _TWO_PI_LO


def _wrap_many(v: Any) -> Any:
    """wrap_one elementwise on an array (the same float operations)."""
    out = np.array(v, float)
    if not out.size:
        return out
    lo, hi = out.min(), out.max()  # (NaN: both NaN)
    if lo > -math.pi and hi <= math.pi:
        return out  # every angle already in (-pi, pi]: the common case, two passes
    if lo >= -WRAP_REDUCE_LIMIT and hi <= WRAP_REDUCE_LIMIT:
        # every angle finite and within the three-part reduction (a warm solve's angle rows a
        # turn or so off): all reduced in one pass, each exactly as below; k = 0 (in range)
        # keeps the angle itself (-0.0 too)
        k, r = _reduce_many(out)
        if np.abs(r).max() < math.pi:  # else a k rounded off by one: the full path
            reduced: np.ndarray = np.where(k == 0.0, out, r)
            return reduced
    wide = ~((out > -math.pi) & (out <= math.pi))  # NaN and inf included
    if not wide.any():
        return out
    w = out[wide]
    with np.errstate(invalid='ignore', over='ignore'):
        _, r = _reduce_many(w)
    r = np.where(r > math.pi, r - 2 * math.pi, np.where(r <= -math.pi, r + 2 * math.pi, r))
    huge = np.isfinite(w) & (np.abs(w) > WRAP_REDUCE_LIMIT)
    if huge.any():
        r[huge] = [wrap_one(a) for a in w[huge].tolist()]
    r[~np.isfinite(w)] = math.nan
    out[wide] = r
    return out


def nan_max(a: Any, b: Any) -> Any:
    """max propagating NaN from either side, like np.maximum (Python's max does not)."""
    return a if (a >= b or a != a) else b


def nan_min(a: Any, b: Any) -> Any:
    return a if (a <= b or a != a) else b


def _pow2_scale(ops: Any, m: Any) -> Any:
    """The even power of two S = 4**k with m / S in [1, 4) (1 where m is 0, negative or not
    finite). Dividing lengths by S is exact and commutes with square roots (sqrt(S) = 2**k), so
    a result formed from the normalised values and multiplied back by S is the one the unscaled
    formulas would give, except that no intermediate overflows (lengths near 1e308) or loses its
    digits to subnormals (5e-324)."""
    _, expo = ops.frexp(ops.where(ops.isfinite(m) & (m > 0), m, 1.0))
    # m in [2**(expo-1), 2**expo); the even exponent 2 * floor((expo - 1) / 2) lies in
    # [-1074, 1022]: S itself neither overflows nor underflows
    return ops.ldexp(1.0, ((expo - 1) >> 1) << 1)


def cabs_one(z: Any) -> float:
    """|z| of a Python complex, inf where it overflows (abs() raises OverflowError there,
    numpy returns inf: a kernel must not depend on which)."""
    try:
        r: float = abs(z)
    except OverflowError:
        return math.inf
    return r


class ScalarOps:
    """Python floats and complex numbers: one command."""

    batch = False
    pi = math.pi
    sqrt = staticmethod(math.sqrt)
    sin = staticmethod(math.sin)
    cos = staticmethod(math.cos)
    atan2 = staticmethod(math.atan2)
    hypot = staticmethod(math.hypot)
    frexp = staticmethod(math.frexp)
    ldexp = staticmethod(math.ldexp)
    isfinite = staticmethod(cmath.isfinite)  # real or complex
    maximum = staticmethod(nan_max)
    minimum = staticmethod(nan_min)

    @staticmethod
    def where(cond: Any, a: Any, b: Any) -> Any:
        return a if cond else b

    @staticmethod
    def not_(cond: Any) -> bool:
        return not cond

    @staticmethod
    def clip(x: Any, lo: Any, hi: Any) -> Any:
        return nan_min(nan_max(x, lo), hi)

    @staticmethod
    def expi(phi: float) -> complex:
        """e^{i phi} as cos + i sin (exactly those two roundings)."""
        return complex(math.cos(phi), math.sin(phi))

    @staticmethod
    def cplx(x: float, y: float) -> complex:
        return complex(x, y)

    wrap = staticmethod(wrap_one)
    cabs = staticmethod(cabs_one)  # |z| of a point, inf beyond the float range

    @staticmethod
    def cmax(z: complex) -> float:
        """max(|x|, |y|) of a point."""
        x, y = abs(z.real), abs(z.imag)
        return x if (x >= y or x != x) else y

    @staticmethod
    def any(mask: Any) -> bool:
        return bool(mask)

    def pow2_scale(self, m: Any) -> Any:
        return _pow2_scale(self, m)

    @staticmethod
    def full(value: Any, like: Any) -> Any:  # noqa: ARG004 (the batch twin needs like)
        return value


class CArray:
    """Complex points of a batch as two real arrays.

    numpy's own complex ufuncs take SIMD paths that round differently for long and short arrays
    (a row's answer would depend on the batch size); these operators use only real ufuncs, in
    exactly the formulas of Python's complex arithmetic, so a row is solved the same in any
    batch and within rounding of the one-command backend."""

    __slots__ = ('re', 'im')
    __array_priority__ = 1000.0  # ndarray (op) CArray defers to the reflected method here

    def __init__(self, re: Any, im: Any):
        self.re, self.im = re, im

    @property
    def real(self) -> Any:
        return self.re

    @property
    def imag(self) -> Any:
        return self.im

    @property
    def shape(self) -> tuple[int, ...]:
        return np.shape(self.re)

    def __getitem__(self, index: Any) -> CArray:
        return CArray(self.re[index], self.im[index])

    def __len__(self) -> int:
        return len(self.re)

    @staticmethod
    def parts(o: Any) -> tuple[Any, Any]:
        """An operand's (real, imaginary) parts; imaginary None for a real one (a real operand
        moves x only)."""
        if isinstance(o, CArray):
            return o.re, o.im
        if isinstance(o, complex):
            return o.real, o.imag
        if getattr(o, 'dtype', None) is not None and o.dtype.kind == 'c':
            raise TypeError('a numpy complex array met a CArray: make it with ops.cplx')
        return o, None

    def __add__(self, o: Any) -> CArray:
        ore, oim = self.parts(o)
        return CArray(self.re + ore, self.im if oim is None else self.im + oim)

    __radd__ = __add__

    def __sub__(self, o: Any) -> CArray:
        ore, oim = self.parts(o)
        return CArray(self.re - ore, self.im if oim is None else self.im - oim)

    def __rsub__(self, o: Any) -> CArray:
        ore, oim = self.parts(o)
        return CArray(ore - self.re, -self.im if oim is None else oim - self.im)

    def __neg__(self) -> CArray:
        return CArray(-self.re, -self.im)

    def __mul__(self, o: Any) -> CArray:
        ore, oim = self.parts(o)
        if oim is None:
            return CArray(self.re * ore, self.im * ore)
        return CArray(self.re * ore - self.im * oim, self.re * oim + self.im * ore)

    __rmul__ = __mul__

    def __truediv__(self, o: Any) -> CArray:
        ore, oim = self.parts(o)
        if oim is not None:
            raise TypeError('CArray divides by real values only')
        return CArray(self.re / ore, self.im / ore)

    def __abs__(self) -> Any:
        return np.hypot(self.re, self.im)


def _batch_where(cond: Any, a: Any, b: Any) -> Any:
    """np.where, for complex points (CArray or Python complex) too."""
    if isinstance(a, (CArray, complex)) or isinstance(b, (CArray, complex)):
        are, aim = CArray.parts(a)
        bre, bim = CArray.parts(b)
        aim = 0.0 if aim is None else aim
        bim = 0.0 if bim is None else bim
        return CArray(np.where(cond, are, bre), np.where(cond, aim, bim))
    return np.where(cond, a, b)


def _batch_isfinite(x: Any) -> Any:
    if isinstance(x, CArray):
        return np.isfinite(x.re) & np.isfinite(x.im)
    if isinstance(x, complex):
        return cmath.isfinite(x)
    return np.isfinite(x)


class BatchOps:
    """numpy arrays with a leading batch axis: many commands at once (points: CArray)."""

    batch = True
    pi = math.pi
    sqrt = staticmethod(np.sqrt)
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    atan2 = staticmethod(np.arctan2)
    hypot = staticmethod(np.hypot)
    frexp = staticmethod(np.frexp)
    ldexp = staticmethod(np.ldexp)
    isfinite = staticmethod(_batch_isfinite)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    where = staticmethod(_batch_where)
    not_ = staticmethod(np.logical_not)
    clip = staticmethod(np.clip)

    @staticmethod
    def expi(phi: Any) -> Any:
        return BatchOps.cplx(np.cos(phi), np.sin(phi))

    @staticmethod
    def cplx(x: Any, y: Any) -> CArray:
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        return CArray(x, y)

    wrap = staticmethod(_wrap_many)
    cabs = staticmethod(abs)  # CArray's |z| (hypot: inf beyond the float range)

    @staticmethod
    def cmax(z: Any) -> Any:
        return np.maximum(np.abs(z.real), np.abs(z.imag))

    @staticmethod
    def any(mask: Any) -> bool:
        return bool(np.any(mask))

    def pow2_scale(self, m: Any) -> Any:
        return _pow2_scale(self, np.asarray(m, float))

    @staticmethod
    def full(value: Any, like: Any) -> Any:
        return np.full(np.shape(like), value)


SCALAR = ScalarOps()
BATCH = BatchOps()


def to_complex(xy: Any) -> CArray:
    """(..., 2) coordinates -> batched complex points."""
    a = np.asarray(xy, float)
    return CArray(a[..., 0], a[..., 1])


def to_xy(z: Any) -> np.ndarray:
    """Batched complex points (CArray, or a numpy complex array) -> (..., 2) coordinates."""
    x, y = np.broadcast_arrays(np.asarray(z.real, float), np.asarray(z.imag, float))
    return np.stack([x, y], axis=-1)
