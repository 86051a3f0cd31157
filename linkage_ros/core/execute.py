"""Execution of a compiled plan over a batch of commands.

:class:`PlanExecutor` runs a :class:`~linkage_ros.core.plan.Plan`'s steps on the ``BATCH``
backend of :mod:`linkage_ros.core.ops` (points complex), with fixed branch signs. Every lookup
of the plan (which link carries a point, reference positions, slide directions) is resolved once
per plan, so a solve does only its arithmetic. One command runs on the plan's one-command
program (:mod:`linkage_ros.core.scalar_plan`, a measured twin tested equal to this executor
row for row), which holds the continuity rule through tangent configurations.

A batch's cost is mostly whole-batch passes and the fresh memory they write (a 20,000-row
float array is 160 kB: page faults as well as its pass). So values the same in every row are
taken once, 0-d (a body frame's root, the ground body at rest), the arithmetic on arrays a step
owns is done in place, and the RRR dyad with its point is one fused kernel
(:func:`~linkage_ros.core.dyads_batch.rrr_point_batch`): the same float operations in the same
order, every answer bit for bit what the plain operators give. A step's arrays, and a placed
body's frame, are let go before the next step makes its own (the page faults of a batch in a
fresh process follow its peak of memory, not its total).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import dyads
from .batch_inplace import (
    REST_ROT,
    REST_T,
    ZERO_0D,
    affine,
    all_positive,
    expi_rows,
    full,
    full_c,
    minus_rotated,
    owned_rows,
    plus_rest,
    rest_angle,
    rows_of,
    slide_offset,
    times,
)
from .dyads import dyad_point, rpr_direction, solve_rpr_dyad, solve_rrp_dyad
from .dyads_batch import rrr_point_batch
from .errors import PlanError
from .ops import BATCH, SCALAR, to_complex
from .plan_lookup import plan_lookup
from .quantities import AngleSpec, PointSpec
from .steps import RollerSide, StepKind

#: Below this dyad margin (|sin| of its transmission angle) continuity decides the branch by the
#: predicted position; above it the previous sign is kept, because an assembly mode can only
#: change by passing through the dyad's singular (tangent) configuration.
CONTINUITY_MARGIN = 0.1

#: A dyad that continuity would move to its other branch between two commands does so only if
#: its margin comes within this of 0 somewhere between them (core.solver.crossing): at a change
#: point it reaches 0 (to rounding: ~1e-8). One whose margin stays above it keeps its sign: a
#: crank-rocker at s + l = p + q - eps dips to about sqrt(eps / l), so one nearer the Grashof
#: limit than ~1e-12 of its lengths is taken as on it, and any further as off it. (Newton places
#: a fold only to ~sqrt(tol): its own threshold is core.solver.asked_mode.fold_margin.)
CROSSING_MARGIN = 1e-6

_GROUND, _KNOWN_POINT, _TWO_POINTS = StepKind.GROUND, StepKind.KNOWN_POINT, StepKind.TWO_POINTS
_POINT_ANGLE, _ANGLE = StepKind.POINT_ANGLE, StepKind.ANGLE
_RRR, _RRP, _RPR = StepKind.RRR, StepKind.RRP, StepKind.RPR
_SIDE = StepKind.SIDE

#: a body's frame: (phi, rot, T) of each member link with the body's root at the identity
_Frame = dict[str, tuple[Any, Any, Any]]


@dataclass
class LinkPoses:
    """Link poses of one configuration or a batch: world(p) = rot * p_ref + T (complex), with
    rot = e^{i phi}, phi the link's rotation from the reference pose (rad)."""

    phi: dict[str, Any] = field(default_factory=dict)
    rot: dict[str, Any] = field(default_factory=dict)
    T: dict[str, Any] = field(default_factory=dict)

    def set(self, link: str, phi: Any, T: Any, rot: Any = None) -> None:
        """Pose of one link; rot defaults to e^{i phi} of one configuration."""
        self.phi[link] = phi
        self.rot[link] = SCALAR.expi(phi) if rot is None else rot
        self.T[link] = T

    def world(self, link: str, p_ref: Any) -> Any:
        return self.rot[link] * p_ref + self.T[link]


