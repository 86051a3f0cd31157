"""The closed chain of a description, in its plane.

Fixed joints merge links into rigid bodies. The chain is every closure plus the tree joints on
the paths from its top body (the ground: the lowest common ancestor of every closure's links)
to the closures' links; joints above the ground (an excavator's swing, the arm carrying a
gripper) are the frame the mechanism is mounted in. The plane is found, not assumed: every
revolute axis of the chain parallel to one direction n, every prismatic axis perpendicular to
it; pins at different depths along n are fine. Each body then moves by (t, phi) in the plane
(phi from its pose at all joint values zero), and each joint is a 2-D relation between two
bodies.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .records import (
    Closure,
    ClosureType,
    Description,
    DescriptionError,
    JointType,
    LinkFrame,
    TreeJoint,
    inverse,
    joint_motion,
)

#: axes within this angle (rad) of parallel (or perpendicular) count as such: descriptions
#: written with 16-digit rpy values agree to ~1e-16; CAD exports to ~1e-12
AXIS_TOLERANCE = 1e-9
#: axes further than AXIS_TOLERANCE from parallel but within this (rad) look like a rounded
#: rpy (3.14159 for pi is 2.7e-6 off), and the refusal says so
_ROUNDED = 1e-3

#: link -> (its body, the link's pose in the body: 4x4)
_BodyOf = Mapping[str, tuple[str, np.ndarray]]


def rot(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True, eq=False)
class PlanarJoint:
    """A tree joint of the chain in the plane: F at ``parent_point`` (parent body, zero pose)
    and M at ``child_point`` (child body) coincide at value 0; a revolute value turns the child
    by ``sign`` * value; a prismatic one moves M along ``direction`` (parent body)."""

    joint: TreeJoint
    parent: str
    child: str
    parent_point: np.ndarray
    child_point: np.ndarray
    sign: float = 1.0
    direction: np.ndarray | None = None

    @property
    def name(self) -> str:
        return self.joint.name

    @property
    def revolute(self) -> bool:
        return self.joint.type is JointType.REVOLUTE


@dataclass(frozen=True, eq=False)
class PlanarClosure:
    """Point ``point_a`` of body ``a`` and ``point_b`` of body ``b`` coincide (a pin), or (a
    slide) b's point runs on the line through a's along ``direction`` (body a) with the bodies'
    angle difference phi_a - phi_b held at ``angle``."""

    closure: Closure
    a: str
    b: str
    point_a: np.ndarray
    point_b: np.ndarray
    direction: np.ndarray | None = None
    angle: float = 0.0

    @property
    def name(self) -> str:
        return self.closure.name


@dataclass(frozen=True, eq=False)
class Chain:
    """A description's closed chain in its plane (see the module docstring)."""

    description: Description
    ground: str  # the ground body (named after its top link)
    bodies: tuple[str, ...]  # breadth-first from the ground
    body_of: dict[str, tuple[str, np.ndarray]]  # link -> (body, link pose in the body)
    joints: tuple[PlanarJoint, ...]  # parents before children
    closures: tuple[PlanarClosure, ...]
    normal: np.ndarray  # n, in the ground body's frame
    basis: np.ndarray  # (2, 3): e1, e2 (in-plane axes, e1 x e2 = n)
    zero_poses: dict[str, np.ndarray]  # body -> 4x4 pose in the ground body at all values 0
    zero_planar: dict[str, np.ndarray]  # body -> its origin in the plane at all values 0

    def project(self, v: np.ndarray) -> np.ndarray:
        planar: np.ndarray = self.basis @ v
        return planar

    def local_point(self, link: str, pose: np.ndarray) -> tuple[str, np.ndarray]:
        """A frame fixed in ``link`` as (body, its point in the body's planar zero frame)."""
        body, x_body_link = self.body_of[link]
        x = self.zero_poses[body] @ x_body_link @ pose
        return body, self.project(x[:3, 3] - self.zero_poses[body][:3, 3])

    def depth(self, link: str, pose: np.ndarray) -> float:
        """How far along the normal a frame fixed in ``link`` lies (m): the same in every
        configuration (the chain moves in its plane)."""
        body, x_body_link = self.body_of[link]
        x = self.zero_poses[body] @ x_body_link @ pose
        return float(self.normal @ x[:3, 3])

    def poses(self, values: Mapping[str, float]) -> dict[str, tuple[np.ndarray, float]]:
        """Every body's (origin in the plane, phi) at these joint values (missing: 0)."""
        out: dict[str, tuple[np.ndarray, float]] = {
            self.ground: (self.zero_planar[self.ground], 0.0)
        }
        for j in self.joints:
            t_p, phi_p = out[j.parent]
            q = float(values.get(j.name, 0.0))
            f = j.parent_point
            if j.revolute:
                phi_c = phi_p + j.sign * q
            else:
                assert j.direction is not None  # every prismatic joint has one
                phi_c = phi_p
                f = f + q * j.direction
            out[j.child] = (t_p + rot(phi_p) @ f - rot(phi_c) @ j.child_point, phi_c)
        return out

    def closure_residual(self, poses: Mapping[str, tuple[np.ndarray, float]]) -> np.ndarray:
        """Each closure's miss: a pin's two coordinates (m); a slide's offset from its line (m)
        and its angle error times the length scale."""
        out = []
        for c in self.closures:
            (t_a, phi_a), (t_b, phi_b) = poses[c.a], poses[c.b]
            gap = (t_b + rot(phi_b) @ c.point_b) - (t_a + rot(phi_a) @ c.point_a)
            if c.direction is None:
                out.extend(gap)
            else:
                d = rot(phi_a) @ c.direction
                out.append(d[0] * gap[1] - d[1] * gap[0])
                out.append(_wrap(phi_a - phi_b - c.angle) * self.length_scale)
        return np.array(out)

    @functools.cached_property
    def length_scale(self) -> float:
        """The chain's size (m): the largest distance between its joints in the zero pose
        (each closure residual is scaled by it: computed once, not per evaluation)."""
        pts = [p for j in self.joints for p in (j.parent_point, j.child_point)]
        pts += list(self.zero_planar.values())
        # (math.dist: no overflow of the squares, a pin at 1e300 m is a finite distance)
        span = max((math.dist(p, q) for p in pts for q in pts[:8]), default=0.0)
        return span if span > 0 else 1.0


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def find_chain(desc: Description) -> Chain:
    """The closed chain of ``desc`` in its plane; DescriptionError naming what is wrong."""
    src = desc.source
    if not desc.closures:
        raise DescriptionError(
            'states no closure: the description is a tree. State where its loop is cut in a '
            "closure file (the CLI's --closures FILE, the node's closures parameter; a "
            'linkage_ros closure file or Gepetto YAML, see docs/ROBOT_DESCRIPTIONS.md)',
            file=src,
        )
    by_child = {j.child: j for j in desc.joints}
    body_of = _bodies(desc, by_child)

    def ancestors(body: str) -> list[str]:
        out = [body]
        while True:
            link = out[-1]
            j = by_child.get(link)
            if j is None:
                return out
            out.append(body_of[j.parent][0])

    for c in desc.closures:  # before the plane: such a chain may have no joint to find it by
        if body_of[c.a.link][0] == body_of[c.b.link][0]:
            raise DescriptionError(
                'joins two frames of one rigid body (no loop)', file=src, key=c.element
            )
    ends = [body_of[end.link][0] for c in desc.closures for end in (c.a, c.b)]
    paths = [ancestors(b) for b in ends]
    common = [b for b in paths[0] if all(b in p for p in paths[1:])]
    if not common:
        raise DescriptionError('its closures are in links of different trees', file=src)
    ground = common[0]
    chain_joints: dict[str, TreeJoint] = {}
    for path in paths:
        for body in path[: path.index(ground)]:
            chain_joints[by_child[body].name] = by_child[body]
    bodies = [ground]
    ordered: list[TreeJoint] = []
    frontier = [ground]
    while frontier:
        nxt = []
        for body in frontier:
            for j in desc.joints:
                if j.name in chain_joints and body_of[j.parent][0] == body:
                    ordered.append(j)
                    bodies.append(j.child)
                    nxt.append(j.child)
        frontier = nxt
    for j in ordered:
        if j.type is JointType.OTHER:
            raise DescriptionError(
                'is in the closed chain but is not revolute, continuous, prismatic or fixed',
                file=src,
                key=j.element,
            )
    zero = _zero_poses(desc, ground, ordered, body_of)
    normal = _normal(desc, ordered, zero, body_of)
    # the plane's axes are the ground frame's (x, y for an xy chain, x and z for an xz one),
    # whichever way the joints turn: a point's plane coordinates are then its coordinates in
    # that frame, as ~/target_point reads them; a joint turning about -n has its value negated
    basis = _basis(normal)
    normal = np.cross(basis[0], basis[1])
    chain = Chain(
        desc,
        ground,
        tuple(bodies),
        body_of,
        (),
        (),
        normal,
        basis,
        zero,
        {b: basis @ zero[b][:3, 3] for b in bodies},
    )
    joints = tuple(_planar_joint(chain, j) for j in ordered)
    chain = Chain(
        desc, ground, tuple(bodies), body_of, joints, (), normal, basis, zero, chain.zero_planar
    )
    closures = tuple(_planar_closure(chain, c) for c in desc.closures)
    return Chain(
        desc,
        ground,
        tuple(bodies),
        body_of,
        joints,
        closures,
        normal,
        basis,
        zero,
        chain.zero_planar,
    )


