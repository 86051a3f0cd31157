"""One entry point for forward and inverse position kinematics of a mechanism.

``Solver(mech, knowns, outputs, method, tol, max_iter, branch)`` compiles once; ``solve`` answers
one command, ``solve_batch`` a vector of commands. Every answer is a :class:`Result`: success or
a reason, loop-closure residual (fraction of the length scale), iterations, solver used, branch and
distance to singularity. A bad or unreachable command is a failed Result, never an exception and
never a NaN.

Methods: ``closed_form`` (the dyad plan; refused when the knowns have no closed-form plan),
``newton`` (loop-closure Newton on every link), ``auto`` (the dyad plan places what it can and
Newton places the rest).
Branch: ``continuous`` (start in the reference pose's assembly mode, then keep the mode nearest
the previous configuration), ``reference`` (the reference pose's signs, always) or an explicit sign
string such as ``+-`` (one sign per branching dyad of the plan, in plan order).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..assemble import ResultAssembler
from ..errors import PlanError, echo
from ..model import Mechanism, SlideActuator
from ..newton import LoopSystem
from ..ops import SCALAR
from ..plan import (
    Plan,
    ScalarPoses,
    Spec,
    limit_violation,
    reference_poses,
    run_one,
    spec_for,
    spec_value_one,
)
from ..quantities import AngleSpec, PointSpec, SlideSpec
from .batch import BatchAPI
from .configuration import ConfigurationReading
from .modes import ModeList, mode_key, newton_modes
from .newton_path import NewtonPath
from .point_pairs import find_point_pairs, pair_values, parse_point, replaced_knowns
from .result import (
    CLOSURE_LIMIT,
    METHODS,
    Result,
    _Prediction,
    _State,
    branch_identity_defined,
    branch_signs,
    branch_text,
    dyad_reason,
)

#: the condition number of an inverse solve's equations at the reference pose above which its
#: knowns are taken not to determine the mechanism (rounding alone gives ~1e16; a generic
#: reference pose of a well-posed solve stays below ~1e6)
UNDETERMINED_COND = 1e12


class Solver(NewtonPath, BatchAPI, ConfigurationReading):
    """Compiled solver for one mechanism, one set of known names and wanted outputs."""

    def __init__(
        self,
        mech: Mechanism,
        knowns: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
        method: str | None = None,
        tol: float = 1e-12,
        max_iter: int = 50,
        branch: str = 'continuous',
    ):
        self.mech = mech
        method = method or mech.solver
        if method not in METHODS:
            raise PlanError(f'unknown solver {method!r}; expected one of {list(METHODS)}')
        if isinstance(tol, bool) or not (
            isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0
        ):
            raise PlanError(f'tolerance must be a positive number (got {tol!r})')
        if isinstance(max_iter, bool) or not (isinstance(max_iter, int) and max_iter > 0):
            raise PlanError(f'max_iter must be a positive integer (got {max_iter!r})')
        self.tol, self.max_iter = float(tol), max_iter
        self.closure_limit = max(CLOSURE_LIMIT, 10.0 * self.tol)
        for what, names in (('knowns', knowns), ('outputs', outputs)):
            if names is not None and (
                isinstance(names, (str, bytes, Mapping))
                or not all(isinstance(v, str) for v in names)
            ):
                raise PlanError(f'{what} must be a list of names (got {names!r})')
        self.knowns = list(knowns) if knowns is not None else list(mech.actuators)
        if len(set(self.knowns)) != len(self.knowns):
            raise PlanError(f'a known is named twice: {self.knowns}')
        # two known points of one link fix its pose: the plan takes the first and the link's
        # angle (point_pairs); parse() converts a request, after checking their distance
        self.point_pairs = find_point_pairs(
            mech, self.knowns, [spec_for(mech, n) for n in self.knowns]
        )
        #: the knowns the plan solves, aligned with ``specs`` (``knowns`` with each pair's
        #: second point replaced by the link's angle)
        self.plan_knowns = replaced_knowns(self.knowns, self.point_pairs)
        if len(set(self.plan_knowns)) != len(self.plan_knowns):
            raise PlanError(
                f'the knowns {self.knowns} give the angle of a link twice (two of its points '
                'fix it already)'
            )
        self.specs = [spec_for(mech, n) for n in self.plan_knowns]
        n_values = sum(s.size for s in self.specs)
        if n_values != mech.dof:
            raise PlanError(
                f'{mech.name!r} has {mech.dof} degree(s) of freedom but the knowns '
                f'{self.knowns} give {n_values} value(s)'
                + (' (two points of one link give 3: its pose)' if self.point_pairs else '')
            )
        self.actuator_specs = [spec_for(mech, a) for a in mech.actuators]
        self.inverse = any(s.name not in mech.actuators for s in self.specs)
        wanted_links, wanted_points = self._wanted(outputs)
        self.plan = Plan(mech, self.specs, wanted_links, wanted_points)
        self.full_plan = self.plan if wanted_links is None else Plan(mech, self.specs, None, None)
        if method == 'closed_form' and not self.plan.complete:
            raise PlanError(
                f'no closed-form dyad plan for knowns {self.knowns} of '
                f'{mech.name!r}; use solver newton or auto'
            )
        self.method = method
        if method == 'newton':
            self.mode = 'newton'
        elif self.plan.complete:
            self.mode = 'closed_form'
        else:
            self.mode = 'hybrid'
        self.closed_links = (
            []
            if self.mode == 'newton'
            else [l for l in self.full_plan.placed_links if l != mech.ground]
        )
        free = [l for l in mech.moving_links if l not in self.closed_links]
        self.system = LoopSystem(mech, self.specs, free)
        self.check_system = LoopSystem(mech, self.specs, mech.moving_links)
        loose = self.check_system.unfixed_links()
        if loose:
            raise PlanError(
                f'the knowns {self.knowns} do not determine {mech.name!r}: they '
                f'give {n_values} value(s) for its {mech.dof} degree(s) of freedom '
                f'but constrain some links twice and leave a motion of '
                f'{loose[0]!r} free; choose knowns that each fix a different '
                'degree of freedom'
            )
        self._ref_values = self._values_at_reference()
        if self.inverse:
            self._check_determined(n_values)
        self.branch_mode, self.fixed_signs = self._parse_branch(branch)
        self._slide_specs = {n: SlideSpec(n, n) for n in mech.prismatics}
        self._assemblers: dict[tuple, Any] = {}  # result assembly per set of placed links
        self.reset()

    # -- set-up helpers ----------------------------------------------------------------------
    def _wanted(self, outputs):
        if outputs is None:
            return None, None
        mech = self.mech
        links, pts = set(), set()
        for name in outputs:
            if name in mech.links:
                links.add(name)
            elif name in mech.points:
                pts.add(name)
            elif name in mech.prismatics:
                pj = mech.prismatics[name]
                links |= {pj.guide, pj.slider}
            elif name in mech.actuators:
                a = mech.actuators[name]
                if isinstance(a, SlideActuator):
                    pj = mech.prismatics[a.joint]
                    links |= {pj.guide, pj.slider}
                else:
                    links |= {a.link, a.reference}
            else:
                rj = next((r for r in mech.revolutes if r.name == name), None)
                if rj is None:
                    raise PlanError(f'unknown output {name!r} of {mech.name!r}')
                links |= {rj.parent, rj.child}
        self.wanted_names = list(outputs)
        return sorted(links), sorted(pts)

    def _parse_branch(self, branch):
        k = len(self.plan.branch_steps)
        if branch in ('continuous', 'reference'):
            return branch, None
        if isinstance(branch, str) and set(branch) <= {'+', '-'}:
            if len(branch) != k:
                raise PlanError(
                    f'branch {branch!r} has {len(branch)} sign(s) but this solve has '
                    + (
                        f'{k} branching dyad(s): '
                        + '; '.join(s.describe(self.plan) for s in self.plan.branch_steps)
                        if k
                        else 'no branching dyad (no sign to give)'
                    )
                )
            return 'explicit', branch_signs(branch)
        raise PlanError(
            f"branch must be 'continuous', 'reference' or a string of + and - (got {branch!r})"
        )

    def _check_determined(self, n_values: int) -> None:
        """Knowns whose equations are singular at the reference pose do not fix the
        configuration (two of them fix the same motion, another stays free) even where the
        sparsity pattern says they might: a solve would return an arbitrary point of a curve of
        solutions. Refused here, as the structural check refuses what it sees."""
        cs = self.check_system
        _, J = cs.evaluate(cs.reference_x(), self._ref_values)
        cond = cs.scaled_cond(J)
        if cond < UNDETERMINED_COND:
            return
        # singular in the reference pose: a drawing at a dead point is singular there only;
        # undetermined knowns are singular everywhere. Look at poses the actuators move to.
        fwd = Solver(self.mech, method='closed_form' if self.plan.complete else 'auto')
        ref = fwd.reference_values()
        scale = self.mech.length_scale
        seen = False
        for step in (0.05, -0.05, 0.3, -0.3):
            # a different step for each actuator: equal steps keep a symmetric drawing symmetric
            cmd = {
                s.name: ref[s.name]
                + (-1) ** k
                * (1 + 0.37 * k)
                * (step if isinstance(s, AngleSpec) else step * 0.1 * scale)
                for k, s in enumerate(fwd.specs)
            }
            r = fwd.solve(cmd, commit=False)
            got = self.configuration_of(r) if r.success else None
            if got is None:
                continue
            seen = True
            poses = got[1]
            vals = [
                np.asarray(v, float) if isinstance(s, PointSpec) else float(v)
                for s, v in ((s, spec_value_one(self.mech, s, poses)) for s in self.specs)
            ]
            _, J = cs.evaluate(cs.x_from_poses(poses), vals)
            if cs.scaled_cond(J) < UNDETERMINED_COND:
                return
        if seen:
            raise PlanError(
                f'the knowns {self.knowns} do not determine {self.mech.name!r}: they give '
                f'{n_values} value(s) for its {self.mech.dof} degree(s) of freedom, but two '
                'of them fix the same motion and leave another free (their equations are '
                f'singular in every pose tried: condition number {cond:.2g} in the reference '
                'pose); choose knowns that each fix a different degree of freedom'
            )

    def _values_at_reference(self):
        ref = reference_poses(self.mech)
        return [
            np.asarray(v, float) if isinstance(s, PointSpec) else float(v)
            for s, v in ((s, spec_value_one(self.mech, s, ref)) for s in self.specs)
        ]

    @property
    def pair_tolerance_m(self) -> float:
        """How far (m) the distance of a target's two points of one link may be from the
        link's: what the solver accepts as loop closure."""
        return self.closure_limit * self.mech.length_scale

    def reference_values(self) -> dict[str, Any]:
        """The known quantities' values in the scene's reference pose ({known name: value})."""
        return {
            s.name: (tuple(float(c) for c in v) if isinstance(s, PointSpec) else float(v))
            for s, v in zip(self.specs, self._ref_values)
        }

    def snapshot(self) -> tuple:
        """The continuity state (the previous configurations it predicts from), opaque: pass it
        to restore() on a solver of the same mechanism and knowns to replay exactly."""
        return tuple(self._history)

    def restore(self, snapshot) -> None:
        """Return to a state taken by snapshot() (of this solver or one with the same knowns);
        ValueError, and no change, for anything else."""
        if not isinstance(snapshot, (tuple, list)) or not all(
            isinstance(st, _State) and len(st.values) == len(self.specs) for st in snapshot
        ):
            raise ValueError(
                'restore() takes what snapshot() returned, of a solver with the '
                f'knowns {self.knowns}'
            )
        self._history = list(snapshot)[-2:]

    @property
    def current_signs(self) -> tuple[int, ...]:
        """The branch signs the next solve starts from (one per branching dyad of the plan)."""
        return tuple(self._signs())

    def reset(self):
        """Forget the previous configuration (continuity restarts from the reference pose)."""
        self._history: list[_State] = []

    @property
    def branch_count(self) -> int:
        return len(self.plan.branch_steps)

    # -- command validation ------------------------------------------------------------------
    def parse(self, values: Mapping[str, Any]) -> list:
        """Validate a {known name: value} command; raise ValueError naming what is wrong."""
        if not isinstance(values, Mapping):
            raise ValueError('a command must map known names to values')
        if self.point_pairs:
            values = pair_values(values, self.knowns, self.point_pairs, self.pair_tolerance_m)
        unknown = [k for k in values if k not in self.plan_knowns]
        if unknown:
            raise ValueError(f'unknown name(s) {echo(unknown)}; this solve takes {self.knowns}')
        missing = [k for k in self.plan_knowns if k not in values]
        if missing:
            raise ValueError(f'missing value(s) for {missing}')
        out = []
        for s in self.specs:
            v = values[s.name]
            if isinstance(s, PointSpec):
                out.append(parse_point(s.name, v))
            else:
                if isinstance(v, (bool, np.bool_)) or not isinstance(
                    v, (int, float, np.floating, np.integer)
                ):
                    raise ValueError(
                        f'{s.name}: value must be a number in {s.unit} (got {echo(v)})'
                    )
                try:
                    fv = float(v)
                except OverflowError:  # a Python int beyond the float range
                    fv = math.inf
                if not math.isfinite(fv):
                    raise ValueError(f'{s.name}: value must be finite (got {echo(v)})')
                out.append(fv)
        return out

    def limit_violation(self, spec: Spec, value: float) -> str | None:
        """Why ``value`` is outside ``spec``'s limits (plan.limit_violation), or None."""
        return limit_violation(spec, value)

    # -- solving -----------------------------------------------------------------------------
    def solve(self, values: Mapping[str, Any], commit: bool = True) -> Result:
        """Solve one command. On success (and commit) the answer becomes the new 'previous
        configuration' for continuity; on failure nothing changes."""
        try:
            vals = self.parse(values)
        except ValueError as exc:
            return Result(False, str(exc), solver=self.mode)
        given = self._echo(vals)
        for pair in self.point_pairs:  # echo the request as given: two points, not an angle
            del given[pair.link_known]
            given[pair.second] = [float(c) for c in values[pair.second]]
        for s, v in zip(self.specs, vals):
            if not isinstance(s, PointSpec):
                bad = self.limit_violation(s, v)
                if bad:
                    return self._fail(bad, given)
        if self.mode == 'closed_form':
            res, state = self._solve_closed(vals)
        else:
            res, state = self._solve_newton(vals)
        if res.success and not res.residual <= self.closure_limit:
            return self._fail(self._closure_reason(res.residual), given, solver=res.solver)
        res.targets = {k: v for k, v in given.items() if k not in self.mech.actuators}
        if res.success and self.inverse:
            for s in self.actuator_specs:
                v = res.inputs.get(s.name)
                if v is not None:
                    bad = self.limit_violation(s, v)
                    if bad:
                        return self._fail(f'target needs {bad}', given, solver=res.solver)
        if res.success and commit and state is not None:
            self._history = (self._history + [state])[-2:]
        return res

    def solve_all(self, values: Mapping[str, Any]) -> list[Result]:
        """Every assembly mode of one command, without touching the continuity history: each
        sign combination of the dyad plan that closes; where Newton places the mechanism, the
        modes a multi-start Newton search finds (see :meth:`modes`: may be incomplete)."""
        return self.modes(values).results

    def modes(self, values: Mapping[str, Any]) -> ModeList:
        """:meth:`solve_all` with whether the list is provably complete (closed form) or the
        result of a search (core.solver.modes)."""
        if self.mode != 'closed_form':
            newton = (
                self
                if self.mode == 'newton'
                else Solver(
                    self.mech,
                    knowns=self.knowns,
                    method='newton',
                    tol=self.tol,
                    max_iter=self.max_iter,
                )
            )
            return newton_modes(newton, values)
        return ModeList(self._closed_form_modes(values))

    def _closed_form_modes(self, values: Mapping[str, Any]) -> list[Result]:
        import itertools

        if not self.branch_count:
            return [self.solve(values, commit=False)]
        out, seen = [], set()
        saved = (self.branch_mode, self.fixed_signs)
        try:
            for combo in itertools.product((1, -1), repeat=self.branch_count):
                self.branch_mode, self.fixed_signs = 'explicit', combo
                r = self.solve(values, commit=False)
                if not r.success:
                    continue
                key = mode_key(r, self.mech.length_scale)
                if key in seen:  # coincident modes (at a toggle) are one answer
                    continue
                seen.add(key)
                out.append(r)
        finally:
            self.branch_mode, self.fixed_signs = saved
        return out or [self.solve(values, commit=False)]

    def _closure_reason(self, residual: float) -> str:
        return (
            f'cannot assemble: the configuration found misses loop closure by '
            f'{residual:.3g} of the length scale (limit {self.closure_limit:.3g}); a known '
            'value may be out of reach of its link'
        )

    def _echo(self, vals):
        return {
            s.name: (list(map(float, v)) if isinstance(s, PointSpec) else float(v))
            for s, v in zip(self.specs, vals)
        }

    def _fail(self, reason, echo, solver=None):
        return Result(
            False,
            reason,
            inputs={k: v for k, v in echo.items() if k in self.mech.actuators},
            targets={k: v for k, v in echo.items() if k not in self.mech.actuators},
            solver=solver or self.mode,
        )

    def _prediction(self, vals):
        """Predicted point positions and link angles for continuity (see :class:`_Prediction`),
        or None when there is no previous configuration to predict from."""
        if self.branch_mode != 'continuous' or not self._history:
            return None
        return _Prediction(self._history, self._step_ratio, vals)

    def _step_ratio(self, prev_vals, last_vals, vals) -> float:
        """How far the new command goes along the previous step (d_now . d_prev / |d_prev|^2,
        clipped to [0, 1.5]): the secant extrapolation factor; 0 when the last step was zero."""
        d_prev = self.check_system.value_step(prev_vals, last_vals)
        d_now = self.check_system.value_step(last_vals, vals)
        den = sum(d * d for d in d_prev)
        if not den > 0:
            return 0.0
        return min(max(sum(n * d for n, d in zip(d_now, d_prev)) / den, 0.0), 1.5)

    def _signs(self):
        if self.branch_mode == 'explicit':
            return self.fixed_signs
        if self.branch_mode == 'continuous' and self._history:
            return self._history[-1].signs
        return self.plan.reference_signs

    def _batch_values(self, vals, n):
        out = []
        for s, v in zip(self.specs, vals):
            a = np.asarray(v, float)
            out.append(a.reshape(n, 2) if isinstance(s, PointSpec) else a.reshape(n))
        return out

    def _state(
        self, vals, poses: ScalarPoses, pts, signs, det_sign=0, margins=(), x_all=None, x_lu=None
    ):
        if x_all is None and self.mode != 'closed_form' and set(poses.phi) >= set(self.mech.links):
            x_all = self.check_system.x_from_poses(poses)
        return _State(vals, x_all, pts, poses, tuple(signs), det_sign, tuple(margins), x_lu)

    def _solve_closed(self, vals):
        prev = self._history[-1].margins if self._history else None
        run = run_one(self.plan, vals, self._signs(), self._prediction(vals), prev_margins=prev)
        if not run.ok:
            return self._fail(
                self._dyad_reason(run.failure, run.violation), self._echo(vals), 'closed_form'
            ), None
        res = self._build(
            run.poses,
            run.points,
            vals,
            solver='closed_form',
            iterations=0,
            signs=run.signs,
            margin=run.margin,
        )
        return res, self._state(vals, run.poses, run.points, run.signs, margins=run.margins)

    def _dyad_reason(self, k, violation):
        return dyad_reason(self.plan, k, violation, self.mech.length_scale)

    # -- result assembly ---------------------------------------------------------------------
    def _assembler(self, placed: Iterable[str]) -> ResultAssembler:
        """The result assembly for configurations that place exactly these links (one per set:
        a dyad plan always places the same links, Newton all of them)."""
        key = tuple(placed)
        fn = self._assemblers.get(key)
        if fn is None:
            fn = ResultAssembler(
                self.mech, self.specs, self.actuator_specs, self.check_system._spec_links, key
            )
            if len(self._assemblers) < 16:  # a handful of sets occur; never grow unbounded
                self._assemblers[key] = fn
        return fn

    def _build(
        self,
        poses: ScalarPoses,
        pts: dict[str, complex],
        vals,
        *,
        solver,
        iterations,
        signs,
        margin,
        cond=None,
    ):
        got = self._assembler(poses.phi)(SCALAR, poses, vals)
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
            branch_text(signs),
            bool(branch_identity_defined(margin, residual)) if signs else True,
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
            + res.residual
            + res.margin
        )
        if not math.isfinite(total) and not all(
            math.isfinite(v)
            for v in [
                *joints.values(),
                *links.values(),
                *inputs.values(),
                *(c for p in points.values() for c in p),
                res.residual,
                res.margin,
            ]
        ):
            return Result(False, 'internal error: non-finite value in the solution', solver=solver)
        return res
