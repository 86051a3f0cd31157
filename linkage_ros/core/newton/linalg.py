"""The linear algebra of one linearisation point: LU (LAPACK getrf) of the scale-free Jacobian,
the Newton step from it, det J sign tracking and the condition number."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from .results import COND_EXACT, SINGULAR_COND, LUFactor


class Lapack(NamedTuple):
    """scipy's LAPACK wrappers the solver uses."""

    getrf: Callable[..., Any]
    getrs: Callable[..., Any]
    gecon: Callable[..., Any]


_LAPACK: list[Lapack] = []


def lapack() -> Lapack:
    """(getrf, getrs, gecon), imported on first use (scipy.linalg costs import time)."""
    if not _LAPACK:
        from scipy.linalg import lapack as lp

        _LAPACK.append(Lapack(lp.dgetrf, lp.dgetrs, lp.dgecon))
    return _LAPACK[0]


def factor(J: np.ndarray) -> LUFactor | None:
    """LU of J with its det sign; None if J is singular to working precision (an exactly zero
    pivot), not square or empty."""
    if J.shape[0] != J.shape[1] or J.size == 0:
        return None
    lu, piv, info = lapack().getrf(J)
    if info != 0:
        return None
    # det J's sign: a negative pivot or a row swap flips it (plain loops: generators summed
    # cost ~1.5 us more per factor on a 9 x 9)
    flips = 0
    for v in lu.diagonal().tolist():
        if v < 0.0:
            flips += 1
    for row, p in enumerate(piv.tolist()):
        if p != row:
            flips += 1
    return lu, piv, (-1 if flips % 2 else 1)


def lu_step(fac: LUFactor, F: np.ndarray) -> np.ndarray | None:
    """dy solving J dy = -F from a factorisation (None if not finite)."""
    dy, info = lapack().getrs(fac[0], fac[1], -F)
    return dy if info == 0 and math.isfinite(float(dy.sum())) else None


def scaled_cond(J: np.ndarray) -> float:
    """Exact 2-norm condition number of J with unit-norm columns (an SVD)."""
    if J.size == 0:
        return 1.0
    peak = np.max(np.abs(J), axis=0)  # pre-scale: column norms of 1e300 overflow
    peak[peak == 0] = 1.0
    Jn = J / peak
    norms = np.linalg.norm(Jn, axis=0)
    norms[norms == 0] = 1.0
    try:
        return float(np.linalg.cond(Jn / norms))
    except np.linalg.LinAlgError:
        return float('inf')


def cond(J: np.ndarray, fac: LUFactor | None) -> float:
    """Condition number of the scale-free J: LAPACK's 1-norm estimate from its LU (1.5-7x
    the exact value on the scenes), or the exact 2-norm one of J with unit-norm columns
    (scaled_cond, an SVD) where the estimate exceeds COND_EXACT or there is no LU."""
    if fac is not None:
        rc, info = lapack().gecon(fac[0], float(abs(J).sum(axis=0).max()))
        if info == 0 and rc * COND_EXACT >= 1.0:
            return float(1.0 / rc)
    return scaled_cond(J)


def side_ok(sign0: int, J: np.ndarray, fac: LUFactor | None) -> bool:
    """The point is on the start's side of det J = 0 (or on the singular set itself, e.g. a
    toggle that is the answer, where the sign is rounding noise)."""
    if sign0 == 0 or (fac is not None and fac[2] == sign0):
        return True
    return scaled_cond(J) > SINGULAR_COND


def sign_of(J: np.ndarray, fac: LUFactor | None) -> int:
    """det J sign for tracking, 0 where J is singular (cond above SINGULAR_COND)."""
    if fac is None:
        return 0
    return fac[2] if cond(J, fac) < SINGULAR_COND else 0


# ---- the same on a stack of square matrices (the batched solve) ---------------------------------
def det_signs(J: np.ndarray) -> np.ndarray:
    """(K,) int sign of det of a (K, n, n) stack; 0 where singular or not finite."""
    if J.shape[0] == 0:
        return np.zeros(0, int)
    # LAPACK's LU takes NaN and inf without failing (the log|det| comes out NaN): no copy of
    # the finite rows needed
    with np.errstate(invalid='ignore', divide='ignore'):
        s, logdet = np.linalg.slogdet(J)
    signs: np.ndarray = np.where(np.isfinite(logdet), s, 0.0).astype(int)
    return signs


def newton_steps(J: np.ndarray, F: np.ndarray) -> np.ndarray:
    """dy (K, n) solving J dy = -F for a (K, n, n) stack; NaN rows where J is singular (one
    singular matrix makes np.linalg.solve raise for the whole stack: then solve the rest)."""
    try:
        steps: np.ndarray = np.linalg.solve(J, -F[:, :, None])[:, :, 0]
        return steps
    except np.linalg.LinAlgError:
        dy = np.full(F.shape, math.nan)
        regular = det_signs(J) != 0
        if regular.any():
            dy[regular] = np.linalg.solve(J[regular], -F[regular][:, :, None])[:, :, 0]
        return dy
