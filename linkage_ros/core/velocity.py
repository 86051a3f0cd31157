"""Velocities from the loop-closure Jacobian: the knowns' rates (actuator rad/s or m/s, or a
target's) -> every link's angular velocity, every joint's rate and every point's velocity.

Exact to rounding: one linear solve with the analytic Jacobian of the loop-closure equations
at the solved configuration (J dx/dt = -dF/dvalue * rates), not a finite difference. Near a
toggle J becomes singular and the velocities grow without bound (as the mechanism's do: a
finite input rate drives an output at an unbounded rate there); ``cond`` says how near, and at
a singular J there is no answer (``success`` False with the reason): singular to rounding, its
condition number above SINGULAR_COND (at the solved pose the rates' rounding error is about
cond * 1e-16 of their size; against the exact mechanism it is about cond^2 * 2e-17, since near
a toggle the pose itself carries its data's rounding amplified by about cond: 1e-6 at cond 2e5,
1e-3 at cond 8e6, 8 % at cond 8e7, all of it at a toggle itself, where a finite answer would
be noise). Rates that are not
finite, or an answer beyond the float range (a rate near the largest double), are refused
saying so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from .errors import echo
from .newton.results import SINGULAR_COND
from .quantities import PointSpec

if TYPE_CHECKING:
    from .solver import Result, Solver


@dataclass
class Velocities:
    """Rates of one configuration: ``links`` rad/s (counter-clockwise), ``joints`` rad/s for
    revolute and m/s for prismatic joints, ``points`` (vx, vy) m/s; ``cond`` is the scaled
    condition number of the loop-closure Jacobian (large near a toggle)."""

    success: bool
    reason: str | None = None
    links: dict[str, float] = field(default_factory=dict)
    joints: dict[str, float] = field(default_factory=dict)
    points: dict[str, tuple[float, float]] = field(default_factory=dict)
    cond: float = math.inf


def velocities(
    solver: Solver, result: Result, values: Mapping[str, Any], rates: Mapping[str, Any]
) -> Velocities:
    """Rates of the configuration ``result`` that ``solver`` solved from ``values``, for the
    knowns' ``rates`` (the same names: rad/s, m/s; a point known's rate is (vx, vy))."""
    mech, system = solver.mech, solver.check_system
    missing = [k for k in solver.knowns if k not in rates]
    if missing:
        return Velocities(False, f'no rate given for {missing}')
    unknown = [k for k in rates if k not in solver.knowns]
    if unknown:  # (as solve refuses a value for a name it does not take)
        return Velocities(
            False,
            f'a rate for {echo(unknown)}, which this solve does not take: it takes '
            f'{list(solver.knowns)}',
        )
    got = solver.configuration_of(result)  # the link poses, read back from the answer
    if got is None:
        return Velocities(False, 'no velocity: not a solved configuration of this mechanism')
    poses = got[1]
    x = system.x_from_poses(poses)
    comps: list[float] = []
    bad: list[str] = []
    for s in solver.specs:
        r = rates[s.name]
        try:
            parts = [float(r[0]), float(r[1])] if isinstance(s, PointSpec) else [float(r)]
        except (TypeError, ValueError, IndexError, KeyError):
            shape = 'two numbers (vx, vy)' if isinstance(s, PointSpec) else 'a number'
            return Velocities(False, f'the rate of {s.name!r} must be {shape} (got {echo(r)})')
        comps += parts
        if not all(map(math.isfinite, parts)):
            bad.append(s.name)
    if bad:
        return Velocities(False, f'no velocity: the rate of {bad} is not finite')
    dx, cond = system.rates(x, solver.parse(values), comps)
    if not cond <= SINGULAR_COND:  # (NaN too)
        return Velocities(
            False,
            f'no velocity: the loop-closure Jacobian is singular here (condition {cond:.3g}; '
            'a toggle, where a finite input rate drives the mechanism at an unbounded rate)',
            cond=cond,
        )
    if dx is None:
        return Velocities(False, _OVERFLOW, cond=cond)
    omega = {mech.ground: 0.0}
    centre = {mech.ground: (0j, 0j)}  # (centroid position, its velocity)
    for link, i in system.index.items():
        omega[link] = float(dx[3 * i])
        centre[link] = (complex(x[3 * i + 1], x[3 * i + 2]), complex(dx[3 * i + 1], dx[3 * i + 2]))

    def carried(link: str, at: complex) -> complex:
        """Velocity of the point of ``link`` now at ``at``."""
        c, v = centre[link]
        return v + 1j * omega[link] * (at - c)

    points = {}
    for p, (px, py) in result.points.items():
        owner = mech.links_of_point(p)[0]
        v = carried(owner, complex(px, py))
        points[p] = (v.real, v.imag)
    joints = {j.name: omega[j.child] - omega[j.parent] for j in mech.revolutes}
    for pj in mech.prismatics.values():
        # slide = u . (P - O): u the guide's direction, O its origin, both turning with it
        rot, T = poses.rot[pj.guide], poses.T[pj.guide]
        u = rot * complex(*pj.direction)
        origin = rot * complex(*pj.origin) + T
        at = complex(*result.points[pj.point])
        dv = carried(pj.slider, at) - carried(pj.guide, origin)
        du = 1j * omega[pj.guide] * u
        d = at - origin
        joints[pj.name] = (u.conjugate() * dv).real + (du.conjugate() * d).real
    every = [*omega.values(), *joints.values(), *(c for v in points.values() for c in v)]
    if not all(map(math.isfinite, every)):
        return Velocities(False, _OVERFLOW, cond=cond)
    return Velocities(True, None, omega, joints, points, cond)


#: why a finite rate at a regular configuration has no answer
_OVERFLOW = (
    'no velocity: the rates are beyond the float range (a rate near the largest double; '
    'the Jacobian is regular here)'
)
