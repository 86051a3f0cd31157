"""The replay's copy of a solver's continuity history, as the node's solver holds it: kept as
entries so that batch rows need not be materialised, and given to the solver when it next
solves one by one."""

from __future__ import annotations

from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from ..core.solver import Solver
from ..core.solver.result import branch_text

if TYPE_CHECKING:
    from ..engine import Engine


class EntryKind(Enum):
    """How a configuration came into a solver's continuity history."""

    ADOPT = 'adopt'  # a result adopted after switching solvers
    SOLVE = 'solve'  # a command the solver answered (its signs replay it)


class HistoryEntry:
    """One configuration in a solver's continuity history, as the node's solver holds it:
    adopted (ADOPT, its result) after switching solvers, or solved (SOLVE, its command and
    signs) after a success."""

    __slots__ = ('kind', 'cmd', 'signs', '_result', 'batch', 'i', 'solver')

    def __init__(self, kind, *, cmd=None, signs=(), result=None, batch=None, i=0, solver=None):
        self.kind, self.cmd, self.signs = kind, cmd, tuple(signs)
        self._result, self.batch, self.i, self.solver = result, batch, i, solver

    def result(self):
        if self._result is None:
            self._result = self.batch.row(self.i, self.solver)
        return self._result

    def point(self, p) -> np.ndarray:
        if self._result is None and self.batch is not None:
            return self.batch.points[p][self.i]
        return np.asarray(self.result().points[p], float)

    def link(self, l) -> float:
        if self._result is None and self.batch is not None:
            return float(self.batch.links[l][self.i])
        return float(self.result().links[l])


class SolverContext:
    """One of the engine's solvers (one set of knowns) and its node-equivalent continuity
    history, kept as entries so batch rows need not be materialised."""

    def __init__(self, engine: Engine, solver: Solver):
        self.engine = engine  # the replay's session (its solvers and last good state)
        self.solver = solver
        self.knowns = list(solver.knowns)
        self.hist: list[HistoryEntry] = []
        self.synced = True  # the solver's own history equals self.hist
        self._explicit: dict[tuple, Solver] = {}

    def explicit(self, signs) -> Solver:
        signs = tuple(signs)
        s = self._explicit.get(signs)
        if s is None:
            s = self._explicit[signs] = self.engine.new_solver(self.knowns, branch_text(signs))
        return s

    def push(self, entry: HistoryEntry):
        """A success of this solver: the engine's new last good state."""
        self.hist = (self.hist + [entry])[-2:]
        self.engine.record(self.solver, entry)

    def sync(self):
        """Give the solver exactly the history the node's solver has (self.hist)."""
        if self.synced:
            return
        S = self.solver
        S.reset()
        states = []
        for e in self.hist:
            if e.kind is EntryKind.ADOPT:
                S.adopt(e.result())
                states.append(S.snapshot()[-1])
            else:
                # the same command with the same branch signs gives the same state
                sx = self.explicit(e.signs)
                sx.reset()
                sx.solve(e.cmd)
                states.append(sx.snapshot()[-1])
                sx.reset()
        S.restore(states)
        self.synced = True
