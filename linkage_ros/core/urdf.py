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
* one frame per moving link, named after the link (``link_<link>`` for a link named like a
  joint: :func:`link_frames`), with its origin at the point of the joint that reaches it and its
  x axis along the link's reported direction (``Link.axis``, the angle the solver reports for
  the link);
* one frame per scene point, ``point_<point>`` (:func:`point_frame`), a fixed child of a link
  that carries it. Joints are named after points (a pin ``A``): a point frame named ``A`` too
  would make ``A`` name two frames in consumers that keep joints and links in one namespace
  (Pinocchio's frames). Every joint and link name of the document is unique
  (:func:`check_frame_names`).

Joint conventions are the solver's (core.assemble): a revolute joint's value is the child
link's angle minus the parent's (rad, wrapped); a prismatic joint's value is the slide along its
direction from its origin (m). A tree edge that runs against the scene's parent -> child order
gets axis -z (or the negated slide direction), so the published value is used unchanged.

The text is meant for ``--ros-args -p robot_description:="$(linkage urdf SCENE)"``, where rcl
reads the value as YAML: it has no ``': '``, ``' #'`` or line-ending ``':'`` (comments are
worded without them, and the scene path is percent-quoted in them), so it is one plain YAML
scalar, whose line breaks YAML folds into spaces (the same XML).
"""

from __future__ import annotations

import enum
import heapq
import math
import re
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .errors import SceneError, echo
from .model import AngleActuator, Mechanism, SlideActuator
from .model.limits import slack, spans_a_turn
from .urdf_visuals import MATERIALS, Pose2D, link_visuals

# ---- planar rigid transforms ---------------------------------------------------------------------


def _wrap(a: float) -> float:
    return math.remainder(a, 2.0 * math.pi)


# ---- the spanning tree ---------------------------------------------------------------------------


class JointKind(enum.Enum):
    REVOLUTE = 'revolute'
    PRISMATIC = 'prismatic'


class UrdfJointType(enum.StrEnum):
    """A URDF joint's ``type`` attribute, as written."""

    CONTINUOUS = 'continuous'
    REVOLUTE = 'revolute'
    PRISMATIC = 'prismatic'
    FIXED = 'fixed'


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
    revolute joints, then prismatic). A roller's joint (Mechanism.rollers) joins the tree only
    where nothing else reaches its link: its line is the drawn side's, and a tree through its
    pin's revolute joint places the roller right on either side of its face."""
    edges: list[tuple[str, JointKind, str, str, str]] = [
        (j.name, JointKind.REVOLUTE, j.point, j.parent, j.child) for j in mech.revolutes
    ] + [
        (p.name, JointKind.PRISMATIC, p.point, p.guide, p.slider) for p in mech.prismatics.values()
    ]
    order, joints, used = [mech.ground], [], set()
    for allowed in ([e for e in edges if e[0] not in mech.rollers], edges):
        queue = list(order)
        while queue:
            link = queue.pop(0)
            for name, kind, point, a, b in allowed:
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
    type: UrdfJointType
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
    mech: Mechanism,
    tj: TreeJoint,
    frames: Mapping[str, Pose2D],
    name: str,
    limits: tuple[float, float] | None,
) -> UrdfJoint:
    """The URDF joint of a tree edge: child frame = parent frame @ origin @ motion(value)."""
    parent, child = frames[tj.parent], frames[tj.child]
    q_ref = _reference_value(mech, tj)
    sign = -1.0 if tj.reversed else 1.0
    if tj.kind is JointKind.REVOLUTE:
        motion = Pose2D(0.0, 0.0, sign * q_ref)
        axis = (0.0, 0.0, sign)
        kind = UrdfJointType.CONTINUOUS if limits is None else UrdfJointType.REVOLUTE
    else:
        d = mech.prismatics[tj.name].direction
        ax, ay = Pose2D(0.0, 0.0, child.yaw).local(sign * d[0], sign * d[1])
        motion = Pose2D(ax * q_ref, ay * q_ref, 0.0)
        axis = (ax, ay, 0.0)
        kind = UrdfJointType.PRISMATIC
    origin = parent.inverse() @ child @ motion.inverse()
    return UrdfJoint(name, kind, tj.parent, tj.child, origin, axis, limits)


