"""A Result whose costly fields are read off its source when first asked: the one lazy-field
machinery of the closed form's answer (closed_form.ClosedResult: the dicts off its run's
registers) and a Newton answer's (newton_path.NewtonResult: the dicts off its link poses, cond
off J at the answer).

What decides an answer is set when it is made (success, residual, branch, margin, ...); most
callers read a few values, many none (a node publishing one output, a bench). A subclass names
its lazy fields (``_LAZY``: a subset of Result's fields) and says how its source fills them
(``_fill``); everything else is here. It reads, compares (equal to a Result of the same values),
copies and pickles (as a plain Result) as the Result it is."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import MISSING, fields
from typing import Any, ClassVar

from .result import Result

_FIELD_NAMES = tuple(f.name for f in fields(Result))


class _Lazy:
    """A field of a LazyResult made on first read: filled by its source, or another field's
    default. A non-data descriptor: once in the instance's ``__dict__`` (filled, or given) the
    value there is read, at the cost of any attribute."""

    def __init__(self, name: str, default: Callable[[], Any] | None = None):
        self.name, self.default = name, default

    def __get__(self, obj: LazyResult | None, owner: type | None = None) -> Any:
        if obj is None:
            return self
        d = _instance_dict(obj)
        if self.default is not None:
            value = d[self.name] = self.default()
            return value
        obj._fill(d, self.name)
        if d.keys() >= obj._LAZY:
            obj._source = None  # every field read: what they were read from is let go
        return d[self.name]


class LazyResult(Result):
    """A Result with fields read when first asked (see the module). Subclasses set ``_LAZY``
    and define ``_fill``; instances are made by ``object.__new__`` and their fields stored."""

    __slots__ = ('_source',)
    _source: Any  # None once every lazy field is filled
    #: the fields the source fills (every other field a Result makes by a factory is made from
    #: that factory on first read)
    _LAZY: ClassVar[frozenset[str]] = frozenset()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for f in fields(Result):
            if f.name in cls._LAZY:
                setattr(cls, f.name, _Lazy(f.name))
            elif f.default_factory is not MISSING:
                setattr(cls, f.name, _Lazy(f.name, f.default_factory))

    def _fill(self, d: dict[str, Any], name: str) -> None:
        """Put field ``name`` (one of _LAZY; with it any others its source makes at the same
        time) into ``d``, the instance's own dict, keeping every value already there."""
        raise NotImplementedError

    @property
    def __dict__(self) -> dict[str, Any]:  # type: ignore[override]
        """The instance's attributes, the lazy ones filled first: ``vars(result)`` and
        ``Result(**result.__dict__)`` see every value (attribute reads do not come here)."""
        d: dict[str, Any] = _instance_dict(self)
        if not d.keys() >= self._LAZY:
            for name in self._LAZY:
                if name not in d:
                    self._fill(d, name)
            self._source = None
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


#: an instance's own attribute dict (LazyResult.__dict__ fills it first)
_instance_dict = Result.__dict__['__dict__'].__get__
