"""The per-row results of a replay: the core's results table (core.solver.table.ResultTable:
columns, each row's status, refused rows NaN) with what the bag adds per command: which
actuators a partial command held, which it named, and the velocities of the commands that
gave some."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Self

import numpy as np

from ..core.solver.table import ResultTable
from ..core.velocity import Velocities
from ..request_checks import velocity_status


@dataclass(eq=False)  # numpy columns: no field-wise ==
class Results(ResultTable):
    """Per-row answers (n rows), NaN where a row was refused (ResultTable's rule)."""

    held_code: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    #: (n,) bool per actuator: the request named this actuator
    input_given: dict[str, np.ndarray] = field(default_factory=dict)
    #: the status's 'velocity' value of each solved command that gave velocities, by row
    #: ('ok (cond C)' or why there is none: request_checks.status_values' words); empty: no rates
    velocity_note: dict[int, str] = field(default_factory=dict)
    #: the status's 'mode_change' of each target answered in another assembly mode, by row
    #: (a ~/target_any_mode: '+ -> -')
    mode_change: dict[int, str] = field(default_factory=dict)
    #: joint rates (rad/s, m/s; NaN where none) and the rows that have them: allocated by the
    #: first command with velocities (a bag without any costs nothing more)
    joint_rates: dict[str, np.ndarray] = field(default_factory=dict)
    velocity_ok: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    batched: int = 0
    sequential: int = 0
    held_names: list[str] = field(default_factory=lambda: [''])

    @classmethod
    def empty(cls, mech: Any, n: int) -> Self:
        res = cls.for_mechanism(mech, n)
        res.held_code = np.zeros(n, np.int32)  # (n,) index into held_names
        res.input_given = {a: np.zeros(n, bool) for a in mech.actuators}
        return res

    def held_code_of(self, name: str) -> int:
        return self._code(self.held_names, name)

    @property
    def has_rates(self) -> bool:
        """Some solved command gave velocities (the outputs then carry joint rates)."""
        return bool(self.velocity_note)

    def store_velocity(self, g: int, vel: Velocities) -> None:
        """Row g's velocities (core.velocity, as Engine.command answers a command with rates)."""
        if not self.velocity_note:
            n = self.ok.size
            self.joint_rates = {j: np.full(n, np.nan) for j in self.joints}
            self.velocity_ok = np.zeros(n, bool)
        self.velocity_note[g] = velocity_status(vel)
        if vel.success:
            self.velocity_ok[g] = True
            for nm, v in vel.joints.items():
                self.joint_rates[nm][g] = v