# ---- limits --------------------------------------------------------------------------------------


def _revolute_limits(mech: Mechanism, tj: TreeJoint) -> tuple[float, float] | None:
    """The joint's range from an angle actuator across it with both limits, shifted into the
    (-pi, pi] the solver wraps joint values to; None (a continuous joint) when there is no such
    actuator or its range crosses the wrap."""
    rj = next(j for j in mech.revolutes if j.name == tj.name)
    for act in mech.actuators.values():
        if not isinstance(act, AngleActuator) or act.min is None or act.max is None:
            continue
        if {act.link, act.reference} != {rj.parent, rj.child}:
            continue
        assert act.link is not None and act.pivot is not None and act.toward is not None
        p, t = mech.points[act.pivot], mech.points[act.toward]
        # actuator angle = direction(pivot -> toward) - reference angle = joint value + c: the
        # link's direction is its axis turned by c, and an actuator measured from the ground
        # counts from +x where the joint counts from the ground's axis (its angle_ref)
        c = math.atan2(t[1] - p[1], t[0] - p[0]) - mech.links[act.link].angle_ref
        if act.reference == mech.ground:
            c += mech.links[mech.ground].angle_ref
        lo, hi = (act.min - c, act.max - c) if act.link == rj.child else (c - act.max, c - act.min)
        if spans_a_turn(lo, hi):
            return None
        shift = _wrap(lo) - lo
        lo, hi = lo + shift, hi + shift
        if hi > math.pi:
            return None
        # widened by the limit rule's slack (model.limits): a command at a limit is answered,
        # and its joint value, a difference of two link angles, may come out an ulp or two
        # past the limit (2.0999999999999996 for 2.1): no value the node publishes lies outside
        return (max(lo - slack(lo), -math.pi), min(hi + slack(hi), math.pi))
    return None


def _input_axes(mech: Mechanism) -> list[np.ndarray]:
    """Samples of each actuator: over its scene limits (else a full turn for an angle, its
    reference value +- a length scale for a slide); a lone actuator also, as finely, over the
    assembly's own range (toggle to toggle), where a slide's extremes often lie."""
    from .motion import input_ranges

    own = input_ranges(mech)
    per = {1: 721, 2: 61, 3: 21}.get(len(mech.actuators), 9)
    axes = []
    for a, act in mech.actuators.items():
        lo, hi = act.min, act.max
        if isinstance(act, AngleActuator):
            lo, hi = (-math.pi, math.pi) if lo is None or hi is None else (lo, hi)
        else:
            ref = mech.prismatics[act.joint].ref_value if act.joint else 0.0
            lo = ref - mech.length_scale if lo is None else lo
            hi = ref + mech.length_scale if hi is None else hi
        axis = [np.linspace(lo, hi, per)]
        o_lo, o_hi = own.get(a, (None, None))
        if len(mech.actuators) == 1 and o_lo is not None and o_hi is not None:
            axis.append(np.linspace(o_lo, o_hi, per))
        axes.append(np.unique(np.concatenate(axis)))
    return axes


