"""The one internal record every description reader produces: a kinematic tree (links, joints
with their frames, axes, limits and marks) plus the closures that cut loops out of it.

Readers (URDF, URDF+ ``<loop>``, the urdfdom ``<constraint>`` proposal, SDFormat, side files)
are thin: they fill these frozen dataclasses and nothing else. Transforms are 4x4 homogeneous
matrices (metres), the pose of a child frame in its parent frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from ..errors import SceneError


class DescriptionError(SceneError):
    """A robot description (or its side file) cannot be read as a planar closed chain; the
    message names the file and the element (``joint 'joint2'``, ``loop 'loop1'``)."""


class JointType(Enum):
    """A tree joint's type as a planar chain sees it."""

    REVOLUTE = 'revolute'  # URDF revolute and continuous, SDF revolute
    PRISMATIC = 'prismatic'
    FIXED = 'fixed'  # merges its two links into one rigid body
    OTHER = 'other'  # floating, planar, ball, screw, ...: not in a planar closed chain


class DescriptionFormat(Enum):
    """The format a description was read from."""

    URDF = 'urdf'  # URDF, with <loop> or <constraint> closures
    SDF = 'sdf'


class ClosureType(Enum):
    """What a closure makes coincide (in the plane of the chain)."""

    REVOLUTE = 'revolute'  # the two frames' origins coincide (a pin); URDF+ loop, SDF, '3d'
    PRISMATIC = 'prismatic'  # the frames keep their orientation, the origin slides on the axis
    FRAME = '6d'  # the two frames coincide: a pin when a cut joint turns one of them


@dataclass(frozen=True)
class Limits:
    """A joint's ``<limit>`` (rad or m); None = not given."""

    lower: float | None = None
    upper: float | None = None


@dataclass(frozen=True)
class Mimic:
    """URDF ``<mimic>``: value = multiplier * leader + offset."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True, eq=False)
class TreeJoint:
    """A joint of the description's tree. The joint frame F is fixed in ``parent`` at
    ``parent_to_joint``; M is fixed in ``child`` at ``child_to_joint``; at value 0 they
    coincide, and the value turns M about (or moves it along) ``axis`` (unit, in F)."""

    name: str
    type: JointType
    parent: str
    child: str
    parent_to_joint: np.ndarray
    child_to_joint: np.ndarray
    axis: np.ndarray
    limits: Limits = Limits()
    mimic: Mimic | None = None
    #: True: commanded (URDF+ independent="true"), False: passive (independent="false", SDF
    #: effort 0), None: not marked
    independent: bool | None = None
    element: str = ''  # how messages name it: "joint 'joint2'"


@dataclass(frozen=True, eq=False)
class LinkFrame:
    """A frame fixed in a link: ``pose`` in the link's frame."""

    link: str
    pose: np.ndarray
    #: the tree joint this frame is the moving frame of (Gepetto's closure frames are joint
    #: frames: the joint's own rotation turns them), or None
    joint: str | None = None


@dataclass(frozen=True, eq=False)
class Closure:
    """Frames ``a`` and ``b`` (fixed in two links) that the chain must bring together."""

    name: str
    type: ClosureType
    a: LinkFrame
    b: LinkFrame
    axis: np.ndarray | None = None  # unit, in frame a; None: the chain's normal
    element: str = ''


@dataclass(frozen=True)
class Description:
    """A robot description read as a tree plus closures (see the module docstring)."""

    name: str
    source: str
    root: str
    links: tuple[str, ...]
    joints: tuple[TreeJoint, ...]
    frames: dict[str, LinkFrame] = field(default_factory=dict)
    closures: tuple[Closure, ...] = ()
    #: actuated joints stated by the description or a side file (None: from the joints' marks)
    actuated: tuple[str, ...] | None = None
    #: lengths stated by a side file, ``{NAME: m}`` (applied to the imported scene)
    dimensions: dict[str, float] = field(default_factory=dict)
    #: the actuated joints' values the chain is assembled at (rad, m; default 0)
    assemble_at: dict[str, float] = field(default_factory=dict)
    #: limits a side file states, overriding the description's ``<limit>``
    limits: dict[str, Limits] = field(default_factory=dict)
    format: DescriptionFormat = DescriptionFormat.URDF

    def joint(self, name: str) -> TreeJoint | None:
        return next((j for j in self.joints if j.name == name), None)

    def limits_of(self, joint: TreeJoint) -> Limits:
        """``joint``'s limits: a side file's where it states them, else its ``<limit>``."""
        return self.limits.get(joint.name, joint.limits)


# ---- transforms -----------------------------------------------------------------------------


def transform(xyz: tuple[float, float, float], rpy: tuple[float, float, float]) -> np.ndarray:
    """The 4x4 transform of URDF/SDF ``xyz`` (m) and fixed-axis roll-pitch-yaw (rad)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    t = np.eye(4)
    t[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    t[:3, 3] = xyz
    return t


def inverse(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """The 4x4 rotation by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    t = np.eye(4)
    t[:3, :3] = np.eye(3) + s * k + (1.0 - c) * (k @ k)
    return t


def joint_motion(joint: TreeJoint, value: float) -> np.ndarray:
    """The motion of M relative to F at ``value`` (rad or m)."""
    if joint.type is JointType.REVOLUTE:
        return rotation_about(joint.axis, value)
    if joint.type is JointType.PRISMATIC:
        t = np.eye(4)
        t[:3, 3] = joint.axis * value
        return t
    return np.eye(4)
