"""The 4R four-bar: crank angle -> coupler and rocker angles, and back."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import numpy.typing as npt

from ..dyads import TANGENCY_TOL, pow2_scale
from .blocks import (
    BlockWork,
    FastRange,
    Good,
    Num,
    fast_atan2,
    rrr_block,
    run_blocked,
    shaped_solution,
    zero_where_not,
)
from .common import (
    NONFINITE_RESIDUAL,
    FourBarInverseSolution,
    FourBarSolution,
    as_float_array,
    branch_sign,
    circle_intersection,
)

# --------------------------------------------------------------------------- four-bar

_LEN, _COORD = FastRange.LENGTH, FastRange.COORDINATE


def _closure_residual(
    l1: np.ndarray,
    l2: np.ndarray,
    l3: np.ndarray,
    l4: np.ndarray,
    t2: np.ndarray,
    t3: np.ndarray,
    t4: np.ndarray,
) -> np.ndarray:
    """|O2A + AB - O2O4 - O4B| / longest link, from angles."""
    rx = l2 * np.cos(t2) + l3 * np.cos(t3) - l1 - l4 * np.cos(t4)
    ry = l2 * np.sin(t2) + l3 * np.sin(t3) - l4 * np.sin(t4)
    scale = np.maximum(np.maximum(np.abs(l1), np.abs(l2)), np.maximum(np.abs(l3), np.abs(l4)))
    residual: np.ndarray = np.hypot(rx, ry) / np.where(scale > 0, scale, 1.0)
    return residual


def _transmission_sin(
    ax: np.ndarray,
    ay: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    o4x: np.ndarray,
    o4y: np.ndarray,
    l3: np.ndarray,
    l4: np.ndarray,
) -> np.ndarray:
    """|sin| of the angle at B between B->A (coupler) and B->O4 (rocker)."""
    # normalise before multiplying so huge lengths cannot overflow the cross product
    s3 = np.where(l3 > 0, l3, 1.0)
    s4 = np.where(l4 > 0, l4, 1.0)
    cross = ((ax - bx) / s3) * ((o4y - by) / s4) - ((ay - by) / s3) * ((o4x - bx) / s4)
    # NaN (0 * inf) only for a link ~1e-308 times the others, accepted by a tangency clamp of
    # order 1: a degenerate configuration, reported as the singularity (0)
    tsin: np.ndarray = np.clip(np.nan_to_num(np.abs(cross), nan=0.0), 0.0, 1.0)
    return tsin


def atan2_half_open(y: npt.ArrayLike, x: npt.ArrayLike) -> np.ndarray:
    """np.arctan2 with -pi (y = -0 or a tiny negative y, x < 0) returned as +pi: (-pi, pi]."""
    a = np.arctan2(y, x)
    return np.where(a == -np.pi, np.pi, a)


def _normalised(*lengths: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """The lengths divided by the power of four S (per element, exact) that brings the longest
    to [1, 4), and S.  The general forms solve the normalised linkage: angles and the relative
    residual do not depend on the scale, and no intermediate overflows (lengths or coordinates
    near 1e308) or loses its digits to subnormals (lengths near 5e-324)."""
    m = np.abs(lengths[0])
    for v in lengths[1:]:
        m = np.maximum(m, np.abs(v))
    S = pow2_scale(m)
    return [v / S for v in lengths], S


def general_inputs(
    args: Sequence[Num], scaled: int
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The general forms' arguments (the branch last) broadcast to one shape, the mask of the
    elements whose other arguments are all finite, and the first ``scaled`` of them (the
    lengths) divided by the power of four S of :func:`_normalised`: (args, finite, S)."""
    arrays = np.broadcast_arrays(*(as_float_array(a) for a in args))
    finite = np.isfinite(arrays[0])
    for a in arrays[1:-1]:
        finite = finite & np.isfinite(a)
    with np.errstate(invalid='ignore', over='ignore'):
        lengths, S = _normalised(*arrays[:scaled])
    return [*lengths, *arrays[scaled:]], finite, S


