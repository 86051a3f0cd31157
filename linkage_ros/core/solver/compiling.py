"""Compiling a solve: the checks that a mechanism and a set of knowns make a solvable problem,
and the parts every command uses (see :class:`~linkage_ros.core.solver.compiled.CompiledSolve`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import PlanError
from ..model import Mechanism, SlideActuator
from ..model.names import Named, NameKind, resolve_name
from ..newton import LoopSystem
from ..plan import Plan, Spec, reference_poses, spec_for, spec_value_one
from ..quantities import AngleSpec, PointSpec, ScalarSpec
from ..steps import Branch, BranchRule, branch_text, sign_combinations
from ..tolerances import NEWTON_TOL_MAX
from .compiled import CompiledSolve, SolveMode
from .continuity import Continuity
from .one import solve_one
from .point_pairs import find_point_pairs, replaced_knowns
from .reading import configuration_of
from .result import CLOSURE_LIMIT, METHODS, NEWTON_TOL, SolveMethod

#: the condition number of an inverse solve's equations at the reference pose above which its
#: knowns are taken not to determine the mechanism (rounding alone gives ~1e16; a generic
#: reference pose of a well-posed solve stays below ~1e6)
UNDETERMINED_COND = 1e12


def compile_solve(
    mech: Mechanism,
    knowns: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    method: str | None = None,  # a SolveMethod's value (METHODS); None: the scene's
    tol: float = NEWTON_TOL,
    max_iter: int = 50,
) -> CompiledSolve:
    """Compile a solve of ``mech`` from ``knowns`` (default: its actuators) for ``outputs``
    (default: everything); PlanError naming what makes it unsolvable."""
    asked = method or mech.solver
    if asked not in METHODS:
        raise PlanError(f'unknown solver {asked!r}; expected one of {list(METHODS)}')
    how = SolveMethod(asked)
    if isinstance(tol, bool) or not (
        isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0
    ):
        raise PlanError(f'tolerance must be a positive number (got {tol!r})')
    if tol > NEWTON_TOL_MAX:
        raise PlanError(
            f'tolerance {tol:g} is too loose: at most {NEWTON_TOL_MAX:g} (a fraction of the '
            "mechanism's length scale: the loop-closure residual an answer may keep; the "
            'default is 1e-12)'
        )
    if isinstance(max_iter, bool) or not (isinstance(max_iter, int) and max_iter > 0):
        raise PlanError(f'max_iter must be a positive integer (got {max_iter!r})')
    for what, names in (('knowns', knowns), ('outputs', outputs)):
        if names is not None and (
            isinstance(names, (str, bytes, Mapping)) or not all(isinstance(v, str) for v in names)
        ):
            raise PlanError(f'{what} must be a list of names (got {names!r})')
    known_names = list(knowns) if knowns is not None else list(mech.actuators)
    if len(set(known_names)) != len(known_names):
        raise PlanError(f'a known is named twice: {known_names}')
    # two known points of one link fix its pose: the plan takes the first and the link's angle
    # (point_pairs); parse() converts a request, after checking their distance
    pairs = find_point_pairs(mech, known_names, [spec_for(mech, n) for n in known_names])
    plan_knowns = replaced_knowns(known_names, pairs)
    if len(set(plan_knowns)) != len(plan_knowns):
        raise PlanError(
            f'the knowns {known_names} give the angle of a link twice (two of its points '
            'fix it already)'
        )
    specs = [spec_for(mech, n) for n in plan_knowns]
    n_values = sum(s.size for s in specs)
    if n_values != mech.dof:
        whole = [s.name for s in specs if isinstance(s, PointSpec)]
        raise PlanError(
            f'{mech.name!r} has {mech.dof} degree(s) of freedom but the knowns '
            f'{known_names} give {n_values} value(s)'
            + (' (two points of one link give 3: its pose)' if pairs else '')
            + (
                # (a point on a one-DOF path is reached by one of its coordinates: an outside
                # scene author tried the foot's x, y first)
                f' (a point gives its x and y: one of them alone is a known too, '
                f'{whole[0].removeprefix("point:")}.x or {whole[0].removeprefix("point:")}.y)'
                if whole and n_values > mech.dof and not pairs
                else ''
            )
        )
    wanted_links, wanted_points = _wanted(mech, outputs)
    plan = Plan(mech, specs, wanted_links, wanted_points)
    full_plan = plan if wanted_links is None else Plan(mech, specs, None, None)
    if how is SolveMethod.CLOSED_FORM and not plan.complete:
        raise PlanError(
            f'no closed-form dyad plan for knowns {known_names} of '
            f'{mech.name!r}; use solver newton or auto'
        )
    if how is SolveMethod.NEWTON:
        mode = SolveMode.NEWTON
    elif plan.complete:
        mode = SolveMode.CLOSED_FORM
    else:
        mode = SolveMode.HYBRID
    closed_links = (
        [] if mode is SolveMode.NEWTON else [l for l in full_plan.placed_links if l != mech.ground]
    )
    free = [l for l in mech.moving_links if l not in closed_links]
    system = LoopSystem(mech, specs, free)
    check_system = LoopSystem(mech, specs, mech.moving_links)
    loose = check_system.unfixed_links()
    if loose:
        raise PlanError(
            f'the knowns {known_names} do not determine {mech.name!r}: they '
            f'give {n_values} value(s) for its {mech.dof} degree(s) of freedom '
            f'but constrain some links twice and leave a motion of '
            f'{loose[0]!r} free; choose knowns that each fix a different '
            'degree of freedom'
        )
    ref = reference_poses(mech)
    ref_values = tuple(_value(mech, s, ref) for s in specs)
    c = CompiledSolve(
        mech=mech,
        knowns=tuple(known_names),
        plan_knowns=tuple(plan_knowns),
        specs=tuple(specs),
        actuator_specs=tuple(_scalar(spec_for(mech, a)) for a in mech.actuators),
        point_pairs=tuple(pairs),
        plan=plan,
        full_plan=full_plan,
        method=how,
        mode=mode,
        system=system,
        check_system=check_system,
        closed_links=tuple(closed_links),
        tol=float(tol),
        max_iter=max_iter,
        closure_limit=max(CLOSURE_LIMIT, 10.0 * float(tol)),
        inverse=any(s.name not in mech.actuators for s in specs),
        ref_values=ref_values,
        limited=tuple(
            (i, s) for i, s in enumerate(specs) if not isinstance(s, PointSpec) and s.bounded
        ),
    )
    if c.inverse:
        check_determined(c, n_values)
    return c


def _scalar(s: Spec) -> ScalarSpec:
    """An actuator's spec: an angle or a slide, never a point."""
    if isinstance(s, PointSpec):
        raise PlanError(f'internal: actuator {s.name!r} read as a point')
    return s


