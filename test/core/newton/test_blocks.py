"""The loop Jacobian's block-triangular form (core/newton/blocks.py).

Oracles: numpy's dense LU (np.linalg.solve, np.linalg.slogdet) on the same matrices, and the
determinant of the permutation matrix for a permutation's sign.

Would fail if: a block ordering left an entry above the block diagonal (the forward
substitution would ignore it), the orderings' sign were dropped from det J, a singular block
were solved instead of handed to the dense path, or blocks small enough to cost more than they
save (the four-bar's) were kept apart.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scenes

from linkage_ros.core.newton.blocks import (
    DENSE_BLOCK,
    block_det_signs,
    block_form,
    block_inverse_norms,
    block_steps,
    dense_parts,
    parts_inverse_norms,
    permutation_sign,
)
from linkage_ros.core.newton.linalg import newton_steps
from linkage_ros.core.newton.tables import jacobian_pattern

ALL_SCENES = scenes.SHIPPED


system = scenes.newton_system


def random_jacobians(sy, rng, N=64):
    """J (N, n, n) and F (N, n) at configurations spread around the reference pose."""
    X, cols = scenes.around_reference(sy, rng, N)
    F, J, _ = sy.evaluate_batch(X, cols)
    return J, F


@pytest.mark.parametrize('order', list(itertools.permutations(range(4))))
def testpermutation_sign(order):
    eye = np.eye(4)
    assert permutation_sign(np.array(order)) == round(np.linalg.det(eye[list(order)]))


@pytest.mark.parametrize('name', ALL_SCENES)
def test_scene_jacobians_solved_block_by_block(name):
    """Every packaged scene: where the form has blocks, J at random configurations has no entry
    above the block diagonal, the forward substitution solves J dy = -F as the dense LU does,
    and det J's sign is the dense one."""
    sy = system(name)
    form = block_form(jacobian_pattern(sy.tables))
    if form is None:
        return
    assert len(form.blocks) >= 2
    rng = np.random.default_rng(7)
    J, F = random_jacobians(sy, rng)
    before: set[int] = set()
    for bl in form.blocks:
        touched = set(np.flatnonzero(np.any(J[:, bl.rows, :] != 0, axis=(0, 1))).tolist())
        assert touched <= before | set(bl.cols.tolist())  # lower block triangular
        assert set(bl.earlier.tolist()) <= before
        before |= set(bl.cols.tolist())
    assert before == set(range(sy.n))
    dy = block_steps(form, J, F)
    assert dy is not None
    dense = np.linalg.solve(J, -F[:, :, None])[:, :, 0]
    scale = np.abs(dense).max(axis=1, keepdims=True)
    cond = np.linalg.cond(J)
    assert np.all(np.abs(dy - dense) / scale <= 1e-14 * cond[:, None])
    assert np.array_equal(block_det_signs(form, J), np.linalg.slogdet(J)[0].astype(int))


def dense_inverse_norms(J):
    """||J^-1||_1 of each matrix, from numpy's dense inverse."""
    return np.abs(np.linalg.inv(J)).sum(axis=1).max(axis=1)


@pytest.mark.parametrize('name', ALL_SCENES)
def test_scene_inverse_norms_block_by_block(name):
    """Every packaged scene with blocks: ||J^-1||_1 found block by block is the dense
    inverse's (to rounding, relative to cond), at random configurations."""
    sy = system(name)
    form = block_form(jacobian_pattern(sy.tables))
    if form is None:
        return
    J, _ = random_jacobians(sy, np.random.default_rng(8))
    got = block_inverse_norms(form, J)
    assert got is not None
    cond = np.linalg.cond(J)
    assert np.all(np.abs(got / dense_inverse_norms(J) - 1) <= 1e-13 * cond)


@pytest.mark.parametrize('name', ['excavator', 'front_loader'])
def test_inverse_norms_reuse_a_kept_work_array(name):
    """parts_inverse_norms with one (n, K, n) work array kept across calls, as BatchNewton
    keeps it: each stack gets the dense inverse's norms (to rounding, relative to cond)
    whatever the call before left in the array (another stack's rows of J^-1, NaN matrices,
    whose norms are NaN)."""
    sy = system(name)
    form = block_form(jacobian_pattern(sy.tables))
    assert form is not None
    rng = np.random.default_rng(9)
    first, _ = random_jacobians(sy, rng)
    second, _ = random_jacobians(sy, rng)
    broken = first.copy()
    broken[::4] = np.nan
    work = np.zeros((sy.n, len(first), sy.n))
    for J in (first, broken, second, first):
        got = parts_inverse_norms(form, dense_parts(form, J), work)
        assert got is not None
        finite = np.isfinite(J).all(axis=(1, 2))
        assert np.all(np.isnan(got[~finite]))
        cond = np.linalg.cond(J[finite])
        assert np.all(np.abs(got[finite] / dense_inverse_norms(J[finite]) - 1) <= 1e-13 * cond)


def test_inverse_norms_with_one_by_one_blocks_and_a_singular_block():
    """Shuffled blocks of 12, 1 and 12 unknowns (too big to merge): the dense inverse's norms;
    a 12 x 12 block with a zero row in one matrix: None (the caller's dense path); a zero 1 x 1
    block in one matrix: that matrix's norm is inf or NaN, the others' as before."""
    rng = np.random.default_rng(5)
    pattern, J = shuffled_block_diagonal(rng, [12, 1, 12])
    form = block_form(pattern)
    assert form is not None and [len(b.cols) for b in form.blocks] == [12, 1, 12]
    got = block_inverse_norms(form, J)
    assert got is not None
    np.testing.assert_allclose(got, dense_inverse_norms(J), rtol=1e-10)
    one = next(b for b in form.blocks if len(b.cols) == 1)
    zero = J.copy()
    zero[3][one.rows[0], one.cols[0]] = 0.0
    got = block_inverse_norms(form, zero)
    assert got is not None and not np.isfinite(got[3])
    keep = np.arange(len(J)) != 3
    np.testing.assert_allclose(got[keep], dense_inverse_norms(J[keep]), rtol=1e-10)
    big = form.blocks[2]
    singular = J.copy()
    singular[6][big.rows[0], big.cols] = 0.0  # stays exactly 0 through the LU
    assert block_inverse_norms(form, singular) is None


