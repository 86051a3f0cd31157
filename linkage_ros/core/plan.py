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
from .model import Mechanism

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


def spec_value_at(mech: Mechanism, spec: Spec, poses: Poses) -> np.ndarray:
    """Evaluate a spec on solved poses: (N,) for angle/slide, (N, 2) for a point."""
    if spec.kind == 'angle':
        d = poses.phi[spec.link] - poses.phi[spec.reference] + spec.offset
        return _wrap_pi(d)
    if spec.kind == 'slide':
        pj = mech.prismatics[spec.joint]
        x = poses.world(spec_point_link(mech, pj.point, pj.slider), pj.point, mech)
        o = poses.apply(pj.guide, np.asarray(pj.origin))
        dvec = dyads.rotate(np.asarray(pj.direction), poses.phi[pj.guide])
        return np.sum((x - o) * dvec, axis=-1)
    owner = mech.links_of_point(spec.point)
    return poses.world(owner[0], spec.point, mech)


def _wrap_pi(a):
    """Wrap to (-pi, pi] using atan2 so that huge inputs keep full precision."""
    return np.arctan2(np.sin(a), np.cos(a))


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
    def body_local(self, bi: int, values: Sequence[np.ndarray], n: int) -> Poses:
        """Poses of the body's member links with its root at the reference pose (identity)."""
        mech = self.mech
        body = self.bodies[bi]
        loc = Poses()
        loc.phi[body.root] = np.zeros(n)
        loc.T[body.root] = np.zeros((n, 2))
        for w in body.welds:
            s = self.specs[w.spec_index]
            v = values[w.spec_index]
            if w.kind == 'angle':
                rel = _wrap_pi(v) - s.offset  # phi[s.link] - phi[s.reference]
                phi = loc.phi[w.via] + (rel if w.link == s.link else -rel)
                loc.phi[w.link] = phi
                p = mech.points[w.shared_point]
                pw = loc.apply(w.via, p)
                loc.T[w.link] = pw - dyads.rotate(np.broadcast_to(p, pw.shape), phi)
            else:
                pj = mech.prismatics[s.joint]
                x_ref = mech.points[pj.point]
                u = np.asarray(pj.direction)
                x_on_guide = x_ref + (v - pj.ref_value)[..., None] * u  # guide reference coords
                loc.phi[w.link] = loc.phi[w.via].copy()
                if w.link == pj.slider:  # guide placed: put the slider point on its line
                    xw = loc.apply(w.via, x_on_guide)
                    loc.T[w.link] = xw - dyads.rotate(
                        np.broadcast_to(x_ref, xw.shape), loc.phi[w.link]
                    )
                else:  # slider placed: hang the guide off it
                    xw = loc.apply(w.via, x_ref)
                    loc.T[w.link] = xw - dyads.rotate(x_on_guide, loc.phi[w.link])
        return loc

    def run(
        self,
        values: Sequence[np.ndarray],
        n: int,
        signs: Sequence[int] | None = None,
        tol: float = dyads.TANGENCY_TOL,
    ):
        """Execute the plan over a batch of n with fixed branch signs (continuity is a
        one-command-at-a-time rule: see run_one).

        ``values[i]`` is the value array of spec i ((n,) or (n, 2)). ``signs`` overrides the
        branch signs (one per branching step). Returns (poses, points, info) where info has
        ok (n,), margin (n,), signs (n, k), failure (step index or -1) and violation (n,).
        """
        mech = self.mech
        signs = list(self.reference_signs if signs is None else signs)
        poses = Poses()
        pts: dict[str, np.ndarray] = {}
        ok = np.ones(n, bool)
        margin = np.ones(n)
        violation = np.zeros(n)
        fail_step = np.full(n, -1)
        used_signs = np.zeros((n, len(self.branch_steps)), int)
        locals_: dict[int, Poses] = {}
        angles: dict[int, np.ndarray] = {}  # body root orientation when known before placing
        bk = 0

        def local(bi):
            if bi not in locals_:
                locals_[bi] = self.body_local(bi, values, n)
            return locals_[bi]

        def local_pt(bi, p):
            loc = local(bi)
            for l in self.bodies[bi].links:
                if p in mech.links[l].points:
                    return loc.world(l, p, mech)
            raise KeyError(p)

        def place_body(bi, phi, T):
            loc = local(bi)
            for l in self.bodies[bi].links:
                poses.phi[l] = phi + loc.phi[l]
                poses.T[l] = dyads.rotate(loc.T[l], phi) + T
            for l in self.bodies[bi].links:
                for p in mech.links[l].points:
                    if p not in pts:
                        pts[p] = poses.world(l, p, mech)

        def fail(mask, k, viol):
            nonlocal ok
            newly = mask & ok
            fail_step[newly] = k
            violation[newly] = viol[newly] if np.ndim(viol) else viol
            ok = ok & ~mask

        def took(k, m, okk, viol):
            """Record a branching step: its sign column, margins and failures."""
            nonlocal margin, bk
            used_signs[:, bk] = signs[bk]
            margin = np.minimum(margin, m)
            fail(~okk, k, viol)
            bk += 1

        for k, st in enumerate(self.steps):
            if st.op == 'ground':
                place_body(st.body, np.zeros(n), np.zeros((n, 2)))
            elif st.op == 'known_point':
                pts[st.point] = np.asarray(values[st.args[0]], float).reshape(n, 2)
            elif st.op == 'two_points':
                p, q = st.args
                lp, lq = local_pt(st.body, p), local_pt(st.body, q)
                phi = dyads.rotation_between(lq - lp, pts[q] - pts[p])
                place_body(st.body, phi, pts[p] - dyads.rotate(lp, phi))
            elif st.op == 'point_angle':
                p = st.args[0]
                phi = angles[st.body]
                place_body(st.body, phi, pts[p] - dyads.rotate(local_pt(st.body, p), phi))
            elif st.op == 'angle':
                link_here, link_there, spec_i = st.args
                src = poses.phi.get(link_there)
                if src is None:
                    sb = self.body_of[link_there]
                    src = angles[sb] + local(sb).phi[link_there]
                if spec_i is None:
                    rel = np.zeros(n)  # prismatic orientation lock
                else:
                    s = self.specs[spec_i]
                    rel = _wrap_pi(values[spec_i]) - s.offset
                    if link_here == s.reference:
                        rel = -rel
                angles[st.body] = src + rel - local(st.body).phi[link_here]
            elif st.op == 'circle_circle':
                b1, p1, b2, p2 = st.args
                x = st.point
                r1 = _norm(local_pt(b1, x) - local_pt(b1, p1))
                r2 = _norm(local_pt(b2, x) - local_pt(b2, p2))
                X, m, okk, viol, _ = dyads.circle_circle(pts[p1], r1, pts[p2], r2, signs[bk], tol)
                pts[x] = X
                took(k, m, okk, viol)
            elif st.op == 'circle_line':
                b1, p1, jname = st.args
                pj = mech.prismatics[jname]
                x = st.point
                r = _norm(local_pt(b1, x) - local_pt(b1, p1))
                g = pj.guide
                p0 = poses.apply(g, mech.points[x])
                u = dyads.rotate(np.broadcast_to(np.asarray(pj.direction), (n, 2)), poses.phi[g])
                X, m, okk, viol = dyads.circle_line(pts[p1], r, p0, u, signs[bk], tol)
                pts[x] = X
                took(k, m, okk, viol)
            elif st.op == 'line_through':
                jname, p = st.args
                pj = mech.prismatics[jname]
                x = st.point
                bi = st.body
                loc = local(bi)
                lp = local_pt(bi, p)
                # the guide line in body-local coordinates: through x_ref on the guide, dir u
                u_loc = dyads.rotate(
                    np.broadcast_to(np.asarray(pj.direction), (n, 2)), loc.phi[pj.guide]
                )
                x_loc = loc.apply(pj.guide, mech.points[x])
                e = dyads.cross2(u_loc, x_loc - lp)  # signed offset of the pivot from the line
                psi0 = np.arctan2(u_loc[:, 1], u_loc[:, 0])

                def solve_phi(s):
                    psi, mm, okk, viol = dyads.line_through_point(pts[p], pts[x], e, s, tol)
                    return psi - psi0, mm, okk, viol

                phi, m, okk, viol = solve_phi(signs[bk])
                angles[bi] = phi
                place_body(bi, phi, pts[p] - dyads.rotate(lp, phi))
                took(k, m, okk, viol)
        info = {
            'ok': ok,
            'margin': margin,
            'signs': used_signs,
            'failure': fail_step,
            'violation': violation,
        }
        return poses, pts, info


