"""The equations of a loop system, typed: which constraint each group of residual rows comes
from (EquationRows) and the compiled instruction each tail row is evaluated from (LineRow,
AngleRow, PointRow). The compiled rows are NamedTuples: evaluation unpacks them as plainly as
tuples (the scalar solve evaluates them ~10 times per command), yet each field has a name."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple

from ..model import PrismaticJoint


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


class RowKind(IntEnum):
    """The kind of a compiled tail row (its first field)."""

    LINE = 0
    ANGLE = 1
    POINT = 2


class LineRow(NamedTuple):
    """u . (w_S(lever_S) - w_G(lever_G)) [- value] (m): the guide's direction u (u0 turned with
    the guide) dotted with the slider point's offset from a base point of the guide."""

    kind: RowKind  # RowKind.LINE
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

    kind: RowKind  # RowKind.ANGLE
    slot_a: int
    slot_b: int
    value: int | None  # spec index, None: locked together (a prismatic joint's guide/slider)
    offset: float  # rad


class PointRow(NamedTuple):
    """Two rows: w(lever) - (x, y) (m), a point of a link at its known position."""

    kind: RowKind  # RowKind.POINT
    slot: int
    lever_x: float
    lever_y: float
    value: int  # spec index


TailRow = LineRow | AngleRow | PointRow
