"""Whether a dyad may change branch between two commands: the closed form's continuity rule
takes the candidate nearest the predicted position near a dyad's singularity, which is right
where the motion passes through it (a change point: both continuations are real motions) and
wrong where it only passes near (a crank-rocker a hair inside the Grashof limit: its margin
dips to ~sqrt(eps) and rises again, and the other branch is the other circuit, which no motion
reaches). Between the two commands the margin of each dyad continuity moved is followed on
the previous branch (the commands a fraction s of the way, s in [0, 1]); a dyad whose margin
stays above CROSSING_MARGIN keeps its sign."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..dyads import wrap_angle
from ..execute import CONTINUITY_MARGIN, CROSSING_MARGIN
from ..quantities import AngleSpec, PointSpec
from ..scalar_plan import ScalarProgram
from .compiled import CompiledSolve, Values
from .continuity import State

#: commands tried along the way before each dyad's lowest is refined: a margin has one dip
#: between the commands of a stream, and 8 intervals find the one of a step taken from far away
_SAMPLES = 9
#: the refinement's resolutions in s: the square of a margin is smooth, ~a (s - s0)^2 near a
#: zero, so s to 1e-9 reads a zero's margin below CROSSING_MARGIN wherever the margin changes
#: less than 1e3 per unit s (a step under ~300 rad); the coarse pass settles a dip that bottoms
#: out far above it (_SETTLED times CROSSING_MARGIN: its best is within ~1e-6 of the bottom)
_S_TOLS = (1e-6, 1e-9)
_SETTLED = 100.0


def interpolate(c: CompiledSolve, a: Values, b: Values, t: float) -> Values:
    """The command a fraction t of the way from a to b (angles the short way round)."""
    out = []
    for s, va, vb in zip(c.specs, a, b):
        if isinstance(s, AngleSpec):
            out.append(wrap_angle(va) + t * wrap_angle(wrap_angle(vb) - wrap_angle(va)))
        elif isinstance(s, PointSpec):
            out.append(np.asarray(va) + t * (np.asarray(vb) - np.asarray(va)))
        else:
            out.append(va + t * (vb - va))
    return out


def lowest_margins(
    prog: ScalarProgram,
    c: CompiledSolve,
    start: Values,
    end: Values,
    signs: Sequence[int],
    dyads: Sequence[int],
) -> dict[int, float]:
    """The lowest margin of each branching dyad in ``dyads`` (indices into the plan's
    branching steps) on the commands between ``start`` and ``end``, on branch ``signs``: 0.0
    where some command between does not assemble (the dyad folded on the way). A dyad's is
    found to CROSSING_MARGIN only where it is below it (a search stops there)."""
    seen: dict[float, tuple[float, ...] | None] = {}

    def margins(s: float) -> tuple[float, ...] | None:
        # (one run gives every dyad's margin: each search's runs serve the others')
        if s not in seen:
            r = prog.run_parsed(interpolate(c, start, end, s), signs)
            seen[s] = None if r.failure >= 0 else r.margins
        return seen[s]

    grid = [float(s) for s in np.linspace(0.0, 1.0, _SAMPLES)]
    if any(margins(s) is None for s in grid):
        return dict.fromkeys(dyads, 0.0)

    def lowest(b: int) -> tuple[float, float]:
        """(dyad b's lowest margin of the commands run so far, the s of it)"""
        return min((m[b], s) for s, m in seen.items() if m is not None)

    out: dict[int, float] = {}
    # (the lowest first: their searches run where the others dip too, as often they do)
    for b in sorted(dyads, key=lambda b: lowest(b)[0]):
        low, at = lowest(b)
        for xatol in _S_TOLS:
            if low <= CROSSING_MARGIN or (xatol < _S_TOLS[0] and low > _SETTLED * CROSSING_MARGIN):
                break
            # between the commands run next to its lowest, where a dip's bottom is (one dip;
            # the searches before leave them close where dips coincide: loops in series)
            lo = max((s for s in seen if s < at), default=0.0)
            hi = min((s for s in seen if s > at), default=1.0)

            def square(s: float, b: int = b) -> float:
                # the margin squared: smooth through a zero (Brent's parabolas converge)
                m = margins(s)
                return 0.0 if m is None else m[b] * m[b]

            brent_minimum(square, lo, hi, xatol)
            if any(m is None for m in seen.values()):
                return dict.fromkeys(dyads, 0.0)
            low, at = lowest(b)
        out[b] = low
    return out


def kept_signs(
    prog: ScalarProgram,
    c: CompiledSolve,
    history: Sequence[State],
    end: Values,
    before: Sequence[int],
    after: Sequence[int],
) -> tuple[int, ...] | None:
    """The branch signs of the command ``end`` once every dyad continuity moved (``before`` ->
    ``after``) without passing through its singularity on the way is put back on its sign of
    ``before``; None where every move passed through one (``after`` stands). The way: from the
    last answer's command (history[-1]) to ``end``, and from the one before (history[-2]),
    which the prediction extrapolates from, for a dyad that step left near its singularity
    (below CONTINUITY_MARGIN): a step that passed a change point keeping its sign lands on the
    other solution curve there, and the next step's move back onto the motion's own is that
    crossing's. Where the input turned back (or held) at the last command, the way goes on
    from it the way it came, as far as the longer step: a toggle there (the input's limit:
    the plan stops assembling, or the margin reaches 0) is passed through, the circuit turning
    back with the input (a triple-rocker driven up to its toggle and back comes back in the
    other sign)."""
    moved = [b for b, (u, v) in enumerate(zip(before, after)) if u != v]
    last = history[-1]
    low = lowest_margins(prog, c, last.values, end, before, moved)
    near = [
        b
        for b in moved
        if low[b] > CROSSING_MARGIN
        and (b >= len(last.margins) or last.margins[b] < CONTINUITY_MARGIN)
    ]
    came: list[float] = []  # the step before, scale-free (none: unknown)
    if near and len(history) > 1:
        prev = history[-2].values
        came = c.check_system.value_step(prev, last.values)
        if any(came):
            low.update(lowest_margins(prog, c, prev, last.values, before, near))
            near = [b for b in near if low[b] > CROSSING_MARGIN]
    if near:
        goes = c.check_system.value_step(last.values, end)
        step = math.sqrt(sum(v * v for v in goes))
        if step > 0.0 and sum(a * b for a, b in zip(came, goes)) <= 0.0:
            # the input turned back (or held) at the last command: through a toggle there
            # (the input's limit: the plan stops assembling or the margin reaches 0), if one
            # lies on the way on from it, as far as the longer of the two steps
            reach = max(step, math.sqrt(sum(v * v for v in came)))
            beyond = interpolate(c, end, last.values, 1.0 + reach / step)
            low.update(lowest_margins(prog, c, last.values, beyond, before, near))
    back = {b for b in moved if low[b] > CROSSING_MARGIN}
    if not back:
        return None
    return tuple(before[b] if b in back else v for b, v in enumerate(after))


#: the golden section's shorter part, (3 - sqrt 5) / 2
_GOLD = 0.5 * (3.0 - math.sqrt(5.0))
_SQRT_EPS = math.sqrt(2.0**-52)


def brent_minimum(
    f: Callable[[float], float], a: float, b: float, xatol: float, max_calls: int = 100
) -> tuple[float, float]:
    """(x, f(x)) at a minimum of ``f`` on [a, b], to ``xatol`` in x: Brent's method, parabolic
    steps through the three best points with golden sections where they do not shrink the
    bracket, as scipy.optimize.fminbound takes them (its tolerances too). Written out: the
    crossing test runs on a live node's command path, and importing scipy.optimize there
    would stall the first command that moves a sign for ~0.4 s."""
    x = w = v = a + _GOLD * (b - a)
    fx = fw = fv = f(x)
    d = e = 0.0
    for _ in range(max_calls - 1):
        mid = 0.5 * (a + b)
        tol1 = _SQRT_EPS * abs(x) + xatol / 3.0
        tol2 = 2.0 * tol1
        if abs(x - mid) <= tol2 - 0.5 * (b - a):
            break
        golden = True
        if abs(e) > tol1:  # a parabola through x, w and v
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            p = -p if q > 0.0 else p
            q = abs(q)
            r, e = e, d
            if abs(p) < abs(0.5 * q * r) and q * (a - x) < p < q * (b - x):
                d = p / q
                if (x + d) - a < tol2 or b - (x + d) < tol2:
                    d = tol1 if x < mid else -tol1
                golden = False
        if golden:
            e = (b - x) if x < mid else (a - x)
            d = _GOLD * e
        u = x + (d if abs(d) >= tol1 else math.copysign(tol1, d))
        fu = f(u)
        if fu <= fx:
            a, b = (a, x) if u < x else (x, b)
            v, fv, w, fw, x, fx = w, fw, x, fx, u, fu
        else:
            a, b = (u, b) if u < x else (a, u)
            if fu <= fw or w == x:
                v, fv, w, fw = w, fw, u, fu
            elif fu <= fv or v in (x, w):
                v, fv = u, fu
    return x, fx
