"""Two points of one link as a target: the link's pose given by two of its points.

The lectures pose inverse problems this way ("the hinges J and K occupy the locations J2 and K2",
seed 003): two points of one rigid link fix its pose, 3 values, since their distance is the
link's. The solver takes such a pair as the first point plus the link's angle (the direction
first -> second, less that direction's angle within the link): the graphical construction with
tracing paper. The pair is accepted when the given distance equals the link's within the solve's
closure tolerance; otherwise it is refused with both distances.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import echo, not_finite
from ..model import Mechanism
from ..plan import Spec
from ..quantities import PointSpec


@dataclass(frozen=True)
class PointPair:
    """Known points ``first`` and ``second`` (known names, e.g. ``point:J``) of ``link``."""

    first: str
    second: str
    link: str
    link_known: str  # the known that replaces ``second``: ``link:<link>``
    distance_m: float  # |second - first| on the link
    direction_rad: float  # direction first -> second minus the link's reported angle


def find_point_pairs(
    mech: Mechanism, knowns: Sequence[str], specs: Sequence[Spec]
) -> list[PointPair]:
    """Each pair of known points carried by one moving link (each point in one pair at most)."""
    points = [(k, s.point) for k, s in zip(knowns, specs) if isinstance(s, PointSpec) and s.point]
    pairs: list[PointPair] = []
    used: set[str] = set()
    for i, (known_a, a) in enumerate(points):
        for known_b, b in points[i + 1 :]:
            if known_a in used or known_b in used:
                continue
            shared = [
                l for l in mech.links_of_point(a) if l != mech.ground and b in mech.links[l].points
            ]
            if not shared:
                continue
            link = mech.links[shared[0]]
            pa, pb = np.asarray(mech.points[a], float), np.asarray(mech.points[b], float)
            d = pb - pa
            distance = float(math.hypot(d[0], d[1]))
            if distance == 0.0:
                continue  # coincident points give no direction
            pairs.append(
                PointPair(
                    known_a,
                    known_b,
                    link.name,
                    f'link:{link.name}',
                    distance,
                    math.atan2(d[1], d[0]) - link.angle_ref,
                )
            )
            used |= {known_a, known_b}
    return pairs


def replaced_knowns(knowns: Sequence[str], pairs: Sequence[PointPair]) -> list[str]:
    """The knowns the plan solves: each pair's second point replaced by its link's angle."""
    second = {p.second: p.link_known for p in pairs}
    return [second.get(k, k) for k in knowns]


def parse_point(name: str, value: Any) -> np.ndarray:
    """A point's value (x, y in m) as a (2,) array; ValueError naming ``name`` for anything but
    two finite real numbers (a bool, a string or a mapping is not a coordinate)."""
    try:
        if isinstance(value, (str, bytes, Mapping)) or any(
            isinstance(c, (bool, np.bool_))
            or not isinstance(c, (int, float, np.floating, np.integer))
            for c in value
        ):
            raise TypeError
        arr = np.asarray(value, float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f'{name}: a point needs two numbers x, y (got {echo(value)})') from None
    if arr.shape != (2,):
        raise ValueError(f'{name}: a point needs two numbers x, y (got {echo(value)})')
    if not np.all(np.isfinite(arr)):
        raise ValueError(not_finite(name, value))
    return arr


def pair_values(
    values: Mapping[str, Any],
    knowns: Sequence[str],
    pairs: Sequence[PointPair],
    tolerance_m: float,
) -> dict[str, Any]:
    """A request by the user's knowns -> the plan's knowns (ValueError naming what is wrong):
    each pair's second point becomes the link angle, after the pair's distance is checked."""
    unknown = [k for k in values if k not in knowns]
    if unknown:
        raise ValueError(f'unknown name(s) {echo(unknown)}; this solve takes {list(knowns)}')
    missing = [k for k in knowns if k not in values]
    if missing:
        raise ValueError(f'missing value(s) for {missing}')
    out = dict(values)
    for p in pairs:
        a, b = parse_point(p.first, values[p.first]), parse_point(p.second, values[p.second])
        d = b - a
        given = float(math.hypot(d[0], d[1]))
        if not abs(given - p.distance_m) <= tolerance_m:
            raise ValueError(
                f'{p.first} and {p.second} are both on link {p.link!r}, {p.distance_m:.9g} m '
                f'apart, but the target puts them {given:.9g} m apart (off by '
                f'{abs(given - p.distance_m):.3g} m, more than the solve tolerance '
                f'{tolerance_m:.3g} m; points read off a drawing need a looser tolerance: '
                '--tol, the tolerance parameter)'
            )
        del out[p.second]
        out[p.link_known] = math.atan2(d[1], d[0]) - p.direction_rad
    return out


def pair_columns(
    columns: Mapping[str, Any],
    pairs: Sequence[PointPair],
    tolerance_m: float,
) -> dict[str, Any]:
    """:func:`pair_values` for batch columns ((n, 2) arrays per point): ValueError naming the
    first row whose pair distance is not the link's."""
    out = dict(columns)
    for p in pairs:
        a = np.asarray(columns[p.first], float).reshape(-1, 2)
        b = np.asarray(columns[p.second], float).reshape(-1, 2)
        if a.shape != b.shape:
            raise ValueError(
                f'batch columns {p.first!r} and {p.second!r} have {a.shape[0]} and '
                f'{b.shape[0]} rows'
            )
        d = b - a
        given = np.hypot(d[:, 0], d[:, 1])
        bad = np.flatnonzero(~(np.abs(given - p.distance_m) <= tolerance_m))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f'row {i}: {p.first} and {p.second} are both on link {p.link!r}, '
                f'{p.distance_m:.9g} m apart, but the row puts them {given[i]:.9g} m apart'
            )
        del out[p.second]
        out[p.link_known] = np.arctan2(d[:, 1], d[:, 0]) - p.direction_rad
    return out
