"""The scene as a URDF tree, for robot_state_publisher and RViz.

URDF describes a tree; a closed chain is a graph. The tree here is a breadth-first spanning tree
of the links from the ground; the joints it leaves out close the loops and are listed in a
comment. Every joint of the tree is named exactly as the node's ``joint_states`` names it, so
stock robot_state_publisher fed by the node places every frame where the solver says: the node
publishes every joint (loop-closing ones too, which robot_state_publisher ignores), and the
values of the tree's joints alone fix every link.

Frames (all prefixed with ``prefix``, as robot_state_publisher's ``frame_prefix`` does, except
the root, which is the node's ``frame_id`` that the node's messages carry):

* the root (``frame_id``) -> the ground link (fixed, identity: the ground frame is the scene's
  coordinate frame, whatever direction the ground link reports);
* one frame per moving link, named after the link, with its origin at the point of the joint
  that reaches it and its x axis along the link's reported direction (``Link.axis``, the
  angle the solver reports for the link);
* one frame per scene point, named after the point, a fixed child of a link that carries it.

Joint conventions are the solver's (core.assemble): a revolute joint's value is the child
link's angle minus the parent's (rad, wrapped); a prismatic joint's value is the slide along its
direction from its origin (m). A tree edge that runs against the scene's parent -> child order
gets axis -z (or the negated slide direction), so the published value is used unchanged.
"""

from __future__ import annotations

import enum
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .errors import SceneError, echo
from .model import Mechanism

# ---- planar rigid transforms ---------------------------------------------------------------------


@dataclass(frozen=True)
class Pose2D:
    """A planar frame: origin (x, y) in m, x axis at ``yaw`` rad counter-clockwise."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def __matmul__(self, other: Pose2D) -> Pose2D:
        """``self`` then ``other`` expressed in ``self``'s frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            self.yaw + other.yaw,
        )

    def inverse(self) -> Pose2D:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(-(c * self.x + s * self.y), s * self.x - c * self.y, -self.yaw)

    def local(self, x: float, y: float) -> tuple[float, float]:
        """World point (x, y) in this frame's coordinates."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = x - self.x, y - self.y
        return c * dx + s * dy, -s * dx + c * dy


def _wrap(a: float) -> float:
    return math.remainder(a, 2.0 * math.pi)


# ---- the spanning tree ---------------------------------------------------------------------------


class JointKind(enum.Enum):
    REVOLUTE = 'revolute'
    PRISMATIC = 'prismatic'


@dataclass(frozen=True)
class TreeJoint:
    """One scene joint as an edge of the tree: ``parent`` -> ``child`` are tree links;
    ``reversed`` when that runs against the scene's order (parent/child, guide/slider)."""

    name: str
    kind: JointKind
    point: str
    parent: str
    child: str
    reversed: bool


@dataclass(frozen=True)
class Tree:
    joints: list[TreeJoint]  # in breadth-first order from the ground
    cut: list[TreeJoint]  # the loop-closing joints (scene order)
    order: list[str]  # links, ground first, in the order the tree reaches them


def spanning_tree(mech: Mechanism) -> Tree:
    """Breadth-first spanning tree of the links from the ground (scene joint order breaks ties:
    revolute joints, then prismatic)."""
    edges: list[tuple[str, JointKind, str, str, str]] = [
        (j.name, JointKind.REVOLUTE, j.point, j.parent, j.child) for j in mech.revolutes
    ] + [
        (p.name, JointKind.PRISMATIC, p.point, p.guide, p.slider) for p in mech.prismatics.values()
    ]
    order, joints, used = [mech.ground], [], set()
    queue = [mech.ground]
    while queue:
        link = queue.pop(0)
        for name, kind, point, a, b in edges:
            if name in used or link not in (a, b):
                continue
            other = b if link == a else a
            if other in order:
                continue
            used.add(name)
            joints.append(TreeJoint(name, kind, point, link, other, reversed=link == b))
            order.append(other)
            queue.append(other)
    unreached = [l for l in mech.links if l not in order]
    if unreached:
        raise SceneError(
            f'links {unreached} are not connected to the ground by any joint: a URDF tree cannot '
            'place them',
            file=mech.source,
        )
    cut = [
        TreeJoint(name, kind, point, a, b, reversed=False)
        for name, kind, point, a, b in edges
        if name not in used
    ]
    return Tree(joints, cut, order)


