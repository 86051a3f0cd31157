"""Which closure checks of a closed-form answer its plan satisfies by construction, and a
proven bound on how much each can miss: the readout (closed_form.SlotReadout) leaves those
checks for when ``Result.residual`` is read, and decides success and branch_defined with the
bound instead (exactly as it would with the checks: see there).

A closure check compares a joint's point as one link places it with the point as the other
places it (or a known angle read back off the placed links with its commanded value). Most
only the run's geometry decides (a body turned to a slide, a known point), and those stay
eager. Three kinds are rounding alone, whatever the command, and a fourth is rounding and the
scene's own drawn lengths; those four are bounded here:

* **anchored**: link L, a one-link body or the root of a welded one, is placed by a
  TWO_POINTS step whose first point is the joint point p, and the other link K set p's
  register, K of the ground body (see below) or placed from a point bounded so (step 2):
  the placement (scalar_plan ``two_points_single``) computes ``y = rot * lp`` and ``T = a - y``
  with ``a = R[p]`` and ``lp`` p's reference position, and the check computes ``a - (rot * p +
  T)``; with ``p == lp`` (the same float pair: checked) ``rot * p`` is ``y`` bit for bit (a
  welded root's frame is the identity: its link pose ``rot * (1 + 0i)`` and ``rot * 0 + T``
  have rot's and T's values, only the sign of a zero may change; ``lp`` is ``1 * p + 0``);
* **root weld**: L is welded to the ground body's root by a known angle that turns it about the
  joint point p (scalar_run ``turn_weld``: frame translation ``T = (1 * p + 0) - y``, ``y = rot *
  p``), the root set p's register (the template: ``1 * p + 0``, p's value) and the GROUND step
  places L with the identity (``(1 + 0i) * z`` and ``z + 0`` have z's value: only the sign of a
  zero may change, never a magnitude), so the check again computes ``a - (y + (a - y))``;
* **weld angle**: a known angle that is such a root weld, read back: the member's angle
  register is ``0.0 + (0.0 + rel)`` (or ``-rel``), the root's ``0.0``, ``rel = w - o`` with ``w``
  the command wrapped to [-pi, pi] and ``o`` the spec's offset, so the read-back is ``g = (w -
  o) + o`` (the reader's offset is the spec's: checked) and the check ``L |wrap(wrap(g) - w)|``;
* **dyad joint**: an RRR dyad with constant radii r1, r2 (scalar_dyads ``solve_rrr``) placed
  the joint point x, and each of the joint's two links, a one-link body, is placed by a
  TWO_POINTS step from one of the dyad's centres q (the one whose radius r is its length) to
  x: the check compares ``rot_K * x + T_K`` of the two links, each of which is x to within
  the dyad's radial error, the drawn length's difference from r and the rotation's rounding
  (step 4: its bound grows with the dyad's scale S, read from a register per solve).

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
   + 2 |p0|_1)(1 + 2^-40). A point that a TWO_POINTS placement from a point q of components
   <= M_q sets (its one link's, or its welded root's: the identity frame) is ``rot * r + (Q -
   rot * q_ref)``: components <= (M_q + |q_ref|_1 + |r|_1)(1 + u)^3 (1 + 2^-50) <= (...)(1 +
   2^-40), bounded in plan order from the ground's. So every anchored or root-weld miss is at
   most 4u max(M_a, |lp|_1 (1 + 2^-40)), M_a the bound of p's register: ``2 EPS max(...)``
   below (EPS = 2u).
3. Weld angle: |w| <= pi(1 + 4u) (ops.wrap_one returns [-pi, pi]); |g - w| <= u(2|w| + |o|)(1 +
   u) =: e. With |o| <= 2^20, e << 1, so g is within e of [-pi, pi]: either the readout's test
   finds g in (-pi, pi] and the miss is fl(L |fl(g - w)|) <= L e (1 + u)^2, or g is just outside,
   ``wrap_one(g)`` (Cody-Waite, |k| = 1 or 0, the final +-2 pi) is g -+ 2 pi within 6 u pi
   (one exact Sterbenz subtraction, two roundings of a value <= pi, 2 pi's float off by <= 2 u
   pi), fl(wrap(g) - w) is -+2 pi + (g - w) within 8.1 u pi, and its wrap within a few u of that
   small difference. In every case the miss is <= L u (11 pi + |o|)(1 + 11 u) <= L EPS (8 pi +
   |o|).

4. Dyad joint. Units: u as above; all quantities of the kernel are in S units (S its power of
   two, every input |component| < 4 S, so r1n, r2n < 4, d <= r1n + r2n < 8); the scaling is
   exact but where a result is subnormal (an absolute 2^-1075 each, collected in the
   2^-1058 below). The check is deferred only where the run's margin, the least of its dyads',
   is above the branch noise bound (> 0), so this dyad's margin is > 0: h > 0, not the toggle
   (h = 0 there), not coincident circles (margin 0), and the computed Kahan factor
   s - (l - m) is > 0. Then m >= l / 2 (else s <= m < l / 2 <= fl(l - m) and the factor would
   be <= 0), l - m is exact (Sterbenz), so (d, r1n, r2n) -- d the float the kernel computed --
   are the sides of a true triangle: |r1n - r2n| <= d <= r1n + r2n. Let A = (d^2 + r1n^2 -
   r2n^2) / (2 d) and H its altitude: A^2 + H^2 = r1n^2, (d - A)^2 + H^2 = r2n^2, |A| <= r1n,
   |d - A| <= r2n, H <= min(r1n, r2n).
   (a) ``along``: t = fl(fl(fl(r1n - r2n) / d) fl(r1n + r2n)) is t*(1 + 4.01 u) with |t*| =
   |r1n - r2n| (r1n + r2n) / d <= r1n + r2n (the triangle: no 1/d growth), so the computed
   foot has |E_a| = |along - A| <= 0.5 u (d + 5.02 |t*|) <= 3.01 u (r1n + r2n); clipping to
   [-r1n, r1n] (which holds A) only shrinks it. (b) ``h`` = H (1 + E_h): Heron's four
   factors on the sorted scaled sides have relative errors 2.01u, u, u, 2.01u (l - m exact),
   their square roots half that plus u each, three products and the division by dn: |E_h|
   <= 12 u. (c) Radial error about c1: x - r1n^2 = along^2 + h^2 - r1n^2 = 2 A E_a + E_a^2 +
   H^2 (2 E_h + E_h^2); dividing by sqrt(x) + r1n >= r1n (and E_a^2 / (sqrt(x) + r1n) <= 2
   |E_a|: sqrt(x) >= |along| >= |E_a| - r1n) gives |sqrt(x) - r1n| <= 4 |E_a| + 25 u r1n;
   about c2 the same with d - along = (d - A) - E_a and r2n. (d) The point: the kernel forms
   ``(c1n + (along + s i h) u_vec) S`` with u_vec = fl(dv / d) (|u_vec| = 1 +- 4 u; c2n - c1n
   = d u_vec + e_D, |e_D| <= 2.01 u d), one complex product (error <= 4.1 u r1n a
   component) and one sum (<= u (4 + 2 r1n)). So |X - Q| for Q = c1 or c2 is r S within
   (20.4 u (r1n + r2n) + 40 u r_max + 6 u + 2.01 u d sqrt 2) S <= 350 u S.
   (e) The placement of link K from q (register Q) to x: b = fl(X - Q) / fl(|.|) and the
   constant unit vector of v = x_ref - q_ref are each within 2.01 u of their directions;
   cross and dot within 2.02 u each, so their angle within 2.9 u; atan2 within 2^-49 (16 u),
   cos and sin within 2^-50: phi is the angle from v to X - Q within 24 u and rot is e^{i
   phi} within 8 u a component. Hence P = rot x_ref + (Q - rot q_ref), as the check computes
   it, is Q + e^{i phi} v within 8 u |v|_1 + 4 u (|q_ref|_1 + |x_ref|_1 + |Q|_inf) (four
   roundings), and |Q + e^{i phi} v - X| <= ||v| - |X - Q|| + 24 u |v| <= ||v| - r| + 350 u S
   + 24 u |v|. With |Q|_inf < 4 S and ||v| - r| <= |fl|fl(v)| - r| (1 + u) + 3 u |v|: each
   side's point is within (|fl|v| - r| + 128 u (|v|_1 + |q_ref|_1 + |x_ref|_1)) (1 + 2^-40) +
   400 u S of X a component (2^-46 = 128 u), and the check, their difference rounded once,
   misses by at most K0 + 2 (1 + u) 400 u S <= K0 + 2^-43 S (K0: the sum of both sides'
   constants, plus 2^-1058). X - Q = 0 is covered too (then |Q + e^{i phi} v - X| = |v|).
   No product overflows where every |reference component| and S are <= 2^1000 (checked; a
   larger S runs the check), so the rotations and translations read are finite (not tested).
   The readout takes the bound at the largest S for which it is <= 2^-38 L (a scene whose
   drawn lengths miss their stated ones by more than half that keeps the check eager).

The bounds need only that the registers a check reads are finite: the readout tests its
points and angles and, for these checks where their magnitudes are not bounded (below), their
links' rot and T (a T = a - y can overflow
where a and y are finite, in a scene drawn at ~1e308 m); any non-finite value takes the exact
path. No command value enters steps 1-3 but through the wrapped angle w, and step 4 only
through the dyad's scale S. A check of any other kind (a dyad with a radius that varies, a
welded body's placement, a weld of a weld, a slide, a known point, a joint no step
constructs) is not bounded here and stays eager.
test/core/solver/test_closure_bound.py checks the bounds against the misses themselves over
hypothesis-drawn four-bars and commands, and a four-bar at ~1e308 m whose frame overflows.
"""

