"""The 50-digit mpmath reference, written from the scene independently of the core."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.model import SlideActuator
from .settings import REF_DPS

# =============================================================================================
# 50-digit reference, independent of the code under test
# =============================================================================================


# The equations (mpmath numbers; points by name, unknown or on the ground). Each is one residual
# row, Rigid two.
@dataclass(frozen=True)
class Distance:
    """|q - p|^2 = d2 (m^2)."""

    p: str
    q: str
    d2: Any


@dataclass(frozen=True)
class Rigid:
    """pj = p0 + a (p1 - p0) + b perp(p1 - p0): a further point of a rigid link."""

    p0: str
    p1: str
    pj: str
    a: Any
    b: Any


@dataclass(frozen=True)
class OnLine:
    """normal . p = c (m): a point on a fixed line, or a slide's value along it."""

    p: str
    normal: tuple[Any, Any]
    c: Any


@dataclass(frozen=True)
class Direction:
    """-sin v (q - p)_x + cos v (q - p)_y = 0: p -> q points along the angle v."""

    p: str
    q: str
    minus_sin: Any
    cos: Any


Equation = Distance | Rigid | OnLine | Direction


# The inputs: where an actuator's value sets an equation (``row``: its index in the list).
@dataclass(frozen=True)
class AngleInput:
    """An angle actuator measured from the ground: pivot -> toward along the value (rad)."""

    actuator: str
    row: int
    pivot: str
    toward: str


@dataclass(frozen=True)
class CylinderInput:
    """A cylinder's throw (m): the distance between its barrel pin and its rod pin."""

    actuator: str
    row: int
    barrel_pin: str
    rod_pin: str


@dataclass(frozen=True)
class SlideInput:
    """A slide on a fixed line: direction . X = value + direction . origin (m)."""

    actuator: str
    row: int
    direction: tuple[Any, Any]
    origin_along: Any


Input = AngleInput | CylinderInput | SlideInput


