"""The compiled loop-closure equations of a mechanism restricted to a set of free links: one
frozen LoopTables (rows, per-row constants, the Jacobian template and where its varying entries
go, unknown scales), built once by compile_tables. Evaluation (evaluate.py), the scalar Newton
(scalar.py) and the batched one (batch.py) are functions over it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from ..mechanism import Mechanism, PrismaticJoint
from ..quantities import AngleSpec, CoordinateSpec, SlideSpec, Spec
from .rows import (
    AngleRow,
    EquationRows,
    LineRow,
    PointRow,
    PrismaticRows,
    RevoluteRow,
    RevoluteRows,
    SpecRows,
    TailRow,
)


class FixedSlots(NamedTuple):
    """The poses of the non-free links the rows name, in slot order: (cos, sin, cx, cy) of each
    (cx, cy its centroid, m) and its rotation phi (rad)."""

    poses: list[tuple[float, float, float, float]]
    phis: list[float]


@dataclass(frozen=True)
class LinkShapes:
    """Each link's own drawing, where links disagree on their shared points (a redraw part of
    the way to new lengths): ``points[link][point]`` (x, y) in m, every point of every link, in
    the frame where the link is at its reference pose; ``line_bases[joint]`` a point of
    prismatic joint ``joint``'s line in its guide's frame (m; default the slider point as
    drawn). The unknowns stay each link's rotation and the place of its drawn centroid."""

    points: Mapping[str, Mapping[str, tuple[float, float]]]
    line_bases: Mapping[str, tuple[float, float]]


class PointOwner(NamedTuple):
    """A point, the first link that carries it and its reference position (complex, m)."""

    point: str
    link: str
    reference: complex


class ConstTemplate:
    """The constant entries of an (m, n) Jacobian, kept sparse (flat position -> value, raw
    units); the dense template (m * n + 1 floats, the last the dummy entry) is built when a
    dense solve first asks for it. A large mechanism's check system only reads the pattern:
    a dense template of its 2700 x 2700 J would be quadratic in the links."""

    def __init__(self, m: int, n: int, entries: Mapping[int, float], col_scale: np.ndarray):
        self.m, self.n = m, n
        self.positions = np.fromiter(entries.keys(), np.intp, len(entries))
        self.values = np.fromiter(entries.values(), float, len(entries))
        self._col_scale = col_scale

    @cached_property
    def raw(self) -> np.ndarray:
        """(m * n + 1,) the constant entries (m and rad units), zero elsewhere."""
        tpl = np.zeros(self.m * self.n + 1)
        tpl[self.positions] = self.values
        return tpl

    @cached_property
    def scaled(self) -> np.ndarray:
        """``raw`` in scale-free units: each column times col_scale."""
        tpl = np.zeros(self.m * self.n + 1)
        tpl[self.positions] = self.values * self._col_scale[self.positions % max(self.n, 1)]
        return tpl


@dataclass(frozen=True, slots=True)
class LoopTables:
    """The loop-closure equations of ``mech`` with ``specs`` known, unknowns the pose (phi rad,
    centroid m) of each link of ``free``. Link *slots*: the free links first (slot = index),
    then ``others``, the non-free links the rows name. Residual rows: the revolute ones first
    (``revs``, two each), then ``tail`` (line, angle and point rows in equation order). The
    Jacobian (m, n) flattened, plus one dummy entry at m * n: ``template`` holds its constant
    entries (``tpl``, dense; ``tpl_s`` the same in scale-free units: columns times
    ``col_scale``), ``jpos`` the flat position of each varying entry in evaluation order (the
    dummy for entries of non-free links, dropped)."""

    mech: Mechanism
    specs: tuple[Spec, ...]
    L: float  # the mechanism's length scale (m)
    free: tuple[str, ...]
    index: dict[str, int]  # free link -> its position in free
    n: int  # unknowns: 3 per free link
    m: int  # residual rows
    centroid: dict[str, np.ndarray]  # every link's reference centroid (m)
    rows: tuple[EquationRows, ...]  # the constraint each group of rows comes from
    col_scale: np.ndarray  # (n,) scale-free J = J * col_scale (1 / L on rotation columns)
    step_scale: np.ndarray  # (n,) dx = dy * step_scale (L on translation columns)
    step_list: list[float]  # step_scale as floats
    inv_step_list: list[float]  # 1 / step_scale as floats
    others: tuple[str, ...]
    revs: tuple[RevoluteRow, ...]
    tail: tuple[TailRow, ...]
    val_rows: tuple[int, ...] | None  # the row of each value component; None: a value moves
    # a non-free link (no prediction)
    template: ConstTemplate
    jpos: np.ndarray
    jpos_unique: bool  # no two varying entries land on one position (assignment, not add)
    ground_slots: FixedSlots | None  # the non-free slots with no fixed poses given (only
    # the ground, at its reference pose); None where others has any other link
    point_owner: list[PointOwner]

    @property
    def tpl(self) -> np.ndarray:
        """The dense template of J's constant entries (m * n + 1,)."""
        return self.template.raw

    @property
    def tpl_s(self) -> np.ndarray:
        """``tpl`` in scale-free units."""
        return self.template.scaled


