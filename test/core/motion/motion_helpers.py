"""Plane geometry and scenes shared by the motion tests (test_motion*.py): the distance of two
angles on the circle, vector angles, cross products, circle intersections, the side of a line,
and a shipped scene's mechanism by name (skipped where the scene is not shipped).
"""

import math

import numpy as np
from scenes import CONFIG

from linkage_ros.core.model import Scene

TWO_PI = 2 * math.pi


def circ(a, b):
    """Distance between two angles on the circle."""
    d = (a - b) % TWO_PI
    return min(d, TWO_PI - d)


def ang(v):
    return math.atan2(v[1], v[0])


def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def circle_meet(c1, r1, c2, r2, side):
    """Intersection of two circles on the given side of c1 -> c2 (+1 left), or None."""
    d = np.asarray(c2, float) - np.asarray(c1, float)
    L = math.hypot(*d)
    if L == 0 or r1 + r2 < L or abs(r1 - r2) > L:
        return None
    a = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    u = d / L
    return np.asarray(c1, float) + a * u + side * h * np.array([-u[1], u[0]])


def side(a, b, x):
    return 1 if cross(b - a, x - a) > 0 else -1


def named_scene(name):
    return Scene.from_yaml(CONFIG / f'{name}.yaml').mechanism
