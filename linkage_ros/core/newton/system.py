"""LoopSystem: the public face of a mechanism's loop-closure equations. It compiles them once
(tables.compile_tables) and hands every call to the module that does it: evaluate (one
configuration), scalar (the Newton solves of one), predictor (the continuation predictor),
batch (N at once), linalg (factorisation, det J sign, condition number)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal, overload

import numpy as np

from ..execute import LinkPoses
from ..mechanism import Mechanism
from ..quantities import Spec
from . import evaluate as ev
from . import linalg, predictor, scalar
from .batch import BatchNewton
from .lean import Kernel
from .results import FAST_STEPS, NEWTON_TOL, BatchSolve, LUFactor, SolveResult
from .tables import LoopTables, PointOwner, compile_tables, pattern_positions, spec_links


class LoopSystem:
    """The loop-closure equations of a mechanism restricted to a set of free links."""

    def __init__(
        self, mech: Mechanism, specs: Sequence[Spec], free_links: Sequence[str] | None = None
    ):
        t = compile_tables(mech, specs, free_links)
        self.tables: LoopTables = t
        self.batch = BatchNewton(t)
        self.mech = mech
        self.specs: list[Spec] = list(t.specs)
        self.L = t.L
        self.free: list[str] = list(t.free)
        self.index: dict[str, int] = t.index
        self.n = t.n
        self.m = t.m
        self.centroid: dict[str, np.ndarray] = t.centroid
        self.col_scale: np.ndarray = t.col_scale
        self.step_scale: np.ndarray = t.step_scale
        self.point_owner: list[PointOwner] = t.point_owner
        #: (free link, where its phi, cx and cy are in x, its reference centroid (complex, m))
        self._centroid_z: list[tuple[str, int, int, int, complex]] = [
            (l, 3 * i, 3 * i + 1, 3 * i + 2, complex(*map(float, t.centroid[l])))
            for l, i in t.index.items()
        ]

    def spec_links(self, s: Spec) -> list[str]:
        """The links a spec's rows involve."""
        return spec_links(self.mech, s)

    # -- conversions between poses and the variable vector -------------------------------------
    def x_from_poses(self, poses: LinkPoses) -> np.ndarray:
        """Variable vector of the free links from a configuration."""
        x = np.empty(self.n)
        for l, i in self.index.items():
            o = self.centroid[l]
            c = poses.rot[l] * complex(o[0], o[1]) + poses.T[l]
            x[3 * i : 3 * i + 3] = (poses.phi[l], c.real, c.imag)
        return x

    def reference_x(self) -> np.ndarray:
        """The variable vector of the reference pose."""
        x = np.zeros(self.n)
        for l, i in self.index.items():
            x[3 * i + 1 : 3 * i + 3] = self.centroid[l]
        return x

    def poses_from_x(
        self, x: np.ndarray | list[float], fixed: LinkPoses | None = None
    ) -> LinkPoses:
        """Configuration of every link: free ones from x (an array, or its list of floats: a
        Newton answer read once), the rest from ``fixed`` (ground at the reference pose)."""
        phi: dict[str, Any] = {}
        rot: dict[str, Any] = {}
        T: dict[str, Any] = {}
        if fixed is not None:
            for l in fixed.phi:
                phi[l], rot[l], T[l] = fixed.phi[l], fixed.rot[l], fixed.T[l]
        ground = self.mech.ground
        if ground not in phi:
            phi[ground], rot[ground], T[ground] = 0.0, 1 + 0j, 0j
        # plain floats and complex numbers: the warm Newton solve reads every configuration
        # it checks through here (a dozen numpy scalar reads per link would cost more)
        xs: list[float] = x if isinstance(x, list) else x.tolist()
        cos, sin = math.cos, math.sin
        for l, ip, ix, iy, o in self._centroid_z:
            p = xs[ip]
            r = complex(cos(p), sin(p))
            phi[l], rot[l], T[l] = p, r, complex(xs[ix], xs[iy]) - r * o
        return LinkPoses(phi, rot, T)

    def configuration(
        self, x: np.ndarray | list[float], fixed: LinkPoses | None = None
    ) -> tuple[LinkPoses, dict[str, complex]]:
        """(poses, points): poses_from_x and every point's world position (complex), each read
        off the first link that carries it."""
        poses = self.poses_from_x(x, fixed)
        rot, T = poses.rot, poses.T
        return poses, {p: rot[l] * z + T[l] for p, l, z in self.point_owner}

    # -- evaluation ---------------------------------------------------------------------------
    @overload
    def evaluate(
        self,
        x: np.ndarray,
        values: Sequence[Any],
        fixed: LinkPoses | None = None,
        jacobian: Literal[True] = True,
    ) -> tuple[np.ndarray, np.ndarray]: ...
    @overload
    def evaluate(
        self, x: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None, jacobian: bool
    ) -> tuple[np.ndarray, np.ndarray | None]: ...
    @overload
    def evaluate(
        self,
        x: np.ndarray,
        values: Sequence[Any],
        fixed: LinkPoses | None = None,
        *,
        jacobian: bool,
    ) -> tuple[np.ndarray, np.ndarray | None]: ...
    def evaluate(
        self,
        x: np.ndarray,
        values: Sequence[Any],
        fixed: LinkPoses | None = None,
        jacobian: bool = True,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Residual F (m,) and, if asked, the analytic Jacobian J (m, n)."""
        return ev.evaluate(self.tables, x, values, fixed, jacobian)

    @overload
    def evaluate_scaled(
        self,
        x: np.ndarray,
        values: Sequence[Any],
        fixed: LinkPoses | None,
        jacobian: Literal[True] = True,
    ) -> tuple[np.ndarray, np.ndarray, float]: ...
    @overload
    def evaluate_scaled(
        self, x: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None, jacobian: bool
    ) -> tuple[np.ndarray, np.ndarray | None, float]: ...
    def evaluate_scaled(
        self,
        x: np.ndarray,
        values: Sequence[Any],
        fixed: LinkPoses | None,
        jacobian: bool = True,
    ) -> tuple[np.ndarray, np.ndarray | None, float]:
        """F / L, J * col_scale (translations / L) and max|F / L| (inf if not finite): the
        scale-free units solve() works in, so nothing overflows at 1e300 m and the LM damping
        means the same at every scale. Steps come back as dy, with dx = dy * self.step_scale."""
        return ev.evaluate_scaled(self.tables, x, values, fixed, jacobian)

    def evaluate_rows_scaled(
        self,
        x: np.ndarray,
        values: Sequence[Any],
        fixed: LinkPoses | None,
        jacobian: bool = True,
    ) -> tuple[np.ndarray, list[float], float]:
        """evaluate_scaled with J left as its varying entries (jacobian_scaled builds it), for
        points where it may not be needed."""
        return ev.evaluate_rows_scaled(self.tables, x, values, fixed, jacobian)

    def jacobian_scaled(self, Jv: Sequence[float]) -> np.ndarray:
        """The scale-free J from evaluate_rows_scaled's varying entries."""
        return ev.jacobian(self.tables, Jv, self.tables.tpl_s)

    def evaluate_batch(
        self, X: np.ndarray, values: Sequence[Any], jacobian: bool = True
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """evaluate_scaled for N configurations at once: returns (F, J, res) in scale-free units,
        F (N, m) = residual / length scale, J (N, m, n) = dF/dx with translation columns times the
        length scale (None if not ``jacobian``), res (N,) = max |F| per row, inf where a row's F
        has a NaN or inf (non-finite X or values give such rows, never an exception).

        X (N, n): rows of the variable vector (phi rad, centroid m per free link). ``values``: one
        entry per spec: (N,) for an angle (rad) or slide (m) spec, (N, 2) for a point (m).
        Only for systems whose non-free links are the ground at its reference pose (what
        evaluate does with fixed=None); ValueError for a hybrid system."""
        return self.batch.evaluate_batch(X, values, jacobian)

    # -- solving ------------------------------------------------------------------------------
    def solve(
        self,
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
        scale-free units (see evaluate_scaled); ``tol`` bounds max|F| / length scale. The det J
        sign tracked is ``start_sign`` (known from the solve that produced x0), else read at
        x0."""
        return scalar.solve(
            self.tables,
            x0,
            values,
            fixed,
            tol=tol,
            max_iter=max_iter,
            keep_det_sign=keep_det_sign,
            start_sign=start_sign,
            guess=guess,
        )

    def solve_from_guess(
        self,
        guess: np.ndarray | list[float],
        values: Sequence[Any],
        fixed: LinkPoses | None = None,
        *,
        tol: float = NEWTON_TOL,
        max_iter: int = 50,
        start_sign: int = 0,
        kernel: Kernel | None = None,
    ) -> SolveResult:
        """The fast path (scalar.solve_from_guess, by ``kernel``, LAPACK's LU where None): one
        Newton step from a predicted guess, then chord steps on its factorisation; declines
        (success False) unless it stays on the det J side ``start_sign`` (0: any) and
        converges quickly."""
        return scalar.solve_from_guess(
            self.tables,
            guess,
            values,
            fixed,
            tol=tol,
            max_iter=max_iter,
            start_sign=start_sign,
            kernel=kernel,
        )

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
        """Newton for N warm starts at once (numpy over the rows): row i from X0[i] (N, n:
        phi rad, centroid m per free link; typically instance i's last solution) to the values
        of row i (as in evaluate_batch), on the side of det J = 0 given by start_sign[i] (+1 or
        -1, or one int for all). Full Newton steps: J evaluated and factorised at every iterate
        (the scalar fast path takes chord steps after its first). Square systems without fixed
        poses only (ValueError otherwise). ``tol`` bounds max|F| / length scale.

        Row i is ok when, as the scalar fast path (solve_from_guess, then finish) would accept
        it: det J at X0[i] is finite with sign start_sign[i]; every step cuts max|F| / L at least
        FAST_RATE-fold down to min(tol, max(FAST_MARGIN * tol, FAST_FLOOR)) within ``max_steps``
        (a step that does not, taken from a point already within ``tol``, leaves the row there,
        converged); det J at the answer has the start's sign (else it crossed det J = 0, maybe
        onto another assembly mode); the answer is off folds (cond < NEAR_SINGULAR_COND, else the
        scalar path polishes it; cond as linalg.cond reports it: see batch.batch_conds) and
        finite. Otherwise the row is *declined*, not failed: ok False, x its X0 row, residual
        max|F| / L at X0, det_sign 0, cond inf; the caller solves it another way (solve(): the
        careful path with line search and LM). Rows never affect one another: each row's result
        is what solving it alone would give.

        ``start_checked``: the caller vouches that start_sign[i] is det J's sign at X0[i] (read
        off J there, e.g. a BatchResult's det_sign at its x: J depends on x alone, not on the
        values), so it is not computed again (one LU per row less); the sign at the answer is
        then checked for every row, those converged at X0 too.

        ``warm``: the caller vouches that X0[i] is a solution at earlier values (a BatchResult's
        x), so the first step from it is the tangent prediction the scalar path takes there
        (predictor.predict: J at the last solution times the change of the values): it is judged
        as the prediction is, by moving no unknown further than MAX_PREDICTION (rad, or length
        scales) to a finite residual, and the FAST_RATE rule holds from the second step on."""
        return self.batch.solve_batch(
            X0,
            values,
            start_sign,
            tol=tol,
            max_steps=max_steps,
            start_checked=start_checked,
            warm=warm,
        )

    def least_miss(
        self, x0: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None = None
    ) -> float:
        """The loop-closure miss (m) of the least-squares configuration nearest ``x0`` (see
        scalar.least_miss)."""
        return scalar.least_miss(self.tables, x0, values, fixed)

    # -- continuation -------------------------------------------------------------------------
    def value_step(self, a: Sequence[Any], b: Sequence[Any]) -> list[float]:
        """b - a per value component in scale-free units (rad, length scales)."""
        return predictor.value_step(self.tables, a, b)

    def rate_factor(self, r: SolveResult) -> LUFactor | None:
        """What predict() needs of a solution (see predictor.rate_factor)."""
        return predictor.rate_factor(self.tables, r)

    def predict(
        self,
        x_last: np.ndarray,
        lu_last: tuple[Any, ...],
        vals_last: Sequence[Any],
        vals: Sequence[Any],
        x_prev: np.ndarray | None = None,
        vals_prev: Sequence[Any] | None = None,
        lu_prev: tuple[Any, ...] | None = None,
    ) -> np.ndarray | None:
        """Predicted solution at ``vals`` from the solution x_last at vals_last and its
        rate_factor ``lu_last``, and optionally the one before (see predictor.predict)."""
        return predictor.predict(
            self.tables, x_last, lu_last, vals_last, vals, x_prev, vals_prev, lu_prev
        )

    def rates(
        self, x: np.ndarray, values: Sequence[Any], value_rates: Sequence[float]
    ) -> tuple[np.ndarray | None, float]:
        """(dx/dt, cond): the unknowns' rates for the knowns' rates (see scalar.rates)."""
        return scalar.rates(self.tables, x, values, value_rates)

    def start_sign(
        self, x: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None = None
    ) -> int:
        """The det J sign a solve from x tracks (0 where J is singular there)."""
        return scalar.det_sign_at(self.tables, x, values, fixed)

    # -- linear algebra -----------------------------------------------------------------------
    def unfixed_links(self) -> list[str]:
        """Free links the equations cannot determine whatever the configuration: by the
        sparsity pattern of J (a maximum matching of rows to unknowns leaves an unknown of each
        unmatched), so [] for a system whose knowns each fix a different degree of freedom.
        Knowns that constrain one link twice (a point on a grounded crank: 2 values, 1 motion)
        leave another link free and make J singular everywhere."""
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import maximum_bipartite_matching

        t = self.tables
        if t.m != t.n or not t.n:
            return []
        at = pattern_positions(t)  # sparse: a big scene's J is mostly zeros
        pattern = csr_matrix((np.ones(len(at)), (at // t.n, at % t.n)), shape=(t.m, t.n))
        rows = maximum_bipartite_matching(pattern, perm_type='column')
        matched = set(rows[rows >= 0].tolist())
        return list(dict.fromkeys(t.free[c // 3] for c in range(t.n) if c not in matched))

    @staticmethod
    def scaled_cond(J: np.ndarray) -> float:
        """Exact 2-norm condition number of J with unit-norm columns (an SVD)."""
        return linalg.scaled_cond(J)

    @staticmethod
    def factor(J: np.ndarray) -> LUFactor | None:
        """LU of J with its det sign; None if singular to working precision, not square or
        empty."""
        return linalg.factor(J)

    @staticmethod
    def cond(J: np.ndarray, fac: LUFactor | None) -> float:
        """Condition number of the scale-free J as the solves report it (see linalg.cond)."""
        return linalg.cond(J, fac)