@dataclass
class PlanRun:
    """What executing a plan gave. One command: ``ok`` a bool, ``failure`` the index of the
    step that did not close (-1) and the run stops there. A batch: ``ok``, ``failure``,
    ``violation`` and ``margin`` are (n,) arrays and every row runs to the end (finite
    placeholders where not ok). ``signs`` and ``margins`` hold one entry per branching step
    taken (the sign used, the dyad's margin). Of a batch, values the same in every row (the
    ground body's poses and points, ``failure`` and ``violation`` where every row closes) are
    read-only views of the one value: they cost no memory (copy one to write into it)."""

    ok: Any
    poses: LinkPoses
    points: dict[str, Any]
    margin: Any = 1.0
    signs: tuple[Any, ...] = ()
    failure: Any = -1
    violation: Any = 0.0
    margins: tuple[Any, ...] = ()


class PlanExecutor:
    """One plan, ready to run on either backend (made once per plan: see :func:`executor`)."""

    def __init__(self, plan: Any):
        self.plan = plan
        mech = plan.mech
        look = plan_lookup(plan)
        self.ref, self.direction, self.single, self.carrier = (
            look.ref,
            look.direction,
            look.single,
            look.carrier,
        )
        #: (body, point, point) -> the length the scene states between them, or their constant
        #: distance within a one-link body; None: measured in the body's frame on every run
        self._stated: dict[tuple[int, str, str], float | None] = {}
        #: per body: each member link's points with their reference positions (what placing
        #: the body places), resolved once
        self.body_points = [
            tuple(
                (link, tuple((p, self.ref[p]) for p in mech.links[link].points)) for link in b.links
            )
            for b in plan.bodies
        ]
        #: per body: True for one link alone (its frame is the identity: nothing to weld)
        #: per TWO_POINTS step of a one-link body: the unit vector between its two points in the
        #: link's frame (a constant)
        self.unit_between: dict[int, complex] = {}
        for k, st in enumerate(plan.steps):
            if st.op is _TWO_POINTS and self.single[st.body]:
                a = self.ref[st.args.second] - self.ref[st.args.first]
                na = SCALAR.cabs(a)
                self.unit_between[k] = a / na if na > 0 else a

    # -- bodies --------------------------------------------------------------------------------
    def _frame(self, ops: Any, bi: int, values: Sequence[Any], zero: Any) -> _Frame:
        """(phi, rot, T) of each member link of body bi with its root at the identity: welds by
        a known angle turn a member about the shared point, welds by a known slide move it
        along the slide."""
        plan, mech = self.plan, self.plan.mech
        body = plan.bodies[bi]
        frame = {body.root: (zero, ops.cplx(zero + 1.0, zero), ops.cplx(zero, zero))}
        for w in body.welds:
            s = plan.specs[w.spec_index]
            v = values[w.spec_index]
            vphi, vrot, vT = frame[w.via]
            if isinstance(s, AngleSpec):
                # phi[s.link] - phi[s.reference] (wrap's array is a new one: worked in place)
                rel = ops.wrap(v)
                rel -= s.offset
                negated = w.link != s.link
                if negated:
                    np.negative(rel, out=rel)
                # phi = vphi + rel; skipped where vphi is the root's +0.0 and rel = x - offset,
                # offset != 0: no entry of rel is -0.0 then (x - offset is +0.0 where the two
                # are equal, else not zero), so 0.0 + rel is rel to the bit (NaN too)
                if negated or vphi is not ZERO_0D or s.offset == 0.0:
                    np.add(vphi, rel, out=rel)
                phi = rel
                rot = expi_rows(phi)
                p = self.ref[w.shared_point]
                frame[w.link] = (phi, rot, minus_rotated(vrot * p + vT, rot, p))
            else:
                pj = mech.prismatics[s.joint]
                x_ref = self.ref[pj.point]
                u, dv = self.direction[pj.name], v - pj.ref_value
                # guide placed: the slider point on its line; slider placed: the guide hung
                # off it (in place where it can be, the same operations: slide_offset)
                slider = w.link == pj.slider
                T = slide_offset(vrot, vT, dv, u, x_ref, slider)
                if T is None:
                    along = x_ref + ops.cplx(dv * u.real, dv * u.imag)
                    if slider:
                        T = (vrot * along + vT) - vrot * x_ref
                    else:
                        T = (vrot * x_ref + vT) - vrot * along
                frame[w.link] = (vphi, vrot, T)
        return frame

    # -- the run -------------------------------------------------------------------------------
    def run(
        self,
        values: Sequence[Any],
        n: int,
        signs: Sequence[int] | None = None,
        tol: float = dyads.TANGENCY_TOL,
    ) -> PlanRun:
        """Execute the plan over a batch of n (``values[i]`` (n,) or (n, 2) arrays) with the
        branch ``signs``, one per branching step (default: the reference pose's); every row
        runs to the end (finite placeholders where it does not close)."""
        vals = [
            to_complex(np.asarray(v, float).reshape(n, 2))
            if isinstance(s, PointSpec)
            else np.asarray(v, float).reshape(n)
            for s, v in zip(self.plan.specs, values)
        ]
        with np.errstate(all='ignore'):
            return self._run(vals, np.zeros(n), signs, tol)

    def _radius(
        self, ops: Any, bi: int, x: str, p: str, local_pt: Any, between: dict[Any, Any]
    ) -> Any:
        """|x - p| within body bi: the length the scene states for a link that carries both
        points (exactly as given), else their constant distance in a one-link body, else the
        distance in the body's frame (``local_pt`` gives each point there); a distance
        measured is kept in ``between`` under (bi, p, x) with the vector x - p, for the
        TWO_POINTS step that places bi from p to x (the same vector: one hypot)."""
        key = (bi, x, p)
        d = self._stated.get(key, False)
        if d is False:
            mech, plan = self.plan.mech, self.plan
            d = next(
                (
                    mech.distance(link, x, p)
                    for link in plan.bodies[bi].links
                    if {x, p} <= set(mech.links[link].points)
                    and mech.distance(link, x, p) is not None
                ),
                None,
            )
            if d is None and self.single[bi]:  # one rigid link: a constant
                d = SCALAR.cabs(self.ref[x] - self.ref[p])
            self._stated[key] = d
        if d is not None:
            return d
        # (local_pt's rot * ref + T, each as CArray's operators compute it)
        v = local_pt(bi, x) - local_pt(bi, p)
        length = ops.cabs(v)
        between[(bi, p, x)] = (v, length)
        return length

    def _run(
        self, values: Sequence[Any], zero: np.ndarray, signs: Sequence[Any] | None, tol: float
    ) -> PlanRun:
        plan, mech, ref = self.plan, self.plan.mech, self.ref
        ops = BATCH
        signs = plan.reference_signs if signs is None else signs
        poses = LinkPoses()
        phi_of, rot_of, T_of = poses.phi, poses.rot, poses.T
        pts: dict[str, Any] = {}
        frames: dict[int, _Frame] = {}
        # a body's points in its frame, and (_radius) vectors between two with their length,
        # each made once: the same bits wherever they are read again
        locals_of: dict[tuple[int, str], Any] = {}
        between: dict[tuple[int, str, str], Any] = {}
        angles: dict[int, Any] = {}  # body root orientation when known before placing
        # a roller's line moved to the side chosen (guide's reference frame, m): SIDE steps
        side_shift: dict[str, Any] = {}
        used: list[Any] = []
        margins: list[Any] = []
        single, body_points = self.single, self.body_points
        ok_all: Any = zero == zero
        # 1 and -1 / 0 in every row until a dyad gives them rows of their own
        margin_all: Any = 1.0
        failure: Any = None
        violation_all: Any = None

        def closes(k: int, okk: Any, violation: Any) -> None:
            """Rows step k closes (okk); the others fail here unless they failed before."""
            nonlocal ok_all, failure, violation_all
            newly = ok_all & ops.not_(okk)
            if newly.any():
                failure = np.where(newly, k, -1.0 if failure is None else failure)
                before = 0.0 if violation_all is None else violation_all
                violation_all = np.where(newly, violation, before)
            ok_all = ok_all & okk

        def frame(bi: int) -> _Frame:
            f = frames.get(bi)
            if f is None:
                # the root's pose 0-d (the identity in every row: taken once for the batch)
                f = frames[bi] = self._frame(ops, bi, values, ZERO_0D)
            return f

        def local_pt(bi: int, p: str) -> Any:
            if single[bi]:  # a single link at the identity
                return ref[p]
            got = locals_of.get((bi, p))
            if got is None:  # (affine: rot * ref[p] + T as CArray's operators give it)
                _, rot, T = frame(bi)[self.carrier[(bi, p)]]
                got = locals_of[(bi, p)] = affine(rot, ref[p], T)
            return got

        def place_body(bi: int, phi: Any, Tb: Any, rot: Any, at_rest: bool = False) -> None:
            """Body bi at angle phi (rot = e^{i phi}, made once by the caller) and offset Tb;
            ``at_rest``: phi = 0 and rot = 1 exactly (the ground's body), so each member keeps
            its frame's rot (1 * r is r to the bit: no frame angle is -0.0) and T + Tb."""
            if single[bi] and not at_rest:  # a single link: its frame is the identity
                ((link, members),) = body_points[bi]
                phi_of[link], rot_of[link], T_of[link] = phi, rot, Tb
                for p, r in members:
                    if p not in pts:
                        pts[p] = affine(rot, r, Tb)
                return
            # at rest: the frame's values as they are (its root's are 0-d, taken once for the
            # whole batch, then written out)
            f = self._frame(ops, bi, values, ZERO_0D) if at_rest else frame(bi)
            n = zero.shape[0]
            # members of one frame angle and rotation (a slide weld keeps its via's: a
            # cylinder's rod turns with its barrel) share one world angle and rotation,
            # made once (the same operations on the same values; poses are never written)
            turned: dict[int, Any] = {}
            for link, members in body_points[bi]:
                lphi, lrot, lT = f[link]
                if at_rest:
                    lr, lt, lp = lrot, plus_rest(lT), rest_angle(n, lphi)
                else:
                    lr = turned.get(id(lrot))
                    if lr is None:
                        lr = turned[id(lrot)] = times(rot, lrot)
                    lp = turned.get(id(lphi))
                    if lp is None:
                        lp = turned[id(lphi)] = full(n, phi + lphi)
                    lt = affine(rot, lT, Tb)
                phi_of[link], rot_of[link], T_of[link] = lp, full_c(n, lr), full_c(n, lt)
                for p, r in members:
                    if p not in pts:
                        pts[p] = full_c(n, affine(lr, r, lt))
            # the body is placed: its frame let go (a later step that asks for it makes it
            # again, to the same bits); the executor's peak of memory is its frames and poses
            frames.pop(bi, None)
            if locals_of:
                for key in [key for key in locals_of if key[0] == bi]:
                    del locals_of[key]

        for k, st in enumerate(plan.steps):
            op = st.op
            # identity tests: enum members are singletons, and == on a StrEnum costs ~8x more
            if op is _TWO_POINTS:
                p, q = st.args.first, st.args.second
                bi = st.body
                b = pts[q] - pts[p]
                nb = ops.cabs(b)
                # unit first: 1e-300 lengths would underflow (the where pass skipped when no
                # length is 0: the common case); b is this step's own: divided in place
                nb = nb if all_positive(nb) else ops.where(nb > 0, nb, 1.0)
                np.divide(b.re, nb, out=b.re)
                np.divide(b.im, nb, out=b.im)
                a = self.unit_between.get(k)
                if a is None:
                    lp = local_pt(bi, p)
                    # the vector and length _radius measured for this body's dyad, if it did
                    # (local_pt(q) - lp exactly: the same points)
                    a, na = between.pop((bi, p, q), (None, None))
                    if a is None:
                        a = local_pt(bi, q) - lp
                        na = ops.cabs(a)
                    na = na if all_positive(na) else ops.where(na > 0, na, 1.0)
                    if rows_of(a):
                        # a is this step's own (a difference just made): divided in place,
                        # then the same products as below, into two arrays
                        np.divide(a.re, na, out=a.re)
                        np.divide(a.im, na, out=a.im)
                        cross = a.re * b.im
                        t = a.im * b.re
                        cross -= t
                        dot = np.multiply(a.re, b.re, out=t)
                        dot += np.multiply(a.im, b.im, out=a.im)
                        del t
                    else:
                        a = a / na
                        cross = a.real * b.imag - a.imag * b.real
                        dot = a.real * b.real + a.imag * b.imag
                else:  # a constant: the same products, written into two arrays
                    lp = ref[p]
                    cross = b.im * a.real
                    t = b.re * a.imag
                    cross -= t
                    dot = b.re * a.real
                    dot += np.multiply(b.im, a.imag, out=t)
                    del t
                del b, nb, a
                # (into cross, an (n,) array of this step's own: the same values)
                owned = owned_rows(cross, dot)
                phi = np.arctan2(cross, dot, out=cross) if owned else ops.atan2(cross, dot)
                del cross, dot  # (a step's arrays let go before the next step makes its own)
                # Measured and not kept (branch rotunit, both in the scalar twin alike, float
                # for float): rot as the unit vector (dot + i cross) / sqrt(dot^2 + cross^2),
                # 324 -> 240 ns per four-bar input with the scaling below, but |rot| 1 to about
                # 1 eps (cos, sin: 0.34) and the coupler point's mean error against the
                # 50-digit oracle 4-6% larger (15,000 inputs); b and a scaled by their larger
                # part instead of their hypot length, 333 -> 286 ns, the four-bar's errors as
                # before or lower but the excavator's bench median 6.4e-16 -> 6.9e-16; b not
                # divided at all where its larger part is in [2^-960, 2^960] (atan2 needs no
                # unit vector; the scalar twin alike), ~15 % of the batched four-bar's time,
                # the excavator's median 6.44e-16 -> 6.73e-16 and max 2.122e-15 -> 2.135e-15
                # (2026-11-28: rounding's luck, but not "as before or better").
                rot = expi_rows(phi)
                place_body(bi, phi, minus_rotated(pts[p], rot, lp), rot)
                del phi, rot
            elif op is _RRR or op is _RRP:
                x = st.point
                if op is _RRR:
                    a = st.args
                    b1, p1, b2, p2 = a.body_a, a.centre_a, a.body_b, a.centre_b
                    r1 = self._radius(ops, b1, x, p1, local_pt, between)
                    r2 = self._radius(ops, b2, x, p2, local_pt, between)
                    # dyads.solve_rrr_dyad and dyad_point in fewer passes
                    sg = signs[len(used)]
                    got = rrr_point_batch(pts[p1], r1, pts[p2], r2, tol, sg)
                    pts[x] = got.point
                    used.append(sg)
                    margins.append(got.margin)
                    # min(1, m) is m itself for the first dyad (m in [+0, 1], no NaN, no -0.0)
                    first = isinstance(margin_all, float)
                    margin_all = got.margin if first else ops.minimum(margin_all, got.margin)
                    if not got.all_ok:
                        closes(k, got.ok, got.violation)
                    del got
                    continue
                else:
                    b1, p1, jname = st.args.body, st.args.centre, st.args.joint
                    g = mech.prismatics[jname].guide
                    r = self._radius(ops, b1, x, p1, local_pt, between)
                    on_line = ref[x] if jname not in side_shift else ref[x] + side_shift[jname]
                    p0 = affine(rot_of[g], on_line, T_of[g])
                    u = times(rot_of[g], self.direction[jname])
                    pair = solve_rrp_dyad(ops, pts[p1], r, p0, u, tol)
                sg = signs[len(used)]
                pts[x], okk = dyad_point(ops, pair, sg)
                used.append(sg)
                margins.append(pair.margin)
                margin_all = ops.minimum(margin_all, pair.margin)
                closes(k, okk, pair.violation)
            elif op is _GROUND:
                # e^{i 0} = 1 exactly on both backends
                # (0-d: each value the same in every row, made once; see place_body)
                place_body(st.body, zero, REST_T, REST_ROT, True)
            elif op is _KNOWN_POINT:
                v = values[st.args.spec_index]
                pts[st.point] = v
            elif op is _POINT_ANGLE:
                p = st.args.point
                phi = angles[st.body]
                rot = expi_rows(phi)  # (ops.expi; P - rot * r below as the operators give it)
                place_body(st.body, phi, minus_rotated(pts[p], rot, local_pt(st.body, p)), rot)
            elif op is _ANGLE:
                here, there, spec_i = st.args.link, st.args.source, st.args.spec_index
                if there in phi_of:
                    src = phi_of[there]
                else:
                    sb = plan.body_of[there]
                    src = angles[sb] + frame(sb)[there][0]
                rel = zero
                if spec_i is not None:
                    s = plan.specs[spec_i]
                    rel = ops.wrap(values[spec_i]) - s.offset
                    if here == s.reference:
                        rel = -rel
                angles[st.body] = src + rel - frame(st.body)[here][0]
            elif op is _RPR:
                jname, p = st.args.joint, st.args.pivot
                pj = mech.prismatics[jname]
                x, bi = st.point, st.body
                _, grot, gT = frame(bi)[pj.guide]
                lp = local_pt(bi, p)
                u_loc = grot * self.direction[jname]
                on_line = ref[x] if jname not in side_shift else ref[x] + side_shift[jname]
                w = (grot * on_line + gT) - lp
                e = u_loc.real * w.imag - u_loc.imag * w.real  # signed offset of the pivot
                psi0 = ops.atan2(u_loc.imag, u_loc.real)
                dy = solve_rpr_dyad(ops, pts[p], pts[x], e, tol)
                sg = signs[len(used)]
                phi = rpr_direction(ops, dy, sg) - psi0
                angles[bi] = phi
                rot = expi_rows(phi)
                place_body(bi, phi, minus_rotated(pts[p], rot, lp), rot)
                used.append(sg)
                margins.append(dy.margin)
                margin_all = ops.minimum(margin_all, dy.margin)
                closes(k, dy.ok, dy.violation)
            elif op is _SIDE:
                sg = signs[len(used)]
                side_shift[st.args.joint] = self._side_shift(st.args, sg)
                used.append(sg)
                margins.append(zero + 1.0)  # never near a toggle: the face lies between sides
            else:
                raise PlanError(f'internal: unknown plan step {op!r}')
        n = zero.shape[0]
        if failure is None:  # every row closed: read-only views of the one value
            failure, violation_all = full(n, -1.0), full(n, 0.0)
        if np.ndim(margin_all) == 0:  # no dyad: an array of the caller's own
            margin_all = np.full(n, margin_all)
        return PlanRun(
            ok_all, poses, pts, margin_all, tuple(used), failure, violation_all, tuple(margins)
        )

    def _side_shift(self, side: RollerSide, sign: Any) -> Any:
        """How far a roller's line moves (complex, m, in its guide's reference frame) for its
        centre to be on side ``sign`` of the face: 0 on the drawn side, else its mirror image
        in the face (twice the drawn offset, across). Either backend (``sign`` +-1 or (n,))."""
        d = side.drawn_offset
        return (sign * abs(d) - d) * (1j * self.direction[side.joint])


def executor(plan: Any) -> PlanExecutor:
    """The plan's executor, made on first use and kept on the plan."""
    ex: PlanExecutor | None = plan.derived.get(PlanExecutor)
    if ex is None:
        ex = plan.derived[PlanExecutor] = PlanExecutor(plan)
    return ex