class MpReference:
    """The scene's position constraints in mpmath, unknowns = world positions of every point
    that is not on the ground link; solved by Newton with an analytic Jacobian at ``dps`` digits,
    started from a double-precision answer.

    Equations, written here from the scene description (points, links, joints, actuators):

    * a link with points p0, p1, p2, ...: |p1 - p0|^2 = d^2 and, for every further point,
      pj = p0 + a (p1 - p0) + b perp(p1 - p0) with (a, b) its reference-pose coordinates in the
      frame spanned by p1 - p0 (rigidity without a reflection ambiguity);
    * a prismatic joint whose guide is the ground: the slider point stays on the fixed line
      (n . (X - X_ref) = 0; an actuated one also d . (X - origin) = value);
    * a hydraulic cylinder (one-point barrel and rod links): |rod pin - barrel pin| = throw;
    * an angle actuator measured from the ground: the pivot -> toward direction of its link is
      the commanded angle (-sin v (T - P)_x + cos v (T - P)_y = 0).

    Anything else raises NotImplementedError: the reference only covers what it was written for.
    """

    def __init__(self, mech, dps: int = REF_DPS):
        import mpmath

        self.mpmath = mpmath
        self.dps = dps
        self.mech = mech
        with mpmath.workdps(dps):
            ground_pts = set(mech.links[mech.ground].points)
            self.names = list(mech.points)
            self.unknown = [p for p in self.names if p not in ground_pts]
            self.col = {p: 2 * i for i, p in enumerate(self.unknown)}
            self.fixed = {
                p: (mpmath.mpf(float(mech.points[p][0])), mpmath.mpf(float(mech.points[p][1])))
                for p in ground_pts
            }
            ref = {
                p: (mpmath.mpf(float(v[0])), mpmath.mpf(float(v[1])))
                for p, v in mech.points.items()
            }
            self.eqs: list[Equation | None] = []  # None: an input's row, set per solve
            for lname, link in mech.links.items():
                if lname == mech.ground or len(link.points) < 2:
                    continue
                p0, p1 = link.points[0], link.points[1]
                ux, uy = ref[p1][0] - ref[p0][0], ref[p1][1] - ref[p0][1]
                self.eqs.append(Distance(p0, p1, ux * ux + uy * uy))
                n2 = ux * ux + uy * uy
                for pj in link.points[2:]:
                    vx, vy = ref[pj][0] - ref[p0][0], ref[pj][1] - ref[p0][1]
                    a = (vx * ux + vy * uy) / n2
                    b = (ux * vy - uy * vx) / n2
                    self.eqs.append(Rigid(p0, p1, pj, a, b))
            self.inputs: list[Input] = []
            actuated_joint = {
                a.joint: name for name, a in mech.actuators.items() if isinstance(a, SlideActuator)
            }
            for pj in mech.prismatics.values():
                g, s = mech.links[pj.guide], mech.links[pj.slider]
                act = actuated_joint.get(pj.name)
                if pj.guide == mech.ground and len(s.points) == 1:
                    d = (mpmath.mpf(pj.direction[0]), mpmath.mpf(pj.direction[1]))
                    X = pj.point
                    self.eqs.append(OnLine(X, (-d[1], d[0]), -d[1] * ref[X][0] + d[0] * ref[X][1]))
                    if act is not None:
                        o = pj.origin
                        self.inputs.append(
                            SlideInput(act, len(self.eqs), d, d[0] * o[0] + d[1] * o[1])
                        )
                        self.eqs.append(None)
                elif len(g.points) == 1 and len(s.points) == 1:
                    base = g.points[0]
                    if (
                        np.hypot(*(np.asarray(pj.origin) - mech.points[base]))
                        > 1e-12 * mech.length_scale
                    ):
                        raise NotImplementedError(
                            f'prismatic {pj.name}: origin is not the barrel pin'
                        )
                    if act is None:
                        continue  # a free cylinder: no constraint between its two pins
                    self.inputs.append(CylinderInput(act, len(self.eqs), base, pj.point))
                    self.eqs.append(None)
                else:
                    raise NotImplementedError(f'prismatic joint {pj.name!r} of this shape')
            for name, a in mech.actuators.items():
                if isinstance(a, SlideActuator):
                    continue
                if a.reference != mech.ground:
                    raise NotImplementedError(f'angle actuator {name!r} relative to a moving link')
                self.inputs.append(AngleInput(name, len(self.eqs), a.pivot, a.toward))
                self.eqs.append(None)
            n_rows = sum(2 if isinstance(e, Rigid) else 1 for e in self.eqs)
            if n_rows != 2 * len(self.unknown):
                raise NotImplementedError(
                    f'{mech.name}: {n_rows} equations for {2 * len(self.unknown)} unknowns'
                )
            self.n = n_rows

    def _equations(self, values: dict[str, float]) -> list[Equation]:
        mpf = self.mpmath.mpf
        eqs = list(self.eqs)
        for item in self.inputs:
            v = mpf(float(values[item.actuator]))
            match item:
                case AngleInput(pivot=p, toward=q):
                    eqs[item.row] = Direction(p, q, -self.mpmath.sin(v), self.mpmath.cos(v))
                case CylinderInput(barrel_pin=p, rod_pin=q):
                    eqs[item.row] = Distance(p, q, v * v)
                case SlideInput(direction=d, origin_along=o):
                    eqs[item.row] = OnLine(self._slide_point(item.actuator), d, v + o)
        missing = [k for k, e in enumerate(eqs) if e is None]
        if missing:
            raise ValueError(f'input rows {missing} without an input')
        return [e for e in eqs if e is not None]

    def _slide_point(self, actuator: str) -> str:
        return self.mech.prismatics[self.mech.actuators[actuator].joint].point

    def _residual(self, X, eqs, jac: bool):
        mp = self.mpmath
        n = self.n
        F = [mp.mpf(0)] * n
        J: Any = mp.zeros(n, n) if jac else None

        def P(p):
            c = self.col.get(p)
            return (X[c], X[c + 1]) if c is not None else self.fixed[p]

        def add(r, p, cx, cy):
            c = self.col.get(p)
            if c is not None and jac:
                J[r, c] += cx
                J[r, c + 1] += cy

        r = 0
        for e in eqs:
            match e:
                case Distance(p, q, d2):
                    (px, py), (qx, qy) = P(p), P(q)
                    dx, dy = qx - px, qy - py
                    F[r] = dx * dx + dy * dy - d2
                    add(r, q, 2 * dx, 2 * dy)
                    add(r, p, -2 * dx, -2 * dy)
                    r += 1
                case Rigid(p0, p1, pj, a, b):
                    (x0, y0), (x1, y1), (xj, yj) = P(p0), P(p1), P(pj)
                    ux, uy = x1 - x0, y1 - y0
                    F[r] = xj - x0 - a * ux + b * uy
                    F[r + 1] = yj - y0 - a * uy - b * ux
                    add(r, pj, 1, 0)
                    add(r, p0, -1 + a, -b)
                    add(r, p1, -a, b)
                    add(r + 1, pj, 0, 1)
                    add(r + 1, p0, b, -1 + a)
                    add(r + 1, p1, -b, -a)
                    r += 2
                case OnLine(p, nrm, c):
                    x, y = P(p)
                    F[r] = nrm[0] * x + nrm[1] * y - c
                    add(r, p, nrm[0], nrm[1])
                    r += 1
                case Direction(p, q, ms, c):
                    (px, py), (qx, qy) = P(p), P(q)
                    F[r] = ms * (qx - px) + c * (qy - py)
                    add(r, q, ms, c)
                    add(r, p, -ms, -c)
                    r += 1
        return F, J

    def solve(self, values: dict[str, float], start: dict[str, tuple[float, float]]):
        """{point: (x_hi, x_lo, y_hi, y_lo)} double-double coordinates of the 50-digit solution
        nearest ``start`` (a double answer), and the final max |F| (m or m^2)."""
        mp = self.mpmath
        with mp.workdps(self.dps):
            eqs = self._equations(values)
            X = mp.matrix(self.n, 1)
            for p, c in self.col.items():
                X[c], X[c + 1] = mp.mpf(float(start[p][0])), mp.mpf(float(start[p][1]))
            tiny = mp.mpf(10) ** (-(self.dps - 5)) * self.mech.length_scale
            res = None
            for _ in range(30):
                F, J = self._residual(X, eqs, True)
                dx = mp.lu_solve(J, mp.matrix([-f for f in F]))
                X = X + dx
                if max(abs(v) for v in dx) < tiny:
                    break
            F, _ = self._residual(X, eqs, False)
            res = float(max(abs(f) for f in F))
            out = {}
            for p in self.names:
                col = self.col.get(p)
                x, y = (X[col], X[col + 1]) if col is not None else self.fixed[p]
                xh, yh = float(x), float(y)
                out[p] = (xh, float(x - xh), yh, float(y - yh))
            return out, res


