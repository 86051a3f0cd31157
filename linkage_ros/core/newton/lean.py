"""The warm scalar Newton solve over plain floats: the fast path's rule (fast_steps) over a
linear-algebra Kernel, and LeanSchur, the kernel for systems whose Jacobian reduces to a 3 x 3
matrix (schur.py: the four-bar's and the slider-crank's 9 x 9 J): the prediction, the fast path
and the answer's checks without a numpy array or a LAPACK call.

Why a plain-float twin of schur.py's batched elimination: one row of the batched arithmetic is
~30 numpy calls (~1 us each); the dense path (scalar.py) takes per command three getrs, two
getrf and an array per evaluation. Measured on the bench's warm sweeps, one command's kernel
(prediction, fast steps, det J sign and the condition bound at the answer; CPU time, best of 7
x 300 interleaved in one process, 2-core machine shared with other jobs, load 3.1-3.4): dense
(predictor.predict + solve_from_guess) against lean (extrapolate + fast_steps by LeanSchur),
four-bar 105 / 121 -> 81 / 91 us, slider-crank 112 / 193 -> 87 / 130 us; with the DenseKernel (the
same LAPACK calls, the rest on lists) Peaucellier 169 / 180 -> 161 / 158 us, excavator 239 / 447 ->
227 / 428 us (two runs each). The steps are the dense ones to rounding
(test/core/newton/test_lean.py holds them to numpy's dense solve and to schur.py's batched
elimination on every scene with a 3 x 3 M, over random poses).

What it decides: det J's sign is parity * sign(det M) (exact, as schur.schur_answer); the
condition number is bounded (cond_bound: never below the exact 1-norm one, so never below
LAPACK's estimate of it, the number finish() reports). scalar.solve_from_guess decides by the
bound where it settles the question (below COND_EXACT: no polish, not singular) and reads the
estimate off the dense J otherwise; the number a Result reports is that estimate, read when
asked (scalar.cond_of). One Newton flow runs on either kernel: newton_path.solve_newton."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from operator import itemgetter
from typing import Any, NamedTuple, Protocol

from ..execute import LinkPoses
from .evaluate import residual_rows
from .results import FAST_FLOOR, FAST_MARGIN, FAST_RATE, FAST_STEPS
from .schur import SchurForm
from .tables import LoopTables


class Kernel(Protocol):
    """The linear algebra fast_steps and the predictor run on: LeanSchur (a 3 x 3 reduction,
    plain floats) or scalar.DenseKernel (LAPACK's LU of the dense J). A factor has a
    ``sign``: det J's, 0 where J is singular."""

    #: whether cond_bound is the condition number finish() reports (not only a bound of it)
    cond_exact: bool

    def factor(self, jv: Sequence[float]) -> Any: ...

    def solve(self, fac: Any, F: Sequence[float]) -> list[float]: ...

    def cond_bound(self, fac: Any) -> float: ...


class LeanFactor(NamedTuple):
    """One linearisation point of a LeanSchur: J packed as schur.py packs it (P: the rows S
    then R, of the A columns, row-major; its first t rows are B = J[S, A]), X = M^-1 (3 x 3,
    row-major) and det J's sign (0: M singular or not finite). A tuple: State.x_lu holds it
    as it holds the dense path's LU."""

    P: list[float]
    X: list[float]
    sign: int


class LeanSchur:
    """The elimination of a SchurForm with |A| = 3 on plain floats (see the module): built once
    per loop system (lean_schur) from the batched solve's tables."""

    __slots__ = (
        'tpl',
        'put',
        'nt',
        'g_rows',
        'cinv_rows',
        's_rows',
        'r_rows',
        't_cols',
        'a_cols',
        'parity',
        't_col_norms',
        'cinv_norm',
        'gi_norm',
        'n',
        'r_plan',
        't_plan',
        'gather',
        's_get',
    )
    cond_exact = False  # cond_bound: an upper bound of the exact 1-norm condition number

    def __init__(self, sf: SchurForm, jv_real: Sequence[int]):
        assert sf.a == 3, 'the lean path inverts a 3 x 3 M by its adjugate'
        self.n = sf.n
        self.tpl: list[float] = sf.tpl.tolist()
        #: (index in residual_rows' varying entries, packed position)
        self.put: list[tuple[int, int]] = list(zip(list(jv_real), sf.pos.tolist()))
        #: P read off [*tpl, *jv] by one itemgetter: position p takes tpl[p], or jv[k]
        #: (at len(tpl) + k) where put places it (the last put wins, as the loop it replaces)
        gather = list(range(len(self.tpl)))
        for k, p in self.put:
            gather[p] = len(self.tpl) + k
        self.gather = itemgetter(*gather)
        self.nt = len(sf.t_cols)
        #: G's and C^-1's nonzero entries per row: (column, value)
        self.g_rows = [[(k, v) for k, v in enumerate(row) if v != 0.0] for row in sf.g.tolist()]
        self.cinv_rows = [
            [(k, v) for k, v in enumerate(row) if v != 0.0] for row in sf.c_inv.tolist()
        ]
        self.s_rows: list[int] = sf.s_rows.tolist()
        #: F's S rows as a sequence (itemgetter of one index returns the item, not a tuple)
        self.s_get = _rows_getter(self.s_rows)
        self.r_rows: list[int] = sf.r_rows.tolist()
        self.t_cols: list[int] = sf.t_cols.tolist()
        self.a_cols: list[int] = sf.a_cols.tolist()
        self.parity = sf.parity
        #: per row of R: (its row of J, G's nonzero entries in that row); per T column: (its
        #: column of J, C^-1's nonzero entries in that row)
        self.r_plan = list(zip(self.r_rows, self.g_rows))
        self.t_plan = list(zip(self.t_cols, self.cinv_rows))
        self.t_col_norms = sf.t_col_norms
        self.cinv_norm = max(sum(abs(row[k]) for row in sf.c_inv.tolist()) for k in range(self.nt))
        # ||[G, -I]||_1: G's column sums, and 1 for each column of -I
        g = sf.g.tolist()
        self.gi_norm = max([1.0, *(sum(abs(row[k]) for row in g) for k in range(self.nt))])

    def factor(self, jv: Sequence[float]) -> LeanFactor:
        """The LeanFactor of the J whose varying entries are ``jv`` (residual_rows' order)."""
        P = list(self.gather([*self.tpl, *jv]))
        e = 3 * self.nt
        M: list[float] = []
        for g_row in self.g_rows:  # M = E - G B
            m0, m1, m2 = P[e], P[e + 1], P[e + 2]
            for k, g in g_row:
                m0 -= g * P[3 * k]
                m1 -= g * P[3 * k + 1]
                m2 -= g * P[3 * k + 2]
            M += (m0, m1, m2)
            e += 3
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = M
        # the adjugate, as schur.inverse_3x3: cofactor (i, j) from rows i+1, i+2 (mod 3)
        c00, c01, c02 = m11 * m22 - m12 * m21, m12 * m20 - m10 * m22, m10 * m21 - m11 * m20
        det = m00 * c00 + m01 * c01 + m02 * c02
        if not (det != 0.0 and det - det == 0.0):  # singular, or NaN / inf entries
            return LeanFactor(P, _NAN9, 0)
        X = [
            c00 / det,
            (m21 * m02 - m22 * m01) / det,
            (m01 * m12 - m02 * m11) / det,
            c01 / det,
            (m22 * m00 - m20 * m02) / det,
            (m02 * m10 - m00 * m12) / det,
            c02 / det,
            (m20 * m01 - m21 * m00) / det,
            (m00 * m11 - m01 * m10) / det,
        ]
        return LeanFactor(P, X, self.parity if det > 0.0 else -self.parity)

    def solve(self, fac: LeanFactor, F: Sequence[float]) -> list[float]:
        """y solving J y = F at the factor's point (NaN entries where it is singular)."""
        P, X = fac.P, fac.X
        FS = self.s_get(F)
        (i0, g0), (i1, g1), (i2, g2) = self.r_plan
        r0, r1, r2 = F[i0], F[i1], F[i2]  # r = F_R - G F_S
        for k, g in g0:
            r0 -= g * FS[k]
        for k, g in g1:
            r1 -= g * FS[k]
        for k, g in g2:
            r2 -= g * FS[k]
        a0 = X[0] * r0 + X[1] * r1 + X[2] * r2  # y_A = M^-1 r
        a1 = X[3] * r0 + X[4] * r1 + X[5] * r2
        a2 = X[6] * r0 + X[7] * r1 + X[8] * r2
        e = 3 * self.nt  # y_T = C^-1 (F_S - B y_A)
        u = [
            f - (b0 * a0 + b1 * a1 + b2 * a2)
            for f, b0, b1, b2 in zip(FS, P[0:e:3], P[1:e:3], P[2:e:3])
        ]
        y = [0.0] * self.n
        c0, c1, c2 = self.a_cols
        y[c0], y[c1], y[c2] = a0, a1, a2
        for c, row in self.t_plan:
            v = 0.0
            for k, ck in row:
                v += ck * u[k]
            y[c] = v
        return y

    def cond_bound(self, fac: LeanFactor) -> float:
        """An upper bound of J's 1-norm condition number ||J||_1 ||J^-1||_1 (inf where J is
        singular): J^-1 = D0 + [W; -I] X [G, -I] with W = C^-1 B (schur._inverse_norms),
        and the 1-norm of a sum and of a product is at most the sum and the product of the
        1-norms."""
        P, X = fac.P, fac.X
        if not fac.sign:
            return math.inf
        e = 3 * self.nt  # the A columns' sums over B, then over all of J (T columns': constant)
        A = list(map(abs, P))  # (|P| once: the same sums, in the same order, as per column)
        b0, b1, b2 = sum(A[0:e:3]), sum(A[1:e:3]), sum(A[2:e:3])
        b_norm = max(b0, b1, b2)
        j_norm = max(
            self.t_col_norms,
            b0 + sum(A[e::3]),
            b1 + sum(A[e + 1 :: 3]),
            b2 + sum(A[e + 2 :: 3]),
        )
        x_norm = max(
            abs(X[0]) + abs(X[3]) + abs(X[6]),
            abs(X[1]) + abs(X[4]) + abs(X[7]),
            abs(X[2]) + abs(X[5]) + abs(X[8]),
        )
        bound = j_norm * (self.cinv_norm + (self.cinv_norm * b_norm + 1.0) * x_norm * self.gi_norm)
        return bound if bound - bound == 0.0 else math.inf


def _rows_getter(rows: list[int]) -> Callable[[Sequence[float]], Sequence[float]]:
    """F's entries at ``rows`` in one call (itemgetter: of one index it returns the item)."""
    if len(rows) > 1:
        got: Callable[[Sequence[float]], Sequence[float]] = itemgetter(*rows)
        return got

    def one(F: Sequence[float]) -> Sequence[float]:
        return [F[i] for i in rows]

    return one


#: X of a singular factor
_NAN9 = [math.nan] * 9


def lean_schur(t: LoopTables, sf: SchurForm | None, jv_real: Sequence[int]) -> LeanSchur | None:
    """The LeanSchur of a loop system whose batched tables reduce J to a 3 x 3 M, else None."""
    if sf is None or sf.a != 3 or not t.jpos_unique or t.m != t.n or t.val_rows is None:
        return None
    return LeanSchur(sf, jv_real)


def evaluate_lean(
    t: LoopTables, x: Sequence[float], values: Sequence[Any], fixed: LinkPoses | None = None
) -> tuple[list[float], list[float], float]:
    """evaluate.evaluate_rows_scaled on a list, F left a list: (F / L, J's varying entries,
    max|F / L|, inf if not finite)."""
    F, jv = residual_rows(t, x, values, fixed, True, 1.0 / t.L)
    res = max(map(abs, F), default=0.0)
    total = sum(F)
    if total - total != 0.0:  # a NaN or inf
        res = math.inf
    return F, jv, res


class FastSteps(NamedTuple):
    """What fast_steps did: ``ok`` (converged on the start's side of det J = 0; else declined),
    the last point x it reached (floats), the steps taken, max|F| / L at x, the kernel's factor
    at x (the guess's where it took no step), J's varying entries and F / L at x, and how many
    Jacobians it factorised."""

    ok: bool
    x: list[float]
    iterations: int
    residual: float
    factor: Any
    jv: list[float]
    F: list[float]
    factors: int


def fast_steps(
    t: LoopTables,
    kernel: Kernel,
    guess: list[float],
    values: Sequence[Any],
    fixed: LinkPoses | None = None,
    *,
    tol: float,
    max_iter: int,
    start_sign: int,
) -> FastSteps:
    """The fast path's rule (scalar.solve_from_guess runs it, by the Newton path's kernel:
    newton_path.newton_kernel): one Newton step from a predicted guess,
    then chord steps on its factorisation, J factorised again at the answer. Steps go on to
    FAST_MARGIN * tol (or FAST_FLOOR) while each cuts max|F| FAST_RATE-fold (an answer just
    inside ``tol`` would leave angles read off its points off by ~tol / link length). Declines
    (ok False) unless J is regular at the guess and at the answer with det sign ``start_sign``
    (0: any) and min(FAST_STEPS, max_iter) such steps reach ``tol``."""
    F, jv, res = evaluate_lean(t, guess, values, fixed)
    fac = kernel.factor(jv)
    steps, it, nj = min(FAST_STEPS, max_iter), 0, 1
    if fac.sign == 0 or res == math.inf or (start_sign and fac.sign != start_sign):
        return FastSteps(False, guess, it, res, fac, jv, F, nj)
    target = min(tol, max(FAST_MARGIN * tol, FAST_FLOOR))
    x, lin, fresh = guess, fac, True
    scale = t.step_list
    while res > target:
        cut = False
        if it < steps:
            # J^-1 F, the step's negative to the bit (LAPACK's solve is odd in its right side)
            y = kernel.solve(lin, F)
            total = sum(y)
            if total - total == 0.0:
                xn = [a - b * s for a, b, s in zip(x, y, scale)]
                Fn, jvn, rn = evaluate_lean(t, xn, values, fixed)
                it += 1
                cut = rn <= FAST_RATE * res
        if not cut:
            if res <= tol:  # converged; the rounding floor is above the margin
                break
            return FastSteps(False, x, it, res, fac, jv, F, nj)
        x, F, jv, res, fresh = xn, Fn, jvn, rn, False
    if not fresh:  # J at the answer: its det sign, cond and factorisation
        fac = kernel.factor(jv)
        nj += 1
        if fac.sign == 0 or (start_sign and fac.sign != start_sign):
            return FastSteps(False, x, it, res, fac, jv, F, nj)
    return FastSteps(True, x, it, res, fac, jv, F, nj)
