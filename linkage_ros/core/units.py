"""The one unit grammar of scene files, the command line and the node's parameters.

A value is a number, optionally followed by a unit: ``60deg``, ``0.5rad``, ``10mm``, ``0.1m``
(spaces between are allowed: ``60 deg``). An angle takes ``rad`` or ``deg`` and is stored in
radians; a length takes ``m``, ``cm`` or ``mm`` and is stored in metres. A bare number is in the
SI unit (rad or m). A unit where the other quantity, or no unit at all, is meant is refused.

A bare angle beyond 2 pi (a full turn) is almost always degrees read as radians: the loaders
warn about it (:func:`degrees_warning`, :func:`span_warning`) instead of refusing it, because a
multi-turn value can be meant.
"""

from __future__ import annotations

import enum
import math
import re
from dataclasses import dataclass


class Quantity(enum.Enum):
    """What a value measures: its units and the SI unit it is stored in."""

    ANGLE = 'angle'
    LENGTH = 'length'

    @property
    def si_unit(self) -> str:
        return 'rad' if self is Quantity.ANGLE else 'm'

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(u for u, (q, _) in UNITS.items() if q is self)


#: unit -> (the quantity it measures, its size in the quantity's SI unit)
UNITS: dict[str, tuple[Quantity, float]] = {
    'rad': (Quantity.ANGLE, 1.0),
    'deg': (Quantity.ANGLE, math.pi / 180.0),
    'm': (Quantity.LENGTH, 1.0),
    'cm': (Quantity.LENGTH, 0.01),
    'mm': (Quantity.LENGTH, 0.001),
}

#: a full turn (rad): a bare angle, or a limit span, beyond it is likely degrees
FULL_TURN = 2.0 * math.pi

# a decimal number (no '_' digit groups: float() reads 1_0 as 10, a typo must not pass), then
# an optional unit of letters
_VALUE_RE = re.compile(
    r'^\s*([-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?)\s*([A-Za-z]+)?\s*$'
)


class UnitError(ValueError):
    """A value that is not a number, or has a unit not meant where it stands. The message
    names neither the key nor the value, and reads after the value (``'60degree' has an unknown
    unit ...``): the caller adds them (a scene key and ``(got ...)``, an option and its text)."""


class WrongUnit(UnitError):
    """A number with a unit of another quantity than the one meant (``60deg`` for a length)."""


@dataclass(frozen=True)
class Reading:
    """A value as read: ``value`` in the SI unit of ``quantity`` (rad or m); ``unit`` the unit
    written, None for a bare number (whose quantity is where it stands)."""

    value: float
    unit: str | None = None

    @property
    def quantity(self) -> Quantity | None:
        """The quantity the written unit measures, None for a bare number."""
        return None if self.unit is None else UNITS[self.unit][0]


def _units_text(quantity: Quantity | None) -> str:
    if quantity is None:
        return 'a plain number, without a unit'
    article = 'an' if quantity is Quantity.ANGLE else 'a'
    return f'{article} {quantity.value} ({quantity.si_unit}; units {", ".join(quantity.units)})'


def parse_text(text: str) -> Reading:
    """``'60deg'`` -> Reading(1.047..., 'deg'); ``'0.5'`` -> Reading(0.5, None). Any known unit;
    :func:`expect` checks it against the quantity meant. UnitError if not a finite number."""
    m = _VALUE_RE.match(text)
    if m is None:
        if text.strip().lower().lstrip('+-') in ('inf', 'infinity', 'nan'):
            raise UnitError('is not a finite number')
        raise UnitError('is not a number')  # also 1_0: float() reads it as 10, a typo
    number, unit = m.group(1), m.group(2)
    value = float(number)
    if not math.isfinite(value):  # 1e400
        raise UnitError('is not a finite number')
    if unit is None:
        return Reading(value)
    if unit not in UNITS:
        folded = unit.lower()
        hint = f' (did you mean {folded!r}?)' if folded in UNITS else ''
        raise UnitError(
            f'has an unknown unit {unit!r}{hint} (angles take rad or deg, lengths m, cm or mm)'
        )
    scaled = value * UNITS[unit][1]
    if not math.isfinite(scaled):
        raise UnitError('is not a finite number')
    return Reading(scaled, unit)


def expect(reading: Reading, quantity: Quantity | None) -> Reading:
    """``reading`` if its unit measures ``quantity`` (a bare number always does); UnitError
    naming both otherwise. ``quantity`` None: a plain number is meant, no unit."""
    if reading.unit is None or reading.quantity is quantity:
        return reading
    assert reading.quantity is not None
    raise WrongUnit(
        f'has a unit of {reading.quantity.value} ({reading.unit!r}), but '
        f'{_units_text(quantity)} is meant'
    )


def read_value(value: object, quantity: Quantity | None) -> Reading:
    """A scene value: a number (int or float, not bool) in the SI unit, or a string with a
    unit of ``quantity`` (``'60deg'``). UnitError says what is wrong, without the key."""
    if isinstance(value, bool):
        raise UnitError('is not a number')
    if isinstance(value, (int, float)):
        v = float(value)
        if not math.isfinite(v):
            raise UnitError('is not a finite number')
        return Reading(v)
    if isinstance(value, str):
        reading = parse_text(value)
        if reading.unit is None:  # a quoted number: YAML would have read it as one unquoted
            raise UnitError(
                'is a quoted number: write it unquoted'
                + ('' if quantity is None else f' or with a unit ({", ".join(quantity.units)})')
            )
        return expect(reading, quantity)
    raise UnitError('is not a number')


def degrees_warning(what: str, reading: Reading) -> str | None:
    """A warning for a bare angle beyond a full turn (likely degrees read as radians), or None.
    ``what`` names where it stands (a scene key, ``--set crank``)."""
    if reading.unit is not None or abs(reading.value) <= FULL_TURN:
        return None
    return (
        f'{what} = {reading.value:g} is read as {reading.value:g} rad '
        f'({reading.value / FULL_TURN:.3g} turns); if degrees are meant, write '
        f'{reading.value:g}deg'
    )


def span_warning(what: str, low: Reading, high: Reading) -> str | None:
    """A warning for angle limits of bare numbers spanning more than a full turn (such limits
    do not limit: an angle compares on the circle), or None."""
    span = high.value - low.value
    if (low.unit is not None and high.unit is not None) or span <= FULL_TURN:
        return None
    return (
        f'{what} span {span:g} rad ({span / FULL_TURN:.3g} turns), more than a full turn, so '
        f'they do not limit the angle; if degrees are meant, write {low.value:g}deg and '
        f'{high.value:g}deg'
    )