def spec_links(mech: Mechanism, s: Spec) -> list[str]:
    """The links a spec's rows involve."""
    if isinstance(s, AngleSpec):
        return [s.link, s.reference]
    if isinstance(s, SlideSpec):
        pj = mech.prismatics[s.joint]
        return [pj.guide, pj.slider]
    if isinstance(s, CoordinateSpec):
        return [mech.ground, mech.links_of_point(s.point)[0]]
    return [mech.links_of_point(s.point)[0]]


def _equation_rows(
    mech: Mechanism, specs: Sequence[Spec], free: set[str]
) -> tuple[list[EquationRows], int]:
    """The constraints that involve a free link (revolutes, prismatics, specs) and their row
    count."""
    rows: list[EquationRows] = []
    m = 0
    for rj in mech.revolutes:
        if rj.parent in free or rj.child in free:
            rows.append(RevoluteRows(rj.parent, rj.child, rj.point))
            m += 2
    for pj in mech.prismatics.values():
        if pj.guide in free or pj.slider in free:
            rows.append(PrismaticRows(pj))
            m += 2
    for i, s in enumerate(specs):
        if any(l in free for l in spec_links(mech, s)):
            rows.append(SpecRows(i))
            m += s.size
    return rows, m


def compile_tables(
    mech: Mechanism,
    specs: Sequence[Spec],
    free_links: Sequence[str] | None = None,
    *,
    shapes: LinkShapes | None = None,
) -> LoopTables:
    """The LoopTables of ``mech`` with ``specs`` known and ``free_links`` (default: the moving
    links) unknown; each link's levers from ``shapes`` where given (else from the drawing)."""
    specs = tuple(specs)
    L = mech.length_scale
    free = list(free_links) if free_links is not None else list(mech.moving_links)
    index = {l: k for k, l in enumerate(free)}
    n = 3 * len(free)
    pts = mech.points
    cen = {
        # divided before the sum: points near 1.8e308 (a scene at the float range's edge)
        # would overflow np.mean's sum
        name: np.sum([pts[p] / len(l.points) for p in l.points], axis=0)
        for name, l in mech.links.items()
    }
    rows, m = _equation_rows(mech, specs, set(free))
    col_scale = np.tile([1.0 / L, 1.0, 1.0], len(free))
    step_scale = np.tile([1.0, L, L], len(free))

    slot = dict(index)
    others: list[str] = []

    def s_of(link: str) -> int:
        if link not in slot:
            slot[link] = len(free) + len(others)
            others.append(link)
        return slot[link]

    dummy = m * n  # varying entries of fixed links land here (dropped)
    consts: dict[int, float] = {}
    jpos: list[int] = []

    def var(r: int, link: str, k: int = 0) -> None:
        i = index.get(link)
        jpos.append(dummy if i is None else r * n + 3 * i + k)

    def const(r: int, link: str, k: int, v: float) -> None:
        i = index.get(link)
        if i is not None:
            pos = r * n + 3 * i + k
            consts[pos] = consts.get(pos, 0.0) + v

    def lever(link: str, p: object) -> tuple[float, float]:
        v = np.asarray(p, float) - cen[link]
        return float(v[0]), float(v[1])

    def on(link: str, p: str) -> tuple[float, float]:
        """Point p as ``link`` carries it (m)."""
        x, y = pts[p] if shapes is None else shapes.points[link][p]
        return float(x), float(y)

    def line_base(pj: PrismaticJoint) -> tuple[float, float]:
        if shapes is None or pj.name not in shapes.line_bases:
            x, y = pts[pj.point]  # the slider point as drawn
            return float(x), float(y)
        return shapes.line_bases[pj.name]

    revs: list[RevoluteRow] = []
    tail: list[TailRow] = []
    r = 0
    for row in rows:
        if not isinstance(row, RevoluteRows):
            continue
        a, b, P = row.parent, row.child, row.point
        revs.append(RevoluteRow(s_of(a), *lever(a, on(a, P)), s_of(b), *lever(b, on(b, P))))
        for rr, link in ((r, a), (r + 1, a), (r, b), (r + 1, b)):
            var(rr, link)
        for rr, link, k, v in (
            (r, a, 1, 1.0),
            (r + 1, a, 2, 1.0),
            (r, b, 1, -1.0),
            (r + 1, b, 2, -1.0),
        ):
            const(rr, link, k, v)
        r += 2

    def line(r: int, G: str, S: str, point: str, u0: object, base: object, vi: int | None) -> None:
        """u0 . (point on S - base on G) [- value]: a slide, a slot's line, or one world
        coordinate of a point (G the ground, base its origin, u0 the axis)."""
        u = np.asarray(u0, float)
        tail.append(
            LineRow(
                s_of(G),
                s_of(S),
                float(u[0]),
                float(u[1]),
                *lever(S, on(S, point)),
                *lever(G, base),
                vi,
            )
        )
        for link, k in ((G, 0), (G, 1), (G, 2), (S, 0), (S, 1), (S, 2)):
            var(r, link, k)

    def angle(r: int, a: str, b: str, vi: int | None, offset: float) -> None:
        tail.append(AngleRow(s_of(a), s_of(b), vi, offset))
        const(r, a, 0, L)
        const(r, b, 0, -L)

    spec_rows: dict[int, int] = {}
    for row in rows:
        if isinstance(row, PrismaticRows):
            pj = row.joint
            d0 = pj.direction
            line(r, pj.guide, pj.slider, pj.point, (-d0[1], d0[0]), line_base(pj), None)
            angle(r + 1, pj.slider, pj.guide, None, 0.0)
            r += 2
        elif isinstance(row, SpecRows):
            i = row.spec_index
            s = specs[i]
            spec_rows[i] = r
            if isinstance(s, AngleSpec):
                angle(r, s.link, s.reference, i, s.offset)
                r += 1
            elif isinstance(s, SlideSpec):
                pj = mech.prismatics[s.joint]
                line(r, pj.guide, pj.slider, pj.point, pj.direction, pj.origin, i)
                r += 1
            elif isinstance(s, CoordinateSpec):
                owner = mech.links_of_point(s.point)[0]
                axis = (1.0, 0.0) if s.axis == 0 else (0.0, 1.0)
                line(r, mech.ground, owner, s.point, axis, (0.0, 0.0), i)
                r += 1
            else:
                owner = mech.links_of_point(s.point)[0]
                tail.append(PointRow(s_of(owner), *lever(owner, on(owner, s.point)), i))
                var(r, owner)
                var(r + 1, owner)
                const(r, owner, 1, 1.0)
                const(r + 1, owner, 2, 1.0)
                r += 2
    val_rows: tuple[int, ...] | None = None
    if all(i in spec_rows for i in range(len(specs))):  # else a value moves fixed links
        val_rows = tuple(  # no prediction then
            rr for i, s in enumerate(specs) for rr in range(spec_rows[i], spec_rows[i] + s.size)
        )
    real = [p for p in jpos if p != dummy]
    point_owner: list[PointOwner] = []
    seen: set[str] = set()
    for l, body in mech.links.items():
        for p in body.points:
            if p not in seen:
                seen.add(p)
                point_owner.append(PointOwner(p, l, complex(*on(l, p))))
    ground_slots = (
        FixedSlots(
            [(1.0, 0.0, float(cen[l][0]), float(cen[l][1])) for l in others],
            [0.0] * len(others),
        )
        if all(l == mech.ground for l in others)
        else None
    )
    return LoopTables(
        mech=mech,
        specs=specs,
        L=L,
        free=tuple(free),
        index=index,
        n=n,
        m=m,
        centroid=cen,
        rows=tuple(rows),
        col_scale=col_scale,
        step_scale=step_scale,
        step_list=step_scale.tolist(),
        inv_step_list=[1.0, 1.0 / L, 1.0 / L] * len(free),
        others=tuple(others),
        revs=tuple(revs),
        tail=tuple(tail),
        val_rows=val_rows,
        template=ConstTemplate(m, n, consts, col_scale),
        jpos=np.array(jpos, np.intp),
        jpos_unique=len(set(real)) == len(real),
        ground_slots=ground_slots,
        point_owner=point_owner,
    )


def pattern_positions(t: LoopTables) -> np.ndarray:
    """The flat positions (each once, sorted) of the entries of J that can be nonzero at some
    configuration (the varying ones of free links and the nonzero constants): the same at
    every configuration. Linear in the entries, not in m * n."""
    dummy = t.m * t.n
    const = t.template.positions[t.template.values != 0]
    return np.unique(np.concatenate([t.jpos[t.jpos != dummy], const]))


def jacobian_pattern(t: LoopTables) -> np.ndarray:
    """(m, n) bool: pattern_positions as a dense matrix."""
    pattern = np.zeros(t.m * t.n, bool)
    pattern[pattern_positions(t)] = True
    out: np.ndarray = pattern.reshape(t.m, t.n)
    return out
