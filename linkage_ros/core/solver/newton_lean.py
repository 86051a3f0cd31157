"""The warm Newton command on plain floats: newton_path.solve_newton's fast path (prediction from
the last answers, the fast Newton steps, the branch-jump and closed-form checks) by the lean
kernel (newton/lean.py), for a Newton solve whose Jacobian reduces to a 3 x 3 matrix and whose
dyad plan reads every link's branch (the four-bar, the slider-crank).

It answers only where the dense path's fast path would have answered, with the same decisions:
None (nothing changed) wherever that path would do anything else (decline the prediction,
polish, meet a singular J, find a branch jump, run the closed-form check, refuse on the asked
branch); solve_newton then takes the command as before. The answer is the dense path's to
rounding: the same rule on the same residual, the steps solved by the Schur complement instead
of LAPACK's LU (test/core/solver/test_newton_lean.py holds the two paths' Results to each
other over the bench sweeps and to the closed form)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..execute import CONTINUITY_MARGIN
from ..newton.lean import Kernel, LeanSolve, evaluate_lean, lean_from_guess
from ..newton.lean import lean_schur as make_lean_schur
from ..newton.scalar import DenseKernel, extrapolate
from ..plan import branch_geometry_one
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import BranchRule, Continuity, State, state_of
from .newton_result import NewtonSource, newton_result
from .result import Result, branch_identity_defined, branch_text

_NEWTON = SolveMode.NEWTON
#: the rules whose branch a Newton answer must be on (solve_newton refuses it otherwise)
_ASKED = (BranchRule.EXPLICIT, BranchRule.REFERENCE)


class LeanNewton:
    """The lean Newton command of one compiled solve (lean_newton makes it)."""

    def __init__(self, c: CompiledSolve, ls: Kernel):
        self.c, self.ls = c, ls
        self.t = c.system.tables
        self.n_steps = len(c.full_plan.branch_steps)
        self.reference_signs = tuple(c.full_plan.reference_signs)
        self.same_plan = c.full_plan is c.plan
        self.branch_texts: dict[tuple[int, ...], str] = {}

    def factor_of(self, s: State) -> Any:
        """The lean factor at a committed answer: its own, or (a dense path's answer) made
        from J there; None where the dense path would not predict from it."""
        lu = s.x_lu
        if lu is None or s.x_all is None:
            return None
        if isinstance(lu, LeanSolve):
            return lu.factor
        fac = self.ls.factor(evaluate_lean(self.t, s.x_all.tolist(), s.values)[1])
        return fac if fac.sign else None

    def command(self, cont: Continuity, vals: Values) -> tuple[Result, State] | None:
        """solve_newton's answer by the fast path from the predicted guess, or None."""
        c, t, ls = self.c, self.t, self.ls
        history = cont.history
        last = history[-1] if history else None
        if last is None or last.x_all is None or not last.det_sign:
            return None
        f_last = self.factor_of(last)
        if f_last is None:
            return None
        prev = history[-2] if len(history) == 2 else None
        guess = None
        if prev is not None and prev.x_all is not None:
            f_prev = self.factor_of(prev) if prev.x_lu is not None else None
            if prev.x_lu is not None and f_prev is None:
                return None  # (the dense path predicts from a singular J's LU: leave it)
            guess = extrapolate(
                t,
                ls.solve,
                last.x_all.tolist(),
                f_last,
                last.values,
                vals,
                prev.x_all.tolist(),
                prev.values,
                f_prev,
            )
        else:
            guess = extrapolate(t, ls.solve, last.x_all.tolist(), f_last, last.values, vals)
        if guess is None:
            return None
        r = lean_from_guess(
            t, ls, guess, vals, tol=c.tol, max_iter=c.max_iter, start_sign=last.det_sign
        )
        if r is None:
            return None
        x = np.array(r.x)
        poses, pts = c.system.configuration(x)
        got_signs, margins = branch_geometry_one(c.full_plan, pts, poses)
        signs = tuple(got_signs)
        before = (
            (last.signs, last.margins)
            if len(last.margins) == self.n_steps
            else branch_geometry_one(c.full_plan, last.points, last.poses)
        )
        if branch_jump(before, (signs, margins)):
            return None
        rule = cont.branch.rule
        check = cont.signs(c.plan) if self.same_plan else None
        bound = r.cond_bound
        if not bound * bound * r.residual * t.n <= 1e-2:
            return None  # the dense path runs the closed-form check: leave it
        if signs != tuple(check or self.reference_signs):
            return None
        if rule in _ASKED and self.same_plan and signs != tuple(cont.signs(c.plan)):
            return None  # refused on the asked branch by the dense path
        margin = min(margins)
        if not math.isfinite(margin + sum(r.x)):
            return None  # (build_result refuses it)
        # the Result's residual: max|F| / L at the answer, the rows' own largest loop-closure
        # miss (build_result reads the same misses off the poses, to rounding)
        residual = r.residual
        texts = self.branch_texts
        text = texts.get(signs)
        if text is None:
            text = branch_text(signs)
            if len(texts) < 64:  # a handful of modes occur; never grow unbounded
                texts[signs] = text
        res = newton_result(
            NewtonSource(c, poses, pts, vals, t, r.jv),
            residual=residual,
            iterations=r.iterations,
            branch=text,
            branch_defined=bool(branch_identity_defined(margin, residual)),
            margin=margin,
        )
        state = state_of(c, vals, poses, pts, signs, r.factor.sign, margins, x_all=x, x_lu=r)
        return res, state


def branch_jump(ga: tuple[Any, ...], gb: tuple[Any, ...]) -> bool:
    """True when a dyad changed side between two configurations (their branch geometry:
    signs, margins, ...) while far from its singularity: only a jump (not a continuous
    motion) does that."""
    return any(
        a != b and min(p, q) >= CONTINUITY_MARGIN for a, b, p, q in zip(ga[0], gb[0], ga[1], gb[1])
    )


def lean_newton(c: CompiledSolve) -> LeanNewton | None:
    """The lean Newton command of ``c`` where it has one (see the module), made on first use
    and kept on it (as closed_form keeps its readout); None otherwise."""
    if _KEY in c.__dict__:
        known: LeanNewton | None = c.__dict__[_KEY]
        return known
    got: LeanNewton | None = None
    t = c.system.tables
    if (
        c.mode is _NEWTON
        and c.full_plan.complete
        and c.full_plan.branch_steps
        and t.m == t.n
        and t.val_rows is not None
        and not c.mech.rollers  # (Newton holds a roller on its drawn side: solve_newton)
    ):
        kernel: Kernel | None = None
        try:
            tabs = c.system.batch.tables()
            kernel = make_lean_schur(t, tabs.schur, tabs.jv_real.tolist())
        except ValueError:  # (a system the batched tables do not take)
            pass
        got = LeanNewton(c, kernel or DenseKernel(t))
    c.__dict__[_KEY] = got
    return got


_KEY = '_lean_newton'
