"""The one name-resolution rule: what a user-facing name means in a mechanism.

A bare name is an actuator, else a joint (revolute, then prismatic), else a link (its angle),
else a point; a prefix picks the kind explicitly (``point:D`` is the point D even where a joint
is also named D, as every point shared by two links is). The solver's knowns (plan.spec_for),
the engine's held values, the motion analyses' keys and the plots' outputs all resolve here.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from ..errors import PlanError, echo
from ..mechanism import Mechanism


class NameKind(Enum):
    """What a name denotes, in the order a bare name is resolved."""

    ACTUATOR = 'actuator'
    JOINT = 'joint'
    LINK = 'link'
    POINT = 'point'


#: the kinds in resolution order (also the prefixes a name may carry: ``point:D``)
KNOWN_KINDS = tuple(k.value for k in NameKind)


@dataclass(frozen=True)
class Named:
    """A resolved name: its kind and the bare name in the mechanism (``given`` as written)."""

    kind: NameKind
    name: str
    given: str

    @property
    def values(self) -> int:
        """How many numbers the quantity is: 2 for a point (x, y), else 1."""
        return 2 if self.kind is NameKind.POINT else 1


def has_kind(mech: Mechanism, kind: NameKind, name: str) -> bool:
    """Whether ``mech`` has a ``kind`` named ``name``."""
    match kind:
        case NameKind.ACTUATOR:
            return name in mech.actuators
        case NameKind.JOINT:
            return any(rj.name == name for rj in mech.revolutes) or name in mech.prismatics
        case NameKind.LINK:
            return name in mech.links
        case NameKind.POINT:
            return name in mech.points


def resolve_name(mech: Mechanism, name: str) -> Named:
    """Resolve a user-facing name (see the module docstring). PlanError for an unknown prefix
    or name. The ground link resolves (as a LINK); whoever needs its angle refuses it."""
    kind_text, _, bare = name.partition(':') if ':' in name else ('', '', name)
    if kind_text:
        if kind_text not in KNOWN_KINDS:
            raise PlanError(
                f'unknown kind {echo(kind_text)} in {echo(name)}; use one of {list(KNOWN_KINDS)}'
            )
        kind = NameKind(kind_text)
        if not has_kind(mech, kind, bare):
            raise PlanError(f'{mech.name!r} has no {kind_text} named {echo(bare)}')
        return Named(kind, bare, name)
    for kind in NameKind:
        if has_kind(mech, kind, name):
            return Named(kind, name, name)
    raise PlanError(
        f'unknown name {echo(name)}: not an actuator, joint, link or point of {mech.name!r}'
    )


def known_name(mech: Mechanism, kind: NameKind, name: str) -> str:
    """The name that resolves to the ``kind`` named ``name``: bare where nothing earlier in the
    order has that name, else prefixed (``point:D``)."""
    bare = resolve_name(mech, name)
    return name if bare.kind is kind else f'{kind.value}:{name}'


#: the axes of a point coordinate name, ``<point>.x`` / ``<point>.y`` (m): a JointState carries
#: one number per name, so a point is two names (scene names are identifiers: no dot)
AXES = ('x', 'y')


def point_coordinate(mech: Mechanism, name: str) -> tuple[str, int] | None:
    """(point, axis index) of a coordinate name ``<point>.x`` / ``<point>.y`` of a point of
    ``mech`` (``point:<point>.x`` too: the prefix that picks a point), or None for any other
    name."""
    point, dot, axis = name.removeprefix('point:').rpartition('.')
    if not dot or axis not in AXES or point not in mech.points:
        return None
    return point, AXES.index(axis)


def depends_on_frame(mech: Mechanism, name: str) -> bool:
    """Whether the value of ``name`` depends on the frame it is given in: a point coordinate
    (m) or a link's angle (rad, absolute: from the frame's +x). An actuator's or a joint's value
    is relative (one link against another): the same in every frame. An unknown name: False
    (it is refused by name, where it is solved)."""
    if point_coordinate(mech, name) is not None:
        return True
    try:
        return resolve_name(mech, name).kind in (NameKind.LINK, NameKind.POINT)
    except PlanError:
        return False
