"""The two number backends (linkage_ros.core.ops) every kernel runs on: one command (Python
numbers) and a batch (numpy arrays, complex points as CArray). Oracles: Python's own complex
arithmetic, 50-digit mpmath, and each row solved alone."""

import math

import mpmath as mp
import numpy as np

from linkage_ros.core import dyads
from linkage_ros.core.ops import BATCH, SCALAR, CArray, to_complex, to_xy


def _angles(rng):
    out = []
    for scale in (4.0, 1e3, 1e6, 3e6, 1e12, 1e300):
        out.append(rng.uniform(-scale, scale, 4000))
    special = [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 1e6, -1e6, 2 * math.pi * 123456]
    special += [0.0, -0.0, 2.0**21, -(2.0**21), 5e-324]
    return np.concatenate(out + [np.array(special)])


def test_one_angle_wrap_on_both_backends():
    """The batch wrap runs the scalar wrap's float operations elementwise: equal bit for bit;
    in (-pi, pi] values are kept exactly; non-finite ones give NaN on both."""
    v = _angles(np.random.default_rng(9))
    got = BATCH.wrap(v)
    want = np.array([SCALAR.wrap(a) for a in v.tolist()])
    assert np.array_equal(got, want)
    inside = np.random.default_rng(1).uniform(-math.pi, math.pi, 1000)
    assert np.array_equal(BATCH.wrap(inside), inside)
    assert all(math.isnan(SCALAR.wrap(a)) for a in (math.nan, math.inf, -math.inf))
    assert np.all(np.isnan(BATCH.wrap(np.array([math.nan, math.inf, -math.inf]))))


def test_angle_wrap_of_arrays_within_the_three_part_range():
    """Arrays whose angles are all finite and within WRAP_REDUCE_LIMIT (a warm batch's angle
    rows: reduced in one pass over the whole array) wrap bit for bit as the scalar wrap does,
    the sign of a zero included: a turn or so off, up to the limit, odd multiples of pi (k
    rounded off by one) and angles already in range mixed in."""
    rng = np.random.default_rng(4)
    odd = np.array([math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 2.0**21, -(2.0**21)])
    for v in (
        rng.uniform(-7.0, 7.0, 1000),
        np.concatenate([rng.uniform(-math.pi, math.pi, 50), [0.0, -0.0, 4.0, -4.0]]),
        rng.uniform(-(2.0**21), 2.0**21, 1000),
        np.concatenate([rng.uniform(-7.0, 7.0, 50), odd]),
    ):
        got = BATCH.wrap(v)
        want = np.array([SCALAR.wrap(a) for a in v.tolist()])
        assert np.array_equal(got, want) and np.array_equal(np.signbit(got), np.signbit(want))


def test_angle_wrap_is_exact_reduction():
    """Against a 50-digit reduction of the float itself: within 2 ulps of the true value in
    [-pi, pi], up to 1e300 rad."""
    v = _angles(np.random.default_rng(3))[::20]
    got = BATCH.wrap(v)
    with mp.workdps(400):  # enough digits for k up to 1e300 / 2 pi
        for a, g in zip(v.tolist(), got.tolist()):
            x = mp.mpf(a)
            r = x - 2 * mp.pi * mp.nint(x / (2 * mp.pi))
            assert -math.pi < g <= math.pi
            assert on_circle(mp.mpf(g) - r) <= 2 * math.ulp(max(abs(float(r)), 1e-300)), a


def on_circle(d):
    """|d| taken modulo 2 pi (mpmath): -math.pi, itself in (-pi, pi] by 1.2e-16, is wrapped
    to math.pi, as floats compare (-math.pi < v <= math.pi), the same angle to 2.4e-16."""
    return abs(d - 2 * mp.pi * mp.nint(d / (2 * mp.pi)))


