"""The plain-float Schur kernel of the warm Newton solve (core/newton/lean.py).

Oracles: numpy's dense LU on the same Jacobian (np.linalg.solve, np.linalg.slogdet, np.linalg.inv
for ||J^-1||_1), schur.py's batched elimination of the same matrices (the algorithm this kernel
is the one-row twin of), LAPACK's condition estimate (scalar.cond_estimate, what a Result
reports), and the fast path by the dense kernel (scalar.solve_from_guess) on the same guesses.

Would fail if: a step, a tangent or det J's sign differed from the dense ones beyond rounding, the
condition bound were ever below the exact 1-norm condition number (the lean path would then keep
an answer the dense path polishes or reads as singular), or the fast path accepted, declined or
stepped differently from the dense one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scenes
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.core.newton import predictor, scalar
from linkage_ros.core.newton.evaluate import jacobian
from linkage_ros.core.newton.lean import evaluate_lean, lean_schur
from linkage_ros.core.newton.linalg import factor
from linkage_ros.core.newton.schur import reduced_steps, schur_answer, schur_back, schur_reduce

ALL_SCENES = scenes.SHIPPED


def _lean(name):
    sy = scenes.newton_system(name)
    tabs = sy.batch.tables()
    return sy, lean_schur(sy.tables, tabs.schur, tabs.jv_real.tolist())


LEAN = [(name, *_lean(name)) for name in ALL_SCENES]
LEAN = [(name, sy, ls) for name, sy, ls in LEAN if ls is not None]
IDS = [name for name, _, _ in LEAN]


def test_the_small_schur_scenes_have_a_lean_kernel():
    # the bench's four-bar and slider-crank reduce to a 3 x 3 M; Peaucellier (7 x 7) and the
    # excavator (blocks) do not
    assert {'four_bar', 'slider_crank'} <= set(IDS)
    assert not {'peaucellier', 'excavator'} & set(IDS)


def _at(sy, ls, x, values):
    """(F list, jv, dense scale-free J, lean factor) at x."""
    F, jv, _ = evaluate_lean(sy.tables, x.tolist(), values)
    return F, jv, jacobian(sy.tables, jv, sy.tables.tpl_s), ls.factor(jv)


@pytest.mark.parametrize(('name', 'sy', 'ls'), LEAN, ids=IDS)
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), spread=st.floats(0.01, 2.0))
def test_steps_sign_and_bound_match_the_dense_lu(name, sy, ls, seed, spread):
    rng = np.random.default_rng(seed)
    x = sy.reference_x() + rng.normal(size=sy.n) * spread * sy.step_scale
    values = [np.asarray(v, float) if np.ndim(v) else float(v) for v in _ref_values(sy)]
    F, _, J, fac = _at(sy, ls, x, values)
    sign, logdet = np.linalg.slogdet(J)
    exact = np.abs(J).sum(axis=0).max() * np.abs(np.linalg.inv(J)).sum(axis=0).max()
    if not np.isfinite(logdet) or exact > 1e10:
        return  # (singular to rounding: no sign to agree on)
    assert fac.sign == int(sign)
    rhs = rng.normal(size=sy.n)
    want = np.linalg.solve(J, rhs)
    got = np.array(ls.solve(fac, rhs.tolist()))
    tol = 1e-13 * exact * np.abs(want).max()
    np.testing.assert_allclose(got, want, rtol=0, atol=tol)
    np.testing.assert_allclose(ls.solve(fac, F), np.linalg.solve(J, F), rtol=0, atol=tol)
    bound = ls.cond_bound(fac)
    assert bound >= exact * (1 - 1e-12)
    # what a Result reports (LAPACK's estimate) never exceeds the exact value the bound covers
    assert scalar.cond_estimate(J, factor(J)) <= bound * (1 + 1e-12) or exact >= 1e4


@pytest.mark.parametrize(('name', 'sy', 'ls'), LEAN, ids=IDS)
def test_the_kernel_is_the_batched_elimination_of_one_row(name, sy, ls):
    # schur.py on the same matrices: the same step and det J sign to rounding
    rng = np.random.default_rng(7)
    X, cols = scenes.around_reference(sy, rng, 32)
    V = sy.batch.values(cols, 32)
    Fb, Jp, _ = sy.batch.evaluate(X, V, True, packed=True)
    sf = sy.batch.layout()
    M, r = schur_reduce(sf, Jp, Fb)
    steps = schur_back(sf, Jp, Fb, reduced_steps(M, r))
    signs, _ = schur_answer(sf, Jp)
    values = [float(v) if not np.ndim(v) else np.asarray(v, float) for v in _ref_values(sy)]
    for k in range(32):
        F, _, J, fac = _at(sy, ls, X[k], values)
        np.testing.assert_allclose(F, Fb[k], rtol=0, atol=1e-15)
        assert fac.sign == signs[k]
        if fac.sign:
            scale = np.abs(steps[k]).max() * np.linalg.cond(J, 1)
            np.testing.assert_allclose(
                [-v for v in ls.solve(fac, F)], steps[k], rtol=0, atol=1e-13 * scale
            )


def _ref_values(sy):
    from linkage_ros.core.solver import Solver

    return Solver(sy.mech, method='newton').compiled.ref_values


@pytest.mark.parametrize(('name', 'sy', 'ls'), LEAN, ids=IDS)
def test_the_fast_path_decides_and_steps_as_the_dense_one(name, sy, ls):
    # guesses at growing distances from a solution: the fast path by the Schur kernel accepts
    # exactly where the one by LAPACK's LU of the dense J does, with the same steps, det sign,
    # answer and reported cond to rounding
    t = sy.tables
    values = list(_ref_values(sy))
    x0 = sy.reference_x()
    sign = sy.start_sign(x0, values)
    rng = np.random.default_rng(3)
    agreed = accepted = 0
    for spread in np.geomspace(1e-9, 0.3, 60):
        guess = x0 + rng.normal(size=sy.n) * spread * sy.step_scale
        dense = scalar.solve_from_guess(t, guess, values, tol=1e-12, start_sign=sign)
        lean = scalar.solve_from_guess(
            t, guess, values, tol=1e-12, max_iter=50, start_sign=sign, kernel=ls
        )
        assert lean.success == dense.success
        if not dense.success:
            continue
        accepted += 1
        assert dense.iterations == lean.iterations and dense.det_sign == lean.det_sign
        np.testing.assert_allclose(lean.x, dense.x, rtol=0, atol=1e-12 * max(1.0, t.L))
        assert abs(lean.residual - dense.residual) <= 1e-14
        assert scalar.cond_of(t, lean) == pytest.approx(dense.cond, rel=1e-6)
        agreed += 1
    assert accepted >= 20 and agreed == accepted


@pytest.mark.parametrize(('name', 'sy', 'ls'), LEAN, ids=IDS)
def test_the_prediction_is_the_dense_one(name, sy, ls):
    # the tangent extrapolation through the kernel and through LAPACK's LU of the same J
    t = sy.tables
    values = list(_ref_values(sy))
    x0 = sy.reference_x()
    F, jv, J, fac = _at(sy, ls, x0, values)
    lu = factor(J)
    for delta in (1e-4, 1e-2, 0.1):
        moved = [v + delta if np.ndim(v) == 0 else np.asarray(v) + delta for v in values]
        want = predictor.predict(t, x0, lu, values, moved)
        got = predictor.extrapolate(t, ls.solve, x0.tolist(), fac, values, moved)
        assert (want is None) == (got is None)
        if want is not None:
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * max(1.0, t.L))
    assert math.isfinite(ls.cond_bound(fac))


def _kept_tangent_tables(sy):
    """The loop tables of a system whose values have one component (the Newton path keeps a
    unit tangent for those); the test is skipped for the others."""
    t = sy.tables
    if t.val_rows is None or len(t.val_rows) != 1:
        pytest.skip('values of more than one component: no kept tangent')
    return t


@pytest.mark.parametrize(('name', 'sy', 'ls'), LEAN, ids=IDS)
def test_the_kept_unit_tangent_is_dx_dvalue(name, sy, ls):
    # predictor.unit_tangent (what a Newton answer keeps for the next two predictions) against
    # numpy's dense solve of J T = -dF/dvalue, dF/dvalue by central differences of F in the
    # value (scale-free: a step of h rad, or h length scales)
    t = _kept_tangent_tables(sy)
    values = list(_ref_values(sy))
    x0 = sy.reference_x()
    _, _, J, fac = _at(sy, ls, x0, values)
    h = 1e-6
    step = h if np.ndim(values[0]) == 0 and sy.tables.specs[0].unit == 'rad' else h * t.L
    F_up = np.array(evaluate_lean(t, x0.tolist(), [values[0] + step])[0])
    F_down = np.array(evaluate_lean(t, x0.tolist(), [values[0] - step])[0])
    want = np.linalg.solve(J, -(F_up - F_down) / (2 * h))
    got = predictor.unit_tangent(t, ls.solve, fac)
    assert got is not None
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-7 * max(1.0, float(np.abs(want).max())))


@pytest.mark.parametrize(('name', 'sy', 'ls'), LEAN, ids=IDS)
def test_the_prediction_from_kept_tangents_is_the_solved_one(name, sy, ls):
    # extrapolate given the kept unit tangents and value steps (the Newton path's warm
    # command) against extrapolate solving both tangents itself (predict's), through two
    # solutions (the cubic Hermite, and the quadratic where the step turns back)
    t = _kept_tangent_tables(sy)
    v0 = list(_ref_values(sy))
    is_angle = sy.tables.specs[0].unit == 'rad'
    scale = 1.0 if is_angle else t.L
    x_prev = sy.reference_x()
    for d1, d2 in ((0.01, 0.012), (0.02, -0.01), (0.005, 0.03)):
        v1 = [v0[0] + d1 * scale]
        v2 = [v1[0] + d2 * scale]
        pred = sy.solve(x_prev, v1, None, tol=1e-13)
        assert pred.success
        x_last = pred.x
        fac_prev = ls.factor(evaluate_lean(t, x_prev.tolist(), v0)[1])
        fac_last = ls.factor(evaluate_lean(t, x_last.tolist(), v1)[1])
        want = predictor.extrapolate(
            t, ls.solve, x_last.tolist(), fac_last, v1, v2, x_prev.tolist(), v0, fac_prev
        )
        got = predictor.extrapolate(
            t,
            ls.solve,
            x_last.tolist(),
            fac_last,
            v1,
            v2,
            x_prev.tolist(),
            v0,
            fac_prev,
            h=predictor.value_step(t, v1, v2),
            hp=predictor.value_step(t, v0, v1),
            unit_last=predictor.unit_tangent(t, ls.solve, fac_last),
            unit_prev=predictor.unit_tangent(t, ls.solve, fac_prev),
        )
        assert want is not None and got is not None
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * max(1.0, t.L))
