"""Compiling (mechanism, knowns, wanted outputs) into a pruned closed-form plan of typed steps."""

from __future__ import annotations

import heapq
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import dyads
from ..disjoint import DisjointSets
from ..dyads import circle_side, line_side, side_sign
from ..errors import PlanError
from ..execute import PlanRun, executor
from ..model import Mechanism
from ..ops import SCALAR, to_xy
from ..quantities import AngleSpec, PointSpec, SlideSpec, Spec
from ..scalar_plan import program
from ..steps import (
    BRANCHING,
    AngleFrom,
    KnownPoint,
    PointAngle,
    RollerSide,
    RPRDyad,
    RRPDyad,
    RRRDyad,
    StepArgs,
    StepKind,
    TwoPoints,
    branch_text,
)
from .poses import Poses, batch_poses

# ---- bodies ----------------------------------------------------------------------------------


#: the steps that place a whole body (its pose, so every point it carries)
_PLACES_BODY = (StepKind.GROUND, StepKind.TWO_POINTS, StepKind.POINT_ANGLE, StepKind.RPR)

#: what a step needs or gives: ('pose', body index), ('angle', body index) or ('pt', point)
Need = tuple[str, int | str]


@dataclass
class Weld:
    """How member ``link`` is placed from ``via`` (already placed) in its body's weld tree."""

    link: str
    via: str
    spec_index: int
    shared_point: str | None = None


@dataclass
class Body:
    index: int
    root: str
    links: list[str]
    welds: list[Weld]
    points: list[str]


@dataclass
class Step:
    op: StepKind
    body: int | None = None
    point: str | None = None
    args: StepArgs | None = None  # what the step works on, by kind (core.steps)
    sign: int = 0  # branching steps: +1 / -1 from the reference pose
    needs: tuple[Need, ...] = ()
    gives: tuple[Need, ...] = ()

    @property
    def branching(self) -> bool:
        return self.op in BRANCHING

    def describe(self, plan: Plan) -> str:
        b = '+'.join(plan.bodies[self.body].links) if self.body is not None else ''
        a = self.args
        if self.op == StepKind.GROUND:
            return f'ground: place {b}'
        if self.op == StepKind.KNOWN_POINT:
            return f'known point {self.point}'
        if isinstance(a, TwoPoints):
            return f'rigid transfer: place {b} from points {a.first}, {a.second}'
        if isinstance(a, PointAngle):
            return f'place {b} from point {a.point} and its known angle'
        if isinstance(a, AngleFrom):
            return f'orientation of {b} from {a.source}'
        if isinstance(a, RRRDyad):
            return (
                f'RRR dyad: {self.point} from circles about {a.centre_a} '
                f'({"+".join(plan.bodies[a.body_a].links)}) and {a.centre_b} '
                f'({"+".join(plan.bodies[a.body_b].links)})'
            )
        if isinstance(a, RRPDyad):
            return f'RRP dyad: {self.point} on slide {a.joint} and circle about {a.centre}'
        if isinstance(a, RPRDyad):
            return f'RPR dyad: orient {b} about {a.pivot} so slide {a.joint} passes {self.point}'
        if isinstance(a, RollerSide):
            return (
                f'roller side: {self.point} on the left (+) or right (-) of the face of slot '
                f'{a.joint}'
            )
        return str(self.op)


