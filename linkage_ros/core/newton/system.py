"""The loop-closure equations of a mechanism: rows, the analytic Jacobian, poses <-> unknowns,
and the linear algebra of one linearisation point."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..dyads import wrap_angle
from ..model import Mechanism
from ..plan import ScalarPoses, Spec
from ..quantities import AngleSpec, SlideSpec
from .batch import BatchSystem
from .results import (
    COND_EXACT,
    SINGULAR_COND,
    _lapack,
)
from .rows import (
    AngleRow,
    EquationRows,
    LineRow,
    PointRow,
    PrismaticRows,
    RevoluteRows,
    RowKind,
    SpecRows,
    TailRow,
    angle_row,
    line_row,
    point_rows,
    revolute_rows,
)
from .solve import ScalarSolve


class LoopSystem(ScalarSolve, BatchSystem):
    """The loop-closure equations of a mechanism restricted to a set of free links."""

    def __init__(
        self, mech: Mechanism, specs: Sequence[Spec], free_links: Sequence[str] | None = None
    ):
        self.mech = mech
        self.specs = list(specs)
        self.L = mech.length_scale
        free = list(free_links) if free_links is not None else mech.moving_links
        self.free = free
        self.index = {l: k for k, l in enumerate(free)}
        self.n = 3 * len(free)
        pts = mech.points
        self.centroid = {
            # divided before the sum: points near 1.8e308 (a scene at the float range's edge)
            # would overflow np.mean's sum
            n: np.sum([pts[p] / len(l.points) for p in l.points], axis=0)
            for n, l in mech.links.items()
        }
        self.rows: list[EquationRows] = []
        m = 0
        fr = set(free)
        for rj in mech.revolutes:
            if rj.parent in fr or rj.child in fr:
                self.rows.append(RevoluteRows(rj.parent, rj.child, rj.point))
                m += 2
        for pj in mech.prismatics.values():
            if pj.guide in fr or pj.slider in fr:
                self.rows.append(PrismaticRows(pj))
                m += 2
        for i, s in enumerate(self.specs):
            links = self.spec_links(s)
            if any(l in fr for l in links):
                self.rows.append(SpecRows(i))
                m += s.size
        self.m = m
        self._col_scale = np.tile([1.0 / self.L, 1.0, 1.0], len(free))
        self.step_scale = np.tile([1.0, self.L, self.L], len(free))
        self._step_list = self.step_scale.tolist()
        self._inv_step_list = [1.0, 1.0 / self.L, 1.0 / self.L] * len(free)
        self._compile()

    def spec_links(self, s: Spec) -> list[str]:
        if isinstance(s, AngleSpec):
            return [s.link, s.reference]
        if isinstance(s, SlideSpec):
            pj = self.mech.prismatics[s.joint]
            return [pj.guide, pj.slider]
        return [self.mech.links_of_point(s.point)[0]]

    def _compile(self):
        """Flat instruction tables for evaluate(): link slots (free links first, then the fixed
        links the rows name), per-row constants, and the Jacobian as a template of its constant
        entries plus the flat positions of the entries that vary (in evaluation order)."""
        mech, L, n, m = self.mech, self.L, self.n, self.m
        pts, cen = mech.points, self.centroid
        slot = dict(self.index)
        self._others: list[str] = []

        def s_of(link):
            if link not in slot:
                slot[link] = len(self.free) + len(self._others)
                self._others.append(link)
            return slot[link]

        dummy = m * n  # varying entries of fixed links land here (dropped)
        tpl = np.zeros(m * n + 1)
        jpos: list[int] = []

        def var(r, link, k=0):
            i = self.index.get(link)
            jpos.append(dummy if i is None else r * n + 3 * i + k)

        def const(r, link, k, v):
            i = self.index.get(link)
            if i is not None:
                tpl[r * n + 3 * i + k] += v

        def lever(link, p):
            v = np.asarray(p, float) - cen[link]
            return float(v[0]), float(v[1])

        self._revs: list[tuple[int, float, float, int, float, float]] = []
        self._tail: list[TailRow] = []
        self._val_rows: list[int] | None = []  # row of each value component
        r = 0
        for row in self.rows:
            if not isinstance(row, RevoluteRows):
                continue
            a, b, P = row.parent, row.child, row.point
            self._revs.append((s_of(a), *lever(a, pts[P]), s_of(b), *lever(b, pts[P])))
            var(r, a), var(r + 1, a), var(r, b), var(r + 1, b)
            const(r, a, 1, 1.0), const(r + 1, a, 2, 1.0)
            const(r, b, 1, -1.0), const(r + 1, b, 2, -1.0)
            r += 2
        self.n_rev = r // 2

        def line(r, pj, u0, base, vi):
            G, S = pj.guide, pj.slider
            self._tail.append(
                LineRow(
                    RowKind.LINE,
                    s_of(G),
                    s_of(S),
                    float(u0[0]),
                    float(u0[1]),
                    *lever(S, pts[pj.point]),
                    *lever(G, base),
                    vi,
                )
            )
            for link, k in ((G, 0), (G, 1), (G, 2), (S, 0), (S, 1), (S, 2)):
                var(r, link, k)

        def angle(r, a, b, vi, offset):
            self._tail.append(AngleRow(RowKind.ANGLE, s_of(a), s_of(b), vi, offset))
            const(r, a, 0, L), const(r, b, 0, -L)

        spec_rows = {}
        for row in self.rows:
            if isinstance(row, PrismaticRows):
                pj = row.joint
                d0 = pj.direction
                line(r, pj, (-d0[1], d0[0]), pts[pj.point], None)
                angle(r + 1, pj.slider, pj.guide, None, 0.0)
                r += 2
            elif isinstance(row, SpecRows):
                i = row.spec_index
                s = self.specs[i]
                spec_rows[i] = r
                if isinstance(s, AngleSpec):
                    angle(r, s.link, s.reference, i, s.offset)
                    r += 1
                elif isinstance(s, SlideSpec):
                    pj = mech.prismatics[s.joint]
                    line(r, pj, pj.direction, pj.origin, i)
                    r += 1
                else:
                    owner = mech.links_of_point(s.point)[0]
                    self._tail.append(
                        PointRow(RowKind.POINT, s_of(owner), *lever(owner, pts[s.point]), i)
                    )
                    var(r, owner), var(r + 1, owner)
                    const(r, owner, 1, 1.0), const(r + 1, owner, 2, 1.0)
                    r += 2
        for i, s in enumerate(self.specs):
            if i not in spec_rows:
                self._val_rows = None  # a value moves fixed links: no prediction
                break
            self._val_rows += [spec_rows[i]] if s.size == 1 else [spec_rows[i], spec_rows[i] + 1]
        self._val_idx = np.array(self._val_rows or [], np.intp)
        self._tpl = tpl
        self._tpl_s = tpl * np.append(np.tile(self._col_scale, m), 1.0)
        self._jpos = np.array(jpos, np.intp)
        real = [p for p in jpos if p != dummy]
        self._jpos_unique = len(set(real)) == len(real)
        self._none_slots = None  # the fixed-link slots when no fixed poses are given
        self.point_owner = []
        seen = set()
        for l, link in mech.links.items():
            for p in link.points:
                if p not in seen:
                    seen.add(p)
                    self.point_owner.append((p, l, complex(*map(float, pts[p]))))

    # -- conversions between poses and the variable vector -------------------------------------
    def x_from_poses(self, poses: ScalarPoses) -> np.ndarray:
        """Variable vector of the free links from a configuration."""
        x = np.empty(self.n)
        for l, i in self.index.items():
            o = self.centroid[l]
            c = poses.rot[l] * complex(o[0], o[1]) + poses.T[l]
            x[3 * i : 3 * i + 3] = (poses.phi[l], c.real, c.imag)
        return x

    def reference_x(self) -> np.ndarray:
        x = np.zeros(self.n)
        for l, i in self.index.items():
            x[3 * i + 1 : 3 * i + 3] = self.centroid[l]
        return x

    def poses_from_x(self, x: np.ndarray, fixed: ScalarPoses | None = None) -> ScalarPoses:
        """Configuration of every link: free ones from x, the rest from ``fixed`` (ground at
        the reference pose)."""
        poses = ScalarPoses()
        if fixed is not None:
            for l in fixed.phi:
                poses.set(l, fixed.phi[l], fixed.T[l], fixed.rot[l])
        if self.mech.ground not in poses.phi:
            poses.set(self.mech.ground, 0.0, 0j, 1 + 0j)
        for l, i in self.index.items():
            phi = float(x[3 * i])
            rot = complex(math.cos(phi), math.sin(phi))
            o = self.centroid[l]
            poses.set(l, phi, complex(x[3 * i + 1], x[3 * i + 2]) - rot * complex(o[0], o[1]), rot)
        return poses

    def configuration(self, x: np.ndarray, fixed: ScalarPoses | None = None):
        """(poses, points): poses_from_x and every point's world position (complex), each read
        off the first link that carries it."""
        poses = self.poses_from_x(x, fixed)
        rot, T = poses.rot, poses.T
        return poses, {p: rot[l] * z + T[l] for p, l, z in self.point_owner}

    # -- evaluation ---------------------------------------------------------------------------
    def _fixed_slots(self, fixed):
        """(cos, sin, cx, cy) and phi of the fixed links the rows name: from ``fixed``, else the
        ground in its reference pose."""
        P, phis = [], []
        for l in self._others:
            o = self.centroid[l]
            if fixed is not None and l in fixed.phi:
                rot = fixed.rot[l]
                c = rot * complex(o[0], o[1]) + fixed.T[l]
                P.append((rot.real, rot.imag, c.real, c.imag))
                phis.append(fixed.phi[l])
            elif l == self.mech.ground:
                P.append((1.0, 0.0, float(o[0]), float(o[1])))
                phis.append(0.0)
            else:
                raise KeyError(f'link {l!r} is neither free nor fixed')
        return P, phis

    def evaluate(
        self,
        x: np.ndarray,
        values: Sequence,
        fixed: ScalarPoses | None = None,
        jacobian: bool = True,
    ):
        """Residual F (m,) and, if asked, the analytic Jacobian J (m, n)."""
        F, Jv = self._rows(x, values, fixed, jacobian, 1.0)
        return np.array(F, float), (self._jacobian(Jv, self._tpl) if jacobian else None)

    def evaluate_scaled(self, x, values, fixed, jacobian=True):
        """F / L, J * col_scale (translations / L) and max|F / L| (inf if not finite): the
        scale-free units solve() works in, so nothing overflows at 1e300 m and the LM damping
        means the same at every scale. Steps come back as dy, with dx = dy * self.step_scale."""
        F, Jv, res = self.evaluate_rows_scaled(x, values, fixed, jacobian)
        return F, self._jacobian(Jv, self._tpl_s) if jacobian else None, res

    def evaluate_rows_scaled(self, x, values, fixed, jacobian=True):
        """evaluate_scaled with J left as its varying entries (self._jacobian(Jv, self._tpl_s)
        builds it), for points where it may not be needed."""
        F, Jv = self._rows(x, values, fixed, jacobian, 1.0 / self.L)
        res = max(map(abs, F), default=0.0)
        total = sum(F)
        if total - total != 0.0:  # a NaN or inf
            res = math.inf
        return np.array(F, float), Jv, res

    def _jacobian(self, Jv, tpl):
        Jf = tpl.copy()
        if self._jpos_unique:
            Jf[self._jpos] = Jv
        else:
            np.add.at(Jf, self._jpos, Jv)
        return Jf[:-1].reshape(self.m, self.n)

    def _rows(self, x, values, fixed, jac, k):
        """The residual rows (a list) times k and, if jac, the varying Jacobian entries (a list
        in _jpos order), those of rotation columns times k."""
        xs = x.tolist() if isinstance(x, np.ndarray) else [float(v) for v in x]
        cos, sin = math.cos, math.sin
        phis = xs[0::3]
        try:
            P = [(cos(p), sin(p), cx, cy) for p, cx, cy in zip(phis, xs[1::3], xs[2::3])]
        except ValueError:  # an infinite angle: NaN rows (callers reject them)
            phis = [math.nan] * len(phis)
            P = [(math.nan,) * 4] * len(phis)
        if self._others:
            if fixed is None:
                if self._none_slots is None:
                    self._none_slots = self._fixed_slots(None)
                ext = self._none_slots
            else:
                ext = self._fixed_slots(fixed)
            P += ext[0]
            phis += ext[1]
        F: list[float] = []
        Jv: list[float] = []
        for ia, lax, lay, ib, lbx, lby in self._revs:
            fx, fy, jv = revolute_rows(*P[ia], lax, lay, *P[ib], lbx, lby, k)
            F += (fx, fy)
            if jac:
                Jv += jv
        kL = self.L * k
        for row in self._tail:
            kind = row[0]
            if kind == RowKind.LINE:
                _, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, vi = row
                v = 0.0 if vi is None else float(values[vi])
                f, jv = line_row(*P[iG], *P[iS], u0x, u0y, lsx, lsy, lgx, lgy, v, k)
                F.append(f)
                if jac:
                    Jv += jv
            elif kind == RowKind.ANGLE:
                _, ia, ib, vi, off = row
                v = 0.0 if vi is None else wrap_angle(float(values[vi]))
                F.append(angle_row(phis[ia], phis[ib], v, off, kL, wrap_angle))
            else:
                _, i, lx, ly, vi = row
                v = values[vi]
                fx, fy, jv = point_rows(*P[i], lx, ly, float(v[0]), float(v[1]), k)
                F += (fx, fy)
                if jac:
                    Jv += jv
        return F, Jv

    # -- rates ----------------------------------------------------------------------------------
    def rates(
        self, x: np.ndarray, values: Sequence, value_rates: Sequence[float]
    ) -> tuple[np.ndarray | None, float]:
        """(dx/dt, cond): the unknowns' rates (per free link: rad/s, then its centroid's m/s)
        for the knowns' rates ``value_rates`` (one per value component: rad/s or m/s), from the
        analytic Jacobian at the solution x: J dx = -dF/dvalue * rates, the tangent predict()
        extrapolates along (scale-free units, then scaled back). cond is J's scaled condition
        number; dx is None where J is singular (a toggle) or a value has no row here."""
        F, J, _ = self.evaluate_scaled(x, values, None)
        cond = self.scaled_cond(J)
        fac = self._factor(J) if self._val_rows is not None else None
        if fac is None:
            return None, cond
        rhs = np.zeros(self.n)
        comps = []
        for s in self.specs:
            comps += [isinstance(s, AngleSpec)] * s.size
        for i, rate, is_angle in zip(self._val_rows or [], value_rates, comps):
            rhs[i] = float(rate) if is_angle else float(rate) / self.L
        dy, info = _lapack()[1](fac[0], fac[1], rhs)
        if info != 0 or not np.all(np.isfinite(dy)):
            return None, cond
        return dy * self.step_scale, cond

    # -- linear algebra -----------------------------------------------------------------------
    def unfixed_links(self) -> list[str]:
        """Free links the equations cannot determine whatever the configuration: by the
        sparsity pattern of J (a maximum matching of rows to unknowns leaves an unknown of each
        unmatched), so [] for a system whose knowns each fix a different degree of freedom.
        Knowns that constrain one link twice (a point on a grounded crank: 2 values, 1 motion)
        leave another link free and make J singular everywhere."""
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import maximum_bipartite_matching

        if self.m != self.n or not self.n:
            return []
        pattern = np.zeros(self.m * self.n + 1, bool)
        pattern[self._jpos] = True
        pattern[:-1] |= self._tpl_s[:-1] != 0
        rows = maximum_bipartite_matching(
            csr_matrix(pattern[:-1].reshape(self.m, self.n).astype(float)), perm_type='column'
        )
        matched = set(rows[rows >= 0].tolist())
        return list(dict.fromkeys(self.free[c // 3] for c in range(self.n) if c not in matched))

    def scaled_cond(self, J: np.ndarray) -> float:
        """Exact 2-norm condition number of J with unit-norm columns (an SVD)."""
        if J.size == 0:
            return 1.0
        peak = np.max(np.abs(J), axis=0)  # pre-scale: column norms of 1e300 overflow
        peak[peak == 0] = 1.0
        Jn = J / peak
        norms = np.linalg.norm(Jn, axis=0)
        norms[norms == 0] = 1.0
        try:
            return float(np.linalg.cond(Jn / norms))
        except np.linalg.LinAlgError:
            return float('inf')

    def _factor(self, J: np.ndarray):
        """LU of J: (lu, piv, det sign); None if J is singular to working precision (an
        exactly zero pivot), not square or empty."""
        if J.shape[0] != J.shape[1] or J.size == 0:
            return None
        lu, piv, info = _lapack()[0](J)
        if info != 0:
            return None
        flips = sum(v < 0.0 for v in lu.diagonal().tolist())
        flips += sum(p != i for i, p in enumerate(piv.tolist()))
        return lu, piv, (-1 if flips % 2 else 1)

    @staticmethod
    def _lu_step(fac, F):
        """dy solving J dy = -F from a factorisation (None if not finite)."""
        dy, info = _lapack()[1](fac[0], fac[1], -F)
        return dy if info == 0 and math.isfinite(float(dy.sum())) else None

    def _cond(self, J, fac) -> float:
        """Condition number of the scale-free J: LAPACK's 1-norm estimate from its LU (1.5-7x
        the exact value on the scenes), or the exact 2-norm one of J with unit-norm columns
        (scaled_cond, an SVD) where the estimate exceeds COND_EXACT or there is no LU."""
        if fac is not None:
            rc, info = _lapack()[2](fac[0], float(abs(J).sum(axis=0).max()))
            if info == 0 and rc * COND_EXACT >= 1.0:
                return 1.0 / rc
        return self.scaled_cond(J)

    def _side_ok(self, sign0: int, J, fac) -> bool:
        """The point is on the start's side of det J = 0 (or on the singular set itself, e.g. a
        toggle that is the answer, where the sign is rounding noise)."""
        if sign0 == 0 or (fac is not None and fac[2] == sign0):
            return True
        return self.scaled_cond(J) > SINGULAR_COND

    def _sign_of(self, J, fac) -> int:
        """det J sign for tracking, 0 where J is singular (cond above SINGULAR_COND)."""
        if fac is None:
            return 0
        return fac[2] if self._cond(J, fac) < SINGULAR_COND else 0

    def start_sign(self, x: np.ndarray, values: Sequence, fixed: ScalarPoses | None = None) -> int:
        """The det J sign a solve from x tracks (0 where J is singular there)."""
        if not self.n:
            return 0
        J = self.evaluate_scaled(x, values, fixed)[1]
        return self._sign_of(J, self._factor(J))
