"""The Result of a lean Newton answer (newton_lean.py), its costly fields read when first asked.

What decides the answer is set when it is made: success, residual, iterations, solver, branch,
branch_defined, margin. The name-keyed dicts (inputs, targets, joints, links, points) are read
off the answer's link poses by the compiled solve's ResultAssembler (what build_result reads
them with), and ``cond`` off the dense J at the answer by the dense path's own function
(scalar.answer_cond), on first read: most callers read a few values, many none (a node
publishing one output, a bench). It reads, compares (equal to a Result of the same values),
copies and pickles (as a plain Result) as the Result it is. The same contract as the closed
form's ClosedResult (closed_form.py), whose fields come from its own registers."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import MISSING, fields
from typing import Any

from ..execute import LinkPoses
from ..newton.scalar import answer_cond
from ..newton.tables import LoopTables
from ..ops import SCALAR
from .compiled import CompiledSolve, Values
from .result import Result

#: the Result fields read off the answer on first use: the dicts (one fill), then cond
_DICTS = ('inputs', 'targets', 'joints', 'links', 'points')
_LAZY_SET = frozenset((*_DICTS, 'cond'))
_FIELD_NAMES = tuple(f.name for f in fields(Result))


class NewtonSource:
    """What a NewtonResult's lazy fields are read from: the solved configuration (poses,
    points), the command and J's varying entries at the answer."""

    __slots__ = ('c', 'poses', 'points', 'vals', 'tables', 'jv')

    def __init__(
        self,
        c: CompiledSolve,
        poses: LinkPoses,
        points: dict[str, complex],
        vals: Values,
        tables: LoopTables,
        jv: list[float],
    ):
        self.c, self.poses, self.points, self.vals = c, poses, points, vals
        self.tables, self.jv = tables, jv

    def fill(self, d: dict[str, Any]) -> None:
        """The dicts into ``d`` (a Result's ``__dict__``) where it has none of its own."""
        got = self.c.assembler(self.poses.phi)(SCALAR, self.poses, self.vals)
        new: dict[str, Any] = {
            'inputs': got.inputs,
            'targets': {},
            'joints': got.joints,
            'links': got.links,
            'points': {p: (v.real, v.imag) for p, v in self.points.items()},
        }
        new.update(d)  # (what the Result was given meanwhile stays)
        d.update(new)

    def cond(self) -> float | None:
        """The condition number build_result would report (None where not finite)."""
        c = answer_cond(self.tables, self.jv)
        return c if math.isfinite(c) else None


class _Lazy:
    """A field of a NewtonResult made on first read: the dicts, cond, or another field's
    default. A non-data descriptor: once in the instance's ``__dict__`` (filled, or given) the
    value there is read, at the cost of any attribute."""

    def __init__(self, name: str, default: Callable[[], Any] | None = None):
        self.name, self.default = name, default

    def __get__(self, obj: NewtonResult | None, owner: type | None = None) -> Any:
        if obj is None:
            return self
        d = _instance_dict(obj)
        if self.default is not None:
            value = d[self.name] = self.default()
        elif self.name == 'cond':
            value = d['cond'] = obj._source.cond()
        else:
            obj._source.fill(d)
            value = d[self.name]
        return value


class NewtonResult(Result):
    """A lean Newton answer (see the module)."""

    __slots__ = ('_source',)
    _source: NewtonSource

    @property
    def __dict__(self) -> dict[str, Any]:  # type: ignore[override]
        """The instance's attributes, the lazy ones filled first: ``vars(result)`` and
        ``Result(**result.__dict__)`` see every value (attribute reads do not come here)."""
        d: dict[str, Any] = _instance_dict(self)
        if not d.keys() >= _LAZY_SET:
            if 'cond' not in d:
                d['cond'] = self._source.cond()
            if not d.keys() >= _LAZY_SET:
                self._source.fill(d)
        return d

    def _values(self) -> tuple[Any, ...]:
        return tuple(getattr(self, n) for n in _FIELD_NAMES)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Result):
            return self._values() == tuple(getattr(other, n) for n in _FIELD_NAMES)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # (a Result is mutable: unhashable)

    def __reduce__(self) -> tuple[Any, ...]:
        return Result, self._values()


for _f in fields(Result):  # the dicts, cond, and every field made with a factory: on first read
    if _f.name in _LAZY_SET:
        setattr(NewtonResult, _f.name, _Lazy(_f.name))
    elif _f.default_factory is not MISSING:
        setattr(NewtonResult, _f.name, _Lazy(_f.name, _f.default_factory))


_new = object.__new__
#: an instance's own attribute dict (NewtonResult.__dict__ fills it first)
_instance_dict = Result.__dict__['__dict__'].__get__


def newton_result(
    source: NewtonSource,
    *,
    residual: float,
    iterations: int,
    branch: str,
    branch_defined: bool,
    margin: float,
) -> NewtonResult:
    """A successful Newton Result whose dicts and cond are read off ``source`` when asked."""
    res: NewtonResult = _new(NewtonResult)
    res._source = source
    res.success, res.reason, res.solver = True, None, 'newton'
    res.residual, res.iterations, res.margin = residual, iterations, margin
    res.branch, res.branch_defined = branch, branch_defined
    return res
