"""One entry point for forward and inverse position kinematics of a mechanism.

``Solver(mech, knowns, outputs, method, tol, max_iter, branch)`` compiles once; ``solve`` answers
one command, ``solve_batch`` a vector of commands. Every answer is a :class:`Result`: success or
a reason, loop-closure residual (fraction of the length scale), iterations, solver used, branch and
distance to singularity. A bad or unreachable command is a failed Result, never an exception and
never a NaN.

Methods: ``closed_form`` (the dyad plan; refused when the knowns have no closed-form plan),
``newton`` (loop-closure Newton on every link), ``auto`` (the dyad plan places what it can and
Newton places the rest).
Branch: ``continuous`` (start in the reference pose's assembly mode, then keep the mode nearest
the previous configuration; a dyad changes sign only through its singularity or turning back
near a toggle, crossing.py),
``reference`` (the reference pose's signs, always) or an explicit sign
string such as ``+-`` (one sign per branching dyad of the plan, in plan order).

The Solver is a thin facade: what the mechanism and knowns fix is one frozen
:class:`~linkage_ros.core.solver.compiled.CompiledSolve` (``compiled``), what changes from command
to command one :class:`~linkage_ros.core.solver.continuity.Continuity` (``continuity``); the
paths are functions over the two (``one.py``, ``newton_path.py``, ``batch.py``, ``modes.py``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..execute import LinkPoses
from ..model import Mechanism
from ..newton import LoopSystem
from ..plan import Plan, Spec, limit_violation
from ..quantities import ScalarSpec
from .batch import BatchResult, solve_batch
from .closed_form import lean_command
from .compiled import CompiledSolve, SolveMode, Values
from .compiling import compile_solve
from .continuity import BranchRule, Continuity, State, parse_branch
from .modes import ModeList, modes_of
from .one import solve_one
from .point_pairs import PointPair
from .reading import adopt, configuration_of, mode_of
from .result import NEWTON_TOL, Effort, Result, SolveMethod


class Solver:
    """Compiled solver for one mechanism, one set of known names and wanted outputs."""

    def __init__(
        self,
        mech: Mechanism,
        knowns: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
        method: str | None = None,
        tol: float = NEWTON_TOL,
        max_iter: int = 50,
        branch: str = 'continuous',
    ):
        self.compiled = compile_solve(mech, knowns, outputs, method, tol, max_iter)
        c = self.compiled
        labels = not c.inverse and not c.full_plan.complete  # modes named by a Jacobian sign
        self.continuity = Continuity(parse_branch(c.plan, branch, labels))
        self._newton: CompiledSolve | None = None  # the mode search's, made on first use
        self._forward: CompiledSolve | None = None  # reads the mechanism's mode, likewise
        self._lean = lean_command(c)  # a forward closed form's common command (closed_form)

    # -- what was compiled (read-only views of ``compiled``) ------------------------------------
    @property
    def mech(self) -> Mechanism:
        return self.compiled.mech

    @property
    def knowns(self) -> list[str]:
        return list(self.compiled.knowns)

    @property
    def plan_knowns(self) -> list[str]:
        return list(self.compiled.plan_knowns)

    @property
    def specs(self) -> list[Spec]:
        return list(self.compiled.specs)

    @property
    def actuator_specs(self) -> list[ScalarSpec]:
        return list(self.compiled.actuator_specs)

    @property
    def point_pairs(self) -> list[PointPair]:
        return list(self.compiled.point_pairs)

    @property
    def plan(self) -> Plan:
        return self.compiled.plan

    @property
    def full_plan(self) -> Plan:
        return self.compiled.full_plan

    @property
    def system(self) -> LoopSystem:
        return self.compiled.system

    @property
    def check_system(self) -> LoopSystem:
        return self.compiled.check_system

    @property
    def method(self) -> SolveMethod:
        return self.compiled.method

    @property
    def mode(self) -> SolveMode:
        return self.compiled.mode

    @property
    def closed_links(self) -> list[str]:
        return list(self.compiled.closed_links)

    @property
    def tol(self) -> float:
        return self.compiled.tol

    @property
    def max_iter(self) -> int:
        return self.compiled.max_iter

    @property
    def closure_limit(self) -> float:
        return self.compiled.closure_limit

    @property
    def inverse(self) -> bool:
        return self.compiled.inverse

    @property
    def branch_count(self) -> int:
        return self.compiled.branch_count

    @property
    def pair_tolerance_m(self) -> float:
        """How far (m) the distance of a target's two points of one link may be from the
        link's: what the solver accepts as loop closure."""
        return self.compiled.pair_tolerance_m

    # -- continuity -----------------------------------------------------------------------------
    @property
    def branch_mode(self) -> BranchRule:
        """continuous, reference or explicit (see the module)."""
        return self.continuity.branch.rule

    @property
    def fixed_signs(self) -> tuple[int, ...] | None:
        """The explicit branch signs (None unless branch_mode is explicit)."""
        return self.continuity.branch.signs

    @property
    def current_signs(self) -> tuple[int, ...]:
        """The branch signs the next solve starts from (one per branching dyad of the plan)."""
        return self.continuity.signs(self.compiled.plan)

    def reference_values(self) -> dict[str, Any]:
        """The known quantities' values in the scene's reference pose ({known name: value})."""
        return self.compiled.reference_values()

    def snapshot(self) -> tuple[State, ...]:
        """The continuity state (the previous configurations it predicts from), opaque: pass it
        to restore() on a solver of the same mechanism and knowns to replay exactly."""
        return tuple(self.continuity.history)

    def restore(self, snapshot: Any) -> None:
        """Return to a state taken by snapshot() (of this solver or one with the same knowns);
        ValueError, and no change, for anything else."""
        if not isinstance(snapshot, (tuple, list)) or not all(map(self._fits, snapshot)):
            raise ValueError(
                'restore() takes what snapshot() returned, of a solver of this mechanism '
                f'({self.mech.name!r}) with the knowns {self.knowns}'
            )
        self.continuity.history = list(snapshot)[-2:]

    def _fits(self, st: Any) -> bool:
        """Whether ``st`` can be a State of this solver: its values one per known, its links,
        points and Newton unknowns this mechanism's (another mechanism's state, with knowns of
        the same names, made the next solve raise or refuse a reachable command)."""
        mech = self.mech
        return (
            isinstance(st, State)
            and len(st.values) == len(self.compiled.specs)
            and set(st.poses.phi) <= set(mech.links)
            and set(st.points) <= set(mech.points)
            and (st.x_all is None or np.shape(st.x_all) == (self.check_system.n,))
        )

    def reset(self) -> None:
        """Forget the previous configuration (continuity restarts from the reference pose)."""
        self.continuity.history = []

    # -- solving --------------------------------------------------------------------------------
    def parse(self, values: Mapping[str, Any]) -> Values:
        """Validate a {known name: value} command; raise ValueError naming what is wrong."""
        return self.compiled.parse(values)

    def limit_violation(self, spec: ScalarSpec, value: float) -> str | None:
        """Why ``value`` is outside ``spec``'s limits (plan.limit_violation), or None."""
        return limit_violation(spec, value)

    def solve(
        self,
        values: Mapping[str, Any],
        commit: bool = True,
        effort: Effort = Effort.FULL,
        within_limits: bool = True,
    ) -> Result:
        """Solve one command. On success (and commit) the answer becomes the new 'previous
        configuration' for continuity; on failure nothing changes. ``effort``: less than FULL
        for a caller that reads only whether it succeeded (result.Effort); ``within_limits``
        False: the limits are not checked (to say which ones stop a target)."""
        if self._lean is not None and within_limits:  # (None from it: the general path)
            res = self._lean.command(self.continuity, values, commit)
            if res is not None:
                return res
        return solve_one(self.compiled, self.continuity, values, commit, effort, within_limits)

    def solve_batch(
        self, columns: Mapping[str, Any], start: BatchResult | None = None
    ) -> BatchResult:
        """Solve n commands at once (see :func:`~linkage_ros.core.solver.batch.solve_batch`)."""
        return solve_batch(self.compiled, self.continuity, columns, start)

    def solve_all(self, values: Mapping[str, Any]) -> list[Result]:
        """Every assembly mode of one command, without touching the continuity history: each
        sign combination of the dyad plan that closes; where Newton places the mechanism, the
        modes a multi-start Newton search finds (see :meth:`modes`: may be incomplete)."""
        return self.modes(values).results

    def modes(self, values: Mapping[str, Any]) -> ModeList:
        """:meth:`solve_all` with whether the list is provably complete (closed form) or the
        result of a search (core.solver.modes)."""
        c = self.compiled
        newton = None
        if c.mode is SolveMode.NEWTON:
            newton = c
        elif c.mode is SolveMode.HYBRID:
            if self._newton is None:
                self._newton = compile_solve(
                    c.mech, c.knowns, None, SolveMethod.NEWTON, c.tol, c.max_iter
                )
            newton = self._newton
        return modes_of(c, self.continuity, values, newton, self.forward_compile())

    def forward_compile(self) -> CompiledSolve:
        """A compile of the mechanism's actuators (this one for a forward solve): what reads
        the mechanism's assembly mode (mode_of, mode_label)."""
        c = self.compiled
        if not c.inverse and set(c.knowns) == set(c.mech.actuators):
            return c
        if self._forward is None:  # an inverse closed form may have a forward that is not
            method = SolveMethod.AUTO if c.method is SolveMethod.CLOSED_FORM else c.method
            self._forward = compile_solve(c.mech, None, None, method, c.tol, c.max_iter)
        return self._forward

    # -- reading answers back -------------------------------------------------------------------
    def adopt(self, result: Result) -> bool:
        """Make a solved configuration (from any solver of this mechanism) the 'previous
        configuration' for continuity and warm starts; False, changing nothing, if unusable."""
        return adopt(self.compiled, self.continuity, result)

    def mode_of(self, result: Result) -> tuple[tuple[int, ...], list[float]] | None:
        """The assembly mode of a solved configuration (core.solver.reading.mode_of)."""
        return mode_of(self.compiled, result)

    def configuration_of(self, result: Result) -> tuple[dict[str, complex], LinkPoses] | None:
        """(points, poses) of a successful result of this mechanism, or None if unusable."""
        return configuration_of(self.compiled, result)