def _norm(v):
    return np.hypot(v[..., 0], v[..., 1])


def _side(p1, p2, x) -> int:
    a, b = p2 - p1, x - p1
    s = float(np.sign(dyads.cross2(a / (np.hypot(*a) or 1.0), b / (np.hypot(*b) or 1.0))))
    return int(s) if s else 1


# ---- one command at a time (scalar, complex numbers) -----------------------------------------


@dataclass
class ScalarPoses:
    """Link poses of one configuration: world(p) = rot * p_ref + T with rot = e^{i phi}."""

    phi: dict[str, float] = field(default_factory=dict)
    rot: dict[str, complex] = field(default_factory=dict)
    T: dict[str, complex] = field(default_factory=dict)

    def set(self, link: str, phi: float, T: complex, rot: complex | None = None):
        self.phi[link] = phi
        self.rot[link] = complex(math.cos(phi), math.sin(phi)) if rot is None else rot
        self.T[link] = T

    def world(self, link: str, p_ref: complex) -> complex:
        return self.rot[link] * p_ref + self.T[link]


def _c(v) -> complex:
    return complex(float(v[0]), float(v[1]))


#: Below this dyad margin (|sin| of its transmission angle) continuity decides the branch by the
#: predicted position; above it the previous sign is kept, because an assembly mode can only
#: change by passing through the dyad's singular (tangent) configuration.
CONTINUITY_MARGIN = 0.1


