"""The warm-started Newton fast path (core.newton): compiled residual and Jacobian, LU-based det J
sign and conditioning, the predictor (LoopSystem.predict) and solve_from_guess, and that the
Solver still never jumps branch when the predictor is used.

Would fail if: the compiled evaluate disagreed with finite differences; the LU sign disagreed with
slogdet; the condition estimate drifted from the exact one; a warm smooth sweep needed more than
one Newton step and one Jacobian factorisation at the answer per solve; a guess on the other
assembly mode were accepted; or a sweep passing near a toggle switched branch.
"""

import math

import numpy as np
import oracles as orc
import pytest
from scenes import four_bar

from linkage_ros.core.model import Scene
from linkage_ros.core.newton import COND_EXACT
from linkage_ros.core.quantities import PointSpec
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.newton_path import branch_of
from linkage_ros.resources import scene_path

SCENES = ['four_bar', 'slider_crank', 'peaucellier', 'excavator']
ALL_SCENES = SCENES + [
    'hart',
    'front_loader',
    'quick_return',
    'scott_russell',
    'plagiograph',
    'inverted_slider_crank',
]
TIGHT = 1e-12
#: knowns giving a hybrid solve (the dyad plan places some links, Newton the rest): point specs
#: and prismatic rows with links held by `fixed` poses
# knowns whose solves are hybrid (the dyad plan places some links, Newton the rest); a point
# on a grounded crank (point:A) is no longer one: it fixes one motion with two values, which
# Solver refuses
HYBRID = {
    'excavator': ['G_Z3_rod', 'point:C'],
    'front_loader': ['Z1', 'F'],
    'plagiograph': ['link:ABD', 'link:BCE'],  # (theta_A and BCE fix one motion: refused)
    'four_bar': ['link:coupler'],
}
# inverse knowns with point rows for the all-free (newton) system
POINT_KNOWNS = {
    'excavator': ['Z1', 'point:L'],
    'front_loader': ['point:T'],
    'plagiograph': ['point:D'],
}


def scene(name):
    return Scene.from_yaml(scene_path(name)).mechanism


def sweep(mech, n):
    """n commands around the bench's closed warm-started path (bench.sweep_inputs)."""
    from linkage_ros.bench import sweep_inputs

    return sweep_inputs(mech, n)


def system_sweep(mech, n, laps=1):
    """The kernel driven like the Solver drives it: guess from predict, det sign tracked."""
    s = Solver(mech, method='newton')
    sy = s.system
    x, vals, lu, before, sign = sy.reference_x(), list(list(s.compiled.ref_values)), None, (), None
    out = []
    for cmd in sweep(mech, n) * laps:
        v = s.parse(cmd)
        guess = sy.predict(x, lu, vals, v, *before) if lu is not None else None
        r = sy.solve(x, v, None, start_sign=sign, guess=guess)
        assert r.success, r.reason
        out.append(r)
        before = (x, vals, lu)
        x, vals, lu, sign = r.x, v, sy.rate_factor(r), r.det_sign or None
    return s, out


# =============================================================================================
# the compiled residual and Jacobian
# =============================================================================================


@pytest.mark.parametrize('name', ALL_SCENES)
def test_jacobian_matches_finite_differences(name):
    """Analytic J of the compiled evaluate vs central differences, at random configurations,
    for all moving links free and for hybrid systems (fixed links from the dyad plan)."""
    mech = scene(name)
    rng = np.random.default_rng(1)
    s = Solver(mech, method='newton')
    systems = [(s.check_system, None, list(s.compiled.ref_values))]
    if name in HYBRID:
        h = Solver(mech, knowns=HYBRID[name], method='auto')
        assert h.mode == 'hybrid'
        systems.append(
            (
                h.system,
                h.compiled.fixed_poses(list(h.compiled.ref_values))[0],
                list(h.compiled.ref_values),
            )
        )
    if name in POINT_KNOWNS:
        p = Solver(mech, knowns=POINT_KNOWNS[name], method='newton')
        assert any(isinstance(sp, PointSpec) for sp in p.specs)
        systems.append((p.system, None, list(p.compiled.ref_values)))
    for sy, fixed, vals in systems:
        step = sy.step_scale
        for _ in range(3):
            x = sy.reference_x() + rng.normal(size=sy.n) * 0.2 * step
            F, J = sy.evaluate(x, vals, fixed)
            F2, none = sy.evaluate(x, vals, fixed, jacobian=False)
            assert none is None and np.array_equal(F, F2)
            Fs, Js, res = sy.evaluate_scaled(x, vals, fixed)
            assert np.allclose(Fs, F / sy.L, rtol=1e-15, atol=0)
            assert np.allclose(Js, J * sy.col_scale, rtol=1e-15, atol=0)
            assert res == float(np.max(np.abs(Fs)))
            for j in range(sy.n):
                e = np.zeros(sy.n)
                e[j] = 1e-6 * step[j]
                fd = (
                    sy.evaluate(x + e, vals, fixed, False)[0]
                    - sy.evaluate(x - e, vals, fixed, False)[0]
                ) / (2 * e[j])
                assert np.allclose(J[:, j], fd, rtol=1e-6, atol=1e-7 * sy.L / step[j]), (name, j)


