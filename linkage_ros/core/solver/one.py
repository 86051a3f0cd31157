"""One command: checked, solved by the dyad plan or by Newton, checked again, committed."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..plan import needs_beyond_limits, run_one
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import Continuity, State, state_of
from .newton_path import solve_newton
from .result import Result


def solve_one(
    c: CompiledSolve, cont: Continuity, values: Mapping[str, Any], commit: bool = True
) -> Result:
    """Solve one command. On success (and commit) the answer becomes the new 'previous
    configuration' of ``cont``; on failure nothing changes."""
    try:
        vals = c.parse(values)
    except ValueError as exc:
        return Result(False, str(exc), solver=c.mode)
    bad = c.limit_refusal(vals) if c.limited else None
    if bad:
        return c.fail(bad, _given(c, vals, values))
    if c.mode is SolveMode.CLOSED_FORM:
        res, state = solve_closed(c, cont, vals)
    else:
        res, state = solve_newton(c, cont, vals)
    if c.inverse:  # the targets echoed as given (a forward solve's knowns are all inputs)
        given = _given(c, vals, values)
        res.targets = {k: v for k, v in given.items() if k not in c.mech.actuators}
    if not res.success:
        return res
    residual = res.residual if res.residual is not None else 0.0
    if not residual <= c.closure_limit:
        return c.fail(c.closure_reason(residual), _given(c, vals, values), res.solver)
    if c.inverse:
        for s in c.actuator_specs:
            v = res.inputs.get(s.name)
            if v is not None:
                why = needs_beyond_limits(s, v)
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


def solve_closed(c: CompiledSolve, cont: Continuity, vals: Values) -> tuple[Result, State | None]:
    """The dyad plan on one command, on the branch ``cont`` chooses."""
    last = cont.last
    run = run_one(
        c.plan,
        vals,
        cont.signs(c.plan),
        cont.prediction(c, vals),
        prev_margins=last.margins if last is not None else None,
    )
    if not run.ok:
        reason = c.dyad_reason(run.failure, run.violation)
        return c.fail(reason, c.echo(vals), SolveMode.CLOSED_FORM), None
    res = c.build_result(
        run.poses,
        run.points,
        vals,
        solver=SolveMode.CLOSED_FORM,
        iterations=0,
        signs=run.signs,
        margin=run.margin,
    )
    return res, state_of(c, vals, run.poses, run.points, run.signs, margins=run.margins)
