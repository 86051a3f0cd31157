"""The velocities of recorded commands, read and checked as the node reads and checks them.

A ~/command JointState may carry one velocity per name (rad/s, m/s); the node then answers
with every joint's velocity (Engine.command with rates). The replay solves the positions as it
always does (vectorised where it can; rows with and without velocities share a run) and asks
core.velocity for each rated row's rates afterwards, from that row's solution: what the node
computes for the same command.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..core.errors import CommandError
from ..request_checks import rates_error, request_rates
from .reading import Commands


@dataclass(frozen=True)
class RunRates:
    """The velocities of a run of command rows (one message shape), as Engine.command takes
    them: ``columns`` {name: (m,) rad/s or m/s}, NaN on the rows that gave none; ``given``
    (m,) bool, the rows that gave one per name."""

    columns: dict[str, np.ndarray]
    given: np.ndarray

    def row(self, i: int) -> dict[str, float] | None:
        """Row i's rates (None: it gave no velocities)."""
        if not self.given[i]:
            return None
        return {nm: float(col[i]) for nm, col in self.columns.items()}

    def rows(self, i0: int, i1: int) -> RunRates:
        return RunRates({nm: c[i0:i1] for nm, c in self.columns.items()}, self.given[i0:i1])

    def in_scene(self, coords: Any) -> RunRates:
        """In the scene's names (a robot description's JointMap.to_scene of rates)."""
        return replace(self, columns=coords.to_scene(self.columns, rates=True, command=True))

    def holding(self, held: Sequence[str]) -> RunRates:
        """A partial command's held actuators move at 0 (Engine.command)."""
        m = self.given.size
        return replace(self, columns={**self.columns, **{h: np.zeros(m) for h in held}})

    def refusals(self) -> dict[int, str]:
        """Engine.command refuses a command with a rate that is not finite before it solves
        (the state does not change): those rows (0-based) and the node's reason for each."""
        finite = np.ones(self.given.size, bool)
        for col in self.columns.values():
            finite &= np.isfinite(col)
        bad = np.flatnonzero(self.given & ~finite).tolist()
        return {i: str(rates_error(self.row(i))) for i in bad}


def run_rates(
    data: Commands, a: int, b: int, names: Sequence[str]
) -> tuple[RunRates | None, dict[int, str]]:
    """The velocities of command rows a..b-1 (the same names), None if no row has any, and
    the rows (0-based) the node refuses for a velocity count that is not one per name
    (conversions.joint_state_rates), with its reason."""
    counts = data.velocity_counts(a, b)
    if not counts.any():
        return None, {}
    k = len(names)
    refused = {}
    for c in np.unique(counts[(counts != 0) & (counts != k)]).tolist():
        try:
            request_rates(names, [0.0] * c)  # the node's check and its words
        except CommandError as exc:
            refused.update({i: str(exc) for i in np.flatnonzero(counts == c).tolist()})
    given = counts == k
    if not given.any():
        return None, refused
    vel = data.velocities(a, b, k)
    return RunRates({nm: vel[:, j] for j, nm in enumerate(names)}, given), refused


def stretches(refused: np.ndarray) -> list[tuple[int, int]]:
    """The [i0, i1) stretches of rows that are not ``refused`` ((m,) bool)."""
    cuts = [-1, *np.flatnonzero(refused).tolist(), refused.size]
    return [(lo + 1, hi) for lo, hi in zip(cuts[:-1], cuts[1:]) if hi > lo + 1]
