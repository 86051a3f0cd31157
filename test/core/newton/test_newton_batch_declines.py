"""The batched Newton kernel (core.newton): the rows LoopSystem.solve_batch declines (the rows
the scalar careful path must take) and the other rows unaffected.

Oracles: the Solver's scalar answers, the closed-form solver for the other assembly mode and the
50-digit four-bar oracle for what cannot be assembled.

Would fail if: a wrong start sign, NaN values, an unreachable input, a far jump, a start on the
other assembly mode or an answer near a fold were accepted instead of declined (x unchanged); a
declined row changed the other rows' results; an empty batch were mishandled; a result aliased
its start; or two batches on one system shared state.
"""

import math

import numpy as np
import oracles as orc
import pytest
from newton_batch_helpers import TOL, check_against_sweep, pick, reported_cond, scalar_sweep, stack
from scenes import four_bar
from test_newton_fast import newton_beside_the_other_mode

from linkage_ros.core.newton import NEAR_SINGULAR_COND, LoopSystem
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.newton_path import branch_of

# =============================================================================================
# declines: rows the scalar careful path must take, and the other rows unaffected
# =============================================================================================


def test_declined_rows_leave_the_others_alone():
    """One batch of the four-bar sweep with rows spoiled in turn: a wrong start sign, NaN / inf
    values, NaN in X0, a start sign of 0 and a 3 rad jump of the crank: those are declined with
    x unchanged; every other row is exactly what solving it alone gives, and the ok ones the
    scalar sweep's answers."""
    sy, xs, signs, vals = scalar_sweep('four_bar', 300)
    n = 40
    X0 = xs[:n].copy()
    start = signs[:n].copy()
    values = stack(sy, vals[1 : n + 1])
    spoiled = {
        3: 'wrong sign',
        7: 'NaN value',
        8: 'inf value',
        11: 'NaN in X0',
        15: 'sign 0',
        19: 'far jump',
        20: 'far jump',
    }
    start[3] = -start[3]
    values[0][7] = math.nan
    values[0][8] = math.inf
    X0[11, 4] = math.nan
    start[15] = 0
    values[0][19] += 3.0
    values[0][20] -= 3.0
    b = sy.solve_batch(X0, values, start)
    for r, why in spoiled.items():
        assert not b.ok[r], why
        assert np.array_equal(b.x[r], X0[r], equal_nan=True), why
        assert b.det_sign[r] == 0 and b.cond[r] == math.inf, why
    rest = [r for r in range(n) if r not in spoiled]
    assert b.ok[rest].all()
    check_against_sweep(sy, xs, signs, vals, b, np.arange(n))
    for r in range(n):  # alone: the same result, spoiled or not
        a = sy.solve_batch(X0[r : r + 1], pick(values, [r]), start[r : r + 1])
        assert a.ok[0] == b.ok[r] and a.iterations[0] == b.iterations[r], r
        assert a.det_sign[0] == b.det_sign[r], r
        np.testing.assert_allclose(a.x[0], b.x[r], rtol=0, atol=1e-15, equal_nan=True)
        np.testing.assert_allclose(a.residual[0], b.residual[r], rtol=1e-15, atol=1e-300)


