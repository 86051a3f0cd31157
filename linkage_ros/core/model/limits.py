"""The one rule for an input's limits: a value is inside [min, max] (within LIMIT_SLACK, the
rounding of its own arithmetic, on either side); an angle with both limits
compares on the circle (brought into [min, min + 2 pi) first, and a refusal names the nearer
limit); an angle with one limit compares as reported, brought into (-pi, pi] first.

:func:`limit_violation` judges one value (the scalar solve, each row of a batch, the scene's
reference pose); :func:`angle_limit_arc` is the same rule as the arc of allowed angles (the
motion analyses clip input ranges to it)."""

from __future__ import annotations

import math

from ..ops import wrap_one

#: a value this close to a limit (relative to max(1, |limit|)) still counts as inside, on
#: either side: the rounding of the value's own arithmetic (an inverse answer at a limit, a
#: value read back off a solved pose, carries it)
LIMIT_SLACK = 1e-12


def slack(limit: float) -> float:
    """How far past ``limit`` a value still counts as inside (LIMIT_SLACK)."""
    return LIMIT_SLACK * max(1.0, abs(limit))


def spans_a_turn(lower: float | None, upper: float | None) -> bool:
    """Whether an angle's limits are a full turn or more apart (they then limit nothing:
    every angle is within them, a whole number of turns away)."""
    return lower is not None and upper is not None and upper - lower >= 2.0 * math.pi


#: a robot description's revolute limits further from 0 than this (rad) and a turn or more
#: apart read as written in degrees (URDF's are radians: [-150, -90] meant degrees), and limit
#: nothing; nearer, they are the joint's range of several turns (a UR-style +-2 pi, a wrist's
#: +-4 rad), within which a value is judged and published as given
DEGREES_LIKE_RAD = 4.0 * math.pi


def written_in_degrees(lower: float | None, upper: float | None) -> bool:
    """Whether a description's revolute limits a turn or more apart read as degrees (an end
    beyond DEGREES_LIKE_RAD): they then limit nothing (the import notes it)."""
    return spans_a_turn(lower, upper) and max(abs(lower or 0.0), abs(upper or 0.0)) > (
        DEGREES_LIKE_RAD
    )


def angle_limit_arc(lo: float | None, hi: float | None) -> tuple[float, float] | None:
    """The angles (rad) :func:`limit_violation` allows, as the arc [a, b] (taken modulo 2 pi:
    an angle v is inside where a + (v - a) mod 2 pi <= b), or None where it allows every angle:
    no limit, or limits a full turn apart. A one-sided limit bounds the reported angle, in
    (-pi, pi]: [lo, pi] or [-pi, hi] (beyond +-pi: every reported angle, or none)."""
    if lo is None and hi is None:
        return None
    if lo is not None and hi is not None:
        return None if spans_a_turn(lo, hi) else (lo, hi)
    return (lo, math.pi) if lo is not None else (-math.pi, hi if hi is not None else math.pi)


def on_arc(value: float, lo: float, hi: float, slack: float = 0.0) -> bool:
    """Whether the angle ``value`` (rad) is on the arc [lo, hi] (taken modulo 2 pi; ``slack``
    rad past ``hi`` still counts): brought into [lo, lo + 2 pi) and compared with hi."""
    return lo + (value - lo) % (2 * math.pi) <= hi + slack


def limit_interval(
    lo: float | None, hi: float | None, periodic: bool
) -> tuple[float, float] | None:
    """The values :func:`limit_violation` allows, as the closed interval [a, b] (-inf / inf
    for a missing limit), where they are one: the limits of a value that is not an angle
    (``periodic``), whose rule is ``lo <= value <= hi`` (a finite value); None for an angle's,
    which compare on the circle. Lets a caller judge a finite value with two comparisons."""
    if periodic:
        return None
    return (-math.inf if lo is None else lo - slack(lo), math.inf if hi is None else hi + slack(hi))


def limit_violation(
    name: str, value: float, lo: float | None, hi: float | None, unit: str, periodic: bool
) -> str | None:
    """Why ``value`` (rad or m) is outside [lo, hi], or None. ``periodic``: an angle."""
    why = _limit_violation(name, value, lo, hi, unit, periodic)
    return None if why is None else why + _unit_hint(value, lo, hi, unit)


