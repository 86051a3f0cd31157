"""Whether a dyad may change branch between two commands: the closed form's continuity rule
takes the candidate nearest the predicted position near a dyad's singularity, which is right
where the motion passes through it (a change point: both continuations are real motions) and
wrong where it only passes near (a crank-rocker a hair inside the Grashof limit: its margin
dips to ~sqrt(eps) and rises again, and the other branch is the other circuit, which no motion
reaches). Between the two commands the margin of each dyad continuity moved is followed on
the previous branch (the commands a fraction s of the way, s in [0, 1]); a dyad whose margin
stays above CROSSING_MARGIN keeps its sign."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from ..dyads import wrap_angle
from ..execute import CROSSING_MARGIN
from ..quantities import AngleSpec, PointSpec
from ..scalar_plan import ScalarProgram
from .compiled import CompiledSolve, Values

#: commands tried along the way before the lowest is refined: a margin has one dip between
#: commands a stream sends, and 16 intervals find the one of a step taken from far away
_SAMPLES = 17
#: the refinement's resolution in s: a margin falls at most ~1 per rad of input near its zero,
#: so a zero is read below CROSSING_MARGIN for any step under ~1e6 rad
_S_TOL = 1e-12


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
    where some command between does not assemble (the dyad folded on the way)."""

    def margins(s: float) -> tuple[float, ...] | None:
        r = prog.run_parsed(interpolate(c, start, end, s), signs)
        return None if r.failure >= 0 else r.margins

    grid = np.linspace(0.0, 1.0, _SAMPLES)
    rows = [margins(float(s)) for s in grid]
    if any(m is None for m in rows):
        return dict.fromkeys(dyads, 0.0)
    out: dict[int, float] = {}
    for b in dyads:
        along = [m[b] for m in rows if m is not None]
        k = int(np.argmin(along))
        if along[k] <= CROSSING_MARGIN:
            out[b] = along[k]
            continue
        lo, hi = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, _SAMPLES - 1)])

        def margin_at(s: float, b: int = b) -> float:
            m = margins(s)
            return 0.0 if m is None else m[b]

        found = minimize_scalar(margin_at, bounds=(lo, hi), method='bounded',
                                options={'xatol': _S_TOL})  # fmt: skip
        out[b] = min(along[k], float(found.fun))
    return out


def kept_signs(
    prog: ScalarProgram,
    c: CompiledSolve,
    start: Values,
    end: Values,
    before: Sequence[int],
    after: Sequence[int],
) -> tuple[int, ...] | None:
    """The branch signs of the command ``end`` once every dyad continuity moved (``before`` ->
    ``after``) without passing through its singularity on the way from ``start`` is put back
    on its sign of ``before``; None where every move passed through one (``after`` stands)."""
    moved = [b for b, (u, v) in enumerate(zip(before, after)) if u != v]
    low = lowest_margins(prog, c, start, end, before, moved)
    back = {b for b in moved if low[b] > CROSSING_MARGIN}
    if not back:
        return None
    return tuple(before[b] if b in back else v for b, v in enumerate(after))
