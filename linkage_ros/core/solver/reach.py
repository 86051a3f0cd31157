"""Where a point target out of reach stops being reachable: on the way from the current
configuration to the target (every known of the target's solve moved together, the point on a
straight line), the last reachable position, found by bisection with the target's own solver.

A refusal can then say what is true in the user's terms: ``point L = (9, -0.25) m is out of
reach: on the straight way there from the current configuration it is reachable up to
(6.61, 0.12) m, 2.42 m short``; for one coordinate known, ``D.x = 10 m is out of reach: ...
reachable up to D.x = 2.475 m, 7.525 m short``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..quantities import CoordinateSpec, PointSpec
from .newton_path import interpolate
from .reading import configuration_of, known_values
from .result import Result
from .solver import Solver

#: bisection steps along the line (the edge to 2^-40 of the line's length)
EDGE_STEPS = 40


@dataclass(frozen=True)
class ReachEdge:
    """The reachable edge toward a point target (or one coordinate's: ``coordinate`` its
    name, ``target`` and ``edge`` one value each): its position (m) and how far short of the
    target it is (m)."""

    point: str
    target: tuple[float, ...]
    edge: tuple[float, ...]
    short_m: float
    coordinate: str = ''

    def describe(self) -> str:
        way = 'is out of reach: on the straight way there from the current configuration it is'
        if self.coordinate:
            name = self.coordinate
            return (
                f'{name} = {self.target[0]:.6g} m {way} reachable up to {name} = '
                f'{self.edge[0]:.6g} m, {self.short_m:.6g} m short'
            )
        (tx, ty), (ex, ey) = self.target, self.edge
        return (
            f'point {self.point} = ({tx:.6g}, {ty:.6g}) m {way} reachable up to ({ex:.6g}, '
            f'{ey:.6g}) m, {self.short_m:.6g} m short'
        )


def reach_edge(solver: Solver, values: Mapping[str, Any], here: Result) -> ReachEdge | None:
    """Where the (first) point target of ``values`` (a command of ``solver``, refused), else its
    first coordinate known, stops being reachable on the way from ``here`` (the current
    configuration, a Result of this mechanism) to the target, every known moved together
    (angles the short way round); None when the solve has neither, gives two points of one
    link, or ``here`` is not a configuration of the mechanism."""
    c = solver.compiled
    k = next((i for i, s in enumerate(c.specs) if isinstance(s, PointSpec)), None)
    if k is None:
        k = next((i for i, s in enumerate(c.specs) if isinstance(s, CoordinateSpec)), None)
    if k is None or c.point_pairs:
        return None
    spec = c.specs[k]
    assert isinstance(spec, PointSpec | CoordinateSpec)
    got = configuration_of(c, here)
    try:
        target = c.parse(values)
    except ValueError:
        return None
    if got is None:
        return None
    start = known_values(c, got[1])

    def command(s: float) -> dict[str, Any]:
        vals = interpolate(c, start, target, s)
        return {
            sp.name: (tuple(float(v) for v in val) if isinstance(sp, PointSpec) else float(val))
            for sp, val in zip(c.specs, vals)
        }

    def reaches(s: float) -> bool:
        return solver.solve(command(s), commit=False).success

    if not reaches(0.0):
        return None
    lo, hi = 0.0, 1.0
    # a target far beyond the mechanism (1e300 m): bisect from where the point could be at
    # most, or the steps' 2^-40 of the line would be wider than the mechanism
    far = _extent(c.mech) / max(_span(spec, start[k], target[k]), 1e-300)
    if far < 1.0:
        if reaches(far):
            lo = far
        else:
            hi = far
    for _ in range(EDGE_STEPS):
        mid = 0.5 * (lo + hi)
        if reaches(mid):
            lo = mid
        else:
            hi = mid
    if isinstance(spec, CoordinateSpec):
        e, t = float(command(lo)[spec.name]), float(target[k])
        return ReachEdge(spec.point, (t,), (e,), abs(t - e), coordinate=spec.name)
    ex, ey = command(lo)[spec.name]
    tx, ty = (float(v) for v in target[k])
    return ReachEdge(spec.point, (tx, ty), (ex, ey), math.hypot(tx - ex, ty - ey))


def _span(spec: PointSpec | CoordinateSpec, start: Any, target: Any) -> float:
    """How far the target's point moves on the line (m)."""
    if isinstance(spec, CoordinateSpec):
        return abs(float(target) - float(start))
    return math.hypot(float(target[0]) - float(start[0]), float(target[1]) - float(start[1]))


def _extent(mech: Any) -> float:
    """Four times the mechanism's span: the sum over its links of each link's largest distance
    between two of its points (m); no point of a mechanism of fixed-length links is further
    from a ground point, and no configuration moves a point further than twice it."""
    total = 0.0
    for link in mech.links.values():
        pts = [mech.points[p] for p in link.points]
        total += max(
            (math.dist(tuple(map(float, a)), tuple(map(float, b))) for a in pts for b in pts),
            default=0.0,
        )
    return 4.0 * total
