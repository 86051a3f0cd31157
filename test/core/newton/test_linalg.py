"""The dense linear algebra of one linearisation point (core/newton/linalg.py): det J's sign off
LAPACK's LU, the sign the Newton path tracks (a fold is crossed where it changes).

Oracle: the determinant worked out by mpmath at 60 digits (no LAPACK, no numpy), on matrices
whose rows are permuted so the LU needs row swaps and whose pivots come out negative.

Would fail if: factor's sign missed a row swap or a negative pivot (the parity of the two counts
is det J's sign), or it took a pivot index for a swap (LAPACK's ipiv is 1-based in Fortran;
scipy's is 0-based).
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.core.newton.linalg import factor


def _det_sign(J: np.ndarray) -> int:
    with mp.workdps(60):
        d = mp.det(mp.matrix(J.tolist()))
    return 1 if d > 0 else -1 if d < 0 else 0


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(1, 10),
    seed=st.integers(0, 2**32 - 1),
    scale=st.sampled_from([1e-8, 1.0, 1e8]),
)
def test_factor_sign_is_the_sign_of_det_j(n, seed, scale):
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(n, n)) * scale
    J = J[rng.permutation(n)]  # rows out of order: the LU swaps them back
    if rng.random() < 0.5:
        J[:, 0] = -J[:, 0]  # a negative first pivot as often as not
    want = _det_sign(J)
    # a determinant too close to zero for the float LU to settle its sign is not asked about
    with mp.workdps(60):
        rel = abs(mp.det(mp.matrix(J.tolist()))) / mp.mpf(np.prod(np.linalg.norm(J, axis=1)))
    if rel < 1e-10:
        return
    fac = factor(J)
    assert fac is not None
    assert fac[2] == want


def test_factor_counts_every_row_swap():
    # a permutation matrix: every pivot 1, the sign its parity alone
    for perm, want in (([1, 0, 2], -1), ([1, 2, 0], 1), ([3, 2, 1, 0], 1), ([0, 1, 3, 2], -1)):
        J = np.eye(len(perm))[perm]
        fac = factor(J)
        assert fac is not None
        assert fac[2] == want == _det_sign(J)


def test_factor_declines_a_singular_or_non_square_j():
    assert factor(np.zeros((3, 3))) is None
    assert factor(np.ones((2, 3))) is None
    assert factor(np.zeros((0, 0))) is None
