"""Mobility and range analysis of planar linkages (pure numpy / math).

Four-bar conventions as in :mod:`linkage_ros.core.fourbar`: ground l1 = |O2O4| with O2 at the
origin and O4 at (l1, 0), input crank l2 = |O2A| at theta2, coupler l3 = |AB|, output rocker
l4 = |O4B| at theta4.  Lengths in any consistent unit, angles in radians counter-clockwise
from +x.

Range results are exact (closed form).  The only geometry used: |A - O4| depends on theta2
alone, |A - O4|^2 = l1^2 + l2^2 - 2 l1 l2 cos(theta2), and the dyad A-B-O4 closes iff
|l3 - l4| <= |A - O4| <= l3 + l4.  The equalities are the toggle positions (coupler and rocker
collinear).  The same holds for the output with |B - O2|^2 = l1^2 + l4^2 + 2 l1 l4 cos(theta4)
and the band [|l2 - l3|, l2 + l3].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .dyads import TANGENCY_TOL
from .fourbar import angle_opposite
from .mechanism import AngleActuator, Mechanism, SceneForm

#: Relative tolerance (of the sum of the four lengths) for the Grashof equality s + l = p + q.
GRASHOF_TOL = 1e-12

_TWO_PI = 2.0 * math.pi
_LENGTH_NAMES = ('l1', 'l2', 'l3', 'l4')


def _lengths(l1: float, l2: float, l3: float, l4: float) -> tuple[float, float, float, float, int]:
    """The four lengths as floats, checked (finite and > 0: NaN would compare as "turns fully"),
    divided by 2**e near the longest, and that exponent e.

    The results are angles, so scale-free; the power of two keeps the quotients exact, and
    squares and sums of huge lengths no longer overflow to inf or NaN."""
    out = []
    for name, v in zip(_LENGTH_NAMES, (l1, l2, l3, l4)):
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise ValueError(f'four-bar length {name} must be a number, got {v!r}') from None
        if not (math.isfinite(f) and f > 0):
            raise ValueError(f'four-bar length {name} must be finite and > 0, got {v!r}')
        out.append(f)
    e = math.frexp(max(out))[1]
    return (
        math.ldexp(out[0], -e),
        math.ldexp(out[1], -e),
        math.ldexp(out[2], -e),
        math.ldexp(out[3], -e),
        e,
    )


def kutzbach_dof(n_links: int, n_lower_pairs: int, n_higher_pairs: int = 0) -> int:
    """Kutzbach (Gruebler) mobility of a planar mechanism: 3(n - 1) - 2 j1 - j2.

    ``n_links`` counts the ground link; ``n_lower_pairs`` are full joints (revolute or
    prismatic, 2 constraints each); ``n_higher_pairs`` are half joints (1 constraint each).
    """
    return 3 * (int(n_links) - 1) - 2 * int(n_lower_pairs) - int(n_higher_pairs)


@dataclass(frozen=True)
class GrashofInfo:
    """Grashof classification of a four-bar (see :func:`grashof_info`)."""

    #: "crank-rocker", "double-crank", "grashof-double-rocker", "change-point", "triple-rocker"
    klass: str
    input_fully_rotates: bool  #: the input crank l2 turns 360 deg relative to the ground
    output_fully_rotates: bool  #: the output link l4 turns 360 deg relative to the ground
    s: float  #: shortest length
    l: float  #: longest length
    p: float  #: the smaller of the two intermediate lengths
    q: float  #: the larger of the two intermediate lengths
    assemblable: bool = True  #: l <= s + p + q (otherwise no configuration exists at all)


def _rotates(g: float, c: float, m: float, n: float, tol: float) -> bool:
    """Does link c (pinned to ground g) turn fully, with m, n the two links of the far dyad?

    The distance from the far end of c to the far ground pivot sweeps [|g - c|, g + c]; the dyad
    (m, n) spans it for every angle iff that sweep lies inside [|m - n|, m + n].
    """
    return (g + c <= m + n + tol) and (abs(g - c) >= abs(m - n) - tol)


def grashof_info(l1: float, l2: float, l3: float, l4: float) -> GrashofInfo:
    """Grashof classification of the four-bar with ground l1, input l2, coupler l3, output l4.

    With s, l the shortest and longest links and p <= q the other two:

    * s + l < p + q (Grashof): shortest is the ground -> "double-crank"; shortest is the input
      or output (adjacent to the ground) -> "crank-rocker" (which one turns fully is in
      ``input_fully_rotates`` / ``output_fully_rotates``); shortest is the coupler ->
      "grashof-double-rocker".
    * s + l = p + q within ``GRASHOF_TOL`` of the sum of the four lengths -> "change-point".
    * s + l > p + q -> "triple-rocker" (non-Grashof: no link turns fully).

    The rotation flags are computed from the exact reachability condition of each ground link
    (see :func:`_rotates`), which agrees with the rule above and also settles the ties of the
    change-point case (e.g. a parallelogram: both turn fully).
    """
    lengths = [float(l1), float(l2), float(l3), float(l4)]
    if not all(math.isfinite(v) and v > 0 for v in lengths):
        raise ValueError(f'four-bar lengths must be finite and > 0, got {lengths}')
    s, p, q, lng = sorted(lengths)
    tol = GRASHOF_TOL * sum(lengths)
    excess = (s + lng) - (p + q)
    if abs(excess) <= tol:
        klass = 'change-point'
    elif excess > 0:
        klass = 'triple-rocker'
    else:
        # Grashof with a strict inequality: the shortest link is unique (two equal shortest
        # links would need l < q), so index() is unambiguous.
        shortest = lengths.index(s)
        klass = {
            0: 'double-crank',
            1: 'crank-rocker',
            2: 'grashof-double-rocker',
            3: 'crank-rocker',
        }[shortest]
    return GrashofInfo(
        klass=klass,
        input_fully_rotates=_rotates(lengths[0], lengths[1], lengths[2], lengths[3], tol),
        output_fully_rotates=_rotates(lengths[0], lengths[3], lengths[1], lengths[2], tol),
        s=s,
        l=lng,
        p=p,
        q=q,
        assemblable=lng <= (s + p + q) + tol,
    )


def grashof_class(l1: float, l2: float, l3: float, l4: float) -> str:
    """Grashof class string of the four-bar, see :func:`grashof_info`."""
    return grashof_info(l1, l2, l3, l4).klass


def _angle_intervals(
    g: float, c: float, m: float, n: float, exp: int = 0
) -> list[tuple[float, float]] | None:
    """Reachable angles phi [rad] of link c about its ground pivot, phi measured from the
    direction towards the other ground pivot (distance g), when the far dyad is (m, n).

    The far end of c is at distance D(phi), D^2 = g^2 + c^2 - 2 g c cos(phi), from the other
    pivot; it must lie in [|m - n|, m + n].  D grows with |phi| on [0, pi], so the set is
    symmetric: |phi| <= beta (upper limit binds), |phi| >= alpha (lower limit binds) or both.

    Returns a list of (lo, hi) intervals with lo < hi, or None when every angle is reachable.
    Raises ValueError when no angle is reachable.  The sides are divided by 2**exp (see
    :func:`_lengths`); the message shows them as given.
    """
    lo_band, hi_band = abs(m - n), m + n
    d_min, d_max = abs(g - c), g + c
    # Same relative clamp as the position solver, so the range endpoints assemble.
    tol = TANGENCY_TOL * max(g, c, m, n)
    if max(d_min, lo_band) > min(d_max, hi_band) + tol:
        raise ValueError(
            f'four-bar cannot be assembled: sides {math.ldexp(g, exp)}, '
            f'{math.ldexp(c, exp)}, {math.ldexp(m, exp)}, {math.ldexp(n, exp)}'
        )
    upper = d_max > hi_band + tol
    lower = d_min < lo_band - tol
    if not upper and not lower:
        return None
    beta = float(angle_opposite(g, c, hi_band))
    alpha = float(angle_opposite(g, c, lo_band))
    if upper and not lower:
        return [(-beta, beta)]
    if lower and not upper:
        return [(alpha, _TWO_PI - alpha)]
    return [(alpha, beta), (-beta, -alpha)]


def fourbar_input_intervals(
    l1: float, l2: float, l3: float, l4: float
) -> list[tuple[float, float]] | None:
    """All reachable input angles theta2 [rad] as a list of counter-clockwise intervals.

    None when the input turns fully.  One interval (symmetric about 0 or pi) for a linkage whose
    input rocks on a single circuit; two mirror-image intervals (upper and lower half-plane, one
    per circuit) when the input rocks inside a Grashof linkage.
    """
    return _angle_intervals(*_lengths(l1, l2, l3, l4))


def fourbar_output_intervals(
    l1: float, l2: float, l3: float, l4: float
) -> list[tuple[float, float]] | None:
    """All reachable output angles theta4 [rad], like :func:`fourbar_input_intervals`."""
    # At O4 the direction towards O2 is theta4 = pi; phi = pi - theta4 maps the generic result.
    g, c, m, n, exp = _lengths(l1, l2, l3, l4)
    ivs = _angle_intervals(g, n, m, c, exp)
    if ivs is None:
        return None
    return [(math.pi - hi, math.pi - lo) for lo, hi in ivs]


def fourbar_input_range(l1: float, l2: float, l3: float, l4: float) -> tuple[float, float] | None:
    """Range of the input angle theta2 [rad] as (min, max), or None if the crank turns fully.

    The range is the closed interval going counter-clockwise from ``min`` to ``max`` with
    min < max; it may contain pi (e.g. (2.1, 4.2)) and ``max`` may exceed pi.  Its endpoints are
    the toggle positions (coupler and rocker collinear, |A - O4| = l3 + l4 or |l3 - l4|).

    * Non-Grashof (triple-rocker) linkages: one interval symmetric about theta2 = 0 or pi,
      covering every assemblable input (both branches).
    * Grashof linkages whose input rocks (double-rocker, or crank-rocker with the crank at the
      output): the input moves in two mirror-image intervals, one per circuit; this returns the
      one in the upper half-plane, 0 <= min < max <= pi (its mirror (-max, -min) is the other,
      see :func:`fourbar_input_intervals`).

    A kite (l1 = l2, l3 = l4) has an isolated singular point inside its range, theta2 = 0, where
    A lands on O4 and B is undetermined; the position solver reports ok False there only.

    Raises ValueError if the linkage cannot be assembled at any input angle.
    """
    ivs = fourbar_input_intervals(l1, l2, l3, l4)
    return None if ivs is None else ivs[0]


def fourbar_output_range(l1: float, l2: float, l3: float, l4: float) -> tuple[float, float] | None:
    """Range of the output angle theta4 [rad] as (min, max), or None if it turns fully.

    Same conventions as :func:`fourbar_input_range`; the limits are the positions where crank
    and coupler are collinear (|B - O2| = l2 + l3 or |l2 - l3|).  For a non-Grashof linkage the
    interval is symmetric about theta4 = 0 or pi; for a rocking output inside a Grashof linkage
    the upper half-plane circuit is returned (0 <= min < max <= pi).
    """
    ivs = fourbar_output_intervals(l1, l2, l3, l4)
    return None if ivs is None else ivs[0]


def fourbar_toggle_angles(l1: float, l2: float, l3: float, l4: float) -> list[float]:
    """Input angles theta2 [rad] in [0, 2 pi), sorted, at which coupler and rocker are collinear.

    These solve |A - O4| = l3 + l4 (extended) or |l3 - l4| (folded), i.e.
    cos(theta2) = (l1^2 + l2^2 - D^2) / (2 l1 l2), each D giving +-theta2.  A D that the crank
    can only just reach (within the relative tangency clamp) gives theta2 = 0 or pi once.
    """
    l1, l2, l3, l4, _ = _lengths(l1, l2, l3, l4)
    tol = TANGENCY_TOL * max(l1, l2, l3, l4)
    out: list[float] = []
    for dist in (l3 + l4, abs(l3 - l4)):
        if abs(l1 - l2) - tol <= dist <= l1 + l2 + tol:
            gamma = float(angle_opposite(l1, l2, dist))
            for ang in (gamma, (_TWO_PI - gamma) % _TWO_PI):
                # a tangent D gives gamma = 0 or pi, where +-gamma coincide
                if not any(abs(ang - a) <= 1e-15 for a in out):
                    out.append(ang)
    return sorted(out)


def transmission_angle(
    l1: npt.ArrayLike,
    l2: npt.ArrayLike,
    l3: npt.ArrayLike,
    l4: npt.ArrayLike,
    theta2: npt.ArrayLike,
) -> np.ndarray:
    """Transmission angle mu [rad, 0..pi] between coupler and rocker at input angle theta2.

    Cosine rule: cos(mu) = (l3^2 + l4^2 - |A - O4|^2) / (2 l3 l4), clipped to [-1, 1] (so an
    input that cannot be assembled reports 0 or pi).  Evaluated as atan2(4*area, l3^2 + l4^2 -
    D^2) with Kahan's triangle area, which equals the clipped cosine rule but keeps full accuracy
    near mu = 0 and pi, where arccos loses half its digits.  Independent of the assembly branch.
    Vectorised over all arguments; lengths must be finite and > 0 and theta2 finite
    (ValueError otherwise).
    """
    args = []
    for name, v in zip(_LENGTH_NAMES + ('theta2',), (l1, l2, l3, l4, theta2)):
        try:
            a = np.asarray(v, dtype=float)  # None becomes NaN here, refused below
        except (TypeError, ValueError):
            raise ValueError(
                f'transmission_angle: {name} must be a number or an array of numbers, got {v!r}'
            ) from None
        if not np.all(np.isfinite(a)):
            raise ValueError(f'transmission_angle: {name} must be finite, got {v!r}')
        if name != 'theta2' and not np.all(a > 0):
            raise ValueError(f'transmission_angle: four-bar length {name} must be > 0, got {v!r}')
        args.append(a)
    a1, a2, a3, a4, t2 = args
    # Divide by a power of two near the longest length (exact; mu is scale-free) so that the
    # squares below cannot overflow for huge lengths.
    exp = -np.frexp(np.maximum(np.maximum(a1, a2), np.maximum(a3, a4)))[1]
    s1, s2, s3, s4 = (np.ldexp(v, exp) for v in (a1, a2, a3, a4))
    # |A - O4|^2 written with sin^2(theta2/2) to avoid cancellation near theta2 = 0.
    d2 = (s1 - s2) ** 2 + 4.0 * s1 * s2 * np.sin(0.5 * t2) ** 2
    return angle_opposite(s3, s4, np.sqrt(d2))


@dataclass(frozen=True)
class ChainInfo:
    """Grashof-type class of a single-loop four-link chain driven by one crank angle (see
    :func:`four_link_chain_info`).

    ``klass``: for '4R' as :attr:`GrashofInfo.klass`; for '3R-1P' 'grashof', 'change-point' or
    'non-grashof'. ``lengths`` (m): 4R ``l1`` (ground), ``l2`` (driven), ``l3`` (coupler),
    ``l4`` (other ground-pivoted link); 3R-1P ``l_a``, ``l_b`` (the two links with two revolutes,
    named in ``links``) and the offset ``e``. A rotation flag is None where it does not apply
    (the output of a slider-crank is a slider) or is not derived (a slider pinned to nothing but
    the ground's slide, driven from the other side).
    """

    chain: str  #: '4R' or '3R-1P'
    klass: str  #: the class, see above
    lengths: dict[str, float]  #: the kinematic dimensions used, see above
    links: tuple[str, ...]  #: the links those lengths belong to, in their order
    input_fully_rotates: bool | None  #: the driven link turns 360 deg relative to the ground
    output_fully_rotates: bool | None  #: the other ground-pivoted link does
    rule: str  #: the inequality that decides the class, with numbers


def slide_chain_class(l_a: float, l_b: float, offset: float, tol: float = GRASHOF_TOL) -> str:
    """Class of a 3R-1P chain with revolute-to-revolute lengths l_a, l_b and offset e (the
    distance between the slide line and the revolute of its guide link, measured across it):
    lmin + e < lmax 'grashof' (the shorter of l_a, l_b turns fully relative to its neighbours),
    = 'change-point', > 'non-grashof' (every link only oscillates). Lengths in any one unit."""
    lmin, lmax = sorted((float(l_a), float(l_b)))
    e = abs(float(offset))
    if not (math.isfinite(lmin) and math.isfinite(lmax) and math.isfinite(e) and lmin > 0):
        raise ValueError(
            f'3R-1P lengths must be finite and > 0, got {l_a!r}, {l_b!r}, offset {offset!r}'
        )
    excess = lmin + e - lmax
    if abs(excess) <= tol * (lmin + lmax + e):
        return 'change-point'
    return 'non-grashof' if excess > 0 else 'grashof'


@dataclass(frozen=True)
class _Pair:
    """One joint of a link, seen from that link: a revolute (else the slide), the link at its
    other side and the point it sits on."""

    revolute: bool
    other: str
    point: str


def four_link_chain_info(mech: Mechanism) -> ChainInfo | None:
    """The Grashof-type class of a mechanism that is one four-link loop (four revolutes, or three
    revolutes and one slide) driven by one angle actuator on a ground-pivoted link (relative to
    the ground), from its reference-pose dimensions; None for any other mechanism.

    4R: :func:`grashof_info` of ground, driven link, coupler and the other ground-pivoted link
    (a ``four_bar`` shortcut scene: its own four lengths).
    3R-1P (seed 003: 'lmin + e > lmax: a non-Grashof 3R-1P chain, no link can rotate
    completely'): :func:`slide_chain_class`; which links turn fully follows from where |A - O|
    of the driven link's far point A can reach:

    * ground between two revolutes a = |O2 O4|, driven link b = |O2 A| pinned at O2 (inverted
      slider-crank): the slide line keeps distance e from O4, which needs |O4 A| >= e: the driven
      link turns fully iff |a - b| >= e, the slotted link at O4 iff b - a >= e; driving the
      slotted link instead swaps the two.
    * ground carries the slide, as guide or slider (slider-crank, crank b, rod c, e the distance
      of O2 from the line B moves on): A must stay within c of that line: the crank turns fully
      iff b + e <= c; the slider does not turn (None).
    """
    links = mech.links
    if (
        len(links) != 4
        or len(mech.actuators) != 1
        or len(mech.prismatics) > 1
        or len(mech.revolutes) + len(mech.prismatics) != 4
    ):
        return None  # not 4R or 3R-1P (e.g. a Scotch yoke)
    act = next(iter(mech.actuators.values()))
    if not isinstance(act, AngleActuator) or act.reference not in (None, mech.ground):
        return None
    pairs: dict[str, list[_Pair]] = {name: [] for name in links}
    for j in mech.revolutes:
        pairs[j.parent].append(_Pair(True, j.child, j.point))
        pairs[j.child].append(_Pair(True, j.parent, j.point))
    for pj in mech.prismatics.values():
        pairs[pj.guide].append(_Pair(False, pj.slider, pj.point))
        pairs[pj.slider].append(_Pair(False, pj.guide, pj.point))
    if any(len(v) != 2 or v[0].other == v[1].other for v in pairs.values()):
        return None  # not one simple loop of four links
    ground, driven = mech.ground, act.link
    if not any(q.other == ground and q.revolute for q in pairs[driven]):
        return None  # the driven link is not pinned to the ground
    pt = {k: np.asarray(v, float) for k, v in mech.points.items()}

    def span(link: str) -> float:  # distance between a link's two revolutes
        a, b = [q.point for q in pairs[link] if q.revolute]
        return float(np.hypot(*(pt[a] - pt[b])))

    tol = GRASHOF_TOL
    output = next(q.other for q in pairs[ground] if q.other != driven)
    coupler = next(l for l in links if l not in (ground, driven, output))
    if not mech.prismatics:
        if mech.form is SceneForm.FOUR_BAR:  # the lengths as the scene gives them
            sc = mech.shortcut
            l1, l2, l3, l4 = sc['ground'], sc['crank'], sc['coupler'], sc['rocker']
        else:
            l1, l2, l3, l4 = span(ground), span(driven), span(coupler), span(output)
        g = grashof_info(l1, l2, l3, l4)
        s, p, q, lng = g.s, g.p, g.q, g.l
        sign = {'change-point': '=', 'triple-rocker': '>'}.get(g.klass, '<')
        rule = f's + l = {s + lng:.6g} {sign} p + q = {p + q:.6g}'
        return ChainInfo(
            '4R',
            g.klass,
            {'l1': l1, 'l2': l2, 'l3': l3, 'l4': l4},
            (ground, driven, coupler, output),
            g.input_fully_rotates,
            g.output_fully_rotates,
            rule,
        )
    pj = next(iter(mech.prismatics.values()))
    u = np.asarray(pj.direction, float)
    u = u / np.hypot(*u)
    line = pt[pj.point]

    def across(p: str) -> float:  # signed distance of point p from the line
        d = pt[p] - line
        return float(u[0] * d[1] - u[1] * d[0])

    guide_r = next(q.point for q in pairs[pj.guide] if q.revolute)
    slider_r = next(q.point for q in pairs[pj.slider] if q.revolute)
    e = abs(across(guide_r) - across(slider_r))
    rr = [l for l in links if all(q.revolute for q in pairs[l])]
    klass = slide_chain_class(span(rr[0]), span(rr[1]), e, tol)
    lmin, lmax = sorted((span(rr[0]), span(rr[1])))
    rule = (
        f'lmin + e = {lmin + e:.6g} '
        f'{"<" if klass == "grashof" else ">" if klass == "non-grashof" else "="} '
        f'lmax = {lmax:.6g}'
    )
    lengths = {'l_a': span(rr[0]), 'l_b': span(rr[1]), 'e': e}
    slack = tol * (lmin + lmax + e)
    if ground in rr:  # inverted slider-crank
        a = span(ground)
        b = span(driven if driven in rr else output)
        rr_turns = abs(a - b) >= e - slack
        slotted_turns = b - a >= e - slack
        inp, out = (rr_turns, slotted_turns) if driven in rr else (slotted_turns, rr_turns)
    else:  # the ground carries the slide (as guide or slider: either way only the
        # relative angle is locked): a slider-crank, the driven link its crank (in rr)
        c = span(coupler)
        inp, out = span(driven) + e <= c + slack, None
    return ChainInfo('3R-1P', klass, lengths, tuple(rr), inp, out, rule)