def _swept_slides(mech: Mechanism, names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """Range of each named prismatic joint over a grid of the actuators' ranges in every
    assembly mode (each sign combination of the dyad plan: the node's 'continuous' branch may
    reach any of them), widened by 5% but not beyond :func:`_slide_bounds`; where Newton places
    links (no plan lists the modes), that bound alone."""
    if not names:
        return {}
    from .solver import SolveMode, Solver
    from .steps import branch_text, sign_combinations

    solver = Solver(mech, knowns=list(mech.actuators), branch='reference')
    if solver.mode is not SolveMode.CLOSED_FORM:
        return _slide_bounds(mech, names)
    grid = np.meshgrid(*_input_axes(mech), indexing='ij')
    values = {a: g.ravel() for a, g in zip(mech.actuators, grid)}
    found: dict[str, list[np.ndarray]] = {n: [] for n in names}
    for signs in sign_combinations(solver.branch_count):  # every assembly mode
        if signs:
            solver = Solver(mech, knowns=list(mech.actuators), branch=branch_text(signs))
        batch = solver.solve_batch(values)
        for n in names:
            v = np.asarray(batch.joints[n])[np.asarray(batch.ok, dtype=bool)]
            found[n].append(v[np.isfinite(v)])
    out = {}
    for n, (b_lo, b_hi) in _slide_bounds(mech, names).items():
        v = np.concatenate(found[n])
        ref = mech.prismatics[n].ref_value
        lo, hi = (float(v.min()), float(v.max())) if v.size else (ref, ref)
        pad = max(0.05 * (hi - lo), 1e-3 * mech.length_scale)
        out[n] = (max(lo - pad, b_lo), min(hi + pad, b_hi))  # the padding, within the bound
    return out


def _slide_bounds(mech: Mechanism, names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """A bound that holds in every assembly mode: a slide's value is at most the distance from
    its origin to its point, and that is at most the length of any chain of rigid distances
    (two points of one link, or a guide's slide origin and a point of the guide) and actuated
    slides with both limits (their largest |limit| plus the point's offset from the line)
    joining them; the shortest such chain (Dijkstra). No chain: a span of 1000 length scales."""
    graph: dict[str, list[tuple[str, float]]] = {}

    def edge(a: str, b: str, w: float) -> None:
        graph.setdefault(a, []).append((b, w))
        graph.setdefault(b, []).append((a, w))

    def at(node: str) -> np.ndarray:
        return np.asarray(
            mech.prismatics[node[1:]].origin if node.startswith('>') else mech.points[node],
            dtype=float,
        )

    for link in mech.links.values():
        members = list(link.points)
        members += ['>' + n for n, pj in mech.prismatics.items() if pj.guide == link.name]
        for i, m in enumerate(members):
            for q in members[i + 1 :]:
                edge(m, q, float(np.hypot(*(at(m) - at(q)))))
    for act in mech.actuators.values():
        if isinstance(act, SlideActuator) and act.min is not None and act.max is not None:
            pj = mech.prismatics[act.joint]
            off = at(pj.point) - at('>' + act.joint)
            perp = abs(float(off[0] * pj.direction[1] - off[1] * pj.direction[0]))
            edge('>' + act.joint, pj.point, max(abs(act.min), abs(act.max)) + perp)
    out = {}
    for n in names:
        target, dist, heap = mech.prismatics[n].point, {'>' + n: 0.0}, [(0.0, '>' + n)]
        bound = 1000.0 * mech.length_scale
        while heap:
            d, node = heapq.heappop(heap)
            if node == target:
                bound = d
                break
            if d > dist.get(node, math.inf):
                continue
            for other, w in graph.get(node, []):
                if d + w < dist.get(other, math.inf):
                    dist[other] = d + w
                    heapq.heappush(heap, (d + w, other))
        bound += 1e-3 * mech.length_scale  # stated lengths differ from drawn ones by rounding
        out[n] = (-bound, bound)
    return out


def joint_limits(mech: Mechanism, tree: Tree) -> dict[str, tuple[float, float] | None]:
    """{tree joint: (lower, upper) or None (continuous)}: a cylinder's or slide actuator's
    limits as the scene gives them; a revolute joint's from an angle actuator across it; a
    passive prismatic joint's (URDF requires limits for one) swept over the inputs in every
    assembly mode (:func:`_swept_slides`), so no value the node publishes lies outside them."""
    out: dict[str, tuple[float, float] | None] = {}
    swept = []
    for tj in tree.joints:
        if tj.kind is JointKind.REVOLUTE:
            out[tj.name] = _revolute_limits(mech, tj)
            continue
        act = next(
            (
                a
                for a in mech.actuators.values()
                if isinstance(a, SlideActuator) and a.joint == tj.name
            ),
            None,
        )
        if act is not None and act.min is not None and act.max is not None:
            out[tj.name] = (act.min, act.max)
        else:
            swept.append(tj.name)
    out.update(_swept_slides(mech, swept))
    return out


# ---- the document --------------------------------------------------------------------------------


def name_error(name: object, allow_empty: bool = False) -> str | None:
    """Why ``name`` cannot name a frame (tf2 and URDF: no whitespace, no leading '/', no
    control or other unprintable characters, which XML cannot carry), or None."""
    if not isinstance(name, str):
        return f'must be a string (got {echo(name)})'
    if not name and not allow_empty:
        return 'must not be empty'
    if not all(c.isprintable() and not c.isspace() for c in name) or name.startswith('/'):
        return (
            f"must have no whitespace or control characters and no leading '/' (got {echo(name)})"
        )
    return None


#: what a frame prefix may be: ASCII letters, digits and _ . - / (not leading), no '--' (which
#: would end an XML comment); nothing XML or a YAML parameter override reads specially
PREFIX_RE = re.compile(r'(?!/)(?!.*--)[A-Za-z0-9_./-]*\Z')
PREFIX_RULE = (
    "must be a string without whitespace, of ASCII letters, digits and '_', '.', '-', '/' only, "
    "with no '--' and no leading '/'"
)


def prefix_error(prefix: object) -> str | None:
    """Why ``prefix`` cannot prefix the frame and joint names (``linkage urdf --prefix`` and the
    node's ``prefix`` parameter), as :data:`PREFIX_RULE` (got ...), or None ('' is fine)."""
    if isinstance(prefix, str) and PREFIX_RE.match(prefix):
        return None
    return f'{PREFIX_RULE} (got {echo(prefix)})'


def point_frame(point: str, prefix: str = '') -> str:
    """The URDF link (TF frame) of a scene point: ``<prefix>point_<point>``, apart from the
    joints, which are named after points."""
    return f'{prefix}point_{point}'


def link_frames(mech: Mechanism, prefix: str = '') -> dict[str, str]:
    """{link: its URDF link (TF frame)}: ``<prefix><link>``, or ``<prefix>link_<link>`` for a
    link named like a joint (the slider_crank and scott_russell shortcuts name a slider and its
    prismatic joint alike), so that no joint and link share a name."""
    joints = set(mech.joint_names)
    return {l: f'{prefix}link_{l}' if l in joints else prefix + l for l in mech.links}


def _comment(text: str) -> str:
    """``text`` made safe in an XML comment and a YAML plain scalar: every character but
    letters, digits, spaces and ``_ . / + , = @ ~ - ( ) ; ' ` `` percent-quoted (UTF-8), and
    no ``--``; the caller words the rest without ': ' or ' #'."""
    safe = set("_./+,=@~-();'` ")
    out = ''.join(
        c
        if c.isalnum() or c in safe
        else ''.join(f'%{b:02X}' for b in c.encode('utf-8', 'replace'))
        for c in text
    )
    return out.replace('--', '-%2D')


def check_frame_names(mech: Mechanism, frame_id: str, prefix: str = '') -> None:
    """URDF links (the root, links, point frames) and joints must all have names of their own:
    consumers such as Pinocchio keep both in one namespace of frames."""
    names = list(link_frames(mech, prefix).values())
    names += [point_frame(p, prefix) for p in mech.points]
    names += [prefix + j for j in mech.joint_names]
    if frame_id in mech.points or frame_id in mech.links or frame_id in names:
        raise SceneError(
            f'frame_id {frame_id!r} is also the name of a point, link or joint; the URDF root '
            'frame must have a name of its own',
            file=mech.source,
        )
    twice = sorted(n for n, k in Counter(names).items() if k > 1)
    if twice:
        raise SceneError(
            f'{twice} would each name two frames of the URDF (a link, a point frame '
            f'{point_frame("<point>", prefix)!r}, a link frame {prefix + "link_<link>"!r} or '
            'a joint): rename one',
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
    why = prefix_error(prefix)
    if why:
        raise ValueError(f'prefix {why}')
    root = frame_id or mech.frame_id
    check_frame_names(mech, root, prefix)
    tree = spanning_tree(mech)
    frames = reference_frames(mech, tree)
    limits = joint_limits(mech, tree)
    lf = link_frames(mech, prefix)
    taken = {root} | {prefix + n for n in mech.joint_names} | set(lf.values())
    taken |= {point_frame(p, prefix) for p in mech.points}
    joints = [
        UrdfJoint(
            _unique(f'{prefix}{root}_to_{mech.ground}', taken),
            UrdfJointType.FIXED,
            root,
            lf[mech.ground],
            Pose2D(),
        )
    ]
    for tj in tree.joints:
        j = tree_joint(mech, tj, frames, prefix + tj.name, limits[tj.name])
        joints.append(
            UrdfJoint(j.name, j.type, lf[j.parent], lf[j.child], j.origin, j.axis, j.limits)
        )
    carrier: dict[str, str] = {}
    for link in tree.order:  # a point's frame hangs from the first link the tree reaches
        for p in mech.links[link].points:
            carrier.setdefault(p, link)
    for p, link in carrier.items():
        x, y = frames[link].local(*(float(v) for v in mech.points[p]))
        joints.append(
            UrdfJoint(
                _unique(f'{prefix}{link}_to_{point_frame(p)}', taken),
                UrdfJointType.FIXED,
                lf[link],
                point_frame(p, prefix),
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


#: why no URDF is written for a robot description (linkage urdf refuses one before reading it)
DESCRIPTION_REFUSAL = (
    "publishes a robot description's own joint names and values: give robot_state_publisher "
    'that description itself (its URDF), which these joint_states drive; linkage urdf writes '
    'the URDF of a scene in its own joint names (for a scene written by linkage import: '
    'without its joint_coordinates key)'
)


def urdf_document(mech: Mechanism, prefix: str = '', frame_id: str | None = None) -> str:
    """The URDF (XML text) of ``mech``; see the module docstring for its frames and joints.
    A mechanism read from a robot description publishes that description's own joint names and
    values: its URDF is the description itself, and one written here would name other joints
    (SceneError)."""

    if mech.joint_coordinates is not None:
        raise SceneError(DESCRIPTION_REFUSAL, file=mech.source)

    root_name = frame_id or mech.frame_id
    tree, joints, _carrier = build_joints(mech, prefix, frame_id)
    frames = reference_frames(mech, tree)
    robot = ET.Element('robot', name=prefix + mech.name)
    # comment text: no ': ', ' #' or '--' (see the module docstring); names are scene names
    # (letters, digits, _) and the prefix is checked (prefix_error)
    robot.append(
        ET.Comment(
            f' generated by `linkage urdf` from {_comment(mech.source)}. Joint names are the '
            'names the linkage_node publishes on joint_states'
            + (f' (prefix {_comment(repr(prefix))})' if prefix else '')
            + '; feed those joint_states to robot_state_publisher. Each scene point P has the '
            f'frame {_comment(point_frame("P", prefix))}. '
        )
    )
    if tree.cut:
        cut = '; '.join(
            f'{prefix}{c.name} ({c.kind.value} at {c.point}, {c.parent} - {c.child})'
            for c in tree.cut
        )
        robot.append(
            ET.Comment(
                ' loop-closing joints left out of this tree (a URDF is a tree) are '
                f'{_comment(cut)}. The node publishes their values too; the tree joints alone '
                'place every link. '
            )
        )
    for name, rgba in MATERIALS.items():
        m = ET.SubElement(robot, 'material', name=name)
        ET.SubElement(m, 'color', rgba=' '.join(_num(v) for v in rgba))
    ET.SubElement(robot, 'link', name=root_name)
    lf = link_frames(mech, prefix)
    for link in tree.order:
        el = ET.SubElement(robot, 'link', name=lf[link])
        for vis in link_visuals(mech, link, frames[link]):
            v = ET.SubElement(el, 'visual')
            _origin(v, vis.xyz, vis.rpy)
            g = ET.SubElement(v, 'geometry')
            ET.SubElement(g, vis.shape, {k: _dims(val) for k, val in vis.size.items()})
            ET.SubElement(v, 'material', name=vis.material)
    for p in mech.points:
        ET.SubElement(robot, 'link', name=point_frame(p, prefix))
    for j in joints:
        el = ET.SubElement(robot, 'joint', name=j.name, type=j.type.value)
        _origin(el, (j.origin.x, j.origin.y, 0.0), (0.0, 0.0, j.origin.yaw))
        ET.SubElement(el, 'parent', link=j.parent)
        ET.SubElement(el, 'child', link=j.child)
        if j.type is not UrdfJointType.FIXED:
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
