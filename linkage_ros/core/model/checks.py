"""Validation helpers: every error names the file, the key and the offending value."""

from __future__ import annotations

import math
from collections.abc import Callable, Container, Mapping
from typing import Any, NoReturn

import numpy as np

from ..errors import SceneError
from .mechanism import NAME_RE

#: a validator's error: raises SceneError naming (key, message, value); never returns
Fail = Callable[..., NoReturn]

# ---- validation helpers ----------------------------------------------------------------------


class _Ctx:
    def __init__(self, source: str):
        self.source = source

    def fail(
        self, key: str, message: str, value: object = None, has_value: bool = True
    ) -> NoReturn:
        raise SceneError(message, file=self.source, key=key, value=value, has_value=has_value)

    def number(self, key: str, value: object, *, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, 'must be a number', value)
        v = float(value)
        if not math.isfinite(v):
            self.fail(key, 'must be finite', value)
        if positive and not v > 0:
            self.fail(key, 'must be > 0', value)
        return v

    def xy(self, key: str, value: object) -> np.ndarray:
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            self.fail(key, 'must be a list [x, y] of two numbers (m)', value)
        return np.array([self.number(f'{key}[{i}]', v) for i, v in enumerate(value)])

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
