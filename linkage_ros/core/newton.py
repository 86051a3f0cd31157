"""Newton loop-closure solver with an analytic Jacobian.

Unknowns: for every *free* link, its rotation phi from the reference pose and the world position
c of its reference centroid o, so that world(p) = R(phi) (p - o) + c. Equations (all in metres;
angle rows are multiplied by the mechanism's length scale so every row has the same unit):

* revolute joint at P between links a, b:         w_a(P) - w_b(P) = 0                  (2 rows)
* prismatic joint (guide G, slider S, point X):   n_G . (w_S(X) - w_G(X)) = 0,  phi_S - phi_G = 0
* known angle spec:                               phi_L - phi_R - (value - offset) = 0
* known slide spec:                               d_G . (w_S(X) - w_G(origin)) - value = 0
* known point spec:                               w_L(X) - (x, y) = 0                  (2 rows)

Convergence is judged on max|F| / length_scale (scale-free). Linear algebra is one LU (LAPACK
getrf) of the scale-free Jacobian per linearisation point: it gives the Newton step and the sign
of det J (from the U diagonal and the pivots). At the answer LAPACK's 1-norm estimate of the
condition number is taken; the exact one (an SVD) only where that estimate is large.

Two paths. The *fast* path starts from a predicted guess (:meth:`LoopSystem.predict`: cubic
Hermite extrapolation from the last two solutions and their tangents dx/dvalue): one Newton step,
then chord steps reusing that factorisation, the Jacobian factorised again only at the answer; it
is taken only if the guess and the answer have the start's det J sign and every step cuts max|F|
tenfold. Otherwise the *careful* path runs from the previous solution: Newton steps with a
backtracking line search, the sign of det J checked at every accepted point (a flip means a branch
jump or a singularity crossed, so the step is shortened), and Levenberg-Marquardt where Newton
steps stop reducing the residual (near singularities).

Batched (:meth:`LoopSystem.evaluate_batch`, :meth:`LoopSystem.solve_batch`): the same residual and
Jacobian for N configurations at once in numpy, and full Newton steps on the N x n x n stack from
warm starts, accepting a row only where the fast path would (FAST_RATE per step, det J sign at
start and answer, cond below POLISH_COND); the rows it declines go to the scalar careful path.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from .dyads import wrap_angle
from .model import Mechanism
from .ops import BATCH
from .plan import ScalarPoses, Spec


@dataclass
class SolveResult:
    """Outcome of one Newton solve (configuration vector x over the free links)."""

    x: np.ndarray
    success: bool
    iterations: int  # steps taken (Newton, chord, line-search, LM and polish)
    residual: float  # max |F| / length scale
    reason: str | None = None
    cond: float = float('inf')  # condition number of the scale-free Jacobian (see _cond)
    det_sign: int = 0
    factor: tuple | None = None  # (lu, piv, det sign) of the scale-free J at x
    jacobians: int = 0  # Jacobians evaluated and factorised
    predicted: bool = False  # converged by the fast path from the predicted guess


@dataclass
class BatchSolve:
    """Outcome of LoopSystem.solve_batch: N warm-started Newton solves at once. Rows are
    independent; a row not ``ok`` was *declined* (not failed): its x is its start, and the caller
    solves it another way (LoopSystem.solve, the scalar careful path)."""

    x: np.ndarray  # (N, n) answers (phi rad, centroid m); the X0 row where declined
    ok: np.ndarray  # (N,) bool: converged on the start's side of det J = 0
    iterations: np.ndarray  # (N,) int: Newton steps evaluated (as SolveResult.iterations)
    residual: np.ndarray  # (N,) max |F| / length scale at x
    det_sign: np.ndarray  # (N,) int: det J sign at x where ok, else 0
    cond: np.ndarray  # (N,) cond(J) at x (as _cond reports it) where ok, else inf


#: at convergence, a scaled cond(J) above this means a near-singular configuration: polish
POLISH_COND = 1e6
POLISH_STEPS = 40
#: a scaled cond(J) above this is a singular configuration (rank-deficient to rounding)
SINGULAR_COND = 1e10
#: LAPACK's 1-norm estimate of cond(J) above this: compute the exact (scaled_cond, an SVD). On the
#: scenes the estimate is 1.5-7x the exact value, so the thresholds above are decided exactly
COND_EXACT = 1e4
#: the fast path: at most this many steps, each cutting max|F| at least by this factor, down to
#: FAST_MARGIN * tol (not below FAST_FLOOR, about the rounding floor of max|F| / L) where they can
FAST_STEPS = 4
FAST_RATE = 0.1
FAST_MARGIN = 1e-2
FAST_FLOOR = 4e-15
#: a prediction moving any unknown further than this (rad, or length scales) is not tried
MAX_PREDICTION = 0.5

_LAPACK = None


def _lapack():
    """(getrf, getrs, gecon) from scipy's LAPACK wrappers, imported on first use."""
    global _LAPACK
    if _LAPACK is None:
        from scipy.linalg import lapack

        _LAPACK = (lapack.dgetrf, lapack.dgetrs, lapack.dgecon)
    return _LAPACK


