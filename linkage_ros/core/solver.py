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

import cmath
import collections.abc
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import dyads
from .assemble import ResultAssembler
from .dyads import wrap_angle
from .errors import PlanError
from .execute import CONTINUITY_MARGIN
from .model import Mechanism
from .newton import LoopSystem
from .ops import BATCH, SCALAR
from .plan import (
    Plan,
    Poses,
    ScalarPoses,
    Spec,
    branch_geometry_batch,
    branch_geometry_one,
    link_poses,
    run_one,
    spec_for,
    spec_value_one,
)

#: machine epsilon (float64): the unit of rounding in branch_identity_defined
_EPS = float(np.finfo(float).eps)


def branch_undefined_below(residual):
    """Dyad margin (|sin| of the transmission angle) below which the two assembly modes cannot
    be told apart, for an answer whose loop closure misses by ``residual`` (fraction of the
    length scale; scalar or array).

    An error bound, not a tuned constant: at a tangency a dyad's normalised height grows like
    sqrt(2 delta) for a relative perturbation delta of its lengths. delta collects the rounding
    of the inputs and of the dyad arithmetic (32 eps: inputs up to ~10 rad or ~10 length scales,
    a few operations each) and what the solve leaves of loop closure (``residual``; Newton at a
    double root stops with the position off by ~sqrt(residual)). The factor 4 covers the O(1)
    geometry factors between that height and the margin. The bound holds whatever BLAS kernel or
    SIMD path computed the answer: every kernel is within a few eps of exact rounding.
    """
    # ** 0.5: the same square root on a float (no numpy call per command) or an array
    return 4.0 * (2.0 * (residual + 32.0 * _EPS)) ** 0.5


def branch_identity_defined(margin, residual):
    """True where ``margin`` is above the noise bound of :func:`branch_undefined_below`
    (scalar or array, elementwise)."""
    return margin > branch_undefined_below(residual)


METHODS = ('auto', 'closed_form', 'newton')
#: a continuation walk gives up after this many times max_iter Newton iterations without a
#: successful substep (an unreachable target would otherwise be bisected 10 levels deep)
WALK_BUDGET = 6
#: without a dyad plan, a scaled cond(J) above this counts as near a singular configuration
NEAR_SINGULAR_COND = 1e6
#: no answer leaves a solver with a loop-closure residual above max(CLOSURE_LIMIT, 10 * tol)
#: (fraction of the length scale): a last guard against a false assembly, e.g. a known point
#: beyond its link's reach placed by the closed-form part of a hybrid solve. The closed forms
#: close to ~1e-15 and to the tangency clamp (1e-12) near toggles, Newton to tol.
CLOSURE_LIMIT = 1e-10


@dataclass
class Result:
    """One solved configuration (or the reason there is none)."""

    success: bool
    reason: str | None = None
    inputs: dict[str, float] = field(default_factory=dict)
    targets: dict[str, Any] = field(default_factory=dict)
    joints: dict[str, float] = field(default_factory=dict)
    links: dict[str, float] = field(default_factory=dict)
    points: dict[str, tuple[float, float]] = field(default_factory=dict)
    residual: float | None = None
    iterations: int = 0
    solver: str = ''
    branch: str = ''
    branch_defined: bool = True
    margin: float | None = None
    cond: float | None = None
    all_branches: list[Result] | None = None

    def to_dict(self, mech: Mechanism | None = None) -> dict[str, Any]:
        links = {}
        for name, ang in self.links.items():
            pts = list(mech.links[name].points) if mech is not None else []
            links[name] = {'points': pts, 'angle': ang}
        out = {
            'status': 'ok' if self.success else 'error',
            'reason': self.reason,
            'inputs': dict(self.inputs),
            'joints': dict(self.joints),
            'links': links,
            'points': {k: [v[0], v[1]] for k, v in self.points.items()},
            'residual': self.residual,
            'branch': self.branch,
            'branch_defined': self.branch_defined,
            'margin': self.margin,
            'solver': self.solver,
            'iterations': self.iterations,
            'cond': self.cond,
        }
        if self.targets:
            out['targets'] = dict(self.targets)
        return out


@dataclass
class _State:
    """The previous configuration: continuity predictions and Newton warm starts start here."""

    values: list
    x_all: np.ndarray | None  # every moving link (phi, cx, cy), for Newton warm starts
    points: dict[str, complex]
    poses: ScalarPoses
    signs: tuple[int, ...]
    det_sign: int
    margins: tuple[float, ...] = ()
    x_lu: tuple | None = None  # Newton: LU of the Jacobian at x_all (for the predictor)


class _Prediction(collections.abc.Mapping):
    """Where continuity expects each point ({name: complex}) and link angle ({'@link': rad}):
    the previous configuration, extrapolated along the previous step after two commands.
    Computed per key on first use: the dyad plan asks only near a singular dyad, so most
    solves never pay for it."""

    def __init__(self, solver: Solver, vals):
        self._last = solver._history[-1]
        self._prev = solver._history[-2] if len(solver._history) == 2 else None
        self._solver, self._vals = solver, vals
        self._ratio: float | None = None

    def __getitem__(self, key: str):
        last = self._last
        if key[:1] == '@':
            return last.poses.phi[key[1:]]
        v = last.points[key]
        prev = self._prev
        if prev is None or key not in prev.points:
            return v
        if self._ratio is None:
            self._ratio = self._solver._step_ratio(prev.values, last.values, self._vals)
        return v + self._ratio * (v - prev.points[key])

    def __contains__(self, key) -> bool:
        if isinstance(key, str) and key[:1] == '@':
            return key[1:] in self._last.poses.phi
        return key in self._last.points

    def __iter__(self):
        yield from self._last.points
        yield from ('@' + l for l in self._last.poses.phi)

    def __len__(self) -> int:
        return len(self._last.points) + len(self._last.poses.phi)


