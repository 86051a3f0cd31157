"""The shortcut forms (four_bar, slider_crank), compiled into the general form."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..analysis import fourbar_input_intervals
from ..units import Quantity
from .actuators import read_limits
from .checks import SceneContext

#: a crank's reference points (A and the output point), (2,) arrays in m
_Points = tuple[np.ndarray, np.ndarray]

# ---- shortcut forms --------------------------------------------------------------------------


def _branch(ctx: SceneContext, key: str, value: object) -> int:
    if isinstance(value, bool):  # True == 1: `branch: true` must not pass for +1
        ctx.fail(key, "must be +1 or -1 (or '+' / '-')", value)
    if value in (1, '+', '+1'):
        return 1
    if value in (-1, '-', '-1'):
        return -1
    ctx.fail(key, "must be +1 or -1 (or '+' / '-')", value)
    return 1


def _crank_actuator(ctx: SceneContext, key: str, spec: Mapping[str, Any]) -> dict[str, Any]:
    """The shortcut forms' crank: the angle of O2 -> A, with optional crank_limits."""
    crank: dict[str, Any] = {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}
    if 'crank_limits' in spec:
        lim = ctx.mapping(f'{key}.crank_limits', spec['crank_limits'])
        ctx.only(f'{key}.crank_limits', lim, {'min', 'max'})
        lo, hi = read_limits(ctx, f'{key}.crank_limits', lim, Quantity.ANGLE)
        crank.update({k: v for k, v in (('min', lo), ('max', hi)) if v is not None})
    return crank


def _reference_input(
    ctx: SceneContext,
    key: str,
    spec: Mapping[str, Any],
    start: float,
    assemble: Callable[[float], _Points | None],
    lengths: list[float],
    intervals: Callable[[], list[tuple[float, float]]],
) -> _Points:
    """The reference crank angle: ``input`` if given (it must assemble), else the first angle
    that assembles stepping out from ``start`` (60 degrees above the ground line) both ways by
    about 0.01 rad: inside the reachable range, up to a step short of a toggle, not on it
    (docs/SCENES.md, "The default input"). ``assemble(theta)`` returns the
    reference points or None; ``intervals()`` lists the (lo, hi) crank angles that assemble
    (exact, from the closure condition)."""
    if 'input' in spec:
        theta = ctx.number(f'{key}.input', spec['input'], quantity=Quantity.ANGLE)
        pts = assemble(theta)
        if pts is None:
            if not intervals():  # no crank angle at all: the lengths are what is wrong
                ctx.fail(key, 'these lengths do not assemble at any crank angle', lengths)
            ctx.fail(f'{key}.input', 'the mechanism does not assemble at this crank angle', theta)
        return pts
    steps = np.repeat(np.linspace(0.01, np.pi, 315), 2) * np.tile([1, -1], 315)
    for theta in start + np.concatenate([[0.0], steps]):
        pts = assemble(float(theta))
        if pts is not None:
            return pts
    # The 0.01 rad grid misses a range narrower than its step (a short rod or coupler): try the
    # middle of each exact range, nearest ``start`` first (the middle is furthest from a toggle).
    mids = [0.5 * (lo + hi) for lo, hi in intervals()]
    for theta in sorted(mids, key=lambda t: abs(math.remainder(t - start, 2 * math.pi))):
        pts = assemble(theta)
        if pts is not None:
            return pts
    ctx.fail(key, 'these lengths do not assemble at any crank angle', lengths)


