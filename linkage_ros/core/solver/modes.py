"""Every assembly mode of a solve that Newton places (no closed-form plan to enumerate).

A dyad plan lists its modes exactly (each sign combination that closes). Where Newton places the
mechanism, the modes are the real roots of the loop equations, and no finite search is known to
find them all here; so they are searched by Newton from many starts (the link angles spread at
random, seeded, so a run is repeatable), every root found is checked to close the loops within
the solver's closure limit (and, for an inverse solve, the actuator limits), and coincident
roots are one mode. Roots on a continuum of solutions (singular Jacobian: a cell folded flat)
are counted apart. The list says it may be incomplete (``ModeList.complete`` is False).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..model import Mechanism
from .result import Result


class Solver(Protocol):
    """What the mode search reads of a solver (core.solver.Solver; a protocol, so this module
    does not import the solver that imports it)."""

    mech: Mechanism
    system: Any
    plan: Any
    tol: float
    max_iter: int
    closure_limit: float
    inverse: bool
    actuator_specs: list[Any]
    mode: str

    @property
    def branch_count(self) -> int: ...

    def solve(self, values: Mapping[str, Any], commit: bool = True) -> Result: ...

    def parse(self, values: Mapping[str, Any]) -> list[Any]: ...

    def reference_values(self) -> dict[str, Any]: ...

    def limit_violation(self, spec: Any, value: float) -> str | None: ...

    def mode_of(self, result: Result) -> Any: ...

    def _build(self, *args: Any, **kwargs: Any) -> Result: ...


#: Newton starts of the search (the first is the scene's reference pose)
MODE_STARTS = 128
#: a root whose scale-free Jacobian is this ill-conditioned is not an isolated assembly mode but
#: a point of a continuum of solutions (a folded cell, a dyad with coincident centres): such
#: roots are counted, not listed (a regular mode here has a condition number of order 10-1e4)
SINGULAR_MODE_COND = 1e10


@dataclass
class ModeList:
    """Assembly modes found for one command; ``complete`` when they are provably all (a
    closed-form plan's sign combinations), False for a multi-start search."""

    results: list[Result] = field(default_factory=list)
    complete: bool = True
    method: str = 'closed-form dyad plan: every sign combination'
    singular: int = 0  # roots found on a continuum of solutions (not listed)


def mode_key(result: Result, scale: float) -> tuple[float, ...]:
    """Points rounded to 1e-9 of the length scale: coincident modes (at a toggle) share it."""
    return tuple(round(c / scale, 9) for p in sorted(result.points) for c in result.points[p])


def newton_modes(solver: Solver, values: Mapping[str, Any], starts: int = MODE_STARTS) -> ModeList:
    """The modes of ``values`` found by Newton from ``starts`` starts (see the docstring).
    ``solver`` must be a Newton-only solver (every moving link a Newton unknown)."""
    found = ModeList(complete=False, method=f'Newton from {starts} starts: may be incomplete')
    first = solver.solve(values, commit=False)  # the answer nearest the current configuration
    seen: set[tuple[float, ...]] = set()
    scale = solver.mech.length_scale
    if first.success:
        found.results.append(first)
        seen.add(mode_key(first, scale))
    try:
        vals = solver.parse(values)
    except ValueError:
        return found if found.results else ModeList([first], False, found.method)
    system = solver.system
    x_ref = system.reference_x()
    rng = np.random.default_rng(20261125)
    for k in range(starts):
        x0 = x_ref.copy()
        if k:
            x0[0::3] = rng.uniform(-math.pi, math.pi, system.n // 3)
        r = system.solve(x0, vals, tol=solver.tol, max_iter=solver.max_iter, keep_det_sign=False)
        if not r.success:
            continue
        poses, pts = system.configuration(r.x)
        res = solver._build(
            poses,
            pts,
            vals,
            solver='newton',
            iterations=r.iterations,
            signs=(),
            margin=1.0 / max(r.cond, 1.0),
            cond=r.cond,
        )
        if not (res.success and res.residual is not None and res.residual <= solver.closure_limit):
            continue
        if not r.cond < SINGULAR_MODE_COND:
            found.singular += 1
            continue
        if solver.inverse and any(
            solver.limit_violation(s, res.inputs[s.name])
            for s in solver.actuator_specs
            if s.name in res.inputs
        ):
            continue
        key = mode_key(res, scale)
        if key in seen:
            continue
        seen.add(key)
        found.results.append(res)
    if not found.results:
        found.results.append(first)
    return found


#: a dyad margin below which the reference pose is read as drawn at that dyad's toggle
TOGGLE_MARGIN = 1e-9


def reference_toggle_warnings(solver: Solver) -> list[str]:
    """Why the reference pose does not choose an assembly mode, if it does not: each branching
    dyad of ``solver``'s forward plan that the drawing puts at its toggle (a cell drawn folded
    flat, a dyad drawn stretched out), where the two modes meet and the drawing's sign is
    rounding. Empty for a drawing clear of every toggle (or without a closed-form plan)."""
    if solver.mode != 'closed_form' or not solver.branch_count:
        return []
    ref = solver.solve(solver.reference_values(), commit=False)
    mode = solver.mode_of(ref) if ref.success else None
    if mode is None:
        return []
    out = []
    for step, margin in zip(solver.plan.branch_steps, mode[1]):
        if margin < TOGGLE_MARGIN:
            out.append(
                f'the reference pose is at the toggle of {step.describe(solver.plan)} (margin '
                f'{margin:.3g}): its assembly mode there is not chosen by the drawing; draw the '
                'pose off the toggle to choose it'
            )
    return out
