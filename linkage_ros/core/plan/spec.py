"""Known (or wanted) quantities of a mechanism: specs, name resolution, and reading a spec's
value off solved poses."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import PlanError
from ..execute import LinkPoses
from ..model import Mechanism
from ..ops import BATCH, SCALAR, to_xy
from .poses import Poses, ScalarPoses, link_poses

# ---- known-quantity specs --------------------------------------------------------------------


@dataclass(frozen=True)
class Spec:
    """One known (or wanted) quantity of a mechanism.

    kind 'angle': phi[link] - phi[reference] = value - offset        (rad; 1 value)
    kind 'slide': value of prismatic joint ``joint``                 (m;   1 value)
    kind 'point': world position of ``point``                        (m;   2 values x, y)
    """

    name: str
    kind: str
    link: str | None = None
    reference: str | None = None
    offset: float = 0.0
    joint: str | None = None
    point: str | None = None
    minimum: float | None = None
    maximum: float | None = None

    @property
    def size(self) -> int:
        return 2 if self.kind == 'point' else 1

    @property
    def unit(self) -> str:
        return 'rad' if self.kind == 'angle' else 'm'


KNOWN_KINDS = ('actuator', 'joint', 'link', 'point')


def spec_for(mech: Mechanism, name: str) -> Spec:
    """Resolve a user-facing name: actuator, then joint, then link (its angle), then point.

    A prefix picks the kind explicitly: ``point:D`` is the point D even where a joint is also
    named D (every point shared by two links is), likewise ``joint:``, ``link:``, ``actuator:``.
    The spec keeps the name exactly as given, so command dicts use the same key.
    """
    kind, _, bare = name.partition(':') if ':' in name else ('', '', name)
    if kind:
        if kind not in KNOWN_KINDS:
            raise PlanError(f'unknown kind {kind!r} in {name!r}; use one of {list(KNOWN_KINDS)}')
        found = _spec_of_kind(mech, kind, bare)
        if found is None:
            raise PlanError(f'{mech.name!r} has no {kind} named {bare!r}')
        return _renamed(found, name)
    for kind in KNOWN_KINDS:
        found = _spec_of_kind(mech, kind, name)
        if found is not None:
            return found
    raise PlanError(
        f'unknown name {name!r}: not an actuator, joint, link or point of {mech.name!r}'
    )


def _renamed(spec: Spec, name: str) -> Spec:
    return Spec(
        name,
        spec.kind,
        spec.link,
        spec.reference,
        spec.offset,
        spec.joint,
        spec.point,
        spec.minimum,
        spec.maximum,
    )


def _spec_of_kind(mech: Mechanism, kind: str, name: str) -> Spec | None:
    if kind == 'actuator' and name in mech.actuators:
        act = mech.actuators[name]
        if act.kind == 'slide':
            return Spec(name, 'slide', joint=act.joint, minimum=act.min, maximum=act.max)
        link = mech.links[act.link]
        v = mech.points[act.toward] - mech.points[act.pivot]
        d0 = math.atan2(v[1], v[0])
        ref_angle = 0.0 if act.reference == mech.ground else mech.links[act.reference].angle_ref
        return Spec(
            name,
            'angle',
            link=link.name,
            reference=act.reference,
            offset=d0 - ref_angle,
            minimum=act.min,
            maximum=act.max,
        )
    if kind == 'joint':
        for rj in mech.revolutes:
            if rj.name == name:
                # joint value = child link angle - parent link angle (each along its axis)
                return Spec(
                    name,
                    'angle',
                    link=rj.child,
                    reference=rj.parent,
                    offset=mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
                )
        if name in mech.prismatics:
            return Spec(name, 'slide', joint=name)
    if kind == 'link' and name in mech.links:
        if name == mech.ground:
            raise PlanError(f'{name!r} is the ground link: its angle is fixed')
        return Spec(
            name, 'angle', link=name, reference=mech.ground, offset=mech.links[name].angle_ref
        )
    if kind == 'point' and name in mech.points:
        return Spec(name, 'point', point=name)
    return None


def spec_point_link(mech: Mechanism, point: str, preferred: str) -> str:
    return preferred if point in mech.links[preferred].points else mech.links_of_point(point)[0]


def _c(v) -> complex:
    return complex(float(v[0]), float(v[1]))


@dataclass(frozen=True)
class SpecReader:
    """How to read one spec's value off solved complex link poses, resolved once: an angle
    (rad, wrapped to (-pi, pi]), a slide (m) or a point's complex position."""

    kind: str
    link: str = ''  # angle: the link; slide: the slider's point's link; point: its link
    reference: str = ''  # angle: the reference link; slide: the guide
    offset: float = 0.0
    p_ref: complex = 0j  # slide / point: the point in the reference pose
    origin: complex = 0j  # slide: the origin on the guide
    direction: complex = 0j  # slide: the direction (reference pose)

    def __call__(self, ops, poses: LinkPoses):
        if self.kind == 'angle':
            return ops.wrap(poses.phi[self.link] - poses.phi[self.reference] + self.offset)
        x = poses.rot[self.link] * self.p_ref + poses.T[self.link]
        if self.kind == 'point':
            return x
        rot = poses.rot[self.reference]
        v = x - (rot * self.origin + poses.T[self.reference])
        d = rot * self.direction
        return v.real * d.real + v.imag * d.imag


