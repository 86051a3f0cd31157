"""The assembly mode a Newton solve is asked for, and the answer it walks on from: the branch
rule's signs read on the whole mechanism's dyad plan (Newton's answers are), and a fold's
margin, below which an answer is in either mode."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..ops import SCALAR
from ..plan.compile import Step
from ..plan.geometry import step_geometry
from ..steps import BranchRule, RRRDyad
from .compiled import CompiledSolve
from .continuity import Continuity, State


def asked_signs(cont: Continuity, full: tuple[int, ...] | None) -> tuple[int, ...] | None:
    """The dyad signs the branch rule asks for (explicit or the reference pose's): ``full``,
    the signs the solve starts from on the whole mechanism's dyad plan (full_plan_signs; None
    where the mechanism has no closed-form plan to read them on), where the rule asks for
    given signs; else None."""
    return full if cont.branch.rule in _SIGNS_ASKED else None


def full_plan_signs(c: CompiledSolve, cont: Continuity) -> tuple[int, ...]:
    """The signs the next solve starts from (Continuity.signs) as signs of the whole
    mechanism's dyad plan, which Newton's answers are read on: continuity's last answer's are
    already; the branch rule's own (explicit, reference) are of ``c.plan``'s dyads, fewer
    where it is pruned to some outputs (CompiledSolve.full_signs)."""
    history = cont.history
    if cont.branch.rule is BranchRule.CONTINUOUS and history:
        signs = tuple(history[-1].signs)
        if len(signs) == len(c.full_plan.branch_steps):
            return signs
    return c.full_signs(cont.signs(c.plan))


def resumed_state(
    c: CompiledSolve, cont: Continuity, asked: tuple[int, ...] | None
) -> State | None:
    """The answer Newton walks on from: the last, unless the mode is asked (``asked``:
    asked_signs) and that answer is on a fold (a drawing on a change point), where it is in
    either mode and a walk from it may take either (start() then starts from the closed
    form's answer in the asked mode)."""
    last = cont.last
    if last is None or last.x_all is None:
        return None
    if asked is not None and last.margins and min(last.margins) <= fold_margin(c):
        return None
    return last


def fold_margin(c: CompiledSolve) -> float:
    """The dyad margin up to which a Newton answer is on a fold (a toggle or change point),
    where its sign is either: there the loop closure's residual grows as the square of the
    distance from the fold, so Newton to ``c.tol`` places a fold's answer only to ~sqrt(tol)
    (a change point's at tol 1e-12: margin ~2e-6). The closed form's own test of a fold
    passed is execute.CROSSING_MARGIN: its answers are exact to rounding."""
    return 10.0 * math.sqrt(c.tol)


def on_fold(
    c: CompiledSolve, step: Step, margin: float, pts: Mapping[str, complex], rot: Mapping[str, Any]
) -> bool:
    """Is a Newton answer on a fold at the branching ``step`` (its ``margin`` read off the
    answer, ``pts`` and ``rot`` its points and link rotations), where its sign is either: the
    margin within fold_margin, and the point that close to the line of its two centres (the
    side step_geometry reads), or the centres one point to Newton's accuracy (fold_margin^2 =
    100 tol of the scale: two circles of one radius there are one circle, every point of it in
    either mode, as a Peaucellier cell folded shut puts A on B). Two circles merely nearly
    concentric (a chain next to a change point, its centres ~1e-8 of the scale apart) have a
    margin near 0 too, while their two points lie far apart, each in its own mode: an answer
    in the other was reported in the asked one (an outside reviewer: 0.46 of the scale away)."""
    fold = fold_margin(c)
    if margin > fold:
        return False
    side, _ = step_geometry(SCALAR, c.full_plan.mech, step, pts, rot)
    if abs(float(side)) <= fold:
        return True
    args = step.args
    if isinstance(args, RRRDyad):
        gap = abs(pts[args.centre_a] - pts[args.centre_b])
        return bool(gap <= fold * fold * c.full_plan.mech.length_scale)
    return False


#: the branch rules that ask for given signs (an answer in another mode is refused)
_SIGNS_ASKED = (BranchRule.EXPLICIT, BranchRule.REFERENCE)
