"""The loop Jacobian reduced to its varying columns (core/newton/schur.py).

Oracles: numpy's dense LU on the same matrices (np.linalg.solve, np.linalg.slogdet,
np.linalg.inv for ||J^-1||_1, np.linalg.cond(J, 1)), and the scene Jacobians built by
evaluate_batch (itself tested against the scalar rows and finite differences).

Would fail if: a column with a varying entry were eliminated as constant (the four-bar's angles,
a slider's translations on a moving guide), the orderings' or det C's sign were dropped from
det J, a reduced step, ||J^-1||_1 or cond differed from the dense ones beyond rounding, a
singular M were solved instead of giving NaN rows (steps) or the dense path (norms), or the
3 x 3 adjugate disagreed with LAPACK.
"""

from __future__ import annotations

import numpy as np
import pytest
import scenes

from linkage_ros.core.newton.linalg import newton_steps
from linkage_ros.core.newton.schur import (
    SchurForm,
    inverse_3x3,
    reduced_steps,
    schur_answer,
    schur_back,
    schur_form,
    schur_inverse_norms,
    schur_reduce,
)

ALL_SCENES = scenes.SHIPPED


system = scenes.newton_system


def packed_jacobians(sy, rng, N=48):
    """(packed J, dense J, F) at configurations spread around the reference pose."""
    X, cols = scenes.around_reference(sy, rng, N)
    V = sy.batch.values(cols, N)
    F, Jp, _ = sy.batch.evaluate(X, V, True, packed=True)
    return Jp, sy.batch.layout().unpack(Jp), F


def forms():
    """(scene, system, form) of every packaged scene whose batched solve is reduced."""
    out = []
    for name in ALL_SCENES:
        sy = system(name)
        if sy.m == sy.n and isinstance(sy.batch.layout(), SchurForm):
            out.append((name, sy, sy.batch.layout()))
    return out


FORMS = forms()


def test_the_bench_scenes_are_reduced_where_it_pays():
    """The four-bar's and slider-crank's 9 unknowns reduce to 3 (a slider on the ground has a
    constant line row), the Peaucellier cell's 21 to 7; the excavator's blocks (9 at most) are
    smaller than its 23 varying columns: it keeps them."""
    sizes = {name: form.a for name, _, form in FORMS}
    assert sizes['four_bar'] == 3 and sizes['slider_crank'] == 3
    assert sizes['peaucellier'] == 7
    assert 'excavator' not in sizes


@pytest.mark.parametrize('name,sy,form', FORMS, ids=[f[0] for f in FORMS])
def test_reduced_solve_equals_the_dense_lu(name, sy, form):
    """Every reduced packaged scene at random configurations: the T columns are constant (and
    nonzero) in every matrix, the step is the dense LU's to rounding (relative to cond), det J's
    sign is slogdet's, ||J^-1||_1 the dense inverse's and the answer checks' cond is
    np.linalg.cond(J, 1)."""
    rng = np.random.default_rng(3)
    Jp, J, F = packed_jacobians(sy, rng)
    Jp2, J2, _ = packed_jacobians(sy, np.random.default_rng(4))
    assert np.array_equal(J[:, :, form.t_cols], J2[:, :, form.t_cols])
    assert np.all(np.any(J[0][:, form.t_cols] != 0, axis=0))
    M, r = schur_reduce(form, Jp, F)
    dy = schur_back(form, Jp, F, reduced_steps(M, r))
    dense = np.linalg.solve(J, -F[:, :, None])[:, :, 0]
    cond = np.linalg.cond(J)
    scale = np.abs(dense).max(axis=1, keepdims=True)
    assert np.all(np.abs(dy - dense) / scale <= 1e-14 * cond[:, None])
    signs, norms = schur_answer(form, Jp)
    assert np.array_equal(signs, np.linalg.slogdet(J)[0].astype(int))
    dense_norms = np.abs(np.linalg.inv(J)).sum(axis=1).max(axis=1)
    assert norms is not None
    assert np.all(np.abs(norms / dense_norms - 1) <= 1e-13 * cond)
    got = schur_inverse_norms(form, Jp)
    assert got is not None and np.all(np.abs(got / dense_norms - 1) <= 1e-13 * cond)
    np.testing.assert_array_equal(form.j_norms(Jp), np.abs(J).sum(axis=1).max(axis=1))
    checked_signs, conds = sy.batch.answer_checks(Jp)
    assert np.array_equal(checked_signs, signs)
    np.testing.assert_allclose(conds, np.linalg.cond(J, 1), rtol=1e-10)


