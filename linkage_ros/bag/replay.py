"""Replay of the commands in bag order with the node's semantics, vectorised where provably
identical."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from ..core.errors import CommandError
from ..core.ops import BATCH, to_complex
from ..core.plan import step_geometry
from ..core.quantities import PointSpec
from ..core.solver import Solver, branch_identity_defined
from ..core.solver.continuity import MAX_STEP_RATIO
from ..core.solver.result import branch_signs, branch_text
from ..core.steps import RPRDyad, RRPDyad, RRRDyad, anchor_of
from ..core.velocity import velocities
from ..engine import (
    SOLVER_CACHE,
    Engine,
    EngineSettings,
    max_request_names,
    request_shape_error,
)
from ..point_coordinates import group_point_coordinates
from ..stamps import stamp_error, stamp_valid
from .history import _Context, _Entry
from .plans import PlanRequest, answer_plan
from .progress import _Progress
from .rates import RunRates, run_rates, stretches
from .reading import Commands
from .results import Results


class _Engine:
    """Solves the commands in order with the node's semantics, on the node's own session
    (linkage_ros.engine.Engine: its forward solver, its solver per set of target names, its
    last good state that a solver adopts when another one has succeeded since it last ran,
    the reference pose as the first good state); what this adds is the vectorised replay."""

    def __init__(self, mech, method, tol, max_iter, branch, hold=()):
        self.mech, self.branch = mech, branch
        self.max_names = max_request_names(mech)
        # the command solver exists from the start (a bad --solver/--branch fails here)
        self.engine = Engine(mech, EngineSettings(method, tol, max_iter, branch, tuple(hold)))
        self.forward = _Context(self.engine, self.engine.forward)
        self._contexts: dict[frozenset, _Context] = {}
        ref = self.engine.last
        if ref is not None:
            reference = self.engine.forward.reference_values()
            self.forward.hist = [
                _Entry('solve', cmd=reference, signs=branch_signs(ref.branch), result=ref)
            ]

    def context_for(self, names) -> _Context | str:
        """The engine's solver for these names (with its replay history), or why not."""
        solver = self.engine.solver_for(names)
        if isinstance(solver, str):
            return solver
        if solver is self.engine.forward:
            return self.forward
        key = frozenset(names)
        ctx = self._contexts.get(key)
        if ctx is None or ctx.solver is not solver:  # new, or rebuilt after the LRU dropped it
            ctx = self._contexts[key] = _Context(self.engine, solver)
            if len(self._contexts) > 2 * SOLVER_CACHE:  # forget the dropped solvers' histories
                live = {id(v) for v in self.engine._solvers.values()}
                self._contexts = {k: c for k, c in self._contexts.items() if id(c.solver) in live}
        return ctx

    # -- driver ----------------------------------------------------------------------------------
    def solve_all(
        self,
        data: Commands,
        progress: _Progress | None = None,
        plans: Sequence[PlanRequest] = (),
        frame_id: str = '',
        decoded: Iterable[PlanRequest] | None = None,
        on_plan: Callable[[PlanRequest], None] | None = None,
    ) -> Results:
        """Every command in order; ``plans`` (recorded trajectories and paths, in bag time
        order) are answered at their place among them, from the state the commands before
        them left (bag.plans.answer_plan). ``decoded`` gives the same plans one at a time with
        their messages (bag.plans.decoded_plans; default: ``plans``, decoded already). Each
        answered plan goes to ``on_plan`` (the outputs), which leaves it only its outcome:
        one plan's message and answer are held at a time."""
        progress = progress or _Progress(False)
        n = data.n
        self.res = res = Results.empty(self.mech, n)
        self.progress = progress
        self.done = 0
        progress.start('solving', n)
        # a plan comes after every command received at or before its own receive time
        cuts = np.searchsorted(data.log_ns, [p.log_ns for p in plans], side='right').tolist()
        pending = list(zip(cuts, plans))
        stream = iter(plans if decoded is None else decoded)

        def plans_up_to(row: int) -> None:
            while pending and pending[0][0] <= row:
                # the solvers get the node's continuity history first (the replay keeps it as
                # entries); the plan leaves the engine's state as it found it
                for ctx in (self.forward, *self._contexts.values()):
                    ctx.sync()
                req = next(stream)
                assert req is pending.pop(0)[1]  # the same plans in the same order
                answer_plan(self.engine, req, frame_id)
                if on_plan is not None:
                    on_plan(req)
                    req.shed()

        plans_up_to(0)
        if n:
            # the node refuses a request whose stamp it cannot echo (negative, nanosec >= 1e9)
            self.bad_stamp = ~stamp_valid(data.sec, data.nanosec)
            breaks = (
                (data.topic[1:] != data.topic[:-1])
                | (data.key[1:] != data.key[:-1])
                | (self.bad_stamp[1:] != self.bad_stamp[:-1])
            )
            change = np.union1d(np.flatnonzero(breaks) + 1, [c for c in cuts if 0 < c < n])
            starts = np.concatenate([[0], change]).astype(int)
            ends = np.concatenate([change, [n]]).astype(int)
            for a, b in zip(starts.tolist(), ends.tolist()):
                self._run(data, a, b)
                self.done = b
                progress.update(b)
                plans_up_to(b)
        plans_up_to(n)
        progress.finish()
        return res

    def _refuse_all(self, a, b, reason):
        """Rows a..b-1 refused, but for rows refused already (the node's first reason holds:
        a bad velocity count is found before the names are looked at)."""
        for g in range(a, b):
            if self.res.reason[g] is None:
                self.res.reason[g] = reason

    def _run(self, data: Commands, a: int, b: int):
        """Rows a..b-1: one topic, one message shape (the same names in the same order), all
        with valid stamps or all not."""
        if self.bad_stamp[a]:  # node.py _answer: refused before solving
            for g in range(a, b):
                self.res.reason[g] = stamp_error(int(data.sec[g]), int(data.nanosec[g]))
            return
        k = int(data.key[a])
        names, npos = list(data.keys[k]), data.npos[k]
        why = request_shape_error(names, npos, self.max_names)
        if why:  # conversions.joint_state_to_command
            self._refuse_all(a, b, why)
            return
        # a command's velocities (conversions.joint_state_rates; a target's are not read)
        rates, refused = run_rates(data, a, b, names) if int(data.topic[a]) == 0 else (None, {})
        for i, why in refused.items():
            self.res.reason[a + i] = why
        vals = data.positions(a, b)
        columns = {nm: vals[:, j] for j, nm in enumerate(names)}
        coords = self.engine.mech.joint_coordinates
        if coords is not None:  # the description's names and values, as the engine takes them
            try:
                columns = coords.to_scene(columns, command=int(data.topic[a]) == 0)
                if rates is not None:
                    rates = rates.in_scene(coords)
            except CommandError as exc:
                self._refuse_all(a, b, str(exc))
                return
            names = list(columns)
        held: tuple[str, ...] | str = ()
        if int(data.topic[a]) == 0:  # Engine.command: a partial command holds the others
            # the run's held values: its rows hold the same actuators at the same last values
            full, held = self.engine.held_values({nm: 0.0 for nm in names})
            if isinstance(held, str):
                self._refuse_all(a, b, held)
                return
            if held:
                columns.update({h: np.full(b - a, full[h]) for h in held})
                if rates is not None:
                    rates = rates.holding(held)
                self.res.held_code[a:b] = self.res.held_code_of(', '.join(held))
                names = list(self.forward.knowns)
        for nm, col in columns.items():
            if nm in self.res.inputs:
                self.res.inputs[nm][a:b] = col
                self.res.input_given[nm][a:b] = nm not in held
        if rates is not None:  # Engine.command refuses a rate that is not finite before solving
            refused.update(rates.refusals())
        if not refused:
            self._answer_run(columns, int(data.topic[a]), a, b, rates)
            return
        for i, why in refused.items():
            self.res.reason[a + i] = why
        skip = np.zeros(b - a, bool)
        skip[list(refused)] = True
        for i0, i1 in stretches(skip):  # the rows between are solved as a run
            self._answer_run(
                {nm: c[i0:i1] for nm, c in columns.items()},
                0,
                a + i0,
                a + i1,
                None if rates is None else rates.rows(i0, i1),
            )

    def _answer_run(self, columns, topic: int, a: int, b: int, rates: RunRates | None) -> None:
        """Rows a..b-1 (``columns``, and a command's ``rates``, indexed from a) in the
        scene's names: the engine's solver for them, then in a batch or one by one."""
        names = list(columns)
        if topic == 1:  # Engine.target: <point>.x, <point>.y make a point
            try:
                columns = group_point_coordinates(self.engine.mech, columns)
            except CommandError as exc:
                self._refuse_all(a, b, str(exc))
                return
            names = list(columns)
        ctx = self.forward if topic == 0 else self.context_for(names)
        if isinstance(ctx, str):  # no solver for these target names
            self._refuse_all(a, b, ctx)
            return
        S = ctx.solver
        # the engine's solve: adopt the last good state if another solver moved on
        if self.engine.bring_up_to_date(S):
            ctx.hist = [_Entry('adopt', result=self.engine.last, signs=_adopted_signs(S))]
            ctx.synced = True
        if set(columns) != set(ctx.knowns):
            # wrong names: the solver's own message (it depends on the names only)
            r = S.solve(_command(columns, 0), commit=False)
            self._refuse_all(a, b, r.reason)
            return
        if topic == 1:  # targets: the engine's assembly-mode rule, one by one
            self._targets(ctx, columns, a, b)
        elif S.mode == 'closed_form' and b - a >= MIN_BATCH:
            self._vectorised(ctx, columns, a, b, rates)
        else:
            self._sequential(ctx, columns, a, b, 0, b - a, rates)

    def _targets(self, ctx: _Context, columns, a, b):
        """Target rows as the node answers ~/target: Engine.solve_target (a solution in the
        current assembly mode, else refused), which commits a success by adoption."""
        ctx.sync()
        S = ctx.solver
        for i in range(b - a):
            r = self.engine.solve_target(S, _command(columns, i))
            self._store(a + i, r)
            if r.success:
                ctx.hist = [_Entry('adopt', result=r, signs=_adopted_signs(S))]
                ctx.synced = True
            if not i & 0xFF:
                self.progress.update(self.done + i)
        self.res.sequential += b - a

    # -- one by one ------------------------------------------------------------------------------
    def _sequential(self, ctx: _Context, columns, a, b, i0, i1, rates: RunRates | None = None):
        ctx.sync()
        S = ctx.solver
        for i in range(i0, i1):
            cmd = _command(columns, i)
            r = S.solve(cmd)
            self._store(a + i, r)
            if r.success:
                ctx.push(_Entry('solve', cmd=cmd, signs=branch_signs(r.branch), result=r))
                rate = None if rates is None else rates.row(i)
                if rate is not None:  # Engine.command: the answer's velocity
                    self.res.store_velocity(a + i, velocities(S, r, cmd, rate))
            if not i & 0xFF:
                self.progress.update(self.done + i)
        self.res.sequential += i1 - i0

    def _store(self, g, r):
        res = self.res
        if not r.success:
            res.reason[g] = r.reason
            for nm, v in r.inputs.items():
                if nm in res.inputs:
                    res.inputs[nm][g] = v
            return
        res.ok[g] = True
        res.residual[g] = r.residual
        res.margin[g] = r.margin if r.margin is not None else np.nan
        res.branch_code[g] = res.branch_code_of(r.branch)
        res.branch_defined[g] = r.branch_defined
        res.iterations[g] = r.iterations
        res.cond[g] = r.cond if r.cond is not None else np.nan
        res.solver_code[g] = res.solver_code_of(r.solver)
        for nm, v in r.inputs.items():
            if nm in res.inputs:
                res.inputs[nm][g] = v
        for nm, v in r.joints.items():
            res.joints[nm][g] = v
        for nm, v in r.points.items():
            res.points[nm][g] = v

    # -- vectorised ------------------------------------------------------------------------------
    def _vectorised(self, ctx: _Context, columns, a, b, rates: RunRates | None):
        S = ctx.solver
        m = b - a
        continuous = (
            S.branch_mode == 'continuous'
            if hasattr(S, 'branch_mode')
            else self.branch == 'continuous'
        )
        pos = 0
        chunk = CHUNK_START
        stretch = SEQUENTIAL_STRETCH // 2
        while pos < m:
            if continuous and not ctx.hist:
                # the very first configuration: the reference assembly mode, no prediction
                self._sequential(ctx, columns, a, b, pos, pos + 1, rates)
                pos += 1
                continue
            end = min(m, pos + chunk)
            cols = {nm: c[pos:end] for nm, c in columns.items()}
            if continuous:
                signs0 = ctx.hist[-1].signs
                solver = ctx.explicit(signs0)
            else:
                solver = S
                signs0 = None
            B: Any = solver.solve_batch(cols)  # BatchResult: its arrays are set, not declared
            take = self._easy_prefix(ctx, solver, B, cols, end - pos) if continuous else end - pos
            # next to a tangency the batched and single dyad formulas may disagree on closing
            near = np.flatnonzero(
                np.asarray(B.ok[:take]) & (np.asarray(B.margin[:take]) < NEAR_TANGENT)
            )
            if near.size:
                take = int(near[0])
            if take:
                take = self._accept(ctx, solver, B, cols, a + pos, take)
                if take and rates is not None:
                    self._batch_rates(ctx, B, cols, rates, a, pos, take)
                pos += take
            if pos < end:
                # a row the batch cannot vouch for: one by one for a while; when batches keep
                # breaking at once (jumpy commands), back off to longer one-by-one stretches
                stretch = SEQUENTIAL_STRETCH if take >= 64 else min(2 * stretch, 4096)
                stop = min(m, pos + stretch)
                self._sequential(ctx, columns, a, b, pos, stop, rates)
                pos = stop
                chunk = max(CHUNK_MIN, min(chunk, 4 * take))
            else:
                stretch = SEQUENTIAL_STRETCH // 2
                chunk = min(CHUNK_MAX, chunk * 4)
            self.progress.update(self.done + pos)

    def _accept(self, ctx, solver, B, cols, g0, take) -> int:
        """Copy the first ``take`` batch rows into the results; returns how many were taken
        (fewer if a single solve accepts a command the batch refused: from there on the rows
        go one by one)."""
        res = self.res
        # refused rows: the node's exact reason (the same solve, with the same branch choices)
        reasons = {}
        cache: dict[bytes, str] = {}
        finite = _finite_rows({nm: c[:take] for nm, c in cols.items()}, take)
        for i in np.flatnonzero(~B.ok[:take]).tolist():
            keyb = None
            if not finite[i]:
                keyb = b''.join(np.asarray(c[i], float).tobytes() for c in cols.values())
                if keyb in cache:
                    reasons[i] = cache[keyb]
                    continue
            r = solver.solve(_command(cols, i), commit=False)
            if r.success:  # a tangency the batch refused: leave it to Solver
                take = i
                break
            reasons[i] = r.reason
            if keyb is not None:
                cache[keyb] = r.reason
        if not take:
            return 0
        sl = slice(g0, g0 + take)
        ok = B.ok[:take]
        okr = np.flatnonzero(ok)
        for i, why in reasons.items():
            if i < take:
                res.reason[g0 + i] = why
        res.ok[sl] = ok
        res.residual[sl] = np.where(ok, B.residual[:take], np.nan)
        res.margin[sl] = np.where(ok, B.margin[:take], np.nan)
        res.iterations[sl] = 0
        nsg = B.signs.shape[1]
        if nsg:
            res.branch_defined[sl] = np.where(
                ok, branch_identity_defined(B.margin[:take], B.residual[:take]), True
            )
            sg = np.asarray(B.signs[:take]) > 0
            keyv = sg.astype(np.int64) @ (np.int64(1) << np.arange(nsg, dtype=np.int64))
            uniq, first, inv = np.unique(keyv, return_index=True, return_inverse=True)
            table = np.array(
                [res.branch_code_of(branch_text(np.where(sg[f], 1, -1))) for f in first.tolist()],
                np.int32,
            )
            res.branch_code[sl] = np.where(ok, table[inv.reshape(-1)], 0)
        else:
            res.branch_code[sl] = np.where(ok, res.branch_code_of(''), 0)
        res.solver_code[sl] = np.where(ok, res.solver_code_of(B.solver), 0)
        for nm, arr in B.inputs.items():
            if nm in res.inputs:
                res.inputs[nm][sl] = np.where(ok, arr[:take], res.inputs[nm][sl])
        for nm, arr in B.joints.items():
            res.joints[nm][sl] = np.where(ok, arr[:take], np.nan)
        for nm, arr in B.points.items():
            if nm in res.points:
                res.points[nm][sl] = np.where(ok[:, None], arr[:take], np.nan)
        # the last two successes become the node's history
        if okr.size:
            self.engine.version += okr.size - min(okr.size, 2)
            for i in okr[-2:].tolist():
                ctx.push(
                    _Entry(
                        'solve',
                        cmd=_command(cols, i),
                        signs=tuple(B.signs[i]),
                        batch=B,
                        i=i,
                        solver=solver,
                    )
                )
            ctx.synced = False
        res.batched += take
        return take

    def _batch_rates(self, ctx: _Context, B, cols, rates: RunRates, a, pos, take) -> None:
        """The velocities of the batch rows just taken (rows pos.. of the run starting at a)
        whose commands gave some, each from its row's solution as Engine.command gives them:
        core.velocity on the engine's solver (positions stay vectorised; rated rows pay for
        this one by one)."""
        rated = np.asarray(B.ok[:take], bool) & rates.given[pos : pos + take]
        for i in np.flatnonzero(rated).tolist():
            rate = rates.row(pos + i)
            assert rate is not None  # a rated row
            self.res.store_velocity(
                a + pos + i, velocities(ctx.solver, B.row(i), _command(cols, i), rate)
            )

    def _easy_prefix(self, ctx: _Context, solver: Solver, B, cols, m) -> int:
        """How many leading batch rows the node's continuity rule provably solves the same way."""
        plan = solver.plan
        bsteps = plan.branch_steps
        if not bsteps:
            return m
        mech = self.mech
        signs0 = list(ctx.hist[-1].signs)
        finite = _finite_rows(cols, m)
        safe = []
        for s in solver.specs:
            v = np.asarray(cols[s.name], float)
            v = v.reshape(m, 2) if isinstance(s, PointSpec) else v.reshape(m)
            safe.append(np.where(np.isfinite(v), v, 0.0))
        okb = np.asarray(B.ok[:m], bool)
        okr = np.flatnonzero(okb)
        step_index = {id(st): k for k, st in enumerate(plan.steps)}
        # the configuration the batch chose (signs0) at each branching step: the batch rows,
        # plus a run for refused rows that still reach some branching step
        reached = {k: okb.copy() for k in range(len(bsteps))}
        names, guides = _step_inputs(mech, bsteps)
        rowpts = {p: np.array(B.points[p][:m], float) for p in names}
        rowphi = {g: np.asarray(B.links[g][:m], float) - mech.links[g].angle_ref for g in guides}
        fin_fail = np.flatnonzero(~okb & finite)
        if fin_fail.size:
            poses_f, pts_f, info_f = plan.run([v[fin_fail] for v in safe], fin_fail.size, signs0)
            for k, st in enumerate(bsteps):
                reached[k][fin_fail] = info_f['ok'] | (info_f['failure'] > step_index[id(st)])
            for p in names:
                if p in pts_f:
                    rowpts[p][fin_fail] = pts_f[p]
            for g in guides:
                if g in poses_f.phi:
                    rowphi[g][fin_fail] = poses_f.phi[g]
        # the previous good configurations of every row: the history, then the batch's ok rows
        seqpts = {
            p: np.concatenate(
                [np.array([e.point(p) for e in ctx.hist]).reshape(-1, 2), rowpts[p][okr]]
            )
            for p in names
        }
        seqphi = {
            g: np.concatenate(
                [np.array([e.link(g) - mech.links[g].angle_ref for e in ctx.hist]), rowphi[g][okr]]
            )
            for g in guides
        }
        nh = len(ctx.hist)
        last_idx = nh + (np.cumsum(okb) - okb) - 1  # into hist + ok batch rows
        prev_idx = last_idx - 1
        has_last = last_idx >= 0
        has_prev = prev_idx >= 0
        li = np.maximum(last_idx, 0)
        pi = np.maximum(prev_idx, 0)
        eps = EASY_MARGIN * mech.length_scale
        gate = _continuity_margin()
        easy = np.ones(m, bool)
        for k, st in enumerate(bsteps):
            need = reached[k] & has_last
            if not np.any(need):
                continue
            if gate is not None:
                # the node keeps the previous sign where the dyad is clear of its singularity
                # now and in the previous configuration (core.plan.CONTINUITY_MARGIN)
                m_now = _step_margin(mech, st, rowpts, rowphi)
                m_seq = _step_margin(mech, st, seqpts, seqphi)
                keep = (m_now > gate + 1e-9) & (m_seq[li] > gate + 1e-9)
                need &= ~keep
                if not np.any(need):
                    continue
            flipped = list(signs0)
            flipped[k] = -flipped[k]
            poses1, pts1, _ = plan.run(safe, m, flipped)
            if isinstance(st.args, RPRDyad):
                gl = mech.prismatics[st.args.joint].guide
                phs = rowphi[gl]
                last = seqphi[gl][li]
                ds = np.abs(BATCH.wrap(phs - last))
                do = np.abs(BATCH.wrap(poses1.phi[gl] - last))
                good = do - ds > EASY_MARGIN
            else:
                x = st.point
                assert x is not None  # an RRR / RRP step places its point
                xs, xo = rowpts[x], pts1[x]
                L, P = seqpts[x][li], seqpts[x][pi]
                good = _dist(xo, L) - _dist(xs, L) > eps
                T = L + MAX_STEP_RATIO * (L - P)  # as far as continuity extrapolates
                good &= ~has_prev | (_dist(xo, T) - _dist(xs, T) > eps)
            easy &= ~need | good
        easy |= ~finite
        # refused on an input limit: the node checks limits before any branch choice
        limited = [
            (k, s)
            for k, s in enumerate(solver.specs)
            if not isinstance(s, PointSpec) and (s.minimum is not None or s.maximum is not None)
        ]
        if limited:
            for i in np.flatnonzero(~easy & ~okb).tolist():
                if any(solver.limit_violation(s, float(safe[k][i])) for k, s in limited):
                    easy[i] = True
        bad = np.flatnonzero(~easy)
        return int(bad[0]) if bad.size else m


