"""The loop Jacobian reduced to its varying columns, for the batched solve.

A link's translation unknowns enter revolute and point rows with constant coefficients (+-1 in
scale-free units) and line rows through the guide's direction (constant where the guide is
the ground). Where every entry of a column is constant at every configuration (tables say so),
call those unknowns T and the rest A. Rows S (|T| of them, picked by pivoted elimination on
the constant columns) make C = J[S, T] a constant invertible matrix; with R the other rows
(D = J[R, T] constant, B = J[S, A] and E = J[R, A] varying) the Newton step is

    dA = M^-1 (G F_S - F_R),  M = E - G B,  G = D C^-1 (constant)
    dT = -C^-1 (F_S + B dA)

and det J = (the orderings' signs) * det C * det M. J^-1 follows from M^-1 by the block
inverse, so ||J^-1||_1 costs an |A| x |A| inverse and a few matrix products. The four-bar's
9 x 9 J reduces to a 3 x 3 M (inverted by its adjugate, no LAPACK call), the slider-crank's too
(its slider's guide is the ground), the Peaucellier cell's 21 x 21 to 7 x 7; the excavator's
23 varying columns are more than its largest block (9): it keeps the blocks. Measured on 200
warm rows, CPU time interleaved with the dense and block paths (load 4-9 on 2 cores): a step
1.3x (four-bar) to 2.0x (Peaucellier) as fast, the answer's det J sign and cond 1.9-2.1x."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .blocks import permutation_sign
from .linalg import det_signs, newton_steps

#: a constant C = J[S, T] worse conditioned than this is not used (the dense path instead):
#: its inverse's rounding would reach the steps
MAX_C_COND = 1e6


@dataclass(frozen=True, slots=True)
class SchurForm:
    """J with constant columns ``t_cols`` eliminated through rows ``s_rows`` (see the module
    docstring). The batched solve keeps J packed as J[s_rows + r_rows, a_cols], (K, m * a),
    row-major: B its first t rows, E the rest."""

    n: int
    t_cols: np.ndarray
    a_cols: np.ndarray
    s_rows: np.ndarray
    r_rows: np.ndarray
    c_inv: np.ndarray  # (t, t)
    g: np.ndarray  # D C^-1, (a, t)
    v: np.ndarray  # [G, -I], (a, n)
    d0: np.ndarray  # [C^-1, 0], (t, n)
    parity: int  # the orderings' signs times sign(det C)
    t_col_norms: float  # the largest |.| column sum of J[:, t_cols] (constant)
    t_part: np.ndarray  # (n * n,) the constant T columns of J, flat, zero elsewhere
    size: int  # m * a
    tpl: np.ndarray  # (size,) the packed stack's constant entries
    pos: np.ndarray  # the packed position of each varying entry
    dense: np.ndarray  # (size,) each packed entry's flat position in the (n, n) J

    @property
    def a(self) -> int:
        return len(self.a_cols)

    def split(self, Jp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, E) of a packed (K, size) stack: views."""
        K, t = Jp.shape[0], len(self.t_cols)
        JA = Jp.reshape(K, self.n, self.a)
        return JA[:, :t], JA[:, t:]

    def unpack(self, Jp: np.ndarray) -> np.ndarray:
        """The dense (K, n, n) stack of a packed one."""
        J = np.empty((Jp.shape[0], self.n * self.n))
        J[:] = self.t_part
        J[:, self.dense] = Jp
        return J.reshape(-1, self.n, self.n)

    def reduced(self, Jp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, M) of a packed stack: M = E - G B, (K, a, a)."""
        B, E = self.split(Jp)
        M: np.ndarray = E - _left(self.g, B)
        return B, M

    def j_norms(self, Jp: np.ndarray) -> np.ndarray:
        """(K,) ||J||_1 (the largest column sum of magnitudes) of a packed stack."""
        K = Jp.shape[0]
        a_norms = np.abs(Jp).reshape(K, self.n, self.a).sum(axis=1).max(axis=1)
        out: np.ndarray = np.maximum(a_norms, self.t_col_norms)  # NaN stays NaN
        return out


def schur_form(const: np.ndarray, jpos: np.ndarray) -> SchurForm | None:
    """The SchurForm of a square (n, n) J whose constant entries are ``const`` and whose
    varying entries sit at the flat positions ``jpos``; None where no column is constant and
    nonzero, or the constant columns do not make a well-conditioned C."""
    m, n = const.shape
    if m != n or not n:
        return None
    varying = np.zeros(n * n, bool)
    varying[jpos] = True
    t_mask = ~varying.reshape(n, n).any(axis=0) & (const != 0).any(axis=0)
    t_cols = np.flatnonzero(t_mask)
    a_cols = np.flatnonzero(~t_mask)
    t = len(t_cols)
    if not t or t == n:
        return None
    # rows S: partial pivoting on the constant columns (a rank below t: J singular everywhere)
    work = const[:, t_cols].copy()
    order = np.arange(m)
    for k in range(t):
        p = k + int(np.argmax(np.abs(work[k:, k])))
        if work[p, k] == 0.0:
            return None
        work[[k, p]], order[[k, p]] = work[[p, k]], order[[p, k]]
        work[k + 1 :, k:] -= np.outer(work[k + 1 :, k] / work[k, k], work[k, k:])
    s_rows, r_rows = order[:t], order[t:]
    C = const[np.ix_(s_rows, t_cols)]
    if np.linalg.cond(C) > MAX_C_COND:
        return None
    c_inv = np.linalg.inv(C)
    a = len(a_cols)
    dense = (order[:, None] * n + a_cols).ravel()
    packed_of = np.full(n * n, -1, np.intp)
    packed_of[dense] = np.arange(m * a)
    pos = packed_of[jpos]
    assert np.all(pos >= 0)  # every varying entry is in an A column
    t_part = np.zeros((n, n))
    t_part[:, t_cols] = const[:, t_cols]
    g = const[np.ix_(r_rows, t_cols)] @ c_inv
    orderings = permutation_sign(order) * permutation_sign(np.concatenate([t_cols, a_cols]))
    return SchurForm(
        n=n,
        t_cols=t_cols,
        a_cols=a_cols,
        s_rows=s_rows,
        r_rows=r_rows,
        c_inv=c_inv,
        g=g,
        v=np.concatenate([g, -np.eye(a)], axis=1),
        d0=np.concatenate([c_inv, np.zeros((t, a))], axis=1),
        parity=orderings * int(np.sign(np.linalg.det(C))),
        t_col_norms=float(np.abs(const[:, t_cols]).sum(axis=0).max()),
        t_part=t_part.ravel(),
        size=m * a,
        tpl=const.ravel()[dense],
        pos=pos,
        dense=dense,
    )


#: the cyclic successors of 0, 1, 2: the cofactor of a 3 x 3 matrix's entry (i, j) is
#: M[i+1, j+1] M[i+2, j+2] - M[i+1, j+2] M[i+2, j+1] (indices mod 3), its sign included
_NEXT = np.array([1, 2, 0])
_AFTER = np.array([2, 0, 1])


def inverse_3x3(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M^-1, det M) of a (K, 3, 3) stack by the adjugate (a dozen whole-stack passes, where
    numpy's stacked LU costs about a microsecond per matrix); rows with det M = 0 come back
    inf or NaN, as rows with NaN entries."""
    cof = (
        M[:, _NEXT[:, None], _NEXT] * M[:, _AFTER[:, None], _AFTER]
        - M[:, _NEXT[:, None], _AFTER] * M[:, _AFTER[:, None], _NEXT]
    )
    det: np.ndarray = (M[:, 0, :] * cof[:, 0, :]).sum(axis=1)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        inverse: np.ndarray = cof.transpose(0, 2, 1) / det[:, None, None]
    return inverse, det


