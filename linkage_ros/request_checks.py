"""The request checks (a JointState request's shape, its rates) and the status fields of an
answer: one set for every front end (the node, ``linkage bag``, trajectories), so each refuses
the same requests with the same words and reports the same fields. ROS-free."""

from __future__ import annotations

import collections
import math
from collections.abc import Container, Iterable, Mapping, Sequence
from typing import Any

from .core.errors import CommandError, echo
from .core.model import Mechanism
from .core.solver import Result
from .core.velocity import Velocities


def rates_error(rates: Mapping[str, float] | None) -> str | None:
    """Why a request's velocities cannot be used (one not finite), or None: the one rule of
    commands and of forward and inverse trajectories."""
    bad = [] if rates is None else [n for n, v in rates.items() if not math.isfinite(v)]
    if not bad:
        return None
    return (
        f'velocity of {echo(bad)} is not finite: give finite rates (rad/s, m/s) for every '
        'name, or no velocity at all'
    )


def name_count_error(count: int, max_names: int) -> str | None:
    """Why a request with ``count`` names is refused before any per-name work, or None."""
    if count <= max_names:
        return None
    return (
        f'JointState has {count} name(s); the scene has only {max_names} names '
        '(actuators, joints, links, and points as <point>.x and <point>.y) to give values for'
    )


def repeated_names(names: Iterable[str]) -> list[str]:
    """The names given more than once, sorted (each once)."""
    return sorted(n for n, count in collections.Counter(names).items() if count > 1)


def joint_names_error(names: Sequence[str], max_names: int) -> str | None:
    """Why a JointTrajectory's ``joint_names`` are malformed (none, too many, an empty or a
    repeated name), or None; in the trajectory's own words (a JointState's are
    :func:`request_shape_error`'s)."""
    if len(names) > max_names:
        return (
            f'JointTrajectory joint_names has {len(names)} names; the scene has only {max_names} '
            'names (actuators, joints, links, and points as <point>.x and <point>.y) to give '
            'values for'
        )
    if not names:
        return 'JointTrajectory joint_names is empty'
    empty = [i for i, n in enumerate(names) if not n]
    if empty:
        return f'JointTrajectory joint_names[{empty[0]}] is an empty string'
    repeated = repeated_names(names)
    if repeated:
        return f'JointTrajectory joint_names {echo(repeated)} more than once'
    return None


def request_shape_error(
    names: Sequence[str], npos: int, max_names: int | None = None
) -> str | None:
    """Why a JointState request (its names and its number of positions) is malformed, or None.

    Only the message's own shape: at least one name, as many positions as names, no empty or
    repeated name. Whether the names and values make sense for the mechanism (unknown or
    missing names, NaN, inf, limits, reachability) is the solver's call. ``max_names``
    (:func:`max_request_names`): more names than that are refused first, before any per-name
    work, so a 10^5-name message costs what a short one does.
    """
    too_many = None if max_names is None else name_count_error(len(names), max_names)
    if too_many:
        return too_many
    if names and len(names) == npos and all(names) and len(set(names)) == len(names):
        return None  # well formed (every command): no per-name diagnosis
    names = list(names)
    if not names and not npos:
        return 'empty JointState: name and position are both empty'
    if len(names) != npos:
        return (
            f'JointState has {len(names)} name(s) {echo(names)} but {npos} position(s); they must '
            'pair up one to one'
        )
    empty = [i for i, n in enumerate(names) if not n]
    if empty:
        return f'JointState name[{empty[0]}] is an empty string'
    dups = repeated_names(names)
    if dups:
        return f'JointState names {echo(dups)} more than once'
    return None


def pick_refusal(names: Sequence[str], npos: int, wanted: Container[str]) -> str | None:
    """Why a hardware JointState that carries some of the ``wanted`` names (state completion:
    the mechanism's inputs among any number of other joints) cannot be read, or None: its
    positions do not pair up with its names, or it names a wanted one twice. A message that
    carries none of them is no request (None)."""
    found = [n for n in names if n in wanted]
    if not found:
        return None
    if npos != len(names):
        return (
            f'JointState has {len(names)} name(s) but {npos} position(s): cannot read {echo(found)}'
        )
    repeated = repeated_names(found)
    if repeated:  # (the repeated ones only: a wanted name given once is no fault)
        return f'JointState names {echo(repeated)} more than once'
    return None


def max_request_names(mech: Mechanism) -> int:
    """The most names a request may carry: every name the scene has (a longer one must repeat
    a name or name something unknown); a point counts twice (``<point>.x``, ``<point>.y``)."""
    return len(mech.actuators) + len(mech.joint_names) + len(mech.links) + 2 * len(mech.points)


def request_values(
    names: Sequence[str], positions: Sequence[float], max_names: int | None = None
) -> dict[str, float]:
    """``{name: position}`` of a JointState request; CommandError if it is malformed."""
    why = request_shape_error(names, len(positions), max_names)
    if why:
        raise CommandError(why)
    return {n: float(p) for n, p in zip(names, positions)}


def request_rates(names: Sequence[str], velocity: Sequence[float]) -> dict[str, float] | None:
    """``{name: velocity}`` of a JointState command (None when velocity is empty, as
    JointState allows); CommandError unless there is one velocity per name."""
    if not len(velocity):
        return None
    if len(velocity) != len(names):
        raise CommandError(
            f'JointState has {len(names)} name(s) but {len(velocity)} velocities; give one '
            'velocity per name (rad/s or m/s) or none'
        )
    return {n: float(v) for n, v in zip(names, velocity)}


def status_values(result: Result, request: str) -> dict[str, Any]:
    """The key/values of the status answering a request, in order. Success: residual
    (fraction of the length scale), branch, branch_defined, margin, solver, iterations, cond
    (Newton only), mode_change (when a target changed it), velocity (when the request gave
    rates: 'ok (cond C)' or why there is none) and request. Failure: request (the reason is
    the status message)."""
    if not result.success:
        return {'request': request}
    values: dict[str, Any] = {
        'residual': result.residual,
        'branch': result.branch,
        'branch_defined': result.branch_defined,
        'margin': result.margin,
        'solver': result.solver,
        'iterations': result.iterations,
    }
    if result.cond is not None:
        values['cond'] = result.cond
    if result.mode_change:
        values['mode_change'] = result.mode_change
    if result.held:
        values['held'] = ', '.join(result.held)
    if result.velocity is not None:
        values['velocity'] = velocity_status(result.velocity)
    values['request'] = request
    return values


def status_text(value: Any) -> str:
    """A status value as the status carries it: '' for none, true / false, a float's repr
    (every digit), else str."""
    if value is None:
        return ''
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def status_texts(result: Result, request: str) -> dict[str, str]:
    """:func:`status_values` as the status's key/value texts."""
    return {k: status_text(v) for k, v in status_values(result, request).items()}


def velocity_status(vel: Velocities) -> str:
    """The status's 'velocity' value of an answer with rates: 'ok (cond C)' (C the scaled
    condition number of the loop-closure Jacobian) or why there are no velocities."""
    return f'ok (cond {vel.cond:.3g})' if vel.success else str(vel.reason)
