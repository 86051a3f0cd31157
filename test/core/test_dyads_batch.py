"""The batch RRR dyad kernel (core.dyads_batch) and the batch solve's shortcuts: each gives bit
for bit what the generic form gives. Oracles: dyads.solve_rrr_dyad on the BATCH backend,
np.ldexp, and limit_violation called row by row."""

import math

import numpy as np
import pytest
import scenes
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.core import dyads
from linkage_ros.core.dyads_batch import pow2, rrr_point_batch, solve_rrr_dyad_batch
from linkage_ros.core.ops import BATCH, CArray
from linkage_ros.core.plan import limit_violation
from linkage_ros.core.quantities import PointSpec
from linkage_ros.core.solver import Solver

_FIELDS = dyads.DyadPair._fields


def _same(a, b):
    """Equal bit for bit (NaN where the other is NaN, and the sign of every zero)."""
    a, b = np.asarray(a), np.asarray(b)
    a, b = np.broadcast_arrays(a, b)
    if a.dtype.kind == 'f' or b.dtype.kind == 'f':
        both_nan = np.isnan(a) & np.isnan(b)
        return bool(np.all(both_nan | ((a == b) & (np.signbit(a) == np.signbit(b)))))
    return bool(np.array_equal(a, b))


def _assert_same_pair(got, want):
    for name, g, w in zip(_FIELDS, got, want):
        if isinstance(w, CArray):
            assert isinstance(g, CArray), name
            assert _same(g.re, w.re) and _same(g.im, w.im), name
        else:
            assert _same(g, w), name


def _generic(c1, r1, c2, r2, tol=dyads.TANGENCY_TOL):
    with np.errstate(all='ignore'):
        return dyads.solve_rrr_dyad(BATCH, c1, r1, c2, r2, tol)


def _batch(c1, r1, c2, r2, tol=dyads.TANGENCY_TOL):
    with np.errstate(all='ignore'):
        return solve_rrr_dyad_batch(c1, r1, c2, r2, tol)


_HOSTILE = [0.0, -0.0, 5e-324, 1e-300, 1e-150, 1.0, 1e150, 1e300, 1.7e308, math.inf, -math.inf]
_HOSTILE += [math.nan, -1.0, 3.0]
_coord = st.one_of(
    st.floats(-10, 10, allow_nan=False), st.sampled_from(_HOSTILE), st.floats(allow_nan=True)
)
_radius = st.one_of(st.floats(0, 10), st.sampled_from(_HOSTILE), st.floats(allow_nan=True))


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(_coord, _coord, _coord, _coord, _radius, _radius), min_size=1, max_size=12)
)
def test_batch_rrr_dyad_is_the_generic_kernel_bit_for_bit(rows):
    """Any mix of rows (closing, not closing, tangent, non-finite, 1e-300 and 1e300 scales):
    every field of the DyadPair equal to the generic kernel's, and each branch's point."""
    a = np.array(rows, float)
    c1, c2 = CArray(a[:, 0], a[:, 1]), CArray(a[:, 2], a[:, 3])
    got, want = _batch(c1, a[:, 4], c2, a[:, 5]), _generic(c1, a[:, 4], c2, a[:, 5])
    _assert_same_pair(got, want)
    for sign in (1, -1):
        zg, okg = dyads.dyad_point(BATCH, got, sign)
        zw, okw = dyads.dyad_point(BATCH, want, sign)
        assert _same(okg, okw) and _same(zg.re, zw.re) and _same(zg.im, zw.im)


def test_batch_rrr_dyad_on_closing_batches_and_stated_lengths():
    """The common batch (every row closes; radii stated as floats) takes the shortcuts: still
    the generic kernel's answer, at every scale and at the toggle."""
    rng = np.random.default_rng(25)
    for scale in (1e-300, 1e-9, 1.0, 1e9, 1e300):
        t = rng.uniform(-math.pi, math.pi, 2000)
        c1 = CArray(0.1 * scale * np.cos(t), 0.1 * scale * np.sin(t))
        c2 = CArray(np.full(2000, 0.3 * scale), np.zeros(2000))
        for r1, r2 in ((0.25, 0.2), (0.15, 0.25), (0.2 + 0.1 - 1e-17, 0.1)):
            got = _batch(c1, r1 * scale, c2, r2 * scale)
            want = _generic(c1, r1 * scale, c2, r2 * scale)
            _assert_same_pair(got, want)