def four_bar_to_general(
    ctx: SceneContext, data: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    from ..dyads import circle_circle

    fb = ctx.mapping('four_bar', data['four_bar'])
    ctx.only(
        'four_bar',
        fb,
        {
            'ground',
            'crank',
            'coupler',
            'rocker',
            'ground_angle',
            'pivots',
            'coupler_point',
            'input',
            'branch',
            'crank_limits',
        },
    )
    l2 = ctx.number('four_bar.crank', fb.get('crank'), quantity=Quantity.LENGTH, positive=True)
    l3 = ctx.number('four_bar.coupler', fb.get('coupler'), quantity=Quantity.LENGTH, positive=True)
    l4 = ctx.number('four_bar.rocker', fb.get('rocker'), quantity=Quantity.LENGTH, positive=True)
    if 'pivots' in fb:
        piv = ctx.mapping('four_bar.pivots', fb['pivots'])
        ctx.only('four_bar.pivots', piv, {'O2', 'O4'})
        o2 = ctx.xy('four_bar.pivots.O2', piv.get('O2'))
        o4 = ctx.xy('four_bar.pivots.O4', piv.get('O4'))
        l1 = float(np.hypot(*(o4 - o2)))
        if not l1 > 0:
            ctx.fail('four_bar.pivots', 'O2 and O4 coincide', fb['pivots'])
        if 'ground' in fb:
            g = ctx.number('four_bar.ground', fb['ground'], quantity=Quantity.LENGTH, positive=True)
            if abs(g - l1) > 1e-9 * max(g, l1):
                ctx.fail('four_bar.ground', f'disagrees with |O2O4| = {l1!r} from pivots', g)
        if 'ground_angle' in fb:
            ctx.fail(
                'four_bar.ground_angle', 'give pivots or ground_angle, not both', fb['ground_angle']
            )
        gang = math.atan2(*(o4 - o2)[::-1])
    else:
        l1 = ctx.number(
            'four_bar.ground', fb.get('ground'), quantity=Quantity.LENGTH, positive=True
        )
        gang = ctx.number(
            'four_bar.ground_angle', fb.get('ground_angle', 0.0), quantity=Quantity.ANGLE
        )
        o2 = np.zeros(2)
        o4 = o2 + l1 * np.array([math.cos(gang), math.sin(gang)])
    branch = _branch(ctx, 'four_bar.branch', fb.get('branch', 1))

    def assemble(theta: float) -> _Points | None:
        a = o2 + l2 * np.array([math.cos(theta), math.sin(theta)])
        b, _, ok, _, _ = circle_circle(a, l3, o4, l4, branch)
        return (a, b) if ok and np.hypot(*(b - a)) > 0 else None

    def intervals() -> list[tuple[float, float]]:
        try:
            ivs = fourbar_input_intervals(l1, l2, l3, l4)
        except ValueError:  # assembles nowhere
            return []
        # None (turns fully) cannot reach here: the grid's first angle assembles
        return [] if ivs is None else [(gang + lo, gang + hi) for lo, hi in ivs]

    a, b = _reference_input(
        ctx, 'four_bar', fb, gang + np.pi / 3, assemble, [l1, l2, l3, l4], intervals
    )
    points = {'O2': o2, 'A': a, 'B': b, 'O4': o4}
    coupler = ['A', 'B']
    cp = fb.get('coupler_point')
    if cp is not None:
        cp = ctx.mapping('four_bar.coupler_point', cp)
        ctx.only('four_bar.coupler_point', cp, {'name', 'distance', 'angle'})
        pname = ctx.name('four_bar.coupler_point.name', cp.get('name', 'P'))
        if pname in points:
            ctx.fail('four_bar.coupler_point.name', 'clashes with O2, A, B or O4', pname)
        dist = ctx.number(
            'four_bar.coupler_point.distance', cp.get('distance'), quantity=Quantity.LENGTH
        )
        ang = ctx.number(
            'four_bar.coupler_point.angle', cp.get('angle', 0.0), quantity=Quantity.ANGLE
        )
        t3 = math.atan2(*(b - a)[::-1])
        with np.errstate(over='ignore'):  # beyond the float range: refused below as not finite
            points[pname] = a + dist * np.array([math.cos(t3 + ang), math.sin(t3 + ang)])
        if not np.all(np.isfinite(points[pname])):
            ctx.fail(
                'four_bar.coupler_point.distance',
                'puts the coupler point beyond the float range',
                cp.get('distance'),
            )
        # the general form would refuse it under links.coupler, a key this file does not have
        for other in ('A', 'B'):
            if np.array_equal(points[pname], points[other]):
                ctx.fail(
                    'four_bar.coupler_point.distance',
                    f'puts {pname} on {other} (at {points[other].tolist()}): two points of one '
                    f'rigid link are one point; give another distance or angle, or drop '
                    f'coupler_point and publish {other} itself (outputs: [{other}])',
                    cp.get('distance'),
                )
        coupler.append(pname)
    crank = _crank_actuator(ctx, 'four_bar', fb)
    general = {
        'points': {k: [float(v[0]), float(v[1])] for k, v in points.items()},
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': coupler,
            'rocker': ['O4', 'B'],
        },
        'actuators': {'crank': crank},
        'outputs': coupler[2:],
    }
    return general, {
        'form': 'four_bar',
        'ground': l1,
        'crank': l2,
        'coupler': l3,
        'rocker': l4,
        'ground_angle': gang,
        'branch': branch,
    }


