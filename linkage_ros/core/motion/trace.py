"""The whole circuit of a Newton-placed mechanism along one scanned known, by pseudo-arclength
continuation (Allgower & Georg's predictor-corrector).

A walk in the known (walk.walk_range) stops at its first turning point each way, so a circuit
with more than two (a Stephenson-III six-bar driven at its output: four) was read as the
stretch between the two next to the drawing. Here the curve F(x, u) = 0 of the loop-closure
equations is followed in (configuration x, known u) space by arclength instead, which passes
turning points in u like any other point: predictor z + h t along the unit tangent t (the null
vector of the augmented Jacobian [F_x F_u], oriented by t_new . t_old > 0), corrector Newton
on [F(z); t . (z - z_pred)] = 0. It goes until the curve closes on itself (back at the drawing)
or leaves the scan's bracket both ways. The turning points of u (t_u = 0: the toggles) are
refined by a bracketed root of t_u between the two trace points around each; between them u is
monotone: the circuit's stretches, each in one mode of the loop Jacobian (its determinant
changes sign at a turning point and nowhere else on a regular curve).

Units are the Newton system's scale-free ones (newton.tables): rotations in rad, translations
and slides in length scales, so one step size means the same at every scale.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import AngleActuator, Mechanism
from ..solver import Result, Solver
from ..solver.reading import configuration_of
from .common import without_limits
from .scan import Bracket, End, EndKind, Segment

#: the first step and the largest step along the curve (scale-free arclength): a circuit of a
#: mechanism spans a few units, so a few hundred steps trace it
FIRST_STEP = 0.02
MAX_STEP = 0.1
#: a step shorter than this fails the trace (a singular point the corrector cannot pass): the
#: caller falls back to the walk
MIN_STEP = 1e-9
#: the largest turn of the tangent (rad) over one accepted step: two turning points of u within
#: one step, where t_u changes sign twice, would go unseen; a smaller turn also keeps the chord
#: within 1 % of the step from the curve (the closure test's band)
MAX_TURN = 0.2
#: the most trace points before the trace gives up (the caller falls back to the walk)
MAX_POINTS = 20000
#: Newton corrections per corrector; a step needing more is halved
MAX_CORRECTIONS = 12
#: a correction below this (scale-free) has converged: one more reaches rounding
CONVERGED_STEP = 1e-10
#: how close the trace must pass the start (of the step's length) to have closed the circuit
CLOSURE_BAND = 0.05


@dataclass(frozen=True)
class CurvePoint:
    """A point of the traced curve: z = (scale-free unknowns, known), t its unit tangent in the
    trace's direction."""

    z: np.ndarray
    t: np.ndarray

    @property
    def rate(self) -> float:
        """d(known)/d(arclength): zero at a turning point of the known."""
        return float(self.t[-1])


@dataclass(frozen=True)
class TracedStretch:
    """One monotone stretch of the known between two turning points (or a turning point and the
    bracket): [lo, hi] (rad or m, unwrapped along the trace), what ends it, and a configuration
    inside it (its Result, its loop-Jacobian mode in ``start.branch``) where its sweep starts."""

    lo: float
    hi: float
    lo_end: End
    hi_end: End
    seed: float
    start: Result
    #: the stretch the drawing lies on (where the mechanism starts: the others are reached
    #: from it through their shared turning points)
    drawn: bool = False


@dataclass(frozen=True)
class TracedCircuit:
    """The traced circuit: whether it closed on itself, its turning points (the known's values,
    rad or m, unwrapped, in trace order) and its monotone stretches. ``full``: the known takes
    every value of a turn on it (an angle, the circuit closing a turn away)."""

    closed: bool
    turns: tuple[float, ...]
    stretches: tuple[TracedStretch, ...]
    full: bool


