"""Which rows of a closed-form batch the node's continuity rule provably solves the same way.

The batch is solved with the branch signs current before it; a single continuous solve
(the node's) could change a sign only at a dyad near its singularity, taking the solution
nearest its prediction. A row is "easy" when, at every branching dyad, the core's rule
(core.solver.continuity: keeps_sign, nearer_for_every_ratio, nearer_angle) gives the batch's
sign: the dyad is clear of its singularity now and before, or the batch's solution is nearer
the prediction than the other one for every extrapolation ratio continuity may use.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.ops import BATCH, to_complex
from ..core.plan import step_geometry
from ..core.quantities import PointSpec
from ..core.solver import Solver
from ..core.solver.continuity import keeps_sign, nearer_angle, nearer_for_every_ratio
from ..core.steps import RPRDyad, RRPDyad, RRRDyad, anchor_of
from .history import HistoryEntry
from .rows import finite_rows

#: how much clearer (m per length scale, rad, or margin) than a tie the rule must decide a row
EASY_MARGIN = 1e-9


def easy_prefix(
    mech: Any, hist: list[HistoryEntry], solver: Solver, B: Any, cols: dict[str, Any], m: int
) -> int:
    """How many leading rows of batch ``B`` (its commands ``cols``, ``m`` rows, solved by
    ``solver`` with the signs of ``hist[-1]``, the node's last good configuration) the node's
    continuity rule provably solves the same way."""
    plan = solver.plan
    bsteps = plan.branch_steps
    if not bsteps:
        return m
    signs0 = list(hist[-1].signs)
    finite = finite_rows(cols, m)
    safe = []
    for s in solver.specs:
        v = np.asarray(cols[s.name], float)
        v = v.reshape(m, 2) if isinstance(s, PointSpec) else v.reshape(m)
        safe.append(np.where(np.isfinite(v), v, 0.0))
    okb = np.asarray(B.ok[:m], bool)
    okr = np.flatnonzero(okb)
    step_index = {id(st): k for k, st in enumerate(plan.steps)}
    # the configuration the batch chose (signs0) at each branching step: the batch rows,
    # plus a run for refused rows that still reach some branching step
    reached = {k: okb.copy() for k in range(len(bsteps))}
    names, guides = _step_inputs(mech, bsteps)
    rowpts = {p: np.array(B.points[p][:m], float) for p in names}
    rowphi = {g: np.asarray(B.links[g][:m], float) - mech.links[g].angle_ref for g in guides}
    fin_fail = np.flatnonzero(~okb & finite)
    if fin_fail.size:
        poses_f, pts_f, info_f = plan.run([v[fin_fail] for v in safe], fin_fail.size, signs0)
        for k, st in enumerate(bsteps):
            reached[k][fin_fail] = info_f['ok'] | (info_f['failure'] > step_index[id(st)])
        for p in names:
            if p in pts_f:
                rowpts[p][fin_fail] = pts_f[p]
        for g in guides:
            if g in poses_f.phi:
                rowphi[g][fin_fail] = poses_f.phi[g]
    # the previous good configurations of every row: the history, then the batch's ok rows
    seqpts = {
        p: np.concatenate([np.array([e.point(p) for e in hist]).reshape(-1, 2), rowpts[p][okr]])
        for p in names
    }
    seqphi = {
        g: np.concatenate(
            [np.array([e.link(g) - mech.links[g].angle_ref for e in hist]), rowphi[g][okr]]
        )
        for g in guides
    }
    nh = len(hist)
    last_idx = nh + (np.cumsum(okb) - okb) - 1  # into hist + ok batch rows
    prev_idx = last_idx - 1
    has_last = last_idx >= 0
    has_prev = prev_idx >= 0
    li = np.maximum(last_idx, 0)
    pi = np.maximum(prev_idx, 0)
    eps = EASY_MARGIN * mech.length_scale
    easy = np.ones(m, bool)
    for k, st in enumerate(bsteps):
        need = reached[k] & has_last
        if not np.any(need):
            continue
        # the sign is kept where the dyad is clear of its singularity now and before
        m_now = _step_margin(mech, st, rowpts, rowphi)
        m_seq = _step_margin(mech, st, seqpts, seqphi)
        need &= ~keeps_sign(m_now, m_seq[li], slack=EASY_MARGIN)
        if not np.any(need):
            continue
        flipped = list(signs0)
        flipped[k] = -flipped[k]
        poses1, pts1, _ = plan.run(safe, m, flipped)
        if isinstance(st.args, RPRDyad):
            gl = mech.prismatics[st.args.joint].guide
            good = nearer_angle(rowphi[gl], poses1.phi[gl], seqphi[gl][li], EASY_MARGIN)
        else:
            x = st.point
            assert x is not None  # an RRR / RRP step places its point
            last, prev = seqpts[x][li], seqpts[x][pi]
            good = nearer_for_every_ratio(rowpts[x], pts1[x], last, prev, has_prev, eps)
        easy &= ~need | good
    easy |= ~finite
    # refused on an input limit: the node checks limits before any branch choice
    limited = [
        (k, s) for k, s in enumerate(solver.specs) if not isinstance(s, PointSpec) and s.bounded
    ]
    if limited:
        for i in np.flatnonzero(~easy & ~okb).tolist():
            if any(solver.limit_violation(s, float(safe[k][i])) for k, s in limited):
                easy[i] = True
    bad = np.flatnonzero(~easy)
    return int(bad[0]) if bad.size else m


def _step_inputs(mech: Any, bsteps: Any) -> tuple[list[str], list[str]]:
    """The points and guide links whose positions decide each branching step."""
    names: list[str] = []
    guides: list[str] = []
    for st in bsteps:
        pts = [st.point, anchor_of(st.args)]
        if isinstance(st.args, RRRDyad):
            pts.append(st.args.centre_b)
        names += [p for p in pts if p not in names]
        if isinstance(st.args, RRPDyad | RPRDyad):
            g = mech.prismatics[st.args.joint].guide
            if g not in guides:
                guides.append(g)
    return names, guides


def _step_margin(mech: Any, st: Any, pts: dict[str, Any], phi: dict[str, Any]) -> np.ndarray:
    """Margin of one branching dyad over rows ((n, 2) points, guide angles phi): the core's
    step_geometry, as a Newton solution's branch is read."""
    zs = {p: to_complex(v) for p, v in pts.items()}
    rot = {g: BATCH.expi(a) for g, a in phi.items()}
    with np.errstate(all='ignore'):
        return np.asarray(step_geometry(BATCH, mech, st, zs, rot)[1], float)
