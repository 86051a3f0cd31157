"""What RViz draws for each link of a scene's URDF: bars between a link's points (the outline
of a plate for a link of three or more points), a pin at each point, barrel and rod for a
cylinder, a block for a slider and a rail for a slide fixed in the ground; the ground in grey.

Sizes follow the scene's length scale. Geometry is written in the link's own frame (the frames
of core.urdf), from the reference-pose coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .model import Mechanism, SlideActuator


@dataclass(frozen=True)
class Pose2D:
    """A planar frame: origin (x, y) in m, x axis at ``yaw`` rad counter-clockwise."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def __matmul__(self, other: Pose2D) -> Pose2D:
        """``self`` then ``other`` expressed in ``self``'s frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            self.yaw + other.yaw,
        )

    def inverse(self) -> Pose2D:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(-(c * self.x + s * self.y), s * self.x - c * self.y, -self.yaw)

    def local(self, x: float, y: float) -> tuple[float, float]:
        """World point (x, y) in this frame's coordinates."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = x - self.x, y - self.y
        return c * dx + s * dy, -s * dx + c * dy


#: material name -> rgba
MATERIALS: dict[str, tuple[float, float, float, float]] = {
    'linkage_ground': (0.5, 0.5, 0.5, 1.0),
    'linkage_link': (0.2, 0.45, 0.75, 1.0),
    'linkage_barrel': (0.85, 0.5, 0.1, 1.0),
    'linkage_rod': (0.8, 0.8, 0.82, 1.0),
    'linkage_pin': (0.15, 0.15, 0.15, 1.0),
}

BAR_RADIUS = 0.015  # of the length scale
PIN_RADIUS = 0.03
THICKNESS = 0.02


@dataclass(frozen=True)
class Visual:
    """One URDF <visual>: ``shape`` cylinder (size radius, length; along z) or box (size)."""

    shape: str
    size: dict[str, float | tuple[float, ...]]
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    material: str


def _bar(
    p: np.ndarray, q: np.ndarray, radius: float, material: str, z: float = 0.0
) -> Visual | None:
    d = q - p
    length = float(np.hypot(*d))
    if not length > 0:
        return None
    mid = (p + q) / 2.0
    return Visual(
        'cylinder',
        {'radius': radius, 'length': length},
        (float(mid[0]), float(mid[1]), z),
        (0.0, math.pi / 2.0, math.atan2(float(d[1]), float(d[0]))),
        material,
    )


def _hull(points: list[np.ndarray]) -> list[np.ndarray]:
    """Convex hull, counter-clockwise (Andrew's monotone chain); collinear points dropped."""
    pts = sorted({(float(p[0]), float(p[1])) for p in points})
    if len(pts) <= 2:
        return [np.array(p) for p in pts]

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    upper: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return [np.array(p) for p in lower[:-1] + upper[:-1]]


def _cylinder_parts(mech: Mechanism) -> dict[str, tuple[bool, str]]:
    """{barrel or rod link: (True for the barrel, False for the rod; its cylinder joint)}."""
    out = {}
    for act in mech.actuators.values():
        if isinstance(act, SlideActuator) and act.cylinder:
            pj = mech.prismatics[act.joint]
            out[pj.guide] = (True, act.joint)
            out[pj.slider] = (False, act.joint)
    return out


def link_visuals(mech: Mechanism, link: str, frame: Pose2D) -> list[Visual]:
    """The visuals of ``link``, in its frame ``frame`` (its reference-pose frame)."""
    L = mech.length_scale
    local = {
        p: np.array(frame.local(*(float(v) for v in mech.points[p])))
        for p in mech.links[link].points
    }
    ground = link == mech.ground
    out: list[Visual | None] = []
    part = _cylinder_parts(mech).get(link)
    if part is not None:
        barrel, joint = part
        pj = mech.prismatics[joint]
        act = mech.actuators[joint]
        tube = act.min if act.min is not None else 0.6 * pj.ref_value
        d = np.array(Pose2D(0.0, 0.0, frame.yaw).local(*pj.direction))
        (pin,) = local.values()
        if barrel:  # from its pin toward the rod's pin
            out.append(_bar(pin, pin + 0.95 * tube * d, 2.2 * BAR_RADIUS * L, 'linkage_barrel'))
        else:  # from its pin back into the barrel
            out.append(_bar(pin, pin - 0.95 * tube * d, 1.1 * BAR_RADIUS * L, 'linkage_rod'))
    else:
        material = 'linkage_ground' if ground else 'linkage_link'
        hull = _hull(list(local.values()))
        edges = [(hull[0], hull[1])] if len(hull) == 2 else list(zip(hull, hull[1:] + hull[:1]))
        for p, q in edges:
            out.append(_bar(p, q, BAR_RADIUS * L, material))
    for pj in mech.prismatics.values():
        if link == pj.slider and part is None:  # a block on its guide
            dx, dy = Pose2D(0.0, 0.0, frame.yaw).local(*pj.direction)
            at = local[pj.point]
            out.append(
                Visual(
                    'box',
                    {'size': (0.15 * L, 0.08 * L, THICKNESS * L)},
                    (float(at[0]), float(at[1]), 0.0),
                    (0.0, 0.0, math.atan2(dy, dx)),
                    'linkage_link',
                )
            )
        if ground and pj.guide == link:  # a rail fixed in the ground
            o = np.array(frame.local(*pj.origin))
            d = np.array(Pose2D(0.0, 0.0, frame.yaw).local(*pj.direction))
            reach = abs(pj.ref_value) + 0.5 * L
            out.append(_bar(o - reach * d, o + reach * d, 0.4 * BAR_RADIUS * L, 'linkage_ground'))
    for p in local.values():
        out.append(
            Visual(
                'cylinder',
                {'radius': PIN_RADIUS * L, 'length': 1.5 * THICKNESS * L},
                (float(p[0]), float(p[1]), 0.0),
                (0.0, 0.0, 0.0),
                'linkage_pin',
            )
        )
    return [v for v in out if v is not None]
