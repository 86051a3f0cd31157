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
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..plan import Spec
from ..quantities import CoordinateSpec, PointSpec
from .compiled import Values
from .crossing import interpolate
from .reading import configuration_of, known_values
from .result import Effort, Result
from .solver import Solver

#: the edge is found to 2^-EDGE_STEPS of the line's length
EDGE_STEPS = 40
#: the first step of the march along the line (a fraction of it)
FIRST_STEP = 1.0 / 64


@dataclass(frozen=True)
class ReachEdge:
    """The reachable edge toward a point target (or one coordinate's: ``coordinate`` its
    name, ``target`` and ``edge`` one value each): its position (m), how far short of the
    target it is (m), the target's other knowns (moved along with the point) and how much of
    the way (0..1) is reached."""

    point: str
    target: tuple[float, ...]
    edge: tuple[float, ...]
    short_m: float
    coordinate: str = ''
    others: tuple[str, ...] = ()
    fraction: float = 0.0
    #: the unit of the known (a point's or coordinate's m; a joint's or link's angle, rad;
    #: a slide, m): ``short_m`` is in it
    unit: str = 'm'
    #: the target's other knowns that stay where they are on the way (a target_point_hold's
    #: names: the bucket held while the lip is out of reach)
    kept: tuple[str, ...] = ()
    #: other knowns of the command that are out of reach moved alone too
    also: tuple[str, ...] = ()

    def describe(self) -> str:
        u = self.unit
        if self.coordinate:
            name = self.coordinate
            asked, at = f'{name} = {self.target[0]:.6g} {u}', f'{name} = {self.edge[0]:.6g} {u}'
        else:
            (tx, ty), (ex, ey) = self.target, self.edge
            asked = f'point {self.point} = ({tx:.6g}, {ty:.6g}) m'
            at = f'({ex:.6g}, {ey:.6g}) m'
        way = 'on the straight way there from the current configuration'
        if self.kept and not self.others:
            asked = f'{asked} with {", ".join(self.kept)} as it is now'
        if not self.others:
            # (that way's edge, where its march stopped at a fold of the way: the point may
            # reach further by another, as a Klann leg's foot does, 0.24 m past it)
            # (a joint's or link's range over the motion: linkage range --curves)
            whole = (
                f"; the point's whole reach: linkage range --point {self.point}"
                if self.point
                else ''
            )
            if not self.point:  # (an angle the short way round)
                way = 'on the way there from the current configuration'
            short = f"{self.short_m:.6g} {u} short (that way's edge{whole})"
            too = (
                f'; {", ".join(self.also)} moved alone (the others where they are) out of reach too'
                if self.also
                else ''
            )
            return f'{asked} is out of reach: {way} it is reachable up to {at}, {short}{too}'
        others = ', '.join(self.others)
        # (the other knowns moved too: where the point hardly moves, they are what is out of
        # reach, and the point's edge would read as its own value "1e-15 m short")
        return (
            f'{asked} with {others} as given is out of reach: {way}, every known moved '
            f'together, it is reachable {self.fraction:.6g} of the way (up to {at}, '
            f'{self.short_m:.6g} {u} short)'
        )


