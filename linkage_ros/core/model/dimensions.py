"""Dimensions stated by name: the distance between two points of a link (``crank.O2-A``) or a
slider's offset (``slide.offset``), given in the scene's ``dimensions`` key, on the command line
(``--dimension``) or through the API (``Scene.from_yaml(path, dimensions=...)``).

A stated dimension is used exactly; the drawn reference pose then only chooses the assembly
mode. The shortcut forms take them as their own parameters (``crank.O2-A`` is ``four_bar.crank``);
the general form is redrawn by :mod:`.redraw` and its solver reads the stated lengths.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import SceneError, echo
from ..mechanism import SceneForm
from ..units import Quantity, UnitError, expect, parse_text, read_value

#: ``link.P-Q`` (a distance, m) or ``slider.offset`` (m)
_DISTANCE_RE = re.compile(
    r'^([A-Za-z][A-Za-z0-9_]*)\.([A-Za-z][A-Za-z0-9_]*)-([A-Za-z][A-Za-z0-9_]*)$'
)
_OFFSET_RE = re.compile(r'^([A-Za-z][A-Za-z0-9_]*)\.offset$')


@dataclass(frozen=True)
class LinkDistance:
    """The distance (m) between points ``p`` and ``q`` of ``link``."""

    link: str
    p: str
    q: str

    @property
    def name(self) -> str:
        return f'{self.link}.{self.p}-{self.q}'


@dataclass(frozen=True)
class SliderOffset:
    """The signed distance (m) of slider ``slider``'s line from its origin, positive to the left
    of its direction."""

    slider: str

    @property
    def name(self) -> str:
        return f'{self.slider}.offset'


Dimension = LinkDistance | SliderOffset

#: the shortcut forms' own length parameters, by dimension name
SHORTCUT_KEYS = {
    SceneForm.FOUR_BAR: {
        'ground.O2-O4': 'ground',
        'crank.O2-A': 'crank',
        'coupler.A-B': 'coupler',
        'rocker.O4-B': 'rocker',
    },
    SceneForm.SLIDER_CRANK: {'crank.O2-A': 'crank', 'rod.A-B': 'rod', 'slider.offset': 'offset'},
}


def parse_name(name: object) -> Dimension | None:
    """The dimension a name states, or None if it is not of the form link.P-Q / slider.offset."""
    if not isinstance(name, str):
        return None
    m = _OFFSET_RE.match(name)
    if m:
        return SliderOffset(m.group(1))
    m = _DISTANCE_RE.match(name)
    if m and m.group(2) != m.group(3):
        return LinkDistance(*m.groups())
    return None


def parse_assignment(text: str) -> tuple[str, float]:
    """``NAME=VALUE`` (the command line's and the node parameter's form) -> (name, value); a
    ValueError names what is wrong."""
    name, sep, raw = text.partition('=')
    name = name.strip()
    if not sep or not name:
        raise ValueError(f'{echo(text)} is not NAME=VALUE (e.g. crank.O2-A=0.016 or =16mm)')
    try:  # the unit grammar of core.units: a length, m unless it says mm or cm
        reading = expect(parse_text(raw), Quantity.LENGTH)
    except UnitError as exc:
        raise ValueError(f'{name}: {echo(raw.strip())} {exc}') from None
    return name, reading.value


def overrides(pairs: Sequence[tuple[str, float]]) -> dict[str, float] | None:
    """NAME=VALUE overrides as a mapping (None for none); ValueError for a name given twice
    (the later would silently win)."""
    out: dict[str, float] = {}
    for name, value in pairs:
        if name in out:
            raise ValueError(
                f'dimension {name} is given twice ({out[name]:g} and {value:g}): give it once'
            )
        out[name] = value
    return out or None


def merge(source: str, stated: object, overrides: Mapping[str, float] | None) -> dict[str, float]:
    """The scene's ``dimensions`` mapping with ``overrides`` on top (an override replaces the
    scene's value of the same name), each checked to be a finite number (a distance > 0)."""
    out: dict[str, float] = {}
    if stated is not None and not isinstance(stated, Mapping):
        raise SceneError(
            'must map dimension names (link.P-Q or slider.offset) to m',
            file=source,
            key='dimensions',
            value=stated,
        )
    for where, items in (('dimensions', stated or {}), ('override', overrides or {})):
        for name, value in items.items():
            key = f'dimensions.{name}' if where == 'dimensions' else f'{where} {name}'
            dim = parse_name(name)
            if dim is None:
                raise SceneError(
                    'a dimension name is link.P-Q (the distance between two points of a link) '
                    'or slider.offset',
                    file=source,
                    key=key,
                    value=name,
                )
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                v = float(value)  # NaN and inf: refused below as not a length
            else:
                try:  # '16mm': the unit grammar of core.units
                    v = read_value(value, Quantity.LENGTH).value
                except UnitError as exc:
                    raise SceneError(
                        f'must be a number (m, or with a unit: m, cm, mm); this one {exc}',
                        file=source,
                        key=key,
                        value=value,
                    ) from None
            if not math.isfinite(v) or (isinstance(dim, LinkDistance) and not v > 0):
                what = 'a finite number' if isinstance(dim, SliderOffset) else 'a length > 0'
                raise SceneError(f'must be {what} (m)', file=source, key=key, value=value)
            out[str(name)] = v
    return out