def _bodies(desc: Description, by_child: dict[str, TreeJoint]) -> dict[str, tuple[str, np.ndarray]]:
    """link -> (its body: the top link of its fixed-joint group, its pose in that body)."""
    out: dict[str, tuple[str, np.ndarray]] = {}

    def resolve(link: str, depth: int = 0) -> tuple[str, np.ndarray]:
        if link in out:
            return out[link]
        j = by_child.get(link)
        if j is None or j.type is not JointType.FIXED or depth > len(desc.links):
            out[link] = (link, np.eye(4))
        else:
            body, x = resolve(j.parent, depth + 1)
            out[link] = (body, x @ j.parent_to_joint @ inverse(j.child_to_joint))
        return out[link]

    for link in desc.links:
        resolve(link)
    return out


def _zero_poses(
    desc: Description, ground: str, ordered: Sequence[TreeJoint], body_of: _BodyOf
) -> dict[str, np.ndarray]:
    poses = {ground: np.eye(4)}
    for j in ordered:
        x_p = (
            poses[j.parent]
            if j.parent in poses
            else (poses[body_of[j.parent][0]] @ body_of[j.parent][1])
        )
        poses[j.child] = x_p @ j.parent_to_joint @ joint_motion(j, 0.0) @ inverse(j.child_to_joint)
    return poses


