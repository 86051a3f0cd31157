"""Branch geometry read off solved positions: the side and margin of each branching dyad."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..dyads import circle_side, line_side, unit_vector
from ..execute import LinkPoses
from ..model import Mechanism
from ..ops import SCALAR, BatchOps, ScalarOps
from ..steps import BranchArgs, RollerSide, RRRDyad, anchor_of
from .compile import Plan, Step
from .poses import ScalarPoses
from .spec import point_complex


def step_geometry(
    ops: ScalarOps | BatchOps,
    mech: Mechanism,
    st: Step,
    pts: Mapping[str, Any],
    rot: Mapping[str, Any],
) -> tuple[Any, Any]:
    """(side, margin) of one branching step read off solved positions, either backend: the
    branch sign is +1 where side >= 0; margin is |sin| of the dyad's transmission angle (0 at
    its singularity). ``pts`` complex points, ``rot`` {link: e^{i phi}} of the guide links.
    A roller's side (core.steps.RollerSide) is the side of the face its centre is on, margin
    1: it cannot be at a toggle. ValueError for a step that does not branch."""

    args = st.args
    if st.point is None or not isinstance(args, BranchArgs):
        raise ValueError(f'step {st.op} places no point by a dyad: it has no branch')
    x = pts[st.point]
    if isinstance(args, RollerSide):
        rot_g = rot[mech.prismatics[args.joint].guide]
        u = rot_g * point_complex(mech.prismatics[args.joint].direction)
        w = x - (pts[args.anchor] + rot_g * args.face)
        side = u.real * w.imag - u.imag * w.real
        return side, ops.where(side == side, 1.0, 1.0)  # 1 also where a row failed (NaN)
    if isinstance(args, RRRDyad):
        a, b = pts[args.centre_a], pts[args.centre_b]
        ax, vb = unit_vector(ops, x - a), unit_vector(ops, x - b)
        side = circle_side(ops, a, b, x, unit_c1_x=ax)
        m = abs(ax.real * vb.imag - ax.imag * vb.real)
    else:
        pj = mech.prismatics[args.joint]
        side = line_side(ops, pts[anchor_of(args)], x, rot[pj.guide] * point_complex(pj.direction))
        m = abs(side)
    return side, ops.clip(m, 0.0, 1.0)


def branch_geometry_of(
    ops: ScalarOps | BatchOps, plan: Plan, pts: Mapping[str, Any], poses: LinkPoses
) -> tuple[list[Any], list[Any]]:
    """Branch signs (+1 / -1) and dyad margins of the plan's branching steps read off a solved
    configuration, either backend (how a Newton solution is told which assembly mode it is
    in): one list entry per branching step."""
    signs: list[Any] = []
    margins: list[Any] = []
    for st in plan.branch_steps:
        side, m = step_geometry(ops, plan.mech, st, pts, poses.rot)
        signs.append(ops.where(side >= 0, 1, -1))
        margins.append(m)
    return signs, margins


def branch_geometry_one(
    plan: Plan, pts: Mapping[str, complex], poses: ScalarPoses
) -> tuple[tuple[int, ...], Sequence[float]]:
    """branch_geometry_of on one configuration: (signs tuple, margins list)."""
    signs, margins = branch_geometry_of(SCALAR, plan, pts, poses)
    return tuple(signs), margins


def rollers_off_drawn_side(
    mech: Mechanism, pts: Mapping[str, complex], poses: LinkPoses
) -> list[str]:
    """The rollers (Mechanism.rollers) of one configuration whose centre is on the side of its
    face it is not drawn on (the face: the line through the joint's origin, fixed in its
    guide)."""
    out = []
    for j in sorted(mech.rollers):
        pj = mech.prismatics[j]
        if pj.guide not in poses.rot or pj.point not in pts:
            continue
        rot = poses.rot[pj.guide]
        u, origin = point_complex(pj.direction), point_complex(pj.origin)
        now = ((rot * u).conjugate() * (pts[pj.point] - (rot * origin + poses.T[pj.guide]))).imag
        drawn = (u.conjugate() * (point_complex(mech.points[pj.point]) - origin)).imag
        if now * drawn < 0:
            out.append(j)
    return out
