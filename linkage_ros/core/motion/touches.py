"""Where a dyad's margin touches zero inside a scanned stretch (a toggle the motion touches and
passes) and whether the motion crosses into the other assembly mode there.

A touch is a change point (seed 000's s + l = p + q, the Scott-Russell's equal links): the two
solutions of a dyad meet and part again. Where its margin is V-shaped (|g| of a g that changes
sign: the two solutions cross), the smooth motion carries on in the other sign, as the
continuous solve (core.solver.continuity) and a real mechanism do; the fixed-sign solution
turns a corner there onto the other curve."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .common import TOUCHED_TOGGLE_MARGIN

#: a sampled local minimum of a dyad's margin below this is refined (golden section) to see
#: whether it touches a toggle (below TOUCHED_TOGGLE_MARGIN): a candidate, not a toggle
DIP_MARGIN = 0.05
#: points a refinement round evaluates in one plan run
_KARY = 16
#: how far apart two touches must be to be two (rad, or of the length scale): a touch's margin
#: rounds to its floor over ~1e-8 of the input, so one touch found from the two stretches it
#: joins may differ by that much
TOUCH_RESOLUTION = 1e-7
#: the margin's growth from a touch at one probe step to two: 2 where it is |linear| (the
#: solutions cross), 4 where it is quadratic (they touch and turn back), 1 where the probes
#: sit on the dyads' tangency floor (a touch flatter still: a higher-order one); a crossing
#: between the two
CROSSING_GROWTH = 3.0
PLATEAU_GROWTH = 1.5
#: probe steps from a touch for its shape (rad, or of the length scale): well clear of the
#: touch's position error (~1e-9) and well inside its dip (grid steps ~1e-2)
_SHAPE_PROBE = 1e-5
#: probe step for a crossing's root (rad, or of the length scale): well past the ~1e-8 a touch
#: is found to, large enough that the margins there (~1e-4, a difference of squares near the
#: tangency) carry about eight digits; g's curvature is extrapolated away
_ROOT_PROBE = 1e-4


def golden_min(f: Callable[[float], float], a: float, b: float, tol: float) -> tuple[float, float]:
    """Golden-section minimum of a unimodal f on [a, b] (robust on the V-shaped margin at a
    tangency, where parabolic steps stall at sqrt(eps))."""
    g = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(200):
        if abs(b - a) <= tol:
            break
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    return (c, fc) if fc <= fd else (d, fd)


def kary_min(
    margins: Callable[[np.ndarray], np.ndarray],
    a: float,
    b: float,
    tol: float,
    failure_ends: bool = False,
) -> tuple[float, float]:
    """The minimum of a unimodal margin on [a, b] (NaN counted as 1: the plan fails there),
    _KARY points a round: one plan run evaluates them all (a run of one point costs about as
    much as one of sixteen: golden_min's point-by-point rounds took seconds per scan). With
    ``failure_ends`` the first value where the plan fails ends the search: (it, NaN) (a dead
    zone in the dip: scan.ScanLine.dead_zones)."""
    best_x, best_f = a, math.inf
    for _ in range(100):
        xs = np.linspace(a, b, _KARY + 2)
        raw = margins(xs)
        if failure_ends and np.isnan(raw).any():
            return float(xs[int(np.flatnonzero(np.isnan(raw))[0])]), math.nan
        fs = np.nan_to_num(raw, nan=1.0)
        i = int(np.argmin(fs))
        if fs[i] < best_f:
            best_x, best_f = float(xs[i]), float(fs[i])
        a, b = float(xs[max(i - 1, 0)]), float(xs[min(i + 1, _KARY + 1)])
        if b - a <= tol:
            break
    return best_x, best_f


def _flat_centre(
    margins: Callable[[np.ndarray], np.ndarray], a: float, x: float, b: float, fx: float
) -> float:
    """Centre of the zone around x where the margin stays at its floor fx (a tangency's margin
    is |linear| in the input but rounds to its floor over ~sqrt(eps): the centre is the
    toggle); each edge to float resolution, _KARY points a round."""
    tau = fx + 1e-14

    def above(xs: np.ndarray) -> np.ndarray:
        return np.asarray(np.nan_to_num(margins(xs), nan=1.0) > tau)

    def edge(inside: float, outside: float) -> float:
        for _ in range(100):
            xs = np.linspace(inside, outside, _KARY + 2)
            j = int(np.argmax(above(xs)[1:])) + 1  # the first sample past the floor
            if (xs[j - 1], xs[j]) == (inside, outside):
                break  # (float resolution)
            inside, outside = float(xs[j - 1]), float(xs[j])
        return inside

    if above(np.array([a, b])).sum() < 2:
        return x
    return 0.5 * (edge(x, a) + edge(x, b))


def touch_points(
    margins: Callable[[np.ndarray], np.ndarray], lo: float, hi: float, n: int, tol: float
) -> list[float]:
    """The inputs in (lo, hi) where the margin (``margins``: inputs -> margins, NaN where the
    plan fails) touches zero: its sampled local minima below DIP_MARGIN, refined to the
    centre of the margin's floor there."""
    xs = np.linspace(lo, hi, n)
    m = margins(xs)
    inner = m[1:-1]  # local minima of the margin below DIP_MARGIN (NaN compares False)
    dips = np.flatnonzero((inner < DIP_MARGIN) & (inner <= m[:-2]) & (inner <= m[2:])) + 1
    out = []
    for i in dips:
        x, fx = kary_min(margins, xs[i - 1], xs[i + 1], tol)
        if fx < TOUCHED_TOGGLE_MARGIN:
            out.append(_flat_centre(margins, xs[i - 1], x, xs[i + 1], fx))
    return out


def crossing_root(margins: Callable[[np.ndarray], np.ndarray], x: float, scale: float) -> float:
    """The change point near ``x`` (a crossing found to ~1e-8) to ~1e-12 of the input. The
    margin is |g| with g smooth and changing sign there: the root of the line through the
    margins at x -+ h (the left one negated) is off by (g'' / 2 g') h^2, so the roots for h and
    2 h are extrapolated (Richardson) to remove it. ``x`` itself where the probes do not
    bracket it (no V there at this scale)."""
    h = _ROOT_PROBE * scale
    m = margins(np.array([x - 2 * h, x - h, x + h, x + 2 * h]))
    if not (np.all(np.isfinite(m)) and m[1] + m[2] > 0 and m[0] + m[3] > 0):
        return x
    near = x - h + 2 * h * float(m[1]) / float(m[1] + m[2])
    wide = x - 2 * h + 4 * h * float(m[0]) / float(m[0] + m[3])
    root = (4 * near - wide) / 3
    return root if abs(root - x) < h else x


def crosses(margins: Callable[[np.ndarray], np.ndarray], x: float, scale: float) -> bool:
    """Whether the margin at the touch ``x`` is V-shaped on both sides (the two solutions cross
    there), not quadratic or flat (they touch and part on the same side)."""
    h = _SHAPE_PROBE * scale
    m = margins(np.array([x - 2 * h, x - h, x + h, x + 2 * h]))
    if not np.all(np.isfinite(m)) or not np.all(m > 0):
        return False
    return bool(
        PLATEAU_GROWTH * m[1] < m[0] < CROSSING_GROWTH * m[1]
        and PLATEAU_GROWTH * m[2] < m[3] < CROSSING_GROWTH * m[2]
    )
