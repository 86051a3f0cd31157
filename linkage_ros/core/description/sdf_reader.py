"""SDFormat (1.7+): a model's links, frames and joints; a joint whose child is already in the
tree is a closure (a loop joint). Passive joints are marked as Drake marks them: ``<effort>0``
in their ``<limit>``.

A joint's parent-side frame: when ``<parent>`` names an explicit ``<frame>``, that frame (the
joint brings it and the joint frame on the child together at value 0, as Drake's four-bar
examples are drawn: the links need not be placed assembled); when it names a link, the joint
frame's initial pose expressed in that link (the SDFormat rule).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from .records import (
    Closure,
    ClosureType,
    Description,
    DescriptionError,
    DescriptionFormat,
    JointType,
    Limits,
    LinkFrame,
    TreeJoint,
    inverse,
    transform,
)
from .xml_text import limits_of, numbers, optional_bool, optional_number, required, unit_axis

_MODEL = '__model__'
_JOINT_TYPES = {
    'revolute': JointType.REVOLUTE,
    'continuous': JointType.REVOLUTE,
    'prismatic': JointType.PRISMATIC,
    'fixed': JointType.FIXED,
}
_CLOSURE_TYPES = {
    'revolute': ClosureType.REVOLUTE,
    'continuous': ClosureType.REVOLUTE,
    'ball': ClosureType.REVOLUTE,
    'prismatic': ClosureType.PRISMATIC,
}


class _Frames:
    """Every named frame's initial pose in the model frame and the link it is attached to."""

    def __init__(self, model: ET.Element, source: str):
        self.source = source
        self.elements: dict[str, tuple[str, ET.Element]] = {}
        for tag in ('link', 'frame', 'joint'):
            for el in model.findall(tag):
                name = required(el, 'name', source, tag)
                if name in self.elements or name in (_MODEL, 'world'):
                    raise DescriptionError(f'{tag} {name!r}: the name is used twice', file=source)
                self.elements[name] = (tag, el)
        self._pose: dict[str, np.ndarray] = {_MODEL: np.eye(4), 'world': np.eye(4)}
        self._busy: set[str] = set()

    def exists(self, name: str) -> bool:
        return name in self.elements or name in (_MODEL, 'world')

    def kind(self, name: str) -> str:
        return self.elements[name][0] if name in self.elements else 'link'

    def pose(self, name: str) -> np.ndarray:
        """The frame's initial pose in the model frame."""
        if name in self._pose:
            return self._pose[name]
        if name not in self.elements:
            raise DescriptionError(f'names an unknown frame {name!r}', file=self.source)
        if name in self._busy:
            raise DescriptionError(
                f'frame {name!r}: its pose is relative to itself (a cycle)', file=self.source
            )
        self._busy.add(name)
        tag, el = self.elements[name]
        default = {
            'link': _MODEL,
            'frame': el.get('attached_to') or _MODEL,
            'joint': _text(el, 'child') or _MODEL,
        }[tag]
        pose_el = el.find('pose')
        rel = (pose_el.get('relative_to') if pose_el is not None else None) or default
        if not self.exists(rel):
            raise DescriptionError(
                f'{tag} {name!r}: pose relative_to an unknown frame', file=self.source, value=rel
            )
        self._pose[name] = self.pose(rel) @ _pose_of(pose_el, self.source, f'{tag} {name!r}')
        self._busy.discard(name)
        return self._pose[name]

    def link_of(self, name: str, depth: int = 0) -> str:
        """The link a frame is attached to (a link is attached to itself)."""
        if name in (_MODEL, 'world'):
            return 'world'
        tag, el = self.elements[name]
        if tag == 'link':
            return name
        if depth > len(self.elements):
            raise DescriptionError(f'frame {name!r} is attached in a cycle', file=self.source)
        target = el.get('attached_to') if tag == 'frame' else _text(el, 'child')
        if not target or not self.exists(target):
            raise DescriptionError(
                f'{tag} {name!r} is attached to an unknown frame', file=self.source, value=target
            )
        return self.link_of(target, depth + 1)


