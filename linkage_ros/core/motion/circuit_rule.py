"""Commands keep the drawing's circuit, as targets keep the mechanism's mode
(core.solver.mode_rule): the forward half of the rule, for a one-actuator mechanism whose
circuit passes its toggles.

A Grashof double-rocker's mirror loop has the dyad's signs over the mirrored input interval,
and "you can never pass on from one mode of assembly to the other" (seed 000): a forward answer
there, while the mechanism is on the drawing's loop, is refused, naming the interval `linkage
check` gives as the input's reachable range. Where the circuit holds another sign combination
at that input, its configuration nearest the last state is the answer instead. (The engine
keeps the rule to one-dyad circuits: a scan through an inversor's fold branches into sign
combinations that are no loop of it.)"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ..quantities import Shown
from ..solver import Result
from ..solver.mode_rule import configuration_distance
from ..steps import branch_text
from .circuits import Circuit

#: a forward solve of a command in the given branch signs (not committed)
SolveInSigns = Callable[[tuple[int, ...], Mapping[str, Any]], Result]


@dataclass(frozen=True)
class CircuitKeeper:
    """The rule for one mechanism: its drawing's ``circuit``, ``on_circuit`` (whether a
    configuration lies on it; None where not known), ``solve_in`` and how a robot description
    writes the actuator (``shown``)."""

    circuit: Circuit
    on_circuit: Callable[[Result], bool | None]
    solve_in: SolveInSigns
    shown: Shown | None = None

    def keep(
        self,
        before: Result | None,
        result: Result,
        values: Mapping[str, Any],
        asked: tuple[int, ...] | None = None,
    ) -> Result:
        """``result`` (a forward answer to ``values`` from the state ``before``) where it is on
        the circuit, or not known to be off it, or the state is off it already (a target
        allowed to change the mode moved it); else the circuit's configuration at that input
        nearest ``before``, in the signs ``asked`` where a branch setting fixes them (another
        mode's would answer a command for a mode it did not ask); else the refusal."""
        if not result.success or self.on_circuit(result) is not False:
            return result
        if before is not None and self.on_circuit(before) is False:
            return result
        c = self.circuit
        value = float(result.inputs.get(c.actuator, math.nan))
        found = []
        elsewhere = []  # the circuit's signs at that input where they are not the asked ones
        for signs in dict.fromkeys(s.signs for s in c.stretches):
            if not c.holds(signs, value):
                continue
            if asked is not None and signs != asked:
                elsewhere.append(signs)
                continue
            r = self.solve_in(signs, values)
            if r.success and self.on_circuit(r):
                found.append(r)
        if found:
            return min(found, key=lambda r: configuration_distance(before, r))
        why = self.refusal(value) if not elsewhere else self.other_mode(value, asked, elsewhere)
        return Result(False, why, inputs=dict(result.inputs), solver=result.solver)

    def other_mode(
        self, value: float, asked: tuple[int, ...] | None, elsewhere: list[tuple[int, ...]]
    ) -> str:
        """Why the actuator at ``value`` is refused in the ``asked`` signs where the drawing's
        circuit passes there in others (``elsewhere``)."""
        c = self.circuit
        unit = 'rad' if c.periodic else 'm'
        shown = self.shown(value) if self.shown is not None else value
        modes = ', '.join(repr(branch_text(s)) for s in elsewhere)
        return (
            f'{c.actuator} = {shown:.6g} {unit} in the assembly mode asked '
            f"({branch_text(asked or ())!r}) is off the drawing's circuit, which passes there "
            f'in mode {modes} (that branch setting, or continuous, answers it; the all-branches '
            'search lists every mode)'
        )

    def refusal(self, value: float) -> str:
        """Why the actuator at ``value`` (the scene's) is refused: only the other loop holds it
        (in a robot description's own values, where it has them)."""
        c = self.circuit
        unit = 'rad' if c.periodic else 'm'
        if self.shown is not None:
            value = self.shown(value)
        return (
            f'{c.actuator} = {value:.6g} {unit} is reachable only on the other loop of the '
            f'mechanism (another assembly mode): from its drawing the actuator moves it over '
            f'{reachable_text(c, self.shown)} (its reachable range), and it cannot pass from '
            'one loop to the other without being taken apart'
        )


def reachable_text(c: Circuit, shown: Shown | None = None) -> str:
    """The actuator values the circuit spans, as a refusal names them (`crank 0.4..1.2 rad`;
    in a robot description's own values where ``shown`` converts them)."""
    unit = 'rad' if c.periodic else 'm'
    spans = c.intervals()
    if shown is not None:  # (scale -1 turns each interval round)
        spans = sorted((min(shown(a), shown(b)), max(shown(a), shown(b))) for a, b in spans)
    return f'{c.actuator} ' + ', '.join(f'{lo:.6g}..{hi:.6g} {unit}' for lo, hi in spans)
