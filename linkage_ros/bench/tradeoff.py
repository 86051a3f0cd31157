"""Speed against accuracy of every solver setting, per scene (scalar sweeps and batches)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from .reference import MpReference, point_errors, reference_points
from .settings import NEWTON_TOLS, SCIPY_XTOLS, SettingFamily, Sizes

#: a batch function's label (time_batches)
K = TypeVar('K', bound=Hashable)

# =============================================================================================
# scenes, inputs and settings
# =============================================================================================


def load_scene(name: str):
    from ..core.model import Scene
    from ..resources import scene_path

    return Scene.from_yaml(scene_path(name)).mechanism


def sweep_inputs(mech, n: int) -> list[dict[str, float]]:
    """A closed warm-started path of n commands starting at the reference pose's input."""
    from ..core.solver import Solver

    ref = list(Solver(mech, method='newton').reference_values().values())
    acts = list(mech.actuators)
    out = []
    phases = []
    for k, a in enumerate(acts):
        act = mech.actuators[a]
        r0 = float(ref[k])
        if act.min is None or act.max is None:
            phases.append(('turn', r0, 0.0, 0.0))
        else:
            mid, amp = 0.5 * (act.min + act.max), 0.4 * (act.max - act.min)
            if a == 'crank':  # Peaucellier: most of the range, through 0
                mid, amp = 0.0, 0.92 * max(abs(act.min), abs(act.max))
            s = max(-1.0, min(1.0, (r0 - mid) / amp))
            phases.append(('osc', mid, amp, math.asin(s)))
    for i in range(n):
        t = 2 * math.pi * i / n
        cmd = {}
        for k, (a, (kind, m, amp, ph)) in enumerate(zip(acts, phases)):
            cmd[a] = m + t if kind == 'turn' else m + amp * math.sin(ph + (k + 1) * t)
        out.append(cmd)
    return out


@dataclass
class SettingResult:
    scene: str
    setting: str
    family: SettingFamily
    tol: float | None = None
    scalar_us: float | None = None
    batch_us: float | None = None
    err_max: float | None = None
    err_median: float | None = None
    batch_err_max: float | None = None
    batch_failures: int | None = None
    batch_careful: int | None = None  # newton batches: rows that took Solver.solve's careful path
    #: Newton 1e-12 batches: scipy root's time per solve over its tight-xtol sweep divided by the
    #: batch's per solve, each batch paired with a scipy sweep right after it (median of the
    #: pairs): both sides timed at the same moment, which a ratio of two phases is not
    batch_vs_scipy: float | None = None
    failures: int = 0
    n: int = 0
    iterations: float | None = None
    note: str = ''

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _median_us(ts: list[int] | np.ndarray) -> float:
    return float(np.median(np.asarray(ts, float))) / 1e3


def _result_points(res, names) -> np.ndarray:
    out = np.full((len(names), 2), np.nan)
    if res.success:
        for j, p in enumerate(names):
            v = res.points.get(p)
            if v is not None:
                out[j] = v
    return out


class Stepper:
    """One solver setting walking the warm-started sweep: ``step(i, cmd)`` times one solve.
    Every setting of a scene is stepped in turn at each input (interleaved), so drifting
    machine load hits all of them alike; the warm-start chain of each setting continues
    across passes (the sweep is a closed path)."""

    def __init__(self, n_inputs: int, n_points: int):
        self.ts: list[int] = []
        self.pts = np.full((n_inputs, n_points, 2), np.nan)
        self.fails = 0
        self.iters: list[float] = []

    def step(self, i: int, cmd: dict, record: bool) -> None:
        raise NotImplementedError

    def median_us(self) -> float:
        return _median_us(self.ts)

    def mean_iterations(self) -> float | None:
        return float(np.mean(self.iters)) if self.iters else None


class SolverStepper(Stepper):
    def __init__(self, solver, n_inputs):
        super().__init__(n_inputs, len(solver.mech.points))
        self.solver = solver
        self.names = list(solver.mech.points)

    def step(self, i, cmd, record):
        t0 = time.perf_counter_ns()
        r = self.solver.solve(cmd)
        self.ts.append(time.perf_counter_ns() - t0)
        if record:
            self.pts[i] = _result_points(r, self.names)
            self.fails += not r.success
            self.iters.append(r.iterations)


class DirectStepper(Stepper):
    def __init__(self, scalar, points, mech, n_inputs):
        super().__init__(n_inputs, len(mech.points))
        self.scalar, self.points = scalar, points

    def step(self, i, cmd, record):
        t = cmd['crank']
        t0 = time.perf_counter_ns()
        sol = self.scalar(t)
        self.ts.append(time.perf_counter_ns() - t0)
        if record:
            self.pts[i] = self.points(t, sol)
            self.fails += not bool(sol.ok)
            self.iters.append(0)


