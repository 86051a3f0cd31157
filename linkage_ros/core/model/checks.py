"""Validation helpers: every error names the file, the key and the offending value."""

from __future__ import annotations

from collections.abc import Callable, Container, Mapping
from typing import Any, NoReturn

import numpy as np

from ..errors import SceneError
from ..mechanism import NAME_RE
from ..units import Quantity, Reading, UnitError, WrongUnit, degrees_warning, read_value

#: a validator's error: raises SceneError naming (key, message, value); never returns
Fail = Callable[..., NoReturn]

# ---- validation helpers ----------------------------------------------------------------------


class SceneContext:
    """The file being read and the warnings its reading collects (a bare angle beyond a full
    turn: likely degrees); ``warnings`` may be shared by the nested builds of one scene."""

    def __init__(self, source: str, warnings: list[str] | None = None):
        self.source = source
        self.warnings: list[str] = [] if warnings is None else warnings

    def warn(self, message: str | None) -> None:
        if message is not None and message not in self.warnings:
            self.warnings.append(message)

    def fail(
        self, key: str, message: str, value: object = None, has_value: bool = True
    ) -> NoReturn:
        if value is None and has_value:  # an absent key reads as None (and so does `key:`)
            what = f'it {message}' if message.startswith('must') else message
            message, has_value = f'is missing or empty: {what}', False
        raise SceneError(message, file=self.source, key=key, value=value, has_value=has_value)

    def reading(self, key: str, value: object, quantity: Quantity | None) -> Reading:
        """``value`` read in the unit grammar (core.units): a number, or a string with a unit
        of ``quantity``; refused naming ``key``."""
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            self.fail(key, f'must be a number{_unit_hint(quantity)}', value)
        try:
            return read_value(value, quantity)
        except WrongUnit as exc:
            self.fail(key, str(exc), value)
        except UnitError as exc:
            self.fail(key, f'must be a number{_unit_hint(quantity)}; this one {exc}', value)

    def number(
        self,
        key: str,
        value: object,
        *,
        quantity: Quantity | None,
        positive: bool = False,
        warn: bool = True,
    ) -> float:
        """A number in the SI unit of ``quantity`` (rad or m; None: a plain number, no unit).
        A bare angle beyond a full turn is read, with a warning (``warn``)."""
        reading = self.reading(key, value, quantity)
        if positive and not reading.value > 0:
            self.fail(key, 'must be > 0', value)
        if warn and quantity is Quantity.ANGLE:
            self.warn(degrees_warning(key, reading))
        return reading.value

    def xy(
        self, key: str, value: object, quantity: Quantity | None = Quantity.LENGTH
    ) -> np.ndarray:
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            self.fail(key, 'must be a list [x, y] of two numbers (m)', value)
        return np.array(
            [self.number(f'{key}[{i}]', v, quantity=quantity) for i, v in enumerate(value)]
        )

    def name(self, key: str, value: object) -> str:
        if not isinstance(value, str) or not NAME_RE.match(value):
            self.fail(key, 'must be a name of letters, digits and _ starting with a letter', value)
        return value

    @staticmethod
    def known(value: object, names: Container[str]) -> bool:
        """``value in names`` for a name; False (not TypeError) for a list or mapping."""
        return isinstance(value, str) and value in names

    def member(self, key: str, value: object, names: Container[str], message: str) -> str:
        """``value`` if it is one of ``names`` (a name, so typed str from here on), else a
        SceneError at ``key`` with ``message``."""
        if isinstance(value, str) and value in names:
            return value
        self.fail(key, message, value)

    def mapping(self, key: str, value: object) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            self.fail(key, 'must be a mapping', value)
        return value

    def only(self, key: str, data: Mapping[str, Any], allowed: set[str]) -> None:
        for k in data:
            if k not in allowed:
                self.fail(
                    f'{key}.{k}' if key else str(k),
                    f'unknown key; expected one of {sorted(allowed)}',
                    has_value=False,
                )


def _unit_hint(quantity: Quantity | None) -> str:
    return (
        ''
        if quantity is None
        else f' ({quantity.si_unit}, or with a unit: {", ".join(quantity.units)})'
    )


TOP_KEYS = {
    'name',
    'frame_id',
    'solver',
    'four_bar',
    'slider_crank',
    'points',
    'links',
    'ground',
    'sliders',
    'cylinders',
    'actuators',
    'outputs',
    'dimensions',
    'slots',
    'distances',
}
