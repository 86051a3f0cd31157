"""The state a solver carries between commands: the previous configurations (continuity and
Newton warm starts) and the branch rule (continuous, reference or explicit signs)."""

from __future__ import annotations

import collections.abc
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import PlanError
from ..execute import CONTINUITY_MARGIN, LinkPoses
from ..ops import BATCH
from ..plan import Plan
from ..steps import Branch as Branch  # re-exported: the solver's vocabulary
from ..steps import BranchRule as BranchRule
from ..steps import read_branch
from .compiled import CompiledSolve, SolveMode, Values

#: the rules as module constants: an enum member's attribute lookup costs ~0.1 us per command
_EXPLICIT, _CONTINUOUS = BranchRule.EXPLICIT, BranchRule.CONTINUOUS


def parse_branch(plan: Plan, branch: Any, newton_labels: bool = False) -> Branch:
    """read_branch's rule, checked against ``plan``: one sign per branching dyad; with
    ``newton_labels`` (a forward solve that Newton places) also 'J+' or 'J-'
    (reading.mode_label); PlanError naming the dyads for anything else."""
    k = len(plan.branch_steps)
    got = read_branch(branch)
    if got is None:
        raise PlanError(
            f"branch must be 'continuous', 'reference' or a string of + and - (got {branch!r})"
        )
    if got.rule is BranchRule.JACOBIAN and not newton_labels:
        raise PlanError(
            f'branch {branch!r} names an assembly mode of a scene Newton places (the sign of '
            "its loop Jacobian's determinant); this solve's modes are "
            + (
                f'the signs of its {k} branching dyad(s), e.g. {"+" * k!r}'
                if k
                else 'not selectable (no branching dyad)'
            )
        )
    if got.rule is BranchRule.EXPLICIT and got.signs is not None and len(got.signs) != k:
        dyads = '; '.join(s.describe(plan) for s in plan.branch_steps)
        raise PlanError(
            f'branch {branch!r} has {len(got.signs)} sign(s) but this solve has '
            + (f'{k} branching dyad(s): {dyads}' if k else 'no branching dyad (no sign to give)')
        )
    return got


@dataclass
class State:
    """A previous configuration: continuity predictions and Newton warm starts start here."""

    values: Values
    x_all: np.ndarray | None  # every moving link (phi, cx, cy), for Newton warm starts
    points: dict[str, complex]
    poses: LinkPoses
    signs: tuple[int, ...]
    det_sign: int
    margins: tuple[float, ...] = ()
    x_lu: tuple[Any, ...] | None = None  # Newton: the kernel's factor of J at x_all (the predictor)


def state_of(
    c: CompiledSolve,
    vals: Values,
    poses: LinkPoses,
    pts: dict[str, complex],
    signs: Sequence[int],
    det_sign: int = 0,
    margins: Sequence[float] = (),
    x_all: np.ndarray | None = None,
    x_lu: tuple[Any, ...] | None = None,
) -> State:
    """The State of a solved configuration (its Newton unknowns read off the poses where a
    Newton solve will start from it and the caller has none)."""
    if (
        x_all is None
        and c.mode is not SolveMode.CLOSED_FORM
        and set(poses.phi) >= set(c.mech.links)
    ):
        x_all = c.check_system.x_from_poses(poses)
    return State(vals, x_all, pts, poses, tuple(signs), det_sign, tuple(margins), x_lu)


@dataclass
class Continuity:
    """A solver's memory: the branch rule and the last one or two answers it committed."""

    branch: Branch = field(default_factory=Branch)
    history: list[State] = field(default_factory=list)

    @property
    def last(self) -> State | None:
        return self.history[-1] if self.history else None

    def commit(self, state: State) -> None:
        last = self.history  # (the last answer and this one, without a slice's list)
        self.history = [last[-1], state] if last else [state]

    def signs(self, plan: Plan) -> tuple[int, ...]:
        """The branch signs the next solve starts from."""
        b = self.branch
        if b.rule is _EXPLICIT and b.signs is not None:
            return b.signs
        if b.rule is _CONTINUOUS and self.history:
            return self.history[-1].signs
        return tuple(plan.reference_signs)

    def prediction(self, c: CompiledSolve, vals: Values) -> Prediction | None:
        """Where continuity expects the next configuration, or None (no history, or a branch
        rule that does not follow the previous answer)."""
        if self.branch.rule is not BranchRule.CONTINUOUS or not self.history:
            return None
        return Prediction(self.history, c, vals)

    def with_branch(self, branch: Branch) -> Continuity:
        """The same history under another branch rule (for a solve that must not commit)."""
        return Continuity(branch, list(self.history))


#: the furthest continuity extrapolates along the previous step (a multiple of it): a command
#: far beyond the last step is predicted no further than this (nearer_for_every_ratio)
MAX_STEP_RATIO = 1.5


