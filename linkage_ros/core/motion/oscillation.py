"""Link oscillation: the range a link's angle sweeps as an input moves."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..dyads import wrap_angle
from ..model import AngleActuator, Mechanism
from ..model.limits import angle_limit_arc
from .common import TWO_PI, past_toggle, reachable_piece
from .ranges import scan_circuit
from .scan import EndKind, ScanLine, Signs, held_reference

# ---- link oscillation -------------------------------------------------------------------------


def oscillation_range(
    mech: Mechanism,
    link: str,
    actuator: str | None = None,
    samples: int = 720,
    held: Mapping[str, Any] | None = None,
) -> tuple[float | None, float | None]:
    """(min, max) of the angle of ``link`` (rad, direction of its axis) while ``actuator`` (default
    the first) runs over its range within its limits, the other actuators held; (None, None) when
    the link turns fully. Follows the circuit through toggles, so both assembly modes a
    non-Grashof chain passes through count. Extremes inside the range are refined by Brent's
    method; the angle convention is the module's (max may exceed pi)."""
    from scipy.optimize import minimize_scalar

    if link not in mech.links or link == mech.ground:
        raise ValueError(f'{link!r} is not a moving link of {mech.name!r}')
    actuator = actuator or next(iter(mech.actuators))
    act = mech.actuators[actuator]
    periodic = isinstance(act, AngleActuator)
    held = held_reference(mech, actuator, held)
    line, x0, segs, _ = scan_circuit(mech, actuator, held, samples)
    if line is None:
        raise ValueError(f'oscillation_range needs a closed-form plan for {actuator!r}')
    if not segs:
        return None, None
    arc = angle_limit_arc(act.min, act.max) if periodic else None
    # sample every segment (clipped to the actuator's limits), unwrap and stitch the angle
    pieces: list[tuple[Signs, np.ndarray, np.ndarray]] = []  # (signs, xs, unwrapped angles)
    stitch: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for k, s in enumerate(segs):
        n = max(
            129,
            int(samples * (s.hi - s.lo) / (TWO_PI if periodic else max(s.hi - s.lo, 1e-300))) + 1,
        )
        xs = np.linspace(s.lo, s.hi, n)
        ang = line.link_angle(xs, s.signs, link)
        # a toggle end read at the toggle itself (common.past_toggle)
        for at, end, outward in ((0, s.lo_end, -1.0), (-1, s.hi_end, 1.0)):
            if end[0] is EndKind.TOGGLE:
                exact = _at_toggle(line, float(xs[at]), outward, s.signs, link)
                if exact is not None:
                    ang[at] = exact
        good = np.isfinite(ang)
        xs, ang = xs[good], np.unwrap(ang[good])
        if xs.size == 0:
            continue
        if s.parent is not None and s.parent in stitch:
            pxs, pang = stitch[s.parent]
            j = int(np.argmin(np.abs(pxs - s.seed)))
            i = int(np.argmin(np.abs(xs - s.seed)))
            ang = ang + TWO_PI * round((pang[j] - ang[i]) / TWO_PI)
        stitch[k] = (xs, ang)
        # clip to the limits
        if arc is not None:  # (the piece the motion reaches: where the stretch starts)
            keep = np.zeros(xs.size, bool)
            for a, b, _, _ in reachable_piece(s.lo, s.hi, s.seed, arc):
                keep |= (xs >= a) & (xs <= b)
            for a, b, _, _ in reachable_piece(s.lo, s.hi, s.seed, arc):
                # make sure the exact limit values are sampled
                for v in (a, b):
                    va = line.link_angle([v], s.signs, link)[0]
                    if np.isfinite(va):
                        j = int(np.argmin(np.abs(xs - v)))
                        xs = np.append(xs, v)
                        ang = np.append(ang, ang[j] + wrap_angle(va - ang[j]))
                        keep = np.append(keep, True)
            xs, ang = xs[keep], ang[keep]
        elif not periodic:
            keep = np.ones(xs.size, bool)
            if act.min is not None:
                keep &= xs >= act.min
            if act.max is not None:
                keep &= xs <= act.max
            xs, ang = xs[keep], ang[keep]
        if xs.size:
            order = np.argsort(xs)
            pieces.append((s.signs, xs[order], ang[order]))
    if not pieces:
        return None, None
    all_ang = np.concatenate([p[2] for p in pieces])
    if all_ang.max() - all_ang.min() >= TWO_PI - 1e-9:
        return None, None

    def extreme(sign: int) -> float:
        best = -math.inf
        for signs, xs, ang in pieces:
            vals = sign * ang
            i = int(np.argmax(vals))
            best = max(best, float(vals[i]))
            if xs.size > 1:
                # the step either side of the best sample; at an end (a limit, a toggle) the
                # step inside it: an extreme just inside a limit beats the value at the limit
                a_i, b_i = max(i - 1, 0), min(i + 1, xs.size - 1)
                centre = float(ang[i])

                def f(x: float, signs: Signs = signs, centre: float = centre) -> float:
                    v = line.link_angle([x], signs, link)[0]
                    if not np.isfinite(v):
                        return math.inf
                    return -sign * (centre + float(wrap_angle(v - centre)))

                r = minimize_scalar(
                    f, bounds=(xs[a_i], xs[b_i]), method='bounded', options={'xatol': 1e-13}
                )
                if np.isfinite(r.fun):
                    best = max(best, -float(r.fun))
        return sign * best

    hi, lo = extreme(1), extreme(-1)
    shift = -TWO_PI * math.floor((lo + math.pi) / TWO_PI)
    return lo + shift, hi + shift


def _at_toggle(line: ScanLine, x: float, outward: float, signs: Signs, link: str) -> float | None:
    """The link's angle at the toggle found at input ``x`` (``outward``: common.past_toggle),
    None if no read past it assembles."""
    for past in past_toggle(x, outward):
        v = line.link_angle([past], signs, link)[0]
        if np.isfinite(v):
            return float(v)
    return None