class KernelStepper(Stepper):
    """The Newton kernel alone (LoopSystem.solve): the like-for-like counterpart of
    scipy.optimize.root (no continuation checks, no Result assembly). Warm-started like the
    Solver: from the previous solution, through the predicted one (LoopSystem.predict from the
    last two solutions and their Jacobian factorisations), tracking the sign of det J; the
    prediction is timed with the solve."""

    def __init__(self, mech, tol, n_inputs):
        from ..core.solver import Solver

        super().__init__(n_inputs, len(mech.points))
        self.solver = Solver(mech, method='newton', tol=tol)
        self.system = self.solver.system
        self.tol = tol
        self.x = self.system.reference_x()
        self.vals = self.rate = self.before = self.sign = None

    def step(self, i, cmd, record):
        vals = self.solver.parse(cmd)
        system = self.system
        t0 = time.perf_counter_ns()
        guess = None
        if self.rate is not None and self.vals is not None:
            guess = system.predict(self.x, self.rate, self.vals, vals, *(self.before or ()))
        r = system.solve(
            self.x, vals, None, tol=self.tol, max_iter=50, start_sign=self.sign, guess=guess
        )
        rate = system.rate_factor(r)
        self.ts.append(time.perf_counter_ns() - t0)
        if r.success:
            self.before = (self.x, self.vals, self.rate) if self.vals is not None else None
            self.x, self.vals, self.rate = r.x, vals, rate
            self.sign = r.det_sign or None
        if record:
            self.fails += not r.success
            self.iters.append(r.iterations)


class ScipyStepper(Stepper):
    """scipy.optimize.root (hybr, finite-difference Jacobian) on the Newton solver's own
    loop-closure residual, warm-started from its previous solution like the Solver."""

    def __init__(self, mech, xtol, n_inputs):
        from ..core.solver import Solver

        super().__init__(n_inputs, len(mech.points))
        self.mech = mech
        self.solver = Solver(mech, method='newton')
        self.system = self.solver.system
        self.xtol = xtol
        self.x = self.system.reference_x()
        self.names = list(mech.points)

    def step(self, i, cmd, record):
        from scipy.optimize import root

        system = self.system
        vals = self.solver.parse(cmd)
        t0 = time.perf_counter_ns()
        sol = root(
            lambda z: system.evaluate(z, vals, None, jacobian=False)[0],
            self.x,
            method='hybr',
            options={'xtol': self.xtol},
        )
        self.ts.append(time.perf_counter_ns() - t0)
        if sol.success:
            self.x = sol.x
        if record:
            self.iters.append(sol.nfev)
            if not sol.success:
                self.fails += 1
                return
            poses = system.poses_from_x(sol.x)
            mech = self.mech
            for l, link in mech.links.items():
                for p in link.points:
                    w = poses.world(l, complex(*mech.points[p]))
                    self.pts[i, self.names.index(p)] = (w.real, w.imag)


def run_interleaved(steppers: Sequence[Stepper], cmds: list[dict], repeats: int) -> None:
    """Every stepper solves input i in turn (rotating who goes first), pass after pass; the
    last pass is recorded (points, failures, iterations)."""
    k = len(steppers)
    for rep in range(repeats):
        last = rep == repeats - 1
        for i, c in enumerate(cmds):
            off = (i + rep) % k
            for j in range(k):
                steppers[(off + j) % k].step(i, c, last)


def time_batches(fns: dict[K, Callable[[], Any]], n: int, repeats: int) -> dict[K, float]:
    """Median time per input (us) of each batch function, the functions taking turns."""
    ts: dict[K, list[float]] = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            t0 = time.perf_counter_ns()
            fn()
            ts[k].append((time.perf_counter_ns() - t0) / n)
    return {k: float(np.median(v)) / 1e3 for k, v in ts.items()}


