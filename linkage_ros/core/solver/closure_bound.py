"""Which closure checks of a closed-form answer its plan satisfies by construction, and a
proven bound on how much each can miss: the readout (closed_form.SlotReadout) leaves those
checks for when ``Result.residual`` is read, and decides success and branch_defined with the
bound instead (exactly as it would with the checks: see there).

A closure check compares a joint's point as one link places it with the point as the other
places it (or a known angle read back off the placed links with its commanded value). Most
only the run's geometry decides (a dyad's point, a body turned to it), and those stay eager.
Three kinds are rounding alone, whatever the command, and are the ones bounded here:

* **anchored**: link L, a one-link body, is placed by a TWO_POINTS step whose first point is
  the joint point p, and the other link K (of the ground body, see below) set p's register:
  the placement (scalar_plan ``two_points_single``) computes ``y = rot * lp`` and ``T = a - y``
  with ``a = R[p]`` and ``lp`` p's reference position, and the check computes ``a - (rot * p +
  T)``; with ``p == lp`` (the same float pair: checked) ``rot * p`` is ``y`` bit for bit;
* **root weld**: L is welded to the ground body's root by a known angle that turns it about the
  joint point p (scalar_run ``turn_weld``: frame translation ``T = (1 * p + 0) - y``, ``y = rot *
  p``), the root set p's register (the template: ``1 * p + 0``, p's value) and the GROUND step
  places L with the identity (``(1 + 0i) * z`` and ``z + 0`` have z's value: only the sign of a
  zero may change, never a magnitude), so the check again computes ``a - (y + (a - y))``;
* **weld angle**: a known angle that is such a root weld, read back: the member's angle
  register is ``0.0 + (0.0 + rel)`` (or ``-rel``), the root's ``0.0``, ``rel = w - o`` with ``w``
  the command wrapped to [-pi, pi] and ``o`` the spec's offset, so the read-back is ``g = (w -
  o) + o`` (the reader's offset is the spec's: checked) and the check ``L |wrap(wrap(g) - w)|``.

The proof (u = 2^-53, the unit roundoff of round-to-nearest doubles; CPython's complex + and -
are componentwise, so each component is one rounded float operation; fl(x) = x (1 + d), |d| <=
u):

1. Anchored and root weld, per component, with a = p's register and y a component of ``rot *
   lp``: t = fl(a - y) = (a - y)(1 + d1), q = fl(y + t) = (a + (a - y) d1)(1 + d2), so a - q =
   -(a - y) d1 - a d2 - (a - y) d1 d2 and the check fl(a - q) has |.| <= (1 + u)(u(2|a| + |y|)
   + u^2(|a| + |y|)) <= 4u max(|a|, |y|).
2. Magnitudes (each component bounded by the 1-norm |z|_1 = |x| + |y|): cos and sin are within
   2^-50 of their true values on any libm, so |rot| components are <= 1 + 2^-50 and a component
   of fl(rot * z) is <= |z|_1 (1 + u)^2 (1 + 2^-50). Hence |y| <= |lp|_1 (1 + 2^-40). The root's
   points are their reference values (template); a member welded to the root about p0 has frame
   translation components <= 2 |p0|_1 (1 + u)^3 (1 + 2^-50) and its points components <= (|q|_1
   + 2 |p0|_1)(1 + 2^-40). So every anchored or root-weld miss is at most 4u max(M_a, |lp|_1 (1 +
   2^-40)), M_a the bound of p's register: ``2 EPS max(...)`` below (EPS = 2u).
3. Weld angle: |w| <= pi(1 + 4u) (ops._wrap_one returns [-pi, pi]); |g - w| <= u(2|w| + |o|)(1 +
   u) =: e. With |o| <= 2^20, e << 1, so g is within e of [-pi, pi]: either the readout's test
   finds g in (-pi, pi] and the miss is fl(L |fl(g - w)|) <= L e (1 + u)^2, or g is just outside,
   ``_wrap_one(g)`` (Cody-Waite, |k| = 1 or 0, the final +-2 pi) is g -+ 2 pi within 6 u pi
   (one exact Sterbenz subtraction, two roundings of a value <= pi, 2 pi's float off by <= 2 u
   pi), fl(wrap(g) - w) is -+2 pi + (g - w) within 8.1 u pi, and its wrap within a few u of that
   small difference. In every case the miss is <= L u (11 pi + |o|)(1 + 11 u) <= L EPS (8 pi +
   |o|).

The bounds need only that the registers a check reads are finite: the readout tests its
points and angles and, for these checks, their links' rot and T (a T = a - y can overflow
where a and y are finite, in a scene drawn at ~1e308 m); any non-finite value takes the exact
path. No dyad, no command value enters them but through the wrapped angle w. A check of any
other kind (a dyad's point, a second point of a TWO_POINTS step, a weld of a weld, a slide, a
known point, a joint no step constructs) is not bounded here and stays eager.
test/core/solver/test_closure_bound.py checks the bounds against the misses themselves over
hypothesis-drawn four-bars and commands, and a four-bar at ~1e308 m whose frame overflows.
"""

