"""The demo sweep: values of the first actuator so joint states flow without any command."""

from __future__ import annotations

import math

from .core.model import AngleActuator, Mechanism


class DemoSweep:
    """Values of the first actuator for the demo: ping-pong between its limits, else a full turn
    (angle) or +-20 % of the length scale around the start (slide). A failed solve (a value the
    mechanism cannot reach) reverses the direction."""

    STEPS_FULL_TURN = 120
    STEPS_PER_PASS = 60

    def __init__(self, mech: Mechanism, actuator: str, start: float):
        a = mech.actuators[actuator]
        self.name = actuator
        self.value = float(start)
        self.wrap = False
        lo, hi = a.min, a.max
        if lo is not None and hi is not None:
            self.value = min(max(self.value, lo), hi)
        elif isinstance(a, AngleActuator):  # a full turn, wrapped to (-pi, pi]
            self.wrap = True
            self.lo, self.hi = -math.pi, math.pi
            self.step = 2 * math.pi / self.STEPS_FULL_TURN
            return
        else:
            span = 0.2 * mech.length_scale
            lo = self.value - span if lo is None else lo
            hi = self.value + span if hi is None else hi
        self.lo, self.hi = lo, hi
        self.step = (hi - lo) / self.STEPS_PER_PASS

    def next(self) -> float:
        v = self.value + self.step
        if self.wrap:
            v = math.remainder(v, 2 * math.pi)
        elif not self.lo <= v <= self.hi:
            self.step = -self.step
            v = min(max(self.value + self.step, self.lo), self.hi)
        self.value = v
        return v

    def bounce(self, failed: float) -> None:
        """The solve at ``failed`` did not close: go back the other way."""
        self.step = -self.step
        self.value = failed + self.step