def batch_columns(cmds: list[dict], n: int) -> dict[str, np.ndarray]:
    reps = -(-n // len(cmds))
    return {a: np.tile(np.array([c[a] for c in cmds], float), reps)[:n] for a in cmds[0]}


# ---- direct closed forms (core.fourbar) ------------------------------------------------------


def _direct(mech):
    """(scalar fn(theta) -> raw result, batch fn(theta array), points(raw) -> (n, P, 2))."""
    from ..core import fourbar
    from ..core.mechanism import SceneForm

    sc = mech.shortcut
    names = list(mech.points)
    if mech.form is SceneForm.FOUR_BAR:
        if sc['ground_angle'] != 0.0:
            raise NotImplementedError('direct closed form: ground_angle must be 0')
        l1, l2, l3, l4, br = sc['ground'], sc['crank'], sc['coupler'], sc['rocker'], sc['branch']
        extra = [p for p in mech.links['coupler'].points if p not in ('A', 'B')]
        P0, A0, B0 = (mech.points[p] for p in (extra[0], 'A', 'B')) if extra else (None,) * 3
        cp = None
        if extra:
            assert P0 is not None and A0 is not None and B0 is not None
            v, u = P0 - A0, B0 - A0
            cp = (math.hypot(*v), math.atan2(v[1], v[0]) - math.atan2(u[1], u[0]))

        def scalar(t):
            return fourbar.fourbar_forward(l1, l2, l3, l4, t, br)

        def points(t, sol):
            t = np.asarray(t, float)
            ok = np.asarray(sol.ok)
            ax, ay = l2 * np.cos(t), l2 * np.sin(t)
            bx, by = ax + l3 * np.cos(sol.theta3), ay + l3 * np.sin(sol.theta3)
            got = {
                'O2': (np.zeros_like(t), np.zeros_like(t)),
                'O4': (np.full_like(t, l1), np.zeros_like(t)),
                'A': (ax, ay),
                'B': (bx, by),
            }
            if cp:
                ang = sol.theta3 + cp[1]
                got[extra[0]] = (ax + cp[0] * np.cos(ang), ay + cp[0] * np.sin(ang))
            out = np.full(t.shape + (len(names), 2), np.nan)
            for j, p in enumerate(names):
                out[..., j, 0], out[..., j, 1] = got[p]
            out[~ok] = np.nan
            return out

        return scalar, scalar, points
    if mech.form is SceneForm.SLIDER_CRANK:
        if sc['direction'] != 0.0:
            raise NotImplementedError('direct closed form: direction must be 0')
        r, rod, e, br = sc['crank'], sc['rod'], sc['offset'], sc['branch']

        def scalar(t):
            return fourbar.slider_crank_forward(r, rod, e, t, br)

        def points(t, sol):
            t = np.asarray(t, float)
            got = {
                'O2': (np.zeros_like(t), np.zeros_like(t)),
                'A': (r * np.cos(t), r * np.sin(t)),
                'B': (np.asarray(sol.x), np.full_like(t, e)),
            }
            out = np.full(t.shape + (len(names), 2), np.nan)
            for j, p in enumerate(names):
                out[..., j, 0], out[..., j, 1] = got[p]
            out[~np.asarray(sol.ok)] = np.nan
            return out

        return scalar, scalar, points
    return None


# =============================================================================================
# the solver-settings table
# =============================================================================================


def bench_scene(name: str, sizes: Sizes) -> tuple[list[SettingResult], dict]:
    from ..core.solver import Solver

    mech = load_scene(name)
    L = mech.length_scale
    cmds = sweep_inputs(mech, sizes.sweep)
    names = list(mech.points)
    rows: list[SettingResult] = []
    info: dict[str, Any] = {
        'scene': name,
        'length_scale': L,
        'n_inputs': len(cmds),
        'actuators': list(mech.actuators),
        'points': names,
    }

    # the reference: 50 digits, from the dyad plan's double answer at every input
    t0 = time.perf_counter()
    plan_solver = Solver(mech, method='closed_form')
    starts = []
    for c in cmds:
        r = plan_solver.solve(c)
        if not r.success:
            raise RuntimeError(f'{name}: the sweep input {c} does not assemble: {r.reason}')
        starts.append(r.points)
    ref = MpReference(mech)
    hi, lo, worst = reference_points(ref, cmds, starts)
    info['reference_seconds'] = time.perf_counter() - t0
    info['reference_residual'] = worst
    info['reference_unknowns'] = ref.n

    def add(row: SettingResult, pts: np.ndarray | None):
        if pts is not None:
            err = point_errors(pts, hi, lo, L)
            good = err[~np.isnan(err)]
            row.err_max = float(good.max()) if good.size else None
            row.err_median = float(np.median(good)) if good.size else None
        row.n = len(cmds)
        rows.append(row)

    # every setting, stepped in turn at each input of the warm-started sweep
    n = len(cmds)
    settings: list[tuple[SettingResult, Stepper, bool]] = []
    direct = _direct(mech)
    if direct is not None:
        scalar, batch, points = direct
        settings.append(
            (
                SettingResult(name, 'direct closed form (core.fourbar)', SettingFamily.DIRECT),
                DirectStepper(scalar, points, mech, n),
                True,
            )
        )
    settings.append(
        (
            SettingResult(name, 'dyad plan (Solver closed_form)', SettingFamily.DYAD),
            SolverStepper(Solver(mech, method='closed_form'), n),
            True,
        )
    )
    for tol in NEWTON_TOLS:
        settings.append(
            (
                SettingResult(name, f'Newton tol {tol:g}', SettingFamily.NEWTON, tol=tol),
                SolverStepper(Solver(mech, method='newton', tol=tol), n),
                True,
            )
        )
    settings.append(
        (
            SettingResult(
                name,
                'Newton kernel tol 1e-12 (LoopSystem.solve)',
                SettingFamily.KERNEL,
                tol=1e-12,
                note='no Result assembly; error not measured',
            ),
            KernelStepper(mech, 1e-12, n),
            False,
        )
    )
    for xtol in SCIPY_XTOLS:
        settings.append(
            (
                SettingResult(
                    name,
                    f'scipy root hybr xtol {xtol:.3g}',
                    SettingFamily.SCIPY,
                    tol=xtol,
                    note='iterations = function evaluations',
                ),
                ScipyStepper(mech, xtol, n),
                True,
            )
        )
    run_interleaved([st for _, st, _ in settings], cmds, sizes.repeats)
    for row, st, _has_pts in settings:
        row.scalar_us = st.median_us()
        row.failures = st.fails
        row.iterations = st.mean_iterations()

    # vectorised batches of the closed forms (per input), taking turns
    cols = batch_columns(cmds, sizes.batch)
    exact = {a: np.array([c[a] for c in cmds]) for a in mech.actuators}
    sb = Solver(mech, method='closed_form')
    fns = {SettingFamily.DYAD: lambda: sb.solve_batch(cols)}
    if direct is not None:
        fns[SettingFamily.DIRECT] = lambda: batch(cols['crank'])
    per = time_batches(fns, sizes.batch, sizes.batch_repeats)
    for row, st, has_pts in settings:
        if row.family is SettingFamily.DIRECT:
            row.batch_us = per[SettingFamily.DIRECT]
            e = point_errors(points(exact['crank'], batch(exact['crank'])), hi, lo, L)
            row.batch_err_max = float(np.nanmax(e))
        elif row.family is SettingFamily.DYAD:
            row.batch_us = per[SettingFamily.DYAD]
            br = sb.solve_batch(exact)
            bpts = np.stack([br.points[p] for p in names], axis=1)
            e = point_errors(np.where(br.ok[:, None, None], bpts, np.nan), hi, lo, L)
            row.batch_err_max = float(np.nanmax(e)) if np.any(~np.isnan(e)) else None
        elif row.family is SettingFamily.NEWTON:
            _newton_batch(row, mech, cmds, sizes.batch_repeats, names, hi, lo)
        add(row, st.pts if has_pts else None)
    return rows, info


def _newton_batch(row: SettingResult, mech, cmds: list[dict], repeats: int, names, hi, lo):
    """Warm-started Newton vectorised over instances: the sweep's n inputs as n independent
    instances, instance i warm-started from its answer at the input before it on the closed
    sweep (the same start the scalar sweep has), all solved by one Solver.solve_batch(start=).
    Time per solve = median batch time / n; errors against the same 50-digit reference. At tol
    1e-12 each batch is followed by a warm scipy root sweep (hybr, xtol 1e-12) over the same
    inputs, and ``batch_vs_scipy`` is the median of the pairs' ratios (per solve): the two sides
    timed at the same moment. (The scalar settings' scipy median comes from another phase of
    the run; on a shared machine the host's speed moves between phases by up to 2x.)"""
    from ..core.solver import Solver

    n = len(cmds)
    assert row.tol is not None  # a Newton setting has one
    solver = Solver(mech, method='newton', tol=row.tol)
    cols = {a: np.array([c[a] for c in cmds], float) for a in mech.actuators}
    before = {a: np.roll(v, 1) for a, v in cols.items()}  # instance i was at input i - 1
    start = solver.solve_batch(before)  # a path, solved one by one
    paired = row.tol == 1e-12 and 1e-12 in SCIPY_XTOLS
    scipy = ScipyStepper(mech, 1e-12, n) if paired else None
    ts, ratios = [], []
    for _ in range(max(repeats, 3)):
        t0 = time.perf_counter_ns()
        res = solver.solve_batch(cols, start=start)
        per_solve = (time.perf_counter_ns() - t0) / n
        ts.append(per_solve)
        if scipy is not None:
            scipy.ts = []
            for i, c in enumerate(cmds):
                scipy.step(i, c, False)
            ratios.append(float(np.median(scipy.ts)) / per_solve)
    row.batch_us = float(np.median(ts)) / 1e3
    row.batch_vs_scipy = float(np.median(ratios)) if ratios else None
    pts = np.stack([res.points[p] for p in names], axis=1)
    e = point_errors(np.where(res.ok[:, None, None], pts, np.nan), hi, lo, mech.length_scale)
    row.batch_err_max = float(np.nanmax(e)) if np.any(~np.isnan(e)) else None
    row.batch_failures = int(np.sum(~res.ok))
    row.batch_careful = int(np.sum(res.careful)) if res.careful is not None else 0