def _unit_hint(value: float, lo: float | None, hi: float | None, unit: str) -> str:
    """' (lengths are in m: 1600 mm is 1.6 m)' where ``value`` read in millimetres (an angle's
    in degrees, beyond a turn) would be within [lo, hi] and is far beyond the limits' size (a
    hundred times their largest magnitude for mm, twenty for degrees: 0.4 m past a stroke of
    +-0.25 m is no unit mistake, though 0.4 mm is within it, nor 6.3 rad for a [0, 0.8]
    knuckle): the likely mistake, named; else ''."""
    if not math.isfinite(value):
        return ''
    bounds = [abs(v) for v in (lo, hi) if v is not None and math.isfinite(v)]
    far = 100.0 if unit == 'm' else 20.0
    if unit == 'm' and bounds and far * abs(value) < max(bounds):
        # the other way round: limits written in mm without their unit (min: 2020 for a
        # cylinder of 2.02 m) that hold the value once read so
        ends = [None if v is None else v / 1000.0 for v in (lo, hi)]
        if (ends[0] is None or value >= ends[0]) and (ends[1] is None or value <= ends[1]):
            shown = ' .. '.join('' if v is None else f'{v:g}' for v in (lo, hi))
            as_mm = ' .. '.join('' if v is None else f'{v:g}' for v in ends)
            return f' (lengths are in m: limits {shown} read in mm are {as_mm} m)'
        return ''
    if not bounds or abs(value) < far * max(bounds):
        return ''
    if unit == 'm':
        meant, what = value / 1000.0, f'lengths are in m: {value:g} mm is {value / 1000.0:g} m'
    elif unit == 'rad' and abs(value) > 2 * math.pi:
        meant = math.radians(value)
        what = f'angles are in rad: {value:g} deg is {meant:.6g} rad'
    else:
        return ''
    inside = (lo is None or meant >= lo) and (hi is None or meant <= hi)
    return f' ({what})' if inside else ''


def _limit_violation(
    name: str, value: float, lo: float | None, hi: float | None, unit: str, periodic: bool
) -> str | None:
    if lo is None and hi is None:
        return None
    v = value
    # an angle is judged as the solve turns it: reduced exactly (float % 2 pi of 1e8 rad is
    # off by ~4e-9 rad, past the slack; of 1e16 rad by radians) before any arithmetic on it
    turned = wrap_one(value) if periodic and math.isfinite(value) else value
    if periodic and lo is not None and hi is not None:
        # (limits a full turn apart take every angle: the arc is the whole circle)
        if on_arc(turned, lo, hi, slack(hi)):
            return None
        v = lo + (turned - lo) % (2 * math.pi)
        over_hi = v - hi
        under_lo = lo + 2 * math.pi - v
        if under_lo <= slack(lo):  # (just below the minimum: brought a turn up, to ~lo + 2 pi)
            return None
        # equally far from both (a value half a turn from the middle of [lo, hi], e.g. -pi/2
        # for [0, pi]): the side the value was written on, not "beyond" a maximum it is not
        tied = abs(under_lo - over_hi) <= LIMIT_SLACK * 2 * math.pi
        if under_lo < over_hi if not tied else value < lo:
            at = _on_circle(value, lo - under_lo, unit)
            return f'{name} = {at} is below its minimum {lo:g} by {under_lo:.3g} {unit}'
        at = _on_circle(value, v, unit)
        return f'{name} = {at} is beyond its maximum {hi:g} by {over_hi:.3g} {unit}'
    if periodic:
        # one limit: the angle as reported, in (-pi, pi] (a command of 4 rad is the angle
        # -2.28 rad, below a minimum of -1 however it is written)
        v = turned  # (wrap_one: in (-pi, pi], -pi given as pi)
    if lo is not None and v < lo - slack(lo):
        got, limit = _apart(value, lo)
        at = _on_circle(value, v, unit, got) if periodic else f'{got} {unit}'
        return f'{name} = {at} is below its minimum {limit} by {lo - v:.3g} {unit}'
    if hi is not None and v > hi + slack(hi):
        got, limit = _apart(value, hi)
        at = _on_circle(value, v, unit, got) if periodic else f'{got} {unit}'
        return f'{name} = {at} is beyond its maximum {limit} by {v - hi:.3g} {unit}'
    return None


def _on_circle(value: float, compared: float, unit: str, text: str | None = None) -> str:
    """An angle as written (``text``, else 9 digits) and, where a whole turn apart from it, the
    angle on the circle it was compared as: '4.5 rad (-1.78318531 rad on the circle)' (a
    bare 'crank = 4.5 rad is below its minimum 0.46 by 2.24 rad' reads as wrong arithmetic)."""
    got = f'{value:.9g}' if text is None else text
    if abs(compared - value) < math.pi:  # the same angle as written (to rounding)
        return f'{got} {unit}'
    return f'{got} {unit} ({compared:.9g} {unit} on the circle)'


def _apart(value: float, limit: float) -> tuple[str, str]:
    """``value`` and ``limit`` as text that shows them apart: 9 significant digits and the
    limit as short as it goes, or both whole where those read alike (1.12 below 1.12)."""
    got, text = f'{value:.9g}', f'{limit:g}'
    if got == f'{limit:.9g}':
        return repr(value), repr(limit)
    return got, text
