"""N configurations at once: the same rows and Jacobian in numpy, Newton on the stack.
BatchNewton holds a system's tables regrouped by row kind (BatchTables, built on first use);
the stack algebra (det signs, steps, condition numbers) is plain functions.

Every step is a full Newton step (J evaluated at each new point). The scalar fast path's chord
steps (one J kept while each step cuts max|F| tenfold) were measured here and are slower
batched: a chord step converges as e^3 where Newton's second gives e^4, so each scene took one
step more, and at 200 rows an evaluation with J costs little more than one without (four-bar:
169 against 146 us, a Newton step 124 against a chord step's 45): 0.92x the four-bar, 0.87x the
slider-crank (CPU time, interleaved, load 0.6)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..ops import BATCH
from ..quantities import AngleSpec, PointSpec
from .batch_tables import BatchTables, PackedJacobian, PoseTable, batch_tables, pose_table
from .blocks import parts_det_signs, parts_inverse_norms, parts_steps
from .linalg import det_signs, newton_steps
from .results import (
    COND_EXACT,
    FAST_FLOOR,
    FAST_MARGIN,
    FAST_RATE,
    FAST_STEPS,
    MAX_PREDICTION,
    NEAR_SINGULAR_COND,
    NEWTON_TOL,
    BatchSolve,
)
from .rows import angle_row, line_row, point_rows, revolute_rows
from .schur import (
    SchurForm,
    reduced_steps,
    schur_answer,
    schur_back,
    schur_inverse_norms,
    schur_reduce,
)
from .tables import LoopTables


def _pose(
    P: np.ndarray, slots: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(cos, sin, cx, cy) of the given slots, each (k, N), from the slot table P (5, slots, N)."""
    c, s, x, y = P[1:, slots]
    return c, s, x, y


