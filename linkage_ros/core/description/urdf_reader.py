"""URDF (as xacro and robot_state_publisher give it) with its closures: URDF+ ``<loop>``
(generalized_rbda: ``<predecessor>``/``<successor>``, also spelt ``sucessor``) and the urdfdom
``<constraint>`` proposal (``parent``/``child`` link, ``parent_origin``/``child_origin``)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

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
    Mimic,
    TreeJoint,
)
from .xml_text import limits_of, optional_bool, optional_number, origin_of, required, unit_axis

_JOINT_TYPES = {
    'revolute': JointType.REVOLUTE,
    'continuous': JointType.REVOLUTE,
    'prismatic': JointType.PRISMATIC,
    'fixed': JointType.FIXED,
    'floating': JointType.OTHER,
    'planar': JointType.OTHER,
}
#: closure types a planar chain can have, and what each makes coincide
_CLOSURE_TYPES = {
    'revolute': ClosureType.REVOLUTE,
    'continuous': ClosureType.REVOLUTE,
    'spherical': ClosureType.REVOLUTE,  # a ball in a planar chain turns about the normal only
    'prismatic': ClosureType.PRISMATIC,
}


def read_urdf(root: ET.Element, source: str) -> Description:
    """A ``<robot>`` element as a tree plus the closures it states."""
    links: list[str] = []
    for el in root.findall('link'):
        name = required(el, 'name', source, 'link')
        if name in links:
            raise DescriptionError(f'link {name!r} is defined twice', file=source)
        links.append(name)
    joints = [_joint(el, source, set(links)) for el in root.findall('joint')]
    names = [j.name for j in joints]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise DescriptionError(f'joint {twice[0]!r} is defined twice', file=source)
    for j in joints:  # (a follower of no joint was dropped from joint_states without a word)
        if j.mimic is not None and (j.mimic.joint == j.name or j.mimic.joint not in names):
            raise DescriptionError(
                'its <mimic> follows itself'
                if j.mimic.joint == j.name
                else '<mimic> names an unknown joint',
                file=source,
                key=f'joint {j.name!r}',
                value=j.mimic.joint,
            )
    closures = [_loop(el, source, set(links)) for el in root.findall('loop')]
    closures += [_constraint(el, source, set(links)) for el in root.findall('constraint')]
    root_link = tree_root(links, joints, source)
    return Description(
        name=root.get('name') or 'robot',
        source=source,
        root=root_link,
        links=tuple(links),
        joints=tuple(joints),
        frames={j.name: LinkFrame(j.parent, j.parent_to_joint, joint=j.name) for j in joints},
        closures=tuple(closures),
        format=DescriptionFormat.URDF,
    )


def tree_root(links: list[str], joints: list[TreeJoint], source: str) -> str:
    """The one link that is no joint's child; refuses a link with two parents, a cycle of
    tree joints, and a forest."""
    parent_of: dict[str, str] = {}
    for j in joints:
        if j.child in parent_of:
            raise DescriptionError(
                f'link {j.child!r} is the child of two joints ({parent_of[j.child]!r} and '
                f'{j.name!r}); state the second as a closure (<loop> or <constraint>)',
                file=source,
            )
        parent_of[j.child] = j.name
    if not links:
        raise DescriptionError('the description has no links', file=source)
    roots = [l for l in links if l not in parent_of]
    if len(roots) != 1:
        what = (
            'no root link (the joints form a cycle)'
            if not roots
            else (f'{len(roots)} root links ({", ".join(roots[:4])}): the links are not one tree')
        )
        raise DescriptionError(what, file=source)
    return roots[0]


def _joint(el: ET.Element, source: str, links: set[str]) -> TreeJoint:
    name = required(el, 'name', source, 'joint')
    where = f'joint {name!r}'
    kind = el.get('type', '')
    if kind not in _JOINT_TYPES:
        raise DescriptionError(
            f'type {kind!r} is not a URDF joint type ({", ".join(_JOINT_TYPES)})',
            file=source,
            key=where,
        )
    parent, child = (_link_of(el, tag, source, where, links) for tag in ('parent', 'child'))
    axis_el = el.find('axis')
    axis = np.array([1.0, 0.0, 0.0])
    if axis_el is not None and _JOINT_TYPES[kind] in (JointType.REVOLUTE, JointType.PRISMATIC):
        axis = unit_axis(axis_el.get('xyz'), source, f'{where} axis')
    lim = el.find('limit')
    limits = Limits()
    if lim is not None and kind != 'continuous':
        limits = limits_of(lim.get('lower'), lim.get('upper'), source, where)
    mimic = None
    mel = el.find('mimic')
    if mel is not None:
        multiplier = optional_number(mel.get('multiplier'), source, f'{where} mimic multiplier')
        offset = optional_number(mel.get('offset'), source, f'{where} mimic offset')
        mimic = Mimic(
            joint=required(mel, 'joint', source, f'{where} mimic'),
            multiplier=1.0 if multiplier is None else multiplier,
            offset=offset or 0.0,
        )
    independent = optional_bool(el.get('independent'), source, f'{where} independent')
    return TreeJoint(
        name=name,
        type=_JOINT_TYPES[kind],
        parent=parent,
        child=child,
        parent_to_joint=origin_of(el.find('origin'), source, f'{where} origin'),
        child_to_joint=np.eye(4),
        axis=axis,
        limits=limits,
        mimic=mimic,
        independent=independent,
        element=where,
    )


def _link_of(el: ET.Element, tag: str, source: str, where: str, links: set[str]) -> str:
    sub = el.find(tag)
    if sub is None:
        raise DescriptionError(f'has no <{tag}>', file=source, key=where)
    link = required(sub, 'link', source, f'{where} {tag}')
    if link not in links:
        raise DescriptionError(f'{tag} names an unknown link', file=source, key=where, value=link)
    return link


def _closure_type(el: ET.Element, source: str, where: str) -> ClosureType:
    kind = (el.get('type') or 'revolute').strip()
    if kind not in _CLOSURE_TYPES:
        raise DescriptionError(
            f'type {kind!r} cannot close a planar chain (revolute, continuous, spherical or '
            'prismatic)',
            file=source,
            key=where,
        )
    return _CLOSURE_TYPES[kind]


def _loop(el: ET.Element, source: str, links: set[str]) -> Closure:
    """URDF+ ``<loop name type><predecessor link><origin/></predecessor><successor ...>
    <axis/></loop>``."""
    name = required(el, 'name', source, 'loop')
    where = f'loop {name!r}'
    ends = []
    for tags in (('predecessor',), ('successor', 'sucessor')):
        sub = next((s for t in tags if (s := el.find(t)) is not None), None)
        if sub is None:
            raise DescriptionError(f'has no <{tags[0]}>', file=source, key=where)
        link = required(sub, 'link', source, f'{where} {tags[0]}')
        if link not in links:
            raise DescriptionError(
                f'{tags[0]} names an unknown link', file=source, key=where, value=link
            )
        ends.append(LinkFrame(link, origin_of(sub.find('origin'), source, f'{where} {tags[0]}')))
    axis_el = el.find('axis')
    axis = None if axis_el is None else unit_axis(axis_el.get('xyz'), source, f'{where} axis')
    return Closure(name, _closure_type(el, source, where), ends[0], ends[1], axis, where)


def _constraint(el: ET.Element, source: str, links: set[str]) -> Closure:
    """urdfdom proposal: ``<constraint name type><parent link/><parent_origin/>
    <parent_axis/><child link/><child_origin/><child_axis/></constraint>``."""
    name = required(el, 'name', source, 'constraint')
    where = f'constraint {name!r}'
    ends = []
    for side in ('parent', 'child'):
        link = _link_of(el, side, source, where, links)
        ends.append(
            LinkFrame(link, origin_of(el.find(f'{side}_origin'), source, f'{where} {side}_origin'))
        )
    axis_el = el.find('parent_axis')
    axis = None if axis_el is None else unit_axis(axis_el.get('xyz'), source, f'{where} axis')
    return Closure(name, _closure_type(el, source, where), ends[0], ends[1], axis, where)