def test_four_bar_blocks_are_merged_back_into_one():
    """The four-bar's J splits into 6 + 1 + 1 + 1 unknowns: below DENSE_BLOCK together, so it
    is solved densely (no form); the excavator's blocks stay apart."""
    assert DENSE_BLOCK >= 9
    assert block_form(jacobian_pattern(system('four_bar').tables)) is None
    form = block_form(jacobian_pattern(system('excavator').tables))
    assert form is not None and sorted(len(b.cols) for b in form.blocks) == [6, 9, 9, 9]


def shuffled_block_diagonal(rng, sizes):
    """A pattern of dense diagonal blocks with one coupling entry below each, rows and columns
    shuffled; and random matrices with that pattern."""
    n = sum(sizes)
    pattern = np.zeros((n, n), bool)
    at = 0
    for k, b in enumerate(sizes):
        pattern[at : at + b, at : at + b] = True
        if k:
            pattern[at, at - 1] = True
        at += b
    pr, pc = rng.permutation(n), rng.permutation(n)
    pattern = pattern[pr][:, pc]
    J = np.where(pattern, rng.normal(size=(40, n, n)), 0.0) + 4.0 * np.where(
        pattern & (np.eye(n, dtype=bool)[pr][:, pc]), 1.0, 0.0
    )
    return pattern, J


def test_shuffled_blocks_found_and_solved():
    rng = np.random.default_rng(3)
    pattern, J = shuffled_block_diagonal(rng, [8, 8, 8])
    form = block_form(pattern)
    assert form is not None and [len(b.cols) for b in form.blocks] == [8, 8, 8]
    F = rng.normal(size=(40, 24))
    dy = block_steps(form, J, F)
    assert dy is not None
    np.testing.assert_allclose(dy, np.linalg.solve(J, -F[:, :, None])[:, :, 0], rtol=1e-9)
    assert np.array_equal(block_det_signs(form, J), np.linalg.slogdet(J)[0].astype(int))


def test_a_singular_block_goes_to_the_dense_path():
    """One matrix with a singular diagonal block: block_steps declines the stack (None), det
    sign 0 there; the batched solver's steps are then the dense ones, NaN for that matrix."""
    rng = np.random.default_rng(4)
    pattern, J = shuffled_block_diagonal(rng, [8, 8, 8])
    form = block_form(pattern)
    assert form is not None
    bl = form.blocks[1]
    J[5][bl.rows[0], bl.cols] = J[5][bl.rows[1], bl.cols]  # two equal rows in that block
    F = rng.normal(size=(40, 24))
    assert block_steps(form, J, F) is None
    signs = block_det_signs(form, J)
    assert signs[5] == 0
    keep = np.arange(40) != 5
    assert np.array_equal(signs[keep], np.linalg.slogdet(J[keep])[0].astype(int))
    dense = newton_steps(J, F)  # what BatchNewton.newton_steps falls back on
    assert np.all(np.isnan(dense[5]))
    np.testing.assert_allclose(
        dense[keep], np.linalg.solve(J[keep], -F[keep][:, :, None])[:, :, 0], rtol=1e-9
    )


def test_structurally_singular_or_not_square_has_no_form():
    pattern = np.ones((4, 4), bool)
    pattern[:, 0] = False  # no row can take unknown 0
    assert block_form(pattern) is None
    assert block_form(np.ones((3, 4), bool)) is None
    assert block_form(np.zeros((0, 0), bool)) is None


@pytest.mark.parametrize('name', ALL_SCENES)
def test_packed_j_norms_are_the_dense_ones(name):
    """Every packaged scene whose batched solve keeps J block by block: ||J||_1 read off the
    packed stack (PackedJacobian.j_norms, no dense J) is the dense J's column-sum norm bit for
    bit, NaN and inf rows included; and the answer's conds (BatchNewton.conds) are numpy's
    dense 1-norm condition numbers (the scalar path's scaled_cond above COND_EXACT)."""
    from linkage_ros.core.newton.batch_tables import PackedJacobian
    from linkage_ros.core.newton.linalg import scaled_cond
    from linkage_ros.core.newton.results import COND_EXACT

    sy = system(name)
    layout = sy.batch.layout()
    if not isinstance(layout, PackedJacobian):
        return
    X, cols = scenes.around_reference(sy, np.random.default_rng(11), 40)
    F, Jp, _ = sy.batch.evaluate(X, sy.batch.values(cols, len(X)), True, packed=True)
    Jp[3, 0] = np.nan
    Jp[5, -1] = np.inf
    J = layout.unpack(Jp)
    np.testing.assert_array_equal(layout.j_norms(Jp), np.abs(J).sum(axis=1).max(axis=1))
    finite = np.isfinite(Jp).all(axis=1)
    Jf = J[finite]
    dense = np.linalg.cond(Jf, 1)
    exact = dense < COND_EXACT / 2  # well clear of the switch (rounding on either side)
    assert exact.any()
    got = sy.batch.conds(Jp[finite])
    np.testing.assert_allclose(got[exact], dense[exact], rtol=1e-12 * dense[exact].max())
    wide = dense > 2 * COND_EXACT
    np.testing.assert_allclose(got[wide], [scaled_cond(j) for j in Jf[wide]], rtol=1e-12)
