"""A JointMap as the scene file's ``joint_coordinates`` key (what ``linkage import`` writes)
and back."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from .checks import Fail
from .joint_map import InputJoint, JointMap, OutputJoint, OutputKind, Plane

_OUTPUT_KEYS = {
    'name',
    'joint',
    'scale',
    'offset',
    'revolute',
    'lower',
    'upper',
    'constant',
    'mimic',
}
_TOP_KEYS = {'actuated', 'outputs', 'inputs', 'plane'}
_INPUT_KEYS = {
    'name',
    'known',
    'scale',
    'offset',
    'revolute',
    'leader',
    'multiplier',
    'mimic_offset',
}


def joint_map_to_dict(jmap: JointMap) -> dict[str, Any]:
    """The scene-file form of a JointMap (read back by :func:`joint_map_from_dict`)."""
    outputs: list[dict[str, Any]] = []
    for o in jmap.outputs:
        if o.kind is OutputKind.CONSTANT:
            outputs.append({'name': o.name, 'constant': o.offset})
            continue
        item: dict[str, Any] = {'name': o.name}
        if o.kind is OutputKind.MIMIC:
            item['mimic'] = o.leader
        else:
            item['joint'] = o.scene_joint
        item['revolute'] = o.revolute
        item.update(scale=o.scale, offset=o.offset)
        if o.lower is not None:
            item['lower'] = o.lower
        if o.upper is not None:
            item['upper'] = o.upper
        outputs.append(item)
    inputs = []
    for i in jmap.inputs.values():
        item = {
            'name': i.name,
            'known': i.scene_name,
            'scale': i.scale,
            'offset': i.offset,
            'revolute': i.revolute,
        }
        if i.leader:
            item.update(leader=i.leader, multiplier=i.multiplier, mimic_offset=i.mimic_offset)
        inputs.append(item)
    out: dict[str, Any] = {'actuated': list(jmap.actuated), 'outputs': outputs, 'inputs': inputs}
    if jmap.plane is not None:
        p = jmap.plane
        out['plane'] = {
            'e1': list(p.e1),
            'e2': list(p.e2),
            'normal': list(p.normal),
            'depths': dict(p.depths),
        }
    return out


def joint_map_from_dict(
    data: Any, scene_joints: Sequence[str], knowns: Sequence[str], fail: Fail
) -> JointMap:
    """A scene's ``joint_coordinates`` -> JointMap; ``fail(key, message, value)`` raises the
    scene's error naming the key. ``scene_joints``: the scene's joints; ``knowns``: its
    actuators and joints (what an input may stand for)."""
    key = 'joint_coordinates'
    if not isinstance(data, Mapping):
        fail(key, 'must be a mapping of actuated, outputs, inputs and plane', data)
    unknown = sorted(set(map(str, data)) - _TOP_KEYS)
    if unknown:
        fail(
            key,
            f'unknown key(s) {unknown} (known: actuated, outputs, inputs, plane)',
            has_value=False,
        )
    outputs: list[OutputJoint] = []
    seen: set[str] = set()
    for k, item in enumerate(_list(data.get('outputs'), f'{key}.outputs', fail)):
        where = f'{key}.outputs[{k}]'
        name = _item_name(item, _OUTPUT_KEYS, where, fail)
        if name in seen:
            fail(where, 'names a joint twice', name)
        if 'constant' in item:
            outputs.append(
                OutputJoint(name, OutputKind.CONSTANT, offset=_num(item['constant'], where, fail))
            )
        elif 'mimic' in item:
            if item['mimic'] not in seen:
                fail(where, 'a mimic follows a joint listed before it', item['mimic'])
            outputs.append(
                OutputJoint(
                    name,
                    OutputKind.MIMIC,
                    scale=_num(item.get('scale', 1.0), where, fail),
                    offset=_num(item.get('offset', 0.0), where, fail),
                    revolute=_flag(item.get('revolute', True), where, fail),
                    leader=item['mimic'],
                )
            )
        else:
            joint = item.get('joint')
            if joint not in scene_joints:
                fail(where, 'joint must name a joint of the scene', joint)
            outputs.append(
                OutputJoint(
                    name,
                    OutputKind.JOINT,
                    joint,
                    _unit(item.get('scale', 1.0), where, fail),
                    _num(item.get('offset', 0.0), where, fail),
                    _flag(item.get('revolute', True), where, fail),
                    lower=_opt(item.get('lower'), where, fail),
                    upper=_opt(item.get('upper'), where, fail),
                )
            )
        seen.add(name)
    inputs: list[InputJoint] = []
    for k, item in enumerate(_list(data.get('inputs'), f'{key}.inputs', fail)):
        where = f'{key}.inputs[{k}]'
        name = _item_name(item, _INPUT_KEYS, where, fail)
        known = item.get('known')
        if known not in knowns:
            fail(where, 'known must name an actuator or joint of the scene', known)
        leader = item.get('leader', '')
        inputs.append(
            InputJoint(
                name,
                known,
                _unit(item.get('scale', 1.0), where, fail),
                _num(item.get('offset', 0.0), where, fail),
                _flag(item.get('revolute', True), where, fail),
                leader=str(leader),
                multiplier=_num(item.get('multiplier', 1.0), where, fail),
                mimic_offset=_num(item.get('mimic_offset', 0.0), where, fail),
            )
        )
    actuated = _list(data.get('actuated'), f'{key}.actuated', fail)
    if not all(isinstance(a, str) and a in seen for a in actuated):
        fail(f'{key}.actuated', 'must name published joints', actuated)
    return JointMap(outputs, inputs, actuated, _plane(data.get('plane'), f'{key}.plane', fail))


def _plane(data: Any, key: str, fail: Fail) -> Plane | None:
    if data is None:
        return None
    want = {'e1', 'e2', 'normal', 'depths'}
    if not isinstance(data, Mapping):
        fail(key, 'must map e1, e2, normal (3 numbers each) and depths ({point: m})', data)
    missing, unknown = sorted(want - set(map(str, data))), sorted(set(map(str, data)) - want)
    if missing or unknown:
        what = [f'missing {missing}'] * bool(missing) + [f'unknown {unknown}'] * bool(unknown)
        fail(
            key,
            'must map e1, e2, normal (3 numbers each) and depths ({point: m}): ' + ', '.join(what),
            has_value=False,
        )
    axes: list[tuple[float, float, float]] = []
    for k in ('e1', 'e2', 'normal'):
        v = data[k]
        if not isinstance(v, list) or len(v) != 3:
            fail(f'{key}.{k}', 'must be 3 numbers', v)
        x, y, z = (_num(c, f'{key}.{k}', fail) for c in v)
        axes.append((x, y, z))
    depths = data['depths']
    if not isinstance(depths, Mapping):
        fail(f'{key}.depths', 'must map point names to m', depths)
    return Plane(
        axes[0],
        axes[1],
        axes[2],
        depths={str(n): _num(d, f'{key}.depths', fail) for n, d in depths.items()},
    )


def _list(value: Any, key: str, fail: Fail) -> list[Any]:
    if value is None:
        return []
    if not isinstance(value, list):
        fail(key, 'must be a list', value)
    return value


def _item_name(item: Any, allowed: set[str], where: str, fail: Fail) -> str:
    if not isinstance(item, Mapping):
        fail(where, 'must be a mapping', item)
    unknown = sorted(set(map(str, item)) - allowed)
    if unknown:
        fail(where, f'unknown key(s) {unknown}', has_value=False)
    name = item.get('name')
    if not isinstance(name, str) or not name:
        fail(where, 'needs a name', name)
    return name


def _num(value: Any, where: str, fail: Fail) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        fail(where, 'must be a finite number', value)
    return float(value)


def _flag(value: Any, where: str, fail: Fail) -> bool:
    """A yes/no key (``revolute``): true or false as YAML writes them; a string such as
    'false' is refused (bool() would read it as true)."""
    if not isinstance(value, bool):
        fail(where, 'revolute must be true or false', value)
    return value


def _opt(value: Any, where: str, fail: Fail) -> float | None:
    return None if value is None else _num(value, where, fail)


def _unit(value: Any, where: str, fail: Fail) -> float:
    v = _num(value, where, fail)
    if v not in (1.0, -1.0):
        fail(where, 'scale must be 1 or -1', value)
    return v
