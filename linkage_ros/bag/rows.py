"""Rows of a run of commands as the solvers take them (one command, finite rows)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


def command_row(columns: Mapping[str, Any], i: int) -> dict[str, Any]:
    """Row i of command columns as one command: floats, (x, y) for a point."""
    out: dict[str, Any] = {}
    for nm, c in columns.items():
        v = c[i]
        out[nm] = (float(v[0]), float(v[1])) if np.ndim(v) else float(v)
    return out


def finite_rows(cols: Mapping[str, Any], m: int) -> np.ndarray:
    """(m,) bool: every value of the row is finite."""
    f = np.ones(m, bool)
    for c in cols.values():
        f &= np.all(np.isfinite(np.asarray(c, float).reshape(m, -1)), axis=1)
    return f
