"""The batched Newton kernel (core.newton): LoopSystem.solve_batch on warm-started sweeps
(evaluate_batch: test_newton_batch_evaluate.py; declined rows: test_newton_batch_declines.py).

Oracles: the Solver's scalar warm-started sweeps (the predictor fast path and careful path,
solved one command at a time), the closed-form solver for the other assembly mode, and
np.linalg.slogdet / scaled_cond at the answers.

Would fail if: a batch answer differed from the scalar sweep's, had another det J sign, a
residual above tol or took more than a few steps; kept arrays changed the answers; the batch or
warm starts broke their acceptance rule; or max_steps were exceeded.
"""

import math

import numpy as np
import pytest
from newton_batch_helpers import (
    POINT_KNOWNS,
    TOL,
    check_against_sweep,
    pick,
    scalar_sweep,
    scene,
    stack,
)

from linkage_ros.core.newton import (
    FAST_FLOOR,
    FAST_MARGIN,
    FAST_RATE,
    MAX_PREDICTION,
    NEAR_SINGULAR_COND,
)
from linkage_ros.core.quantities import PointSpec
from linkage_ros.core.solver import Solver

SWEEP_SCENES = ['four_bar', 'slider_crank', 'peaucellier', 'excavator']


# =============================================================================================
# solve_batch on warm-started sweeps: the scalar Solver's answers
# =============================================================================================


@pytest.mark.parametrize('name', SWEEP_SCENES)
def test_solve_batch_reproduces_the_scalar_sweep(name):
    """Every step k - 1 -> k of a 300-command sweep as one batch (X0 = x_{k-1}, start sign
    det_sign_{k-1}, values at k): (nearly) every row ok, each the scalar answer within 1e-10
    (scale-free), residual within tol, same det J sign, at most 4 Newton steps."""
    sy, xs, signs, vals = scalar_sweep(name, 300)
    K = len(xs)
    X0 = xs[:-1]
    keep = X0.copy()
    b = sy.solve_batch(X0, stack(sy, vals[1:]), signs[:-1], tol=TOL)
    assert np.array_equal(X0, keep)  # the start is not written to
    assert b.x.shape == (K - 1, sy.n) and b.ok.dtype == bool
    assert b.ok.mean() >= 0.98, b.ok.mean()
    check_against_sweep(sy, xs, signs, vals, b, np.arange(K - 1))
    assert b.iterations[b.ok].max() <= 4
    # declined rows (if any) are left at their start
    assert np.array_equal(b.x[~b.ok], X0[~b.ok])
    assert np.all(b.det_sign[~b.ok] == 0) and np.all(np.isinf(b.cond[~b.ok]))


@pytest.mark.parametrize('name', ['four_bar', 'excavator'])
def test_kept_arrays_leave_the_answers_alone(name):
    """The batched solve keeps its packed J arrays (their constant entries not written again)
    and its J^-1 rows array for the next batch of the same size: a batch solved after others
    (of this size with NaN and noisy starts, of another size) is the batch a fresh system
    solves, bit for bit, and the scalar sweep's answers."""
    sy, xs, signs, vals = scalar_sweep(name, 200)
    X0, V, S = xs[:-1], stack(sy, vals[1:]), signs[:-1]
    fresh = Solver(scene(name), method='newton').system.solve_batch(X0, V, S, tol=TOL)
    used = Solver(scene(name), method='newton').system
    rng = np.random.default_rng(17)
    noisy = X0 + rng.normal(size=X0.shape) * 0.05 * used.step_scale
    noisy[::7] = np.nan
    used.solve_batch(noisy, V, S, tol=TOL)
    used.solve_batch(X0[:50], pick(V, slice(0, 50)), S[:50], tol=TOL)
    used.solve_batch(noisy, V, S, tol=TOL)
    again = used.solve_batch(X0, V, S, tol=TOL)
    for field in ('x', 'ok', 'iterations', 'residual', 'det_sign', 'cond'):
        assert np.array_equal(getattr(again, field), getattr(fresh, field)), field
    check_against_sweep(used, xs, signs, vals, again, np.arange(len(xs) - 1))


