"""Reading a solved configuration back: adopting it for continuity, and its assembly mode."""

from __future__ import annotations

import cmath
import math

import numpy as np

from ..dyads import wrap_angle
from ..execute import LinkPoses
from ..plan import branch_geometry_one, spec_value_one
from ..quantities import PointSpec
from .compiled import CompiledSolve, Values
from .continuity import Continuity, state_of
from .result import Result, branch_text


def configuration_of(
    c: CompiledSolve, result: Result
) -> tuple[dict[str, complex], LinkPoses] | None:
    """(points, poses) of a successful result of this mechanism, or None if unusable: failed,
    missing a link or point, non-finite, or its points not where its link angles put them (not
    a rigid configuration of this mechanism)."""
    mech = c.mech
    try:
        if not (
            isinstance(result, Result)
            and result.success
            and set(result.links) == set(mech.links)
            and set(result.points) >= set(mech.points)
        ):
            return None
        pts = {
            p: complex(float(result.points[p][0]), float(result.points[p][1])) for p in mech.points
        }
        phis = {l: float(result.links[l]) for l in mech.links}
    except (TypeError, ValueError, IndexError, KeyError, AttributeError):
        return None
    if not all(math.isfinite(v) for v in phis.values()) or not all(
        cmath.isfinite(w) for w in pts.values()
    ):
        return None
    poses = LinkPoses()
    tol = c.closure_limit * mech.length_scale
    for l, link in mech.links.items():
        phi = wrap_angle(phis[l] - link.angle_ref)
        rot = complex(math.cos(phi), math.sin(phi))
        p = link.points[0]
        poses.set(l, phi, pts[p] - rot * complex(*mech.points[p]), rot)
        if any(
            abs(poses.world(l, complex(*mech.points[q])) - pts[q]) > tol for q in link.points[1:]
        ):
            return None
    return pts, poses


def known_values(c: CompiledSolve, poses: LinkPoses) -> Values:
    """The knowns' values in a configuration, as parse() gives them."""
    out: Values = []
    for s in c.specs:
        v = spec_value_one(c.mech, s, poses)
        out.append(np.asarray(v, float) if isinstance(s, PointSpec) else float(v))
    return out


def adopt(c: CompiledSolve, cont: Continuity, result: Result) -> bool:
    """Make a solved configuration (from any solver of this mechanism) the 'previous
    configuration' of ``cont``. Returns False, changing nothing, if the result is unusable
    (see :func:`configuration_of`)."""
    got = configuration_of(c, result)
    if got is None:
        return False
    pts, poses = got
    if c.plan.complete:
        signs, margins = branch_geometry_one(c.plan, pts, poses)
    else:
        signs, margins = c.plan.reference_signs, ()
    cont.history = [state_of(c, known_values(c, poses), poses, pts, signs, margins=margins)]
    return True


def mode_of(c: CompiledSolve, result: Result) -> tuple[tuple[int, ...], list[float]] | None:
    """The assembly mode of a solved configuration (from any solver of this mechanism) as this
    solve reads it. With a closed-form plan of every link: the branch sign and dyad margin of
    each branching step (a sign is undefined where its margin is ~0, at that dyad's toggle).
    Without one (a forward solve that Newton places): the sign of the determinant of the loop
    Jacobian over every moving link at the configuration, with 1 / its scaled condition number
    as the margin (the sign is undefined at a singular configuration, where the modes meet).
    None if the result is unusable (see :func:`configuration_of`), or for an inverse solve
    without a complete plan (the forward solve reads the mechanism's mode)."""
    plan = c.plan if c.plan.complete else c.full_plan
    if not plan.complete and c.inverse:
        return None
    got = configuration_of(c, result)
    if got is None:
        return None
    if plan.complete:
        signs, margins = branch_geometry_one(plan, *got)
        return tuple(int(s) for s in signs), [float(m) for m in margins]
    return jacobian_mode(c, got[1])


def jacobian_mode(c: CompiledSolve, poses: LinkPoses) -> tuple[tuple[int, ...], list[float]]:
    """((det sign,), [1 / scaled cond]) of the loop Jacobian of ``c``'s knowns over every moving
    link at a configuration: the assembly-mode reading where no dyad plan gives signs."""
    cs = c.check_system
    _, J = cs.evaluate(cs.x_from_poses(poses), known_values(c, poses))
    if J.shape[0] != J.shape[1] or not J.size:
        return (), []
    sign, _ = np.linalg.slogdet(J)
    return (int(sign) if sign else 1,), [min(1.0, 1.0 / cs.scaled_cond(J))]


def jacobian_sign(c: CompiledSolve, poses: LinkPoses) -> int:
    """The determinant sign of the loop Jacobian of ``c``'s knowns over every moving link at a
    configuration (0 if it is not square, or exactly singular)."""
    cs = c.check_system
    _, J = cs.evaluate(cs.x_from_poses(poses), known_values(c, poses))
    if J.shape[0] != J.shape[1] or not J.size:
        return 0
    return int(np.linalg.slogdet(J)[0])


def mode_label(c: CompiledSolve, signs: tuple[int, ...]) -> str:
    """An assembly mode as statuses show it and ``branch`` takes it: the forward dyads' signs
    ('+-'), or where Newton places the mechanism the loop Jacobian's determinant sign ('J+')."""
    text = branch_text(signs)
    return text if c.full_plan.complete else 'J' + text
