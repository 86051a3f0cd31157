"""The per-row results of a replay (columns of numpy arrays)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.velocity import Velocities
from ..engine import velocity_status

# ---- solving -----------------------------------------------------------------------------------


@dataclass
class Results:
    """Per-row answers (n rows), NaN where a row was refused."""

    ok: np.ndarray
    reason: list
    residual: np.ndarray
    margin: np.ndarray
    branch_code: np.ndarray  # (n,) index into branch_names ('' for refused rows)
    branch_defined: np.ndarray
    iterations: np.ndarray
    cond: np.ndarray
    solver_code: np.ndarray  # (n,) index into solver_names
    held_code: np.ndarray  # (n,) index into held_names: the actuators a partial command held
    inputs: dict[str, np.ndarray]  # solved, or as commanded (NaN too) on refused rows
    input_given: dict[str, np.ndarray]  # (n,) bool: the request named this actuator
    joints: dict[str, np.ndarray]
    points: dict[str, np.ndarray]
    #: the status's 'velocity' value of each solved command that gave velocities, by row
    #: ('ok (cond C)' or why there is none: engine.status_values' words); empty: no rates
    velocity_note: dict[int, str] = field(default_factory=dict)
    #: joint rates (rad/s, m/s; NaN where none) and the rows that have them: allocated by the
    #: first command with velocities (a bag without any costs nothing more)
    joint_rates: dict[str, np.ndarray] = field(default_factory=dict)
    velocity_ok: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    batched: int = 0
    sequential: int = 0
    branch_names: list = field(default_factory=lambda: [''])
    solver_names: list = field(default_factory=lambda: [''])
    held_names: list = field(default_factory=lambda: [''])

    def _code(self, table: list, name: str) -> int:
        try:
            return table.index(name)
        except ValueError:
            table.append(name)
            return len(table) - 1

    def branch_code_of(self, name: str) -> int:
        return self._code(self.branch_names, name)

    def solver_code_of(self, name: str) -> int:
        return self._code(self.solver_names, name)

    def held_code_of(self, name: str) -> int:
        return self._code(self.held_names, name)

    def branch(self, i: int) -> str:
        return self.branch_names[self.branch_code[i]]

    def solver(self, i: int) -> str:
        return self.solver_names[self.solver_code[i]]

    @classmethod
    def empty(cls, mech, n):
        return cls(
            ok=np.zeros(n, bool),
            reason=[None] * n,
            residual=np.full(n, np.nan),
            margin=np.full(n, np.nan),
            branch_code=np.zeros(n, np.int32),
            branch_defined=np.ones(n, bool),
            iterations=np.zeros(n, np.int64),
            cond=np.full(n, np.nan),
            solver_code=np.zeros(n, np.int32),
            held_code=np.zeros(n, np.int32),
            inputs={a: np.full(n, np.nan) for a in mech.actuators},
            input_given={a: np.zeros(n, bool) for a in mech.actuators},
            joints={j: np.full(n, np.nan) for j in mech.joint_names},
            points={p: np.full((n, 2), np.nan) for p in mech.points},
        )

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
