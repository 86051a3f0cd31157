"""Redraw a general-form scene with stated dimensions: the reference pose closed again with the
new link shapes, every actuator held at its drawn value, in the drawn assembly mode.

The solvers read link shapes from the reference-pose coordinates, so a changed length needs a
consistent new drawing. That is found here by continuation: the stated dimensions are reached
from the drawn ones in steps, each step closing every joint by the Newton module's solve from
the step before (core.newton: a root of the square closure to CLOSURE_TOL of the length scale,
not a least-squares fit), and the sign of the closure Jacobian's determinant must not change on
the way: a sign change means the path crossed a singular (toggle) position, where the assembly
mode could change, and the redraw is refused rather than landing in another mode.

The equations are the solvers' own loop tables, compiled with each link's own shape
(core.newton.tables.LinkShapes): part of the way to the new lengths the links disagree on
where their shared points are, so every link carries its own copy of each of its points.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from ..dyads import circle_side, dyad_point, side_sign, solve_rrr_dyad
from ..errors import SceneError
from ..mechanism import AngleActuator, Mechanism, SlideActuator
from ..newton.results import FAST_FLOOR
from ..newton.scalar import solve, solve_from_guess
from ..newton.tables import LinkShapes, compile_tables
from ..ops import SCALAR
from ..quantities import AngleSpec, SlideSpec
from .checks import Fail
from .dimensions import LinkDistance, SliderOffset, parse_name

#: the largest closure miss accepted at each continuation step (fraction of the length scale)
CLOSURE_TOL = 1e-12
#: the most continuation steps (halving a step that fails, from 8 equal steps)
MAX_STEPS = 512
#: the smallest continuation step (fraction of the way): a redraw that cannot advance by this
#: much does not close there (it stops at a fold, where every step beyond fails); a failed
#: step costs a whole careful Newton solve, so the way to the fold is not crept finer
MIN_STEP = 1.0 / 1024
#: the most Newton iterations of one continuation step: a step that closes does so in a handful
#: (4-5 on the scenes, from the step before); one that has not in this many is at or past a
#: fold, and is halved (each careful iteration of a 64-link scene costs milliseconds)
MAX_ITERATIONS = 10
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
    """The reference pose's closure equations with the shapes at one blend, as the Newton
    module's loop tables (core.newton.tables, compiled with each link's own shape): every
    joint closed, every actuator held at its drawn value. Unknowns: each moving link's rotation
    phi (rad) from its drawn place and the position (m) of its drawn points' centroid; rows in
    units of the length scale (angles in rad)."""

    def __init__(self, mech: Mechanism, shapes: _Shapes):
        self.mech, self.shapes = mech, shapes
        self.links = mech.moving_links
        self.drawn_arm = {
            a.name: self._arm(a, shapes.local(a.link, 0.0))
            for a in mech.actuators.values()
            if isinstance(a, AngleActuator)
        }
        # a slide actuator's value as drawn (m); an angle actuator's is the turn 0 of its arm
        self.values: list[float] = [
            self._slide_drawn(a) if isinstance(a, SlideActuator) else 0.0
            for a in mech.actuators.values()
        ]
        #: the drawn pose's det J sign (the assembly mode kept), 0: singular there, untracked
        self.sign = 0
        self.set_blend(0.0)

    @staticmethod
    def _arm(act: AngleActuator, local: Mapping[str, complex]) -> complex:
        return local[act.toward] - local[act.pivot]

    def _slide_drawn(self, act: SlideActuator) -> float:
        pj = self.mech.prismatics[act.joint]
        at = self.shapes.drawn[pj.point] - complex(*pj.origin)
        return (at * complex(*pj.direction).conjugate()).real

    def set_blend(self, lam: float) -> None:
        """Compile the closure with the shapes at blend ``lam``: an angle actuator holds its
        arm's drawn direction, so its known turn is offset by how far the new shape turned the
        arm in the link's frame."""
        mech = self.mech
        self.local = {l: self.shapes.local(l, lam) for l in mech.links}
        specs: list[AngleSpec | SlideSpec] = []
        for act in mech.actuators.values():
            if isinstance(act, SlideActuator):
                specs.append(SlideSpec(act.name, act.joint))
            else:
                arm0 = self.drawn_arm[act.name]
                turn = self._arm(act, self.local[act.link]) / arm0 if arm0 else 1.0
                specs.append(AngleSpec(act.name, act.link, act.reference, cmath.phase(turn)))
        lines = {
            j: _xy(self.shapes.drawn[pj.point] + complex(*pj.direction) * 1j * shift)
            for j, pj in mech.prismatics.items()
            if (shift := self.shapes.offset_shift(j, lam))
        }
        shapes = LinkShapes(
            {l: {p: _xy(z) for p, z in pts.items()} for l, pts in self.local.items()}, lines
        )
        self.tables = compile_tables(mech, specs, self.links, shapes=shapes)

    def reference(self) -> np.ndarray:
        """The drawn pose: every link unturned, at its drawn centroid."""
        t = self.tables
        x = np.zeros(t.n)
        for l, i in t.index.items():
            x[3 * i + 1 : 3 * i + 3] = t.centroid[l]
        return x

    def pose(self, x: np.ndarray, link: str) -> tuple[complex, complex]:
        """(rotation, translation) of ``link``: world = rotation * local + translation."""
        t = self.tables
        i = t.index.get(link)
        if i is None:
            return 1 + 0j, 0j
        phi, cx, cy = x[3 * i : 3 * i + 3]
        rot = complex(math.cos(phi), math.sin(phi))
        o = t.centroid[link]
        return rot, complex(cx, cy) - rot * complex(o[0], o[1])

    def world(self, x: np.ndarray, link: str, p: str) -> complex:
        rot, t = self.pose(x, link)
        return rot * self.local[link][p] + t

    def line(self, x: np.ndarray, j: str) -> tuple[complex, complex]:
        """Slider j's line in the world: (its unit direction, its origin)."""
        pj = self.mech.prismatics[j]
        rot, t = self.pose(x, pj.guide)
        return rot * complex(*pj.direction), rot * complex(*pj.origin) + t


