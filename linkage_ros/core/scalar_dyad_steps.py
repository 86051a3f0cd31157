"""The dyad steps of a :class:`~linkage_ros.core.scalar_plan.ScalarProgram`: closures over
register indices (resolved by the program once per plan) that solve one dyad of one command.

Each is the batch executor's step of the same kind (core/execute.py), operation for operation:
the RRR and RRP dyads place their point, the RPR dyad turns and places its body, the roller
side moves a roller's line to its mirror in the face. Where a dyad is near its singularity (its
margin now or in the previous answer below CONTINUITY_MARGIN) the branch nearest the prediction
is taken (:meth:`~linkage_ros.core.scalar_run.SlotRun.decide`).
"""

from __future__ import annotations

from cmath import isfinite as _cfinite
from collections.abc import Callable
from math import atan2, cos, sin
from typing import Any

from .execute import CONTINUITY_MARGIN
from .ops import cabs_one
from .scalar_dyads import rpr_angle, rrp_point, rrr_fallback, solve_rpr, solve_rrp, solve_rrr
from .scalar_run import Refused, SlotRun, Step, coincident, wrap

_CM = CONTINUITY_MARGIN

#: a dyad side's length: (its constant value, None) or (0.0, its reader from the registers)
Radius = tuple[float, Callable[[list[Any]], float] | None]


def rrr_step(
    at: tuple[int, int],
    x: str,
    regs: tuple[int, int, int, int],
    radius_a: Radius,
    radius_b: Radius,
    ref_off: complex,
) -> Step:
    """Point ``x`` (register regs[0]) at radius_a from centre A (regs[1]) and radius_b from
    centre B (regs[2]), the kernel's scale S in regs[3] (closure_bound reads it); ``ref_off``:
    x less A in the reference pose (for coincident circles); ``at``: (the plan step's index,
    the index of its sign among the branching steps')."""
    sx, s1, s2, s_scale = regs
    r1_const, r1_of = radius_a
    r2_const, r2_of = radius_b
    k_step, b = at
    # both radii constant (most dyads): their larger one and their difference are too
    fixed = r1_of is None and r2_of is None
    big_fixed = r2_const if r2_const > r1_const else r1_const
    gap_fixed = abs(r1_const - r2_const)

    def rrr(r: SlotRun) -> None:
        R = r.R
        c1, c2, tol = R[s1], R[s2], r.tol
        # (the cheap test first: equal radii are rare)
        if fixed:
            r1, r2 = r1_const, r2_const
            near = gap_fixed <= tol * big_fixed and cabs_one(c1 - c2) <= tol * big_fixed
        else:
            r1 = r1_const if r1_of is None else r1_of(R)
            r2 = r2_const if r2_of is None else r2_of(R)
            big = r2 if r2 > r1 else r1  # max(r1, r2), without the call
            near = abs(r1 - r2) <= tol * big and cabs_one(c1 - c2) <= tol * big
        if near:
            coincident(r, at, x, sx, c1, r1, ref_off)
            return
        pair = solve_rrr(c1, r1, c2, r2, tol)
        base, u, along, h, S, margin, ok, violation, _ = pair
        if not ok:
            R[sx] = rrr_fallback(pair, c1)
            raise Refused(k_step, violation)
        sg = r.signs[b]
        spread = 1j * h  # complex(0.0 * h, h) bit for bit: h is finite and >= +0.0 here
        if (margin < _CM or r.prev_small) and r.decide(margin, x):
            target = r.prefer[x]  # type: ignore[index]
            plus = (base + (along + 1 * spread) * u) * S
            plus = plus if _cfinite(plus) else rrr_fallback(pair, c1)
            minus = (base + (along + -1 * spread) * u) * S
            minus = minus if _cfinite(minus) else rrr_fallback(pair, c1)
            sg = 1 if cabs_one(plus - target) <= cabs_one(minus - target) else -1
        z = (base + (along + sg * spread) * u) * S
        if not _cfinite(z):  # beyond the float range
            R[sx] = rrr_fallback(pair, c1)
            raise Refused(k_step, 0.0)
        R[sx] = z
        R[s_scale] = S
        r.used += (sg,)  # (SlotRun.taken, inlined)
        r.margins += (margin,)
        if margin < r.margin:
            r.margin = margin

    return rrr


