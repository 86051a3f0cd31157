"""A compiled solve: what a mechanism and a set of known names fix once, for every command.

:class:`CompiledSolve` is frozen: the specs of the knowns, the dyad plans, the Newton loop
systems, the solve mode and the tolerances. The closed-form path (``one.py``), the Newton path
(``newton_path.py``), the batch (``batch.py``) and the mode search (``modes.py``) are functions
over it and over the caller's :class:`~linkage_ros.core.solver.continuity.Continuity`; the
public :class:`~linkage_ros.core.solver.Solver` holds one of each. Built by
:func:`~linkage_ros.core.solver.compiling.compile_solve`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property
from typing import Any, NoReturn

import numpy as np

from ..assemble import ResultAssembler
from ..errors import echo, not_finite
from ..execute import LinkPoses
from ..model import Mechanism
from ..newton import LoopSystem
from ..ops import SCALAR
from ..plan import Plan, Spec, limit_violation, run_one
from ..quantities import PointSpec, ScalarSpec
from .point_pairs import PointPair, pair_values, parse_point
from .result import Result, SolveMethod, answer_branch, dyad_reason

#: one command's known values in spec order: a float (rad or m) or an (x, y) point array (m)
Values = list[Any]


class SolveMode(StrEnum):
    """How a solve places the mechanism (the ``solver`` field of every Result)."""

    CLOSED_FORM = 'closed_form'  # the dyad plan places every link
    HYBRID = 'hybrid'  # the dyad plan places what it can, Newton the rest
    NEWTON = 'newton'  # loop-closure Newton on every moving link


@dataclass(frozen=True, eq=False)
class CompiledSolve:
    """One mechanism, one set of knowns and wanted outputs, compiled (see the module)."""

    mech: Mechanism
    #: the names a command gives, as the caller listed them
    knowns: tuple[str, ...]
    #: the knowns the plan solves, aligned with ``specs`` (two points of one link: the first
    #: point and the link's angle, see point_pairs)
    plan_knowns: tuple[str, ...]
    specs: tuple[Spec, ...]
    #: every actuator's spec (an angle or a slide), in the mechanism's order
    actuator_specs: tuple[ScalarSpec, ...]
    point_pairs: tuple[PointPair, ...]
    #: the dyad plan of the wanted outputs, and of every link (the same object without outputs)
    plan: Plan
    full_plan: Plan
    method: SolveMethod
    mode: SolveMode
    #: Newton over the links the dyad plan does not place, and over every moving link
    system: LoopSystem
    check_system: LoopSystem
    closed_links: tuple[str, ...]
    tol: float
    max_iter: int
    #: the largest loop-closure residual (fraction of the length scale) an answer may have
    closure_limit: float
    #: some known is not an actuator (an inverse solve)
    inverse: bool
    #: the knowns' values in the reference pose, in spec order
    ref_values: tuple[Any, ...]
    #: per spec: its limits as (index, spec) where it has any (the command check)
    limited: tuple[tuple[int, ScalarSpec], ...]
    #: result assembly per set of placed links (a handful occur: bounded, see assembler)
    _assemblers: dict[tuple[str, ...], ResultAssembler] = field(default_factory=dict, repr=False)
    #: what the solve paths derive from this compiled solve once (the closed form's readout,
    #: the Newton path's kernel), keyed by what it is: made on first use (the dict is not
    #: frozen; a lookup per command)
    derived: dict[str, Any] = field(default_factory=dict, repr=False)

    # -- facts ---------------------------------------------------------------------------------
    @property
    def branch_count(self) -> int:
        """Branching dyads of the plan (one sign each in a branch string)."""
        return len(self.plan.branch_steps)

    @cached_property
    def branch_positions(self) -> tuple[int, ...]:
        """Where each branching dyad of ``plan`` is among ``full_plan``'s (its index there): a
        plan pruned to some outputs keeps some of the whole mechanism's dyads. Both plans
        compile the same steps (``steps_all``, in one order) and prune them differently."""
        full, plan = self.full_plan, self.plan
        if plan is full:
            return tuple(range(len(plan.branch_steps)))
        full_at = {id(s): k for k, s in enumerate(full.steps_all)}
        position = {full_at[id(s)]: j for j, s in enumerate(full.branch_steps)}
        at = {id(s): k for k, s in enumerate(plan.steps_all)}
        return tuple(position[at[id(s)]] for s in plan.branch_steps)

    def full_signs(self, signs: Sequence[int]) -> tuple[int, ...]:
        """``signs`` of ``plan``'s branching dyads as signs of ``full_plan``'s: a dyad a plan
        pruned to some outputs leaves out keeps its sign in the reference pose."""
        if self.plan is self.full_plan:
            return tuple(signs)
        out = list(self.full_plan.reference_signs)
        for j, sign in zip(self.branch_positions, signs):
            out[j] = sign
        return tuple(out)

    @property
    def pair_tolerance_m(self) -> float:
        """How far (m) the distance of a target's two points of one link may be from the
        link's: what the solver accepts as loop closure."""
        return self.closure_limit * self.mech.length_scale

    def reference_values(self) -> dict[str, Any]:
        """The known quantities' values in the scene's reference pose ({known name: value})."""
        return {
            s.name: (tuple(float(c) for c in v) if isinstance(s, PointSpec) else float(v))
            for s, v in zip(self.specs, self.ref_values)
        }

    # -- commands ------------------------------------------------------------------------------
    def parse(self, values: Mapping[str, Any]) -> Values:
        """Validate a {known name: value} command; raise ValueError naming what is wrong."""
        if type(values) is not dict and not isinstance(values, Mapping):  # (an ABC check)
            raise ValueError('a command must map known names to values')
        if self.point_pairs:
            values = pair_values(values, list(self.knowns), self.point_pairs, self.pair_tolerance_m)
        if len(values) != len(self.specs):
            self._refuse_names(values)
        out: Values = []
        for s in self.specs:
            try:
                v = values[s.name]
            except KeyError:
                self._refuse_names(values)
            if isinstance(s, PointSpec):
                out.append(parse_point(s.name, v))
            elif type(v) is float and v - v == 0.0:  # the common case: a finite float
                out.append(v)
            else:
                out.append(_parse_number(s, v))
        return out

    def _refuse_names(self, values: Mapping[str, Any]) -> NoReturn:
        unknown = [k for k in values if k not in self.plan_knowns]
        if unknown:
            raise ValueError(
                f'unknown name(s) {echo(unknown)}; this solve takes {list(self.knowns)}'
            )
        missing = [k for k in self.plan_knowns if k not in values]
        raise ValueError(f'missing value(s) for {missing}')

    def limit_refusal(self, vals: Sequence[Any]) -> str | None:
        """Why a command's known values break a limit of their own, or None."""
        for i, s in self.limited:
            bad = limit_violation(s, vals[i])
            if bad:
                return bad
        return None

    def echo(self, vals: Sequence[Any]) -> dict[str, Any]:
        """A command's values as a Result echoes them ({name: float or [x, y]})."""
        return {
            s.name: (list(map(float, v)) if isinstance(s, PointSpec) else float(v))
            for s, v in zip(self.specs, vals)
        }

    def fail(self, reason: str, given: Mapping[str, Any], solver: str | None = None) -> Result:
        """A refused Result echoing the command (inputs: its actuators; targets: the rest)."""
        actuators = self.mech.actuators
        return Result(
            False,
            reason,
            inputs={k: v for k, v in given.items() if k in actuators},
            targets={k: v for k, v in given.items() if k not in actuators},
            solver=solver or self.mode,
        )

    def closure_reason(self, residual: float) -> str:
        return (
            f'cannot assemble: the configuration found misses loop closure by '
            f'{residual:.3g} of the length scale (limit {self.closure_limit:.3g}); a known '
            'value may be out of reach of its link'
        )

    def dyad_reason(self, step: int, violation: float, plan: Plan | None = None) -> str:
        return dyad_reason(plan or self.plan, step, violation, self.mech.length_scale)

    # -- placing -------------------------------------------------------------------------------
    def fixed_poses(
        self, vals: Values, signs: Sequence[int] | None = None
    ) -> tuple[LinkPoses | None, str | None]:
        """Hybrid mode: the closed-form part's link poses (and the ground) at ``vals`` in its
        dyads' ``signs`` (None: the reference pose's), or the reason it does not close; (None,
        None) in the other modes."""
        if self.mode is not SolveMode.HYBRID:
            return None, None
        run = run_one(self.full_plan, vals, signs, None)
        if not run.ok:
            return None, self.dyad_reason(run.failure, run.violation, self.full_plan)
        keep = LinkPoses()
        for l in (*self.closed_links, self.mech.ground):
            keep.set(l, run.poses.phi[l], run.poses.T[l], run.poses.rot[l])
        return keep, None

    def sub_x(self, x_all: np.ndarray) -> np.ndarray:
        """The Newton unknowns of ``system`` out of those of every moving link."""
        if self.mode is SolveMode.NEWTON:  # every moving link is free, in the same order
            return x_all
        idx = self.check_system.index
        free = self.system.free
        if not free:
            return np.zeros(0)
        return np.concatenate([x_all[3 * idx[l] : 3 * idx[l] + 3] for l in free])

    def assembler(self, placed: Iterable[str]) -> ResultAssembler:
        """The result assembly for configurations that place exactly these links (one per set:
        a dyad plan always places the same links, Newton all of them)."""
        key = tuple(placed)
        fn = self._assemblers.get(key)
        if fn is None:
            fn = ResultAssembler(
                self.mech, self.specs, self.actuator_specs, self.check_system.spec_links, key
            )
            if len(self._assemblers) < 16:  # a handful of sets occur; never grow unbounded
                self._assemblers[key] = fn
        return fn

    def build_result(
        self,
        poses: LinkPoses,
        pts: Mapping[str, complex],
        vals: Values,
        *,
        solver: str,
        iterations: int,
        signs: Sequence[int],
        margin: float,
        cond: float | None = None,
        label: str | None = None,
    ) -> Result:
        """The Result of one solved configuration (refused if any value is not finite).
        ``label``: the mode's name where the dyad signs do not give it (reading.mode_label)."""
        got = self.assembler(poses.phi)(SCALAR, poses, vals)
        inputs, joints, links, residual = got.inputs, got.joints, got.links, got.residual
        points = {p: (v.real, v.imag) for p, v in pts.items()}
        res = Result(
            True,
            None,
            inputs,
            {},
            joints,
            links,
            points,
            residual,
            iterations,
            solver,
            *answer_branch(signs, label, margin, residual),
            float(margin),
            cond if cond is None or math.isfinite(cond) else None,
        )
        # one sum is finite when every term is (and may overflow only at ~1e308 scales, where
        # the exact check below runs)
        total = (
            sum(joints.values())
            + sum(links.values())
            + sum(inputs.values())
            + sum(v.real + v.imag for v in pts.values())
            + residual
            + res.margin
        )
        if not math.isfinite(total) and not all(
            math.isfinite(v)
            for v in [
                *joints.values(),
                *links.values(),
                *inputs.values(),
                *(c for p in points.values() for c in p),
                residual,
                float(margin),
            ]
        ):
            return Result(False, 'internal error: non-finite value in the solution', solver=solver)
        return res


def _parse_number(s: Spec, v: Any) -> float:
    """One angle or slide value of a command as a finite float; ValueError naming the spec.
    A 0-d numpy array is its one number (solve_batch takes it as a batch of one)."""
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v[()]
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.floating, np.integer)):
        raise ValueError(f'{s.name}: value must be a number in {s.unit} (got {echo(v)})')
    try:
        fv = float(v)
    except OverflowError:  # a Python int beyond the float range
        fv = math.inf
    if not math.isfinite(fv):
        raise ValueError(not_finite(s.name, v))
    return fv