def _value(mech: Mechanism, s: Spec, poses: Any) -> Any:
    v = spec_value_one(mech, s, poses)
    return np.asarray(v, float) if isinstance(s, PointSpec) else float(v)


def _wanted(
    mech: Mechanism, outputs: Sequence[str] | None
) -> tuple[list[str] | None, list[str] | None]:
    """The links and points the wanted outputs need placed (None: every one). An output says
    what to place: a bare name is a link, else a point (a scene's outputs are point names: a
    point needs one of its links placed, the joint of the same name both), else resolved by
    the one rule (model.names: actuator, joint); a prefix such as ``point:P`` picks the kind."""
    if outputs is None:
        return None, None
    links: set[str] = set()
    pts: set[str] = set()
    for name in outputs:
        try:
            if name in mech.links:
                named = Named(NameKind.LINK, name, name)
            elif name in mech.points:
                named = Named(NameKind.POINT, name, name)
            else:
                named = resolve_name(mech, name)
        except PlanError:
            raise PlanError(f'unknown output {name!r} of {mech.name!r}') from None
        match named.kind:
            case NameKind.POINT:
                pts.add(named.name)
            case NameKind.LINK:
                links.add(named.name)
            case NameKind.ACTUATOR:
                a = mech.actuators[named.name]
                if isinstance(a, SlideActuator):
                    pj = mech.prismatics[a.joint]
                    links |= {pj.guide, pj.slider}
                else:
                    links |= {a.link, a.reference}
            case NameKind.JOINT if named.name in mech.prismatics:
                pj = mech.prismatics[named.name]
                links |= {pj.guide, pj.slider}
            case NameKind.JOINT:
                rj = next(r for r in mech.revolutes if r.name == named.name)
                links |= {rj.parent, rj.child}
    return sorted(links), sorted(pts)