def _world_axis(joint: TreeJoint, zero: Mapping[str, np.ndarray], body_of: _BodyOf) -> np.ndarray:
    body, x = body_of[joint.parent]
    r = (zero[body] @ x @ joint.parent_to_joint)[:3, :3]
    axis: np.ndarray = r @ joint.axis
    return axis


def _normal(
    desc: Description,
    ordered: Sequence[TreeJoint],
    zero: Mapping[str, np.ndarray],
    body_of: _BodyOf,
) -> np.ndarray:
    src = desc.source
    revolute = [(j, _world_axis(j, zero, body_of)) for j in ordered if j.type is JointType.REVOLUTE]
    prismatic = [
        (j, _world_axis(j, zero, body_of)) for j in ordered if j.type is JointType.PRISMATIC
    ]
    if revolute:
        first, n = revolute[0]
    elif len(prismatic) >= 2:
        first, n = prismatic[0][0], np.cross(prismatic[0][1], prismatic[1][1])
        if not np.linalg.norm(n) > AXIS_TOLERANCE:
            raise DescriptionError('the chain slides along one direction only: no plane', file=src)
        n = n / np.linalg.norm(n)
    else:
        raise DescriptionError('the chain has no revolute joint to find its plane by', file=src)
    for j, a in revolute:
        angle = math.asin(min(1.0, float(np.linalg.norm(np.cross(a, n)))))
        if angle > AXIS_TOLERANCE:
            raise DescriptionError(
                f'not a planar chain: the axes of joints {first.name!r} and {j.name!r} are '
                f'{math.degrees(angle):.6g} deg from parallel'
                + (
                    f' (axes count as parallel within {AXIS_TOLERANCE:g} rad: an <origin> rpy '
                    'rounded to a few digits, 3.14159 for pi, is this far off; write it to 16 '
                    'digits, 3.141592653589793)'
                    if angle < _ROUNDED
                    else ''
                ),
                file=src,
            )
    for j, a in prismatic:
        off = abs(float(a @ n))
        if off > AXIS_TOLERANCE:
            raise DescriptionError(
                f'not a planar chain: the prismatic axis of {j.name!r} is '
                f'{math.degrees(math.asin(min(1.0, off))):.6g} deg out of the plane normal to '
                f'the axis of {first.name!r}',
                file=src,
            )
    return n


