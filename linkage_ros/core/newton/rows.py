"""The equations of a loop system, typed: which constraint each group of residual rows comes
from (EquationRows) and the compiled instruction each tail row is evaluated from (LineRow,
AngleRow, PointRow). The compiled rows are NamedTuples: evaluation unpacks them as plainly as
tuples (the scalar solve evaluates them ~10 times per command), yet each field has a name."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, TypeVar

import numpy as np

from ..mechanism import PrismaticJoint


@dataclass(frozen=True)
class RevoluteRows:
    """Two rows: the joint's point, as carried by ``parent`` and by ``child``, coincides."""

    parent: str
    child: str
    point: str


@dataclass(frozen=True)
class PrismaticRows:
    """Two rows: the slider point stays on the guide's line (a line row) and the slider turns
    with the guide (an angle row)."""

    joint: PrismaticJoint


@dataclass(frozen=True)
class SpecRows:
    """One row (angle, slide) or two (point): the known value of spec ``spec_index``."""

    spec_index: int


EquationRows = RevoluteRows | PrismaticRows | SpecRows


class RevoluteRow(NamedTuple):
    """Two rows: a revolute joint's point as carried by the link in ``slot_a`` minus as carried
    by the link in ``slot_b`` (levers: the point's offsets from each link's centroid, m)."""

    slot_a: int
    lever_ax: float
    lever_ay: float
    slot_b: int
    lever_bx: float
    lever_by: float


class LineRow(NamedTuple):
    """u . (w_S(lever_S) - w_G(lever_G)) [- value] (m): the guide's direction u (u0 turned with
    the guide) dotted with the slider point's offset from a base point of the guide."""

    guide_slot: int
    slider_slot: int
    u0x: float
    u0y: float
    slider_lever_x: float
    slider_lever_y: float
    guide_lever_x: float
    guide_lever_y: float
    value: int | None  # spec index, None: the line itself (value 0)


class AngleRow(NamedTuple):
    """L * wrap(phi_a - phi_b [- (value - offset)]) (m): a relative angle, in length units."""

    slot_a: int
    slot_b: int
    value: int | None  # spec index, None: locked together (a prismatic joint's guide/slider)
    offset: float  # rad


class PointRow(NamedTuple):
    """Two rows: w(lever) - (x, y) (m), a point of a link at its known position."""

    slot: int
    lever_x: float
    lever_y: float
    value: int  # spec index


TailRow = LineRow | AngleRow | PointRow


# ---- the residual formulas, once --------------------------------------------------------------
# Each takes floats (the scalar solve, one row at a time) or numpy arrays (the batched solve,
# every row of that kind for every configuration at once): the same expressions serve both.
# A link's pose enters as (c, s, x, y) = (cos phi, sin phi, centroid x, centroid y); a lever is
# a point's offset from its link's centroid in the reference pose (m); k scales the residual
# (1 or 1 / length scale). Each returns the residual row(s) and the varying Jacobian entries
# in the order compile_tables lists them (rotation columns times k).

#: a float (one row) or an array (a kind's rows for every configuration)
Num = TypeVar('Num', float, np.ndarray)


def revolute_rows(
    c1: Num,
    s1: Num,
    x1: Num,
    y1: Num,
    lax: Num,
    lay: Num,
    c2: Num,
    s2: Num,
    x2: Num,
    y2: Num,
    lbx: Num,
    lby: Num,
    k: float,
) -> tuple[Num, Num, tuple[Num, Num, Num, Num]]:
    """The joint's point as carried by link a minus as carried by link b: (fx, fy, jacobian
    entries d/dphi_a of fx, fy, d/dphi_b of fx, fy). d/dphi of a world point is perp(lever)."""
    rax, ray = c1 * lax - s1 * lay, s1 * lax + c1 * lay
    rbx, rby = c2 * lbx - s2 * lby, s2 * lbx + c2 * lby
    fx = ((x1 + rax) - (x2 + rbx)) * k
    fy = ((y1 + ray) - (y2 + rby)) * k
    return fx, fy, (-ray * k, rax * k, rby * k, -rbx * k)


def line_row(
    cG: Num,
    sG: Num,
    xG: Num,
    yG: Num,
    cS: Num,
    sS: Num,
    xS: Num,
    yS: Num,
    u0x: Num,
    u0y: Num,
    lsx: Num,
    lsy: Num,
    lgx: Num,
    lgy: Num,
    value: Num,
    k: float,
) -> tuple[Num, tuple[Num, Num, Num, Num, Num, Num]]:
    """u . (w_S(lever_S) - w_G(lever_G)) - value (m, times k), u the guide's turned direction:
    (f, jacobian entries d/d(phi_G, x_G, y_G, phi_S, x_S, y_S)); d u / dphi_G = perp(u)."""
    ux, uy = cG * u0x - sG * u0y, sG * u0x + cG * u0y
    srx, sry = cS * lsx - sS * lsy, sS * lsx + cS * lsy
    grx, gry = cG * lgx - sG * lgy, sG * lgx + cG * lgy
    dx, dy = (xS + srx) - (xG + grx), (yS + sry) - (yG + gry)
    f = ((ux * dx + uy * dy) - value) * k
    jac = (
        (-uy * dx + ux * dy - (ux * -gry + uy * grx)) * k,
        -ux,
        -uy,
        (ux * -sry + uy * srx) * k,
        ux,
        uy,
    )
    return f, jac


def angle_row(
    phi_a: Num,
    phi_b: Num,
    wrapped_value: Num,
    offset: Num,
    kL: float,
    wrap: Callable[[Num], Num],
) -> Num:
    """L * wrap(phi_a - phi_b - (value - offset)) (m, times k = kL / L): ``wrapped_value`` is the
    known angle already wrapped (0 for a locked pair); its Jacobian entries are constants."""
    return kL * wrap((phi_a - phi_b) - (wrapped_value - offset))


def point_rows(
    c: Num, s: Num, cx: Num, cy: Num, lx: Num, ly: Num, vx: Num, vy: Num, k: float
) -> tuple[Num, Num, tuple[Num, Num]]:
    """The point on its link minus its known position (vx, vy): (fx, fy, jacobian entries
    d/dphi of fx, fy)."""
    rx, ry = c * lx - s * ly, s * lx + c * ly
    return ((cx + rx) - vx) * k, ((cy + ry) - vy) * k, (-ry * k, rx * k)