def _determined_in(c: CompiledSolve, fwd: CompiledSolve, cont: Continuity) -> bool | None:
    """Whether ``c``'s knowns fix the configuration at some pose the actuators move to on
    ``cont``'s branch (their equations well-conditioned there); None where no such pose
    assembled."""
    cs, mech = c.check_system, c.mech
    ref = fwd.reference_values()
    scale = mech.length_scale
    seen: bool | None = None
    for step in (0.05, -0.05, 0.3, -0.3):
        # a different step for each actuator: equal steps keep a symmetric drawing symmetric
        cmd = {
            s.name: ref[s.name]
            + (-1) ** k
            * (1 + 0.37 * k)
            * (step if isinstance(s, AngleSpec) else step * 0.1 * scale)
            for k, s in enumerate(fwd.specs)
        }
        r = solve_one(fwd, Continuity(cont.branch), cmd, commit=False)
        got = configuration_of(c, r) if r.success else None
        if got is None:
            continue
        seen = False
        poses = got[1]
        _, J = cs.evaluate(cs.x_from_poses(poses), [_value(mech, s, poses) for s in c.specs])
        if cs.scaled_cond(J) < UNDETERMINED_COND:
            return True
    return seen


def _modes_determined(c: CompiledSolve, fwd: CompiledSolve) -> list[str]:
    """The assembly modes of the forward dyad plan, other than the drawn one, in which ``c``'s
    knowns do fix the configuration (their branch text)."""
    plan = fwd.full_plan
    if not (plan.complete and plan.branch_steps):
        return []
    drawn = tuple(plan.reference_signs)
    return [
        branch_text(signs)
        for signs in sign_combinations(len(plan.branch_steps))
        if signs != drawn
        and _determined_in(c, fwd, Continuity(Branch(BranchRule.EXPLICIT, signs))) is True
    ]


def check_determined(c: CompiledSolve, n_values: int) -> None:
    """Knowns whose equations are singular at the reference pose do not fix the configuration
    (two of them fix the same motion, another stays free) even where the sparsity pattern says
    they might: a solve would return an arbitrary point of a curve of solutions. Refused here,
    as the structural check refuses what it sees."""
    cs = c.check_system
    _, J = cs.evaluate(cs.reference_x(), list(c.ref_values))
    cond = cs.scaled_cond(J)
    if cond < UNDETERMINED_COND:
        return
    # singular in the reference pose: a drawing at a dead point is singular there only;
    # undetermined knowns are singular everywhere. Look at poses the actuators move to.
    mech = c.mech
    fwd = compile_solve(
        mech, method=SolveMethod.CLOSED_FORM if c.plan.complete else SolveMethod.AUTO
    )
    seen = _determined_in(c, fwd, Continuity())
    if seen is True:
        return
    if seen is not None:
        singular = (
            f'singular in every pose tried: condition number {cond:.2g} in the reference pose'
        )
        if len(c.knowns) == 1:  # one known that fixes nothing: a constant of the geometry
            # (in the drawn assembly mode: in another it may move, as the x of a straight-line
            # linkage's tracing point does where its cell folds the other way)
            others = _modes_determined(c, fwd)
            elsewhere = (
                f' It does change in assembly mode(s) {", ".join(others)}, but a solve for it '
                'starts from the drawn one, where it fixes nothing.'
                if others
                else ''
            )
            raise PlanError(
                f'the known {c.knowns[0]!r} does not determine {mech.name!r}: it does not '
                'change as the mechanism moves in its drawn assembly mode (a quantity its '
                'geometry keeps constant there, such as one coordinate of a point that moves '
                f'on a straight line; its equation is {singular}); choose a known that moves '
                f'with the mechanism.{elsewhere}'
            )
        raise PlanError(
            f'the knowns {list(c.knowns)} do not determine {mech.name!r}: they give '
            f'{n_values} value(s) for its {mech.dof} degree(s) of freedom, but two '
            'of them fix the same motion and leave another free (their equations are '
            f'{singular}); choose knowns that each fix a different degree of freedom'
        )