from __future__ import annotations

import math
from typing import Any

from ..ops import _wrap_one
from ..quantities import AngleSpec
from ..scalar_plan import ScalarProgram
from ..steps import StepKind, TwoPoints
from .result import _EPS

#: magnitudes through one placement: the (1 + u)^k (1 + 2^-50) factors of the proof, rounded up
_GROWTH = 1.0 + 2.0**-40
#: a known angle's offset beyond this (rad) is not bounded here (step 3 needs |o| <= 2^20)
_OFFSET_LIMIT = 2.0**20
_PI = math.pi
_NEG_PI = -math.pi
#: step 4: a dyad joint's miss grows by at most this times the dyad's scale S (>= 2 (1 + u)
#: 400 u = 800.1 u), and each side's constant part by this times its 1-norms (>= 36 u)
DYAD_SCALE_GROWTH = 2.0**-43
_SIDE_ROUNDING = 2.0**-46
#: underflow's absolute errors (subnormal results), rounded up generously
_UNDERFLOW = 2.0**-1058
#: reference points and scales beyond this (m) are not bounded here (no product overflows)
_REF_LIMIT = 2.0**1000


def _norm1(z: complex) -> float:
    return abs(z.real) + abs(z.imag)


class ConstructedChecks:
    """The checks of one compiled solve's plan that are rounding alone (see the module), with
    their bounds (m)."""

    def __init__(self, plan: Any, prog: ScalarProgram):
        self.plan, self.prog = plan, prog
        ref = prog.ref
        #: the ground body: its root, and its members welded to the root by a known angle about
        #: a shared point (member -> weld)
        self.root: str | None = None
        self.root_welds: dict[str, Any] = {}
        ground = [st.body for st in plan.steps if st.op is StepKind.GROUND]
        if len(ground) == 1:
            body = plan.bodies[ground[0]]
            if body.links and body.links[0] == body.root:
                self.root = body.root
                for w in body.welds:
                    if (
                        w.via == body.root
                        and w.shared_point is not None
                        and isinstance(plan.specs[w.spec_index], AngleSpec)
                    ):
                        self.root_welds[w.link] = w
        #: a bound on each component of the points the ground body's placement sets (m)
        self.magnitude: dict[str, float] = {}
        for point, link in prog.set_by.items():
            if link == self.root:
                self.magnitude[point] = _norm1(ref[point])
            elif link in self.root_welds:
                p0 = ref[self.root_welds[link].shared_point]
                self.magnitude[point] = (_norm1(ref[point]) + 2.0 * _norm1(p0)) * _GROWTH
        #: one-link bodies placed by TWO_POINTS: link -> its first point; and (its body, its
        #: second point)
        self.anchor: dict[str, str] = {}
        self.placed_to: dict[str, tuple[int, str]] = {}
        for st in plan.steps:
            if (
                st.op is StepKind.TWO_POINTS
                and isinstance(st.args, TwoPoints)
                and prog.single[st.body]
            ):
                (link,) = plan.bodies[st.body].links
                self.anchor[link] = st.args.first
                self.placed_to[link] = (st.body, st.args.second)

    def joint(self, point: str, p: complex, setter: str, checker: str) -> float | None:
        """The bound (m) on the check of a revolute joint at ``point`` (reference position p, as
        the readout uses it) whose register ``setter``'s placement set and ``checker``'s
        placement is compared with, or None (not rounding alone)."""
        ref = self.prog.ref.get(point)
        if ref is None or ref != p or self.prog.set_by.get(point) != setter:
            return None
        lp = _norm1(ref) * _GROWTH  # |rot * lp| (step 2)
        if self.anchor.get(checker) == point and point in self.magnitude:  # anchored
            return 2.0 * _EPS * max(self.magnitude[point], lp)
        weld = self.root_welds.get(checker)
        if setter == self.root and weld is not None and weld.shared_point == point:  # root weld
            return 2.0 * _EPS * max(_norm1(ref), lp)
        return None

    def dyad_joint(self, point: str, p: complex, links: tuple[str, str]) -> (
        tuple[float, int] | None
    ):  # fmt: skip
        """(K0 (m), the register of the dyad's scale S) where the revolute at ``point``
        (reference position p, as the readout uses it) between ``links`` is a second point of
        both their placements after an RRR dyad with constant radii placed it (step 4 of the
        module: its check misses by at most K0 + DYAD_SCALE_GROWTH * S), else None."""
        prog = self.prog
        ref = prog.ref.get(point)
        fixed = prog.rrr_fixed.get(point)
        if fixed is None or ref is None or ref != p or _norm1(ref) > _REF_LIMIT:
            return None
        a, r1, r2 = fixed
        k0 = 0.0
        for link in links:
            body, second = self.placed_to.get(link, (-1, ''))
            first = self.anchor.get(link)
            if second != point:
                return None
            if first == a.centre_a and body == a.body_a:
                r = r1
            elif first == a.centre_b and body == a.body_b:
                r = r2
            else:
                return None
            q = prog.ref[first]
            v = ref - q
            if _norm1(q) > _REF_LIMIT or not math.isfinite(_norm1(v)):
                return None
            # (|v| less r: the drawn length's difference from the stated one, and its rounding)
            k0 += abs(abs(v) - r) + _SIDE_ROUNDING * (_norm1(v) + _norm1(q) + _norm1(ref))
        return k0 * _GROWTH + _UNDERFLOW, prog.iscale[point]

    def angle(self, spec_index: int, link: str, reference: str, offset: float, L: float) -> (
        float | None
    ):  # fmt: skip
        """The bound (m: L times rad) on the read-back of known angle ``spec_index`` (read as
        ``link`` less ``reference`` plus ``offset``), or None."""
        s = self.plan.specs[spec_index]
        if not isinstance(s, AngleSpec) or s.offset != offset or abs(offset) > _OFFSET_LIMIT:
            return None
        for member, w in self.root_welds.items():
            if (
                w.spec_index == spec_index
                and {member, w.via} == {link, reference}
                and (s.link, s.reference) == (link, reference)
            ):
                return L * _EPS * (8.0 * math.pi + abs(offset))
        return None


