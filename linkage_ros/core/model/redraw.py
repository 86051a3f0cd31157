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

import numpy as np

from ..dyads import dyad_point, solve_rrr_dyad
from ..errors import SceneError
from ..ops import SCALAR
from .dimensions import LinkDistance, SliderOffset, parse_name
from .mechanism import AngleActuator, Mechanism, SlideActuator

#: the largest closure miss accepted at each continuation step (fraction of the length scale)
CLOSURE_TOL = 1e-12
#: the most continuation steps (halving a step that fails, from 8 equal steps)
MAX_STEPS = 512
#: the most moving links a redraw takes: it solves one dense system of 3 unknowns per link
#: (the Jansen leg has 7, the excavator 13); a scene of thousands would take hours and GBs
MAX_REDRAW_LINKS = 64


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

    def __init__(self, mech: Mechanism, dims: Mapping[str, float], fail):
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

    def _check_pair(self, dim: LinkDistance, fail, value) -> None:
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

    def local(self, link: str, lam: float, fail=None) -> dict[str, complex]:
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
            drawn_side = ((self.drawn[p] - z0) * axis.conjugate()).imag
            r0, r1 = length(pts[0], p), length(pts[1], p)
            # the dyad solver's own circle-circle construction (Kahan's triangle height)
            pair = solve_rrr_dyad(SCALAR, out[pts[0]], r0, out[pts[1]], r1)
            z, ok = dyad_point(SCALAR, pair, -1.0 if drawn_side < 0 else 1.0)
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

    def set_blend(self, lam: float) -> None:
        self.local = {l: self.shapes.local(l, lam) for l in self.mech.links}
        self.lines = {
            j: complex(*pj.direction) * 1j * self.shapes.offset_shift(j, lam)
            for j, pj in self.mech.prismatics.items()
        }

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
        mech, out = self.mech, []
        for act in mech.actuators.values():
            if isinstance(act, SlideActuator):
                pj = mech.prismatics[act.joint]
                _, u, origin = self._line(x, pj.name)
                at = self.world(x, pj.slider, pj.point)
                out.append(((at - origin) * u.conjugate()).real / self.L)
            else:
                link, ref = str(act.link), str(act.reference)
                v = self.world(x, link, str(act.toward)) - self.world(x, link, str(act.pivot))
                base = 0.0 if ref == mech.ground else mech.links[ref].angle_ref + self.angle(x, ref)
                out.append(math.atan2(v.imag, v.real) - base)
        return np.array(out)

    def residual(self, x: np.ndarray) -> np.ndarray:
        mech, out = self.mech, []
        for rj in mech.revolutes:
            d = self.world(x, rj.parent, rj.point) - self.world(x, rj.child, rj.point)
            out += [d.real / self.L, d.imag / self.L]
        for j, pj in mech.prismatics.items():
            on, u, _ = self._line(x, j)
            at = self.world(x, pj.slider, pj.point)
            out.append(((at - on) * u.conjugate()).imag / self.L)
            out.append(self.angle(x, pj.slider) - self.angle(x, pj.guide))
        turn = self._actuators(x) - self.held
        is_angle = [isinstance(a, AngleActuator) for a in mech.actuators.values()]
        out += [math.remainder(t, 2 * math.pi) if a else t for t, a in zip(turn, is_angle)]
        return np.array(out)


def redraw(mech: Mechanism, dims: Mapping[str, float]) -> Redrawn:
    """The reference pose of ``mech`` redrawn with the stated dimensions ``dims`` (names as
    :func:`.dimensions.parse_name` reads them, values in m). Raises SceneError naming the
    dimension when a name does not fit the mechanism, a link cannot take the lengths, or the
    pose cannot be closed in the drawn assembly mode with the actuators at their drawn values."""

    def fail(name: str, message: str, value: object) -> None:
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
    lam, step, steps = 0.0, 1.0 / 8, 0
    while lam < 1.0:
        steps += 1
        if steps > MAX_STEPS or step < 1.0 / (1 << 20):
            raise SceneError(
                f'the drawn pose cannot be closed with {names}: at {lam:.0%} of the way from '
                'the drawn lengths the mechanism stops closing with every actuator held at its '
                'drawn value (it would not assemble, or would pass a toggle position and change '
                'assembly mode); redraw the reference pose nearer the new dimensions',
                file=mech.source,
                key='dimensions',
                value=dict(dims),
            )
        nxt = min(1.0, lam + step)
        closure.set_blend(nxt)
        got = _close(closure, x)
        if got is None or (sign != 0 and _orientation(closure, got) != sign):
            step /= 2
            continue
        x, lam, step = got, nxt, min(2 * step, 1.0 / 8)
    return _read(closure, x)


def _close(closure: _Closure, x0: np.ndarray) -> np.ndarray | None:
    """The closed pose nearest ``x0`` at the current blend, or None where it does not close."""
    if not len(x0):
        return x0
    from scipy.optimize import least_squares  # only a redraw needs it (0.4 s to import)

    with np.errstate(all='ignore'):
        sol = least_squares(
            closure.residual, x0, method='lm', xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=400
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
    h = 1e-7
    jac = np.empty((n, n))
    for k in range(n):
        e = np.zeros(n)
        e[k] = h
        jac[:, k] = (closure.residual(x + e) - closure.residual(x - e)) / (2 * h)
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
