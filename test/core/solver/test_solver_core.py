"""The general solver machinery: plan compilation, closed form vs Newton and branch selection
(refused commands, limits, unreachable inputs and scene errors: test_solver_refusals.py; the
dyad kernels: test/core/test_dyad_kernels.py; one command vs a batch: test_solver_batch.py).

Every expected number comes from ``oracles`` (50-digit mpmath geometry taking the float inputs
exactly) or from elementary geometry written out here -- never from the code under test.
"""

import math

import mpmath as mp
import numpy as np
import oracles as orc
import pytest
from scenes import four_bar, slider_crank
from solver_core_helpers import AGREE, CRANK_ROCKER, TIGHT, five_bar, lever

from linkage_ros.core.errors import PlanError
from linkage_ros.core.solver import Solver


def ops(solver):
    return [s.op for s in solver.plan.steps]


def pt_dist(p, q):
    return math.hypot(p[0] - q[0], p[1] - q[1])


def max_point_gap(r1, r2):
    return max(pt_dist(r1.points[p], r2.points[p]) for p in r1.points)


# =============================================================================================
# plan compilation
# =============================================================================================


def test_plan_four_bar_forward_and_inverse():
    l1, l2, l3, l4 = CRANK_ROCKER
    m = four_bar(*CRANK_ROCKER)
    fwd = Solver(m)
    assert ops(fwd) == ['ground', 'circle_circle', 'two_points', 'two_points']
    assert fwd.plan.branch_steps[0].point == 'B'
    assert 'RRR dyad: B from circles about A (coupler) and O4 (rocker)' in fwd.plan.describe()[1]
    inv = Solver(m, knowns=['rocker'])
    assert ops(inv) == ['ground', 'circle_circle', 'two_points', 'two_points']
    assert inv.plan.branch_steps[0].point == 'A'
    assert inv.inverse and inv.mode == 'closed_form'
    # answers against the oracle (B left of A -> O4 / A left of O2 -> B in the reference pose)
    for t in np.linspace(-3.0, 3.0, 13):
        r = fwd.solve({'crank': float(t)})
        want = orc.fourbar(l1, l2, l3, l4, t, 1)
        assert r.success and r.branch == '+'
        assert orc.point_error(r.points['B'], want['B']) <= TIGHT * m.length_scale
        assert orc.angle_error(r.links['coupler'], want['theta3']) <= TIGHT
        assert orc.angle_error(r.links['rocker'], want['theta4']) <= TIGHT
    ref_side = orc.cross(m.points['B'] - m.points['O2'], m.points['A'] - m.points['O2'])
    sign = 1 if ref_side > 0 else -1
    lo, hi = _rocker_range(CRANK_ROCKER)
    for t4 in np.linspace(lo, hi, 11)[1:-1]:
        r = inv.solve({'rocker': float(t4)})
        want = orc.fourbar_inverse(l1, l2, l3, l4, t4, sign)
        assert r.success, r.reason
        assert orc.point_error(r.points['A'], want['A']) <= TIGHT * m.length_scale
        assert orc.angle_error(r.inputs['crank'], want['theta2']) <= TIGHT
        assert r.targets == {'rocker': float(t4)}


def _rocker_range(L):
    """Rocker extremes of a crank-rocker on its upper ('+') branch: where crank and coupler are
    collinear (cosine rule, mpmath)."""
    t4 = [float(t) for t, _ in orc.fourbar_output_toggles(*L) if t > 0]
    return min(t4), max(t4)


def test_plan_slider_crank_forward_and_inverse():
    r_, rod, e, dang = 1.0, 3.0, 0.5, 0.3
    m = slider_crank(r_, rod, e, dang)
    fwd = Solver(m)
    assert 'circle_line' in ops(fwd)
    assert any('RRP dyad: B on slide slider' in d for d in fwd.plan.describe())
    for t in np.linspace(-3.1, 3.1, 13):
        res = fwd.solve({'crank': float(t)})
        want = orc.slider_crank(r_, rod, e, dang, t, 1)
        assert res.success
        assert orc.point_error(res.points['B'], want['B']) <= TIGHT * m.length_scale
        assert abs(res.joints['slider'] - float(want['x'])) <= TIGHT * m.length_scale
        assert orc.angle_error(res.links['rod'], want['theta3']) <= TIGHT
    inv = Solver(m, knowns=['slider'])
    assert ops(inv)[:2] == ['ground', 'circle_circle']
    assert inv.plan.branch_steps[0].point == 'A'
    for x in np.linspace(2.2, 3.8, 9):
        res = inv.solve({'slider': float(x)})
        want = orc.slider_crank_inverse(r_, rod, e, dang, x, 1)
        assert res.success, res.reason
        assert orc.point_error(res.points['A'], want['A']) <= TIGHT * m.length_scale
        assert orc.angle_error(res.inputs['crank'], want['theta2']) <= TIGHT