class Solver:
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
        self.specs = [spec_for(mech, n) for n in self.knowns]
        n_values = sum(s.size for s in self.specs)
        if n_values != mech.dof:
            raise PlanError(
                f'{mech.name!r} has {mech.dof} degree(s) of freedom but the knowns '
                f'{self.knowns} give {n_values} value(s)'
                + (
                    _same_link_points_hint(mech, self.knowns, self.specs)
                    if n_values == mech.dof + 1
                    else ''
                )
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
        self.branch_mode, self.fixed_signs = self._parse_branch(branch)
        self._slide_specs = {n: Spec(n, 'slide', joint=n) for n in mech.prismatics}
        self._ref_values = self._values_at_reference()
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
                if a.kind == 'slide':
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
            return 'explicit', tuple(1 if c == '+' else -1 for c in branch)
        raise PlanError(
            f"branch must be 'continuous', 'reference' or a string of + and - (got {branch!r})"
        )

    def _values_at_reference(self):
        ref = ScalarPoses()
        for l in self.mech.links:
            ref.set(l, 0.0, 0j, 1 + 0j)
        return [
            np.asarray(v, float) if s.kind == 'point' else float(v)
            for s, v in ((s, spec_value_one(self.mech, s, ref)) for s in self.specs)
        ]

    def reference_values(self) -> dict[str, Any]:
        """The known quantities' values in the scene's reference pose ({known name: value})."""
        return {
            s.name: (tuple(float(c) for c in v) if s.kind == 'point' else float(v))
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

    def adopt(self, result: Result) -> bool:
        """Make a solved configuration (from any solver of this mechanism) the 'previous
        configuration' for continuity and warm starts. Returns False, changing nothing, if the
        result is unusable: failed, missing a link or point, non-finite, or its points not where
        its link angles put them (not a rigid configuration of this mechanism)."""
        mech = self.mech
        try:
            if not (
                isinstance(result, Result)
                and result.success
                and set(result.links) == set(mech.links)
                and set(result.points) >= set(mech.points)
            ):
                return False
            pts = {
                p: complex(float(result.points[p][0]), float(result.points[p][1]))
                for p in mech.points
            }
            phis = {l: float(result.links[l]) for l in mech.links}
        except (TypeError, ValueError, IndexError, KeyError, AttributeError):
            return False
        if not all(math.isfinite(v) for v in phis.values()) or not all(
            cmath.isfinite(w) for w in pts.values()
        ):
            return False
        poses = ScalarPoses()
        tol = self.closure_limit * mech.length_scale
        for l, link in mech.links.items():
            phi = wrap_angle(phis[l] - link.angle_ref)
            rot = complex(math.cos(phi), math.sin(phi))
            p = link.points[0]
            poses.set(l, phi, pts[p] - rot * complex(*mech.points[p]), rot)
            if any(
                abs(poses.world(l, complex(*mech.points[q])) - pts[q]) > tol
                for q in link.points[1:]
            ):
                return False
        vals = []
        for s in self.specs:
            v = spec_value_one(mech, s, poses)
            vals.append(np.asarray(v, float) if s.kind == 'point' else float(v))
        if self.plan.complete:
            signs, margins = branch_geometry_one(self.plan, pts, poses)
        else:
            signs, margins = self.plan.reference_signs, ()
        self._history = [self._state(vals, poses, pts, signs, margins=margins)]
        return True

    # -- command validation ------------------------------------------------------------------
    def parse(self, values: Mapping[str, Any]) -> list:
        """Validate a {known name: value} command; raise ValueError naming what is wrong."""
        if not isinstance(values, Mapping):
            raise ValueError('a command must map known names to values')
        unknown = [k for k in values if k not in self.knowns]
        if unknown:
            raise ValueError(f'unknown name(s) {unknown}; this solve takes {self.knowns}')
        missing = [k for k in self.knowns if k not in values]
        if missing:
            raise ValueError(f'missing value(s) for {missing}')
        out = []
        for s in self.specs:
            v = values[s.name]
            if s.kind == 'point':
                try:
                    if isinstance(v, (str, bytes, Mapping)) or any(
                        isinstance(c, (bool, np.bool_))
                        or not isinstance(c, (int, float, np.floating, np.integer))
                        for c in v
                    ):
                        raise TypeError
                    arr = np.asarray(v, float).reshape(-1)
                except (TypeError, ValueError, OverflowError):
                    raise ValueError(
                        f'{s.name}: a point needs two numbers x, y (got {v!r})'
                    ) from None
                if arr.shape != (2,):
                    raise ValueError(f'{s.name}: a point needs two numbers x, y (got {v!r})')
                if not np.all(np.isfinite(arr)):
                    raise ValueError(f'{s.name}: value must be finite (got {v!r})')
                out.append(arr)
            else:
                if isinstance(v, (bool, np.bool_)) or not isinstance(
                    v, (int, float, np.floating, np.integer)
                ):
                    raise ValueError(f'{s.name}: value must be a number in {s.unit} (got {v!r})')
                try:
                    fv = float(v)
                except OverflowError:  # a Python int beyond the float range
                    fv = math.inf
                if not math.isfinite(fv):
                    raise ValueError(f'{s.name}: value must be finite (got {v!r})')
                out.append(fv)
        return out

    def limit_violation(self, spec: Spec, value: float) -> str | None:
        lo, hi = spec.minimum, spec.maximum
        if lo is None and hi is None:
            return None
        v = value
        if spec.kind == 'angle' and lo is not None and hi is not None:
            # angles compare on the circle: bring v into [lo, lo + 2 pi)
            v = lo + (value - lo) % (2 * math.pi)
            if v <= hi + 1e-12 * max(1.0, abs(hi)):
                return None
            over_hi = v - hi
            under_lo = lo + 2 * math.pi - v
            if under_lo < over_hi:
                return (
                    f'{spec.name} = {value:.9g} {spec.unit} is below its minimum {lo:g} '
                    f'by {under_lo:.3g} {spec.unit}'
                )
            return (
                f'{spec.name} = {value:.9g} {spec.unit} is beyond its maximum {hi:g} by '
                f'{over_hi:.3g} {spec.unit}'
            )
        if lo is not None and v < lo:
            return (
                f'{spec.name} = {value:.9g} {spec.unit} is below its minimum {lo:g} by '
                f'{lo - v:.3g} {spec.unit}'
            )
        if hi is not None and v > hi:
            return (
                f'{spec.name} = {value:.9g} {spec.unit} is beyond its maximum {hi:g} by '
                f'{v - hi:.3g} {spec.unit}'
            )
        return None

    # -- solving -----------------------------------------------------------------------------
    def solve(self, values: Mapping[str, Any], commit: bool = True) -> Result:
        """Solve one command. On success (and commit) the answer becomes the new 'previous
        configuration' for continuity; on failure nothing changes."""
        try:
            vals = self.parse(values)
        except ValueError as exc:
            return Result(False, str(exc), solver=self.mode)
        echo = self._echo(vals)
        for s, v in zip(self.specs, vals):
            if s.kind != 'point':
                bad = self.limit_violation(s, v)
                if bad:
                    return self._fail(bad, echo)
        if self.mode == 'closed_form':
            res, state = self._solve_closed(vals)
        else:
            res, state = self._solve_newton(vals)
        if res.success and not res.residual <= self.closure_limit:
            return self._fail(self._closure_reason(res.residual), echo, solver=res.solver)
        res.targets = {k: v for k, v in echo.items() if k not in self.mech.actuators}
        if res.success and self.inverse:
            for s in self.actuator_specs:
                v = res.inputs.get(s.name)
                if v is not None:
                    bad = self.limit_violation(s, v)
                    if bad:
                        return self._fail(f'target needs {bad}', echo, solver=res.solver)
        if res.success and commit and state is not None:
            self._history = (self._history + [state])[-2:]
        return res

    def solve_all(self, values: Mapping[str, Any]) -> list[Result]:
        """Every assembly mode of one command (each sign combination of the dyad plan that
        closes), without touching the continuity history. Newton-only solves have no enumerable
        branches: the single answer nearest the current configuration is returned."""
        import itertools

        if self.mode != 'closed_form' or not self.branch_count:
            return [self.solve(values, commit=False)]
        out, seen = [], set()
        saved = (self.branch_mode, self.fixed_signs)
        try:
            for combo in itertools.product((1, -1), repeat=self.branch_count):
                self.branch_mode, self.fixed_signs = 'explicit', combo
                r = self.solve(values, commit=False)
                if not r.success:
                    continue
                key = tuple(
                    round(c / self.mech.length_scale, 9)
                    for p in sorted(r.points)
                    for c in r.points[p]
                )
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
            s.name: (list(map(float, v)) if s.kind == 'point' else float(v))
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
        return _Prediction(self, vals)

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
            out.append(a.reshape(n, 2) if s.kind == 'point' else a.reshape(n))
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
        st = self.plan.steps[k]
        what = st.describe(self.plan)
        return (
            f'cannot assemble: {what} does not close; the constraint misses by '
            f'{violation:.6g} m ({violation / self.mech.length_scale:.3g} of the length scale)'
        )

    # Newton (alone, or for the links the dyad plan cannot place) with continuation
    def _fixed_poses(self, vals):
        """Run the closed-form part (hybrid mode); returns (poses, reason or None)."""
        if self.mode != 'hybrid':
            return None, None
        run = run_one(self.full_plan, vals, None, None)
        if not run.ok:
            st = self.full_plan.steps[run.failure]
            return None, (
                f'cannot assemble: {st.describe(self.full_plan)} does not close; misses '
                f'by {run.violation:.6g} m'
            )
        keep = ScalarPoses()
        for l in self.closed_links + [self.mech.ground]:
            keep.set(l, run.poses.phi[l], run.poses.T[l], run.poses.rot[l])
        return keep, None

    def _newton_at(self, vals, x0, start_sign=None):
        fixed, reason = self._fixed_poses(vals)
        if reason:
            return None, reason, None
        r = self.system.solve(
            x0, vals, fixed, tol=self.tol, max_iter=self.max_iter, start_sign=start_sign
        )
        return r, None, fixed

    def _start(self, vals):
        """Warm start (values, x): the previous solution, else the reference pose; and the
        predicted solution at ``vals`` (newton mode, after a Newton solve: LoopSystem.predict)."""
        if self._history and self._history[-1].x_all is not None:
            last = self._history[-1]
            guess = None
            if last.x_lu is not None and self.mode == 'newton':
                prev = self._history[-2] if len(self._history) == 2 else None
                before = (
                    (prev.x_all, prev.values, prev.x_lu)
                    if prev is not None and prev.x_all is not None
                    else ()
                )
                guess = self.system.predict(last.x_all, last.x_lu, last.values, vals, *before)
            return last.values, self._sub_x(last.x_all), guess
        x_all = self.check_system.reference_x()
        if (
            self.branch_mode == 'explicit'
            and self.fixed_signs != self.plan.reference_signs
            and self.full_plan.complete
        ):
            # another assembly mode: start from the dyad plan's answer at the reference input
            run = run_one(self.full_plan, self._ref_values, self.fixed_signs, None)
            if run.ok:
                x_all = self.check_system.x_from_poses(run.poses)
        return self._ref_values, self._sub_x(x_all), None

    def _sub_x(self, x_all):
        if self.mode == 'newton':  # every moving link is free, in the same order
            return x_all
        idx = self.check_system.index
        return (
            np.concatenate([x_all[3 * idx[l] : 3 * idx[l] + 3] for l in self.system.free])
            if self.system.free
            else np.zeros(0)
        )

    def _branch_of(self, x, fixed):
        """(signs, margins, poses, points) of configuration x: its dyads' sides and margins."""
        poses, pts = self.system.configuration(x, fixed)
        return (*branch_geometry_one(self.full_plan, pts, poses), poses, pts)

    def _near_singular(self, x, fixed, values) -> bool:
        """A dyad of the configuration is near its singular (tangent) position, or, without a
        dyad plan to read that from, the Jacobian is ill-conditioned."""
        if self.full_plan.complete and self.full_plan.branch_steps:
            return min(self._branch_of(x, fixed)[1]) < CONTINUITY_MARGIN
        J = self.system.evaluate(x, values, fixed)[1]
        return self.system.scaled_cond(J) > NEAR_SINGULAR_COND

    def _branch_jump(self, ga, gb) -> bool:
        """True when a dyad changed side between two configurations (their _branch_of) while
        far from its singularity: only a jump (not a continuous motion) does that."""
        return any(
            a != b and min(p, q) >= CONTINUITY_MARGIN
            for a, b, p, q in zip(ga[0], gb[0], ga[1], gb[1])
        )

    def _interp(self, a, b, t):
        out = []
        for s, va, vb in zip(self.specs, a, b):
            if s.kind == 'angle':
                out.append(wrap_angle(va) + t * wrap_angle(wrap_angle(vb) - wrap_angle(va)))
            elif s.kind == 'point':
                out.append(np.asarray(va) + t * (np.asarray(vb) - np.asarray(va)))
            else:
                out.append(va + t * (vb - va))
        return out

    def _solve_newton(self, vals):
        solver_name = 'newton' if self.mode == 'newton' else 'hybrid'
        # the closed form's branch signs for the check below (reference ones without a history)
        check_signs = self._signs() if self.full_plan is self.plan else None

        def refusal():
            """An input the closed form cannot assemble on the current branch cannot be reached
            by continuation either: refuse at once (Newton would grind to its caps first)."""
            if not self.full_plan.complete:
                return None
            run = run_one(self.full_plan, vals, check_signs, None)
            if run.ok:
                return None
            st = self.full_plan.steps[run.failure]
            return self._fail(
                f'cannot assemble: {st.describe(self.full_plan)} does not '
                f'close; the constraint misses by {run.violation:.6g} m '
                f'({run.violation / self.mech.length_scale:.3g} of the length '
                'scale)',
                self._echo(vals),
                solver_name,
            )

        v0, x0, guess = self._start(vals)
        total_iter = [0]
        since_progress = [0]  # iterations since the last substep that succeeded
        branches = bool(self.full_plan.complete and self.full_plan.branch_steps)
        seen: dict[int, tuple] = {}  # branch geometry of the configurations met in this solve
        last = self._history[-1] if self._history else None
        if branches and last is not None and last.x_all is not None:
            # x0 is the previous answer: its points and poses are known, and a Newton answer
            # (x_lu set) also left its dyads' sides and margins (full plan: see the end)
            known_geo = (
                (last.signs, last.margins)
                if last.x_lu is not None and len(last.margins) == len(self.full_plan.branch_steps)
                else branch_geometry_one(self.full_plan, last.points, last.poses)
            )
            seen[id(x0)] = (x0, (*known_geo, last.poses, last.points))

        def geometry(x, fixed):
            g = seen.get(id(x))
            if g is None or g[0] is not x:
                g = seen[id(x)] = (x, self._branch_of(x, fixed))
            return g[1]

        def jump(xa, fixed_a, xb, fixed_b):
            return branches and self._branch_jump(geometry(xa, fixed_a), geometry(xb, fixed_b))

        def walk(va, xa, vb, depth, sign_a=None):
            fixed_a = self._fixed_poses(va)[0]
            if sign_a is None:  # det J sign at the start; 0 where it is singular
                sign_a = self.system.start_sign(xa, va, fixed_a)
            r, reason, fixed = self._newton_at(vb, xa, sign_a)
            jumped = False
            if r is not None:
                total_iter[0] += r.iterations
                since_progress[0] += r.iterations
                if r.success and (sign_a == 0 or r.det_sign == sign_a or r.det_sign == 0):
                    # det J keeps its sign when two dyads flip together: compare dyad sides too
                    jumped = jump(xa, fixed_a, r.x, fixed)
                    if not jumped:
                        since_progress[0] = 0
                        return r, None, fixed
                if sign_a != 0 and self._near_singular(xa, fixed_a, va):
                    # det J may change sign only by passing a singular configuration, and one is
                    # near: step without the sign guard, keep it if no dyad jumped sides
                    r2, _, fixed2 = self._newton_at(vb, xa, 0)
                    total_iter[0] += r2.iterations
                    if r2.success and not jump(xa, fixed_a, r2.x, fixed2):
                        since_progress[0] = 0
                        return r2, None, fixed2
            if depth >= 10 or since_progress[0] > WALK_BUDGET * self.max_iter:
                if r is None:
                    return None, reason, None
                if jumped:
                    return (
                        None,
                        (
                            'Newton could only reach this input in another assembly mode '
                            '(a branch jump): it is not reachable on the current branch '
                            'without crossing a singularity'
                        ),
                        None,
                    )
                why = r.reason or (
                    'the sign of det J changed: a singularity (toggle or change '
                    'point) lies between the previous configuration and this input'
                )
                return None, why, None
            vm = self._interp(va, vb, 0.5)
            rm, why, fm = walk(va, xa, vm, depth + 1, sign_a)
            if rm is None:
                return None, why, None
            return walk(vm, rm.x, vb, depth + 1, rm.det_sign)

        known = (
            last.det_sign
            if last is not None and last.x_all is not None and last.det_sign != 0
            else None
        )
        r = fixed = None
        if guess is not None and known is not None:
            # newton mode: the fast path from the predicted solution, kept if no dyad jumped sides
            rf = self.system.solve_from_guess(
                guess, vals, None, tol=self.tol, max_iter=self.max_iter, start_sign=known
            )
            total_iter[0] += rf.iterations
            if rf.success and not jump(x0, None, rf.x, None):
                r = rf
        # the closed-form check is skipped only where it must pass: the answer is on the
        # check's branch and well-conditioned enough for its residual (cond^2 residual n small:
        # Newton-Kantorovich) that an exact assembly on that branch lies next to it
        if (
            r is None
            or not r.cond * r.cond * r.residual * self.system.n <= 1e-2
            or (
                branches
                and tuple(geometry(r.x, None)[0])
                != tuple(check_signs or self.full_plan.reference_signs)
            )
        ):
            bad = refusal()
            if bad is not None:
                return bad, None
        if r is None:
            r, reason, fixed = walk(v0, x0, vals, 0, known)
        if r is None:
            res = self._fail(reason, self._echo(vals), solver_name)
            res.iterations = total_iter[0]
            return res, None
        if branches:
            signs_t, margins, poses, pts = geometry(r.x, fixed)
        else:
            poses, pts = self.system.configuration(r.x, fixed)
            signs_t, margins = (
                branch_geometry_one(self.full_plan, pts, poses)
                if self.full_plan.complete
                else ((), [])
            )
        if (
            self.branch_mode in ('explicit', 'reference')
            and self.full_plan.complete
            and self.full_plan is self.plan
        ):
            want = tuple(self._signs())
            if signs_t != want:
                return self._fail(
                    f'Newton converged to assembly mode {_sign_str(signs_t)}, not the '
                    f'requested {_sign_str(want)}: the input is not reachable on '
                    'that branch from the start configuration without crossing a '
                    'singularity',
                    self._echo(vals),
                    solver_name,
                ), None
        margin = min(margins) if margins else 1.0 / max(r.cond, 1.0)
        res = self._build(
            poses,
            pts,
            vals,
            solver=solver_name,
            iterations=total_iter[0],
            signs=signs_t,
            margin=margin,
            cond=r.cond,
        )
        newton = self.mode == 'newton'  # x is then x_all, and predicts the next solve
        return res, self._state(
            vals,
            poses,
            pts,
            signs_t,
            r.det_sign,
            margins,
            x_all=r.x if newton else None,
            x_lu=self.system.rate_factor(r) if newton else None,
        )

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
            _sign_str(signs),
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

    # -- batches -----------------------------------------------------------------------------
    def solve_batch(
        self, columns: Mapping[str, Any], start: BatchResult | None = None
    ) -> BatchResult:
        """Solve n commands at once. ``columns`` maps each known name to an (n,) array ((n, 2)
        for points).

        closed_form: one vectorised dyad-plan run with fixed branch signs (the explicit ones,
        else the current/reference ones).

        newton / auto without ``start``: the rows are one path, solved one after another by
        ``solve`` (warm-started and branch-tracked from the solver's state, which they update).

        newton with ``start``: n independent instances advancing together (a fleet of
        mechanisms, simulation environments), row i warm-started from row i of ``start``, an
        earlier newton BatchResult of this solver with the same n. Vectorised Newton answers
        every row it can prove is on the start's branch (det J keeps its sign, each step cuts
        the residual tenfold, the dyads keep their sides, the answer is well conditioned); the
        other rows take ``solve``'s careful path from their start, so the answers are those
        ``solve`` would give from that start."""
        names = list(columns)
        unknown = [k for k in names if k not in self.knowns]
        missing = [k for k in self.knowns if k not in columns]
        if unknown or missing:
            raise ValueError(
                f'batch columns must be exactly {self.knowns}'
                f'{"; unknown " + str(unknown) if unknown else ""}'
                f'{"; missing " + str(missing) if missing else ""}'
            )
        arrays = []
        n = None
        for s in self.specs:
            a = self._batch_column(s, columns[s.name])
            if n is None:
                n = a.shape[0]
            elif a.shape[0] != n:
                raise ValueError(f'batch column {s.name!r} has {a.shape[0]} rows, expected {n}')
            arrays.append(a)
        if start is not None:
            if self.mode != 'newton':
                raise ValueError(f'start= warm-starts newton batches; this solver is {self.mode}')
            if not isinstance(start, BatchResult) or start.x is None:
                raise ValueError(
                    'start must be a newton BatchResult of this solver (a closed-form '
                    'batch carries no Newton state)'
                )
            if start.n != (n or 0):
                raise ValueError(
                    f'start has {start.n} rows but this batch has {n or 0}: row i starts from row i'
                )
            theirs = getattr(start, 'source', None)
            if theirs != self._batch_source():
                what = f'{theirs[0]!r} with knowns {list(theirs[1])}' if theirs else 'unknown'
                raise ValueError(
                    'start must be a newton BatchResult of a solver of this '
                    f'mechanism ({self.mech.name!r}, its reference geometry) with '
                    f'knowns {self.knowns}; got one of {what}'
                )
            if not (
                isinstance(start.x, np.ndarray)
                and start.x.shape == (start.n, self.system.n)
                and np.shape(start.det_sign) == (start.n,)
                and np.shape(start.ok) == (start.n,)
            ):
                raise ValueError(
                    'start is not a newton BatchResult as solve_batch made it (its '
                    'x, det_sign or ok arrays have the wrong shape)'
                )
        return BatchResult.solve(self, arrays, n or 0, start)

    def _batch_source(self) -> tuple:
        """What a newton batch's x means (the mechanism, its reference geometry, the knowns and
        the Newton unknowns): start= takes only batches of the same. Made once per solver."""
        src = self.__dict__.get('_source')
        if src is None:
            src = self._source = (
                self.mech.name,
                tuple(self.knowns),
                tuple(self.system.free),
                tuple((p, float(v[0]), float(v[1])) for p, v in self.mech.points.items()),
            )
        return src

    @staticmethod
    def _batch_column(s: Spec, v) -> np.ndarray:
        """One command column as floats, (n,) or (n, 2) for a point; ValueError naming the
        column for anything but real numbers (bool, str, complex and object columns too)."""
        a = np.asarray(v)
        if a.dtype.kind not in 'iuf':
            raise ValueError(
                f'batch column {s.name!r} must hold real numbers ({s.unit}), got '
                f'an array of {a.dtype}'
            )
        a = a.astype(float)
        if s.kind == 'point':
            if a.ndim == 0 or a.shape[-1] != 2 or a.ndim > 2:
                raise ValueError(
                    f'batch column {s.name!r} must have shape (n, 2) (x, y in m), got {a.shape}'
                )
            return a.reshape(-1, 2)
        if a.ndim > 1:
            raise ValueError(f'batch column {s.name!r} must have shape (n,), got {a.shape}')
        return a.reshape(-1)


class BatchResult:
    """Results of n commands as arrays: ok (n,), reason list, points {name: (n, 2)},
    joints / links / inputs {name: (n,)}, residual, margin, iterations, signs (n, k); newton
    batches also x (n, 3 * moving links: the Newton unknowns) and det_sign (n,), what the next
    batch of the same instances starts from (Solver.solve_batch(start=...))."""

    x: np.ndarray | None = None
    det_sign: np.ndarray | None = None
    careful: np.ndarray | None = None  # newton batches with start=: rows Solver.solve answered
    rows: list[Result] | None = None

    @classmethod
    def solve(
        cls, solver: Solver, arrays: list[np.ndarray], n: int, start: BatchResult | None = None
    ) -> BatchResult:
        self = cls()
        self.n = n
        self.values = arrays  # the command columns, in solver.specs order
        self.source = solver._batch_source()
        finite = np.ones(n, bool)
        for a in arrays:
            finite &= np.all(np.isfinite(a.reshape(n, -1 if n else 1)), axis=1)
        self.reason = [None] * n
        for i in np.flatnonzero(~finite):
            self.reason[i] = 'value must be finite (NaN or inf in the command)'
        safe = [np.where(np.isfinite(a), a, 0.0) for a in arrays]
        limit_bad = np.zeros(n, bool)
        for s, a in zip(solver.specs, safe):
            if s.kind != 'point' and (s.minimum is not None or s.maximum is not None):
                for i in np.flatnonzero(finite & ~limit_bad):
                    why = solver.limit_violation(s, float(a[i]))
                    if why:
                        limit_bad[i] = True
                        self.reason[i] = why
        if solver.mode != 'closed_form':
            if start is not None:
                return cls._newton(self, solver, arrays, safe, finite & ~limit_bad, start)
            return cls._sequential(self, solver, arrays, n)
        poses, pts, info = solver.plan.run(safe, n, solver._signs())
        ok = info['ok'] & finite & ~limit_bad
        for i in np.flatnonzero(~info['ok'] & finite & ~limit_bad):
            self.reason[i] = solver._dyad_reason(
                int(info['failure'][i]), float(info['violation'][i])
            )
        got = _batch_assembly(solver, poses, safe)
        residual = np.where(ok, got.residual, 0.0)
        far = ok & ~(residual <= solver.closure_limit)  # as Solver.solve: no false assembly
        for i in np.flatnonzero(far):
            self.reason[i] = solver._closure_reason(float(residual[i]))
        ok &= ~far
        self._fill(solver, poses, pts, arrays, safe, finite, ok, got)
        self.margin = np.where(self.ok, info['margin'], 0.0)
        self.signs = info['signs']
        self.residual = np.where(self.ok, residual, 0.0)
        self.iterations = np.zeros(n, int)
        self.solver = 'closed_form'
        return self

    def _fill(self, solver, poses, pts, arrays, safe, finite, ok, got=None):
        """points, links, joints and inputs of the rows ``ok`` from their poses (0 elsewhere);
        an inverse solve's actuator beyond its limits turns its row into a failure. Returns the
        assembly (``got``, when the caller already has it)."""
        if got is None:
            got = _batch_assembly(solver, poses, safe)
        self.points = {p: np.where(ok[:, None], v, 0.0) for p, v in pts.items()}
        self.links = {l: np.where(ok, v, 0.0) for l, v in got.links.items()}
        self.joints = {j: np.where(ok, v, 0.0) for j, v in got.joints.items()}
        self.inputs = {a: np.where(ok, v, 0.0) for a, v in got.inputs.items()}
        for s, a in zip(solver.specs, arrays):
            if s.name in solver.mech.actuators:
                self.inputs[s.name] = np.where(ok, a, np.where(finite, a, 0.0))
        if solver.inverse:
            for s in solver.actuator_specs:
                if s.name in self.inputs and (s.minimum is not None or s.maximum is not None):
                    for i in np.flatnonzero(ok):
                        why = solver.limit_violation(s, float(self.inputs[s.name][i]))
                        if why:
                            ok[i] = False
                            self.reason[i] = f'target needs {why}'
        self.ok = ok
        return got

    @staticmethod
    def _newton(self, solver, arrays, safe, valid, start):
        """Vectorised warm-started Newton over independent instances (see Solver.solve_batch);
        the rows it cannot vouch for go through Solver.solve from their start."""
        mech, n, system = solver.mech, self.n, solver.system
        plan = solver.full_plan
        branches = bool(plan.complete and plan.branch_steps)
        k = len(plan.branch_steps) if branches else 0
        eligible = np.flatnonzero(valid & start.ok & (start.det_sign != 0))
        x = np.zeros((n, system.n))
        accepted = np.zeros(n, bool)
        iterations = np.zeros(n, int)
        residual = np.zeros(n)
        det_sign = np.zeros(n, int)
        cond = np.full(n, np.inf)
        if len(eligible):
            bs = system.solve_batch(
                start.x[eligible],
                [a[eligible] for a in safe],
                start.det_sign[eligible],
                tol=solver.tol,
            )
            rows = eligible[bs.ok]
            x[rows], iterations[eligible] = bs.x[bs.ok], bs.iterations
            residual[rows], det_sign[rows], cond[rows] = (
                bs.residual[bs.ok],
                bs.det_sign[bs.ok],
                bs.cond[bs.ok],
            )
            # Solver.solve checks the closed form can assemble unless the answer is provably on
            # its branch: well conditioned for its residual (Newton-Kantorovich) and the dyads on
            # the start's sides. A row that needs that check (or changed sides) goes there too.
            accepted[rows] = cond[rows] ** 2 * residual[rows] * system.n <= 1e-2
        poses = _batch_poses(solver, x)
        pts = {p: poses.world(l, p, mech) for p, l, _ in system._point_owner}
        signs = np.zeros((n, k), int)
        margin = np.where(accepted, 1.0 / np.maximum(cond, 1.0), 0.0)
        if branches:
            signs, margins = branch_geometry_batch(plan, pts, poses)
            accepted &= np.all(signs == start.signs, axis=1)
            margin = np.min(margins, axis=1)
        if solver.branch_mode == 'explicit':
            accepted &= np.all(signs == np.asarray(solver.fixed_signs, int), axis=1)
        elif solver.branch_mode == 'reference' and branches:
            accepted &= np.all(signs == np.asarray(plan.reference_signs, int), axis=1)
        got = self._fill(solver, poses, pts, arrays, safe, valid, accepted.copy())
        self.x, self.det_sign = x, np.where(self.ok, det_sign, 0)
        self.signs, self.margin = (
            np.where(self.ok[:, None], signs, 0),
            np.where(self.ok, margin, 0.0),
        )
        self.iterations = np.where(self.ok, iterations, 0)
        self.residual = np.where(
            self.ok,
            np.maximum(residual, got.residual),
            0.0,
        )
        self.solver = solver.mode
        self.careful = valid & ~accepted
        careful = np.flatnonzero(self.careful)
        if len(careful):
            snapshot = solver.snapshot()
            try:
                for i in careful:
                    r = self._careful_row(solver, arrays, start, i)
                    self._set_row(solver, i, r, iterations[i])
            finally:
                solver.restore(snapshot)
        return self

    def _careful_row(self, solver, arrays, start, i) -> Result:
        """Row i by Solver.solve from row i of ``start`` (its configuration, det J sign and
        dyad sides; the reference pose if that row failed), committed so its x can be read."""
        solver.reset()
        if start.ok[i]:
            xi = start.x[i]
            poses, pts = solver.check_system.configuration(xi)
            vals = [
                np.array(a[i], float) if s.kind == 'point' else float(a[i])
                for s, a in zip(solver.specs, start.values)
            ]
            if solver.full_plan.complete:
                signs, margins = branch_geometry_one(solver.full_plan, pts, poses)
            else:
                signs, margins = solver.plan.reference_signs, ()
            solver._history = [
                solver._state(
                    vals, poses, pts, signs, int(start.det_sign[i]), margins, x_all=xi.copy()
                )
            ]
        cmd = {
            s.name: (arrays[k][i] if s.kind == 'point' else float(arrays[k][i]))
            for k, s in enumerate(solver.specs)
        }
        return solver.solve(cmd)

    def _set_row(self, solver, i, r: Result, spent: int):
        """Write one Result into row i (x and det_sign from the solver's committed state)."""
        self.ok[i], self.reason[i] = r.success, r.reason
        if not r.success:
            self.det_sign[i] = 0
            return
        for table, got in ((self.links, r.links), (self.joints, r.joints), (self.inputs, r.inputs)):
            for name in table:
                table[name][i] = got.get(name, 0.0)
        for p in self.points:
            self.points[p][i] = r.points.get(p, (0.0, 0.0))
        self.margin[i], self.residual[i] = r.margin or 0.0, r.residual or 0.0
        self.iterations[i] = r.iterations + spent
        if self.signs.shape[1] == len(r.branch):
            self.signs[i] = [1 if c == '+' else -1 for c in r.branch]
        state = solver._history[-1]
        self.x[i], self.det_sign[i] = state.x_all, state.det_sign

    @staticmethod
    def _sequential(self, solver, arrays, n):
        mech = solver.mech
        rows, states = [], {}
        for i in range(n):
            if self.reason[i] is not None:
                rows.append(Result(False, self.reason[i]))
                continue
            cmd = {
                s.name: (arrays[k][i] if s.kind == 'point' else float(arrays[k][i]))
                for k, s in enumerate(solver.specs)
            }
            rows.append(solver.solve(cmd))
            if rows[-1].success:
                states[i] = solver._history[-1]
        self.ok = np.array([r.success for r in rows], bool)
        self.reason = [r.reason for r in rows]
        names_p = list(mech.points)
        self.points = {
            p: np.array([r.points.get(p, (0.0, 0.0)) for r in rows]).reshape(n, 2) for p in names_p
        }
        self.links = {l: np.array([r.links.get(l, 0.0) for r in rows]) for l in mech.links}
        self.joints = {j: np.array([r.joints.get(j, 0.0) for r in rows]) for j in mech.joint_names}
        self.inputs = {a: np.array([r.inputs.get(a, 0.0) for r in rows]) for a in mech.actuators}
        self.margin = np.array([r.margin or 0.0 for r in rows])
        self.residual = np.array([r.residual or 0.0 for r in rows])
        self.iterations = np.array([r.iterations for r in rows])
        self.signs = np.zeros((n, 0), int)
        self.solver = solver.mode
        self.rows = rows
        if solver.mode == 'newton':  # what a later batch of these rows may start from
            self.x, self.det_sign = np.zeros((n, solver.system.n)), np.zeros(n, int)
            for i in np.flatnonzero(self.ok):
                self.x[i], self.det_sign[i] = states[i].x_all, states[i].det_sign
            k = len(solver.full_plan.branch_steps) if solver.full_plan.complete else 0
            self.signs = np.array(
                [
                    [1 if c == '+' else -1 for c in r.branch]
                    if r.success and len(r.branch) == k
                    else [0] * k
                    for r in rows
                ],
                int,
            ).reshape(n, k)
        return self

    def row(self, i: int, solver: Solver) -> Result:
        if getattr(self, 'rows', None) is not None:
            return self.rows[i]
        if not self.ok[i]:
            return Result(False, self.reason[i], solver=self.solver)
        sg = tuple(int(s) for s in self.signs[i])
        return Result(
            True,
            None,
            inputs={k: float(v[i]) for k, v in self.inputs.items()},
            joints={k: float(v[i]) for k, v in self.joints.items()},
            links={k: float(v[i]) for k, v in self.links.items()},
            points={k: (float(v[i, 0]), float(v[i, 1])) for k, v in self.points.items()},
            residual=float(self.residual[i]),
            iterations=int(self.iterations[i]),
            solver=self.solver,
            branch=_sign_str(sg),
            margin=float(self.margin[i]),
            branch_defined=(
                bool(branch_identity_defined(self.margin[i], self.residual[i])) if sg else True
            ),
        )


def _same_link_points_hint(mech: Mechanism, knowns: Sequence[str], specs: Sequence[Spec]) -> str:
    """For one value too many: two known points on one link (the graphical method's 'move the
    bin by J and K') fix its pose, 3 values, not 4; say so, and give the knowns with the second
    point replaced by that link's angle."""
    points = [(k, s.point) for k, s in zip(knowns, specs) if s.kind == 'point']
    for i, (_, a) in enumerate(points):
        for known_b, b in points[i + 1 :]:
            shared = [l for l in mech.links_of_point(a) if b in mech.links[l].points]
            if shared:
                link = shared[0]
                better = [link if k == known_b else k for k in knowns]
                return (
                    f' (points {a!r} and {b!r} are both on link {link!r}: their distance '
                    f'is fixed, so together they give its pose, 3 values, not 4; give one '
                    f'of them and the link angle instead: knowns {better})'
                )
    return ''


def _batch_assembly(solver: Solver, poses: Poses, arrays) -> Any:
    """ResultAssembler on batched (n, 2)-coordinate poses."""
    with np.errstate(all='ignore'):
        return solver._assembler(poses.phi)(BATCH, link_poses(poses), arrays)


def _batch_poses(solver: Solver, x: np.ndarray) -> Poses:
    """Poses of every link from newton unknowns x (n, 3 per moving link: phi and the world
    position of the link's reference centroid o, so T = c - R(phi) o); the ground at rest."""
    system, n = solver.system, x.shape[0]
    poses = Poses({solver.mech.ground: np.zeros(n)}, {solver.mech.ground: np.zeros((n, 2))})
    for l, i in system.index.items():
        phi = x[:, 3 * i]
        poses.phi[l] = phi
        poses.T[l] = x[:, 3 * i + 1 : 3 * i + 3] - dyads.rotate(
            np.broadcast_to(system.centroid[l], (n, 2)), phi
        )
    return poses


def _sign_str(signs) -> str:
    return ''.join('+' if s > 0 else '-' for s in signs)