def test_evaluate_scale_free():
    """All lengths times 1e-300 or 1e300: the scale-free F and J are the same numbers."""
    base = four_bar((4.0, 1.5, 4.5, 3.0))
    ref = Solver(base, method='newton').system
    x0 = ref.reference_x()
    x0[0::3] += [0.3, -0.2, 0.1]
    vals = [0.7]
    F0, J0, _ = ref.evaluate_scaled(x0, vals, None)
    for k in (1e-300, 1e300):
        sy = Solver(four_bar(tuple(k * v for v in (4.0, 1.5, 4.5, 3.0))), method='newton').system
        x = x0 * np.tile([1.0, k, k], 3)
        F, J, res = sy.evaluate_scaled(x, vals, None)
        assert math.isfinite(res)
        assert np.allclose(F, F0, rtol=1e-12, atol=1e-14)
        assert np.allclose(J, J0, rtol=1e-12, atol=1e-14)


# =============================================================================================
# LU: det J sign and conditioning
# =============================================================================================


def test_lu_det_sign_equals_slogdet_sign():
    rng = np.random.default_rng(2)
    sy = Solver(scene('four_bar'), method='newton').system
    for n in (1, 2, 3, 9, 21, 33):
        for _ in range(40):
            A = rng.normal(size=(n, n))
            if rng.random() < 0.3:
                A = A[rng.permutation(n)]
            fac = sy.factor(A)
            assert fac is not None
            assert fac[2] == int(np.linalg.slogdet(A)[0])
    S = np.ones((3, 3))
    S[:, 2] = 0.0
    assert sy.factor(S) is None and np.linalg.slogdet(S)[0] == 0  # exactly singular


@pytest.mark.parametrize('name', SCENES)
def test_lu_sign_and_cond_estimate_on_scene_jacobians(name):
    """At every answer of a sweep: the LU's det sign is slogdet's, and the 1-norm condition
    estimate is within a factor 1 .. 30 of the exact scaled condition number (the thresholds
    it guards are 100x above COND_EXACT, where the exact value is computed instead)."""
    mech = scene(name)
    s, results = system_sweep(mech, 40)
    sy = s.system
    for r in results:
        F, J, _ = sy.evaluate_scaled(r.x, list(s.compiled.ref_values), None)
        fac = sy.factor(J)
        assert fac[2] == int(np.linalg.slogdet(J)[0])
        est, exact = sy.cond(J, fac), sy.scaled_cond(J)
        assert est <= COND_EXACT
        assert exact / 1.5 <= est <= 30 * exact, (est, exact)


def test_cond_is_exact_near_a_singularity():
    """Above COND_EXACT the reported cond is scaled_cond itself (an SVD)."""
    sy = Solver(scene('four_bar'), method='newton').system
    J = np.eye(4)
    J[3, 3] = 1e-9
    assert sy.cond(J, sy.factor(J)) == sy.scaled_cond(J)


# =============================================================================================
# the fast path on warm smooth sweeps
# =============================================================================================


@pytest.mark.parametrize('name', SCENES)
def test_warm_sweep_takes_the_fast_path(name):
    """After two solves the predictor is warm: every solve of a smooth sweep converges from the
    predicted guess in one Newton step (one Jacobian factorised for it, one at the answer for
    det J, cond and the next prediction) plus at most one chord step on the same factorisation
    to push the residual 100x below tol; the careful path took 3 Newton steps. The answers sit
    at the rounding floor (max|F| <= 1e-14 of the length scale)."""
    mech = scene(name)
    _, results = system_sweep(mech, 200, laps=2)
    warm = results[3:]
    assert all(r.predicted for r in warm)
    assert all(r.residual <= 1e-14 for r in warm)
    assert all(r.jacobians == 2 for r in warm)
    assert max(r.iterations for r in warm) <= 2
    if name in ('four_bar', 'slider_crank'):
        assert np.mean([r.iterations == 1 for r in warm]) >= 0.5