def reduced_steps(M: np.ndarray, r: np.ndarray) -> np.ndarray:
    """dA solving M dA = -r for a (K, a, a) stack; NaN rows where M is singular (see
    linalg.newton_steps: the dense LU, except 3 x 3 stacks: inverse_3x3)."""
    if M.shape[1] != 3:
        return newton_steps(M, r)
    inverse, det = inverse_3x3(M)
    with np.errstate(invalid='ignore', over='ignore'):
        dA: np.ndarray = -np.matmul(inverse, r[:, :, None])[:, :, 0]
    singular = ~(det != 0.0) | ~np.isfinite(det)
    if singular.any():
        dA[singular] = np.nan
    return dA


def schur_reduce(sf: SchurForm, Jp: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M, r) of J dy = -F for a packed stack: M dA = -r gives the A part of dy (the caller
    solves the reduced stack, as it handles singular matrices), schur_back the rest."""
    _, M = sf.reduced(Jp)
    r: np.ndarray = F[:, sf.r_rows] - F[:, sf.s_rows] @ sf.g.T
    return M, r


def schur_back(sf: SchurForm, Jp: np.ndarray, F: np.ndarray, dA: np.ndarray) -> np.ndarray:
    """dy (K, n) from the reduced step dA (K, a): dT = -C^-1 (F_S + B dA)."""
    B, _ = sf.split(Jp)
    dy = np.empty(F.shape)
    dy[:, sf.a_cols] = dA
    dy[:, sf.t_cols] = -(F[:, sf.s_rows] + np.matmul(B, dA[:, :, None])[:, :, 0]) @ sf.c_inv.T
    return dy


def schur_answer(sf: SchurForm, Jp: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(det J signs, ||J^-1||_1) of a packed (K, size) stack, both from one reduction: the
    signs as linalg.det_signs gives them (0 where singular or not finite), the norms as
    schur_inverse_norms (None: the caller goes dense)."""
    B, M = sf.reduced(Jp)
    if M.shape[1] == 3:
        X3, det = inverse_3x3(M)
        signs = np.where(np.isfinite(det), np.sign(det), 0.0).astype(int) * sf.parity
        return signs, _inverse_norms(sf, B, X3)
    signs = det_signs(M) * sf.parity
    X = _inverse(M)
    return signs, None if X is None else _inverse_norms(sf, B, X)