def _continuity_margin() -> float | None:
    """The dyad margin above which the core's continuity keeps the previous branch sign."""
    try:
        from ..core.execute import CONTINUITY_MARGIN

        return float(CONTINUITY_MARGIN)
    except ImportError:
        return None


def _step_inputs(mech, bsteps):
    """The points and guide links whose positions decide each branching step."""
    names, guides = [], []
    for st in bsteps:
        pts = [st.point, anchor_of(st.args)]
        if isinstance(st.args, RRRDyad):
            pts.append(st.args.centre_b)
        names += [p for p in pts if p not in names]
        if isinstance(st.args, RRPDyad | RPRDyad):
            g = mech.prismatics[st.args.joint].guide
            if g not in guides:
                guides.append(g)
    return names, guides


def _step_margin(mech, st, pts, phi) -> np.ndarray:
    """Margin of one branching dyad over rows ((n, 2) points, guide angles phi): the core's
    step_geometry, as a Newton solution's branch is read."""
    zs = {p: to_complex(v) for p, v in pts.items()}
    rot = {g: BATCH.expi(a) for g, a in phi.items()}
    with np.errstate(all='ignore'):
        return np.asarray(step_geometry(BATCH, mech, st, zs, rot)[1], float)


def _command(columns, i) -> dict:
    out = {}
    for nm, c in columns.items():
        v = c[i]
        out[nm] = (float(v[0]), float(v[1])) if np.ndim(v) else float(v)
    return out


def _finite_rows(cols, m) -> np.ndarray:
    f = np.ones(m, bool)
    for c in cols.values():
        f &= np.all(np.isfinite(np.asarray(c, float).reshape(m, -1)), axis=1)
    return f


def _adopted_signs(S: Solver) -> tuple[int, ...]:
    """The branch signs a solver holds after adopt() (its plan's signs of that pose)."""
    return S.current_signs


def _dist(a, b):
    d = a - b
    return np.hypot(d[:, 0], d[:, 1])


def solve_commands(
    mech, data: Commands, method=None, tol=1e-12, max_iter=50, branch='continuous'
) -> Results:
    """Solve decoded commands in order as the node would (library entry point)."""
    return _Engine(mech, method, tol, max_iter, branch).solve_all(data)


CHUNK_MIN, CHUNK_START, CHUNK_MAX = 256, 8192, 65536


SEQUENTIAL_STRETCH = 16


EASY_MARGIN = 1e-9


MIN_BATCH = 32


NEAR_TANGENT = 1e-6
