"""One run of a :class:`~linkage_ros.core.scalar_plan.ScalarProgram`: its registers and
continuity state (:class:`SlotRun`), and the step closures that several kinds of step share
(placing a welded body, a weld by angle or by slide, coincident circles)."""

from __future__ import annotations

import math
from cmath import isfinite as _cfinite
from collections.abc import Callable, Mapping, Sequence
from math import cos, sin
from typing import Any

from .execute import CONTINUITY_MARGIN
from .ops import cabs_one, wrap_one

_PI = math.pi
_CM = CONTINUITY_MARGIN


class Refused(Exception):
    """A step that does not close: its index and by how much (m); the run stops there."""

    def __init__(self, step: int, violation: float):
        self.step, self.violation = step, violation


class SlotRun:
    """One run: its registers and its continuity inputs and outputs. What most runs never set
    or read (a prediction given, by how much a refused step misses) is the class's value, stored
    on a run only where it differs (fewer stores per command; what every run reads is a slot:
    a class value is read ~3x slower through an instance)."""

    R: list[Any]  # the registers (see ScalarProgram: points, poses, frames, orientations)
    values: list[Any]
    signs: Sequence[int]
    #: made on first use by predict, if given
    prefer: Mapping[str, Any] | None = None
    #: predict(predict_from, values) makes ``prefer`` (a function and its first argument, not
    #: a closure over them: nothing is made per run for the prediction most runs never ask)
    predict: Callable[[Any, list[Any]], Mapping[str, Any] | None] | None
    predict_from: Any
    prev_small: bool  # some previous margin is below CONTINUITY_MARGIN
    prev_margins: Sequence[float] | None
    tol: float
    #: the branch sign taken at each branching step so far, and the dyad's margin (tuples: a
    #: State keeps them as they are)
    used: tuple[int, ...]
    margins: tuple[float, ...]
    margin: float  # the least of them (1.0 without a branching step)
    failure: int  # the step that did not close, or -1
    violation: float = 0.0  # by how much it misses (m)

    __slots__ = (
        'R',
        'values',
        'signs',
        'predict',
        'predict_from',
        'prev_small',
        'prev_margins',
        'tol',
        'used',
        'margins',
        'margin',
        'failure',
        '__dict__',  # (the class's values above where a run differs)
    )

    def prediction(self) -> Mapping[str, Any] | None:
        """Where continuity expects this configuration (None: nowhere), made on first use."""
        if self.predict is not None:
            self.prefer, self.predict = self.predict(self.predict_from, self.values), None
        return self.prefer

    def decide(self, margin: float, key: str) -> bool:
        """Continuity decides this branching step: the dyad's margin, now or in the previous
        answer, is below CONTINUITY_MARGIN and there is a prediction for ``key``."""
        if not margin < _CM:
            prev, b = self.prev_margins, len(self.used)
            if not (prev and b < len(prev) and prev[b] < _CM):
                return False
        prefer = self.prediction()
        return prefer is not None and key in prefer

    def taken(self, sign: int, margin: float) -> None:
        self.used += (sign,)
        self.margins += (margin,)
        if margin < self.margin:
            self.margin = margin


def wrap(a: float) -> float:
    """The angle wrap (ops), its common case inline."""
    return a if -_PI < a <= _PI else wrap_one(a)


Step = Callable[[SlotRun], None]


def welded_placer(
    members: list[Any], pose: tuple[float, complex, complex] = (0.0, 1 + 0j, 0j)
) -> Callable[..., None]:
    """place(r, phi, rot, T) of a welded body's members: each posed from its frame registers,
    and the points it sets first. ``pose``: the pose place(r) takes (the ground's: its step is
    the placer itself, no partial's call in between)."""
    phi0, rot0, T0 = pose

    def place_welded(r: SlotRun, phi: float = phi0, rot: complex = rot0, Tb: complex = T0) -> None:
        R = r.R
        for iphi, irot, iT, pts, fphi, frot, fT in members:
            lr = rot * R[frot]
            lt = rot * R[fT] + Tb
            R[iphi], R[irot], R[iT] = phi + R[fphi], lr, lt
            for s, ref in pts:
                R[s] = lr * ref + lt

    return place_welded


def turn_weld(
    wrapped: int, offset: float, forward: bool, p: complex, via: tuple[int, int, int],
    out: tuple[int, int, int], fixed: tuple[complex, complex] | None = None,
) -> Step:  # fmt: skip
    """A weld by a known angle (its value wrapped to (-pi, pi] in register ``wrapped``): the
    member turned about the shared point p. ``fixed``: the via's frame rotation and
    translation where they are constants (the root's), its point p computed once here."""
    vphi, vrot, vT = via
    lphi, lrot, lT = out
    at = None if fixed is None else fixed[0] * p + fixed[1]  # (the very floats a run makes)

    def turn(r: SlotRun) -> None:
        R = r.R
        rel = R[wrapped] - offset
        phi = R[vphi] + (rel if forward else -rel)
        rot = complex(cos(phi), sin(phi))
        pv = at if at is not None else R[vrot] * p + R[vT]
        R[lphi], R[lrot], R[lT] = phi, rot, pv - rot * p

    return turn


def slide_weld(
    i: int, ref_value: float, forward: bool, x_ref: complex, u: complex,
    via: tuple[int, int, int], out: tuple[int, int, int],
    fixed: tuple[complex, complex] | None = None,
) -> Step:  # fmt: skip
    """A weld by known slide ``values[i]``: the member moved along the slide (``forward``: the
    slider placed off its guide, else the guide off its slider). ``fixed``: as turn_weld's
    (x_ref in the via's frame computed once)."""
    vphi, vrot, vT = via
    lphi, lrot, lT = out
    at = None if fixed is None else fixed[0] * x_ref
    ux, uy = u.real, u.imag

    def slide(r: SlotRun) -> None:
        R = r.R
        dv = r.values[i] - ref_value
        along = x_ref + complex(dv * ux, dv * uy)
        vr = R[vrot]
        vx = at if at is not None else vr * x_ref
        if forward:  # guide placed: the slider point on its line
            T = (vr * along + R[vT]) - vx
        else:  # slider placed: hang the guide off it
            T = (vx + R[vT]) - vr * along
        R[lphi], R[lrot], R[lT] = R[vphi], vr, T

    return slide


def coincident(
    r: SlotRun, at: tuple[int, int], x: str, sx: int, c1: complex, r1: float, ref_off: complex
) -> None:
    """Coincident circles (a change point, e.g. a rhombus folded flat) leave x anywhere on the
    circle: keep it where continuity predicts, else where the reference pose has it relative to
    the first centre. Branch identity is undefined there (margin 0). ``at``: (the plan step's
    index, the index of its sign)."""
    k, b = at
    prefer = r.prediction()
    guess = prefer.get(x) if prefer else None
    off = (guess - c1) if guess is not None else ref_off
    n = cabs_one(off)
    off = off / n if 0 < n < math.inf else 1 + 0j
    foot = c1 + r1 * off
    sg = r.signs[b]
    if r.decide(0.0, x):
        sg = 1  # both branches are the one point
    z = (foot + (0.0 + sg * 0.0) * 1.0) * 1.0
    if not _cfinite(z):
        r.R[sx] = foot
        raise Refused(k, 0.0)
    r.R[sx] = z
    r.taken(sg, 0.0)
