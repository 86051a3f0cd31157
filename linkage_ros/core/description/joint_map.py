"""The description's own joint coordinates, as a mapping at the edge of the engine.

Inside, joint values follow the scene's convention (a revolute joint is the child link's axis
angle minus the parent's). A description's joint is a rotation about its own axis from its own
zero pose, or a displacement along its prismatic axis. Both are affine in each other (a sign and
an offset), calibrated once at the reference pose; this module applies them where results leave
the engine (joint_states) and where requests enter it (commands, targets, trajectories). The
solver never learns URDF frames.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

from ..errors import CommandError


class OutputKind(Enum):
    REVOLUTE = 'revolute'  # sign * (child link angle - parent link angle) + offset
    PRISMATIC = 'prismatic'  # the scene slider's value + offset
    CUT = 'cut'  # a closure's joint frame: sign * (link a angle - link b angle) + offset
    CONSTANT = 'constant'  # a closure's joint frame held at ``offset`` (the other one turns)
    MIMIC = 'mimic'  # multiplier * leader + offset (a mimic outside the closed chain)


@dataclass(frozen=True)
class OutputJoint:
    """One published joint: how its value follows from a solved result."""

    name: str
    kind: OutputKind
    link_a: str = ''  # revolute: the child's body; cut: the body carrying frame a
    link_b: str = ''  # revolute: the parent's body; cut: the other body
    scene_joint: str = ''  # prismatic: the scene's slider
    sign: float = 1.0
    offset: float = 0.0
    leader: str = ''  # mimic
    lower: float | None = None  # the description's limits: a revolute value is wrapped into
    upper: float | None = None  # them where it fits


@dataclass(frozen=True)
class InputJoint:
    """A description joint a request may name: value ``scene = scale * q + offset`` of the
    scene's known ``scene_name`` (an actuator, or a joint for targets)."""

    name: str
    scene_name: str
    scale: float
    offset: float
    revolute: bool
    #: an actuated joint that follows another by its <mimic> (a gripper's second finger):
    #: value = multiplier * leader + mimic_offset, set whenever the leader is commanded
    leader: str = ''
    multiplier: float = 1.0
    mimic_offset: float = 0.0


def wrap(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    a = math.remainder(angle, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


class JointMap:
    """Scene values <-> the description's joint names and values (see the module docstring)."""

    def __init__(self, outputs: Sequence[OutputJoint], inputs: Sequence[InputJoint]):
        self.outputs = tuple(outputs)
        self.inputs = {i.name: i for i in inputs}
        self.names = tuple(o.name for o in self.outputs)
        self._followers = {i.leader: i for i in inputs if i.leader}

    # -- out: a solved result -> the description's joint values --------------------------------
    def positions(self, links: Mapping[str, float], joints: Mapping[str, float]) -> list[float]:
        """Every published joint's value from a result's link angles and joint values."""
        out: dict[str, float] = {}
        for o in self.outputs:
            if o.kind is OutputKind.PRISMATIC:
                v = joints[o.scene_joint] + o.offset
            elif o.kind is OutputKind.CONSTANT:
                v = o.offset
            elif o.kind is OutputKind.MIMIC:
                v = o.sign * out[o.leader] + o.offset
            else:
                v = _fit(wrap(o.sign * (links[o.link_a] - links[o.link_b]) + o.offset), o)
            out[o.name] = v
        return [out[n] for n in self.names]

    def velocities(self, links: Mapping[str, float], joints: Mapping[str, float]) -> list[float]:
        """Every published joint's rate (rad/s, m/s) from a result's link and joint rates."""
        out: dict[str, float] = {}
        for o in self.outputs:
            if o.kind is OutputKind.PRISMATIC:
                v = joints[o.scene_joint]
            elif o.kind is OutputKind.CONSTANT:
                v = 0.0
            elif o.kind is OutputKind.MIMIC:
                v = o.sign * out[o.leader]
            else:
                v = o.sign * (links[o.link_a] - links[o.link_b])
            out[o.name] = v
        return [out[n] for n in self.names]

    # -- in: the description's names and values -> the scene's knowns -------------------------
    def to_scene(self, values: Mapping[str, Any], rates: bool = False) -> dict[str, Any]:
        """A request's values (or, ``rates``, their rates) with every description joint turned
        into the scene's known; other names (links, points, the scene's own) pass unchanged.
        A mimic-coupled actuator follows its leader; naming it is refused."""
        out: dict[str, Any] = {}
        for name, value in values.items():
            entry = self.inputs.get(name)
            if entry is None:
                if any(o.name == name for o in self.outputs):
                    raise CommandError(
                        f'joint {name!r} follows from the closed chain (a closure frame or a '
                        'mimic outside the loop): it cannot be commanded'
                    )
                out[name] = value
                continue
            if entry.leader:
                raise CommandError(
                    f'joint {name!r} follows {entry.leader!r} by its <mimic>: command '
                    f'{entry.leader!r}'
                )
            out[entry.scene_name] = self._convert(entry, value, rates)
            follower = self._followers.get(name)
            if follower is not None:
                q = follower.multiplier * float(value) + (0.0 if rates else follower.mimic_offset)
                out[follower.scene_name] = self._convert(follower, q, rates)
        return out

    @staticmethod
    def _convert(entry: InputJoint, value: Any, rates: bool) -> Any:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return value  # the engine's checks name a bad value
        v = entry.scale * float(value) + (0.0 if rates else entry.offset)
        return wrap(v) if entry.revolute and not rates and math.isfinite(v) else v

    def describe(self) -> dict[str, Any]:
        return {
            'joints': list(self.names),
            'inputs': {i.name: i.scene_name for i in self.inputs.values() if not i.leader},
        }


def _fit(v: float, o: OutputJoint) -> float:
    """A wrapped angle moved by 2 pi into the joint's limits where that fits."""
    if o.lower is not None and v < o.lower and v + 2.0 * math.pi <= (o.upper or math.inf):
        return v + 2.0 * math.pi
    if o.upper is not None and v > o.upper and v - 2.0 * math.pi >= (o.lower or -math.inf):
        return v - 2.0 * math.pi
    return v