def finish_outputs(
    values: Iterable[np.ndarray], ok: np.ndarray, finite: np.ndarray, residual: np.ndarray
) -> tuple[list[np.ndarray], np.ndarray]:
    """Zero the placeholders where not ok and make the residual finite."""
    vals = [np.where(ok, v, 0.0) for v in values]
    res = np.where(finite & np.isfinite(residual), residual, NONFINITE_RESIDUAL)
    return vals, res


def longest_length(*lengths: Num) -> Num:
    if all(isinstance(v, float) for v in lengths):
        return max(lengths)  # scalars: no ufunc call per block
    m = lengths[0]
    for v in lengths[1:]:
        m = np.maximum(m, v)
    return m


def _fourbar_forward_fast(
    l1: Num,
    l2: Num,
    l3: Num,
    l4: Num,
    t2: Num,
    sgn: Num,
    tol: float,
    out: Sequence[np.ndarray],
    ws: BlockWork,
) -> Good:
    angles, ok, tsin, res = out  # angles = (theta3, theta4)
    w = ws('w', 2)  # w = O4 - A
    np.cos(t2, out=w[0])
    np.sin(t2, out=w[1])
    w *= -l2
    w[0] += l1
    # B from circle (A, l3) and circle (O4, l4): v = (B - A, B - O4)
    v, area4, mis, good = rrr_block(w, l3, l4, sgn, tol, ok, ws)
    fast_atan2(v[:, 1], v[:, 0], angles, ws)
    # |sin mu| = 2 * area(A, B, O4) / (l3 l4), the Kahan area: accurate near the toggles too
    np.multiply(area4, 0.5 / (l3 * l4), out=tsin)
    np.minimum(tsin, 1.0, out=tsin)
    np.divide(mis, longest_length(l1, l2, l3, l4), out=res)
    zero_where_not(ok, angles)
    return good


def _fourbar_forward_general(
    l1: Num, l2: Num, l3: Num, l4: Num, t2: Num, br: Num, tangency_tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    (l1, l2, l3, l4, t2, br), finite, _ = general_inputs((l1, l2, l3, l4, t2, br), 4)
    with np.errstate(invalid='ignore', over='ignore'):
        ax, ay = l2 * np.cos(t2), l2 * np.sin(t2)
        o4x, o4y = l1, np.zeros_like(l1)
        b, _, ok = circle_intersection(
            np.stack([ax, ay], -1), l3, np.stack([o4x, o4y], -1), l4, br, tangency_tol
        )
        ok = np.asarray(ok) & finite & (l1 >= 0) & (l2 >= 0)
        bx, by = b[..., 0], b[..., 1]
        t3 = atan2_half_open(by - ay, bx - ax)
        t4 = atan2_half_open(by - o4y, bx - o4x)
        tsin = _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4)
        residual = _closure_residual(l1, l2, l3, l4, t2, t3, t4)
    (t3, t4, tsin), residual = finish_outputs((t3, t4, tsin), ok, finite, residual)
    return t3, t4, ok, tsin, residual


def fourbar_forward(
    l1: npt.ArrayLike,
    l2: npt.ArrayLike,
    l3: npt.ArrayLike,
    l4: npt.ArrayLike,
    theta2: npt.ArrayLike,
    branch: npt.ArrayLike = 1,
    tangency_tol: float = TANGENCY_TOL,
) -> FourBarSolution:
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
    args = (
        as_float_array(l1),
        as_float_array(l2),
        as_float_array(l3),
        as_float_array(l4),
        as_float_array(theta2),
        branch_sign(branch),
    )
    with np.errstate(all='ignore'):
        outs, shape = run_blocked(
            _fourbar_forward_fast,
            _fourbar_forward_general,
            args,
            (_LEN, _LEN, _LEN, _LEN, None, None),
            2,
            float(tangency_tol),
        )
    return shaped_solution(FourBarSolution, outs, shape)


