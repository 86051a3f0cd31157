"""The description's own joint coordinates, as a mapping at the edge of the engine.

Inside, joint values follow the scene's convention (a revolute joint is the child link's axis
angle minus the parent's). A description's joint is a rotation about its own axis from its own
zero pose, or a displacement along its prismatic axis. Both are affine in each other (a sign and
an offset), calibrated once at the reference pose; this module applies them where results leave
the engine (joint_states) and where requests enter it (commands, targets, trajectories). The
solver never learns URDF frames.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from ..errors import CommandError
from ..quantities import Shown
from .limits import limit_interval, limit_violation, slack, spans_a_turn, written_in_degrees


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
    """``angle`` in (-pi, pi] (a float, or elementwise for a batch's array), exactly as
    math.remainder gives it but -pi given as pi (as ops.wrap_one: both ways agree at odd
    multiples of pi): fmod is exact, and moving its result by 2 pi into the range is too
    (Sterbenz), where shifting by pi first and back rounded (0.05 came back
    0.04999999999999982, a bag's inputs unlike the node's)."""
    if isinstance(angle, np.ndarray):
        turn = 2.0 * math.pi
        f = np.fmod(angle, turn)
        return np.where(f > math.pi, f - turn, np.where(f <= -math.pi, f + turn, f))
    r = math.remainder(angle, 2.0 * math.pi)
    return math.pi if r == -math.pi else r


def wrap_given(angle: Any) -> Any:
    """``angle`` wrapped (:func:`wrap`) where it is finite; an infinite or NaN value as given
    (a float, or elementwise for an array): a command of +inf is refused as ``got inf``, and a
    refused row shows inf, where wrapping made it NaN (or raised, for a float)."""
    if isinstance(angle, np.ndarray):
        finite = np.isfinite(angle)
        with np.errstate(invalid='ignore'):  # (fmod of inf: NaN, replaced by the inf)
            return np.where(finite, wrap(angle), angle)
    return wrap(angle) if math.isfinite(angle) else angle


@dataclass(frozen=True)
class Plane:
    """Where the chain's plane lies in its ground link's 3-D frame: a scene point (x, y) is
    ``x * e1 + y * e2 + depth * normal`` (m), its depth the pin's along the joint axes."""

    e1: tuple[float, float, float]
    e2: tuple[float, float, float]
    normal: tuple[float, float, float]
    depths: dict[str, float]

    def point_3d(self, name: str, x: float, y: float) -> tuple[float, float, float]:
        d = self.depths.get(name, 0.0)
        return (
            x * self.e1[0] + y * self.e2[0] + d * self.normal[0],
            x * self.e1[1] + y * self.e2[1] + d * self.normal[1],
            x * self.e1[2] + y * self.e2[2] + d * self.normal[2],
        )

    def plane_xy(self, x: float, y: float, z: float) -> tuple[float, float]:
        """A 3-D point of the ground link's frame, projected into the plane."""
        return (
            x * self.e1[0] + y * self.e1[1] + z * self.e1[2],
            x * self.e2[0] + y * self.e2[1] + z * self.e2[2],
        )


class JointMap:
    """Scene values <-> the description's joint names and values (see the module docstring),
    and scene points <-> the ground link's 3-D frame (``plane``)."""

    def __init__(
        self,
        outputs: Sequence[OutputJoint],
        inputs: Sequence[InputJoint],
        actuated: Sequence[str] = (),
        plane: Plane | None = None,
    ):
        self.outputs = tuple(outputs)
        self.inputs = {i.name: i for i in inputs}
        self.names = tuple(o.name for o in self.outputs)
        self.actuated = tuple(actuated)
        #: the actuated joints a request sets: not one that follows another by its <mimic>
        self.commanded = tuple(a for a in self.actuated if not self.inputs[a].leader)
        self.plane = plane
        self._followers = {i.leader: i for i in inputs if i.leader}

    def point_3d(self, name: str, x: float, y: float) -> tuple[float, float, float]:
        """Scene point ``name`` at (x, y) in the ground link's 3-D frame (m)."""
        return (x, y, 0.0) if self.plane is None else self.plane.point_3d(name, x, y)

    def plane_xy(self, x: float, y: float, z: float) -> tuple[float, float]:
        """A point of the ground link's 3-D frame in the chain's plane (m)."""
        return (x, y) if self.plane is None else self.plane.plane_xy(x, y, z)

    # -- out: a solved result -> the description's joint values --------------------------------
    def positions(
        self, joints: Mapping[str, Any], inputs: Mapping[str, Any] | None = None
    ) -> list[Any]:
        """Every published joint's value from a result's scene joint values (floats, or a
        batch's arrays); with its ``inputs`` (the scene's actuator values), an actuated joint
        whose limits span turns at its command's own turn (actuated_value)."""
        out: dict[str, Any] = {}
        for o in self.outputs:
            if o.kind is OutputKind.CONSTANT:
                v = o.offset
            elif o.kind is OutputKind.MIMIC:
                v = o.scale * out[o.leader] + o.offset
            elif (
                inputs is not None
                and self._multi_turn(o.name)
                and self.inputs[o.name].scene_name in inputs
            ):
                v = self.actuated_value(o.name, inputs[self.inputs[o.name].scene_name])
            else:
                v = o.scale * joints[o.scene_joint] + o.offset
                if o.revolute:
                    v = fit_to_limits(wrap(v), o)
            out[o.name] = v
        return [out[n] for n in self.names]

    def passive_beyond_rows(self, joints: Mapping[str, Any]) -> Any:
        """Where the published passive joints break their <limit>s (beyond LIMIT_SLACK): a
        bool, or per row of a batch's arrays (the actuated joints' limits are the actuators',
        checked before any solve)."""
        values = dict(zip(self.names, self.positions(joints)))
        beyond: Any = False
        for o, (a, b) in self._passive_limits:
            v = values[o.name]
            beyond = beyond | (v < a) | (v > b)
        return beyond

    def passive_beyond(self, joints: Mapping[str, float]) -> str | None:
        """Why an answer's passive joints break a <limit> (the first that does), or None."""
        values = dict(zip(self.names, self.positions(joints)))
        for o, (a, b) in self._passive_limits:
            v = float(values[o.name])
            if v < a or v > b:
                unit = 'rad' if o.revolute else 'm'
                lo = -math.inf if o.lower is None else o.lower
                hi = math.inf if o.upper is None else o.upper
                return (
                    f'the answer puts passive joint {o.name} at {v:.9g} {unit}, beyond its '
                    f'<limit> [{lo:g}, {hi:g}] {unit}'
                )
        return None

    @functools.cached_property
    def _passive_limits(self) -> tuple[tuple[OutputJoint, tuple[float, float]], ...]:
        """The passive published joints with a <limit>, and the values it allows (the limit
        rule's interval, its slack on each side; a revolute value is already brought into
        the limits where it fits: fit_to_limits). A revolute joint's limits a full turn or
        more apart limit nothing (the import notes it, as for an actuated joint's): its angle
        is in them a whole number of turns away (limits written in degrees, [-150, -90],
        refused every answer as "beyond" them)."""
        return tuple(
            (o, interval)
            for o in self.outputs
            if o.kind is OutputKind.JOINT
            and o.name not in self.actuated
            and (o.lower is not None or o.upper is not None)
            and not (o.revolute and written_in_degrees(o.lower, o.upper))
            and (interval := limit_interval(o.lower, o.upper, False)) is not None
        )

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

    def actuated_values(self, inputs: Mapping[str, Any]) -> list[Any]:
        """The actuated joints' values from the scene's actuator values (floats or arrays;
        a refused request's given inputs too)."""
        return [self.actuated_value(a, inputs[self.inputs[a].scene_name]) for a in self.actuated]

    def actuated_value(self, joint: str, scene_value: Any) -> Any:
        """The actuated joint ``joint``'s value as published, from its scene actuator's (a
        float or an array): scale * (scene - offset), an angle wrapped and moved by 2 pi into
        the joint's limits where that fits."""
        entry = self.inputs[joint]
        given = entry.scale * (scene_value - entry.offset)  # scale is +-1
        if not entry.revolute:
            return given
        v = wrap_given(given)
        out = self._output_of.get(joint)
        if out is not None:
            v = fit_to_limits(v, out)
        if out is not None and self._multi_turn(joint):
            # a command's own turn where it is within the limits (to_scene leaves it unwrapped)
            assert out.lower is not None and out.upper is not None  # (_multi_turn)
            within = (given >= out.lower - slack(out.lower)) & (
                given <= out.upper + slack(out.upper)
            )
            v = (
                np.where(within, given, v)
                if isinstance(given, np.ndarray)
                else given
                if within
                else v
            )
        return v

    @functools.cached_property
    def _output_of(self) -> dict[str, OutputJoint]:
        """Each published joint by name."""
        return {o.name: o for o in self.outputs}

    def shown(self, actuator: str) -> Shown | None:
        """How the description writes the scene's actuator ``actuator`` (its actuated joint's
        value: ``scale * (scene - offset)``), None where it is the scene's value."""
        entry = self.inputs.get(actuator)
        if entry is None or entry.scene_name != actuator or (entry.scale, entry.offset) == (1, 0):
            return None
        return Shown(entry.scale, entry.offset)

    def broken_mimic(self, inputs: Mapping[str, float]) -> str | None:
        """Why the scene's actuator values ``inputs`` (a solved configuration's) break a
        <mimic> between actuated joints (a gripper's second knuckle follows the first: an
        inverse solve does not know it), in the description's names and values; None where
        every follower is at multiplier * leader + offset (to 1e-9 rad or m)."""
        values = dict(zip(self.actuated, self.actuated_values(inputs)))
        for name in self.actuated:
            entry = self.inputs[name]
            if not entry.leader or entry.leader not in values:
                continue
            want = entry.multiplier * values[entry.leader] + entry.mimic_offset
            got = values[name]
            miss = wrap(got - want) if entry.revolute else got - want
            if not abs(miss) <= 1e-9:
                return (
                    f'{name} follows {entry.leader} by its <mimic> ({name} = '
                    f'{entry.multiplier:g} * {entry.leader} + {entry.mimic_offset:g}), and this '
                    f'answer has {entry.leader} = {values[entry.leader]:.9g}, {name} = '
                    f'{got:.9g}: a pose the one actuator cannot give'
                )
        return None

    # -- in: the description's names and values -> the scene's knowns -------------------------
    def to_scene(
        self, values: Mapping[str, Any], rates: bool = False, command: bool = False
    ) -> dict[str, Any]:
        """A request's values (or, ``rates``, their rates; floats, or a recorded bag's arrays
        of them) with every description joint turned into the scene's known; other names
        (links, points, the scene's own) pass unchanged. A mimic-coupled actuator follows its
        leader; naming it is refused, and so is a passive joint in a ``command`` (CommandError,
        in the description's names)."""
        out: dict[str, Any] = {}
        for name, value in values.items():
            entry = self._entry(name, command)
            if entry is None:
                out[name] = value
                continue
            out[entry.scene_name] = self._convert(entry, value, rates, self._multi_turn(name))
            follower = self._followers.get(name)
            if follower is not None:
                v = np.asarray(value, np.float64) if isinstance(value, np.ndarray) else float(value)
                q = follower.multiplier * v + (0.0 if rates else follower.mimic_offset)
                out[follower.scene_name] = self._convert(
                    follower, q, rates, self._multi_turn(follower.name)
                )
        return out

    def beyond_limit(self, name: str, value: Any) -> str | None:
        """Why the value a request gives the description's revolute joint ``name`` (as given,
        not on the circle) is outside its limits (its <limit>, or the closure file's): such a
        joint turns between them, so a value a turn away is not the angle it wraps to (6.3 rad
        against [0, 0.8] is not 0.017 rad there); None where it is within, or the joint has
        no limit or one end only (a continuous one) or is prismatic (its actuator's own check
        reads those values as they are). Array rows: :meth:`rows_beyond_limits`."""
        if not self._bounded(name) or not isinstance(value, int | float):
            return None
        out = self._output_of[name]
        return limit_violation(name, float(value), out.lower, out.upper, 'rad', False)

    def _bounded(self, name: str) -> bool:
        """Whether ``name`` is a revolute input joint with both limit ends, not written in
        degrees (one end bounds no angle: an arc needs two; limits that read as degrees are no
        limit: docs/ROBOT_DESCRIPTIONS.md). Limits a turn or more apart bound it as given: a
        wrist's [-4, 4] rad refuses 4.5 (it was taken as 4.5 - 2 pi)."""
        entry, out = self.inputs.get(name), self._output_of.get(name)
        if entry is None or out is None or not entry.revolute:
            return False
        if out.lower is None or out.upper is None:
            return False
        return not written_in_degrees(out.lower, out.upper)

    def _multi_turn(self, name: str) -> bool:
        """Whether ``name`` is a revolute input joint whose limits (a turn or more apart, in
        radians) bound it as given: its value is kept as given, not wrapped (3.5 within
        [-4, 4] was published -2.78)."""
        return name in self._multi_turn_names

    @functools.cached_property
    def _multi_turn_names(self) -> frozenset[str]:
        """The input joints :meth:`_multi_turn` names, found once (every answer's positions
        and every request's values ask)."""
        return frozenset(
            name
            for name in self.inputs
            if self._bounded(name)
            and (out := self._output_of.get(name)) is not None
            and spans_a_turn(out.lower, out.upper)
        )

    def refusal(self, values: Mapping[str, Any]) -> str | None:
        """Why a request (the description's names and values, before :meth:`to_scene`) is
        refused as it stands: the first value beyond its joint's limit (:meth:`beyond_limit`),
        or None. The engine and the command line refuse it before any solve."""
        for name, value in values.items():
            for joint, q in self._with_follower(name, value):
                why = self.beyond_limit(joint, q)
                if why is not None:
                    return why
        return None

    def _with_follower(self, name: str, value: Any) -> list[tuple[str, Any]]:
        """(joint, value) of a request's ``name`` and of the actuated joint that follows it by
        its <mimic> (multiplier * value + offset: the value it is given, as to_scene gives it)."""
        out = [(name, value)]
        follower = self._followers.get(name)
        if follower is not None and isinstance(value, int | float | np.ndarray):
            out.append((follower.name, follower.multiplier * value + follower.mimic_offset))
        return out

    def rows_beyond_limits(self, columns: Mapping[str, Any]) -> dict[int, str]:
        """:meth:`beyond_limit` over a recorded bag's columns (an array per request name):
        {row: its first reason, in the columns' order}; the rows found by the same interval
        (model.limits.limit_interval: the limits and their rounding slack), each reason by
        :meth:`beyond_limit` itself."""
        refused: dict[int, str] = {}
        pairs = [jq for name, col in columns.items() for jq in self._with_follower(name, col)]
        for name, col in pairs:
            if not self._bounded(name):
                continue
            out = self._output_of[name]
            interval = limit_interval(out.lower, out.upper, False)
            assert interval is not None  # (not an angle's rule: periodic False)
            lo, hi = interval
            v = np.asarray(col, np.float64)
            with np.errstate(invalid='ignore'):
                rows = np.flatnonzero((v < lo) | (v > hi))  # (NaN: neither)
            for i in rows.tolist():
                why = self.beyond_limit(name, float(v[i]))
                if why is not None:
                    refused.setdefault(i, why)
        return refused

    def _entry(self, name: str, command: bool) -> InputJoint | None:
        """The input ``name`` stands for (None: not the description's joint), or why it cannot
        be set (CommandError)."""
        entry = self.inputs.get(name)
        if entry is None:
            if any(o.name == name for o in self.outputs):
                raise CommandError(
                    f'joint {name!r} follows from the closed chain (a closure frame or a '
                    'mimic outside the loop): it cannot be commanded'
                )
            return None
        if entry.leader:
            raise CommandError(
                f'joint {name!r} follows {entry.leader!r} by its <mimic>: command {entry.leader!r}'
            )
        if command and name not in self.actuated:
            raise CommandError(
                f'joint {name!r} is passive: the closed chain places it. Command '
                f'{", ".join(self.commanded)}, or ask for {name!r} as a target (~/target, '
                '--target)'
            )
        return entry

    @staticmethod
    def _convert(entry: InputJoint, value: Any, rates: bool, as_given: bool = False) -> Any:
        """scale * value + offset (a rate: scale * value), an angle wrapped unless
        ``as_given`` (a joint whose limits span turns: its turn is kept); a float or an array
        of them; anything else unchanged (the engine's checks name a bad value)."""
        offset = 0.0 if rates else entry.offset
        wrapped = entry.revolute and not rates and not as_given
        if isinstance(value, np.ndarray):
            v = entry.scale * np.asarray(value, np.float64) + offset
            return np.asarray(wrap_given(v), np.float64) if wrapped else v
        if isinstance(value, bool) or not isinstance(value, int | float):
            return value
        x = entry.scale * float(value) + offset
        return wrap_given(x) if wrapped else x

    def describe(self) -> dict[str, Any]:
        return {
            'joints': list(self.names),
            'inputs': {i.name: i.scene_name for i in self.inputs.values() if not i.leader},
        }


def fit_to_limits(v: Any, o: OutputJoint) -> Any:
    """A wrapped angle moved by 2 pi toward the joint's limits where that does not pass them
    (one value or an array: the same rule; a limit of 0 is a limit). Limits a turn or more
    apart limit nothing (spans_a_turn): there it is moved only where that lands it in them,
    not a turn toward limits written in degrees ([-150, -90]: -2.09 rad published -8.38)."""
    lo = -math.inf if o.lower is None else o.lower
    hi = math.inf if o.upper is None else o.upper
    up, down = v + 2.0 * math.pi, v - 2.0 * math.pi
    # (the far bound the moved value must not pass: the near one, where limits are a turn wide)
    up_to, down_to = (lo, hi) if spans_a_turn(o.lower, o.upper) else (-math.inf, math.inf)
    if isinstance(v, np.ndarray):
        v = np.where((v < lo) & (up >= up_to) & (up <= hi), up, v)
        return np.where((v > hi) & (down >= lo) & (down <= down_to), down, v)
    if v < lo and up_to <= up <= hi:
        return up
    if v > hi and lo <= down <= down_to:
        return down
    return v