@pytest.mark.parametrize('name', SCENES)
def test_solver_warm_sweep_one_step_and_agrees_with_closed_form(name):
    """Solver.solve(method='newton') on the bench sweep: Result.iterations drops to the fast
    path's (<= 2; the careful path took 3), the residual is within tol and every point matches
    the closed form (same branch)."""
    mech = scene(name)
    nw = Solver(mech, method='newton')
    cf = Solver(mech, method='closed_form')
    for i, cmd in enumerate(sweep(mech, 200) * 2):
        r, c = nw.solve(cmd), cf.solve(cmd)
        assert r.success and c.success, (r.reason, c.reason)
        assert r.residual <= TIGHT
        assert r.branch == c.branch
        if i >= 3:
            assert r.iterations <= 2, (i, r.iterations)
        gap = (
            max(
                math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                for p in r.points
            )
            / mech.length_scale
        )
        assert gap <= 1e-9, (i, gap)


def test_predictor_is_scale_free():
    """The same sweep at 1e-300 and 1e300 m: the fast path's steps, same angles."""
    L = (4.0, 1.5, 4.5, 3.0)
    ts = list(np.linspace(0.3, 2.3, 80))
    s1 = Solver(four_bar(L), method='newton')
    ref = [s1.solve({'crank': t}) for t in ts]
    for k in (1e-300, 1e300):
        s = Solver(four_bar(tuple(k * v for v in L)), method='newton')
        for i, (t, want) in enumerate(zip(ts, ref)):
            r = s.solve({'crank': t})
            assert r.success and r.residual <= TIGHT
            if i >= 3:
                assert r.iterations <= 2, (k, i, r.iterations)
            assert max(orc.angle_error(r.links[l], want.links[l]) for l in r.links) <= 1e-12


# =============================================================================================
# the fast path never returns another assembly mode
# =============================================================================================


def newton_beside_the_other_mode(t):
    """A crank-rocker Newton solver that has just solved crank = t - 0.05 (its last state), and
    a closed-form solver pinned to the other assembly mode."""
    mech = four_bar((4.0, 1.5, 4.5, 3.0))
    nw = Solver(mech, method='newton')
    assert nw.solve({'crank': t - 0.05}).success
    last = nw.continuity.history[-1]
    other = Solver(mech, method='closed_form', branch='-' if last.signs[0] > 0 else '+')
    return mech, nw, last, other


def test_guess_on_the_other_branch_is_declined():
    """A guess that is the other assembly mode's exact answer (so it 'converges' at once) is
    declined on its det J sign, and solve() then returns the start's mode from x0."""
    t = 1.0
    mech, nw, last, other = newton_beside_the_other_mode(t)
    sy = nw.system
    ro = other.solve({'crank': t})
    assert ro.success
    nw2 = Solver(mech, method='newton')
    assert nw2.adopt(ro)
    x_other = nw2.continuity.history[-1].x_all
    vals = nw.parse({'crank': t})
    r = sy.solve_from_guess(x_other, vals, None, start_sign=last.det_sign)
    assert not r.success and not r.predicted
    r = sy.solve(last.x_all, vals, None, start_sign=last.det_sign, guess=x_other)
    assert r.success and not r.predicted and r.det_sign == last.det_sign
    assert branch_of(nw.compiled, r.x, None)[0] == last.signs


NEAR = [1e-2, 1e-4, 1e-6, 1e-8]