class LoopSystem:
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
            n: np.mean([pts[p] for p in l.points], axis=0) for n, l in mech.links.items()
        }
        self.rows: list[tuple] = []
        m = 0
        fr = set(free)
        for rj in mech.revolutes:
            if rj.parent in fr or rj.child in fr:
                self.rows.append(('rev', rj.parent, rj.child, rj.point))
                m += 2
        for pj in mech.prismatics.values():
            if pj.guide in fr or pj.slider in fr:
                self.rows.append(('pri', pj))
                m += 2
        for i, s in enumerate(self.specs):
            links = self._spec_links(s)
            if any(l in fr for l in links):
                self.rows.append(('spec', i))
                m += s.size
        self.m = m
        self._col_scale = np.tile([1.0 / self.L, 1.0, 1.0], len(free))
        self._step_scale = np.tile([1.0, self.L, self.L], len(free))
        self._step_list = self._step_scale.tolist()
        self._inv_step_list = [1.0, 1.0 / self.L, 1.0 / self.L] * len(free)
        self._compile()

    def _spec_links(self, s: Spec) -> list[str]:
        if s.kind == 'angle':
            return [s.link, s.reference]
        if s.kind == 'slide':
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

        self._revs, self._tail = [], []
        self._val_rows: list[int] | None = []  # row of each value component
        r = 0
        for row in self.rows:
            if row[0] != 'rev':
                continue
            _, a, b, P = row
            self._revs.append((s_of(a), *lever(a, pts[P]), s_of(b), *lever(b, pts[P])))
            var(r, a), var(r + 1, a), var(r, b), var(r + 1, b)
            const(r, a, 1, 1.0), const(r + 1, a, 2, 1.0)
            const(r, b, 1, -1.0), const(r + 1, b, 2, -1.0)
            r += 2
        self.n_rev = r // 2

        def line(r, pj, u0, base, vi):
            G, S = pj.guide, pj.slider
            self._tail.append(
                (
                    0,
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
            self._tail.append((1, s_of(a), s_of(b), vi, offset))
            const(r, a, 0, L), const(r, b, 0, -L)

        spec_rows = {}
        for row in self.rows:
            if row[0] == 'pri':
                pj = row[1]
                d0 = pj.direction
                line(r, pj, (-d0[1], d0[0]), pts[pj.point], None)
                angle(r + 1, pj.slider, pj.guide, None, 0.0)
                r += 2
            elif row[0] == 'spec':
                i = row[1]
                s = self.specs[i]
                spec_rows[i] = r
                if s.kind == 'angle':
                    angle(r, s.link, s.reference, i, s.offset)
                    r += 1
                elif s.kind == 'slide':
                    pj = mech.prismatics[s.joint]
                    line(r, pj, pj.direction, pj.origin, i)
                    r += 1
                else:
                    owner = mech.links_of_point(s.point)[0]
                    self._tail.append((2, s_of(owner), *lever(owner, pts[s.point]), i))
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
        self._point_owner = []
        seen = set()
        for l, link in mech.links.items():
            for p in link.points:
                if p not in seen:
                    seen.add(p)
                    self._point_owner.append((p, l, complex(*map(float, pts[p]))))

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
        return poses, {p: rot[l] * z + T[l] for p, l, z in self._point_owner}

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

    def _eval_s(self, x, values, fixed, jacobian=True):
        """F / L, J * col_scale (translations / L) and max|F / L| (inf if not finite): the
        scale-free units solve() works in, so nothing overflows at 1e300 m and the LM damping
        means the same at every scale. Steps come back as dy, with dx = dy * self._step_scale."""
        F, Jv, res = self._eval_rows_s(x, values, fixed, jacobian)
        return F, self._jacobian(Jv, self._tpl_s) if jacobian else None, res

    def _eval_rows_s(self, x, values, fixed, jacobian=True):
        """_eval_s with J left as its varying entries (self._jacobian(Jv, self._tpl_s) builds
        it), for points where it may not be needed."""
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
            c1, s1, x1, y1 = P[ia]
            c2, s2, x2, y2 = P[ib]
            rax, ray = c1 * lax - s1 * lay, s1 * lax + c1 * lay
            rbx, rby = c2 * lbx - s2 * lby, s2 * lbx + c2 * lby
            F.append(((x1 + rax) - (x2 + rbx)) * k)
            F.append(((y1 + ray) - (y2 + rby)) * k)
            if jac:  # d/dphi of a world point is perp(lever)
                Jv += (-ray * k, rax * k, rby * k, -rbx * k)
        kL = self.L * k
        for row in self._tail:
            kind = row[0]
            if kind == 0:  # line row: u . (w_S(X) - w_G(base)) [- value]
                _, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, vi = row
                cG, sG, xG, yG = P[iG]
                cS, sS, xS, yS = P[iS]
                ux, uy = cG * u0x - sG * u0y, sG * u0x + cG * u0y
                srx, sry = cS * lsx - sS * lsy, sS * lsx + cS * lsy
                grx, gry = cG * lgx - sG * lgy, sG * lgx + cG * lgy
                dx, dy = (xS + srx) - (xG + grx), (yS + sry) - (yG + gry)
                f = ux * dx + uy * dy
                F.append((f if vi is None else f - float(values[vi])) * k)
                if jac:  # d u / dphi_G = perp(u)
                    Jv += (
                        (-uy * dx + ux * dy - (ux * -gry + uy * grx)) * k,
                        -ux,
                        -uy,
                        (ux * -sry + uy * srx) * k,
                        ux,
                        uy,
                    )
            elif kind == 1:  # angle row: L * wrap(phi_a - phi_b [- (value - offset)])
                _, ia, ib, vi, off = row
                a = phis[ia] - phis[ib]
                if vi is not None:
                    a -= wrap_angle(float(values[vi])) - off
                F.append(kL * wrap_angle(a))
            else:  # point row: w(X) - (x, y)
                _, i, lx, ly, vi = row
                c, s, cx, cy = P[i]
                rx, ry = c * lx - s * ly, s * lx + c * ly
                v = values[vi]
                F.append(((cx + rx) - float(v[0])) * k)
                F.append(((cy + ry) - float(v[1])) * k)
                if jac:
                    Jv += (-ry * k, rx * k)
        return F, Jv

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
        J = self._eval_s(x, values, fixed)[1]
        return self._sign_of(J, self._factor(J))

    # -- continuation: predictor ----------------------------------------------------------------
    def value_step(self, a: Sequence, b: Sequence) -> list[float]:
        """b - a per value component in scale-free units (rad, length scales)."""
        out, L = [], self.L
        for s, va, vb in zip(self.specs, a, b):
            if s.kind == 'angle':  # reduce first: vb - va may overflow
                out.append(wrap_angle(wrap_angle(float(vb)) - wrap_angle(float(va))))
            elif s.kind == 'slide':
                out.append(float(vb) / L - float(va) / L)
            else:
                out += [float(vb[0]) / L - float(va[0]) / L, float(vb[1]) / L - float(va[1]) / L]
        return out

    def rate_factor(self, r: SolveResult) -> tuple | None:
        """What predict() needs of a solution: its Jacobian's factorisation (dx/dvalue there is
        its inverse applied to -dF/dvalue); None if it failed or a value has no row here. Only
        meaningful where no fixed link moves with the values (the Solver: newton mode)."""
        if not r.success or r.factor is None or self._val_rows is None:
            return None
        return r.factor

    def predict(
        self,
        x_last: np.ndarray,
        lu_last: tuple,
        vals_last: Sequence,
        vals: Sequence,
        x_prev: np.ndarray | None = None,
        vals_prev: Sequence | None = None,
        lu_prev: tuple | None = None,
    ) -> np.ndarray | None:
        """Predicted solution at ``vals`` from the solution x_last at vals_last and its
        rate_factor ``lu_last`` (the tangent T = dx/dvalue is its inverse applied to -dF/dvalue).
        h = value_step(vals_last, vals); alone: x_last + T h. Given the solution before (x_prev at
        vals_prev, hp the step since, s = h.hp / hp.hp, w = h - s hp): along hp the cubic
        Hermite extrapolation through both solutions and their tangents (with ``lu_prev``),
        else the quadratic one (the curvature the tangent missed over hp, times s^2), plus
        T w off that line. None if it moves an unknown by more than MAX_PREDICTION (rad, or
        length scales)."""
        getrs = _lapack()[1]
        h = self.value_step(vals_last, vals)
        c_last, c_prev, k_back = h, None, 0.0
        if x_prev is not None and vals_prev is not None:
            hp = self.value_step(vals_prev, vals_last)
            den = sum(v * v for v in hp)
            s = sum(u * v for u, v in zip(h, hp)) / den if den > 0 else math.inf
            if lu_prev is not None and -1.0 <= s <= 1.5:
                t = 1.0 + s  # Hermite on t in [0, 1] from x_prev to x_last
                t2, t3 = t * t, t * t * t
                w = [u - s * v for u, v in zip(h, hp)]
                k_back = 2 * t3 - 3 * t2 + 1
                c_prev = [(t3 - 2 * t2 + t) * v - s * u for u, v in zip(w, hp)]
                c_last = [(t3 - t2) * v + t * u for u, v in zip(w, hp)]
            elif abs(s) <= 2.0:
                k_back = s * s
                c_last = [u + k_back * v for u, v in zip(h, hp)]

        n, rows = self.n, self._val_rows

        def tangent(lu, c):  # T c, scale-free (a list)
            rhs = [0.0] * n
            for i, v in zip(rows, c):
                rhs[i] = v  # -dF/dvalue (scale-free) times c
            y, info = getrs(lu[0], lu[1], np.array(rhs))
            return y.tolist() if info == 0 else [math.nan] * n

        # plain Python on these short vectors: a dozen numpy calls would cost more
        dy = tangent(lu_last, c_last)
        if c_prev is not None:
            dy = [a + b for a, b in zip(dy, tangent(lu_prev, c_prev))]
        xl = x_last.tolist()
        if k_back:
            back = [a - b for a, b in zip(x_prev.tolist(), xl)]
            for j in range(0, n, 3):
                if abs(back[j]) > math.pi:  # angles a turn apart
                    back[j] = math.remainder(back[j], 2 * math.pi)
            dy = [d + k_back * b * w for d, b, w in zip(dy, back, self._inv_step_list)]
        if not (max(map(abs, dy), default=0.0) <= MAX_PREDICTION and math.isfinite(sum(dy))):
            return None
        return np.array([x + d * w for x, d, w in zip(xl, dy, self._step_list)])

    # -- solving ------------------------------------------------------------------------------
    def solve(
        self,
        x0: np.ndarray,
        values: Sequence,
        fixed: ScalarPoses | None = None,
        *,
        tol: float = 1e-12,
        max_iter: int = 50,
        keep_det_sign: bool = True,
        start_sign: int | None = None,
        guess: np.ndarray | None = None,
    ) -> SolveResult:
        """Solve from ``guess`` by the fast path if given and it qualifies (solve_from_guess),
        else from x0 by Newton with a line search on det-sign flips and an LM fallback. Works in
        scale-free units (see _eval_s); ``tol`` bounds max|F| / length scale. The det J sign
        tracked is ``start_sign`` (known from the solve that produced x0), else read at x0."""
        x = np.array(x0, float)
        square = self.m == self.n
        nj = 0
        F = J = fac = None
        # at a singular start (a change point) det J has no meaningful sign: do not track it
        sign0 = 0 if not keep_det_sign else start_sign
        if sign0 is None:
            F, J, res = self._eval_s(x, values, fixed)
            fac = self._factor(J)
            nj += 1
            sign0 = self._sign_of(J, fac)
        spent = 0
        if guess is not None:
            r = self.solve_from_guess(
                guess, values, fixed, tol=tol, max_iter=max_iter, start_sign=sign0
            )
            r.jacobians += nj
            if r.success:
                return r
            spent, nj = r.iterations, r.jacobians
        if F is None:
            F, J, res = self._eval_s(x, values, fixed)
            fac = self._factor(J)
            nj += 1
        it = 0
        mu = None
        while res > tol and it < max_iter:
            it += 1
            fnorm = math.sqrt(float(F @ F))
            step = None
            if mu is None:
                if square:
                    dy = self._lu_step(fac, F) if fac is not None else None
                else:
                    dy = np.linalg.lstsq(J, -F, rcond=None)[0]
                    dy = dy if np.all(np.isfinite(dy)) else None
                if dy is not None:
                    step = dy * self._step_scale
            accepted = False
            if step is not None:
                alpha = 1.0
                for _ in range(10):
                    xn = x + alpha * step
                    # the full step usually holds: evaluate J with it; shorter trials F alone
                    Fn, Jn, rn = self._eval_s(xn, values, fixed, alpha == 1.0)
                    if math.sqrt(float(Fn @ Fn)) < (1.0 - 1e-4 * alpha) * fnorm:
                        if Jn is None:
                            Jn = self._eval_s(xn, values, fixed)[1]
                        facn = self._factor(Jn)
                        nj += 1
                        if self._side_ok(sign0, Jn, facn):
                            x, F, J, fac, res = xn, Fn, Jn, facn, rn
                            accepted = True
                            break
                    alpha *= 0.5
            if not accepted:
                # Levenberg-Marquardt with Marquardt's column scaling
                JtJ = J.T @ J
                g = J.T @ F
                D = np.diag(JtJ).copy()
                D[D == 0] = 1.0
                mu = mu or 1e-3
                for _ in range(12):
                    try:
                        dy = np.linalg.solve(JtJ + mu * np.diag(D), -g)
                    except np.linalg.LinAlgError:
                        mu *= 10
                        continue
                    xn = x + dy * self._step_scale
                    Fn, Jn, rn = self._eval_s(xn, values, fixed)
                    if math.sqrt(float(Fn @ Fn)) < fnorm:
                        facn = self._factor(Jn)
                        nj += 1
                        if self._side_ok(sign0, Jn, facn):
                            x, F, J, fac, res = xn, Fn, Jn, facn, rn
                            mu = max(mu / 10, 1e-12)
                            accepted = True
                            break
                    mu *= 10
                if not accepted:
                    break
        r = self._finish(x, F, J, fac, res, it, values, fixed, polish=res <= tol)
        r.iterations += spent
        r.jacobians += nj
        if res <= tol:
            return r
        r.success = False
        r.factor = None
        if it >= max_iter:
            r.reason = (
                f'Newton reached its iteration cap ({max_iter}) with loop-closure residual '
                f'{r.residual:.3g} of the length scale (tolerance {tol:g})'
            )
        else:
            r.reason = (
                f'Newton stalled with loop-closure residual {r.residual:.3g} of the length '
                f'scale: no assembly near the start (cond J = {r.cond:.3g}); the input may '
                'be beyond a limit or toggle position'
            )
        return r

    def solve_from_guess(
        self,
        guess: np.ndarray,
        values: Sequence,
        fixed: ScalarPoses | None = None,
        *,
        tol: float = 1e-12,
        max_iter: int = 50,
        start_sign: int = 0,
    ) -> SolveResult:
        """The fast path: one Newton step from a predicted guess, then chord steps on its
        factorisation, J factorised again at the answer. Steps go on to FAST_MARGIN * tol (or
        FAST_FLOOR) while each cuts max|F| FAST_RATE-fold (an answer just inside ``tol`` would
        leave angles read off its points off by ~tol / link length). Declines (success False,
        the steps spent counted) unless J is regular at the guess and at the answer with det
        sign ``start_sign`` (0: any) and min(FAST_STEPS, max_iter) such steps reach ``tol``."""
        x = guess = np.array(guess, float)  # the result never aliases the caller's array
        F, J, res = self._eval_s(x, values, fixed)
        fac = self._factor(J)
        steps, it, nj = min(FAST_STEPS, max_iter), 0, 1
        Jv = None

        def declined():
            return SolveResult(
                guess, False, it, res, 'the predicted start did not qualify', jacobians=nj
            )

        if fac is None or not math.isfinite(res) or (start_sign and fac[2] != start_sign):
            return declined()
        lin = fac
        target = min(tol, max(FAST_MARGIN * tol, FAST_FLOOR))
        while res > target:
            dy = self._lu_step(lin, F) if it < steps else None
            if dy is not None:
                xn = x + dy * self._step_scale
                Fn, Jvn, rn = self._eval_rows_s(xn, values, fixed)
                it += 1
            if dy is None or not rn <= FAST_RATE * res:
                if res <= tol:  # converged; the rounding floor is above the margin
                    break
                return declined()
            x, F, Jv, res, fac = xn, Fn, Jvn, rn, None
        if fac is None:  # J at the answer: its det sign, cond and factorisation
            J = self._jacobian(Jv, self._tpl_s)
            fac = self._factor(J)
            nj += 1
            if fac is None or (start_sign and fac[2] != start_sign):
                return declined()
        r = self._finish(x, F, J, fac, res, it, values, fixed)
        if start_sign and r.det_sign not in (0, start_sign):
            return declined()  # polishing near a fold crossed det J = 0
        r.jacobians += nj
        r.predicted = True
        return r

    def _finish(self, x, F, J, fac, res, it, values, fixed, polish=True) -> SolveResult:
        """The result at x (marked a success: the caller decides): condition number, det J
        sign and, if ``polish`` (converged) and near a fold, polishing steps."""
        square = self.m == self.n
        cond = self._cond(J, fac)
        nj = 0
        if polish and cond > POLISH_COND:
            # near a toggle Newton converges only linearly and the configuration error is
            # ~sqrt(residual): polish while it still pays, so margins and branch signs read off
            # the answer are as exact as floating point allows
            for _ in range(POLISH_STEPS):
                if res <= 1e-15:
                    break
                if square:
                    dy = self._lu_step(fac, F) if fac is not None else None
                    if dy is None:
                        break
                else:
                    dy = np.linalg.lstsq(J, -F, rcond=None)[0]
                xn = x + dy * self._step_scale
                Fn, Jn, rn = self._eval_s(xn, values, fixed)
                if not (np.all(np.isfinite(xn)) and rn < 0.7 * res):
                    break
                x, F, J, res = xn, Fn, Jn, rn
                fac = self._factor(J)
                nj += 1
                it += 1
            cond = self._cond(J, fac)
        det = fac[2] if fac is not None and cond < SINGULAR_COND else 0  # 0: singular, no sign
        return SolveResult(x, True, it, res, None, cond, det, fac, nj)

    # -- batched: N configurations at once (numpy over the rows, loops only over the tables) ---
    def _batch_tables(self) -> SimpleNamespace:
        """The compiled tables regrouped by row kind as index and constant arrays, so one numpy
        expression evaluates a kind for every configuration and every row of that kind. Built on
        first use; ValueError for a system whose rows name a non-free link other than the
        ground (a hybrid system: its fixed poses vary per solve)."""
        tab = getattr(self, '_batch_tab', None)
        if tab is not None:
            return tab
        foreign = [l for l in self._others if l != self.mech.ground]
        if foreign:
            raise ValueError(
                f'batched evaluation takes no fixed poses, but the rows name the '
                f'non-free link(s) {foreign}; use evaluate/solve with their poses'
            )
        # value columns: one per value component, then an all-zero one for rows without a value
        cols, c = [], 0
        for s in self.specs:
            cols.append(c)
            c += s.size
        zero = c
        # the fixed slots (the ground at its reference pose) as (phi, cos, sin, cx, cy)
        fixed = (
            np.array(
                [
                    (0.0, 1.0, 0.0, float(self.centroid[l][0]), float(self.centroid[l][1]))
                    for l in self._others
                ]
            )
            .reshape(-1, 5)
            .T[:, None, :]
        )
        revs = np.array(self._revs, float).reshape(-1, 6)
        nrev = len(self._revs)
        lines, angles, points = [], [], []
        r, j = 2 * nrev, 4 * nrev  # next residual row and next varying-entry column
        for row in self._tail:
            if row[0] == 0:
                _, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, vi = row
                lines.append(
                    (r, j, iG, iS, u0x, u0y, lsx, lsy, lgx, lgy, zero if vi is None else cols[vi])
                )
                r, j = r + 1, j + 6
            elif row[0] == 1:
                _, ia, ib, vi, off = row
                angles.append((r, ia, ib, zero if vi is None else cols[vi], off))
                r += 1
            else:
                _, i, lx, ly, vi = row
                points.append((r, j, i, lx, ly, cols[vi]))
                r, j = r + 2, j + 2
        assert r == self.m and j == len(self._jpos), 'batched tables out of step with _compile'
        ln = np.array(lines, float).reshape(-1, 11)
        an = np.array(angles, float).reshape(-1, 5)
        pt = np.array(points, float).reshape(-1, 6)
        idx = lambda a: a.astype(np.intp)  # noqa: E731
        real = self._jpos != self.m * self.n  # entries of fixed links are dropped
        tab = SimpleNamespace(
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
            line_k=tuple(ln[:, 4:10].T),
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
            j_pos=self._jpos[real],
            j_tpl=self._tpl_s[:-1],
        )
        self._batch_tab = tab
        return tab

    def _batch_values(self, values: Sequence, N: int) -> np.ndarray:
        """(N, columns) matrix of the values (angles wrapped as _rows wraps them, rad; slides
        and points m), then a zero column: what the batched rows subtract."""
        tab = self._batch_tables()
        if len(values) != len(self.specs):
            raise ValueError(f'{len(values)} value arrays for {len(self.specs)} specs')
        V = np.zeros((N, tab.n_cols))
        for s, v, c in zip(self.specs, values, tab.cols):
            shape = (N, 2) if s.kind == 'point' else (N,)
            try:
                arr = np.broadcast_to(np.asarray(v, float), shape)
            except ValueError:
                raise ValueError(
                    f'values for {s.name!r} ({s.kind}) must have shape {shape}, got {np.shape(v)}'
                ) from None
            if s.kind == 'point':
                V[:, c : c + 2] = arr
            elif s.kind == 'angle':
                V[:, c] = BATCH.wrap(arr)
            else:
                V[:, c] = arr
        return V

    def _batch_eval(self, X: np.ndarray, V: np.ndarray, jacobian: bool):
        """_eval_s for the rows of X (N, n) with the value matrix V (_batch_values): F (N, m),
        J (N, m, n) or None, res (N,). The same formulas in the same order as _rows."""
        tab = self._batch_tables()
        N, m, nf = X.shape[0], self.m, len(self.free)
        k = 1.0 / self.L
        kL = self.L * k  # as _rows: not exactly 1
        with np.errstate(invalid='ignore', over='ignore'):
            # slots (free links, then the ground): phi, cos, sin, cx, cy
            P = np.empty((5, N, nf + len(self._others)))
            phi = X[:, 0::3]
            P[0, :, :nf] = phi
            np.cos(phi, out=P[1, :, :nf])
            np.sin(phi, out=P[2, :, :nf])
            P[3, :, :nf] = X[:, 1::3]
            P[4, :, :nf] = X[:, 2::3]
            P[:, :, nf:] = tab.fixed
            blown = np.isinf(phi).any(axis=1)
            if blown.any():  # as _rows, where math.cos raises: NaN free slots
                P[:, blown, :nf] = math.nan
            F = np.empty((N, m))
            Jv = np.empty((N, len(self._jpos))) if jacobian else None
            nrev = len(tab.rev_a)
            if nrev:  # revolute rows: w_a(P) - w_b(P)
                c1, s1, x1, y1 = P[1:, :, tab.rev_a]
                c2, s2, x2, y2 = P[1:, :, tab.rev_b]
                (lax, lay), (lbx, lby) = tab.rev_la, tab.rev_lb
                rax, ray = c1 * lax - s1 * lay, s1 * lax + c1 * lay
                rbx, rby = c2 * lbx - s2 * lby, s2 * lbx + c2 * lby
                F[:, 0 : 2 * nrev : 2] = ((x1 + rax) - (x2 + rbx)) * k
                F[:, 1 : 2 * nrev : 2] = ((y1 + ray) - (y2 + rby)) * k
                if jacobian:
                    Jv[:, : 4 * nrev] = np.stack(
                        (-ray * k, rax * k, rby * k, -rbx * k), axis=-1
                    ).reshape(N, 4 * nrev)
            if len(tab.line_row):  # line rows: u . (w_S(X) - w_G(base)) [- value]
                cG, sG, xG, yG = P[1:, :, tab.line_g]
                cS, sS, xS, yS = P[1:, :, tab.line_s]
                u0x, u0y, lsx, lsy, lgx, lgy = tab.line_k
                ux, uy = cG * u0x - sG * u0y, sG * u0x + cG * u0y
                srx, sry = cS * lsx - sS * lsy, sS * lsx + cS * lsy
                grx, gry = cG * lgx - sG * lgy, sG * lgx + cG * lgy
                dx, dy = (xS + srx) - (xG + grx), (yS + sry) - (yG + gry)
                F[:, tab.line_row] = ((ux * dx + uy * dy) - V[:, tab.line_val]) * k
                if jacobian:
                    Jv[:, tab.line_jv] = np.stack(
                        (
                            (-uy * dx + ux * dy - (ux * -gry + uy * grx)) * k,
                            -ux,
                            -uy,
                            (ux * -sry + uy * srx) * k,
                            ux,
                            uy,
                        ),
                        axis=-1,
                    )
            if len(tab.ang_row):  # angle rows: L * wrap(phi_a - phi_b - (value - off))
                a = P[0][:, tab.ang_a] - P[0][:, tab.ang_b]
                a = a - (V[:, tab.ang_val] - tab.ang_off)
                F[:, tab.ang_row] = kL * BATCH.wrap(a)
            if len(tab.pt_row):  # point rows: w(X) - (x, y)
                c, s, cx, cy = P[1:, :, tab.pt_link]
                lx, ly = tab.pt_lever
                rx, ry = c * lx - s * ly, s * lx + c * ly
                F[:, tab.pt_row] = ((cx + rx) - V[:, tab.pt_val]) * k
                F[:, tab.pt_row + 1] = ((cy + ry) - V[:, tab.pt_val + 1]) * k
                if jacobian:
                    Jv[:, tab.pt_jv] = np.stack((-ry * k, rx * k), axis=-1)
        res = np.abs(F).max(axis=1) if m else np.zeros(N)
        res[~np.isfinite(F).all(axis=1)] = math.inf
        if not jacobian:
            return F, None, res
        J = np.empty((N, m * self.n))
        J[:] = tab.j_tpl
        if self._jpos_unique:
            J[:, tab.j_pos] = Jv[:, tab.jv_real]
        else:
            np.add.at(J, (slice(None), tab.j_pos), Jv[:, tab.jv_real])
        return F, J.reshape(N, m, self.n), res

    def evaluate_batch(self, X: np.ndarray, values: Sequence, jacobian: bool = True):
        """_eval_s for N configurations at once: returns (F, J, res) in scale-free units,
        F (N, m) = residual / length scale, J (N, m, n) = dF/dx with translation columns times the
        length scale (None if not ``jacobian``), res (N,) = max |F| per row, inf where a row's F
        has a NaN or inf (non-finite X or values give such rows, never an exception).

        X (N, n): rows of the variable vector (phi rad, centroid m per free link). ``values``: one
        entry per spec: (N,) for 'angle' (rad) and 'slide' (m) specs, (N, 2) for 'point' (m).
        Only for systems whose non-free links are the ground at its reference pose (what
        evaluate does with fixed=None); ValueError for a hybrid system."""
        X = np.asarray(X, float)
        if X.ndim != 2 or X.shape[1] != self.n:
            raise ValueError(f'X must have shape (N, {self.n}), got {X.shape}')
        return self._batch_eval(X, self._batch_values(values, X.shape[0]), jacobian)

    @staticmethod
    def _det_signs(J: np.ndarray) -> np.ndarray:
        """(K,) int sign of det of a (K, n, n) stack; 0 where singular or not finite."""
        if J.shape[0] == 0:
            return np.zeros(0, int)
        # LAPACK's LU takes NaN and inf without failing (the log|det| comes out NaN): no copy of
        # the finite rows needed
        with np.errstate(invalid='ignore', divide='ignore'):
            s, logdet = np.linalg.slogdet(J)
        return np.where(np.isfinite(logdet), s, 0.0).astype(int)

    @staticmethod
    def _newton_steps(J: np.ndarray, F: np.ndarray) -> np.ndarray:
        """dy (K, n) solving J dy = -F for a (K, n, n) stack; NaN rows where J is singular (one
        singular matrix makes np.linalg.solve raise for the whole stack: then solve the rest)."""
        try:
            return np.linalg.solve(J, -F[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            dy = np.full(F.shape, math.nan)
            regular = LoopSystem._det_signs(J) != 0
            if regular.any():
                dy[regular] = np.linalg.solve(J[regular], -F[regular][:, :, None])[:, :, 0]
            return dy

    @staticmethod
    def _scaled_conds(J: np.ndarray) -> np.ndarray:
        """scaled_cond of each matrix of a finite (K, m, n) stack (inf if an SVD fails)."""
        if J.shape[0] == 0 or J.shape[1] * J.shape[2] == 0:
            return np.ones(J.shape[0])
        peak = np.max(np.abs(J), axis=1, keepdims=True)  # pre-scale, as scaled_cond
        peak[peak == 0] = 1.0
        Jn = J / peak
        norms = np.linalg.norm(Jn, axis=1, keepdims=True)
        norms[norms == 0] = 1.0
        try:
            with np.errstate(divide='ignore', invalid='ignore'):
                return np.linalg.cond(Jn / norms)
        except np.linalg.LinAlgError:
            return np.full(J.shape[0], math.inf)

    @staticmethod
    def _batch_conds(J: np.ndarray) -> np.ndarray:
        """cond of each matrix of a finite (K, n, n) stack as _cond reports it: the 1-norm
        condition number of the scale-free J (exact here, from its inverse; the scalar path
        takes LAPACK's estimate of it) where that is below COND_EXACT, else scaled_cond. Only
        the rows above pay for an SVD (an SVD costs ~5 LUs: the batch's largest cost)."""
        out = np.full(J.shape[0], math.inf)
        if J.shape[0] == 0:
            return out
        try:
            inv = np.linalg.inv(J)
        except np.linalg.LinAlgError:  # an exactly singular matrix: SVDs for all
            return LoopSystem._scaled_conds(J)
        with np.errstate(invalid='ignore', over='ignore'):
            c1 = np.abs(J).sum(axis=1).max(axis=1) * np.abs(inv).sum(axis=1).max(axis=1)
        small = c1 < COND_EXACT  # False for NaN
        out[small] = c1[small]
        if not small.all():
            out[~small] = LoopSystem._scaled_conds(J[~small])
        return out

    def solve_batch(
        self,
        X0: np.ndarray,
        values: Sequence,
        start_sign,
        *,
        tol: float = 1e-12,
        max_steps: int = FAST_STEPS + 2,
    ) -> BatchSolve:
        """Newton for N warm starts at once (numpy over the rows): row i from X0[i] (N, n:
        phi rad, centroid m per free link; typically instance i's last solution) to the values
        of row i (as in evaluate_batch), on the side of det J = 0 given by start_sign[i] (+1 or
        -1, or one int for all). Full Newton steps: J evaluated and factorised at every iterate
        (the scalar fast path takes chord steps after its first). Square systems without fixed
        poses only (ValueError otherwise). ``tol`` bounds max|F| / length scale.

        Row i is ok when, as the scalar fast path (solve_from_guess, then _finish) would accept
        it: det J at X0[i] is finite with sign start_sign[i]; every step cuts max|F| / L at least
        FAST_RATE-fold down to min(tol, max(FAST_MARGIN * tol, FAST_FLOOR)) within ``max_steps``
        (a step that does not, taken from a point already within ``tol``, leaves the row there,
        converged); det J at the answer has the start's sign (else it crossed det J = 0, maybe
        onto another assembly mode); the answer is off folds (cond < POLISH_COND, else the
        scalar path polishes it; cond as _cond reports it: see _batch_conds) and finite.
        Otherwise the row is *declined*, not failed:
        ok False, x its X0 row, residual max|F| / L at X0, det_sign 0, cond inf; the caller
        solves it another way (solve(): the careful path with line search and LM). Rows never
        affect one another: each row's result is what solving it alone would give."""
        self._batch_tables()  # ValueError first if the system needs fixed poses
        if self.m != self.n:
            raise ValueError(
                f'solve_batch needs a square system (m = {self.m} rows, n = {self.n} unknowns)'
            )
        X0 = np.asarray(X0, float)
        if X0.ndim != 2 or X0.shape[1] != self.n:
            raise ValueError(f'X0 must have shape (N, {self.n}), got {X0.shape}')
        N = X0.shape[0]
        V = self._batch_values(values, N)
        want = np.broadcast_to(np.asarray(start_sign), (N,))
        sign0 = np.where(want == 1, 1, np.where(want == -1, -1, 0))
        target = min(tol, max(FAST_MARGIN * tol, FAST_FLOOR))

        x = X0.copy()
        F, J, res = self._batch_eval(x, V, True)
        res0 = res.copy()
        iterations = np.zeros(N, int)
        live = (sign0 != 0) & np.isfinite(res)
        live[live] = self._det_signs(J[live]) == sign0[live]
        done = live & (res <= target)  # converged (pending det sign and cond at the answer)
        active = live & ~done  # still stepping
        for _ in range(max_steps):
            rows = np.flatnonzero(active)
            if not rows.size:
                break
            xn = x[rows] + self._newton_steps(J[rows], F[rows]) * self._step_scale
            Fn, Jn, rn = self._batch_eval(xn, V[rows], True)
            iterations[rows] += 1
            cut = rn <= FAST_RATE * res[rows]  # False for NaN
            stalled = rows[~cut]
            active[stalled] = False
            done[stalled] = res[stalled] <= tol  # at the rounding floor already: converged
            moved = rows[cut]
            x[moved], F[moved], J[moved], res[moved] = xn[cut], Fn[cut], Jn[cut], rn[cut]
            there = moved[rn[cut] <= target]
            active[there] = False
            done[there] = True
        rows = np.flatnonzero(active)  # out of steps: converged if within tol
        done[rows] = res[rows] <= tol

        # at the answer: the start's det J sign (else it crossed det J = 0: maybe another
        # branch; rows still at X0 were checked there) and off folds (else the scalar path
        # polishes)
        rows = np.flatnonzero(done & (iterations > 0))
        done[rows] = self._det_signs(J[rows]) == sign0[rows]
        cond = np.full(N, math.inf)
        rows = np.flatnonzero(done)
        cond[rows] = self._batch_conds(J[rows])
        ok = done & (cond < POLISH_COND) & np.isfinite(x).all(axis=1) & np.isfinite(res)
        return BatchSolve(
            x=np.where(ok[:, None], x, X0),
            ok=ok,
            iterations=iterations,
            residual=np.where(ok, res, res0),
            det_sign=np.where(ok, sign0, 0),
            cond=np.where(ok, cond, math.inf),
        )
