"""Constraints between links, written as the designer states them and compiled into the general
form's links and sliders (so every solver, the URDF and the outputs treat them as any other):

- ``slots``: a point of one link stays on a line fixed in another at a fixed angle (a pin in a
  slot: the angle-line constraint), or, with ``radius``, stays that far from it (a roller or a
  round jaw of that radius touching a flat face: circle-line tangency). Compiled as a pin block
  ``NAME_pin`` carrying the point, sliding on the line: a prismatic joint ``NAME`` whose value
  is the distance (m) along the line from ``through``.
- ``distances``: two points of different links keep a fixed distance (a constraint, not an
  actuator). Compiled as a binary link ``NAME`` between them.

The lengths they state (``radius``, ``length``) are stated dimensions (``NAME.offset``,
``NAME.P-Q``): used exactly, the drawing redrawn to them like any other.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..units import Quantity
from .checks import SceneContext


def expand_constraints(
    ctx: SceneContext, data: Mapping[str, Any], points: Mapping[str, np.ndarray]
) -> tuple[dict[str, Any], dict[str, float], frozenset[str]]:
    """The scene with its ``slots`` and ``distances`` compiled into links and sliders, the
    dimensions they state (name -> m), and the slots that are rollers (a ``radius`` > 0: the
    side of the face is an assembly choice, Mechanism.rollers)."""
    out = {k: v for k, v in data.items() if k not in ('slots', 'distances')}
    links = dict(ctx.mapping('links', data.get('links')))
    sliders = list(data.get('sliders') or [])
    if not isinstance(data.get('sliders') or [], list):
        ctx.fail('sliders', 'must be a list of prismatic joints', data.get('sliders'))
    stated: dict[str, float] = {}
    rollers: set[str] = set()
    taken = set(links) | {s.get('name') for s in sliders if isinstance(s, Mapping)}
    taken |= set(data.get('cylinders') or {})

    def new_name(key: str, value: object, makes_pin_block: bool) -> str:
        name = ctx.name(key, value)
        if name in taken:
            ctx.fail(key, 'is already the name of a link, slider, cylinder or constraint', name)
        # a slot also makes the link NAME_pin: say which name clashes, not only NAME
        if makes_pin_block and f'{name}_pin' in taken:
            ctx.fail(
                key,
                f"link name '{name}_pin' (made for the slot's pin block) is already used; "
                'give the slot another name',
                name,
            )
        taken.add(name)
        return name

    def carriers(p: str) -> list[str]:
        return [
            str(n)
            for n, members in links.items()
            if isinstance(members, (list, tuple)) and p in members
        ]

    for i, spec in enumerate(_entries(ctx, data, 'slots')):
        key = f'slots[{i}]'
        ctx.only(key, spec, {'name', 'point', 'link', 'through', 'angle', 'radius'})
        name = new_name(f'{key}.name', spec.get('name'), makes_pin_block=True)
        key = f'slots.{name}'
        point, link, through = spec.get('point'), spec.get('link'), spec.get('through')
        if not ctx.known(point, points):
            ctx.fail(f'{key}.point', 'must name a point', point)
        if not ctx.known(link, links):
            ctx.fail(f'{key}.link', 'must name the link the line is fixed in', link)
        point, link = str(point), str(link)
        if link in carriers(point):
            ctx.fail(
                f'{key}.link', f'carries {point!r} itself: the line must be in another link', link
            )
        if not carriers(point):
            ctx.fail(f'{key}.point', 'is on no link', point)
        members = links[link]
        if through is not None and (not ctx.known(through, points) or through not in members):
            ctx.fail(f'{key}.through', f'must name a point of link {link!r}', through)
        through = None if through is None else str(through)
        axis = _axis_angle(points, members)
        radius = None
        if 'radius' in spec:
            radius = ctx.number(f'{key}.radius', spec['radius'], quantity=Quantity.LENGTH)
            if radius < 0:
                ctx.fail(f'{key}.radius', 'must be >= 0 (m)', radius)
            if through is None:
                ctx.fail(
                    f'{key}.through', 'a face needs a point of the link it passes through', None
                )
            if 'angle' not in spec:
                ctx.fail(f'{key}.angle', "a face needs its angle from the link's axis (rad)", None)
        at = points[point]
        if 'angle' in spec:
            direction = axis + ctx.number(f'{key}.angle', spec['angle'], quantity=Quantity.ANGLE)
        elif through is not None and np.hypot(*(at - points[through])) > 0:
            v = at - points[through]
            direction = math.atan2(v[1], v[0])  # the slot runs from `through` toward the pin
        else:
            ctx.fail(f'{key}.angle', "give the line's angle from the link's axis (rad)", None)
        u = np.array([math.cos(direction), math.sin(direction)])
        block = f'{name}_pin'
        taken.add(block)
        links[block] = [point]
        slider: dict[str, Any] = {
            'name': name,
            'guide': link,
            'slider': block,
            'point': point,
            'direction': [float(u[0]), float(u[1])],
        }
        if through is not None:
            slider['origin'] = through
            if through != point:
                side = float(u[0] * (at - points[through])[1] - u[1] * (at - points[through])[0])
                # the pin on the line, or the roller's centre one radius off the face on the
                # side it is drawn (a centre drawn on the face: the left side)
                r = radius or 0.0
                stated[f'{name}.offset'] = math.copysign(r, side) if side else r
                if r > 0:
                    rollers.add(name)
        sliders.append(slider)

    for i, spec in enumerate(_entries(ctx, data, 'distances')):
        key = f'distances[{i}]'
        ctx.only(key, spec, {'name', 'between', 'length'})
        name = new_name(f'{key}.name', spec.get('name'), makes_pin_block=False)
        key = f'distances.{name}'
        pair = spec.get('between')
        if (
            not isinstance(pair, (list, tuple))
            or len(pair) != 2
            or not all(ctx.known(p, points) for p in pair)
            or pair[0] == pair[1]
        ):
            ctx.fail(f'{key}.between', 'must name two different points', pair)
        p, q = pair
        shared = set(carriers(p)) & set(carriers(q))
        if shared:
            ctx.fail(
                f'{key}.between',
                f'{p} and {q} are both on link {sorted(shared)[0]!r}: their distance is '
                'fixed already',
                list(pair),
            )
        if not np.hypot(*(points[p] - points[q])) > 0:
            ctx.fail(f'{key}.between', f'{p} and {q} coincide in the reference pose', list(pair))
        links[name] = [p, q]
        if 'length' in spec:
            stated[f'{name}.{p}-{q}'] = ctx.number(
                f'{key}.length', spec['length'], quantity=Quantity.LENGTH, positive=True
            )
    out['links'] = links
    if sliders:
        out['sliders'] = sliders
    return out, stated, frozenset(rollers)


def _entries(ctx: SceneContext, data: Mapping[str, Any], key: str) -> list[Mapping[str, Any]]:
    raw = data.get(key) or []
    if not isinstance(raw, list):
        ctx.fail(key, 'must be a list of mappings', raw)
    return [ctx.mapping(f'{key}[{i}]', e) for i, e in enumerate(raw)]


def _axis_angle(points: Mapping[str, np.ndarray], members: Any) -> float:
    """The reported direction of a link in the reference pose: first -> second point (rad), 0
    for a one-point link (as the loader makes it)."""
    if isinstance(members, (list, tuple)) and len(members) >= 2:
        a, b = points.get(members[0]), points.get(members[1])
        if a is not None and b is not None:
            v = b - a
            return math.atan2(v[1], v[0])
    return 0.0
