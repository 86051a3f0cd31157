"""The circuit through the reference pose of a one-actuator mechanism: which configurations the
mechanism reaches from its drawing by moving its actuator, through toggles (the scan of
ranges.scan_circuit, each stretch clipped to the actuator's limits where its motion reaches
them).

A dyad's branch sign names the assembly mode only where its toggle is never crossed. A
non-Grashof four-bar passes its toggles and takes up the mirror configuration on one circuit
(seed 000: "there is only one curve, because there is only one mode of assembly"); a Grashof
double-rocker has two circuits, each through both signs. The target rule (core.solver.mode_rule)
asks a Circuit whether two configurations of different signs are one motion apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..model import AngleActuator, Mechanism
from ..model.limits import angle_limit_arc
from .ranges import scan_circuit
from .scan import EndKind
from .touches import TOUCH_RESOLUTION

#: how far past a stretch's end (rad or m) a value still counts as on it: its toggle ends are
#: refined to about 1e-12, and a configuration at a toggle is on both stretches
END_SLACK = 1e-9


@dataclass(frozen=True)
class Stretch:
    """The circuit in one sign combination of the forward dyads: the actuator over [lo, hi]
    (angles unwrapped), or every value (``full``)."""

    signs: tuple[int, ...]
    lo: float
    hi: float
    full: bool


@dataclass(frozen=True)
class Circuit:
    """The circuit through the reference pose of actuator ``actuator`` (see the module)."""

    actuator: str
    periodic: bool
    stretches: tuple[Stretch, ...]

    def holds(self, signs: tuple[int, ...], value: float) -> bool:
        """Whether the configuration with forward dyad signs ``signs`` at actuator ``value``
        (rad or m) lies on the circuit."""
        for s in self.stretches:
            if s.signs != tuple(signs):
                continue
            if s.full:
                return True
            v = value
            if self.periodic:  # the turn of value nearest the stretch's middle
                v -= 2 * math.pi * round((value - 0.5 * (s.lo + s.hi)) / (2 * math.pi))
            if s.lo - END_SLACK <= v <= s.hi + END_SLACK:
                return True
        return False

    def intervals(self) -> list[tuple[float, float]]:
        """The actuator values (rad or m, unwrapped) the circuit spans, its stretches' intervals
        merged where they meet (within END_SLACK), in increasing order."""
        merged: list[tuple[float, float]] = []
        for lo, hi in sorted((s.lo, s.hi) for s in self.stretches):
            if merged and lo <= merged[-1][1] + END_SLACK:
                merged[-1] = (merged[-1][0], max(merged[-1][1], hi))
            else:
                merged.append((lo, hi))
        return merged

    @property
    def crosses_signs(self) -> bool:
        """Whether the circuit takes up more than one sign combination (passes a toggle)."""
        return len({s.signs for s in self.stretches}) > 1


def reference_circuit(mech: Mechanism, samples: int = 720) -> Circuit | None:
    """The reference pose's circuit, or None where it is not scanned (more than one actuator
    or degree of freedom, no closed-form scan of the actuator) or the drawing does not choose
    it: drawn on a change point, two circuits pass through the pose (a parallelogram drawn
    folded flat lies on the parallelogram's motion and on the anti-parallelogram's; the scan
    follows one of them, which the drawing does not name)."""
    if len(mech.actuators) != 1 or mech.dof != 1:
        return None
    name = next(iter(mech.actuators))
    line, x0, segments, _bracket = scan_circuit(mech, name, {}, samples)
    if line is None or not segments:
        return None
    drawn = segments[0]  # (the scan's first segment is the drawing's)
    if drawn.lo_end[0] is EndKind.CROSSING and line.same(drawn.lo, x0, TOUCH_RESOLUTION):
        return None
    act = mech.actuators[name]
    periodic = isinstance(act, AngleActuator)
    limits = angle_limit_arc(act.min, act.max) if periodic else (act.min, act.max)
    stretches = []
    for s in segments:  # each within the limits: what its motion reaches from its start
        reached = line.reached(s.lo, s.hi, s.seed, limits)
        if reached is not None:
            stretches.append(Stretch(tuple(s.signs), *reached, s.full and reached == (s.lo, s.hi)))
    return Circuit(name, periodic, tuple(stretches)) if stretches else None