@dataclass
class ScalarRun:
    ok: bool
    poses: ScalarPoses
    points: dict[str, complex]
    margin: float = 1.0
    signs: tuple[int, ...] = ()
    failure: int = -1
    violation: float = 0.0
    margins: tuple[float, ...] = ()


def run_one(
    plan: Plan,
    values,
    signs=None,
    prefer: dict | None = None,
    tol: float = dyads.TANGENCY_TOL,
    prev_margins=None,
) -> ScalarRun:
    """Scalar twin of :meth:`Plan.run` for one command: ``values[i]`` a float (angle/slide) or an
    (x, y) pair (point). ``signs`` are the branch signs to keep. ``prefer`` maps point names to
    predicted complex positions and '@link' to predicted link angles: where a dyad is near its
    singularity (its margin now or in ``prev_margins`` below CONTINUITY_MARGIN) the branch
    nearest the prediction is taken instead (continuity through tangent configurations).

    Runs the plan's straight-line Python (:func:`_compile_scalar`, made on first use)."""
    fn = plan.__dict__.get('_scalar_fn')
    if fn is None:
        fn = plan._scalar_fn = _compile_scalar(plan)
    return fn(values, plan.reference_signs if signs is None else signs, prefer, tol, prev_margins)


class _ScalarCode:
    """Source of one plan's scalar solve, emitted step by step (see _compile_scalar)."""

    def __init__(self, plan: Plan):
        self.plan = plan
        self.mech = plan.mech
        self.pc = {p: _c(v) for p, v in self.mech.points.items()}
        self.lines: list[str] = []
        self.ns = {
            'cos': math.cos,
            'sin': math.sin,
            'atan2': math.atan2,
            'wrap_angle': dyads.wrap_angle,
            'circle_circle_pair': dyads.circle_circle_pair,
            'circle_line_pair': dyads.circle_line_pair,
            'line_through_pair': dyads.line_through_pair,
            'ScalarRun': ScalarRun,
            'ScalarPoses': ScalarPoses,
            'CONTINUITY_MARGIN': CONTINUITY_MARGIN,
        }
        self.link_id = {l: k for k, l in enumerate(self.mech.links)}
        self.point_id = {p: k for k, p in enumerate(self.mech.points)}
        self.placed_links: list[str] = []  # in placement order (the poses' dict order)
        self.placed_points: list[str] = []
        self.frames: dict[int, dict[str, tuple[str, str, str]]] = {}  # body local frames
        self.point_link: dict[tuple[int, str], str] = {}
        for b in plan.bodies:
            for l in b.links:
                for p in self.mech.links[l].points:
                    self.point_link.setdefault((b.index, p), l)
        self.branches = 0  # branching steps emitted so far

    def emit(self, line: str):
        self.lines.append('    ' + line)

    def const(self, value) -> str:
        name = f'K{len(self.ns)}'
        self.ns[name] = value
        return name

    def pt(self, p: str) -> str:
        return f'p{self.point_id[p]}'

    def link(self, l: str) -> str:
        return str(self.link_id[l])

    def frame(self, bi: int) -> dict[str, tuple[str, str, str]]:
        """(phi, rot, T) expressions of each member link in the body's local frame. A body
        without welds is its root alone at the identity; a welded body's frame depends on the
        command's values, so its code is emitted here, before its first use."""
        got = self.frames.get(bi)
        if got is not None:
            return got
        body = self.plan.bodies[bi]
        frame = {body.root: ('0.0', '(1+0j)', '0j')}
        for w in body.welds:
            s = self.plan.specs[w.spec_index]
            tag = f'{bi}_{self.link(w.link)}'
            vphi, vrot, vT = frame[w.via]
            if w.kind == 'angle':
                self.emit(
                    f'rel = wrap_angle(float(values[{w.spec_index}])) - {self.const(s.offset)}'
                )
                self.emit(f'lph{tag} = {vphi} + {"rel" if w.link == s.link else "-rel"}')
                p = self.const(self.pc[w.shared_point])
                self.emit(f'lro{tag} = complex(cos(lph{tag}), sin(lph{tag}))')
                self.emit(f'lT{tag} = ({vrot} * {p} + {vT}) - lro{tag} * {p}')
            else:
                pj = self.mech.prismatics[s.joint]
                x_ref = self.const(self.pc[pj.point])
                self.emit(
                    f'along = {x_ref} + (float(values[{w.spec_index}]) - '
                    f'{self.const(pj.ref_value)}) * {self.const(_c(pj.direction))}'
                )
                self.emit(f'lph{tag} = {vphi}')
                self.emit(f'lro{tag} = {vrot}')
                if w.link == pj.slider:
                    self.emit(f'lT{tag} = ({vrot} * along + {vT}) - {vrot} * {x_ref}')
                else:
                    self.emit(f'lT{tag} = ({vrot} * {x_ref} + {vT}) - {vrot} * along')
            frame[w.link] = (f'lph{tag}', f'lro{tag}', f'lT{tag}')
        self.frames[bi] = frame
        return frame

    def local_pt(self, bi: int, p: str) -> str:
        """Expression of point p in body bi's local frame (a constant for an unwelded body)."""
        l = self.point_link[(bi, p)]
        if not self.plan.bodies[bi].welds:
            return self.const((1 + 0j) * self.pc[p] + 0j)
        _, rot, T = self.frame(bi)[l]
        return f'({rot} * {self.const(self.pc[p])} + {T})'

    def place_body(self, bi: int, phi: str, Tb: str):
        """Every member link's world pose from the body's rotation phi (a variable) and
        translation Tb (an expression), and the world position of their points not yet placed."""
        frame = self.frame(bi)
        self.emit(f'Tb = {Tb}')
        self.emit(f'rot = complex(cos({phi}), sin({phi}))')
        for l in self.plan.bodies[bi].links:
            lphi, lrot, lT = frame[l]
            k = self.link(l)
            self.emit(f'ro{k} = rot * {lrot}')
            self.emit(f'T{k} = rot * {lT} + Tb')
            self.emit(f'ph{k} = {phi} + {lphi}')
            self.placed_links.append(l)
            for p in self.mech.links[l].points:
                if p not in self.placed_points:
                    self.emit(f'{self.pt(p)} = ro{k} * {self.const(self.pc[p])} + T{k}')
                    self.placed_points.append(p)

    def result(self, ok: bool, k: int = -1) -> str:
        """The ScalarRun of everything placed so far."""
        ids = [self.link(l) for l in self.placed_links]
        poses = (
            'ScalarPoses({'
            + ', '.join(f'{l!r}: ph{k}' for l, k in zip(self.placed_links, ids))
            + '}, {'
            + ', '.join(f'{l!r}: ro{k}' for l, k in zip(self.placed_links, ids))
            + '}, {'
            + ', '.join(f'{l!r}: T{k}' for l, k in zip(self.placed_links, ids))
            + '})'
        )
        pts = '{' + ', '.join(f'{p!r}: {self.pt(p)}' for p in self.placed_points) + '}'
        used = '(' + ''.join(f'sg{b}, ' for b in range(self.branches)) + ')'
        margins = '(' + ''.join(f'm{b}, ' for b in range(self.branches)) + ')'
        if ok:
            return f'ScalarRun(True, {poses}, {pts}, margin, {used}, margins={margins})'
        return f'ScalarRun(False, {poses}, {pts}, 0.0, {used}, {k}, viol, {margins})'

    def near_singular(self, then: list[str]):
        """Code that runs ``then`` when the current branching step's dyad is near its
        singularity now (margin m) or was at the previous solve (prev_margins)."""
        b = self.branches
        self.emit(
            f'    prev = prev_margins[{b}] if prev_margins and {b} < len(prev_margins) else 1.0'
        )
        self.emit('    if min(m, prev) < CONTINUITY_MARGIN:')
        for line in then:
            self.emit('        ' + line)

    def took(self):
        b = self.branches
        self.emit(f'sg{b} = sg')
        self.emit(f'm{b} = m')
        self.emit('margin = min(margin, m)')
        self.branches += 1

    def step(self, k: int, st: Step):
        op = st.op
        if op == 'ground':
            self.emit('phi = 0.0')
            self.place_body(st.body, 'phi', '0j')
        elif op == 'known_point':
            self.emit(f'v = values[{st.args[0]}]')
            self.emit(f'{self.pt(st.point)} = complex(float(v[0]), float(v[1]))')
            self.placed_points.append(st.point)
        elif op == 'two_points':
            p, q = st.args
            self.emit(f'lp = {self.local_pt(st.body, p)}')
            self.emit(f'a = {self.local_pt(st.body, q)} - lp')
            self.emit(f'b = {self.pt(q)} - {self.pt(p)}')
            # unit first: 1e-300 lengths would underflow
            self.emit('a, b = a / abs(a), b / (abs(b) or 1.0)')
            self.emit(
                'phi = atan2(a.real * b.imag - a.imag * b.real, a.real * b.real + a.imag * b.imag)'
            )
            self.place_body(st.body, 'phi', f'{self.pt(p)} - complex(cos(phi), sin(phi)) * lp')
        elif op == 'point_angle':
            p = st.args[0]
            self.emit(f'phi = ang{st.body}')
            self.place_body(
                st.body,
                'phi',
                f'{self.pt(p)} - complex(cos(phi), sin(phi)) * {self.local_pt(st.body, p)}',
            )
        elif op == 'angle':
            here, there, spec_i = st.args
            here_phi = self.frame(st.body)[here][0]  # any frame code first: it uses rel
            if there in self.placed_links:
                self.emit(f'src = ph{self.link(there)}')
            else:
                sb = self.plan.body_of[there]
                there_phi = self.frame(sb)[there][0]
                self.emit(f'src = ang{sb} + {there_phi}')
            self.emit('rel = 0.0')
            if spec_i is not None:
                s = self.plan.specs[spec_i]
                self.emit(f'rel = wrap_angle(float(values[{spec_i}])) - {self.const(s.offset)}')
                if here == s.reference:
                    self.emit('rel = -rel')
            self.emit(f'ang{st.body} = src + rel - {here_phi}')
        elif op in ('circle_circle', 'circle_line'):
            x = st.point
            X = self.pt(x)
            if op == 'circle_circle':
                b1, p1, b2, p2 = st.args
                P1, P2 = self.pt(p1), self.pt(p2)
                self.emit(f'r1 = abs({self.local_pt(b1, x)} - {self.local_pt(b1, p1)})')
                self.emit(f'r2 = abs({self.local_pt(b2, x)} - {self.local_pt(b2, p2)})')
                self.emit('big = max(r1, r2)')
                self.emit(f'if abs({P1} - {P2}) <= tol * big and abs(r1 - r2) <= tol * big:')
                # coincident circles (a change point: e.g. a rhombus folded flat): x may be
                # anywhere on the circle; keep it where continuity predicts, else where the
                # reference pose has it relative to p1. Branch identity is undefined (margin 0).
                self.emit(f'    guess = prefer.get({x!r}) if prefer else None')
                self.emit(
                    f'    off = (guess - {P1}) if guess is not None else '
                    f'{self.const(self.pc[x] - self.pc[p1])}'
                )
                self.emit('    off = off / abs(off) if abs(off) > 0 else 1 + 0j')
                self.emit(f'    foot, vec, m, ok, viol = {P1} + r1 * off, 0j, 0.0, True, 0.0')
                self.emit('else:')
                self.emit(
                    f'    foot, vec, m, ok, viol = circle_circle_pair({P1}, r1, {P2}, r2, tol)'
                )
            else:
                b1, p1, jname = st.args
                pj = self.mech.prismatics[jname]
                g = self.link(pj.guide)
                self.emit(f'r = abs({self.local_pt(b1, x)} - {self.local_pt(b1, p1)})')
                self.emit(
                    f'foot, vec, m, ok, viol = circle_line_pair({self.pt(p1)}, r, '
                    f'ro{g} * {self.const(self.pc[x])} + T{g}, '
                    f'ro{g} * {self.const(_c(pj.direction))}, tol)'
                )
            self.emit('if not ok:')
            self.emit(f'    return {self.result(False, k)}')
            # the two solutions are foot +- vec: + is the dyad's positive branch
            self.emit(f'sg = signs[{self.branches}]')
            self.emit(f'if prefer is not None and {x!r} in prefer:')
            self.near_singular(
                [
                    f'target = prefer[{x!r}]',
                    'sg = 1 if abs((foot + vec) - target) <= abs((foot - vec) - target) else -1',
                ]
            )
            self.emit(f'{X} = foot + sg * vec')
            self.placed_points.append(x)
            self.took()
        elif op == 'line_through':
            jname, p = st.args
            pj = self.mech.prismatics[jname]
            x, bi = st.point, st.body
            frame = self.frame(bi)
            self.emit(f'lp = {self.local_pt(bi, p)}')
            gphi, grot, gT = frame[pj.guide]
            self.emit(f'u_loc = {grot} * {self.const(_c(pj.direction))}')
            self.emit(f'w = ({grot} * {self.const(self.pc[x])} + {gT}) - lp')
            self.emit('e = u_loc.real * w.imag - u_loc.imag * w.real')  # signed pivot offset
            self.emit('psi0 = atan2(u_loc.imag, u_loc.real)')
            self.emit(
                f'beta, along, m, ok, viol = line_through_pair({self.pt(p)}, {self.pt(x)}, e, tol)'
            )
            self.emit('if not ok:')
            self.emit(f'    return {self.result(False, k)}')
            self.emit('phi_p = beta - atan2(e, along) - psi0')
            self.emit('phi_m = beta - atan2(e, -along) - psi0')
            self.emit(f'sg = signs[{self.branches}]')
            key = '@' + pj.guide
            self.emit(f'if prefer is not None and {key!r} in prefer:')
            self.near_singular(
                [
                    f'last = prefer[{key!r}]',
                    f'sg = 1 if abs(wrap_angle(phi_p + {gphi} - last)) <= '
                    f'abs(wrap_angle(phi_m + {gphi} - last)) else -1',
                ]
            )
            self.emit('phi = phi_p if sg > 0 else phi_m')
            self.emit(f'ang{bi} = phi')
            self.place_body(bi, 'phi', f'{self.pt(p)} - complex(cos(phi), sin(phi)) * lp')
            self.took()
        else:
            raise PlanError(f'internal: unknown plan step {op!r}')


