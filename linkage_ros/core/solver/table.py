"""One results table: the answers to n commands as columns, with each row's status (ok, or
refused and why).

A batch solve produces it (``BatchResult.table()``), ``linkage bag`` fills it row by row and
from batches (its replay), and the bag's CSV, Parquet and result-bag writers read it. The one
rule of a refused row lives here: ``ok`` False, its ``reason``, NaN in every number column
(residual, margin, cond, joints, points, links; inputs as commanded where the filler knows the
command, else NaN), branch and solver ''.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, Self

import numpy as np

from .result import Result, branch_identity_defined, branch_text


class BatchColumns(Protocol):
    """What a table takes from a batch solve (core.solver.batch.BatchResult): per-row arrays
    with the solve's own zeros in refused rows."""

    ok: np.ndarray
    reason: list[str | None]
    residual: np.ndarray
    margin: np.ndarray
    iterations: np.ndarray
    signs: np.ndarray
    solver: str
    inputs: dict[str, np.ndarray]
    joints: dict[str, np.ndarray]
    points: dict[str, np.ndarray]
    links: dict[str, np.ndarray]


def _nan(n: int) -> np.ndarray:
    return np.full(n, np.nan)


@dataclass(eq=False)  # numpy columns: no field-wise ==
class ResultTable:
    """Per-row answers of n commands (module docstring: a refused row). Branch and solver
    are codes into ``branch_names`` / ``solver_names`` (code 0: '', a refused row's)."""

    ok: np.ndarray  # (n,) bool
    reason: list[str | None]  # why each refused row was refused (None: answered, or not yet)
    residual: np.ndarray
    margin: np.ndarray
    branch_code: np.ndarray  # (n,) int32 index into branch_names
    branch_defined: np.ndarray  # (n,) bool
    iterations: np.ndarray  # (n,) int64
    cond: np.ndarray  # NaN where the solve gave no condition number
    solver_code: np.ndarray  # (n,) int32 index into solver_names
    inputs: dict[str, np.ndarray]  # actuator values (rad, m)
    joints: dict[str, np.ndarray]  # joint values (rad, m)
    points: dict[str, np.ndarray]  # (n, 2) positions (m)
    links: dict[str, np.ndarray] = field(default_factory=dict)  # link angles (rad), if kept
    branch_names: list[str] = field(default_factory=lambda: [''])
    solver_names: list[str] = field(default_factory=lambda: [''])

    @classmethod
    def blank(
        cls,
        n: int,
        inputs: Iterable[str],
        joints: Iterable[str],
        points: Iterable[str],
        links: Iterable[str] = (),
    ) -> Self:
        """n rows not answered yet: each as a refused row (NaN) with no reason."""
        return cls(
            ok=np.zeros(n, bool),
            reason=[None] * n,
            residual=_nan(n),
            margin=_nan(n),
            branch_code=np.zeros(n, np.int32),
            branch_defined=np.ones(n, bool),
            iterations=np.zeros(n, np.int64),
            cond=_nan(n),
            solver_code=np.zeros(n, np.int32),
            inputs={a: _nan(n) for a in inputs},
            joints={j: _nan(n) for j in joints},
            points={p: np.full((n, 2), np.nan) for p in points},
            links={l: _nan(n) for l in links},
        )

    @classmethod
    def for_mechanism(cls, mech: Any, n: int) -> Self:
        """A blank table of n rows with a column per actuator, joint and point of ``mech``."""
        return cls.blank(n, mech.actuators, mech.joint_names, mech.points)

    @classmethod
    def from_batch(cls, batch: BatchColumns) -> Self:
        """A batch solve's answers (its columns, links included), refused rows NaN."""
        n = int(np.shape(batch.ok)[0])
        table = cls.blank(n, batch.inputs, batch.joints, batch.points, batch.links)
        table.put_batch(0, batch, n)
        return table

    @property
    def n(self) -> int:
        return int(self.ok.size)

    # -- the string columns ------------------------------------------------------------------
    @staticmethod
    def _code(table: list[str], name: str) -> int:
        try:
            return table.index(name)
        except ValueError:
            table.append(name)
            return len(table) - 1

    def branch_code_of(self, name: str) -> int:
        return self._code(self.branch_names, name)

    def solver_code_of(self, name: str) -> int:
        return self._code(self.solver_names, name)

    def branch(self, i: int) -> str:
        return self.branch_names[int(self.branch_code[i])]

    def solver(self, i: int) -> str:
        return self.solver_names[int(self.solver_code[i])]

    # -- filling -----------------------------------------------------------------------------
    def put_result(self, g: int, r: Result) -> None:
        """Row g from one solve's Result (a refusal: its reason and, of its numbers, the
        inputs it was given)."""
        for nm, v in r.inputs.items():
            if nm in self.inputs:
                self.inputs[nm][g] = v
        if not r.success:
            self.reason[g] = r.reason
            return
        self.ok[g] = True
        self.residual[g] = r.residual
        self.margin[g] = r.margin if r.margin is not None else np.nan
        self.branch_code[g] = self.branch_code_of(r.branch)
        self.branch_defined[g] = r.branch_defined
        self.iterations[g] = r.iterations
        self.cond[g] = r.cond if r.cond is not None else np.nan
        self.solver_code[g] = self.solver_code_of(r.solver)
        for columns, got in ((self.joints, r.joints), (self.links, r.links)):
            for nm, v in got.items():
                if nm in columns:
                    columns[nm][g] = v
        for nm, p in r.points.items():
            if nm in self.points:
                self.points[nm][g] = p

    def put_batch(
        self,
        g0: int,
        batch: BatchColumns,
        take: int,
        reasons: Mapping[int, str] | None = None,
    ) -> None:
        """Rows g0 .. g0 + take - 1 from the first ``take`` rows of a batch solve; a refused
        row's reason from ``reasons`` (by batch row; default the batch's own), its inputs
        left as they are (the command, where the caller put it)."""
        sl = slice(g0, g0 + take)
        ok = np.asarray(batch.ok[:take], bool)
        if reasons is None:
            reasons = {
                i: batch.reason[i] or 'refused' for i in np.flatnonzero(~ok).tolist()
            }  # fmt: skip
        for i, why in reasons.items():
            if i < take:
                self.reason[g0 + i] = why
        self.ok[sl] = ok
        # np.where(ok, answer, refused): the answer itself where every row is ok (the common
        # batch: one pass, not a where pass and a copy)
        every = bool(np.all(ok))

        def pick(answer: Any, refused: Any) -> Any:
            return answer if every else np.where(ok, answer, refused)

        self.residual[sl] = pick(batch.residual[:take], np.nan)
        self.margin[sl] = pick(batch.margin[:take], np.nan)
        self.iterations[sl] = pick(batch.iterations[:take], 0)
        self.cond[sl] = np.nan
        self.branch_code[sl] = pick(self._branch_codes(batch.signs[:take]), 0)
        nsg = int(np.shape(batch.signs)[1]) if np.ndim(batch.signs) == 2 else 0
        self.branch_defined[sl] = (
            pick(branch_identity_defined(batch.margin[:take], batch.residual[:take]), True)
            if nsg
            else True
        )
        self.solver_code[sl] = pick(self.solver_code_of(str(batch.solver)), 0)
        for nm, arr in batch.inputs.items():
            if nm in self.inputs:
                self.inputs[nm][sl] = pick(arr[:take], self.inputs[nm][sl])
        for columns, got in ((self.joints, batch.joints), (self.links, batch.links)):
            for nm, arr in got.items():
                if nm in columns:
                    columns[nm][sl] = pick(arr[:take], np.nan)
        for nm, arr in batch.points.items():
            if nm in self.points:
                self.points[nm][sl] = (
                    arr[:take] if every else np.where(ok[:, None], arr[:take], np.nan)
                )

    def _branch_codes(self, signs: np.ndarray) -> np.ndarray:
        """The branch code of each row of (rows, k) branch signs (one text per distinct row)."""
        rows = int(np.shape(signs)[0])
        k = int(np.shape(signs)[1]) if np.ndim(signs) == 2 else 0
        if not k:
            return np.full(rows, self.branch_code_of(''), np.int32)
        plus = np.asarray(signs) > 0
        key = plus.astype(np.int64) @ (np.int64(1) << np.arange(k, dtype=np.int64))
        _, first, inv = np.unique(key, return_index=True, return_inverse=True)
        codes = [
            self.branch_code_of(branch_text(_signs_of(plus[f]))) for f in first.tolist()
        ]  # fmt: skip
        return np.asarray(codes, np.int32)[inv.reshape(-1)]


def _signs_of(plus: Sequence[bool] | np.ndarray) -> tuple[int, ...]:
    return tuple(1 if p else -1 for p in np.asarray(plus).tolist())