def _assert_point_is_generic(c1, r1, c2, r2, sign, tol=dyads.TANGENCY_TOL):
    """rrr_point_batch: the generic kernel's point of branch ``sign`` (dyad_point), its ok
    mask, and the pair's margin and violation, bit for bit."""
    with np.errstate(all='ignore'):
        got = rrr_point_batch(c1, r1, c2, r2, tol, sign)
        want = _generic(c1, r1, c2, r2, tol)
        z, ok = dyads.dyad_point(BATCH, want, sign)
    assert _same(got.point.re, z.re) and _same(got.point.im, z.im)
    assert _same(got.ok, ok) and got.all_ok == bool(np.all(ok))
    assert _same(got.margin, want.margin) and _same(got.violation, want.violation)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(_coord, _coord, _coord, _coord, _radius, _radius), min_size=1, max_size=12),
    st.sampled_from([1, -1, 'rows']),
)
def test_rrr_point_is_the_generic_kernel_and_dyad_point_bit_for_bit(rows, sign):
    """Any mix of rows, and a branch sign for the batch or per row: the generic answer."""
    a = np.array(rows, float)
    c1, c2 = CArray(a[:, 0], a[:, 1]), CArray(a[:, 2], a[:, 3])
    sg = np.where(np.arange(len(a)) % 2 == 0, 1, -1) if sign == 'rows' else sign
    _assert_point_is_generic(c1, a[:, 4], c2, a[:, 5], sg)


def test_rrr_point_on_closing_batches_at_every_scale_and_at_the_toggle():
    """The common batch (every row closes: the in-place form), radii stated as floats or
    given per row, centres near 1e-300 (subnormal scales) to 1e300, tangent dyads (the toggle
    band) and a row at the far side: the generic answer, bit for bit."""
    rng = np.random.default_rng(27)
    n = 3000
    for scale in (1e-310, 1e-300, 1e-9, 1.0, 1e9, 1e300):
        t = rng.uniform(-math.pi, math.pi, n)
        c1 = CArray(0.1 * scale * np.cos(t), 0.1 * scale * np.sin(t))
        c2 = CArray(np.full(n, 0.3 * scale), np.zeros(n))
        for r1, r2 in ((0.25, 0.2), (0.15, 0.25), (0.2 + 0.1 - 1e-17, 0.1), (0.1, 0.2)):
            for sign in (1, -1):
                _assert_point_is_generic(c1, r1 * scale, c2, r2 * scale, sign)
                radii = rng.uniform(0.9, 1.1, n) * r1 * scale
                _assert_point_is_generic(c1, radii, c2, r2 * scale, sign)
    # exactly tangent rows: |c2 - c1| = r1 + r2 (a toggle in every row)
    t = rng.uniform(-math.pi, math.pi, n)
    c1 = CArray(np.zeros(n), np.zeros(n))
    c2 = CArray(0.5 * np.cos(t), 0.5 * np.sin(t))
    for sign in (1, -1):
        _assert_point_is_generic(c1, 0.25, c2, 0.25, sign)
        _assert_point_is_generic(c1, 0.375, c2, 0.125, sign)


def _one_value(v, n):
    """v in every one of n rows as the executor gives a ground point: a read-only view."""
    return np.broadcast_to(np.float64(v), (n,))


@pytest.mark.parametrize('which', ['first', 'second', 'both'])
def test_rrr_point_with_a_centre_the_same_in_every_row(which):
    """A centre that is one value in every row (a ground point: a stride-0 view, taken once
    by the kernel), the other per row or one value too, radii stated or per row, hostile
    values in the one-value centre: the generic answer, bit for bit."""
    rng = np.random.default_rng(29)
    n = 500
    t = rng.uniform(-math.pi, math.pi, n)
    rows = CArray(0.1 * np.cos(t), 0.1 * np.sin(t))
    for x, y in ((0.3, 0.0), (-0.2, 0.25), (0.0, -0.0), (1e300, 0.0), (math.nan, 0.0)):
        one = CArray(_one_value(x, n), _one_value(y, n))
        if which == 'both':
            c1, c2 = CArray(_one_value(0.05, n), _one_value(-0.02, n)), one
        else:
            c1, c2 = (one, rows) if which == 'first' else (rows, one)
        for r1 in (0.25, rng.uniform(0.2, 0.3, n)):
            for sign in (1, -1):
                _assert_point_is_generic(c1, r1, c2, 0.2, sign)


