"""A loop system's tables regrouped for the batched solve (BatchTables: rows by kind, the
constant parts of J, how J is stored: PackedJacobian block by block or SchurForm), built once
per system on its first batched call (BatchNewton.tables)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .blocks import Block, BlockForm, BlockParts, block_form
from .rows import AngleRow, LineRow
from .schur import SchurForm, schur_form
from .tables import LoopTables, jacobian_pattern


@dataclass(frozen=True, slots=True)
class PackedJacobian:
    """A square system's J stored block by block, as the batched solve keeps it: for each block
    of ``form`` its diagonal part (b x b, row-major), then the part left of it (b x e), so each
    is a view of the packed (K, size) stack rather than a gather from a dense one (the
    excavator's 33 x 33 J packs into 405 entries). Every other entry of J is zero at every
    configuration."""

    form: BlockForm  # the system's block form, else one block: the whole J
    whole: bool  # one block: the packed J is the dense one, flattened
    at: tuple[tuple[int, int], ...]  # each block's offsets: its diagonal part, the part left
    size: int
    tpl: np.ndarray  # (size,) the scale-free J's constant entries
    pos: np.ndarray  # the packed position of each varying entry of a free link
    dense: np.ndarray  # (size,) each packed entry's flat position in the (m, n) J
    by_column: tuple[np.ndarray, ...]  # j_norms' layers: layer i the packed position of the
    # i-th entry (in row order) of each column that has one, the columns ordered by entry
    # count, most first (so layer i covers a leading run of them)

    def j_norms(self, Jp: np.ndarray) -> np.ndarray:
        """(K,) ||J||_1 (the largest column sum of magnitudes) of a packed (K, size) stack,
        without the dense J: each column's entries summed in row order, layer by layer, as a
        sum over the dense J's rows does (its zeros add nothing), so the same floats; no
        temporary larger than J itself (a (K, entries, n) gather page-faulted)."""
        first, *rest = self.by_column
        if not first.size:  # no entries at all: J is 0
            return np.zeros(Jp.shape[0])
        magnitudes = np.abs(Jp)
        sums = magnitudes[:, first]
        for layer in rest:
            sums[:, : len(layer)] += magnitudes[:, layer]
        norms: np.ndarray = sums.max(axis=1)
        return norms

    def parts(self, Jp: np.ndarray) -> BlockParts:
        """The BlockParts of a packed (K, size) stack: views, no copies."""
        K = Jp.shape[0]
        out: BlockParts = []
        for bl, (d, e) in zip(self.form.blocks, self.at):
            b, w = len(bl.cols), len(bl.earlier)
            out.append(
                (Jp[:, d : d + b * b].reshape(K, b, b), Jp[:, e : e + b * w].reshape(K, b, w))
            )
        return out

    def unpack(self, Jp: np.ndarray) -> np.ndarray:
        """The dense (K, n, n) stack of a packed one (a view where ``whole``)."""
        n = sum(len(bl.cols) for bl in self.form.blocks)
        if self.whole:
            return Jp.reshape(-1, n, n)
        J = np.zeros((Jp.shape[0], n * n))
        J[:, self.dense] = Jp
        return J.reshape(-1, n, n)


def packed_jacobian(
    form: BlockForm | None, n: int, tpl: np.ndarray, pos: np.ndarray
) -> PackedJacobian:
    """The PackedJacobian of an (n, n) J with this block form (None: one block), constant
    entries ``tpl`` (flat, n * n) and varying entries at the flat positions ``pos``."""
    whole = form is None
    if form is None:
        every = np.arange(n)
        form = BlockForm((Block(every, every, np.zeros(0, np.intp)),), 1)
    flat: list[np.ndarray] = []
    at: list[tuple[int, int]] = []
    size = 0
    for bl in form.blocks:
        diag = (bl.rows[:, None] * n + bl.cols).ravel()
        left = (bl.rows[:, None] * n + bl.earlier).ravel()
        at.append((size, size + diag.size))
        flat += [diag, left]
        size += diag.size + left.size
    dense = np.concatenate(flat) if flat else np.zeros(0, np.intp)
    packed_of = np.full(n * n, -1, np.intp)
    packed_of[dense] = np.arange(size)
    packed_pos = packed_of[pos]
    # the blocks cover every entry that can be nonzero (jacobian_pattern): none is lost
    assert np.all(packed_pos >= 0) and np.count_nonzero(tpl) == np.count_nonzero(tpl[dense])
    return PackedJacobian(
        form, whole, tuple(at), size, tpl[dense], packed_pos, dense, _by_column(dense, n)
    )


def _by_column(dense: np.ndarray, n: int) -> tuple[np.ndarray, ...]:
    """PackedJacobian.by_column: ``dense`` each packed entry's flat position in the (n, n) J.
    A column without entries (only in a J singular everywhere) is left out: its sum, 0, is
    never above the others'."""
    row, col = np.divmod(dense, n)
    counts = np.bincount(col, minlength=n)
    columns = np.argsort(-counts, kind='stable')  # most entries first
    entries = [np.flatnonzero(col == j)[np.argsort(row[col == j], kind='stable')] for j in columns]
    depth = int(counts.max(initial=0))
    return tuple(
        np.array([e[i] for e in entries if len(e) > i], np.intp) for i in range(depth)
    ) or (np.zeros(0, np.intp),)


@dataclass(frozen=True, slots=True)
class BatchTables:
    """LoopTables regrouped by row kind as index and constant arrays, so one numpy expression
    evaluates a kind for every configuration and every row of that kind. Slots: the free links,
    then the ground (the only non-free link a batched system may name). Value columns: one per
    value component, then an all-zero one (``n_cols - 1``) for rows without a value."""

    n_cols: int
    cols: list[int]  # each spec's first value column
    fixed: np.ndarray  # (5, 1, k): (phi, cos, sin, cx, cy) of the non-free slots
    rev_a: np.ndarray  # revolute rows: slots and levers (m) of both links
    rev_la: tuple[np.ndarray, np.ndarray]
    rev_b: np.ndarray
    rev_lb: tuple[np.ndarray, np.ndarray]
    line_row: np.ndarray  # line rows: residual row, varying-entry columns (6 each), slots,
    line_jv: np.ndarray  # constants (u0x, u0y, slider and guide levers) and value column
    line_g: np.ndarray
    line_s: np.ndarray
    line_k: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    line_val: np.ndarray
    ang_row: np.ndarray  # angle rows: residual row, slots, value column, offset (rad)
    ang_a: np.ndarray
    ang_b: np.ndarray
    ang_val: np.ndarray
    ang_off: np.ndarray
    pt_row: np.ndarray  # point rows: first residual row, varying-entry columns (2 each),
    pt_jv: np.ndarray  # slot, lever (m), x value column
    pt_link: np.ndarray
    pt_lever: tuple[np.ndarray, np.ndarray]
    pt_val: np.ndarray
    jv_real: np.ndarray  # the varying entries of free links (those of the ground dropped)
    j_pos: np.ndarray  # ... and their flat positions in J
    j_tpl: np.ndarray  # the scale-free J's constant entries, flat (m * n,)
    form: BlockForm | None  # J's block-triangular form (None: not square, or singular)
    packed: PackedJacobian | None  # how the batched solve stores J (None: not square)
    schur: SchurForm | None  # ... or, where it is smaller, reduced to its varying columns


def _largest_block(form: BlockForm | None, n: int) -> int:
    return n if form is None else max(len(bl.cols) for bl in form.blocks)


def batch_tables(t: LoopTables) -> BatchTables:
    """The BatchTables of ``t``; ValueError for a system whose rows name a non-free link other
    than the ground (a hybrid system: its fixed poses vary per solve)."""
    foreign = [l for l in t.others if l != t.mech.ground]
    if foreign:
        raise ValueError(
            f'batched evaluation takes no fixed poses, but the rows name the '
            f'non-free link(s) {foreign}; use evaluate/solve with their poses'
        )
    cols: list[int] = []
    c = 0
    for s in t.specs:
        cols.append(c)
        c += s.size
    zero = c
    # the fixed slots (the ground at its reference pose) as (phi, cos, sin, cx, cy)
    fixed = (
        np.array(
            [(0.0, 1.0, 0.0, float(t.centroid[l][0]), float(t.centroid[l][1])) for l in t.others]
        )
        .reshape(-1, 5)
        .T[:, None, :]
    )
    revs = np.array(t.revs, float).reshape(-1, 6)
    nrev = len(t.revs)
    lines: list[tuple[float, ...]] = []
    angles: list[tuple[float, ...]] = []
    points: list[tuple[float, ...]] = []
    r, j = 2 * nrev, 4 * nrev  # next residual row and next varying-entry column
    for row in t.tail:
        if isinstance(row, LineRow):
            iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, vi = row
            lines.append(
                (r, j, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, zero if vi is None else cols[vi])
            )
            r, j = r + 1, j + 6
        elif isinstance(row, AngleRow):
            ia, ib, va, off = row
            angles.append((r, ia, ib, zero if va is None else cols[va], off))
            r += 1
        else:
            i, lx, ly, vp = row
            points.append((r, j, i, lx, ly, cols[vp]))
            r, j = r + 2, j + 2
    assert r == t.m and j == len(t.jpos), 'batched tables out of step with compile_tables'
    ln = np.array(lines, float).reshape(-1, 11)
    an = np.array(angles, float).reshape(-1, 5)
    pt = np.array(points, float).reshape(-1, 6)

    def idx(a: np.ndarray) -> np.ndarray:
        return a.astype(np.intp)

    real = t.jpos != t.m * t.n  # entries of fixed links are dropped
    tpl = t.tpl_s[:-1]
    if t.jpos_unique and len(ln):
        # a line row's entries on its slider's translations are its guide's direction: constant
        # where the guide is not free (the ground at rest), so they join the template (the
        # same float operations as line_row: the same bits)
        fixed_at = idx(ln[:, 2]) - len(t.free)
        on_fixed = np.flatnonzero(fixed_at >= 0)
        if on_fixed.size:
            cos_g, sin_g = _fixed_cos_sin(fixed, fixed_at[on_fixed])
            u0x, u0y = ln[on_fixed, 4], ln[on_fixed, 5]
            jv = idx(ln[on_fixed, 1])
            tpl = tpl.copy()
            ux, uy = cos_g * u0x - sin_g * u0y, sin_g * u0x + cos_g * u0y
            for entries, value in ((jv + 4, ux), (jv + 5, uy)):
                live = real[entries]
                tpl[t.jpos[entries[live]]] = value[live]
                real[entries] = False
    form = block_form(jacobian_pattern(t))
    square = t.m == t.n and t.n
    packed = packed_jacobian(form, t.n, tpl, t.jpos[real]) if square else None
    schur = schur_form(tpl.reshape(t.m, t.n), t.jpos[real]) if square else None
    if schur is not None and schur.a >= _largest_block(form, t.n):
        schur = None  # the blocks are smaller: no gain
    return BatchTables(
        n_cols=zero + 1,
        cols=cols,
        fixed=fixed,
        rev_a=idx(revs[:, 0]),
        rev_la=(revs[:, 1], revs[:, 2]),
        rev_b=idx(revs[:, 3]),
        rev_lb=(revs[:, 4], revs[:, 5]),
        line_row=idx(ln[:, 0]),
        line_jv=idx(ln[:, 1])[:, None] + np.arange(6),
        line_g=idx(ln[:, 2]),
        line_s=idx(ln[:, 3]),
        line_k=(ln[:, 4], ln[:, 5], ln[:, 6], ln[:, 7], ln[:, 8], ln[:, 9]),
        line_val=idx(ln[:, 10]),
        ang_row=idx(an[:, 0]),
        ang_a=idx(an[:, 1]),
        ang_b=idx(an[:, 2]),
        ang_val=idx(an[:, 3]),
        ang_off=an[:, 4],
        pt_row=idx(pt[:, 0]),
        pt_jv=idx(pt[:, 1])[:, None] + np.arange(2),
        pt_link=idx(pt[:, 2]),
        pt_lever=(pt[:, 3], pt[:, 4]),
        pt_val=idx(pt[:, 5]),
        jv_real=np.flatnonzero(real),
        j_pos=t.jpos[real],
        j_tpl=tpl,
        form=form,
        packed=packed,
        schur=schur,
    )


def _fixed_cos_sin(fixed: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cos, sin) of the fixed slots ``at`` (indices among the non-free slots)."""
    return fixed[1, 0, at], fixed[2, 0, at]


@dataclass(frozen=True, slots=True)
class PoseTable:
    """What a batched solve's configurations are read with (core.solver.newton_poses): each
    free link's reference centroid (m), each point's owner slot (free links in the unknowns'
    order, then the ground) and reference position (m), the points in the tables' order."""

    centroids: tuple[np.ndarray, np.ndarray]
    owner: np.ndarray
    points: tuple[np.ndarray, np.ndarray]
    names: tuple[str, ...]


def pose_table(t: LoopTables) -> PoseTable:
    """The PoseTable of a system whose every link but the ground is free (ValueError else)."""
    slots = dict(t.index)
    if not all(l in slots or l == t.mech.ground for _, l, _ in t.point_owner):
        raise ValueError('reading poses off the unknowns needs every link but the ground free')
    cen = np.array([t.centroid[l] for l in t.index], float).reshape(-1, 2)
    owner = [slots.get(l, len(slots)) for _, l, _ in t.point_owner]
    ref = np.array([t.mech.points[p] for p, _, _ in t.point_owner], float).reshape(-1, 2)
    return PoseTable(
        (cen[:, 0], cen[:, 1]),
        np.array(owner, np.intp),
        (ref[:, 0], ref[:, 1]),
        tuple(p for p, _, _ in t.point_owner),
    )
