"""Replay of the commands in bag order with the node's semantics, vectorised where provably
identical."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..core.errors import CommandError
from ..core.solver import SolveMode, Solver
from ..core.solver.continuity import BranchRule
from ..core.solver.result import branch_signs
from ..core.tolerances import NEWTON_TOL
from ..core.velocity import velocities
from ..engine import SOLVER_CACHE, Engine, EngineSettings
from ..point_coordinates import group_point_coordinates
from ..request_checks import max_request_names, request_shape_error
from ..stamps import names_frame_error, stamp_error, stamp_valid
from .easy_rows import easy_prefix
from .history import EntryKind, HistoryEntry, SolverContext
from .plans import PlanRequest, answer_plan
from .progress import Progress
from .rates import RunRates, run_rates, stretches
from .reading import Commands
from .results import Results
from .rows import command_row, finite_rows


def _solved_rows(columns: Mapping[str, Any], i0: int, i1: int) -> int:
    """How many of rows i0..i1 reach a solve: those whose values are all finite (a NaN row is
    refused as it stands, before any solve: the summary counts it so)."""
    return int(np.count_nonzero(finite_rows({n: c[i0:i1] for n, c in columns.items()}, i1 - i0)))


class ReplayEngine:
    """Solves the commands in order with the node's semantics, on the node's own session
    (linkage_ros.engine.Engine: its forward solver, its solver per set of target names, its
    last good state that a solver adopts when another one has succeeded since it last ran,
    the reference pose as the first good state); what this adds is the vectorised replay."""

    def __init__(self, mech, method, tol, max_iter, branch, hold=()):
        self.mech, self.branch = mech, branch
        #: the node's frame_id in the run recorded (solve_all's; '': not known, a recorded
        #: target's frame is not checked)
        self.frame_id = ''
        self.max_names = max_request_names(mech)
        # the command solver exists from the start (a bad --solver/--branch fails here)
        self.engine = Engine(mech, EngineSettings(method, tol, max_iter, branch, tuple(hold)))
        self.forward = SolverContext(self.engine, self.engine.forward)
        self._contexts: dict[frozenset, SolverContext] = {}
        ref = self.engine.last
        if ref is not None:
            reference = self.engine.forward.reference_values()
            self.forward.hist = [
                HistoryEntry(
                    EntryKind.SOLVE, cmd=reference, signs=branch_signs(ref.branch), result=ref
                )
            ]

    def context_for(self, names) -> SolverContext | str:
        """The engine's solver for these names (with its replay history), or why not."""
        solver = self.engine.solver_for(names)
        if isinstance(solver, str):
            return solver
        if solver is self.engine.forward:
            return self.forward
        key = frozenset(names)
        ctx = self._contexts.get(key)
        if ctx is None or ctx.solver is not solver:  # new, or rebuilt after the LRU dropped it
            ctx = self._contexts[key] = SolverContext(self.engine, solver)
            if len(self._contexts) > 2 * SOLVER_CACHE:  # forget the dropped solvers' histories
                live = {id(v) for v in self.engine.cached_solvers()}
                self._contexts = {k: c for k, c in self._contexts.items() if id(c.solver) in live}
        return ctx

    # -- driver ----------------------------------------------------------------------------------
    def solve_all(
        self,
        data: Commands,
        progress: Progress | None = None,
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
        one plan's message and answer are held at a time. ``frame_id``: the node's, which a
        recorded target of point coordinates or link angles must be in (or have none), as the
        node refuses it otherwise ('': not checked)."""
        progress = progress or Progress(False)
        self.frame_id = frame_id
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
                if req is not pending.pop(0)[1]:
                    raise ValueError('decoded must give the plans, in their order')
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
        if int(data.topic[a]) != 0 and self.frame_id:  # node_requests.on_target: no tf
            why = names_frame_error('target', self.mech, names, data.frame(k), self.frame_id)
            if why:
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
            # (Engine.command / target: a value beyond its joint's <limit> as given)
            for i, why in coords.rows_beyond_limits(columns).items():
                refused.setdefault(i, why)
            try:
                columns = coords.to_scene(columns, command=int(data.topic[a]) == 0)
                if rates is not None:
                    rates = rates.in_scene(coords)
            except CommandError as exc:
                self._refuse_all(a, b, str(exc))
                return
            names = list(columns)
        held: tuple[str, ...] | str = ()
        if int(data.topic[a]) == 0:  # Engine.command: a joint, link or point is ~/target's
            misplaced = self.engine.not_actuators({nm: 0.0 for nm in names})
            if misplaced is not None:
                self._refuse_all(a, b, misplaced)
                return
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
            for i, why in rates.refusals().items():
                refused.setdefault(i, why)
        if not refused:
            self._answer_run(
                columns, int(data.topic[a]), a, b, rates, data.requests[int(data.topic[a])]
            )
            return
        for i, why in refused.items():
            self.res.reason[a + i] = why
        skip = np.zeros(b - a, bool)
        skip[list(refused)] = True
        for i0, i1 in stretches(skip):  # the rows between are solved as a run
            self._answer_run(
                {nm: c[i0:i1] for nm, c in columns.items()},
                int(data.topic[a]),
                a + i0,
                a + i1,
                None if rates is None else rates.rows(i0, i1),
                data.requests[int(data.topic[a])],
            )

    def _answer_run(
        self, columns, topic: int, a: int, b: int, rates: RunRates | None, request: str
    ) -> None:
        """Rows a..b-1 (``columns``, and a command's ``rates``, indexed from a) in the
        scene's names: the engine's solver for them, then in a batch or one by one.
        ``request``: what the topic carries (Commands.requests)."""
        names = list(columns)
        if topic != 0:  # Engine.target: <point>.x, <point>.y make a point
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
            ctx.hist = [
                HistoryEntry(EntryKind.ADOPT, result=self.engine.last, signs=_adopted_signs(S))
            ]
            ctx.synced = True
        if set(columns) != set(ctx.knowns):
            # wrong names: the solver's own message (it depends on the names only)
            r = S.solve(command_row(columns, 0), commit=False)
            self._refuse_all(a, b, r.reason)
            return
        if topic != 0:  # targets: the engine's assembly-mode rule, one by one
            self._targets(ctx, columns, a, b, request == 'target_any_mode')
        elif S.mode is SolveMode.CLOSED_FORM and b - a >= MIN_BATCH:
            self._vectorised(ctx, columns, a, b, rates)
        else:
            self._sequential(ctx, columns, a, b, 0, b - a, rates)

    def _targets(self, ctx: SolverContext, columns, a, b, any_mode: bool = False):
        """Target rows as the node answers ~/target (``any_mode``: ~/target_any_mode):
        Engine.solve_target (a solution in the current assembly mode, else refused, or in
        another where ``any_mode`` allows it), which commits a success by adoption."""
        ctx.sync()
        S = ctx.solver
        for i in range(b - a):
            r = self.engine.solve_target(S, command_row(columns, i), allow_mode_change=any_mode)
            self.res.put_result(a + i, r)
            if r.success and r.mode_change:
                self.res.mode_change[a + i] = r.mode_change
            if r.success:
                ctx.hist = [HistoryEntry(EntryKind.ADOPT, result=r, signs=_adopted_signs(S))]
                ctx.synced = True
            if not i & 0xFF:
                self.progress.update(self.done + i)
        self.res.sequential += _solved_rows(columns, 0, b - a)

    # -- one by one ------------------------------------------------------------------------------
    def _sequential(self, ctx: SolverContext, columns, a, b, i0, i1, rates: RunRates | None = None):
        ctx.sync()
        S = ctx.solver
        engine = self.engine
        for i in range(i0, i1):
            cmd = command_row(columns, i)
            r, adopted = engine.solve_on_circuit(S, cmd)  # as Engine.forward_solve
            self.res.put_result(a + i, r)
            if r.success:
                if adopted:
                    ctx.push(HistoryEntry(EntryKind.ADOPT, result=r, signs=_adopted_signs(S)))
                else:
                    ctx.push(
                        HistoryEntry(
                            EntryKind.SOLVE, cmd=cmd, signs=branch_signs(r.branch), result=r
                        )
                    )
                rate = None if rates is None else rates.row(i)
                if rate is not None:  # Engine.command: the answer's velocity
                    self.res.store_velocity(a + i, velocities(S, r, cmd, rate))
            if not i & 0xFF:
                self.progress.update(self.done + i)
        self.res.sequential += _solved_rows(columns, i0, i1)

    # -- vectorised ------------------------------------------------------------------------------
    def _vectorised(self, ctx: SolverContext, columns, a, b, rates: RunRates | None):
        S = ctx.solver
        m = b - a
        continuous = S.branch_mode is BranchRule.CONTINUOUS
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
            take = (
                easy_prefix(self.mech, ctx.hist, solver, B, cols, end - pos)
                if continuous
                else end - pos
            )
            if take and self.engine.circuit.checked:
                take = self._on_circuit_prefix(B, cols, take)
            if take and self.mech.joint_coordinates is not None:
                take = self._within_passive_limits_prefix(B, take)
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

    def _on_circuit_prefix(self, B, cols, take: int) -> int:
        """How many of the first ``take`` batch rows Engine.forward_solve answers as the
        batch does: up to the first answer on another circuit than the reference pose's while
        the state is on it (that row is refused, one by one)."""
        engine = self.engine
        last = engine.last
        circuit = engine.circuit.reference
        if circuit is None or (last is not None and engine.circuit.holds(last) is False):
            return take
        values = np.asarray(cols[circuit.actuator], float)
        ok = np.asarray(B.ok[:take], bool)
        for i in np.flatnonzero(ok).tolist():
            if not circuit.holds(tuple(int(v) for v in B.signs[i]), float(values[i])):
                return i
        return take

    def _within_passive_limits_prefix(self, B, take: int) -> int:
        """How many of the first ``take`` batch rows keep the description's passive joints
        within their <limit>s, as Engine.forward_solve requires (the first that does not is
        refused, one by one)."""
        coords = self.mech.joint_coordinates
        joints = {j: np.asarray(v[:take], float) for j, v in B.joints.items()}
        beyond = np.asarray(coords.passive_beyond_rows(joints), bool) & np.asarray(B.ok[:take])
        bad = np.flatnonzero(beyond)
        return int(bad[0]) if bad.size else take

    def _accept(self, ctx, solver, B, cols, g0, take) -> int:
        """Copy the first ``take`` batch rows into the results; returns how many were taken
        (fewer if a single solve accepts a command the batch refused: from there on the rows
        go one by one)."""
        res = self.res
        # refused rows: the node's exact reason (the same solve, with the same branch choices)
        reasons = {}
        cache: dict[bytes, str] = {}
        finite = finite_rows({nm: c[:take] for nm, c in cols.items()}, take)
        for i in np.flatnonzero(~B.ok[:take]).tolist():
            keyb = None
            if not finite[i]:
                keyb = b''.join(np.asarray(c[i], float).tobytes() for c in cols.values())
                if keyb in cache:
                    reasons[i] = cache[keyb]
                    continue
            r = solver.solve(command_row(cols, i), commit=False)
            if r.success:  # a tangency the batch refused: leave it to Solver
                take = i
                break
            reasons[i] = self.engine.circuit.with_reach(r).reason or ''
            if keyb is not None:
                cache[keyb] = r.reason
        if not take:
            return 0
        res.put_batch(g0, B, take, reasons)
        okr = np.flatnonzero(B.ok[:take])
        # the last two successes become the node's history
        if okr.size:
            self.engine.version += okr.size - min(okr.size, 2)
            for i in okr[-2:].tolist():
                ctx.push(
                    HistoryEntry(
                        EntryKind.SOLVE,
                        cmd=command_row(cols, i),
                        signs=tuple(B.signs[i]),
                        batch=B,
                        i=i,
                        solver=solver,
                    )
                )
            ctx.synced = False
        res.batched += int(np.count_nonzero(finite[:take]))  # (a NaN row reaches no solve)
        return take

    def _batch_rates(self, ctx: SolverContext, B, cols, rates: RunRates, a, pos, take) -> None:
        """The velocities of the batch rows just taken (rows pos.. of the run starting at a)
        whose commands gave some, each from its row's solution as Engine.command gives them:
        core.velocity on the engine's solver (positions stay vectorised; rated rows pay for
        this one by one)."""
        rated = np.asarray(B.ok[:take], bool) & rates.given[pos : pos + take]
        for i in np.flatnonzero(rated).tolist():
            rate = rates.row(pos + i)
            assert rate is not None  # a rated row
            self.res.store_velocity(
                a + pos + i, velocities(ctx.solver, B.row(i), command_row(cols, i), rate)
            )


def _adopted_signs(S: Solver) -> tuple[int, ...]:
    """The branch signs a solver holds after adopt() (its plan's signs of that pose)."""
    return S.current_signs


def solve_commands(
    mech, data: Commands, method=None, tol=NEWTON_TOL, max_iter=50, branch='continuous'
) -> Results:
    """Solve decoded commands in order as the node would (library entry point)."""
    return ReplayEngine(mech, method, tol, max_iter, branch).solve_all(data)


CHUNK_MIN, CHUNK_START, CHUNK_MAX = 256, 8192, 65536


#: rows solved one by one from a row the batch cannot vouch for (doubled, up to 4096, while
#: batches keep breaking at once: jumpy commands)
SEQUENTIAL_STRETCH = 16

#: the fewest commands of one set of names solved as a batch (fewer: one by one, cheaper; the
#: summary's one-by-one rows count them, README)
MIN_BATCH = 32


NEAR_TANGENT = 1e-6
