"""Quantities designers ask for, over one input's range: the signed transmission angle of each
RRR dyad and its extremes, an output's extremes (stroke or swing) with the input values there,
and the time ratio of a fully turning crank.

The transmission angle of an RRR dyad is the angle at its point X between the directions to
its two circle centres (the classical mu of a four-bar: the angle A-B-O4 between coupler and
rocker), signed counter-clockwise from the first centre's direction to the second's, in
(-pi, pi]: its size is the classical mu in [0, pi] and its sign tells the assembly mode, which
the margin |sin mu| cannot (it does not tell mu from pi - mu either).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import AngleActuator, Mechanism
from ..model.names import NameKind, resolve_name
from ..solver import Result, SolveMode, Solver
from ..solver.result import NEWTON_TOL, branch_text, named_value
from ..steps import RRRDyad
from ..velocity import Velocities, velocities
from .common import past_toggle
from .ranges import input_ranges, scan_circuit
from .scan import EndKind, held_reference, turns_fully
from .touches import golden_min
from .trace import reachable_stretches

#: an output whose swing (rad) or stroke (of the length scale) is no more than this does not
#: move (it rounds): it has no time ratio
STILL = 1e-9
#: a refined extreme may exceed the best sample by no more than this fraction of the largest
#: value the quantity takes (rounding: both are computed to a few ulps of the terms that make
#: them, and the best sample may sit on the extreme itself, where the two differ by rounding
#: alone; a value near 0, a slider's end at x = 0, is computed from terms of the mechanism's
#: size, so the band is not a fraction of the value itself)
_LEVEL = 1e-13
#: the steps the two grid steps around an extreme are cut into where the rate does not change
#: sign across them
_FINER = 16
#: the fewest samples input_sweep takes (4 degrees a step over a full turn): its extremes are
#: bracketed between samples, and 2 samples found a non-Grashof rocker's minimum at 2.86 rad
#: where it is 1.06 (its default is 1440)
MIN_SAMPLES = 90


def transmission_angles(solver: Solver, result: Result) -> dict[str, float]:
    """{'<A>-<X>-<B>': signed angle (rad)} of every RRR dyad of ``solver``'s plan at a solved
    configuration (see the module docstring)."""
    out = {}
    for step in solver.plan.steps:
        a = step.args
        if not isinstance(a, RRRDyad) or step.point is None:
            continue
        x = np.asarray(result.points[step.point], float)
        u = np.asarray(result.points[a.centre_a], float) - x
        v = np.asarray(result.points[a.centre_b], float) - x
        u, v = u * _unit_scale(u), v * _unit_scale(v)  # the angle does not depend on either
        key = f'{a.centre_a}-{step.point}-{a.centre_b}'
        out[key] = math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1])
    return out


def _unit_scale(*vectors: np.ndarray) -> float:
    """The power of two that brings the vectors' largest component into [0.5, 1): products
    of mechanisms drawn at 1e-170 m underflow and at 1e160 m overflow, while a power of two
    scales them exactly (the same bits at every other size). 1 for zero or non-finite ones."""
    peak = max(float(np.max(np.abs(w))) for w in vectors)
    if not 0.0 < peak < math.inf:
        return 1.0
    return math.ldexp(1.0, -math.frexp(peak)[1])


@dataclass
class Extreme:
    """The least and greatest value of a quantity over the input's range, and where: the input
    value and, where the circuit passes more than one assembly mode (through a toggle into the
    dyad's other sign), the mode's branch signs there (an input has a configuration in each)."""

    minimum: float
    maximum: float
    input_at_min: float
    input_at_max: float
    mode_at_min: str = ''
    mode_at_max: str = ''


@dataclass
class InputSweep:
    """What one input's range gives (see :func:`input_sweep`). Angles in rad, lengths in m."""

    actuator: str
    full_turn: bool
    outputs: dict[str, Extreme]  # link:<name> angle (rad; min in (-pi, pi]), joint:<name> value
    transmission: dict[str, Extreme]  # |mu| of each RRR dyad, the classical angle in [0, pi]
    time_ratio: dict[str, float]  # full turn only: slower / faster stroke of each output
    #: the link:<name> outputs that turn fully (no extremes: a double-crank's follower)
    turns_fully: tuple[str, ...] = ()


def _value(mech: Mechanism, r: Result, output: str) -> float:
    """An output's value: ``link:<name>`` its angle (rad), ``joint:<name>`` its value (the
    name resolved by the one rule: model.names)."""
    return float(named_value(mech, r, output))


#: d(quantity)/d(input) at a solved configuration and its velocities (rates for input rate 1)
RateOf = Callable[[Result, Velocities], float]
#: a quantity's value at a solved configuration, taken on the turn nearest ``near`` for angles
ValueNear = Callable[[Result, float], float]


def _output_rate(mech: Mechanism, output: str) -> RateOf:
    """d(output)/d(input): a link's angular velocity or a joint's rate, for input rate 1."""
    named = resolve_name(mech, output)
    if named.kind is NameKind.LINK:
        return lambda r, v: float(v.links[named.name])
    return lambda r, v: float(v.joints[named.name])


def _transmission_rate(solver: Solver, key: str) -> RateOf:
    """d|mu|/d(input) of the RRR dyad ``key`` ('<A>-<X>-<B>', as :func:`transmission_angles`):
    mu = atan2(u x w, u . w) with u = A - X, w = B - X, differentiated with the points'
    velocities."""
    centre_a, point, centre_b = key.split('-')

    def rate(r: Result, v: Velocities) -> float:
        x, a, b = (np.asarray(r.points[p], float) for p in (point, centre_a, centre_b))
        vx, va, vb = (np.asarray(v.points[p], float) for p in (point, centre_a, centre_b))
        u, w, du, dw = a - x, b - x, va - vx, vb - vx
        # d_mu has the fourth power of a length above and below: scaled alike, exactly
        k = _unit_scale(u, w)
        u, w, du, dw = u * k, w * k, du * k, dw * k
        cross, dot = u[0] * w[1] - u[1] * w[0], u @ w
        d_cross = du[0] * w[1] - du[1] * w[0] + u[0] * dw[1] - u[1] * dw[0]
        d_dot = du @ w + u @ dw
        d_mu = (dot * d_cross - cross * d_dot) / (cross * cross + dot * dot)
        return float(math.copysign(1.0, math.atan2(cross, dot)) * d_mu)

    return rate


def _rate_root(
    solver: Solver, act: str, rate_of: RateOf, a: float, b: float, sign: float, scale: float
) -> float | None:
    """The input in [a, b] where the quantity's rate d(quantity)/d(input) is zero, rising
    through zero for a minimum (sign +1), falling for a maximum (sign -1): Brent's method to a
    few ulps of the input (the extreme of a smooth quantity is a simple root of its rate, where
    golden-section search on the value stalls at sqrt(eps)). None when the rate does not change
    sign on [a, b] (an end of the range, a flat top) or has no value there (a toggle)."""
    from scipy.optimize import brentq

    def rate(x: float) -> float:
        r = solver.solve({act: x}, commit=False)
        if not r.success:
            return math.nan
        v = velocities(solver, r, {act: x}, {act: 1.0})
        return sign * rate_of(r, v) if v.success else math.nan

    ra, rb = rate(a), rate(b)
    if not (math.isfinite(ra) and math.isfinite(rb)) or ra > 0.0 or rb < 0.0:
        return None
    if ra == 0.0 or rb == 0.0:
        return a if ra == 0.0 else b
    try:
        x = brentq(rate, a, b, xtol=1e-300 + 1e-17 * scale, rtol=4 * np.finfo(float).eps)
    except (ValueError, RuntimeError):
        return None
    return float(x) if math.isfinite(x) else None


@dataclass
class _Piece:
    """One branch's stretch of the input's circuit: its solver (the branch's signs), the input
    samples where it assembles and their solutions."""

    solver: Solver
    grid: np.ndarray
    results: list[Result]


def _circuit(mech: Mechanism, act: str, samples: int) -> tuple[bool, list[_Piece]]:
    """(full turn, pieces): the input's circuit within its limits, through its toggles and so
    every branch it passes (ranges.scan_circuit, as ``linkage range --links`` follows it: a
    non-Grashof crank's swing one way in one assembly mode and back in the other), sampled
    ``samples`` times a piece."""
    held = held_reference(mech, act, None)
    _, x0, segs, _ = scan_circuit(mech, act, held, samples)
    # the range the input may take (its toggles within its limits: input_ranges)
    periodic = isinstance(mech.actuators[act], AngleActuator)
    rlo, rhi = input_ranges(mech)[act]
    bounds = None if rlo is None or rhi is None else (rlo, rhi)
    full = periodic and turns_fully(segs) and bounds is None
    if bounds is not None and any(s.start is not None for s in segs):
        segs = reachable_stretches(segs, x0, bounds, periodic)
    pieces = []
    for seg in segs:
        lo, hi = seg.lo, seg.hi
        if bounds is not None and seg.full:  # a crank that could turn fully, stopped by limits
            lo, hi = bounds
        elif bounds is not None:  # the range on the turn of the piece's start (its seed:
            # the reference value, the toggle or change point it starts from): a piece through a
            # change point spans a turn, the limits' arc on its other turn is not reached
            mid = (bounds[0] + bounds[1]) / 2
            turn = round((seg.seed - mid) / (2 * math.pi)) * 2 * math.pi if periodic else 0.0
            lo, hi = max(lo, bounds[0] + turn), min(hi, bounds[1] + turn)
        if full and seg.full:
            grid = x0 + np.linspace(0.0, 2 * math.pi, samples, endpoint=False)
        elif math.isfinite(lo) and math.isfinite(hi) and lo < hi:
            grid = np.linspace(lo, hi, samples)
        elif bounds is not None and not seg.full and lo >= hi:
            continue  # a stretch past a change point outside the limits
        else:
            raise ValueError(f'{act!r} has no bounded range to sweep')
        if seg.start is not None:  # a traced stretch: in its loop-Jacobian mode, from the
            # trace's own configuration on it (the mode recurs on other stretches: from the
            # drawing, a solve in it may land on another)
            solver = Solver(mech, branch=seg.start.branch)
            pieces.append(_swept(solver, act, seg, grid.copy(), seg.seed, seg.start))
            continue
        branch = branch_text(seg.signs) if seg.signs else 'continuous'
        piece = _swept(Solver(mech, branch=branch), act, seg, grid.copy())
        pieces.append(piece)
        if not seg.signs and not seg.full and piece.results:  # (an untraced walk's stretch)
            # Newton places the mechanism (no dyad signs): the continuous sweep from the drawing
            # follows one half of the circuit (between the input's toggles, or a toggle and a
            # limit); the way back is the loop Jacobian's other mode (its determinant changes
            # sign at a toggle: a Stephenson six-bar driven at its output, whose crank turns
            # fully over the two halves, was read as swinging over one, an outside scene
            # author; a cylinder-driven triad stopped at its cylinder's dead centre)
            back = _half_back(mech, act, seg, grid, piece)
            if back is not None:
                pieces.append(back)
    if not any(p.results for p in pieces):
        raise ValueError(f'{act!r} has no range to sweep')
    return full, pieces


#: in an outward_order: where the solver goes back to its start
BACK_TO_START = -1


def outward_order(grid: Any, start: float) -> list[int]:
    """The indices of ``grid`` (inputs, ascending) from ``start`` up, BACK_TO_START, then from
    ``start`` down: a continuation from a start inside the grid approaches each end (a toggle)
    and never steps off one, where Newton may take either half of a circuit."""
    split = int(np.searchsorted(grid, start))
    return [*range(split, len(grid)), BACK_TO_START, *range(split - 1, -1, -1)]


def _swept(
    solver: Solver,
    act: str,
    seg: Any,
    grid: np.ndarray,
    outward_from: float | None = None,
    start: Result | None = None,
) -> _Piece:
    """The piece of ``seg`` (a scan segment) that ``solver`` (its branch) solves over ``grid``
    (the input's samples, in order; changed where an end is read past a toggle). With
    ``outward_from`` (an input inside the grid where the solver's start lies) the samples are
    solved in its outward_order, from ``start`` (a configuration there) where given, else from
    the solver's own start."""
    # an end of the piece at its toggle: read at the toggle itself (common.past_toggle)
    toggle_at = {
        0: -1.0 if seg.lo_end[0] is EndKind.TOGGLE and grid[0] == seg.lo else 0.0,
        len(grid) - 1: 1.0 if seg.hi_end[0] is EndKind.TOGGLE and grid[-1] == seg.hi else 0.0,
    }
    order = list(range(len(grid))) if outward_from is None else outward_order(grid, outward_from)
    got: dict[int, Result] = {}
    if start is not None:
        solver.adopt(start)
    for k in order:
        if k == BACK_TO_START:
            solver.reset()
            if start is not None:
                solver.adopt(start)
            continue
        v = grid[k]
        outward = toggle_at.get(k, 0.0)
        for past in past_toggle(float(v), outward) if outward else ():
            if solver.solve({act: past}, commit=False).success:
                grid[k] = v = past
                break
        r = solver.solve({act: float(v)})
        if r.success:
            got[k] = r
        elif 0 < k < len(grid) - 1:  # (an end is a toggle: it may miss by rounding)
            raise ValueError(f'{act} = {v:.9g} does not assemble: {r.reason}')
    kept = sorted(got)
    return _Piece(solver, grid[kept], [got[k] for k in kept])


#: how close (of the length scale) the half back's ends must come to the first half's, at the
#: toggles where the two meet, to be the same circuit (another circuit's configuration at those
#: inputs is a finite distance away; at a toggle read to ~1e-11 of the input the halves meet to
#: ~sqrt(1e-11))
_HALVES_MEET = 1e-3


def _half_back(
    mech: Mechanism, act: str, seg: Any, grid: np.ndarray, first: _Piece
) -> _Piece | None:
    """The way back of a Newton-placed circuit from its toggles (``seg``: a segment with no dyad
    signs, a toggle at one end or both, a limit at the other): swept in the loop Jacobian's
    other mode than ``first``'s, kept only where it meets ``first`` at each toggle (the same
    circuit, not another one in that mode); None otherwise."""
    toggles = [k for k, end in ((0, seg.lo_end), (-1, seg.hi_end)) if end[0] is EndKind.TOGGLE]
    if not toggles:
        return None
    labels = [r.branch for r in first.results]
    drawn = max(set(labels), key=labels.count)
    if drawn not in ('J+', 'J-'):
        return None
    try:  # (from the drawing's input: the other mode's start lies there, as start() takes it)
        other = _swept(
            Solver(mech, branch='J-' if drawn == 'J+' else 'J+'), act, seg, grid.copy(), seg.seed
        )
    except ValueError:  # (that mode's root there lies on no circuit through both toggles)
        return None
    if not other.results:
        return None
    reach = _HALVES_MEET * mech.length_scale
    for k in toggles:
        if first.grid[k] != other.grid[k]:  # (an end sample that did not solve: unmatched)
            return None
        a, b = first.results[k], other.results[k]
        if max(math.dist(a.points[p], b.points[p]) for p in a.points) > reach:
            return None
    return other


def _arc_start(raw: list[np.ndarray], closed: bool) -> float | None:
    """The angle (rad) where the arc that the angles ``raw`` (one array per piece, each in
    input order; ``closed``: one piece over a full turn of the input, its last sample followed
    by its first) cover begins: just after their largest gap around the circle. None where the
    angle turns fully: a step between neighbouring samples, taken the short way (each is less
    than half a turn), passes through that gap. Where the gap lies between the ends of two
    pieces (their toggle, where an end sample may be missing: it did not assemble by rounding)
    no step joins them, and a gap no wider than 1.5 steps there is passed too. The steps are
    read where they are taken, not compared with the largest step anywhere: a lever whose pivot
    the crank pin passes close by (a slotted lever with r/d near 1) swings through nearly pi
    within one input step, next to its extremes, and still swings."""
    around: list[float] = []
    at_end: list[float] = []  # per sample: its step into the piece if it ends one, else 0
    crossings: list[tuple[float, float]] = []  # per step: (from, signed short-way change)
    for a in raw:
        if not a.size:
            continue
        seq = np.append(a, a[0]) if closed and a.size > 1 else a
        d = np.remainder(np.diff(seq) + math.pi, 2 * math.pi) - math.pi
        ends = np.zeros(a.size)
        if not closed and a.size > 1:
            ends[0], ends[-1] = abs(d[0]), abs(d[-1])
        around += np.mod(a, 2 * math.pi).tolist()
        at_end += ends.tolist()
        crossings += list(zip(seq[:-1].tolist(), d.tolist()))
    order = np.argsort(around)
    at = np.asarray(around)[order]
    end_step = np.asarray(at_end)[order]
    gaps = np.diff(np.append(at, at[0] + 2 * math.pi))
    j = int(np.argmax(gaps))
    k = (j + 1) % at.size
    if gaps[j] <= 1.5 * max(end_step[j], end_step[k]):
        return None
    mid = at[j] + gaps[j] / 2
    for start, change in crossings:  # a step through the gap: the angle passes it
        into = math.remainder(mid - start, 2 * math.pi)
        if (0.0 < into < change) or (change < into < 0.0):
            return None
    return float(at[k])


def _wrapped(e: Extreme) -> Extreme:
    """``e`` with its inputs (crank angles on the circuit, unwrapped) in (-pi, pi]."""
    return dataclasses.replace(
        e,
        input_at_min=math.remainder(e.input_at_min, 2 * math.pi),
        input_at_max=math.remainder(e.input_at_max, 2 * math.pi),
    )


def input_sweep(
    mech: Mechanism, outputs: list[str], samples: int = 1440, tol: float = NEWTON_TOL
) -> InputSweep:
    """Sweep the only actuator of a 1-DOF mechanism over its circuit (:func:`_circuit`: a full
    turn when it turns fully, else its range one way and back, through the toggles at its ends
    into the other assembly mode where the circuit goes there): each output's extremes and the
    input values there (an angle that turns fully has none: :attr:`InputSweep.turns_fully`),
    the transmission angles' extremes, and for a full turn the time ratio of each output (the
    crank turn from its minimum to its maximum against the turn back, the larger over the
    smaller: 1 for a symmetric motion). An extreme inside the range is the root of the
    quantity's rate d(quantity)/d(input) (the exact Jacobian velocities), found by Brent's
    method between the samples around the best one, on that sample's branch: the input there to
    a few ulps, so the dead-centre inputs, swing, stroke and time ratio are exact to about 1e-15
    relative (tested to 1e-12 against the closed forms for ten drawings each; where the closed
    form is ill-conditioned, as a quick-return's time ratio with r/d near 1, to its condition
    number times a few eps; a swing or stroke is max - min, so relative to itself its rounding
    is about eps * |max| / stroke: 1e-12 for a 1 mm crank's stroke of a slider 10 m out, an
    outside reviewer's case; where Newton places the mechanism, each value to its tolerance).
    Where the rate does not change sign between those samples it is
    looked for in sixteen finer steps between them (a lever that flips between its extremes
    within one step); where it changes sign in none (an extreme at an end of the range, where
    the input toggles) the value is minimised by golden-section search to ``tol`` of the input
    instead (about 1e-8 of the input where the quantity is flat there). ValueError for a
    mechanism with more than one actuator, and for ``samples`` (the grid of the circuit) fewer
    than MIN_SAMPLES."""
    if len(mech.actuators) != 1:
        raise ValueError(f'{mech.name!r} has {len(mech.actuators)} actuators; this needs one')
    if (
        isinstance(samples, bool)
        or not isinstance(samples, int | np.integer)
        or samples < MIN_SAMPLES
    ):
        raise ValueError(
            f'samples must be an int of at least {MIN_SAMPLES} (got {samples!r}): a coarser '
            'grid can step over an extreme, which is then not bracketed'
        )
    (act,) = mech.actuators
    full, pieces = _circuit(mech, act, samples)
    scale = 1.0 if isinstance(mech.actuators[act], AngleActuator) else mech.length_scale
    # the input's travel before the motion repeats: one turn, or the stretches' sum where the
    # circuit passes change points (a change-point four-bar's takes two turns: seed 000)
    # (whole turns: the change points' positions are found to ~1e-8)
    travel = sum(float(p.grid[-1] - p.grid[0]) for p in pieces if p.grid.size)
    # an input has a configuration in each mode the circuit passes: an extreme names its mode
    several_modes = len({r.branch for p in pieces for r in p.results}) > 1
    period = 2 * math.pi * (1 if len(pieces) == 1 else max(1, round(travel / (2 * math.pi))))

    def refine(
        piece: _Piece, series: np.ndarray, f_of: ValueNear, rate_of: RateOf, i: int, sign: float
    ) -> tuple[float, float]:
        """The extreme near sample i of a piece's ``series`` (sign +1 min, -1 max): (input,
        value), on the piece's branch."""
        grid, exact = piece.grid, piece.solver
        n = len(grid)
        # every solve below from the sample's own configuration: from wherever the piece's
        # sweep left the solver, Newton walked back across the circuit (and its toggles) for
        # each one (0.2 s a solve: a Hart inversor's `linkage check` by Newton took 21 s)
        exact.reset()
        exact.adopt(piece.results[i])
        if full and len(pieces) == 1:  # one turn's grid: its neighbours wrap around
            a, b = grid[i] - (grid[1] - grid[0]), grid[i] + (grid[1] - grid[0])
        else:  # (a stretch between change points: past its end the sign is the other curve)
            a, b = grid[max(i - 1, 0)], grid[min(i + 1, n - 1)]
        x = _rate_root(exact, act, rate_of, float(a), float(b), sign, scale)
        fx = math.inf
        if x is not None:
            r = exact.solve({act: x}, commit=False)
            fx = sign * f_of(r, series[i]) if r.success else math.inf
        else:
            # no sign change across the two steps: the rate may turn back within them (a lever
            # flipping between its two extremes within one step, r/d near 1): the roots in
            # finer steps, the best of them
            edges = np.linspace(float(a), float(b), _FINER + 1).tolist()
            for lo, hi in zip(edges[:-1], edges[1:]):
                got = _rate_root(exact, act, rate_of, lo, hi, sign, scale)
                if got is None:
                    continue
                at = exact.solve({act: got}, commit=False)
                if at.success and sign * f_of(at, series[i]) < fx:
                    x, fx = got, sign * f_of(at, series[i])
        # the root kept where its value is the sample's or better, to rounding (a sample on the
        # extreme itself is as low, and the root is where it is to a few ulps)
        if x is not None and fx <= sign * series[i] + _LEVEL * float(np.max(np.abs(series))):
            return x, sign * fx  # (unwrapped: the circuit's own input coordinate)

        def f(x: float) -> float:
            r = exact.solve({act: x}, commit=False)
            if not r.success:
                return math.inf
            return sign * f_of(r, series[i])

        # no sign change of the rate on the grid step: an end of the range (a toggle of the
        # input, where the rate has no value) or a flat top; the least value found there
        x, fx = golden_min(f, float(a), float(b), tol)
        if not fx <= sign * series[i]:  # an end of the range, or a flat top
            x, fx = float(grid[i]), sign * float(series[i])
        return x, sign * fx

    def extreme(series: list[np.ndarray], f_of: ValueNear, rate_of: RateOf) -> Extreme:
        """The least and greatest of ``series`` (one array per piece), each refined."""
        ends = []
        modes = []
        for sign in (1.0, -1.0):  # the least, then the greatest: (piece, sample) of the best
            k, i = min(
                ((k, int(np.argmin(sign * a))) for k, a in enumerate(series) if a.size),
                key=lambda ki: sign * float(series[ki[0]][ki[1]]),
            )
            ends.append(refine(pieces[k], series[k], f_of, rate_of, i, sign))
            modes.append(pieces[k].results[i].branch if several_modes else '')
        (x_lo, v_lo), (x_hi, v_hi) = ends
        return Extreme(v_lo, v_hi, x_lo, x_hi, *modes)

    out: dict[str, Extreme] = {}
    ratios: dict[str, float] = {}
    turning: list[str] = []
    for name in outputs:
        if not name.startswith(('link:', 'joint:')):
            raise ValueError(f'output {name!r}: name it link:<name> or joint:<name>')
        raw = [np.array([_value(mech, r, name) for r in p.results]) for p in pieces]
        angle = name.startswith('link:')
        if angle:
            start = _arc_start(raw, full and len(pieces) == 1)
            if start is None:
                turning.append(name)
                continue
            # every angle on the turn from the arc's start: the arc is [start, start + swing]
            series = [start + np.mod(a - start, 2 * math.pi) for a in raw]
        else:
            series = raw

        def f_of(r: Result, near: float, name: str = name, angle: bool = angle) -> float:
            v = _value(mech, r, name)
            return near + math.remainder(v - near, 2 * math.pi) if angle else v

        ext = extreme(series, f_of, _output_rate(mech, name))
        if angle:  # the swing's start in (-pi, pi]
            shift = ext.minimum - math.remainder(ext.minimum, 2 * math.pi)
            ext = dataclasses.replace(ext, minimum=ext.minimum - shift, maximum=ext.maximum - shift)
        out[name] = ext
        still = ext.maximum - ext.minimum <= STILL * (1.0 if angle else mech.length_scale)
        if full and not still:  # over the circuit's period: a turn, or more past change points
            forward = (ext.input_at_max - ext.input_at_min) % period
            back = period - forward
            short = min(forward, back)
            ratios[name] = max(forward, back) / short if short else math.inf
        if full:
            out[name] = _wrapped(ext)
    trans: dict[str, Extreme] = {}
    angles = [[transmission_angles(p.solver, r) for r in p.results] for p in pieces]
    keys = next(iter(a[0] for a in angles if a))
    for key in keys:
        mus = [np.array([abs(a[key]) for a in piece]) for piece in angles]

        def mu_of(r: Result, near: float, key: str = key) -> float:
            return abs(transmission_angles(pieces[0].solver, r)[key])

        trans[key] = extreme(mus, mu_of, _transmission_rate(pieces[0].solver, key))
        if full:
            trans[key] = _wrapped(trans[key])
    return InputSweep(act, full, out, trans, ratios, tuple(turning))


def classical_outputs(mech: Mechanism) -> list[str]:
    """The outputs a designer asks about for a 1-DOF mechanism (``link:<name>``,
    ``joint:<name>``): each link pivoted on the ground that the actuator does not drive (a
    rocker), and each slider joint on the ground's guide that is not an actuator (a slider's
    stroke)."""
    driven = {a.link if isinstance(a, AngleActuator) else a.joint for a in mech.actuators.values()}
    ground = set(mech.links[mech.ground].points)
    rockers = [
        l
        for l, link in mech.links.items()
        if l != mech.ground and l not in driven and len(set(link.points) & ground) == 1
    ]
    sliders = [
        j for j, pj in mech.prismatics.items() if pj.guide == mech.ground and j not in driven
    ]
    return [f'link:{l}' for l in rockers] + [f'joint:{j}' for j in sliders]


def quantities_report(mech: Mechanism) -> dict[str, Any] | None:
    """:func:`input_sweep` of :func:`classical_outputs` as plain data (None where it does not
    apply: not 1-DOF); where the sweep cannot be made, {'actuator', 'unavailable': why} (the
    motion section was left out without a word: a six-bar whose circuit passes a change point
    Newton cannot follow, an adversary)."""
    if len(mech.actuators) != 1:
        return None
    try:
        sweep = input_sweep(mech, classical_outputs(mech))
    except ValueError as exc:
        return {'actuator': next(iter(mech.actuators)), 'unavailable': str(exc)}

    def ext(e: Extreme) -> dict[str, Any]:
        out: dict[str, Any] = {
            'min': e.minimum,
            'max': e.maximum,
            'input_at_min': e.input_at_min,
            'input_at_max': e.input_at_max,
        }
        if e.mode_at_min or e.mode_at_max:  # (the circuit passes more than one mode)
            out.update(mode_at_min=e.mode_at_min, mode_at_max=e.mode_at_max)
        return out

    return {
        'actuator': sweep.actuator,
        'full_turn': sweep.full_turn,
        'outputs': {
            n: {**ext(e), 'stroke': e.maximum - e.minimum, 'time_ratio': sweep.time_ratio.get(n)}
            for n, e in sweep.outputs.items()
        },
        'turns_fully': list(sweep.turns_fully),
        'transmission_angle': {k: ext(e) for k, e in sweep.transmission.items()},
    }


def link_swings(
    mech: Mechanism, links: list[str], actuator: str
) -> dict[str, tuple[float | None, float | None]]:
    """(min, max) of each link's angle (rad; (None, None): it turns fully) over ``actuator``'s
    circuit, the others held: oscillation.oscillation_range where a closed-form plan places the
    mechanism; where Newton does, the circuit swept both ways between its toggles
    (:func:`input_sweep`: one actuator only). ValueError where neither applies."""
    from .oscillation import oscillation_range

    if Solver(mech).mode is SolveMode.CLOSED_FORM:
        return {link: oscillation_range(mech, link, actuator) for link in links}
    if len(mech.actuators) != 1:
        raise ValueError(
            f'{mech.name!r} is placed by Newton and has {len(mech.actuators)} actuators: link '
            'swings are swept for one actuator only'
        )
    sweep = input_sweep(mech, [f'link:{link}' for link in links])
    return {
        link: (None, None)
        if f'link:{link}' in sweep.turns_fully
        else (sweep.outputs[f'link:{link}'].minimum, sweep.outputs[f'link:{link}'].maximum)
        for link in links
    }