def _fourbar_inverse_fast(
    l1: Num,
    l2: Num,
    l3: Num,
    l4: Num,
    t4: Num,
    sgn: Num,
    tol: float,
    out: Sequence[np.ndarray],
    ws: BlockWork,
) -> Good:
    angles, ok, tsin, res = out  # angles = (theta2, theta3)
    cs, w = ws('cs', 2), ws('w', 2)
    np.cos(t4, out=cs[0])
    np.sin(t4, out=cs[1])
    np.multiply(cs, -l4, out=w)  # w = O2 - B = -(O4 + l4 (c4, s4))
    w[0] -= l1
    # A from circle (B, l3) and circle (O2, l2): v = (A - B, A - O2)
    v, _, mis, good = rrr_block(w, l3, l2, sgn, tol, ok, ws)
    np.negative(v[0], out=v[0])  # B - A
    v = v[::-1]  # (A - O2, B - A): theta2, theta3
    fast_atan2(v[:, 1], v[:, 0], angles, ws)
    # |sin mu| = |cross(B - A, B - O4)| / (l3 l4), B - O4 = l4 (c4, s4)
    ba = v[1]
    ba *= cs[::-1]
    np.subtract(ba[0], ba[1], out=tsin)
    np.abs(tsin, out=tsin)
    tsin /= l3
    np.minimum(tsin, 1.0, out=tsin)
    np.divide(mis, longest_length(l1, l2, l3, l4), out=res)
    zero_where_not(ok, angles, tsin)
    return good


def _fourbar_inverse_general(
    l1: Num, l2: Num, l3: Num, l4: Num, t4: Num, br: Num, tangency_tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    (l1, l2, l3, l4, t4, br), finite, _ = general_inputs((l1, l2, l3, l4, t4, br), 4)
    with np.errstate(invalid='ignore', over='ignore'):
        o4x, o4y = l1, np.zeros_like(l1)
        bx, by = o4x + l4 * np.cos(t4), o4y + l4 * np.sin(t4)
        a, _, ok = circle_intersection(
            np.stack([bx, by], -1), l3, np.zeros(bx.shape + (2,)), l2, br, tangency_tol
        )
        ok = np.asarray(ok) & finite & (l1 >= 0) & (l4 >= 0)
        ax, ay = a[..., 0], a[..., 1]
        t2 = atan2_half_open(ay, ax)
        t3 = atan2_half_open(by - ay, bx - ax)
        tsin = _transmission_sin(ax, ay, bx, by, o4x, o4y, l3, l4)
        residual = _closure_residual(l1, l2, l3, l4, t2, t3, t4)
    (t2, t3, tsin), residual = finish_outputs((t2, t3, tsin), ok, finite, residual)
    return t2, t3, ok, tsin, residual


def fourbar_inverse(
    l1: npt.ArrayLike,
    l2: npt.ArrayLike,
    l3: npt.ArrayLike,
    l4: npt.ArrayLike,
    theta4: npt.ArrayLike,
    branch: npt.ArrayLike = 1,
    tangency_tol: float = TANGENCY_TOL,
) -> FourBarInverseSolution:
    """Four-bar inverse position analysis: rocker angle -> crank and coupler angles.

    B = O4 + l4*(cos theta4, sin theta4); A is the intersection of circle (B, l3) and circle
    (O2, l2) to the left (``branch`` = +1) or right (-1) of the vector B -> O2.

    Returns
    -------
    FourBarInverseSolution(theta2, theta3, ok, transmission_sin, residual)
        Same conventions as :func:`fourbar_forward` (transmission angle still taken at B,
        between coupler and rocker).
    """
    args = (
        as_float_array(l1),
        as_float_array(l2),
        as_float_array(l3),
        as_float_array(l4),
        as_float_array(theta4),
        branch_sign(branch),
    )
    with np.errstate(all='ignore'):
        outs, shape = run_blocked(
            _fourbar_inverse_fast,
            _fourbar_inverse_general,
            args,
            (_LEN, _LEN, _LEN, _LEN, None, None),
            2,
            float(tangency_tol),
        )
    return shaped_solution(FourBarInverseSolution, outs, shape)
