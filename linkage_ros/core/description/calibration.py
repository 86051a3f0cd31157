"""Calibration of the joint map: every description joint's affine map onto a scene value,
fixed at the reference pose (the imported scene solved at its own values)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from ..model import Mechanism
from ..model.joint_map import InputJoint, JointMap, OutputJoint, OutputKind, Plane
from .chain import Chain
from .records import ClosureType, DescriptionError, JointType
from .scene_names import SceneNames


def _offset(value: float, revolute: bool) -> float:
    """A calibrated offset: an angle's within (-pi, pi] (values are compared on the circle), and
    never -0.0 (a written scene shows 0.0)."""
    return (math.remainder(value, 2.0 * math.pi) if revolute else value) + 0.0


def calibrate_joint_map(
    chain: Chain, acts: Sequence[str], q: Mapping[str, float], mech: Mechanism, names: SceneNames
) -> JointMap:
    """Calibrate every affine map at the reference pose (the scene solved at its own values)."""
    from ..solver import Solver

    solver = Solver(mech)
    ref = solver.solve(solver.reference_values())
    if not ref.success:
        raise DescriptionError(
            f'the imported scene does not solve at its reference pose: {ref.reason}',
            file=chain.description.source,
        )
    # the drawing's own revolute values (the scene is drawn in the pose q describes: each link
    # at its reference angle). Paired with q they make every offset exact; the closed form's
    # re-solve of the reference is exact too, but of the closed pose, which at a toggle lies
    # ~1e-8 rad (the root of rounding) from the least-squares assembly q came from
    drawn = dict(ref.joints)
    for rj in mech.revolutes:
        child, parent = mech.links[rj.child], mech.links[rj.parent]
        drawn[rj.name] = math.remainder(child.angle_ref - parent.angle_ref, 2.0 * math.pi)
    desc = chain.description
    poses = chain.poses(q)
    outputs: list[OutputJoint] = []
    inputs: list[InputJoint] = []
    lname = {b: names.of[('link', b)] for b in chain.bodies}

    def scene_pin(point: str, a: str, b: str) -> tuple[str, float]:
        """The scene joint at ``point`` between bodies a and b, and +1 if a is its child
        (its value is then angle(a) - angle(b)), else -1."""
        r = next(r for r in mech.revolutes if r.point == point and {r.parent, r.child} == {a, b})
        return r.name, 1.0 if r.child == a else -1.0

    for j in chain.joints:
        lim = desc.limits_of(j.joint)
        if j.revolute:
            name, sigma = scene_pin(names.point(j.name), lname[j.child], lname[j.parent])
            scale = sigma * j.sign  # q = sign * (angle(child) - angle(parent)) + const
        else:
            name, scale = names.of[('point', j.name)], 1.0  # the slider's name
        offset = _offset(q[j.name] - scale * drawn[name], j.revolute)
        outputs.append(
            OutputJoint(
                j.name,
                OutputKind.JOINT,
                name,
                scale,
                offset,
                j.revolute,
                lower=lim.lower,
                upper=lim.upper,
            )
        )
        # scale is +-1: the inverse map has the same scale
        inputs.append(InputJoint(j.name, name, scale, -scale * offset, j.revolute))
    for a in acts:  # an actuated joint is commanded through its actuator
        j = next(x for x in chain.joints if x.name == a)
        sname = names.of[('point', a)]  # the actuator keeps the joint's own name
        scale = j.sign if j.revolute else 1.0
        mimic = j.joint.mimic
        leader = mimic.joint if mimic is not None and mimic.joint in acts else ''
        inputs = [i for i in inputs if i.name != a]
        inputs.append(
            InputJoint(
                a,
                sname,
                scale,
                _offset(ref.inputs[sname] - scale * q[a], j.revolute),
                j.revolute,
                leader=leader,
                multiplier=mimic.multiplier if leader and mimic else 1.0,
                mimic_offset=mimic.offset if leader and mimic else 0.0,
            )
        )
    outputs += _cut_joints(chain, poses, drawn, lname, names, scene_pin)
    published = {o.name for o in outputs}
    # mimics outside the chain follow their published leader, which may itself be such a mimic
    # declared after them: passes until none is added (each after its leader: positions
    # reads the leader's value first)
    added = True
    while added:
        added = False
        for tj in desc.joints:
            if tj.mimic is not None and tj.name not in published and tj.mimic.joint in published:
                outputs.append(
                    OutputJoint(
                        tj.name,
                        OutputKind.MIMIC,
                        scale=tj.mimic.multiplier,
                        offset=tj.mimic.offset,
                        revolute=tj.type is not JointType.PRISMATIC,
                        leader=tj.mimic.joint,
                    )
                )
                published.add(tj.name)
                added = True
    plane = Plane(
        _vec3(chain.basis[0]),
        _vec3(chain.basis[1]),
        _vec3(chain.normal),
        depths={p: d for p, d in names.depths.items() if p in mech.points},
    )
    return JointMap(outputs, inputs, acts, plane)


def _vec3(v: np.ndarray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


def _cut_joints(
    chain: Chain,
    poses: Mapping[str, tuple[np.ndarray, float]],
    ref_joints: Mapping[str, float],
    lname: Mapping[str, str],
    names: SceneNames,
    scene_pin: Callable[[str, str, str], tuple[str, float]],
) -> list[OutputJoint]:
    """The joints whose frames a closure names (Gepetto's dummy closure joints): the first held
    at 0, the second turned with the closure's pin so that the two frames coincide."""
    from .chain import angle_about_normal, frame_rotation, tilts

    out: list[OutputJoint] = []
    desc = chain.description
    for c in chain.closures:
        ends = [
            (e, j) for e in (c.closure.a, c.closure.b) if e.joint and (j := desc.joint(e.joint))
        ]
        if not ends or c.direction is not None:
            continue
        if len(ends) == 2:
            out.append(OutputJoint(ends[0][1].name, OutputKind.CONSTANT, offset=0.0))
        end, joint = ends[-1]
        if joint.type is not JointType.REVOLUTE:
            continue
        other = c.closure.a if end is c.closure.b else c.closure.b
        mine, theirs = chain.body_of[end.link][0], chain.body_of[other.link][0]
        turn = frame_rotation(chain, end) @ frame_rotation(chain, other).T
        if c.closure.type is ClosureType.REVOLUTE and tilts(chain, turn):
            # a pin (Gepetto's '3d') makes only the origins meet: frames that tilt apart never
            # coincide, and no value of this joint is the closure's; it is held at 0
            out.append(OutputJoint(joint.name, OutputKind.CONSTANT, offset=0.0))
            continue
        # frames equal: Rot(n, phi_mine + s q - phi_theirs) = R_theirs0 R_mine0^T
        delta = angle_about_normal(chain, turn, c.closure.element)
        w = frame_rotation(chain, end) @ joint.axis
        s = 1.0 if float(w @ chain.normal) > 0 else -1.0
        q_ref = s * (poses[theirs][1] - poses[mine][1] - delta)
        pin, sigma = scene_pin(names.point(c.name), lname[theirs], lname[mine])
        scale = s * sigma
        out.append(
            OutputJoint(
                joint.name,
                OutputKind.JOINT,
                pin,
                scale,
                _offset(q_ref - scale * ref_joints[pin], True),
                True,
                lower=joint.limits.lower,
                upper=joint.limits.upper,
            )
        )
    return out


__all__ = ['calibrate_joint_map']
