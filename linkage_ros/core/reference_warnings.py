"""Warnings about the reference pose, for every plan kind: a drawing at a toggle or folded flat.

A reference pose drawn where two assembly modes meet (a dyad stretched out or folded, a cell
folded flat) loads, but the drawing does not choose its assembly mode there. For a closed-form
plan :func:`~linkage_ros.core.solver.modes.reference_toggle_warnings` names each branching dyad
at its toggle; here the same is said of any plan: the closed-form dyads of a hybrid plan by their
margins, and the Newton part by the loop-closure Jacobian, singular at such a pose (Peaucellier's
inversor drawn folded flat, OP = a - b, is a hybrid plan whose dyads and Newton loop both fold).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .plan import branch_geometry_one
from .quantities import PointSpec
from .solver.compiled import SolveMode
from .solver.modes import reference_toggle_warnings, toggle_remedy, toggle_warnings
from .solver.result import SIGN_MARGIN, Result
from .velocity import velocities

if TYPE_CHECKING:
    from .solver import Solver

#: a loop-closure Jacobian condition above this at the reference pose: a singular position (the
#: condition grows as 1 / margin toward a toggle; SIGN_MARGIN is the dyads' threshold)
SINGULAR_CONDITION = 1.0 / SIGN_MARGIN


def reference_pose_warnings(solver: Solver) -> list[str]:
    """Why the reference pose does not choose an assembly mode, if it does not, whatever the
    plan: each branching closed-form dyad drawn at its toggle, else a loop-closure Jacobian
    singular there (its condition). Empty for a drawing clear of both, or one that does not
    solve (its solve says why)."""
    values = solver.reference_values()
    ref = solver.solve(values, commit=False)
    passive = _passive_limit_warnings(solver, ref)
    if solver.mode is SolveMode.CLOSED_FORM:
        return reference_toggle_warnings(solver.compiled) + passive
    if not ref.success:
        return []
    out = passive
    got = solver.configuration_of(ref)
    if got is not None and solver.mode is not SolveMode.NEWTON and solver.plan.branch_steps:
        _, margins = branch_geometry_one(solver.plan, *got)
        out += toggle_warnings(solver.plan, margins)
    rates = {s.name: (1.0, 0.0) if isinstance(s, PointSpec) else 1.0 for s in solver.specs}
    v = velocities(solver, ref, values, rates)
    if not v.success or v.cond > SINGULAR_CONDITION:
        out.append(
            f'the reference pose is at a singular position of the loop closure (Jacobian '
            f'condition {v.cond:.3g}: a toggle, or a cell folded flat): its assembly mode there '
            'is not chosen by the drawing; '
            + toggle_remedy(solver.mech.joint_coordinates is not None)
        )
    return out


def _passive_limit_warnings(solver: Solver, ref: Result) -> list[str]:
    """A robot description assembled where a passive joint is beyond its <limit>: every
    command near the drawing is refused for it (Engine.beyond_passive_limits)."""
    coords = solver.mech.joint_coordinates
    if coords is None or not ref.success:
        return []
    why = coords.passive_beyond(ref.joints)
    if why is None:
        return []
    return [
        "the reference pose is beyond a passive joint's limit ("
        + why.removeprefix('the answer puts ')
        + '): commands there are refused; assemble it within the limits (assemble_at in a '
        'closure file)'
    ]
