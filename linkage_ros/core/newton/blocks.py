"""The loop Jacobian's block-triangular form, for the batched solve.

Which entries of J can be nonzero does not depend on the configuration (tables.jacobian_pattern),
so its rows and unknowns can be ordered once so that J is block lower triangular (a perfect
matching of rows to unknowns, then the strongly connected components of the unknowns' dependency
graph in dependency order: what sparse solvers such as KLU do for circuit matrices). A Newton
step is then a forward substitution through the diagonal blocks, and det J the product of their
determinants times the sign of the two orderings. The excavator's 33 x 33 J falls apart into
blocks of 9, 9, 9 and 6, the Peaucellier cell's 21 x 21 into 9 and 12 (the four-bar's 9 x 9
into 6 and three 1 x 1, merged back into one: see DENSE_BLOCK). numpy's stacked LU costs about
16.6 us per 33 x 33 matrix and 1 us per 9 x 9 on the bench machine, so the blocks cut the
excavator's batched steps about 2-3x. The scalar path keeps one LAPACK LU of the whole J:
there a call's fixed cost (a few us) outweighs the arithmetic."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: diagonal blocks are merged up to this size: a stacked LU of up to 12 x 12 matrices costs
#: about numpy's per-call overhead (measured: splitting the four-bar's 9 x 9 into 6 and three
#: 1 x 1 blocks made its steps 1.6x slower; the excavator's 33 x 33 into 9, 9, 9, 6 2.3x faster)
DENSE_BLOCK = 12


@dataclass(frozen=True, slots=True)
class Block:
    """One diagonal block: the residual rows that determine the unknowns ``cols`` once the
    unknowns ``earlier`` (of blocks before it) are known."""

    rows: np.ndarray
    cols: np.ndarray
    earlier: np.ndarray


@dataclass(frozen=True, slots=True)
class BlockForm:
    """The diagonal blocks in dependency order; det J = parity * prod(det of each block)."""

    blocks: tuple[Block, ...]
    parity: int
    #: the residual rows and the unknowns in block order, and each unknown's place in it
    row_order: np.ndarray = field(init=False, repr=False, compare=False)
    col_order: np.ndarray = field(init=False, repr=False, compare=False)
    place: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rows = [bl.rows for bl in self.blocks]
        cols = [bl.cols for bl in self.blocks]
        col_order = np.concatenate(cols) if cols else np.zeros(0, np.intp)
        place = np.empty(len(col_order), np.intp)
        place[col_order] = np.arange(len(col_order))
        object.__setattr__(self, 'row_order', np.concatenate(rows) if rows else col_order)
        object.__setattr__(self, 'col_order', col_order)
        object.__setattr__(self, 'place', place)


def permutation_sign(order: np.ndarray) -> int:
    """+1 / -1: the sign of a permutation of range(len(order)) (from its cycle count)."""
    seen = np.zeros(len(order), bool)
    cycles = 0
    for i in range(len(order)):
        if not seen[i]:
            cycles += 1
            j = i
            while not seen[j]:
                seen[j] = True
                j = int(order[j])
    return -1 if (len(order) - cycles) % 2 else 1


def block_form(pattern: np.ndarray) -> BlockForm | None:
    """The block-triangular form of a square (n, n) sparsity pattern (bool), its blocks merged
    up to DENSE_BLOCK; None where that leaves one block, or the pattern is not square, empty or
    structurally singular (no perfect matching: J singular everywhere)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components, maximum_bipartite_matching

    m, n = pattern.shape
    if m != n or not n:
        return None
    col_of_row = maximum_bipartite_matching(csr_matrix(pattern.astype(float)), perm_type='column')
    if np.any(col_of_row < 0):
        return None
    row_of_col = np.empty(n, np.intp)
    row_of_col[col_of_row] = np.arange(n)
    # unknown j (solved by its matched row) depends on every unknown that row involves
    depends = pattern[row_of_col]  # (n, n): depends[j, k]
    count, label = connected_components(
        csr_matrix(depends.astype(float)), directed=True, connection='strong'
    )
    members = [np.flatnonzero(label == b) for b in range(count)]
    needs = [
        set(label[np.flatnonzero(depends[cols].any(axis=0))].tolist()) - {b}
        for b, cols in enumerate(members)
    ]
    order: list[int] = []
    placed: set[int] = set()
    while len(order) < count:  # dependency order (the component graph has no cycles)
        ready = [b for b in range(count) if b not in placed and needs[b] <= placed]
        order.extend(ready)
        placed.update(ready)
    # consecutive blocks merged while they fit DENSE_BLOCK: small ones cost a call each
    groups: list[list[int]] = []
    for b in order:
        size = len(members[b])
        if groups and sum(len(members[g]) for g in groups[-1]) + size <= DENSE_BLOCK:
            groups[-1].append(b)
        else:
            groups.append([b])
    if len(groups) == 1:
        return None  # one block: the dense solve
    blocks: list[Block] = []
    for group in groups:
        cols = np.concatenate([members[b] for b in group])
        rows = row_of_col[cols]
        used = np.flatnonzero(pattern[rows].any(axis=0))
        blocks.append(Block(rows, cols, np.setdiff1d(used, cols)))
    row_order = np.concatenate([bl.rows for bl in blocks])
    col_order = np.concatenate([bl.cols for bl in blocks])
    return BlockForm(tuple(blocks), permutation_sign(row_order) * permutation_sign(col_order))


