"""Shared pieces of the motion analyses: tolerances, name keys, reference values, limits."""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Iterable

import numpy as np

from ..execute import CROSSING_MARGIN
from ..model import AngleActuator, Mechanism
from ..model.names import NameKind, known_name
from ..plan import Poses, spec_for, spec_value_at
from ..quantities import PointSpec

TWO_PI = 2.0 * math.pi
#: boundary refinement tolerance for angles (rad) and slides (fraction of the length scale)
ANGLE_TOL = 1e-12
LENGTH_TOL = 1e-12
#: points evaluated per refinement round (a 17-ary search: ~9 rounds from a grid step to 1e-12)
KARY = 16
#: a local minimum of a dyad's margin along a scanned input, refined to the input tolerance,
#: below this is a toggle the circuit touches (a change point): the continuous solve's own
#: crossing threshold (execute.CROSSING_MARGIN: a gap of less than ~1e-12 of the lengths is on
#: the change point), so a scan and a sweep agree where the motion goes (at 1e-7, a four-bar
#: 1e-14 inside its Grashof limit was swept across its change point and scanned as never
#: reaching it: half its rocker's swing, a numerics reviewer). Not the assembly-mode threshold
#: (result.SIGN_MARGIN)
TOUCHED_TOGGLE_MARGIN = CROSSING_MARGIN
#: cap on circuit segments followed through assembly-mode changes
MAX_SEGMENTS = 64
#: how far past a toggle found to rounding it is read (multiples of the input's ulp)
TOGGLE_NUDGES = (4.0, 64.0, 1024.0)


def past_toggle(x: float, outward: float) -> list[float]:
    """Inputs a few ulps past a toggle found at ``x`` (``outward`` +1 past an upper end of the
    input's range, -1 past a lower one), nearest first. Found to rounding, the toggle may lie a
    few ulps inside or out, and near it a configuration moves like the square root of the
    distance (1e-15 of input: 3e-8 rad); read past it by less than the tangency tolerance, the
    dyad is placed at its tangency: the toggle itself."""
    ulp = math.ulp(max(abs(x), 1.0))
    return [x + outward * k * ulp for k in TOGGLE_NUDGES]


# ---- small helpers ----------------------------------------------------------------------------


def point_key(mech: Mechanism, name: str) -> str:
    """The known name that means *point* ``name`` (prefixed ``point:`` where the one rule,
    model.names, resolves the bare name to something else: a joint, as every point shared by two
    links is)."""
    if name not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {name!r}; points: {sorted(mech.points)}')
    return known_name(mech, NameKind.POINT, name)


def link_key(mech: Mechanism, name: str) -> str:
    """The known name that means the angle of link ``name``."""
    if name not in mech.links:
        raise ValueError(f'{mech.name!r} has no link {name!r}; links: {sorted(mech.links)}')
    if name == mech.ground:
        raise ValueError(f'{name!r} is the ground link: its angle is fixed')
    return known_name(mech, NameKind.LINK, name)


def without_limits(mech: Mechanism) -> Mechanism:
    """A shallow copy of ``mech`` whose actuators have no min / max (to probe the assembly)."""
    return limits_lifted(mech, mech.actuators)


def limits_lifted(mech: Mechanism, names: Iterable[str]) -> Mechanism:
    """A shallow copy of ``mech`` whose actuators ``names`` have no min / max (a cylinder's
    length stays above 0: its spec says so whatever its limits)."""
    lift = set(names)
    free = copy.copy(mech)
    free.actuators = {
        n: dataclasses.replace(a, min=None, max=None) if n in lift else a
        for n, a in mech.actuators.items()
    }
    return free


def input_limits_lifted(mech: Mechanism, name: str) -> Mechanism | None:
    """``mech`` with angle actuator ``name``'s limits lifted, or None where it has none (or is a
    slide: a cylinder's stroke is its body, not a setting a circuit could pass). The lectures'
    "through what angle can link 4 oscillate" is the whole circuit, through the toggles a
    scene's crank limits may keep its input short of."""
    act = mech.actuators[name]
    if not isinstance(act, AngleActuator) or (act.min is None and act.max is None):
        return None
    return limits_lifted(mech, [name])


def _identity_poses(mech: Mechanism) -> Poses:
    poses = Poses()
    for l in mech.links:
        poses.phi[l] = np.zeros(1)
        poses.T[l] = np.zeros((1, 2))
    return poses


def reference_value(mech: Mechanism, name: str) -> float | np.ndarray:
    """Value of a known (actuator, joint, link angle or point) in the reference pose: rad or m,
    (x, y) (m) for a point."""
    spec = spec_for(mech, name)
    v = spec_value_at(mech, spec, _identity_poses(mech))[0]
    return np.asarray(v, float).copy() if isinstance(spec, PointSpec) else float(v)


def reference_scalar(mech: Mechanism, name: str) -> float:
    """Value of a scalar known (an actuator, joint or link angle: rad or m) in the reference
    pose; ValueError for a point."""
    v = reference_value(mech, name)
    if isinstance(v, np.ndarray):
        raise ValueError(f'{name!r} is a point of {mech.name!r}: it has two coordinates')
    return v


def reference_point(mech: Mechanism, name: str) -> np.ndarray:
    """A point's (x, y) (m) in the reference pose (``name`` resolves to a point)."""
    v = reference_value(mech, name)
    if not isinstance(v, np.ndarray):
        raise ValueError(f'{name!r} is no point of {mech.name!r}')
    return v


def reachable_piece(
    lo: float, hi: float, seed: float, lim: tuple[float, float]
) -> list[tuple[float, float, bool, bool]]:
    """The piece of [lo, hi] inside the circular interval ``lim`` that holds ``seed`` (where
    a stretch of the motion starts: the motion within the limits cannot leave it), as a list
    of at most one :func:`clip_periodic` piece."""
    tol = 1e-9 * max(1.0, abs(seed))
    return [p for p in clip_periodic(lo, hi, lim) if p[0] - tol <= seed <= p[1] + tol][:1]


def clip_periodic(
    lo: float, hi: float, lim: tuple[float, float]
) -> list[tuple[float, float, bool, bool]]:
    """Pieces of the unwrapped interval [lo, hi] inside the circular interval lim = (a, b)."""
    a, b = lim
    out: list[tuple[float, float, bool, bool]] = []
    k0 = math.floor((lo - b) / TWO_PI)
    for k in range(k0, k0 + 4):
        x, y = max(lo, a + TWO_PI * k), min(hi, b + TWO_PI * k)
        if x <= y:
            out.append((x, y, x == a + TWO_PI * k, y == b + TWO_PI * k))
    return out