class Plan:
    """A compiled closed-form plan for one set of known specs and wanted outputs."""

    def __init__(
        self,
        mech: Mechanism,
        specs: Sequence[Spec],
        wanted_links: Iterable[str] | None,
        wanted_points: Iterable[str] | None = None,
    ):
        self.mech = mech
        self.specs = list(specs)
        #: what other modules derive from this plan once (its batch executor, its one-command
        #: program, its lookups), keyed by the derived object's class: made on first use
        self.derived: dict[type, Any] = {}
        self._build_bodies()
        self._compile()
        self._prune(wanted_links, wanted_points)

    # -- bodies -------------------------------------------------------------------------------
    def _build_bodies(self) -> None:
        mech = self.mech
        sets = DisjointSets(mech.links)
        find = sets.find
        edges: list[tuple[str, str, int, str | None]] = []
        self.relations: list[tuple[str, str, int | None]] = []  # angle-only relations
        for i, s in enumerate(self.specs):
            if isinstance(s, AngleSpec):
                shared = set(mech.links[s.link].points) & set(mech.links[s.reference].points)
                if shared:
                    edges.append((s.reference, s.link, i, sorted(shared)[0]))
                else:
                    self.relations.append((s.reference, s.link, i))
            elif isinstance(s, SlideSpec):
                pj = mech.prismatics[s.joint]
                edges.append((pj.guide, pj.slider, i, None))
        for pj in mech.prismatics.values():
            if not any(
                isinstance(slide := self.specs[e[2]], SlideSpec) and slide.joint == pj.name
                for e in edges
            ):
                self.relations.append((pj.guide, pj.slider, None))  # orientation lock
        for a, b, i, _ in edges:
            if not sets.union(a, b):
                raise PlanError(
                    f'known {self.specs[i].name!r} over-constrains links {a!r} and '
                    f'{b!r}: they are already rigidly connected by other knowns'
                )
        groups: dict[str, list[str]] = {}
        for n in mech.links:
            groups.setdefault(find(n), []).append(n)
        group_edges: dict[str, list[tuple[str, str, int, str | None]]] = {}
        for e in edges:  # (each group's edges in one pass: linear in a scene of many bodies)
            group_edges.setdefault(find(e[0]), []).append(e)
        self.bodies: list[Body] = []
        self.body_of: dict[str, int] = {}
        for group, members in groups.items():
            root = mech.ground if mech.ground in members else members[0]
            placed, welds, todo = [root], [], list(group_edges.get(group, ()))
            while todo:
                progressed = False
                for e in list(todo):
                    a, b, i, sp = e
                    if a in placed and b not in placed:
                        welds.append(Weld(b, a, i, sp))
                        placed.append(b)
                    elif b in placed and a not in placed:
                        welds.append(Weld(a, b, i, sp))
                        placed.append(a)
                    else:
                        continue
                    todo.remove(e)
                    progressed = True
                if not progressed:
                    break
            pts = list(dict.fromkeys(p for n in placed for p in mech.links[n].points))
            body = Body(len(self.bodies), root, placed, welds, pts)
            self.bodies.append(body)
            for n in placed:
                self.body_of[n] = body.index

    # -- compile ------------------------------------------------------------------------------
    def _compile(self) -> None:
        mech = self.mech
        steps: list[Step] = []
        known_pts: set[str] = set()
        placed: set[int] = set()
        angled: set[int] = set()
        pt_bodies: dict[str, list[int]] = {}
        for b in self.bodies:
            for p in b.points:
                pt_bodies.setdefault(p, []).append(b.index)

        # The bodies to look at again: only a point becoming known or a body getting its angle
        # can let a body be placed, so a pass skips the others (it would find nothing for
        # them, as in the pass before): the same steps in the same order, in linear time.
        dirty: set[int] = {b.index for b in self.bodies}
        ahead: list[int] = []  # this pass's dirty bodies after `at` (a heap: index order)
        at = -1  # the body this pass is at
        angle_partners: dict[int, set[int]] = {}
        for link_a, link_b, _ in self.relations:
            ba, bb = self.body_of[link_a], self.body_of[link_b]
            angle_partners.setdefault(ba, set()).add(bb)
            angle_partners.setdefault(bb, set()).add(ba)

        def mark(bodies: Iterable[int]) -> None:
            for bi in bodies:
                if bi not in dirty:
                    dirty.add(bi)
                    if bi > at:  # (the pass reaches it; else the next pass does)
                        heapq.heappush(ahead, bi)

        def learn_points(points: Iterable[str]) -> None:
            for p in points:
                if p not in known_pts:
                    known_pts.add(p)
                    mark(pt_bodies.get(p, ()))

        def learn_angle(bi: int) -> None:
            angled.add(bi)
            mark(angle_partners.get(bi, ()))

        def place(step: Step, bi: int) -> None:
            steps.append(step)
            placed.add(bi)
            learn_angle(bi)
            learn_points(self.bodies[bi].points)

        gb = self.body_of[mech.ground]
        place(Step(StepKind.GROUND, body=gb, gives=(('pose', gb),)), gb)
        for i, s in enumerate(self.specs):
            if isinstance(s, PointSpec):
                if s.point in known_pts:
                    raise PlanError(
                        f'known point {s.point!r} is fixed by the ground; it cannot be a target'
                    )
                steps.append(
                    Step(
                        StepKind.KNOWN_POINT,
                        point=s.point,
                        args=KnownPoint(i),
                        gives=(('pt', s.point),),
                    )
                )
                known_pts.add(s.point)

        def known_of(bi: int) -> list[str]:
            return [p for p in self.bodies[bi].points if p in known_pts]

        def point_needs(p: str) -> Need:
            return ('pt', p)

        while len(placed) < len(self.bodies):
            progress = False
            # non-branching steps first, over the dirty bodies in index order
            ahead[:] = sorted(dirty)
            at = -1
            while ahead:
                bi = at = heapq.heappop(ahead)
                dirty.discard(bi)  # (marked again below where it changes)
                if bi in placed:
                    continue
                kp = known_of(bi)
                two = self._two_distinct(bi, kp)
                if two:
                    place(
                        Step(
                            StepKind.TWO_POINTS,
                            body=bi,
                            args=TwoPoints(*two),
                            needs=(point_needs(two[0]), point_needs(two[1])),
                            gives=(('pose', bi),),
                        ),
                        bi,
                    )
                    progress = True
                    continue
                if bi in angled and kp:
                    place(
                        Step(
                            StepKind.POINT_ANGLE,
                            body=bi,
                            args=PointAngle(kp[0]),
                            needs=(point_needs(kp[0]), ('angle', bi)),
                            gives=(('pose', bi),),
                        ),
                        bi,
                    )
                    progress = True
                    continue
                if bi not in angled:
                    rel = self._angle_source(bi, angled)
                    if rel is not None:
                        src_body, link_here, link_there, spec_i = rel
                        steps.append(
                            Step(
                                StepKind.ANGLE,
                                body=bi,
                                args=AngleFrom(link_here, link_there, spec_i),
                                needs=(('angle', src_body),),
                                gives=(('angle', bi),),
                            )
                        )
                        learn_angle(bi)
                        mark((bi,))  # (it may now be placed from a point and its angle)
                        progress = True
            if progress:
                continue
            step = self._branching_step(placed, known_pts, pt_bodies, known_of)
            if step is None:
                break
            side = self._roller_side(step)
            if side is not None:  # the roller's side first: its dyad runs on that side's line
                steps.append(side)
            steps.append(step)
            if step.op == StepKind.RPR:
                assert step.body is not None  # an RPR step names the body it orients
                placed.add(step.body)
                learn_angle(step.body)
                learn_points(self.bodies[step.body].points)
            else:
                assert step.point is not None  # an RRR / RRP step names the point it solves
                learn_points((step.point,))
        self.steps_all = steps

    def _roller_side(self, dyad: Step) -> Step | None:
        """The SIDE step of the roller a dyad step places (an RRP or RPR of a roller's slot
        drawn off its face), which the dyad then needs; None for any other step."""
        args = dyad.args
        if not isinstance(args, RRPDyad | RPRDyad) or args.joint not in self.mech.rollers:
            return None
        mech = self.mech
        pj = mech.prismatics[args.joint]
        u, x = _cx(pj.direction), _cx(mech.points[pj.point])
        face = _cx(pj.origin)
        offset = (u.conjugate() * (x - face)).imag  # left of the face's direction: +
        if offset == 0.0:  # drawn on its face (a stated offset of 0): no side to choose
            return None
        anchor = mech.links[pj.guide].points[0]
        dyad.needs = (*dyad.needs, ('side', args.joint))
        return Step(
            StepKind.SIDE,
            point=pj.point,
            args=RollerSide(args.joint, anchor, face - _cx(mech.points[anchor]), offset),
            sign=1 if offset > 0 else -1,
            gives=(('side', args.joint),),
        )

    def _two_distinct(self, bi: int, kp: Sequence[str]) -> tuple[str, str] | None:
        for i in range(len(kp)):
            for j in range(i + 1, len(kp)):
                if np.hypot(*(self.mech.points[kp[i]] - self.mech.points[kp[j]])) > 0:
                    return (kp[i], kp[j])
        return None

    def _angle_source(self, bi: int, angled: set[int]) -> tuple[int, str, str, int | None] | None:
        for a, b, i in self.relations:
            ba, bb = self.body_of[a], self.body_of[b]
            if bb == bi and ba in angled:
                return ba, b, a, i
            if ba == bi and bb in angled:
                return bb, a, b, i
        return None

    def _branching_step(
        self,
        placed: set[int],
        known_pts: set[str],
        pt_bodies: Mapping[str, list[int]],
        known_of: Callable[[int], list[str]],
    ) -> Step | None:
        mech = self.mech
        ref = mech.points
        # RRR: an unknown point shared by two unplaced bodies, each with one known point
        for x, owners in pt_bodies.items():
            if x in known_pts:
                continue
            cands = [bi for bi in owners if bi not in placed and known_of(bi)]
            for i in range(len(cands)):
                for j in range(i + 1, len(cands)):
                    b1, b2 = cands[i], cands[j]
                    p1, p2 = known_of(b1)[0], known_of(b2)[0]
                    if p1 == p2 or np.hypot(*(ref[p1] - ref[p2])) == 0:
                        continue  # concentric circles: no dyad
                    sign = side_sign(circle_side(SCALAR, _cx(ref[p1]), _cx(ref[p2]), _cx(ref[x])))
                    return Step(
                        StepKind.RRR,
                        point=x,
                        args=RRRDyad(b1, p1, b2, p2),
                        sign=sign,
                        needs=(('pt', p1), ('pt', p2)),
                        gives=(('pt', x),),
                    )
        # RRP: slider point on a placed guide's line, also on a body with one known point
        for pj in mech.prismatics.values():
            x = pj.point
            if x in known_pts:
                continue
            gb = self.body_of[pj.guide]
            sb = self.body_of[pj.slider]
            if gb not in placed or sb == gb:
                continue
            for bi in pt_bodies[x]:
                if bi in placed or bi == sb or not known_of(bi):
                    continue
                p1 = known_of(bi)[0]
                sign = side_sign(line_side(SCALAR, _cx(ref[p1]), _cx(ref[x]), _cx(pj.direction)))
                return Step(
                    StepKind.RRP,
                    point=x,
                    args=RRPDyad(bi, p1, pj.name),
                    sign=sign,
                    needs=(('pt', p1), ('pose', gb)),
                    gives=(('pt', x),),
                )
        # RPR: a known slider point, the guide pivoting about one known point
        for pj in mech.prismatics.values():
            x = pj.point
            gb = self.body_of[pj.guide]
            if x not in known_pts or gb in placed or self.body_of[pj.slider] == gb:
                continue
            kp = [p for p in known_of(gb) if p != x]
            if not kp:
                continue
            p = kp[0]
            sign = side_sign(line_side(SCALAR, _cx(ref[p]), _cx(ref[x]), _cx(pj.direction)))
            return Step(
                StepKind.RPR,
                body=gb,
                point=x,
                args=RPRDyad(pj.name, p),
                sign=sign,
                needs=(('pt', x), ('pt', p)),
                gives=(('pose', gb),),
            )
        return None

    # -- pruning ------------------------------------------------------------------------------
    def _prune(
        self, wanted_links: Iterable[str] | None, wanted_points: Iterable[str] | None
    ) -> None:
        mech = self.mech
        if wanted_links is None and wanted_points is None:
            wanted_links = list(mech.links)
        wanted_links = list(wanted_links or [])
        wanted_points = list(wanted_points or [])
        need: set[Need] = set()
        for link in wanted_links:
            need.add(('pose', self.body_of[link]))
        for p in wanted_points:
            need.add(('pt', p))
        # a point is given by a step that gives it or by placing any body that carries it
        keep = [False] * len(self.steps_all)
        for k in range(len(self.steps_all) - 1, -1, -1):
            st = self.steps_all[k]
            gives = set(st.gives)
            if st.op in _PLACES_BODY:  # ground, two points, point + angle, RPR
                assert st.body is not None  # a step that places a body names it
                gives |= {('pt', p) for p in self.bodies[st.body].points}
                gives.add(('angle', st.body))
            hit = gives & need
            if hit or st.op == StepKind.GROUND:
                keep[k] = True
                need -= hit
                need |= set(st.needs)
        # anything still needed was never produced: the plan cannot give it
        self.missing = sorted(need)
        self.steps = [s for s, k in zip(self.steps_all, keep) if k]
        self.complete = not self.missing
        placed = {s.body for s in self.steps if s.body is not None and s.op in _PLACES_BODY}
        self.placed_links = [l for b in sorted(placed) for l in self.bodies[b].links]
        self.branch_steps = [s for s in self.steps if s.branching]
        #: the branch sign of each branching step in the reference pose
        self.reference_signs: tuple[int, ...] = tuple(s.sign for s in self.branch_steps)

    def describe(self) -> list[str]:
        out = []
        for s in self.steps:
            text = s.describe(self)
            if s.branching:
                text += f' [branch {branch_text((s.sign,))} in the reference pose]'
            out.append(text)
        return out

    # -- execution ----------------------------------------------------------------------------
    def run(
        self,
        values: Sequence[np.ndarray],
        n: int,
        signs: Sequence[int] | None = None,
        tol: float = dyads.TANGENCY_TOL,
    ) -> tuple[Poses, dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Execute the plan over a batch of n with fixed branch signs (the batch view of
        :class:`~linkage_ros.core.execute.PlanExecutor`: points as (n, 2) arrays).

        ``values[i]`` is the value array of spec i ((n,) or (n, 2)). ``signs`` overrides the
        branch signs (one per branching step). Returns (poses, points, info) where info has
        ok (n,), margin (n,) (the least), margins (n, k) (each branching dyad's), signs (n, k),
        failure (step index or -1) and violation (n,).
        """

        r = executor(self).run(values, n, signs, tol=tol)
        k = len(self.branch_steps)
        used = np.zeros((n, k), int)
        for b, sg in enumerate(r.signs):
            used[:, b] = sg
        margins = np.zeros((n, k))
        for b, m in enumerate(r.margins[:k]):
            margins[:, b] = m
        info = {
            'ok': np.asarray(r.ok, bool),
            'margin': np.asarray(r.margin, float),
            'margins': margins,
            'signs': used,
            'failure': np.asarray(r.failure).astype(int),
            'violation': np.asarray(r.violation, float),
        }
        return batch_poses(r.poses), {p: to_xy(z) for p, z in r.points.items()}, info


def _norm(v: np.ndarray) -> np.ndarray:
    norm: np.ndarray = np.hypot(v[..., 0], v[..., 1])
    return norm


def _cx(v: Sequence[float] | npt.NDArray[np.float64]) -> complex:
    return complex(float(v[0]), float(v[1]))


# ---- one command at a time -------------------------------------------------------------------

#: one configuration's link poses (complex): see execute.LinkPoses
#: what running a plan gave: see execute.PlanRun


def run_one(
    plan: Plan,
    values: Sequence[Any],
    signs: Sequence[int] | None = None,
    prefer: Mapping[str, Any] | None = None,
    tol: float = dyads.TANGENCY_TOL,
    prev_margins: Sequence[float] | None = None,
) -> PlanRun:
    """:class:`~linkage_ros.core.scalar_plan.ScalarProgram` on one command: ``values[i]`` a
    float (angle/slide) or an (x, y) pair (point); ``prefer`` and ``prev_margins`` steer
    continuity through tangent configurations (see ScalarProgram.run)."""
    return program(plan).run(values, signs, prefer, prev_margins, tol)