@pytest.mark.parametrize('name', SWEEP_SCENES)
def test_coarse_steps_are_declined_or_right(name):
    """A 60-command sweep (steps too big for some rows to converge FAST_RATE per step): every
    row is either declined at its start or the scalar answer; never another one."""
    sy, xs, signs, vals = scalar_sweep(name, 60)
    b = sy.solve_batch(xs[:-1], stack(sy, vals[1:]), signs[:-1], tol=TOL)
    check_against_sweep(sy, xs, signs, vals, b, np.arange(len(xs) - 1))
    assert np.array_equal(b.x[~b.ok], xs[:-1][~b.ok])
    for i in np.flatnonzero(~b.ok):  # residual at the start, as documented
        assert b.residual[i] == pytest.approx(
            sy.evaluate_scaled(xs[i], vals[i + 1], None)[2], rel=1e-12
        )


def rule(sy, x0, vals, sign, tol=TOL, max_steps=6, warm=False):
    """The acceptance rule solve_batch documents, one row in plain scalar code (evaluate_scaled,
    np.linalg.solve, slogdet, scaled_cond): (ok, x, steps, stalled converged). ``warm``: the
    first step is judged as the scalar path's prediction (it moves no unknown further than
    MAX_PREDICTION, to a finite residual), not by FAST_RATE."""
    target = min(tol, max(FAST_MARGIN * tol, FAST_FLOOR))
    F, J, res = sy.evaluate_scaled(x0, vals, None)
    if sign not in (1, -1) or not math.isfinite(res):
        return False, x0, 0, False
    s0, logdet = np.linalg.slogdet(J)
    if s0 != sign or not math.isfinite(logdet):
        return False, x0, 0, False
    x, steps, stalled = x0, 0, False
    while res > target and steps < max_steps:
        dy = np.linalg.solve(J, -F)
        xn = x + dy * sy.step_scale
        Fn, Jn, rn = sy.evaluate_scaled(xn, vals, None)
        steps += 1
        if warm and steps == 1:
            passed = np.max(np.abs(dy)) <= MAX_PREDICTION and math.isfinite(rn)
        else:
            passed = rn <= FAST_RATE * res
        if not passed:
            stalled = res <= tol
            break
        x, F, J, res = xn, Fn, Jn, rn
    s1, logdet = np.linalg.slogdet(J)
    ok = (
        res <= tol
        and s1 == sign
        and math.isfinite(logdet)
        and sy.scaled_cond(J) < NEAR_SINGULAR_COND
        and np.all(np.isfinite(x))
    )
    return ok, (x if ok else x0), steps, stalled and ok


def check_rule(sy, X0, rows, signs, **kw):
    """solve_batch against rule() row by row; returns rule()'s verdicts."""
    b = sy.solve_batch(X0, stack(sy, rows), signs, **kw)
    verdicts = [rule(sy, X0[i], rows[i], int(signs[i]), **kw) for i in range(len(X0))]
    assert len(verdicts) == len(X0) > 0
    for i, (ok, x, steps, _) in enumerate(verdicts):
        assert b.ok[i] == ok and b.iterations[i] == steps, (i, b.ok[i], ok, b.iterations[i], steps)
        if ok:
            assert np.all(np.abs(b.x[i] - x) / sy.step_scale <= 1e-12), i
        else:
            assert np.array_equal(b.x[i], X0[i], equal_nan=True), i
    return verdicts


def noisy_starts(sy, xs, vals, rng, N=150):
    """N starts near random sweep solutions aimed at other random inputs of the sweep: (X0,
    their values, det J's sign at each start)."""
    start, aim = rng.integers(0, len(xs), N), rng.integers(0, len(xs), N)
    X0 = xs[start] + rng.normal(size=(N, sy.n)) * 0.05 * sy.step_scale
    rows = [vals[i] for i in aim]
    own = np.array(
        [int(np.linalg.slogdet(sy.evaluate_scaled(X0[i], rows[i], None)[1])[0]) for i in range(N)]
    )
    return X0, rows, own