def test_plan_cylinder_driven_lever():
    """Forward: the cylinder at a known length is one rigid strut, so P is an RRR dyad about O
    and C. Inverse (lever angle known): the barrel orients through P (RPR)."""
    m = lever()
    assert m.dof == 1 and m.actuators['cyl'].cylinder
    fwd = Solver(m)
    assert ops(fwd)[:2] == ['ground', 'circle_circle']
    assert 'C (cyl_barrel+cyl_rod)' in fwd.plan.describe()[1]
    pts = m.points
    l_op = float(np.hypot(*(pts['P'] - pts['O'])))
    sign = fwd.plan.branch_steps[0].sign
    for length in np.linspace(0.55, 1.38, 8):
        r = fwd.solve({'cyl': float(length)})
        want = orc.circle_circle(pts['O'], l_op, pts['C'], length, sign)
        assert r.success, r.reason
        assert orc.point_error(r.points['P'], want.point) <= TIGHT * m.length_scale
        assert abs(r.joints['cyl'] - length) <= TIGHT * m.length_scale
        # the barrel and rod point along C -> P
        axis = float(orc.direction(pts['C'], r.points['P']))
        assert orc.angle_error(r.links['cyl_barrel'], axis) <= 1e-12
        assert orc.angle_error(r.links['cyl_rod'], axis) <= 1e-12
    inv = Solver(m, knowns=['lever'])
    assert 'line_through' in ops(inv)
    lever_ref = math.atan2(*(pts['P'] - pts['O'])[::-1])
    for ang in np.linspace(lever_ref - 0.5, lever_ref + 0.5, 9):
        r = inv.solve({'lever': float(ang)})
        with mp.workdps(50):
            p = (l_op * mp.cos(mp.mpf(float(ang))), l_op * mp.sin(mp.mpf(float(ang))))
            want_len = mp.hypot(p[0] - pts['C'][0], p[1] - pts['C'][1])
        assert r.success, r.reason
        assert abs(r.inputs['cyl'] - float(want_len)) <= TIGHT * m.length_scale


def test_plan_five_bar_forward_and_point_known():
    m = five_bar()
    pts = m.points
    lens = {
        k: float(np.hypot(*(pts[a] - pts[b])))
        for k, (a, b) in {
            'left': ('O1', 'A'),
            'right': ('O5', 'B'),
            'ac': ('A', 'C'),
            'bc': ('B', 'C'),
        }.items()
    }
    fwd = Solver(m)
    assert m.dof == 2 and fwd.knowns == ['q1', 'q2']
    assert ops(fwd) == ['ground', 'circle_circle', 'two_points', 'two_points']
    assert fwd.plan.branch_steps[0].point == 'C'
    inv = Solver(m, knowns=['point:C'])
    assert ops(inv)[:3] == ['ground', 'known_point', 'circle_circle']
    assert [s.point for s in inv.plan.branch_steps] == ['A', 'B']
    for q1, q2 in [(1.6, 1.5), (1.3, 1.9), (2.0, 1.2), (1.5708, 1.5708)]:
        r = fwd.solve({'q1': q1, 'q2': q2})
        want = orc.five_bar(
            pts['O1'], pts['O5'], lens['left'], lens['right'], lens['ac'], lens['bc'], q1, q2, 1
        )
        assert r.success and r.branch == '+'
        assert orc.point_error(r.points['C'], want['C']) <= TIGHT * m.length_scale
        # inverse: the point C found above gives back the two crank angles
        c = r.points['C']
        ri = inv.solve({'point:C': c})
        assert ri.success, ri.reason
        assert abs(ri.inputs['q1'] - q1) <= 1e-10 and abs(ri.inputs['q2'] - q2) <= 1e-10
        a = orc.circle_circle(pts['O1'], lens['left'], c, lens['ac'], 1).point
        b = orc.circle_circle(c, lens['bc'], pts['O5'], lens['right'], 1).point
        assert orc.point_error(ri.points['A'], a) <= TIGHT * m.length_scale
        assert orc.point_error(ri.points['B'], b) <= TIGHT * m.length_scale
        assert ri.residual <= TIGHT


