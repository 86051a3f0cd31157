"""Redraw a general-form scene with stated dimensions: the reference pose closed again with the
new link shapes, every actuator held at its drawn value, in the drawn assembly mode.

The solvers read link shapes from the reference-pose coordinates, so a changed length needs a
consistent new drawing. That is found here by continuation: the stated dimensions are reached
from the drawn ones in steps, each step closing every joint (Newton-type least squares from the
step before), and the sign of the closure Jacobian's determinant must not change on the way:
a sign change means the path crossed a singular (toggle) position, where the assembly mode
could change, and the redraw is refused rather than landing in another mode.

The equations are written here, apart from the solvers', because here the link shapes are the
unknowns' parameters: every link carries its own local copy of a shared point, which the
solvers' equations (one coordinate per point) cannot express.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from ..dyads import circle_side, dyad_point, side_sign, solve_rrr_dyad
from ..errors import SceneError
from ..ops import SCALAR
from .checks import Fail
from .dimensions import LinkDistance, SliderOffset, parse_name
from .mechanism import AngleActuator, Mechanism, SlideActuator

#: the largest closure miss accepted at each continuation step (fraction of the length scale)
CLOSURE_TOL = 1e-12
#: the most continuation steps (halving a step that fails, from 8 equal steps)
MAX_STEPS = 512
#: the smallest continuation step (fraction of the way): a redraw that cannot advance by this
#: much does not close there (it stops at a fold, where every step beyond fails); each
#: failed step of a 64-link scene costs seconds, so the way to the fold is not crept finer
MIN_STEP = 1.0 / 1024
#: the most moving links a redraw takes: it solves one dense system of 3 unknowns per link
#: (the Jansen leg has 7, the excavator 13); a scene of thousands would take hours and GBs
MAX_REDRAW_LINKS = 64


class RedrawRefused(SceneError):
    """The continuation from the drawn lengths to the stated ones stopped closing (the
    dimensions are valid names and values; the pose with them is not reached)."""


@dataclass(frozen=True)
class Redrawn:
    """The new reference pose: every point's coordinates (m), and each slider's line as its
    direction (unit) and origin (m) in the new pose."""

    points: dict[str, tuple[float, float]]
    slider_directions: dict[str, tuple[float, float]]
    slider_origins: dict[str, tuple[float, float]]


class _Shapes:
    """Each link's points in its own frame (the drawn coordinates, the link at angle 0), with
    the stated lengths blended in by ``lam`` (0 = as drawn, 1 = as stated)."""

    def __init__(self, mech: Mechanism, dims: Mapping[str, float], fail: Fail):
        self.mech = mech
        self.drawn = {p: complex(*map(float, xy)) for p, xy in mech.points.items()}
        self.lengths: dict[str, dict[frozenset[str], tuple[float, float]]] = {}
        self.offsets: dict[str, tuple[float, float]] = {}
        for name, value in dims.items():
            dim = parse_name(name)
            if isinstance(dim, LinkDistance):
                self._check_pair(dim, fail, value)
                d0 = abs(self.drawn[dim.p] - self.drawn[dim.q])
                self.lengths.setdefault(dim.link, {})[frozenset((dim.p, dim.q))] = (d0, value)
            elif isinstance(dim, SliderOffset):
                pj = mech.prismatics.get(dim.slider)
                act = mech.actuators.get(dim.slider)
                if pj is None or (
                    isinstance(act, SlideActuator) and act.cylinder
                ):  # a cylinder has no offset
                    fail(name, f'{dim.slider!r} is not a slider of {mech.name!r}', value)
                assert pj is not None  # fail raises
                u = complex(*pj.direction)
                off0 = ((self.drawn[pj.point] - complex(*pj.origin)) * u.conjugate()).imag
                if off0 == 0.0 and self.drawn[pj.point] == complex(*pj.origin):
                    fail(
                        name,
                        f'slider {dim.slider!r} measures from its own point (no `origin`): '
                        'give it an origin in the guide to measure the offset from',
                        value,
                    )
                self.offsets[dim.slider] = (off0, value)
        for link, pairs in self.lengths.items():
            shape = self.local(link, 1.0, fail)
            for pair, (_, want) in pairs.items():
                p, q = sorted(pair)
                if not math.isfinite(abs(shape[p] - shape[q])):
                    fail(f'{link}.{p}-{q}', 'puts the link beyond the float range', want)

    def _check_pair(self, dim: LinkDistance, fail: Fail, value: object) -> None:
        link = self.mech.links.get(dim.link)
        if link is None:
            fail(dim.name, f'{dim.link!r} is not a link of {self.mech.name!r}', value)
            return
        pts = link.points
        for p in (dim.p, dim.q):
            if p not in pts:
                fail(dim.name, f'{p!r} is not a point of link {dim.link!r} {list(pts)}', value)
        defining = {frozenset(pts[:2])} | {
            frozenset((pts[i], pts[k])) for k in range(2, len(pts)) for i in (0, 1)
        }
        if frozenset((dim.p, dim.q)) not in defining:
            names = ', '.join(sorted(f'{dim.link}.{"-".join(sorted(d))}' for d in defining))
            fail(
                dim.name,
                f'a link is dimensioned by the distances of each point from its first two '
                f'points; for {dim.link!r} those are {names}',
                value,
            )

    def local(self, link: str, lam: float, fail: Fail | None = None) -> dict[str, complex]:
        """Link ``link``'s points at blend ``lam``: its first point and axis direction stay
        where drawn, each further point is placed by its distances from the first two on the
        side it is drawn (the two-circle construction)."""
        pts = self.mech.links[link].points
        pairs = self.lengths.get(link)
        if not pairs:
            return {p: self.drawn[p] for p in pts}

        def length(p: str, q: str) -> float:
            d0, d1 = pairs.get(frozenset((p, q)), (abs(self.drawn[p] - self.drawn[q]),) * 2)
            return d0 + lam * (d1 - d0)

        z0, z1 = self.drawn[pts[0]], self.drawn[pts[1]]
        axis = (z1 - z0) / abs(z1 - z0)
        d01 = length(pts[0], pts[1])
        out = {pts[0]: z0, pts[1]: z0 + d01 * axis}
        for p in pts[2:]:
            # the side it is drawn on, by the dyads' own branch-side rule (side_sign)
            drawn_side = side_sign(circle_side(SCALAR, z0, z1, self.drawn[p]))
            r0, r1 = length(pts[0], p), length(pts[1], p)
            # the dyad solver's own circle-circle construction (Kahan's triangle height)
            pair = solve_rrr_dyad(SCALAR, out[pts[0]], r0, out[pts[1]], r1)
            z, ok = dyad_point(SCALAR, pair, float(drawn_side))
            if not ok and fail is not None:
                # blame a side the user stated (the last: the point's own), not always P0-p
                sides = [(pts[0], pts[1], d01), (pts[0], p, r0), (pts[1], p, r1)]
                stated = [side for side in sides if frozenset(side[:2]) in pairs]
                blamed_p, blamed_q, blamed = stated[-1] if stated else sides[1]
                fail(
                    f'{link}.{blamed_p}-{blamed_q}',
                    f'with {link}.{pts[0]}-{pts[1]} = {d01:.9g}, {link}.{pts[0]}-{p} = '
                    f'{r0:.9g} and {link}.{pts[1]}-{p} = {r1:.9g} the link is no triangle '
                    '(one side is longer than the other two together)',
                    blamed,
                )
            out[p] = z
        return out

    def offset_shift(self, slider: str, lam: float) -> float:
        off0, off1 = self.offsets.get(slider, (0.0, 0.0))
        return lam * (off1 - off0)


class _Closure:
    """The reference pose's closure equations with the shapes at one blend: every joint closed,
    every actuator at its drawn value. Unknowns: each moving link's (phi, x / L, y / L) from its
    drawn place; residuals in units of the length scale."""

    def __init__(self, mech: Mechanism, shapes: _Shapes):
        self.mech, self.shapes = mech, shapes
        self.links = mech.moving_links
        self.index = {l: i for i, l in enumerate(self.links)}
        self.L = mech.length_scale
        self.set_blend(0.0)
        self.held = self._actuators(np.zeros(3 * len(self.links)))
        self.groups = self._column_groups()
        rows = self._row_links()
        #: the residual rows of each unknown (those of its link)
        self.rows_of = [
            np.array([r for r, row in enumerate(rows) if self.links[c // 3] in row], int)
            for c in range(3 * len(self.links))
        ]

    def _row_links(self) -> list[tuple[str, str]]:
        """The links each residual row depends on (the order of :meth:`residual`)."""
        mech = self.mech
        rows: list[tuple[str, str]] = []
        for rj in mech.revolutes:
            rows += [(rj.parent, rj.child)] * 2
        for pj in mech.prismatics.values():
            rows += [(pj.guide, pj.slider)] * 2
        for act in mech.actuators.values():
            if isinstance(act, SlideActuator):
                pj = mech.prismatics[act.joint]
                rows.append((pj.guide, pj.slider))
            else:
                rows.append((str(act.link), str(act.reference)))
        return rows

    def _column_groups(self) -> list[np.ndarray]:
        """The unknowns in groups no two of which share a residual row (greedy colouring of
        the links: a row touches at most two links), so a finite-difference Jacobian costs one
        residual per group and not one per unknown (a chain of 63 links: a handful, not 189)."""
        neighbours: dict[str, set[str]] = {l: set() for l in self.links}
        for row in self._row_links():
            moving = [l for l in row if l in self.index]
            for a in moving:
                neighbours[a].update(b for b in moving if b != a)
        colour: dict[str, int] = {}
        for link in self.links:
            taken = {colour[b] for b in neighbours[link] if b in colour}
            colour[link] = next(c for c in range(len(self.links) + 1) if c not in taken)
        groups = []
        for c in sorted(set(colour.values())):
            members = [self.index[l] for l in self.links if colour[l] == c]
            for k in range(3):  # phi, x, y of each link apart (they share the link's rows)
                groups.append(np.array([3 * i + k for i in members]))
        return groups

    def jacobian(self, x: np.ndarray, h: float = 1e-7) -> np.ndarray:
        """d residual / d x by central differences, one pair of residuals per column group."""
        n = len(x)
        jac = np.zeros((len(self.residual(x)), n))
        for cols in self.groups:
            e = np.zeros(n)
            e[cols] = h
            diff = (self.residual(x + e) - self.residual(x - e)) / (2 * h)
            for c in cols:
                mine = self.rows_of[c]
                jac[mine, c] = diff[mine]
        return jac

    def set_blend(self, lam: float) -> None:
        self.local = {l: self.shapes.local(l, lam) for l in self.mech.links}
        self.lines = {
            j: complex(*pj.direction) * 1j * self.shapes.offset_shift(j, lam)
            for j, pj in self.mech.prismatics.items()
        }
        self.arrays = _Arrays(self)

    def pose(self, x: np.ndarray, link: str) -> tuple[complex, complex]:
        """(rotation, translation) of ``link``: world = rotation * local + translation."""
        i = self.index.get(link)
        if i is None:
            return 1 + 0j, 0j
        phi, tx, ty = x[3 * i : 3 * i + 3]
        return complex(math.cos(phi), math.sin(phi)), complex(tx, ty) * self.L

    def angle(self, x: np.ndarray, link: str) -> float:
        i = self.index.get(link)
        return float(x[3 * i]) if i is not None else 0.0

    def world(self, x: np.ndarray, link: str, p: str) -> complex:
        rot, t = self.pose(x, link)
        return rot * self.local[link][p] + t

    def _line(self, x: np.ndarray, j: str) -> tuple[complex, complex, complex]:
        """Slider j's line in the world: (a point on it, its unit direction, its origin)."""
        pj = self.mech.prismatics[j]
        rot, t = self.pose(x, pj.guide)
        u = complex(*pj.direction)
        base = self.shapes.drawn[pj.point] + self.lines[j]
        return rot * base + t, rot * u, rot * complex(*pj.origin) + t

    def _actuators(self, x: np.ndarray) -> np.ndarray:
        """Each actuator's value (rad, or m / L), in the order of ``mech.actuators``."""
        a = self.arrays
        rot, T, phi = a.poses(x)
        out = np.zeros(len(a.is_angle))
        if a.s_idx.size:
            u = rot[a.s_guide] * a.s_dir
            origin = rot[a.s_guide] * a.s_origin + T[a.s_guide]
            at = rot[a.s_slider] * a.s_local + T[a.s_slider]
            out[a.s_idx] = ((at - origin) * u.conj()).real / self.L
        if a.a_idx.size:
            v = rot[a.a_link] * a.a_arm
            base = np.where(a.a_ref_is_ground, 0.0, a.a_ref_angle + phi[a.a_ref])
            out[a.a_idx] = np.arctan2(v.imag, v.real) - base
        return out

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Every joint's closure and every actuator's turn from its drawn value (rows: each
        revolute's x, y miss, each slider's miss off its line and turn against its guide, each
        actuator), in units of the length scale and rad; one numpy pass over the joints."""
        a = self.arrays
        rot, T, phi = a.poses(x)
        d = rot[a.r_parent] * a.r_parent_local + T[a.r_parent]
        d = d - (rot[a.r_child] * a.r_child_local + T[a.r_child])
        revolute = np.column_stack([d.real, d.imag]).ravel() / self.L
        on = rot[a.p_guide] * a.p_base + T[a.p_guide]
        u = rot[a.p_guide] * a.p_dir
        at = rot[a.p_slider] * a.p_local + T[a.p_slider]
        slide = np.column_stack(
            [((at - on) * u.conj()).imag / self.L, phi[a.p_slider] - phi[a.p_guide]]
        ).ravel()
        turn = self._actuators(x) - self.held
        turn = np.array(
            [math.remainder(t, 2 * math.pi) if ang else t for t, ang in zip(turn, a.is_angle)]
        )
        return np.concatenate([revolute, slide, turn])


class _Arrays:
    """The closure's joints as index and coordinate arrays at one blend (the vectorised
    residual's): link index ``len(links)`` is the fixed frame (the ground)."""

    def __init__(self, c: _Closure):
        mech, local, fixed = c.mech, c.local, len(c.links)

        def at(link: str) -> int:
            return c.index.get(link, fixed)

        def ints(v: list[int]) -> np.ndarray:
            return np.array(v, int)

        def cplx(v: list[complex]) -> np.ndarray:
            return np.array(v, complex)

        self.n = fixed
        self.L = c.L
        rv = mech.revolutes
        self.r_parent = ints([at(j.parent) for j in rv])
        self.r_child = ints([at(j.child) for j in rv])
        self.r_parent_local = cplx([local[j.parent][j.point] for j in rv])
        self.r_child_local = cplx([local[j.child][j.point] for j in rv])
        pr = list(mech.prismatics.values())
        self.p_guide = ints([at(pj.guide) for pj in pr])
        self.p_slider = ints([at(pj.slider) for pj in pr])
        self.p_base = cplx([c.shapes.drawn[pj.point] + c.lines[pj.name] for pj in pr])
        self.p_dir = cplx([complex(*pj.direction) for pj in pr])
        self.p_local = cplx([local[pj.slider][pj.point] for pj in pr])
        acts = list(mech.actuators.values())
        self.is_angle = [isinstance(act, AngleActuator) for act in acts]
        slides = [
            (i, mech.prismatics[a.joint])
            for i, a in enumerate(acts)
            if isinstance(a, SlideActuator)
        ]
        self.s_idx = ints([i for i, _ in slides])
        self.s_guide = ints([at(pj.guide) for _, pj in slides])
        self.s_slider = ints([at(pj.slider) for _, pj in slides])
        self.s_dir = cplx([complex(*pj.direction) for _, pj in slides])
        self.s_origin = cplx([complex(*pj.origin) for _, pj in slides])
        self.s_local = cplx([local[pj.slider][pj.point] for _, pj in slides])
        angles = [(i, a) for i, a in enumerate(acts) if isinstance(a, AngleActuator)]
        self.a_idx = ints([i for i, _ in angles])
        self.a_link = ints([at(str(a.link)) for _, a in angles])
        self.a_arm = cplx(
            [
                local[str(a.link)][str(a.toward)] - local[str(a.link)][str(a.pivot)]
                for _, a in angles
            ]
        )
        self.a_ref = ints([at(str(a.reference)) for _, a in angles])
        self.a_ref_is_ground = np.array([a.reference == mech.ground for _, a in angles], bool)
        self.a_ref_angle = np.array(
            [
                0.0 if a.reference == mech.ground else mech.links[a.reference].angle_ref
                for _, a in angles
            ]
        )

    def poses(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotation, translation (m), angle) of every link, the fixed frame last."""
        phi = np.append(x[0::3], 0.0)
        T = np.append((x[1::3] + 1j * x[2::3]) * self.L, 0j)
        return np.cos(phi) + 1j * np.sin(phi), T, phi


def redraw(mech: Mechanism, dims: Mapping[str, float]) -> Redrawn:
    """The reference pose of ``mech`` redrawn with the stated dimensions ``dims`` (names as
    :func:`.dimensions.parse_name` reads them, values in m). Raises SceneError naming the
    dimension when a name does not fit the mechanism, a link cannot take the lengths, or the
    pose cannot be closed in the drawn assembly mode with the actuators at their drawn values."""

    def fail(name: str, message: str, value: object) -> NoReturn:
        raise SceneError(message, file=mech.source, key=f'dimensions.{name}', value=value)

    if len(mech.moving_links) > MAX_REDRAW_LINKS:
        raise SceneError(
            f'stated dimensions redraw the mechanism by one dense solve, for at most '
            f'{MAX_REDRAW_LINKS} moving links; this one has {len(mech.moving_links)}: draw it '
            'with the lengths instead',
            file=mech.source,
            key='dimensions',
            value=sorted(dims)[:3],
        )
    shapes = _Shapes(mech, dims, fail)
    closure = _Closure(mech, shapes)
    shown = [f'{k} = {v:g} m' for k, v in list(dims.items())[:3]]
    names = ', '.join(shown) + (f' and {len(dims) - 3} more' if len(dims) > 3 else '')
    x = np.zeros(3 * len(closure.links))
    sign = _orientation(closure, x)
    lam, step, steps, failed = 0.0, 1.0 / 8, 0, False
    while lam < 1.0:
        steps += 1
        if steps > MAX_STEPS or step < MIN_STEP:
            held = ' with every actuator held at its drawn value' if mech.actuators else ''
            raise RedrawRefused(
                f'the drawn pose cannot be closed with {names}: at {lam:.0%} of the way from '
                f'the drawn lengths the mechanism stops closing{held} (it would not assemble, '
                'or would pass a toggle position and change assembly mode); redraw the '
                'reference pose nearer the new dimensions',
                file=mech.source,
                key='dimensions',
                value=dict(dims),
            )
        nxt = min(1.0, lam + step)
        closure.set_blend(nxt)
        got = _close(closure, x)
        if got is None or (sign != 0 and _orientation(closure, got) != sign):
            step, failed = step / 2, True
            continue
        # after a failure the step grows again only once one has succeeded at its size: the
        # way to a fold is halved, not retried at double the step after each success
        x, lam = got, nxt
        step, failed = (step if failed else min(2 * step, 1.0 / 8)), False
    return _read(closure, x)


def _close(closure: _Closure, x0: np.ndarray) -> np.ndarray | None:
    """The closed pose nearest ``x0`` at the current blend, or None where it does not close."""
    if not len(x0):
        return x0
    from scipy.optimize import least_squares  # only a redraw needs it (0.4 s to import)

    with np.errstate(all='ignore'):
        sol = least_squares(
            closure.residual,
            x0,
            jac=closure.jacobian,
            method='lm',
            xtol=1e-15,
            ftol=1e-15,
            gtol=1e-15,
            max_nfev=400,
        )
    miss = closure.residual(sol.x)
    if not np.all(np.isfinite(miss)) or float(np.max(np.abs(miss), initial=0.0)) > CLOSURE_TOL:
        return None
    return np.asarray(sol.x, float)


def _orientation(closure: _Closure, x: np.ndarray) -> int:
    """The sign of the closure Jacobian's determinant (central differences): it changes only
    through a singular position, where the assembly mode can change."""
    n = len(x)
    if not n:
        return 0
    jac = closure.jacobian(x)
    s, logdet = np.linalg.slogdet(jac)
    return int(s) if math.isfinite(logdet) and logdet > n * math.log(1e-9) else 0


def _read(closure: _Closure, x: np.ndarray) -> Redrawn:
    mech = closure.mech
    points = {}
    for p in mech.points:
        link = mech.links_of_point(p)[0]
        z = closure.world(x, link, p)
        points[p] = (z.real, z.imag)
    directions, origins = {}, {}
    for j in mech.prismatics:
        _, u, origin = closure._line(x, j)
        directions[j] = (u.real, u.imag)
        origins[j] = (origin.real, origin.imag)
    return Redrawn(points, directions, origins)