def read_sdf(root: ET.Element, source: str) -> Description:
    """The one model of an ``<sdf>`` document (directly or in a ``<world>``)."""
    models = root.findall('model') or [m for w in root.findall('world') for m in w.findall('model')]
    if len(models) != 1:
        raise DescriptionError(f'has {len(models)} <model> elements; give one model', file=source)
    model = models[0]
    if model.find('include') is not None or model.find('model') is not None:
        raise DescriptionError(
            '<include> and nested <model> are not resolved: give the expanded model (gz sdf -p)',
            file=source,
        )
    frames = _Frames(model, source)
    links = [required(el, 'name', source, 'link') for el in model.findall('link')]
    uses_world = False
    joints: list[TreeJoint] = []
    loop_elements: list[tuple[ET.Element, TreeJoint]] = []
    for el in model.findall('joint'):
        joint = _joint(el, frames, source)
        uses_world |= 'world' in (joint.parent, joint.child)
        joints.append(joint)
        loop_elements.append((el, joint))
    if not links:
        raise DescriptionError(f'model {model.get("name")!r} has no links', file=source)
    all_links = (['world'] if uses_world else []) + links
    tree, closures = _split_tree(all_links, loop_elements, source)
    root_link = 'world' if uses_world else _root(all_links, tree, source)
    return Description(
        name=model.get('name') or 'model',
        source=source,
        root=root_link,
        links=tuple(all_links),
        joints=tuple(tree),
        frames={
            name: LinkFrame(
                frames.link_of(name), inverse(frames.pose(frames.link_of(name))) @ frames.pose(name)
            )
            for name, (tag, _) in frames.elements.items()
            if tag == 'frame'
        },
        closures=tuple(closures),
        format=DescriptionFormat.SDF,
    )


def _split_tree(
    links: list[str], joints: Sequence[tuple[ET.Element, TreeJoint]], source: str
) -> tuple[list[TreeJoint], list[Closure]]:
    """Tree joints in breadth-first order from the root; a joint whose child is already
    reached is a closure."""
    children = {j.child for _, j in joints}
    reached = {l for l in links if l not in children} or {links[0]}
    tree, pending = [], list(joints)
    progress = True
    while progress:
        progress = False
        for item in list(pending):
            _, j = item
            if j.parent in reached and j.child not in reached:
                tree.append(j)
                reached.add(j.child)
                pending.remove(item)
                progress = True
    closures = []
    for el, j in pending:
        if j.parent not in reached or j.child not in reached:
            raise DescriptionError(
                f'{j.element} is not connected to the rest of the model', file=source
            )
        kind = (el.get('type') or '').strip()
        if kind not in _CLOSURE_TYPES:
            raise DescriptionError(
                f'type {kind!r} cannot close a planar chain (revolute, continuous, ball or '
                'prismatic)',
                file=source,
                key=j.element,
            )
        closures.append(
            Closure(
                j.name,
                _CLOSURE_TYPES[kind],
                LinkFrame(j.parent, j.parent_to_joint),
                LinkFrame(j.child, j.child_to_joint),
                j.axis,
                j.element,
            )
        )
    return tree, closures


def _root(links: list[str], tree: Sequence[TreeJoint], source: str) -> str:
    children = {j.child for j in tree}
    roots = [l for l in links if l not in children]
    if len(roots) != 1:
        raise DescriptionError(
            f'{len(roots)} root links ({", ".join(roots[:4])}): the model is not one tree',
            file=source,
        )
    return roots[0]


