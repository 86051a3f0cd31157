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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..newton.results import SINGULAR_COND
from ..plan import Plan, limit_violation
from ..steps import RollerSide, sign_combinations
from .compiled import CompiledSolve, SolveMode
from .continuity import Branch, BranchRule, Continuity
from .one import solve_one
from .reading import mode_label, mode_of
from .result import SIGN_MARGIN, Result, branch_text

#: Newton starts of the search (the first is the scene's reference pose)
MODE_STARTS = 128


@dataclass
class ModeList:
    """Assembly modes found for one command; ``complete`` when they are provably all (a
    closed-form plan's sign combinations), False for a multi-start search."""

    results: list[Result] = field(default_factory=list)
    complete: bool = True
    method: str = 'closed-form dyad plan: every sign combination'
    singular: int = 0  # roots found on a continuum of solutions (not listed)
    #: the branch the drawing is in (the plan's reference signs; '' without a dyad plan)
    drawn: str = ''
    #: what each branch sign chooses, in order (a dyad's side, a roller's side of its face)
    signs: tuple[str, ...] = ()
    #: each roller (slot with a radius) the plan places: its branch sign's index and drawn side
    rollers: tuple[RollerChoice, ...] = ()

    def roller_sides(self, result: Result) -> dict[str, str]:
        """The side of its face each roller is on in one listed mode: 'left' or 'right' of
        the face's direction ({} where the mode's branch does not say)."""
        if len(result.branch) != len(self.drawn):
            return {}
        return {r.joint: _side_word(result.branch[r.index]) for r in self.rollers}


@dataclass(frozen=True)
class RollerChoice:
    """A roller's side as a branch sign: slot ``joint``, sign ``index`` of the branch text,
    the side it is drawn on ('left' / 'right' of its face's direction)."""

    joint: str
    index: int
    drawn: str


def _side_word(sign: str) -> str:
    return 'left' if sign == '+' else 'right'


def _described(c: CompiledSolve, found: ModeList) -> ModeList:
    """``found`` with what the dyad plan says of its modes: the drawn branch, each sign's
    choice, the rollers' sides."""
    plan = c.plan
    found.drawn = branch_text(plan.reference_signs)
    found.signs = tuple(st.describe(plan) for st in plan.branch_steps)
    found.rollers = tuple(
        RollerChoice(st.args.joint, k, _side_word(branch_text((st.sign,))))
        for k, st in enumerate(plan.branch_steps)
        if isinstance(st.args, RollerSide)
    )
    return found


#: two answers whose points all lie within this fraction of the length scale of each other are
#: one assembly mode (coincident modes at a toggle; one Newton root reached from two starts,
#: which agree only to its convergence, ~1e-12 times the condition number)
SAME_MODE = 1e-6


def same_configuration(a: Result, b: Result, scale: float) -> bool:
    """Whether two answers place every point within SAME_MODE of the length scale."""
    tol = SAME_MODE * scale
    return all(
        abs(a.points[p][0] - q[0]) <= tol and abs(a.points[p][1] - q[1]) <= tol
        for p, q in b.points.items()
        if p in a.points
    )


def _is_new(r: Result, found: list[Result], scale: float) -> bool:
    return not any(same_configuration(r, f, scale) for f in found)


def modes_of(
    c: CompiledSolve,
    cont: Continuity,
    values: Mapping[str, Any],
    newton: CompiledSolve | None = None,
    forward: CompiledSolve | None = None,
) -> ModeList:
    """Every assembly mode of one command (``cont`` is read, never changed): each sign
    combination of the dyad plan that closes; where Newton places the mechanism, the modes a
    multi-start Newton search finds with ``newton`` (a Newton-only compile of the same knowns;
    ``c`` itself in newton mode). Where no dyad plan gives the modes' signs, each answer's
    ``branch`` is the mechanism's mode label as ``forward`` (a forward compile) reads it
    (reading.mode_label: the loop Jacobian's determinant sign, 'J+' or 'J-')."""
    if c.mode is SolveMode.CLOSED_FORM:
        listed = ModeList(closed_form_modes(c, cont, values))
        if not c.inverse or forward is None:
            return _described(c, listed)
        # a target's answers in the mechanism's modes (the forward dyads' signs, as a
        # command's status shows them), not the inverse plan's own signs
        _label_modes(forward, listed.results)
        return _described(forward, listed) if forward.full_plan.complete else listed
    if newton is None or newton.mode is not SolveMode.NEWTON:
        raise ValueError('the modes of a Newton solve need a Newton-only compile of its knowns')
    found = newton_modes(newton, values, cont if newton is c else None)
    if forward is not None:  # each answer labelled with the mechanism's mode
        _label_modes(forward, found.results)
    return found


def _label_modes(forward: CompiledSolve, results: Sequence[Result]) -> None:
    """Each answer's ``branch``: the mechanism's assembly mode there, as ``forward`` (a
    forward compile) reads it (reading.mode_label: the forward dyads' signs, or the loop
    Jacobian's determinant sign where Newton places the mechanism)."""
    for r in results:
        mode = mode_of(forward, r) if r.success else None
        if mode is not None and mode[0]:
            r.branch = mode_label(forward, mode[0])
            r.branch_defined = min(mode[1]) > SIGN_MARGIN


