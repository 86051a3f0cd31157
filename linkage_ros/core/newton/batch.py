"""N configurations at once: the same rows and Jacobian in numpy, Newton on the stack."""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from ..ops import BATCH
from ..quantities import AngleSpec, PointSpec
from .results import (
    COND_EXACT,
    FAST_FLOOR,
    FAST_MARGIN,
    FAST_RATE,
    FAST_STEPS,
    POLISH_COND,
    BatchSolve,
)
from .rows import AngleRow, LineRow, angle_row, line_row, point_rows, revolute_rows

if TYPE_CHECKING:
    pass


class BatchSystem:
    """LoopSystem's batched evaluation and solve (a mixin: it uses the compiled rows)."""

    # -- batched: N configurations at once (numpy over the rows, loops only over the tables) ---
    def _batch_tables(self) -> SimpleNamespace:
        """The compiled tables regrouped by row kind as index and constant arrays, so one numpy
        expression evaluates a kind for every configuration and every row of that kind. Built on
        first use; ValueError for a system whose rows name a non-free link other than the
        ground (a hybrid system: its fixed poses vary per solve)."""
        tab = getattr(self, '_batch_tab', None)
        if tab is not None:
            return tab
        foreign = [l for l in self._others if l != self.mech.ground]
        if foreign:
            raise ValueError(
                f'batched evaluation takes no fixed poses, but the rows name the '
                f'non-free link(s) {foreign}; use evaluate/solve with their poses'
            )
        # value columns: one per value component, then an all-zero one for rows without a value
        cols, c = [], 0
        for s in self.specs:
            cols.append(c)
            c += s.size
        zero = c
        # the fixed slots (the ground at its reference pose) as (phi, cos, sin, cx, cy)
        fixed = (
            np.array(
                [
                    (0.0, 1.0, 0.0, float(self.centroid[l][0]), float(self.centroid[l][1]))
                    for l in self._others
                ]
            )
            .reshape(-1, 5)
            .T[:, None, :]
        )
        revs = np.array(self._revs, float).reshape(-1, 6)
        nrev = len(self._revs)
        lines, angles, points = [], [], []
        r, j = 2 * nrev, 4 * nrev  # next residual row and next varying-entry column
        for row in self._tail:
            if isinstance(row, LineRow):
                _, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, vi = row
                lines.append(
                    (r, j, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, zero if vi is None else cols[vi])
                )
                r, j = r + 1, j + 6
            elif isinstance(row, AngleRow):
                _, ia, ib, vi, off = row
                angles.append((r, ia, ib, zero if vi is None else cols[vi], off))
                r += 1
            else:
                _, i, lx, ly, vi = row
                points.append((r, j, i, lx, ly, cols[vi]))
                r, j = r + 2, j + 2
        assert r == self.m and j == len(self._jpos), 'batched tables out of step with _compile'
        ln = np.array(lines, float).reshape(-1, 11)
        an = np.array(angles, float).reshape(-1, 5)
        pt = np.array(points, float).reshape(-1, 6)
        idx = lambda a: a.astype(np.intp)  # noqa: E731
        real = self._jpos != self.m * self.n  # entries of fixed links are dropped
        tab = SimpleNamespace(
            n_cols=zero + 1,
            cols=cols,
            fixed=fixed,
            rev_a=idx(revs[:, 0]),
            rev_la=(revs[:, 1], revs[:, 2]),
            rev_b=idx(revs[:, 3]),
            rev_lb=(revs[:, 4], revs[:, 5]),
            line_row=idx(ln[:, 0]),
            line_jv=idx(ln[:, 1])[:, None] + np.arange(6),
            line_g=idx(ln[:, 2]),
            line_s=idx(ln[:, 3]),
            line_k=tuple(ln[:, 4:10].T),
            line_val=idx(ln[:, 10]),
            ang_row=idx(an[:, 0]),
            ang_a=idx(an[:, 1]),
            ang_b=idx(an[:, 2]),
            ang_val=idx(an[:, 3]),
            ang_off=an[:, 4],
            pt_row=idx(pt[:, 0]),
            pt_jv=idx(pt[:, 1])[:, None] + np.arange(2),
            pt_link=idx(pt[:, 2]),
            pt_lever=(pt[:, 3], pt[:, 4]),
            pt_val=idx(pt[:, 5]),
            jv_real=np.flatnonzero(real),
            j_pos=self._jpos[real],
            j_tpl=self._tpl_s[:-1],
        )
        self._batch_tab = tab
        return tab

    def _batch_values(self, values: Sequence, N: int) -> np.ndarray:
        """(N, columns) matrix of the values (angles wrapped as _rows wraps them, rad; slides
        and points m), then a zero column: what the batched rows subtract."""
        tab = self._batch_tables()
        if len(values) != len(self.specs):
            raise ValueError(f'{len(values)} value arrays for {len(self.specs)} specs')
        V = np.zeros((N, tab.n_cols))
        for s, v, c in zip(self.specs, values, tab.cols):
            shape = (N, 2) if isinstance(s, PointSpec) else (N,)
            try:
                arr = np.broadcast_to(np.asarray(v, float), shape)
            except ValueError:
                raise ValueError(
                    f'values for {s.name!r} ({s.unit}) must have shape {shape}, got {np.shape(v)}'
                ) from None
            if isinstance(s, PointSpec):
                V[:, c : c + 2] = arr
            elif isinstance(s, AngleSpec):
                V[:, c] = BATCH.wrap(arr)
            else:
                V[:, c] = arr
        return V

    def _batch_eval(self, X: np.ndarray, V: np.ndarray, jacobian: bool):
        """evaluate_scaled for the rows of X (N, n) with the value matrix V (_batch_values):
        F (N, m),
        J (N, m, n) or None, res (N,). The formulas are core.newton.rows', as in _rows."""
        tab = self._batch_tables()
        N, m, nf = X.shape[0], self.m, len(self.free)
        k = 1.0 / self.L
        kL = self.L * k  # as _rows: not exactly 1
        with np.errstate(invalid='ignore', over='ignore'):
            # slots (free links, then the ground): phi, cos, sin, cx, cy
            P = np.empty((5, N, nf + len(self._others)))
            phi = X[:, 0::3]
            P[0, :, :nf] = phi
            np.cos(phi, out=P[1, :, :nf])
            np.sin(phi, out=P[2, :, :nf])
            P[3, :, :nf] = X[:, 1::3]
            P[4, :, :nf] = X[:, 2::3]
            P[:, :, nf:] = tab.fixed
            blown = np.isinf(phi).any(axis=1)
            if blown.any():  # as _rows, where math.cos raises: NaN free slots
                P[:, blown, :nf] = math.nan
            F = np.empty((N, m))
            Jv = np.empty((N, len(self._jpos))) if jacobian else None
            nrev = len(tab.rev_a)
            if nrev:  # revolute rows: w_a(P) - w_b(P)
                fx, fy, jv = revolute_rows(
                    *P[1:, :, tab.rev_a], *tab.rev_la, *P[1:, :, tab.rev_b], *tab.rev_lb, k
                )
                F[:, 0 : 2 * nrev : 2] = fx
                F[:, 1 : 2 * nrev : 2] = fy
                if jacobian:
                    Jv[:, : 4 * nrev] = np.stack(jv, axis=-1).reshape(N, 4 * nrev)
            if len(tab.line_row):  # line rows: u . (w_S(X) - w_G(base)) [- value]
                f, jv = line_row(
                    *P[1:, :, tab.line_g],
                    *P[1:, :, tab.line_s],
                    *tab.line_k,
                    V[:, tab.line_val],
                    k,
                )
                F[:, tab.line_row] = f
                if jacobian:
                    Jv[:, tab.line_jv] = np.stack(jv, axis=-1)
            if len(tab.ang_row):  # angle rows: L * wrap(phi_a - phi_b - (value - off))
                F[:, tab.ang_row] = angle_row(
                    P[0][:, tab.ang_a],
                    P[0][:, tab.ang_b],
                    V[:, tab.ang_val],
                    tab.ang_off,
                    kL,
                    BATCH.wrap,
                )
            if len(tab.pt_row):  # point rows: w(X) - (x, y)
                fx, fy, jv = point_rows(
                    *P[1:, :, tab.pt_link],
                    *tab.pt_lever,
                    V[:, tab.pt_val],
                    V[:, tab.pt_val + 1],
                    k,
                )
                F[:, tab.pt_row] = fx
                F[:, tab.pt_row + 1] = fy
                if jacobian:
                    Jv[:, tab.pt_jv] = np.stack(jv, axis=-1)
        res = np.abs(F).max(axis=1) if m else np.zeros(N)
        res[~np.isfinite(F).all(axis=1)] = math.inf
        if not jacobian:
            return F, None, res
        J = np.empty((N, m * self.n))
        J[:] = tab.j_tpl
        if self._jpos_unique:
            J[:, tab.j_pos] = Jv[:, tab.jv_real]
        else:
            np.add.at(J, (slice(None), tab.j_pos), Jv[:, tab.jv_real])
        return F, J.reshape(N, m, self.n), res

    def evaluate_batch(self, X: np.ndarray, values: Sequence, jacobian: bool = True):
        """evaluate_scaled for N configurations at once: returns (F, J, res) in scale-free units,
        F (N, m) = residual / length scale, J (N, m, n) = dF/dx with translation columns times the
        length scale (None if not ``jacobian``), res (N,) = max |F| per row, inf where a row's F
        has a NaN or inf (non-finite X or values give such rows, never an exception).

        X (N, n): rows of the variable vector (phi rad, centroid m per free link). ``values``: one
        entry per spec: (N,) for 'angle' (rad) and 'slide' (m) specs, (N, 2) for 'point' (m).
        Only for systems whose non-free links are the ground at its reference pose (what
        evaluate does with fixed=None); ValueError for a hybrid system."""
        X = np.asarray(X, float)
        if X.ndim != 2 or X.shape[1] != self.n:
            raise ValueError(f'X must have shape (N, {self.n}), got {X.shape}')
        return self._batch_eval(X, self._batch_values(values, X.shape[0]), jacobian)

    @staticmethod
    def _det_signs(J: np.ndarray) -> np.ndarray:
        """(K,) int sign of det of a (K, n, n) stack; 0 where singular or not finite."""
        if J.shape[0] == 0:
            return np.zeros(0, int)
        # LAPACK's LU takes NaN and inf without failing (the log|det| comes out NaN): no copy of
        # the finite rows needed
        with np.errstate(invalid='ignore', divide='ignore'):
            s, logdet = np.linalg.slogdet(J)
        return np.where(np.isfinite(logdet), s, 0.0).astype(int)

    @staticmethod
    def _newton_steps(J: np.ndarray, F: np.ndarray) -> np.ndarray:
        """dy (K, n) solving J dy = -F for a (K, n, n) stack; NaN rows where J is singular (one
        singular matrix makes np.linalg.solve raise for the whole stack: then solve the rest)."""
        try:
            return np.linalg.solve(J, -F[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            dy = np.full(F.shape, math.nan)
            regular = BatchSystem._det_signs(J) != 0
            if regular.any():
                dy[regular] = np.linalg.solve(J[regular], -F[regular][:, :, None])[:, :, 0]
            return dy

    @staticmethod
    def _scaled_conds(J: np.ndarray) -> np.ndarray:
        """scaled_cond of each matrix of a finite (K, m, n) stack (inf if an SVD fails)."""
        if J.shape[0] == 0 or J.shape[1] * J.shape[2] == 0:
            return np.ones(J.shape[0])
        peak = np.max(np.abs(J), axis=1, keepdims=True)  # pre-scale, as scaled_cond
        peak[peak == 0] = 1.0
        Jn = J / peak
        norms = np.linalg.norm(Jn, axis=1, keepdims=True)
        norms[norms == 0] = 1.0
        try:
            with np.errstate(divide='ignore', invalid='ignore'):
                return np.linalg.cond(Jn / norms)
        except np.linalg.LinAlgError:
            return np.full(J.shape[0], math.inf)

    @staticmethod
    def _batch_conds(J: np.ndarray) -> np.ndarray:
        """cond of each matrix of a finite (K, n, n) stack as _cond reports it: the 1-norm
        condition number of the scale-free J (exact here, from its inverse; the scalar path
        takes LAPACK's estimate of it) where that is below COND_EXACT, else scaled_cond. Only
        the rows above pay for an SVD (an SVD costs ~5 LUs: the batch's largest cost)."""
        out = np.full(J.shape[0], math.inf)
        if J.shape[0] == 0:
            return out
        try:
            inv = np.linalg.inv(J)
        except np.linalg.LinAlgError:  # an exactly singular matrix: SVDs for all
            return BatchSystem._scaled_conds(J)
        with np.errstate(invalid='ignore', over='ignore'):
            c1 = np.abs(J).sum(axis=1).max(axis=1) * np.abs(inv).sum(axis=1).max(axis=1)
        small = c1 < COND_EXACT  # False for NaN
        out[small] = c1[small]
        if not small.all():
            out[~small] = BatchSystem._scaled_conds(J[~small])
        return out

    def solve_batch(
        self,
        X0: np.ndarray,
        values: Sequence,
        start_sign,
        *,
        tol: float = 1e-12,
        max_steps: int = FAST_STEPS + 2,
    ) -> BatchSolve:
        """Newton for N warm starts at once (numpy over the rows): row i from X0[i] (N, n:
        phi rad, centroid m per free link; typically instance i's last solution) to the values
        of row i (as in evaluate_batch), on the side of det J = 0 given by start_sign[i] (+1 or
        -1, or one int for all). Full Newton steps: J evaluated and factorised at every iterate
        (the scalar fast path takes chord steps after its first). Square systems without fixed
        poses only (ValueError otherwise). ``tol`` bounds max|F| / length scale.

        Row i is ok when, as the scalar fast path (solve_from_guess, then _finish) would accept
        it: det J at X0[i] is finite with sign start_sign[i]; every step cuts max|F| / L at least
        FAST_RATE-fold down to min(tol, max(FAST_MARGIN * tol, FAST_FLOOR)) within ``max_steps``
        (a step that does not, taken from a point already within ``tol``, leaves the row there,
        converged); det J at the answer has the start's sign (else it crossed det J = 0, maybe
        onto another assembly mode); the answer is off folds (cond < POLISH_COND, else the
        scalar path polishes it; cond as _cond reports it: see _batch_conds) and finite.
        Otherwise the row is *declined*, not failed:
        ok False, x its X0 row, residual max|F| / L at X0, det_sign 0, cond inf; the caller
        solves it another way (solve(): the careful path with line search and LM). Rows never
        affect one another: each row's result is what solving it alone would give."""
        self._batch_tables()  # ValueError first if the system needs fixed poses
        if self.m != self.n:
            raise ValueError(
                f'solve_batch needs a square system (m = {self.m} rows, n = {self.n} unknowns)'
            )
        X0 = np.asarray(X0, float)
        if X0.ndim != 2 or X0.shape[1] != self.n:
            raise ValueError(f'X0 must have shape (N, {self.n}), got {X0.shape}')
        N = X0.shape[0]
        V = self._batch_values(values, N)
        want = np.broadcast_to(np.asarray(start_sign), (N,))
        sign0 = np.where(want == 1, 1, np.where(want == -1, -1, 0))
        target = min(tol, max(FAST_MARGIN * tol, FAST_FLOOR))

        x = X0.copy()
        F, J, res = self._batch_eval(x, V, True)
        res0 = res.copy()
        iterations = np.zeros(N, int)
        live = (sign0 != 0) & np.isfinite(res)
        live[live] = self._det_signs(J[live]) == sign0[live]
        done = live & (res <= target)  # converged (pending det sign and cond at the answer)
        active = live & ~done  # still stepping
        for _ in range(max_steps):
            rows = np.flatnonzero(active)
            if not rows.size:
                break
            xn = x[rows] + self._newton_steps(J[rows], F[rows]) * self.step_scale
            Fn, Jn, rn = self._batch_eval(xn, V[rows], True)
            iterations[rows] += 1
            cut = rn <= FAST_RATE * res[rows]  # False for NaN
            stalled = rows[~cut]
            active[stalled] = False
            done[stalled] = res[stalled] <= tol  # at the rounding floor already: converged
            moved = rows[cut]
            x[moved], F[moved], J[moved], res[moved] = xn[cut], Fn[cut], Jn[cut], rn[cut]
            there = moved[rn[cut] <= target]
            active[there] = False
            done[there] = True
        rows = np.flatnonzero(active)  # out of steps: converged if within tol
        done[rows] = res[rows] <= tol

        # at the answer: the start's det J sign (else it crossed det J = 0: maybe another
        # branch; rows still at X0 were checked there) and off folds (else the scalar path
        # polishes)
        rows = np.flatnonzero(done & (iterations > 0))
        done[rows] = self._det_signs(J[rows]) == sign0[rows]
        cond = np.full(N, math.inf)
        rows = np.flatnonzero(done)
        cond[rows] = self._batch_conds(J[rows])
        ok = done & (cond < POLISH_COND) & np.isfinite(x).all(axis=1) & np.isfinite(res)
        return BatchSolve(
            x=np.where(ok[:, None], x, X0),
            ok=ok,
            iterations=iterations,
            residual=np.where(ok, res, res0),
            det_sign=np.where(ok, sign0, 0),
            cond=np.where(ok, cond, math.inf),
        )