@pytest.mark.parametrize('eps', NEAR)
def test_sweep_passing_near_a_toggle_keeps_its_branch(eps):
    """A crank-rocker a hair inside the Grashof limit (s + l = p + q - eps): twice round, the
    coupler and rocker pass within ~sqrt(eps) of folding flat (the dyad margin dips to
    ~sqrt(eps)). Newton (continuous) must follow its branch: every answer is the closed form's
    on the starting branch, never the other mode."""
    L = (4.0, 1.5, 5.5 - eps, 3.0)  # 1.5 + 5.5 = 4 + 3: the change point
    mech = four_bar(L)
    nw = Solver(mech, method='newton')
    ts = list(np.linspace(-math.pi, math.pi, 241))[:-1] * 2
    first = nw.solve({'crank': ts[0]})
    assert first.success
    cf = Solver(mech, method='closed_form', branch=first.branch)
    low = 1.0
    for t in ts:
        r = nw.solve({'crank': t})
        assert r.success and r.residual <= TIGHT, (t, r.reason)
        assert r.branch == first.branch, (t, r.branch)
        c = cf.solve({'crank': t})
        gap = (
            max(
                math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                for p in r.points
            )
            / mech.length_scale
        )
        rho = max(r.residual, 2.0**-52)
        assert gap <= 1e-9 + 8 * rho / math.sqrt(r.margin**2 + rho), (t, gap, r.margin)
        low = min(low, r.margin)
    assert low < 10 * math.sqrt(eps)  # it did pass near the fold


@pytest.mark.parametrize(
    'L', [(4.0, 3.0, 1.5, 4.5), (4.0, 3.0, 5.0, 2.5)], ids=['double_rocker', 'triple_rocker']
)
def test_reference_branch_up_to_a_toggle_and_back(L):
    """Driven towards each input toggle to within 1e-12 rad and back out in shrinking then
    growing steps (where the predictor extrapolates hardest), branch 'reference': every answer
    is on the reference branch with the closed form's points, or a failure with a reason."""
    mech = four_bar(L)
    for tau, _ in orc.fourbar_toggles(*L):
        for side in (1, -1):
            probe = orc.fourbar(*L, float(tau + side * 1e-3), 1)
            if not probe['ok']:
                continue
            d = [10.0**-e for e in range(1, 13)]
            ts = [float(tau + side * v) for v in d + d[::-1]]
            nw = Solver(mech, method='newton', branch='reference')
            cf = Solver(mech, method='closed_form', branch='reference')
            for t in ts:
                r, c = nw.solve({'crank': t}), cf.solve({'crank': t})
                if not r.success:
                    assert r.reason
                    continue
                assert c.success and r.branch == c.branch, (t, r.branch, c.branch)
                assert r.residual <= TIGHT
                gap = (
                    max(
                        math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                        for p in r.points
                    )
                    / mech.length_scale
                )
                rho = max(r.residual, c.residual, 2.0**-52)
                m = min(r.margin, c.margin)
                assert gap <= 1e-9 + 8 * rho / math.sqrt(m * m + rho), (t, gap)


def test_fast_path_result_does_not_alias_the_guess():
    s = Solver(scene('four_bar'), method='newton')
    sy = s.system
    guess = sy.reference_x()  # already the answer at the reference input
    keep = guess.copy()
    r = sy.solve_from_guess(
        guess, list(s.compiled.ref_values), None, tol=1e-12, max_iter=50, start_sign=None
    )
    assert r.success and r.x is not guess
    r.x[:] = 7.0
    assert np.array_equal(guess, keep)


@pytest.mark.parametrize('name', ALL_SCENES)
def test_fast_path_answer_reads_as_its_configuration_does(name):
    """Each warm fast-path answer of a sweep carries what its configuration gives when read
    afresh: the residual max|F| / L there (evaluate_scaled), det J's sign (numpy's slogdet of
    the scale-free J there), cond as linalg.cond reports it (numpy's 1-norm of J into LAPACK's
    estimate, or the SVD) and the LU the next prediction solves with (LAPACK's getrf of that
    J). Would fail if the fast path reported a quantity of another point (the guess, a chord
    iterate) or computed one of them differently (the 1-norm, the sign reading)."""
    from scipy.linalg import lapack

    mech = scene(name)
    s, results = system_sweep(mech, 60)
    sy = s.system
    vals_of = [s.parse(cmd) for cmd in sweep(mech, 60)]
    warm = [(r, v) for r, v in zip(results, vals_of) if r.predicted]
    assert len(warm) >= 50
    for r, v in warm:
        F, J, res = sy.evaluate_scaled(r.x, v, None)
        assert r.residual == res
        assert r.det_sign == int(np.linalg.slogdet(J)[0])
        lu, piv, info = lapack.dgetrf(J)
        assert info == 0
        assert np.array_equal(r.factor[0], lu) and np.array_equal(r.factor[1], piv)
        assert r.cond == sy.cond(J, (lu, piv, r.det_sign))