def _basis(n: np.ndarray) -> np.ndarray:
    """In-plane axes e1, e2: the two of the ground frame's x, y, z most nearly in the plane
    (in that order: an excavator's xz plane gives x forward, z up; a plane turned about z by a
    mount keeps z up), projected and made orthonormal."""
    eye = np.eye(3)
    picks = sorted(sorted(range(3), key=lambda k: abs(float(eye[k] @ n)))[:2])
    e1 = eye[picks[0]] - (eye[picks[0]] @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    if float(e2 @ eye[picks[1]]) < 0:
        e2 = -e2  # keep the second axis's sense; n flips instead (n = e1 x e2)
    return np.array([e1, e2])


def _planar_joint(chain: Chain, j: TreeJoint) -> PlanarJoint:
    pb, f = chain.local_point(j.parent, j.parent_to_joint)
    cb, m = chain.local_point(j.child, j.child_to_joint)
    a = _world_axis(j, chain.zero_poses, chain.body_of)
    if j.type is JointType.REVOLUTE:
        return PlanarJoint(j, pb, cb, f, m, sign=1.0 if float(a @ chain.normal) > 0 else -1.0)
    d = chain.project(a)
    return PlanarJoint(j, pb, cb, f, m, direction=d / np.linalg.norm(d))


def frame_rotation(chain: Chain, end: LinkFrame) -> np.ndarray:
    body, x = chain.body_of[end.link]
    rotation: np.ndarray = (chain.zero_poses[body] @ x @ end.pose)[:3, :3]
    return rotation


def tilts(chain: Chain, r: np.ndarray) -> bool:
    """Rotation ``r`` turns the chain's normal (it is not a turn about the normal only)."""
    n = chain.normal
    return float(np.linalg.norm(r @ n - n)) > 1e-6


def angle_about_normal(chain: Chain, r: np.ndarray, what: str) -> float:
    """The angle of rotation ``r`` about the chain's normal; refuses a rotation that tilts."""
    if tilts(chain, r):
        raise DescriptionError(
            f'{what}: its two frames are not turned about the plane normal '
            'only (they tilt out of the plane)',
            file=chain.description.source,
        )
    e1 = chain.basis[0]
    v = r @ e1
    return math.atan2(float(v @ chain.basis[1]), float(v @ e1))


def _planar_closure(chain: Chain, c: Closure) -> PlanarClosure:
    src = chain.description.source
    for end in (c.a, c.b):
        if end.link not in chain.body_of or chain.body_of[end.link][0] not in chain.zero_poses:
            raise DescriptionError(
                'joins a link outside the chain', file=src, key=c.element, value=end.link
            )
    ba, pa = chain.local_point(c.a.link, c.a.pose)
    bb, pb = chain.local_point(c.b.link, c.b.pose)
    if ba == bb:
        raise DescriptionError(
            'joins two frames of one rigid body (no loop)', file=src, key=c.element
        )
    ra = frame_rotation(chain, c.a)
    if c.axis is not None:
        w = ra @ c.axis
        if c.type is ClosureType.PRISMATIC:
            if abs(float(w @ chain.normal)) > AXIS_TOLERANCE:
                raise DescriptionError(
                    'its prismatic axis is not in the plane of the chain', file=src, key=c.element
                )
        elif float(np.linalg.norm(np.cross(w, chain.normal))) > AXIS_TOLERANCE:
            raise DescriptionError(
                "its axis is not parallel to the chain's joint axes", file=src, key=c.element
            )
    if c.type is ClosureType.FRAME and c.a.joint is None and c.b.joint is None:
        raise DescriptionError(
            "a '6d' closure of frames no joint turns welds two bodies into one: a planar loop "
            "needs a pin ('3d') or a joint frame",
            file=src,
            key=c.element,
        )
    if c.type is not ClosureType.PRISMATIC:
        return PlanarClosure(c, ba, bb, pa, pb)
    if c.axis is None:
        raise DescriptionError('a prismatic closure needs an axis', file=src, key=c.element)
    d = chain.project(ra @ c.axis)
    rb = frame_rotation(chain, c.b)
    # frames equal when Rot(n, phi_a - phi_b) = R_b0 R_a0^T
    angle = angle_about_normal(chain, rb @ ra.T, c.element)
    return PlanarClosure(c, ba, bb, pa, pb, direction=d / np.linalg.norm(d), angle=angle)
