"""Walks with the solver (Newton / hybrid plans, inverse problems with limits)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from ..model import Mechanism
from ..solver import Result, Solver
from ..solver.result import Effort
from .common import ANGLE_TOL, LENGTH_TOL, TWO_PI, without_limits
from .scan import NOWHERE, Bracket, Component, EndKind

#: how walk_range's bisection solves its probes: it reads where the range ends, not why. Near a
#: fold (a toggle, a dead centre) the solution's branch is u^2 = distance to the fold, on which
#: Newton from the accepted side converges to any probe on it: the walk's halvings add nothing
#: there but their cost where the probe is past the fold (a Stephenson six-bar's `linkage check`
#: spent 90 % of its 28 s of CPU in them)
PROBE = Effort.DIRECT

# ---- walks with the solver (Newton / hybrid plans, inverse problems with limits) --------------


def walk_commands(
    solver: Solver,
    command: Callable[[float], dict[str, Any]],
    start: Result,
    x0: float,
    direction: int,
    step: float,
    extent: float,
    tol: float,
    probe: Effort = Effort.FULL,
) -> tuple[float | None, str | None, Result]:
    """Follow a scalar known from x0 in one direction with warm-started, branch-continuous solves
    until a solve is refused, then bisect between the last accepted and the first refused value,
    each probe solved with ``probe``'s effort (Effort.DIRECT: Newton straight from the last
    accepted value, for a caller that reads no reason: a probe past a fold fails in one Newton
    where the continuation walk grinds through its halvings).

    Returns (boundary or None, reason or None, result at the boundary); None when ``extent`` is
    covered without a refusal.
    """
    solver.reset()
    solver.adopt(start)
    x, last = x0, start
    while True:
        done = abs(x - x0)
        if done >= extent * (1 - 1e-15):
            return None, None, last
        xn = x0 + direction * min(done + step, extent)
        r = solver.solve(command(xn))
        if r.success:
            x, last = xn, r
            continue
        good, bad, why = x, xn, r.reason
        while abs(bad - good) > tol:
            mid = 0.5 * (good + bad)
            if mid in (good, bad):
                break
            solver.reset()
            solver.adopt(last)
            rm = solver.solve(command(mid), commit=False, effort=probe)
            if rm.success:
                good, last = mid, rm
            else:
                bad, why = mid, rm.reason
        return good, why, last


def walk_range(
    mech: Mechanism,
    scan: str,
    held: Mapping[str, Any],
    x0: float,
    periodic: bool,
    bracket: Bracket | None = None,
    step: float | None = None,
) -> Component:
    """Range of a known by continuation (when no closed-form plan exists): (lo, hi, lo_end,
    hi_end) or None for a full turn."""
    free = without_limits(mech)
    solver = Solver(free, knowns=[scan] + list(held), branch='continuous', max_iter=200)

    def command(v: float) -> dict[str, Any]:
        return {scan: v, **held}

    start = solver.solve(command(x0), commit=False)
    if not start.success:
        return NOWHERE
    if periodic:
        step = step or math.radians(2.0)
        tol = ANGLE_TOL
        ends = []
        for d in (1, -1):
            b, _, _ = walk_commands(solver, command, start, x0, d, step, TWO_PI, tol, PROBE)
            ends.append(b)
        if ends[0] is None or ends[1] is None:
            return None
        return ends[1], ends[0], (EndKind.TOGGLE, None), (EndKind.TOGGLE, None)
    assert bracket is not None, 'a slide walk needs its bracket'
    blo, bhi, hard_lo, hard_hi = bracket
    step = step or (bhi - blo) / 360.0
    tol = LENGTH_TOL * mech.length_scale
    hi, _, _ = walk_commands(solver, command, start, x0, 1, step, bhi - x0, tol, PROBE)
    lo, _, _ = walk_commands(solver, command, start, x0, -1, step, x0 - blo, tol, PROBE)
    hi_end = (
        (EndKind.TOGGLE, None)
        if hi is not None
        else (EndKind.LIMIT if hard_hi else EndKind.BRACKET, None)
    )
    lo_end = (
        (EndKind.TOGGLE, None)
        if lo is not None
        else (EndKind.LIMIT if hard_lo else EndKind.BRACKET, None)
    )
    return (blo if lo is None else lo), (bhi if hi is None else hi), lo_end, hi_end
