"""The closed-form path of one command: the plan's slot program, then the Result read off its
slots.

:class:`SlotReadout` is the one-command twin of :class:`~linkage_ros.core.assemble.
ResultAssembler` (which reads a batch, and a Newton answer's name-keyed poses): the same
values by the same float operations (every commanded actuator as given, every other actuator,
joint and link whose links are placed, and the loop-closure residual as a fraction of the
length scale), with every name resolved to a slot of :class:`~linkage_ros.core.scalar_plan.
ScalarProgram` once, so that a command builds each of the Result's dicts once. Measured in one
process (CPU time, best of 15 x 2000 calls on one four-bar configuration; 2-core machine shared
with other jobs, load ~10): ``CompiledSolve.build_result`` over the assembler 13.0 us, this
readout with the Result 7.9 us. A closed-form answer's State (:class:`SlotState`) reads its
name-keyed points and poses off the registers only when continuity asks.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..assemble import roller_offset
from ..execute import LinkPoses
from ..ops import _wrap_one
from ..plan import ReadKind, SpecReader, spec_reader
from ..quantities import SlideSpec
from ..scalar_plan import ScalarProgram, program
from ..scalar_run import SlotRun
from ..steps import branch_text
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import Continuity, State
from .result import _EPS, Result

_PI = math.pi
_CLOSED_FORM = SolveMode.CLOSED_FORM
_POINT = ReadKind.POINT


def _wrap(a: float) -> float:
    return a if -_PI < a <= _PI else _wrap_one(a)


def _slot_reader(read: SpecReader, prog: ScalarProgram) -> Callable[[list[Any]], Any]:
    """SpecReader.__call__ on a run's registers: an angle (rad, wrapped), a slide (m) or a
    point (complex)."""
    if read.kind is ReadKind.ANGLE:
        a, b, off = prog.iphi[read.link], prog.iphi[read.reference], read.offset
        return lambda R: _wrap(R[a] - R[b] + off)
    rot, T, p_ref = prog.irot[read.link], prog.iT[read.link], read.p_ref
    if read.kind is ReadKind.POINT:
        return lambda R: R[rot] * p_ref + R[T]
    grot, gT, origin, direction = (
        prog.irot[read.reference],
        prog.iT[read.reference],
        read.origin,
        read.direction,
    )

    def slide(R: list[Any]) -> float:
        x = R[rot] * p_ref + R[T]
        g = R[grot]
        v = x - (g * origin + R[gT])
        d = g * direction
        return v.real * d.real + v.imag * d.imag  # type: ignore[no-any-return]

    return slide


def _c(v: Any) -> complex:
    return complex(float(v[0]), float(v[1]))


class SlotReadout:
    """What to read off a program's runs for one compiled solve, resolved once (see the
    module)."""

    def __init__(self, c: CompiledSolve, prog: ScalarProgram):
        mech, specs = c.mech, c.specs
        self.prog = prog
        have = set(prog.link_names)
        spec_links = c.check_system.spec_links
        self.L = mech.length_scale
        commanded = {s.name: i for i, s in enumerate(specs)}
        #: (actuator, index of its commanded value), and the others' readers
        self.commanded = [(a, commanded[a]) for a in mech.actuators if a in commanded]
        self.read_inputs = [
            (a, _slot_reader(spec_reader(mech, s), prog))
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

        #: (joint, child, parent, angle offset, point, parent rot, T, child rot, T, and the
        #: point's register where it is that of the parent / the child)
        self.revolutes = [
            (
                rj.name,
                iphi[rj.child],
                iphi[rj.parent],
                mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
                _c(mech.points[rj.point]),
                irot[rj.parent],
                iT[rj.parent],
                irot[rj.child],
                iT[rj.child],
                reg(rj.point, rj.parent),
                reg(rj.point, rj.child),
            )
            for rj in mech.revolutes
            if rj.parent in have and rj.child in have
        ]
        self.slides = [
            (
                pj.name,
                _slot_reader(spec_reader(mech, SlideSpec(pj.name, pj.name)), prog),
                _c(mech.points[pj.point]),
                1j * _c(pj.direction),
                iphi[pj.slider],
                irot[pj.slider],
                iT[pj.slider],
                iphi[pj.guide],
                irot[pj.guide],
                iT[pj.guide],
                roller_offset(mech, pj.name),
            )  # fmt: skip
            for pj in mech.prismatics.values()
            if pj.guide in have and pj.slider in have
        ]
        self.links = [(l, iphi[l], mech.links[l].angle_ref) for l in mech.links if l in have]
        read_knowns = [
            (i, spec_reader(mech, s))
            for i, s in enumerate(specs)
            if all(l in have for l in spec_links(s))
        ]
        #: the known angles read inline (their link's and reference's phi registers, offset)
        self.angle_knowns = [
            (i, iphi[read.link], iphi[read.reference], read.offset)
            for i, read in read_knowns
            if read.kind is ReadKind.ANGLE
        ]
        self.knowns = [
            (i, read.kind, _slot_reader(read, prog))
            for i, read in read_knowns
            if read.kind is not ReadKind.ANGLE
        ]
        self.point_names = prog.point_names
        self._branch_texts: dict[tuple[int, ...], str] = {}

    def branch_text(self, signs: tuple[int, ...]) -> str:
        text = self._branch_texts.get(signs)
        if text is None:
            text = branch_text(signs)
            if len(self._branch_texts) < 64:  # a handful of modes occur; never grow unbounded
                self._branch_texts[signs] = text
        return text

    def result(self, r: SlotRun, vals: Values, signs: tuple[int, ...]) -> Result:
        """The Result of a run that closed (refused if any value is not finite)."""
        L, R = self.L, r.R
        # (loops, not comprehensions: a comprehension is a call in Python 3.11)
        inputs: dict[str, float] = {}
        for actuator, i in self.commanded:
            inputs[actuator] = float(vals[i])
        if self.read_inputs:
            inputs.update((a, read(R)) for a, read in self.read_inputs)
            inputs = {a: inputs[a] for a in self.input_order}
        # ``total``: every float of the Result summed as it is made (the finiteness test below)
        joints: dict[str, float] = {}
        worst = total = 0.0
        for name, child, parent, offset, p, prot, pT, crot, cT, preg, creg in self.revolutes:
            a = offset + R[child] - R[parent]
            if not -_PI < a <= _PI:
                a = _wrap_one(a)
            joints[name] = a
            total += a
            d = (R[preg] if preg >= 0 else R[prot] * p + R[pT]) - (
                R[creg] if creg >= 0 else R[crot] * p + R[cT]
            )
            # the largest component (a NaN one makes the Result refused whatever the residual)
            a = abs(d.real)
            if a > worst:
                worst = a
            a = abs(d.imag)
            if a > worst:
                worst = a
        for name, read, p, normal, sphi, srot, sT, gphi, grot, gT, face in self.slides:
            joints[name] = a = read(R)
            total += a
            off = (R[srot] * p + R[sT]) - (R[grot] * p + R[gT])
            nrm = R[grot] * normal
            # ResultAssembler's rule: a roller (face: its drawn offset) closes on either side
            across = off.real * nrm.real + off.imag * nrm.imag
            a = abs(abs(across + face) - abs(face)) if face else abs(across)
            if a > worst:  # max(worst, a), without the call
                worst = a
            a = R[sphi] - R[gphi]
            if not -_PI < a <= _PI:
                a = _wrap_one(a)
            a = L * abs(a)
            if a > worst:
                worst = a
        links: dict[str, float] = {}
        for l, i, ref in self.links:
            a = ref + R[i]
            if not -_PI < a <= _PI:
                a = _wrap_one(a)
            links[l] = a
            total += a
        for i, ia, ib, off in self.angle_knowns:  # _slot_reader's angle, _wrap inlined
            got = R[ia] - R[ib] + off
            if not -_PI < got <= _PI:
                got = _wrap_one(got)
            v = vals[i]
            if not -_PI < v <= _PI:  # reduce v exactly first
                v = _wrap_one(v)
            a = got - v
            if not -_PI < a <= _PI:
                a = _wrap_one(a)
            a = L * abs(a)
            if a > worst:  # max(worst, a)
                worst = a
        for i, kind, read in self.knowns:
            got, v = read(R), vals[i]
            if kind is _POINT:
                a = max(abs(got.real - v[0]), abs(got.imag - v[1]))
            else:
                a = abs(got - v)
            if a > worst:  # max(worst, a)
                worst = a
        residual = worst / L
        names = self.point_names
        points: dict[str, tuple[float, float]] = {}
        zsum = 0j
        for point, z in zip(names, R):
            points[point] = (z.real, z.imag)
            zsum += z
        margin = float(r.margin)
        defined = True
        if signs:  # branch_identity_defined (result.py), inlined
            defined = margin > 4.0 * (2.0 * (residual + 32.0 * _EPS)) ** 0.5
        # one sum is finite when every term is (it may overflow only at ~1e308 scales, where
        # the exact check below runs)
        total += sum(inputs.values()) + (zsum.real + zsum.imag) + residual + margin
        if total - total != 0.0 and not all(
            math.isfinite(v)
            for v in [
                *joints.values(),
                *links.values(),
                *inputs.values(),
                *(c for p in points.values() for c in p),
                residual,
                margin,
            ]
        ):
            return Result(
                False, 'internal error: non-finite value in the solution', solver=_CLOSED_FORM
            )
        return Result(
            True,
            None,
            inputs,
            {},
            joints,
            links,
            points,
            residual,
            0,
            _CLOSED_FORM,
            self._branch_texts.get(signs) or self.branch_text(signs),
            defined,
            margin,
            None,
        )


def readout(c: CompiledSolve) -> SlotReadout:
    """The compiled solve's readout, made on first use and kept on it (as ``program`` keeps
    the program on its plan: a dict lookup per command, where a WeakKeyDictionary's made a
    weak reference each time)."""
    got: SlotReadout | None = c.__dict__.get('_slot_readout')
    if got is None:
        got = c.__dict__['_slot_readout'] = SlotReadout(c, program(c.plan))
    return got


class SlotState(State):
    """The State of a closed-form answer whose points and poses (name-keyed, as State holds
    them) are read off the run's registers on first use: most commands never ask (continuity
    reads them near a singular dyad only). Pickles as a plain State."""

    def __init__(
        self,
        values: Values,
        signs: tuple[int, ...],
        margins: tuple[float, ...],
        prog: ScalarProgram,
        registers: list[Any],
    ):  # State's fields set here, points and poses on first use
        self.values, self.x_all, self.signs, self.det_sign = values, None, signs, 0
        self.margins, self.x_lu = margins, None
        self._prog, self._registers = prog, registers
        self._points: dict[str, complex] | None = None
        self._poses: LinkPoses | None = None

    @property
    def points(self) -> dict[str, complex]:
        if self._points is None:
            self._points = self._prog.points_closed(self._registers)
        return self._points

    @points.setter
    def points(self, value: dict[str, complex]) -> None:
        self._points = value

    @property
    def poses(self) -> LinkPoses:
        if self._poses is None:
            self._poses = self._prog.poses_closed(self._registers)
        return self._poses

    @poses.setter
    def poses(self, value: LinkPoses) -> None:
        self._poses = value

    def __reduce__(self) -> tuple[Any, ...]:
        return State, (
            self.values, None, self.points, self.poses, self.signs, 0, self.margins, None
        )  # fmt: skip


def solve_closed(c: CompiledSolve, cont: Continuity, vals: Values) -> tuple[Result, State | None]:
    """The dyad plan on one command, on the branch ``cont`` chooses."""
    read = readout(c)
    prog, history = read.prog, cont.history
    r = prog.execute(
        vals,
        cont.signs(c.plan),
        None,
        history[-1].margins if history else None,
        predict=lambda: cont.prediction(c, vals),
    )
    if r.failure >= 0:
        reason = c.dyad_reason(r.failure, r.violation)
        return c.fail(reason, c.echo(vals), _CLOSED_FORM), None
    signs = tuple(r.used)
    res = read.result(r, vals, signs)
    return res, SlotState(vals, signs, tuple(r.margins), prog, r.R)
