"""A closed-form plan compiled for one command: slot-indexed steps over plain floats.

:class:`ScalarProgram` is the one-command twin of :class:`~linkage_ros.core.execute.PlanExecutor`
(which runs a batch): everything a step looks up by name there is resolved here once per plan
into indices of one list of registers (points, link poses, welded bodies' frames, body
orientations) and constants, and each step becomes a closure over them. A run copies the
register template and builds the name-keyed dicts of a PlanRun only when asked. The dyad steps
are :mod:`linkage_ros.core.scalar_dyad_steps` (over :mod:`linkage_ros.core.scalar_dyads`).

The arithmetic mirrors the batch executor's, operation for operation (see scalar_dyads); the
answers agree bit for bit where numpy's trigonometry rounds as libm's does, and within a few
ulps where it does not: on an AVX-512 host numpy's arctan2 is a SIMD kernel that differs from
libm's atan2 in about 8 % of random arguments (its sin, cos and hypot agree there), and an
outside review found last bits apart on some excavator and Scott-Russell commands (a point's
only, where the angle that differed is not an output). With libm's atan2 in numpy's place
every row of those sweeps is equal bit for bit (traced 2026-11-28); test_closed_form compares
float for float where the two agree. Continuity is the
one-command rule of the executor: where a dyad is near its singularity (its margin now or in the
previous answer below CONTINUITY_MARGIN) the branch nearest the prediction is taken, and
coincident circles (a change point) keep the point where continuity predicts it. A dyad's radius
measured on every run (a cylinder's) keeps its vector for the body's placement, which measures
the same floats.

Why a twin: the generic executor on the one-command backend looks every name up per step and
calls an ops function per where / max (measured, load ~10: the generic executor 32 us a run of
the four-bar's plan, this program 8.6 us, a ``math`` four-bar 1.6 us). Constants are resolved
when the program is made: RRR radii, each known angle wrapped once per run, a welded body's
points carried by its root (or by a member slid off it) computed once by the very float
operations a run would make, the welded ground's step its placer at the identity pose.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from math import atan2, cos, sin
from typing import Any

from .dyads import TANGENCY_TOL
from .errors import PlanError
from .execute import CONTINUITY_MARGIN, LinkPoses, PlanRun
from .ops import cabs_one, wrap_one
from .plan_lookup import plan_lookup
from .quantities import AngleSpec, PointSpec
from .scalar_dyad_steps import rpr_step, rrp_step, rrr_step, side_step
from .scalar_run import Refused, SlotRun, Step, slide_weld, turn_weld, welded_placer
from .steps import (
    AngleFrom,
    KnownPoint,
    PointAngle,
    RollerSide,
    RPRDyad,
    RRPDyad,
    RRRDyad,
    StepKind,
    TwoPoints,
)

_CM = CONTINUITY_MARGIN
_PI = math.pi
_NEG_PI = -math.pi  # (one load where -_PI is two)
_PLACES_BODY = (StepKind.GROUND, StepKind.TWO_POINTS, StepKind.POINT_ANGLE, StepKind.RPR)


class ScalarProgram:
    """One plan, compiled for one command at a time (made once per plan: see :func:`program`).

    Registers: ``ip[point]`` its position; ``iphi``, ``irot``, ``iT`` [link] its pose (angle
    from the reference pose, rad; e^{i phi}; translation); ``ifphi``, ``ifrot``, ``ifT`` [link]
    the same in its welded body's frame; ``iang[body]`` the body's orientation where known
    before it is placed. Points and links are numbered in the order a run sets them."""

    def __init__(self, plan: Any):
        self.plan = plan
        mech = plan.mech
        look = plan_lookup(plan)
        self.ref, self.direction = look.ref, look.direction
        self.single, self.carrier = look.single, look.carrier
        points_set: dict[str, None] = {}  # (ordered: dict keys, linear in a big scene)
        link_order: list[str] = []
        for st in plan.steps:
            if st.op in _PLACES_BODY:
                for link in plan.bodies[st.body].links:
                    link_order.append(link)
                    points_set.update(dict.fromkeys(mech.links[link].points))
            elif st.point is not None:
                points_set[st.point] = None
        point_order = list(points_set)
        self.point_names = tuple(point_order)
        self.link_names = tuple(link_order)
        # registers: the points a run sets and its links' angles first (what a Result's
        # finiteness test sums), the others, every link's rot, T and frame, bodies' angles
        rest_points = [p for p in mech.points if p not in points_set]
        links_set = set(link_order)
        rest_links = [l for l in mech.links if l not in links_set]
        links = [*link_order, *rest_links]
        nl = len(links)
        self.n_set = len(point_order) + len(link_order)
        self.ip = {p: i for i, p in enumerate(point_order)}
        self.iphi = {l: len(point_order) + i for i, l in enumerate(link_order)}
        self.ip.update({p: self.n_set + i for i, p in enumerate(rest_points)})
        n = self.n_set + len(rest_points)
        self.iphi.update({l: n + i for i, l in enumerate(rest_links)})
        n += len(rest_links)
        self.irot = {l: n + i for i, l in enumerate(links)}
        self.iT = {l: n + nl + i for i, l in enumerate(links)}
        self.ifphi = {l: n + 2 * nl + i for i, l in enumerate(links)}
        self.ifrot = {l: n + 3 * nl + i for i, l in enumerate(links)}
        self.ifT = {l: n + 4 * nl + i for i, l in enumerate(links)}
        self.iang = [n + 5 * nl + b for b in range(len(plan.bodies))]
        self.template: list[Any] = [None] * (n + 5 * nl + len(plan.bodies))
        #: point -> the link whose placement set it (rot * p_ref + T of that link exactly)
        self.set_by: dict[str, str] = {}
        self._members: dict[int, list[Any]] = {}  # per body placed: what _placer places
        self.n_placed = len(link_order)
        self.point_specs = tuple(isinstance(s, PointSpec) for s in plan.specs)
        self.any_point = any(self.point_specs)
        used_bodies: set[int] = set()
        for st in plan.steps:
            a = st.args
            for b in (st.body, *(getattr(a, f, None) for f in ('body_a', 'body_b', 'body'))):
                if b is not None:
                    used_bodies.add(b)
            if isinstance(a, AngleFrom):
                used_bodies.add(plan.body_of[a.source])
        #: each known angle's value wrapped to (-pi, pi] once per run (spec index -> register)
        self.iwrap: dict[int, int] = {}
        for i, s in enumerate(plan.specs):
            if isinstance(s, AngleSpec):
                self.iwrap[i] = len(self.template)
                self.template.append(0.0)
        self._wrap_regs = tuple(self.iwrap.items())
        #: pairs of links whose angle and rotation registers a run sets to the very same floats
        #: (a weld by a slide, a welded body's placement): a readout need not compare them
        self.same_turn: set[frozenset[str]] = set()
        #: a welded member -> its frame rotation where it is a constant (_frame_of)
        self.fixed_rot: dict[str, complex] = {}
        #: the steps of a run: the frames of the welded bodies it uses, then the plan's
        self.steps: list[Step] = []
        for b in sorted(used_bodies):
            if not self.single[b]:
                self.steps.extend(self._frame_of(b))
        set_pts: set[str] = set()
        placed: set[str] = set()
        #: a roller's line shift for the side its SIDE step chose (complex, m, in its guide's
        #: frame; 0, the drawn side, in the template)
        self.ishift: dict[str, int] = {}
        for st in plan.steps:
            if isinstance(st.args, RollerSide):
                self.ishift[st.args.joint] = len(self.template)
                self.template.append(complex(0.0, 0.0))
        #: an RRR dyad's point -> its scale S's register; (its args, radii (m)) where constant
        self.iscale: dict[str, int] = {}
        self.rrr_fixed: dict[str, tuple[RRRDyad, float, float]] = {}
        #: (body, x, p) -> the registers of x - p in the body's frame and its length (_radius)
        self.measured: dict[tuple[int, str, str], int] = {}
        #: the branching steps so far (a dyad step's index into the run's signs, fixed here)
        self._branches = 0
        for k, st in enumerate(plan.steps):
            step = self._compile(k, st, set_pts, placed)
            if step is not None:
                self.steps.append(step)

    # -- compile time --------------------------------------------------------------------------
    def _frame_of(self, bi: int) -> list[Step]:
        """Fill the frame registers of a welded body's members (its root at the identity, the
        template's constants): a weld by a known angle turns a member about the shared point,
        by a known slide moves it along the slide."""
        plan, mech = self.plan, self.plan.mech
        body = plan.bodies[bi]
        R = self.template
        R[self.ifphi[body.root]] = 0.0
        R[self.ifrot[body.root]] = complex(1.0, 0.0)
        R[self.ifT[body.root]] = complex(0.0, 0.0)
        self.fixed_rot[body.root] = R[self.ifrot[body.root]]
        steps: list[Step] = []
        for w in body.welds:
            if not isinstance(plan.specs[w.spec_index], AngleSpec):  # slide_weld: not turned
                self.same_turn.add(frozenset((w.via, w.link)))
                if w.via in self.fixed_rot:  # (slide_weld copies its via's rotation)
                    self.fixed_rot[w.link] = self.fixed_rot[w.via]
            s = plan.specs[w.spec_index]
            via = (self.ifphi[w.via], self.ifrot[w.via], self.ifT[w.via])
            # a weld to the root: the via's frame is the template's constants (the identity)
            fixed = (R[via[1]], R[via[2]]) if w.via == body.root else None
            out = (self.ifphi[w.link], self.ifrot[w.link], self.ifT[w.link])
            if isinstance(s, AngleSpec):
                assert w.shared_point is not None  # an angle weld turns about a shared point
                turn = self.iwrap[w.spec_index], s.offset, w.link == s.link
                steps.append(turn_weld(*turn, self.ref[w.shared_point], via, out, fixed))
            else:
                pj = mech.prismatics[s.joint]
                line = self.ref[pj.point], self.direction[pj.name]
                slide = w.spec_index, pj.ref_value, w.link == pj.slider
                steps.append(slide_weld(*slide, *line, via, out, fixed))
        return steps

    def _placer(self, bi: int, set_pts: set[str], placed: set[str]) -> Callable[..., None]:
        """place(r, phi, rot, T): the body's members posed and the points it sets first."""
        mech = self.plan.mech
        members = []
        for link in self.plan.bodies[bi].links:
            new = tuple(
                (self.ip[p], self.ref[p]) for p in mech.links[link].points if p not in set_pts
            )
            set_pts.update(mech.links[link].points)
            placed.add(link)
            new_at = {i for i, _ in new}
            for p in mech.links[link].points:
                if self.ip[p] in new_at:
                    self.set_by[p] = link
            members.append((self.iphi[link], self.irot[link], self.iT[link], new,
                            self.ifphi[link], self.ifrot[link], self.ifT[link]))  # fmt: skip
        self._members[bi] = members
        if self.single[bi]:
            ((iphi, irot, iT, pts, _, _, _),) = members

            def place_single(r: SlotRun, phi: float, rot: complex, Tb: complex) -> None:
                R = r.R
                R[iphi], R[irot], R[iT] = phi, rot, Tb
                for s, ref in pts:
                    R[s] = rot * ref + Tb

            return place_single

        return welded_placer(members)

    def _local(self, bi: int, p: str) -> Callable[[list[Any]], complex]:
        """A point of body bi in the body's frame."""
        ref = self.ref[p]
        if self.single[bi]:
            return lambda R: ref
        at_root = self._at_root(bi, p)
        if at_root is not None:
            return lambda R: at_root
        carrier = self.carrier[(bi, p)]
        frot, fT = self.ifrot[carrier], self.ifT[carrier]
        return lambda R: R[frot] * ref + R[fT]

    def _at_root(self, bi: int, p: str) -> complex | None:
        """A point of welded body bi in the body's frame where its root carries it (its frame's
        constants, _frame_of, computed once by a run's very float operations), else None."""
        root = self.plan.bodies[bi].root
        if self.single[bi] or self.carrier[(bi, p)] != root:
            return None
        at: complex = self.template[self.ifrot[root]] * self.ref[p] + self.template[self.ifT[root]]
        return at

    def _turned(self, bi: int, p: str) -> complex | None:
        """rot * p_ref of a point of welded body bi whose carrier's frame rotation is a
        constant (fixed_rot), computed once by a run's very float operation; else None."""
        if self.single[bi]:
            return None
        rot = self.fixed_rot.get(self.carrier[(bi, p)])
        return None if rot is None else rot * self.ref[p]

    def _radius(self, bi: int, x: str, p: str) -> tuple[float, Callable[[list[Any]], float] | None]:
        """|x - p| within body bi: the length the scene states for a link that carries both
        points, else their constant distance in a one-link body (a float), else measured in
        the body's frame on every run (a function of the registers), as the executor does."""
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
            d = cabs_one(self.ref[x] - self.ref[p])
        if d is not None:
            return float(d), None
        cx, cp = self.carrier[(bi, x)], self.carrier[(bi, p)]
        rx, tx, rp, tp = self.ifrot[cx], self.ifT[cx], self.ifrot[cp], self.ifT[cp]
        x_ref, p_ref = self.ref[x], self.ref[p]
        p_at = self._at_root(bi, p)  # (a cylinder's: its barrel's end at the root)
        x_turned = self._turned(bi, x)  # (and its rod's end, slid off the root)

        # (the vector and its length kept for the body's TWO_POINTS placement from p to x,
        # which measures the very same floats: _two_points)
        iu = self.measured[(bi, x, p)] = len(self.template)
        self.template += [None, None]
        inorm = iu + 1

        def radius(R: list[Any]) -> float:
            xr = x_turned if x_turned is not None else R[rx] * x_ref
            pa = p_at if p_at is not None else R[rp] * p_ref + R[tp]
            R[iu] = u = (xr + R[tx]) - pa
            try:  # (ops' cabs, inlined: a call per run saved)
                n: float = abs(u)
            except OverflowError:
                n = math.inf
            R[inorm] = n
            return n

        return 0.0, radius

    def _compile(self, k: int, st: Any, set_pts: set[str], placed: set[str]) -> Step | None:
        a = st.args
        op = st.op
        if op is StepKind.GROUND:
            place = self._placer(st.body, set_pts, placed)
            rot0, T0 = complex(cos(0.0), sin(0.0)), complex(0.0, 0.0)
            at_compile = SlotRun()
            at_compile.R = self.template
            if self.single[st.body]:  # a constant: placed once, in the template
                place(at_compile, 0.0, rot0, T0)
                return None
            # the root's frame is the identity: its pose and points are constants too
            root, *rest = self._members[st.body]
            welded_placer([root])(at_compile, 0.0, rot0, T0)
            # the step is the placer at the identity pose (no frame of its own)
            return welded_placer(rest, (0.0, rot0, T0))
        if op is StepKind.KNOWN_POINT and isinstance(a, KnownPoint):
            s, i = self.ip[st.point], a.spec_index
            set_pts.add(st.point)

            def known_point(r: SlotRun) -> None:
                v = r.values[i]
                r.R[s] = complex(float(v[0]), float(v[1]))

            return known_point
        if op is StepKind.TWO_POINTS and isinstance(a, TwoPoints):
            return self._two_points(st.body, a, set_pts, placed)
        if op is StepKind.POINT_ANGLE and isinstance(a, PointAngle):
            sp, lp_of, ang = self.ip[a.point], self._local(st.body, a.point), self.iang[st.body]
            place = self._placer(st.body, set_pts, placed)

            def point_angle(r: SlotRun) -> None:
                R = r.R
                phi = R[ang]
                rot = complex(cos(phi), sin(phi))
                place(r, phi, rot, R[sp] - rot * lp_of(R))

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
        if op is StepKind.SIDE and isinstance(a, RollerSide):
            return self._side(a)
        raise PlanError(f'internal: unknown plan step {op!r}')

    def _two_points(self, bi: int, a: TwoPoints, set_pts: set[str], placed: set[str]) -> Step:
        sp, sq = self.ip[a.first], self.ip[a.second]
        place = self._placer(bi, set_pts, placed)
        if self.single[bi]:  # the unit vector between the points in the link's frame: constant
            ((iphi, irot, iT, pts, _, _, _),) = self._members[bi]
            v = self.ref[a.second] - self.ref[a.first]
            nv = cabs_one(v)
            unit, lp = (v / nv if nv > 0 else v), self.ref[a.first]
            ux, uy = unit.real, unit.imag

            def two_points_single(r: SlotRun) -> None:
                R = r.R
                p = R[sp]
                b = R[sq] - p
                try:
                    nb = abs(b)
                except OverflowError:  # beyond the float range (as ops' cabs)
                    nb = math.inf
                b = b / (nb if nb > 0 else 1.0)  # unit first: 1e-300 lengths would underflow
                bx, by = b.real, b.imag  # (each read once: a complex's attribute is slow)
                phi = atan2(ux * by - uy * bx, ux * bx + uy * by)
                rot = complex(cos(phi), sin(phi))
                T = p - rot * lp
                R[iphi], R[irot], R[iT] = phi, rot, T
                for s, ref in pts:
                    R[s] = rot * ref + T

            return two_points_single
        # the points in the body's frame: their carriers' frame registers (_local, inlined)
        cp, cq = self.carrier[(bi, a.first)], self.carrier[(bi, a.second)]
        prot, pT, p_ref = self.ifrot[cp], self.ifT[cp], self.ref[a.first]
        qrot, qT, q_ref = self.ifrot[cq], self.ifT[cq], self.ref[a.second]
        p_at = self._at_root(bi, a.first)
        q_turned = self._turned(bi, a.second)
        # where a dyad's radius measured this body's second point from its first in this run
        # (the same expression on the same registers), its vector and length (-1: none)
        iu = self.measured.get((bi, a.second, a.first), -1)

        def two_points(r: SlotRun) -> None:
            R = r.R
            b = R[sq] - R[sp]
            try:  # (ops' cabs, inlined)
                nb = abs(b)
            except OverflowError:
                nb = math.inf
            b = b / (nb if nb > 0 else 1.0)
            lp = p_at if p_at is not None else R[prot] * p_ref + R[pT]
            if iu >= 0:
                u, nu = R[iu], R[iu + 1]
            else:
                u = ((q_turned if q_turned is not None else R[qrot] * q_ref) + R[qT]) - lp
                nu = cabs_one(u)
            u = u / (nu if nu > 0 else 1.0)
            ux, uy = u.real, u.imag  # (each read once: a complex's attribute is slow)
            bx, by = b.real, b.imag
            phi = atan2(ux * by - uy * bx, ux * bx + uy * by)
            rot = complex(cos(phi), sin(phi))
            place(r, phi, rot, R[sp] - rot * lp)

        return two_points

    def _angle(self, bi: int, a: AngleFrom, placed: set[str]) -> Step:
        plan = self.plan
        ang = self.iang[bi]
        # the step's link's angle in its body (None: 0, a one-link body's root)
        here = None if self.single[bi] else self.ifphi[a.link]
        if a.source in placed:  # its pose is known: its angle
            src, src_in_body, from_pose = self.iphi[a.source], None, True
        else:  # its body's orientation and its angle in the body (None: 0)
            sb = plan.body_of[a.source]
            src, from_pose = self.iang[sb], False
            src_in_body = None if self.single[sb] else self.ifphi[a.source]
        i = a.spec_index
        offset, negate, wreg = 0.0, False, -1
        if i is not None:
            s = plan.specs[i]
            offset, negate, wreg = s.offset, a.link == s.reference, self.iwrap[i]

        def angle(r: SlotRun) -> None:
            R = r.R
            source = R[src]
            if not from_pose:
                source = source + (0.0 if src_in_body is None else R[src_in_body])
            rel = 0.0
            if i is not None:
                rel = R[wreg] - offset
                if negate:
                    rel = -rel
            R[ang] = source + rel - (0.0 if here is None else R[here])

        return angle

    def _branch(self) -> int:
        """The index of the next branching step's sign (each takes one)."""
        self._branches += 1
        return self._branches - 1

    def _rrr(self, k: int, x: str, a: RRRDyad) -> Step:
        radius_a = self._radius(a.body_a, x, a.centre_a)
        radius_b = self._radius(a.body_b, x, a.centre_b)
        self.iscale[x] = len(self.template)  # (S where its kernel placed x, else NaN)
        self.template.append(math.nan)
        if radius_a[1] is None and radius_b[1] is None:
            self.rrr_fixed[x] = (a, radius_a[0], radius_b[0])
        return rrr_step(
            (k, self._branch()),
            x,
            (self.ip[x], self.ip[a.centre_a], self.ip[a.centre_b], self.iscale[x]),
            radius_a,
            radius_b,
            self.ref[x] - self.ref[a.centre_a],
        )

    def _side(self, a: RollerSide) -> Step:
        return side_step(
            self._branch(), self.ishift[a.joint], a.drawn_offset, 1j * self.direction[a.joint]
        )

    def _rrp(self, k: int, x: str, a: RRPDyad) -> Step:
        pj = self.plan.mech.prismatics[a.joint]
        return rrp_step(
            (k, self._branch()),
            x,
            (self.ip[x], self.ip[a.centre], self.irot[pj.guide], self.iT[pj.guide]),
            self._radius(a.body, x, a.centre),
            (self.ref[x], self.direction[a.joint]),
            self.ishift.get(a.joint),
        )

    def _rpr(self, k: int, st: Any, a: RPRDyad, set_pts: set[str], placed: set[str]) -> Step:
        bi = st.body
        pj = self.plan.mech.prismatics[a.joint]
        guide = (self.ifphi[pj.guide], self.ifrot[pj.guide], self.ifT[pj.guide])
        return rpr_step(
            (k, self._branch()),
            (self.ip[st.point], self.ip[a.pivot], self.iang[bi]),
            None if self.single[bi] else guide,
            self._local(bi, a.pivot),
            (self.ref[st.point], self.direction[a.joint], '@' + pj.guide),
            self.ishift.get(a.joint),
            self._placer(bi, set_pts, placed),
        )

    # -- a run ---------------------------------------------------------------------------------
    def execute(
        self,
        values: Sequence[Any],
        signs: Sequence[int] | None = None,
        prefer: Mapping[str, Any] | None = None,
        prev_margins: Sequence[float] | None = None,
        tol: float = TANGENCY_TOL,
        predict: Callable[[Any, list[Any]], Mapping[str, Any] | None] | None = None,
        predict_from: Any = None,
    ) -> SlotRun:
        """Execute the plan on one command (``values[i]`` a float, or an (x, y) pair) with
        branch ``signs`` (default: the reference pose's); ``prefer`` maps points to predicted
        positions and '@link' to predicted angles (continuity), or ``predict(predict_from,
        values)`` makes them when first needed; ``prev_margins``: the previous answer's dyad
        margins. Returns the run (``failure``: the step that did not close, -1: none)."""
        if self.any_point:
            vals = [v if pt else float(v) for pt, v in zip(self.point_specs, values)]
        else:  # no comprehension's frame for the common command
            vals = list(map(float, values))
        signs = self.plan.reference_signs if signs is None else signs
        return self.run_parsed(vals, signs, prev_margins, predict, predict_from, prefer, tol)

    def run_parsed(
        self,
        values: list[Any],
        signs: Sequence[int],
        prev_margins: Sequence[float] | None = None,
        predict: Callable[[Any, list[Any]], Mapping[str, Any] | None] | None = None,
        predict_from: Any = None,
        prefer: Mapping[str, Any] | None = None,
        tol: float = TANGENCY_TOL,
    ) -> SlotRun:
        """:meth:`execute` on a command as a solver has parsed it (a float per angle or slide,
        an (x, y) pair per point: ``CompiledSolve.parse``), which the run keeps as it is."""
        r = SlotRun()
        r.R = R = self.template.copy()
        for i, reg in self._wrap_regs:
            v = values[i]
            R[reg] = v if _NEG_PI < v <= _PI else wrap_one(v)
        # (one store a field: a tuple assignment of many builds and unpacks a tuple; prefer and
        # violation the class's values unless given or refused)
        r.values = values
        r.signs = signs
        if prefer is not None:
            r.prefer = prefer
        r.predict = predict
        r.predict_from = predict_from
        r.prev_margins = prev_margins
        r.tol = tol
        r.prev_small = min(prev_margins) < _CM if prev_margins else False
        r.used = ()
        r.margins = ()
        r.margin = 1.0
        r.failure = -1
        try:
            for step in self.steps:
                step(r)
        except Refused as stop:
            r.failure, r.violation, r.margin = stop.step, stop.violation, 0.0
        return r

    def points_of(self, r: SlotRun) -> dict[str, complex]:
        """The points a run set, by name, in the order it set them."""
        if r.failure < 0:
            return self.points_closed(r.R)
        return {p: v for p, v in zip(self.point_names, r.R) if v is not None}

    def points_closed(self, R: list[Any]) -> dict[str, complex]:
        """points_of a run that closed, from its registers."""
        return dict(zip(self.point_names, R))

    def poses_of(self, r: SlotRun) -> LinkPoses:
        """The link poses a run placed, by name, in the order it placed them."""
        if r.failure < 0:
            return self.poses_closed(r.R)
        R, names = r.R, self.link_names
        poses = LinkPoses()
        for l in names:
            if R[self.iphi[l]] is not None:
                poses.phi[l] = R[self.iphi[l]]
                poses.rot[l], poses.T[l] = R[self.irot[l]], R[self.iT[l]]
        return poses

    def poses_closed(self, R: list[Any]) -> LinkPoses:
        """poses_of a run that closed, from its registers."""
        names, n = self.link_names, self.n_placed
        if not n:
            return LinkPoses()
        phi, rot, T = self.iphi[names[0]], self.irot[names[0]], self.iT[names[0]]
        return LinkPoses(
            dict(zip(names, R[phi : phi + n])),
            dict(zip(names, R[rot : rot + n])),
            dict(zip(names, R[T : T + n])),
        )

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
        poses, points, ok = self.poses_of(r), self.points_of(r), r.failure < 0
        return PlanRun(ok, poses, points, r.margin, r.used, r.failure, r.violation, r.margins)


def program(plan: Any) -> ScalarProgram:
    """The plan's one-command program, made on first use and kept on the plan."""
    prog: ScalarProgram | None = plan.derived.get(ScalarProgram)
    if prog is None:
        prog = plan.derived[ScalarProgram] = ScalarProgram(plan)
    return prog
