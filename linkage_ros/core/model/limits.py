"""The one rule for an input's limits: a value is inside [min, max]; an angle compares on the
circle (brought into [min, min + 2 pi) first, and a refusal names the nearer limit)."""

from __future__ import annotations

import math

#: a value this close to the maximum (relative) still counts as inside: the rounding of the
#: value's own arithmetic
LIMIT_SLACK = 1e-12


def limit_violation(
    name: str, value: float, lo: float | None, hi: float | None, unit: str, periodic: bool
) -> str | None:
    """Why ``value`` (rad or m) is outside [lo, hi], or None. ``periodic``: an angle."""
    if lo is None and hi is None:
        return None
    v = value
    if periodic and lo is not None and hi is not None:
        v = lo + (value - lo) % (2 * math.pi)
        if v <= hi + LIMIT_SLACK * max(1.0, abs(hi)):
            return None
        over_hi = v - hi
        under_lo = lo + 2 * math.pi - v
        # equally far from both (a value half a turn from the middle of [lo, hi], e.g. -pi/2
        # for [0, pi]): the side the value was written on, not "beyond" a maximum it is not
        tied = abs(under_lo - over_hi) <= LIMIT_SLACK * 2 * math.pi
        if under_lo < over_hi if not tied else value < lo:
            return (
                f'{name} = {value:.9g} {unit} is below its minimum {lo:g} by {under_lo:.3g} {unit}'
            )
        return f'{name} = {value:.9g} {unit} is beyond its maximum {hi:g} by {over_hi:.3g} {unit}'
    if lo is not None and v < lo:
        return f'{name} = {value:.9g} {unit} is below its minimum {lo:g} by {lo - v:.3g} {unit}'
    if hi is not None and v > hi:
        return f'{name} = {value:.9g} {unit} is beyond its maximum {hi:g} by {v - hi:.3g} {unit}'
    return None
