"""Shared pieces of the motion analyses: tolerances, name keys, reference values, limits."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from ..model import Mechanism
from ..plan import Poses, spec_for, spec_value_at
from ..quantities import PointSpec

TWO_PI = 2.0 * math.pi
#: boundary refinement tolerance for angles (rad) and slides (fraction of the length scale)
ANGLE_TOL = 1e-12
LENGTH_TOL = 1e-12
#: points evaluated per refinement round (a 17-ary search: ~9 rounds from a grid step to 1e-12)
_KARY = 16
#: a dyad margin below this after refinement is a toggle
TOGGLE_MARGIN = 1e-7
#: cap on circuit segments followed through assembly-mode changes
_MAX_SEGMENTS = 64


# ---- small helpers ----------------------------------------------------------------------------


def point_key(mech: Mechanism, name: str) -> str:
    """The known name that means *point* ``name`` (prefixed ``point:`` where a joint, link or
    actuator has the same name, as every point shared by two links does)."""
    if name not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {name!r}; points: {sorted(mech.points)}')
    clash = name in mech.actuators or name in mech.joint_names or name in mech.links
    return f'point:{name}' if clash else name


def link_key(mech: Mechanism, name: str) -> str:
    """The known name that means the angle of link ``name``."""
    if name not in mech.links:
        raise ValueError(f'{mech.name!r} has no link {name!r}; links: {sorted(mech.links)}')
    if name == mech.ground:
        raise ValueError(f'{name!r} is the ground link: its angle is fixed')
    clash = name in mech.actuators or name in mech.joint_names
    return f'link:{name}' if clash else name


def without_limits(mech: Mechanism) -> Mechanism:
    """A shallow copy of ``mech`` whose actuators have no min / max (to probe the assembly)."""
    free = copy.copy(mech)
    free.actuators = {
        n: dataclasses.replace(a, min=None, max=None) for n, a in mech.actuators.items()
    }
    return free


def _identity_poses(mech: Mechanism) -> Poses:
    poses = Poses()
    for l in mech.links:
        poses.phi[l] = np.zeros(1)
        poses.T[l] = np.zeros((1, 2))
    return poses


def reference_value(mech: Mechanism, name: str):
    """Value of a known (actuator, joint, link angle or point) in the reference pose."""
    spec = spec_for(mech, name)
    v = spec_value_at(mech, spec, _identity_poses(mech))[0]
    return np.asarray(v, float).copy() if isinstance(spec, PointSpec) else float(v)


def _limit_interval(act, periodic: bool):
    """The actuator's limits as (lo, hi) with None for a missing side; for angles a circular
    interval [lo, hi] (None when the limits leave the full turn), mirroring Solver.limit_violation
    (one-sided angle limits compare the value wrapped to (-pi, pi])."""
    lo, hi = act.min, act.max
    if not periodic:
        return lo, hi
    if lo is None and hi is None:
        return None
    if lo is not None and hi is not None:
        return None if hi - lo >= TWO_PI else (lo, hi)
    return (lo, math.pi) if lo is not None else (-math.pi, hi)


def _clip_periodic(lo, hi, lim):
    """Pieces of the unwrapped interval [lo, hi] inside the circular interval lim = (a, b)."""
    a, b = lim
    out = []
    k0 = math.floor((lo - b) / TWO_PI)
    for k in range(k0, k0 + 4):
        x, y = max(lo, a + TWO_PI * k), min(hi, b + TWO_PI * k)
        if x <= y:
            out.append((x, y, x == a + TWO_PI * k, y == b + TWO_PI * k))
    return out
