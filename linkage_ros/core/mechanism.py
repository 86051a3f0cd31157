"""The frozen description of a mechanism: links, joints, actuators, the Mechanism."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, ClassVar, Protocol

import numpy as np

from .dyads import wrap_angle
from .quantities import Shown

NAME_RE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')


class SolveMethod(StrEnum):
    """The solver a solve is asked for (a scene's ``solver``, the ``solver`` setting)."""

    AUTO = 'auto'  # the closed form where the dyad plan places every link, else Newton
    CLOSED_FORM = 'closed_form'
    NEWTON = 'newton'


#: the solver names a scene or a setting takes
METHODS = tuple(m.value for m in SolveMethod)


class SceneForm(StrEnum):
    """How a scene file states its mechanism (its one form key)."""

    GENERAL = 'general'  # points, links, sliders, ... (the ``points`` key)
    FOUR_BAR = 'four_bar'
    SLIDER_CRANK = 'slider_crank'


@dataclass(frozen=True)
class Link:
    """A rigid body: the named points it carries, in reference-pose coordinates.

    Its reported angle is the direction of ``axis`` (a point pair, counter-clockwise from +x, rad);
    by default the first two points (theta2 = direction O2->A for a crank). ``angle_ref`` is that
    direction in the reference pose.
    """

    name: str
    points: tuple[str, ...]
    angle_ref: float = 0.0
    axis: tuple[str, str] | None = None


@dataclass(frozen=True)
class RevoluteJoint:
    """Links ``parent`` and ``child`` share ``point``; the joint value is the child's angle minus
    the parent's angle (rad), each link's angle being the direction of its axis (first -> second
    point), so a URDF with each link frame on its axis reproduces the pose."""

    name: str
    point: str
    parent: str
    child: str


@dataclass(frozen=True)
class PrismaticJoint:
    """Point ``point`` of link ``slider`` slides on a line fixed in link ``guide``.

    The line passes through the point's reference position with unit ``direction`` (reference
    pose); the slider keeps its orientation relative to the guide. The joint value is the signed
    distance (m) along ``direction`` from ``origin`` (a reference-pose position fixed in the guide).
    """

    name: str
    guide: str
    slider: str
    point: str
    direction: tuple[float, float]
    origin: tuple[float, float]
    ref_value: float


@dataclass(frozen=True)
class AngleActuator:
    """An angle input (rad): the direction of ``pivot`` -> ``toward`` on ``link``, measured
    counter-clockwise from the reported direction of ``reference`` (from +x when the reference
    is the ground link). Limits compare on the circle."""

    name: str
    link: str
    reference: str
    pivot: str
    toward: str
    min: float | None = None
    max: float | None = None
    unit: ClassVar[str] = 'rad'
    periodic: ClassVar[bool] = True


@dataclass(frozen=True)
class SlideActuator:
    """A slide input (m): the value of prismatic joint ``joint`` (a cylinder's pin-to-pin
    length when ``cylinder``)."""

    name: str
    joint: str
    min: float | None = None
    max: float | None = None
    cylinder: bool = False
    unit: ClassVar[str] = 'm'
    periodic: ClassVar[bool] = False


#: an input of a mechanism
Actuator = AngleActuator | SlideActuator


class JointCoordinates(Protocol):
    """A robot description's own joint coordinates (names, origins, axes, zero pose), mapped
    at the edge of the engine: results leave in them, requests enter in them
    (core.description.JointMap implements it). The solver never sees them."""

    @property
    def names(self) -> tuple[str, ...]: ...

    @property
    def actuated(self) -> tuple[str, ...]: ...

    @property
    def commanded(self) -> tuple[str, ...]: ...

    def positions(
        self, joints: Mapping[str, Any], inputs: Mapping[str, Any] | None = None
    ) -> list[Any]: ...

    def velocities(self, joints: Mapping[str, Any]) -> list[Any]: ...

    def actuated_values(self, inputs: Mapping[str, Any]) -> list[Any]: ...

    def point_3d(self, name: str, x: float, y: float) -> tuple[float, float, float]: ...

    def plane_xy(self, x: float, y: float, z: float) -> tuple[float, float]: ...

    def to_scene(
        self, values: Mapping[str, Any], rates: bool = False, command: bool = False
    ) -> dict[str, Any]: ...

    def refusal(self, values: Mapping[str, Any]) -> str | None: ...

    def rows_beyond_limits(self, columns: Mapping[str, Any]) -> dict[int, str]: ...

    def broken_mimic(self, inputs: Mapping[str, float]) -> str | None: ...

    def passive_beyond(self, joints: Mapping[str, float]) -> str | None: ...

    def passive_beyond_rows(self, joints: Mapping[str, Any]) -> Any: ...

    def shown(self, actuator: str) -> Shown | None: ...


@dataclass
class Mechanism:
    name: str
    points: dict[str, np.ndarray]
    links: dict[str, Link]
    ground: str
    revolutes: list[RevoluteJoint]
    prismatics: dict[str, PrismaticJoint]
    actuators: dict[str, Actuator]
    outputs: tuple[str, ...]
    frame_id: str = 'world'
    solver: str = 'auto'
    source: str = '<scene>'
    length_scale: float = 1.0
    form: SceneForm = SceneForm.GENERAL
    shortcut: dict[str, Any] = field(default_factory=dict)
    #: lengths the scene states (m), by (link, point, point): used exactly wherever the solver
    #: needs that distance, instead of the distance of the drawn reference coordinates (which
    #: is the given length only to within rounding)
    dimensions: dict[tuple[str, str, str], float] = field(default_factory=dict)
    #: the dimensions stated by name (the scene's ``dimensions`` key and overrides), m
    stated: dict[str, float] = field(default_factory=dict)
    #: a robot description's joint coordinates (None: the scene's own are published)
    joint_coordinates: JointCoordinates | None = None
    #: the prismatic joints that are rollers on a flat face (slots with a ``radius``): the
    #: point keeps its offset from the line through the joint's origin on either side, the
    #: side being an assembly choice (a branch sign of the plan: core.steps.RollerSide)
    rollers: frozenset[str] = frozenset()

    def distance(self, link: str, p: str, q: str) -> float | None:
        """The stated length between points p and q of ``link``, or None."""
        d = self.dimensions.get((link, p, q))
        return self.dimensions.get((link, q, p)) if d is None else d

    # ---- derived views -------------------------------------------------------------------
    @property
    def moving_links(self) -> list[str]:
        return [n for n in self.links if n != self.ground]

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.revolutes] + list(self.prismatics)

    @property
    def output_joint_names(self) -> list[str]:
        """The joints published (joint_states, trajectories, CSV): the description's where the
        mechanism came from one, else the scene's."""
        jc = self.joint_coordinates
        return list(jc.names) if jc is not None else self.joint_names

    def output_joints(
        self, joints: Mapping[str, Any], inputs: Mapping[str, Any] | None = None
    ) -> list[Any]:
        """The published joints' values (rad, m) from a result's scene joint values (floats,
        or a batch's arrays); ``inputs``, its actuator values: a description's actuated joint
        whose limits span turns is published at the command's turn."""
        jc = self.joint_coordinates
        if jc is None:
            return [joints[j] for j in self.joint_names]
        return jc.positions(joints, inputs)

    def output_joint_rates(self, joints: Mapping[str, Any]) -> list[Any]:
        """The published joints' rates (rad/s, m/s) from a result's scene joint rates."""
        jc = self.joint_coordinates
        if jc is None:
            return [joints[j] for j in self.joint_names]
        return jc.velocities(joints)

    def point_3d(self, name: str, x: float, y: float) -> tuple[float, float, float]:
        """Point ``name`` at scene (x, y) in ``frame_id``'s 3-D coordinates (m): z = 0 for a
        scene file; a description's plane placed in its ground link's frame."""
        jc = self.joint_coordinates
        return (x, y, 0.0) if jc is None else jc.point_3d(name, x, y)

    def plane_xy(self, x: float, y: float, z: float) -> tuple[float, float]:
        """A point of ``frame_id``'s 3-D coordinates in the scene's plane (z ignored for a
        scene file; projected onto a description's plane)."""
        jc = self.joint_coordinates
        return (x, y) if jc is None else jc.plane_xy(x, y, z)

    @property
    def output_input_names(self) -> list[str]:
        """The inputs as published: the description's actuated joints, else the actuators."""
        jc = self.joint_coordinates
        return list(jc.actuated) if jc is not None else list(self.actuators)

    @property
    def commanded_input_names(self) -> list[str]:
        """The inputs a command sets: the actuators, or the description's actuated joints less
        those that follow another by their <mimic>."""
        jc = self.joint_coordinates
        return list(jc.commanded) if jc is not None else list(self.actuators)

    def output_inputs(self, inputs: Mapping[str, Any]) -> list[Any]:
        """The inputs' values as published (the description's joint values, else the
        actuators') from the scene's actuator values (floats or a batch's arrays)."""
        jc = self.joint_coordinates
        if jc is None:
            return [inputs[a] for a in self.actuators]
        return jc.actuated_values(inputs)

    def links_of_point(self, point: str) -> list[str]:
        return [n for n, l in self.links.items() if point in l.points]

    @property
    def dof(self) -> int:
        """Kutzbach mobility 3(n - 1) - 2j (revolute and prismatic pairs count as one each)."""
        return 3 * (len(self.links) - 1) - 2 * (len(self.revolutes) + len(self.prismatics))

    def describe(self) -> dict[str, Any]:
        return {
            'name': self.name,
            'links': {n: list(l.points) for n, l in self.links.items()},
            'joints': {
                j.name: {'type': 'revolute', 'point': j.point, 'parent': j.parent, 'child': j.child}
                for j in self.revolutes
            }
            | {
                p.name: {
                    'type': 'prismatic',
                    'guide': p.guide,
                    'slider': p.slider,
                    'point': p.point,
                }
                for p in self.prismatics.values()
            },
            'actuators': {a.name: actuator_kind(a) for a in self.actuators.values()},
            'n_links': len(self.links),
            'n_joints': len(self.revolutes) + len(self.prismatics),
            'dof': self.dof,
        }


def actuator_kind(act: Actuator) -> str:
    """The actuator's type as scene files write it (``angle`` or ``slide``): for output only."""
    return 'angle' if isinstance(act, AngleActuator) else 'slide'


def reference_value(mech: Mechanism, act: Actuator) -> float:
    """The actuator's value in the reference pose (rad or m), read off the drawing."""
    if isinstance(act, SlideActuator):
        return mech.prismatics[act.joint].ref_value
    v = mech.points[act.toward] - mech.points[act.pivot]
    ref = 0.0 if act.reference == mech.ground else mech.links[act.reference].angle_ref
    return wrap_angle(math.atan2(float(v[1]), float(v[0])) - ref)
