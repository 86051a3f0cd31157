"""Solving one configuration over the compiled tables: the fast and careful Newton paths, the
rates at a solution and the closest miss where none closes (the continuation predictor they
start from: predictor.py).

Why one configuration is not a batch of one (batch.py): the same fast-path rule on numpy
arrays costs a fixed ~150 numpy calls whatever N is. Measured on the warm four-bar and
excavator sweeps (same start, same guess, same answer to rounding): solve_from_guess 63 us and
184 us, BatchNewton.solve_batch of one row 463 us and 970 us (7.3x and 5.3x). Here the rows are
plain floats and ``math`` and the linear algebra one LAPACK LU per linearisation point, reused
for the chord steps. test/core/newton/test_newton_batch.py holds the two to the same answers
(test_solve_batch_reproduces_the_scalar_sweep: every step of 300-command sweeps).

Why the LU stays LAPACK's: a pure-Python LU with partial pivoting costs 24 us for a 6 x 6 matrix
and 36 us for the four-bar's 9 x 9 on the bench machine (load ~4), getrf 1.8 and 2.6 us, getrs
0.9 us. The fast path is therefore kept to the fewest calls: no per-call closure, the Newton
step as J^-1 F subtracted (no negated copy of F; the same floats), LAPACK's 1-norm (dlange: the
same column sums as numpy's three reductions) for the condition estimate. Measured in one
process against the code before (CPU time, interleaved best of 9 x 300 calls at one command of
the bench sweep, 2-core machine shared with other jobs, load ~5.5): solve_from_guess four_bar
77.3 -> 65.5 us, slider_crank 88.5 -> 70.5, peaucellier 114.5 -> 106.8, excavator 228 -> 240
(noise: its time is the rows' Python); the answers are the same to the last bit
(test_fast_path_answer_reads_as_its_configuration_does holds each to its configuration).

The fast path's rule is written once, in lean.fast_steps, over a linear-algebra kernel:
solve_from_guess runs it by the DenseKernel here (getrf / getrs on the dense J, the same
calls as before on the same floats) where no kernel is given; the Newton path
(solver/newton_path.py) passes its compiled solve's kernel, lean.LeanSchur where J reduces to a
3 x 3. The predictor is one too: predictor.extrapolate, over either kernel's solve
(predictor.predict: LAPACK's)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ..execute import LinkPoses
from ..quantities import AngleSpec
from .evaluate import evaluate, evaluate_scaled, jacobian
from .lean import Kernel, fast_steps
from .linalg import cond, factor, lapack, lu_step, scaled_cond, side_ok, sign_of
from .results import (
    COND_EXACT,
    NEAR_SINGULAR_COND,
    NEWTON_TOL,
    POLISH_STEPS,
    SINGULAR_COND,
    LUFactor,
    SolveResult,
)
from .tables import LoopTables

_PI = math.pi


def least_miss(
    t: LoopTables, x0: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None = None
) -> float:
    """The loop-closure miss (m, the largest row) of the least-squares configuration nearest
    ``x0`` at ``values``: how far the mechanism is from closing at an input Newton could not
    reach (scipy's trust-region least squares from x0, on the analytic Jacobian). A local
    minimum: no configuration near x0 closes better."""
    from scipy.optimize import least_squares

    def fun(x: np.ndarray) -> np.ndarray:
        return evaluate(t, x, values, fixed, jac=False)[0] / t.L

    def jac(x: np.ndarray) -> np.ndarray:
        J = evaluate(t, x, values, fixed)[1]
        assert J is not None
        return J / t.L

    if not t.n:
        return float(np.max(np.abs(fun(x0)), initial=0.0)) * t.L
    start = fun(np.asarray(x0, float))
    if not np.all(np.isfinite(start)):  # a value at ~1e308 m overflows the rows: no closing
        return math.inf
    with np.errstate(all='ignore'):
        sol = least_squares(
            fun,
            np.asarray(x0, float),
            jac=jac,
            method='trf',
            x_scale='jac',
            xtol=1e-15,
            ftol=1e-15,
            gtol=1e-15,
            max_nfev=200,
        )
    return float(np.max(np.abs(fun(sol.x)), initial=0.0)) * t.L


def answer_cond(t: LoopTables, jv: Sequence[float]) -> float:
    """The condition number finish() reports at an answer whose J has the varying entries
    ``jv`` (evaluate_rows_scaled's): the same function of the same J."""
    J = jacobian(t, jv, t.tpl_s)
    return cond_estimate(J, factor(J))


def cond_of(t: LoopTables, r: SolveResult) -> float:
    """``r.cond``, the condition number finish() reports at the answer: read off J there
    (answer_cond) and kept where the fast path left it unread (nan; r.cond_bound bounds it)."""
    c = r.cond
    if c != c and r.jv is not None:
        c = r.cond = answer_cond(t, r.jv)
    return c


class DenseFactor(NamedTuple):
    """One linearisation point of the DenseKernel: LAPACK's LU of the scale-free J (lu, piv),
    det J's sign (0: singular) and J itself (its condition estimate)."""

    lu: np.ndarray
    piv: np.ndarray
    sign: int
    J: np.ndarray


class DenseKernel:
    """lean.Kernel by LAPACK's LU of the dense J (getrf, getrs, the condition estimate
    finish() reports): solve_from_guess's and predictor.predict's by default, and the Newton path's
    where J does not reduce to a 3 x 3 (solver/newton_path.newton_kernel)."""

    #: cond_bound is the condition number finish() reports itself
    cond_exact = True

    def __init__(self, t: LoopTables):
        self.t, self.n = t, t.n

    def factor(self, jv: Sequence[float]) -> DenseFactor:
        J = jacobian(self.t, jv, self.t.tpl_s)
        fac = factor(J)  # (as solve_from_guess: a point with non-finite rows is declined)
        if fac is None:
            return DenseFactor(J, J, 0, J)
        return DenseFactor(fac[0], fac[1], fac[2], J)

    def solve(self, fac: tuple[Any, ...], F: Sequence[float]) -> list[float]:
        """J^-1 F from a DenseFactor or an LUFactor (NaN entries where LAPACK refuses)."""
        y, info = lapack().getrs(fac[0], fac[1], np.array(F))
        out: list[float] = y.tolist() if info == 0 else [math.nan] * self.n
        return out

    def cond_bound(self, fac: DenseFactor) -> float:
        """The condition number finish() reports (not a bound: the same number)."""
        if not fac.sign:
            return math.inf
        return cond_estimate(fac.J, (fac.lu, fac.piv, fac.sign))


def rates(
    t: LoopTables, x: np.ndarray, values: Sequence[Any], value_rates: Sequence[float]
) -> tuple[np.ndarray | None, float]:
    """(dx/dt, cond): the unknowns' rates (per free link: rad/s, then its centroid's m/s)
    for the knowns' rates ``value_rates`` (one per value component: rad/s or m/s), from the
    analytic Jacobian at the solution x: J dx = -dF/dvalue * rates, the tangent
    predictor.predict() extrapolates along (scale-free units, then scaled back). cond is J's
    scaled condition number; dx is None where J is singular (a toggle) or a value has no row
    here."""
    F, J, _ = evaluate_scaled(t, x, values, None)
    c = scaled_cond(J)
    fac = factor(J) if t.val_rows is not None else None
    if fac is None:
        return None, c
    rhs = np.zeros(t.n)
    comps: list[bool] = []
    for s in t.specs:
        comps += [isinstance(s, AngleSpec)] * s.size
    for i, rate, is_angle in zip(t.val_rows or (), value_rates, comps):
        rhs[i] = float(rate) if is_angle else float(rate) / t.L
    dy, info = lapack().getrs(fac[0], fac[1], rhs)
    if info != 0 or not np.all(np.isfinite(dy)):
        return None, c
    out: np.ndarray = dy * t.step_scale
    return out, c


def det_sign_at(
    t: LoopTables, x: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None = None
) -> int:
    """The det J sign a solve from x tracks (0 where J is singular there)."""
    if not t.n:
        return 0
    J = evaluate_scaled(t, x, values, fixed)[1]
    return sign_of(J, factor(J))


# -- solving ------------------------------------------------------------------------------------
def solve(
    t: LoopTables,
    x0: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None = None,
    *,
    tol: float = NEWTON_TOL,
    max_iter: int = 50,
    keep_det_sign: bool = True,
    start_sign: int | None = None,
    guess: np.ndarray | None = None,
) -> SolveResult:
    """Solve from ``guess`` by the fast path if given and it qualifies (solve_from_guess),
    else from x0 by Newton with a line search on det-sign flips and an LM fallback. Works in
    scale-free units (see evaluate_scaled); ``tol`` bounds max|F| / length scale. The det J sign
    tracked is ``start_sign`` (known from the solve that produced x0), else read at x0."""
    x = np.array(x0, float)
    square = t.m == t.n
    nj = 0
    at_x0: tuple[np.ndarray, np.ndarray, float, LUFactor | None] | None = None
    # at a singular start (a change point) det J has no meaningful sign: do not track it
    sign0 = 0 if not keep_det_sign else start_sign
    if sign0 is None:
        F0, J0, res0 = evaluate_scaled(t, x, values, fixed)
        at_x0 = F0, J0, res0, factor(J0)
        nj += 1
        sign0 = sign_of(J0, at_x0[3])
    spent = 0
    if guess is not None:
        r = solve_from_guess(t, guess, values, fixed, tol=tol, max_iter=max_iter, start_sign=sign0)
        r.jacobians += nj
        if r.success:
            return r
        spent, nj = r.iterations, r.jacobians
    # the careful path: a request far out of range (a coordinate of 1e154 m) overflows F @ F
    # and its steps to inf; the refusal says so, numpy need not
    with np.errstate(over='ignore', invalid='ignore'):
        return _careful(t, x, values, fixed, tol, max_iter, square, sign0, at_x0, spent, nj)


def _careful(
    t: LoopTables,
    x: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None,
    tol: float,
    max_iter: int,
    square: bool,
    sign0: int,
    at_x0: tuple[np.ndarray, np.ndarray, float, LUFactor | None] | None,
    spent: int,
    nj: int,
) -> SolveResult:
    """solve()'s Newton from x with a line search on det-sign flips and an LM fallback
    (``spent`` iterations and ``nj`` Jacobians spent before it)."""
    if at_x0 is None:
        F0, J0, res0 = evaluate_scaled(t, x, values, fixed)
        at_x0 = F0, J0, res0, factor(J0)
        nj += 1
    F, J, res, fac = at_x0
    it = 0
    mu: float | None = None
    while res > tol and it < max_iter:
        it += 1
        fnorm = math.sqrt(float(F @ F))
        step = None
        if mu is None:
            dy: np.ndarray | None
            if square:
                dy = lu_step(fac, F) if fac is not None else None
            else:
                dy = np.linalg.lstsq(J, -F, rcond=None)[0]
                dy = dy if np.all(np.isfinite(dy)) else None
            if dy is not None:
                step = dy * t.step_scale
        accepted = False
        if step is not None:
            alpha = 1.0
            for _ in range(10):
                xn = x + alpha * step
                # the full step usually holds: evaluate J with it; shorter trials F alone
                Fn, Jn, rn = evaluate_scaled(t, xn, values, fixed, alpha == 1.0)
                if math.sqrt(float(Fn @ Fn)) < (1.0 - 1e-4 * alpha) * fnorm:
                    if Jn is None:
                        Jn = evaluate_scaled(t, xn, values, fixed)[1]
                    facn = factor(Jn)
                    nj += 1
                    if side_ok(sign0, Jn, facn):
                        x, F, J, fac, res = xn, Fn, Jn, facn, rn
                        accepted = True
                        break
                alpha *= 0.5
        if not accepted:
            # Levenberg-Marquardt with Marquardt's column scaling
            JtJ = J.T @ J
            g = J.T @ F
            D = np.diag(JtJ).copy()
            D[D == 0] = 1.0
            mu = mu or 1e-3
            for _ in range(12):
                try:
                    dy = np.linalg.solve(JtJ + mu * np.diag(D), -g)
                except np.linalg.LinAlgError:
                    mu *= 10
                    continue
                xn = x + dy * t.step_scale
                Fn, Jm, rn = evaluate_scaled(t, xn, values, fixed)
                if math.sqrt(float(Fn @ Fn)) < fnorm:
                    facn = factor(Jm)
                    nj += 1
                    if side_ok(sign0, Jm, facn):
                        x, F, J, fac, res = xn, Fn, Jm, facn, rn
                        mu = max(mu / 10, 1e-12)
                        accepted = True
                        break
                mu *= 10
            if not accepted:
                break
    r = finish(t, x, F, J, fac, res, it, values, fixed, polish=res <= tol)
    r.iterations += spent
    r.jacobians += nj
    if res <= tol:
        return r
    r.success = False
    r.factor = None
    if it >= max_iter:
        r.reason = (
            f'Newton reached its iteration cap ({max_iter}) with loop-closure residual '
            f'{r.residual:.3g} of the length scale (tolerance {tol:g})'
        )
    else:
        r.reason = (
            f'Newton stalled with loop-closure residual {r.residual:.3g} of the length '
            f'scale: no assembly near the start (cond J = {r.cond:.3g}); the input may '
            'be beyond a limit or toggle position'
        )
    return r


def solve_from_guess(
    t: LoopTables,
    guess: np.ndarray | list[float],
    values: Sequence[Any],
    fixed: LinkPoses | None = None,
    *,
    tol: float = NEWTON_TOL,
    max_iter: int = 50,
    start_sign: int = 0,
    kernel: Kernel | None = None,
) -> SolveResult:
    """The fast path (lean.fast_steps, its rule) by ``kernel`` (LAPACK's LU of the dense J
    where None), then finish() at its answer. Declines (success False, the steps spent
    counted) where fast_steps does, or where polishing the answer crossed a fold (det J's sign
    changed).

    finish() is not run where the kernel's condition bound at the answer is below COND_EXACT:
    the condition number finish() reports (LAPACK's 1-norm estimate, never above the exact
    1-norm condition number, which the bound is never below) is then below COND_EXACT <
    NEAR_SINGULAR_COND < SINGULAR_COND, so finish would neither polish nor read J as singular: the
    answer is the kernel's, its det sign the factor's. Its ``cond`` is then the bound where
    the kernel's bound is the estimate itself (DenseKernel), else nan, read when asked
    (cond_of); ``jv`` and ``factor`` are J's varying entries and the kernel's factor there."""
    start = guess if isinstance(guess, list) else np.asarray(guess, float).tolist()
    kern = kernel if kernel is not None else DenseKernel(t)
    got = fast_steps(
        t, kern, start, values, fixed, tol=tol, max_iter=max_iter, start_sign=start_sign
    )
    nj = got.factors
    if not got.ok:
        return SolveResult(
            np.array(start), False, got.iterations, got.residual, _DECLINED, jacobians=nj
        )
    fac = got.factor
    bound = kern.cond_bound(fac)
    if bound < COND_EXACT:
        return SolveResult(
            np.array(got.x),
            True,
            got.iterations,
            got.residual,
            None,
            bound if kern.cond_exact else math.nan,
            fac.sign,
            fac,
            nj,
            True,
            bound,
            got.jv,
        )
    lu: LUFactor | None
    if isinstance(fac, DenseFactor):
        J, lu = fac.J, (fac.lu, fac.piv, fac.sign)
    else:
        J = jacobian(t, got.jv, t.tpl_s)
        lu = factor(J)
    r = finish(
        t, np.array(got.x), np.array(got.F), J, lu, got.residual, got.iterations, values, fixed
    )
    if start_sign and r.det_sign not in (0, start_sign):  # polished over a fold
        return SolveResult(
            np.array(start), False, got.iterations, got.residual, _DECLINED, jacobians=nj
        )
    r.jacobians += nj
    r.predicted = True
    return r


#: why the fast path declined a guess (the caller then takes the careful path)
_DECLINED = 'the predicted start did not qualify'


def cond_estimate(J: np.ndarray, fac: LUFactor | None) -> float:
    """linalg.cond with LAPACK's 1-norm of J (dlange) for numpy's three reductions: the same
    column sums in the same order (one call instead of three)."""
    if fac is not None:
        lp = lapack()
        rc, info = lp.gecon(fac[0], _dlange()('1', J))
        if info == 0 and rc * COND_EXACT >= 1.0:
            return float(1.0 / rc)
    return cond(J, fac)


_DLANGE: list[Any] = []


def _dlange() -> Any:
    if not _DLANGE:
        from scipy.linalg.lapack import dlange

        _DLANGE.append(dlange)
    return _DLANGE[0]


def finish(
    t: LoopTables,
    x: np.ndarray,
    F: np.ndarray,
    J: np.ndarray,
    fac: LUFactor | None,
    res: float,
    it: int,
    values: Sequence[Any],
    fixed: LinkPoses | None,
    polish: bool = True,
) -> SolveResult:
    """The result at x (marked a success: the caller decides): condition number, det J
    sign and, if ``polish`` (converged) and near a fold, polishing steps."""
    square = t.m == t.n
    c = cond_estimate(J, fac)
    nj = 0
    if polish and c > NEAR_SINGULAR_COND:
        # near a toggle Newton converges only linearly and the configuration error is
        # ~sqrt(residual): polish while it still pays, so margins and branch signs read off
        # the answer are as exact as floating point allows
        for _ in range(POLISH_STEPS):
            if res <= 1e-15:
                break
            if square:
                dy = lu_step(fac, F) if fac is not None else None
                if dy is None:
                    break
            else:
                dy = np.linalg.lstsq(J, -F, rcond=None)[0]
            xn = x + dy * t.step_scale
            Fn, Jn, rn = evaluate_scaled(t, xn, values, fixed)
            if not (np.all(np.isfinite(xn)) and rn < 0.7 * res):
                break
            x, F, J, res = xn, Fn, Jn, rn
            fac = factor(J)
            nj += 1
            it += 1
        c = cond_estimate(J, fac)
    det = fac[2] if fac is not None and c < SINGULAR_COND else 0  # 0: singular, no sign
    return SolveResult(x, True, it, res, None, c, det, fac, nj)
