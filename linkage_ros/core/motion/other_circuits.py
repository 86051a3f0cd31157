"""The other circuits of a one-input mechanism: where its input angle also assembles, apart
from the drawing's circuit, in some assembly mode. A Grashof double-rocker's input rocks over
one interval on the drawing's side of the ground line and over its mirror on the other: a
second circuit, reached only by taking the linkage apart, which the lectures describe beside
the first."""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..model import AngleActuator, Mechanism
from ..model.limits import angle_limit_arc
from .common import TWO_PI, without_limits
from .ranges import actuator_range
from .scan import NOWHERE, ScanLine


def other_circuits(mech: Mechanism, name: str, samples: int = 720) -> list[tuple[float, float]]:
    """[(lo, hi), ...] (rad, lo < hi, written within a turn of 0) where the angle input
    ``name`` assembles in some assembly mode of the closed-form plan outside the drawing's
    circuit, within the input's limits (an arc) where it has them; each end the toggle the
    circuit scan finds (ScanLine.component: to 1e-12 rad), or a limit. Empty where the input
    turns fully, is not an angle, or Newton places the scene."""
    act = mech.actuators[name]
    if len(mech.actuators) != 1 or not isinstance(act, AngleActuator):
        return []
    info = actuator_range(without_limits(mech), name, samples)
    drawn = info.get('assembly')
    if info.get('full_turn') or not drawn:
        return []
    line = ScanLine(mech, name, {}, samples)
    if not line.closed:
        return []
    step = TWO_PI / samples
    theta = drawn[0] + step * (np.arange(samples) + 0.5)  # one turn from the drawn start
    outside = theta > drawn[1] + step
    found: list[tuple[float, float]] = []
    for signs in itertools.product((1, -1), repeat=len(line.branch_of_step)):
        ok = line.ok(theta, signs) & outside
        for k in np.flatnonzero(ok & ~np.roll(ok, 1)).tolist():  # each run's first sample
            comp = line.component(float(theta[k]), signs)
            if comp is None or comp is NOWHERE:  # (a full turn; nowhere: slides only)
                continue
            lo, hi = comp[0], comp[1]
            while lo > math.pi:  # (written within a turn of 0, as the drawn circuit is)
                lo, hi = lo - TWO_PI, hi - TWO_PI
            for part in _within(lo, hi, angle_limit_arc(act.min, act.max)):
                if not any(abs(part[0] - a) < 1e-9 and abs(part[1] - b) < 1e-9 for a, b in found):
                    found.append(part)
    return sorted(found)


def _within(lo: float, hi: float, arc: tuple[float, float] | None) -> list[tuple[float, float]]:
    """The parts of the interval [lo, hi] (rad) on the limits' arc (None: no limits), each
    written as the arc writes it."""
    if arc is None:
        return [(lo, hi)]
    a, b = arc
    out = []
    for k in (-1, 0, 1):
        s, e = max(lo + k * TWO_PI, a), min(hi + k * TWO_PI, b)
        if s < e:
            out.append((s, e))
    return out
