"""The batch executor's arithmetic in place: CArray products and sums written into arrays of
their own (a batch's peak of fresh memory, and fewer whole-batch passes), each giving exactly
the floats CArray's operators give (ops.CArray); the read-only (n,) views of a value that is
the same in every row; a batch's finiteness test in one pass per column. Each function's
docstring says when it writes in place and why the bits are the same; their users are
:class:`~linkage_ros.core.execute.PlanExecutor` and the closed-form batch solve
(core.solver.batch)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .ops import BATCH, CArray

#: the pose of a body at rest, 0-d: the same in every row (execute.PlanExecutor._run place_body)
ZERO_0D = np.zeros(())
REST_ROT, REST_T = CArray(np.ones(()), np.zeros(())), CArray(np.zeros(()), np.zeros(()))


def full(n: int, v: Any) -> Any:
    """A 0-d value as an (n,) array of it (anything else as it is): a read-only view of the
    one value, which costs no memory."""
    if np.ndim(v):
        return v
    # (np.broadcast_to does the same at ~10x the cost of this constructor)
    view = np.ndarray((n,), np.float64, np.array([v], np.float64), 0, (0,))
    view.flags.writeable = False
    return view


def full_c(n: int, z: Any) -> Any:
    """A 0-d point (CArray) as (n,) arrays of it (read-only views, see full)."""
    if isinstance(z, CArray) and np.ndim(z.re) == 0:
        return CArray(full(n, z.re), full(n, z.im))
    return z


def rest_angle(n: int, phi: Any) -> Any:
    """0.0 + phi (a member's angle in a body at rest) as (n,) values: a read-only view of a
    0-d angle, and an array of the frame's own as it is: no frame angle is -0.0 (each is
    0.0 + rel, or rel = x - offset with offset != 0, or a sum of such, and a float sum is
    -0.0 only where both terms are), so 0.0 + phi is phi to the bit (NaN too)."""
    if np.ndim(phi) == 0:
        return full(n, 0.0 + phi)
    return phi


def plus_rest(T: Any) -> Any:
    """T + REST_T (x + 0.0 and y + 0.0, as CArray's + computes it), in place where T is an
    at-rest frame's own (n,) arrays."""
    if not rows_of(T):
        return T + REST_T
    np.add(T.re, 0.0, out=T.re)
    np.add(T.im, 0.0, out=T.im)
    return T


def rows_of(z: Any) -> bool:
    """A CArray of (n,) float arrays (what the in-place forms below write into)."""
    return isinstance(z, CArray) and isinstance(z.re, np.ndarray) and z.re.ndim == 1


def is_point(r: Any) -> bool:
    """A complex constant or a CArray (a point CArray's * multiplies as complex numbers)."""
    return isinstance(r, (complex, CArray))


def times(rot: Any, r: Any) -> Any:
    """rot * r, as CArray's operators compute it (r a point), into two arrays."""
    if not (rows_of(rot) and is_point(r)):
        return rot * r
    return CArray(*_rotated(rot, r))


def _rotated(rot: CArray, r: Any) -> tuple[np.ndarray, np.ndarray]:
    """The parts of rot * r (rot (n,) rows, r a point) as CArray's * computes them: (rot.re
    r.real - rot.im r.imag, rot.re r.imag + rot.im r.real), into two new arrays."""
    re = rot.re * r.real
    t = rot.im * r.imag
    re -= t
    im = rot.re * r.imag
    im += np.multiply(rot.im, r.real, out=t)
    return re, im


def affine(rot: Any, r: Any, T: Any) -> Any:
    """rot * r + T, as CArray's operators compute it (r a point), into two arrays."""
    if not (rows_of(rot) and is_point(r)):
        return rot * r + T
    tre, tim = CArray.parts(T)
    re, im = _rotated(rot, r)
    re += tre
    if tim is not None:  # (a real T moves x only, as CArray's + does)
        im += tim
    return CArray(re, im)


def minus_rotated(P: Any, rot: Any, r: Any) -> Any:
    """P - rot * r, as CArray's operators compute it (r a point), into two arrays; P itself
    where that is P to the bit in every row (turned_about_origin: a body turned about its
    frame's origin, as a crank about a ground pivot at (0, 0))."""
    if r == 0 and turned_about_origin(P, rot):
        return P
    if not (rows_of(rot) and isinstance(P, CArray) and is_point(r)):
        return P - rot * r
    re, im = _rotated(rot, r)
    return CArray(np.subtract(P.re, re, out=re), np.subtract(P.im, im, out=im))


def slide_offset(
    vrot: Any, vT: Any, dv: Any, u: complex, x_ref: complex, slider: bool
) -> CArray | None:
    """A slide weld's member offset, as CArray's operators compute it, into arrays of its own:
    along = x_ref + (dv u.real + i dv u.imag), then (vrot along + vT) - vrot x_ref for the
    slider (``slider``), else (vrot x_ref + vT) - vrot along. None unless dv is an (n,)
    float array of the caller's own (written into) and vrot and vT CArrays (the caller
    takes the operators then)."""
    if not (owned_rows(dv, dv) and isinstance(vrot, CArray) and isinstance(vT, CArray)):
        return None
    # (checked before dv is written into: the caller's operators read it otherwise)
    parts = (vrot.re, vrot.im, vT.re, vT.im)
    if np.broadcast_shapes(dv.shape, *map(np.shape, parts)) != dv.shape:
        return None
    are = dv * u.real
    aim = np.multiply(dv, u.imag, out=dv)
    are += x_ref.real  # x_ref + CArray: CArray.__add__ (its part first)
    aim += x_ref.imag
    # vrot * along: (vrot.re are - vrot.im aim) + i (vrot.re aim + vrot.im are)
    t = np.multiply(vrot.im, aim)
    re = np.multiply(vrot.re, are)
    re -= t
    im = np.multiply(vrot.re, aim, out=aim)
    im += np.multiply(vrot.im, are, out=are)
    del t, are, aim
    fixed = vrot * x_ref  # (one value where vrot is: the body's root)
    if slider:
        re += vT.re
        im += vT.im
        re -= fixed.re
        im -= fixed.im
        return CArray(re, im)
    fixed = fixed + vT
    np.subtract(fixed.re, re, out=re)
    np.subtract(fixed.im, im, out=im)
    return CArray(re, im)


def expi_rows(phi: Any) -> Any:
    """ops.expi (e^{i phi}: cos and sin) of an (n,) float array without its broadcast (a
    few us of Python per call: the two arrays have phi's shape already)."""
    if isinstance(phi, np.ndarray) and phi.ndim == 1 and phi.dtype == np.float64:
        return CArray(np.cos(phi), np.sin(phi))
    return BATCH.expi(phi)


def turned_about_origin(P: Any, rot: Any) -> bool:
    """P - rot * 0 is P to the bit in every row: P one value (0-d) with no part -0.0, and
    every rot finite. rot * 0 is then a zero of either sign in each part (inf * 0 would be
    NaN), and p - z for a zero z is p itself unless p is -0.0 (-0.0 - -0.0 is +0.0)."""
    if not (isinstance(P, CArray) and np.ndim(P.re) == 0 and np.ndim(P.im) == 0):
        return False
    if any(v == 0.0 and math.copysign(1.0, v) < 0 for v in (float(P.re), float(P.im))):
        return False
    if not (rows_of(rot) and rot.re.size):
        return False
    # (max and min propagate NaN; -inf + inf is NaN, and a sum beyond the float range only
    # sends a finite batch the long way)
    spread = rot.re.max() + rot.re.min() + rot.im.max() + rot.im.min()
    return bool(np.isfinite(spread))


def owned_rows(a: Any, b: Any) -> bool:
    """a is an (n,) float array (written into: the caller's own) and b has its shape."""
    return (
        isinstance(a, np.ndarray)
        and a.ndim == 1
        and a.dtype == np.float64
        and a.flags.writeable
        and np.shape(b) == a.shape
    )


def all_positive(x: Any) -> bool:
    """Every entry of a batch's array > 0 (False for NaN, and for no entries)."""
    return isinstance(x, np.ndarray) and x.size > 0 and bool(x.min() > 0)


def every_finite_in(arrays: Any) -> bool:
    """Every value of every array finite, in one summing pass per array: a sum is finite only
    if each of its terms is (inf and NaN carry through a sum: inf - inf is NaN); a sum that
    is not finite (overflowed, or not) is answered value by value."""
    with np.errstate(over='ignore', invalid='ignore'):
        return all(math.isfinite(a.sum()) or bool(np.isfinite(a).all()) for a in arrays)