def reference_points(ref: MpReference, values_list: Sequence[dict], starts: Sequence[dict]):
    """(n, P, 2) hi and lo arrays of the reference points (in mech.points order)."""
    names = ref.names
    n = len(values_list)
    hi = np.full((n, len(names), 2), np.nan)
    lo = np.zeros((n, len(names), 2))
    worst = 0.0
    for i, (vals, st) in enumerate(zip(values_list, starts)):
        pts, res = ref.solve(vals, st)
        worst = max(worst, res)
        for j, p in enumerate(names):
            xh, xl, yh, yl = pts[p]
            hi[i, j] = (xh, yh)
            lo[i, j] = (xl, yl)
    return hi, lo, worst


def point_errors(points: np.ndarray, hi: np.ndarray, lo: np.ndarray, scale: float) -> np.ndarray:
    """Per input: max over points of |answer - reference| / scale. NaN answers (missing point,
    failed solve) give NaN rows; points the answer does not have are skipped."""
    d = (points - hi) - lo  # double-double difference, exact enough near 0
    dist = np.hypot(d[..., 0], d[..., 1])
    have = ~np.isnan(dist)
    dist = np.where(have, dist, -np.inf)
    worst = dist.max(axis=1)
    return np.where(np.isfinite(worst), worst / scale, np.nan)
