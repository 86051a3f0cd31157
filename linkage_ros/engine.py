"""The ROS-free session every front end shares: the node, ``linkage bag`` and any other.

An :class:`Engine` holds one mechanism's solvers and its one 'last good state': the forward
solver for commands, inverse solvers compiled on demand per set of target names (an LRU cache),
each brought up to the last good state before use, so FK and IK continue from the same
configuration. A refused request changes nothing. The request checks and the status fields
every front end shares are request_checks'.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from .core.errors import CommandError, PlanError, echo
from .core.model import Mechanism
from .core.model.names import NameKind, resolve_name
from .core.solver import Result, SolveMode, Solver
from .core.solver.mode_rule import Mode, ModeKeeper
from .core.solver.reach import reach_edge
from .core.solver.result import does_not_assemble, named_value
from .core.steps import BranchRule
from .core.tolerances import NEWTON_TOL
from .core.velocity import velocities
from .drawing_circuit import DrawingCircuit
from .point_coordinates import group_point_coordinates
from .request_checks import rates_error
from .setting_checks import check_point_hold

#: inverse solvers kept per engine (one per set of target names); least recently used dropped
SOLVER_CACHE = 32


@dataclass(frozen=True)
class EngineSettings:
    """How the engine solves (the node's parameters of the same names)."""

    solver: str | None = None  # auto, closed_form, newton; None = the scene's
    tolerance: float = NEWTON_TOL  # Newton tolerance, fraction of the length scale
    max_iterations: int = 50
    branch: str = 'continuous'  # continuous, reference or explicit signs such as '+-'
    target_point_hold: tuple[str, ...] = ()  # held by a point target (DOF > 2)
    #: new inverse solvers compiled per second at most (a live node's protection against a
    #: flood of requests naming ever new sets of targets); None: no limit (offline tools)
    compile_rate: float | None = None


class GoodState(Protocol):
    """The last good state: a Result, or something that makes one when it is needed (the bag
    replay keeps batch rows unmaterialised)."""

    def result(self) -> Result: ...


def _kind_of(mech: Mechanism, name: str) -> NameKind | None:
    try:
        return resolve_name(mech, name).kind
    except PlanError:
        return None


#: what a command may name besides the forward solver's knowns without the 'use ~/target'
#: answer: actuators (the solver refuses one it does not know) and names that do not resolve
_NOT_KNOWN = (NameKind.ACTUATOR, None)


class Engine:
    """Solvers of one mechanism sharing one 'last good state' (see the module docstring).

    The reference pose, solved by the forward solver, is the first good state. ``version``
    counts the good states; a solver that has not seen the current one adopts it before its
    next solve.
    """

    def __init__(
        self,
        mech: Mechanism,
        settings: EngineSettings,
        clock: Callable[[], float] = time.monotonic,
    ):
        """``clock`` (s): what the compile budget (settings.compile_rate) is timed by."""
        self.mech = mech
        self.settings = settings
        self.forward = self.new_solver(None)  # PlanError: a branch or solver that does not fit
        #: the forward solver's actuators, as a tuple and as its key in _synced (every command
        #: asks; Solver.knowns builds a new list each time)
        self._actuators = tuple(self.forward.knowns)
        self._forward_key = frozenset(self._actuators)
        check_point_hold(mech, settings.target_point_hold)
        self._solvers: OrderedDict[frozenset[str], Solver | str] = OrderedDict()
        #: known-set -> the state version that solver last saw (lazy adopt before use)
        self._synced: dict[frozenset[str], int] = {}
        self.version = 0
        self._last: Result | GoodState | None = None
        ref = self.forward.solve(self.forward.reference_values())
        if ref.success:
            self._last = ref
        self._synced[self._forward_key] = self.version
        self._clock = clock
        self._tokens, self._t_tokens = float(SOLVER_CACHE), self._clock()
        #: the drawing's circuit, forward answers held to it (drawing_circuit)
        self.circuit = DrawingCircuit(
            mech, self.forward, lambda r: self.mode(r), lambda signs: self.new_solver(None, signs)
        )
        #: the target rule: answers keep the assembly mode (core.solver.mode_rule)
        self.keeper = ModeKeeper(
            mech,
            self.forward,
            lambda knowns, branch, method: self.new_solver(knowns, branch, method),
            self.circuit.holds,
            # (a description's passive joints within their <limit>s: another solution in
            # mode that keeps them is the answer, not a refusal)
            lambda r: self.beyond_passive_limits(r) is None,
            # (a circuit that passes no toggle, its actuator's limits aside: the other signs
            # are another circuit)
            self.circuit.joined_by_motion,
        )
        #: the drawing's assembly mode (what ``branch: reference`` keeps targets in)
        self._reference_mode = self.keeper.mode(ref if ref.success else None)
        # the circuit scan now (about 0.1 s where it passes toggles), not in the first command
        _ = self.circuit.checked

    # -- the good state ----------------------------------------------------------------------------
    @property
    def last(self) -> Result | None:
        """The last good state as a Result (None before there is one)."""
        if self._last is None or isinstance(self._last, Result):
            return self._last
        self._last = self._last.result()
        return self._last

    def record(self, solver: Solver, state: Result | GoodState) -> None:
        """A success of ``solver`` (which committed it itself): the new last good state."""
        self._last = state
        self.version += 1
        self._synced[self._key(solver)] = self.version

    def _key(self, solver: Solver) -> frozenset[str]:
        """``solver``'s known-set (its key in _synced)."""
        return self._forward_key if solver is self.forward else frozenset(solver.knowns)

    def bring_up_to_date(self, solver: Solver) -> bool:
        """Before ``solver`` solves: adopt the last good state if another solver has succeeded
        since it last ran. True if it adopted one."""
        key = self._key(solver)
        adopted = False
        last = self.last if self._synced.get(key) != self.version else None
        if last is not None:
            adopted = solver.adopt(last)
        self._synced[key] = self.version
        return adopted

    def cached_solvers(self) -> list[Solver]:
        """The solvers the engine keeps for targets (the forward one not counted), least
        recently used first: a caller that keeps something per solver forgets the others'."""
        return [v for v in self._solvers.values() if not isinstance(v, str)]

    def checkpoint(self) -> tuple[Any, ...]:
        """The engine's state (last good state, versions, every solver's continuity), opaque:
        :meth:`rollback` returns to it (a trajectory is solved, then the state restored)."""
        solvers = [self.forward, *self.cached_solvers()]
        return (self._last, self.version, dict(self._synced), [(s, s.snapshot()) for s in solvers])

    def rollback(self, token: tuple[Any, ...]) -> None:
        self._last, self.version, synced, snaps = token
        self._synced = dict(synced)
        for solver, snap in snaps:
            solver.restore(snap)

    # -- solvers -----------------------------------------------------------------------------------
    def new_solver(
        self, knowns: Sequence[str] | None, branch: str | None = None, method: str | None = None
    ) -> Solver:
        """A solver with the engine's settings (``branch``, ``method``: instead of theirs). The
        ``branch`` setting names a mode of the forward plan: a target's solver follows its own
        plan continuously, and the target rule keeps its answers in that mode."""
        s = self.settings
        if branch is None:
            forward = knowns is None or set(knowns) == set(self.mech.actuators)
            branch = s.branch if forward else 'continuous'
        return Solver(
            self.mech,
            knowns=knowns,
            method=s.solver if method is None else method,
            tol=s.tolerance,
            max_iter=s.max_iterations,
            branch=branch,
        )

    def solver_for(self, knowns: Sequence[str]) -> Solver | str:
        """The cached solver for this set of knowns, or the reason it cannot be built (or, with
        ``compile_rate``, why it is not built now)."""
        key = frozenset(knowns)
        if key == self._forward_key:
            return self.forward
        hit = self._solvers.get(key)
        if hit is None:
            busy = self._compile_budget()
            if busy:
                return busy
            try:
                hit = self.new_solver(list(knowns))
            except PlanError as exc:
                hit = str(exc)
            self._solvers[key] = hit
            while len(self._solvers) > SOLVER_CACHE:
                old, _ = self._solvers.popitem(last=False)
                self._synced.pop(old, None)
        self._solvers.move_to_end(key)
        return hit

    def _compile_budget(self) -> str | None:
        """Take one compile from a token bucket of ``compile_rate`` per second (a burst of the
        cache's size); why not, when it is empty."""
        rate = self.settings.compile_rate
        if rate is None:
            return None
        now = self._clock()
        self._tokens = min(float(SOLVER_CACHE), self._tokens + (now - self._t_tokens) * rate)
        self._t_tokens = now
        if self._tokens < 1.0:
            return (
                f'too many new sets of target names: at most {rate:g} new ones per second are '
                'compiled (sets already used are answered at once); send it again later'
            )
        self._tokens -= 1.0
        return None

    # -- requests ----------------------------------------------------------------------------------
    def command(
        self, values: Mapping[str, float], rates: Mapping[str, float] | None = None
    ) -> Result:
        """Forward kinematics: ``{actuator: value}``; with ``rates`` ({actuator: rad/s or m/s},
        the same names) the answer's ``velocity`` holds every joint's, link's and point's rate
        (core.velocity: exact, from the loop-closure Jacobian). A partial command (some
        actuators, no unknown name) holds the others at their values in the last good state
        (their rates 0): the answer's ``held`` names them. A mechanism read from a robot
        description takes its own joint names and values (mech.joint_coordinates)."""
        try:
            beyond = self.beyond_limits(values)
            values = self.to_scene(values, command=True)
            rates = None if rates is None else self.to_scene(rates, rates=True, command=True)
        except CommandError as exc:
            return Result(False, str(exc))
        if beyond is not None:
            return Result(False, beyond)
        misplaced = self.not_actuators(values)
        if misplaced is not None:
            return Result(False, misplaced)
        unasked = [] if rates is None else [n for n in rates if n not in values]
        if unasked:
            return Result(
                False,
                f'velocity of {echo(unasked)} without a value: give velocities for the names '
                'the command gives (an actuator it holds keeps its value, at rate 0)',
            )
        values, held = self.held_values(values)
        if isinstance(held, str):
            return Result(False, held)
        if rates is not None and held:
            rates = {**rates, **{a: 0.0 for a in held}}
        bad_rates = rates_error(rates)
        if bad_rates:
            return Result(False, bad_rates)
        result = self.forward_solve(values)
        if rates is not None and result.success:
            result.velocity = velocities(self.forward, result, values, rates)
        result.held = held
        return result

    def forward_solve(self, values: Mapping[str, Any]) -> Result:
        """The forward solver on a complete command in the scene's names (Engine.command's
        solve, and the command line's): brought up to date, solved, refused if the actuator
        cannot move the mechanism there (solve_on_circuit), and on success the new last good
        state."""
        solver = self.forward
        self.bring_up_to_date(solver)
        result, _adopted = self.solve_on_circuit(solver, values)
        if result.success:
            self.record(solver, result)
        return result

    def solve_on_circuit(self, solver: Solver, values: Mapping[str, Any]) -> tuple[Result, bool]:
        """The forward ``solver`` (up to date) on ``values``, held to the drawing's circuit
        (DrawingCircuit.keep): its answer, committed to it; the circuit's own configuration, adopted
        by it (True); or the refusal, the solver as it was. The caller records a success (the
        bag's replay keeps its own history of them)."""
        before, snap = self.last, solver.snapshot()
        result = self.circuit.with_reach(solver.solve(values))
        beyond = self.beyond_passive_limits(result)
        if beyond is not None:
            solver.restore(snap)  # a refused request changes nothing
            return beyond, False
        if not self.circuit.checked:
            return result, False
        kept = self.circuit.keep(before, result, values)
        if kept is result:
            return result, False
        solver.restore(snap)
        if not kept.success:
            return kept, False
        beyond = self.beyond_passive_limits(kept)
        if beyond is not None:
            return beyond, False
        solver.adopt(kept)
        return kept, True

    def not_actuators(self, values: Mapping[str, Any]) -> str | None:
        """Why a command naming a joint, link or point (not an actuator) is refused, with the
        request that takes it (as the CLI's --set says "use --target"), or None. Other unknown
        names are the solver's to refuse."""
        acts = self._actuators
        mech = self.mech
        named = [n for n in values if n not in acts and _kind_of(mech, n) not in _NOT_KNOWN]
        if not named:
            return None
        return (
            f'{echo(named)} not an actuator of {mech.name!r} (actuators: {list(acts)}): a '
            'command sets actuators; use ~/target for joints and links, '
            '~/target_point/<point> for points'
        )

    def beyond_limits(self, values: Mapping[str, Any]) -> str | None:
        """Why a request in a robot description's values gives a joint a value beyond its
        <limit> (JointMap.refusal: as given, not on the circle), or None (a scene file's:
        its actuators' limits are checked on the circle by the solver)."""
        coords = self.mech.joint_coordinates
        return None if coords is None else coords.refusal(values)

    def to_scene(
        self, values: Mapping[str, Any], rates: bool = False, command: bool = False
    ) -> dict[str, Any]:
        """A request in the robot description's joint names and values -> the scene's knowns
        (unchanged for a scene file); CommandError naming a joint that cannot be set (in a
        ``command``: a passive one too)."""
        coords = self.mech.joint_coordinates
        return dict(values) if coords is None else coords.to_scene(values, rates, command)

    def held_values(
        self, values: Mapping[str, Any]
    ) -> tuple[dict[str, Any], tuple[str, ...] | str]:
        """A command naming some actuators (and nothing else) -> every actuator, the others at
        their values in the last good state, and the names held (or why they cannot be)."""
        acts = self._actuators
        held = tuple(a for a in acts if a not in values)
        if not values or not held or any(n not in acts for n in values):
            return dict(values), ()  # complete, empty or naming something else: the solver's
        last = self.last
        if last is None:
            return dict(values), (
                f'missing value(s) for {list(held)} and no good state to hold them at: name '
                'every actuator in the first command'
            )
        full = {a: values[a] if a in values else last.inputs[a] for a in acts}
        return full, held

    def target(
        self, values: Mapping[str, float], allow_mode_change: bool = False, replace: bool = True
    ) -> Result:
        """Inverse kinematics: ``{joint/link/actuator name: value}`` (DOF values in all), in
        the mechanism's current assembly mode (see :meth:`solve_target`). A point is given as
        ``<point>.x`` and ``<point>.y`` (point_coordinates)."""
        try:
            beyond = self.beyond_limits(values)
            knowns = group_point_coordinates(self.mech, self.to_scene(values))
        except CommandError as exc:
            return Result(False, str(exc))
        if beyond is not None:
            return Result(False, beyond)
        return self.solve_target(self.solver_for(list(knowns)), knowns, allow_mode_change, replace)

    # -- the assembly-mode rule for targets ------------------------------------------------------
    def mode(self, result: Result | None) -> Mode | None:
        """The mechanism's assembly mode in a configuration (core.solver.mode_rule)."""
        return self.keeper.mode(result)

    def solve_target(
        self,
        solver: Solver | str,
        values: Mapping[str, Any],
        allow_mode_change: bool = False,
        replace: bool = True,
    ) -> Result:
        """A target in the current assembly mode (the rule: core.solver.mode_rule); under an
        explicit ``branch`` setting (or ``reference``) in the mode it names (the drawing's),
        which no request changes.
        ``replace=False`` (a trajectory's next point): the inverse solver's continuous answer
        only, never a solution elsewhere in the mode (that would be a jump)."""
        if isinstance(solver, str):
            return Result(False, solver)
        self.bring_up_to_date(solver)
        last = self.last
        fixed = self.fixed_mode()
        before = self.mode(last) if fixed is None else fixed
        if before is None or last is None:
            snap = solver.snapshot()
            result = solver.solve(values)
            broken = self.broken_mimic(result) or self.beyond_passive_limits(result)
            if broken is not None:
                solver.restore(snap)
                return broken
            if result.success:
                self.record(solver, result)
            return self._out_of_reach(solver, values, result, allow_mode_change)
        answer = self.keeper.target(
            solver,
            values,
            last,
            before,
            allow_mode_change and fixed is None,
            replace,
            held_by='' if fixed is None else f'branch setting {self.settings.branch!r}',
        )
        broken = self.broken_mimic(answer.result) or self.beyond_passive_limits(answer.result)
        if broken is not None:
            return broken
        off = self._off_circuit_under(fixed, last, answer.result)
        if off is not None:
            return off
        if answer.commit:
            solver.adopt(answer.result)
            self.record(solver, answer.result)
        return self._out_of_reach(solver, values, answer.result, allow_mode_change)

    def _off_circuit_under(self, fixed: Mode | None, last: Result, result: Result) -> Result | None:
        """Under a branch setting (which holds signs, not circuits), a target's answer on
        another circuit than the state's, refused as a command there is (DrawingCircuit.keep): the
        double-rocker's mirror loop has the setting's signs too."""
        if fixed is None or not result.success or not self.circuit.checked:
            return None
        if self.circuit.holds(last) is not True or self.circuit.holds(result) is not False:
            return None
        return Result(
            False,
            f'target is reachable only in another circuit of the mechanism (signs '
            f'{result.branch}, a loop its actuator does not reach from the current one); the '
            f'branch setting {self.settings.branch!r} keeps the mechanism in its mode',
            solver=result.solver,
        )

    def beyond_passive_limits(self, result: Result) -> Result | None:
        """An answer refused where it puts a passive joint of the robot description beyond
        its <limit> (JointMap.passive_beyond): the chain closes there, but the robot cannot
        take the pose (a slider's travel, a knuckle's stop)."""
        coords = self.mech.joint_coordinates
        if not result.success or coords is None:
            return None
        why = coords.passive_beyond(result.joints)
        if why is None:
            return None
        return Result(False, f'cannot be reached: {why}', solver=result.solver)

    def broken_mimic(self, result: Result) -> Result | None:
        """A target's answer refused where it breaks a <mimic> between the description's
        actuated joints (JointCoordinates.broken_mimic): a command sets the follower from its
        leader, but an inverse solve moves them apart (a gripper's two knuckles)."""
        coords = self.mech.joint_coordinates
        if not result.success or coords is None:
            return None
        why = coords.broken_mimic(result.inputs)
        if why is None:
            return None
        return Result(
            False,
            f'target cannot be reached: {why} (give targets that keep the <mimic>, or command '
            'the leader)',
            solver=result.solver,
        )

    def mode_changes(self, before: Mode, here: Result | None, result: Result) -> bool:
        """Whether ``result`` is in another assembly mode than ``before`` (that of ``here``):
        other dyad signs clear of their toggles, not on one circuit with ``here`` (under a
        branch setting, the signs alone: it holds them)."""
        return self.keeper.changes_mode(before, here if self.fixed_mode() is None else None, result)

    def fixed_mode(self) -> Mode | None:
        """The assembly mode the ``branch`` setting fixes (the forward dyads' signs, or the loop
        Jacobian's sign 'J+' / 'J-'; 'reference': the drawing's), None under 'continuous'."""
        branch = self.forward.continuity.branch  # (the setting, as the forward solver read it)
        if branch.rule is BranchRule.CONTINUOUS:
            return None
        if branch.rule is BranchRule.REFERENCE:
            return self._reference_mode
        signs = (branch.det_sign,) if branch.det_sign is not None else branch.signs or ()
        return signs, [1.0] * len(signs)

    def _out_of_reach(
        self, solver: Solver, values: Mapping[str, Any], result: Result, searched: bool
    ) -> Result:
        """A target that cannot be assembled, said in the user's terms first: for a point,
        where it stops being reachable on the line toward the target (core.solver.reach), then
        the solver's own reason (the dyad or loop that does not close, with its miss); where
        Newton placed it, that other modes are searched on request (``searched``: they were)."""
        if self.last is None or not does_not_assemble(result):
            return result
        self.way_edge(solver, values, result)
        if solver.mode is not SolveMode.CLOSED_FORM and self.fixed_mode() is None and not searched:
            # (a closed form searched them all; a branch setting allows no other mode; a slide
            # or angle target gets it too: a press's ram beyond its stroke in the current mode
            # and within it in another was refused without it)
            result.reason = (
                f'{result.reason}; other assembly modes are searched on request '
                '(~/target_any_mode, linkage solve --any-mode)'
            )
        return result

    def way_edge(
        self, solver: Solver, values: Mapping[str, Any], result: Result, keep_mode: bool = True
    ) -> Result:
        """``result`` (a refusal of ``values`` by ``solver`` that does not assemble, changed)
        told first where the way there from the last good state stops (core.solver.reach);
        with ``keep_mode`` the way stops where it would leave the assembly mode, as the target
        rule answers."""
        last = self.last
        if last is None or not does_not_assemble(result):
            return result
        before = self.mode(last) if keep_mode else None
        edge = reach_edge(
            solver,
            values,
            last,
            # (a joint's or link's value told in the scene's terms: not for a description,
            # whose joint values are its own)
            scalars=self.mech.joint_coordinates is None,
            keeps=None if before is None else lambda r: not self.mode_changes(before, last, r),
        )
        if edge is not None:
            result.reason = f'{edge.describe()}; {result.reason}'
        return result

    def point_hold(self, point: str) -> list[str]:
        """The target_point_hold names a target on ``point`` keeps (the point itself excepted)."""
        return [h for h in self.settings.target_point_hold if h != point]

    def held_now(self, names: Sequence[str]) -> dict[str, Any] | str:
        """``names`` at their values in the last good state, or why there are none."""
        last = self.last
        if last is None:
            return (
                f'no good state yet to take the held value(s) {list(names)} from: send a '
                'command first'
            )
        return {h: named_value(self.mech, last, h) for h in names}

    def target_point(self, point: str, xy: tuple[float, float]) -> Result:
        """Inverse kinematics: put ``point`` at ``xy``; target_point_hold names keep their value
        in the last good state."""
        key = f'point:{point}'  # explicit: a point may share its name with a joint
        hold = self.point_hold(point)
        solver = self.solver_for([key] + hold)
        values: dict[str, Any] = {}
        if hold and not isinstance(solver, str):
            held = self.held_now(hold)
            if isinstance(held, str):
                return Result(False, held)
            values = held
        if isinstance(solver, str) and self.mech.dof > 2 and not hold:
            solver += (
                f' (a point target fixes 2 of the {self.mech.dof} degrees of freedom: '
                'set the parameter target_point_hold)'
            )
        values[key] = xy
        return self.solve_target(solver, values)