#: each block's diagonal part (K, b, b) and the part left of it (K, b, e) of a stack of J:
#: gathered from dense matrices (dense_parts), or views of a packed stack (batch.py)
BlockParts = list[tuple[np.ndarray, np.ndarray]]


def dense_parts(form: BlockForm, J: np.ndarray) -> BlockParts:
    """The BlockParts of a dense (K, n, n) stack (copies)."""
    return [
        (J[:, bl.rows[:, None], bl.cols], J[:, bl.rows[:, None], bl.earlier]) for bl in form.blocks
    ]


def block_det_signs(form: BlockForm, J: np.ndarray) -> np.ndarray:
    """(K,) int sign of det of a (K, n, n) stack with this block form; 0 where singular or not
    finite (as a dense slogdet's sign)."""
    return parts_det_signs(form, dense_parts(form, J))


def parts_det_signs(form: BlockForm, parts: BlockParts) -> np.ndarray:
    """block_det_signs from the stack's BlockParts: the product of the blocks' signs, 0 where
    some block's log|det| is not finite (a singular block's is -inf, a NaN one's NaN: so is
    their sum; finite ones sum to a finite value), tested once on the sum."""
    K = parts[0][0].shape[0]
    sign = np.full(K, form.parity, float)
    logdets = np.zeros(K)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        for bl, (diag, _) in zip(form.blocks, parts):
            if len(bl.cols) == 1:
                a = diag[:, 0, 0]
                sign *= np.sign(a)  # NaN for NaN
                logdets += np.log(np.abs(a))  # -inf for 0, inf for inf
            else:
                s, logdet = np.linalg.slogdet(diag)
                sign *= s
                logdets += logdet
        total = float(logdets.sum())
        if total - total != 0.0:  # some matrix singular or not finite: 0 there (rare)
            sign[~np.isfinite(logdets)] = 0.0
    out: np.ndarray = sign.astype(int)
    return out


def block_steps(form: BlockForm, J: np.ndarray, F: np.ndarray) -> np.ndarray | None:
    """dy (K, n) solving J dy = -F for a (K, n, n) stack by forward substitution through the
    blocks; None if a block of some matrix is singular (numpy's stacked solve then fails for
    the whole stack: the caller solves densely, row by row where it must)."""
    return parts_steps(form, dense_parts(form, J), F)