def test_scalar_wrap_at_the_edges_of_its_branches():
    """The one-float wrap where it changes method (its in-range test, the three-part reduction's
    limit, atan2 beyond), on ints and numpy scalars too: within 2 ulps of a 50-digit reduction,
    and NaN for NaN and inf (a numpy inf too, with no warning raised)."""
    import warnings

    from linkage_ros.core.ops import WRAP_REDUCE_LIMIT, wrap_one

    edges = []
    for x in (math.pi, 3 * math.pi, WRAP_REDUCE_LIMIT, 1e300):
        for y in (x, math.nextafter(x, 0.0), math.nextafter(x, math.inf)):
            edges += [y, -y, np.float64(y)]
    edges += [7, -7, 2**21, 10**30]
    with mp.workdps(400):
        for a in edges:
            g = wrap_one(a)
            x = mp.mpf(float(a))
            r = x - 2 * mp.pi * mp.nint(x / (2 * mp.pi))
            assert -math.pi < g <= math.pi, a  # as TOPICS.md promises: -pi is given as pi
            assert on_circle(mp.mpf(float(g)) - r) <= 2 * math.ulp(max(abs(float(r)), 1e-300)), a
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        for a in (math.nan, math.inf, -math.inf, np.float64(math.inf), np.float64(math.nan)):
            assert math.isnan(wrap_one(a))


def test_carray_arithmetic_is_pythons_complex_arithmetic():
    """CArray (a batch of complex points as two real arrays) rounds exactly as Python's complex
    numbers do, operation by operation: the batch and the one-command backend agree bitwise."""
    rng = np.random.default_rng(5)
    a = rng.normal(0, 10, (500, 2))
    b = rng.normal(0, 10, (500, 2))
    s = rng.normal(0, 10, 500)
    za, zb = to_complex(a), to_complex(b)
    ops = {
        'mul': (lambda x, y, t: x * y),
        'add': (lambda x, y, t: x + y),
        'sub': (lambda x, y, t: x - y),
        'real*': (lambda x, y, t: t * x),
        'div real': (lambda x, y, t: x / t),
        'mixed': (lambda x, y, t: (x - y) * (t + y) + x / t),
    }
    for name, f in ops.items():
        got = to_xy(f(za, zb, s))
        for i in range(500):
            want = f(complex(*a[i]), complex(*b[i]), float(s[i]))
            assert got[i, 0] == want.real and got[i, 1] == want.imag, (name, i)
    assert np.array_equal(abs(za), [abs(complex(*p)) for p in a])


def test_a_row_is_solved_the_same_in_any_batch():
    """numpy's complex ufuncs round differently on long and short arrays (SIMD paths); the batch
    backend does not use them: a dyad row solved in a batch of 4096 equals the same row alone,
    bit for bit, and the one-command backend agrees with both to a few ulps."""
    rng = np.random.default_rng(11)
    n = 4096
    c1 = rng.normal(0, 1, (n, 2))
    c2 = c1 + rng.normal(0, 1, (n, 2))
    d = np.hypot(*(c2 - c1).T)
    r1 = rng.uniform(0.3, 1.0, n) * d
    r2 = d - r1 + rng.uniform(0.05, 1.0, n) * r1
    many = dyads.circle_circle(c1, r1, c2, r2, 1)
    for i in range(0, n, 97):
        one = dyads.circle_circle(c1[i : i + 1], r1[i : i + 1], c2[i : i + 1], r2[i : i + 1], 1)
        assert np.array_equal(many.point[i], one.point[0])
        pair = dyads.solve_rrr_dyad(SCALAR, complex(*c1[i]), r1[i], complex(*c2[i]), r2[i])
        z, ok = dyads.dyad_point(SCALAR, pair, 1)
        assert ok == bool(many.ok[i])
        if ok:
            assert abs(z - complex(*many.point[i])) <= 8 * 2.0**-52 * 4 / many.margin[i]


def test_backends_share_one_interface():
    """Everything a kernel may call exists on both backends."""
    names = {n for n in dir(SCALAR) if not n.startswith('_')}
    assert names == {n for n in dir(BATCH) if not n.startswith('_')}
    assert SCALAR.batch is False and BATCH.batch is True
    assert isinstance(BATCH.expi(np.zeros(3)), CArray)
