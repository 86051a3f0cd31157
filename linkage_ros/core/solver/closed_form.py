"""The closed-form path of one command: the plan's slot program, then the Result read off its
slots.

:class:`SlotReadout` is the one-command twin of :class:`~linkage_ros.core.assemble.
ResultAssembler` (which reads a batch, and a Newton answer's name-keyed poses): the same
values by the same float operations (every commanded actuator as given, every other actuator,
joint and link whose links are placed, and the loop-closure residual as a fraction of the
length scale), with every name resolved to a slot of :class:`~linkage_ros.core.scalar_plan.
ScalarProgram` once. What decides the answer is computed with it (the residual, the margin and
branch_defined, whether every value is finite); the Result's name-keyed dicts and branch
text are read off the registers when first asked (:class:`ClosedResult`), and a closed-form
answer's State (:class:`SlotState`) reads its points and poses only when continuity asks.

:meth:`SlotReadout.lean_command` is ``solve_one`` for the common command of a forward closed
form (a dict of one finite float per actuator that assembles): no general checks of what that
command is not, no per-command dicts; any other command or answer goes the general way.

The closure checks a plan satisfies by construction (a one-link body's first point, a weld
to the ground's root, its known angle read back, a dyad's point where both its links'
placements end) are left for when ``Result.residual`` is read (:class:`ClosedLazyResidual`):
closure_bound proves how much they can miss, and that bound decides success and
branch_defined wherever it settles them (else every check runs). Every field of every Result
is the one every check gives, bit for bit (test/core/solver/test_closure_bound.py; and old
against new over every packaged scene's warm sweep and hostile commands when it was made).
Measured (CPU time, best of 200-300 passes of the 200-command warm sweep, old and new
interleaved in one process, load 1.9-2.9): the four-bar's ``Solver.solve`` 16.3-16.5 us before
any, 14.0-14.7 us with the first three kinds left out, 12.6-13.3 us with the dyad joint too
and their frames not tested where bounded (the ``math`` four-bar 1.6 us); the excavator
50.2-51.2 -> 47.7-48.1 us (its links' and cylinders' first points, its bucket's dyad joint).
Then fewer operations per run (the same floats: a run's rare fields on its class, its signs and
margins tuples, the welded ground's placer called as the step, the every-run checks behind one
flag, ops' wrap with its range test first; best of 150 passes interleaved in one process, load
2.9-3.1): the four-bar 12.7-14.5 -> 11.6-12.8 us (7.5-8.5x -> 6.9-7.7x the ``math`` four-bar),
the excavator 45.1-52.8 -> 45.0-47.9 us (its cost is its dyads' kernels and eager checks).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from ..assemble import roller_offset
from ..ops import wrap_one
from ..plan import ReadKind, limit_violation, spec_reader, value_interval
from ..quantities import PointSpec, ScalarSpec, SlideSpec
from ..scalar_plan import ScalarProgram, program
from ..scalar_run import SlotRun
from .closed_result import (
    ClosedLazyResidual,
    SlotState,
    closed_result,
    lazy_residual_result,
    slot_state,
)
from .closure_bound import (
    ConstructedChecks,
    angle_worst,
    frames_bounded,
    one_side_worst,
    scale_caps,
    two_sides_worst,
)
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import Continuity, State
from .crossing import kept_signs
from .result import EPS, Result
from .slot_reads import SlideRead, as_complex, slot_reader

_PI = math.pi
_NEG_PI = -math.pi  # (one load where -_PI is two)
_CLOSED_FORM = SolveMode.CLOSED_FORM
_POINT = ReadKind.POINT


class SlotReadout:
    """What to read off a program's runs for one compiled solve, resolved once (see the
    module)."""

    def __init__(self, c: CompiledSolve, prog: ScalarProgram, defer: bool = True):
        """``defer``: leave the checks the plan satisfies by construction for when the
        residual is read (closure_bound); False: every check when the Result is made."""
        mech, specs = c.mech, c.specs
        self.c, self.prog, self.plan = c, prog, c.plan
        have = set(prog.link_names)
        spec_links = c.check_system.spec_links
        self.L = mech.length_scale
        self.closure_limit = c.closure_limit
        self.limited = bool(c.limited)
        #: the limited knowns whose limits are an interval of values (index, lower, upper: a
        #: slide's, plan.value_interval), and the others (an angle's: on the circle)
        self.limit_intervals: list[tuple[int, float, float]] = []
        self.limit_arcs: list[tuple[int, ScalarSpec]] = []
        for i, spec in c.limited:
            interval = value_interval(spec)
            if interval is None:
                self.limit_arcs.append((i, spec))
            else:
                self.limit_intervals.append((i, *interval))
        #: the names of a command's values, in spec order (lean_command's parse)
        self.known_names = tuple(s.name for s in specs)
        self.n_known = len(self.known_names)
        commanded = {s.name: i for i, s in enumerate(specs)}
        #: (actuator, index of its commanded value), and the others' readers
        self.commanded = [(a, commanded[a]) for a in mech.actuators if a in commanded]
        self.read_inputs = [
            (a, slot_reader(spec_reader(mech, s), prog))
            for a, s in zip(mech.actuators, c.actuator_specs)
            if a not in commanded and all(l in have for l in spec_links(s))
        ]
        #: the actuators in the mechanism's order (the Result's dict order)
        self.input_order = [
            a for a, s in zip(mech.actuators, c.actuator_specs)
            if a in commanded or all(l in have for l in spec_links(s))
        ]  # fmt: skip
        iphi, irot, iT = prog.iphi, prog.irot, prog.iT

        def reg(point: str, link: str) -> int:
            """The point's register where the run set it as rot * p_ref + T of ``link`` (the
            very float the joint check would compute), else -1."""
            return prog.ip[point] if prog.set_by.get(point) == link else -1

        revolutes = [rj for rj in mech.revolutes if rj.parent in have and rj.child in have]
        #: each revolute's angle: (joint, child's phi register, parent's, angle offset)
        self.revolute_angles = [
            (
                rj.name,
                iphi[rj.child],
                iphi[rj.parent],
                mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
            )
            for rj in revolutes
        ]
        # each revolute's closure (its point placed by the parent minus by the child), split by
        # whether one side's placement set the point's register (that side's point is the
        # register: the miss is the register less the other side's point, negated where the
        # child set it, which changes no component's magnitude) or neither did; the checks the
        # plan satisfies by construction (closure_bound) apart, with their bounds
        # (not with a known point: its miss may be a numpy float, whose type the residual and
        # branch_defined then take where it is the largest, which only the checks tell)
        if any(isinstance(s, PointSpec) for s in specs):
            defer = False
        constructed = ConstructedChecks(c.plan, prog) if defer else None
        bounds: list[float] = []
        self.closure_one_side: list[tuple[complex, int, int, int]] = []
        self.closure_two_sides: list[tuple[complex, int, int, int, int]] = []
        #: the one-side checks and known angles read back left for when the residual is read
        self.closure_one_side_lazy: list[tuple[complex, int, int, int]] = []
        self.closure_two_sides_lazy: list[tuple[complex, int, int, int, int]] = []
        frames: set[int] = set()
        dyad_joints: list[tuple[tuple[complex, int, int, int, int], float, int]] = []
        self.angle_knowns_lazy: list[tuple[int, int, int, float]] = []
        for rj in revolutes:
            p = as_complex(mech.points[rj.point])
            preg, creg = reg(rj.point, rj.parent), reg(rj.point, rj.child)
            prot, pT, crot, cT = irot[rj.parent], iT[rj.parent], irot[rj.child], iT[rj.child]
            if preg >= 0:
                check, setter, checker = (p, preg, crot, cT), rj.parent, rj.child
            elif creg >= 0:
                check, setter, checker = (p, creg, prot, pT), rj.child, rj.parent
            else:  # (a dyad's point, where both its links' placements end: closure_bound)
                two = (p, prot, pT, crot, cT)
                dyad = (
                    constructed.dyad_joint(rj.point, p, (rj.parent, rj.child))
                    if constructed
                    else None
                )
                if dyad is None:
                    self.closure_two_sides.append(two)
                else:
                    dyad_joints.append((two, *dyad))
                continue
            bound = constructed.joint(rj.point, p, setter, checker) if constructed else None
            if bound is None:
                self.closure_one_side.append(check)
            else:
                self.closure_one_side_lazy.append(check)
                bounds.append(bound)
                if not frames_bounded(bound):  # (its rot and T tested on every run)
                    frames.update(check[2:])
        read_knowns = [
            (i, spec_reader(mech, s))
            for i, s in enumerate(specs)
            if all(l in have for l in spec_links(s))
        ]
        # a known that reads as a joint's slide (an actuator's, usually) is read there once
        slide_known: dict[str, int] = {}
        for pj in mech.prismatics.values():
            joint_read = spec_reader(mech, SlideSpec(pj.name, pj.name))
            for i, read in read_knowns:
                if read == joint_read and pj.name not in slide_known:
                    slide_known[pj.name] = i
        self.slides: list[SlideRead] = []
        for pj in mech.prismatics.values():
            if pj.guide not in have or pj.slider not in have:
                continue
            read = spec_reader(mech, SlideSpec(pj.name, pj.name))
            self.slides.append(
                SlideRead(
                    pj.name,
                    slot_reader(read, prog),
                    as_complex(mech.points[pj.point]),
                    1j * as_complex(pj.direction),
                    iphi[pj.slider],
                    irot[pj.slider],
                    iT[pj.slider],
                    iphi[pj.guide],
                    irot[pj.guide],
                    iT[pj.guide],
                    roller_offset(mech, pj.name),
                    slide_known.get(pj.name, -1),
                    irot[read.link],
                    iT[read.link],
                    read.p_ref,
                    read.origin,
                    read.direction,
                    (irot[read.link], iT[read.link], read.p_ref)
                    == (irot[pj.slider], iT[pj.slider], as_complex(mech.points[pj.point])),
                    frozenset((pj.slider, pj.guide)) not in prog.same_turn,
                )  # fmt: skip
            )
            assert read.reference == pj.guide  # (the guide's registers above)
        read_slide = {sl.known for sl in self.slides}
        self.links = [(l, iphi[l], mech.links[l].angle_ref) for l in mech.links if l in have]
        #: the known angles read inline (the register of the value wrapped, their link's and
        #: reference's phi registers, offset)
        self.angle_knowns: list[tuple[int, int, int, float]] = []
        for i, read in read_knowns:
            if read.kind is ReadKind.ANGLE:
                angle = (prog.iwrap[i], iphi[read.link], iphi[read.reference], read.offset)
                bound = (
                    constructed.angle(i, read.link, read.reference, read.offset, self.L)
                    if constructed
                    else None
                )
                if bound is None:
                    self.angle_knowns.append(angle)
                else:
                    self.angle_knowns_lazy.append(angle)
                    bounds.append(bound)
        #: the dyad joints left for later: (S's register, the largest S their bound allows, the
        #: check: run now where S is larger); their bound is this S's
        self.dyad_scales = scale_caps(dyad_joints, self.L, self.closure_two_sides, bounds)
        self.closure_two_sides_lazy = [two for _, _, two in self.dyad_scales]
        #: the most any check left for later can miss (m; closure_bound's proof), or None: no
        #: check is left (none is rounding alone, or their bound is no use against the limit)
        self.miss_bound: float | None = max(bounds) if bounds else None
        if self.miss_bound is not None and not self.miss_bound / self.L <= self.closure_limit:
            self.closure_one_side += self.closure_one_side_lazy
            self.angle_knowns += self.angle_knowns_lazy
            self.closure_two_sides += self.closure_two_sides_lazy
            self.closure_one_side_lazy, self.angle_knowns_lazy = [], []
            self.closure_two_sides_lazy, self.dyad_scales = [], []
            self.miss_bound = None
        #: the residual the bound allows, and the branch noise bound at it (result.py's
        #: branch_undefined_below, as result() computes it)
        self.bound_residual = self.bound_noise = math.inf
        #: the frame registers (rot, T) those checks read where their bound needs them tested
        #: finite (the finiteness sum of points and angles does not read them: a T at ~1e308
        #: m; closure_bound.frames_bounded, and a dyad joint's step 4: finite where bounded)
        self.lazy_frames = sorted(frames)
        if self.miss_bound is not None:
            self.bound_residual = self.miss_bound / self.L
            self.bound_noise = 4.0 * (2.0 * (self.bound_residual + 32.0 * EPS)) ** 0.5
        self.knowns = [
            (i, read.kind, slot_reader(read, prog))
            for i, read in read_knowns
            if read.kind is not ReadKind.ANGLE and i not in read_slide
        ]
        self.point_names = prog.point_names
        #: the registers of the points a run sets and of the placed links' angles, the first
        #: of the register list (ScalarProgram)
        self.n_set = prog.n_set
        self.n_points = len(prog.point_names)  # (complex; the links' angles after them)
        #: any check made on every run (result's first loops)
        self.eager = bool(
            self.closure_one_side
            or self.closure_two_sides
            or self.slides
            or self.angle_knowns
            or self.knowns
        )

    def result(self, r: SlotRun, state: SlotState) -> Result:
        """The Result of a run that closed (refused if any value is not finite), ``state`` its
        State. What decides it is computed here: the loop-closure residual (or a bound that
        settles what it decides: closure_bound), the margin and branch_defined, whether every
        value is finite; the name-keyed dicts (inputs, joints, links, points) and the branch
        text are read off the registers when first asked (:class:`ClosedResult`, from the
        State: one object holds what both read)."""
        L, R = self.L, r.R  # (pairs: a wider tuple assignment builds a tuple)
        vals, signs = state.values, state.signs
        # (loops, not comprehensions: a comprehension is a call in Python 3.11)
        worst = 0.0  # the largest component of a closure miss (m); NaN ones are not counted
        # ``total``: the values of the Result that may not be finite, summed (the test below)
        total = 0.0
        if self.eager:  # (none in a one-loop forward plan such as the four-bar's)
            if self.closure_one_side:  # (the order of the checks changes no maximum)
                worst = one_side_worst(self.closure_one_side, R, worst)
            if self.closure_two_sides:
                worst = two_sides_worst(self.closure_two_sides, R, worst)
            for (_, _, p, normal, sphi, srot, sT, gphi, grot, gT, face, known,
                 xrot, xT, x_ref, origin, direction, at_point, turned) in self.slides:  # fmt: skip
                # the slide's value: slot_reads.slot_reader's slide, inlined
                g = R[grot]
                x = R[xrot] * x_ref + R[xT]
                v = x - (g * origin + R[gT])
                d = g * direction
                got = v.real * d.real + v.imag * d.imag
                total += got
                if known >= 0:  # the slide is a known: its miss (the knowns' loop below, once)
                    a = abs(got - vals[known])
                    if a > worst:
                        worst = a
                off = (x if at_point else R[srot] * p + R[sT]) - (g * p + R[gT])
                nrm = g * normal
                # ResultAssembler's rule: a roller (face: its drawn offset) closes on either side
                across = off.real * nrm.real + off.imag * nrm.imag
                a = abs(abs(across + face) - abs(face)) if face else abs(across)
                if a > worst:
                    worst = a
                if turned:
                    a = R[sphi] - R[gphi]
                    if not _NEG_PI < a <= _PI:
                        a = wrap_one(a)
                    a = L * abs(a)
                    if a > worst:
                        worst = a
            if self.angle_knowns:
                worst = angle_worst(self.angle_knowns, R, worst, L)
            for i, kind, read in self.knowns:  # (empty in a forward solve)
                got, v = read(R), vals[i]
                if kind is _POINT:
                    a = max(abs(got.real - v[0]), abs(got.imag - v[1]))
                else:
                    a = abs(got - v)
                if a > worst:
                    worst = a
        margin = r.margin  # (a float: 1.0, or a dyad's)
        # Every value is finite when these are: a joint or link angle is one of the placed
        # links' angles (bounded) less another plus a constant, a point its register, an input
        # commanded (parsed: finite) or read here. One sum is finite when every term is (it
        # may overflow only at ~1e308 scales, where the exact check below runs).
        if self.read_inputs:
            for _, read in self.read_inputs:
                total += read(R)
        # (the angles apart: sum's float loop is several times faster than its general one)
        zsum = sum(R[: self.n_points], 0j)
        total += zsum.real + zsum.imag + sum(R[self.n_points : self.n_set], margin)
        bound = self.miss_bound
        if bound is not None:
            for i_scale, cap, two in self.dyad_scales:  # (a dyad's S beyond its bound's,
                if not R[i_scale] <= cap:  # or NaN where the kernel did not place it: now)
                    worst = two_sides_worst([two], R, worst)
            # The checks left out miss by at most ``bound`` on finite registers
            # (closure_bound), so the residual is at most ``high``: where that passes the
            # closure limit and puts the margin above the noise bound (monotone in the
            # residual), success and branch_defined are what the residual itself would give,
            # and it is computed when read (ClosedLazyResidual); else it is computed now.
            if worst > bound:
                high = worst / L
                noise = 4.0 * (2.0 * (high + 32.0 * EPS)) ** 0.5
            else:  # (the same floats, computed once)
                high, noise = self.bound_residual, self.bound_noise
            defined = True
            if signs:  # (the comparison's own type: a numpy margin gives numpy's bool)
                defined = margin > noise
            fz = sum(map(R.__getitem__, self.lazy_frames), total) if self.lazy_frames else total
            if defined and high <= self.closure_limit and fz - fz == 0.0:
                return lazy_residual_result(state, worst, margin, defined)
            worst = self.lazy_worst(R, worst)
        residual = worst / L
        defined = True
        if signs:  # branch_identity_defined (result.py), inlined
            defined = margin > 4.0 * (2.0 * (residual + 32.0 * EPS)) ** 0.5
        total += residual
        if total - total != 0.0 and not self._all_finite(R, vals, residual, margin):
            return Result(
                False, 'internal error: non-finite value in the solution', solver=_CLOSED_FORM
            )
        return closed_result(state, residual, margin, defined)

    def lazy_worst(self, R: list[Any], worst: float) -> float:
        """``worst`` (m) and the misses of the checks left for when the residual is read."""
        if self.closure_one_side_lazy:
            worst = one_side_worst(self.closure_one_side_lazy, R, worst)
        if self.closure_two_sides_lazy:
            worst = two_sides_worst(self.closure_two_sides_lazy, R, worst)
        if self.angle_knowns_lazy:
            worst = angle_worst(self.angle_knowns_lazy, R, worst, self.L)
        return worst

    def fill(self, d: dict[str, Any], R: list[Any], vals: Values) -> None:
        """The name-keyed values of a run that closed into ``d`` (a Result's ``__dict__``),
        where it has none of its own: inputs, joints, links, points (and targets, none)."""
        inputs: dict[str, float] = {}
        for actuator, i in self.commanded:
            inputs[actuator] = float(vals[i])
        if self.read_inputs:
            inputs.update((a, read(R)) for a, read in self.read_inputs)
            inputs = {a: inputs[a] for a in self.input_order}
        joints: dict[str, float] = {}
        for name, child, parent, offset in self.revolute_angles:
            a = offset + R[child] - R[parent]
            if not _NEG_PI < a <= _PI:
                a = wrap_one(a)
            joints[name] = a
        for slide in self.slides:
            joints[slide.joint] = slide.reader(R)
        links: dict[str, float] = {}
        for l, i, ref in self.links:
            a = ref + R[i]
            if not _NEG_PI < a <= _PI:
                a = wrap_one(a)
            links[l] = a
        points: dict[str, tuple[float, float]] = {}
        for point, z in zip(self.point_names, R):
            points[point] = (z.real, z.imag)
        got = {'inputs': inputs, 'targets': {}, 'joints': joints, 'links': links, 'points': points}
        got.update(d)  # (what the Result was given meanwhile stays)
        d.update(got)

    def _all_finite(self, R: list[Any], vals: Values, residual: float, margin: float) -> bool:
        """Every value of the Result finite (the exact check where the sum overflowed)."""
        d: dict[str, Any] = {}
        self.fill(d, R, vals)
        return all(
            math.isfinite(v)
            for v in [
                *d['joints'].values(),
                *d['links'].values(),
                *d['inputs'].values(),
                *(c for p in d['points'].values() for c in p),
                residual,
                margin,
            ]
        )

    def lean_command(
        self, cont: Continuity, values: Mapping[str, Any], commit: bool = True
    ) -> Result | None:
        """:func:`~linkage_ros.core.solver.one.solve_one` of a forward closed-form solve for
        the common command (a dict of one finite float per known) that assembles: the same
        Result by the same steps, without the general path's checks of what this command
        is not. None, having changed nothing, for any other command or answer: solve_one
        answers those (it refuses them, or echoes other kinds of values)."""
        names = self.known_names
        if type(values) is not dict or len(values) != self.n_known:
            return None
        vals: Values = []
        try:
            for name in names:
                v = values[name]
                if type(v) is not float or v - v != 0.0:  # (an int, NaN, ...)
                    return None
                vals.append(v)
        except KeyError:
            return None
        if self.limited:  # (the interval test is limit_violation's None: value_interval)
            for i, lo, hi in self.limit_intervals:
                if not lo <= vals[i] <= hi:
                    return None
            for i, spec in self.limit_arcs:
                if limit_violation(spec, vals[i]) is not None:
                    return None
        r = run_command(self.prog, self.c, cont, vals)
        if r.failure >= 0:
            return None
        state = slot_state(vals, r.used, r.margins, self, r.R)
        res = self.result(r, state)
        if not res.success:
            return None
        # (a residual left for later is within the limit: SlotReadout.result)
        if type(res) is not ClosedLazyResidual and not res.residual <= self.closure_limit:  # type: ignore[operator]
            return None
        if commit:
            cont.commit(state)
        return res


_READOUT = 'readout'


def readout(c: CompiledSolve) -> SlotReadout:
    """The compiled solve's readout, made on first use and kept on it (as ``program`` keeps
    the program on its plan: a dict lookup per command, where a WeakKeyDictionary's made a
    weak reference each time)."""
    got: SlotReadout | None = c.derived.get(_READOUT)
    if got is None:
        got = c.derived[_READOUT] = SlotReadout(c, program(c.plan))
    return got


class LeanCommand:
    """``command(cont, values, commit)``: :meth:`SlotReadout.lean_command` of a compiled
    solve, its readout made on the first command (a solver that never solves one never pays
    for it)."""

    command: Callable[[Continuity, Mapping[str, Any], bool], Result | None]

    def __init__(self, c: CompiledSolve):
        self._c = c
        self.command = self._first

    def _first(self, cont: Continuity, values: Mapping[str, Any], commit: bool) -> Result | None:
        self.command = readout(self._c).lean_command
        return self.command(cont, values, commit)


def lean_command(c: CompiledSolve) -> LeanCommand | None:
    """The lean path of ``c``'s commands where it has one: a forward closed-form solve (every
    known an actuator's angle or slide), else None."""
    if c.mode is not _CLOSED_FORM or c.inverse or c.point_pairs:
        return None
    if any(isinstance(s, PointSpec) for s in c.specs):
        return None
    return LeanCommand(c)


