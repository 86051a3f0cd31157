"""Newton loop-closure solver with an analytic Jacobian.

Unknowns: for every *free* link, its rotation phi from the reference pose and the world position
c of its reference centroid o, so that world(p) = R(phi) (p - o) + c. Equations (all in metres;
angle rows are multiplied by the mechanism's length scale so every row has the same unit):

* revolute joint at P between links a, b:         w_a(P) - w_b(P) = 0                  (2 rows)
* prismatic joint (guide G, slider S, point X):   n_G . (w_S(X) - w_G(X)) = 0,  phi_S - phi_G = 0
* known angle spec:                               phi_L - phi_R - (value - offset) = 0
* known slide spec:                               d_G . (w_S(X) - w_G(origin)) - value = 0
* known point spec:                               w_L(X) - (x, y) = 0                  (2 rows)

Convergence is judged on max|F| / length_scale (scale-free). Linear algebra is one LU (LAPACK
getrf) of the scale-free Jacobian per linearisation point: it gives the Newton step and the sign
of det J (from the U diagonal and the pivots). At the answer LAPACK's 1-norm estimate of the
condition number is taken; the exact one (an SVD) only where that estimate is large.

Two paths. The *fast* path starts from a predicted guess (predictor.extrapolate over the solve's
kernel, as :meth:`LoopSystem.predict` over LAPACK's LU: cubic
Hermite extrapolation from the last two solutions and their tangents dx/dvalue): one Newton step,
then chord steps reusing that factorisation, the Jacobian factorised again only at the answer; it
is taken only if the guess and the answer have the start's det J sign and every step cuts max|F|
tenfold (lean.py: the same rule on plain floats, the linear algebra through schur.py's
elimination of the centroid columns, where that leaves a 3 x 3 matrix: the four-bar, the
slider-crank). Otherwise the *careful* path runs from the previous solution: Newton steps with a
backtracking line search, the sign of det J checked at every accepted point (a flip means a branch
jump or a singularity crossed, so the step is shortened), and Levenberg-Marquardt where Newton
steps stop reducing the residual (near singularities).

Batched (:meth:`LoopSystem.evaluate_batch`, :meth:`LoopSystem.solve_batch`): the same residual and
Jacobian for N configurations at once in numpy, and full Newton steps on the N x n x n stack from
warm starts, accepting a row only where the fast path would (FAST_RATE per step, det J sign at
start and answer, cond below NEAR_SINGULAR_COND); the rows it declines go to the scalar careful
path.
Its linear algebra goes block by block where J's fixed sparsity makes it block triangular
(blocks.py: the excavator's 33 x 33 J is four blocks of at most 9).

Modules (no one imports back): tables (the equations compiled once: a frozen LoopTables),
evaluate (one configuration's rows), linalg (LU, det sign, cond), scalar (the one-configuration
solves), predictor (the continuation predictor they start from), lean (the warm fast path on
plain floats), batch (N at once), blocks (J's block-triangular form for the batch), results
(outcomes and constants); system's LoopSystem is the facade the solver uses.
"""

from __future__ import annotations

from .results import (
    COND_EXACT,
    FAST_FLOOR,
    FAST_MARGIN,
    FAST_RATE,
    FAST_STEPS,
    MAX_PREDICTION,
    NEAR_SINGULAR_COND,
    POLISH_STEPS,
    SINGULAR_COND,
    BatchSolve,
    SolveResult,
)
from .system import LoopSystem

__all__ = [
    'COND_EXACT',
    'FAST_FLOOR',
    'FAST_MARGIN',
    'FAST_RATE',
    'FAST_STEPS',
    'MAX_PREDICTION',
    'NEAR_SINGULAR_COND',
    'POLISH_STEPS',
    'SINGULAR_COND',
    'BatchSolve',
    'LoopSystem',
    'SolveResult',
]
