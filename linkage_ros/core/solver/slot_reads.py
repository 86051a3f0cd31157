"""What a closed-form readout (closed_form.SlotReadout) reads off a run's registers, resolved
when it is made: a known's or actuator's value as SpecReader reads it by name, and a prismatic
joint's registers and constants (:class:`SlideRead`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

from ..ops import wrap_one
from ..plan import ReadKind, SpecReader
from ..scalar_plan import ScalarProgram

_PI = math.pi
_NEG_PI = -math.pi


def _wrap(a: float) -> float:
    return a if _NEG_PI < a <= _PI else wrap_one(a)


def slot_reader(read: SpecReader, prog: ScalarProgram) -> Callable[[list[Any]], Any]:
    """SpecReader.__call__ on a run's registers: an angle (rad, wrapped), a slide (m) or a
    point (complex)."""
    if read.kind is ReadKind.ANGLE:
        a, b, off = prog.iphi[read.link], prog.iphi[read.reference], read.offset
        return lambda R: _wrap(R[a] - R[b] + off)
    rot, T, p_ref = prog.irot[read.link], prog.iT[read.link], read.p_ref
    if read.kind is ReadKind.POINT:
        return lambda R: R[rot] * p_ref + R[T]
    grot, gT, origin, direction = (
        prog.irot[read.reference],
        prog.iT[read.reference],
        read.origin,
        read.direction,
    )

    def slide(R: list[Any]) -> float:
        x = R[rot] * p_ref + R[T]
        g = R[grot]
        v = x - (g * origin + R[gT])
        d = g * direction
        return v.real * d.real + v.imag * d.imag  # type: ignore[no-any-return]

    return slide


def as_complex(v: Any) -> complex:
    """An (x, y) pair as x + iy."""
    return complex(float(v[0]), float(v[1]))


class SlideRead(NamedTuple):
    """What SlotReadout.result reads of one prismatic joint, by register (a NamedTuple: the
    loop unpacks it as plainly as a tuple, yet each field has a name)."""

    joint: str
    reader: Callable[[list[Any]], float]  # its slide value from the registers (m)
    point: complex  # the slider point's reference position (m)
    normal: complex  # the guide's normal (i times its direction)
    slider_phi: int
    slider_rot: int
    slider_T: int
    guide_phi: int
    guide_rot: int
    guide_T: int
    face: float  # a roller's drawn offset from its face (m; 0: a plain slider)
    known: int  # the known value it is (index), -1: none
    read_rot: int  # the rot and T registers of the link carrying the slider point
    read_T: int
    read_ref: complex  # the point, the guide's origin and direction the slide is read with
    origin: complex
    direction: complex
    #: the slide is read at the slider point as the slider places it (the registers and the
    #: point above): that one complex serves both
    read_at_point: bool
    #: the slider and the guide may be turned apart (else the run sets their angles to the
    #: same floats: ScalarProgram.same_turn, and the angle's miss is 0.0)
    turned: bool