# ---- the continuity rule over many rows (linkage bag proves batch rows follow it) --------------
# One command's solve applies it inside the dyad plan (core.execute.PlanExecutor: its
# near_singular test and the nearest-to-``prefer`` choice); these state the same rule on arrays,
# for a caller that must show a batch row gets the sign a single continuous solve would give.


def keeps_sign(margin_now: np.ndarray, margin_prev: np.ndarray, slack: float = 0.0) -> np.ndarray:
    """Where a dyad keeps its previous branch sign whatever continuity predicts: clear of its
    singularity (margin, |sin| of its transmission angle, at or above CONTINUITY_MARGIN) now
    and in the previous configuration, since an assembly mode changes only through that
    singularity. ``slack``: that much clearer (margins computed another way may differ in
    their last bits)."""
    bound = CONTINUITY_MARGIN + slack
    return np.asarray((np.asarray(margin_now) >= bound) & (np.asarray(margin_prev) >= bound))


def predicted_point(last: np.ndarray, prev: np.ndarray, ratio: float) -> np.ndarray:
    """Where continuity expects a point ((n, 2), m): ``last`` extrapolated ``ratio`` times the
    previous step (last - prev); ratio is step_ratio's, in [0, MAX_STEP_RATIO]."""
    return np.asarray(last + ratio * (last - prev))


def nearer_for_every_ratio(
    chosen: np.ndarray,
    other: np.ndarray,
    last: np.ndarray,
    prev: np.ndarray,
    has_prev: np.ndarray,
    slack: float,
) -> np.ndarray:
    """Where a dyad near its singularity takes ``chosen`` rather than ``other`` ((n, 2)
    candidate positions of its point) under the continuity rule, whatever the step ratio: the
    rule takes the candidate nearest the prediction (predicted_point), and ``chosen`` is
    nearer than ``other`` by more than ``slack`` (m) at ratio 0 and, with a previous
    configuration (``has_prev``), at MAX_STEP_RATIO; the difference of the squared distances is
    linear in the ratio, so its two ends decide every ratio between."""

    def gap(target: np.ndarray) -> np.ndarray:
        return np.asarray(_dist(other, target) - _dist(chosen, target))

    good = gap(last) > slack
    far = predicted_point(last, prev, MAX_STEP_RATIO)
    return np.asarray(good & (~np.asarray(has_prev, bool) | (gap(far) > slack)))


def nearer_angle(
    chosen: np.ndarray, other: np.ndarray, last: np.ndarray, slack: float
) -> np.ndarray:
    """The same rule for a dyad placed by a link's angle (an RPR dyad: continuity predicts the
    guide's previous angle, no extrapolation): ``chosen`` (rad) is nearer ``last`` than
    ``other`` by more than ``slack`` (rad), the differences wrapped to (-pi, pi]."""
    return np.asarray(np.abs(BATCH.wrap(other - last)) - np.abs(BATCH.wrap(chosen - last)) > slack)


def _dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = a - b
    return np.asarray(np.hypot(d[:, 0], d[:, 1]))


def step_ratio(c: CompiledSolve, prev_vals: Values, last_vals: Values, vals: Values) -> float:
    """How far the new command goes along the previous step (d_now . d_prev / |d_prev|^2,
    clipped to [0, MAX_STEP_RATIO]): the secant extrapolation factor; 0 when the last step was
    zero."""
    d_prev = c.check_system.value_step(prev_vals, last_vals)
    d_now = c.check_system.value_step(last_vals, vals)
    den = sum(d * d for d in d_prev)
    if not den > 0:
        return 0.0
    return min(max(sum(n * d for n, d in zip(d_now, d_prev)) / den, 0.0), MAX_STEP_RATIO)


class Prediction(collections.abc.Mapping[str, Any]):
    """Where continuity expects each point ({name: complex}) and link angle ({'@link': rad}):
    the previous configuration, extrapolated along the previous step after two commands.
    Computed per key on first use: the dyad plan asks only near a singular dyad, so most
    solves never pay for it."""

    def __init__(self, history: Sequence[State], c: CompiledSolve, vals: Values):
        self._last = history[-1]
        self._prev = history[-2] if len(history) == 2 else None
        self._c, self._vals = c, vals
        self._ratio: float | None = None

    def __getitem__(self, key: str) -> Any:
        last = self._last
        if key[:1] == '@':
            return last.poses.phi[key[1:]]
        v = last.points[key]
        prev = self._prev
        if prev is None or key not in prev.points:
            return v
        if self._ratio is None:
            self._ratio = step_ratio(self._c, prev.values, last.values, self._vals)
        return v + self._ratio * (v - prev.points[key])

    def __contains__(self, key: object) -> bool:
        if isinstance(key, str) and key[:1] == '@':
            return key[1:] in self._last.poses.phi
        return key in self._last.points

    def __iter__(self) -> Iterator[str]:
        yield from self._last.points
        yield from ('@' + l for l in self._last.poses.phi)

    def __len__(self) -> int:
        return len(self._last.points) + len(self._last.poses.phi)
