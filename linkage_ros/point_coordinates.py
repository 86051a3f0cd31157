"""Point coordinates in a JointState target: ``<point>.x`` and ``<point>.y`` (m).

A ``~/target`` (sensor_msgs/JointState) carries one number per name, so a point of the
mechanism is given as two names, ``J.x`` and ``J.y`` (scene names are identifiers: no dot, so
nothing else is named so). Together with other names this gives every inverse problem the
lectures pose in one request: two points of one link (``J.x, J.y, K.x, K.y``: the excavator bin
by its hinges), a point and a link angle (``L.x, L.y, bucket``), a point and an actuator, or
one coordinate and a link angle (``D.x, bin``: the other coordinate is solved). The node and
the bag tool both group them here, so both answer the same request alike.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .core.errors import CommandError, echo
from .core.model import Mechanism
from .core.model.names import AXES, point_coordinate


def group_point_coordinates(mech: Mechanism, values: Mapping[str, Any]) -> dict[str, Any]:
    """``{'J.x': x, 'J.y': y, ...}`` -> ``{'point:J': (x, y), ...}`` (numbers or equal-length
    arrays: then an (n, 2) column); other names unchanged, in order, a coordinate given
    without the other axis among them (one coordinate is a known of its own: the lecture's
    loader bin by its hinge's x and its angle). CommandError for a coordinate of a point the
    scene does not have."""
    if not any('.' in name for name in values):
        return dict(values)
    out: dict[str, Any] = {}
    for name, value in values.items():
        if '.' not in name:
            out[name] = value
            continue
        coordinate = point_coordinate(mech, name)
        if coordinate is None:
            raise CommandError(
                f'unknown name {echo(name)}: a point coordinate is <point>.x or <point>.y '
                f'with a point of {mech.name!r}'
            )
        point, axis = coordinate
        key = f'point:{point}'
        if key in out:
            continue
        other = f'{point}.{AXES[1 - axis]}'
        if other not in values:  # one coordinate: a known of its own (the other one solved)
            out[name] = value
            continue
        x, y = values[f'{point}.x'], values[f'{point}.y']
        if np.ndim(x):
            out[key] = np.stack([np.asarray(x, float), np.asarray(y, float)], axis=-1)
        else:
            out[key] = (x, y)
    return out


def pose_target(
    mech: Mechanism, link: str, xy: tuple[float, float], yaw_rad: float
) -> dict[str, Any]:
    """A link's pose as target names: its first point (where its axis starts: the scene's
    first point of the link) at ``xy`` (m) and the link's angle ``yaw_rad`` (its reported angle,
    the axis direction from +x): 3 values, the pose of a rigid body in the plane."""
    if link not in mech.links or link == mech.ground:
        raise CommandError(f'unknown link {echo(link)}: a pose target names a moving link')
    members = mech.links[link].points
    point = members[0]
    ground = mech.links[mech.ground].points
    pivot = next((p for p in members if p in ground), None)
    if pivot is not None:
        # it turns about a ground pivot: its pose is fixed by its angle, and a target is the
        # angle alone, the first point where that angle puts it (m) checked against the pose's
        g = mech.points[pivot]
        turn = yaw_rad - mech.links[link].angle_ref
        rel = mech.points[point] - g
        px = float(g[0] + math.cos(turn) * rel[0] - math.sin(turn) * rel[1])
        py = float(g[1] + math.sin(turn) * rel[0] + math.cos(turn) * rel[1])
        off = float(np.hypot(xy[0] - px, xy[1] - py))
        if not off <= POSE_PIVOT_TOL * mech.length_scale:
            at = 'the pivot' if pivot == point else 'where that angle puts it'
            raise CommandError(
                f'the pose of {echo(link)} turns about its ground pivot {pivot}: its first point '
                f'{point} is at ({px:.6g}, {py:.6g}) m, {at}, and a pose at ({xy[0]:.6g}, '
                f'{xy[1]:.6g}) m is {off:.3g} m off it (send that position, or the angle alone: '
                f'link {link} on ~/target)'
            )
        return {f'link:{link}': yaw_rad}
    return {f'{point}.x': xy[0], f'{point}.y': xy[1], f'link:{link}': yaw_rad}


#: how far (of the length scale) a pose target's position may be from the ground pivot its
#: link turns about: a pose read off tf carries the rounding of its transforms
POSE_PIVOT_TOL = 1e-9