def _inverse(M: np.ndarray) -> np.ndarray | None:
    """numpy's inverse of a stack; None if some matrix is exactly singular (numpy refuses the
    whole stack)."""
    try:
        with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
            X: np.ndarray = np.linalg.inv(M)
            return X
    except np.linalg.LinAlgError:
        return None


def schur_inverse_norms(sf: SchurForm, Jp: np.ndarray) -> np.ndarray | None:
    """(K,) ||J^-1||_1 of a packed stack from the block inverse (None if M is singular for
    some matrix: numpy's stacked inverse fails for the whole stack; the caller goes dense)."""
    B, M = sf.reduced(Jp)
    X = _inverse(M)
    return None if X is None else _inverse_norms(sf, B, X)


def _inverse_norms(sf: SchurForm, B: np.ndarray, X: np.ndarray) -> np.ndarray:
    """||J^-1||_1 from B and X = M^-1: in the orderings (T, A) x (S, R),
    J^-1 = [[C^-1 + W X G, -W X], [-X G, X]] = [[C^-1, 0], [0, 0]] + [W; -I] X [G, -I] with
    W = C^-1 B; the 1-norm (the largest column sum of magnitudes) does not depend on the
    orderings."""
    K, a = X.shape[0], X.shape[1]
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        Y = (X.reshape(K * a, a) @ sf.v).reshape(K, a, sf.n)  # X [G, -I]
        top = np.matmul(_left(sf.c_inv, B), Y)
        top += sf.d0
        sums = np.abs(top).sum(axis=1)
        sums += np.abs(Y).sum(axis=1)
        norms: np.ndarray = sums.max(axis=1)
    return norms


def _left(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """A @ B[k] for every matrix of a (K, p, q) stack, as one matrix product (numpy's stacked
    matmul with a constant left factor goes matrix by matrix): a (K, r, q) view."""
    K, p, q = B.shape
    prod: np.ndarray = (B.transpose(0, 2, 1).reshape(K * q, p) @ A.T).reshape(K, q, A.shape[0])
    return prod.transpose(0, 2, 1)