def test_unreachable_input_is_declined():
    """A double rocker (shortest link the coupler) driven from an assembled pose to crank
    angles where it cannot be assembled (the 50-digit oracle says so): declined, x unchanged;
    reachable rows in the same batch ok."""
    L = (4.0, 3.0, 1.5, 4.5)
    mech = four_bar(L)
    nw = Solver(mech, method='newton')
    sy = nw.system
    toggles = sorted(float(t) for t, _ in orc.fourbar_toggles(*L))
    ts = np.linspace(-math.pi, math.pi, 721)[:-1]
    reach = [t for t in ts if orc.fourbar(*L, float(t), 1)['ok']]
    far = [
        t
        for t in ts
        if not orc.fourbar(*L, float(t), 1)['ok'] and min(abs(t - g) for g in toggles) > 0.05
    ]
    assert reach and far
    t0 = reach[len(reach) // 2]
    r = nw.solve({'crank': float(t0)})
    assert r.success
    x0, s0 = nw.continuity.history[-1].x_all, nw.continuity.history[-1].det_sign
    near = [t0 + 1e-3, t0 - 1e-3]
    targets = near + far[:10]
    b = sy.solve_batch(np.tile(x0, (len(targets), 1)), [np.array(targets)], s0)
    assert b.ok[:2].all()
    assert not b.ok[2:].any()
    assert np.array_equal(b.x[2:], np.tile(x0, (len(targets) - 2, 1)))
    assert np.all(b.residual[2:] > TOL)


def test_start_on_the_other_assembly_mode_is_declined():
    """The other assembly mode's exact answer as the start (so it is converged at once), but
    this mode's det J sign: declined, never returned. With the other mode's own sign (from
    slogdet) the same start is ok and is the closed form's other mode."""
    t = 1.0
    mech, nw, last, other = newton_beside_the_other_mode(t)
    sy = nw.system
    targets = [t, t + 0.02, t - 0.02]
    x_other = []
    for tt in targets:
        ro = other.solve({'crank': tt})
        assert ro.success
        adopt = Solver(mech, method='newton')
        assert adopt.adopt(ro)
        x_other.append(adopt.continuity.history[-1].x_all)
    x_other = np.array(x_other)
    sign_other = int(np.linalg.slogdet(sy.evaluate_scaled(x_other[0], [t], None)[1])[0])
    assert sign_other == -last.det_sign
    # starts: the other mode at t (converged), and the other mode at t +- 0.02 aimed at t
    X0 = x_other
    vals = [np.full(3, t)]
    b = sy.solve_batch(X0, vals, last.det_sign)
    assert not b.ok.any()
    assert np.array_equal(b.x, X0)
    # from this mode's last answer it is ok and on this mode
    mine = sy.solve_batch(last.x_all[None, :], [np.array([t])], last.det_sign)
    assert mine.ok[0] and mine.det_sign[0] == last.det_sign
    assert branch_of(nw.compiled, mine.x[0], None)[0] == last.signs
    # with the other mode's sign: ok, and the other mode's closed-form answer
    b2 = sy.solve_batch(X0, vals, sign_other)
    assert b2.ok.all() and np.all(b2.det_sign == sign_other)
    gap = np.abs((b2.x - x_other[0]) / sy.step_scale)
    assert gap.max() <= 1e-10


def test_answers_near_a_fold_are_declined():
    """A double rocker driven towards an input toggle (10^-e rad from it, e = 1 .. 13) by the
    scalar Solver, which polishes near the fold: its answers as starts, at their own inputs and
    det J signs. Rows whose exact scaled cond is below NEAR_SINGULAR_COND are ok, on the same
    branch, at B where the 50-digit oracle puts it to within the conditioning (the scalar answers
    within tol are only cond * tol accurate: Newton goes on to the target); the two nearest the
    fold (cond 2.6e6, 8e6, still with a det sign) are declined, for the scalar path to polish."""
    L = (4.0, 3.0, 1.5, 4.5)
    mech = four_bar(L)
    # the toggle (0.84 rad) that the crank reaches from above
    tau = min(
        float(t)
        for t, _ in orc.fourbar_toggles(*L)
        if t > 0 and orc.fourbar(*L, float(t) + 1e-3, 1)['ok']
    )
    nw = Solver(mech, method='newton', branch='reference')
    sy = nw.system
    xs, signs, conds, ts = [], [], [], []
    for e in range(1, 14):
        t = tau + 10.0**-e
        r = nw.solve({'crank': t})
        assert r.success and nw.continuity.history[-1].det_sign != 0
        xs.append(nw.continuity.history[-1].x_all)
        signs.append(nw.continuity.history[-1].det_sign)
        conds.append(
            sy.scaled_cond(sy.evaluate_scaled(xs[-1], [t], None)[1])
        )  # exact, not estimated
        ts.append(t)
    xs, conds = np.array(xs), np.array(conds)
    near = conds >= NEAR_SINGULAR_COND
    assert near[-2:].all() and not near[:-2].any()
    b = sy.solve_batch(xs, [np.array(ts)], np.array(signs))
    assert np.array_equal(b.ok, ~near)
    assert np.array_equal(b.x[near], xs[near])
    assert np.all(b.residual[~near] <= TOL)
    reported = np.array(
        [reported_cond(sy, sy.evaluate_scaled(b.x[i], [ts[i]], None)[1]) for i in range(len(ts))]
    )
    np.testing.assert_allclose(b.cond[~near], reported[~near], rtol=0.05)

    def gap_to_oracle(x, t, branch):
        B = sy.configuration(x)[1]['B']
        return orc.point_error((B.real, B.imag), orc.fourbar(*L, t, branch)['B']) / sy.L

    branch = min((1, -1), key=lambda br: gap_to_oracle(xs[0], ts[0], br))
    for i in np.flatnonzero(b.ok):
        gap = gap_to_oracle(b.x[i], ts[i], branch)
        # the configuration error of an answer is about cond * residual
        assert gap <= 1e-12 + 4 * b.cond[i] * max(b.residual[i], 2.0**-52), (i, gap)


def test_empty_batch():
    sy, xs, signs, vals = scalar_sweep('four_bar', 300)
    b = sy.solve_batch(np.zeros((0, sy.n)), [np.zeros(0)], np.zeros(0, int))
    assert b.x.shape == (0, sy.n)
    for a in (b.ok, b.iterations, b.residual, b.det_sign, b.cond):
        assert a.shape == (0,)
    assert b.ok.dtype == bool


def test_result_does_not_alias_the_start():
    sy, xs, signs, vals = scalar_sweep('four_bar', 300)
    X0 = xs[1:4].copy()
    b = sy.solve_batch(X0, stack(sy, vals[1:4]), signs[1:4], max_steps=0)
    assert b.ok.all() and np.array_equal(b.x, X0)
    b.x[:] = 7.0
    assert np.array_equal(X0, xs[1:4])


@pytest.mark.parametrize('name', ['four_bar', 'excavator'])
def test_start_checked_skips_only_the_start_sign(name):
    """start_checked=True (the caller read start_sign off J at X0, as Solver.solve_batch does
    from a BatchResult) gives the same rows as the checked call where the signs are right; with
    every sign flipped (a wrong vouch) no row comes back ok on the wrong side: the sign at the
    answer is checked for every row, those converged at X0 as well (slogdet of the scalar
    Jacobian as the oracle)."""
    sy, xs, signs, vals = scalar_sweep(name, 300)
    X0, values = xs[:-1], stack(sy, vals[1:])
    a = sy.solve_batch(X0, values, signs[:-1])
    b = sy.solve_batch(X0, values, signs[:-1], start_checked=True)
    for field in ('x', 'ok', 'iterations', 'residual', 'det_sign', 'cond'):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    at = sy.solve_batch(xs, stack(sy, vals), signs, start_checked=True, max_steps=0)
    assert at.ok.all()  # converged at X0: the sign there is checked, and right
    wrong = sy.solve_batch(xs, stack(sy, vals), -signs, start_checked=True)
    assert not wrong.ok.any()
    for i in range(0, len(xs), 37):
        _, Js, _ = sy.evaluate_scaled(xs[i], vals[i], None)
        assert int(np.linalg.slogdet(Js)[0]) == signs[i] != -signs[i]


@pytest.mark.parametrize('name', ['four_bar', 'excavator'])
def test_batches_on_one_system_do_not_share_state(name):
    """The batched solve keeps its packed-J arrays for the next batch of the same size:
    batches of several sizes and with a declined row (the gather and scatter path), one after
    another on one system, give exactly what each gives on a system of its own, and the scalar
    sweep's answers; no later batch writes into an earlier one's answers."""
    sy, xs, signs, vals = scalar_sweep(name, 300)
    cases = []
    for lo, hi in ((0, 120), (120, 299), (5, 125), (0, 120)):
        X0, start = xs[lo:hi].copy(), signs[lo:hi].copy()
        start[3] = -start[3]  # a wrong start sign: declined
        cases.append((lo, X0, stack(sy, vals[lo + 1 : hi + 1]), start))
    fields = ('x', 'ok', 'iterations', 'residual', 'det_sign', 'cond')
    answers = []
    for lo, X0, values, start in cases:
        got = sy.solve_batch(X0, values, start, tol=TOL)
        alone = LoopSystem(sy.mech, sy.specs, sy.free).solve_batch(X0, values, start, tol=TOL)
        for field in fields:
            assert np.array_equal(getattr(got, field), getattr(alone, field)), field
        assert not got.ok[3] and got.ok.mean() >= 0.98
        check_against_sweep(sy, xs, signs, vals, got, np.arange(lo, lo + len(X0)))
        answers.append((got, {f: getattr(got, f).copy() for f in fields}))
    for got, copies in answers:
        for field in fields:
            assert np.array_equal(getattr(got, field), copies[field]), field
