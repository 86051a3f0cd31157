"""Many commands at once: a BatchResult (the closed form vectorised; Newton over instances)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..assemble import Assembly
from ..assemble_batch import assemble_batch
from ..batch_inplace import every_finite_in, expi_rows
from ..errors import not_finite
from ..execute import LinkPoses, executor
from ..ops import BATCH
from ..plan import (
    Plan,
    Spec,
    branch_geometry_of,
    branch_geometry_one,
    limit_violation,
    needs_beyond_limits,
    value_interval,
)
from ..quantities import AngleSpec, PointSpec, ScalarSpec
from ..steps import StepKind
from .compiled import CompiledSolve, SolveMode
from .continuity import BranchRule, Continuity, state_of
from .newton_poses import newton_poses
from .one import solve_one
from .point_pairs import pair_columns
from .result import (
    KANTOROVICH_BOUND,
    Result,
    branch_identity_defined,
    branch_signs,
    branch_text,
)
from .table import ResultTable


@dataclass(eq=False)
class BatchResult:
    """Results of n commands as arrays: ok (n,), reason list, points {name: (n, 2)},
    joints / links / inputs {name: (n,)}, residual, margin, iterations, signs (n, k) (0 in a
    refused row; :meth:`table` gives them as the one results table, NaN there); newton
    batches also x (n, 3 * moving links: the Newton unknowns) and det_sign (n,), what the next
    batch of the same instances starts from (Solver.solve_batch(start=...))."""

    n: int
    #: the command columns, in the solve's spec order
    values: list[np.ndarray]
    #: what a newton batch's x means (see batch_source): start= takes only batches of the same
    source: tuple[Any, ...]
    reason: list[str | None]
    ok: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    points: dict[str, np.ndarray] = field(default_factory=dict)
    joints: dict[str, np.ndarray] = field(default_factory=dict)
    links: dict[str, np.ndarray] = field(default_factory=dict)
    inputs: dict[str, np.ndarray] = field(default_factory=dict)
    residual: np.ndarray = field(default_factory=lambda: np.zeros(0))
    margin: np.ndarray = field(default_factory=lambda: np.zeros(0))
    iterations: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    signs: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), int))
    solver: str = SolveMode.CLOSED_FORM
    x: np.ndarray | None = None
    det_sign: np.ndarray | None = None
    #: newton batches with start=: the rows solve_one answered (the careful path)
    careful: np.ndarray | None = None
    #: a batch solved row by row: each row's Result
    rows: list[Result] | None = None

    def table(self) -> ResultTable:
        """These answers as the package's one results table (core.solver.table: a refused
        row NaN where these arrays hold 0)."""
        return ResultTable.from_batch(self)

    def row(self, i: int, solver: Any = None) -> Result:
        """Row i as the Result solve() gives (``solver`` is accepted for callers of old)."""
        if self.rows is not None:
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


def solve_batch(
    c: CompiledSolve,
    cont: Continuity,
    columns: Mapping[str, Any],
    start: BatchResult | None = None,
) -> BatchResult:
    """Solve n commands at once. ``columns`` maps each known name to an (n,) array ((n, 2)
    for points).

    closed_form: one vectorised dyad-plan run with fixed branch signs (the explicit ones,
    else the current/reference ones).

    newton / auto without ``start``: the rows are one path, solved one after another by
    ``solve_one`` (warm-started and branch-tracked from ``cont``, which they update).

    newton with ``start``: n independent instances advancing together (a fleet of
    mechanisms, simulation environments), row i warm-started from row i of ``start``, an
    earlier newton BatchResult of this solve with the same n. Vectorised Newton answers
    every row it can prove is on the start's branch (det J keeps its sign, the first step, the
    tangent prediction the scalar path takes, moves no unknown further than MAX_PREDICTION and
    each step after it cuts the residual tenfold, the dyads keep their sides, the answer is
    well conditioned); the other rows take ``solve_one``'s careful path from their start, so
    the answers are those ``solve_one`` would give from that start."""
    arrays, n = _columns(c, columns)
    source = batch_source(c)
    if start is not None:
        _check_start(c, start, n, source)
    out = BatchResult(n, arrays, source, [None] * n)
    every_finite = every_finite_in(arrays)
    finite = np.ones(n, bool)
    for a in () if every_finite else arrays:  # (a point's rows: both coordinates)
        finite &= np.isfinite(a) if a.ndim == 1 else np.all(np.isfinite(a), axis=1)
    for i in () if every_finite else np.flatnonzero(~finite).tolist():
        # the single solve's refusal: the row's first value that is not finite, named
        for s, a in zip(c.specs, arrays):
            v = a[i].tolist()
            if not all(map(math.isfinite, v if isinstance(v, list) else [v])):
                out.reason[i] = not_finite(s.name, tuple(v) if isinstance(v, list) else v)
                break
    # non-finite values as 0 (their rows are refused); read only from here on
    safe = arrays if every_finite else [np.where(np.isfinite(a), a, 0.0) for a in arrays]
    limit_bad = np.zeros(n, bool)
    for s, a in zip(c.specs, safe):
        if not isinstance(s, PointSpec) and s.bounded:
            for i in np.flatnonzero(finite & ~limit_bad & _limit_suspects(s, a)).tolist():
                why = limit_violation(s, float(a[i]))
                if why:
                    limit_bad[i] = True
                    out.reason[i] = why
    if c.mode is not SolveMode.CLOSED_FORM:
        if start is not None:
            _newton(out, c, cont, arrays, safe, finite & ~limit_bad, start)
        else:
            _sequential(out, c, cont, arrays)
        return out
    run = executor(c.plan).run(safe, n, cont.signs(c.plan))
    closed = np.asarray(run.ok, bool)
    valid = finite & ~limit_bad
    ok = closed & valid
    # (the index lists made only where a row needs words: the common batch has none)
    every_closed = bool(closed.all())
    not_closed = [] if every_closed else np.flatnonzero(~closed & valid).tolist()
    if not_closed:
        failure = np.asarray(run.failure).astype(int)
        violation = np.asarray(run.violation, float)
        for i in not_closed:
            out.reason[i] = c.dyad_reason(int(failure[i]), float(violation[i]))
    # what the answers need of the run taken out, the rest (each dyad's margin, the failure
    # and violation rows) let go before the poses are read: the batch's peak of memory is
    # there (a batch's arrays are most of its cost in fresh memory, page faults included)
    run_poses, points, margin, signs = run.poses, run.points, run.margin, run.signs
    del run
    with np.errstate(all='ignore'):
        poses = _assembly_poses(c.plan, run_poses)
        got = assemble_batch(c.assembler(run_poses.phi), poses, safe, release=True)
        # the poses are read: their arrays let go before the answers are written
        del poses, run_poses
    every = bool(np.all(ok))
    # (the where passes skipped where every row is ok: they would copy)
    residual = _owned_where(ok, got.residual, every)
    # as solve_one: no false assembly (every row within the limit where the largest residual
    # is: max propagates NaN, which fails <= as each row's test does)
    if not (every and n and residual.max() <= c.closure_limit):
        far = ok & ~(residual <= c.closure_limit)
        for i in np.flatnonzero(far).tolist() if far.any() else ():
            out.reason[i] = c.closure_reason(float(residual[i]))
        ok &= ~far
        every = bool(np.all(ok))
    every = _fill(out, c, points, arrays, finite, ok, got, every)
    out.margin = _owned_where(out.ok, margin, every)
    out.signs = np.zeros((n, len(c.plan.branch_steps)), int)
    for b, sg in enumerate(signs):
        out.signs[:, b] = sg
    if not every:
        out.signs[~out.ok] = 0  # (the docstring's 0 in a refused row, as the Newton path's)
    out.residual = _owned_where(out.ok, residual, every)
    out.iterations = np.zeros(n, int)
    out.solver = SolveMode.CLOSED_FORM
    return out


def _owned_where(ok: np.ndarray, v: Any, every: bool) -> np.ndarray:
    """np.where(ok, v, 0.0); ``v`` itself where every row is ok and it is an (n,) float array
    (an array the caller owns: nothing else holds it)."""
    if every and isinstance(v, np.ndarray) and v.shape == ok.shape and v.dtype == np.float64:
        return v
    return np.where(ok, v, 0.0)


def _fill(
    out: BatchResult,
    c: CompiledSolve,
    pts: dict[str, Any],
    arrays: list[np.ndarray],
    finite: np.ndarray,
    ok: np.ndarray,
    got: Assembly,
    every: bool | None = None,
) -> bool:
    """points, links, joints and inputs of the rows ``ok`` from their assembly (0 elsewhere);
    an inverse solve's actuator beyond its limits turns its row into a failure. ``pts`` (the
    solved points, complex or (n, 2)) is emptied as its points are written. ``every``: ok
    holds in every row (taken from ``ok`` when not given); returns whether out.ok does."""
    if every is None:
        every = bool(np.all(ok))
    taken: set[int] = set()  # arrays handed out as they are: each to one output only
    # each point's (n, 2) array made as its complex form is let go (pts is the caller's own)
    out.points = {}
    for p in list(pts):
        out.points[p] = _points_where(ok, pts.pop(p), every)
    out.links = {l: _where_ok(ok, v, every, taken) for l, v in got.links.items()}
    out.joints = {j: _where_ok(ok, v, every, taken) for j, v in got.joints.items()}
    out.inputs = {a: _where_ok(ok, v, every, taken) for a, v in got.inputs.items()}
    for s, a in zip(c.specs, arrays):
        if s.name in c.mech.actuators:  # a copy: out.values holds the column
            out.inputs[s.name] = a.copy() if every else np.where(ok, a, np.where(finite, a, 0.0))
    if c.inverse:
        bounded = [s for s in c.actuator_specs if s.name in out.inputs and s.bounded]
        suspects = np.zeros(ok.shape, bool)
        for s in bounded:
            suspects |= _limit_suspects(s, out.inputs[s.name])
        for i in np.flatnonzero(ok & suspects).tolist():
            why = needs_beyond_limits((s, float(out.inputs[s.name][i])) for s in bounded)
            if why:
                ok[i] = False
                out.reason[i] = why
                every = False
    out.ok = ok
    return every


#: |limit| (rad) up to which a periodic angle inside [minimum, maximum] as written is inside
#: as limit_violation reads it too (its reduction lo + (v - lo) mod 2 pi then rounds off by a
#: few ulps of this, far below its slack of 1e-12)
_PERIODIC_FAST_LIMIT = 1e3


def _limit_suspects(s: ScalarSpec, a: np.ndarray) -> np.ndarray:
    """The rows of column ``a`` that may break ``s``'s limits: every row limit_violation
    would refuse is among them, so it runs on these rows only (a Python call per row costs
    ~30x the vectorised test)."""
    interval = value_interval(s)
    if interval is not None:  # (not an angle: an interval of values)
        outside: np.ndarray = ~((a >= interval[0]) & (a <= interval[1]))
        return outside
    lo, hi = s.minimum, s.maximum
    if s.periodic and lo is not None and hi is not None:
        if max(abs(lo), abs(hi)) > _PERIODIC_FAST_LIMIT:
            return np.ones(a.shape, bool)
        return ~((a >= lo) & (a <= hi))  # NaN rows too
    # one limit on an angle: limit_violation compares it brought into (-pi, pi], so any row
    # outside (-pi, pi] may break it whatever its written value
    suspect = ~((a > -math.pi) & (a <= math.pi))
    if lo is not None:
        suspect |= a < lo
    if hi is not None:
        suspect |= a > hi
    return suspect


def _newton(
    out: BatchResult,
    c: CompiledSolve,
    cont: Continuity,
    arrays: list[np.ndarray],
    safe: list[np.ndarray],
    valid: np.ndarray,
    start: BatchResult,
) -> None:
    """Vectorised warm-started Newton over independent instances (see solve_batch); the rows
    it cannot vouch for go through solve_one from their start."""
    n, system, plan = out.n, c.system, c.full_plan
    assert start.x is not None and start.det_sign is not None  # checked by _check_start
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
        every = len(eligible) == n  # the common case: no gathers, no scatters
        # start.det_sign is det J's sign at start.x, checked when that batch was solved
        bs = system.solve_batch(
            start.x if every else start.x[eligible],
            safe if every else [a[eligible] for a in safe],
            start.det_sign if every else start.det_sign[eligible],
            tol=c.tol,
            start_checked=True,
            warm=True,  # start.x: solutions at the batch before
        )
        if every and bs.ok.all():  # bs's arrays are its own (not start's)
            x, iterations, residual, det_sign, cond = (
                bs.x,
                bs.iterations,
                bs.residual,
                bs.det_sign,
                bs.cond,
            )
            rows = eligible
        else:
            rows = eligible[bs.ok]
            x[rows], iterations[eligible] = bs.x[bs.ok], bs.iterations
            residual[rows], det_sign[rows], cond[rows] = (
                bs.residual[bs.ok],
                bs.det_sign[bs.ok],
                bs.cond[bs.ok],
            )
        # solve_one checks the closed form can assemble unless the answer is provably on its
        # branch: well conditioned for its residual (Newton-Kantorovich) and the dyads on the
        # start's sides. A row that needs that check (or changed sides) goes there too.
        accepted[rows] = cond[rows] ** 2 * residual[rows] * system.n <= KANTOROVICH_BOUND
    poses, pts = newton_poses(c, x)
    signs = np.zeros((n, k), int)
    if branches:
        # (plan.branch_geometry_of on the complex poses and points of newton_poses)
        with np.errstate(all='ignore'):
            sides, margins = branch_geometry_of(BATCH, plan, pts, poses)
        dyad_margins = np.zeros((n, k))
        for j in range(k):
            signs[:, j], dyad_margins[:, j] = sides[j], margins[j]
        accepted &= np.all(signs == start.signs, axis=1)
        margin = np.min(dyad_margins, axis=1)
    else:
        margin = np.where(accepted, 1.0 / np.maximum(cond, 1.0), 0.0)
    rule = cont.branch.rule
    if rule is BranchRule.EXPLICIT:
        accepted &= np.all(signs == np.asarray(cont.branch.signs, int), axis=1)
    elif rule is BranchRule.REFERENCE and branches:
        accepted &= np.all(signs == np.asarray(plan.reference_signs, int), axis=1)
    with np.errstate(all='ignore'):
        got = assemble_batch(c.assembler(poses.phi), poses, safe)
    _fill(out, c, pts, arrays, valid, accepted.copy(), got)
    residual = np.maximum(residual, got.residual)
    if out.ok.all():  # the common case: the arrays are this call's own, no where passes
        out.x, out.det_sign, out.signs = x, det_sign, signs
        out.margin, out.iterations, out.residual = margin, iterations, residual
    else:
        out.x, out.det_sign = x, np.where(out.ok, det_sign, 0)
        out.signs = np.where(out.ok[:, None], signs, 0)
        out.margin = np.where(out.ok, margin, 0.0)
        out.iterations = np.where(out.ok, iterations, 0)
        out.residual = np.where(out.ok, residual, 0.0)
    out.solver = c.mode
    out.careful = valid & ~accepted
    for i in np.flatnonzero(out.careful).tolist():
        _set_row(out, i, *_careful_row(c, cont, arrays, start, i), int(iterations[i]))


def _careful_row(
    c: CompiledSolve, cont: Continuity, arrays: list[np.ndarray], start: BatchResult, i: int
) -> tuple[Result, Continuity]:
    """Row i by solve_one from row i of ``start`` (its configuration, det J sign and dyad
    sides; the reference pose if that row failed), on a continuity of its own (the caller's
    is not touched); returns the answer and that continuity (its state: the row's x)."""
    row = Continuity(cont.branch)
    if start.ok[i] and start.x is not None and start.det_sign is not None:
        xi = start.x[i]
        poses, pts = c.check_system.configuration(xi)
        vals = [
            np.array(a[i], float) if isinstance(s, PointSpec) else float(a[i])
            for s, a in zip(c.specs, start.values)
        ]
        if c.full_plan.complete:
            signs, margins = branch_geometry_one(c.full_plan, pts, poses)
        else:
            signs, margins = c.plan.reference_signs, ()
        det = int(start.det_sign[i])
        row.history = [state_of(c, vals, poses, pts, signs, det, margins, x_all=xi.copy())]
    return solve_one(c, row, _row_command(c, arrays, i)), row


def _row_command(c: CompiledSolve, arrays: list[np.ndarray], i: int) -> dict[str, Any]:
    return {
        s.name: (arrays[k][i] if isinstance(s, PointSpec) else float(arrays[k][i]))
        for k, s in enumerate(c.specs)
    }


def _set_row(out: BatchResult, i: int, r: Result, row: Continuity, spent: int) -> None:
    """Write one Result into row i (x and det_sign from the row's committed state)."""
    assert out.x is not None and out.det_sign is not None
    out.ok[i], out.reason[i] = r.success, r.reason
    if not r.success:
        out.det_sign[i] = 0
        return
    for table, got in ((out.links, r.links), (out.joints, r.joints), (out.inputs, r.inputs)):
        for name in table:
            table[name][i] = got.get(name, 0.0)
    for p in out.points:
        out.points[p][i] = r.points.get(p, (0.0, 0.0))
    out.margin[i], out.residual[i] = r.margin or 0.0, r.residual or 0.0
    out.iterations[i] = r.iterations + spent
    if out.signs.shape[1] == len(r.branch):
        out.signs[i] = branch_signs(r.branch)
    state = row.last
    if state is not None and state.x_all is not None:
        out.x[i], out.det_sign[i] = state.x_all, state.det_sign


def _sequential(
    out: BatchResult, c: CompiledSolve, cont: Continuity, arrays: list[np.ndarray]
) -> None:
    """The rows as one path, one after another (each committed to ``cont``)."""
    mech, n = c.mech, out.n
    rows: list[Result] = []
    x_rows: dict[int, tuple[np.ndarray | None, int]] = {}
    for i in range(n):
        if out.reason[i] is not None:
            rows.append(Result(False, out.reason[i]))
            continue
        rows.append(solve_one(c, cont, _row_command(c, arrays, i)))
        if rows[-1].success and cont.last is not None:
            x_rows[i] = (cont.last.x_all, cont.last.det_sign)
    out.ok = np.array([r.success for r in rows], bool)
    out.reason = [r.reason for r in rows]
    out.points = {
        p: np.array([r.points.get(p, (0.0, 0.0)) for r in rows]).reshape(n, 2) for p in mech.points
    }
    out.links = {l: np.array([r.links.get(l, 0.0) for r in rows]) for l in mech.links}
    out.joints = {j: np.array([r.joints.get(j, 0.0) for r in rows]) for j in mech.joint_names}
    out.inputs = {a: np.array([r.inputs.get(a, 0.0) for r in rows]) for a in mech.actuators}
    out.margin = np.array([r.margin or 0.0 for r in rows])
    out.residual = np.array([r.residual or 0.0 for r in rows])
    out.iterations = np.array([r.iterations for r in rows])
    out.signs = np.zeros((n, 0), int)
    out.solver = c.mode
    out.rows = rows
    if c.mode is SolveMode.NEWTON:  # what a later batch of these rows may start from
        out.x, out.det_sign = np.zeros((n, c.system.n)), np.zeros(n, int)
        for i in np.flatnonzero(out.ok).tolist():
            x_i, det = x_rows[i]
            if x_i is not None:
                out.x[i], out.det_sign[i] = x_i, det
        k = len(c.full_plan.branch_steps) if c.full_plan.complete else 0
        out.signs = np.array(
            [branch_signs(r.branch) if r.success and len(r.branch) == k else [0] * k for r in rows],
            int,
        ).reshape(n, k)


def _where_ok(ok: np.ndarray, v: Any, every: bool, taken: set[int]) -> np.ndarray:
    """np.where(ok, v, 0.0); ``v`` itself where every row is ok and it is an (n,) float array
    of the assembly's not handed out yet (``taken``: the ids handed out; a cylinder's throw is
    both an input and a joint value, and the two must not share one array)."""
    if (
        every
        and isinstance(v, np.ndarray)
        and v.shape == ok.shape
        and v.dtype == np.float64
        and id(v) not in taken
    ):
        taken.add(id(v))
        return v
    return np.where(ok, v, 0.0)


def _points_where(ok: np.ndarray, z: Any, every: bool) -> np.ndarray:
    """Batched points (complex, or (n, 2) coordinates) as (n, 2) coordinates where ``ok``,
    0 elsewhere (``every``: ok in every row)."""
    if isinstance(z, np.ndarray):
        return np.where(ok[:, None], z, 0.0)
    xy = np.empty((ok.shape[0], 2)) if every else np.zeros((ok.shape[0], 2))
    if every:
        xy[:, 0], xy[:, 1] = z.real, z.imag
    else:
        np.copyto(xy[:, 0], z.real, where=ok)
        np.copyto(xy[:, 1], z.imag, where=ok)
    return xy


def _assembly_poses(plan: Plan, poses: LinkPoses) -> LinkPoses:
    """The executor's batched poses as the assembly reads them: each link's rot as
    e^{i phi} of its own angle. A member of a body welded by a known angle has for rot a
    product of its body's rotations there, which rounds differently: it is made again. Not
    in the ground's body, placed at rest (its members keep e^{i phi} of their frame angles),
    nor in a body welded by slides only (each member's rot is the body's times exactly 1: the
    body's own, to the bit; see PlanExecutor)."""
    at_rest = {st.body for st in plan.steps if st.op is StepKind.GROUND}
    welded = {
        l
        for b in plan.bodies
        if b.index not in at_rest
        and any(isinstance(plan.specs[w.spec_index], AngleSpec) for w in b.welds)
        for l in b.links
    }
    if not welded:
        return poses
    rot = {l: (expi_rows(poses.phi[l]) if l in welded else r) for l, r in poses.rot.items()}
    return LinkPoses(poses.phi, rot, poses.T)


def _columns(c: CompiledSolve, columns: Mapping[str, Any]) -> tuple[list[np.ndarray], int]:
    """The command columns as float arrays in spec order, and their row count."""
    unknown = [k for k in columns if k not in c.knowns]
    missing = [k for k in c.knowns if k not in columns]
    if unknown or missing:
        raise ValueError(
            f'batch columns must be exactly {list(c.knowns)}'
            f'{"; unknown " + str(unknown) if unknown else ""}'
            f'{"; missing " + str(missing) if missing else ""}'
        )
    if c.point_pairs:
        columns = pair_columns(columns, c.point_pairs, c.pair_tolerance_m)
    arrays: list[np.ndarray] = []
    n: int | None = None
    for s in c.specs:
        a = _batch_column(s, columns[s.name])
        if n is None:
            n = a.shape[0]
        elif a.shape[0] != n:
            raise ValueError(f'batch column {s.name!r} has {a.shape[0]} rows, expected {n}')
        arrays.append(a)
    return arrays, n or 0


def _check_start(c: CompiledSolve, start: BatchResult, n: int, source: tuple[Any, ...]) -> None:
    """ValueError unless ``start`` is a newton batch of this solve (its batch_source:
    ``source``) with n rows."""
    if c.mode is not SolveMode.NEWTON:
        raise ValueError(f'start= warm-starts newton batches; this solver is {c.mode}')
    if not isinstance(start, BatchResult) or start.x is None:
        raise ValueError(
            'start must be a newton BatchResult of this solver (a closed-form '
            'batch carries no Newton state)'
        )
    if start.n != n:
        raise ValueError(
            f'start has {start.n} rows but this batch has {n}: row i starts from row i'
        )
    theirs = start.source
    if theirs != source:
        what = f'{theirs[0]!r} with knowns {list(theirs[1])}' if theirs else 'unknown'
        raise ValueError(
            'start must be a newton BatchResult of a solver of this '
            f'mechanism ({c.mech.name!r}, its reference geometry) with '
            f'knowns {list(c.knowns)}; got one of {what}'
        )
    if not (
        isinstance(start.x, np.ndarray)
        and start.x.shape == (start.n, c.system.n)
        and isinstance(start.det_sign, np.ndarray)
        and start.det_sign.shape == (start.n,)
        and np.shape(start.ok) == (start.n,)
    ):
        raise ValueError(
            'start is not a newton BatchResult as solve_batch made it (its '
            'x, det_sign or ok arrays have the wrong shape)'
        )


def batch_source(c: CompiledSolve) -> tuple[Any, ...]:
    """What a newton batch's x means (the mechanism, its reference geometry, the knowns and
    the Newton unknowns): start= takes only batches of the same."""
    return (
        c.mech.name,
        tuple(c.knowns),
        tuple(c.system.free),
        tuple((p, float(v[0]), float(v[1])) for p, v in c.mech.points.items()),
    )


def _batch_column(s: Spec, v: Any) -> np.ndarray:
    """One command column as floats, (n,) or (n, 2) for a point; ValueError naming the
    column for anything but real numbers (bool, str, complex and object columns too)."""
    a = np.asarray(v)
    if a.dtype.kind not in 'iuf':
        raise ValueError(
            f'batch column {s.name!r} must hold real numbers ({s.unit}), got an array of {a.dtype}'
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
