"""The scene file's prismatic pairs: ``cylinders`` (a barrel and a rod link, their prismatic
joint and its actuator each) and ``sliders`` (a prismatic joint between two links)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..mechanism import Actuator, Link, PrismaticJoint, SlideActuator
from ..units import Quantity
from .actuators import read_limits
from .checks import SceneContext


def read_cylinders(
    ctx: SceneContext,
    data: Mapping[str, Any],
    points: Mapping[str, np.ndarray],
    links: dict[str, Link],
    prismatics: dict[str, PrismaticJoint],
    actuators: dict[str, Actuator],
) -> None:
    """cylinders: each adds a barrel and a rod link, their prismatic joint and its actuator."""
    # cylinders: barrel pinned at `from`, rod pinned at `to`, a prismatic pair between them
    cyl_raw = data.get('cylinders') or {}
    ctx.mapping('cylinders', cyl_raw)
    for cname, spec in cyl_raw.items():
        key = f'cylinders.{cname}'
        ctx.name(key, cname)
        if cname in links:
            ctx.fail(key, 'is the name of a link; a cylinder needs a name of its own', cname)
        spec = ctx.mapping(key, spec)
        ctx.only(key, spec, {'from', 'to', 'min', 'max'})
        a = ctx.member(f'{key}.from', spec.get('from'), points, 'must name a point')
        b = ctx.member(f'{key}.to', spec.get('to'), points, 'must name a point')
        axis = points[b] - points[a]
        length = float(np.hypot(*axis))
        if not length > 0:
            ctx.fail(key, 'pins `from` and `to` coincide in the reference pose', [a, b])
        both = [ln.name for ln in links.values() if a in ln.points and b in ln.points]
        if both:  # a rigid length: it drives nothing (and leaves the mechanism undriven)
            ctx.fail(
                key,
                f'pins `from` and `to` are both points of link {both[0]!r}, so their distance '
                'is fixed and the cylinder drives nothing; pin its ends on two links that move '
                'relative to each other',
                [a, b],
            )
        barrel, rod = f'{cname}_barrel', f'{cname}_rod'
        for ln in (barrel, rod):
            if ln in links:
                ctx.fail(key, f'link name {ln!r} (made for the cylinder) is already used', ln)
        ang = math.atan2(axis[1], axis[0])
        links[barrel] = Link(barrel, (a,), angle_ref=ang)
        links[rod] = Link(rod, (b,), angle_ref=ang)
        u = axis / length
        prismatics[cname] = PrismaticJoint(
            cname,
            barrel,
            rod,
            b,
            (float(u[0]), float(u[1])),
            (float(points[a][0]), float(points[a][1])),
            length,
        )
        lo, hi = read_limits(ctx, key, spec, Quantity.LENGTH)
        if lo is not None and lo <= 0:
            ctx.fail(f'{key}.min', 'a cylinder length must be > 0', lo)
        actuators[cname] = SlideActuator(cname, joint=cname, min=lo, max=hi, cylinder=True)


def read_sliders(
    ctx: SceneContext,
    data: Mapping[str, Any],
    points: Mapping[str, np.ndarray],
    links: Mapping[str, Link],
    prismatics: dict[str, PrismaticJoint],
) -> None:
    """sliders: prismatic joints between two links."""
    sliders_raw = data.get('sliders') or []
    if not isinstance(sliders_raw, list):
        ctx.fail('sliders', 'must be a list of prismatic joints', sliders_raw)
    for i, spec in enumerate(sliders_raw):
        key = f'sliders[{i}]'
        spec = ctx.mapping(key, spec)
        ctx.only(key, spec, {'name', 'guide', 'slider', 'point', 'direction', 'origin'})
        jname = ctx.name(f'{key}.name', spec.get('name'))
        key = f'sliders.{jname}'
        if jname in prismatics:
            ctx.fail(key, 'duplicate prismatic joint name', jname)
        guide_v, slider_v, point_v = spec.get('guide'), spec.get('slider'), spec.get('point')
        roles = {'guide': 'the link the slide line is fixed in', 'slider': 'the link that slides'}
        for k, v in (('guide', guide_v), ('slider', slider_v)):
            if v is None:  # not "(got None)": say what is missing
                ctx.fail(f'{key}.{k}', f'is missing: name {roles[k]}', has_value=False)
        guide = ctx.member(f'{key}.guide', guide_v, links, f'must name a link ({roles["guide"]})')
        slider = ctx.member(
            f'{key}.slider', slider_v, links, f'must name a link ({roles["slider"]})'
        )
        if guide == slider:
            ctx.fail(f'{key}.slider', 'must differ from the guide link', slider)
        if point_v is None:
            ctx.fail(
                f'{key}.point',
                f'is missing: name the point of {slider!r} that runs on the line',
                has_value=False,
            )
        point = ctx.member(
            f'{key}.point',
            point_v,
            links[slider].points,
            f'must be a point of the slider link {slider!r}',
        )
        d = spec.get('direction', 0.0)
        if isinstance(d, (list, tuple)):
            dv = ctx.xy(f'{key}.direction', d, quantity=None)
        else:
            ang = ctx.number(f'{key}.direction', d, quantity=Quantity.ANGLE)
            dv = np.array([math.cos(ang), math.sin(ang)])
        n = float(np.hypot(*dv))
        if not n > 0:
            ctx.fail(f'{key}.direction', 'must be a non-zero vector', d)
        dv = dv / n
        o = spec.get('origin', point)
        if isinstance(o, str):
            if not ctx.known(o, points):
                ctx.fail(f'{key}.origin', 'must name a point or be [x, y]', o)
            ov = points[o]
        else:
            ov = ctx.xy(f'{key}.origin', o)
        ref_value = float(np.dot(points[point] - ov, dv))
        prismatics[jname] = PrismaticJoint(
            jname,
            guide,
            slider,
            point,
            (float(dv[0]), float(dv[1])),
            (float(ov[0]), float(ov[1])),
            ref_value,
        )
