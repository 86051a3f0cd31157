"""One entry point for forward and inverse position kinematics of a mechanism: :class:`Solver`
(``solver.py``; its Newton path in ``newton_path.py``), every answer a :class:`Result`
(``result.py``), many commands at once a :class:`BatchResult` (``batch.py``)."""

from __future__ import annotations

from .batch import BatchResult
from .result import (
    CLOSURE_LIMIT,
    METHODS,
    NEAR_SINGULAR_COND,
    WALK_BUDGET,
    Result,
    branch_identity_defined,
    branch_undefined_below,
)
from .solver import Solver

__all__ = [
    'CLOSURE_LIMIT',
    'METHODS',
    'NEAR_SINGULAR_COND',
    'WALK_BUDGET',
    'BatchResult',
    'Result',
    'Solver',
    'branch_identity_defined',
    'branch_undefined_below',
]