def test_plan_is_pruned_to_the_wanted_outputs():
    """Asking only for the crank link needs no dyad at all."""
    m = four_bar(*CRANK_ROCKER)
    s = Solver(m, outputs=['crank'])
    assert ops(s) == ['ground']
    r = s.solve({'crank': 0.3})
    assert r.success and set(r.links) == {'ground', 'crank'}


# =============================================================================================
# closed form vs Newton over sweeps
# =============================================================================================


def _sweep_agree(mech, knowns, commands, branch='continuous'):
    cf = Solver(mech, knowns=knowns, method='closed_form', branch=branch)
    nw = Solver(mech, knowns=knowns, method='newton', branch=branch)
    worst = 0.0
    for cmd in commands:
        a, b = cf.solve(cmd), nw.solve(cmd)
        assert a.success and b.success, (cmd, a.reason, b.reason)
        assert a.branch == b.branch, cmd
        assert a.residual <= TIGHT and b.residual <= TIGHT
        gap = max_point_gap(a, b) / mech.length_scale
        for link in a.links:
            gap = max(gap, abs(math.remainder(a.links[link] - b.links[link], 2 * math.pi)))
        worst = max(worst, gap)
    assert worst <= AGREE, worst


def test_closed_form_and_newton_agree_four_bar_sweeps():
    m = four_bar(*CRANK_ROCKER, coupler_point={'distance': 2.0, 'angle': 0.4})
    _sweep_agree(m, None, [{'crank': float(t)} for t in np.linspace(0, 4 * math.pi, 241)])
    lo, hi = _rocker_range(CRANK_ROCKER)
    path = np.concatenate(
        [np.linspace(lo + 0.02, hi - 0.02, 60), np.linspace(hi - 0.02, lo + 0.02, 60)]
    )
    _sweep_agree(m, ['rocker'], [{'rocker': float(t)} for t in path])


def test_closed_form_and_newton_agree_slider_crank_sweeps():
    m = slider_crank(1.0, 3.0, 0.5, 0.3)
    _sweep_agree(m, None, [{'crank': float(t)} for t in np.linspace(0, 4 * math.pi, 241)])
    path = np.concatenate([np.linspace(2.1, 3.9, 50), np.linspace(3.9, 2.1, 50)])
    _sweep_agree(m, ['slider'], [{'slider': float(x)} for x in path])


def test_closed_form_and_newton_agree_lever_and_five_bar_sweeps():
    m = lever()
    path = np.concatenate([np.linspace(0.55, 1.38, 40), np.linspace(1.38, 0.55, 40)])
    _sweep_agree(m, None, [{'cyl': float(x)} for x in path])
    _sweep_agree(
        m, ['lever'], [{'lever': 0.6 * math.sin(s)} for s in np.linspace(0, 2 * math.pi, 60)]
    )
    m5 = five_bar()
    _sweep_agree(
        m5,
        None,
        [
            {'q1': 1.6 + 0.3 * math.sin(s), 'q2': 1.5 + 0.3 * math.cos(s)}
            for s in np.linspace(0, 2 * math.pi, 60)
        ],
    )
    _sweep_agree(
        m5,
        ['point:C'],
        [
            {'point:C': (0.5 + 0.15 * math.cos(s), 1.1 + 0.1 * math.sin(s))}
            for s in np.linspace(0, 2 * math.pi, 60)
        ],
    )