from __future__ import annotations

import math
from typing import Any

from ..ops import wrap_one
from ..quantities import AngleSpec
from ..scalar_plan import ScalarProgram
from ..steps import StepKind, TwoPoints
from .result import EPS

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


def frames_bounded(bound: float) -> bool:
    """Whether the frames a check of steps 1-2 reads are finite wherever its points and
    angles are (then the readout need not test them): its bound is 2 EPS max(M_a, |lp|_1
    GROWTH), and where that max is <= 2^1000 every register it reads (a, y = rot lp, T = a -
    y, rot p + T; rot is the cosine and sine of a finite angle, or their product with (1, 0))
    is below 2^1002 in magnitude. (Step 3 reads angles only; step 4 bounds its own.)"""
    return bound <= 2.0 * EPS * _REF_LIMIT


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
        #: bodies placed by TWO_POINTS: their one link or their root (where it carries the
        #: first point) -> the first point; a one-link body's -> (its body, the second point);
        #: and the points such a placement sets from a first point of bounded magnitude
        #: (step 2), in plan order
        self.anchor: dict[str, str] = {}
        self.placed_to: dict[str, tuple[int, str]] = {}
        set_by_link: dict[str, list[str]] = {}  # (each link's points once: linear in a big
        for point, link in prog.set_by.items():  # scene)
            set_by_link.setdefault(link, []).append(point)
        for st in plan.steps:
            if not (st.op is StepKind.TWO_POINTS and isinstance(st.args, TwoPoints)):
                continue
            body, first = plan.bodies[st.body], st.args.first
            if prog.single[st.body]:
                self.placed_to[body.root] = (st.body, st.args.second)
            elif prog.carrier[(st.body, first)] != body.root:
                continue
            self.anchor[body.root] = first
            if first in self.magnitude:
                grown = self.magnitude[first] + _norm1(ref[first])
                for point in set_by_link.get(body.root, ()):
                    self.magnitude[point] = (grown + _norm1(ref[point])) * _GROWTH

    def joint(self, point: str, p: complex, setter: str, checker: str) -> float | None:
        """The bound (m) on the check of a revolute joint at ``point`` (reference position p, as
        the readout uses it) whose register ``setter``'s placement set and ``checker``'s
        placement is compared with, or None (not rounding alone)."""
        ref = self.prog.ref.get(point)
        if ref is None or ref != p or self.prog.set_by.get(point) != setter:
            return None
        lp = _norm1(ref) * _GROWTH  # |rot * lp| (step 2)
        if self.anchor.get(checker) == point and point in self.magnitude:  # anchored
            return 2.0 * EPS * max(self.magnitude[point], lp)
        weld = self.root_welds.get(checker)
        if setter == self.root and weld is not None and weld.shared_point == point:  # root weld
            return 2.0 * EPS * max(_norm1(ref), lp)
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
                return L * EPS * (8.0 * math.pi + abs(offset))
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
            got = wrap_one(got)
        a = got - R[wrapped]  # (the value reduced exactly first, by the run)
        if not _NEG_PI < a <= _PI:
            a = wrap_one(a)
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
