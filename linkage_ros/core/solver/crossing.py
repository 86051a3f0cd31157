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
from collections.abc import Sequence

import numpy as np

from ..brent import brent_minimum
from ..dyads import wrap_angle
from ..execute import CONTINUITY_MARGIN, CROSSING_MARGIN
from ..quantities import AngleSpec, PointSpec
from ..scalar_plan import ScalarProgram
from .compiled import CompiledSolve, Values
from .continuity import State

#: commands tried along the way before each dyad's lowest is refined: a margin has one dip
#: between the commands of a stream, and 8 intervals find the one of a step taken from far away
_SAMPLES = 9
#: the refinement's resolutions in s (Brent's: within xatol / 3 + 1.5e-8 s of the bottom): the
#: square of a margin is smooth, ~a (s - s0)^2 near a zero, and Brent's parabolas land on the
#: bottom of one, so a zero is read below CROSSING_MARGIN for any step under a few rad; the
#: coarse pass settles a dip that bottoms out far above it (_SETTLED times CROSSING_MARGIN)
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
    where, at some command between, the plan stops assembling at that dyad or at one before
    it (where it folded on the way, or cannot be told). A dyad's is found to CROSSING_MARGIN
    only where it is below it (its search stops there)."""
    seen: dict[float, tuple[float, ...]] = {}

    def margins(s: float) -> tuple[float, ...]:
        # (one run gives every dyad's margin: each search's runs serve the others')
        if s not in seen:
            seen[s] = dyad_margins(prog, interpolate(c, start, end, s), signs)
        return seen[s]

    grid = [float(s) for s in np.linspace(0.0, 1.0, _SAMPLES)]
    for s in grid:
        margins(s)

    def lowest(b: int) -> tuple[float, float]:
        """(dyad b's lowest margin of the commands run so far, the s of it)"""
        return min((m[b], s) for s, m in seen.items())

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
                return margins(s)[b] ** 2

            brent_minimum(square, lo, hi, xatol)
            low, at = lowest(b)
        out[b] = low
    return out


def dyad_margins(prog: ScalarProgram, vals: Values, signs: Sequence[int]) -> tuple[float, ...]:
    """Each branching dyad's margin at command ``vals`` on branch ``signs`` (one per sign):
    0.0 for the dyad where the plan stops assembling and every dyad after it."""
    r = prog.run_parsed(vals, signs)
    m: tuple[float, ...] = r.margins
    return m + (0.0,) * (len(signs) - len(m)) if r.failure >= 0 else m


#: how far on past a turn-back a toggle is looked for: this many of the longer step at most
_AHEAD_STEPS = 64


def toggles_ahead(
    prog: ScalarProgram,
    c: CompiledSolve,
    last: Values,
    towards: Values,
    signs: Sequence[int],
    dyads: Sequence[int],
) -> list[int]:
    """The dyads of ``dyads`` that fold ahead of the command ``last``, in steps of the way to
    ``towards`` (the way the input was going): the plan stops assembling at the dyad itself
    before its margin rises again (from the turn-back in its near-toggle zone, the margin falls
    to the toggle, where the input's range ends; a dip short of 0 rises again, and a limit of
    another loop is not this dyad's toggle)."""
    out = []
    for b in dyads:
        low = math.inf
        for k in range(1, _AHEAD_STEPS + 1):
            r = prog.run_parsed(interpolate(c, last, towards, float(k)), signs)
            if r.failure >= 0 and len(r.margins) <= b:
                if len(r.margins) == b:  # (the run stopped at this dyad: its toggle)
                    out.append(b)
                break
            m = r.margins[b]  # (placed: the run went on past this dyad)
            if m >= low or m >= CONTINUITY_MARGIN:  # rising again, or out of the zone
                break
            low = m
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
    crossing's. Where the input turned back (or held) at the last command, in a dyad's
    near-toggle zone with its toggle ahead (toggles_ahead: the way it came, or with no step
    before, the other way from the new step), continuity's choice stands as at the toggle:
    the circuit turns back there with the input (a triple-rocker driven up to its toggle and
    back comes back in the other sign); a turn-back short of the toggle may so come back in
    either sign, by how near it came and how large the steps."""
    moved = [b for b, (u, v) in enumerate(zip(before, after)) if u != v]
    last = history[-1]
    low = lowest_margins(prog, c, last.values, end, before, moved)
    near = [
        b
        for b in moved
        if low[b] > CROSSING_MARGIN
        and (b >= len(last.margins) or last.margins[b] < CONTINUITY_MARGIN)
    ]
    came: list[float] = []  # the step before, scale-free (none: no answer before the last)
    prev = history[-2].values if len(history) > 1 else None
    if near and prev is not None:
        came = c.check_system.value_step(prev, last.values)
        if any(came):
            low.update(lowest_margins(prog, c, prev, last.values, before, near))
            near = [b for b in near if low[b] > CROSSING_MARGIN]
    if near:
        goes = c.check_system.value_step(last.values, end)
        if any(goes) and sum(a * b for a, b in zip(came, goes)) <= 0.0:  # turned back, or held
            # (a step on the way it came: from the one before, or back from the new one)
            if prev is not None and any(came):  # (came is the step from prev)
                ahead = interpolate(c, prev, last.values, 2.0)
            else:
                ahead = interpolate(c, end, last.values, 2.0)
            for b in toggles_ahead(prog, c, last.values, ahead, before, near):
                low[b] = 0.0
    back = {b for b in moved if low[b] > CROSSING_MARGIN}
    if not back:
        return None
    return tuple(before[b] if b in back else v for b, v in enumerate(after))