def closed_form_modes(
    c: CompiledSolve, cont: Continuity, values: Mapping[str, Any]
) -> list[Result]:
    """The dyad plan's answer for each sign combination that closes (coincident ones once)."""
    if not c.branch_count:
        return [solve_one(c, cont.with_branch(cont.branch), values, commit=False)]
    out: list[Result] = []
    for combo in sign_combinations(c.branch_count):
        r = solve_one(c, cont.with_branch(Branch(BranchRule.EXPLICIT, combo)), values, commit=False)
        # coincident modes (at a toggle) are one answer
        if r.success and _is_new(r, out, c.mech.length_scale):
            out.append(r)
    return out or [solve_one(c, cont.with_branch(cont.branch), values, commit=False)]


def newton_modes(
    c: CompiledSolve,
    values: Mapping[str, Any],
    cont: Continuity | None = None,
    starts: int = MODE_STARTS,
) -> ModeList:
    """The modes of ``values`` found by Newton from ``starts`` starts (see the docstring).
    ``c`` must be a Newton-only compile (every moving link a Newton unknown); ``cont`` its
    continuity, read and never changed."""
    found = ModeList(complete=False, method=f'Newton from {starts} starts: may be incomplete')
    # the answer nearest the current configuration (the reference one without a history)
    first = solve_one(
        c, cont.with_branch(cont.branch) if cont else Continuity(), values, commit=False
    )
    scale = c.mech.length_scale
    if first.success:
        found.results.append(first)
    try:
        vals = c.parse(values)
    except ValueError:
        return found if found.results else ModeList([first], False, found.method)
    system = c.system
    x_ref = system.reference_x()
    rng = np.random.default_rng(20261125)
    for k in range(starts):
        x0 = x_ref.copy()
        if k:
            x0[0::3] = rng.uniform(-math.pi, math.pi, system.n // 3)
        r = system.solve(x0, vals, tol=c.tol, max_iter=c.max_iter, keep_det_sign=False)
        if not r.success:
            continue
        poses, pts = system.configuration(r.x)
        res = c.build_result(
            poses,
            pts,
            vals,
            solver=SolveMode.NEWTON,
            iterations=r.iterations,
            signs=(),
            margin=1.0 / max(r.cond, 1.0),
            cond=r.cond,
        )
        if not (res.success and res.residual is not None and res.residual <= c.closure_limit):
            continue
        # a root this ill-conditioned (SINGULAR_COND) is no isolated assembly mode but a point
        # of a continuum of solutions (a folded cell, a dyad with coincident centres): counted,
        # not listed (a regular mode here has a condition number of order 10-1e4)
        if not r.cond < SINGULAR_COND:
            found.singular += 1
            continue
        if c.inverse and any(
            limit_violation(s, res.inputs[s.name]) for s in c.actuator_specs if s.name in res.inputs
        ):
            continue
        if _is_new(res, found.results, scale):
            found.results.append(res)
    if not found.results:
        found.results.append(first)
    return found


def reference_toggle_warnings(c: CompiledSolve) -> list[str]:
    """Why the reference pose does not choose an assembly mode, if it does not: each branching
    dyad of the forward plan ``c`` that the drawing puts at its toggle (a cell drawn folded
    flat, a dyad drawn stretched out), where the two modes meet and the drawing's sign is
    rounding. Empty for a drawing clear of every toggle (or without a closed-form plan)."""
    if c.mode is not SolveMode.CLOSED_FORM or not c.branch_count:
        return []
    ref = solve_one(c, Continuity(), c.reference_values(), commit=False)
    mode = mode_of(c, ref) if ref.success else None
    if mode is None:
        return []
    return toggle_warnings(c.plan, mode[1])


def toggle_warnings(plan: Plan, margins: Sequence[float]) -> list[str]:
    """The reference-pose warning of each branching step of ``plan`` whose dyad margin (as
    drawn) is below SIGN_MARGIN, where its branch sign is not the assembly mode: the one wording
    of the closed-form and the hybrid plans."""
    return [
        f'the reference pose is at the toggle of {step.describe(plan)} (margin {margin:.3g}): '
        'its assembly mode there is not chosen by the drawing; '
        + toggle_remedy(plan.mech.joint_coordinates is not None)
        for step, margin in zip(plan.branch_steps, margins)
        if margin < SIGN_MARGIN
    ]


def toggle_remedy(description: bool) -> str:
    """How to choose the assembly mode of a reference pose at a toggle: a scene's drawing is
    redrawn; a robot description's pose is its joints' zeros, which the integrator does not
    redraw (docs/ROBOT_DESCRIPTIONS.md)."""
    if description:
        return (
            'assemble it at other actuated joint values (assemble_at in a closure file) or '
            'choose the mode with the branch setting (--branch, the branch parameter)'
        )
    return 'draw the pose off the toggle to choose it'