# ---- frames and joint origins at the reference pose ----------------------------------------------


@dataclass(frozen=True)
class UrdfJoint:
    """One URDF joint: ``origin`` (parent frame -> joint frame) and ``axis`` (joint frame)."""

    name: str
    type: str  # continuous, revolute, prismatic or fixed
    parent: str
    child: str
    origin: Pose2D
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    limits: tuple[float, float] | None = None


def _reference_value(mech: Mechanism, tj: TreeJoint) -> float:
    """The joint's value in the reference pose (what the solver reports there)."""
    if tj.kind is JointKind.PRISMATIC:
        return mech.prismatics[tj.name].ref_value
    rj = next(j for j in mech.revolutes if j.name == tj.name)
    return _wrap(mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref)


def reference_frames(mech: Mechanism, tree: Tree) -> dict[str, Pose2D]:
    """Every link's frame in the reference pose (scene coordinates): the ground at the origin,
    each other link at the point of the tree joint that reaches it, x along its direction."""
    frames = {mech.ground: Pose2D()}
    for tj in tree.joints:
        x, y = (float(v) for v in mech.points[tj.point])
        frames[tj.child] = Pose2D(x, y, mech.links[tj.child].angle_ref)
    return frames


def tree_joint(
    mech: Mechanism, tj: TreeJoint, frames: Mapping[str, Pose2D], name: str, limits
) -> UrdfJoint:
    """The URDF joint of a tree edge: child frame = parent frame @ origin @ motion(value)."""
    parent, child = frames[tj.parent], frames[tj.child]
    q_ref = _reference_value(mech, tj)
    sign = -1.0 if tj.reversed else 1.0
    if tj.kind is JointKind.REVOLUTE:
        motion = Pose2D(0.0, 0.0, sign * q_ref)
        axis = (0.0, 0.0, sign)
        kind = 'continuous' if limits is None else 'revolute'
    else:
        d = mech.prismatics[tj.name].direction
        ax, ay = Pose2D(0.0, 0.0, child.yaw).local(sign * d[0], sign * d[1])
        motion = Pose2D(ax * q_ref, ay * q_ref, 0.0)
        axis = (ax, ay, 0.0)
        kind = 'prismatic'
    origin = parent.inverse() @ child @ motion.inverse()
    return UrdfJoint(name, kind, tj.parent, tj.child, origin, axis, limits)


# ---- limits --------------------------------------------------------------------------------------


def _revolute_limits(mech: Mechanism, tj: TreeJoint) -> tuple[float, float] | None:
    """The joint's range from an angle actuator across it with both limits, shifted into the
    (-pi, pi] the solver wraps joint values to; None (a continuous joint) when there is no such
    actuator or its range crosses the wrap."""
    rj = next(j for j in mech.revolutes if j.name == tj.name)
    for act in mech.actuators.values():
        if act.kind != 'angle' or act.min is None or act.max is None:
            continue
        if {act.link, act.reference} != {rj.parent, rj.child}:
            continue
        assert act.link is not None and act.pivot is not None and act.toward is not None
        p, t = mech.points[act.pivot], mech.points[act.toward]
        # actuator angle = direction(pivot -> toward) - reference angle = joint value + c
        c = math.atan2(t[1] - p[1], t[0] - p[0]) - mech.links[act.link].angle_ref
        lo, hi = (act.min - c, act.max - c) if act.link == rj.child else (c - act.max, c - act.min)
        if hi - lo >= 2.0 * math.pi:
            return None
        shift = _wrap(lo) - lo
        lo, hi = lo + shift, hi + shift
        return (lo, hi) if hi <= math.pi else None
    return None


