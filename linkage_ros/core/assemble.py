"""Reading a solution off solved link poses: inputs, joints, link angles and the loop-closure
residual, written once for one command and for a batch (core.ops backends)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from .model import Mechanism
from .plan import ReadKind, Spec, SpecReader, spec_reader
from .quantities import SlideSpec


@dataclass
class Assembly:
    """Values read off one configuration (floats) or a batch ((n,) arrays)."""

    inputs: dict[str, Any]
    joints: dict[str, Any]
    links: dict[str, Any]
    residual: Any  # largest loop-closure miss, fraction of the length scale


def _c(v: Any) -> complex:
    return complex(float(v[0]), float(v[1]))


def roller_offset(mech: Mechanism, joint: str) -> float:
    """A roller's drawn signed distance from its face (m, left of the joint's direction +),
    0.0 for any other prismatic joint (its point on its line, which is then the residual)."""
    if joint not in mech.rollers:
        return 0.0
    pj = mech.prismatics[joint]
    u = _c(pj.direction)
    return (u.conjugate() * (_c(mech.points[pj.point]) - _c(pj.origin))).imag


class ResultAssembler:
    """What to read off configurations whose placed links are ``placed`` (a dyad plan always
    places the same links; Newton all of them), resolved once.

    Every commanded actuator as given, every other actuator, joint and link whose links are
    placed, and the loop-closure residual over the joints and knowns whose links are placed, as
    a fraction of the length scale (rotation errors count as length scale * angle; the largest
    single component, the Newton rows' metric, so a Newton answer converged to tolerance
    reports a residual within it).
    """

    def __init__(
        self,
        mech: Mechanism,
        specs: Sequence[Spec],
        actuator_specs: Sequence[Spec],
        spec_links: Any,
        placed: Iterable[str],
    ):
        self.mech = mech
        self.specs = list(specs)
        have = set(placed)
        self.L = mech.length_scale
        commanded = {s.name: i for i, s in enumerate(self.specs)}
        #: (actuator, index of its commanded value or None, its spec)
        self.inputs = [
            (a, commanded.get(a), spec_reader(mech, s))
            for a, s in zip(mech.actuators, actuator_specs)
            if a in commanded or all(l in have for l in spec_links(s))
        ]
        self.revolutes = [
            (
                rj.name,
                rj.child,
                rj.parent,
                mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
                _c(mech.points[rj.point]),
            )
            for rj in mech.revolutes
            if rj.parent in have and rj.child in have
        ]
        self.slides = [
            (
                pj.name,
                pj.slider,
                pj.guide,
                spec_reader(mech, SlideSpec(pj.name, pj.name)),
                _c(mech.points[pj.point]),
                1j * _c(pj.direction),
                roller_offset(mech, pj.name),
            )
            for pj in mech.prismatics.values()
            if pj.guide in have and pj.slider in have
        ]
        self.links = [(l, link.angle_ref) for l, link in mech.links.items() if l in have]
        self.knowns = [
            (i, spec_reader(mech, s))
            for i, s in enumerate(self.specs)
            if all(l in have for l in spec_links(s))
        ]

    def __call__(self, ops: Any, poses: Any, values: Sequence[Any]) -> Assembly:
        """Read one configuration (``ops`` SCALAR, ``values`` as Solver.parse gives them) or a
        batch (BATCH, (n,) / (n, 2) arrays); ``poses`` are complex link poses."""
        L, phi, rot, T = self.L, poses.phi, poses.rot, poses.T
        # builtin max for one command (as fast as it gets; a NaN anywhere makes the Result
        # refused by Solver._build's finiteness check whatever the residual says)
        mx, wrap = (ops.maximum if ops.batch else max), ops.wrap
        #: each reading made once (a cylinder's throw is its joint's value, and a known's)
        read_once: dict[SpecReader, Any] = {}

        def reading(read: SpecReader) -> Any:
            got = read_once.get(read)
            if got is None:
                got = read_once[read] = read(ops, poses)
            return got

        inputs = {}
        for a, i, read in self.inputs:
            if i is not None:  # commanded: the value exactly as given
                inputs[a] = values[i] if ops.batch else float(values[i])
            else:
                inputs[a] = reading(read)
        joints = {}
        worst = 0.0
        for name, child, parent, offset, p in self.revolutes:
            joints[name] = wrap(offset + phi[child] - phi[parent])
            d = (rot[parent] * p + T[parent]) - (rot[child] * p + T[child])
            worst = mx(worst, mx(abs(d.real), abs(d.imag)))
        for name, slider, guide, read, p, normal, face in self.slides:
            joints[name] = reading(read)
            off = (rot[slider] * p + T[slider]) - (rot[guide] * p + T[guide])
            nrm = rot[guide] * normal
            # the point's miss from its line; a roller's (face: its drawn offset) from either
            # line ``face`` off its face (both sides close: the side is an assembly mode)
            across = off.real * nrm.real + off.imag * nrm.imag
            worst = mx(worst, abs(abs(across + face) - abs(face)))
            worst = mx(worst, L * abs(wrap(phi[slider] - phi[guide])))
        links = {l: wrap(ref + phi[l]) for l, ref in self.links}
        for i, read in self.knowns:
            got, v = reading(read), values[i]
            if read.kind is ReadKind.POINT:
                vx, vy = (v[:, 0], v[:, 1]) if ops.batch else (v[0], v[1])
                worst = mx(worst, mx(abs(got.real - vx), abs(got.imag - vy)))
            elif read.kind is ReadKind.ANGLE:  # reduce v exactly first
                worst = mx(worst, L * abs(wrap(got - wrap(v))))
            else:
                worst = mx(worst, abs(got - v))
        return Assembly(inputs, joints, links, worst / L)
