"""Known (or wanted) quantities of a mechanism: specs, name resolution, and reading a spec's
value off solved poses."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import PlanError
from ..execute import LinkPoses
from ..model import Mechanism, SlideActuator
from ..model.limits import limit_interval as _limit_interval
from ..model.limits import limit_violation as _limit_violation
from ..model.names import KNOWN_KINDS as KNOWN_KINDS
from ..model.names import NameKind, point_coordinate, resolve_name
from ..ops import BATCH, SCALAR, to_xy
from ..quantities import AngleSpec, CoordinateSpec, PointSpec, ScalarSpec, SlideSpec, Spec
from .poses import Poses, ScalarPoses, link_poses

# ---- known-quantity specs --------------------------------------------------------------------


def spec_for(mech: Mechanism, name: str) -> Spec:
    """Resolve a user-facing name (the one rule: model.names.resolve_name: actuator, then
    joint, then link (its angle), then point; ``point:D`` picks the kind explicitly) to its
    spec. The spec keeps the name exactly as given, so command dicts use the same key. A
    coordinate name ``D.x`` / ``D.y`` (scene names have no dot) is one coordinate of a point."""
    coordinate = point_coordinate(mech, name)
    if coordinate is not None:
        point, axis = coordinate
        if point in mech.links[mech.ground].points:
            raise PlanError(
                f'known {name!r}: point {point!r} is fixed by the ground; it cannot be a target'
            )
        return CoordinateSpec(name, point, axis)
    named = resolve_name(mech, name)
    spec = _spec_of(mech, named.kind, named.name)
    return replace(spec, name=name) if named.given != named.name else spec


def _spec_of(mech: Mechanism, kind: NameKind, name: str) -> Spec:
    match kind:
        case NameKind.ACTUATOR:
            act = mech.actuators[name]
            coords = mech.joint_coordinates
            shown = None if coords is None else coords.shown(name)
            if isinstance(act, SlideActuator):
                return SlideSpec(
                    name,
                    act.joint,
                    minimum=act.min,
                    maximum=act.max,
                    shown=shown,
                    length=act.cylinder,
                )
            link = mech.links[act.link]
            v = mech.points[act.toward] - mech.points[act.pivot]
            d0 = math.atan2(v[1], v[0])
            ref_angle = 0.0 if act.reference == mech.ground else mech.links[act.reference].angle_ref
            return AngleSpec(
                name,
                link.name,
                act.reference,
                offset=d0 - ref_angle,
                minimum=act.min,
                maximum=act.max,
                shown=shown,
            )
        case NameKind.JOINT:
            for rj in mech.revolutes:
                if rj.name == name:
                    # joint value = child link angle - parent link angle (each along its axis)
                    return AngleSpec(
                        name,
                        rj.child,
                        rj.parent,
                        offset=mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
                    )
            return SlideSpec(name, name)
        case NameKind.LINK:
            if name == mech.ground:
                raise PlanError(f'{name!r} is the ground link: its angle is fixed')
            return AngleSpec(name, name, mech.ground, offset=mech.links[name].angle_ref)
        case NameKind.POINT:
            return PointSpec(name, name)


def spec_point_link(mech: Mechanism, point: str, preferred: str) -> str:
    return preferred if point in mech.links[preferred].points else mech.links_of_point(point)[0]


def point_complex(v: Sequence[float] | npt.NDArray[np.float64]) -> complex:
    return complex(float(v[0]), float(v[1]))


class ReadKind(Enum):
    ANGLE = 'angle'
    SLIDE = 'slide'
    POINT = 'point'
    COORDINATE = 'coordinate'


@dataclass(frozen=True)
class SpecReader:
    """How to read one spec's value off solved complex link poses, resolved once: an angle
    (rad, wrapped to (-pi, pi]), a slide (m), a point's complex position or one of its
    coordinates (m)."""

    kind: ReadKind
    link: str = ''  # angle: the link; slide: the slider's point's link; point: its link
    reference: str = ''  # angle: the reference link; slide: the guide
    offset: float = 0.0
    p_ref: complex = 0j  # slide / point: the point in the reference pose
    origin: complex = 0j  # slide: the origin on the guide
    direction: complex = 0j  # slide: the direction (reference pose)
    axis: int = 0  # coordinate: 0 x, 1 y

    def __call__(self, ops: Any, poses: LinkPoses) -> Any:
        if self.kind is ReadKind.ANGLE:
            return ops.wrap(poses.phi[self.link] - poses.phi[self.reference] + self.offset)
        x = poses.rot[self.link] * self.p_ref + poses.T[self.link]
        if self.kind is ReadKind.POINT:
            return x
        if self.kind is ReadKind.COORDINATE:
            return x.imag if self.axis else x.real
        rot = poses.rot[self.reference]
        v = x - (rot * self.origin + poses.T[self.reference])
        d = rot * self.direction
        return v.real * d.real + v.imag * d.imag


def spec_reader(mech: Mechanism, spec: Spec) -> SpecReader:
    match spec:
        case AngleSpec():
            return SpecReader(ReadKind.ANGLE, spec.link, spec.reference, spec.offset)
        case SlideSpec():
            pj = mech.prismatics[spec.joint]
            return SpecReader(
                ReadKind.SLIDE,
                spec_point_link(mech, pj.point, pj.slider),
                pj.guide,
                p_ref=point_complex(mech.points[pj.point]),
                origin=point_complex(pj.origin),
                direction=point_complex(pj.direction),
            )
        case PointSpec():
            return SpecReader(
                ReadKind.POINT,
                mech.links_of_point(spec.point)[0],
                p_ref=point_complex(mech.points[spec.point]),
            )
        case CoordinateSpec():
            return SpecReader(
                ReadKind.COORDINATE,
                mech.links_of_point(spec.point)[0],
                p_ref=point_complex(mech.points[spec.point]),
                axis=spec.axis,
            )


def spec_value_of(ops: Any, mech: Mechanism, spec: Spec, poses: LinkPoses) -> Any:
    """A spec's value on solved poses (complex link poses, either backend): an angle (rad,
    wrapped to (-pi, pi]) or slide (m), or a point's complex position."""
    return spec_reader(mech, spec)(ops, poses)