def side_step(b: int, shift: int, drawn_offset: float, across: complex) -> Step:
    """The roller's side (the executor's SIDE step): its sign moves the roller's line
    (register ``shift``) to the mirror of the drawn one in the face, or leaves it; never near a
    toggle. ``across``: the unit normal of the slide direction; ``b``: the index of its sign."""
    d = drawn_offset

    def side(r: SlotRun) -> None:
        sg = r.signs[b]
        r.R[shift] = (sg * abs(d) - d) * across
        r.taken(sg, 1.0)

    return side


def rrp_step(
    at: tuple[int, int],
    x: str,
    regs: tuple[int, int, int, int],
    radius: Radius,
    line: tuple[complex, complex],
    shift: int | None,
) -> Step:
    """Point ``x`` (regs[0]) at ``radius`` from its centre (regs[1]) on a slide's line: through
    line[0] (x's reference position, moved by the shift register where the slide has one)
    along line[1], both in the guide's frame (its rotation regs[2], translation regs[3]);
    ``at``: (the plan step's index, the index of its sign)."""
    sx, s1, grot, gT = regs
    k, b = at
    r_const, r_of = radius
    xref, d = line
    ish = shift

    def rrp(r: SlotRun) -> None:
        R = r.R
        rad = r_const if r_of is None else r_of(R)
        rot = R[grot]
        on_line = xref if ish is None else xref + R[ish]
        pair = solve_rrp(R[s1], rad, rot * on_line + R[gT], rot * d, r.tol)
        margin = pair[4]
        if not pair[5]:
            raise Refused(k, pair[6])
        sg = r.signs[b]
        if (margin < _CM or r.prev_small) and r.decide(margin, x):
            target = r.prefer[x]  # type: ignore[index]
            plus, _ = rrp_point(pair, 1)
            minus, _ = rrp_point(pair, -1)
            sg = 1 if cabs_one(plus - target) <= cabs_one(minus - target) else -1
        z, ok = rrp_point(pair, sg)
        R[sx] = z
        if not ok:  # beyond the float range
            raise Refused(k, 0.0)
        r.taken(sg, margin)

    return rrp


def rpr_step(
    at: tuple[int, int],
    regs: tuple[int, int, int],
    guide: tuple[int, int, int] | None,
    local_pivot: Callable[[list[Any]], complex],
    line: tuple[complex, complex, str],
    shift: int | None,
    place: Callable[..., None],
) -> Step:
    """Turn and place a body whose slide passes through a pivot: regs = (the slide's point,
    the pivot, the body's orientation register); ``guide``: the guide's (angle, rotation,
    translation) registers in its welded body's frame, None where the body is a single link
    (the identity); line = (the point's reference position, the slide direction, the
    continuity key); ``place(r, phi, rot, T)`` sets the body's links; ``at``: (the plan step's
    index, the index of its sign)."""
    sx, sp, ang = regs
    k, b = at
    xref, d, key = line
    ish = shift

    def rpr(r: SlotRun) -> None:
        R = r.R
        if guide is None:
            fphi, frot, fT = 0.0, complex(1.0, 0.0), complex(0.0, 0.0)
        else:
            fphi, frot, fT = R[guide[0]], R[guide[1]], R[guide[2]]
        lp = local_pivot(R)
        u = frot * d
        w = (frot * (xref if ish is None else xref + R[ish]) + fT) - lp
        e = u.real * w.imag - u.imag * w.real  # signed offset of the pivot
        psi0 = atan2(u.imag, u.real)
        pair = solve_rpr(R[sp], R[sx], e, r.tol)
        margin = pair[3]
        if not pair[4]:
            raise Refused(k, pair[5])
        sg = r.signs[b]
        if (margin < _CM or r.prev_small) and r.decide(margin, key):
            last = r.prefer[key]  # type: ignore[index]
            miss_p = abs(wrap(rpr_angle(pair, 1) - psi0 + fphi - last))
            sg = 1 if miss_p <= abs(wrap(rpr_angle(pair, -1) - psi0 + fphi - last)) else -1
        phi = rpr_angle(pair, sg) - psi0
        R[ang] = phi
        rot = complex(cos(phi), sin(phi))
        place(r, phi, rot, R[sp] - rot * lp)
        r.taken(sg, margin)

    return rpr
