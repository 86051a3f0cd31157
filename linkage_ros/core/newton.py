"""Newton loop-closure solver with an analytic Jacobian.

Unknowns: for every *free* link, its rotation phi from the reference pose and the world position
c of its reference centroid o, so that world(p) = R(phi) (p - o) + c. Equations (all in metres;
angle rows are multiplied by the mechanism's length scale so every row has the same unit):

* revolute joint at P between links a, b:         w_a(P) - w_b(P) = 0                  (2 rows)
* prismatic joint (guide G, slider S, point X):   n_G . (w_S(X) - w_G(X)) = 0,  phi_S - phi_G = 0
* known angle spec:                               phi_L - phi_R - (value - offset) = 0
* known slide spec:                               d_G . (w_S(X) - w_G(origin)) - value = 0
* known point spec:                               w_L(X) - (x, y) = 0                  (2 rows)

Convergence is judged on max|F| / length_scale (scale-free). Between steps the sign of det J is
checked: a flip means a branch jump or a singularity crossed, so the step is bisected. Where Newton
steps stop reducing the residual (near singularities) a Levenberg-Marquardt step takes over.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .dyads import wrap_angle
from .model import Mechanism
from .plan import ScalarPoses, Spec


@dataclass
class SolveResult:
    """Outcome of one Newton solve (configuration vector x over the free links)."""
    x: np.ndarray
    success: bool
    iterations: int
    residual: float              # max |F| / length scale
    reason: str | None = None
    cond: float = float('inf')   # condition number of the column-scaled Jacobian
    det_sign: int = 0


#: at convergence, a scaled cond(J) above this means a near-singular configuration: polish
POLISH_COND = 1e6
POLISH_STEPS = 40
#: a scaled cond(J) above this is a singular configuration (rank-deficient to rounding)
SINGULAR_COND = 1e10




class LoopSystem:
    """The loop-closure equations of a mechanism restricted to a set of free links."""

    def __init__(self, mech: Mechanism, specs: Sequence[Spec], free_links: Sequence[str] | None = None):
        self.mech = mech
        self.specs = list(specs)
        self.L = mech.length_scale
        free = list(free_links) if free_links is not None else mech.moving_links
        self.free = free
        self.index = {l: k for k, l in enumerate(free)}
        self.n = 3 * len(free)
        pts = mech.points
        self.centroid = {n: np.mean([pts[p] for p in l.points], axis=0) for n, l in mech.links.items()}
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
        # revolute rows come first and are evaluated vectorised: for each, the two links (index
        # into all links), their levers p - o (complex) and their variable columns (-1: fixed)
        self.all_links = list(mech.links)
        lidx = {l: i for i, l in enumerate(self.all_links)}
        rev = [row for row in self.rows if row[0] == 'rev']
        self.n_rev = len(rev)
        self._rev_link = np.array([[lidx[a], lidx[b]] for _, a, b, _ in rev], int).reshape(-1, 2)
        self._rev_lever = np.array(
            [[complex(*(pts[P] - self.centroid[a])), complex(*(pts[P] - self.centroid[b]))]
             for _, a, b, P in rev], complex).reshape(-1, 2)
        self._rev_col = np.array([[3 * self.index[l] if l in self.index else -1 for l in (a, b)]
                                  for _, a, b, _ in rev], int).reshape(-1, 2)
        self._free_idx = np.array([lidx[l] for l in free], int)
        # flat Jacobian positions of the revolute entries, per side (0: parent, 1: child):
        # (row, d/dphi), (row+1, d/dphi), (row, d/dcx), (row+1, d/dcy) for free links only
        self._rev_flat, self._rev_mask = [], []
        for side in (0, 1):
            col = self._rev_col[:, side] if self.n_rev else np.zeros(0, int)
            m_ = col >= 0
            rr, cc = 2 * np.arange(self.n_rev)[m_], col[m_]
            n = self.n
            self._rev_flat.append(np.concatenate([rr * n + cc, (rr + 1) * n + cc,
                                                  rr * n + cc + 1, (rr + 1) * n + cc + 2]))
            self._rev_mask.append(m_)
        self._centroid_c = np.array([complex(*self.centroid[l]) for l in self.all_links])

    def _spec_links(self, s: Spec) -> list[str]:
        if s.kind == 'angle':
            return [s.link, s.reference]
        if s.kind == 'slide':
            pj = self.mech.prismatics[s.joint]
            return [pj.guide, pj.slider]
        return [self.mech.links_of_point(s.point)[0]]

    # -- conversions between poses and the variable vector -------------------------------------
    def x_from_poses(self, poses: ScalarPoses) -> np.ndarray:
        """Variable vector of the free links from a configuration."""
        x = np.empty(self.n)
        for l, i in self.index.items():
            o = self.centroid[l]
            c = poses.rot[l] * complex(o[0], o[1]) + poses.T[l]
            x[3 * i:3 * i + 3] = (poses.phi[l], c.real, c.imag)
        return x

    def reference_x(self) -> np.ndarray:
        x = np.zeros(self.n)
        for l, i in self.index.items():
            x[3 * i + 1:3 * i + 3] = self.centroid[l]
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

    @staticmethod
    def _rot(phi: float, v) -> np.ndarray:
        c, s = math.cos(phi), math.sin(phi)
        return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])

    # -- evaluation ---------------------------------------------------------------------------
    def _pose(self, link, x, fixed):
        """(phi, cos, sin, cx, cy, column or -1) of a link, free or fixed."""
        i = self.index.get(link)
        if i is not None:
            phi, cx, cy = x[3 * i], x[3 * i + 1], x[3 * i + 2]
            return phi, math.cos(phi), math.sin(phi), cx, cy, 3 * i
        if fixed is not None and link in fixed.phi:
            phi, rot = fixed.phi[link], fixed.rot[link]
            o = self.centroid[link]
            c = rot * complex(o[0], o[1]) + fixed.T[link]
            return phi, rot.real, rot.imag, c.real, c.imag, -1
        if link == self.mech.ground:
            o = self.centroid[link]
            return 0.0, 1.0, 0.0, float(o[0]), float(o[1]), -1
        raise KeyError(f'link {link!r} is neither free nor fixed')

    def evaluate(self, x: np.ndarray, values: Sequence, fixed: ScalarPoses | None = None,
                 jacobian: bool = True):
        """Residual F (m,) and, if asked, the analytic Jacobian J (m, n)."""
        mech, L = self.mech, self.L
        F = np.empty(self.m)
        J = np.zeros((self.m, self.n)) if jacobian else None
        cache: dict[str, tuple] = {}

        def pose(link):
            p = cache.get(link)
            if p is None:
                p = cache[link] = self._pose(link, x, fixed)
            return p

        def world(link, p):
            """world position and the lever R(p - o) (for d/dphi = perp(lever))."""
            phi, c, s, cx, cy, col = pose(link)
            o = self.centroid[link]
            vx, vy = p[0] - o[0], p[1] - o[1]
            rx, ry = c * vx - s * vy, s * vx + c * vy
            return cx + rx, cy + ry, rx, ry, col

        def add_point(row, link, p, sign):
            """Add sign * d w_link(p) / dx into rows row, row+1."""
            wx, wy, rx, ry, col = world(link, p)
            if jacobian and col >= 0:
                J[row, col] += sign * -ry
                J[row + 1, col] += sign * rx
                J[row, col + 1] += sign
                J[row + 1, col + 2] += sign
            return wx, wy

        r = 2 * self.n_rev
        if self.n_rev:
            self._revolute_rows(x, fixed, F, J)
        pts = mech.points
        for row in self.rows[self.n_rev:]:
            kind = row[0]
            if kind == 'pri':
                pj = row[1]
                F[r], F[r + 1] = self._line_rows(r, J, pj, pj.point, pts[pj.point], world, pose, L,
                                                 normal=True)
                r += 2
            else:
                s = self.specs[row[1]]
                v = values[row[1]]
                if s.kind == 'angle':
                    pl, pr = pose(s.link), pose(s.reference)
                    F[r] = L * wrap_angle(pl[0] - pr[0] - (wrap_angle(float(v)) - s.offset))
                    if jacobian:
                        if pl[5] >= 0:
                            J[r, pl[5]] += L
                        if pr[5] >= 0:
                            J[r, pr[5]] -= L
                    r += 1
                elif s.kind == 'slide':
                    pj = mech.prismatics[s.joint]
                    F[r] = self._line_rows(r, J, pj, pj.point, np.asarray(pj.origin), world, pose,
                                           L, normal=False)[0] - float(v)
                    r += 1
                else:
                    owner = mech.links_of_point(s.point)[0]
                    wx, wy = add_point(r, owner, pts[s.point], 1.0)
                    F[r], F[r + 1] = wx - float(v[0]), wy - float(v[1])
                    r += 2
        return F, J

    def _revolute_rows(self, x, fixed, F, J):
        """Rows w_a(P) - w_b(P) of every revolute joint at once (complex arithmetic)."""
        phi = np.zeros(len(self.all_links))
        c = self._centroid_c.copy()            # ground and unknown-fixed: reference pose
        if fixed is not None:
            for i, l in enumerate(self.all_links):
                if l in fixed.phi and l not in self.index:
                    phi[i] = fixed.phi[l]
                    c[i] = fixed.rot[l] * self._centroid_c[i] + fixed.T[l]
        if len(self._free_idx):
            phi[self._free_idx] = x[0::3]
            c[self._free_idx] = x[1::3] + 1j * x[2::3]
        rot = np.exp(1j * phi)
        lever = rot[self._rev_link] * self._rev_lever          # (n_rev, 2)
        w = c[self._rev_link] + lever
        d = w[:, 0] - w[:, 1]
        F[0:2 * self.n_rev:2] = d.real
        F[1:2 * self.n_rev:2] = d.imag
        if J is None:
            return
        vals = []
        for side, sign in ((0, 1.0), (1, -1.0)):
            lv = lever[self._rev_mask[side], side]
            ones = np.full(len(lv), sign)
            vals.append(np.concatenate([sign * -lv.imag, sign * lv.real, ones, ones]))  # i*lever
        # one scatter for all entries (bincount sums the parent and child contributions)
        J += np.bincount(np.concatenate(self._rev_flat), weights=np.concatenate(vals),
                         minlength=J.size).reshape(J.shape)

    def _line_rows(self, r, J, pj, xname, base_ref, world, pose, L, normal):
        """Rows of a prismatic pair: the slider point's offset from the guide line (normal=True,
        plus the orientation lock) or its signed distance along it from base_ref (normal=False)."""
        G, S = pj.guide, pj.slider
        phiG, cG, sG, _, _, colG = pose(G)
        phiS, _, _, _, _, colS = pose(S)
        d0 = pj.direction
        if normal:
            u0 = (-d0[1], d0[0])
        else:
            u0 = d0
        ux, uy = cG * u0[0] - sG * u0[1], sG * u0[0] + cG * u0[1]
        sx, sy, srx, sry, _ = world(S, self.mech.points[xname])
        gx, gy, grx, gry, _ = world(G, base_ref)
        dx, dy = sx - gx, sy - gy
        f = ux * dx + uy * dy
        if J is not None:
            if colG >= 0:
                # d u / dphi = perp(u); d w_G / dphi = perp(lever)
                J[r, colG] += (-uy) * dx + ux * dy - (ux * (-gry) + uy * grx)
                J[r, colG + 1] -= ux
                J[r, colG + 2] -= uy
            if colS >= 0:
                J[r, colS] += ux * (-sry) + uy * srx
                J[r, colS + 1] += ux
                J[r, colS + 2] += uy
        if not normal:
            return f, 0.0
        g = L * wrap_angle(phiS - phiG)
        if J is not None:
            if colS >= 0:
                J[r + 1, colS] += L
            if colG >= 0:
                J[r + 1, colG] -= L
        return f, g

    # -- solving ------------------------------------------------------------------------------
    def scaled_cond(self, J: np.ndarray) -> float:
        if J.size == 0:
            return 1.0
        peak = np.max(np.abs(J), axis=0)         # pre-scale: column norms of 1e300 overflow
        peak[peak == 0] = 1.0
        Jn = J / peak
        norms = np.linalg.norm(Jn, axis=0)
        norms[norms == 0] = 1.0
        try:
            return float(np.linalg.cond(Jn / norms))
        except np.linalg.LinAlgError:
            return float('inf')

    def det_sign(self, J: np.ndarray) -> int:
        if J.shape[0] != J.shape[1] or J.size == 0:
            return 0
        sign, logdet = np.linalg.slogdet(J)
        return int(sign) if np.isfinite(logdet) else 0

    def _same_side(self, sign0: int, J: np.ndarray) -> bool:
        """The step stays on the start's side of det J = 0 (or lands on the singular set itself,
        e.g. a toggle that is the answer, where the sign is rounding noise)."""
        return (sign0 == 0 or self.det_sign(J) == sign0
                or self.scaled_cond(J) > SINGULAR_COND)

    def _scaled(self, x, values, fixed):
        """F and J in scale-free units: rows / L and translations / L (so nothing overflows at
        1e300 m, and the LM damping means the same at every scale). Steps come back as
        dy, with dx = dy * self._step_scale."""
        F, J = self.evaluate(x, values, fixed)
        return F / self.L, J * self._col_scale

    def solve(self, x0: np.ndarray, values: Sequence, fixed: ScalarPoses | None = None, *,
              tol: float = 1e-12, max_iter: int = 50, keep_det_sign: bool = True,
              start_sign: int | None = None) -> SolveResult:
        """Newton iterations from x0; line-search bisection on det-sign flips; LM fallback.
        Works in scale-free units (see _scaled); ``tol`` bounds max|F| / length scale."""
        self._col_scale = np.tile([1.0 / self.L, 1.0, 1.0], len(self.free))
        self._step_scale = np.tile([1.0, self.L, self.L], len(self.free))
        x = np.array(x0, float)
        F, J = self._scaled(x, values, fixed)
        res = float(np.max(np.abs(F))) if F.size else 0.0
        # at a singular start (a change point) det J has no meaningful sign: do not track it
        if not keep_det_sign:
            sign0 = 0
        elif start_sign is not None:          # known from the solve that produced x0
            sign0 = start_sign
        else:
            sign0 = self.det_sign(J) if self.scaled_cond(J) < SINGULAR_COND else 0
        it = 0
        mu = None
        square = J.shape[0] == J.shape[1]
        while res > tol and it < max_iter:
            it += 1
            fnorm = float(np.linalg.norm(F))
            step = None
            if mu is None:
                try:
                    dx = np.linalg.solve(J, -F) if square else np.linalg.lstsq(J, -F, rcond=None)[0]
                    if np.all(np.isfinite(dx)):
                        step = dx * self._step_scale
                except np.linalg.LinAlgError:
                    step = None
            accepted = False
            if step is not None:
                alpha = 1.0
                for _ in range(10):
                    xn = x + alpha * step
                    Fn, Jn = self._scaled(xn, values, fixed)
                    if (np.linalg.norm(Fn) < (1.0 - 1e-4 * alpha) * fnorm
                            and self._same_side(sign0, Jn)):
                        x, F, J = xn, Fn, Jn
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
                        dx = np.linalg.solve(JtJ + mu * np.diag(D), -g)
                    except np.linalg.LinAlgError:
                        mu *= 10
                        continue
                    xn = x + dx * self._step_scale
                    Fn, Jn = self._scaled(xn, values, fixed)
                    if np.linalg.norm(Fn) < fnorm and self._same_side(sign0, Jn):
                        x, F, J = xn, Fn, Jn
                        mu = max(mu / 10, 1e-12)
                        accepted = True
                        break
                    mu *= 10
                if not accepted:
                    break
            res = float(np.max(np.abs(F))) if F.size else 0.0
        cond = self.scaled_cond(J)
        if res <= tol and cond > POLISH_COND:
            # near a toggle Newton converges only linearly and the configuration error is
            # ~sqrt(residual): polish while it still pays, so margins and branch signs read off
            # the answer are as exact as floating point allows
            for _ in range(POLISH_STEPS):
                if res <= 1e-15:
                    break
                try:
                    dx = np.linalg.solve(J, -F) if square else np.linalg.lstsq(J, -F, rcond=None)[0]
                except np.linalg.LinAlgError:
                    break
                xn = x + dx * self._step_scale
                Fn, Jn = self._scaled(xn, values, fixed)
                rn = float(np.max(np.abs(Fn)))
                if not (np.all(np.isfinite(xn)) and rn < 0.7 * res):
                    break
                x, F, J, res = xn, Fn, Jn, rn
                it += 1
            cond = self.scaled_cond(J)
        det = self.det_sign(J) if cond < SINGULAR_COND else 0     # 0: singular, no sign
        if res <= tol:
            return SolveResult(x, True, it, res, None, cond, det)
        if it >= max_iter:
            reason = (f'Newton reached its iteration cap ({max_iter}) with loop-closure residual '
                      f'{res:.3g} of the length scale (tolerance {tol:g})')
        else:
            reason = (f'Newton stalled with loop-closure residual {res:.3g} of the length scale: '
                      f'no assembly near the start (cond J = {cond:.3g}); the input may be beyond '
                      'a limit or toggle position')
        return SolveResult(x, False, it, res, reason, cond, det)
