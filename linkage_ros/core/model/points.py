"""The reference pose's points: ``points`` of a general-form scene, each given as [x, y] (m) or
placed by its distances from two other points (the two-circle construction)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..dyads import TOGGLE_BAND, circle_circle
from ..units import Quantity
from .checks import SceneContext


def read_points(ctx: SceneContext, data: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """points: name -> [x, y] (m), the reference pose."""
    pts_raw = ctx.mapping('points', data.get('points'))
    if not pts_raw:
        ctx.fail('points', 'must name at least two points', pts_raw)
    points: dict[str, np.ndarray] = {}
    by_distances: dict[str, Mapping[str, Any]] = {}
    for pname, xy in pts_raw.items():
        ctx.name(f'points.{pname}', pname)
        if isinstance(xy, Mapping):  # placed by its distances from two other points
            by_distances[str(pname)] = xy
        else:
            points[pname] = ctx.xy(f'points.{pname}', xy)
    # in passes: a point may be placed from points placed by distances before it
    while by_distances:
        ready = [
            n
            for n, spec in by_distances.items()
            if isinstance(spec.get('distances'), Mapping)
            and all(q in points for q in spec['distances'])
        ]
        if not ready:
            name = next(iter(by_distances))
            spec = by_distances[name]
            dist = spec.get('distances')
            if not isinstance(dist, Mapping):
                ctx.fail(f'points.{name}.distances', 'must map two point names to m', dist)
            missing = [q for q in dist if q not in points and q not in by_distances]
            ctx.fail(
                f'points.{name}.distances',
                f'names unknown point(s) {missing}'
                if missing
                else 'the points it is placed from are placed from each other (a cycle)',
                list(dist),
            )
        for name in ready:
            points[name] = _point_from_distances(ctx, name, by_distances.pop(name), points)
    return points


def _point_from_distances(
    ctx: SceneContext, name: str, spec: Mapping[str, Any], points: Mapping[str, np.ndarray]
) -> np.ndarray:
    """``{distances: {A: r1, B: r2}, side: left | right}``: the point r1 from A and r2 from B
    (m), on the given side of the line A -> B (the two-circle construction). Tangent circles
    give their one common point (either side). Refused, naming the key, where the circles do
    not meet or A and B coincide."""
    key = f'points.{name}'
    ctx.only(key, spec, {'distances', 'side'})
    dist = spec['distances']
    if len(dist) != 2:
        ctx.fail(f'{key}.distances', 'must give the distances from exactly two points', list(dist))
    (a, r1_raw), (b, r2_raw) = dist.items()
    r1 = ctx.number(f'{key}.distances.{a}', r1_raw, quantity=Quantity.LENGTH, positive=True)
    r2 = ctx.number(f'{key}.distances.{b}', r2_raw, quantity=Quantity.LENGTH, positive=True)
    side = spec.get('side', 'left')
    if side not in ('left', 'right'):
        ctx.fail(f'{key}.side', "must be 'left' or 'right' of the line from the first point", side)
    pa, pb = points[a], points[b]
    if np.array_equal(pa, pb):
        ctx.fail(f'{key}.distances', f'{a} and {b} coincide: no line to place it from', list(dist))
    # the dyad solver's own circle-circle construction: circles that miss by more than the
    # toggle band do not meet; a tangency within it (decimal coordinates a rounding apart:
    # SCENES.md) lands on it
    sol = circle_circle(pa, r1, pb, r2, 1.0 if side == 'left' else -1.0, tol=TOGGLE_BAND)
    if not bool(sol.ok):
        d = float(math.hypot(*(pb - pa)))
        ctx.fail(
            f'{key}.distances',
            f'circles of {r1:g} m about {a} and {r2:g} m about {b} ({d:.9g} m apart) do not meet',
            dict(dist),
        )
    return np.asarray(sol.point, float)
