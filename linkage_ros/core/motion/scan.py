"""One-dimensional scans of an actuator over a closed-form plan (segments where it assembles)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Any, Literal, TypeAlias

import numpy as np
import numpy.typing as npt

from ..dyads import wrap_angle
from ..model import Mechanism, SlideActuator
from ..model.limits import limit_violation
from ..plan import Poses
from ..quantities import AngleSpec, PointSpec
from ..solver import Result, SolveMode, Solver
from .common import (
    ANGLE_TOL,
    KARY,
    LENGTH_TOL,
    MAX_SEGMENTS,
    TWO_PI,
    reachable_piece,
    reference_value,
    without_limits,
)
from .touches import TOUCH_RESOLUTION, crosses, crossing_root, kary_min, touch_points

#: how far inside an assembly edge its toggle's margin is sampled (rad, or of the length scale):
#: well clear of the tangency clamp (1e-12) and close enough for a parabola in margin^2 to be
#: exact to rounding
_TOGGLE_PROBE = 1e-6

#: a dyad margin below this at a toggle found to ~1e-12 of the input: that dyad is at its
#: toggle too (the margin grows as the square root of the distance from it)
_AT_TOGGLE = 1e-4
#: where a scan of a cylinder without a min starts (of the length scale): a length is more
#: than 0, and a command down to this is on the circuit the scan finds (at 1e-6 a command of
#: 1e-6 m on a 1 m boom was refused as "the other loop")
CYLINDER_FLOOR = 1e-12
#: a dyad margin below this at a crossing found to ~1e-8: a candidate for meeting there
_NEAR_CROSSING = 1e-3
#: a dyad margin whose least sample is below this may dip to 0 between samples: a dead zone
#: narrower than the scan's step (a four-bar 2e-7 of its crank past a change point cannot
#: pass 2e-3 rad of its crank's turn, which 720 samples stepped over: a numerics reviewer) is
#: searched for there. Next to a toggle the margin grows as the square root of the distance
#: (about 0.1 a step of 2 pi / 720 away on the scenes), past a change point linearly
_DIP_SEARCH = 0.3


class EndKind(StrEnum):
    """Why a stretch of a circuit ends where it does (its value names the end in a report)."""

    TOGGLE = 'toggle'  # the assembly ends: a branching dyad at its toggle
    CROSSING = 'crossing'  # the motion goes on in other dyad signs (a change point, touches.py)
    LIMIT = 'limit'  # the scene's limit
    BRACKET = 'bracket'  # the scan's own bracket (no limit there)
    FULL = 'full'  # a full turn: no end


class Nowhere(Enum):
    """A scan's answer where nothing assembles at the seed."""

    EMPTY = 'empty'


#: nothing assembles at the seed (a Component)
NOWHERE = Nowhere.EMPTY

#: a segment end: (TOGGLE, the branching dyads at their toggle, beyond which the first fails,
#: or None), (CROSSING, the dyads whose other signs the motion goes on in, or None where the
#: segment starts at one: a change point, touches.py; a symmetric mechanism's two halves cross
#: at one input), (LIMIT, None), (BRACKET, None) or (FULL, None)
End: TypeAlias = tuple[EndKind, tuple[int, ...] | None]
#: one branch sign per branching dyad of the plan
Signs: TypeAlias = tuple[int, ...]
#: a slide's scan bracket: (lo, hi, lo is a hard limit, hi is a hard limit) (m)
Bracket: TypeAlias = tuple[float, float, bool, bool]
#: the assembling interval around a seed: (lo, hi, lo_end, hi_end); None for a full turn, or
#: NOWHERE where nothing assembles
Component: TypeAlias = tuple[float, float, End, End] | None | Literal[Nowhere.EMPTY]
#: limits a scan respects: a circular (lo, hi) arc or None (angles), (lo, hi) with None sides
#: (slides)
Limits: TypeAlias = tuple[float | None, float | None] | None

# ---- one-dimensional scans over a closed-form plan --------------------------------------------


@dataclass
class Segment:
    """A stretch of the circuit on one assembly mode: the scanned known over [lo, hi] (unwrapped
    for angles), or the full turn; its ends are End pairs (EndKind and the dyads there)."""

    signs: Signs
    lo: float
    hi: float
    lo_end: End
    hi_end: End
    seed: float
    parent: int | None = None
    full: bool = False
    #: a traced (Newton-placed) stretch: its configuration at ``seed``, where its sweep starts
    #: (its loop-Jacobian mode in ``start.branch``: the same mode recurs on other stretches)
    start: Result | None = None
    #: a traced stretch the drawing lies on
    drawn: bool = False


