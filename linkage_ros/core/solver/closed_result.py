"""The Result and State of a closed-form answer (closed_form.SlotReadout made them), whose
name-keyed values are read off the run's registers when first asked."""

from __future__ import annotations

from typing import Any, Protocol

from ..execute import LinkPoses
from ..scalar_plan import ScalarProgram
from ..steps import branch_text
from .compiled import SolveMode, Values
from .continuity import State
from .lazy_result import LazyResult


class Readout(Protocol):
    """What the answer reads its values with (closed_form.SlotReadout)."""

    L: float  # the length scale (m)
    prog: ScalarProgram

    def fill(self, d: dict[str, Any], R: list[Any], vals: Values) -> None: ...

    def lazy_worst(self, R: list[Any], worst: float) -> float: ...


class ClosedResult(LazyResult):
    """A closed-form answer whose name-keyed dicts (inputs, targets, joints, links, points)
    are read off its run's registers when first asked, by the readout's very operations, and
    its branch text off its signs (lazy_result.LazyResult: the machinery). Every other field
    is set when it is made (or is Result's default)."""

    __slots__ = ()
    _source: SlotState  # what fills the dicts: the readout, the run's registers and values
    _LAZY = frozenset(('inputs', 'targets', 'joints', 'links', 'points', 'branch'))

    def _fill(self, d: dict[str, Any], name: str) -> None:
        st = self._source
        if name == 'branch':  # (the text decides nothing: most callers never read it)
            d['branch'] = branch_text(st.signs)
        else:
            st._read.fill(d, st._registers, st.values)


class ClosedLazyResidual(ClosedResult):
    """A ClosedResult whose residual too is computed when first read, from its run's
    registers, by the very operations SlotReadout.result would have used (closure_bound: the
    checks its plan satisfies by construction)."""

    __slots__ = ('_worst',)
    _worst: float  # the largest miss of the checks made when it was made (m)
    _LAZY = ClosedResult._LAZY | {'residual'}

    def _fill(self, d: dict[str, Any], name: str) -> None:
        if name != 'residual':
            super()._fill(d, name)
            return
        st = self._source
        read = st._read
        d['residual'] = read.lazy_worst(st._registers, self._worst) / read.L


_new_closed = object.__new__
_CLOSED_FORM = SolveMode.CLOSED_FORM


def closed_result(state: SlotState, residual: float, margin: float, defined: bool) -> ClosedResult:
    """A successful closed-form Result whose dicts and branch text are read off ``state``."""
    res: ClosedResult = _new_closed(ClosedResult)
    res._source = state
    res.success, res.solver = True, _CLOSED_FORM
    res.residual, res.margin, res.branch_defined = residual, margin, defined
    return res


def lazy_residual_result(
    state: SlotState, worst: float, margin: float, defined: bool
) -> ClosedLazyResidual:
    """closed_result whose residual too is read off ``state`` when asked, ``worst`` (m) the
    largest miss of the checks already made."""
    res: ClosedLazyResidual = _new_closed(ClosedLazyResidual)
    res._source, res._worst = state, worst
    res.success, res.solver = True, _CLOSED_FORM
    res.margin, res.branch_defined = margin, defined
    return res


class SlotState(State):
    """The State of a closed-form answer whose points and poses (name-keyed, as State holds
    them) are read off the run's registers on first use: most commands never ask (continuity
    reads them near a singular dyad only). Made by :func:`slot_state`; pickles as a plain
    State."""

    _read: Readout
    _registers: list[Any]
    # State's other fields are the class's defaults below (fewer stores per command)
    x_all = None
    det_sign = 0
    _points: dict[str, complex] | None = None
    _poses: LinkPoses | None = None

    @property
    def points(self) -> dict[str, complex]:
        if self._points is None:
            self._points = self._read.prog.points_closed(self._registers)
        return self._points

    @points.setter
    def points(self, value: dict[str, complex]) -> None:
        self._points = value

    @property
    def poses(self) -> LinkPoses:
        if self._poses is None:
            self._poses = self._read.prog.poses_closed(self._registers)
        return self._poses

    @poses.setter
    def poses(self, value: LinkPoses) -> None:
        self._poses = value

    def __reduce__(self) -> tuple[Any, ...]:
        return State, (
            self.values, None, self.points, self.poses, self.signs, 0, self.margins, None
        )  # fmt: skip


def slot_state(
    values: Values,
    signs: tuple[int, ...],
    margins: tuple[float, ...],
    read: Readout,
    registers: list[Any],
) -> SlotState:
    """The SlotState of a run's answer (a function: a class's call costs ~1/3 more)."""
    state: SlotState = _new_closed(SlotState)
    state.values, state.signs, state.margins = values, signs, margins
    state._read, state._registers = read, registers
    return state
