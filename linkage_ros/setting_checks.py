"""A setting's refusal (a node parameter, a CLI option of the same meaning): :class:`ConfigError`
naming the setting and its value, and the checks of a setting that need the mechanism
(``target_point_hold``), shared by the engine and the node's parameters."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .core.errors import LinkageError, PlanError, echo
from .core.model import Mechanism
from .core.model.names import Named, NameKind, resolve_name


class ConfigError(LinkageError):
    """A setting (node parameter) is invalid: the message names it and the value."""


#: the most characters of a refused setting's value a message quotes (a scene path is one)
SETTING_ECHO_CHARS = 4096


def fail_setting(name: str, message: str, value: Any) -> None:
    # a path is quoted whole (up to PATH_MAX); a 10^5-character value is not
    raise ConfigError(f'parameter {name!r}: {message} (got {echo(value, SETTING_ECHO_CHARS)})')


def held_name(mech: Mechanism, name: str) -> Named | None:
    """``name`` resolved as a held value takes it (the one rule: model.names), or None: unknown,
    or the ground link (its angle is fixed)."""
    try:
        named = resolve_name(mech, name)
    except PlanError:
        return None
    return None if named.kind is NameKind.LINK and named.name == mech.ground else named


def check_point_hold(mech: Mechanism, hold: Sequence[str]) -> None:
    """ConfigError unless ``hold`` (target_point_hold) names values a point target can keep
    and, with the target's 2 values, gives ``mech``'s degrees of freedom; nothing held is
    always fine."""
    if not hold:
        return
    resolved = [held_name(mech, h) for h in hold]
    bad = [h for h, named in zip(hold, resolved) if named is None]
    if bad:
        fail_setting(
            'target_point_hold',
            f'unknown name(s) {bad} in scene {mech.name!r}; '
            'expected actuator, joint, (moving) link or point names',
            list(hold),
        )
    size = sum(named.values for named in resolved if named is not None)
    if 2 + size != mech.dof:
        fail_setting(
            'target_point_hold',
            f'a point target (2 values) plus these held names '
            f'({size} value(s)) must give the {mech.dof} degree(s) of freedom of '
            f'{mech.name!r}',
            list(hold),
        )
