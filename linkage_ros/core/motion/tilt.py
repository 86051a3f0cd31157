"""Tilt of a link about a held point (the bin's tilt about its lip)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..model import Mechanism
from ..solver import Result, Solver
from ..solver.mode_rule import ModeKeeper
from ..solver.result import NEWTON_TOL
from .common import link_key, point_key, reference_scalar
from .walk import walk_commands

# ---- tilt of a link about a held point --------------------------------------------------------


def max_tilt(
    mech: Mechanism,
    lip: str,
    link: str,
    hold_point: Sequence[float] | np.ndarray | None = None,
    start_angle: float | None = None,
    inputs: Mapping[str, float] | None = None,
    held: Sequence[str] | None = None,
    step: float = math.radians(1.0),
    max_rotation: float = math.pi,
    tol: float = NEWTON_TOL,
    method: str | None = None,
) -> dict[str, Any]:
    """Largest rotation of ``link`` (the bin) about its point ``lip`` (L) held fixed, within the
    actuator limits: inverse kinematics with knowns [lip point, link angle] (plus ``held``
    actuators at their current values when the mechanism has more than three DOF), scanning the
    link's angle from its current value both ways with branch-continuous solves and refining the
    first refused angle by bisection to ``tol`` rad.

    The current configuration is the reference pose, or the forward solve of ``inputs``
    ({actuator: value}); ``hold_point`` / ``start_angle`` override the lip position and the start
    angle. Returns a dict: ``min`` / ``max`` (link angle, rad, unwrapped around ``start``; None when
    no refusal within ``max_rotation``), ``tilt_down`` = start - min, ``tilt_up`` = max - start,
    ``reason`` {'min': ..., 'max': ...} (the solver's refusal just beyond each bound: an actuator
    limit or a dyad that no longer closes), ``inputs_at`` {'min': {...}, 'max': {...}} (actuator
    values at the bounds), ``hold_point``, ``start``, ``ok`` (False with ``reason['start']`` when
    the start itself is refused).
    """
    if lip not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {lip!r}')
    if link not in mech.links or link == mech.ground:
        raise ValueError(f'{link!r} is not a moving link of {mech.name!r}')
    if lip not in mech.links[link].points:
        raise ValueError(f'point {lip!r} is not on link {link!r}')
    extra = mech.dof - 3
    if extra < 0:
        raise ValueError(
            f'{mech.name!r} has {mech.dof} DOF: holding a point (2) and turning a '
            'link about it (1) needs at least 3'
        )
    if held is None:
        held = list(mech.actuators)[:extra]
    held = list(held)
    if len(held) != extra:
        raise ValueError(f'hold exactly {extra} actuator(s) of {mech.name!r} (got {held})')
    pk, lk = point_key(mech, lip), link_key(mech, link)
    current = {a: reference_scalar(mech, a) for a in mech.actuators}
    forward = Solver(mech, method=method)
    if inputs:
        current.update({k: float(v) for k, v in inputs.items()})
    fwd = forward.solve(current, commit=False)  # (the mechanism as it stands)
    if inputs:
        if not fwd.success:
            return {
                'ok': False,
                'link': link,
                'lip': lip,
                'min': None,
                'max': None,
                'reason': {'start': fwd.reason},
            }
        lip_now = np.asarray(fwd.points[lip], float)
        ang_now = fwd.links[link]
    else:
        lip_now = np.asarray(mech.points[lip], float)
        ang_now = mech.links[link].angle_ref
    hold = lip_now if hold_point is None else np.asarray(hold_point, float).reshape(2)
    a0 = float(ang_now if start_angle is None else start_angle)
    solver = Solver(mech, knowns=[pk, lk] + held, method=method, branch='continuous', max_iter=200)

    def command(angle: float) -> dict[str, Any]:
        cmd: dict[str, Any] = {pk: hold, lk: angle}
        cmd.update({h: current[h] for h in held})
        return cmd

    base = {
        'link': link,
        'lip': lip,
        'hold_point': [float(hold[0]), float(hold[1])],
        'start': a0,
        'held': {h: float(current[h]) for h in held},
    }
    # the start pose in the mechanism's assembly mode (the target rule, as ~/target answers
    # it): a continuous solve from the drawing may land in another mode with the same lip and
    # angle, whose limits are not this mechanism's as it stands
    start = _start_in_mode(mech, forward, solver, fwd, command(a0), method)
    if not start.success:
        return {
            **base,
            'ok': False,
            'min': None,
            'max': None,
            'tilt_up': None,
            'tilt_down': None,
            'reason': {'start': start.reason},
            'inputs_at': {},
        }
    res: dict[str, Any] = {**base, 'ok': True, 'reason': {}, 'inputs_at': {}}
    for d, key in ((1, 'max'), (-1, 'min')):
        b, why, last = walk_commands(solver, command, start, a0, d, step, max_rotation, tol)
        res[key] = b
        res['reason'][key] = why
        res['inputs_at'][key] = dict(last.inputs)
    res['tilt_up'] = None if res['max'] is None else res['max'] - a0
    res['tilt_down'] = None if res['min'] is None else a0 - res['min']
    return res


def _start_in_mode(
    mech: Mechanism,
    forward: Solver,
    solver: Solver,
    now: Result,
    values: Mapping[str, Any],
    method: str | None,
) -> Result:
    """The tilt's start (``values``: the lip, the angle, the held actuators) in the assembly
    mode of the configuration ``now`` (core.solver.mode_rule's target rule), or why not."""
    if not now.success:
        return solver.solve(values, commit=False)

    def make(knowns: Sequence[str] | None, branch: str | None, how: str | None) -> Solver:
        return Solver(
            mech, knowns=knowns, method=how or method, branch=branch or 'continuous', max_iter=200
        )

    keeper = ModeKeeper(mech, forward, make)
    before = keeper.mode(now)
    if before is None:
        return solver.solve(values, commit=False)
    solver.reset()
    solver.adopt(now)
    answer = keeper.target(
        solver, values, now, before, held_by='tilt, which starts from the mechanism as it stands,'
    ).result
    solver.reset()
    return answer