def parts_steps(form: BlockForm, parts: BlockParts, F: np.ndarray) -> np.ndarray | None:
    """block_steps from the stack's BlockParts. The right-hand sides are taken in block order
    at once (one gather of -F) and the steps found in block order (each block's earlier steps
    one gather of them), put in the unknowns' order at the end (one scatter): fewer numpy
    calls than a gather and a scatter per block, the same float operations."""
    K, n = F.shape
    rhs_all = np.negative(F[:, form.row_order])
    ys = np.empty((K, n))  # the steps, in block order
    at = 0
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        for bl, (diag, left) in zip(form.blocks, parts):
            size = len(bl.cols)
            rhs = rhs_all[:, at : at + size]
            if bl.earlier.size:
                rhs -= np.einsum('kij,kj->ki', left, ys[:, form.place[bl.earlier]])
            if size == 1:
                a = diag[:, 0, 0]
                if not np.all(a != 0.0):
                    return None
                ys[:, at] = rhs[:, 0] / a
            else:
                try:
                    ys[:, at : at + size] = np.linalg.solve(diag, rhs[..., None])[..., 0]
                except np.linalg.LinAlgError:
                    return None
            at += size
    dy = np.empty((K, n))
    dy[:, form.col_order] = ys
    return dy


def block_inverse_norms(form: BlockForm, J: np.ndarray) -> np.ndarray | None:
    """(K,) ||J^-1||_1 (its largest column sum of magnitudes) of each matrix of a (K, n, n)
    stack with this block form. J^-1's rows are found block by block (the inverse of the
    diagonal block times the identity's rows minus the blocks left of it times the rows of
    J^-1 before it), stored in block order (the 1-norm does not depend on the rows' order);
    on the excavator about a third of the flops and copies of a dense stacked inverse. None
    if a block of some matrix is singular (numpy's stacked inverse fails for the whole stack:
    the caller takes the dense path); a singular 1 x 1 block makes its matrix's norm inf or
    NaN."""
    return parts_inverse_norms(form, dense_parts(form, J))


def parts_inverse_norms(
    form: BlockForm, parts: BlockParts, work: np.ndarray | None = None
) -> np.ndarray | None:
    """block_inverse_norms from the stack's BlockParts. J^-1 is taken with its rows (unknowns)
    and columns (residual rows) both in block order, where it is block lower triangular: each
    block's rows X_b (K, b, w) are found on the w columns of the blocks up to it only (the
    rows it needs of earlier blocks gathered in one call) and written into ``work``, J^-1's
    rows in block order as an (n, K, n) array (row, matrix, column) whose entries right of
    each block's columns are zero (np.zeros, or an array an earlier call with this form
    wrote: those entries stay zero; a kept one costs no fresh pages and no zeroing); then
    |J^-1| in place and its column sums in one reduction over the first axis (each of its
    slices a whole row of every matrix: a third of the time of reducing the (K, n, n) middle
    axis). The same float operations as the dense form, in the same order: each column
    summed row by row, a dense J^-1's zeros adding nothing. Against summing each block's rows
    one at a time, about a third of the numpy calls (the excavator: 25 against 78)."""
    K = parts[0][0].shape[0]
    n = sum(len(bl.cols) for bl in form.blocks)
    if work is None or work.shape != (n, K, n):
        work = np.zeros((n, K, n))
    place = form.place  # each unknown's row of J^-1 in the block order
    at = 0
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        for bl, (diag, left) in zip(form.blocks, parts):
            size = len(bl.cols)
            if size == 1:
                d_inv = 1.0 / diag
            else:
                try:
                    d_inv = np.linalg.inv(diag)
                except np.linalg.LinAlgError:
                    return None
            X = work[at : at + size].transpose(1, 0, 2)  # (K, b, n) view
            lower = X[:, :, :at]
            if bl.earlier.size:  # [-d_inv (left X_earlier), d_inv]
                earlier = work[place[bl.earlier], :, :at].transpose(1, 0, 2)
                np.matmul(d_inv, left @ earlier, out=lower)
                np.negative(lower, out=lower)
            else:  # the columns before it are zero
                lower.fill(0.0)
            X[:, :, at : at + size] = d_inv
            at += size
        magnitudes = np.abs(work, out=work)
        norms: np.ndarray = np.add.reduce(magnitudes, axis=0).max(axis=1)
    return norms
