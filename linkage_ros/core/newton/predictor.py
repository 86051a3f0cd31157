"""The continuation predictor of a warm Newton solve: the solution at the next values
extrapolated from the last one (and the one before) along the tangent dx/dvalue, solved by the
linear algebra of whichever kernel factorised J there (lean.LeanSchur's or scalar.DenseKernel's;
predict: LAPACK's). The fast path (lean.fast_steps) starts from what it predicts."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from operator import mul
from typing import Any

import numpy as np

from ..ops import wrap_one
from ..quantities import AngleSpec, PointSpec
from .results import MAX_PREDICTION, LUFactor, SolveResult
from .scalar import DenseKernel
from .tables import LoopTables

_PI = math.pi


def value_step(t: LoopTables, a: Sequence[Any], b: Sequence[Any]) -> list[float]:
    """b - a per value component in scale-free units (rad, length scales)."""
    out: list[float] = []
    L = t.L
    for s, va, vb in zip(t.specs, a, b):
        if type(s) is AngleSpec:  # reduce first: vb - va may overflow
            # (each wrap's own first test inline: an angle in (-pi, pi] is itself, no call)
            fb, fa = float(vb), float(va)
            d = (fb if -_PI < fb <= _PI else wrap_one(fb)) - (
                fa if -_PI < fa <= _PI else wrap_one(fa)
            )
            out.append(d if -_PI < d <= _PI else wrap_one(d))
        elif type(s) is not PointSpec:  # a slide or one coordinate (m)
            out.append(float(vb) / L - float(va) / L)
        else:
            out += [float(vb[0]) / L - float(va[0]) / L, float(vb[1]) / L - float(va[1]) / L]
    return out


def rate_factor(t: LoopTables, r: SolveResult) -> LUFactor | None:
    """What predict() needs of a solution: its Jacobian's factorisation (dx/dvalue there is
    its inverse applied to -dF/dvalue); None if it failed or a value has no row here. Only
    meaningful where no fixed link moves with the values (the Solver: newton mode)."""
    if not r.success or r.factor is None or t.val_rows is None:
        return None
    fac: LUFactor = r.factor
    return fac


def predict(
    t: LoopTables,
    x_last: np.ndarray,
    lu_last: tuple[Any, ...],
    vals_last: Sequence[Any],
    vals: Sequence[Any],
    x_prev: np.ndarray | None = None,
    vals_prev: Sequence[Any] | None = None,
    lu_prev: tuple[Any, ...] | None = None,
) -> np.ndarray | None:
    """Predicted solution at ``vals`` from the solution x_last at vals_last and its
    rate_factor ``lu_last`` (an LUFactor: the tangent T = dx/dvalue is its inverse applied to
    -dF/dvalue), and optionally the solution before (see extrapolate). None if it moves an
    unknown by more than MAX_PREDICTION (rad, or length scales)."""
    got = extrapolate(
        t, DenseKernel(t).solve, x_last.tolist(), lu_last, vals_last, vals,
        None if x_prev is None else x_prev.tolist(), vals_prev, lu_prev,
    )  # fmt: skip
    return None if got is None else np.array(got)


def extrapolate(
    t: LoopTables,
    solve: Callable[[Any, list[float]], list[float]],
    xl: list[float],
    lu_last: Any,
    vals_last: Sequence[Any],
    vals: Sequence[Any],
    x_prev: list[float] | None = None,
    vals_prev: Sequence[Any] | None = None,
    lu_prev: Any = None,
    *,
    h: list[float] | None = None,
    hp: list[float] | None = None,
    unit_last: list[float] | None = None,
    unit_prev: list[float] | None = None,
) -> list[float] | None:
    """The continuation predictor (predict's, and the Newton path's over its kernel) over plain
    floats: the solution at ``vals`` predicted from the solution ``xl`` at vals_last, where
    ``solve(lu, rhs)`` is J^-1 rhs at that solution (``lu_last`` its factorisation in the
    caller's form). h = value_step(vals_last, vals); alone: xl + T h (``tangent``).
    Given the solution before (x_prev at vals_prev, hp the step since, s = h.hp / hp.hp,
    w = h - s hp): along hp the cubic Hermite extrapolation through both solutions and their
    tangents (with ``lu_prev``), else the quadratic one (the curvature the tangent missed over
    hp, times s^2), plus T w off that line. None if it moves an unknown by more than
    MAX_PREDICTION (rad, or length scales).

    What a caller already has it may give (the Newton path keeps them with each answer, so a
    warm command solves for no tangent): ``h`` and ``hp`` (value_step's, the same lists), and
    where the values have one component, ``unit_last`` / ``unit_prev``: unit_tangent at that
    solution (T c is then c times it: the same to rounding)."""
    if h is None:
        h = value_step(t, vals_last, vals)
    c_last: list[float] = h
    c_prev: list[float] | None = None
    k_back = 0.0
    if x_prev is not None and vals_prev is not None:
        if hp is None:
            hp = value_step(t, vals_prev, vals_last)
        den = sum(map(mul, hp, hp))  # (the products and sums of a generator, without one)
        s = sum(map(mul, h, hp)) / den if den > 0 else math.inf
        if lu_prev is not None and -1.0 <= s <= 1.5:
            tt = 1.0 + s  # Hermite on tt in [0, 1] from x_prev to x_last
            t2, t3 = tt * tt, tt * tt * tt
            w = [u - s * v for u, v in zip(h, hp)]
            k_back = 2 * t3 - 3 * t2 + 1
            c_prev = [(t3 - 2 * t2 + tt) * v - s * u for u, v in zip(w, hp)]
            c_last = [(t3 - t2) * v + tt * u for u, v in zip(w, hp)]
        elif abs(s) <= 2.0:
            k_back = s * s
            c_last = [u + k_back * v for u, v in zip(h, hp)]

    # plain Python on these short vectors: a dozen numpy calls would cost more
    back: list[float] | None = None
    if k_back and x_prev is not None:
        back = [a - b for a, b in zip(x_prev, xl)]
        for j in range(0, t.n, 3):
            if abs(back[j]) > _PI:  # angles a turn apart
                back[j] = math.remainder(back[j], 2 * math.pi)
    dy = tangent(t, solve, lu_last, c_last, unit_last)
    if c_prev is not None:  # (set only with lu_prev)
        dy = [a + b for a, b in zip(dy, tangent(t, solve, lu_prev, c_prev, unit_prev))]
    if back is not None:
        dy = [d + k_back * b * w for d, b, w in zip(dy, back, t.inv_step_list)]
    if not (max(map(abs, dy), default=0.0) <= MAX_PREDICTION and math.isfinite(sum(dy))):
        return None
    return [x + d * w for x, d, w in zip(xl, dy, t.step_list)]


def tangent(
    t: LoopTables,
    solve: Callable[[Any, list[float]], list[float]],
    lu: Any,
    c: Sequence[float],
    unit: list[float] | None = None,
) -> list[float]:
    """T c, T = dx/dvalue (scale-free) at a solution: J^-1 times -dF/dvalue c (scale-free: c on
    the value rows), by ``solve(lu, rhs)`` at that solution; where ``unit`` is given (T of a
    single value component: unit_tangent's), c[0] times it. extrapolate's tangents, and
    unit_tangent's for c = 1."""
    if unit is not None:
        k = c[0]
        return [k * u for u in unit]
    rhs = [0.0] * t.n
    for i, v in zip(t.val_rows or (), c):
        rhs[i] = v
    return solve(lu, rhs)


def unit_tangent(
    t: LoopTables, solve: Callable[[Any, list[float]], list[float]], lu: Any
) -> list[float] | None:
    """dx/dvalue (scale-free) at a solution of a system whose values have one component: the
    tangent for c = 1; None where the values have more components (or none), or a value has no
    row."""
    rows = t.val_rows
    if rows is None or len(rows) != 1:
        return None
    return tangent(t, solve, lu, (1.0,))