def test_inverse_3x3_equals_lapack():
    """The adjugate inverse and det of random and badly scaled 3 x 3 matrices: numpy's."""
    rng = np.random.default_rng(11)
    M = rng.normal(size=(200, 3, 3)) * np.exp(rng.normal(size=(200, 1, 1)) * 3)
    inverse, det = inverse_3x3(M)
    np.testing.assert_allclose(det, np.linalg.det(M), rtol=1e-12)
    cond = np.linalg.cond(M)
    err = np.abs(inverse - np.linalg.inv(M)).max(axis=(1, 2))
    assert np.all(err <= 1e-14 * cond * np.abs(np.linalg.inv(M)).max(axis=(1, 2)))


def test_singular_reduced_matrices():
    """A singular M in one matrix of the stack: its step is NaN (3 x 3 and dense), the other
    rows are the dense LU's; its det sign is 0; the norms go to the caller's dense path (None)
    where numpy's inverse refuses the stack."""
    rng = np.random.default_rng(2)
    for a in (3, 4):
        M = rng.normal(size=(6, a, a))
        M[2, 1] = 0.0  # a zero row: exactly singular
        r = rng.normal(size=(6, a))
        for dA in (reduced_steps(M, r), newton_steps(M, r)):
            assert np.all(np.isnan(dA[2]))
            keep = np.arange(6) != 2
            np.testing.assert_allclose(
                dA[keep], np.linalg.solve(M[keep], -r[keep][:, :, None])[:, :, 0], rtol=1e-10
            )
    sy = system('four_bar')
    form = sy.batch.layout()
    assert isinstance(form, SchurForm)
    Jp, J, _ = packed_jacobians(sy, np.random.default_rng(5), N=4)
    B, E = form.split(Jp)  # views of Jp
    # M = E - G B with B = 0 and a zero row of E in matrix 1: exactly singular
    B[1] = 0.0
    E[1, 0] = 0.0
    signs, _ = schur_answer(form, Jp)
    assert signs[1] == 0 and np.array_equal(
        np.delete(signs, 1), np.linalg.slogdet(np.delete(form.unpack(Jp), 1, axis=0))[0]
    )


def test_no_form_without_constant_columns_or_with_a_singular_c():
    """Nothing constant, everything constant, a not square J or a constant part of rank below
    its column count: no form."""
    n = 4
    every = np.arange(n * n)
    assert schur_form(np.eye(n), every) is None  # every entry varies
    assert schur_form(np.eye(n), np.zeros(0, np.intp)) is None  # nothing varies
    assert schur_form(np.ones((3, 4)), np.zeros(0, np.intp)) is None
    const = np.zeros((n, n))
    const[:, 2] = const[:, 3] = 1.0  # two equal constant columns: C singular
    varying = np.array([r * n + c for r in range(n) for c in (0, 1)])
    assert schur_form(const, varying) is None
    const[:, 3] = [1.0, -1.0, 2.0, 0.5]
    form = schur_form(const, varying)
    assert form is not None and list(form.t_cols) == [2, 3] and form.a == 2


@pytest.mark.parametrize('name', ['peaucellier', 'excavator', 'four_bar'])
def test_one_singular_answer_leaves_the_others_conds_alone(name):
    """The answer checks of a stack with one exactly singular Jacobian: that row's det sign is
    0 and its cond inf, every other row's cond is what it is without it (np.linalg.cond(J, 1)
    where exact), not the scaled_cond a failed inverse of the whole stack falls back to."""
    sy = system(name)
    Jp, dense, _ = packed_jacobians(sy, np.random.default_rng(11), N=6)
    _, alone = sy.batch.answer_checks(Jp[1:])
    Jp = Jp.copy()
    Jp[0] = 0.0  # every entry, constant ones too: J[0] is the zero matrix
    signs, conds = sy.batch.answer_checks(Jp)
    assert signs[0] == 0 and conds[0] == np.inf
    # the same to rounding (the four-bar's 3 x 3 rows may take the other inverse's route)
    np.testing.assert_allclose(conds[1:], alone, rtol=1e-12)
    exact = alone < 1e8
    np.testing.assert_allclose(alone[exact], np.linalg.cond(dense[1:][exact], 1), rtol=1e-9)
