"""Shared by the numerical stability tests (test_stability*.py): the tolerances, the double
rocker, triple rocker and crank-rocker, the methods, and the checks that every float of a Result
is finite and of an answer's angle errors against ``oracles`` (50-digit mpmath).
"""

import math

import numpy as np
import oracles as orc

EPS = 2.0**-52

TIGHT = 1e-12


DOUBLE_ROCKER = (4.0, 3.0, 1.5, 4.5)  # Grashof, shortest is the coupler: input in two arcs

TRIPLE_ROCKER = (4.0, 3.0, 5.0, 2.5)  # non-Grashof, input range symmetric about pi

CRANK_ROCKER = (4.0, 1.5, 4.5, 3.0)

METHODS = ['closed_form', 'newton']


def assert_finite(result):
    """Every float anywhere in Result.to_dict() is finite (None is allowed)."""
    bad = []

    def walk(obj, path):
        if isinstance(obj, dict):
            for k, v in obj.items():
                walk(v, f'{path}.{k}')
        elif isinstance(obj, (list, tuple)):
            for i, v in enumerate(obj):
                walk(v, f'{path}[{i}]')
        elif (isinstance(obj, float) and not math.isfinite(obj)) or (
            isinstance(obj, (np.floating, np.ndarray)) and not np.all(np.isfinite(obj))
        ):
            bad.append(path)

    walk(result.to_dict(), '')
    assert not bad, (bad, result)
    if not result.success:
        assert isinstance(result.reason, str) and result.reason.strip()


def angle_errors(res, want):
    return max(
        orc.angle_error(res.links['coupler'], want['theta3']),
        orc.angle_error(res.links['rocker'], want['theta4']),
    )
