"""Bounded, safe reading of a description's XML text (URDF or SDFormat) and the attribute
readers both formats share."""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import numpy as np

from .records import DescriptionError, Limits, transform

#: the largest description read (bytes): expanded URDFs of whole robots are a few hundred kB
MAX_DESCRIPTION_BYTES = 4 << 20
#: the most links plus joints plus closures a description may have
MAX_ELEMENTS = 5000

_COMMENT = re.compile(r'<!--.*?-->', re.DOTALL)
#: the namespaces xacro files declare (the ROS wiki's addresses over the years)
_XACRO_NAMESPACES = (
    'http://ros.org/wiki/xacro',
    'http://www.ros.org/wiki/xacro',
    'http://wiki.ros.org/xacro',
)


def parse_xml(text: str, source: str) -> ET.Element:
    """The root element of ``text``, refusing what a description never needs and an attacker
    would use: a DOCTYPE (entity expansion), more than MAX_DESCRIPTION_BYTES, unexpanded xacro."""
    if len(text.encode('utf-8', 'surrogatepass')) > MAX_DESCRIPTION_BYTES:
        raise DescriptionError(
            f'larger than {MAX_DESCRIPTION_BYTES} bytes, the limit for a robot description',
            file=source,
        )
    if re.search(r'<!DOCTYPE|<!ENTITY', text, re.IGNORECASE):
        raise DescriptionError(
            'a DOCTYPE or entity declaration is not allowed in a robot description '
            '(entities expand without bound); remove it',
            file=source,
        )
    # comments go before parsing: real descriptions put '--' in them (Drake's ASCII figures),
    # which tinyxml2 and urdfdom accept and expat refuses
    text = _COMMENT.sub('', text)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise DescriptionError(f'malformed XML: {exc}', file=source) from None
    xacro = [
        'xacro:' + el.tag.split('}', 1)[1]
        for el in root.iter()
        if isinstance(el.tag, str)
        and el.tag.startswith(tuple('{' + ns + '}' for ns in _XACRO_NAMESPACES))
    ]
    unexpanded = xacro or [
        f'{el.tag} {k}="{v}"'
        for el in root.iter()
        for k, v in el.attrib.items()
        if '${' in v or '$(' in v
    ]
    if unexpanded:
        first = unexpanded[0]
        raise DescriptionError(
            f'an unexpanded xacro file ({first!s:.60} ...): run xacro on it first '
            '(xacro robot.urdf.xacro > robot.urdf) and give the result',
            file=source,
        )
    count = sum(1 for el in root.iter() if el.tag in ('link', 'joint', 'loop', 'constraint'))
    if count > MAX_ELEMENTS:
        raise DescriptionError(
            f'{count} links, joints and closures; at most {MAX_ELEMENTS} are read', file=source
        )
    return root


def numbers(
    text: str | None, n: int, source: str, where: str, default: tuple[float, ...]
) -> tuple[float, ...]:
    """``n`` finite numbers separated by white space, or ``default`` when absent."""
    if text is None:
        return default
    parts = text.split()
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise DescriptionError(f'expects {n} finite numbers', file=source, key=where, value=text)
    return values


def origin_of(el: ET.Element | None, source: str, where: str) -> np.ndarray:
    """The transform of an ``<origin xyz rpy>`` element (identity when absent)."""
    if el is None:
        return np.eye(4)
    xyz = numbers(el.get('xyz'), 3, source, f'{where} xyz', (0.0, 0.0, 0.0))
    rpy = numbers(el.get('rpy'), 3, source, f'{where} rpy', (0.0, 0.0, 0.0))
    return transform(xyz, rpy)  # type: ignore[arg-type]


def unit_axis(
    text: str | None,
    source: str,
    where: str,
    default: tuple[float, ...] = (1.0, 0.0, 0.0),
) -> np.ndarray:
    v = np.array(numbers(text, 3, source, where, default))
    norm = float(np.linalg.norm(v))
    if not norm > 0:
        raise DescriptionError('an axis must not be zero', file=source, key=where, value=text)
    return v / norm


#: the words of an XML bool (URDF+'s independent, SDFormat's bools), read in any case
_TRUE, _FALSE = ('true', '1'), ('false', '0')


def optional_bool(text: str | None, source: str, where: str) -> bool | None:
    """An XML bool attribute or element text: true or 1, false or 0 (any case; None where it
    is absent); anything else is refused naming it (an SDF degrees="1" was read as radians)."""
    if text is None:
        return None
    word = text.strip().lower()
    if word not in _TRUE + _FALSE:
        raise DescriptionError(
            f'{where}: {text!r} is not a bool (true, false, 1 or 0)', file=source, key=where
        )
    return word in _TRUE


def optional_number(text: str | None, source: str, where: str) -> float | None:
    if text is None or not text.strip():
        return None
    return numbers(text, 1, source, where, ())[0]


def upside_down(lower: float | None, upper: float | None) -> str | None:
    """Why limits ``lower`` > ``upper`` (a URDF <limit>, a closure file's limits) allow no
    value, or None."""
    if lower is not None and upper is not None and lower > upper:
        return f'lower {lower:g} is above upper {upper:g}: no value fits; swap them'
    return None


def limits_of(lower_text: str | None, upper_text: str | None, source: str, where: str) -> Limits:
    """A joint's ``<limit>`` lower and upper (rad or m; either may be missing); a lower above
    the upper is refused (it was read as the interval between them, silently)."""
    lower = optional_number(lower_text, source, f'{where} limit lower')
    upper = optional_number(upper_text, source, f'{where} limit upper')
    why = upside_down(lower, upper)
    if why:
        raise DescriptionError(f'limit {why}', file=source, key=f'{where} limit')
    return Limits(lower, upper)


def required(el: ET.Element, attr: str, source: str, where: str) -> str:
    value = el.get(attr)
    if value is None or not value.strip():
        raise DescriptionError(f'has no {attr!r} attribute', file=source, key=where)
    return value.strip()
