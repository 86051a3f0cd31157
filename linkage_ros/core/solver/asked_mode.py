"""The assembly mode a Newton solve is asked for, and the answer it walks on from: the branch
rule's signs read on the whole mechanism's dyad plan (Newton's answers are), and a fold's
margin, below which an answer is in either mode."""

from __future__ import annotations

import math

from ..steps import BranchRule
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


#: the branch rules that ask for given signs (an answer in another mode is refused)
_SIGNS_ASKED = (BranchRule.EXPLICIT, BranchRule.REFERENCE)
