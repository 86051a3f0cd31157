"""Compile (mechanism, known quantities, wanted outputs) into a closed-form solve plan.

Known quantities are *specs*: an actuator or joint value, a link's angle, or a point's (x, y).
A known joint value between two links that share a point welds them into one rigid *body*
(a crank at a known angle is welded to the ground; a cylinder at a known throw is one rigid
strut). The plan then places bodies exactly as the graphical "tracing paper" method does:

* ``two_points``   a body with two known points is placed (rigid transfer),
* ``point_angle``  a body with a known point and a known orientation is placed,
* ``circle_circle`` (RRR) a point shared by two bodies that each have one known point,
* ``circle_line``   (RRP) a slider point on a known guide line and on a body with one known point,
* ``line_through``  (RPR) a guide body pivoting on a known point whose line must pass a known point.

Every branching step carries an explicit sign; the default is the sign seen in the reference pose.
The plan is pruned backwards to the steps the wanted outputs depend on, and is cached by the
caller per (mechanism, knowns, outputs). Execution is vectorised over a leading batch axis.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from . import dyads
from .errors import PlanError
from .execute import LinkPoses, PlanRun, executor
from .model import Mechanism
from .ops import BATCH, SCALAR, to_complex, to_xy

# ---- known-quantity specs --------------------------------------------------------------------


@dataclass(frozen=True)
class Spec:
    """One known (or wanted) quantity of a mechanism.

    kind 'angle': phi[link] - phi[reference] = value - offset        (rad; 1 value)
    kind 'slide': value of prismatic joint ``joint``                 (m;   1 value)
    kind 'point': world position of ``point``                        (m;   2 values x, y)
    """

    name: str
    kind: str
    link: str | None = None
    reference: str | None = None
    offset: float = 0.0
    joint: str | None = None
    point: str | None = None
    minimum: float | None = None
    maximum: float | None = None

    @property
    def size(self) -> int:
        return 2 if self.kind == 'point' else 1

    @property
    def unit(self) -> str:
        return 'rad' if self.kind == 'angle' else 'm'


KNOWN_KINDS = ('actuator', 'joint', 'link', 'point')


def spec_for(mech: Mechanism, name: str) -> Spec:
    """Resolve a user-facing name: actuator, then joint, then link (its angle), then point.

    A prefix picks the kind explicitly: ``point:D`` is the point D even where a joint is also
    named D (every point shared by two links is), likewise ``joint:``, ``link:``, ``actuator:``.
    The spec keeps the name exactly as given, so command dicts use the same key.
    """
    kind, _, bare = name.partition(':') if ':' in name else ('', '', name)
    if kind:
        if kind not in KNOWN_KINDS:
            raise PlanError(f'unknown kind {kind!r} in {name!r}; use one of {list(KNOWN_KINDS)}')
        found = _spec_of_kind(mech, kind, bare)
        if found is None:
            raise PlanError(f'{mech.name!r} has no {kind} named {bare!r}')
        return _renamed(found, name)
    for kind in KNOWN_KINDS:
        found = _spec_of_kind(mech, kind, name)
        if found is not None:
            return found
    raise PlanError(
        f'unknown name {name!r}: not an actuator, joint, link or point of {mech.name!r}'
    )


def _renamed(spec: Spec, name: str) -> Spec:
    return Spec(
        name,
        spec.kind,
        spec.link,
        spec.reference,
        spec.offset,
        spec.joint,
        spec.point,
        spec.minimum,
        spec.maximum,
    )


def _spec_of_kind(mech: Mechanism, kind: str, name: str) -> Spec | None:
    if kind == 'actuator' and name in mech.actuators:
        act = mech.actuators[name]
        if act.kind == 'slide':
            return Spec(name, 'slide', joint=act.joint, minimum=act.min, maximum=act.max)
        link = mech.links[act.link]
        v = mech.points[act.toward] - mech.points[act.pivot]
        d0 = math.atan2(v[1], v[0])
        ref_angle = 0.0 if act.reference == mech.ground else mech.links[act.reference].angle_ref
        return Spec(
            name,
            'angle',
            link=link.name,
            reference=act.reference,
            offset=d0 - ref_angle,
            minimum=act.min,
            maximum=act.max,
        )
    if kind == 'joint':
        for rj in mech.revolutes:
            if rj.name == name:
                # joint value = child link angle - parent link angle (each along its axis)
                return Spec(
                    name,
                    'angle',
                    link=rj.child,
                    reference=rj.parent,
                    offset=mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
                )
        if name in mech.prismatics:
            return Spec(name, 'slide', joint=name)
    if kind == 'link' and name in mech.links:
        if name == mech.ground:
            raise PlanError(f'{name!r} is the ground link: its angle is fixed')
        return Spec(
            name, 'angle', link=name, reference=mech.ground, offset=mech.links[name].angle_ref
        )
    if kind == 'point' and name in mech.points:
        return Spec(name, 'point', point=name)
    return None


def spec_point_link(mech: Mechanism, point: str, preferred: str) -> str:
    return preferred if point in mech.links[preferred].points else mech.links_of_point(point)[0]


# ---- poses -----------------------------------------------------------------------------------


@dataclass
class Poses:
    """Link poses over a batch: world(p) = R(phi) p_ref + T, with p_ref the reference position."""

    phi: dict[str, np.ndarray] = field(default_factory=dict)
    T: dict[str, np.ndarray] = field(default_factory=dict)

    def apply(self, link: str, p_ref: np.ndarray) -> np.ndarray:
        return (
            dyads.rotate(np.broadcast_to(p_ref, self.T[link].shape), self.phi[link]) + self.T[link]
        )

    def world(self, link: str, point: str, mech: Mechanism) -> np.ndarray:
        return self.apply(link, mech.points[point])


# ---- bodies ----------------------------------------------------------------------------------


@dataclass
class Weld:
    """How member ``link`` is placed from ``via`` (already placed) in its body's weld tree."""

    link: str
    via: str
    spec_index: int
    kind: str  # 'angle' or 'slide'
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
    op: str
    body: int | None = None
    point: str | None = None
    args: tuple = ()
    sign: int = 0  # branching steps: +1 / -1 from the reference pose
    needs: tuple = ()
    gives: tuple = ()

    @property
    def branching(self) -> bool:
        return self.op in ('circle_circle', 'circle_line', 'line_through')

    def describe(self, plan: Plan) -> str:
        b = plan.bodies[self.body].links if self.body is not None else None
        if self.op == 'ground':
            return f'ground: place {"+".join(b)}'
        if self.op == 'known_point':
            return f'known point {self.point}'
        if self.op == 'two_points':
            return f'rigid transfer: place {"+".join(b)} from points {self.args[0]}, {self.args[1]}'
        if self.op == 'point_angle':
            return f'place {"+".join(b)} from point {self.args[0]} and its known angle'
        if self.op == 'angle':
            return f'orientation of {"+".join(b)} from {self.args[1]}'
        if self.op == 'circle_circle':
            return (
                f'RRR dyad: {self.point} from circles about {self.args[1]} '
                f'({"+".join(plan.bodies[self.args[0]].links)}) and {self.args[3]} '
                f'({"+".join(plan.bodies[self.args[2]].links)})'
            )
        if self.op == 'circle_line':
            return f'RRP dyad: {self.point} on slide {self.args[2]} and circle about {self.args[1]}'
        if self.op == 'line_through':
            return (
                f'RPR dyad: orient {"+".join(b)} about {self.args[1]} so slide '
                f'{self.args[0]} passes {self.point}'
            )
        return self.op


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
        self._build_bodies()
        self._compile()
        self._prune(wanted_links, wanted_points)

    # -- bodies -------------------------------------------------------------------------------
    def _build_bodies(self):
        mech = self.mech
        parent = {n: n for n in mech.links}

        def find(a):
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            return a

        edges: list[tuple[str, str, int, str, str | None]] = []
        self.relations: list[tuple[str, str, int | None]] = []  # angle-only relations
        for i, s in enumerate(self.specs):
            if s.kind == 'angle':
                shared = set(mech.links[s.link].points) & set(mech.links[s.reference].points)
                if shared:
                    edges.append((s.reference, s.link, i, 'angle', sorted(shared)[0]))
                else:
                    self.relations.append((s.reference, s.link, i))
            elif s.kind == 'slide':
                pj = mech.prismatics[s.joint]
                edges.append((pj.guide, pj.slider, i, 'slide', None))
        for pj in mech.prismatics.values():
            if not any(e[3] == 'slide' and self.specs[e[2]].joint == pj.name for e in edges):
                self.relations.append((pj.guide, pj.slider, None))  # orientation lock
        for a, b, i, _kind, _ in edges:
            ra, rb = find(a), find(b)
            if ra == rb:
                raise PlanError(
                    f'known {self.specs[i].name!r} over-constrains links {a!r} and '
                    f'{b!r}: they are already rigidly connected by other knowns'
                )
            parent[rb] = ra
        groups: dict[str, list[str]] = {}
        for n in mech.links:
            groups.setdefault(find(n), []).append(n)
        self.bodies: list[Body] = []
        self.body_of: dict[str, int] = {}
        for members in groups.values():
            root = mech.ground if mech.ground in members else members[0]
            placed, welds, todo = [root], [], [e for e in edges if find(e[0]) == find(root)]
            while todo:
                progressed = False
                for e in list(todo):
                    a, b, i, kind, sp = e
                    if a in placed and b not in placed:
                        welds.append(Weld(b, a, i, kind, sp))
                        placed.append(b)
                    elif b in placed and a not in placed:
                        welds.append(Weld(a, b, i, kind, sp))
                        placed.append(a)
                    else:
                        continue
                    todo.remove(e)
                    progressed = True
                if not progressed:
                    break
            pts = []
            for n in placed:
                pts += [p for p in mech.links[n].points if p not in pts]
            body = Body(len(self.bodies), root, placed, welds, pts)
            self.bodies.append(body)
            for n in placed:
                self.body_of[n] = body.index

    # -- compile ------------------------------------------------------------------------------
    def _compile(self):
        mech = self.mech
        steps: list[Step] = []
        known_pts: set[str] = set()
        placed: set[int] = set()
        angled: set[int] = set()
        pt_bodies: dict[str, list[int]] = {}
        for b in self.bodies:
            for p in b.points:
                pt_bodies.setdefault(p, []).append(b.index)

        def place(step: Step, bi: int):
            steps.append(step)
            placed.add(bi)
            angled.add(bi)
            known_pts.update(self.bodies[bi].points)

        gb = self.body_of[mech.ground]
        place(Step('ground', body=gb, gives=(('pose', gb),)), gb)
        for i, s in enumerate(self.specs):
            if s.kind == 'point':
                if s.point in known_pts:
                    raise PlanError(
                        f'known point {s.point!r} is fixed by the ground; it cannot be a target'
                    )
                steps.append(
                    Step('known_point', point=s.point, args=(i,), gives=(('pt', s.point),))
                )
                known_pts.add(s.point)

        def known_of(bi):
            return [p for p in self.bodies[bi].points if p in known_pts]

        def point_needs(p):
            return ('pt', p)

        while len(placed) < len(self.bodies):
            progress = False
            # non-branching steps first
            for b in self.bodies:
                bi = b.index
                if bi in placed:
                    continue
                kp = known_of(bi)
                two = self._two_distinct(bi, kp)
                if two:
                    place(
                        Step(
                            'two_points',
                            body=bi,
                            args=two,
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
                            'point_angle',
                            body=bi,
                            args=(kp[0],),
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
                                'angle',
                                body=bi,
                                args=(link_here, link_there, spec_i),
                                needs=(('angle', src_body),),
                                gives=(('angle', bi),),
                            )
                        )
                        angled.add(bi)
                        progress = True
            if progress:
                continue
            step = self._branching_step(placed, known_pts, pt_bodies, known_of)
            if step is None:
                break
            steps.append(step)
            if step.op == 'line_through':
                placed.add(step.body)
                angled.add(step.body)
                known_pts.update(self.bodies[step.body].points)
            else:
                known_pts.add(step.point)
        self.steps_all = steps

    def _two_distinct(self, bi, kp):
        for i in range(len(kp)):
            for j in range(i + 1, len(kp)):
                if np.hypot(*(self.mech.points[kp[i]] - self.mech.points[kp[j]])) > 0:
                    return (kp[i], kp[j])
        return None

    def _angle_source(self, bi, angled):
        for a, b, i in self.relations:
            ba, bb = self.body_of[a], self.body_of[b]
            if bb == bi and ba in angled:
                return ba, b, a, i
            if ba == bi and bb in angled:
                return bb, a, b, i
        return None

    def _branching_step(self, placed, known_pts, pt_bodies, known_of):
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
                    sign = _side(ref[p1], ref[p2], ref[x])
                    return Step(
                        'circle_circle',
                        point=x,
                        args=(b1, p1, b2, p2),
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
                u = np.asarray(pj.direction)
                sign = int(np.sign(np.dot(ref[x] - ref[p1], u))) or 1
                return Step(
                    'circle_line',
                    point=x,
                    args=(bi, p1, pj.name),
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
            u = np.asarray(pj.direction)
            sign = int(np.sign(np.dot(ref[x] - ref[p], u))) or 1
            return Step(
                'line_through',
                body=gb,
                point=x,
                args=(pj.name, p),
                sign=sign,
                needs=(('pt', x), ('pt', p)),
                gives=(('pose', gb),),
            )
        return None

    # -- pruning ------------------------------------------------------------------------------
    def _prune(self, wanted_links, wanted_points):
        mech = self.mech
        if wanted_links is None and wanted_points is None:
            wanted_links = list(mech.links)
        wanted_links = list(wanted_links or [])
        wanted_points = list(wanted_points or [])
        need: set = set()
        for link in wanted_links:
            need.add(('pose', self.body_of[link]))
        for p in wanted_points:
            need.add(('pt', p))
        # a point is given by a step that gives it or by placing any body that carries it
        keep = [False] * len(self.steps_all)
        for k in range(len(self.steps_all) - 1, -1, -1):
            st = self.steps_all[k]
            gives = set(st.gives)
            if st.op in ('ground', 'two_points', 'point_angle', 'line_through'):
                gives |= {('pt', p) for p in self.bodies[st.body].points}
            if st.op == 'line_through':
                gives.add(('angle', st.body))
            if st.op in ('ground', 'two_points', 'point_angle'):
                gives.add(('angle', st.body))
            hit = gives & need
            if hit or st.op == 'ground':
                keep[k] = True
                need -= hit
                need |= set(st.needs)
        # anything still needed was never produced: the plan cannot give it
        self.missing = sorted(need)
        self.steps = [s for s, k in zip(self.steps_all, keep) if k]
        self.complete = not self.missing
        placed = {
            s.body
            for s in self.steps
            if s.op in ('ground', 'two_points', 'point_angle', 'line_through')
        }
        self.placed_links = [l for b in sorted(placed) for l in self.bodies[b].links]
        self.branch_steps = [s for s in self.steps if s.branching]

    @property
    def reference_signs(self) -> tuple[int, ...]:
        return tuple(s.sign for s in self.branch_steps)

    def describe(self) -> list[str]:
        out = []
        for s in self.steps:
            text = s.describe(self)
            if s.branching:
                text += f' [branch {"+" if s.sign > 0 else "-"} in the reference pose]'
            out.append(text)
        return out

    # -- execution ----------------------------------------------------------------------------
    def run(
        self,
        values: Sequence[np.ndarray],
        n: int,
        signs: Sequence[int] | None = None,
        tol: float = dyads.TANGENCY_TOL,
    ):
        """Execute the plan over a batch of n with fixed branch signs (the batch view of
        :class:`~linkage_ros.core.execute.PlanExecutor`: points as (n, 2) arrays).

        ``values[i]`` is the value array of spec i ((n,) or (n, 2)). ``signs`` overrides the
        branch signs (one per branching step). Returns (poses, points, info) where info has
        ok (n,), margin (n,), signs (n, k), failure (step index or -1) and violation (n,).
        """

        r = executor(self).run(values, n, signs, tol=tol)
        k = len(self.branch_steps)
        used = np.zeros((n, k), int)
        for b, sg in enumerate(r.signs):
            used[:, b] = sg
        info = {
            'ok': np.asarray(r.ok, bool),
            'margin': np.asarray(r.margin, float),
            'signs': used,
            'failure': np.asarray(r.failure).astype(int),
            'violation': np.asarray(r.violation, float),
        }
        return batch_poses(r.poses), {p: to_xy(z) for p, z in r.points.items()}, info


def batch_poses(poses: LinkPoses) -> Poses:
    """(n, 2)-coordinate view of batched complex link poses."""
    return Poses(dict(poses.phi), {l: to_xy(T) for l, T in poses.T.items()})


def link_poses(poses: Poses) -> LinkPoses:
    """Complex view of (n, 2)-coordinate batched link poses."""
    out = LinkPoses()
    for l, phi in poses.phi.items():
        out.set(l, phi, to_complex(poses.T[l]), BATCH.expi(phi))
    return out


def _norm(v):
    return np.hypot(v[..., 0], v[..., 1])


def _side(p1, p2, x) -> int:
    a, b = p2 - p1, x - p1
    s = float(np.sign(dyads.cross2(a / (np.hypot(*a) or 1.0), b / (np.hypot(*b) or 1.0))))
    return int(s) if s else 1


# ---- one command at a time -------------------------------------------------------------------

#: one configuration's link poses (complex): see execute.LinkPoses
ScalarPoses = LinkPoses
#: what running a plan gave: see execute.PlanRun
ScalarRun = PlanRun


def run_one(
    plan: Plan,
    values,
    signs=None,
    prefer: dict | None = None,
    tol: float = dyads.TANGENCY_TOL,
    prev_margins=None,
) -> PlanRun:
    """:class:`~linkage_ros.core.execute.PlanExecutor` on one command: ``values[i]`` a float
    (angle/slide) or an (x, y) pair (point); ``prefer`` and ``prev_margins`` steer continuity
    through tangent configurations (see PlanExecutor.run)."""
    return executor(plan).run(values, None, signs, prefer, prev_margins, tol)


def _c(v) -> complex:
    return complex(float(v[0]), float(v[1]))


@dataclass(frozen=True)
class SpecReader:
    """How to read one spec's value off solved complex link poses, resolved once: an angle
    (rad, wrapped to (-pi, pi]), a slide (m) or a point's complex position."""

    kind: str
    link: str = ''  # angle: the link; slide: the slider's point's link; point: its link
    reference: str = ''  # angle: the reference link; slide: the guide
    offset: float = 0.0
    p_ref: complex = 0j  # slide / point: the point in the reference pose
    origin: complex = 0j  # slide: the origin on the guide
    direction: complex = 0j  # slide: the direction (reference pose)

    def __call__(self, ops, poses: LinkPoses):
        if self.kind == 'angle':
            return ops.wrap(poses.phi[self.link] - poses.phi[self.reference] + self.offset)
        x = poses.rot[self.link] * self.p_ref + poses.T[self.link]
        if self.kind == 'point':
            return x
        rot = poses.rot[self.reference]
        v = x - (rot * self.origin + poses.T[self.reference])
        d = rot * self.direction
        return v.real * d.real + v.imag * d.imag


def spec_reader(mech: Mechanism, spec: Spec) -> SpecReader:
    if spec.kind == 'angle':
        return SpecReader('angle', spec.link, spec.reference, spec.offset)
    if spec.kind == 'slide':
        pj = mech.prismatics[spec.joint]
        return SpecReader(
            'slide',
            spec_point_link(mech, pj.point, pj.slider),
            pj.guide,
            p_ref=_c(mech.points[pj.point]),
            origin=_c(pj.origin),
            direction=_c(pj.direction),
        )
    return SpecReader(
        'point', mech.links_of_point(spec.point)[0], p_ref=_c(mech.points[spec.point])
    )


def spec_value_of(ops, mech: Mechanism, spec: Spec, poses: LinkPoses):
    """A spec's value on solved poses (complex link poses, either backend): an angle (rad,
    wrapped to (-pi, pi]) or slide (m), or a point's complex position."""
    return spec_reader(mech, spec)(ops, poses)


def spec_value_one(mech: Mechanism, spec: Spec, poses: ScalarPoses):
    """A spec's value on one configuration: a float, or (x, y) for a point."""
    v = spec_value_of(SCALAR, mech, spec, poses)
    return (v.real, v.imag) if spec.kind == 'point' else v


def spec_value_at(mech: Mechanism, spec: Spec, poses: Poses) -> np.ndarray:
    """A spec's value on batched poses: (N,) for angle/slide, (N, 2) for a point."""
    with np.errstate(all='ignore'):
        v = spec_value_of(BATCH, mech, spec, link_poses(poses))
    return to_xy(v) if spec.kind == 'point' else np.asarray(v, float)


def step_geometry(ops, mech: Mechanism, st: Step, pts, rot) -> tuple:
    """(side, margin) of one branching step read off solved positions, either backend: the
    branch sign is +1 where side >= 0; margin is |sin| of the dyad's transmission angle (0 at
    its singularity). ``pts`` complex points, ``rot`` {link: e^{i phi}} of the guide links."""

    def unit(z):  # hypot: no overflow at 1e200; a zero vector stays 0
        r = abs(z)
        return z / ops.where(r > 0, r, 1.0)

    x = pts[st.point]
    if st.op == 'circle_circle':
        a, b = pts[st.args[1]], pts[st.args[3]]
        ab, ax = unit(b - a), unit(x - a)  # units: products of 1e200 overflow
        side = ab.real * ax.imag - ab.imag * ax.real
        vb = unit(x - b)
        m = abs(ax.real * vb.imag - ax.imag * vb.real)
    else:
        pj = mech.prismatics[st.args[0] if st.op == 'line_through' else st.args[2]]
        u = rot[pj.guide] * _c(pj.direction)
        v = unit(x - pts[st.args[1]])
        side = v.real * u.real + v.imag * u.imag
        m = abs(side)
    return side, ops.clip(m, 0.0, 1.0)


def branch_geometry_of(ops, plan: Plan, pts, poses: LinkPoses):
    """Branch signs (+1 / -1) and dyad margins of the plan's branching steps read off a solved
    configuration, either backend (how a Newton solution is told which assembly mode it is
    in): one list entry per branching step."""
    signs, margins = [], []
    for st in plan.branch_steps:
        side, m = step_geometry(ops, plan.mech, st, pts, poses.rot)
        signs.append(ops.where(side >= 0, 1, -1))
        margins.append(m)
    return signs, margins


def branch_geometry_one(plan: Plan, pts: dict[str, complex], poses: ScalarPoses):
    """branch_geometry_of on one configuration: (signs tuple, margins list)."""
    signs, margins = branch_geometry_of(SCALAR, plan, pts, poses)
    return tuple(signs), margins


def branch_geometry_batch(plan: Plan, pts: dict[str, np.ndarray], poses: Poses):
    """branch_geometry_of over a batch: points {name: (n, 2)} and batched poses -> signs (n, k)
    (+1 / -1) and margins (n, k) of the plan's k branching steps."""
    n = poses.phi[plan.mech.ground].shape[0]
    k = len(plan.branch_steps)
    zs = {p: to_complex(v) for p, v in pts.items()}
    with np.errstate(all='ignore'):
        sg, mg = branch_geometry_of(BATCH, plan, zs, link_poses(poses))
    signs, margins = np.zeros((n, k), int), np.zeros((n, k))
    for j in range(k):
        signs[:, j], margins[:, j] = sg[j], mg[j]
    return signs, margins
