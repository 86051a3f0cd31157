"""The frozen description of a mechanism: links, joints, actuators, the Mechanism."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

NAME_RE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
SOLVERS = ('auto', 'closed_form', 'newton')


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
class Actuator:
    """An input: ``kind`` 'angle' (rad) or 'slide' (m).

    angle: the direction of ``pivot`` -> ``toward`` on ``link`` measured counter-clockwise from
    the reported direction of ``reference`` (from +x when the reference is the ground link).
    slide: the value of prismatic joint ``joint`` (a cylinder's pin-to-pin length).
    """

    name: str
    kind: str
    link: str | None = None
    reference: str | None = None
    pivot: str | None = None
    toward: str | None = None
    joint: str | None = None
    min: float | None = None
    max: float | None = None
    cylinder: bool = False


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
    form: str = 'general'
    shortcut: dict[str, Any] = field(default_factory=dict)
    #: lengths the scene states (m), by (link, point, point): used exactly wherever the solver
    #: needs that distance, instead of the distance of the drawn reference coordinates (which
    #: is the given length only to within rounding)
    dimensions: dict[tuple[str, str, str], float] = field(default_factory=dict)
    #: the dimensions stated by name (the scene's ``dimensions`` key and overrides), m
    stated: dict[str, float] = field(default_factory=dict)

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
            'actuators': {a.name: a.kind for a in self.actuators.values()},
            'n_links': len(self.links),
            'n_joints': len(self.revolutes) + len(self.prismatics),
            'dof': self.dof,
        }
