"""Motion limits, reachable regions and tilt ranges of a mechanism (pure numpy / scipy).

Everything here is built on :class:`~linkage_ros.core.solver.Solver` (its compiled dyad plan for
vectorised scans, its continuation solves for walks) and returns plain data (dicts, tuples,
lists of floats); nothing prints.

* :func:`input_ranges` / :func:`actuator_range`: the range of each actuator with the others held at
  their reference-pose values. The assembly is scanned over a full turn (angles) or over the
  scene's [min, max] (slides; a generous bracket around the reference throw when a side has no
  limit), each boundary is refined to 1e-12 rad / 1e-12 of the length scale (a toggle position),
  and the result is intersected with the actuator's own limits.
* :func:`toggle_positions`: input values where a dyad of the assembly has a toggle (margin -> 0).
* :func:`oscillation_range`: the range of a link's angle while an input runs over its range (the
  oscillation of a rocker, of both links of a non-Grashof chain, ...).
* :func:`reachable_region`: the region a point reaches while the actuators run over their limits
  (the seed's "zone of hinge K"): with two actuators, the four extreme arcs (each actuator at its
  min or max while the other sweeps) joined into a polygon, checked against a sampled cloud.
* :func:`max_tilt`: the largest rotation of a link (the bin) about one of its points (the lip)
  held fixed, within the actuator limits: an inverse-kinematics walk with knowns [lip, link].

Circuits. A single-DOF scan follows the mechanism through its assembly modes the way it moves:
it starts in the reference pose's mode; where a dyad toggles (the scanned input reaches an
extreme) the motion continues in the mode with that dyad's sign flipped, with the input running
back. The range of the input is the union over the circuit so found, which is exact for
single-loop chains (both modes of a four-bar's dyad cover the same input interval) and follows
the physical motion for multi-loop ones. Scanning samples the circuit on a grid (``samples``
per full turn / bracket), so an assembly gap narrower than one grid step can be missed.

Angle conventions (rad): a range that does not cover the full turn is reported as (min, max) with
min < max, the motion going counter-clockwise from min to max; max may exceed pi (a reachable set
spanning angle pi or 0/2pi is one interval, e.g. (0.40, 5.88)). Where a bound is the scene's own
limit, that limit is reported as written in the scene; otherwise min lies in [-pi, pi).
A full turn without limits is (None, None).
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .dyads import wrap_angle
from .model import Mechanism
from .plan import Poses, spec_for, spec_value_at
from .solver import Result, Solver

TWO_PI = 2.0 * math.pi
#: boundary refinement tolerance for angles (rad) and slides (fraction of the length scale)
ANGLE_TOL = 1e-12
LENGTH_TOL = 1e-12
#: points evaluated per refinement round (a 17-ary search: ~9 rounds from a grid step to 1e-12)
_KARY = 16
#: a dyad margin below this after refinement is a toggle
TOGGLE_MARGIN = 1e-7
#: cap on circuit segments followed through assembly-mode changes
_MAX_SEGMENTS = 64


# ---- small helpers ----------------------------------------------------------------------------


def point_key(mech: Mechanism, name: str) -> str:
    """The known name that means *point* ``name`` (prefixed ``point:`` where a joint, link or
    actuator has the same name, as every point shared by two links does)."""
    if name not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {name!r}; points: {sorted(mech.points)}')
    clash = name in mech.actuators or name in mech.joint_names or name in mech.links
    return f'point:{name}' if clash else name


def link_key(mech: Mechanism, name: str) -> str:
    """The known name that means the angle of link ``name``."""
    if name not in mech.links:
        raise ValueError(f'{mech.name!r} has no link {name!r}; links: {sorted(mech.links)}')
    if name == mech.ground:
        raise ValueError(f'{name!r} is the ground link: its angle is fixed')
    clash = name in mech.actuators or name in mech.joint_names
    return f'link:{name}' if clash else name


def without_limits(mech: Mechanism) -> Mechanism:
    """A shallow copy of ``mech`` whose actuators have no min / max (to probe the assembly)."""
    free = copy.copy(mech)
    free.actuators = {
        n: dataclasses.replace(a, min=None, max=None) for n, a in mech.actuators.items()
    }
    return free


def _identity_poses(mech: Mechanism) -> Poses:
    poses = Poses()
    for l in mech.links:
        poses.phi[l] = np.zeros(1)
        poses.T[l] = np.zeros((1, 2))
    return poses


def reference_value(mech: Mechanism, name: str):
    """Value of a known (actuator, joint, link angle or point) in the reference pose."""
    spec = spec_for(mech, name)
    v = spec_value_at(mech, spec, _identity_poses(mech))[0]
    return np.asarray(v, float).copy() if spec.kind == 'point' else float(v)


def _limit_interval(act, periodic: bool):
    """The actuator's limits as (lo, hi) with None for a missing side; for angles a circular
    interval [lo, hi] (None when the limits leave the full turn), mirroring Solver.limit_violation
    (one-sided angle limits compare the value wrapped to (-pi, pi])."""
    lo, hi = act.min, act.max
    if not periodic:
        return lo, hi
    if lo is None and hi is None:
        return None
    if lo is not None and hi is not None:
        return None if hi - lo >= TWO_PI else (lo, hi)
    return (lo, math.pi) if lo is not None else (-math.pi, hi)


def _clip_periodic(lo, hi, lim):
    """Pieces of the unwrapped interval [lo, hi] inside the circular interval lim = (a, b)."""
    a, b = lim
    out = []
    k0 = math.floor((lo - b) / TWO_PI)
    for k in range(k0, k0 + 4):
        x, y = max(lo, a + TWO_PI * k), min(hi, b + TWO_PI * k)
        if x <= y:
            out.append((x, y, x == a + TWO_PI * k, y == b + TWO_PI * k))
    return out


# ---- one-dimensional scans over a closed-form plan --------------------------------------------


@dataclass
class _Segment:
    """A stretch of the circuit on one assembly mode: the scanned known over [lo, hi] (unwrapped
    for angles), or the full turn; ends are ('toggle', branch) / ('limit', None) / ('bracket',
    None) / ('full', None)."""

    signs: tuple
    lo: float
    hi: float
    lo_end: tuple
    hi_end: tuple
    seed: float
    parent: int | None = None
    full: bool = False


class _Line:
    """The mechanism along one scanned known with every other known held (closed-form plan)."""

    def __init__(
        self,
        mech: Mechanism,
        scan: str,
        held: Mapping[str, Any],
        samples: int = 720,
        bracket: tuple | None = None,
    ):
        self.mech = mech
        self.free = without_limits(mech)
        self.scan = scan
        self.held = dict(held)
        self.solver = Solver(self.free, knowns=[scan] + list(self.held), branch='reference')
        self.closed = self.solver.mode == 'closed_form'
        self.plan = self.solver.plan
        self.spec = self.solver.specs[0]
        self.periodic = self.spec.kind == 'angle'
        self.scale = mech.length_scale
        self.tol = ANGLE_TOL if self.periodic else LENGTH_TOL * self.scale
        self.samples = max(16, int(samples))
        self.bracket = bracket  # slides: (lo, hi, lo_hard, hi_hard)
        self.branch_of_step = {}
        k = 0
        for i, st in enumerate(self.plan.steps):
            if st.branching:
                self.branch_of_step[i] = k
                k += 1

    # -- evaluation
    def run(self, x, signs):
        x = np.atleast_1d(np.asarray(x, float))
        n = x.shape[0]
        values = [x]
        for s in self.solver.specs[1:]:
            v = self.held[s.name]
            values.append(
                np.tile(np.asarray(v, float), (n, 1)) if s.kind == 'point' else np.full(n, float(v))
            )
        return self.plan.run(values, n, list(signs))

    def ok(self, x, signs) -> np.ndarray:
        return np.asarray(self.run(x, signs)[2]['ok'], bool)

    def _failing_branch(self, x, signs):
        info = self.run([x], signs)[2]
        if info['ok'][0]:
            return None
        return self.branch_of_step.get(int(info['failure'][0]))

    def refine(self, good: float, bad: float, signs) -> tuple[float, int | None]:
        """Boundary between an assembling ``good`` and a failing ``bad`` value (k-ary search);
        returns (last assembling value, index of the branching dyad that fails beyond)."""
        for _ in range(200):
            if abs(bad - good) <= self.tol:
                break
            xs = good + (bad - good) * np.arange(1, _KARY + 1) / (_KARY + 1)
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
        return good, self._failing_branch(bad, signs)

    # -- components
    def component(self, seed: float, signs):
        """The interval of assembling values around ``seed`` on one assembly mode:
        None for a full turn, else (lo, hi, lo_end, hi_end)."""
        if self.periodic:
            return self._component_periodic(seed, signs)
        return self._component_line(seed, signs)

    def _component_periodic(self, seed, signs):
        n = self.samples
        c = n // 2
        dt = TWO_PI / n
        xs = seed + (np.arange(n) - c) * dt
        ok = self.ok(xs, signs)
        ok[c] = True  # the seed assembles (it may sit on a toggle)
        if ok.all():
            return None
        up = 0
        while ok[(c + up + 1) % n]:
            up += 1
        down = 0
        while ok[(c - down - 1) % n]:
            down += 1
        hi, kh = self.refine(seed + up * dt, seed + (up + 1) * dt, signs)
        lo, kl = self.refine(seed - down * dt, seed - (down + 1) * dt, signs)
        return lo, hi, ('toggle', kl), ('toggle', kh)

    def _component_line(self, seed, signs):
        blo, bhi, hard_lo, hard_hi = self.bracket
        grow = 0
        while True:
            xs = np.unique(
                np.concatenate([np.linspace(blo, bhi, self.samples), [min(max(seed, blo), bhi)]])
            )
            c = int(np.searchsorted(xs, min(max(seed, blo), bhi)))
            ok = self.ok(xs, signs)
            if not ok[c]:
                # a seed outside the limits (or on a toggle's wrong side): nearest assembling sample
                good = np.flatnonzero(ok)
                if good.size == 0:
                    return 'empty'
                c = int(good[np.argmin(np.abs(good - c))])
            i = c
            while i + 1 < xs.size and ok[i + 1]:
                i += 1
            j = c
            while j - 1 >= 0 and ok[j - 1]:
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
        if i == xs.size - 1:
            hi, hi_end = float(xs[-1]), ('limit' if hard_hi else 'bracket', None)
        else:
            hi, k = self.refine(float(xs[i]), float(xs[i + 1]), signs)
            hi_end = ('toggle', k)
        if j == 0:
            lo, lo_end = float(xs[0]), ('limit' if hard_lo else 'bracket', None)
        else:
            lo, k = self.refine(float(xs[j]), float(xs[j - 1]), signs)
            lo_end = ('toggle', k)
        return lo, hi, lo_end, hi_end

    def _soft_low(self, v):
        act = self.mech.actuators.get(self.scan)
        if act is not None and act.cylinder:
            return max(v, 1e-6 * self.scale)  # a cylinder's pin-to-pin length stays > 0
        return v

    def _same(self, a, b):
        if self.periodic:
            return abs(wrap_angle(a - b)) <= 1e-9
        return abs(a - b) <= 1e-9 * self.scale

    # -- circuits
    def within(self, v: float, limits) -> bool:
        """Is ``v`` inside the actuator's limits ((lo, hi) with None sides for slides, a circular
        (lo, hi) or None for angles)?"""
        if limits is None:
            return True
        lo, hi = limits
        if self.periodic:
            return (v - lo) % TWO_PI <= (hi - lo) + 1e-12
        tol = 1e-12 * self.scale
        return (lo is None or v >= lo - tol) and (hi is None or v <= hi + tol)

    def circuit(self, x0: float, limits=None) -> list[_Segment]:
        """Follow the motion from ``x0`` in the reference assembly mode through every toggle
        (only toggles inside ``limits``: the motion cannot reach the others)."""
        ref = tuple(self.plan.reference_signs)
        segs: list[_Segment] = []
        queue = [(ref, float(x0), None)]
        while queue and len(segs) < _MAX_SEGMENTS:
            signs, seed, parent = queue.pop(0)
            comp = self.component(seed, signs)
            if comp == 'empty':
                continue
            if comp is None:
                if not any(s.full and s.signs == signs for s in segs):
                    segs.append(
                        _Segment(
                            signs,
                            seed - math.pi,
                            seed + math.pi,
                            ('full', None),
                            ('full', None),
                            seed,
                            parent,
                            full=True,
                        )
                    )
                continue
            lo, hi, lo_end, hi_end = comp
            if any(
                s.signs == signs and not s.full and self._same(s.lo, lo) and self._same(s.hi, hi)
                for s in segs
            ):
                continue
            segs.append(_Segment(signs, lo, hi, lo_end, hi_end, seed, parent))
            me = len(segs) - 1
            for end, (kind, k) in ((lo, lo_end), (hi, hi_end)):
                if kind == 'toggle' and k is not None and self.within(end, limits):
                    flipped = list(signs)
                    flipped[k] = -flipped[k]
                    queue.append((tuple(flipped), end, me))
        return segs

    # -- sampled quantities
    def margins(self, xs, signs):
        _, _, info = self.run(xs, signs)
        return np.where(info['ok'], info['margin'], np.nan)

    def link_angle(self, xs, signs, link):
        poses, _, info = self.run(xs, signs)
        ang = self.mech.links[link].angle_ref + np.asarray(poses.phi[link], float)
        return np.where(info['ok'], ang, np.nan)


def _held_reference(mech: Mechanism, scan: str, held: Mapping[str, Any] | None):
    out = {}
    for a in mech.actuators:
        if a == scan:
            continue
        out[a] = (held or {}).get(a, reference_value(mech, a))
    return out


def _slide_bracket(mech: Mechanism, name: str, x0: float):
    act = mech.actuators.get(name)
    lo = act.min if act is not None else None
    hi = act.max if act is not None else None
    w = 4.0 * mech.length_scale
    blo = lo if lo is not None else x0 - w
    bhi = hi if hi is not None else x0 + w
    if lo is None and act is not None and act.cylinder:
        blo = max(blo, 1e-6 * mech.length_scale)
    return blo, bhi, lo is not None, hi is not None


# ---- walks with the solver (Newton / hybrid plans, inverse problems with limits) --------------


def _walk(
    solver: Solver,
    command: Callable[[float], dict],
    start: Result,
    x0: float,
    direction: int,
    step: float,
    extent: float,
    tol: float,
):
    """Follow a scalar known from x0 in one direction with warm-started, branch-continuous solves
    until a solve is refused, then bisect between the last accepted and the first refused value.

    Returns (boundary or None, reason or None, result at the boundary); None when ``extent`` is
    covered without a refusal.
    """
    solver.reset()
    solver.adopt(start)
    x, last = x0, start
    while True:
        done = abs(x - x0)
        if done >= extent * (1 - 1e-15):
            return None, None, last
        xn = x0 + direction * min(done + step, extent)
        r = solver.solve(command(xn))
        if r.success:
            x, last = xn, r
            continue
        good, bad, why = x, xn, r.reason
        while abs(bad - good) > tol:
            mid = 0.5 * (good + bad)
            if mid in (good, bad):
                break
            solver.reset()
            solver.adopt(last)
            rm = solver.solve(command(mid), commit=False)
            if rm.success:
                good, last = mid, rm
            else:
                bad, why = mid, rm.reason
        return good, why, last


def _walk_range(
    mech: Mechanism,
    scan: str,
    held: Mapping[str, Any],
    x0: float,
    periodic: bool,
    bracket=None,
    step=None,
):
    """Range of a known by continuation (when no closed-form plan exists): (lo, hi, lo_end,
    hi_end) or None for a full turn."""
    free = without_limits(mech)
    solver = Solver(free, knowns=[scan] + list(held), branch='continuous', max_iter=200)

    def command(v):
        return {scan: v, **held}

    start = solver.solve(command(x0), commit=False)
    if not start.success:
        return 'empty'
    if periodic:
        step = step or math.radians(2.0)
        tol = ANGLE_TOL
        ends = []
        for d in (1, -1):
            b, why, _ = _walk(solver, command, start, x0, d, step, TWO_PI, tol)
            ends.append(b)
        if ends[0] is None or ends[1] is None:
            return None
        return ends[1], ends[0], ('toggle', None), ('toggle', None)
    blo, bhi, hard_lo, hard_hi = bracket
    step = step or (bhi - blo) / 360.0
    tol = LENGTH_TOL * mech.length_scale
    hi, _, _ = _walk(solver, command, start, x0, 1, step, bhi - x0, tol)
    lo, _, _ = _walk(solver, command, start, x0, -1, step, x0 - blo, tol)
    hi_end = ('toggle', None) if hi is not None else ('limit' if hard_hi else 'bracket', None)
    lo_end = ('toggle', None) if lo is not None else ('limit' if hard_lo else 'bracket', None)
    return (blo if lo is None else lo), (bhi if hi is None else hi), lo_end, hi_end


# ---- actuator ranges --------------------------------------------------------------------------


def _scan_circuit(mech: Mechanism, name: str, held: Mapping[str, Any], samples: int):
    """(line, x0, segments, bracket) of one scanned actuator; line None for a walk."""
    x0 = reference_value(mech, name)
    act = mech.actuators[name]
    periodic = act.kind == 'angle'
    bracket = None if periodic else _slide_bracket(mech, name, x0)
    line = _Line(mech, name, held, samples, bracket)
    if line.closed:
        limits = _limit_interval(act, True) if periodic else (act.min, act.max)
        return line, x0, line.circuit(x0, limits), bracket
    comp = _walk_range(mech, name, held, x0, periodic, bracket)
    if comp == 'empty':
        return None, x0, [], bracket
    if comp is None:
        return (
            None,
            x0,
            [
                _Segment(
                    (),
                    x0 - math.pi,
                    x0 + math.pi,
                    ('full', None),
                    ('full', None),
                    x0,
                    None,
                    full=True,
                )
            ],
            bracket,
        )
    lo, hi, le, he = comp
    return None, x0, [_Segment((), lo, hi, le, he, x0)], bracket


def actuator_range(
    mech: Mechanism, name: str, samples: int = 720, held: Mapping[str, Any] | None = None
) -> dict:
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
    periodic = act.kind == 'angle'
    held = _held_reference(mech, name, held)
    line, x0, segs, _ = _scan_circuit(mech, name, held, samples)
    out = {
        'name': name,
        'kind': act.kind,
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
    if periodic and (full or hi - lo >= TWO_PI - 1e-12):
        full = True
    lo_seg = min(segs, key=lambda s: s.lo)
    hi_seg = max(segs, key=lambda s: s.hi)
    lo_src = None if full else _source(lo_seg.lo_end)
    hi_src = None if full else _source(hi_seg.hi_end)
    toggles = (
        _segment_toggles(line, segs)
        if line is not None
        else [v for s in segs for v, e in ((s.lo, s.lo_end), (s.hi, s.hi_end)) if e[0] == 'toggle']
    )
    if periodic:
        lim = _limit_interval(act, True)
        if full:
            out['full_turn'] = True
            if lim is not None:
                out.update(min=lim[0], max=lim[1], min_source='limit', max_source='limit')
        else:
            if lim is None:
                pieces = [(lo, hi, False, False)]
            else:
                pieces = _clip_periodic(lo, hi, lim)
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
            if a_lim:
                shift = lim[0] - a
            elif b_lim:
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
        out['toggles'] = _dedupe(sorted(toggles), None)
    return out


def _dedupe(values, periodic) -> list[float]:
    res: list[float] = []
    for v in values:
        if not res or abs(v - res[-1]) > 1e-9:
            res.append(float(v))
    if periodic and len(res) > 1 and abs(res[0] + TWO_PI - res[-1]) <= 1e-9:
        res.pop()
    return res


def _source(end):
    return {'toggle': 'toggle', 'limit': 'limit', 'bracket': 'bracket'}.get(end[0])


def _golden_min(f, a: float, b: float, tol: float) -> tuple[float, float]:
    """Golden-section minimum of a unimodal f on [a, b] (robust on the V-shaped margin at a
    tangency, where parabolic steps stall at sqrt(eps))."""
    g = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(200):
        if abs(b - a) <= tol:
            break
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    return (c, fc) if fc <= fd else (d, fd)


def _flat_centre(f, a: float, x: float, b: float, fx: float) -> float:
    """Centre of the zone around x where f stays at its floor fx (a tangency's margin is
    |linear| in the input but rounds to its floor over ~sqrt(eps): the centre is the toggle)."""
    tau = fx + 1e-14

    def edge(inside, outside):
        for _ in range(200):
            mid = 0.5 * (inside + outside)
            if mid in (inside, outside):
                break
            if f(mid) <= tau:
                inside = mid
            else:
                outside = mid
        return inside

    if f(a) <= tau or f(b) <= tau:
        return x
    return 0.5 * (edge(x, a) + edge(x, b))


def _segment_toggles(line: _Line, segs: Sequence[_Segment]) -> list[float]:
    """Assembly-limited segment ends plus interior points where a dyad margin touches zero."""
    out = []
    for s in segs:
        for v, e in ((s.lo, s.lo_end), (s.hi, s.hi_end)):
            if e[0] == 'toggle':
                out.append(v)
        n = max(64, line.samples // (1 if s.full else 2))
        xs = np.linspace(s.lo, s.hi, n)
        m = line.margins(xs, s.signs)
        for i in range(1, n - 1):
            if not (np.isfinite(m[i]) and m[i] < 0.05 and m[i] <= m[i - 1] and m[i] <= m[i + 1]):
                continue

            def f(x, signs=s.signs):
                v = line.margins([x], signs)[0]
                return 1.0 if not np.isfinite(v) else float(v)

            x, fx = _golden_min(f, xs[i - 1], xs[i + 1], line.tol)
            if fx < TOGGLE_MARGIN:
                out.append(_flat_centre(f, xs[i - 1], x, xs[i + 1], fx))
    # dedupe
    res: list[float] = []
    for v in sorted(out):
        if not res or not line._same(res[-1], v):
            res.append(v)
    return res


def input_ranges(
    mech: Mechanism, samples: int = 720
) -> dict[str, tuple[float | None, float | None]]:
    """{actuator: (min or None, max or None)} with the other actuators held at their
    reference-pose values: the toggle positions where the assembly ends (refined to 1e-12 rad or
    1e-12 of the length scale), intersected with the actuator's own min / max.

    An angle that turns fully without limits gives (None, None); a reachable set spanning angle
    pi (or 0/2pi) is one interval min < max with max possibly > pi (see the module docstring).
    A slide without a limit on a side where the assembly does not end within a bracket of
    thousands of length scales around its reference value gives None on that side.
    """
    out = {}
    for name in mech.actuators:
        info = actuator_range(mech, name, samples)
        out[name] = (info['min'], info['max'])
    return out


def toggle_positions(
    mech: Mechanism, actuator: str, samples: int = 720, held: Mapping[str, Any] | None = None
) -> list[float]:
    """Values of ``actuator`` (others held at the reference pose) where a dyad of the assembly
    toggles (its margin, |sin| of the transmission angle or its analogue, reaches 0): the ends of
    the assembly's range and any interior tangency, over every assembly mode the motion passes
    through. Geometric: the actuator's own limits are not applied (compare with
    :func:`actuator_range`). Angles are reported in [min, min + 2 pi) of the range."""
    return actuator_range(mech, actuator, samples, held)['toggles']


# ---- link oscillation -------------------------------------------------------------------------


def oscillation_range(
    mech: Mechanism,
    link: str,
    actuator: str | None = None,
    samples: int = 720,
    held: Mapping[str, Any] | None = None,
):
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
    periodic = act.kind == 'angle'
    held = _held_reference(mech, actuator, held)
    line, x0, segs, _ = _scan_circuit(mech, actuator, held, samples)
    if line is None:
        raise ValueError(f'oscillation_range needs a closed-form plan for {actuator!r}')
    if not segs:
        return None, None
    lim = _limit_interval(act, periodic) if periodic else (act.min, act.max)
    # sample every segment (clipped to the actuator's limits), unwrap and stitch the angle
    pieces = []  # (signs, xs, unwrapped angles)
    stitch: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for k, s in enumerate(segs):
        n = max(
            129,
            int(samples * (s.hi - s.lo) / (TWO_PI if periodic else max(s.hi - s.lo, 1e-300))) + 1,
        )
        xs = np.linspace(s.lo, s.hi, n)
        ang = line.link_angle(xs, s.signs, link)
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
        if periodic and lim is not None:
            keep = np.zeros(xs.size, bool)
            for a, b, _, _ in _clip_periodic(s.lo, s.hi, lim):
                keep |= (xs >= a) & (xs <= b)
            for a, b, _, _ in _clip_periodic(s.lo, s.hi, lim):
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
            if lim[0] is not None:
                keep &= xs >= lim[0]
            if lim[1] is not None:
                keep &= xs <= lim[1]
            xs, ang = xs[keep], ang[keep]
        if xs.size:
            order = np.argsort(xs)
            pieces.append((s.signs, xs[order], ang[order]))
    if not pieces:
        return None, None
    all_ang = np.concatenate([p[2] for p in pieces])
    if all_ang.max() - all_ang.min() >= TWO_PI - 1e-9:
        return None, None

    def extreme(sign):
        best = -math.inf
        for signs, xs, ang in pieces:
            vals = sign * ang
            i = int(np.argmax(vals))
            best = max(best, float(vals[i]))
            if 0 < i < xs.size - 1:
                centre = float(ang[i])

                def f(x, signs=signs, centre=centre):
                    v = line.link_angle([x], signs, link)[0]
                    if not np.isfinite(v):
                        return math.inf
                    return -sign * (centre + wrap_angle(v - centre))

                r = minimize_scalar(
                    f, bounds=(xs[i - 1], xs[i + 1]), method='bounded', options={'xatol': 1e-13}
                )
                if np.isfinite(r.fun):
                    best = max(best, -float(r.fun))
        return sign * best

    hi, lo = extreme(1), extreme(-1)
    shift = -TWO_PI * math.floor((lo + math.pi) / TWO_PI)
    return lo + shift, hi + shift


# ---- reachable regions ------------------------------------------------------------------------


def _actuator_limits(mech: Mechanism, name: str, samples: int) -> tuple[float, float]:
    act = mech.actuators[name]
    if act.min is not None and act.max is not None:
        return float(act.min), float(act.max)
    info = actuator_range(mech, name, samples)
    x0 = info['reference']
    if act.kind == 'angle':
        if info['min'] is None:
            return x0 - math.pi, x0 + math.pi
        return float(info['min']), float(info['max'])
    lo = info['min'] if info['min'] is not None else x0 - mech.length_scale
    hi = info['max'] if info['max'] is not None else x0 + mech.length_scale
    return float(lo), float(hi)


def _moving_actuators(mech: Mechanism, point: str, solver: Solver) -> list[str]:
    ref = {a: reference_value(mech, a) for a in mech.actuators}
    base = solver.solve_batch({a: [v] for a, v in ref.items()})
    p0 = base.points[point][0]
    out = []
    for a, act in mech.actuators.items():
        d = 1e-4 if act.kind == 'angle' else 1e-4 * mech.length_scale
        moved = False
        for sgn in (1, -1):
            cols = {b: [v] for b, v in ref.items()}
            cols[a] = [ref[a] + sgn * d]
            r = solver.solve_batch(cols)
            if r.ok[0]:
                moved = float(np.hypot(*(r.points[point][0] - p0))) > 1e-9 * mech.length_scale
                break
        if moved:
            out.append(a)
    return out


def _polygon_area(poly: np.ndarray) -> float:
    if len(poly) < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def points_in_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule: which of the (n, 2) points lie inside the closed polygon (m, 2)."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    poly = np.asarray(poly, float).reshape(-1, 2)
    x, y = pts[:, 0][:, None], pts[:, 1][:, None]
    x1, y1 = poly[:, 0][None, :], poly[:, 1][None, :]
    x2, y2 = np.roll(poly[:, 0], -1)[None, :], np.roll(poly[:, 1], -1)[None, :]
    cond = (y1 > y) != (y2 > y)
    with np.errstate(divide='ignore', invalid='ignore'):
        xint = x1 + (y - y1) * (x2 - x1) / np.where(y2 != y1, y2 - y1, 1.0)
    return (np.sum(cond & (x < xint), axis=1) % 2) == 1


def distance_to_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each of the (n, 2) points to the polygon's edges."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    a = np.asarray(poly, float).reshape(-1, 2)
    b = np.roll(a, -1, axis=0)
    ab = b - a
    L2 = np.sum(ab * ab, axis=1)
    best = np.full(pts.shape[0], np.inf)
    for k in range(0, a.shape[0], 256):
        aa, bb, ll = a[k : k + 256], ab[k : k + 256], L2[k : k + 256]
        ap = pts[:, None, :] - aa[None, :, :]
        t = np.clip(np.sum(ap * bb[None], axis=2) / np.where(ll > 0, ll, 1.0)[None], 0.0, 1.0)
        d = ap - t[..., None] * bb[None]
        best = np.minimum(best, np.min(np.hypot(d[..., 0], d[..., 1]), axis=1))
    return best


def _concave_hull(pts: np.ndarray, max_edge: float) -> np.ndarray:
    """Outer boundary (m, 2) of the alpha shape of ``pts``: the Delaunay triangles whose edges are
    all at most ``max_edge`` long, merged."""
    from scipy.spatial import Delaunay

    pts = np.unique(np.asarray(pts, float), axis=0)
    if pts.shape[0] < 3:
        return pts
    try:
        tri = Delaunay(pts)
    except Exception:  # noqa: BLE001 - collinear cloud: a path, no area
        order = np.argsort(pts[:, 0] + 1e-3 * pts[:, 1])
        return pts[order]
    s = tri.simplices
    e = np.stack(
        [np.linalg.norm(pts[s[:, i]] - pts[s[:, (i + 1) % 3]], axis=1) for i in range(3)], axis=1
    )
    keep = s[np.max(e, axis=1) <= max_edge]
    if keep.size == 0:
        keep = s
    count: dict[tuple[int, int], int] = {}
    for t in keep:
        for i in range(3):
            a, b = int(t[i]), int(t[(i + 1) % 3])
            key = (a, b) if a < b else (b, a)
            count[key] = count.get(key, 0) + 1
    edges = [k for k, c in count.items() if c == 1]
    adj: dict[int, list[int]] = {}
    for a, b in edges:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    used = set()
    loops = []
    for a, b in edges:
        if (a, b) in used:
            continue
        loop = [a]
        prev, cur = a, b
        used.add((min(a, b), max(a, b)))
        while cur != a and len(loop) <= len(edges):
            loop.append(cur)
            nxt = [v for v in adj[cur] if (min(cur, v), max(cur, v)) not in used]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            used.add((min(prev, cur), max(prev, cur)))
        loops.append(pts[loop])
    return max(loops, key=_polygon_area) if loops else pts


def reachable_region(
    mech: Mechanism,
    point: str,
    samples_per_actuator: int = 41,
    actuators: Sequence[str] | None = None,
    edge_samples: int | None = None,
    limits: Mapping[str, tuple[float, float]] | None = None,
    held: Mapping[str, Any] | None = None,
) -> dict:
    """Region reached by ``point`` while ``actuators`` run over their limits (the others held at
    the reference pose), e.g. the seed's zone of the excavator's hinge K for the Z1, Z2 ranges.

    ``actuators`` defaults to those that move the point. Limits are the scene's min / max, else
    :func:`actuator_range` (a full turn for a rotating crank); ``limits`` overrides them. The
    mechanism stays in the reference assembly mode.

    Returns a dict of plain data:

    * ``boundary`` [[x, y], ...] the closed polygon (first vertex not repeated); with two
      actuators the four extreme arcs (each actuator at its min or max while the other sweeps)
      joined in order, with ``boundary_inputs`` {actuator: [value per vertex]} (method
      'extreme_arcs'); one actuator: the path itself ('path', area 0); otherwise, or when the
      cloud does not lie inside the arcs (the map folds, or a corner of the throw box does not
      assemble), the concave hull of the cloud ('concave_hull');
    * ``area``, ``cloud`` (sampled points on a grid of the throws), ``arcs`` (each with ``fixed``
      = [actuator, 'min'|'max', value], ``sweep`` and ``points``), ``limits``, ``held``;
    * ``hull_check``: ``outside`` (cloud points outside the boundary beyond ``tolerance``),
      ``max_outside``, ``convex_hull_area``, ``convex`` (the region equals its convex hull).
    """
    if point not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {point!r}; points: {sorted(mech.points)}')
    solver = Solver(mech, outputs=[point], branch='reference')
    acts = list(actuators) if actuators is not None else _moving_actuators(mech, point, solver)
    for a in acts:
        if a not in mech.actuators:
            raise ValueError(f'{a!r} is not an actuator of {mech.name!r}')
    held_vals = {
        a: (held or {}).get(a, reference_value(mech, a)) for a in mech.actuators if a not in acts
    }
    lims = {
        a: tuple(map(float, (limits or {}).get(a) or _actuator_limits(mech, a, 720))) for a in acts
    }
    scale = mech.length_scale
    n = max(2, int(samples_per_actuator))
    if len(acts) >= 3:
        n = max(2, min(n, int(round(30000 ** (1.0 / len(acts))))))
    ne = int(edge_samples) if edge_samples else 4 * (n - 1) + 1

    def solve(cols):
        full = {a: np.asarray(cols[a], float) for a in acts}
        m = next(iter(full.values())).shape[0] if full else 1
        for a, v in held_vals.items():
            full[a] = np.full(m, float(v))
        r = solver.solve_batch(full)
        return r.ok, r.points[point]

    out: dict[str, Any] = {
        'point': point,
        'actuators': acts,
        'limits': {a: list(lims[a]) for a in acts},
        'held': {a: float(v) for a, v in held_vals.items()},
    }
    if not acts:
        p = reference_value(mech, point_key(mech, point))
        out.update(
            boundary=[list(map(float, p))],
            boundary_inputs={},
            area=0.0,
            cloud=[list(map(float, p))],
            arcs=[],
            method='point',
            hull_check={
                'outside': 0,
                'max_outside': 0.0,
                'tolerance': 0.0,
                'convex_hull_area': 0.0,
                'convex': True,
            },
        )
        return out
    # the cloud: a grid over the throws, solved in serpentine order (sequential Newton solves
    # then stay continuous), kept in natural order
    axes = [np.linspace(lims[a][0], lims[a][1], n) for a in acts]
    grid = np.array(list(itertools.product(*axes)))
    perm = np.arange(grid.shape[0])
    if len(acts) >= 2:
        rows = perm.reshape(-1, n).copy()
        rows[1::2] = rows[1::2, ::-1]
        perm = rows.reshape(-1)
    ok_s, P_s = solve({a: grid[perm, i] for i, a in enumerate(acts)})
    ok = np.zeros(grid.shape[0], bool)
    P = np.zeros((grid.shape[0], 2))
    ok[perm], P[perm] = ok_s, P_s
    cloud = P[ok]
    out['cloud'] = cloud.tolist()
    arcs = []
    if len(acts) == 1:
        a = acts[0]
        xs = np.linspace(lims[a][0], lims[a][1], ne)
        okp, pp = solve({a: xs})
        boundary, binputs = pp[okp], {a: xs[okp].tolist()}
        method = 'path'
        area = 0.0
    elif len(acts) == 2:
        a1, a2 = acts
        (l1, h1), (l2, h2) = lims[a1], lims[a2]
        s1 = np.linspace(l1, h1, ne)
        s2 = np.linspace(l2, h2, ne)
        specs = [
            (a1, 'min', l1, a2, s2),
            (a2, 'max', h2, a1, s1),
            (a1, 'max', h1, a2, s2[::-1]),
            (a2, 'min', l2, a1, s1[::-1]),
        ]
        verts, ins1, ins2, complete = [], [], [], True
        for fixed, which, val, sweep, vals in specs:
            cols = {fixed: np.full(vals.size, val), sweep: vals}
            okp, pp = solve(cols)
            complete &= bool(okp.all())
            arcs.append(
                {
                    'fixed': [fixed, which, float(val)],
                    'sweep': sweep,
                    'inputs': vals[okp].tolist(),
                    'points': pp[okp].tolist(),
                }
            )
            # drop each arc's last vertex: it is the next arc's first (a shared corner)
            sel = np.flatnonzero(okp)
            sel = sel[sel < vals.size - 1]
            verts.append(pp[sel])
            ins1.append(cols[a1][sel])
            ins2.append(cols[a2][sel])
        boundary = np.concatenate(verts)
        binputs = {a1: np.concatenate(ins1).tolist(), a2: np.concatenate(ins2).tolist()}
        method = 'extreme_arcs' if complete else 'concave_hull'
        area = _polygon_area(boundary)
    else:
        boundary, binputs, method, area = None, {}, 'concave_hull', 0.0
    # hull check: the cloud must lie inside the boundary
    spacing = _grid_spacing(P, ok, n, len(acts))
    tolerance = 1e-9 * scale
    hull_area = 0.0
    if len(acts) >= 2 and cloud.shape[0] >= 3:
        try:
            from scipy.spatial import ConvexHull

            hull_area = float(ConvexHull(cloud).volume)
        except Exception:  # noqa: BLE001 - degenerate cloud
            hull_area = 0.0
    outside, max_out = 0, 0.0
    if method == 'extreme_arcs':
        inside = points_in_polygon(cloud, boundary)
        d = distance_to_polygon(cloud[~inside], boundary) if (~inside).any() else np.zeros(0)
        outside = int(np.sum(d > tolerance))
        max_out = float(d.max()) if d.size else 0.0
        if outside:
            method = 'concave_hull'
    if method == 'concave_hull':
        pts = np.concatenate(
            [cloud] + [np.asarray(a['points'], float).reshape(-1, 2) for a in arcs]
        )
        boundary = _concave_hull(pts, 2.5 * spacing)
        binputs = {}
        area = _polygon_area(boundary)
    out.update(
        boundary=np.asarray(boundary, float).tolist(),
        boundary_inputs=binputs,
        area=float(area),
        arcs=arcs,
        method=method,
        hull_check={
            'outside': outside,
            'max_outside': max_out,
            'tolerance': tolerance,
            'convex_hull_area': hull_area,
            'convex': bool(hull_area > 0 and area >= hull_area * (1 - 1e-3)),
        },
    )
    return out


def _grid_spacing(P: np.ndarray, ok: np.ndarray, n: int, k: int) -> float:
    """Largest image distance between neighbouring samples of the throw grid (any axis)."""
    if k == 0 or P.shape[0] < 2:
        return 0.0
    Pg = P.reshape((n,) * k + (2,))
    okg = ok.reshape((n,) * k)
    best = 0.0
    for ax in range(k):
        d = np.linalg.norm(np.diff(Pg, axis=ax), axis=-1)
        both = np.logical_and(np.delete(okg, 0, axis=ax), np.delete(okg, -1, axis=ax))
        if both.any():
            best = max(best, float(d[both].max()))
    return best


# ---- tilt of a link about a held point --------------------------------------------------------


def max_tilt(
    mech: Mechanism,
    lip: str,
    link: str,
    hold_point=None,
    start_angle: float | None = None,
    inputs: Mapping[str, float] | None = None,
    held: Sequence[str] | None = None,
    step: float = math.radians(1.0),
    max_rotation: float = math.pi,
    tol: float = 1e-12,
    method: str | None = None,
) -> dict:
    """Largest rotation of ``link`` (the bin) about its point ``lip`` (L) held fixed, within the
    actuator limits: inverse kinematics with knowns [lip point, link angle] (plus ``held``
    actuators at their current values when the mechanism has more than three DOF), scanning the
    link's angle from its current value both ways with branch-continuous solves and refining the
    first refused angle by bisection to ``tol`` rad.

    The current configuration is the reference pose, or the forward solve of ``inputs``
    ({actuator: value}); ``hold_point`` / ``start_angle`` override the lip position and the start
    angle. Returns a dict: ``min`` / ``max`` (link angle, rad, unwrapped around ``start``; None when
    no refusal within ``max_rotation``), ``tilt_down`` = start - min, ``tilt_up`` = max - start,
    ``reason`` {'min': ..., 'max': ...} (the solver's refusal just beyond each bound: an actuator
    limit or a dyad that no longer closes), ``inputs_at`` {'min': {...}, 'max': {...}} (actuator
    values at the bounds), ``hold_point``, ``start``, ``ok`` (False with ``reason['start']`` when
    the start itself is refused).
    """
    if lip not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {lip!r}')
    if link not in mech.links or link == mech.ground:
        raise ValueError(f'{link!r} is not a moving link of {mech.name!r}')
    if lip not in mech.links[link].points:
        raise ValueError(f'point {lip!r} is not on link {link!r}')
    extra = mech.dof - 3
    if extra < 0:
        raise ValueError(
            f'{mech.name!r} has {mech.dof} DOF: holding a point (2) and turning a '
            'link about it (1) needs at least 3'
        )
    if held is None:
        held = list(mech.actuators)[:extra]
    held = list(held)
    if len(held) != extra:
        raise ValueError(f'hold exactly {extra} actuator(s) of {mech.name!r} (got {held})')
    pk, lk = point_key(mech, lip), link_key(mech, link)
    current = {a: reference_value(mech, a) for a in mech.actuators}
    if inputs:
        current.update({k: float(v) for k, v in inputs.items()})
        fwd = Solver(mech, method=method).solve(current)
        if not fwd.success:
            return {
                'ok': False,
                'link': link,
                'lip': lip,
                'min': None,
                'max': None,
                'reason': {'start': fwd.reason},
            }
        lip_now = np.asarray(fwd.points[lip], float)
        ang_now = fwd.links[link]
    else:
        lip_now = np.asarray(mech.points[lip], float)
        ang_now = mech.links[link].angle_ref
    hold = lip_now if hold_point is None else np.asarray(hold_point, float).reshape(2)
    a0 = float(ang_now if start_angle is None else start_angle)
    solver = Solver(mech, knowns=[pk, lk] + held, method=method, branch='continuous', max_iter=200)

    def command(angle):
        cmd = {pk: hold, lk: angle}
        cmd.update({h: current[h] for h in held})
        return cmd

    base = {
        'link': link,
        'lip': lip,
        'hold_point': [float(hold[0]), float(hold[1])],
        'start': a0,
        'held': {h: float(current[h]) for h in held},
    }
    start = solver.solve(command(a0), commit=False)
    if not start.success:
        return {
            **base,
            'ok': False,
            'min': None,
            'max': None,
            'tilt_up': None,
            'tilt_down': None,
            'reason': {'start': start.reason},
            'inputs_at': {},
        }
    res = {**base, 'ok': True, 'reason': {}, 'inputs_at': {}}
    for d, key in ((1, 'max'), (-1, 'min')):
        b, why, last = _walk(solver, command, start, a0, d, step, max_rotation, tol)
        res[key] = b
        res['reason'][key] = why
        res['inputs_at'][key] = dict(last.inputs)
    res['tilt_up'] = None if res['max'] is None else res['max'] - a0
    res['tilt_down'] = None if res['min'] is None else a0 - res['min']
    return res


__all__ = [
    'input_ranges',
    'actuator_range',
    'toggle_positions',
    'oscillation_range',
    'reachable_region',
    'max_tilt',
    'reference_value',
    'without_limits',
    'point_key',
    'link_key',
    'points_in_polygon',
    'distance_to_polygon',
]
