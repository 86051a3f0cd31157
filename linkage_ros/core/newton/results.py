"""What a Newton solve gives (one system or a batch) and the solver's constants."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, TypeAlias

import numpy as np

from ..tolerances import NEWTON_TOL as NEWTON_TOL  # re-exported: Newton's default

#: LAPACK's LU of a square J: (lu, piv, det sign), getrf's packed L and U, its row pivots and
#: the sign of det J (+1 / -1) read off them. A plain tuple, not a NamedTuple: the scalar solve
#: builds two per command, and a NamedTuple's constructor (a Python call) costs ~0.5 us each
LUFactor: TypeAlias = tuple[np.ndarray, np.ndarray, int]


@dataclass
class SolveResult:
    """Outcome of one Newton solve (configuration vector x over the free links)."""

    x: np.ndarray
    success: bool
    iterations: int  # steps taken (Newton, chord, line-search, LM and polish)
    residual: float  # max |F| / length scale
    reason: str | None = None
    #: condition number of the scale-free Jacobian (see linalg.cond); nan where the fast path
    #: left it unread (scalar.cond_of reads it; cond_bound bounds it)
    cond: float = float('inf')
    det_sign: int = 0
    #: LU and det sign of the scale-free J at x (an LUFactor; the kernel's factor, with a
    #: ``sign``, where the fast path answered without finish: scalar.solve_from_guess)
    factor: Any = None
    jacobians: int = 0  # Jacobians evaluated and factorised
    predicted: bool = False  # converged by the fast path from the predicted guess
    cond_bound: float = float('inf')  # an upper bound of cond (the fast path's kernel's)
    jv: list[float] | None = None  # J's varying entries at x (the fast path's answer)


@dataclass
class BatchSolve:
    """Outcome of LoopSystem.solve_batch: N warm-started Newton solves at once. Rows are
    independent; a row not ``ok`` was *declined* (not failed): its x is its start, and the caller
    solves it another way (LoopSystem.solve, the scalar careful path)."""

    x: np.ndarray  # (N, n) answers (phi rad, centroid m); the X0 row where declined
    ok: np.ndarray  # (N,) bool: converged on the start's side of det J = 0
    iterations: np.ndarray  # (N,) int: Newton steps evaluated (as SolveResult.iterations)
    residual: np.ndarray  # (N,) max |F| / length scale at x
    det_sign: np.ndarray  # (N,) int: det J sign at x where ok, else 0
    cond: np.ndarray  # (N,) cond(J) at x (as linalg.cond reports it) where ok, else inf


#: a scaled cond(J) above this is a near-singular configuration (Newton polishes its answer;
#: without a dyad plan it counts as near a singularity)
NEAR_SINGULAR_COND = 1e6
POLISH_STEPS = 40
#: a scaled cond(J) above this is a singular configuration (rank-deficient to rounding)
SINGULAR_COND = 1e10
#: LAPACK's 1-norm estimate of cond(J) above this: compute the exact (scaled_cond, an SVD). On the
#: scenes the estimate is 1.5-7x the exact value, so the thresholds above are decided exactly
COND_EXACT = 1e4
#: the fast path: at most this many steps, each cutting max|F| at least by this factor, down to
#: FAST_MARGIN * tol (not below FAST_FLOOR, about the rounding floor of max|F| / L) where they can
FAST_STEPS = 4
FAST_RATE = 0.1
FAST_MARGIN = 1e-2
FAST_FLOOR = 4e-15
#: a prediction moving any unknown further than this (rad, or length scales) is not tried
MAX_PREDICTION = 0.5