def _pair(constants: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """A pair of (k,) per-row constants as (k, 1) columns (evaluate's rows are (k, N))."""
    return constants[0][:, None], constants[1][:, None]


# ---- the algebra of a stack of square matrices ------------------------------------------------
def scaled_conds(J: np.ndarray) -> np.ndarray:
    """linalg.scaled_cond of each matrix of a finite (K, m, n) stack (inf if an SVD fails)."""
    if J.shape[0] == 0 or J.shape[1] * J.shape[2] == 0:
        return np.ones(J.shape[0])
    peak = np.max(np.abs(J), axis=1, keepdims=True)  # pre-scale, as scaled_cond
    peak[peak == 0] = 1.0
    Jn = J / peak
    norms = np.linalg.norm(Jn, axis=1, keepdims=True)
    norms[norms == 0] = 1.0
    try:
        with np.errstate(divide='ignore', invalid='ignore'):
            conds: np.ndarray = np.linalg.cond(Jn / norms)
            return conds
    except np.linalg.LinAlgError:
        return np.full(J.shape[0], math.inf)


def batch_conds(J: np.ndarray, inverse_norms: np.ndarray | None = None) -> np.ndarray:
    """cond of each matrix of a finite (K, n, n) stack as linalg.cond reports it: the 1-norm
    condition number of the scale-free J (exact here, from its inverse: ``inverse_norms``
    ||J^-1||_1 if given, else from a dense inverse; the scalar path takes LAPACK's estimate of
    it) where that is below COND_EXACT, else scaled_cond. Only the rows above pay for an SVD
    (an SVD costs ~5 LUs: the batch's largest cost)."""
    if J.shape[0] == 0:
        return np.full(0, math.inf)
    if inverse_norms is None:
        try:
            inverse = np.linalg.inv(J)
        except np.linalg.LinAlgError:  # an exactly singular matrix: SVDs for all
            return scaled_conds(J)
        inverse_norms = np.abs(inverse).sum(axis=1).max(axis=1)
    with np.errstate(invalid='ignore', over='ignore'):
        c1 = np.abs(J).sum(axis=1).max(axis=1) * inverse_norms
    return exact_or_scaled(c1, lambda rows: J[rows])


#: the batched solve keeps up to this many of its packed-J arrays between batches, each of up
#: to SPARE_BYTES, for the next batch of the same size: fresh memory costs page faults (on the
#: bench machine about a fifth of the excavator's batch: its 200 x 405 J is 648 kB, made
#: four times a batch), reused memory does not
SPARE_ARRAYS = 3
SPARE_BYTES = 4 << 20


def exact_or_scaled(c1: np.ndarray, dense_rows: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """The 1-norm condition numbers ``c1`` where below COND_EXACT, else scaled_cond of the
    dense matrices ``dense_rows(mask)`` gives for the other rows (batch_conds)."""
    out = np.full(c1.shape[0], math.inf)
    small = c1 < COND_EXACT  # False for NaN
    out[small] = c1[small]
    if not small.all():
        out[~small] = scaled_conds(dense_rows(~small))
    return out


class BatchNewton:
    """A loop system's batched evaluation and Newton solve (numpy over the rows, loops only
    over the tables). Its BatchTables are built on the first batched call."""

    def __init__(self, t: LoopTables):
        self.t = t
        self._tables: BatchTables | None = None
        self._poses: PoseTable | None = None
        # packed-J arrays of earlier batches, free for the next (taken and given back whole:
        # a list's pop and append are atomic, so two threads never share one)
        self._spare: list[np.ndarray] = []
        # J^-1 rows arrays of earlier answer checks (parts_inverse_norms' work: zero right of
        # each block, which stays so), taken and given back whole as the spares
        self._inverse_rows: list[np.ndarray] = []

    def _take(self, N: int, size: int) -> tuple[np.ndarray, bool]:
        """An (N, size) float array to write over: a spare one of that shape (True: a packed J,
        its constant entries in place), else new (False)."""
        spare = self._spare
        if spare and spare[-1].shape == (N, size):
            try:
                a = spare.pop()
            except IndexError:  # another thread took the last one
                return np.empty((N, size)), False
            if a.shape == (N, size):
                return a, True
        return np.empty((N, size)), False

    def _give_back(self, a: np.ndarray) -> None:
        """Keep ``a`` (a whole batch's packed J, nothing else holds it any more: every entry
        evaluate wrote, the constant ones never written over) for a later batch; the spares
        of another batch size are let go."""
        if a.nbytes > SPARE_BYTES:
            return
        spare = self._spare
        if spare and spare[0].shape != a.shape:
            spare.clear()
        if len(spare) < SPARE_ARRAYS:
            spare.append(a)

    def tables(self) -> BatchTables:
        """The BatchTables (ValueError for a hybrid system: see batch_tables)."""
        if self._tables is None:
            self._tables = batch_tables(self.t)
        return self._tables

    def pose_table(self) -> PoseTable:
        """The PoseTable configurations are read with (built on first use)."""
        if self._poses is None:
            self._poses = pose_table(self.t)
        return self._poses

    def layout(self) -> PackedJacobian | SchurForm:
        """How the batched solve stores J: reduced to its varying columns where that is
        smaller than its blocks (SchurForm), else block by block (PackedJacobian)."""
        tab = self.tables()
        if tab.schur is not None:
            return tab.schur
        assert tab.packed is not None, 'the batched solve takes square systems only'
        return tab.packed

    def det_signs(self, Jp: np.ndarray) -> np.ndarray:
        """det_signs of a packed (K, size) stack of this system's Jacobians, block by block
        (or from the reduced matrix M)."""
        layout = self.layout()
        if isinstance(layout, SchurForm):
            signs: np.ndarray = det_signs(layout.reduced(Jp)[1]) * layout.parity
            return signs
        if layout.whole or not Jp.shape[0]:
            return det_signs(layout.unpack(Jp))
        return parts_det_signs(layout.form, layout.parts(Jp))

    def conds(self, Jp: np.ndarray) -> np.ndarray:
        """batch_conds of a packed (K, size) stack of this system's Jacobians, ||J^-1||_1
        found block by block (parts_inverse_norms) or from M (schur_inverse_norms)."""
        layout = self.layout()
        if isinstance(layout, SchurForm):
            norms = schur_inverse_norms(layout, Jp) if Jp.shape[0] else None
            if norms is None:
                return batch_conds(layout.unpack(Jp))
            with np.errstate(invalid='ignore', over='ignore'):
                c1 = layout.j_norms(Jp) * norms
            return exact_or_scaled(c1, lambda rows: layout.unpack(Jp[rows]))
        if layout.whole or not Jp.shape[0]:
            return batch_conds(layout.unpack(Jp))
        K, n = Jp.shape[0], self.t.n
        kept = self._inverse_rows
        try:
            work = kept.pop() if kept and kept[-1].shape == (n, K, n) else None
        except IndexError:  # another thread took it
            work = None
        if work is None:
            work = np.zeros((n, K, n))
        norms = parts_inverse_norms(layout.form, layout.parts(Jp), work)
        if work.nbytes <= SPARE_BYTES:
            kept.clear()  # (one kept: of the latest batch size)
            kept.append(work)
        if norms is None:
            return batch_conds(layout.unpack(Jp))
        with np.errstate(invalid='ignore', over='ignore'):
            c1 = layout.j_norms(Jp) * norms
        return exact_or_scaled(c1, lambda rows: layout.unpack(Jp[rows]))

    def answer_checks(self, Jp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(det_signs, conds) of a packed (K, size) stack: what an answer is checked by,
        from one reduction where J is reduced to its varying columns. An exactly singular
        matrix (det sign 0) gets cond inf and is left out of the others' inverses: in the
        stack it would fail every row's inverse and turn every cond into scaled_cond."""
        layout = self.layout()
        reduced = isinstance(layout, SchurForm) and Jp.shape[0]
        if reduced:
            assert isinstance(layout, SchurForm)
            signs, norms = schur_answer(layout, Jp)
        else:
            signs, norms = self.det_signs(Jp), None
        singular = signs == 0
        if singular.any():
            conds = np.full(Jp.shape[0], math.inf)
            if not singular.all():
                conds[~singular] = self.conds(Jp[~singular])
            return signs, conds
        if not reduced:
            return signs, self.conds(Jp)
        assert isinstance(layout, SchurForm)
        if norms is None:
            return signs, batch_conds(layout.unpack(Jp))
        with np.errstate(invalid='ignore', over='ignore'):
            c1 = layout.j_norms(Jp) * norms
        return signs, exact_or_scaled(c1, lambda rows: layout.unpack(Jp[rows]))

    def newton_steps(self, Jp: np.ndarray, F: np.ndarray) -> np.ndarray:
        """newton_steps for a packed (K, size) stack of this system's Jacobians: forward
        substitution through its blocks, densely where a block of some matrix is singular;
        or the reduced step (NaN rows where M, so J, is singular)."""
        layout = self.layout()
        if isinstance(layout, SchurForm):
            M, r = schur_reduce(layout, Jp, F)
            return schur_back(layout, Jp, F, reduced_steps(M, r))
        blocks = not layout.whole and Jp.shape[0]
        dy = parts_steps(layout.form, layout.parts(Jp), F) if blocks else None
        return newton_steps(layout.unpack(Jp), F) if dy is None else dy

    def values(self, values: Sequence[Any], N: int) -> np.ndarray:
        """(columns, N) matrix of the values (angles wrapped as evaluate.residual_rows wraps
        them, rad; slides and points m), then a zero row: what the batched rows subtract (a
        value column of the commands a row of it, as evaluate lays its rows out)."""
        tab = self.tables()
        specs = self.t.specs
        if len(values) != len(specs):
            raise ValueError(f'{len(values)} value arrays for {len(specs)} specs')
        V = np.zeros((tab.n_cols, N))
        for s, v, c in zip(specs, values, tab.cols):
            shape = (N, 2) if isinstance(s, PointSpec) else (N,)
            try:
                arr = np.broadcast_to(np.asarray(v, float), shape)
            except ValueError:
                raise ValueError(
                    f'values for {s.name!r} ({s.unit}) must have shape {shape}, got {np.shape(v)}'
                ) from None
            if isinstance(s, PointSpec):
                V[c : c + 2] = arr.T
            elif isinstance(s, AngleSpec):
                V[c] = BATCH.wrap(arr)
            else:
                V[c] = arr
        return V

    def evaluate(
        self,
        X: np.ndarray,
        V: np.ndarray,
        jacobian: bool,
        packed: bool = False,
        out: np.ndarray | None = None,
        templated: bool = False,
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """evaluate_scaled for the rows of X (N, n) with the value matrix V (values()):
        F (N, m), J (N, m, n) (``packed``: (N, size) as PackedJacobian stores it, written
        into ``out`` if given; ``templated``: ``out`` is such a J already, its constant
        entries in place, so only the varying ones are written) or None, res (N,). The
        formulas are core.newton.rows', as in evaluate.residual_rows."""
        t, tab = self.t, self.tables()
        N, m, nf = X.shape[0], t.m, len(t.free)
        k = 1.0 / t.L
        kL = t.L * k  # as residual_rows: not exactly 1
        # every array below is slot- or row-major, (k, N): each formula's operation one run
        # over the N configurations of each row, a (k,) table a column, and the (N, k) layout
        # came out of the slot gathers strided (1.5-3x the time per operation, the same floats)
        with np.errstate(invalid='ignore', over='ignore'):
            # slots (free links, then the ground) x configurations: phi, cos, sin, cx, cy
            P = np.empty((5, nf + len(t.others), N))
            phi = X[:, 0::3].T
            P[0, :nf] = phi
            np.cos(phi, out=P[1, :nf])
            np.sin(phi, out=P[2, :nf])
            P[3, :nf] = X[:, 1::3].T
            P[4, :nf] = X[:, 2::3].T
            P[:, nf:] = tab.fixed.transpose(0, 2, 1)
            total = float(phi.sum())
            if total - total != 0.0:  # a NaN or inf angle somewhere: look closer (rare)
                blown = np.isinf(phi).any(axis=0)
                # as residual_rows, where math.cos raises: NaN free slots
                P[:, :nf, blown] = math.nan
            FT = np.empty((m, N))
            JvT = np.empty((len(t.jpos), N)) if jacobian else None
            nrev = len(tab.rev_a)
            if nrev:  # revolute rows: w_a(P) - w_b(P)
                fx, fy, jv = revolute_rows(
                    *_pose(P, tab.rev_a),
                    *_pair(tab.rev_la),
                    *_pose(P, tab.rev_b),
                    *_pair(tab.rev_lb),
                    k,
                )
                FT[0 : 2 * nrev : 2] = fx
                FT[1 : 2 * nrev : 2] = fy
                if JvT is not None:
                    # each entry into its rows (np.stack would cost several of these)
                    for e, entry in enumerate(jv):
                        JvT[e : 4 * nrev : 4] = entry
            if len(tab.line_row):  # line rows: u . (w_S(X) - w_G(base)) [- value]
                f, jl = line_row(
                    *_pose(P, tab.line_g),
                    *_pose(P, tab.line_s),
                    *_pair(tab.line_k[0:2]),
                    *_pair(tab.line_k[2:4]),
                    *_pair(tab.line_k[4:6]),
                    V[tab.line_val],
                    k,
                )
                FT[tab.line_row] = f
                if JvT is not None:
                    for e, entry in enumerate(jl):
                        JvT[tab.line_jv[:, e]] = entry
            if len(tab.ang_row):  # angle rows: L * wrap(phi_a - phi_b - (value - off))
                FT[tab.ang_row] = angle_row(
                    P[0][tab.ang_a],
                    P[0][tab.ang_b],
                    V[tab.ang_val],
                    tab.ang_off[:, None],
                    kL,
                    BATCH.wrap,
                )
            if len(tab.pt_row):  # point rows: w(X) - (x, y)
                fx, fy, jp = point_rows(
                    *_pose(P, tab.pt_link),
                    *_pair(tab.pt_lever),
                    V[tab.pt_val],
                    V[tab.pt_val + 1],
                    k,
                )
                FT[tab.pt_row] = fx
                FT[tab.pt_row + 1] = fy
                if JvT is not None:
                    for e, entry in enumerate(jp):
                        JvT[tab.pt_jv[:, e]] = entry
        res = np.abs(FT).max(axis=0) if m else np.zeros(N)  # NaN where F has one
        total = float(res.sum())
        if total - total != 0.0:  # a row with NaN or inf: inf (rare)
            res[~np.isfinite(res)] = math.inf
        F = np.ascontiguousarray(FT.T)
        if JvT is None:
            return F, None, res
        layout = self.layout() if packed else None
        tpl, pos = (tab.j_tpl, tab.j_pos) if layout is None else (layout.tpl, layout.pos)
        J = np.empty((N, len(tpl))) if out is None else out
        if t.jpos_unique:
            if out is None or not templated:
                J[:] = tpl
            J[:, pos] = JvT[tab.jv_real].T
        else:
            J[:] = tpl
            # numpy's stubs take no tuple index for ufunc.at
            np.add.at(J, (slice(None), pos), JvT[tab.jv_real].T)  # type: ignore[arg-type]
        return F, (J if packed else J.reshape(N, m, t.n)), res

    def evaluate_batch(
        self, X: np.ndarray, values: Sequence[Any], jacobian: bool = True
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """LoopSystem.evaluate_batch (its docstring)."""
        X = np.asarray(X, float)
        n = self.t.n
        if X.ndim != 2 or X.shape[1] != n:
            raise ValueError(f'X must have shape (N, {n}), got {X.shape}')
        return self.evaluate(X, self.values(values, X.shape[0]), jacobian)

    def _evaluate_jac(
        self, X: np.ndarray, V: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        out, templated = self._take(X.shape[0], self.layout().size)
        F, J, res = self.evaluate(X, V, True, packed=True, out=out, templated=templated)
        assert J is not None
        return F, J, res

    def solve_batch(
        self,
        X0: np.ndarray,
        values: Sequence[Any],
        start_sign: int | np.ndarray | Sequence[int],
        *,
        tol: float = NEWTON_TOL,
        max_steps: int = FAST_STEPS + 2,
        start_checked: bool = False,
        warm: bool = False,
    ) -> BatchSolve:
        """LoopSystem.solve_batch (its docstring)."""
        self.tables()  # ValueError first if the system needs fixed poses
        t = self.t
        if t.m != t.n:
            raise ValueError(
                f'solve_batch needs a square system (m = {t.m} rows, n = {t.n} unknowns)'
            )
        X0 = np.asarray(X0, float)
        if X0.ndim != 2 or X0.shape[1] != t.n:
            raise ValueError(f'X0 must have shape (N, {t.n}), got {X0.shape}')
        N = X0.shape[0]
        V = self.values(values, N)
        want = np.broadcast_to(np.asarray(start_sign), (N,))
        sign0 = np.where(want == 1, 1, np.where(want == -1, -1, 0))
        target = min(tol, max(FAST_MARGIN * tol, FAST_FLOOR))

        # x, F, J, res: each row's latest accepted iterate. While every row steps (the common
        # case) they are replaced whole, never gathered or scattered (copies of J cost as much
        # as a step)
        x = X0
        F, J, res = self._evaluate_jac(x, V)
        res0 = res
        iterations = np.zeros(N, int)
        live = (sign0 != 0) & np.isfinite(res)
        if not start_checked:  # else the caller read start_sign off J at X0 (J needs no values)
            live[live] = self.det_signs(_rows_of(J, live)) == sign0[live]
        done = live & (res <= target)  # converged (pending det sign and cond at the answer)
        active = live & ~done  # still stepping
        # every row stepping (the common case): the rows are not listed, nor the masks
        # written, until one row stops
        all_stepping = N > 0 and bool(active.all())
        rows = np.arange(N)
        for step in range(max_steps):
            if all_stepping:
                every = True
            else:
                rows = np.flatnonzero(active)
                if not rows.size:
                    break
                every = rows.size == N
            Ja, Fa = (J, F) if every else (J[rows], F[rows])
            dy = self.newton_steps(Ja, Fa)
            xn = (x if every else x[rows]) + dy * t.step_scale
            Fn, Jn, rn = self._evaluate_jac(xn, V if every else V[:, rows])
            if every:
                iterations += 1
            else:
                iterations[rows] += 1
            ra = res if every else res[rows]
            with np.errstate(invalid='ignore'):
                if warm and step == 0:
                    # the first step from a solution at earlier values is the tangent
                    # prediction the scalar path takes (predictor.predict): judged as it is
                    # judged there, by how far it moves (MAX_PREDICTION); the rate from the next
                    cut = (np.abs(dy).max(axis=1) <= MAX_PREDICTION) & np.isfinite(rn)
                else:
                    cut = rn <= FAST_RATE * ra  # False for NaN
            if every and cut.all():
                self._give_back(J)
                x, F, J, res = xn, Fn, Jn, rn
                there = rn <= target
                if there.any():
                    active &= ~there
                    done |= there
                    all_stepping = False
                continue
            all_stepping = False
            stalled = rows[~cut]
            active[stalled] = False
            done[stalled] = ra[~cut] <= tol  # at the rounding floor already: converged
            moved = rows[cut]
            if x is X0:  # the first scatter: own copies, the start is not written to (F
                # and J are this call's own already; res0 keeps the start's residuals)
                x, res = x.copy(), res.copy()
            x[moved], F[moved], J[moved], res[moved] = xn[cut], Fn[cut], Jn[cut], rn[cut]
            if every:  # (a part's Jn is let go: the spares are whole batches')
                self._give_back(Jn)
            there = moved[rn[cut] <= target]
            active[there] = False
            done[there] = True
        rows = np.flatnonzero(active)  # out of steps: converged if within tol
        done[rows] = res[rows] <= tol

        # at the answer: the start's det J sign (else it crossed det J = 0: maybe another
        # branch; rows still at X0 were checked there) and off folds (else the scalar path
        # polishes)
        check = done if start_checked else done & (iterations > 0)
        if done.all():  # the common case: no gathers, no scatters
            signs, cond = self.answer_checks(J)
            done = ~check | (signs == sign0)
        else:
            answers = np.flatnonzero(done)
            signs, conds = self.answer_checks(J[done])
            cond = np.full(N, math.inf)
            cond[answers] = conds
            done[answers] = ~check[answers] | (signs == sign0[answers])
        self._give_back(J)  # nothing below reads J
        ok = done & (cond < NEAR_SINGULAR_COND) & np.isfinite(x).all(axis=1) & np.isfinite(res)
        if ok.all():  # the common case: no where passes (and x never the caller's X0)
            return BatchSolve(
                x=x.copy() if x is X0 else x,
                ok=ok,
                iterations=iterations,
                residual=res.copy() if res is res0 else res,
                det_sign=sign0,
                cond=cond,
            )
        return BatchSolve(
            x=np.where(ok[:, None], x, X0),
            ok=ok,
            iterations=iterations,
            residual=np.where(ok, res, res0),
            det_sign=np.where(ok, sign0, 0),
            cond=np.where(ok, cond, math.inf),
        )


def _rows_of(A: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """A[mask], without the copy where every row is asked for."""
    return A if mask.all() else A[mask]
