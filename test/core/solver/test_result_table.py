"""The one results table (core.solver.table.ResultTable) and the continuity rule over rows
(core.solver.continuity: keeps_sign, nearer_for_every_ratio, nearer_angle).

Oracles: the closed-form four-bar at 50 digits (oracles.fourbar), the side of B relative to
A -> O4 for the branch text, plain distances for the rule.
"""

from __future__ import annotations

import math

import numpy as np
import oracles as orc
from hypothesis import given, settings
from hypothesis import strategies as st
from scenes import four_bar

from linkage_ros.core.execute import CONTINUITY_MARGIN
from linkage_ros.core.solver import ResultTable, Solver
from linkage_ros.core.solver.continuity import (
    MAX_STEP_RATIO,
    keeps_sign,
    nearer_angle,
    nearer_for_every_ratio,
    predicted_point,
)

TRIPLE_ROCKER = (4.0, 3.0, 5.0, 2.5)  # non-Grashof: no assembly near theta2 = 0


def _crank_columns():
    thetas = np.array([0.0, 0.9, math.nan, 1.7, 3.0, 0.05, -2.5, math.inf])
    return thetas


def test_a_batch_as_the_table_refused_rows_nan_answered_rows_the_closed_form():
    mech = four_bar(*TRIPLE_ROCKER)
    thetas = _crank_columns()
    batch = Solver(mech, method='closed_form', branch='+').solve_batch({'crank': thetas})
    table = batch.table()
    assert isinstance(table, ResultTable) and table.n == thetas.size
    l1, l2, l3, l4 = TRIPLE_ROCKER
    for i, t in enumerate(thetas.tolist()):
        want = orc.fourbar(l1, l2, l3, l4, t, 1) if math.isfinite(t) else {'ok': False}
        assert bool(table.ok[i]) == want['ok'], (i, t)
        if not want['ok']:
            assert table.reason[i], (i, t)  # refused: why, and no numbers
            for col in (table.residual, table.margin, table.cond):
                assert math.isnan(col[i])
            assert all(math.isnan(v[i]) for v in table.joints.values())
            assert all(np.isnan(v[i]).all() for v in table.points.values())
            assert all(math.isnan(v[i]) for v in table.links.values())
            assert table.branch(i) == '' and table.solver(i) == ''
            # BatchResult's own arrays keep their zeros (its public attributes are unchanged)
            assert batch.joints['A'][i] == 0.0 and batch.residual[i] == 0.0
            continue
        assert table.reason[i] is None
        for p in ('A', 'B'):
            assert orc.point_error(table.points[p][i], want[p]) <= 1e-12 * l1
        assert orc.angle_error(table.joints['O4'][i], want['theta4']) <= 1e-12
        # the branch text: '+' when B is left of A -> O4 (the oracle's convention)
        a, b, o4 = table.points['A'][i], table.points['B'][i], table.points['O4'][i]
        left = (o4[0] - a[0]) * (b[1] - a[1]) - (o4[1] - a[1]) * (b[0] - a[0]) > 0
        assert table.branch(i) == ('+' if left else '-')
        assert table.solver(i) == 'closed_form' and table.residual[i] <= 1e-12
        assert table.margin[i] == batch.margin[i] > 0


def test_rows_one_by_one_and_a_batch_fill_the_same_table():
    """put_result (a single solve's Result per row) and from_batch give the same table: the
    same NaN rows and the same numbers (the bag fills its table both ways)."""
    mech = four_bar(*TRIPLE_ROCKER)
    thetas = _crank_columns()
    batch = Solver(mech, method='closed_form', branch='+').solve_batch({'crank': thetas})
    one = Solver(mech, method='closed_form', branch='+')
    rows = ResultTable.blank(thetas.size, mech.actuators, mech.joint_names, mech.points)
    for i, t in enumerate(thetas.tolist()):
        rows.put_result(i, one.solve({'crank': t}, commit=False))
    table = batch.table()
    assert rows.ok.tolist() == table.ok.tolist()
    assert [r is None for r in rows.reason] == [r is None for r in table.reason]
    for name in mech.joint_names:
        np.testing.assert_allclose(rows.joints[name], table.joints[name], atol=1e-12)
    for p in mech.points:
        np.testing.assert_allclose(rows.points[p], table.points[p], atol=1e-12)
    assert [rows.branch(i) for i in range(rows.n)] == [table.branch(i) for i in range(table.n)]


def test_keeps_sign_is_the_continuity_margin_now_and_before():
    above, below = CONTINUITY_MARGIN * (1 + 1e-12), CONTINUITY_MARGIN * (1 - 1e-12)
    now = np.array([above, above, below, below, 0.5])
    prev = np.array([above, below, above, below, 0.5])
    assert keeps_sign(now, prev).tolist() == [True, False, False, False, True]
    # a slack asks for that much more
    assert keeps_sign(now, prev, slack=1e-6).tolist() == [False, False, False, False, True]


def test_nearer_for_every_ratio_by_hand():
    chosen = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    other = -chosen
    last = np.array([[0.5, 0.0], [0.1, 0.0], [0.1, 0.0]])
    prev = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.0]])
    has_prev = np.array([True, True, False])
    # row 0: moving towards chosen; row 1: nearer chosen now, but the step predicts -0.5,
    # nearer other; row 2: the same without a previous configuration (no extrapolation)
    got = nearer_for_every_ratio(chosen, other, last, prev, has_prev, 1e-9)
    assert got.tolist() == [True, False, True]


def _xy():
    return st.tuples(
        st.floats(-2, 2, allow_nan=False, allow_subnormal=False),
        st.floats(-2, 2, allow_nan=False, allow_subnormal=False),
    )


@settings(max_examples=300, deadline=None)
@given(_xy(), _xy(), _xy(), _xy(), st.floats(0.0, MAX_STEP_RATIO))
def test_nearer_for_every_ratio_holds_at_every_ratio(chosen, other, last, prev, ratio):
    """Where the rule says chosen wins, it is nearer the prediction at any ratio in
    [0, MAX_STEP_RATIO] (distances computed here from predicted_point's definition)."""
    c, o, l, p = (np.array([v], float) for v in (chosen, other, last, prev))
    if not nearer_for_every_ratio(c, o, l, p, np.array([True]), 1e-9)[0]:
        return
    target = (l[0][0] + ratio * (l[0][0] - p[0][0]), l[0][1] + ratio * (l[0][1] - p[0][1]))
    np.testing.assert_allclose(predicted_point(l, p, ratio)[0], target, rtol=0, atol=1e-15)
    d_c = math.dist(chosen, target)
    d_o = math.dist(other, target)
    assert d_c < d_o + 1e-12


def test_nearer_angle_wraps():
    last = np.array([3.1, 0.0])
    chosen = np.array([-3.1, 0.2])  # 0.083 rad from 3.1 across +-pi; 0.2 from 0
    other = np.array([2.9, -0.3])
    assert nearer_angle(chosen, other, last, 1e-9).tolist() == [True, True]
    assert nearer_angle(other, chosen, last, 1e-9).tolist() == [False, False]
