"""The Newton path of a solve (Newton alone, or the hybrid remainder the dyad plan cannot place):
warm start, continuation with branch checks, a careful fallback.

A Newton solve's prediction and fast path run on the compiled solve's kernel (newton_kernel:
lean.LeanSchur, plain floats, where J reduces to a 3 x 3; else scalar.DenseKernel, LAPACK's LU),
whose factor at each answer the State keeps for the next prediction (a Linearisation: with the Schur
kernel also the tangent dx/dvalue there, solved once rather than by each of the next two
predictions); the walk (careful path) stays on the dense J. Its decisions read one definition each,
whatever the kernel: ``cond`` is the condition number finish() reports (LAPACK's 1-norm estimate off
the dense J, scalar.cond_of), decided by the kernel's upper bound of it where that settles the
question; the Result's residual is the assembler's (build_result's) metric, read as max|F| / L over
the Newton rows at the answer where those are all the closures it reads (SolveResult.residual: the
rows of a Newton solve are every joint's and known's closure, as the assembler reads them off the
poses; a hybrid solve's residual is the assembler's)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ..execute import CONTINUITY_MARGIN, LinkPoses
from ..newton.lean import Kernel, LeanSchur, evaluate_lean, lean_schur
from ..newton.predictor import extrapolate, unit_tangent, value_step
from ..newton.results import SolveResult
from ..newton.scalar import DenseKernel, cond_of, solve_from_guess
from ..plan import branch_geometry_one, rollers_off_drawn_side, run_one
from ..quantities import AngleSpec
from ..steps import RollerSide
from .asked_mode import asked_signs, full_plan_signs, on_fold, resumed_state
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import BranchRule, Continuity, State, state_of
from .crossing import interpolate
from .newton_result import NewtonSource, newton_result
from .reading import jacobian_sign, mode_label
from .result import (
    CLOSURE_LIMIT,
    KANTOROVICH_BOUND,
    MAX_HALVINGS,
    NEAR_SINGULAR_COND,
    WALK_BUDGET,
    Effort,
    Result,
    answer_branch,
    branch_text,
)

#: what a configuration's branch geometry is: (signs, margins, poses, points)
Geometry = tuple[tuple[int, ...], Sequence[float], LinkPoses, dict[str, complex]]


def newton_at(
    c: CompiledSolve,
    vals: Values,
    x0: np.ndarray,
    start_sign: int | None = None,
    closed_signs: Sequence[int] | None = None,
) -> tuple[SolveResult | None, str | None, LinkPoses | None]:
    """Newton (with the closed-form part placed first in hybrid mode, in ``closed_signs``)
    from x0 at vals."""
    fixed, reason = c.fixed_poses(vals, closed_signs)
    if reason:
        return None, reason, None
    r = c.system.solve(x0, vals, fixed, tol=c.tol, max_iter=c.max_iter, start_sign=start_sign)
    return r, None, fixed


def newton_kernel(c: CompiledSolve) -> Kernel | None:
    """The linear algebra of ``c``'s prediction and fast path: lean.LeanSchur where its J
    reduces to a 3 x 3, else scalar.DenseKernel; None where it predicts nothing (hybrid mode,
    a non-square J, a value without a row). Made on first use and kept on ``c``."""
    if _KERNEL in c.derived:
        known: Kernel | None = c.derived[_KERNEL]
        return known
    got: Kernel | None = None
    t = c.system.tables
    if c.mode is SolveMode.NEWTON and t.n and t.m == t.n and t.val_rows is not None:
        try:
            tabs = c.system.batch.tables()
            got = lean_schur(t, tabs.schur, tabs.jv_real.tolist())
        except ValueError:  # (a system the batched tables do not take)
            pass
        if got is None:
            got = DenseKernel(t)
    c.derived[_KERNEL] = got
    return got


_KERNEL = 'newton_kernel'


class Linearisation(NamedTuple):
    """What a Newton answer leaves the next command's prediction (State.x_lu): its unknowns as
    floats (State.x_all's, as the predictor reads them), the kernel's factor of J there,
    predictor.unit_tangent there (None: values of more than one component), and the value step
    that led to it (predictor.value_step from ``step_from``, the values of the answer before, to
    its own): computed once, each read by the next two predictions."""

    x: list[float]
    factor: Any
    unit: list[float] | None
    step_from: Values | None
    step: list[float] | None


def start(
    c: CompiledSolve,
    cont: Continuity,
    vals: Values,
    kernel: Kernel | None,
    last: State | None,
    asked: tuple[int, ...] | None,
) -> tuple[Values, np.ndarray, list[float] | None, list[float] | None]:
    """Warm start (values, x): the resumed answer ``last`` (resumed_state); else, where the
    mode is asked (``asked``: asked_signs), the dyad plan's answer in it at ``vals`` or at the
    reference input; else the reference pose (a Jacobian mode's start, for a J+ / J- branch).
    Then the predicted solution at ``vals`` (newton mode, after a Newton solve:
    predictor.extrapolate by ``kernel`` from the Linearisations the States keep) and the value
    step it predicted over."""
    if last is not None and last.x_all is not None:
        guess = h = None
        lin = last.x_lu
        if isinstance(lin, Linearisation) and kernel is not None:
            t = c.system.tables
            h = value_step(t, last.values, vals)
            prev = cont.history[-2] if len(cont.history) == 2 else None
            if prev is not None and prev.x_all is not None:
                before = prev.x_lu if isinstance(prev.x_lu, Linearisation) else None
                guess = extrapolate(
                    t,
                    kernel.solve,
                    lin.x,
                    lin.factor,
                    last.values,
                    vals,
                    prev.x_all.tolist() if before is None else before.x,
                    prev.values,
                    None if before is None else before.factor,
                    h=h,
                    hp=lin.step if lin.step_from is prev.values else None,
                    unit_last=lin.unit,
                    unit_prev=None if before is None else before.unit,
                )
            else:
                guess = extrapolate(
                    t, kernel.solve, lin.x, lin.factor, last.values, vals,
                    h=h, unit_last=lin.unit,
                )  # fmt: skip
        return last.values, c.sub_x(last.x_all), guess, h
    x_all = c.check_system.reference_x()
    if asked is not None:
        # the asked mode, where the dyad plan has it: its answer at this command (a drawing
        # on a change point is in both modes, and Newton from it may take either), else at
        # the reference input (another mode than the drawing's)
        for at in (vals, list(c.ref_values)):
            run = run_one(c.full_plan, at, asked, None)
            if run.ok:
                return at, c.sub_x(c.check_system.x_from_poses(run.poses)), None, None
    if cont.branch.rule is BranchRule.JACOBIAN and cont.branch.det_sign is not None:
        x_all = jacobian_mode_start(c, cont.branch.det_sign, x_all)
    return list(c.ref_values), c.sub_x(x_all), None, None


#: Newton starts tried for a configuration in a requested Jacobian mode
JACOBIAN_MODE_STARTS = 64


def jacobian_mode_root(
    c: CompiledSolve, det_sign: int, vals: Values, x_near: np.ndarray
) -> SolveResult | None:
    """A configuration at ``vals`` (over every moving link: ``c.check_system``) whose loop
    Jacobian has the determinant sign ``det_sign``: Newton from ``x_near``, then from starts
    with the link angles spread at random (seeded: repeatable), the root nearest ``x_near``
    of the first few found; None if no start reaches one."""
    cs = c.check_system
    rng = np.random.default_rng(20261126)
    found: list[SolveResult] = []
    for k in range(JACOBIAN_MODE_STARTS):
        x0 = x_near.copy()
        if k:
            x0[0::3] = rng.uniform(-math.pi, math.pi, cs.n // 3)
        r = cs.solve(x0, vals, tol=c.tol, max_iter=c.max_iter, keep_det_sign=False)
        if r.success and r.det_sign == det_sign:
            found.append(r)
            if len(found) == 4:
                break
    if not found:
        return None
    return min(found, key=lambda r: float(np.sum((r.x - x_near) ** 2)))


def jacobian_mode_start(c: CompiledSolve, det_sign: int, x_ref: np.ndarray) -> np.ndarray:
    """A configuration at the reference input in the Jacobian mode ``det_sign`` (see
    jacobian_mode_root); the reference pose if it is in it or none is found."""
    cs, vals = c.check_system, list(c.ref_values)
    if cs.start_sign(x_ref, vals) == det_sign:
        return x_ref
    r = jacobian_mode_root(c, det_sign, vals, x_ref)
    return x_ref if r is None else r.x


def refusal_at(
    c: CompiledSolve,
    vals: Values,
    x0: np.ndarray,
    walk_reason: str | None,
    closed_signs: Sequence[int] | None = None,
) -> str:
    """Why the input ``vals`` was not reached, with the closure miss at that input: the walk's
    own reason is about the last input part-way to it that it tried (a dyad missing by
    1e-8 m just past the edge of reach, Newton stalling with a small residual there), not
    about the input asked for."""
    fixed, closed_reason = c.fixed_poses(vals, closed_signs)
    if closed_reason is not None:
        return closed_reason  # the closed-form part, at the input asked for
    L = c.mech.length_scale
    miss = c.system.least_miss(x0, vals, fixed)
    walked = f'; continuation from the current configuration stopped: {walk_reason}'
    if math.isinf(miss):
        return (
            'cannot assemble at this input: its loop-closure equations overflow (a value '
            f'near the largest double){walked}'
        )
    if not miss <= max(CLOSURE_LIMIT, 10 * c.tol) * L:
        # a least-squares search from one start finds a nearest configuration, not every one:
        # a mechanism Newton places may close in another assembly mode far from it (a triad
        # just past its drawn circuit's toggle does), so this is no proof that none closes
        return (
            f'no assembly near the current configuration at this input: the nearest '
            f'configuration found from it misses closing by {miss:.6g} m ({miss / L:.3g} of the '
            f'length scale); other assembly modes, if any, are listed by the all-branches '
            f'search{walked}'
        )
    return (
        'this input assembles, but not from the current configuration on its branch '
        f'(a least-squares configuration closes it to {miss / L:.3g} of the length scale)' + walked
    )


def _unexplained(walk_reason: str | None) -> str:
    """A refusal by less than Effort.FULL: the walk's own reason, about the last input it
    tried, not measured at the input asked for."""
    return f'not reached from the current configuration: {walk_reason}'


def branch_of(c: CompiledSolve, x: np.ndarray | list[float], fixed: LinkPoses | None) -> Geometry:
    """(signs, margins, poses, points) of configuration x (an array, or its list of floats):
    its dyads' sides and margins."""
    poses, pts = c.system.configuration(x, fixed)
    return (*branch_geometry_one(c.full_plan, pts, poses), poses, pts)


def near_singular(c: CompiledSolve, x: np.ndarray, fixed: LinkPoses | None, values: Values) -> bool:
    """A dyad of the configuration is near its singular (tangent) position, or, without a
    dyad plan to read that from, the Jacobian is ill-conditioned."""
    if c.full_plan.complete and c.full_plan.branch_steps:
        return min(branch_of(c, x, fixed)[1]) < CONTINUITY_MARGIN
    J = c.system.evaluate(x, values, fixed)[1]
    return c.system.scaled_cond(J) > NEAR_SINGULAR_COND


def branch_jump(ga: Geometry, gb: Geometry) -> bool:
    """True when a dyad changed side between two configurations (branch_of: their geometry) while
    far from its singularity: only a jump (not a continuous motion) does that."""
    for a, b, p, q in zip(ga[0], gb[0], ga[1], gb[1]):  # (a loop: any() of a generator costs more)
        if a != b and min(p, q) >= CONTINUITY_MARGIN:
            return True
    return False


def roller_side_refusal(c: CompiledSolve, cont: Continuity) -> str | None:
    """Why Newton cannot solve from here, if a roller is to be on the side of its face that is
    not drawn (an explicit branch, or the configuration continuity starts from): Newton's loop
    equations hold each roller on its drawn side, so it would flip the roller through its
    face (or grind and fail). None where every roller is on its drawn side."""
    if not c.mech.rollers:
        return None
    plan, last = c.full_plan, cont.last
    flipped: list[str] = []
    where = 'is asked to be'  # by the branch
    if cont.branch.rule is BranchRule.EXPLICIT and cont.branch.signs and plan is c.plan:
        flipped = [
            st.args.joint
            for st, want, drawn in zip(
                plan.branch_steps, cont.branch.signs, plan.reference_signs, strict=True
            )
            if isinstance(st.args, RollerSide) and want != drawn
        ]
    elif cont.branch.rule is BranchRule.CONTINUOUS and last is not None:
        flipped = rollers_off_drawn_side(c.mech, last.points, last.poses)
        where = 'is'  # in the configuration continuity starts from
    if not flipped:
        return None
    return (
        f'the roller of slot {flipped[0]!r} {where} on the side of its face it is not drawn on; '
        'Newton solves a roller on its drawn side only and cannot move it through its face: '
        'solve this in closed form (solver closed_form), or take the drawn side (branch)'
    )


def closed_part_signs(c: CompiledSolve, last: State | None) -> tuple[int, ...] | None:
    """Hybrid mode: the signs of the closed-form part's dyads in the configuration a solve
    resumes from (None: no history, or another mode: the reference pose's). That part was
    always placed in the drawing's signs, so a target's hybrid solver could not continue from
    a configuration with a dyad of it on the other side: a landing gear's inverse solve (its
    brace's knee placed by a dyad) snapped back over centre at the next target, and under a
    branch setting a trajectory was refused at its second point (an integrator)."""
    if c.mode is not SolveMode.HYBRID or last is None or not c.full_plan.branch_steps:
        return None
    signs = branch_geometry_one(c.full_plan, last.points, last.poses)[0]
    return tuple(signs) if all(s in (-1, 1) for s in signs) else None


def resumed_geometry(c: CompiledSolve, last: State) -> Geometry:
    """The branch geometry of the configuration a warm solve starts from, the previous answer:
    its points and poses are known, and a Newton answer (x_lu set) also left its dyads' sides
    and margins (full plan: see solve_newton's end)."""
    if last.x_lu is not None and len(last.margins) == len(c.full_plan.branch_steps):
        return last.signs, last.margins, last.poses, last.points
    return (*branch_geometry_one(c.full_plan, last.points, last.poses), last.poses, last.points)


class CarefulPath:
    """The careful path of one command: continuation by halving the value step, each substep a
    Newton solve guarded by det J's sign and by the dyads' sides (branch_jump), with the
    iterations it spends. Made only where the fast path declined; its walk recurses on plain
    methods (a recursive closure would be a reference cycle the garbage collector collects)."""

    __slots__ = ('c', 'branches', 'iterations', 'since_progress', 'seen', 'halvings', 'closed')

    def __init__(
        self,
        c: CompiledSolve,
        branches: bool,
        iterations: int,
        halvings: int,
        closed_signs: Sequence[int] | None = None,
    ):
        self.c, self.branches = c, branches
        self.closed = closed_signs  # hybrid mode: the closed-form part's dyad signs
        self.halvings = halvings  # how deep the walk halves the step
        self.iterations = iterations  # every Newton iteration of the command
        self.since_progress = 0  # iterations since the last substep that succeeded
        #: branch geometry of the configurations met, by id (the array kept: ids stay unique)
        self.seen: dict[int, tuple[np.ndarray, Geometry]] = {}

    def know(self, x: np.ndarray, geo: Geometry) -> None:
        """The branch geometry of ``x`` is ``geo`` (read elsewhere: not read again)."""
        self.seen[id(x)] = (x, geo)

    def geometry(self, x: np.ndarray, fixed: LinkPoses | None) -> Geometry:
        g = self.seen.get(id(x))
        if g is None or g[0] is not x:
            g = self.seen[id(x)] = (x, branch_of(self.c, x, fixed))
        return g[1]

    def jump(
        self, xa: np.ndarray, fixed_a: LinkPoses | None, xb: np.ndarray, fixed_b: LinkPoses | None
    ) -> bool:
        return self.branches and branch_jump(self.geometry(xa, fixed_a), self.geometry(xb, fixed_b))

    def walk(
        self, va: Values, xa: np.ndarray, vb: Values, depth: int, sign_a: int | None = None
    ) -> tuple[SolveResult | None, str | None, LinkPoses | None]:
        """Newton from the solution xa at va to vb, halving the step where it fails: (answer,
        None, its fixed poses) or (None, why, None)."""
        c = self.c
        fixed_a = c.fixed_poses(va, self.closed)[0]
        if sign_a is None:  # det J sign at the start; 0 where it is singular
            sign_a = c.system.start_sign(xa, va, fixed_a)
        r, reason, fixed = newton_at(c, vb, xa, sign_a, self.closed)
        jumped = False
        if r is not None:
            self.iterations += r.iterations
            self.since_progress += r.iterations
            if r.success and (sign_a == 0 or r.det_sign == sign_a or r.det_sign == 0):
                # det J keeps its sign when two dyads flip together: compare dyad sides too
                jumped = self.jump(xa, fixed_a, r.x, fixed)
                if not jumped:
                    self.since_progress = 0
                    return r, None, fixed
            if sign_a != 0 and near_singular(c, xa, fixed_a, va):
                # det J may change sign only by passing a singular configuration, and one is
                # near: step without the sign guard, keep it if no dyad jumped sides
                r2, _, fixed2 = newton_at(c, vb, xa, 0, self.closed)  # (placed as r was)
                self.iterations += r2.iterations if r2 is not None else 0
                if r2 is not None and r2.success and not self.jump(xa, fixed_a, r2.x, fixed2):
                    self.since_progress = 0
                    return r2, None, fixed2
        if depth >= self.halvings or self.since_progress > WALK_BUDGET * c.max_iter:
            if r is None:
                return None, reason, None
            if jumped:
                return (
                    None,
                    (
                        'Newton could only reach this input in another assembly mode '
                        '(a branch jump): it is not reachable on the current branch '
                        'without crossing a singularity'
                    ),
                    None,
                )
            why: str | None = r.reason or (
                'the sign of det J changed: a singularity (toggle or change '
                'point) lies between the previous configuration and this input'
            )
            return None, why, None
        vm = interpolate(c, va, vb, 0.5)
        rm, why, fm = self.walk(va, xa, vm, depth + 1, sign_a)
        if rm is None:
            return None, why, None
        return self.walk(vm, rm.x, vb, depth + 1, rm.det_sign)


def the_long_way(c: CompiledSolve, start: Values, end: Values) -> Values | None:
    """The midpoint between two commands with every angle that changes taken the long way
    round (interpolate's short-way midpoint turned by pi), or None where no angle changes."""
    mid = interpolate(c, start, end, 0.5)
    turned = False
    for k, (s, a, b) in enumerate(zip(c.specs, start, end)):
        if (
            isinstance(s, AngleSpec)
            and abs(math.remainder(float(b) - float(a), 2 * math.pi)) > 1e-9
        ):
            mid[k] = float(mid[k]) + math.pi
            turned = True
    return mid if turned else None


def closed_form_refusal(
    c: CompiledSolve, vals: Values, check_signs: Sequence[int] | None, solver_name: str
) -> Result | None:
    """An input the closed form cannot assemble on the current branch cannot be reached by
    continuation either: refuse at once (Newton would grind to its caps first)."""
    if not c.full_plan.complete:
        return None
    run = run_one(c.full_plan, vals, check_signs, None)
    if run.ok:
        return None
    reason = c.dyad_reason(run.failure, run.violation, c.full_plan)
    return c.fail(reason, c.echo(vals), solver_name)


def solve_newton(
    c: CompiledSolve, cont: Continuity, vals: Values, effort: Effort = Effort.FULL
) -> tuple[Result, State | None]:
    """One command by Newton (continuation from the last answer, branch checks), as hard as
    ``effort`` says (result.Effort)."""
    newton_mode = c.mode is SolveMode.NEWTON  # (else hybrid)
    solver_name = 'newton' if newton_mode else 'hybrid'
    # the closed form's branch signs for the check below (reference ones without a history)
    check_signs = full_plan_signs(c, cont) if c.full_plan.complete else None
    side = roller_side_refusal(c, cont)
    if side is not None:
        return c.fail(side, c.echo(vals), solver_name), None
    kernel = newton_kernel(c)
    t = c.system.tables
    want = asked_signs(cont, check_signs)
    last = resumed_state(c, cont, want)
    v0, x0, guess, step = start(c, cont, vals, kernel, last, want)
    iterations = 0
    branches = bool(c.full_plan.complete and c.full_plan.branch_steps)
    warm = last is not None and last.x_all is not None
    known = last.det_sign if last is not None and warm and last.det_sign != 0 else None
    closed = closed_part_signs(c, last)
    r: SolveResult | None = None
    xs: list[float] = []  # r.x as floats, read once (set with r on the fast path)
    fixed: LinkPoses | None = None
    geo: Geometry | None = None  # the answer's branch geometry, read once
    if guess is not None and known is not None and last is not None:
        # newton mode: the fast path from the predicted solution, kept if no dyad jumped sides
        rf = solve_from_guess(
            t, guess, vals, None, tol=c.tol, max_iter=c.max_iter, start_sign=known, kernel=kernel
        )
        iterations += rf.iterations
        if rf.success:
            xs = rf.x.tolist()
            if not branches:
                r = rf
            else:
                geo = branch_of(c, xs, None)
                if branch_jump(resumed_geometry(c, last), geo):
                    geo = None
                else:
                    r = rf
    # the closed-form check is skipped only where it must pass: the answer is on the
    # check's branch and well-conditioned enough for its residual (cond^2 residual n small:
    # Newton-Kantorovich) that an exact assembly on that branch lies next to it (cond: the
    # reported one, cond_of; the kernel's bound of it decides where it suffices)
    n = c.system.n
    if (
        r is None
        or not (
            r.cond_bound * r.cond_bound * r.residual * n <= KANTOROVICH_BOUND
            or cond_of(t, r) * cond_of(t, r) * r.residual * n <= KANTOROVICH_BOUND
        )
        or (geo is not None and tuple(geo[0]) != tuple(check_signs or c.full_plan.reference_signs))
    ):
        bad = closed_form_refusal(c, vals, check_signs, solver_name)
        if bad is not None:
            return bad, None
    reason: str | None = None
    whole: SolveResult | None = None  # a root over every moving link (check_system's)
    if r is None:
        halvings = 0 if effort is Effort.DIRECT else MAX_HALVINGS
        path = CarefulPath(c, branches, iterations, halvings, closed)
        if branches and warm and last is not None:
            path.know(x0, resumed_geometry(c, last))
        r, reason, fixed = path.walk(v0, x0, vals, 0, known)
        iterations = path.iterations
        around = the_long_way(c, v0, vals) if r is None and effort is Effort.FULL else None
        if around is not None:
            # the short way round from the last answer may cross where the mechanism does
            # not assemble (a non-Grashof crank from -2.2 to 2.0 rad past +-pi): its crank
            # turns the other way, through the long way's midpoint (each half of it shorter
            # than a half turn, so the walk's short ways follow it)
            path = CarefulPath(c, branches, iterations, MAX_HALVINGS, closed)
            if branches and warm and last is not None:
                path.know(x0, resumed_geometry(c, last))
            rm, _, _ = path.walk(v0, x0, around, 0, known)
            if rm is not None:
                r, _, fixed = path.walk(around, rm.x, vals, 0, rm.det_sign)
            iterations = path.iterations
        if r is None and c.full_plan.complete:
            # the walk stalled where the closed form assembles this input on the branch (next
            # to a toggle of a chain near a change point, Newton from the last answer may crawl
            # at a nearly singular J: an outside reviewer's four-bar 1, 1, 1, 1.001): Newton
            # from the closed form's answer in the branch's signs, as a start without history
            run = run_one(c.full_plan, vals, check_signs, None)
            if run.ok:
                path = CarefulPath(c, branches, iterations, 0)
                r, _, fixed = path.walk(
                    vals, c.sub_x(c.check_system.x_from_poses(run.poses)), vals, 0
                )
                iterations = path.iterations
        want_det = cont.branch.det_sign
        if (
            r is None
            and effort is Effort.FULL
            and not c.inverse
            and not c.full_plan.complete
            and cont.branch.rule is BranchRule.JACOBIAN
            and want_det is not None
        ):
            # a mode a branch setting names reaches this input on another stretch of the
            # circuit than the walk's, past a toggle of the input (a Stephenson-III six-bar
            # driven at its output: J+ at drive 3.65 lies beyond the drawing's turning point,
            # and --branch J+ was refused where --all-branches lists it): its root nearest
            # where the mechanism is
            near = last.x_all if last is not None and last.x_all is not None else None
            alt = jacobian_mode_root(
                c, want_det, vals, c.check_system.reference_x() if near is None else near
            )
            if alt is not None:  # (over every moving link: read as the mode check reads it)
                r, whole = alt, alt
                iterations += alt.iterations
        if r is not None and whole is None:
            xs = r.x.tolist()
            if branches:
                geo = path.geometry(r.x, fixed)
    if r is None:
        why = (
            refusal_at(c, vals, x0, reason, closed)
            if effort is Effort.FULL
            else _unexplained(reason)
        )
        res = c.fail(why, c.echo(vals), solver_name)
        res.iterations = iterations
        return res, None
    signs_t: tuple[int, ...]
    margins: Sequence[float]
    if whole is not None:
        xs = whole.x.tolist()
        poses, pts = c.check_system.configuration(whole.x)
        signs_t, margins = (), ()
    elif geo is not None:
        signs_t, margins, poses, pts = geo
    else:
        poses, pts = c.system.configuration(xs, fixed)
        signs_t, margins = (
            branch_geometry_one(c.full_plan, pts, poses) if c.full_plan.complete else ((), [])
        )
    if want is not None:
        if signs_t != want and all(
            s == w or on_fold(c, st, m, pts, poses.rot)
            for s, w, m, st in zip(signs_t, want, margins, c.full_plan.branch_steps)
        ):
            signs_t = want  # (on a fold: this configuration is in either mode, as Newton has it)
        if signs_t != want and last is not None:
            # the walk from the last answer ended in another mode (across a near-fold, where
            # the modes pass close): the asked mode's answer from the closed form's in it (no
            # history: start() takes it; once, as that walk has no last answer)
            res, state = solve_newton(c, Continuity(cont.branch), vals, effort)
            res.iterations += iterations
            return res, state
        if signs_t != want:
            return c.fail(
                f'Newton converged to assembly mode {branch_text(signs_t)}, not the '
                f'requested {branch_text(want)}: the input is not reachable on '
                'that branch from the start configuration without crossing a '
                'singularity',
                c.echo(vals),
                solver_name,
            ), None
    label = None
    if not c.inverse and not c.full_plan.complete:
        # a forward solve that Newton places: its mode is the loop Jacobian's determinant sign
        det = jacobian_sign(c, poses)
        want_det = cont.branch.det_sign
        if cont.branch.rule is BranchRule.JACOBIAN and want_det is not None and det != want_det:
            # the continuation ended in the other mode: the root in the requested one
            x_all = c.check_system.x_from_poses(poses)
            alt = jacobian_mode_root(c, want_det, vals, x_all)
            if alt is None:
                return c.fail(
                    f'Newton converged to assembly mode {mode_label(c, (det,)) if det else "J0"}'
                    f', not the requested {mode_label(c, (want_det,))}, and no root in that mode '
                    f'was found from {JACOBIAN_MODE_STARTS} starts',
                    c.echo(vals),
                    solver_name,
                ), None
            iterations += alt.iterations
            r, det, xs = alt, want_det, alt.x.tolist()
            poses, pts = c.check_system.configuration(alt.x)
        label = mode_label(c, (det,)) if det else ''
    margin = min(margins) if margins else 1.0 / max(cond_of(t, r), 1.0)
    src = NewtonSource(c, poses, pts, vals, t, r)
    # the residual: the assembler's (the largest loop-closure component over every joint and
    # known whose links are placed, / L); in newton mode those are exactly the Newton rows, so
    # it is their max|F| / L at the answer; in hybrid mode the rows are a part: read them all
    residual = r.residual if newton_mode else src.assembly().residual
    # (the points are functions of x and the closed form's finite poses: finite with x; the
    # one sum may overflow only at ~1e308 length scales, where every value is looked at)
    if not math.isfinite(margin + residual + sum(xs)) and not all(
        map(math.isfinite, [margin, residual, *xs])
    ):
        return c.fail(
            'internal error: non-finite value in the solution', c.echo(vals), solver_name
        ), None
    branch, defined = answer_branch(signs_t, label, margin, residual)
    res = newton_result(
        src,
        solver=solver_name,
        residual=residual,
        iterations=iterations,
        branch=branch,
        branch_defined=defined,
        margin=float(margin),
    )
    x_lu: Linearisation | None = None
    if kernel is not None and r.success:  # (newton mode: x is x_all, and predicts the next)
        fac = r.factor if r.jv is not None else kernel.factor(evaluate_lean(t, xs, vals)[1])
        if fac.sign:
            # the tangent once here where J is LeanSchur's; the DenseKernel's solved per
            # command as predict() does: its answers' cond (LAPACK's estimate, which moves by
            # tens of % between answers a rounding apart) then keeps its bits
            unit = unit_tangent(t, kernel.solve, fac) if isinstance(kernel, LeanSchur) else None
            x_lu = Linearisation(xs, fac, unit, v0 if step is not None else None, step)
    return res, state_of(
        c,
        vals,
        poses,
        pts,
        signs_t,
        r.det_sign,
        margins,
        x_all=r.x if newton_mode else None,
        x_lu=x_lu,
    )
