"""One configuration's residual and analytic Jacobian from the compiled tables (plain floats and
``math`` row by row: the scalar solve evaluates them ~10 times per command)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal, overload

import numpy as np

from ..execute import LinkPoses
from ..ops import SCALAR
from .rows import AngleRow, LineRow, angle_row, line_row, point_rows, revolute_rows
from .tables import FixedSlots, LoopTables

#: dyads.wrap_angle's function itself: one Python call less per angle row and value
_wrap = SCALAR.wrap
_PI = math.pi


def fixed_slots(t: LoopTables, fixed: LinkPoses | None) -> FixedSlots:
    """The non-free slots' poses: from ``fixed``, else the ground in its reference pose
    (KeyError for another link without a pose)."""
    if fixed is None and t.ground_slots is not None:
        return t.ground_slots
    P: list[tuple[float, float, float, float]] = []
    phis: list[float] = []
    for l in t.others:
        o = t.centroid[l]
        if fixed is not None and l in fixed.phi:
            rot = fixed.rot[l]
            c = rot * complex(o[0], o[1]) + fixed.T[l]
            P.append((rot.real, rot.imag, c.real, c.imag))
            phis.append(fixed.phi[l])
        elif l == t.mech.ground:
            P.append((1.0, 0.0, float(o[0]), float(o[1])))
            phis.append(0.0)
        else:
            raise KeyError(f'link {l!r} is neither free nor fixed')
    return FixedSlots(P, phis)


def residual_rows(
    t: LoopTables,
    x: np.ndarray | Sequence[float],
    values: Sequence[Any],
    fixed: LinkPoses | None,
    jac: bool,
    k: float,
) -> tuple[list[float], list[float]]:
    """The residual rows (a list) times k and, if jac, the varying Jacobian entries (a list
    in jpos order), those of rotation columns times k."""
    # (a list is the scalar solve's own, of floats: read as it is)
    xs: list[float] = (
        x if type(x) is list else x.tolist() if isinstance(x, np.ndarray) else list(map(float, x))
    )
    cos, sin = math.cos, math.sin
    phis = xs[0::3]
    try:
        P = [(cos(p), sin(p), cx, cy) for p, cx, cy in zip(phis, xs[1::3], xs[2::3])]
    except ValueError:  # an infinite angle: NaN rows (callers reject them)
        phis = [math.nan] * len(phis)
        P = [(math.nan,) * 4] * len(phis)
    if t.others:
        ground = t.ground_slots
        ext = ground if fixed is None and ground is not None else fixed_slots(t, fixed)
        P += ext.poses
        phis += ext.phis
    F: list[float] = []
    Jv: list[float] = []
    for ia, lax, lay, ib, lbx, lby in t.revs:
        fx, fy, jv = revolute_rows(*P[ia], lax, lay, *P[ib], lbx, lby, k)
        F += (fx, fy)
        if jac:
            Jv += jv
    kL = t.L * k
    for row in t.tail:
        if isinstance(row, LineRow):
            iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, vi = row
            v = 0.0 if vi is None else float(values[vi])
            f, jl = line_row(*P[iG], *P[iS], u0x, u0y, lsx, lsy, lgx, lgy, v, k)
            F.append(f)
            if jac:
                Jv += jl
        elif isinstance(row, AngleRow):
            ia, ib, vi, off = row
            v = 0.0 if vi is None else float(values[vi])
            if not -_PI < v <= _PI:  # (wrap's own first test: in range it is v itself)
                v = _wrap(v)
            F.append(angle_row(phis[ia], phis[ib], v, off, kL, _wrap))
        else:
            i, lx, ly, vp_i = row
            vp = values[vp_i]
            fx, fy, jp = point_rows(*P[i], lx, ly, float(vp[0]), float(vp[1]), k)
            F += (fx, fy)
            if jac:
                Jv += jp
    return F, Jv


def jacobian(t: LoopTables, Jv: Sequence[float], tpl: np.ndarray) -> np.ndarray:
    """The (m, n) Jacobian: the template ``tpl`` (t.tpl or t.tpl_s) with the varying entries
    ``Jv`` (residual_rows') in place."""
    Jf = tpl.copy()
    if t.jpos_unique:
        Jf[t.jpos] = Jv
    else:
        np.add.at(Jf, t.jpos, Jv)
    return Jf[:-1].reshape(t.m, t.n)


@overload
def evaluate(
    t: LoopTables,
    x: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None = None,
    jac: Literal[True] = True,
) -> tuple[np.ndarray, np.ndarray]: ...
@overload
def evaluate(
    t: LoopTables, x: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None, jac: bool
) -> tuple[np.ndarray, np.ndarray | None]: ...
def evaluate(
    t: LoopTables,
    x: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None = None,
    jac: bool = True,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Residual F (m,) (m) and, if ``jac``, the analytic Jacobian J (m, n)."""
    F, Jv = residual_rows(t, x, values, fixed, jac, 1.0)
    return np.array(F, float), (jacobian(t, Jv, t.tpl) if jac else None)


def evaluate_rows_scaled(
    t: LoopTables,
    x: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None,
    jac: bool = True,
) -> tuple[np.ndarray, list[float], float]:
    """evaluate_scaled with J left as its varying entries (jacobian(t, Jv, t.tpl_s) builds it),
    for points where it may not be needed."""
    F, Jv = residual_rows(t, x, values, fixed, jac, 1.0 / t.L)
    res = max(map(abs, F), default=0.0)
    total = sum(F)
    if total - total != 0.0:  # a NaN or inf
        res = math.inf
    return np.array(F, float), Jv, res


@overload
def evaluate_scaled(
    t: LoopTables,
    x: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None,
    jac: Literal[True] = True,
) -> tuple[np.ndarray, np.ndarray, float]: ...
@overload
def evaluate_scaled(
    t: LoopTables, x: np.ndarray, values: Sequence[Any], fixed: LinkPoses | None, jac: bool
) -> tuple[np.ndarray, np.ndarray | None, float]: ...
def evaluate_scaled(
    t: LoopTables,
    x: np.ndarray,
    values: Sequence[Any],
    fixed: LinkPoses | None,
    jac: bool = True,
) -> tuple[np.ndarray, np.ndarray | None, float]:
    """F / L, J * col_scale (translations / L) and max|F / L| (inf if not finite): the
    scale-free units the solves work in, so nothing overflows at 1e300 m and the LM damping
    means the same at every scale. Steps come back as dy, with dx = dy * t.step_scale."""
    F, Jv, res = evaluate_rows_scaled(t, x, values, fixed, jac)
    return F, jacobian(t, Jv, t.tpl_s) if jac else None, res
