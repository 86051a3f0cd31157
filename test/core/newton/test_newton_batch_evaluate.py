"""The batched Newton kernel (core.newton): LoopSystem.evaluate_batch.

Oracles: the scalar residual/Jacobian evaluate_scaled row by row, central differences and
dyads.wrap_angle.

Would fail if: a batched row disagreed with the scalar evaluation (F, J or res, including the
angle wrap of large values and non-finite inputs); J disagreed with finite differences; the
packed Jacobian lost an entry; or an empty batch, a hybrid system or a non-square system were
mishandled.
"""

import math

import numpy as np
import pytest
from newton_batch_helpers import POINT_KNOWNS, scene, stack

from linkage_ros.core.newton import LoopSystem
from linkage_ros.core.newton.batch_tables import PackedJacobian
from linkage_ros.core.quantities import AngleSpec, PointSpec, SlideSpec
from linkage_ros.core.solver import Solver
from linkage_ros.resources import config_dir

ALL_SCENES = sorted(p.stem for p in config_dir().glob('*.yaml'))


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
