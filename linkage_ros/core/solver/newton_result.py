"""The Result of a Newton answer (newton_path.solve_newton), its costly fields read when first
asked (lazy_result.LazyResult: the machinery, shared with the closed form's ClosedResult).

What decides the answer is set when it is made: success, residual, iterations, solver, branch,
branch_defined, margin. The name-keyed dicts (inputs, targets, joints, links, points) are read
off the answer's link poses by the compiled solve's ResultAssembler (what build_result reads
them with), and ``cond`` is the condition number the Newton solve reports at the answer
(scalar.cond_of: LAPACK's estimate off the dense J, read there on first use where the fast path
left it unread)."""

from __future__ import annotations

import math
from typing import Any

from ..assemble import Assembly
from ..execute import LinkPoses
from ..newton.results import SolveResult
from ..newton.scalar import answer_cond
from ..newton.tables import LoopTables
from ..ops import SCALAR
from .compiled import CompiledSolve, Values
from .lazy_result import LazyResult


class NewtonSource:
    """What a NewtonResult's lazy fields are read from: the solved configuration (poses,
    points), the command, and the answer's cond (or, where the fast path left it unread, J's
    varying entries there to read it from: not the solve's factor or J, which a Result kept by a
    caller would otherwise keep alive)."""

    __slots__ = ('c', 'poses', 'points', 'vals', 'tables', 'cond', 'jv', '_assembly')

    def __init__(
        self,
        c: CompiledSolve,
        poses: LinkPoses,
        points: dict[str, complex],
        vals: Values,
        tables: LoopTables,
        answer: SolveResult,
    ):
        self.c, self.poses, self.points, self.vals = c, poses, points, vals
        self.tables, self.cond = tables, answer.cond
        self.jv = answer.jv if answer.cond != answer.cond else None  # (nan: unread)
        self._assembly: Assembly | None = None

    def assembly(self) -> Assembly:
        """The ResultAssembler's reading of the answer (build_result's), made once."""
        got = self._assembly
        if got is None:
            got = self._assembly = self.c.assembler(self.poses.phi)(SCALAR, self.poses, self.vals)
        return got


class NewtonResult(LazyResult):
    """A Newton answer (see the module)."""

    __slots__ = ()
    _source: NewtonSource
    _LAZY = frozenset(('inputs', 'targets', 'joints', 'links', 'points', 'cond'))

    def _fill(self, d: dict[str, Any], name: str) -> None:
        src = self._source
        if name == 'cond':
            c = src.cond
            if c != c and src.jv is not None:  # (scalar.cond_of's reading)
                c = answer_cond(src.tables, src.jv)
            d['cond'] = c if math.isfinite(c) else None
            return
        got = src.assembly()
        new: dict[str, Any] = {
            'inputs': got.inputs,
            'targets': {},
            'joints': got.joints,
            'links': got.links,
            'points': {p: (v.real, v.imag) for p, v in src.points.items()},
        }
        new.update(d)  # (what the Result was given meanwhile stays)
        d.update(new)


_new = object.__new__


def newton_result(
    source: NewtonSource,
    *,
    solver: str,
    residual: float,
    iterations: int,
    branch: str,
    branch_defined: bool,
    margin: float,
) -> NewtonResult:
    """A successful Newton Result whose dicts and cond are read off ``source`` when asked."""
    res: NewtonResult = _new(NewtonResult)
    res._source = source
    res.success, res.reason, res.solver = True, None, solver
    res.residual, res.iterations, res.margin = residual, iterations, margin
    res.branch, res.branch_defined = branch, branch_defined
    return res
