"""Assembling a robot description's chain: its loops closed at the actuated joints' values by
least squares over the passive joints from the description's own pose (the assembly mode
nearest it), and whether that pose ties two modes."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ..model.joint_map import wrap
from .chain import Chain
from .records import DescriptionError

#: a description's loops count as closed when they miss by at most this fraction of its size
#: (the solver's own closure limit)
CLOSED = 1e-10
#: random restarts of the assembly before a description is refused as unassemblable
ASSEMBLY_STARTS = 24
#: ... or this many, when the best of them still misses by more than FAR_OPEN of the chain's
#: size (a loop a finite distance too long or short for its links: every local minimum of the
#: miss is far from zero; a chain that closes is found closed from most starts)
FAR_OPEN_STARTS = 6
FAR_OPEN = 1e-3


def values_text(acts: Sequence[str], q: Mapping[str, float]) -> str:
    """The actuated values a note or refusal names (``joint1 = 0, joint2 = 0``)."""
    return ', '.join(f'{a} = {q[a]:.6g}' for a in acts) or 'its pose'


def assemble_chain(
    chain: Chain, acts: Sequence[str], given: dict[str, float]
) -> tuple[dict[str, float], float, bool]:
    """Every chain joint's value with the loops closed at the actuated values ``given``
    (actuated joints only: the importer checked them); the gap (m) the loops had before;
    and whether the description's pose ties two assembly modes (_tied)."""
    desc = chain.description
    passive = [j for j in chain.joints if j.name not in acts]
    base = {j.name: float(given.get(j.name, 0.0)) for j in chain.joints}
    # a passive joint the description gives by <mimic> is where its rule puts it (the
    # description's own pose, whose gap the note reports), else at 0
    for _ in passive:
        for j in passive:
            m = j.joint.mimic
            if m is not None and m.joint in base:
                base[j.name] = m.multiplier * base[m.joint] + m.offset
    scale = chain.length_scale

    def residual(x: np.ndarray) -> np.ndarray:
        vals = dict(base)
        vals.update({j.name: float(v) for j, v in zip(passive, x)})
        return chain.closure_residual(chain.poses(vals)) / scale

    x0 = np.array([base[j.name] for j in passive])
    gap = float(np.linalg.norm(residual(x0))) * scale
    best_x, best, best_k = x0, math.inf, -1
    rng = np.random.default_rng(0)
    for k in range(ASSEMBLY_STARTS):
        start = (
            x0
            if k == 0
            else x0
            + np.array(
                [
                    rng.uniform(-math.pi, math.pi) if j.revolute else rng.normal(0, scale)
                    for j in passive
                ]
            )
        )
        if not passive:
            break
        fit = _fit(residual, start)
        miss = float(np.linalg.norm(fit.fun))
        if miss < best:
            best_x, best, best_k = fit.x, miss, k
        if best <= CLOSED:
            break
        if k + 1 >= FAR_OPEN_STARTS and best > FAR_OPEN:
            break  # every start so far stopped far from closing: the loops cannot close
    miss = float(np.linalg.norm(residual(best_x))) * scale
    if miss > CLOSED * scale:
        raise DescriptionError(
            f'cannot assemble at {values_text(acts, base)}: the nearest configuration misses '
            f'closing by {miss:.6g} m ({miss / scale:.3g} of its size)',
            file=desc.source,
        )
    q = dict(base)
    q.update({j.name: float(v) for j, v in zip(passive, best_x)})
    for j in passive:
        if j.revolute:
            q[j.name] = wrap(q[j.name])
    # (a closed description is its own assembly; one closed from another start is no nearest)
    tied = gap > CLOSED * scale and best_k == 0 and _tied(residual, x0, passive, scale)
    return q, gap, tied


#: how far either side of the description's pose the tie test starts (rad, or of the length
#: scale), and how far apart its two assemblies must be to be two modes (a dyad's two sides
#: are apart by O(1); one mode's assemblies from starts 1e-7 apart by about that)
TIE_STEP = 1e-7
TIE_APART = 1e-3


def _tied(
    residual: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    passive: Sequence[Any],
    scale: float,
) -> bool:
    """Whether the open description's pose ``x0`` lies on the ridge between two assembly
    modes: least squares from a hair either side of it (a seeded random direction) closes the
    loops in two configurations apart. A drawing flat on a dyad's centre line (generalized_rbda's
    six-bar) is such a ridge: which side it closes to is rounding's choice, and a frame turned
    by 1e-6 rad, the same robot, flips it (an outside reviewer's find)."""
    if not len(x0):
        return False
    u = np.random.default_rng(1).normal(size=len(x0))
    u *= TIE_STEP / np.linalg.norm(u)
    u *= np.array([1.0 if j.revolute else scale for j in passive])
    ends = []
    for start in (x0 + u, x0 - u):
        fit = _fit(residual, start)
        if float(np.linalg.norm(fit.fun)) > CLOSED:
            return False
        ends.append(fit.x)
    turns = np.array([j.revolute for j in passive])
    apart = np.where(
        turns,
        np.abs(np.remainder(ends[0] - ends[1] + math.pi, 2 * math.pi) - math.pi),
        np.abs(ends[0] - ends[1]) / scale,
    )
    return bool(apart.max() > TIE_APART)


def _fit(residual: Callable[[np.ndarray], np.ndarray], start: np.ndarray) -> Any:
    """Least squares over the passive joints from ``start``: Levenberg-Marquardt to the last
    digits (the assembly and the tie test alike)."""
    from scipy.optimize import least_squares

    return least_squares(residual, start, xtol=1e-15, ftol=1e-15, gtol=1e-15, method='lm')
