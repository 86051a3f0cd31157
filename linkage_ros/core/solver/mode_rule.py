"""The assembly-mode rule for targets: a real mechanism changes its assembly mode only when it is
taken apart or driven through a toggle position (a cylinder's dead centre inside its limits, a
dyad folded flat), never by reaching for a target, so an inverse solve (a target) answers in the
mechanism's current mode.

:class:`ModeKeeper` applies the rule for one mechanism (the engine's targets, and any front end
that asks): an answer in another mode (or one refused on a limit) is replaced by a solution in
the current mode within limits where one exists (the inverse plan's other branches are tried;
where Newton places the rest, restarts spread over the actuator ranges in that mode, then a
multi-start search of the target's solutions: a Newton inverse may have several in one mode,
such as the two roots either side of the fold of one point coordinate); if only other modes
reach the target it is refused, naming the mode that would, unless the caller allows the
change (the answer then says ``mode_change``). A trajectory's next point takes no such
replacement (``replace=False``): it would be a jump, not a motion.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..model import Mechanism
from ..plan.spec import NEEDS_BEYOND_LIMITS, needs_beyond_limits
from ..quantities import AngleSpec, CoordinateSpec
from .compiled import SolveMode
from .modes import newton_modes
from .reading import mode_label
from .result import (
    SIGN_MARGIN,
    Effort,
    Result,
    branch_identity_defined,
    branch_text,
    does_not_assemble,
)
from .solver import Solver

#: an assembly mode: the branch sign and margin (|sin| of its transmission angle) of each
#: branching dyad of the forward plan
Mode = tuple[tuple[int, ...], list[float]]

#: the most branching steps of an inverse plan whose 2^k branch choices are searched for a
#: solution in the current assembly mode
MAX_BRANCHES = 6
#: the most restarts of a Newton inverse solve that looks for a solution in the current mode
MAX_STARTS = 16
#: Newton iterations the restarts may spend on starts that fail, in units of max_iter: a
#: target the mechanism cannot reach walks into a fold from every start (300-600 iterations
#: each on the loader, ~0.1 s), on the node's command thread; the restarts that place a
#: reachable target do it within the first few (nearest first: at most three failed walks
#: before it, over 100 random loader targets)
RESTART_BUDGET = 40
#: variants (other branch signs, Newton only) kept per keeper; the oldest dropped beyond it
MAX_VARIANTS = 128
#: starts of the last search for a solution in the current mode (modes.newton_modes), tried
#: where the restarts found none and the target was not refused as unreachable
SEARCH_STARTS = 64


def mode_differs(before: Mode, after: Mode | None) -> bool:
    """Whether two assembly modes differ at a dyad clear of its toggle in both."""
    if after is None:
        return False
    return any(
        sb != sa and mb > SIGN_MARGIN and ma > SIGN_MARGIN
        for sb, sa, mb, ma in zip(before[0], after[0], before[1], after[1])
    )


def configuration_distance(a: Result | None, b: Result) -> float:
    """Sum of squared point displacements between two configurations (m^2)."""
    if a is None:
        return 0.0
    return sum(
        (b.points[p][0] - a.points[p][0]) ** 2 + (b.points[p][1] - a.points[p][1]) ** 2
        for p in a.points
        if p in b.points
    )


#: makes a solver with the caller's settings: (knowns or None for the actuators, branch or None,
#: method or None) -> Solver
SolverMaker = Callable[[Sequence[str] | None, str | None, str | None], Solver]
#: whether a configuration lies on the circuit through the reference pose (core.motion.circuits:
#: a non-Grashof four-bar passes its toggles, so its dyad's two signs are one mode; a Grashof
#: double-rocker's mirror loop has the same signs and is another), None where not known
OnCircuit = Callable[[Result], bool | None]


@dataclass(frozen=True)
class TargetAnswer:
    """What the rule answers a target: the result, and whether the caller should commit it (make
    it the mechanism's state)."""

    result: Result
    commit: bool


class ModeKeeper:
    """The target rule for one mechanism (see the module); ``make`` builds solvers with the
    caller's settings, ``forward`` reads a configuration's mode."""

    def __init__(
        self,
        mech: Mechanism,
        forward: Solver,
        make: SolverMaker,
        on_circuit: OnCircuit | None = None,
        takes: Callable[[Result], bool] | None = None,
        joined_by_motion: Callable[[], bool | None] | None = None,
    ):
        self.mech, self.forward, self.make = mech, forward, make
        self.on_circuit = on_circuit
        #: whether the actuator's motion takes the mechanism through a toggle into other signs
        #: (False: every other sign combination is another circuit, as a crank-rocker's
        #: mirror curve; None: not known), asked only to word a refusal
        self.joined_by_motion = joined_by_motion
        #: whether the robot can take a solved pose (a robot description's passive joints
        #: within their <limit>s); None: every pose
        self.takes = takes
        #: (target names, branch signs or 'newton') -> that variant of the names' inverse solver
        self._variants: dict[tuple[frozenset[str], str], Solver] = {}
        #: assembly mode -> forward configurations spread over the actuator ranges in it
        self._starts: dict[tuple[int, ...], list[Result]] = {}

    def _fits(self, r: Result) -> bool:
        """A solution the rule may answer: solved, and a pose the robot can take (takes)."""
        return r.success and (self.takes is None or self.takes(r))

    def label(self, mode: Mode) -> str:
        """A mode as statuses show it: '+-' (the forward dyads' signs) or 'J+' (reading)."""
        return mode_label(self.forward.compiled, mode[0])

    def mode(self, result: Result | None) -> Mode | None:
        """The mechanism's assembly mode in a configuration: the branch signs (and margins) of
        the forward solver's dyads there. None where it is not defined (no closed-form forward
        plan, no configuration)."""
        return None if result is None else self.forward.mode_of(result)

    def _changes_circuit(self, here: Result | None, result: Result) -> bool:
        """Whether ``result`` lies on another circuit than ``here``, both known (on_circuit):
        the change is the loop, whatever the signs say; or in other signs where no motion
        passes a toggle (joined_by_motion False: a crank-rocker's two curves)."""
        joined = self.joined_by_motion
        if here is not None and joined is not None and joined() is False:
            return True
        if here is None or self.on_circuit is None:
            return False
        a, b = self.on_circuit(here), self.on_circuit(result)
        return a is not None and b is not None and a != b

    def changes_mode(self, before: Mode, here: Result | None, result: Result) -> bool:
        """Whether ``result`` is in another mode than ``before`` (the mode of ``here``): on
        another circuit than ``here`` where the circuit is known (on_circuit), one circuit
        through its toggles whatever the signs; else its forward dyads' signs differ clear of
        their toggles."""
        if here is not None and self.on_circuit is not None:
            a, b = self.on_circuit(here), self.on_circuit(result)  # (each read once)
            if a is not None and b is not None and a != b:
                return True  # another circuit: the actuator cannot take the mechanism there
            if a and b:
                return False  # one circuit through its toggles: any signs
        return mode_differs(before, self.mode(result))

    def target(
        self,
        solver: Solver,
        values: Mapping[str, Any],
        last: Result,
        before: Mode,
        allow_mode_change: bool = False,
        replace: bool = True,
        held_by: str = '',
    ) -> TargetAnswer:
        """``solver`` (brought up to ``last``, the mechanism's state in mode ``before``) on a
        target, under the rule. ``replace=False``: only the inverse solver's own continuous
        answer (a trajectory's next point), as it is, committed only in mode. ``held_by``: what
        holds the mode (a branch setting), named in a refusal instead of how to ask for a
        change."""
        result = solver.solve(values, commit=False)
        first = result
        after = self.mode(result) if result.success else None
        # a branch setting holds the signs themselves; else a circuit's toggles are no change
        here = None if held_by else last
        in_mode = result.success and not self.changes_mode(before, here, result)
        if in_mode and self._fits(result):
            if replace and _folded(after) and not _folded(before):
                # a dyad at its toggle is in every mode, and a fold may be where the inverse
                # plan lands while the mode has a regular solution (a Peaucellier cell with A
                # on B, P anywhere): that one, where there is one
                alt = self.in_mode(solver, values, before, last, here)
                if alt is not None and not _folded(self.mode(alt)):
                    return self._answer(alt, self.mode(alt) or before)
            return self._answer(result, after or before)  # the inverse solver's continuity
        if not replace:
            return TargetAnswer(result, False)
        # another mode, or refused (a limit): the solution in mode nearest the last good state
        # among the inverse plan's other branches
        alt = self.in_mode(solver, values, before, last, here)
        found: list[Result] | None = None  # the multi-start search's solutions, made once
        if alt is None and _worth_a_search(solver, result):
            found = self._search(solver, values)
            alt = self._nearest(
                [r for r in found if self._fits(r) and not self.changes_mode(before, here, r)],
                last,
            )
        if alt is not None:
            return self._answer(alt, self.mode(alt) or before)
        if in_mode:  # in mode but a pose the robot cannot take, and no other in mode it can:
            return TargetAnswer(result, False)  # (the caller refuses it, saying which joint)
        if not result.success and solver.mode is SolveMode.CLOSED_FORM:
            # refused from here, and no solution in mode: does another mode reach it? (the
            # inverse plan's every branch, nearest the last good state first)
            other = self._other_mode(solver, values, last)
            if other is not None:
                result, after = other, self.mode(other)
        elif not result.success and allow_mode_change:
            # Newton places the target: a change of mode asked for searches every mode (the
            # multi-start search, 0.1-0.6 s: only on request; a plain refusal says so)
            other = self._nearest(self._search(solver, values) if found is None else found, last)
            if other is not None:
                result, after = other, self.mode(other)
        if not result.success or after is None:
            blocked = self._limits_stop(solver, values, before, last, here, first)
            return TargetAnswer(result if blocked is None else blocked, False)
        if not allow_mode_change:
            circuit = self._changes_circuit(here, result) or self.label(after) == self.label(before)
            # (a change of circuit is a loop the actuator does not reach: no motion makes it)
            change = (
                'only taking the mechanism apart moves it to another circuit'
                if circuit
                else 'only a motion through a toggle position, or taking the mechanism apart, '
                'changes its mode'
            )
            why = (
                f'the {held_by} keeps the mechanism in mode {self.label(before)}'
                if held_by
                else f'the mechanism is in mode {self.label(before)} and a target keeps it '
                f'({change}: ask for the change explicitly to allow it: '
                '~/target_any_mode on the node, linkage solve --any-mode)'
            )
            where = (
                f'another circuit of the mechanism (signs {self.label(after)}, a loop its '
                'actuator does not reach from the current one)'
                if circuit
                else f'assembly mode {self.label(after)} {self._of_what()}'
            )
            said = f'target is reachable only in {where}; {why}'
            if (first.reason or '').startswith(NEEDS_BEYOND_LIMITS):
                # the current mode's answer is there, beyond a limit: that first (a loader's
                # bin hinge needing Z2 1e-6 m past its maximum was told it is reachable only
                # in another mode: a numerics reviewer)
                said = f'{first.reason} from the current configuration; within the limits it ' + (
                    said.removeprefix('target ')
                )
            return TargetAnswer(Result(False, said, solver=result.solver), False)
        circuit = self._changes_circuit(here, result) or self.label(before) == self.label(after)
        result.mode_change = f'{self.label(before)} -> {self.label(after)}' + (
            ' (another circuit)' if circuit else ''
        )
        return self._answer(result, after)

    def _limits_stop(
        self,
        solver: Solver,
        values: Mapping[str, Any],
        before: Mode,
        last: Result | None,
        here: Result | None,
        first: Result,
    ) -> Result | None:
        """A target refused as not assembling from here, whose answer in the current mode
        exists beyond the actuators' limits: refused naming every limit it needs passed, not as
        a dyad that does not close (the inverse plan's signs at the target are not the current
        ones, so its direct solve does not close, while the way there stops at a limit: a
        loader's bucket-tip target needing both cylinders beyond their limits, an engineer);
        None otherwise."""
        if not does_not_assemble(first) or not any(s.bounded for s in solver.actuator_specs):
            return None
        free = self.in_mode(solver, values, before, last, here, within_limits=False)
        why = (
            None
            if free is None
            else needs_beyond_limits(
                (s, v) for s in solver.actuator_specs if (v := free.inputs.get(s.name)) is not None
            )
        )
        if why is None:
            return None
        return Result(
            False,
            f'{why} (its answer in the current assembly mode {self.label(before)}, without the '
            'limits)',
            solver=first.solver,
            targets=first.targets,
        )

    def _answer(self, result: Result, mode: Mode) -> TargetAnswer:
        """A target's answer, its ``branch`` the mechanism's mode (the forward dyads' signs or
        the Jacobian's sign), as a command's status shows it, not the inverse plan's signs."""
        result.branch = self.label(mode)
        result.branch_defined = bool(
            branch_identity_defined(min(mode[1], default=1.0), result.residual or 0.0)
        )
        return TargetAnswer(result, True)

    def _of_what(self) -> str:
        if self.forward.full_plan.complete:
            return 'of the forward dyads'
        return "(the sign of the loop Jacobian's determinant)"

    def in_mode(
        self,
        solver: Solver,
        values: Mapping[str, Any],
        before: Mode,
        last: Result | None,
        here: Result | None,
        within_limits: bool = True,
    ) -> Result | None:
        """The solution of the target in assembly mode ``before`` within limits nearest
        ``last``: every branch of the inverse plan's dyads is tried (a closed-form plan has no
        other solutions); where Newton places the rest (hybrid, newton), each branch is solved
        from ``last`` and then, if none is in mode, restarted from configurations spread over
        the actuator ranges in that mode (a Newton root depends on its start; RESTART_BUDGET
        bounds the failed ones). None if none is found. ``here``: the configuration whose
        circuit counts as the mode (changes_mode; None: the signs alone, as a branch setting
        holds them). ``within_limits`` False: the solution whatever the actuators' limits,
        from the current configuration only (no restarts)."""
        k = solver.branch_count
        if k > MAX_BRANCHES:
            return None
        alternatives = [self._with_signs(solver, code, k) for code in range(2**k)] if k else []
        closed = solver.mode is SolveMode.CLOSED_FORM
        if not closed:
            alternatives = alternatives or [solver]
        best: tuple[bool, float, Result] | None = None
        for alt in alternatives:
            if alt.mode is not SolveMode.CLOSED_FORM and last is not None:
                alt.adopt(last)  # Newton starts from the mechanism's state
            r = alt.solve(
                values, commit=False, effort=Effort.UNEXPLAINED, within_limits=within_limits
            )
            mode = self.mode(r) if r.success else None
            if not self._fits(r) or self.changes_mode(before, here, r):
                continue
            key = (_folded(mode), configuration_distance(last, r))  # a regular one first
            if best is None or key < best[:2]:
                best = (*key, r)
        if best is not None or closed or not within_limits:
            # (without the limits only from the current configuration: that search names the
            # limits of a refusal, and the restarts' budget is the target's own)
            return None if best is None else best[2]
        return self.multi_start(self._newton_for(solver), values, before, last, here)

    def _other_mode(
        self, solver: Solver, values: Mapping[str, Any], last: Result | None
    ) -> Result | None:
        """The solution of a closed-form inverse in any mode nearest ``last`` (each branch of
        the inverse plan), or None."""
        return self._nearest([r for r in solver.solve_all(values) if self._fits(r)], last)

    def _search(self, solver: Solver, values: Mapping[str, Any]) -> list[Result]:
        """The target's solutions within limits a multi-start Newton search finds
        (modes.newton_modes from SEARCH_STARTS starts), in any mode."""
        found = newton_modes(self._newton_for(solver).compiled, values, starts=SEARCH_STARTS)
        return [r for r in found.results if r.success]

    @staticmethod
    def _nearest(found: Sequence[Result], last: Result | None) -> Result | None:
        """The one of ``found`` nearest ``last`` (configuration_distance), or None."""
        return min(found, key=lambda r: configuration_distance(last, r), default=None)

    def _with_signs(self, solver: Solver, code: int, k: int) -> Solver:
        """The inverse solver of ``solver``'s knowns with the branch signs of bit pattern
        ``code`` (k dyads)."""
        signs = branch_text(-1 if code >> i & 1 else 1 for i in range(k))
        return self._variant(solver, signs, lambda: self.make(solver.knowns, signs, None))

    def _newton_for(self, solver: Solver) -> Solver:
        """A Newton-only solver of ``solver``'s knowns: its root is the one nearest its start,
        where a hybrid solve's closed-form part fixes some values whatever the start."""
        return self._variant(solver, 'newton', lambda: self.make(solver.knowns, None, 'newton'))

    def _variant(self, solver: Solver, kind: str, make: Callable[[], Solver]) -> Solver:
        key = (frozenset(solver.knowns), kind)
        alt = self._variants.get(key)
        if alt is None:
            alt = self._variants[key] = make()
            if len(self._variants) > MAX_VARIANTS:
                self._variants.pop(next(iter(self._variants)))
        return alt

    def multi_start(
        self,
        solver: Solver,
        values: Mapping[str, Any],
        before: Mode,
        last: Result | None,
        here: Result | None,
    ) -> Result | None:
        """A Newton (or hybrid) inverse solve converges to the root nearest its start, which
        may lie in another mode or beyond a limit while the target has a solution in the
        current mode within limits. Restart it from configurations spread over the actuators'
        ranges in the current mode (nearest ``last`` first) and return the first solution in
        mode within limits; None if none of MAX_STARTS starts reaches one."""
        found = None
        budget = RESTART_BUDGET * solver.compiled.max_iter
        try:
            for start in self._mode_starts(before[0], last)[:MAX_STARTS]:
                if budget <= 0:
                    break
                solver.adopt(start)
                r = solver.solve(values, commit=False, effort=Effort.UNEXPLAINED)
                if self._fits(r) and not self.changes_mode(before, here, r):
                    found = r
                    break
                budget -= r.iterations
        finally:
            if last is not None:
                solver.adopt(last)
        return found

    def _mode_starts(self, signs: tuple[int, ...], last: Result | None) -> list[Result]:
        """Configurations in assembly mode ``signs`` spread over the actuators' ranges (a
        grid of forward solves, made once per mode), nearest ``last`` first."""
        starts = self._starts.get(signs)
        if starts is None:
            # (the mode as a branch setting names it: 'J+' where Newton places the mechanism;
            # '+' was refused as a sign for a dyad there is not: an adversary's six-bar)
            fwd = self.make(None, mode_label(self.forward.compiled, signs), None)
            levels = 3 if len(fwd.actuator_specs) <= 4 else 2
            axes = []
            for spec in fwd.actuator_specs:  # a forward solve: its knowns are the actuators
                lo, hi = spec.minimum, spec.maximum
                if lo is None or hi is None:
                    if not isinstance(spec, AngleSpec):  # an unlimited slide: about its reference
                        ref = fwd.reference_values()[spec.name]
                        scale = 0.2 * self.mech.length_scale
                        lo, hi = ref - scale, ref + scale
                    else:
                        lo, hi = -math.pi, math.pi
                axes.append([lo + (hi - lo) * (k + 0.5) / levels for k in range(levels)])
            starts = []
            for combo in itertools.islice(itertools.product(*axes), MAX_STARTS * 4):
                r = fwd.solve(dict(zip(fwd.knowns, combo)), commit=False)
                if r.success and not mode_differs((signs, [1.0] * len(signs)), self.mode(r)):
                    starts.append(r)
            self._starts[signs] = starts
        return sorted(starts, key=lambda r: configuration_distance(last, r))


def _worth_a_search(solver: Solver, result: Result) -> bool:
    """Whether a target the restarts did not place in mode is worth the multi-start search
    (40-80 ms on the loader, 0.6 s on the excavator): it names one point coordinate, whose
    fold splits a mode into two regions the restarts may miss (other Newton targets keep the
    restarts' answer: a refusal on the command thread must stay short), and it was answered
    in another mode or refused on a limit or from where the mechanism is, not as out of reach
    (that search would find nothing)."""
    if solver.mode is SolveMode.CLOSED_FORM:
        return False
    if not any(isinstance(s, CoordinateSpec) for s in solver.specs):
        return False
    return not does_not_assemble(result)


def _folded(mode: Mode | None) -> bool:
    """A configuration with a dyad at its toggle (its sign not read as the mode)."""
    return mode is not None and any(m <= SIGN_MARGIN for m in mode[1])