def slider_crank_to_general(
    ctx: SceneContext, data: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    sc = ctx.mapping('slider_crank', data['slider_crank'])
    ctx.only(
        'slider_crank',
        sc,
        {'crank', 'rod', 'offset', 'direction', 'input', 'branch', 'crank_limits'},
    )
    r = ctx.number('slider_crank.crank', sc.get('crank'), quantity=Quantity.LENGTH, positive=True)
    rod = ctx.number('slider_crank.rod', sc.get('rod'), quantity=Quantity.LENGTH, positive=True)
    e = ctx.number('slider_crank.offset', sc.get('offset', 0.0), quantity=Quantity.LENGTH)
    dang = ctx.number('slider_crank.direction', sc.get('direction', 0.0), quantity=Quantity.ANGLE)
    branch = _branch(ctx, 'slider_crank.branch', sc.get('branch', 1))
    d = np.array([math.cos(dang), math.sin(dang)])
    n = np.array([-d[1], d[0]])
    o2 = np.zeros(2)
    foot = o2 + e * n

    def assemble(theta: float) -> _Points | None:
        a = o2 + r * np.array([math.cos(theta), math.sin(theta)])
        dy = e - float(np.dot(a, n))
        if rod - abs(dy) < 0:
            return None
        # roots factor by factor: the product underflows for lengths near 1e-300
        x = float(np.dot(a, d)) + branch * math.sqrt(rod - abs(dy)) * math.sqrt(rod + abs(dy))
        return a, foot + x * d

    def intervals() -> list[tuple[float, float]]:
        # A's height over the line of stroke is r sin(phi), phi = theta - direction; the rod
        # reaches the line iff |e - r sin(phi)| <= rod
        lo, hi = max((e - rod) / r, -1.0), min((e + rod) / r, 1.0)
        if lo > hi:
            return []
        a0, a1 = math.asin(lo), math.asin(hi)
        return [(dang + a0, dang + a1), (dang + math.pi - a1, dang + math.pi - a0)]

    a, b = _reference_input(
        ctx, 'slider_crank', sc, dang + np.pi / 3, assemble, [r, rod, e], intervals
    )
    crank = _crank_actuator(ctx, 'slider_crank', sc)
    general = {
        'points': {
            'O2': [0.0, 0.0],
            'A': [float(a[0]), float(a[1])],
            'B': [float(b[0]), float(b[1])],
        },
        'links': {'ground': ['O2'], 'crank': ['O2', 'A'], 'rod': ['A', 'B'], 'slider': ['B']},
        'sliders': [
            {
                'name': 'slider',
                'guide': 'ground',
                'slider': 'slider',
                'point': 'B',
                'direction': [float(d[0]), float(d[1])],
                'origin': [float(foot[0]), float(foot[1])],
            }
        ],
        'actuators': {'crank': crank},
        'outputs': [],
    }
    return general, {
        'form': 'slider_crank',
        'crank': r,
        'rod': rod,
        'offset': e,
        'direction': dang,
        'branch': branch,
    }