def solve_closed(c: CompiledSolve, cont: Continuity, vals: Values) -> tuple[Result, State | None]:
    """The dyad plan on one command, on the branch ``cont`` chooses."""
    read = readout(c)
    r = run_command(read.prog, c, cont, vals)
    if r.failure >= 0:
        reason = c.dyad_reason(r.failure, r.violation)
        return c.fail(reason, c.echo(vals), _CLOSED_FORM), None
    state = slot_state(vals, r.used, r.margins, read, r.R)
    return read.result(r, state), state


def run_command(prog: ScalarProgram, c: CompiledSolve, cont: Continuity, vals: Values) -> SlotRun:
    """The plan's run on one command, on the branch ``cont`` chooses: near a dyad's
    singularity the continuity rule's nearest candidate, and a dyad it moves to its other
    branch put back where the motion from the last answer does not pass through the
    singularity (crossing.kept_signs)."""
    history = cont.history
    signs = cont.signs(c.plan)
    r = prog.run_parsed(vals, signs, history[-1].margins if history else None, cont.prediction, c)
    if r.used == signs or r.failure >= 0 or not history:  # (the common run: no move)
        return r
    kept = kept_signs(prog, c, history, vals, signs, r.used)
    if kept is None:
        return r
    # (the kept signs as given: a dyad after one put back keeps the sign continuity chose for
    # it with that one moved, where it has a choice at all)
    back = prog.run_parsed(vals, kept)
    return back if back.failure < 0 else r
