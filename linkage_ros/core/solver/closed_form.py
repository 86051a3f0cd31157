"""The closed-form path of one command: the plan's slot program, then the Result read off its
slots.

:class:`SlotReadout` is the one-command twin of :class:`~linkage_ros.core.assemble.
ResultAssembler` (which reads a batch, and a Newton answer's name-keyed poses): the same
values by the same float operations (every commanded actuator as given, every other actuator,
joint and link whose links are placed, and the loop-closure residual as a fraction of the
length scale), with every name resolved to a slot of :class:`~linkage_ros.core.scalar_plan.
ScalarProgram` once, so that a command builds each of the Result's dicts once. Measured in one
process (warm four-bar, 2-core machine at load ~5): ``build_result`` over the assembler took
18 us of a 53 us solve, this readout and the Result ~6 us.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable
from typing import Any

from ..ops import _wrap_one
from ..plan import ReadKind, SpecReader, spec_reader
from ..quantities import PointSpec, SlideSpec
from ..scalar_plan import ScalarProgram, SlotRun, program
from ..steps import branch_text
from .compiled import CompiledSolve, SolveMode, Values
from .continuity import Continuity, State
from .result import _EPS, Result

_PI = math.pi
_CLOSED_FORM = SolveMode.CLOSED_FORM


def _wrap(a: float) -> float:
    return a if -_PI < a <= _PI else _wrap_one(a)


def _slot_reader(read: SpecReader, ls: dict[str, int]) -> Callable[[SlotRun], Any]:
    """SpecReader.__call__ on a run's slots: an angle (rad, wrapped), a slide (m) or a point
    (complex)."""
    if read.kind is ReadKind.ANGLE:
        a, b, off = ls[read.link], ls[read.reference], read.offset
        return lambda r: _wrap(r.phi[a] - r.phi[b] + off)
    link, p_ref = ls[read.link], read.p_ref
    if read.kind is ReadKind.POINT:
        return lambda r: r.rot[link] * p_ref + r.T[link]
    g, origin, direction = ls[read.reference], read.origin, read.direction

    def slide(r: SlotRun) -> float:
        x = r.rot[link] * p_ref + r.T[link]
        rot = r.rot[g]
        v = x - (rot * origin + r.T[g])
        d = rot * direction
        return v.real * d.real + v.imag * d.imag  # type: ignore[no-any-return]

    return slide


class SlotReadout:
    """What to read off a program's runs for one compiled solve, resolved once (see the
    module)."""

    def __init__(self, c: CompiledSolve, prog: ScalarProgram):
        mech, specs = c.mech, c.specs
        ls = prog.lslot
        have = set(prog.link_names)
        spec_links = c.check_system.spec_links
        self.L = mech.length_scale
        commanded = {s.name: i for i, s in enumerate(specs)}
        #: (actuator, index of its commanded value, or its reader)
        self.inputs: list[tuple[str, int | None, Callable[[SlotRun], Any] | None]] = []
        for a, s in zip(mech.actuators, c.actuator_specs):
            if a in commanded:
                self.inputs.append((a, commanded[a], None))
            elif all(l in have for l in spec_links(s)):
                self.inputs.append((a, None, _slot_reader(spec_reader(mech, s), ls)))
        self.revolutes = [
            (
                rj.name,
                ls[rj.child],
                ls[rj.parent],
                mech.links[rj.child].angle_ref - mech.links[rj.parent].angle_ref,
                complex(float(mech.points[rj.point][0]), float(mech.points[rj.point][1])),
            )
            for rj in mech.revolutes
            if rj.parent in have and rj.child in have
        ]
        self.slides = [
            (
                pj.name,
                ls[pj.slider],
                ls[pj.guide],
                _slot_reader(spec_reader(mech, SlideSpec(pj.name, pj.name)), ls),
                complex(float(mech.points[pj.point][0]), float(mech.points[pj.point][1])),
                1j * complex(float(pj.direction[0]), float(pj.direction[1])),
            )
            for pj in mech.prismatics.values()
            if pj.guide in have and pj.slider in have
        ]
        self.link_names = tuple(l for l in mech.links if l in have)
        self.links = [(ls[l], mech.links[l].angle_ref) for l in self.link_names]
        self.knowns = [
            (i, spec_reader(mech, s).kind, _slot_reader(spec_reader(mech, s), ls))
            for i, s in enumerate(specs)
            if all(l in have for l in spec_links(s))
        ]
        self.point_names = prog.point_names
        #: the Result's echo of a command: its point knowns as given
        self.points_known = any(isinstance(s, PointSpec) for s in specs)
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
        L, phi, rot, T = self.L, r.phi, r.rot, r.T
        inputs = {}
        for a, i, read in self.inputs:
            inputs[a] = float(vals[i]) if read is None else read(r)  # type: ignore[index]
        joints = {}
        worst = 0.0
        for name, child, parent, offset, p in self.revolutes:
            joints[name] = _wrap(offset + phi[child] - phi[parent])
            d = (rot[parent] * p + T[parent]) - (rot[child] * p + T[child])
            dx, dy = abs(d.real), abs(d.imag)
            m = dy if dy > dx else dx
            if m > worst:
                worst = m
        for name, slider, guide, read, p, normal in self.slides:
            joints[name] = read(r)
            off = (rot[slider] * p + T[slider]) - (rot[guide] * p + T[guide])
            nrm = rot[guide] * normal
            worst = max(worst, abs(off.real * nrm.real + off.imag * nrm.imag))
            worst = max(worst, L * abs(_wrap(phi[slider] - phi[guide])))
        links = {l: _wrap(ref + phi[s]) for l, (s, ref) in zip(self.link_names, self.links)}
        for i, kind, read in self.knowns:
            got, v = read(r), vals[i]
            if kind is ReadKind.POINT:
                worst = max(worst, max(abs(got.real - v[0]), abs(got.imag - v[1])))
            elif kind is ReadKind.ANGLE:  # reduce v exactly first
                worst = max(worst, L * abs(_wrap(got - _wrap(v))))
            else:
                worst = max(worst, abs(got - v))
        residual = worst / L
        points = {p: (z.real, z.imag) for p, z in zip(self.point_names, r.P)}
        margin = float(r.margin)
        defined = True
        if signs:  # branch_identity_defined (result.py), inlined
            defined = bool(margin > 4.0 * (2.0 * (residual + 32.0 * _EPS)) ** 0.5)
        total = (
            sum(joints.values())
            + sum(links.values())
            + sum(inputs.values())
            + sum([x + y for x, y in points.values()])
            + residual
            + margin
        )
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
            self.branch_text(signs),
            defined,
            margin,
            None,
        )


#: each compiled solve's readout, made on first use (kept while the compiled solve lives)
_READOUTS: weakref.WeakKeyDictionary[CompiledSolve, SlotReadout] = weakref.WeakKeyDictionary()


def readout(c: CompiledSolve) -> SlotReadout:
    got = _READOUTS.get(c)
    if got is None:
        got = _READOUTS[c] = SlotReadout(c, program(c.plan))
    return got


def solve_closed(c: CompiledSolve, cont: Continuity, vals: Values) -> tuple[Result, State | None]:
    """The dyad plan on one command, on the branch ``cont`` chooses."""
    last = cont.last
    prog = program(c.plan)
    r = prog.execute(
        vals,
        cont.signs(c.plan),
        cont.prediction(c, vals),
        last.margins if last is not None else None,
    )
    if r.failure >= 0:
        reason = c.dyad_reason(r.failure, r.violation)
        return c.fail(reason, c.echo(vals), _CLOSED_FORM), None
    signs = tuple(r.used)
    res = readout(c).result(r, vals, signs)
    state = State(vals, None, prog.points_of(r), prog.poses_of(r), signs, 0, tuple(r.margins), None)
    return res, state
