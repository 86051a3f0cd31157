"""The batched Newton kernel (core.newton): LoopSystem.evaluate_batch and LoopSystem.solve_batch.

Oracles: the scalar residual/Jacobian evaluate_scaled row by row, central differences,
dyads.wrap_angle,
the Solver's scalar warm-started sweeps (the predictor fast path and careful path, solved one
command at a time), the closed-form solver for the other assembly mode, the 50-digit four-bar
oracle for what cannot be assembled, and np.linalg.slogdet / scaled_cond at the answers.

Would fail if: a batched row disagreed with the scalar evaluation (F, J or res, including the
angle wrap of large values and non-finite inputs); J disagreed with finite differences; a batch
answer differed from the scalar sweep's, had another det J sign, a residual above tol or took
more than a few steps; a wrong start sign, NaN values, an unreachable input, a far jump or a start
on the other assembly mode were accepted instead of declined (x unchanged); a declined row
changed the other rows' results; max_steps were exceeded; or an empty batch, a hybrid system or a
non-square system were mishandled.
"""

import functools
import math

import numpy as np
import oracles as orc
import pytest
from scenes import four_bar
from test_newton_fast import newton_beside_the_other_mode

from linkage_ros.bench import sweep_inputs
from linkage_ros.core.model import Scene
from linkage_ros.core.newton import (
    COND_EXACT,
    FAST_FLOOR,
    FAST_MARGIN,
    FAST_RATE,
    MAX_PREDICTION,
    NEAR_SINGULAR_COND,
    LoopSystem,
)
from linkage_ros.core.newton.batch_tables import PackedJacobian
from linkage_ros.core.quantities import AngleSpec, PointSpec, SlideSpec
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.newton_path import branch_of
from linkage_ros.resources import config_dir, scene_path

ALL_SCENES = sorted(p.stem for p in config_dir().glob('*.yaml'))
SWEEP_SCENES = ['four_bar', 'slider_crank', 'peaucellier', 'excavator']
#: Newton-mode systems with point specs (knowns), none of which the actuators give
#: (a point on a moving link: 'point:A' would be singular, A's owner being a crank)
POINT_KNOWNS = [
    ('excavator', ('O2', 'point:J')),
    ('front_loader', ('point:E',)),
    ('plagiograph', ('point:D',)),
]
TOL = 1e-12


def reported_cond(sy, Js):
    """cond as LoopSystem.cond reports it, computed independently: the exact 1-norm condition
    number of the scale-free J (numpy) below COND_EXACT, else the exact scaled 2-norm one."""
    c1 = np.linalg.cond(Js, 1)
    return c1 if c1 < COND_EXACT else sy.scaled_cond(Js)


def scene(name):
    return Scene.from_yaml(scene_path(name)).mechanism


def stack(sy, rows):
    """Per-spec value arrays ((N,) or (N, 2)) from per-row value lists."""
    out = []
    for i, s in enumerate(sy.specs):
        col = [np.asarray(r[i], float) for r in rows]
        out.append(
            np.array(col, float).reshape(len(rows), *((2,) if isinstance(s, PointSpec) else ()))
        )
    return out


def pick(values, idx):
    """Rows idx of per-spec value arrays."""
    return [np.asarray(v)[idx] for v in values]


@functools.cache
def scalar_sweep(name, n):
    """The Solver (newton) warm-started one command at a time over the bench's closed path:
    (system, x_k (K, n), det_sign_k (K,), values_k per row)."""
    s = Solver(scene(name), method='newton')
    xs, signs, vals = [], [], []
    for cmd in sweep_inputs(s.mech, n):
        r = s.solve(cmd)
        assert r.success, r.reason
        xs.append(s.continuity.history[-1].x_all.copy())
        signs.append(s.continuity.history[-1].det_sign)
        vals.append(s.parse(cmd))
    return s.system, np.array(xs), np.array(signs), vals


def random_inputs(sy, ref_values, N, rng, spread=0.3):
    """N configurations around the reference and values around the reference ones."""
    X = sy.reference_x() + rng.normal(size=(N, sy.n)) * spread * sy.step_scale
    rows = []
    for _ in range(N):
        row = []
        for s, v in zip(sy.specs, ref_values):
            if isinstance(s, AngleSpec):
                row.append(float(v) + rng.normal() * 2.0)  # some beyond (-pi, pi]
            elif isinstance(s, SlideSpec):
                row.append(float(v) + rng.normal() * 0.1 * sy.L)
            else:
                row.append(np.asarray(v, float) + rng.normal(size=2) * 0.1 * sy.L)
        rows.append(row)
    return X, rows


def systems():
    """(label, system, reference values): every scene in config/ with its actuators known
    (newton mode), and the point-spec ones."""
    out = []
    for name in ALL_SCENES:
        s = Solver(scene(name), method='newton')
        out.append((name, s.system, list(s.compiled.ref_values)))
    for name, knowns in POINT_KNOWNS:
        s = Solver(scene(name), knowns=list(knowns), method='newton')
        assert s.mode == 'newton' and any(isinstance(sp, PointSpec) for sp in s.specs)
        out.append((f'{name}:{"+".join(knowns)}', s.system, list(s.compiled.ref_values)))
    return out