def _joint(el: ET.Element, frames: _Frames, source: str) -> TreeJoint:
    name = required(el, 'name', source, 'joint')
    where = f'joint {name!r}'
    kind = (el.get('type') or '').strip()
    ends = []
    for tag in ('parent', 'child'):
        ref = _text(el, tag)
        if not ref or not frames.exists(ref):
            raise DescriptionError(
                f'<{tag}> names an unknown link or frame', file=source, key=where, value=ref
            )
        ends.append(ref)
    parent_ref, child_ref = ends
    parent, child = frames.link_of(parent_ref), frames.link_of(child_ref)
    x_joint = frames.pose(name)  # initial pose of the joint frame in the model frame
    child_to_joint = inverse(frames.pose(child)) @ x_joint
    # the joint frame as the model is assembled at value 0, its parent side: the named frame
    # itself where the parent is a frame (the child is joined to it), else its drawn pose
    x_assembled = frames.pose(parent_ref) if frames.kind(parent_ref) == 'frame' else x_joint
    parent_to_joint = inverse(frames.pose(parent)) @ x_assembled
    axis_el = el.find('axis')
    axis = np.array([0.0, 0.0, 1.0])
    limits, independent = Limits(), None
    if axis_el is not None:
        xyz = axis_el.find('xyz')
        axis = unit_axis(
            None if xyz is None else xyz.text, source, f'{where} axis', (0.0, 0.0, 1.0)
        )
        if xyz is not None and (xyz.get('expressed_in') or '') not in ('', name):
            frame = xyz.get('expressed_in') or ''
            if not frames.exists(frame):
                raise DescriptionError(
                    'axis expressed_in an unknown frame', file=source, key=where, value=frame
                )
            # (the joint frame where the model is assembled: an axis expressed_in __model__ is
            # the model's direction however the child was drawn before it was joined)
            axis = (x_assembled[:3, :3].T @ frames.pose(frame)[:3, :3]) @ axis
        elif optional_bool(
            _text(axis_el, 'use_parent_model_frame'), source, f'{where} use_parent_model_frame'
        ):
            # SDFormat 1.6 and older: the axis is in the model frame (1.7: expressed_in)
            axis = x_assembled[:3, :3].T @ axis
        lim = axis_el.find('limit')
        if lim is not None:
            limits = limits_of(_text(lim, 'lower'), _text(lim, 'upper'), source, where)
            effort = optional_number(_text(lim, 'effort'), source, f'{where} limit effort')
            if effort == 0.0:
                independent = False
    return TreeJoint(
        name=name,
        type=_JOINT_TYPES.get(kind, JointType.OTHER),
        parent=parent,
        child=child,
        parent_to_joint=parent_to_joint,
        child_to_joint=child_to_joint,
        axis=axis,
        limits=limits,
        independent=independent,
        element=where,
    )


def _quaternion_pose(v: Sequence[float], source: str, where: str) -> np.ndarray:
    """The 4x4 transform of a quat_xyzw pose (x y z qx qy qz qw), the quaternion normalised (a
    zero one is no rotation: refused)."""
    from scipy.spatial.transform import Rotation

    q = np.array(v[3:], float)
    norm = float(np.linalg.norm(q))
    if not norm > 0.0:
        raise DescriptionError('pose quaternion of length 0', file=source, key=where)
    t = np.eye(4)
    t[:3, :3] = Rotation.from_quat(q / norm).as_matrix()  # scalar last, as SDFormat writes it
    t[:3, 3] = v[:3]
    return t


def _text(el: ET.Element, tag: str) -> str | None:
    sub = el.find(tag)
    return None if sub is None or sub.text is None else sub.text.strip()


def _pose_of(el: ET.Element | None, source: str, where: str) -> np.ndarray:
    if el is None or not (el.text or '').strip():
        return np.eye(4)
    fmt = el.get('rotation_format') or 'euler_rpy'
    if fmt == 'quat_xyzw':  # SDFormat 1.9: x y z, then the quaternion qx qy qz qw
        return _quaternion_pose(numbers(el.text, 7, source, f'{where} pose', ()), source, where)
    if fmt != 'euler_rpy':
        raise DescriptionError(
            f'pose rotation_format {fmt!r}: SDFormat has euler_rpy and quat_xyzw',
            file=source,
            key=where,
        )
    v = numbers(el.text, 6, source, f'{where} pose', ())
    scale = (
        math.pi / 180.0
        if optional_bool(el.get('degrees'), source, f'{where} pose degrees')
        else 1.0
    )
    return transform(v[:3], (v[3] * scale, v[4] * scale, v[5] * scale))  # type: ignore[arg-type]