def _compile_scalar(plan: Plan):
    """The plan as one straight-line Python function (values, signs, prefer, tol,
    prev_margins) -> ScalarRun: every lookup of the plan (bodies, local frames, reference
    points, which link carries which point) is resolved here once, so a solve executes only
    its arithmetic. This is the node's per-command path."""
    code = _ScalarCode(plan)
    code.emit('margin = 1.0')
    for k, st in enumerate(plan.steps):
        code.step(k, st)
    code.emit(f'return {code.result(True)}')
    src = 'def run(values, signs, prefer, tol, prev_margins):\n' + '\n'.join(code.lines) + '\n'
    namespace = dict(code.ns)
    exec(compile(src, f'<scalar plan of {plan.mech.name}>', 'exec'), namespace)  # noqa: S102 (to go: issue 15)
    fn = namespace['run']
    fn.source = src  # the generated code, for debugging
    return fn


def _unit(z: complex) -> complex:
    a = abs(z)
    return z / a if a > 0 else 0j


def spec_value_one(mech: Mechanism, spec: Spec, poses: ScalarPoses):
    """Evaluate a spec on one configuration: a float, or (x, y) for a point."""
    if spec.kind == 'angle':
        return dyads.wrap_angle(poses.phi[spec.link] - poses.phi[spec.reference] + spec.offset)
    if spec.kind == 'slide':
        pj = mech.prismatics[spec.joint]
        x = poses.world(spec_point_link(mech, pj.point, pj.slider), _c(mech.points[pj.point]))
        o = poses.world(pj.guide, _c(pj.origin))
        d = poses.rot[pj.guide] * _c(pj.direction)
        v = x - o
        return v.real * d.real + v.imag * d.imag
    w = poses.world(mech.links_of_point(spec.point)[0], _c(mech.points[spec.point]))
    return (w.real, w.imag)