def _xy(z: complex) -> tuple[float, float]:
    return z.real, z.imag


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
    x = closure.reference()
    sign = closure.sign = _orientation(closure, x)
    lam, step, steps, failed = 0.0, 1.0 / 8, 0, False
    while lam < 1.0:
        steps += 1
        if steps > MAX_STEPS or step < MIN_STEP:
            held = ' with every actuator held at its drawn value' if mech.actuators else ''
            raise RedrawRefused(
                f'the drawn pose cannot be closed with {names}: at {lam:.0%} of the way from '
                f'the drawn lengths the mechanism stops closing{held} (it would not assemble, '
                'or would pass a toggle position and change assembly mode); if these lengths '
                'close in some pose, redraw the reference pose nearer it (a coupler longer '
                'than the other links together closes in none)',
                file=mech.source,
                key='dimensions',
                value=dict(dims),
            )
        nxt = min(1.0, lam + step)
        closure.set_blend(nxt)
        got = close_redraw(closure, x)
        if got is None or (sign != 0 and _orientation(closure, got) != sign):
            step, failed = step / 2, True
            continue
        # after a failure the step grows again only once one has succeeded at its size: the
        # way to a fold is halved, not retried at double the step after each success
        x, lam = got, nxt
        step, failed = (step if failed else min(2 * step, 1.0 / 8)), False
    return _read(closure, x)


def close_redraw(closure: _Closure, x0: np.ndarray) -> np.ndarray | None:
    """The closed pose nearest ``x0`` at the current blend, or None where it does not close.
    Solved by the Newton module (core.newton.scalar.solve over the loop tables): Newton steps on
    the analytic Jacobian with a backtracking line search, Levenberg-Marquardt where they stall
    (Gauss-Newton least squares where rows outnumber unknowns), every accepted point kept on
    the drawn side of det J = 0 (``closure.sign``; 0: any). Success means every row closes to
    max|F| <= CLOSURE_TOL of the length scale (rad for the held angles): the least-squares
    minimum of a pose that cannot close is no answer, it is None. A closed pose then goes on
    by the module's fast path (solve_from_guess: Newton steps while each cuts max|F| tenfold)
    to FAST_FLOOR, about the rounding floor, where it gets there (else it stays as closed):
    the redrawn points are the new drawing the solvers read link lengths from, so they close
    as well as floating point allows, not just inside the tolerance."""
    if not len(x0):
        return x0
    with np.errstate(all='ignore'):
        got = solve(
            closure.tables,
            x0,
            closure.values,
            tol=CLOSURE_TOL,
            max_iter=MAX_ITERATIONS,
            start_sign=closure.sign,
        )
        if not got.success:
            return None
        tight = solve_from_guess(
            closure.tables, got.x, closure.values, tol=FAST_FLOOR, start_sign=closure.sign
        )
    return tight.x if tight.success else got.x


def _orientation(closure: _Closure, x: np.ndarray) -> int:
    """The sign of the closure Jacobian's determinant (the Newton module's, 0 where it is
    singular): it changes only through a singular position, where the assembly mode can
    change."""
    if not len(x):
        return 0
    from ..newton.scalar import det_sign_at  # here: see _Closure.set_blend

    with np.errstate(all='ignore'):
        return det_sign_at(closure.tables, x, closure.values)


def _read(closure: _Closure, x: np.ndarray) -> Redrawn:
    mech = closure.mech
    points = {}
    for p in mech.points:
        link = mech.links_of_point(p)[0]
        z = closure.world(x, link, p)
        points[p] = (z.real, z.imag)
    directions, origins = {}, {}
    for j in mech.prismatics:
        u, origin = closure.line(x, j)
        directions[j] = (u.real, u.imag)
        origins[j] = (origin.real, origin.imag)
    return Redrawn(points, directions, origins)