@pytest.mark.parametrize('centres', ['rows', 'one value'])
def test_rrr_point_with_one_scale_in_every_row(centres):
    """Every length in [1, 4) (a scale of 1 in every row: the kernel divides nothing), in
    [4, 16) (one scale, not 1) and straddling 4 (two scales), centres per row or both one
    value (two ground pivots: d taken once), radii stated or per row: the generic answer,
    bit for bit."""
    rng = np.random.default_rng(31)
    n = 400
    for scale in (1.0, 4.0, 3.0):
        t = rng.uniform(-math.pi, math.pi, n)
        if centres == 'rows':
            c1 = CArray(scale * 1.2 * np.cos(t), scale * 1.2 * np.sin(t))
            c2 = CArray(scale * (1.2 * np.cos(t) + 1.5), scale * 1.2 * np.sin(t))
        else:
            c1 = CArray(_one_value(scale * 1.1, n), _one_value(scale * 1.05, n))
            c2 = CArray(_one_value(scale * 2.3, n), _one_value(scale * 1.7, n))
        for r1 in (scale * 1.3, scale * rng.uniform(1.1, 1.4, n)):
            for r2 in (scale * 1.0, scale * rng.uniform(1.0, 1.2, n)):
                for sign in (1, -1):
                    _assert_point_is_generic(c1, r1, c2, r2, sign)


def test_pow2_is_ldexp_over_the_whole_exponent_range():
    k = np.arange(-1100, 1100)
    with np.errstate(over='ignore'):  # 2 ** 1024 and beyond: inf on both
        assert _same(pow2(k), np.ldexp(1.0, k))
    normal = np.arange(-1022, 1024, dtype=np.int32)
    assert _same(pow2(normal), np.ldexp(1.0, normal))


def _limited_scenes():
    out = []
    for stem in ('excavator', 'four_bar_grashof_double_rocker', 'hart', 'peaucellier'):
        out.append((stem, scenes.load(stem)))
    out.append(('oscillating', scenes.load('inverted_slider_crank_oscillating')))
    return out


@pytest.mark.parametrize(('stem', 'mech'), _limited_scenes(), ids=lambda v: str(v)[:20])
def test_batch_refuses_exactly_the_rows_limit_violation_refuses(stem, mech):
    """Every row of a batch is refused for a limit exactly where limit_violation (the one
    rule), called on that row alone, refuses it, with its words: values on, a hair beyond and
    far beyond each limit, whole turns away (periodic angles) and at random."""
    solver = Solver(mech, method='closed_form')
    c = solver.compiled
    rng = np.random.default_rng(len(stem))
    n = 4000
    cols = {}
    for s in c.specs:
        assert not isinstance(s, PointSpec)
        lo = s.minimum if s.minimum is not None else -3.0
        hi = s.maximum if s.maximum is not None else 3.0
        span = hi - lo
        a = rng.uniform(lo - span, hi + span, n)
        edges = [lo, hi, np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)]
        edges += [np.nextafter(lo, np.inf), np.nextafter(hi, -np.inf)]
        edges += [lo + 2 * math.pi, hi - 2 * math.pi, lo - 4 * math.pi, hi + 1e-12, lo - 1e-12]
        a[: len(edges)] = edges
        a[len(edges) : 2 * len(edges)] = rng.permutation(edges)
        cols[s.name] = a
    got = solver.solve_batch(cols)
    for i in range(n):
        want = None
        for s in c.specs:
            if s.minimum is not None or s.maximum is not None:
                want = limit_violation(s, float(cols[s.name][i]))
                if want:
                    break
        if want:
            assert got.reason[i] == want, i
        else:
            assert got.reason[i] is None or 'minimum' not in got.reason[i], i


@pytest.mark.parametrize('stem', ['excavator', 'four_bar', 'slider_crank'])
def test_batch_outputs_share_no_memory(stem):
    """Every output array of a batch whose rows all solve is its own (a cylinder's throw is an
    input and a joint value; the command columns are echoed in values): writing into one
    changes no other."""
    mech = scenes.load(stem)
    solver = Solver(mech, method='closed_form')
    ref = solver.compiled.reference_values()
    cols = {k: np.full(50, v) for k, v in ref.items()}
    got = solver.solve_batch(cols)
    assert got.ok.all()
    arrays = [*got.values, got.residual, got.margin, got.signs]
    for table in (got.points, got.joints, got.links, got.inputs):
        arrays.extend(table.values())
    arrays.extend(cols.values())
    for i, a in enumerate(arrays):
        for b in arrays[i + 1 :]:
            assert not np.shares_memory(a, b)