def branch_geometry_one(plan: Plan, pts: dict[str, complex], poses: ScalarPoses):
    """Branch signs and dyad margins of the plan's branching steps read off one configuration
    (how a Newton solution is told which assembly mode it is in)."""
    mech = plan.mech
    signs, margins = [], []
    for st in plan.branch_steps:
        x = pts[st.point]
        if st.op == 'circle_circle':
            _, p1, _, p2 = st.args
            a, b = pts[p1], pts[p2]
            ab, ax = _unit(b - a), _unit(x - a)  # units: products of 1e200 overflow
            side = ab.real * ax.imag - ab.imag * ax.real
            va, vb = _unit(x - a), _unit(x - b)
            m = abs(va.real * vb.imag - va.imag * vb.real)
        else:
            pj = mech.prismatics[st.args[0] if st.op == 'line_through' else st.args[2]]
            base = pts[st.args[1]]
            u = poses.rot[pj.guide] * _c(pj.direction)
            v = _unit(x - base)
            side = v.real * u.real + v.imag * u.imag
            m = abs(side)
        signs.append(1 if side >= 0 else -1)
        margins.append(min(max(m, 0.0), 1.0))
    return tuple(signs), margins


def branch_geometry_batch(plan: Plan, pts: dict[str, np.ndarray], poses: Poses):
    """branch_geometry_one over a batch: points {name: (n, 2)} and batched poses -> signs (n, k)
    (+1 / -1) and margins (n, k) of the plan's k branching steps."""
    n = poses.phi[plan.mech.ground].shape[0]

    def unit(v):  # hypot: no overflow at 1e200; a zero vector stays 0
        r = np.hypot(v[:, 0], v[:, 1])
        return v / np.where(r > 0, r, 1.0)[:, None]

    signs, margins = (
        np.zeros((n, len(plan.branch_steps)), int),
        np.zeros((n, len(plan.branch_steps))),
    )
    for k, st in enumerate(plan.branch_steps):
        x = pts[st.point]
        if st.op == 'circle_circle':
            _, p1, _, p2 = st.args
            a, b = pts[p1], pts[p2]
            side = dyads.cross2(unit(b - a), unit(x - a))
            m = np.abs(dyads.cross2(unit(x - a), unit(x - b)))
        else:
            pj = plan.mech.prismatics[st.args[0] if st.op == 'line_through' else st.args[2]]
            u = dyads.rotate(
                np.broadcast_to(np.asarray(pj.direction, float), (n, 2)), poses.phi[pj.guide]
            )
            side = np.sum(unit(x - pts[st.args[1]]) * u, axis=-1)
            m = np.abs(side)
        signs[:, k] = np.where(side >= 0, 1, -1)
        margins[:, k] = np.clip(m, 0.0, 1.0)
    return signs, margins
