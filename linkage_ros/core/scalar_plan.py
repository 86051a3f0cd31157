"""A closed-form plan compiled for one command: slot-indexed steps over plain floats.

:class:`ScalarProgram` is the one-command twin of :class:`~linkage_ros.core.execute.PlanExecutor`
(which runs a batch): everything a step looks up by name there (which link carries a point,
reference positions, slide directions, stated lengths, which points a body placement sets
first) is resolved here once per plan into slot indices and constants, and each step becomes a
closure over them. A run keeps points and link poses in lists indexed by slot and builds the
name-keyed dicts a :class:`~linkage_ros.core.execute.PlanRun` holds once, at the end. The dyads
are :mod:`linkage_ros.core.scalar_dyads`.

The arithmetic is the batch executor's, operation for operation (the float results are the
same, the sign of a zero aside: see scalar_dyads); continuity is the one-command rule of the
executor it replaces: where a dyad is near its singularity (its margin now or in the previous
answer below CONTINUITY_MARGIN) the branch nearest the prediction is taken, and coincident
circles (a change point) keep the point where continuity predicts it.

Why a twin: the generic executor on the one-command backend cost 25 us of a 61 us warm
four-bar ``Solver.solve`` (issue 25's measurement: ~220 Python calls per solve, dict lookups by
name per step and an ops call per where / max); this program runs the same plan in ~4 us.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from math import atan2, cos, sin
from typing import Any

from .dyads import TANGENCY_TOL
from .errors import PlanError
from .execute import CONTINUITY_MARGIN, LinkPoses, PlanRun
from .ops import _cabs_one, _wrap_one
from .quantities import AngleSpec, PointSpec
from .scalar_dyads import (
    rpr_angle,
    rrp_point,
    rrr_fallback,
    rrr_point,
    solve_rpr,
    solve_rrp,
    solve_rrr,
)
from .steps import AngleFrom, KnownPoint, PointAngle, RPRDyad, RRPDyad, RRRDyad, StepKind, TwoPoints

_PI = math.pi


class _Refused(Exception):
    """A step that does not close: its index and by how much (m); the run stops there."""

    def __init__(self, step: int, violation: float):
        self.step, self.violation = step, violation


class SlotRun:
    """The slots of one run (points, link poses, body frames and orientations) and its
    continuity inputs and outputs."""

    P: list[Any]  # complex points by slot (None: not set yet)
    phi: list[Any]  # link poses by slot: angle (rad), e^{i phi}, translation
    rot: list[Any]
    T: list[Any]
    fphi: list[Any]  # welded bodies: each member's pose with the body's root at the identity
    frot: list[Any]
    fT: list[Any]
    ang: list[Any]  # body orientation (rad) when known before the body is placed
    values: list[Any]
    signs: Sequence[int]
    prefer: Mapping[str, Any] | None
    prev_margins: Sequence[float] | None
    tol: float
    used: list[int]  # the branch sign taken at each branching step so far
    margins: list[float]  # and the dyad's margin
    margin: float  # the least of them (1.0 without a branching step)
    failure: int  # the step that did not close, or -1
    violation: float  # by how much it misses (m)

    __slots__ = (
        'P',
        'phi',
        'rot',
        'T',
        'fphi',
        'frot',
        'fT',
        'ang',
        'values',
        'signs',
        'prefer',
        'prev_margins',
        'tol',
        'used',
        'margins',
        'margin',
        'failure',
        'violation',
    )

    def near_singular(self, m: float) -> bool:
        """Continuity decides this dyad's branch: its margin, now or in the previous answer,
        is below CONTINUITY_MARGIN."""
        b = len(self.used)
        prev = self.prev_margins
        p = prev[b] if prev and b < len(prev) else 1.0
        return min(m, p) < CONTINUITY_MARGIN

    def taken(self, sign: int, margin: float) -> None:
        self.used.append(sign)
        self.margins.append(margin)
        if margin < self.margin:
            self.margin = margin


def _wrap(a: float) -> float:
    return a if -_PI < a <= _PI else _wrap_one(a)


Step = Callable[[SlotRun], None]


class ScalarProgram:
    """One plan, compiled for one command at a time (made once per plan: see :func:`program`)."""

    def __init__(self, plan: Any):
        self.plan = plan
        mech = plan.mech
        self.ref = {p: complex(float(v[0]), float(v[1])) for p, v in mech.points.items()}
        self.direction = {
            j: complex(float(pj.direction[0]), float(pj.direction[1]))
            for j, pj in mech.prismatics.items()
        }
        self.single = [not b.welds for b in plan.bodies]
        self.carrier: dict[tuple[int, str], str] = {}
        for b in plan.bodies:
            for link in b.links:
                for p in mech.links[link].points:
                    self.carrier.setdefault((b.index, p), link)
        # slots: points and links in the order a run first sets them (the order of the dicts
        # a PlanRun holds), then the others
        point_order: list[str] = []
        link_order: list[str] = []
        self._simulate(point_order, link_order)
        self.point_names = tuple(point_order)
        self.link_names = tuple(link_order)
        self.pslot = {
            p: i
            for i, p in enumerate([*point_order, *(p for p in mech.points if p not in point_order)])
        }
        self.lslot = {
            l: i
            for i, l in enumerate([*link_order, *(l for l in mech.links if l not in link_order)])
        }
        self.n_points, self.n_links = len(mech.points), len(mech.links)
        self.n_bodies = len(plan.bodies)
        self.point_specs = tuple(isinstance(s, PointSpec) for s in plan.specs)
        used_bodies: set[int] = set()
        for st in plan.steps:
            a = st.args
            used_bodies.update(
                b
                for b in (
                    st.body,
                    getattr(a, 'body_a', None),
                    getattr(a, 'body_b', None),
                    getattr(a, 'body', None),
                )
                if b is not None  # fmt: skip
            )
            if isinstance(a, AngleFrom):
                used_bodies.add(plan.body_of[a.source])
        #: the frames a run needs: its welded bodies'
        self.frames: list[Step] = [
            self._frame_of(b) for b in sorted(used_bodies) if not self.single[b]
        ]
        self.steps: list[Step] = []
        set_pts: set[str] = set()
        placed: set[str] = set()
        for k, st in enumerate(plan.steps):
            self.steps.append(self._compile(k, st, set_pts, placed))

    # -- compile time --------------------------------------------------------------------------
    def _simulate(self, point_order: list[str], link_order: list[str]) -> None:
        """The order in which a run sets points and places links (static: a plan always does
        the same steps)."""
        plan, mech = self.plan, self.plan.mech
        for st in plan.steps:
            op = st.op
            if op in (StepKind.GROUND, StepKind.TWO_POINTS, StepKind.POINT_ANGLE, StepKind.RPR):
                for link in plan.bodies[st.body].links:
                    link_order.append(link)
                    point_order.extend(p for p in mech.links[link].points if p not in point_order)
            elif st.point is not None and st.point not in point_order:
                point_order.append(st.point)

    def _frame_of(self, bi: int) -> Step:
        """Fill the frame slots of a welded body's members (its root at the identity): welds by
        a known angle turn a member about the shared point, by a known slide move it along."""
        plan, mech, ls = self.plan, self.plan.mech, self.lslot
        body = plan.bodies[bi]
        root = ls[body.root]
        welds: list[tuple[Any, ...]] = []
        for w in body.welds:
            s = plan.specs[w.spec_index]
            if isinstance(s, AngleSpec):
                assert w.shared_point is not None  # an angle weld turns about a shared point
                welds.append(
                    (
                        True,
                        ls[w.link],
                        ls[w.via],
                        w.spec_index,
                        s.offset,
                        w.link == s.link,
                        self.ref[w.shared_point],
                        0j,
                        0.0,
                    )  # fmt: skip
                )
            else:
                pj = mech.prismatics[s.joint]
                welds.append(
                    (
                        False,
                        ls[w.link],
                        ls[w.via],
                        w.spec_index,
                        pj.ref_value,
                        w.link == pj.slider,
                        self.ref[pj.point],
                        self.direction[pj.name],
                        0.0,
                    )  # fmt: skip
                )

        def frame(r: SlotRun) -> None:
            fphi, frot, fT, values = r.fphi, r.frot, r.fT, r.values
            fphi[root], frot[root], fT[root] = 0.0, complex(1.0, 0.0), complex(0.0, 0.0)
            for is_angle, link, via, i, c0, forward, p, u, _ in welds:
                vphi, vrot, vT = fphi[via], frot[via], fT[via]
                if is_angle:
                    rel = _wrap(values[i]) - c0
                    phi = vphi + (rel if forward else -rel)
                    rot = complex(cos(phi), sin(phi))
                    fphi[link], frot[link], fT[link] = phi, rot, (vrot * p + vT) - rot * p
                else:
                    dv = values[i] - c0
                    along = p + complex(dv * u.real, dv * u.imag)
                    if forward:  # guide placed: the slider point on its line
                        T = (vrot * along + vT) - vrot * p
                    else:  # slider placed: hang the guide off it
                        T = (vrot * p + vT) - vrot * along
                    fphi[link], frot[link], fT[link] = vphi, vrot, T

        return frame

    def _placer(self, bi: int, set_pts: set[str], placed: set[str]) -> Callable[..., None]:
        """place(run, phi, rot, T): the body's members posed and the points it sets first."""
        plan, mech, ls, ps = self.plan, self.plan.mech, self.lslot, self.pslot
        members = []
        for link in plan.bodies[bi].links:
            new = [(ps[p], self.ref[p]) for p in mech.links[link].points if p not in set_pts]
            set_pts.update(mech.links[link].points)
            placed.add(link)
            members.append((ls[link], tuple(new)))
        if self.single[bi]:
            ((lslot, pts),) = members

            def place_single(r: SlotRun, phi: float, rot: complex, Tb: complex) -> None:
                r.phi[lslot], r.rot[lslot], r.T[lslot] = phi, rot, Tb
                P = r.P
                for s, ref in pts:
                    P[s] = rot * ref + Tb

            return place_single

        def place_welded(r: SlotRun, phi: float, rot: complex, Tb: complex) -> None:
            P, fphi, frot, fT = r.P, r.fphi, r.frot, r.fT
            for lslot, pts in members:
                lr = rot * frot[lslot]
                lt = rot * fT[lslot] + Tb
                r.phi[lslot], r.rot[lslot], r.T[lslot] = phi + fphi[lslot], lr, lt
                for s, ref in pts:
                    P[s] = lr * ref + lt

        return place_welded

    def _local(self, bi: int, p: str) -> Callable[[SlotRun], complex]:
        """A point of body bi in the body's frame."""
        ref = self.ref[p]
        if self.single[bi]:
            return lambda r: ref
        c = self.lslot[self.carrier[(bi, p)]]
        return lambda r: r.frot[c] * ref + r.fT[c]

    def _radius(self, bi: int, x: str, p: str) -> Callable[[SlotRun], float]:
        """|x - p| within body bi: the length the scene states for a link that carries both
        points, else their constant distance in a one-link body, else measured in the body's
        frame on every run (as the batch executor reads it)."""
        mech, plan = self.plan.mech, self.plan
        d = next(
            (
                mech.distance(link, x, p)
                for link in plan.bodies[bi].links
                if {x, p} <= set(mech.links[link].points) and mech.distance(link, x, p) is not None
            ),
            None,
        )
        if d is None and self.single[bi]:
            d = _cabs_one(self.ref[x] - self.ref[p])
        if d is not None:
            stated = d
            return lambda r: stated
        cx, cp = self.lslot[self.carrier[(bi, x)]], self.lslot[self.carrier[(bi, p)]]
        rx, rp = self.ref[x], self.ref[p]
        return lambda r: _cabs_one((r.frot[cx] * rx + r.fT[cx]) - (r.frot[cp] * rp + r.fT[cp]))

    def _compile(self, k: int, st: Any, set_pts: set[str], placed: set[str]) -> Step:
        ps, a = self.pslot, st.args
        op = st.op
        if op is StepKind.GROUND:
            place = self._placer(st.body, set_pts, placed)

            def ground(r: SlotRun) -> None:
                place(r, 0.0, complex(cos(0.0), sin(0.0)), complex(0.0, 0.0))

            return ground
        if op is StepKind.KNOWN_POINT and isinstance(a, KnownPoint):
            s, i = ps[st.point], a.spec_index
            set_pts.add(st.point)

            def known_point(r: SlotRun) -> None:
                v = r.values[i]
                r.P[s] = complex(float(v[0]), float(v[1]))

            return known_point
        if op is StepKind.TWO_POINTS and isinstance(a, TwoPoints):
            return self._two_points(k, st.body, a, set_pts, placed)
        if op is StepKind.POINT_ANGLE and isinstance(a, PointAngle):
            sp, lp, bslot = ps[a.point], self._local(st.body, a.point), st.body
            place = self._placer(st.body, set_pts, placed)

            def point_angle(r: SlotRun) -> None:
                phi = r.ang[bslot]
                rot = complex(cos(phi), sin(phi))
                place(r, phi, rot, r.P[sp] - rot * lp(r))

            return point_angle
        if op is StepKind.ANGLE and isinstance(a, AngleFrom):
            return self._angle(st.body, a, placed)
        if op is StepKind.RRR and isinstance(a, RRRDyad):
            set_pts.add(st.point)
            return self._rrr(k, st.point, a)
        if op is StepKind.RRP and isinstance(a, RRPDyad):
            set_pts.add(st.point)
            return self._rrp(k, st.point, a)
        if op is StepKind.RPR and isinstance(a, RPRDyad):
            return self._rpr(k, st, a, set_pts, placed)
        raise PlanError(f'internal: unknown plan step {op!r}')

    def _two_points(
        self, k: int, bi: int, a: TwoPoints, set_pts: set[str], placed: set[str]
    ) -> Step:
        sp, sq = self.pslot[a.first], self.pslot[a.second]
        place = self._placer(bi, set_pts, placed)
        if self.single[bi]:  # the unit vector between the points in the link's frame: constant
            v = self.ref[a.second] - self.ref[a.first]
            nv = _cabs_one(v)
            unit, lp_ref = (v / nv if nv > 0 else v), self.ref[a.first]

            def two_points_single(r: SlotRun) -> None:
                P = r.P
                b = P[sq] - P[sp]
                nb = _cabs_one(b)
                b = b / (nb if nb > 0 else 1.0)  # unit first: 1e-300 lengths would underflow
                phi = atan2(unit.real * b.imag - unit.imag * b.real,
                            unit.real * b.real + unit.imag * b.imag)  # fmt: skip
                rot = complex(cos(phi), sin(phi))
                place(r, phi, rot, P[sp] - rot * lp_ref)

            return two_points_single
        lp_of, lq_of = self._local(bi, a.first), self._local(bi, a.second)

        def two_points(r: SlotRun) -> None:
            P = r.P
            b = P[sq] - P[sp]
            nb = _cabs_one(b)
            b = b / (nb if nb > 0 else 1.0)
            lp = lp_of(r)
            u = lq_of(r) - lp
            nu = _cabs_one(u)
            u = u / (nu if nu > 0 else 1.0)
            phi = atan2(u.real * b.imag - u.imag * b.real, u.real * b.real + u.imag * b.imag)
            rot = complex(cos(phi), sin(phi))
            place(r, phi, rot, P[sp] - rot * lp)

        return two_points

    def _angle(self, bi: int, a: AngleFrom, placed: set[str]) -> Step:
        plan, ls = self.plan, self.lslot
        here = ls[a.link]
        here_single = self.single[bi]
        if a.source in placed:  # its pose is known: its angle
            src_slot = ls[a.source]

            def source(r: SlotRun) -> float:
                return r.phi[src_slot]  # type: ignore[no-any-return]
        else:  # its body's orientation and its angle in the body
            sb, there = plan.body_of[a.source], ls[a.source]
            there_single = self.single[sb]

            def source(r: SlotRun) -> float:
                return r.ang[sb] + (0.0 if there_single else r.fphi[there])  # type: ignore[no-any-return]

        i = a.spec_index
        offset, negate = 0.0, False
        if i is not None:
            s = plan.specs[i]
            offset, negate = s.offset, a.link == s.reference

        def angle(r: SlotRun) -> None:
            rel = 0.0
            if i is not None:
                rel = _wrap(r.values[i]) - offset
                if negate:
                    rel = -rel
            r.ang[bi] = source(r) + rel - (0.0 if here_single else r.fphi[here])

        return angle

    def _rrr(self, k: int, x: str, a: RRRDyad) -> Step:
        sx, s1, s2 = self.pslot[x], self.pslot[a.centre_a], self.pslot[a.centre_b]
        r1_of = self._radius(a.body_a, x, a.centre_a)
        r2_of = self._radius(a.body_b, x, a.centre_b)
        ref_off = self.ref[x] - self.ref[a.centre_a]

        def rrr(r: SlotRun) -> None:
            P = r.P
            r1, r2 = r1_of(r), r2_of(r)
            c1, c2 = P[s1], P[s2]
            prefer, tol = r.prefer, r.tol
            big = max(r1, r2)
            if _cabs_one(c1 - c2) <= tol * big and abs(r1 - r2) <= tol * big:
                # coincident circles (a change point, e.g. a rhombus folded flat) leave x
                # anywhere on the circle: keep it where continuity predicts, else where the
                # reference pose has it relative to c1; branch identity undefined (margin 0)
                guess = prefer.get(x) if prefer else None
                off = (guess - c1) if guess is not None else ref_off
                n = _cabs_one(off)
                off = off / n if 0 < n < math.inf else 1 + 0j
                foot = c1 + r1 * off
                sg = r.signs[len(r.used)]
                if prefer is not None and x in prefer and r.near_singular(0.0):
                    sg = 1  # both branches are the one point
                z = (foot + (0.0 + sg * 0.0) * 1.0) * 1.0
                if not _cfinite_point(z):
                    P[sx] = foot
                    raise _Refused(k, 0.0)
                P[sx] = z
                r.taken(sg, 0.0)
                return
            pair = solve_rrr(c1, r1, c2, r2, tol)
            margin = pair[5]
            if not pair[6]:
                raise _Refused(k, pair[7])
            sg = r.signs[len(r.used)]
            if prefer is not None and x in prefer and r.near_singular(margin):
                target = prefer[x]
                plus, ok = rrr_point(pair, 1)
                plus = plus if ok else rrr_fallback(pair, c1)
                minus, ok = rrr_point(pair, -1)
                minus = minus if ok else rrr_fallback(pair, c1)
                sg = 1 if _cabs_one(plus - target) <= _cabs_one(minus - target) else -1
            z, ok = rrr_point(pair, sg)
            if not ok:  # beyond the float range
                P[sx] = rrr_fallback(pair, c1)
                raise _Refused(k, 0.0)
            P[sx] = z
            r.taken(sg, margin)

        return rrr

    def _rrp(self, k: int, x: str, a: RRPDyad) -> Step:
        mech = self.plan.mech
        pj = mech.prismatics[a.joint]
        sx, s1, g = self.pslot[x], self.pslot[a.centre], self.lslot[pj.guide]
        r_of = self._radius(a.body, x, a.centre)
        xref, d = self.ref[x], self.direction[a.joint]

        def rrp(r: SlotRun) -> None:
            P = r.P
            rad = r_of(r)
            grot = r.rot[g]
            pair = solve_rrp(P[s1], rad, grot * xref + r.T[g], grot * d, r.tol)
            margin = pair[4]
            if not pair[5]:
                raise _Refused(k, pair[6])
            sg = r.signs[len(r.used)]
            prefer = r.prefer
            if prefer is not None and x in prefer and r.near_singular(margin):
                target = prefer[x]
                plus, _ = rrp_point(pair, 1)
                minus, _ = rrp_point(pair, -1)
                sg = 1 if _cabs_one(plus - target) <= _cabs_one(minus - target) else -1
            z, ok = rrp_point(pair, sg)
            P[sx] = z
            if not ok:  # beyond the float range
                raise _Refused(k, 0.0)
            r.taken(sg, margin)

        return rrp

    def _rpr(self, k: int, st: Any, a: RPRDyad, set_pts: set[str], placed: set[str]) -> Step:
        mech, bi = self.plan.mech, st.body
        pj = mech.prismatics[a.joint]
        sx, sp = self.pslot[st.point], self.pslot[a.pivot]
        guide = self.lslot[pj.guide]
        single = self.single[bi]
        lp_of = self._local(bi, a.pivot)
        xref, d, key = self.ref[st.point], self.direction[a.joint], '@' + pj.guide
        place = self._placer(bi, set_pts, placed)

        def rpr(r: SlotRun) -> None:
            P = r.P
            if single:
                gphi, grot, gT = 0.0, complex(1.0, 0.0), complex(0.0, 0.0)
            else:
                gphi, grot, gT = r.fphi[guide], r.frot[guide], r.fT[guide]
            lp = lp_of(r)
            u = grot * d
            w = (grot * xref + gT) - lp
            e = u.real * w.imag - u.imag * w.real  # signed offset of the pivot
            psi0 = atan2(u.imag, u.real)
            pair = solve_rpr(P[sp], P[sx], e, r.tol)
            margin = pair[3]
            if not pair[4]:
                raise _Refused(k, pair[5])
            sg = r.signs[len(r.used)]
            prefer = r.prefer
            if prefer is not None and key in prefer and r.near_singular(margin):
                last = prefer[key]
                miss_p = abs(_wrap(rpr_angle(pair, 1) - psi0 + gphi - last))
                sg = 1 if miss_p <= abs(_wrap(rpr_angle(pair, -1) - psi0 + gphi - last)) else -1
            phi = rpr_angle(pair, sg) - psi0
            r.ang[bi] = phi
            rot = complex(cos(phi), sin(phi))
            place(r, phi, rot, P[sp] - rot * lp)
            r.taken(sg, margin)

        return rpr

    # -- a run ---------------------------------------------------------------------------------
    def execute(
        self,
        values: Sequence[Any],
        signs: Sequence[int] | None = None,
        prefer: Mapping[str, Any] | None = None,
        prev_margins: Sequence[float] | None = None,
        tol: float = TANGENCY_TOL,
    ) -> SlotRun:
        """Execute the plan on one command (``values[i]`` a float, or an (x, y) pair for a
        point) with branch ``signs`` (default: the reference pose's); ``prefer`` maps point
        names to predicted complex positions and '@link' to predicted link angles (continuity,
        see the module), ``prev_margins`` are the previous answer's dyad margins. The run's
        slots as they are: ``failure`` is the index of the step that did not close (-1: none)."""
        r = SlotRun()
        r.values = [v if is_point else float(v) for is_point, v in zip(self.point_specs, values)]
        r.signs = self.plan.reference_signs if signs is None else signs
        r.prefer, r.prev_margins, r.tol = prefer, prev_margins, tol
        r.P = [None] * self.n_points
        n = self.n_links
        r.phi, r.rot, r.T = [None] * n, [None] * n, [None] * n
        if self.frames:
            r.fphi, r.frot, r.fT = [None] * n, [None] * n, [None] * n
        r.ang = [None] * self.n_bodies
        r.used, r.margins, r.margin = [], [], 1.0
        r.failure, r.violation = -1, 0.0
        try:
            for frame in self.frames:
                frame(r)
            for step in self.steps:
                step(r)
        except _Refused as stop:
            r.failure, r.violation, r.margin = stop.step, stop.violation, 0.0
        return r

    def points_of(self, r: SlotRun) -> dict[str, complex]:
        """The points a run set, by name, in the order it set them."""
        if r.failure < 0:
            return dict(zip(self.point_names, r.P))
        return {p: v for p, v in zip(self.point_names, r.P) if v is not None}

    def poses_of(self, r: SlotRun) -> LinkPoses:
        """The link poses a run placed, by name, in the order it placed them."""
        names = self.link_names
        if r.failure < 0:
            return LinkPoses(
                dict(zip(names, r.phi)), dict(zip(names, r.rot)), dict(zip(names, r.T))
            )
        poses = LinkPoses()
        for l, phi, rot, T in zip(names, r.phi, r.rot, r.T):
            if phi is not None:
                poses.phi[l], poses.rot[l], poses.T[l] = phi, rot, T
        return poses

    def run(
        self,
        values: Sequence[Any],
        signs: Sequence[int] | None = None,
        prefer: Mapping[str, Any] | None = None,
        prev_margins: Sequence[float] | None = None,
        tol: float = TANGENCY_TOL,
    ) -> PlanRun:
        """:meth:`execute` as a :class:`~linkage_ros.core.execute.PlanRun` (name-keyed)."""
        r = self.execute(values, signs, prefer, prev_margins, tol)
        return PlanRun(
            r.failure < 0,
            self.poses_of(r),
            self.points_of(r),
            r.margin,
            tuple(r.used),
            r.failure,
            r.violation,
            tuple(r.margins),
        )


def _cfinite_point(z: complex) -> bool:
    return z.real - z.real == 0.0 and z.imag - z.imag == 0.0


def program(plan: Any) -> ScalarProgram:
    """The plan's one-command program, made on first use and kept on the plan."""
    prog: ScalarProgram | None = plan.__dict__.get('_scalar_program')
    if prog is None:
        prog = plan._scalar_program = ScalarProgram(plan)
    return prog
