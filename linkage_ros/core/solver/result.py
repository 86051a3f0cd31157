"""Result (what every solve answers), the branch-identity bound and the branch text."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, TypeVar

import numpy as np

from ..mechanism import METHODS as METHODS  # re-exported: the solver's vocabulary
from ..mechanism import SolveMethod as SolveMethod
from ..model import Mechanism
from ..model.names import NameKind, resolve_name
from ..newton.results import NEAR_SINGULAR_COND as NEAR_SINGULAR_COND  # re-exported
from ..steps import branch_signs as branch_signs  # re-exported: the solver's vocabulary
from ..steps import branch_text as branch_text
from ..tolerances import NEWTON_TOL as NEWTON_TOL

#: machine epsilon (float64): the unit of rounding in branch_identity_defined
EPS = float(np.finfo(float).eps)

#: one command's float or a batch's array: the bounds below run the same on either
_FloatOrArray = TypeVar('_FloatOrArray', float, np.ndarray)


def branch_undefined_below(residual: _FloatOrArray) -> _FloatOrArray:
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
    bound: _FloatOrArray = 4.0 * (2.0 * (residual + 32.0 * EPS)) ** 0.5
    return bound


def branch_identity_defined(margin: _FloatOrArray, residual: _FloatOrArray) -> bool | np.ndarray:
    """True where ``margin`` is above the noise bound of :func:`branch_undefined_below`
    (scalar or array, elementwise)."""
    return margin > branch_undefined_below(residual)


def answer_branch(
    signs: Sequence[int], label: str | None, margin: float, residual: float
) -> tuple[str, bool]:
    """A solved configuration's (branch, branch_defined): its dyad signs' text, or ``label``
    where the signs do not name its mode (reading.mode_label); defined where the margin is
    above the noise bound, and always where there is no branch to name."""
    text = branch_text(tuple(signs)) if label is None else label
    return text, bool(branch_identity_defined(margin, residual)) if signs or label else True


#: a dyad margin below which its branch sign is not read as the assembly mode: at (or within
#: rounding of) its toggle the two modes meet. The one threshold of that meaning: the target
#: rule (mode_rule) and the reference-pose toggle warning (modes) use it.
SIGN_MARGIN = 1e-9


#: a continuation walk gives up after this many times max_iter Newton iterations without a
#: successful substep (an unreachable target would otherwise be bisected 10 levels deep)
WALK_BUDGET = 6
#: how deep a continuation walk halves its step (to 2^-10 of the way) before it gives up
MAX_HALVINGS = 10


class Effort(Enum):
    """How hard a solve tries, for callers that read only whether it succeeded."""

    #: the continuation walk, and a refusal measured at the input (the nearest
    #: configuration's miss: a least-squares search, ~0.1 s on the excavator)
    FULL = 'full'
    #: the walk, a refusal without that measure
    UNEXPLAINED = 'unexplained'
    #: Newton straight from the previous configuration, no halved steps (a march's probe: one
    #: past a fold fails within max_iter iterations, a walk grinds ten times as long)
    DIRECT = 'direct'


#: how the reasons of a refusal because the mechanism does not close at its input start: the
#: closed form's proof, and Newton's least-squares search from the current configuration
NO_ASSEMBLY_REASONS = ('cannot assemble', 'no assembly near the current configuration')


def does_not_assemble(result: Result) -> bool:
    """Whether ``result`` was refused because the mechanism does not close at its input
    (NO_ASSEMBLY_REASONS), not on a limit, a name or a mode."""
    return not result.success and (result.reason or '').startswith(NO_ASSEMBLY_REASONS)


#: an answer with cond(J)^2 * residual * n at most this has an exact assembly on its branch next
#: to it (Newton-Kantorovich): the closed-form check of a Newton answer is skipped there
KANTOROVICH_BOUND = 1e-2
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
    #: set by a front end that allowed a target to change the assembly mode: 'before -> after'
    mode_change: str = ''
    #: rates of this configuration (core.velocity.Velocities), when the request gave rates
    velocity: Any = None
    #: set by a front end for a partial command: the actuators it held at their last values
    held: tuple[str, ...] = ()

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
            **_described(mech, self),
            'links': links,
            'points': {k: [v[0], v[1]] for k, v in self.points.items()},
            'residual': self.residual,
            'branch': self.branch,
            # (a refused solve has no branch to be defined or not)
            'branch_defined': self.branch_defined if self.success else None,
            'margin': self.margin,
            'solver': self.solver,
            'iterations': self.iterations,
            'cond': self.cond,
        }
        if self.targets:
            out['targets'] = dict(self.targets)
        return out


def named_value(mech: Mechanism, result: Result, name: str) -> Any:
    """The value of a known-able ``name`` in a solved result, the name resolved by the one rule
    (model.names.resolve_name: actuator, joint, link angle, point, or as its prefix says): a
    float (rad or m), or (x, y) (m) for a point. PlanError for a name the mechanism lacks."""
    named = resolve_name(mech, name)
    match named.kind:
        case NameKind.ACTUATOR:
            return result.inputs[named.name]
        case NameKind.JOINT:
            return result.joints[named.name]
        case NameKind.LINK:
            return result.links[named.name]
        case NameKind.POINT:
            return result.points[named.name]


def _described(mech: Mechanism | None, result: Result) -> dict[str, Any]:
    """``inputs`` and ``joints`` in a robot description's own names and values, for a
    mechanism read from one (a refused result has none)."""
    if mech is None or mech.joint_coordinates is None or not result.joints:
        return {}
    return {
        'inputs': dict(zip(mech.output_input_names, mech.output_inputs(result.inputs))),
        'joints': dict(
            zip(mech.output_joint_names, mech.output_joints(result.joints, result.inputs))
        ),
    }


def dyad_reason(plan: Any, k: int, violation: float, length_scale: float) -> str:
    """Why a solve is refused where step ``k`` of ``plan`` (a dyad) does not close by
    ``violation`` (m): the one wording of the closed form, the hybrid and the batch."""
    what = plan.steps[k].describe(plan)
    return (
        f'cannot assemble: {what} does not close; the constraint misses by '
        f'{violation:.6g} m ({violation / length_scale:.3g} of the length scale)'
    )