# =============================================================================================
# explicit branches
# =============================================================================================


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_explicit_branches_give_the_two_assembly_modes(method):
    l1, l2, l3, l4 = CRANK_ROCKER
    m = four_bar(*CRANK_ROCKER)
    for t in (0.0, 0.9, 2.0, math.pi, -2.5):
        res = {}
        for br in '+-':
            s = Solver(m, method=method, branch=br)
            r = s.solve({'crank': t})
            assert r.success, (t, br, r.reason)
            assert r.branch == br and r.residual <= TIGHT
            want = orc.fourbar(l1, l2, l3, l4, t, 1 if br == '+' else -1)
            assert orc.point_error(r.points['B'], want['B']) <= AGREE * m.length_scale
            res[br] = r
        # the two modes are mirror images of each other about the line A-O4
        a = np.array(res['+'].points['A'])
        o4 = np.array(res['+'].points['O4'])
        u = (o4 - a) / np.linalg.norm(o4 - a)
        bp, bm = np.array(res['+'].points['B']) - a, np.array(res['-'].points['B']) - a
        mirrored = 2 * np.dot(bp, u) * u - bp
        assert np.linalg.norm(mirrored - bm) <= AGREE * m.length_scale
        assert orc.cross(u, bp) > 0 > orc.cross(u, bm)


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_explicit_branches_two_dyads(method):
    """The five-bar inverse has two dyads: all four sign strings assemble and close."""
    m = five_bar()
    target = (0.52, 1.08)
    seen = set()
    for br in ('++', '+-', '-+', '--'):
        s = Solver(m, knowns=['point:C'], method=method, branch=br)
        r = s.solve({'point:C': target})
        assert r.success, (br, r.reason)
        assert r.branch == br and r.residual <= TIGHT
        assert pt_dist(r.points['C'], target) <= TIGHT
        seen.add((round(r.points['A'][0], 9), round(r.points['B'][0], 9)))
    assert len(seen) == 4


BAD_BRANCHES = [
    ('+-', '2 sign'),
    ('', '0 sign'),
    ('x', "'x'"),
    ('up', "'up'"),
    (5, '5'),
    (None, 'None'),
    ('++-', '3 sign'),
]


@pytest.mark.parametrize('branch, fragment', BAD_BRANCHES)
def test_bad_branch_strings_raise_plan_error(branch, fragment):
    m = four_bar(*CRANK_ROCKER)
    with pytest.raises(PlanError) as exc:
        Solver(m, branch=branch)
    assert fragment in str(exc.value)


IMPOSSIBLE_KNOWNS = [
    (lambda: four_bar(*CRANK_ROCKER), ['crank', 'rocker'], 'degree(s) of freedom'),
    (lambda: four_bar(*CRANK_ROCKER), ['nosuch'], "unknown name 'nosuch'"),
    (lambda: four_bar(*CRANK_ROCKER), ['ground'], 'ground link'),
    (lambda: four_bar(*CRANK_ROCKER), ['crank', 'crank'], 'named twice'),
    (lambda: four_bar(*CRANK_ROCKER), ['point:Q'], "no point named 'Q'"),
    (lambda: four_bar(*CRANK_ROCKER), ['bogus:crank'], "unknown kind 'bogus'"),
    (five_bar, ['point:O1'], "'O1' is fixed by the ground"),
    (five_bar, ['point:C', 'q1'], 'degree(s) of freedom'),
]


@pytest.mark.parametrize('make, knowns, fragment', IMPOSSIBLE_KNOWNS)
def test_impossible_knowns_raise_plan_error(make, knowns, fragment):
    with pytest.raises(PlanError) as exc:
        Solver(make(), knowns=knowns)
    assert fragment in str(exc.value)


def test_no_closed_form_plan_is_refused_for_closed_form_only():
    m = five_bar()
    with pytest.raises(PlanError, match='no closed-form dyad plan'):
        Solver(m, knowns=['upper_l', 'upper_r'], method='closed_form')
    s = Solver(m, knowns=['upper_l', 'upper_r'])  # auto: Newton places the rest
    assert s.mode == 'hybrid'


@pytest.mark.parametrize(
    'kwargs, fragment',
    [
        ({'method': 'bogus'}, "unknown solver 'bogus'"),
        ({'tol': -1.0}, 'tolerance'),
        ({'tol': float('nan')}, 'tolerance'),
        ({'max_iter': 0}, 'max_iter'),
        ({'outputs': ['nosuch']}, "unknown output 'nosuch'"),
    ],
)
def test_bad_solver_settings_raise_plan_error(kwargs, fragment):
    with pytest.raises(PlanError) as exc:
        Solver(four_bar(*CRANK_ROCKER), **kwargs)
    assert fragment in str(exc.value)
