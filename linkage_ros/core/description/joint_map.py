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

import numpy as np

from ..errors import CommandError


class OutputKind(Enum):
    JOINT = 'joint'  # scale * (a scene joint's value) + offset (revolute: wrapped)
    CONSTANT = 'constant'  # a closure's joint frame held at ``offset`` (the other one turns)
    MIMIC = 'mimic'  # scale * leader + offset (a <mimic> outside the closed chain)


@dataclass(frozen=True)
class OutputJoint:
    """One published joint: an affine function of one scene joint's value. A description's
    tree joint joins the same two bodies as a scene joint; a closure's cut joint turns with the
    closure's pin."""

    name: str
    kind: OutputKind
    scene_joint: str = ''
    scale: float = 1.0
    offset: float = 0.0
    revolute: bool = True
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


def wrap(angle: Any) -> Any:
    """``angle`` in [-pi, pi] (a float, or elementwise for a batch's array)."""
    if isinstance(angle, np.ndarray):
        return np.remainder(angle + math.pi, 2.0 * math.pi) - math.pi
    return math.remainder(angle, 2.0 * math.pi)


class JointMap:
    """Scene values <-> the description's joint names and values (see the module docstring)."""

    def __init__(
        self,
        outputs: Sequence[OutputJoint],
        inputs: Sequence[InputJoint],
        actuated: Sequence[str] = (),
    ):
        self.outputs = tuple(outputs)
        self.inputs = {i.name: i for i in inputs}
        self.names = tuple(o.name for o in self.outputs)
        self.actuated = tuple(actuated)
        self._followers = {i.leader: i for i in inputs if i.leader}

    # -- out: a solved result -> the description's joint values --------------------------------
    def positions(self, joints: Mapping[str, Any]) -> list[Any]:
        """Every published joint's value from a result's scene joint values (floats, or a
        batch's arrays)."""
        out: dict[str, Any] = {}
        for o in self.outputs:
            if o.kind is OutputKind.CONSTANT:
                v = o.offset
            elif o.kind is OutputKind.MIMIC:
                v = o.scale * out[o.leader] + o.offset
            else:
                v = o.scale * joints[o.scene_joint] + o.offset
                if o.revolute:
                    v = _fit(wrap(v), o)
            out[o.name] = v
        return [out[n] for n in self.names]

    def velocities(self, joints: Mapping[str, Any]) -> list[Any]:
        """Every published joint's rate (rad/s, m/s) from a result's scene joint rates."""
        out: dict[str, Any] = {}
        for o in self.outputs:
            if o.kind is OutputKind.CONSTANT:
                v = 0.0
            elif o.kind is OutputKind.MIMIC:
                v = o.scale * out[o.leader]
            else:
                v = o.scale * joints[o.scene_joint]
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


def _fit(v: Any, o: OutputJoint) -> Any:
    """A wrapped angle moved by 2 pi into the joint's limits where that fits."""
    if isinstance(v, np.ndarray):
        lo = -math.inf if o.lower is None else o.lower
        hi = math.inf if o.upper is None else o.upper
        v = np.where((v < lo) & (v + 2.0 * math.pi <= hi), v + 2.0 * math.pi, v)
        return np.where((v > hi) & (v - 2.0 * math.pi >= lo), v - 2.0 * math.pi, v)
    if o.lower is not None and v < o.lower and v + 2.0 * math.pi <= (o.upper or math.inf):
        return v + 2.0 * math.pi
    if o.upper is not None and v > o.upper and v - 2.0 * math.pi >= (o.lower or -math.inf):
        return v - 2.0 * math.pi
    return v
