"""The offset slider-crank: crank angle -> rod angle and slider position, back, and the stroke."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from ..dyads import TANGENCY_TOL
from .blocks import (
    BlockWork,
    FastRange,
    Good,
    Num,
    fast_atan2,
    good_mask,
    rrr_block,
    run_blocked,
    shaped_solution,
    zero_where_not,
)
from .common import (
    NONFINITE_RESIDUAL,
    SliderCrankInverseSolution,
    SliderCrankSolution,
    as_float_array,
    branch_sign,
    circle_intersection,
)
from .four_r import atan2_half_open, finish_outputs, general_inputs, longest_length

# --------------------------------------------------------------------------- slider-crank

_LEN, _COORD = FastRange.LENGTH, FastRange.COORDINATE


def _slider_residual(
    r: np.ndarray, l: np.ndarray, e: np.ndarray, t2: np.ndarray, t3: np.ndarray, x: np.ndarray
) -> np.ndarray:
    """|O2A + AB - (x, e)| / max(r, l, |e|)."""
    rx = r * np.cos(t2) + l * np.cos(t3) - x
    ry = r * np.sin(t2) + l * np.sin(t3) - e
    scale = np.maximum(np.maximum(np.abs(r), np.abs(l)), np.abs(e))
    residual: np.ndarray = np.hypot(rx, ry) / np.where(scale > 0, scale, 1.0)
    return residual


def _slider_forward_fast(
    r: Num, l: Num, e: Num, t2: Num, sgn: Num, tol: float, out: Sequence[np.ndarray], ws: BlockWork
) -> Good:
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
    scale = longest_length(r, l, np.abs(e))
    np.greater_equal(gap, np.multiply(scale, -tol), out=ok)
    # |B_x - A_x| = sqrt((l - |dy|)(l + |dy|)); 0 where clamped or not ok (gap <= 0 there)
    np.maximum(gap, 0.0, out=gap)
    ady += l
    gap *= ady
    np.sqrt(gap, out=hx)
    hx *= sgn
    np.add(a[0], hx, out=x)
    fast_atan2(dy, hx, t3, ws)  # where not ok: the rod pointing straight at the line (+-pi/2)
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
    zero_where_not(ok, t3)
    return good_mask(res, None, ws)


def _slider_forward_general(
    r: Num, l: Num, e: Num, t2: Num, br: Num, tangency_tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    (r, l, e, t2, br), finite, S = general_inputs((r, l, e, t2, br), 3)
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
        t3 = np.where(ok, atan2_half_open(dy, br * half), np.arctan2(dy, 0.0))
        residual = _slider_residual(r, l, e, t2, t3, x)
        # back to length units; an x beyond the float range (r + l near 1.8e308) is not
        # representable: not ok, x = A_x (finite: |A_x| <= r) and the residual of a wrong answer
        x, ax = x * S, ax * S
        beyond = ok & ~np.isfinite(x)
        ok &= ~beyond
        x = np.where(beyond, ax, x)
        residual = np.where(beyond, NONFINITE_RESIDUAL, residual)
    (t3,), residual = finish_outputs((t3,), ok, finite, residual)
    x = np.where(finite, x, 0.0)
    return x, t3, ok, residual


def slider_crank_forward(
    r: npt.ArrayLike,
    l: npt.ArrayLike,
    e: npt.ArrayLike,
    theta2: npt.ArrayLike,
    branch: npt.ArrayLike = 1,
    tangency_tol: float = TANGENCY_TOL,
) -> SliderCrankSolution:
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
    args = (
        as_float_array(r),
        as_float_array(l),
        as_float_array(e),
        as_float_array(theta2),
        branch_sign(branch),
    )
    with np.errstate(all='ignore'):
        outs, shape = run_blocked(
            _slider_forward_fast,
            _slider_forward_general,
            args,
            (_LEN, _LEN, _COORD, None, None),
            1,
            float(tangency_tol),
        )
    return shaped_solution(SliderCrankSolution, outs, shape)


def _slider_inverse_fast(
    r: Num, l: Num, e: Num, x: Num, sgn: Num, tol: float, out: Sequence[np.ndarray], ws: BlockWork
) -> Good:
    angles, ok, res = out  # angles = (theta2, theta3)
    w = ws('w', 2)  # w = B - O2 = (x, e)
    np.copyto(w[0], x)
    np.copyto(w[1], e)
    # A from circle (O2, r) and circle (B, l): v = (A - O2, A - B)
    v, _, mis, good = rrr_block(w, r, l, sgn, tol, ok, ws)
    np.negative(v[1], out=v[1])  # B - A
    fast_atan2(v[:, 1], v[:, 0], angles, ws)
    np.divide(mis, longest_length(r, l, np.abs(e)), out=res)
    zero_where_not(ok, angles)
    return good


def _slider_inverse_general(
    r: Num, l: Num, e: Num, x: Num, br: Num, tangency_tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    (r, l, e, x, br), finite, _ = general_inputs((r, l, e, x, br), 4)
    with np.errstate(invalid='ignore', over='ignore'):
        a, _, ok = circle_intersection(
            np.zeros(x.shape + (2,)), r, np.stack([x, e], -1), l, br, tangency_tol
        )
        ok = np.asarray(ok) & finite
        ax, ay = a[..., 0], a[..., 1]
        t2 = atan2_half_open(ay, ax)
        t3 = atan2_half_open(e - ay, x - ax)
        residual = _slider_residual(r, l, e, t2, t3, x)
    (t2, t3), residual = finish_outputs((t2, t3), ok, finite, residual)
    return t2, t3, ok, residual


def slider_crank_inverse(
    r: npt.ArrayLike,
    l: npt.ArrayLike,
    e: npt.ArrayLike,
    x: npt.ArrayLike,
    branch: npt.ArrayLike = 1,
    tangency_tol: float = TANGENCY_TOL,
) -> SliderCrankInverseSolution:
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
    args = (
        as_float_array(r),
        as_float_array(l),
        as_float_array(e),
        as_float_array(x),
        branch_sign(branch),
    )
    with np.errstate(all='ignore'):
        outs, shape = run_blocked(
            _slider_inverse_fast,
            _slider_inverse_general,
            args,
            (_LEN, _LEN, _COORD, _COORD, None),
            1,
            float(tangency_tol),
        )
    return shaped_solution(SliderCrankInverseSolution, outs, shape)


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