SYSTEMS = systems()
IDS = [label for label, _, _ in SYSTEMS]


def assert_rows_equal_scalar(sy, X, rows, skip=()):
    """evaluate_batch against evaluate_scaled row by row (the rows in skip: the scalar form
    raises)."""
    F, J, res = sy.evaluate_batch(X, stack(sy, rows))
    assert F.shape == (len(X), sy.m) and J.shape == (len(X), sy.m, sy.n) and res.shape == (len(X),)
    for i in range(len(X)):
        if i in skip:
            continue
        Fs, Js, rs = sy.evaluate_scaled(X[i], rows[i], None)
        np.testing.assert_allclose(F[i], Fs, rtol=1e-14, atol=1e-14, equal_nan=True)
        np.testing.assert_allclose(J[i], Js, rtol=1e-14, atol=1e-14, equal_nan=True)
        if math.isinf(rs):
            assert res[i] == math.inf, i
        else:
            assert res[i] == pytest.approx(rs, rel=1e-14, abs=1e-14), i
    return F, J, res


# =============================================================================================
# evaluate_batch
# =============================================================================================


@pytest.mark.parametrize('label,sy,ref', SYSTEMS, ids=IDS)
def test_evaluate_batch_equals_scalar_rows(label, sy, ref):
    """50 random configurations and values: F, J and res equal the scalar evaluate_scaled per row;
    jacobian=False gives the same F and res and no J."""
    rng = np.random.default_rng(7)
    X, rows = random_inputs(sy, ref, 50, rng)
    F, J, res = assert_rows_equal_scalar(sy, X, rows)
    assert np.all(np.isfinite(res))
    F2, none, res2 = sy.evaluate_batch(X, stack(sy, rows), jacobian=False)
    assert none is None and np.array_equal(F, F2) and np.array_equal(res, res2)


@pytest.mark.parametrize('label,sy,ref', SYSTEMS, ids=IDS)
def test_evaluate_batch_non_finite_and_huge_inputs(label, sy, ref):
    """Angle values of +-1e6 rad (and 3 pi, -pi, 1e300) reduce as the scalar wrap does; NaN or
    inf anywhere in a row (values or X) gives res inf for that row, no exception, and leaves
    the other rows as the scalar form has them."""
    rng = np.random.default_rng(8)
    X, rows = random_inputs(sy, ref, 50, rng)
    angle = [i for i, s in enumerate(sy.specs) if isinstance(s, AngleSpec)]
    skip = set()
    for r, big in zip(
        range(12),
        (
            1e6,
            -1e6,
            3 * math.pi,
            -math.pi,
            1e300,
            123456.789,
            -654321.0,
            2 * math.pi * 1e5,
            math.pi,
            7.0,
            -7.0,
            1e6 + 0.5,
        ),
    ):
        for i in angle:
            rows[r][i] = big
    bad = {}  # row -> how it is broken
    for r in range(20, 26):
        i = r % len(sy.specs)
        s = sy.specs[i]
        v = [math.nan, math.inf, -math.inf][r % 3]
        rows[r][i] = np.array([v, 0.0]) if isinstance(s, PointSpec) else v
        bad[r] = 'value'
        if isinstance(s, AngleSpec) and math.isinf(v):
            skip.add(r)  # math.sin(inf) raises in the scalar form
    X[30, 0] = math.nan
    X[31, 0] = math.inf  # an infinite angle: the scalar form NaNs all slots
    X[32, 1] = -math.inf
    X[33, 2] = math.nan
    bad.update({30: 'x', 31: 'x', 32: 'x', 33: 'x'})
    with np.errstate(all='raise'):  # no floating-point warnings escape either
        F, J, res = assert_rows_equal_scalar(sy, X, rows, skip)
    for r in bad:
        assert res[r] == math.inf, (r, bad[r])
    good = [r for r in range(50) if r not in bad]
    assert np.all(np.isfinite(res[good]))


@pytest.mark.parametrize('label,sy,ref', SYSTEMS, ids=IDS)
def test_evaluate_batch_jacobian_matches_finite_differences(label, sy, ref):
    """J of evaluate_batch against central differences of its own F in the scale-free
    variables (x moved by h * step_scale), at 20 configurations at once."""
    rng = np.random.default_rng(10)
    X, rows = random_inputs(sy, ref, 20, rng, spread=0.15)
    vals = stack(sy, rows)
    _, J, _ = sy.evaluate_batch(X, vals)
    h = 1e-6
    for j in range(sy.n):
        e = np.zeros(sy.n)
        e[j] = h * sy.step_scale[j]
        fd = (
            sy.evaluate_batch(X + e, vals, False)[0] - sy.evaluate_batch(X - e, vals, False)[0]
        ) / (2 * h)
        np.testing.assert_allclose(J[:, :, j], fd, rtol=1e-6, atol=1e-8, err_msg=f'{label} {j}')


