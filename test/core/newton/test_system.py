"""LoopSystem's configuration read off Newton unknowns (core/newton/system.py).

Oracle: each link's rigid motion written out here: a free link at unknowns (phi, cx, cy) (its
rotation from the reference pose, and where its reference centroid o went) carries a point drawn
at p to (cx, cy) + e^{i phi} (p - o), and its pose is rot = e^{i phi} (cmath.exp), T = (cx, cy) -
rot o; the ground stays at rest.

Would fail if: configuration (or poses_from_x) read the unknowns as a list of floats (the warm
Newton solve passes its answer read once, not the array) otherwise than as the array, or placed
a point off the wrong link or pose.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest
import scenes
from hypothesis import given, settings
from hypothesis import strategies as st

SYSTEMS = {name: scenes.newton_system(name) for name in scenes.SHIPPED}


def _expected(sy, xs):
    """(rot, T, points) of unknowns ``xs`` by each link's rigid motion (see the module)."""
    rot, T = {sy.mech.ground: 1 + 0j}, {sy.mech.ground: 0j}
    for l, i in sy.index.items():
        o = complex(*map(float, sy.centroid[l]))
        rot[l] = cmath.exp(1j * xs[3 * i])
        T[l] = complex(xs[3 * i + 1], xs[3 * i + 2]) - rot[l] * o
    points = {}
    for p, l, z in sy.point_owner:
        if l == sy.mech.ground:
            points[p] = z
        else:
            i = sy.index[l]
            o = complex(*map(float, sy.centroid[l]))
            points[p] = complex(xs[3 * i + 1], xs[3 * i + 2]) + rot[l] * (z - o)
    return rot, T, points


@pytest.mark.parametrize('name', scenes.SHIPPED)
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), spread=st.floats(0.0, 3.0))
def test_configuration_places_every_point_by_its_links_rigid_motion(name, seed, spread):
    sy = SYSTEMS[name]
    rng = np.random.default_rng(seed)
    x = sy.reference_x() + rng.normal(size=sy.n) * spread * sy.step_scale
    xs = x.tolist()
    rot, T, points = _expected(sy, xs)
    tol = 1e-13 * max(sy.L, max(map(abs, xs), default=0.0))
    for given_x in (x, xs):  # the array, and its list of floats
        poses, pts = sy.configuration(given_x)
        assert sy.poses_from_x(given_x).phi == poses.phi
        assert set(poses.phi) == set(rot) and set(pts) == set(points)
        for l, i in sy.index.items():
            assert poses.phi[l] == xs[3 * i]
        for l in rot:
            assert abs(poses.rot[l] - rot[l]) <= 1e-15 and math.isclose(abs(poses.rot[l]), 1.0)
            assert abs(poses.T[l] - T[l]) <= tol
        for p, want in points.items():
            assert abs(pts[p] - want) <= tol, (p, pts[p], want)