def spec_reader(mech: Mechanism, spec: Spec) -> SpecReader:
    if spec.kind == 'angle':
        return SpecReader('angle', spec.link, spec.reference, spec.offset)
    if spec.kind == 'slide':
        pj = mech.prismatics[spec.joint]
        return SpecReader(
            'slide',
            spec_point_link(mech, pj.point, pj.slider),
            pj.guide,
            p_ref=_c(mech.points[pj.point]),
            origin=_c(pj.origin),
            direction=_c(pj.direction),
        )
    return SpecReader(
        'point', mech.links_of_point(spec.point)[0], p_ref=_c(mech.points[spec.point])
    )


def spec_value_of(ops, mech: Mechanism, spec: Spec, poses: LinkPoses):
    """A spec's value on solved poses (complex link poses, either backend): an angle (rad,
    wrapped to (-pi, pi]) or slide (m), or a point's complex position."""
    return spec_reader(mech, spec)(ops, poses)


def spec_value_one(mech: Mechanism, spec: Spec, poses: ScalarPoses):
    """A spec's value on one configuration: a float, or (x, y) for a point."""
    v = spec_value_of(SCALAR, mech, spec, poses)
    return (v.real, v.imag) if spec.kind == 'point' else v


def spec_value_at(mech: Mechanism, spec: Spec, poses: Poses) -> np.ndarray:
    """A spec's value on batched poses: (N,) for angle/slide, (N, 2) for a point."""
    with np.errstate(all='ignore'):
        v = spec_value_of(BATCH, mech, spec, link_poses(poses))
    return to_xy(v) if spec.kind == 'point' else np.asarray(v, float)


def limit_violation(spec: Spec, value: float) -> str | None:
    """Why ``value`` is outside ``spec``'s limits, or None. Angles compare on the circle: the
    value is brought into [min, min + 2 pi) first, and a refusal names the nearer limit."""
    lo, hi = spec.minimum, spec.maximum
    if lo is None and hi is None:
        return None
    v = value
    if spec.kind == 'angle' and lo is not None and hi is not None:
        # angles compare on the circle: bring v into [lo, lo + 2 pi)
        v = lo + (value - lo) % (2 * math.pi)
        if v <= hi + 1e-12 * max(1.0, abs(hi)):
            return None
        over_hi = v - hi
        under_lo = lo + 2 * math.pi - v
        if under_lo < over_hi:
            return (
                f'{spec.name} = {value:.9g} {spec.unit} is below its minimum {lo:g} '
                f'by {under_lo:.3g} {spec.unit}'
            )
        return (
            f'{spec.name} = {value:.9g} {spec.unit} is beyond its maximum {hi:g} by '
            f'{over_hi:.3g} {spec.unit}'
        )
    if lo is not None and v < lo:
        return (
            f'{spec.name} = {value:.9g} {spec.unit} is below its minimum {lo:g} by '
            f'{lo - v:.3g} {spec.unit}'
        )
    if hi is not None and v > hi:
        return (
            f'{spec.name} = {value:.9g} {spec.unit} is beyond its maximum {hi:g} by '
            f'{v - hi:.3g} {spec.unit}'
        )
    return None