@pytest.mark.parametrize('name', ['four_bar', 'peaucellier', 'excavator'])
def test_solve_batch_follows_its_rule(name):
    """Row by row the verdict, steps and answer of the documented rule (rule(), scalar code):
    sweep steps coarse and fine (on the excavator's 200-command sweep some first steps cut
    max|F| only 9.6-fold: declined), starts a few ulps off the answers at tighter tolerances,
    max_steps 2, and noisy starts aimed at random inputs."""
    for n in (60, 200):
        sy, xs, signs, vals = scalar_sweep(name, n)
        check_rule(sy, xs[:-1], vals[1:], signs[:-1])
    check_rule(sy, xs[:-1], vals[1:], signs[:-1], max_steps=2)
    rng = np.random.default_rng(13)
    for amp in (1e-15, 4e-15):  # starts a few ulps off the answers
        near = xs + rng.normal(size=xs.shape) * amp * sy.step_scale
        for tol in (1e-13, 3e-14, 1e-14):
            check_rule(sy, near, vals, signs, tol=tol)
    check_rule(sy, *noisy_starts(sy, xs, vals, rng))


@pytest.mark.parametrize('name', ['four_bar', 'peaucellier', 'excavator'])
def test_warm_starts_follow_their_rule(name):
    """warm=True (X0 solutions at the values before, as Solver.solve_batch(start=) passes):
    row by row the verdict, steps and answer of rule(warm=True), on fine and coarse sweeps and
    on noisy starts aimed at random inputs (where the first step may jump: declined by its
    size or by the rate of the steps after it)."""
    for n in (60, 200):
        sy, xs, signs, vals = scalar_sweep(name, n)
        check_rule(sy, xs[:-1], vals[1:], signs[:-1], warm=True)
    rng = np.random.default_rng(16)
    X0, rows, own = noisy_starts(sy, xs, vals, rng)
    verdicts = check_rule(sy, X0, rows, own, warm=True)
    assert 0 < sum(v[0] for v in verdicts) < len(rows)  # some accepted, some declined


def test_warm_start_answers_the_rows_whose_first_step_cut_less_than_tenfold():
    """The excavator's 200-command sweep: some first steps from x_{k-1} cut max|F| only
    9.6-9.9-fold (the rate rule declines them: the careful path); judged as the scalar path's
    prediction (warm=True) every row is answered, each the scalar sweep's x_k (within 1e-10
    length scales, same det J sign, scaled cond and slogdet of the scalar Jacobian there)."""
    sy, xs, signs, vals = scalar_sweep('excavator', 200)
    X0, values = xs[:-1], stack(sy, vals[1:])
    cold = sy.solve_batch(X0, values, signs[:-1], start_checked=True)
    warm = sy.solve_batch(X0, values, signs[:-1], start_checked=True, warm=True)
    assert (~cold.ok).sum() >= 5  # the rows the rate rule declines
    assert warm.ok.all()
    check_against_sweep(sy, xs, signs, vals, warm, np.arange(len(xs) - 1))
    # where both answer, the same steps and answers
    both = cold.ok
    assert np.array_equal(cold.iterations[both], warm.iterations[both])
    assert np.all(np.abs(cold.x[both] - warm.x[both]) / sy.step_scale <= 1e-12)


def test_a_step_that_cannot_cut_at_the_rounding_floor_is_converged():
    """Four-bar starts moved off the sweep's answers until max|F| / L is 4.6e-15, just above
    the target (FAST_FLOOR; tol 1e-13): a step cannot always cut that tenfold, the rounding
    floor being near 5e-16. Such a row is converged at its start (ok, x the start, one step
    counted), like the scalar fast path's `if res <= tol: break`."""
    sy, xs, signs, vals = scalar_sweep('four_bar', 200)
    rng = np.random.default_rng(15)
    d = rng.normal(size=xs.shape) * sy.step_scale
    slope = np.array(
        [sy.evaluate_scaled(xs[i] + 1e-9 * d[i], vals[i], None)[2] / 1e-9 for i in range(len(xs))]
    )
    X0 = xs + (4.6e-15 / slope)[:, None] * d
    verdicts = check_rule(sy, X0, vals, signs, tol=1e-13)
    stalled = [i for i, v in enumerate(verdicts) if v[3]]
    assert len(stalled) >= 5
    b = sy.solve_batch(X0, stack(sy, vals), signs, tol=1e-13)
    assert b.ok.all()
    for i in stalled:
        assert np.array_equal(b.x[i], X0[i]) and b.iterations[i] == 1
        assert FAST_FLOOR < b.residual[i] <= 1e-13


