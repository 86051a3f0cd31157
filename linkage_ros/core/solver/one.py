"""One command: checked, solved by the dyad plan or by Newton, checked again, committed."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..plan import needs_beyond_limits
from .closed_form import solve_closed
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import Continuity
from .newton_path import solve_newton
from .result import Effort, Result

_CLOSED_FORM = SolveMode.CLOSED_FORM  # (an enum member's lookup costs ~0.1 us per command)


def solve_one(
    c: CompiledSolve,
    cont: Continuity,
    values: Mapping[str, Any],
    commit: bool = True,
    effort: Effort = Effort.FULL,
    within_limits: bool = True,
) -> Result:
    """Solve one command. On success (and commit) the answer becomes the new 'previous
    configuration' of ``cont``; on failure nothing changes (``effort``: Solver.solve's).
    ``within_limits`` False: the limits are not checked (the target rule asks where a target
    refused as not assembling would be without them, to name the limits that stop it)."""
    try:
        vals = c.parse(values)
    except ValueError as exc:
        return Result(False, str(exc), solver=c.mode)
    bad = c.limit_refusal(vals) if c.limited and within_limits else None
    if bad:
        return c.fail(bad, _given(c, vals, values))
    if c.mode is _CLOSED_FORM:
        res, state = solve_closed(c, cont, vals)
    else:
        res, state = solve_newton(c, cont, vals, effort)
    if c.inverse:  # the targets echoed as given (a forward solve's knowns are all inputs)
        given = _given(c, vals, values)
        res.targets = {k: v for k, v in given.items() if k not in c.mech.actuators}
    if not res.success:
        return res
    residual = res.residual if res.residual is not None else 0.0
    if not residual <= c.closure_limit:
        return c.fail(c.closure_reason(residual), _given(c, vals, values), res.solver)
    if c.inverse and within_limits:
        why = needs_beyond_limits(
            (s, v) for s in c.actuator_specs if (v := res.inputs.get(s.name)) is not None
        )
        if why:
            return c.fail(why, given, solver=res.solver)
    if commit and state is not None:
        cont.commit(state)
    return res


def _given(c: CompiledSolve, vals: Values, values: Mapping[str, Any]) -> dict[str, Any]:
    """The command as a Result echoes it: two points of one link as given, not as an angle."""
    given = c.echo(vals)
    for pair in c.point_pairs:
        del given[pair.link_known]
        given[pair.second] = [float(v) for v in values[pair.second]]
    return given