def turns_fully(segs: Sequence[Segment]) -> bool:
    """Whether the circuit ``segs`` of an angle takes every input value with no end: one full
    turn, or stretches joined only at change points."""
    return bool(segs) and all(
        s.full or (s.lo_end[0] is EndKind.CROSSING and s.hi_end[0] is EndKind.CROSSING)
        for s in segs
    )


class ScanLine:
    """The mechanism along one scanned known with every other known held (closed-form plan)."""

    def __init__(
        self,
        mech: Mechanism,
        scan: str,
        held: Mapping[str, Any],
        samples: int = 720,
        bracket: Bracket | None = None,
    ):
        self.mech = mech
        self.free = without_limits(mech)
        self.scan = scan
        self.held = dict(held)
        # (the geometry, whichever solver the scene asks for: the closed form where there is
        # one; a scene with `solver: newton` read a Hart inversor's and a Scott-Russell's
        # motion through their toggles by Newton walks that stop at them, the Scott-Russell's
        # stroke without its limits 0.24 m where its limits alone allow 0.3)
        self.solver = Solver(
            self.free, knowns=[scan] + list(self.held), branch='reference', method='auto'
        )
        self.closed = self.solver.mode is SolveMode.CLOSED_FORM
        self.plan = self.solver.plan
        self.spec = self.solver.specs[0]
        self.periodic = isinstance(self.spec, AngleSpec)
        self.scale = mech.length_scale
        self.tol = ANGLE_TOL if self.periodic else LENGTH_TOL * self.scale
        self.samples = max(16, int(samples))
        self.bracket = bracket  # slides: (lo, hi, lo_hard, hi_hard)
        self.branch_of_step: dict[int, int] = {}
        k = 0
        for i, st in enumerate(self.plan.steps):
            if st.branching:
                self.branch_of_step[i] = k
                k += 1

    # -- evaluation
    def run(
        self, x: npt.ArrayLike, signs: Sequence[int]
    ) -> tuple[Poses, dict[str, np.ndarray], dict[str, np.ndarray]]:
        x = np.atleast_1d(np.asarray(x, float))
        n = x.shape[0]
        values = [x]
        for s in self.solver.specs[1:]:
            v = self.held[s.name]
            values.append(
                np.tile(np.asarray(v, float), (n, 1))
                if isinstance(s, PointSpec)
                else np.full(n, float(v))
            )
        return self.plan.run(values, n, list(signs))

    def ok(self, x: npt.ArrayLike, signs: Sequence[int]) -> np.ndarray:
        return np.asarray(self.run(x, signs)[2]['ok'], bool)

    def _failing_branch(self, x: float, signs: Sequence[int]) -> int | None:
        info = self.run([x], signs)[2]
        if info['ok'][0]:
            return None
        return self.branch_of_step.get(int(info['failure'][0]))

    def refine(self, good: float, bad: float, signs: Sequence[int]) -> tuple[float, int | None]:
        """The toggle between an assembling ``good`` and a failing ``bad`` value; returns (the
        toggle, index of the branching dyad that fails beyond). A k-ary search finds where the
        plan stops assembling to ``tol``; that edge lies past the true toggle by the dyads'
        tangency clamp (1e-12 of the length scale), so the toggle itself is then found as the
        root of the margin squared (|sin| of the transmission angle, squared: linear in the
        input at a toggle), a parabola through three samples just inside the edge."""
        for _ in range(200):
            if abs(bad - good) <= self.tol:
                break
            xs = good + (bad - good) * np.arange(1, KARY + 1) / (KARY + 1)
            okk = self.ok(xs, signs)
            fails = np.flatnonzero(~okk)
            if fails.size == 0:
                new_good, new_bad = xs[-1], bad
            else:
                i = int(fails[0])
                new_good = xs[i - 1] if i > 0 else good
                new_bad = xs[i]
            if new_good == good and new_bad == bad:
                break
            good, bad = float(new_good), float(new_bad)
        return self._toggle_root(good, bad, signs), self._failing_branch(bad, signs)

    def _toggle_root(self, good: float, bad: float, signs: Sequence[int]) -> float:
        """The zero of the margin squared near the assembly edge ``good`` (``good`` itself where
        the samples do not show a toggle's parabola: an edge that is no tangency)."""
        step = math.copysign(_TOGGLE_PROBE * (1.0 if self.periodic else self.scale), bad - good)
        xs = good - step * np.arange(1.0, 4.0)
        m = self.margins(xs, signs)
        if not np.all(np.isfinite(m)) or not np.all(m > 0):
            return good
        coef = np.polyfit((xs - good) / step, m * m, 2)  # in steps from the edge
        roots = np.roots(coef) if coef[0] != 0.0 else np.roots(coef[1:])
        near = [float(r.real) for r in roots if abs(r.imag) == 0.0 and -0.5 <= r.real <= 1e-3]
        if not near:
            return good
        return good + step * max(near)

    def _dip(self, a: float, b: float, signs: Sequence[int], k: int) -> float | None:
        """A value in [a, b] where the plan does not assemble, found by zooming in on the
        least margin of dyad ``k`` (unimodal there: a V past a change point, a cusp at a
        toggle), or None where the margin stays above 0 down to the scan's tolerance."""

        def own(xs: np.ndarray) -> np.ndarray:  # dyad k's margin, NaN where the plan fails
            info = self.run(xs, signs)[2]
            return np.where(info['ok'], np.asarray(info['margins'])[:, k], np.nan)

        x, at = kary_min(own, a, b, self.tol, failure_ends=True)
        return x if math.isnan(at) else None

    def dead_zones(self, xs: np.ndarray, ok: np.ndarray, signs: Sequence[int]) -> dict[int, float]:
        """{i: a value between xs[i] and the next sample (xs[i + 1]; for an angle's turn of
        samples, the last's next is the first's, a turn on) where the plan does not assemble,
        given as its offset from xs[i]}, for each pair of assembling samples with such a value
        between them: the local minima of each dyad's margin below _DIP_SEARCH, searched."""
        n = len(xs)
        if n < 3 or not ok.any():
            return {}
        m = np.asarray(self.run(xs, signs)[2]['margins'], float)
        if m.ndim != 2 or m.shape[1] == 0:
            return {}
        m = np.where(ok[:, None], m, np.inf)
        step = xs[1] - xs[0] if self.periodic else None
        out: dict[int, float] = {}
        for k in range(m.shape[1]):
            col = m[:, k]
            if self.periodic:
                left, right = np.roll(col, 1), np.roll(col, -1)
            else:
                left = np.concatenate([[np.inf], col[:-1]])
                right = np.concatenate([col[1:], [np.inf]])
            lows = np.flatnonzero((col < _DIP_SEARCH) & (col <= left) & (col <= right))
            for s in lows.tolist():
                if self.periodic:
                    assert step is not None
                    a, b = float(xs[s]) - step, float(xs[s]) + step
                else:
                    a, b = float(xs[max(s - 1, 0)]), float(xs[min(s + 1, n - 1)])
                x = self._dip(a, b, signs, k)
                if x is None:
                    continue
                if x > xs[s]:
                    i, base = s, float(xs[s])
                elif self.periodic:  # (the sample before the first: the last, a turn back)
                    assert step is not None
                    i, base = (s - 1) % n, float(xs[s]) - step
                elif s > 0:
                    i, base = s - 1, float(xs[s - 1])
                else:
                    continue
                out.setdefault(i, x - base)
        return out

    # -- components
    def component(self, seed: float, signs: Sequence[int]) -> Component:
        """The interval of assembling values around ``seed`` on one assembly mode:
        None for a full turn, else (lo, hi, lo_end, hi_end)."""
        if self.periodic:
            return self._component_periodic(seed, signs)
        return self._component_line(seed, signs)

    def _component_periodic(self, seed: float, signs: Sequence[int]) -> Component:
        n = self.samples
        c = n // 2
        dt = TWO_PI / n
        xs = seed + (np.arange(n) - c) * dt
        ok = self.ok(xs, signs)
        ok[c] = True  # the seed assembles (it may sit on a toggle)
        dips = self.dead_zones(xs, ok, signs)
        if ok.all() and not dips:
            return None
        up = 0
        while ok[(c + up + 1) % n] and (c + up) % n not in dips:
            up += 1
        down = 0
        while ok[(c - down - 1) % n] and (c - down - 1) % n not in dips:
            down += 1
        past_hi = dips.get((c + up) % n, dt)  # (where the motion up fails, from its last sample)
        past_lo = dt - dips.get((c - down - 1) % n, 0.0)
        hi, kh = self.refine(seed + up * dt, seed + up * dt + past_hi, signs)
        lo, kl = self.refine(seed - down * dt, seed - down * dt - past_lo, signs)
        return (
            lo,
            hi,
            (EndKind.TOGGLE, self._toggling(lo, seed - down * dt, signs, kl)),
            (EndKind.TOGGLE, self._toggling(hi, seed + up * dt, signs, kh)),
        )

    def _toggling(
        self, x: float, inside: float, signs: Sequence[int], k: int | None
    ) -> tuple[int, ...] | None:
        """The branching dyads at their toggle at ``x`` (the toggle of dyad ``k``, found from
        the assembling value ``inside``): ``k`` and any other whose margin is below _AT_TOGGLE
        there (a symmetric gripper's two halves reach their toggles at one input, and the
        motion turns back through both)."""
        if k is None:
            return None
        for at in (x, inside):
            _, _, info = self.run([at], signs)
            if info['ok'][0]:
                low = np.flatnonzero(info['margins'][0] < _AT_TOGGLE).tolist()
                return tuple(sorted({k, *low}))
        return (k,)

    def _component_line(self, seed: float, signs: Sequence[int]) -> Component:
        assert self.bracket is not None, 'a slide scan needs its bracket'
        blo, bhi, hard_lo, hard_hi = self.bracket
        grow = 0
        while True:
            xs = np.unique(
                np.concatenate([np.linspace(blo, bhi, self.samples), [min(max(seed, blo), bhi)]])
            )
            c = int(np.searchsorted(xs, min(max(seed, blo), bhi)))
            ok = self.ok(xs, signs)
            dips = self.dead_zones(xs, ok, signs)
            if not ok[c]:
                # a seed outside the limits (or on a toggle's wrong side): nearest assembling sample
                good = np.flatnonzero(ok)
                if good.size == 0:
                    return NOWHERE
                c = int(good[np.argmin(np.abs(good - c))])
            i = c
            while i + 1 < xs.size and ok[i + 1] and i not in dips:
                i += 1
            j = c
            while j - 1 >= 0 and ok[j - 1] and j - 1 not in dips:
                j -= 1
            soft_hit = (i == xs.size - 1 and not hard_hi) or (j == 0 and not hard_lo)
            if soft_hit and grow < 3:
                grow += 1
                w = 4.0 * (bhi - blo)
                if i == xs.size - 1 and not hard_hi:
                    bhi = bhi + w
                if j == 0 and not hard_lo:
                    blo = self._soft_low(blo - w)
                continue
            break
        hi_end: End
        lo_end: End
        if i == xs.size - 1:
            hi, hi_end = float(xs[-1]), (EndKind.LIMIT if hard_hi else EndKind.BRACKET, None)
        else:
            hi, k = self.refine(float(xs[i]), float(xs[i]) + dips.get(i, xs[i + 1] - xs[i]), signs)
            hi_end = (EndKind.TOGGLE, self._toggling(hi, float(xs[i]), signs, k))
        if j == 0:
            lo, lo_end = float(xs[0]), (EndKind.LIMIT if hard_lo else EndKind.BRACKET, None)
        else:
            lo, k = self.refine(float(xs[j]), float(xs[j - 1]) + dips.get(j - 1, 0.0), signs)
            lo_end = (EndKind.TOGGLE, self._toggling(lo, float(xs[j]), signs, k))
        return lo, hi, lo_end, hi_end

    def _soft_low(self, v: float) -> float:
        act = self.mech.actuators.get(self.scan)
        if isinstance(act, SlideActuator) and act.cylinder:
            return max(v, CYLINDER_FLOOR * self.scale)  # a pin-to-pin length stays > 0
        return v

    def same(self, a: float, b: float, tol: float = 1e-9) -> bool:
        """Whether two inputs are one within ``tol`` (rad, or of the length scale)."""
        if self.periodic:
            return abs(wrap_angle(a - b)) <= tol
        return abs(a - b) <= tol * self.scale

    # -- circuits
    def within(self, v: float, limits: Limits) -> bool:
        """Is ``v`` inside the actuator's limits ((lo, hi) with None sides for slides, a circular
        (lo, hi) or None for angles)?"""
        if limits is None:
            return True
        lo, hi = limits
        # the limit rule itself (model.limits: an angle on the arc, each side with its slack)
        return limit_violation('', v, lo, hi, '', self.periodic) is None

    def crossings(self, lo: float, hi: float, signs: Signs) -> list[tuple[float, tuple[int, ...]]]:
        """The change points in (lo, hi) on ``signs`` where the motion crosses into the other
        sign of a dyad (see touches.py): (input, the dyads' indices), in increasing order. The
        dyads are those whose two solutions meet there (each one's flip leaves every point):
        one, or more where they cross at one input (a symmetric gripper's two parallelograms,
        which the motion carries on through together)."""
        n = max(64, int(self.samples * (hi - lo) / (TWO_PI if self.periodic else hi - lo)) + 1)

        def margins(xs: np.ndarray) -> np.ndarray:
            return self.margins(xs, signs)

        scale = 1.0 if self.periodic else self.scale
        out = []
        for x in touch_points(margins, lo, hi, n, self.tol):
            if not crosses(margins, x, scale):
                continue
            # the dyads whose two solutions meet there (margins ~0): two in series (a double
            # parallelogram) or side by side (a symmetric gripper) cross together, and flipping
            # one alone leaves the other's circles apart. The root is the first one's (in plan
            # order: the others follow it), found on its own margin: the least of several is
            # no |linear| V where a later one's slope differs on the two sides
            near = self.run([x], signs)[2]['margins'][0]
            candidates = np.flatnonzero(near < _NEAR_CROSSING).tolist()
            if not candidates:
                continue
            first = candidates[0]

            def own(xs: np.ndarray, k: int = first) -> np.ndarray:
                return self.run(xs, signs)[2]['margins'][:, k]

            x = crossing_root(own, x, scale)
            at = self.run([x], signs)[2]['margins'][0]
            meet = tuple(k for k in candidates if at[k] < _AT_TOGGLE)
            if meet:
                out.append((x, meet))
        return out

    def _piece(
        self, comp: Component, seed: float, signs: Signs, way: int
    ) -> tuple[float, float, End, End] | None:
        """The stretch of ``comp`` (the assembling interval around ``seed``; None: a full turn)
        that the motion follows on ``signs`` from ``seed``: both ways (``way`` 0) or onward
        from a change point at ``seed`` (+1 up, -1 down), to the next change point or the
        component's end. None: a full turn with no change point."""
        assert comp is not NOWHERE
        lo_end: End
        hi_end: End
        if comp is None:
            lo, hi, lo_end, hi_end = (
                seed - math.pi,
                seed + math.pi,
                (EndKind.FULL, None),
                (EndKind.FULL, None),
            )
            # a turn and a quarter each side: a change point on the turn's seam is inside
            found = self.crossings(seed - 1.25 * math.pi, seed + 1.25 * math.pi, signs)
            found = [(x + t, k) for x, k in found for t in (-TWO_PI, 0.0, TWO_PI)]
        else:
            lo, hi, lo_end, hi_end = comp
            found = self.crossings(lo, hi, signs)
        # the seed's own change point, found again from this side, is not the next one; a
        # drawing on a change point (way 0) starts the stretch up from it
        eps = TOUCH_RESOLUTION * (1.0 if self.periodic else self.scale)
        up = [(x, k) for x, k in found if x > seed + eps]
        down = [(x, k) for x, k in found if x < seed - eps or (way == 0 and x <= seed + eps)]
        if comp is None and not found:
            return None
        a, a_end = (max(down)[0], (EndKind.CROSSING, max(down)[1])) if down else (lo, lo_end)
        b, b_end = (min(up)[0], (EndKind.CROSSING, min(up)[1])) if up else (hi, hi_end)
        if way > 0:
            a, a_end = seed, (EndKind.CROSSING, None)
        elif way < 0:
            b, b_end = seed, (EndKind.CROSSING, None)
        return a, b, a_end, b_end

    def reached(
        self, lo: float, hi: float, seed: float, limits: Limits
    ) -> tuple[float, float] | None:
        """The values of the stretch [lo, hi] the motion from ``seed`` reaches: all of them,
        or for an angle with limits the piece on the limits' arc around the seed (the stretch
        past a change point spans a turn, and its part a turn away is not reached); None where
        the seed is off that arc."""
        if not self.periodic or limits is None:
            return lo, hi
        a, b = limits
        assert a is not None and b is not None  # an arc has both ends
        piece = reachable_piece(lo, hi, seed, (a, b))
        return (piece[0][0], piece[0][1]) if piece else None

    def _reaches(self, reached: tuple[float, float] | None, end: float, limits: Limits) -> bool:
        """Whether the motion gets to a stretch's ``end`` within ``limits``: an angle's within
        the values it ``reached`` (:meth:`reached`), a slide's between the limits."""
        if not self.periodic or limits is None:
            return self.within(end, limits)
        tol = 1e-12 + 1e-9 * abs(end)
        return reached is not None and reached[0] - tol <= end <= reached[1] + tol

    def circuit(self, x0: float, limits: Limits = None) -> list[Segment]:
        """Follow the motion from ``x0`` in the reference assembly mode through every toggle
        and change point (only those inside ``limits``: the motion cannot reach the others)."""
        ref = tuple(self.plan.reference_signs)
        segs: list[Segment] = []
        # (signs, seed, the segment it came from, way: 0 both ways, +1 / -1 onward from a
        # change point at seed)
        queue: list[tuple[Signs, float, int | None, int]] = [(ref, float(x0), None, 0)]
        keys: list[tuple[float, float]] = []  # each segment's reached values (reached)
        while queue and len(segs) < MAX_SEGMENTS:
            signs, seed, parent, way = queue.pop(0)
            comp = self.component(seed, signs)
            if comp is NOWHERE:
                continue
            piece = self._piece(comp, seed, signs, way)
            if piece is None:
                if not any(s.full and s.signs == signs for s in segs):
                    segs.append(
                        Segment(
                            signs,
                            seed - math.pi,
                            seed + math.pi,
                            (EndKind.FULL, None),
                            (EndKind.FULL, None),
                            seed,
                            parent,
                            full=True,
                        )
                    )
                continue
            lo, hi, lo_end, hi_end = piece
            # a stretch seen before: the same signs over the same reached values (a turn apart
            # is the same where nothing limits the angle; within limits, what the motion
            # reaches from each seed)
            reached = self.reached(lo, hi, seed, limits)
            key = reached or (seed, seed)
            if any(
                s.signs == signs
                and not s.full
                and self.same(k[0], key[0], TOUCH_RESOLUTION)
                and self.same(k[1], key[1], TOUCH_RESOLUTION)
                for s, k in zip(segs, keys)
            ):
                continue
            segs.append(Segment(signs, lo, hi, lo_end, hi_end, seed, parent))
            keys.append(key)
            me = len(segs) - 1
            for end, (kind, k), onward in ((lo, lo_end, -1), (hi, hi_end, 1)):
                if k is None or not self._reaches(reached, end, limits):
                    continue
                flipped = list(signs)
                for i in k:
                    flipped[i] = -flipped[i]
                if kind is EndKind.TOGGLE:
                    queue.append((tuple(flipped), end, me, 0))
                elif kind is EndKind.CROSSING:
                    queue.append((tuple(flipped), end, me, onward))
        return segs

    # -- sampled quantities
    def margins(self, xs: npt.ArrayLike, signs: Sequence[int]) -> np.ndarray:
        _, _, info = self.run(xs, signs)
        return np.where(info['ok'], info['margin'], np.nan)

    def link_angle(self, xs: npt.ArrayLike, signs: Sequence[int], link: str) -> np.ndarray:
        poses, _, info = self.run(xs, signs)
        ang = self.mech.links[link].angle_ref + np.asarray(poses.phi[link], float)
        return np.where(info['ok'], ang, np.nan)


def held_reference(mech: Mechanism, scan: str, held: Mapping[str, Any] | None) -> dict[str, Any]:
    """The other actuators' values a scan holds: ``held``'s, else the reference pose's."""
    out: dict[str, Any] = {}
    for a in mech.actuators:
        if a == scan:
            continue
        out[a] = (held or {}).get(a, reference_value(mech, a))
    return out


def slide_bracket(mech: Mechanism, name: str, x0: float) -> Bracket:
    """Where a slide's scan looks (m): its limits, else 4 length scales either side."""
    act = mech.actuators.get(name)
    lo = act.min if act is not None else None
    hi = act.max if act is not None else None
    w = 4.0 * mech.length_scale
    blo = lo if lo is not None else x0 - w
    bhi = hi if hi is not None else x0 + w
    if lo is None and isinstance(act, SlideActuator) and act.cylinder:
        blo = max(blo, CYLINDER_FLOOR * mech.length_scale)
    return blo, bhi, lo is not None, hi is not None
