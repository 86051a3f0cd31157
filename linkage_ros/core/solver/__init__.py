"""One entry point for forward and inverse position kinematics of a mechanism: :class:`Solver`
(``solver.py``), a facade over a frozen :class:`CompiledSolve` (``compiled.py``, made by
``compiling.py``) and the caller's :class:`Continuity` (``continuity.py``); the paths are
functions over the two: one command (``one.py``, its Newton part ``newton_path.py``), many
commands (``batch.py``: :class:`BatchResult`), every assembly mode (``modes.py``), answers read
back (``reading.py``). Every answer is a :class:`Result` (``result.py``); many answers as
columns with each row's status are a :class:`ResultTable` (``table.py``)."""

from __future__ import annotations

from .batch import BatchResult
from .compiled import CompiledSolve, SolveMode
from .compiling import compile_solve
from .continuity import Branch, BranchRule, Continuity
from .result import (
    CLOSURE_LIMIT,
    METHODS,
    NEAR_SINGULAR_COND,
    WALK_BUDGET,
    Effort,
    Result,
    SolveMethod,
    branch_identity_defined,
    branch_undefined_below,
)
from .solver import Solver
from .table import ResultTable

__all__ = [
    'CLOSURE_LIMIT',
    'METHODS',
    'NEAR_SINGULAR_COND',
    'WALK_BUDGET',
    'BatchResult',
    'Branch',
    'BranchRule',
    'CompiledSolve',
    'Continuity',
    'Effort',
    'SolveMethod',
    'SolveMode',
    'compile_solve',
    'Result',
    'ResultTable',
    'Solver',
    'branch_identity_defined',
    'branch_undefined_below',
]