class _Curve:
    """F(x, u) = 0 of one Newton system with the known u free: residual, augmented Jacobian,
    tangent and corrector, in scale-free units."""

    def __init__(self, solver: Solver, scan: str, held: Mapping[str, Any], periodic: bool):
        c = solver.compiled
        self.compiled = c
        self.system = c.check_system
        t = self.system.tables
        self.n = self.system.n
        self.step = np.asarray(t.step_scale, float)
        self.unit = 1.0 if periodic else float(t.L)  # the known's scale (rad, or length scale)
        self.periodic = periodic
        self.base = c.parse({scan: 0.0, **held})
        rows = t.val_rows
        # F_u: the known enters its own row as -u (newton.rows: angle and line rows), so its
        # column is -e_row; None where it does not (a value that moves a fixed link)
        self.row = rows[0] if rows is not None and rows and c.knowns[0] == scan else None
        # the coordinates that are angles (compared a turn apart): every phi, and u if periodic
        self.angles = np.zeros(self.n + 1, bool)
        self.angles[0 : self.n : 3] = True
        self.angles[-1] = periodic

    def values(self, w: float) -> list[Any]:
        vals = list(self.base)
        vals[0] = w * self.unit
        return vals

    def residual(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(F, [F_x F_u]) at z, scale-free."""
        x = z[: self.n] * self.step
        F, J, _ = self.system.evaluate_scaled(x, self.values(float(z[-1])), None)
        if self.row is not None:
            Fu = np.zeros(len(F))
            Fu[self.row] = -1.0
        else:  # (linear in the value: a central difference is exact to rounding)
            h = 1e-6
            Fp = self.system.evaluate_scaled(x, self.values(float(z[-1]) + h), None, False)[0]
            Fm = self.system.evaluate_scaled(x, self.values(float(z[-1]) - h), None, False)[0]
            Fu = (Fp - Fm) / (2 * h)
        return F, np.column_stack([J, Fu])

    def tangent(self, A: np.ndarray, orient: np.ndarray | None) -> np.ndarray | None:
        """The unit null vector of A = [F_x F_u], with t . orient > 0 (the bordered system
        [A; orient^T] t = e_last); without ``orient`` from the SVD, t_u >= 0."""
        if orient is None:
            t: np.ndarray = np.linalg.svd(A)[2][-1]
            return t if t[-1] >= 0 else -t
        rhs = np.zeros(A.shape[1])
        rhs[-1] = 1.0
        try:
            t = np.linalg.solve(np.vstack([A, orient]), rhs)
        except np.linalg.LinAlgError:
            return None
        norm = float(np.linalg.norm(t))
        return t / norm if math.isfinite(norm) and norm > 0 else None

    def correct(self, guess: np.ndarray, normal: np.ndarray, anchor: np.ndarray) -> Any:
        """Newton on [F(z); normal . (z - anchor)] = 0 from ``guess``: (z, A there, corrections)
        or None where it does not converge."""
        z = guess.copy()
        last = math.inf
        for k in range(MAX_CORRECTIONS):
            F, A = self.residual(z)
            g = np.append(F, normal @ (z - anchor))
            if not np.all(np.isfinite(g)):
                return None
            try:
                dz = np.linalg.solve(np.vstack([A, normal]), -g)
            except np.linalg.LinAlgError:
                return None
            size = float(np.max(np.abs(dz)))
            if not math.isfinite(size) or (k >= 2 and size > 0.5 * last):
                return None  # not contracting: the guess is off this curve's basin
            z = z + dz
            if size < CONVERGED_STEP:  # (quadratic: this correction brought z to rounding)
                return z, self.residual(z)[1], k + 1
            last = size
        return None

    def gap(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """b - a with angle coordinates a turn apart taken the short way."""
        d: np.ndarray = b - a
        d[self.angles] = np.remainder(d[self.angles] + math.pi, 2 * math.pi) - math.pi
        return d


def _follow(
    curve: _Curve, first: CurvePoint, bounds: tuple[float, float]
) -> tuple[list[CurvePoint], str]:
    """Trace from ``first`` along its tangent: (points, 'closed' | 'bracket' | 'stalled'). The
    known is kept within ``bounds`` (scale-free): the trace ends with a point on the bound it
    reaches."""
    pts = [first]
    h, longest, away = FIRST_STEP, 0.0, False
    while len(pts) < MAX_POINTS:
        p = pts[-1]
        pred = p.z + h * p.t
        got = curve.correct(pred, p.t, pred)
        t = None if got is None else curve.tangent(got[1], p.t)
        if got is None or t is None or float(t @ p.t) < math.cos(MAX_TURN):
            h /= 2
            if h < MIN_STEP:
                return pts, 'stalled'
            continue
        z, _, corrections = got
        w = float(z[-1])
        if not bounds[0] <= w <= bounds[1]:  # the point on the bound, between p and z
            edge = bounds[0] if w < bounds[0] else bounds[1]
            normal = np.zeros(len(z))
            normal[-1] = 1.0
            anchor = p.z.copy()
            anchor[-1] = edge
            on = curve.correct(p.z + (z - p.z) * (edge - p.z[-1]) / (w - p.z[-1]), normal, anchor)
            if on is not None:
                tb = curve.tangent(on[1], p.t)
                pts.append(CurvePoint(on[0], p.t if tb is None else tb))
            return pts, 'bracket'
        new = CurvePoint(z, t)
        longest = max(longest, float(np.linalg.norm(z - p.z)))
        start = curve.gap(pts[0].z, z)
        # (the closure test waits until the trace has been three steps from its start: the
        # first steps pass next to it)
        away = away or float(np.linalg.norm(start)) > 3 * longest
        if away and _passes(curve, p, new, pts[0]):
            return pts, 'closed'
        pts.append(new)
        if corrections <= 3 and float(t @ p.t) > math.cos(MAX_TURN / 2):
            h = min(1.5 * h, MAX_STEP)
    return pts, 'stalled'


def _passes(curve: _Curve, a: CurvePoint, b: CurvePoint, start: CurvePoint) -> bool:
    """Whether the step a -> b passes through ``start`` the way the trace left it (the chord
    lies within CLOSURE_BAND of its length from the curve: MAX_TURN)."""
    step = curve.gap(a.z, b.z)
    to = curve.gap(a.z, start.z)
    length2 = float(step @ step)
    if length2 == 0.0:
        return False
    lam = float(to @ step) / length2
    off = float(np.linalg.norm(to - lam * step))
    return (
        -CLOSURE_BAND <= lam <= 1 + CLOSURE_BAND
        and off <= CLOSURE_BAND * math.sqrt(length2)
        and float(start.t @ step) > 0
    )


def _turning_point(curve: _Curve, a: CurvePoint, b: CurvePoint) -> np.ndarray | None:
    """The point between trace points a and b where t_u = 0 (their rates differ in sign):
    the root in lam of t_u at a + lam (b - a) corrected onto the curve across the chord. At a
    turning point u is quadratic in arclength, so a root to ~1e-13 of the step puts u there to
    rounding."""
    from scipy.optimize import brentq  # (~0.4 s to import: only where a trace runs)

    chord = curve.gap(a.z, b.z)
    found: dict[float, np.ndarray] = {}

    def rate(lam: float) -> float:
        if lam == 0.0:
            return a.rate
        if lam == 1.0:
            return b.rate
        q = a.z + lam * chord
        got = curve.correct(q, chord, q)
        if got is None:
            raise ValueError('no curve point across the chord')
        t = curve.tangent(got[1], chord)
        if t is None:
            raise ValueError('no tangent')
        found[lam] = got[0]
        return float(t[-1])

    try:
        lam = float(brentq(rate, 0.0, 1.0, xtol=1e-14, rtol=4 * np.finfo(float).eps))
    except (ValueError, RuntimeError):
        return None
    if lam in (0.0, 1.0):
        return (a if lam == 0.0 else b).z.copy()
    if lam not in found:  # (brentq's last evaluation is its answer: found holds it)
        try:
            rate(lam)
        except ValueError:
            return None
    return found[lam]


def _seed_result(curve: _Curve, z: np.ndarray) -> Result:
    """The Result of the traced configuration z (a warm start for a stretch's sweep), named by
    its loop-Jacobian mode ('J+' / 'J-': the determinant's sign, as reading.jacobian_mode)."""
    c, system = curve.compiled, curve.system
    x = z[: curve.n] * curve.step
    vals = curve.values(float(z[-1]))
    poses, pts = system.configuration(x)
    _, J, _ = system.evaluate_scaled(x, vals, None)
    sign = np.linalg.slogdet(J)[0]
    margin = min(1.0, 1.0 / system.scaled_cond(J))
    return c.build_result(
        poses,
        pts,
        vals,
        solver='newton',
        iterations=0,
        signs=(),
        margin=margin,
        label='J+' if sign >= 0 else 'J-',
    )


def trace_circuit(
    mech: Mechanism,
    scan: str,
    held: Mapping[str, Any],
    x0: float,
    bracket: Bracket | None = None,
) -> TracedCircuit | None:
    """The circuit through the drawing of the known ``scan`` (at ``x0``; the others ``held``),
    traced by arclength (see the module) on the mechanism without its limits; a slide within
    ``bracket``. None where the drawing does not assemble at x0, the loop equations are not
    square (redundant constraints), or the trace stalls or does not close within MAX_POINTS:
    the caller's walk answers then."""
    periodic = isinstance(mech.actuators[scan], AngleActuator)
    solver = Solver(without_limits(mech), knowns=[scan, *held], branch='continuous', max_iter=200)
    system = solver.compiled.check_system
    if system.m != system.n or not system.n or solver.compiled.knowns[0] != scan:
        return None
    curve = _Curve(solver, scan, held, periodic)
    start = solver.solve({scan: x0, **held}, commit=False)
    got = configuration_of(solver.compiled, start) if start.success else None
    if got is None:
        return None
    z0 = np.append(system.x_from_poses(got[1]) / curve.step, x0 / curve.unit)
    polished = curve.correct(z0, np.eye(len(z0))[-1], z0)  # (onto the curve to rounding)
    if polished is None:
        return None
    t0 = curve.tangent(polished[1], None)
    if t0 is None:
        return None
    first = CurvePoint(polished[0], t0)
    if bracket is None:
        bounds = (-math.inf, math.inf)
    else:
        bounds = (bracket[0] / curve.unit, bracket[1] / curve.unit)
    ahead, how = _follow(curve, first, bounds)
    if how == 'stalled':
        return None
    if how == 'closed':
        pts, closed = ahead, True
    else:
        back, how_back = _follow(curve, CurvePoint(first.z, -first.t), bounds)
        if how_back != 'bracket':
            return None
        pts = [CurvePoint(p.z, -p.t) for p in reversed(back[1:])] + ahead
        closed = False
    return _circuit_of(curve, pts, closed, bracket, 0 if closed else len(back) - 1)


def _circuit_of(
    curve: _Curve, pts: list[CurvePoint], closed: bool, bracket: Bracket | None, drawn: int
) -> TracedCircuit | None:
    """The turning points and monotone stretches of a traced curve (``closed``: its last point
    is followed by its first; ``drawn``: the index of the drawing's point)."""
    n = len(pts)
    seq = list(pts)
    turn_of_circuit = 0.0
    if closed:  # the first point again, as the trace reaches it (its known unwrapped from the
        # last: a turn on where the known turned fully)
        turn_of_circuit = float(pts[-1].z[-1] + curve.gap(pts[-1].z, pts[0].z)[-1] - pts[0].z[-1])
        seq.append(_shifted(pts[0], turn_of_circuit))
    turns: list[tuple[int, np.ndarray]] = []  # (i, z): between seq[i] and seq[i + 1]
    for i in range(len(seq) - 1):
        a, b = seq[i], seq[i + 1]
        if a.rate * b.rate < 0 or (b.rate == 0.0 and a.rate != 0.0):
            z = _turning_point(curve, a, b)
            if z is None:
                return None
            turns.append((i, z))
    us = [float(p.z[-1]) for p in seq]
    span = max(us) - min(us)
    full = closed and curve.periodic and span >= 2 * math.pi - 1e-12
    if closed and not turns:
        return TracedCircuit(True, (), (), True)
    # the stretches between consecutive bounds: turning points, and an open curve's ends (at
    # the bracket); a closed curve's last stretch runs on through its start to the first
    # turning point a circuit later
    bounds: list[tuple[int, np.ndarray | None]]
    if closed:
        i0, z0 = turns[0]
        seq += [_shifted(p, turn_of_circuit) for p in pts[1 : i0 + 2]]
        again = z0.copy()
        again[-1] += turn_of_circuit
        bounds = [*turns, (i0 + n, again)]
    else:
        bounds = [(-1, None), *turns, (n - 1, None)]
    lo_kind = EndKind.LIMIT if bracket is not None and bracket[2] else EndKind.BRACKET
    hi_kind = EndKind.LIMIT if bracket is not None and bracket[3] else EndKind.BRACKET
    unit = curve.unit
    stretches = []
    for (i, za), (j, zb) in zip(bounds[:-1], bounds[1:]):
        inside = seq[i + 1 : j + 1]
        ua = float(inside[0].z[-1] if za is None else za[-1])
        ub = float(inside[-1].z[-1] if zb is None else zb[-1])
        lo, hi = min(ua, ub), max(ua, ub)

        def end(z: np.ndarray | None, u: float, lo: float = lo) -> End:
            if z is not None:
                return (EndKind.TOGGLE, None)
            return (lo_kind if u == lo else hi_kind, None)

        ends = {ua: end(za, ua), ub: end(zb, ub)}
        mid = 0.5 * (lo + hi)
        seed = min(inside, key=lambda p: abs(float(p.z[-1]) - mid))
        stretches.append(
            TracedStretch(
                lo * unit,
                hi * unit,
                ends[lo] if ua != ub else end(za, ua),
                ends[hi] if ua != ub else end(zb, ub),
                float(seed.z[-1]) * unit,
                _seed_result(curve, seed.z),
                # (a closed curve's drawing is its first point, and again a circuit on)
                i + 1 <= drawn <= j or (closed and i + 1 <= drawn + n <= j),
            )
        )
    turn_values = tuple(float(z[-1]) * unit for _, z in turns)
    return TracedCircuit(closed, turn_values, tuple(stretches), full)


def _shifted(p: CurvePoint, turn: float) -> CurvePoint:
    """``p`` with its known ``turn`` on (the same configuration, a circuit later)."""
    z = p.z.copy()
    z[-1] += turn
    return CurvePoint(z, p.t)


def reachable_stretches(
    segs: Sequence[Segment], x0: float, bounds: tuple[float, float], periodic: bool
) -> list[Segment]:
    """The traced stretches (scan_circuit's segments, in trace order) the mechanism reaches from the
    drawing's within ``bounds`` (the input's limits): from the drawn stretch on, each neighbour
    whose shared turning point lies within them (an angle's limits taken on the turn of the
    drawing). A circuit split by the limits into two stretches the drawing's does not join
    was read whole (a Stephenson-III six-bar with drive limits 3.2 .. 3.6 rad swung its crank
    255 deg where it reaches 123: an adversary)."""
    drawn = next((k for k, s in enumerate(segs) if s.drawn), None)
    if drawn is None:
        return list(segs)
    lo, hi = bounds
    if periodic:
        turn = 2 * math.pi * round((x0 - 0.5 * (lo + hi)) / (2 * math.pi))
        lo, hi = lo + turn, hi + turn
    n = len(segs)
    keep = {drawn}
    for step in (1, -1):
        k = drawn
        while True:
            nxt = (k + step) % n
            if nxt in keep or (k + step) not in range(n) and not _cyclic(segs):
                break
            shared = _shared_turn(segs[k], segs[nxt])
            if shared is None or not lo <= shared <= hi:
                break
            keep.add(nxt)
            k = nxt
    return [s for k, s in enumerate(segs) if k in keep]


def _cyclic(segs: Sequence[Segment]) -> bool:
    """Whether traced stretches close a circuit (every end a toggle: no bracket or limit)."""
    return all(e[0] is EndKind.TOGGLE for s in segs for e in (s.lo_end, s.hi_end))


def _shared_turn(a: Segment, b: Segment) -> float | None:
    """The turning point (a toggle end) two neighbouring stretches share, as ``a`` has it."""
    for v, e in ((a.lo, a.lo_end), (a.hi, a.hi_end)):
        if e[0] is EndKind.TOGGLE and any(
            math.isclose(v, w, rel_tol=0.0, abs_tol=1e-9 * max(1.0, abs(v)))
            for w, f in ((b.lo, b.lo_end), (b.hi, b.hi_end))
            if f[0] is EndKind.TOGGLE
        ):
            return float(v)
    return None