def two_sides_worst(
    checks: list[tuple[complex, int, int, int, int]], R: list[Any], worst: float
) -> float:
    """``worst`` (m) and the largest component of each two-side closure miss: the point as one
    link places it less as the other does (NaN ones not counted)."""
    for p, prot, pT, crot, cT in checks:
        d = (R[prot] * p + R[pT]) - (R[crot] * p + R[cT])
        a = abs(d.real)
        if a > worst:
            worst = a
        a = abs(d.imag)
        if a > worst:
            worst = a
    return worst


def one_side_worst(checks: list[tuple[complex, int, int, int]], R: list[Any], worst: float) -> (
    float
):  # fmt: skip
    """``worst`` (m) and the largest component of each one-side closure miss: a point's
    register less the point as the other link places it (NaN ones not counted)."""
    for p, reg, rot, T in checks:
        d = R[reg] - (R[rot] * p + R[T])
        a = abs(d.real)
        if a > worst:  # max(worst, a), without the call (NaN is never greater)
            worst = a
        a = abs(d.imag)
        if a > worst:
            worst = a
    return worst


def angle_worst(
    checks: list[tuple[int, int, int, float]], R: list[Any], worst: float, L: float
) -> float:
    """``worst`` (m) and each known angle's miss read back off the placed links (times L)."""
    for wrapped, ia, ib, off in checks:  # slot_reads.slot_reader's angle, its wrap inlined
        got = R[ia] - R[ib] + off
        if not _NEG_PI < got <= _PI:
            got = _wrap_one(got)
        a = got - R[wrapped]  # (the value reduced exactly first, by the run)
        if not _NEG_PI < a <= _PI:
            a = _wrap_one(a)
        a = L * abs(a)
        if a > worst:
            worst = a
    return worst


#: a dyad joint is left for later where its bound at S is at most this fraction of the length
#: scale (the residual it allows keeps the branch noise bound low: ~1e-5)
_DYAD_TARGET = 2.0**-38


def scale_caps(
    joints: list[tuple[tuple[complex, int, int, int, int], float, int]],
    L: float,
    eager: list[tuple[complex, int, int, int, int]],
    bounds: list[float],
) -> list[tuple[int, float, tuple[complex, int, int, int, int]]]:
    """(S's register, the largest S its bound is taken at, the check) of each dyad joint (the
    check, K0, S's register: ConstructedChecks.dyad_joint) whose bound K0 + DYAD_SCALE_GROWTH S
    is within _DYAD_TARGET L for some S, its bound at that S appended to ``bounds``; the
    others' checks are appended to ``eager``."""
    out = []
    target = _DYAD_TARGET * L
    for two, k0, i_scale in joints:
        if not k0 <= 0.5 * target:
            eager.append(two)
            continue
        cap = min(_REF_LIMIT, (target - k0) / DYAD_SCALE_GROWTH * (1.0 - 2.0**-50))
        bounds.append((k0 + DYAD_SCALE_GROWTH * cap) * (1.0 + 2.0**-50))
        out.append((i_scale, cap, two))
    return out


def scales_worst(
    scales: list[tuple[int, float, tuple[complex, int, int, int, int]]], R: list[Any], worst: float
) -> float:
    """``worst`` (m) and the check of each dyad joint whose scale S is beyond the one its
    bound was taken at (or NaN: the kernel did not place the point)."""
    for i_scale, cap, two in scales:
        if not R[i_scale] <= cap:
            worst = two_sides_worst([two], R, worst)
    return worst
