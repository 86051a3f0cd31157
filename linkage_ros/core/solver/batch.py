"""Many commands at once: BatchResult (closed form vectorised; Newton over instances)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import dyads
from ..ops import BATCH
from ..plan import (
    Poses,
    Spec,
    branch_geometry_batch,
    branch_geometry_one,
    link_poses,
)
from ..quantities import PointSpec
from .point_pairs import pair_columns
from .result import Result, branch_identity_defined, branch_signs, branch_text

#: core.solver.Solver, which mixes BatchAPI in: not imported (it imports this module); the
#: batch functions read its compiled parts (specs, plan, Newton system) and continuity state
Solver = Any


class BatchResult:
    """Results of n commands as arrays: ok (n,), reason list, points {name: (n, 2)},
    joints / links / inputs {name: (n,)}, residual, margin, iterations, signs (n, k); newton
    batches also x (n, 3 * moving links: the Newton unknowns) and det_sign (n,), what the next
    batch of the same instances starts from (Solver.solve_batch(start=...))."""

    x: np.ndarray | None = None
    det_sign: np.ndarray | None = None
    careful: np.ndarray | None = None  # newton batches with start=: rows Solver.solve answered
    rows: list[Result] | None = None

    @classmethod
    def solve(
        cls, solver: Solver, arrays: list[np.ndarray], n: int, start: BatchResult | None = None
    ) -> BatchResult:
        self = cls()
        self.n = n
        self.values = arrays  # the command columns, in solver.specs order
        self.source = solver._batch_source()
        finite = np.ones(n, bool)
        for a in arrays:
            finite &= np.all(np.isfinite(a.reshape(n, -1 if n else 1)), axis=1)
        self.reason = [None] * n
        for i in np.flatnonzero(~finite):
            self.reason[i] = 'value must be finite (NaN or inf in the command)'
        safe = [np.where(np.isfinite(a), a, 0.0) for a in arrays]
        limit_bad = np.zeros(n, bool)
        for s, a in zip(solver.specs, safe):
            if not isinstance(s, PointSpec) and (s.minimum is not None or s.maximum is not None):
                for i in np.flatnonzero(finite & ~limit_bad):
                    why = solver.limit_violation(s, float(a[i]))
                    if why:
                        limit_bad[i] = True
                        self.reason[i] = why
        if solver.mode != 'closed_form':
            if start is not None:
                return cls._newton(self, solver, arrays, safe, finite & ~limit_bad, start)
            return cls._sequential(self, solver, arrays, n)
        poses, pts, info = solver.plan.run(safe, n, solver._signs())
        ok = info['ok'] & finite & ~limit_bad
        for i in np.flatnonzero(~info['ok'] & finite & ~limit_bad):
            self.reason[i] = solver._dyad_reason(
                int(info['failure'][i]), float(info['violation'][i])
            )
        got = _batch_assembly(solver, poses, safe)
        residual = np.where(ok, got.residual, 0.0)
        far = ok & ~(residual <= solver.closure_limit)  # as Solver.solve: no false assembly
        for i in np.flatnonzero(far):
            self.reason[i] = solver._closure_reason(float(residual[i]))
        ok &= ~far
        self._fill(solver, poses, pts, arrays, safe, finite, ok, got)
        self.margin = np.where(self.ok, info['margin'], 0.0)
        self.signs = info['signs']
        self.residual = np.where(self.ok, residual, 0.0)
        self.iterations = np.zeros(n, int)
        self.solver = 'closed_form'
        return self

    def _fill(self, solver, poses, pts, arrays, safe, finite, ok, got=None):
        """points, links, joints and inputs of the rows ``ok`` from their poses (0 elsewhere);
        an inverse solve's actuator beyond its limits turns its row into a failure. Returns the
        assembly (``got``, when the caller already has it)."""
        if got is None:
            got = _batch_assembly(solver, poses, safe)
        self.points = {p: np.where(ok[:, None], v, 0.0) for p, v in pts.items()}
        self.links = {l: np.where(ok, v, 0.0) for l, v in got.links.items()}
        self.joints = {j: np.where(ok, v, 0.0) for j, v in got.joints.items()}
        self.inputs = {a: np.where(ok, v, 0.0) for a, v in got.inputs.items()}
        for s, a in zip(solver.specs, arrays):
            if s.name in solver.mech.actuators:
                self.inputs[s.name] = np.where(ok, a, np.where(finite, a, 0.0))
        if solver.inverse:
            for s in solver.actuator_specs:
                if s.name in self.inputs and (s.minimum is not None or s.maximum is not None):
                    for i in np.flatnonzero(ok):
                        why = solver.limit_violation(s, float(self.inputs[s.name][i]))
                        if why:
                            ok[i] = False
                            self.reason[i] = f'target needs {why}'
        self.ok = ok
        return got

    @staticmethod
    def _newton(self, solver, arrays, safe, valid, start):
        """Vectorised warm-started Newton over independent instances (see Solver.solve_batch);
        the rows it cannot vouch for go through Solver.solve from their start."""
        mech, n, system = solver.mech, self.n, solver.system
        plan = solver.full_plan
        branches = bool(plan.complete and plan.branch_steps)
        k = len(plan.branch_steps) if branches else 0
        eligible = np.flatnonzero(valid & start.ok & (start.det_sign != 0))
        x = np.zeros((n, system.n))
        accepted = np.zeros(n, bool)
        iterations = np.zeros(n, int)
        residual = np.zeros(n)
        det_sign = np.zeros(n, int)
        cond = np.full(n, np.inf)
        if len(eligible):
            bs = system.solve_batch(
                start.x[eligible],
                [a[eligible] for a in safe],
                start.det_sign[eligible],
                tol=solver.tol,
            )
            rows = eligible[bs.ok]
            x[rows], iterations[eligible] = bs.x[bs.ok], bs.iterations
            residual[rows], det_sign[rows], cond[rows] = (
                bs.residual[bs.ok],
                bs.det_sign[bs.ok],
                bs.cond[bs.ok],
            )
            # Solver.solve checks the closed form can assemble unless the answer is provably on
            # its branch: well conditioned for its residual (Newton-Kantorovich) and the dyads on
            # the start's sides. A row that needs that check (or changed sides) goes there too.
            accepted[rows] = cond[rows] ** 2 * residual[rows] * system.n <= 1e-2
        poses = _batch_poses(solver, x)
        pts = {p: poses.world(l, p, mech) for p, l, _ in system._point_owner}
        signs = np.zeros((n, k), int)
        margin = np.where(accepted, 1.0 / np.maximum(cond, 1.0), 0.0)
        if branches:
            signs, margins = branch_geometry_batch(plan, pts, poses)
            accepted &= np.all(signs == start.signs, axis=1)
            margin = np.min(margins, axis=1)
        if solver.branch_mode == 'explicit':
            accepted &= np.all(signs == np.asarray(solver.fixed_signs, int), axis=1)
        elif solver.branch_mode == 'reference' and branches:
            accepted &= np.all(signs == np.asarray(plan.reference_signs, int), axis=1)
        got = self._fill(solver, poses, pts, arrays, safe, valid, accepted.copy())
        self.x, self.det_sign = x, np.where(self.ok, det_sign, 0)
        self.signs, self.margin = (
            np.where(self.ok[:, None], signs, 0),
            np.where(self.ok, margin, 0.0),
        )
        self.iterations = np.where(self.ok, iterations, 0)
        self.residual = np.where(
            self.ok,
            np.maximum(residual, got.residual),
            0.0,
        )
        self.solver = solver.mode
        self.careful = valid & ~accepted
        careful = np.flatnonzero(self.careful)
        if len(careful):
            snapshot = solver.snapshot()
            try:
                for i in careful:
                    r = self._careful_row(solver, arrays, start, i)
                    self._set_row(solver, i, r, iterations[i])
            finally:
                solver.restore(snapshot)
        return self

    def _careful_row(self, solver, arrays, start, i) -> Result:
        """Row i by Solver.solve from row i of ``start`` (its configuration, det J sign and
        dyad sides; the reference pose if that row failed), committed so its x can be read."""
        solver.reset()
        if start.ok[i]:
            xi = start.x[i]
            poses, pts = solver.check_system.configuration(xi)
            vals = [
                np.array(a[i], float) if isinstance(s, PointSpec) else float(a[i])
                for s, a in zip(solver.specs, start.values)
            ]
            if solver.full_plan.complete:
                signs, margins = branch_geometry_one(solver.full_plan, pts, poses)
            else:
                signs, margins = solver.plan.reference_signs, ()
            solver._history = [
                solver._state(
                    vals, poses, pts, signs, int(start.det_sign[i]), margins, x_all=xi.copy()
                )
            ]
        cmd = {
            s.name: (arrays[k][i] if isinstance(s, PointSpec) else float(arrays[k][i]))
            for k, s in enumerate(solver.specs)
        }
        return solver.solve(cmd)

    def _set_row(self, solver, i, r: Result, spent: int):
        """Write one Result into row i (x and det_sign from the solver's committed state)."""
        self.ok[i], self.reason[i] = r.success, r.reason
        if not r.success:
            self.det_sign[i] = 0
            return
        for table, got in ((self.links, r.links), (self.joints, r.joints), (self.inputs, r.inputs)):
            for name in table:
                table[name][i] = got.get(name, 0.0)
        for p in self.points:
            self.points[p][i] = r.points.get(p, (0.0, 0.0))
        self.margin[i], self.residual[i] = r.margin or 0.0, r.residual or 0.0
        self.iterations[i] = r.iterations + spent
        if self.signs.shape[1] == len(r.branch):
            self.signs[i] = branch_signs(r.branch)
        state = solver._history[-1]
        self.x[i], self.det_sign[i] = state.x_all, state.det_sign

    @staticmethod
    def _sequential(self, solver, arrays, n):
        mech = solver.mech
        rows, states = [], {}
        for i in range(n):
            if self.reason[i] is not None:
                rows.append(Result(False, self.reason[i]))
                continue
            cmd = {
                s.name: (arrays[k][i] if isinstance(s, PointSpec) else float(arrays[k][i]))
                for k, s in enumerate(solver.specs)
            }
            rows.append(solver.solve(cmd))
            if rows[-1].success:
                states[i] = solver._history[-1]
        self.ok = np.array([r.success for r in rows], bool)
        self.reason = [r.reason for r in rows]
        names_p = list(mech.points)
        self.points = {
            p: np.array([r.points.get(p, (0.0, 0.0)) for r in rows]).reshape(n, 2) for p in names_p
        }
        self.links = {l: np.array([r.links.get(l, 0.0) for r in rows]) for l in mech.links}
        self.joints = {j: np.array([r.joints.get(j, 0.0) for r in rows]) for j in mech.joint_names}
        self.inputs = {a: np.array([r.inputs.get(a, 0.0) for r in rows]) for a in mech.actuators}
        self.margin = np.array([r.margin or 0.0 for r in rows])
        self.residual = np.array([r.residual or 0.0 for r in rows])
        self.iterations = np.array([r.iterations for r in rows])
        self.signs = np.zeros((n, 0), int)
        self.solver = solver.mode
        self.rows = rows
        if solver.mode == 'newton':  # what a later batch of these rows may start from
            self.x, self.det_sign = np.zeros((n, solver.system.n)), np.zeros(n, int)
            for i in np.flatnonzero(self.ok):
                self.x[i], self.det_sign[i] = states[i].x_all, states[i].det_sign
            k = len(solver.full_plan.branch_steps) if solver.full_plan.complete else 0
            self.signs = np.array(
                [
                    branch_signs(r.branch) if r.success and len(r.branch) == k else [0] * k
                    for r in rows
                ],
                int,
            ).reshape(n, k)
        return self

    def row(self, i: int, solver: Solver) -> Result:
        if getattr(self, 'rows', None) is not None:
            return self.rows[i]
        if not self.ok[i]:
            return Result(False, self.reason[i], solver=self.solver)
        sg = tuple(int(s) for s in self.signs[i])
        return Result(
            True,
            None,
            inputs={k: float(v[i]) for k, v in self.inputs.items()},
            joints={k: float(v[i]) for k, v in self.joints.items()},
            links={k: float(v[i]) for k, v in self.links.items()},
            points={k: (float(v[i, 0]), float(v[i, 1])) for k, v in self.points.items()},
            residual=float(self.residual[i]),
            iterations=int(self.iterations[i]),
            solver=self.solver,
            branch=branch_text(sg),
            margin=float(self.margin[i]),
            branch_defined=(
                bool(branch_identity_defined(self.margin[i], self.residual[i])) if sg else True
            ),
        )


def _batch_assembly(solver: Solver, poses: Poses, arrays) -> Any:
    """ResultAssembler on batched (n, 2)-coordinate poses."""
    with np.errstate(all='ignore'):
        return solver._assembler(poses.phi)(BATCH, link_poses(poses), arrays)


def _batch_poses(solver: Solver, x: np.ndarray) -> Poses:
    """Poses of every link from newton unknowns x (n, 3 per moving link: phi and the world
    position of the link's reference centroid o, so T = c - R(phi) o); the ground at rest."""
    system, n = solver.system, x.shape[0]
    poses = Poses({solver.mech.ground: np.zeros(n)}, {solver.mech.ground: np.zeros((n, 2))})
    for l, i in system.index.items():
        phi = x[:, 3 * i]
        poses.phi[l] = phi
        poses.T[l] = x[:, 3 * i + 1 : 3 * i + 3] - dyads.rotate(
            np.broadcast_to(system.centroid[l], (n, 2)), phi
        )
    return poses


class BatchAPI:
    """Solver's many-commands entry point (a mixin of :class:`Solver`): columns in, one
    :class:`BatchResult` out."""

    def solve_batch(
        self, columns: Mapping[str, Any], start: BatchResult | None = None
    ) -> BatchResult:
        """Solve n commands at once. ``columns`` maps each known name to an (n,) array ((n, 2)
        for points).

        closed_form: one vectorised dyad-plan run with fixed branch signs (the explicit ones,
        else the current/reference ones).

        newton / auto without ``start``: the rows are one path, solved one after another by
        ``solve`` (warm-started and branch-tracked from the solver's state, which they update).

        newton with ``start``: n independent instances advancing together (a fleet of
        mechanisms, simulation environments), row i warm-started from row i of ``start``, an
        earlier newton BatchResult of this solver with the same n. Vectorised Newton answers
        every row it can prove is on the start's branch (det J keeps its sign, each step cuts
        the residual tenfold, the dyads keep their sides, the answer is well conditioned); the
        other rows take ``solve``'s careful path from their start, so the answers are those
        ``solve`` would give from that start."""
        names = list(columns)
        unknown = [k for k in names if k not in self.knowns]
        missing = [k for k in self.knowns if k not in columns]
        if unknown or missing:
            raise ValueError(
                f'batch columns must be exactly {self.knowns}'
                f'{"; unknown " + str(unknown) if unknown else ""}'
                f'{"; missing " + str(missing) if missing else ""}'
            )
        if self.point_pairs:
            columns = pair_columns(columns, self.point_pairs, self.pair_tolerance_m)
        arrays = []
        n = None
        for s in self.specs:
            a = self._batch_column(s, columns[s.name])
            if n is None:
                n = a.shape[0]
            elif a.shape[0] != n:
                raise ValueError(f'batch column {s.name!r} has {a.shape[0]} rows, expected {n}')
            arrays.append(a)
        if start is not None:
            if self.mode != 'newton':
                raise ValueError(f'start= warm-starts newton batches; this solver is {self.mode}')
            if not isinstance(start, BatchResult) or start.x is None:
                raise ValueError(
                    'start must be a newton BatchResult of this solver (a closed-form '
                    'batch carries no Newton state)'
                )
            if start.n != (n or 0):
                raise ValueError(
                    f'start has {start.n} rows but this batch has {n or 0}: row i starts from row i'
                )
            theirs = getattr(start, 'source', None)
            if theirs != self._batch_source():
                what = f'{theirs[0]!r} with knowns {list(theirs[1])}' if theirs else 'unknown'
                raise ValueError(
                    'start must be a newton BatchResult of a solver of this '
                    f'mechanism ({self.mech.name!r}, its reference geometry) with '
                    f'knowns {self.knowns}; got one of {what}'
                )
            if not (
                isinstance(start.x, np.ndarray)
                and start.x.shape == (start.n, self.system.n)
                and np.shape(start.det_sign) == (start.n,)
                and np.shape(start.ok) == (start.n,)
            ):
                raise ValueError(
                    'start is not a newton BatchResult as solve_batch made it (its '
                    'x, det_sign or ok arrays have the wrong shape)'
                )
        return BatchResult.solve(self, arrays, n or 0, start)

    def _batch_source(self) -> tuple:
        """What a newton batch's x means (the mechanism, its reference geometry, the knowns and
        the Newton unknowns): start= takes only batches of the same. Made once per solver."""
        src = self.__dict__.get('_source')
        if src is None:
            src = self._source = (
                self.mech.name,
                tuple(self.knowns),
                tuple(self.system.free),
                tuple((p, float(v[0]), float(v[1])) for p, v in self.mech.points.items()),
            )
        return src

    @staticmethod
    def _batch_column(s: Spec, v) -> np.ndarray:
        """One command column as floats, (n,) or (n, 2) for a point; ValueError naming the
        column for anything but real numbers (bool, str, complex and object columns too)."""
        a = np.asarray(v)
        if a.dtype.kind not in 'iuf':
            raise ValueError(
                f'batch column {s.name!r} must hold real numbers ({s.unit}), got '
                f'an array of {a.dtype}'
            )
        a = a.astype(float)
        if isinstance(s, PointSpec):
            if a.ndim == 0 or a.shape[-1] != 2 or a.ndim > 2:
                raise ValueError(
                    f'batch column {s.name!r} must have shape (n, 2) (x, y in m), got {a.shape}'
                )
            return a.reshape(-1, 2)
        if a.ndim > 1:
            raise ValueError(f'batch column {s.name!r} must have shape (n,), got {a.shape}')
        return a.reshape(-1)