@pytest.mark.parametrize('label,sy,ref', SYSTEMS, ids=IDS)
def test_packed_jacobian_holds_every_entry(label, sy, ref):
    """The J the batched solve keeps packed (BatchNewton.evaluate(packed=True): block by block,
    or only its varying columns where those are fewer) unpacks to evaluate_batch's dense J bit
    for bit (every entry that can be nonzero is kept or constant; the rest are 0), with the
    same F and res; block parts are views of it."""
    if sy.m != sy.n:
        return
    rng = np.random.default_rng(9)
    X, rows = random_inputs(sy, ref, 30, rng)
    V = sy.batch.values(stack(sy, rows), len(X))
    F, J, res = sy.evaluate_batch(X, stack(sy, rows))
    Fp, Jp, rp = sy.batch.evaluate(X, V, True, packed=True)
    layout = sy.batch.layout()
    assert Jp.shape == (len(X), layout.size)
    assert np.array_equal(layout.unpack(Jp), J, equal_nan=True)
    assert np.array_equal(Fp, F, equal_nan=True) and np.array_equal(rp, res)
    if isinstance(layout, PackedJacobian):
        for diag, left in layout.parts(Jp):
            assert np.shares_memory(diag, Jp) and (left.size == 0 or np.shares_memory(left, Jp))


def test_evaluate_batch_empty_and_shape_errors():
    sy = Solver(scene('four_bar'), method='newton').system
    F, J, res = sy.evaluate_batch(np.zeros((0, sy.n)), [np.zeros(0)])
    assert F.shape == (0, sy.m) and J.shape == (0, sy.m, sy.n) and res.shape == (0,)
    with pytest.raises(ValueError, match='shape'):
        sy.evaluate_batch(np.zeros((3, sy.n + 1)), [np.zeros(3)])
    with pytest.raises(ValueError, match='shape'):
        sy.evaluate_batch(np.zeros((3, sy.n)), [np.zeros(4)])
    with pytest.raises(ValueError):
        sy.evaluate_batch(np.zeros((3, sy.n)), [np.zeros(3), np.zeros(3)])


def test_hybrid_system_is_refused():
    """A system whose rows name links placed by the dyad plan (fixed poses per solve) is not
    batched: a clear ValueError, not a wrong answer."""
    h = Solver(scene('excavator'), knowns=['G_Z3_rod', 'point:C'], method='auto')
    assert h.mode == 'hybrid' and 'boom' in h.closed_links
    sy = h.system
    X = np.tile(sy.reference_x(), (2, 1))
    vals = [
        np.full(2, float(list(h.compiled.ref_values)[0])),
        np.tile(list(h.compiled.ref_values)[1], (2, 1)),
    ]
    with pytest.raises(ValueError, match='fixed poses'):
        sy.evaluate_batch(X, vals)
    with pytest.raises(ValueError, match='fixed poses'):
        sy.solve_batch(X, vals, 1)


def test_non_square_system():
    """Without its input spec the four-bar has 8 rows and 9 unknowns: evaluate_batch still
    equals the scalar rows, solve_batch refuses."""
    mech = scene('four_bar')
    sy = LoopSystem(mech, [], mech.moving_links)
    assert sy.m != sy.n
    rng = np.random.default_rng(11)
    X, rows = random_inputs(sy, [], 10, rng)
    assert_rows_equal_scalar(sy, X, rows)
    with pytest.raises(ValueError, match='square'):
        sy.solve_batch(X, [], 1)


# =============================================================================================
# solve_batch on warm-started sweeps: the scalar Solver's answers
# =============================================================================================


def check_against_sweep(sy, xs, signs, vals, b, rows):
    """Each ok row among ``rows`` (indices of the step k - 1 -> k) is the scalar x_k on the
    same det J side, at its residual, with the slogdet sign and scaled_cond of the scalar
    Jacobian there."""
    k = np.asarray(rows) + 1
    ok = b.ok
    gap = np.abs(b.x[ok] - xs[k][ok]) / sy.step_scale
    assert gap.max(initial=0.0) <= 1e-10, gap.max()
    assert np.all(b.residual[ok] <= TOL)
    assert np.array_equal(b.det_sign[ok], signs[k][ok])
    for i in np.flatnonzero(ok):
        vk = vals[k[i]]
        _, Js, rs = sy.evaluate_scaled(b.x[i], vk, None)
        # a few ulps apart at the rounding floor: wrap and atan2 are vectorised separately
        assert b.residual[i] == pytest.approx(rs, rel=1e-12, abs=2e-15)
        assert b.det_sign[i] == int(np.linalg.slogdet(Js)[0])
        assert b.cond[i] == pytest.approx(reported_cond(sy, Js), rel=1e-10)
        assert b.cond[i] < NEAR_SINGULAR_COND


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
