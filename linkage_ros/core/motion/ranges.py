"""Actuator ranges: the input intervals where a mechanism assembles, and its toggles."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..mechanism import actuator_kind
from ..model import AngleActuator, Mechanism
from ..model.limits import angle_limit_arc
from .common import TWO_PI, clip_periodic, reference_scalar
from .components import actuator_parts
from .scan import (
    NOWHERE,
    Bracket,
    End,
    EndKind,
    ScanLine,
    Segment,
    Signs,
    held_reference,
    slide_bracket,
    turns_fully,
)
from .touches import TOUCH_RESOLUTION, touch_points
from .trace import trace_circuit
from .walk import walk_range

# ---- actuator ranges --------------------------------------------------------------------------


def scan_circuit(
    mech: Mechanism, name: str, held: Mapping[str, Any], samples: int
) -> tuple[ScanLine | None, float, list[Segment], Bracket | None]:
    """(line, x0, segments, bracket) of one scanned actuator; line None for a walk."""
    x0 = reference_scalar(mech, name)
    act = mech.actuators[name]
    periodic = isinstance(act, AngleActuator)
    bracket = None if periodic else slide_bracket(mech, name, x0)
    line = ScanLine(mech, name, held, samples, bracket)
    if line.closed:
        limits = angle_limit_arc(act.min, act.max) if periodic else (act.min, act.max)
        return line, x0, line.circuit(x0, limits), bracket
    traced = trace_circuit(mech, name, held, x0, bracket)
    if traced is not None and traced.full:
        return None, x0, [_full_turn(x0)], bracket
    if traced is not None:  # every monotone stretch of the whole circuit, its ends toggles
        # (or the bracket): a walk in the known stops at the first toggle each way
        return (
            None,
            x0,
            [
                Segment((), s.lo, s.hi, s.lo_end, s.hi_end, s.seed, start=s.start, drawn=s.drawn)
                for s in traced.stretches
            ],
            bracket,
        )
    comp = walk_range(mech, name, held, x0, periodic, bracket)
    if comp is NOWHERE:
        return None, x0, [], bracket
    if comp is None:
        return None, x0, [_full_turn(x0)], bracket
    lo, hi, le, he = comp
    return None, x0, [Segment((), lo, hi, le, he, x0)], bracket


def _full_turn(x0: float) -> Segment:
    """The segment of an angle that turns fully (a turn about ``x0``)."""
    return Segment(
        (), x0 - math.pi, x0 + math.pi, (EndKind.FULL, None), (EndKind.FULL, None), x0, None, True
    )


def actuator_range(
    mech: Mechanism, name: str, samples: int = 720, held: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """Range of one actuator with the other actuators held (at their reference-pose values unless
    ``held`` gives them).

    Returns a dict: ``min``, ``max`` (None for no bound), ``min_source`` / ``max_source``
    ('toggle': the assembly ends there; 'limit': the scene's limit; None), ``full_turn`` (the
    assembly lets an angle turn fully), ``toggles`` (assembly toggles, see
    :func:`toggle_positions`), ``reference`` (the reference-pose value), ``kind``, ``unit``.
    """
    if name not in mech.actuators:
        raise ValueError(
            f'{mech.name!r} has no actuator {name!r}; actuators: {sorted(mech.actuators)}'
        )
    act = mech.actuators[name]
    periodic = isinstance(act, AngleActuator)
    held = held_reference(mech, name, held)
    line, x0, segs, _ = scan_circuit(mech, name, held, samples)
    out: dict[str, Any] = {
        'name': name,
        'kind': actuator_kind(act),
        'unit': 'rad' if periodic else 'm',
        'reference': x0,
        'min': None,
        'max': None,
        'min_source': None,
        'max_source': None,
        'full_turn': False,
        'toggles': [],
        'assembles': bool(segs),
        'assembly': None,
    }
    if not segs:
        return out
    full = any(s.full for s in segs)
    lo = min(s.lo for s in segs)
    hi = max(s.hi for s in segs)
    if periodic and (full or hi - lo >= TWO_PI - 1e-12 or turns_fully(segs)):
        full = True
    lo_seg = min(segs, key=lambda s: s.lo)
    hi_seg = max(segs, key=lambda s: s.hi)
    lo_src = None if full else _source(lo_seg.lo_end)
    hi_src = None if full else _source(hi_seg.hi_end)
    toggles = (
        _segment_toggles(line, segs)
        if line is not None
        else [
            v
            for s in segs
            for v, e in ((s.lo, s.lo_end), (s.hi, s.hi_end))
            if e[0] is EndKind.TOGGLE
        ]
    )
    if periodic:
        lim = angle_limit_arc(act.min, act.max)
        if full:
            out['full_turn'] = True
            if lim is not None:
                out.update(min=lim[0], max=lim[1], min_source='limit', max_source='limit')
        else:
            if lim is None:
                pieces = [(lo, hi, False, False)]
            else:
                pieces = clip_periodic(lo, hi, lim)
            if not pieces:
                out['assembles'] = False
                return out
            # the piece holding the reference value (else the nearest one)
            piece = min(
                pieces,
                key=lambda p: 0.0 if p[0] <= x0 <= p[1] else min(abs(p[0] - x0), abs(p[1] - x0)),
            )
            a, b, a_lim, b_lim = piece
            shift = 0.0
            if a_lim and lim is not None:
                shift = lim[0] - a
            elif b_lim and lim is not None:
                shift = lim[1] - b
            else:
                shift = -TWO_PI * math.floor((a + math.pi) / TWO_PI)
            out.update(
                min=a + shift,
                max=b + shift,
                min_source='limit' if a_lim else lo_src,
                max_source='limit' if b_lim else hi_src,
            )
        # toggles and the assembly's own range in one turn starting at the assembly's min
        if full:
            base = -math.pi
            out['assembly'] = None
        else:
            base = lo - TWO_PI * math.floor((lo + math.pi) / TWO_PI)
            out['assembly'] = [base, base + (hi - lo)]
        out['toggles'] = _dedupe(sorted(base + (t - base) % TWO_PI for t in toggles), True)
    else:
        out.update(
            min=lo if lo_src != 'bracket' else None,
            max=hi if hi_src != 'bracket' else None,
            min_source=lo_src if lo_src != 'bracket' else None,
            max_source=hi_src if hi_src != 'bracket' else None,
        )
        # the assembly's own ends (unknown beyond a scene limit: the scan stops there)
        out['assembly'] = [lo if lo_src == 'toggle' else None, hi if hi_src == 'toggle' else None]
        out['toggles'] = _dedupe(sorted(toggles), False, mech.length_scale)
    return out


def _dedupe(values: Sequence[float], periodic: bool, scale: float = 1.0) -> list[float]:
    """``values`` (sorted) with those within TOUCH_RESOLUTION (rad, or of the length
    ``scale`` for slides) of the one before dropped."""
    tol = TOUCH_RESOLUTION * (1.0 if periodic else scale)
    res: list[float] = []
    for v in values:
        if not res or abs(v - res[-1]) > tol:
            res.append(float(v))
    if periodic and len(res) > 1 and abs(res[0] + TWO_PI - res[-1]) <= tol:
        res.pop()
    return res


def _source(end: End) -> str | None:
    kind = end[0]
    return kind.value if kind in (EndKind.TOGGLE, EndKind.LIMIT, EndKind.BRACKET) else None


def _segment_toggles(line: ScanLine, segs: Sequence[Segment]) -> list[float]:
    """Assembly-limited segment ends, the change points where the circuit crosses into the
    other assembly mode and interior points where a dyad margin touches zero."""
    out = []
    for s in segs:
        for v, e in ((s.lo, s.lo_end), (s.hi, s.hi_end)):
            if e[0] in (EndKind.TOGGLE, EndKind.CROSSING):
                out.append(v)
        n = max(64, line.samples // (1 if s.full else 2))

        def margins(xs: np.ndarray, signs: Signs = s.signs) -> np.ndarray:
            return line.margins(xs, signs)

        out += touch_points(margins, s.lo, s.hi, n, line.tol)
    # one value per toggle: a touch is found from each stretch it bounds, to TOUCH_RESOLUTION
    res: list[float] = []
    for v in sorted(out):
        if not res or not line.same(res[-1], v, TOUCH_RESOLUTION):
            res.append(v)
    return res


def input_ranges(
    mech: Mechanism, samples: int = 720
) -> dict[str, tuple[float | None, float | None]]:
    """{actuator: (min or None, max or None)} with the other actuators held at their
    reference-pose values: the toggle positions where the assembly ends (refined to 1e-12 rad or
    1e-12 of the length scale; where Newton places the scene, to where its solve still closes,
    up to ~1e-10 past), intersected with the actuator's own min / max.

    An angle that turns fully without limits gives (None, None); a reachable set spanning angle
    pi (or 0/2pi) is one interval min < max with max possibly > pi (see the module docstring).
    A slide without a limit on a side where the assembly does not end within a bracket of
    thousands of length scales around its reference value gives None on that side.
    """
    return {name: (i['min'], i['max']) for name, i in actuator_ranges(mech, samples).items()}


def actuator_ranges(mech: Mechanism, samples: int = 720) -> dict[str, dict[str, Any]]:
    """{actuator: :func:`actuator_range`} of every actuator, the others held at their
    reference-pose values. Each actuator is scanned on the independent part of the scene it
    moves (see :mod:`.components`): the same answer as on the whole scene, in time linear in
    the number of independent parts."""
    parts = actuator_parts(mech)
    return {name: actuator_range(parts[name], name, samples) for name in mech.actuators}


def toggle_positions(
    mech: Mechanism, actuator: str, samples: int = 720, held: Mapping[str, Any] | None = None
) -> list[float]:
    """Values of ``actuator`` (others held at the reference pose) where a dyad of the assembly
    toggles (its margin, |sin| of the transmission angle or its analogue, reaches 0): the ends of
    the assembly's range and any interior tangency, over every assembly mode the motion passes
    through. Geometric: the actuator's own limits are not applied (compare with
    :func:`actuator_range`). Angles are reported in [min, min + 2 pi) of the range."""
    toggles: list[float] = actuator_range(mech, actuator, samples, held)['toggles']
    return toggles
