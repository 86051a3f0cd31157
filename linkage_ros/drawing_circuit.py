"""The drawing's circuit as the engine holds forward answers to it (ROS-free).

A one-actuator mechanism whose drawing's circuit passes its toggles (a non-Grashof four-bar's
two dyad signs are one motion; a Grashof double-rocker's mirror loop is another circuit with
the same signs) is held to that circuit by commands: core.motion.circuit_rule does the
holding, this class scans the circuit once and answers the engine's questions about it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

from .core.model import Mechanism
from .core.motion.circuit_rule import CircuitKeeper, reachable_text
from .core.motion.circuits import Circuit
from .core.motion.circuits import reference_circuit as scan_reference_circuit
from .core.motion.common import without_limits
from .core.quantities import Shown
from .core.solver import Result, Solver
from .core.solver.mode_rule import Mode
from .core.solver.result import does_not_assemble
from .core.steps import BranchRule, branch_text


class DrawingCircuit:
    """The reference pose's circuit of ``mech`` (scanned when first asked), read with the
    engine's ``mode`` of a configuration; ``sign_solver(text)`` compiles a forward solver
    in the branch signs ``text``."""

    def __init__(
        self,
        mech: Mechanism,
        forward: Solver,
        mode: Callable[[Result], Mode | None],
        sign_solver: Callable[[str], Solver],
    ):
        self.mech = mech
        self.forward = forward
        self._mode = mode
        self._sign_solver = sign_solver
        #: forward solvers per branch sign combination (keep's)
        self._sign_solvers: dict[str, Solver] = {}

    @functools.cached_property
    def reference(self) -> Circuit | None:
        """The reference pose's circuit (core.motion.circuits), scanned when first asked."""
        return scan_reference_circuit(self.mech)

    @functools.cached_property
    def _free(self) -> Circuit | None:
        """The reference pose's circuit with the actuator's limits aside."""
        return scan_reference_circuit(without_limits(self.mech))

    def joined_by_motion(self) -> bool | None:
        """Whether the actuator's motion passes a toggle into the forward dyads' other signs,
        its limits aside (a non-Grashof mechanism whose crank limits stop short of its toggles
        still has one circuit: its other sign is beyond a toggle, not another circuit); None
        where the circuit is not scanned (several actuators, Newton). Scanned when first
        asked: only a refusal's wording reads it."""
        free = self._free
        return None if free is None else free.crosses_signs

    def holds(self, r: Result) -> bool | None:
        """Whether a configuration lies on the reference pose's circuit, where that circuit
        passes its toggles; None where not known (no such circuit, or no mode read)."""
        c = self.reference
        if c is None or not c.crosses_signs:
            return None
        mode, value = self._mode(r), r.inputs.get(c.actuator)
        if mode is None or value is None:
            return None
        return c.holds(mode[0], float(value))

    def _shown(self, actuator: str) -> Shown | None:
        """How a robot description shows ``actuator``'s values (None: the scene's own)."""
        coords = self.mech.joint_coordinates
        return None if coords is None else coords.shown(actuator)

    def with_reach(self, result: Result) -> Result:
        """A forward refusal that does not assemble (``result``, changed) told what the
        actuator does reach from the drawing, where one actuator moves the mechanism (the
        range `linkage check` gives)."""
        if not does_not_assemble(result):
            return result
        c = self.reference
        branch = self.forward.continuity.branch
        if (
            c is not None
            and branch.rule is BranchRule.EXPLICIT
            and all(s.signs != tuple(branch.signs or ()) for s in c.stretches)
        ):
            # (a branch setting that holds signs the drawing's circuit never takes: its range
            # is not the drawing's; an integrator's landing gear under --branch +- was told
            # -0.03 m lay inside the -+ circuit's -0.1..0.06 m, where +- reaches -0.0228)
            return result
        if c is not None and not all(s.full for s in c.stretches):
            result.reason = (
                f'{result.reason}; from its drawing the actuator moves it over '
                f'{reachable_text(c, self._shown(c.actuator))} (its reachable range)'
            )
        return result

    @functools.cached_property
    def _keeper(self) -> CircuitKeeper | None:
        """The forward half of the mode rule (core.motion.circuit_rule), for a one-actuator
        mechanism whose drawing's circuit passes its toggles."""
        c = self.reference
        if c is None or not c.crosses_signs or len(c.stretches[0].signs) != 1:
            # (one branching dyad: a four-bar's or a slider-crank's circuits are its loops. A
            # scan through an inversor's fold, where two dyads degenerate at once, branches
            # into sign combinations that are no loop of its own: Peaucellier's took up 60
            # stretches; there the rule stays the targets' alone)
            return None
        return CircuitKeeper(c, self.holds, self._solve_in_signs, self._shown(c.actuator))

    @property
    def checked(self) -> bool:
        """Whether forward answers are held to the drawing's circuit (keep)."""
        return self._keeper is not None

    def keep(self, before: Result | None, result: Result, values: Mapping[str, Any]) -> Result:
        """A forward answer to ``values`` from the state ``before`` held to the drawing's
        circuit (core.motion.circuit_rule.CircuitKeeper.keep): as it is, the circuit's own
        configuration at that input, or refused."""
        keeper = self._keeper
        if keeper is None:
            return result
        branch = self.forward.continuity.branch
        asked = branch.signs if branch.rule is BranchRule.EXPLICIT else None
        return keeper.keep(before, result, values, asked)

    def _solve_in_signs(self, signs: tuple[int, ...], values: Mapping[str, Any]) -> Result:
        """A forward solve of ``values`` in branch ``signs`` (a solver per sign combination,
        kept), not committed."""
        text = branch_text(signs)
        solver = self._sign_solvers.get(text)
        if solver is None:
            solver = self._sign_solvers[text] = self._sign_solver(text)
        return solver.solve(values, commit=False)