def spec_value_one(mech: Mechanism, spec: Spec, poses: ScalarPoses) -> Any:
    """A spec's value on one configuration: a float, or (x, y) for a point."""
    v = spec_value_of(SCALAR, mech, spec, poses)
    return (v.real, v.imag) if isinstance(spec, PointSpec) else v


def spec_value_at(mech: Mechanism, spec: Spec, poses: Poses) -> np.ndarray:
    """A spec's value on batched poses: (N,) for angle/slide, (N, 2) for a point."""
    with np.errstate(all='ignore'):
        v = spec_value_of(BATCH, mech, spec, link_poses(poses))
    return to_xy(v) if isinstance(spec, PointSpec) else np.asarray(v, float)


def limit_violation(spec: ScalarSpec, value: float) -> str | None:
    """Why ``value`` is outside ``spec``'s limits (the one rule: model.limits), or None; for a
    robot description's actuator, in its own values (``spec.shown``: the same interval); a
    cylinder's length of 0 or less, which its limits (a min > 0) name first where it has one."""
    lo, hi, shown = spec.minimum, spec.maximum, spec.shown
    given = value
    if shown is not None and (lo is not None or hi is not None):
        ends = [None if v is None else shown(v) for v in (lo, hi)]
        lo, hi = ends if shown.scale > 0 else ends[::-1]
        value = shown(value)
    why = _limit_violation(spec.name, value, lo, hi, spec.unit, spec.periodic)
    if why is None and isinstance(spec, SlideSpec) and spec.length and not given > 0:
        return (
            f"{spec.name} = {given:.9g} m is not a length: a cylinder's pin-to-pin length is "
            'more than 0'
        )
    return why


def value_interval(spec: ScalarSpec) -> tuple[float, float] | None:
    """The values :func:`limit_violation` allows ``spec``, as the closed interval [a, b] (the
    slack included: model.limits.limit_interval), where they are one: not an angle's, which
    compare on the circle. A cylinder's length starts at the least double above 0. Lets a
    caller judge a finite value with two comparisons."""
    interval = _limit_interval(spec.minimum, spec.maximum, spec.periodic)
    if interval is None:
        return None
    lo, hi = interval
    if isinstance(spec, SlideSpec) and spec.length:
        lo = max(lo, math.ulp(0.0))
    return lo, hi


#: how an inverse solve's refusal of an answer beyond an actuator's limits starts
NEEDS_BEYOND_LIMITS = 'target needs '


def needs_beyond_limits(needs: Iterable[tuple[ScalarSpec, float]]) -> str | None:
    """Why an inverse solve's answer is refused where it needs actuators beyond their limits
    (``needs``: each actuator's spec and the value the answer gives it), every one that is
    named (an operator who moves the boom back within its limit must not be refused again for
    the bucket), or None: the one wording of the scalar and the batch solve and the target
    rule."""
    whys = [why for spec, value in needs if (why := limit_violation(spec, value)) is not None]
    return f'{NEEDS_BEYOND_LIMITS}{"; and ".join(whys)}' if whys else None
