"""Result types, helpers, triangle formulas and the batched circle intersection (core.dyads)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from ..dyads import TANGENCY_TOL, circle_circle, kahan_four_area

# Residual reported for non-finite inputs, where no misclosure can be measured: one full
# link length, i.e. "completely wrong", while keeping every output finite.
NONFINITE_RESIDUAL = 1.0


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


def as_float_array(x: npt.ArrayLike) -> np.ndarray:
    return np.asarray(x, dtype=float)


def scalar_out(x: np.ndarray) -> Any:
    """Turn 0-d arrays into numpy scalars so scalar calls give scalar-like results."""
    return x[()] if isinstance(x, np.ndarray) and x.ndim == 0 else x


def branch_sign(s: npt.ArrayLike) -> np.ndarray:
    """Branch / sign argument -> exactly +1.0 or -1.0 (negative means -1, anything else +1)."""
    return np.where(as_float_array(s) < 0, -1.0, 1.0)


def triangle_area(a: npt.ArrayLike, b: npt.ArrayLike, c: npt.ArrayLike) -> np.ndarray:
    """Area [length^2] of the triangle with sides a, b, c [length], by Kahan's stable formula.

    Side lengths that violate the triangle inequality (no triangle) give 0, so callers that care
    must check the inequality themselves (:func:`circle_intersection` does).
    """
    with np.errstate(invalid='ignore', over='ignore'):
        four_area_n, _, _, scale = kahan_four_area(a, b, c)
        area: np.ndarray = scalar_out(
            0.25 * four_area_n * scale * scale
        )  # (a numpy scalar for 0-d)
        return area


def angle_opposite(
    side_a: npt.ArrayLike, side_b: npt.ArrayLike, opposite: npt.ArrayLike
) -> np.ndarray:
    """Angle [rad, 0..pi] between sides a and b of a triangle, opposite the third side.

    Computed as atan2(4*area, a^2 + b^2 - opposite^2) on sides normalised by the longest (= the
    cosine rule, but accurate near 0 and pi where arccos loses half of its digits).
    Out-of-range sides give 0 or pi, i.e. the clipped cosine rule.
    """
    a, b, c = np.broadcast_arrays(
        as_float_array(side_a), as_float_array(side_b), as_float_array(opposite)
    )
    with np.errstate(invalid='ignore'):
        four_area_n, _, _, scale = kahan_four_area(a, b, c)
        an, bn, cn = a / scale, b / scale, c / scale
        angle: np.ndarray = scalar_out(np.arctan2(four_area_n, (an * an + bn * bn) - cn * cn))
        return angle


# --------------------------------------------------------------------------- circle-circle


def circle_intersection(
    c1: npt.ArrayLike,
    r1: npt.ArrayLike,
    c2: npt.ArrayLike,
    r2: npt.ArrayLike,
    sign: npt.ArrayLike,
    tangency_tol: float = TANGENCY_TOL,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    sol = circle_circle(c1, r1, c2, r2, branch_sign(sign), tangency_tol)
    return sol.point, scalar_out(sol.height), scalar_out(sol.ok)