def test_never_returns_the_other_side_of_det_j():
    """3000 starts well off the Peaucellier cell's solutions, aimed at random inputs, with the
    start's own det J sign and up to 30 steps: a few Newton runs there cut max|F| tenfold per
    step and still end across det J = 0. Every ok row's answer has the start's sign (slogdet of
    the scalar Jacobian) and is a solution; the rest are at their start."""
    sy, xs, signs, vals = scalar_sweep('peaucellier', 60)
    rng = np.random.default_rng(14)
    N = 3000
    start, aim = rng.integers(0, len(xs), N), rng.integers(0, len(xs), N)
    X0 = xs[start] + rng.normal(size=(N, sy.n)) * 0.3 * sy.step_scale
    values = stack(sy, [vals[i] for i in aim])
    _, J0, _ = sy.evaluate_batch(X0, values)
    own = np.linalg.slogdet(J0)[0].astype(int)
    b = sy.solve_batch(X0, values, own, max_steps=30)
    assert 50 <= b.ok.sum() < N
    _, J, res = sy.evaluate_batch(b.x, values)
    assert np.array_equal(np.linalg.slogdet(J[b.ok])[0].astype(int), own[b.ok])
    assert np.all(res[b.ok] <= TOL)
    assert np.array_equal(b.x[~b.ok], X0[~b.ok])


@pytest.mark.parametrize('name', ['four_bar', 'excavator'])
def test_max_steps(name):
    """max_steps bounds the steps; with 0 steps only starts already converged are ok (x_k
    itself as the start: all ok, unchanged, no step)."""
    sy, xs, signs, vals = scalar_sweep(name, 300)
    b1 = sy.solve_batch(xs[:-1], stack(sy, vals[1:]), signs[:-1], max_steps=1)
    assert b1.iterations.max() <= 1
    assert np.all(b1.residual[b1.ok] <= TOL)
    # one good step is not enough for most rows: declined after moving, x and residual are
    # the start's again
    moved_then_declined = np.flatnonzero(~b1.ok & (b1.iterations == 1))
    assert len(moved_then_declined) > len(xs) // 2
    for i in moved_then_declined:
        assert np.array_equal(b1.x[i], xs[i])
        assert b1.residual[i] == pytest.approx(
            sy.evaluate_scaled(xs[i], vals[i + 1], None)[2], rel=1e-12
        )
    b3 = sy.solve_batch(xs[:-1], stack(sy, vals[1:]), signs[:-1], max_steps=3)
    assert b3.iterations.max() <= 3 and b3.ok.sum() >= b1.ok.sum()
    at = sy.solve_batch(xs[1:], stack(sy, vals[1:]), signs[1:], max_steps=0)
    assert at.ok.all() and np.array_equal(at.x, xs[1:]) and not at.iterations.any()
    assert np.all(at.residual <= max(TOL, FAST_FLOOR))


@pytest.mark.parametrize('name,knowns', POINT_KNOWNS, ids=[n for n, _ in POINT_KNOWNS])
def test_solve_batch_with_point_specs(name, knowns):
    """Point (and angle) knowns: 40 targets a little off the reference, batch from the
    reference against the scalar careful solve from the same start."""
    s = Solver(scene(name), knowns=list(knowns), method='newton')
    sy = s.system
    x_ref, ref = sy.reference_x(), list(s.compiled.ref_values)
    sign = sy.start_sign(x_ref, ref)
    assert sign in (1, -1)
    rng = np.random.default_rng(12)
    rows = []
    for _ in range(40):
        rows.append(
            [
                np.asarray(v, float) + rng.normal(size=2) * 2e-3 * sy.L
                if isinstance(sp, PointSpec)
                else float(v) + rng.normal() * 2e-3
                for sp, v in zip(sy.specs, ref)
            ]
        )
    b = sy.solve_batch(np.tile(x_ref, (40, 1)), stack(sy, rows), sign)
    assert b.ok.mean() >= 0.9
    for i in np.flatnonzero(b.ok):
        r = sy.solve(x_ref, rows[i], None, start_sign=sign)
        assert r.success and r.det_sign == sign
        assert np.abs((b.x[i] - r.x) / sy.step_scale).max() <= 1e-10
        assert b.det_sign[i] == sign and b.residual[i] <= TOL