def apply_to_shortcut(
    source: str, form: SceneForm, data: Mapping[str, Any], dims: Mapping[str, float]
) -> dict[str, Any]:
    """A shortcut scene (``form``: a shortcut's, under its key) with its length parameters
    replaced by the stated dimensions."""
    keys = dict(SHORTCUT_KEYS[form])
    key = form.value
    spec = dict(data[key]) if isinstance(data[key], Mapping) else data[key]
    cp = spec.get('coupler_point') if form is SceneForm.FOUR_BAR else None
    if isinstance(cp, Mapping):  # the coupler point's distance from A
        keys[f'coupler.A-{cp.get("name", "P")}'] = 'coupler_point'
    for name, value in dims.items():
        if name not in keys:
            raise SceneError(
                f'is not a dimension of the {key} shortcut (its dimensions: '
                f'{", ".join(keys)}); for others write the scene in the general form',
                file=source,
                key=f'dimensions.{name}',
                value=value,
            )
        if form is SceneForm.FOUR_BAR and keys[name] == 'ground' and 'pivots' in spec:
            raise SceneError(
                'the four_bar gives its ground by pivots: move O2 or O4 instead',
                file=source,
                key=f'dimensions.{name}',
                value=value,
            )
        if keys[name] == 'coupler_point':
            spec['coupler_point'] = {**cp, 'distance': value}  # type: ignore[dict-item]
        else:
            spec[keys[name]] = value
    out = {k: v for k, v in data.items() if k != 'dimensions'}
    out[key] = spec
    return out


#: a stated length this many times its drawn one (or its inverse) is a unit slip, likely
_UNIT_SLIP = 100.0


def unit_slips(points: Mapping[str, Any], dims: Mapping[str, float]) -> list[str]:
    """'crank.O2-A = 16 m is 160x its drawn 0.1 m: ...' for each stated link length far from
    the drawing's (``points``: the drawn positions, m; 16 meant as mm)."""
    slips = []
    for name, value in dims.items():
        dim = parse_name(name)
        if not isinstance(dim, LinkDistance):
            continue
        p, q = points.get(dim.p), points.get(dim.q)
        if p is None or q is None:
            continue
        length = math.dist(p, q)
        if length > 0 and not 1 / _UNIT_SLIP < value / length < _UNIT_SLIP:
            slips.append(
                f'{name} = {value:.6g} m is {value / length:.3g}x its drawn {length:.3g} m: '
                f'lengths are in m (write {value:g}mm for millimetres)'
            )
    return slips
