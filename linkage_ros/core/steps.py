"""The kinds of step a closed-form plan is made of (core.plan compiles them, core.execute runs
them)."""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from enum import StrEnum


class StepKind(StrEnum):
    """What a plan step does (the module docstring describes each)."""

    GROUND = 'ground'  # place the ground's body at rest
    KNOWN_POINT = 'known_point'  # a point given by the command
    TWO_POINTS = 'two_points'  # rigid transfer: a body from two of its known points
    POINT_ANGLE = 'point_angle'  # a body from a known point and its known orientation
    ANGLE = 'angle'  # a body's orientation from another's and a known angle
    RRR = 'circle_circle'  # RRR dyad: a point on two circles
    RRP = 'circle_line'  # RRP dyad: a slider point on a circle and a line
    RPR = 'line_through'  # RPR dyad: a guide turned so its line passes a known point
    SIDE = 'roller_side'  # which side of its flat face a roller is on (an assembly choice)


BRANCHING = (StepKind.RRR, StepKind.RRP, StepKind.RPR, StepKind.SIDE)


# ---- what each kind of step works on (Step.args) -------------------------------------------


@dataclass(frozen=True)
class KnownPoint:
    """KNOWN_POINT: the point (Step.point) is the value of spec ``spec_index``."""

    spec_index: int


@dataclass(frozen=True)
class TwoPoints:
    """TWO_POINTS: the body is placed from two of its points, both known and distinct."""

    first: str
    second: str


@dataclass(frozen=True)
class PointAngle:
    """POINT_ANGLE: the body is placed from a known point of it and its known orientation."""

    point: str


@dataclass(frozen=True)
class AngleFrom:
    """ANGLE: the orientation of ``link`` (in the step's body) from ``source`` (in a body whose
    orientation is known), related by spec ``spec_index`` (an angle) or locked (None: the
    guide and slider of a prismatic joint turn together)."""

    link: str
    source: str
    spec_index: int | None


@dataclass(frozen=True)
class RRRDyad:
    """RRR: the point (Step.point) on a circle about ``centre_a`` (a known point of body
    ``body_a``) and one about ``centre_b`` (of ``body_b``)."""

    body_a: int
    centre_a: str
    body_b: int
    centre_b: str


@dataclass(frozen=True)
class RRPDyad:
    """RRP: the slider point (Step.point) of ``joint`` on its guide's line and on a circle
    about ``centre`` (a known point of body ``body``)."""

    body: int
    centre: str
    joint: str


@dataclass(frozen=True)
class RPRDyad:
    """RPR: the step's body (the guide of ``joint``) turned about its known point ``pivot`` so
    that its line passes the known slider point (Step.point)."""

    joint: str
    pivot: str


@dataclass(frozen=True)
class RollerSide:
    """SIDE: the side of its flat face that the roller of slot ``joint`` (a slot with a
    ``radius``: its centre, Step.point, keeps that distance from the face) is on: +1 left of
    the face's direction, -1 right. Either side closes wherever the other does (the centre on
    the face's mirror line), and a roller cannot pass from one to the other without crossing
    the face (distance 0, impossible with a radius): an assembly choice like a dyad's sign,
    never changed by continuity. The next step (the RRP or RPR dyad of ``joint``) puts the
    centre on the line ``offset`` (m, signed) off the face, the face being the line through
    ``face`` (a point fixed in the guide, reference coordinates relative to its point
    ``anchor``) along the joint's direction; ``offset`` is the drawn one, or its mirror."""

    joint: str
    anchor: str
    face: complex  # the face point minus the anchor's, reference pose (m)
    drawn_offset: float  # the centre's signed distance from the face as drawn (m; left +)


StepArgs = (
    KnownPoint | TwoPoints | PointAngle | AngleFrom | RRRDyad | RRPDyad | RPRDyad | RollerSide
)

#: what a branching step works on
BranchArgs = RRRDyad | RRPDyad | RPRDyad | RollerSide


def anchor_of(args: BranchArgs) -> str:
    """The known point a branching step's sign is measured from (the first circle's centre,
    the guide's pivot, or a point of the roller's face link)."""
    if isinstance(args, RRRDyad):
        return args.centre_a
    if isinstance(args, RRPDyad):
        return args.centre
    if isinstance(args, RollerSide):
        return args.anchor
    return args.pivot


# ---- branch signs as text: one sign per branching step ----------------------------------------


def branch_signs(text: str) -> tuple[int, ...]:
    """Branch text as signs: (+1, -1) for '+-' (the inverse of :func:`branch_text`)."""
    return tuple(1 if c == '+' else -1 for c in text)


def branch_text(signs: Iterable[float]) -> str:
    """Branch signs as the status shows them: '+-' for (+1, -1). A tuple's text is kept (every
    answer names its mode, and a mechanism meets a handful of them)."""
    key = signs if type(signs) is tuple else None
    if key is not None:
        text = _BRANCH_TEXTS.get(key)
        if text is not None:
            return text
    text = ''.join('+' if s > 0 else '-' for s in signs)
    if key is not None and len(_BRANCH_TEXTS) < 256:  # (bounded: never grows with the input)
        _BRANCH_TEXTS[key] = text
    return text


_BRANCH_TEXTS: dict[tuple[float, ...], str] = {}


# ---- the branch setting: which assembly mode a solve takes ------------------------------------


class BranchRule(StrEnum):
    """Which assembly mode a solve takes."""

    CONTINUOUS = 'continuous'  # the reference pose's first, then the one nearest the last answer
    REFERENCE = 'reference'  # the reference pose's signs, always
    EXPLICIT = 'explicit'  # given signs, one per branching dyad of the plan
    JACOBIAN = 'jacobian'  # where Newton places the mechanism: a loop Jacobian determinant sign


@dataclass(frozen=True)
class Branch:
    """A branch rule and, for an explicit one, its signs (+1 / -1 per branching dyad)."""

    rule: BranchRule = BranchRule.CONTINUOUS
    signs: tuple[int, ...] | None = None
    #: JACOBIAN: the sign (+1 / -1) of the loop Jacobian's determinant over every moving link
    det_sign: int | None = None


def read_branch(text: object) -> Branch | None:
    """A branch setting's text as its rule (the one reading of it): 'continuous', 'reference',
    'J+' / 'J-' (the loop Jacobian's determinant sign) or a string of + and - (one sign per
    branching dyad; how many a plan has, parse_branch checks); None for anything else."""
    if text in ('continuous', 'reference'):
        return Branch(BranchRule(text))
    if text in ('J+', 'J-'):
        return Branch(BranchRule.JACOBIAN, det_sign=1 if text == 'J+' else -1)
    if isinstance(text, str) and set(text) <= {'+', '-'}:
        return Branch(BranchRule.EXPLICIT, branch_signs(text))
    return None


def sign_combinations(branch_count: int) -> Iterator[tuple[int, ...]]:
    """Every assembly mode of a dyad plan with ``branch_count`` branching steps, as branch
    signs: (+1, ..., +1) first, then in the order of :func:`itertools.product` over (+1, -1)
    (one empty combination where nothing branches)."""
    return itertools.product((1, -1), repeat=branch_count)
