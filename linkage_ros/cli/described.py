"""A robot description's own joint names and values on the command line.

A mechanism read from a description (``mech.joint_coordinates`` set) takes requests in the
description's joint names and values and answers in them (core.model.joint_map): the CLI
converts a command line's knowns with :func:`scene_command` before a Solver sees them, as the
node's Engine does, and reports actuator ranges (``check``, ``range``) in the description's
values with :class:`InputValues`. For a scene file every function here is the identity.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..core.model.joint_map import (
    InputJoint,
    JointMap,
)
from ..point_coordinates import group_point_coordinates

TURN = 2.0 * math.pi


def joint_map(mech) -> JointMap | None:
    """The description's joint map, or None for a scene file's mechanism."""
    jc = mech.joint_coordinates
    return jc if isinstance(jc, JointMap) else None


def commanded(mech) -> list[str]:
    """The names ``--set`` takes (mech.commanded_input_names)."""
    return mech.commanded_input_names


def scene_names(mech, name: str) -> list[str]:
    """The scene's knowns a request name stands for (a mimic leader sets its follower too);
    CommandError for a joint that cannot be set (a closure frame, a mimic follower)."""
    jc = mech.joint_coordinates
    if jc is None:
        return [name]
    return list(jc.to_scene({name: 0.0}))


def scene_command(mech, command: Mapping[str, Any]) -> dict[str, Any]:
    """A command line's knowns (the description's names and values) -> the solver's, a
    point's two coordinates ``P.x``, ``P.y`` as the point ``point:P`` (as the node's Engine
    groups them: point_coordinates)."""
    jc = mech.joint_coordinates
    return group_point_coordinates(mech, dict(command) if jc is None else jc.to_scene(command))


def beyond_limits(mech, command: Mapping[str, Any]) -> str | None:
    """Why a command line's knowns (a robot description's names and values) give a joint a
    value beyond its <limit> (as given, not on the circle: JointMap.refusal, as the node's
    Engine refuses it), or None; None for a scene file."""
    jc = mech.joint_coordinates
    return None if jc is None else jc.refusal(command)


def grouped_knowns(mech, knowns: Sequence[str]) -> list[str]:
    """The solver's knowns of a command line's: ``P.x`` and ``P.y`` both given are the point
    ``point:P`` (in the place of the first), by the rule :func:`scene_command` groups their
    values with (point_coordinates)."""
    return list(group_point_coordinates(mech, dict.fromkeys(knowns, 0.0)))


def request_echo(mech, d: dict[str, Any], command: Mapping[str, Any]) -> dict[str, Any]:
    """An answer's echo of the request (``targets``; a refused answer's ``inputs``) as the
    request gave it. The solver echoes the scene's knowns, and a refused result has no joints
    for Result.to_dict to map back; for a description both become the request's names and
    values. A scene file's answer is left as it is."""
    if mech.joint_coordinates is None or not command:
        return d
    acts = set(commanded(mech))
    if 'targets' in d:
        d['targets'] = {k: v for k, v in command.items() if k not in acts}
    if d.get('status') != 'ok':
        d['inputs'] = {k: v for k, v in command.items() if k in acts}
    return d


def unit_of(mech, name: str) -> str | None:
    """'rad' or 'm' for a description joint's name, None for any other name."""
    jm = joint_map(mech)
    if jm is None:
        return None
    entry = jm.inputs.get(name)
    if entry is not None:
        return 'rad' if entry.revolute else 'm'
    out = next((o for o in jm.outputs if o.name == name), None)
    if out is None:
        return None
    return 'rad' if out.revolute else 'm'


class InputValues:
    """An actuator's values (the scene's convention: a range, toggles, the reference) -> the
    description's joint values. ``scene = scale * q + offset`` (scale +-1), so ``q = scale *
    (scene - offset)``. One value (a toggle, the reference) is then given as joint_states
    publishes it (a revolute joint's wrapped to (-pi, pi], moved by 2 pi into its limits where
    that fits); a range is moved by whole turns to contain the reference as published, so it
    stays one interval around the pose the mechanism is in."""

    def __init__(self, mech):
        self.mech = mech
        self.jm = joint_map(mech)
        #: scene actuator -> the description's actuated joint it is
        self._entries: dict[str, InputJoint] = {}
        if self.jm is not None:
            for name in self.jm.actuated:
                entry = self.jm.inputs.get(name)
                if entry is not None and entry.scene_name in mech.actuators:
                    self._entries[entry.scene_name] = entry
        self._reference: dict[str, float] = {}

    def name(self, actuator: str) -> str:
        """The description's joint name of a scene actuator (itself for a scene)."""
        found = self._entries.get(actuator)
        return actuator if found is None else found.name

    def actuator(self, name: str) -> str:
        """The scene actuator a description joint name drives (the name itself otherwise)."""
        for act, entry in self._entries.items():
            if entry.name == name:
                return act
        return name

    def reversed(self, actuator: str) -> bool:
        """Whether the description's joint turns against the scene's actuator (a range's ends
        swap)."""
        found = self._entries.get(actuator)
        return found is not None and found.scale < 0

    def value(self, actuator: str, v: float | None) -> float | None:
        """One value (a toggle, the reference, an extreme's input), as published."""
        found = self._entries.get(actuator)
        if found is None or v is None:
            return v
        assert self.jm is not None  # (an entry is the joint map's)
        return float(self.jm.actuated_value(found.name, v))

    def interval(
        self, actuator: str, lo: float | None, hi: float | None
    ) -> tuple[float | None, float | None]:
        """A range (None: open on that side) around the reference as published; a reversed
        joint swaps its ends."""
        entry = self._entries.get(actuator)
        if entry is None:
            return lo, hi
        a, b = (None if v is None else entry.scale * (v - entry.offset) for v in (lo, hi))
        if entry.scale < 0:
            a, b = b, a
        if entry.revolute and (a is not None or b is not None):
            ref = self._published_reference(actuator)
            if a is not None:  # the whole turns that bring the low end to or below the pose
                k = math.floor((ref - a) / TURN + 1e-9)
            else:
                k = math.ceil((ref - b) / TURN - 1e-9)  # type: ignore[operator]
            a, b = (None if v is None else v + k * TURN for v in (a, b))
        return a, b

    def values(self, actuator: str, vs: Sequence[float]) -> list[float]:
        """Several single values (toggles), sorted."""
        return sorted(float(self.value(actuator, v)) for v in vs)  # type: ignore[arg-type]

    def _published_reference(self, actuator: str) -> float:
        if actuator not in self._reference:
            from ..core.motion.common import reference_scalar

            v = self.value(actuator, reference_scalar(self.mech, actuator))
            self._reference[actuator] = float(v)  # type: ignore[arg-type]
        return self._reference[actuator]