def _swept_slides(mech: Mechanism, names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """Range of each named prismatic joint over a grid of the actuators' ranges (the scene's
    limits, else the assembly's own range, else a full turn), widened by 5%."""
    if not names:
        return {}
    from .motion import input_ranges
    from .solver import Solver

    ranges = input_ranges(mech)
    per = {1: 721, 2: 61, 3: 21}.get(len(mech.actuators), 9)
    axes = []
    for a, act in mech.actuators.items():
        lo, hi = ranges.get(a, (None, None))
        if lo is None or hi is None:
            if act.kind == 'angle':
                lo, hi = -math.pi, math.pi
            else:
                ref = mech.prismatics[act.joint].ref_value if act.joint else 0.0
                lo = ref - mech.length_scale if lo is None else lo
                hi = ref + mech.length_scale if hi is None else hi
        axes.append(np.linspace(lo, hi, per))
    grid = np.meshgrid(*axes, indexing='ij')
    solver = Solver(mech, knowns=list(mech.actuators), branch='reference')
    batch = solver.solve_batch({a: g.ravel() for a, g in zip(mech.actuators, grid)})
    out = {}
    for n in names:
        v = np.asarray(batch.joints[n])[np.asarray(batch.ok, dtype=bool)]
        v = v[np.isfinite(v)]
        ref = mech.prismatics[n].ref_value
        lo, hi = (float(v.min()), float(v.max())) if v.size else (ref, ref)
        pad = max(0.05 * (hi - lo), 1e-3 * mech.length_scale)
        out[n] = (lo - pad, hi + pad)
    return out


def joint_limits(mech: Mechanism, tree: Tree) -> dict[str, tuple[float, float] | None]:
    """{tree joint: (lower, upper) or None (continuous)}: a cylinder's or slide actuator's
    limits as the scene gives them; a revolute joint's from an angle actuator across it; a
    passive prismatic joint's (URDF requires limits for one) swept, advisory only."""
    out: dict[str, tuple[float, float] | None] = {}
    swept = []
    for tj in tree.joints:
        if tj.kind is JointKind.REVOLUTE:
            out[tj.name] = _revolute_limits(mech, tj)
            continue
        act = next((a for a in mech.actuators.values() if a.joint == tj.name), None)
        if act is not None and act.min is not None and act.max is not None:
            out[tj.name] = (act.min, act.max)
        else:
            swept.append(tj.name)
    out.update(_swept_slides(mech, swept))
    return out


# ---- the document --------------------------------------------------------------------------------


def name_error(name: str, allow_empty: bool = False) -> str | None:
    """Why ``name`` cannot prefix or name a frame (tf2 and URDF: no whitespace, no leading
    '/', no XML-hostile control characters), or None."""
    if not isinstance(name, str):
        return f'must be a string (got {echo(name)})'
    if not name and not allow_empty:
        return 'must not be empty'
    if any(c.isspace() or ord(c) < 32 for c in name) or name.startswith('/'):
        return (
            f"must have no whitespace or control characters and no leading '/' (got {echo(name)})"
        )
    return None


def check_frame_names(mech: Mechanism, frame_id: str) -> None:
    """URDF links are named after links and points (and the root): they must all differ."""
    clash = sorted(set(mech.points) & set(mech.links))
    if clash:
        raise SceneError(
            f'{clash} name both a point and a link; the URDF has a frame for each point and '
            'each link, named after it, so the names must differ (rename one)',
            file=mech.source,
        )
    if frame_id in mech.points or frame_id in mech.links:
        raise SceneError(
            f'frame_id {frame_id!r} is also the name of a point or link; the URDF root frame '
            'must have a name of its own',
            file=mech.source,
        )


def _unique(name: str, taken: set[str]) -> str:
    while name in taken:
        name += '_fixed'
    taken.add(name)
    return name


def build_joints(
    mech: Mechanism, prefix: str = '', frame_id: str | None = None
) -> tuple[Tree, list[UrdfJoint], dict[str, str]]:
    """(tree, URDF joints in document order, {point: link that carries its frame})."""
    root = frame_id or mech.frame_id
    check_frame_names(mech, root)
    tree = spanning_tree(mech)
    frames = reference_frames(mech, tree)
    limits = joint_limits(mech, tree)
    taken = {prefix + n for n in mech.joint_names}
    joints = [
        UrdfJoint(
            _unique(f'{prefix}{root}_to_{mech.ground}', taken),
            'fixed',
            root,
            prefix + mech.ground,
            Pose2D(),
        )
    ]
    for tj in tree.joints:
        j = tree_joint(mech, tj, frames, prefix + tj.name, limits[tj.name])
        joints.append(
            UrdfJoint(
                j.name, j.type, prefix + j.parent, prefix + j.child, j.origin, j.axis, j.limits
            )
        )
    carrier: dict[str, str] = {}
    for link in tree.order:  # a point's frame hangs from the first link the tree reaches
        for p in mech.links[link].points:
            carrier.setdefault(p, link)
    for p, link in carrier.items():
        x, y = frames[link].local(*(float(v) for v in mech.points[p]))
        joints.append(
            UrdfJoint(
                _unique(f'{prefix}{link}_to_{p}', taken),
                'fixed',
                prefix + link,
                prefix + p,
                Pose2D(x, y, 0.0),
            )
        )
    return tree, joints, carrier


def _num(v: float) -> str:
    return repr(float(v)) if v != 0 else '0'


def _origin(parent: ET.Element, xyz: Iterable[float], rpy: Iterable[float]) -> None:
    ET.SubElement(
        parent,
        'origin',
        xyz=' '.join(_num(v) for v in xyz),
        rpy=' '.join(_num(v) for v in rpy),
    )


def urdf_document(mech: Mechanism, prefix: str = '', frame_id: str | None = None) -> str:
    """The URDF (XML text) of ``mech``; see the module docstring for its frames and joints."""
    from .urdf_visuals import MATERIALS, link_visuals

    root_name = frame_id or mech.frame_id
    tree, joints, _carrier = build_joints(mech, prefix, frame_id)
    frames = reference_frames(mech, tree)
    robot = ET.Element('robot', name=prefix + mech.name)
    robot.append(
        ET.Comment(
            f' generated by `linkage urdf` from {mech.source}. Joint names are the names the '
            'linkage_node publishes on joint_states'
            + (f' (prefix {prefix!r})' if prefix else '')
            + '; feed those joint_states to robot_state_publisher. '
        )
    )
    if tree.cut:
        cut = '; '.join(
            f'{prefix}{c.name} ({c.kind.value} at {c.point}, {c.parent} - {c.child})'
            for c in tree.cut
        )
        robot.append(
            ET.Comment(
                f' loop-closing joints, not in this tree (a URDF is a tree): {cut}. The node '
                'publishes their values too; the tree joints alone place every link. '
            )
        )
    for name, rgba in MATERIALS.items():
        m = ET.SubElement(robot, 'material', name=name)
        ET.SubElement(m, 'color', rgba=' '.join(_num(v) for v in rgba))
    ET.SubElement(robot, 'link', name=root_name)
    for link in tree.order:
        el = ET.SubElement(robot, 'link', name=prefix + link)
        for vis in link_visuals(mech, link, frames[link]):
            v = ET.SubElement(el, 'visual')
            _origin(v, vis.xyz, vis.rpy)
            g = ET.SubElement(v, 'geometry')
            ET.SubElement(g, vis.shape, {k: _dims(val) for k, val in vis.size.items()})
            ET.SubElement(v, 'material', name=vis.material)
    for p in mech.points:
        ET.SubElement(robot, 'link', name=prefix + p)
    for j in joints:
        el = ET.SubElement(robot, 'joint', name=j.name, type=j.type)
        _origin(el, (j.origin.x, j.origin.y, 0.0), (0.0, 0.0, j.origin.yaw))
        ET.SubElement(el, 'parent', link=j.parent)
        ET.SubElement(el, 'child', link=j.child)
        if j.type != 'fixed':
            ET.SubElement(el, 'axis', xyz=' '.join(_num(v) for v in j.axis))
        if j.limits is not None:
            # kinematics only: no effort or velocity limit is known (URDF requires the keys)
            ET.SubElement(
                el,
                'limit',
                lower=_num(j.limits[0]),
                upper=_num(j.limits[1]),
                effort='0',
                velocity='0',
            )
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding='unicode') + '\n'


def _dims(value: float | tuple[float, ...]) -> str:
    if isinstance(value, tuple):
        return ' '.join(_num(v) for v in value)
    return _num(value)