def reach_edge(
    solver: Solver,
    values: Mapping[str, Any],
    here: Result,
    scalars: bool = True,
    keeps: Callable[[Result], bool] | None = None,
) -> ReachEdge | None:
    """Where the (first) point target of ``values`` (a command of ``solver``, refused), else its
    first coordinate known, else (``scalars``) the joint, link or slide value it moves furthest
    (of a turn, or of the length scale: a crane's fold cylinder commanded past its dead centre
    with the lift held was named as the lift, 2e-16 m short), stops
    being reachable on the way from ``here`` (the current configuration, a Result of this
    mechanism) to the target, every known moved together (angles the short way round); None
    when the solve has none of them, gives two points of one link, or ``here`` is not a
    configuration of the mechanism. ``keeps``: whether a configuration on the way is one the
    answer may be (its assembly mode kept: the way stops where it leaves it, as at a toggle
    the inverse plan's continuity passes)."""
    c = solver.compiled
    k = next((i for i, s in enumerate(c.specs) if isinstance(s, PointSpec)), None)
    if k is None:
        k = next((i for i, s in enumerate(c.specs) if isinstance(s, CoordinateSpec)), None)
    if k is None and not (scalars and c.specs) or c.point_pairs:
        return None
    got = configuration_of(c, here)
    try:
        target = c.parse(values)
    except ValueError:
        return None
    if got is None:
        return None
    start = known_values(c, got[1])
    also: tuple[str, ...] = ()
    if k is None:
        # a known out of reach with the others where they are now is what the refusal names,
        # moved alone (a crane's jib cylinder past its dead centre, whatever the lift, was
        # named as the lift moved with it, "0.06 m short": a hydraulics engineer)
        failing = _alone_out_of_reach(solver, c, start, target)
        if failing:
            k = failing[0]
            also = tuple(c.specs[i].name for i in failing[1:])
            target = [target[i] if i == k else start[i] for i in range(len(start))]
    if k is None:  # (a rocker's angle, a slide: out of reach where the mechanism turns back)
        ends = interpolate(c, start, target, 1.0)
        k = max(
            range(len(c.specs)),
            key=lambda i: (
                _span(c.specs[i], start[i], ends[i])
                / (2 * math.pi if c.specs[i].unit == 'rad' else c.mech.length_scale)
            ),
        )
    spec = c.specs[k]

    def command(s: float) -> dict[str, Any]:
        vals = interpolate(c, start, target, s)
        return {
            sp.name: (tuple(float(v) for v in val) if isinstance(sp, PointSpec) else float(val))
            for sp, val in zip(c.specs, vals)
        }

    def reaches(s: float) -> bool:
        # a probe: Newton straight from the last value reached, committed (the march
        # continues from it; the solver's state is restored below). A probe past a fold fails
        # within max_iter iterations, where a walk halving its step grinds ten times as long
        got = solver.solve(command(s), commit=True, effort=Effort.DIRECT)
        return got.success and (keeps is None or keeps(got))

    snap = solver.snapshot()
    try:
        if not reaches(0.0):
            return None
        lo, hi = 0.0, 1.0
        # a target far beyond the mechanism (1e300 m): march only as far as the point could
        # be at most, or the steps' 2^-40 of the line would be wider than the mechanism
        far = (
            _extent(c.mech) / max(_span(spec, start[k], target[k]), 1e-300)
            if spec.unit == 'm'
            else math.inf  # (an angle's way is at most half a turn)
        )
        if far < 1.0:
            if reaches(far):
                lo = far
            else:
                hi = far
        # march toward the target (continuation: each step from the last value reached), the
        # step doubled after a value reached and halved after one not, to 2^-EDGE_STEPS of the
        # way: the edge of what is reached lies in [lo, hi]
        step, smallest = FIRST_STEP * (hi - lo), (hi - lo) * 2.0**-EDGE_STEPS
        while hi - lo > smallest:
            s = lo + min(step, 0.5 * (hi - lo))
            if reaches(s):
                lo, step = s, 2.0 * step
            else:
                hi, step = s, 0.5 * step
    finally:
        solver.restore(snap)
    # the other knowns that move on the way (a known held where it is leaves the point alone)
    moved = interpolate(c, start, target, 1.0)
    others = tuple(
        sp.name
        for i, sp in enumerate(c.specs)
        if i != k and _span(sp, start[i], moved[i]) > 1e-12 * max(1.0, _size(moved[i]))
    )
    kept = tuple(sp.name for i, sp in enumerate(c.specs) if i != k and sp.name not in others)
    if not isinstance(spec, PointSpec):  # one value: a coordinate, an angle or a slide
        e, t = float(command(lo)[spec.name]), float(target[k])
        # (an angle the short way round; a coordinate names its point)
        short = abs(math.remainder(t - e, 2 * math.pi)) if spec.unit == 'rad' else abs(t - e)
        point = spec.point if isinstance(spec, CoordinateSpec) else ''
        return ReachEdge(point, (t,), (e,), short, spec.name, others, lo, spec.unit, kept, also)
    ex, ey = command(lo)[spec.name]
    tx, ty = (float(v) for v in target[k])
    short = math.hypot(tx - ex, ty - ey)
    return ReachEdge(spec.point, (tx, ty), (ex, ey), short, '', others, lo, kept=kept)


def _alone_out_of_reach(solver: Solver, c: Any, start: Values, target: Values) -> list[int]:
    """The knowns of several moved that, each moved alone to its target (the others where
    they are in ``start``), are not reached from the solver's configuration (in spec order;
    [] where one known moved or none fails alone). Each is a full continuation walk from the
    current configuration (the solver's state is kept)."""
    ends = interpolate(c, start, target, 1.0)
    moved = [
        i
        for i, sp in enumerate(c.specs)
        if _span(sp, start[i], ends[i]) > 1e-12 * max(1.0, _size(ends[i]))
    ]
    if len(moved) < 2:
        return []
    failing = []
    snap = solver.snapshot()
    try:
        for i in moved:
            vals = [target[j] if j == i else start[j] for j in range(len(start))]
            command = {sp.name: float(v) for sp, v in zip(c.specs, vals)}
            if not solver.solve(command, commit=False).success:
                failing.append(i)
            solver.restore(snap)
    finally:
        solver.restore(snap)
    return failing


def _span(spec: Spec, start: Any, target: Any) -> float:
    """How far a known moves between two of its values (m, or rad: callers pass the end of
    the short way round, interpolate's)."""
    if isinstance(spec, PointSpec):
        return math.hypot(float(target[0]) - float(start[0]), float(target[1]) - float(start[1]))
    return abs(float(target) - float(start))


def _size(value: Any) -> float:
    """A known's value's largest magnitude (m or rad; a point's coordinates)."""
    return float(np.max(np.abs(np.asarray(value, float))))


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
