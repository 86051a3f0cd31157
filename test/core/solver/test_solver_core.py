"""The general solver machinery: dyad primitives, plan compilation, closed form vs Newton,
branch selection, command validation, limits, unreachable inputs and scene errors.

Every expected number comes from ``oracles`` (50-digit mpmath geometry taking the float inputs
exactly) or from elementary geometry written out here -- never from the code under test.
"""

import cmath
import math
import re

import mpmath as mp
import numpy as np
import oracles as orc
import pytest
import scenes
from scenes import CONFIG, four_bar, slider_crank

from linkage_ros.core import dyads
from linkage_ros.core.errors import PlanError, SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.ops import SCALAR
from linkage_ros.core.solver import Result, Solver, compiling

EPS = 2.0**-52
TIGHT = 1e-12  # loop closure, fraction of the length scale
AGREE = 1e-9  # closed form vs Newton, fraction of the length scale

CRANK_ROCKER = (4.0, 1.5, 4.5, 3.0)  # (ground, crank, coupler, rocker), Grashof
TRIPLE_ROCKER = (4.0, 3.0, 5.0, 2.5)  # non-Grashof, input range symmetric about pi


# A lever pivoting on the ground at O, driven by a hydraulic cylinder from the ground pin C to the
# lever pin P; T is a tool point on the lever. |OP| = 0.6, |OC| = sqrt(0.85) ~ 0.922, so the
# cylinder can span 0.322 .. 1.522 m (it is limited to 0.5 .. 1.4 m).
LEVER = {
    'name': 'lever',
    'points': {'O': [0.0, 0.0], 'C': [0.2, -0.9], 'P': [0.6, 0.0], 'T': [1.2, 0.3]},
    'links': {'ground': ['O', 'C'], 'lever': ['O', 'P', 'T']},
    'cylinders': {'cyl': {'from': 'C', 'to': 'P', 'min': 0.5, 'max': 1.4}},
}

# A 2-DOF five-bar: cranks O1-A and O5-B, coupler links A-C(-P) and C-B.
FIVE_BAR = {
    'name': 'five_bar',
    'points': {
        'O1': [0.0, 0.0],
        'O5': [1.0, 0.0],
        'A': [0.0, 0.6],
        'B': [1.0, 0.6],
        'C': [0.5, 1.2],
        'P': [0.25, 1.2],
    },
    'links': {
        'ground': ['O1', 'O5'],
        'left': ['O1', 'A'],
        'upper_l': ['A', 'C', 'P'],
        'upper_r': ['C', 'B'],
        'right': ['O5', 'B'],
    },
    'actuators': {
        'q1': {'type': 'angle', 'link': 'left', 'pivot': 'O1'},
        'q2': {'type': 'angle', 'link': 'right', 'pivot': 'O5'},
    },
}


def lever():
    return Scene.from_dict(LEVER).mechanism


def five_bar():
    return Scene.from_dict(FIVE_BAR).mechanism


def ops(solver):
    return [s.op for s in solver.plan.steps]


def pt_dist(p, q):
    return math.hypot(p[0] - q[0], p[1] - q[1])


def max_point_gap(r1, r2):
    return max(pt_dist(r1.points[p], r2.points[p]) for p in r1.points)


# =============================================================================================
# dyad primitives against mpmath
# =============================================================================================

SCALES = [1e-6, 1e-3, 1.0, 1e3, 1e6]


def _rrr_cases(rng, scale, n=40):
    """Random circle pairs that intersect with a margin well away from tangency."""
    out = []
    while len(out) < n:
        c1 = rng.uniform(-2, 2, 2) * scale
        ang = rng.uniform(-math.pi, math.pi)
        d = rng.uniform(0.2, 2.0) * scale
        c2 = c1 + d * np.array([math.cos(ang), math.sin(ang)])
        r1 = rng.uniform(0.2, 2.0) * scale
        r2 = rng.uniform(0.2, 2.0) * scale
        if abs(r1 - r2) + 0.05 * scale < d < r1 + r2 - 0.05 * scale:
            out.append((c1, r1, c2, r2))
    return out


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
def test_circle_circle_matches_mpmath(scale, sign):
    """Both intersections, at scales 1e-6 .. 1e6, to a few ulps of the scale (well away from
    tangency: margin >= ~0.05 so the conditioning is O(1/margin))."""
    rng = np.random.default_rng(17)
    for c1, r1, c2, r2 in _rrr_cases(rng, scale):
        X, margin, ok, viol = dyads.circle_circle(c1, r1, c2, r2, sign)[:4]
        want = orc.circle_circle(c1, r1, c2, r2, sign)
        assert bool(ok) and float(viol) == 0.0
        err = orc.point_error(X, want.point)
        assert err <= 1e-14 * scale / float(want.margin), (c1, r1, c2, r2, err)
        assert abs(float(margin) - float(want.margin)) <= 1e-12
        # the sign convention: +1 is left of c1 -> c2
        side = float(orc.cross(np.subtract(c2, c1), np.subtract(X, c1)))
        assert side * sign > 0


@pytest.mark.parametrize('scale', SCALES)
def test_circle_circle_near_tangency_sqrt_law(scale):
    """d = r1 + r2 - eps * scale (external) and d = |r1 - r2| + eps * scale (internal): the
    height is ~sqrt(eps) and its error obeys the square-root law (see oracles.sqrt_law_bound)."""
    r1, r2 = 1.3 * scale, 0.7 * scale
    for external in (True, False):
        for eps_rel in (0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3):
            with mp.workdps(50):
                d = (
                    (mp.mpf(r1) + mp.mpf(r2) - eps_rel * scale)
                    if external
                    else (mp.mpf(r1) - mp.mpf(r2) + eps_rel * scale)
                )
            c1 = np.array([0.3, -0.2]) * scale
            u = np.array([math.cos(0.7), math.sin(0.7)])
            c2 = c1 + float(d) * u
            for sign in (1, -1):
                X, margin, ok, viol = dyads.circle_circle(c1, r1, c2, r2, sign)[:4]
                want = orc.circle_circle(c1, r1, c2, r2, sign)
                assert bool(ok), (external, eps_rel)
                if want.point is None:  # rounding of c2 put it just outside: the clamp
                    assert float(want.miss) <= dyads.TANGENCY_TOL * 2 * scale
                    continue
                err = orc.point_error(X, want.point)
                distance = max(float(-want.miss) / scale, 0.0)
                assert err <= scale * (1e-15 + orc.sqrt_law_bound(distance, EPS)), (
                    external,
                    eps_rel,
                    err,
                )


@pytest.mark.parametrize('scale', SCALES)
def test_circle_circle_beyond_tangency(scale):
    """Missing by 1e-9 of the scale: refused, with the violation equal to the miss; within the
    1e-12 clamp: assembled on the centre line (margin 0)."""
    r1, r2 = 1.3 * scale, 0.7 * scale
    c1 = np.array([0.1, 0.2]) * scale
    u = np.array([math.cos(-2.0), math.sin(-2.0)])
    for miss_rel, should_close in ((1e-9, False), (1e-6, False), (3e-14, True)):
        c2 = c1 + (r1 + r2 + miss_rel * scale) * u
        X, margin, ok, viol = dyads.circle_circle(c1, r1, c2, r2, 1)[:4]
        want = orc.circle_circle(c1, r1, c2, r2, 1)
        assert bool(ok) == should_close, miss_rel
        assert np.all(np.isfinite(X)) and np.isfinite(margin) and np.isfinite(viol)
        if should_close:
            assert float(margin) <= 1e-6
            assert orc.point_error(X, (c1 + r1 * u)) <= 1e-6 * scale
        else:
            assert float(viol) == pytest.approx(float(want.miss), rel=1e-5)
            assert float(margin) == 0.0


def test_circle_circle_degenerate_inputs_stay_finite():
    """Concentric circles, zero radius, NaN and inf: ok False and finite placeholders."""
    cases = [
        ((0, 0), 1.0, (0, 0), 1.0),
        ((0, 0), 0.0, (1, 0), 1.0),
        ((0, 0), 1.0, (np.nan, 0), 1.0),
        ((0, 0), np.inf, (1, 0), 1.0),
        ((np.inf, 0), 1.0, (1, 0), 1.0),
        ((0, 0), -1.0, (1, 0), 1.0),
    ]
    for c1, r1, c2, r2 in cases:
        X, margin, ok, viol = dyads.circle_circle(
            np.array(c1, float), r1, np.array(c2, float), r2, 1
        )[:4]
        assert not bool(ok), (c1, r1, c2, r2)
        assert np.all(np.isfinite(X)) and np.isfinite(margin) and np.isfinite(viol)


def test_circle_circle_batched_broadcasts_signs():
    """One call over a batch with mixed signs equals the per-row calls."""
    rng = np.random.default_rng(5)
    cases = _rrr_cases(rng, 1.0, 12)
    c1 = np.array([c[0] for c in cases])
    r1 = np.array([c[1] for c in cases])
    c2 = np.array([c[2] for c in cases])
    r2 = np.array([c[3] for c in cases])
    sign = np.where(np.arange(len(cases)) % 2 == 0, 1, -1)
    X = dyads.circle_circle(c1, r1, c2, r2, sign)[0]
    for i in range(len(cases)):
        xi = dyads.circle_circle(c1[i], r1[i], c2[i], r2[i], sign[i])[0]
        assert np.array_equal(X[i], xi)


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
def test_circle_line_matches_mpmath(scale, sign):
    rng = np.random.default_rng(3)
    for _ in range(40):
        c = rng.uniform(-2, 2, 2) * scale
        ang = rng.uniform(-math.pi, math.pi)
        u = np.array([math.cos(ang), math.sin(ang)])
        r = rng.uniform(0.3, 2.0) * scale
        dist = rng.uniform(-0.9, 0.9) * r
        p0 = c + dist * np.array([-u[1], u[0]]) + rng.uniform(-3, 3) * scale * u
        X, margin, ok, viol = dyads.circle_line(c, r, p0, u, sign)
        want = orc.circle_line(c, r, p0, u, sign)
        assert bool(ok)
        err = orc.point_error(X, want.point)
        assert err <= 1e-14 * scale / float(want.margin)
        assert abs(float(margin) - float(want.margin)) <= 1e-12
        # +1 is further along +u than the foot of the centre
        along = float(np.dot(np.subtract(X, c), u))
        assert along * sign > 0


@pytest.mark.parametrize('scale', SCALES)
def test_circle_line_refuses_a_miss_with_its_amount(scale):
    c = np.array([0.2, 0.1]) * scale
    u = np.array([0.6, 0.8])
    r = 1.0 * scale
    for miss_rel in (1e-9, 0.5):
        p0 = c + (r + miss_rel * scale) * np.array([-u[1], u[0]])
        X, margin, ok, viol = dyads.circle_line(c, r, p0, u, 1)
        assert not bool(ok) and np.all(np.isfinite(X))
        want = orc.circle_line(c, r, p0, u, 1)
        assert float(viol) == pytest.approx(float(want.miss), rel=1e-5)


@pytest.mark.parametrize('scale', SCALES)
@pytest.mark.parametrize('sign', [1, -1])
def test_line_through_point_matches_mpmath(scale, sign):
    rng = np.random.default_rng(11)
    for _ in range(40):
        p = rng.uniform(-1, 1, 2) * scale
        x = p + rng.uniform(0.3, 2.0) * scale * np.array(
            [math.cos(a := rng.uniform(-math.pi, math.pi)), math.sin(a)]
        )
        rho = float(np.hypot(*(x - p)))
        e = rng.uniform(-0.9, 0.9) * rho
        psi, margin, ok, viol = dyads.line_through_point(p, x, e, sign)
        want = orc.line_through_point(p, x, e, sign)
        assert bool(ok)
        assert orc.angle_error(float(psi), want) <= 1e-14 / float(margin)
        # the defining properties, checked on the float answer
        d = np.array([math.cos(float(psi)), math.sin(float(psi))])
        assert float(orc.cross(d, x - p)) == pytest.approx(e, abs=1e-14 * scale / float(margin))
        assert float(np.dot(d, x - p)) * sign > 0


def test_one_command_backend_agrees_with_the_batch_backend():
    """Each dyad kernel is written once (core.dyads, on core.ops backends); run on Python
    numbers (one command) and on numpy arrays (a batch) it agrees to a few ulps, both signs, and
    on ok/violation."""
    rng = np.random.default_rng(23)
    for scale in SCALES:
        for c1, r1, c2, r2 in _rrr_cases(rng, scale, 15):
            pair = dyads.solve_rrr_dyad(SCALAR, complex(*c1), r1, complex(*c2), r2)
            for s in (1, -1):
                X, mb, okb, vb = dyads.circle_circle(c1, r1, c2, r2, s)[:4]
                z, ok = dyads.dyad_point(SCALAR, pair, s)
                assert abs(z - complex(*X)) <= 8 * EPS * scale / float(mb)
            assert ok == bool(okb) and abs(pair.margin - float(mb)) <= 1e-14
        # a miss
        pair = dyads.solve_rrr_dyad(SCALAR, 0j, 1.0 * scale, 3.0 * scale, 1.0 * scale)
        vb = dyads.circle_circle((0, 0), 1.0 * scale, (3.0 * scale, 0), 1.0 * scale, 1)[3]
        assert not pair.ok and pair.violation == pytest.approx(float(vb), rel=1e-12)
        # circle-line
        c = complex(0.2, -0.1) * scale
        u = cmath.exp(0.4j)
        p0 = c + 0.3 * scale * 1j * u
        pair = dyads.solve_rrp_dyad(SCALAR, c, 0.8 * scale, p0, u)
        for s in (1, -1):
            X = dyads.circle_line(
                (c.real, c.imag), 0.8 * scale, (p0.real, p0.imag), (u.real, u.imag), s
            )[0]
            assert abs(dyads.dyad_point(SCALAR, pair, s)[0] - complex(*X)) <= 8 * EPS * scale
        # line through a point
        p, x, e = complex(0.1, 0.2) * scale, complex(1.1, -0.4) * scale, 0.3 * scale
        dy = dyads.solve_rpr_dyad(SCALAR, p, x, e)
        for s in (1, -1):
            psi = dyads.line_through_point((p.real, p.imag), (x.real, x.imag), e, s)[0]
            assert orc.angle_error(dyads.rpr_direction(SCALAR, dy, s), float(psi)) <= 1e-15


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


# =============================================================================================
# bad commands: a failed Result naming the problem, and no change of state
# =============================================================================================

BAD_SCALAR_COMMANDS = [
    ({'crank': float('nan')}, ['crank', 'finite']),
    ({'crank': float('inf')}, ['crank', 'finite']),
    ({'crank': -float('inf')}, ['crank', 'finite']),
    ({'crank': 0.5, 'extra': 1.0}, ['unknown', 'extra']),
    ({'crnk': 0.5}, ['unknown', 'crnk']),
    ({}, ['missing', 'crank']),
    ({'crank': '0.5'}, ['crank', 'number']),
    ({'crank': None}, ['crank', 'number']),
    ({'crank': [0.5]}, ['crank', 'number']),
    ({'crank': True}, ['crank', 'number']),
    ({'crank': 1 + 0j}, ['crank', 'number']),
    ([0.5], ['command']),
]


def _parallelogram():
    return four_bar(2.0, 1.0, 2.0, 1.0)


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
@pytest.mark.parametrize('bad, words', BAD_SCALAR_COMMANDS)
def test_bad_command_is_refused_and_changes_nothing(method, bad, words):
    """The bad command fails with a reason naming the problem; the following good commands give
    exactly what they give without it (continuity history untouched). The sweep runs through a
    change point of a parallelogram, where the history decides the branch."""
    m = _parallelogram()
    seq = [0.3, 0.15, 0.0, -0.15, -0.3]

    def run(bad_at):
        s = Solver(m, method=method)
        out = []
        for i, t in enumerate(seq):
            if i == bad_at:
                r = s.solve(bad)
                assert not r.success
                assert r.reason and all(w in r.reason for w in words), r.reason
            out.append(s.solve({'crank': t}))
        return out

    clean = run(None)
    for bad_at in (1, 3):
        dirty = run(bad_at)
        for a, b in zip(clean, dirty):
            assert a.success == b.success and a.branch == b.branch
            assert a.points == b.points


BAD_POINT_COMMANDS = [
    ({'point:C': (0.5, 1.1, 0.0)}, ['point:C', 'two numbers']),
    ({'point:C': (0.5,)}, ['point:C', 'two numbers']),
    ({'point:C': 0.5}, ['point:C', 'two numbers']),
    ({'point:C': 'ab'}, ['point:C', 'two numbers']),
    ({'point:C': (0.5, float('nan'))}, ['point:C', 'finite']),
    ({'point:C': (float('inf'), 1.0)}, ['point:C', 'finite']),
    ({'C': (0.5, 1.1)}, ['unknown', "'C'"]),
]


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
@pytest.mark.parametrize('bad, words', BAD_POINT_COMMANDS)
def test_bad_point_command_is_refused_and_changes_nothing(method, bad, words):
    m = five_bar()
    seq = [(0.5, 1.1), (0.52, 1.12), (0.55, 1.1), (0.5, 1.05)]

    def run(bad_at):
        s = Solver(m, knowns=['point:C'], method=method)
        out = []
        for i, c in enumerate(seq):
            if i == bad_at:
                r = s.solve(bad)
                assert not r.success
                assert r.reason and all(w in r.reason for w in words), r.reason
            out.append(s.solve({'point:C': c}))
        return out

    clean = run(None)
    dirty = run(2)
    assert all(r.success for r in clean)
    for a, b in zip(clean, dirty):
        assert a.points == b.points and a.branch == b.branch


# =============================================================================================
# actuator limits
# =============================================================================================


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_angle_limits_refuse_with_the_amount(method):
    m = four_bar(*CRANK_ROCKER, input=0.5, crank_limits={'min': -1.0, 'max': 1.0})
    s = Solver(m, method=method)
    assert s.solve({'crank': 0.999}).success
    assert s.solve({'crank': 1.0}).success
    r = s.solve({'crank': 1.5})
    assert not r.success
    assert 'crank' in r.reason and 'maximum' in r.reason and re.search(r'by 0\.5\b', r.reason)
    r = s.solve({'crank': -1.25})
    assert not r.success
    assert 'minimum' in r.reason and re.search(r'by 0\.25\b', r.reason)
    # and the refusals did not move the solver: it continues from 1.0
    r = s.solve({'crank': 0.99})
    assert r.success and r.branch == '+'


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_cylinder_limits_forward_and_inverse(method):
    m = lever()
    s = Solver(m, method=method)
    r = s.solve({'cyl': 1.5})
    assert not r.success and 'cyl' in r.reason and 'maximum' in r.reason
    assert re.search(r'by 0\.1\b', r.reason), r.reason
    r = s.solve({'cyl': 0.4})
    assert not r.success and 'minimum' in r.reason and re.search(r'by 0\.1\b', r.reason)
    # inverse: a lever angle that needs the cylinder longer than its maximum
    inv = Solver(m, knowns=['lever'], method=method)
    pts = m.points
    l_op = float(np.hypot(*(pts['P'] - pts['O'])))
    c = pts['C']
    # the lever angle at which |CP| = 1.45 (> max 1.4), by the cosine rule in triangle O C P
    oc = float(np.hypot(*c))
    ang_c = math.atan2(c[1], c[0])
    gamma = math.acos((oc**2 + l_op**2 - 1.45**2) / (2 * oc * l_op))
    for target in (ang_c + gamma, ang_c - gamma):
        r = inv.solve({'lever': _wrap(target)})
        if r.success:
            continue  # not this side of the ground line
        assert 'target needs' in r.reason and 'cyl' in r.reason and 'maximum' in r.reason
        assert re.search(r'by 0\.05\b', r.reason), r.reason
        # the batch refuses the row in the same words (one rule: plan.needs_beyond_limits)
        batch = inv.solve_batch({'lever': [_wrap(target)]})
        assert not batch.ok[0] and batch.reason[0] == r.reason
        break
    else:
        pytest.fail('no lever angle needing a 1.45 m cylinder was refused')


def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


# =============================================================================================
# unreachable inputs
# =============================================================================================


def _miss_in(reason):
    m = re.search(r'misses by ([0-9.eE+-]+) m', reason)
    assert m, reason
    return float(m.group(1))


def test_unreachable_four_bar_names_the_dyad_and_the_miss():
    l1, l2, l3, l4 = TRIPLE_ROCKER
    m = four_bar(*TRIPLE_ROCKER)
    s = Solver(m, method='closed_form')
    for t in (0.0, 0.3, -0.5):
        want = orc.fourbar(l1, l2, l3, l4, t, 1)
        assert not want['ok']
        r = s.solve({'crank': t})
        assert not r.success
        assert 'RRR dyad: B from circles about A (coupler) and O4 (rocker)' in r.reason
        assert _miss_in(r.reason) == pytest.approx(float(want['miss']), rel=1e-5)
        assert r.inputs == {'crank': t}
    nw = Solver(m, method='newton')
    r = nw.solve({'crank': 0.0})
    assert not r.success and r.reason


def test_unreachable_slider_crank_inverse_names_the_dyad_and_the_miss():
    m = slider_crank(1.0, 3.0, 0.5, 0.3)
    s = Solver(m, knowns=['slider'], method='closed_form')
    for x in (4.5, 10.0, -5.0):
        want = orc.slider_crank_inverse(1.0, 3.0, 0.5, 0.3, x, 1)
        assert not want['ok']
        r = s.solve({'slider': x})
        assert not r.success
        assert 'RRR dyad: A from circles about O2 (crank) and B (rod)' in r.reason
        assert _miss_in(r.reason) == pytest.approx(float(want['miss']), rel=1e-5)
        assert r.targets == {'slider': x}


def test_unreachable_five_bar_point():
    m = five_bar()
    s = Solver(m, knowns=['point:C'])
    r = s.solve({'point:C': (0.5, 5.0)})
    assert not r.success and 'RRR dyad: A from circles about O1 (left) and C' in r.reason
    lens_left = 0.6
    l_ac = math.hypot(0.5, 0.6)
    assert _miss_in(r.reason) == pytest.approx(math.hypot(0.5, 5.0) - lens_left - l_ac, rel=1e-5)


# =============================================================================================
# scene errors name the file, the key and the value
# =============================================================================================

GOOD_POINTS = """\
points:
  O2: [0.0, 0.0]
  A: [0.5, 0.866]
  B: [2.6, 1.5]
  O4: [3.0, 0.0]
"""
GOOD_LINKS = """\
links:
  ground: [O2, O4]
  crank: [O2, A]
  coupler: [A, B]
  rocker: [O4, B]
"""
GOOD_ACT = """\
actuators:
  crank: {type: angle, link: crank, pivot: O2}
"""

BROKEN_SCENES = {
    'unknown_point': (
        GOOD_POINTS + GOOD_LINKS.replace('[A, B]', '[A, Z]') + GOOD_ACT,
        ['links.coupler', "unknown point 'Z'"],
    ),
    'non_numeric': (
        GOOD_POINTS.replace('[2.6, 1.5]', '[2.6, abc]') + GOOD_LINKS + GOOD_ACT,
        ['points.B[1]', 'number', "'abc'"],
    ),
    'dof_mismatch': (
        GOOD_POINTS + GOOD_LINKS + GOOD_ACT + '  rock: {type: angle, link: rocker, pivot: O4}\n',
        ['actuators', '1 degree(s) of freedom', '2 actuator(s)', "'rock'"],
    ),
    'unknown_top_key': (
        GOOD_POINTS + GOOD_LINKS + GOOD_ACT + 'linkz: {}\n',
        ['linkz', 'unknown key'],
    ),
    'duplicate_slider': (
        """\
points: {O2: [0, 0], A: [0.3, 0.4], B: [1.5, 0], C: [1.8, 0]}
links: {ground: [O2], crank: [O2, A], rod: [A, B, C], s1: [B], s2: [C]}
sliders:
  - {name: slide, guide: ground, slider: s1, point: B, direction: 0.0}
  - {name: slide, guide: ground, slider: s2, point: C, direction: 0.0}
actuators: {crank: {type: angle, link: crank, pivot: O2}}
""",
        ['sliders.slide', 'duplicate', "'slide'"],
    ),
    'actuator_named_like_cylinder': (
        """\
points: {O: [0, 0], C: [-0.5, -0.3], P: [0.4, 0.3]}
links: {ground: [O, C], lever: [O, P]}
cylinders: {cyl: {from: C, to: P}}
actuators: {cyl: {type: angle, link: lever, pivot: O}}
""",
        ['actuators.cyl', 'duplicate', "'cyl'"],
    ),
    'four_bar_bad_length': (
        'four_bar: {ground: 4, crank: abc, coupler: 4.5, rocker: 3}\n',
        ['four_bar.crank', 'number', "'abc'"],
    ),
    'four_bar_negative_length': (
        'four_bar: {ground: 4, crank: -1.5, coupler: 4.5, rocker: 3}\n',
        ['four_bar.crank', '> 0', '-1.5'],
    ),
}


@pytest.mark.parametrize('name', sorted(BROKEN_SCENES))
def test_scene_errors_name_file_key_and_value(tmp_path, name):
    text, fragments = BROKEN_SCENES[name]
    path = tmp_path / f'{name}.yaml'
    path.write_text(text)
    with pytest.raises(SceneError) as exc:
        Scene.from_yaml(path)
    msg = str(exc.value)
    assert str(path) in msg, msg
    for f in fragments:
        assert f in msg, (f, msg)


def test_scene_error_duplicate_yaml_key_is_not_silently_dropped(tmp_path):
    """Two points named A in one mapping: YAML's last-one-wins would silently build a different
    mechanism than the file shows. The loader must refuse, naming the key."""
    text = GOOD_POINTS.replace('  B:', '  A: [0.6, 0.8]\n  B:') + GOOD_LINKS + GOOD_ACT
    path = tmp_path / 'dup.yaml'
    path.write_text(text)
    with pytest.raises(SceneError) as exc:
        Scene.from_yaml(path)
    msg = str(exc.value)
    assert str(path) in msg and 'A' in msg and 'duplicate' in msg.lower()


# ---- one command and a batch: the same answers (plan.run_one and solve_batch) -----------------

SHIPPED = scenes.SHIPPED


@pytest.mark.parametrize('scene', SHIPPED)
def test_one_command_and_batch_backends_agree(scene):
    """Solver.solve (the one-command program) and Solver.solve_batch (the batch executor):
    for every knowns set a shipped scene admits in closed form, with all outputs and pruned to
    one, they agree on success, points, joints, links and inputs to 1e-12 of the length scale,
    and both close their loops."""
    mech = Scene.from_yaml(f'config/{scene}.yaml').mechanism
    L = mech.length_scale
    rng = np.random.default_rng(7)
    checked = 0
    for knowns in scenes.knowns_sets(mech):
        for outputs in (None, list(mech.outputs)[:1]):
            try:
                s = Solver(
                    mech, knowns=knowns, outputs=outputs, method='closed_form', branch='reference'
                )
            except PlanError:
                continue
            ref = s.reference_values()
            cols = {}
            for k, v in ref.items():
                if isinstance(v, (list, tuple)):
                    cols[k] = np.asarray(v, float) + rng.normal(0, 0.05 * L, (12, 2))
                else:  # wide spread: some commands are beyond a limit or do not assemble
                    cols[k] = v + rng.normal(0, 0.6, 12)
            batch = s.solve_batch(cols)
            for i in range(12):
                cmd = {k: (c[i].tolist() if c.ndim == 2 else float(c[i])) for k, c in cols.items()}
                r = s.solve(cmd)
                assert r.success == bool(batch.ok[i]), (
                    knowns,
                    outputs,
                    cmd,
                    r.reason,
                    batch.reason[i],
                )
                if not r.success:
                    continue
                checked += 1
                assert r.residual <= TIGHT and batch.residual[i] <= TIGHT
                assert set(r.points) == set(batch.points)
                for p, xy in r.points.items():
                    assert np.max(np.abs(np.asarray(xy) - batch.points[p][i])) <= TIGHT * L, p
                for table, got in (
                    (batch.joints, r.joints),
                    (batch.links, r.links),
                    (batch.inputs, r.inputs),
                ):
                    assert set(got) == set(table)
                    for name, v in got.items():
                        d = v - table[name][i]
                        if name in mech.joint_names and name in mech.prismatics:
                            assert abs(d) <= TIGHT * L, name
                        else:  # angles: compare on the circle
                            assert abs(math.remainder(d, 2 * math.pi)) <= TIGHT, name
    assert checked >= 6, f'{scene}: too few assembling commands to compare ({checked})'


# ---- warm-started Newton over a batch of instances (Solver.solve_batch(start=)) ---------------


def _instance_paths(mech, n, steps):
    """n instances spread along a closed path through the actuator ranges, each moving one
    small step per batch: columns for steps 0..steps."""
    ref = Solver(mech, method='newton').reference_values()
    out = []
    for k in range(steps + 1):
        cols = {}
        for j, a in enumerate(mech.actuators):
            act = mech.actuators[a]
            phase = 2 * np.pi * (np.arange(n) / n) + 0.02 * k
            if act.min is None or act.max is None:
                cols[a] = ref[a] + phase
            else:
                mid, amp = 0.5 * (act.min + act.max), 0.3 * (act.max - act.min)
                cols[a] = mid + amp * np.sin(phase * (j + 1))
        out.append(cols)
    return out


@pytest.mark.parametrize('scene', ['four_bar', 'slider_crank', 'peaucellier', 'excavator'])
def test_newton_batch_of_instances_matches_the_closed_form(scene):
    """Each row is one mechanism advancing along its own path, warm-started from its previous
    answer. Oracle: the dyad plan (a different method) at the same inputs on the reference
    branch. The rows are answered mostly by the vectorised path, all close their loops."""
    mech = Scene.from_yaml(f'config/{scene}.yaml').mechanism
    L = mech.length_scale
    newton = Solver(mech, method='newton')
    closed = Solver(mech, method='closed_form', branch='reference')
    paths = _instance_paths(mech, 40, 3)
    batch = newton.solve_batch(paths[0])  # no start: the rows are solved as one path
    assert batch.ok.all() and batch.x is not None
    for cols in paths[1:]:
        batch = newton.solve_batch(cols, start=batch)
        want = closed.solve_batch(cols)
        assert batch.ok.all() and want.ok.all()
        assert np.sum(batch.careful) <= 4, np.sum(batch.careful)
        assert np.max(batch.residual) <= TIGHT
        for p in mech.points:
            assert np.max(np.abs(batch.points[p] - want.points[p])) <= AGREE * L, p
        assert np.array_equal(batch.signs, want.signs)
        for j in mech.joint_names:
            assert np.max(
                np.abs(np.remainder(batch.joints[j] - want.joints[j] + np.pi, 2 * np.pi) - np.pi)
            ) <= AGREE * max(L, 1.0), j


@pytest.mark.parametrize('scene', ['four_bar', 'slider_crank', 'peaucellier', 'excavator'])
def test_newton_batch_of_instances_one_sweep_step_each(scene):
    """The bench's case: the 200 inputs of a closed sweep as 200 instances, each warm-started
    from its answer at the input before it. Oracle: the scalar Solver walking the sweep one
    command at a time. Every row is answered by the vectorised path (none by the careful path:
    on the excavator 16 first steps from the start cut max|F| only 9.6-9.9-fold, judged now as
    the scalar path's prediction is), on the scalar answer's branch, within 1e-10 of its
    points."""
    from linkage_ros.bench import sweep_inputs

    mech = Scene.from_yaml(f'config/{scene}.yaml').mechanism
    L = mech.length_scale
    cmds = sweep_inputs(mech, 200)
    walk = Solver(mech, method='newton')
    want = [walk.solve(c) for c in cmds]
    assert all(r.success for r in want)
    newton = Solver(mech, method='newton')
    cols = {a: np.array([c[a] for c in cmds], float) for a in mech.actuators}
    start = newton.solve_batch({a: np.roll(v, 1) for a, v in cols.items()})
    batch = newton.solve_batch(cols, start=start)
    assert batch.ok.all() and batch.careful is not None and not batch.careful.any()
    assert np.max(batch.residual) <= TIGHT
    for p in mech.points:
        got = batch.points[p]
        ref = np.array([r.points[p] for r in want])
        assert np.max(np.abs(got - ref)) <= 1e-10 * L, p
    assert [batch.row(i).branch for i in range(200)] == [r.branch for r in want]


def test_newton_batch_rows_it_cannot_vouch_for_take_the_careful_path():
    """Bad rows fail with a reason and leave the others alone; a big jump (no fast-path proof)
    is solved by Solver.solve's careful path from that row's start, like the closed form; a row
    whose start failed starts from the reference pose; an input past a toggle is refused."""
    mech = four_bar(*TRIPLE_ROCKER)  # non-Grashof: the crank cannot turn fully
    newton = Solver(mech, method='newton')
    closed = Solver(mech, method='closed_form', branch='reference')
    t0 = closed.reference_values()['crank']
    start = newton.solve_batch({'crank': np.array([t0, t0 + 0.1, t0, t0 - 0.1, np.nan])})
    assert list(start.ok) == [True, True, True, True, False]
    cmd = np.array([t0 + 0.02, t0 + 0.12, np.nan, t0 + 0.9, t0 + 0.03])
    before = newton.snapshot()
    got = newton.solve_batch({'crank': cmd}, start=start)
    assert newton.snapshot() == before  # the solver's own state is untouched
    assert not got.ok[2] and 'finite' in got.reason[2]
    assert got.careful[3] and got.careful[4] and not got.careful[0] and not got.careful[1]
    want = closed.solve_batch({'crank': np.nan_to_num(cmd)})
    for i in (0, 1, 3, 4):
        assert got.ok[i] == want.ok[i], (i, got.reason[i], want.reason[i])
        if got.ok[i]:
            for p in mech.points:
                assert np.max(np.abs(got.points[p][i] - want.points[p][i])) <= AGREE * 4.0
    # crank at 0 rad: A = (3, 0) is 1 from O4 (4, 0), closer than coupler - rocker = 2.5
    far = newton.solve_batch({'crank': np.zeros(5)}, start=got)
    assert not far.ok.any(), 'a crank angle outside the input range was assembled'
    assert all(far.reason)


def test_newton_batch_start_is_checked():
    mech = four_bar(*CRANK_ROCKER)
    newton = Solver(mech, method='newton')
    t = np.linspace(0.0, 1.0, 5)
    start = newton.solve_batch({'crank': t})
    with pytest.raises(ValueError, match='5 rows'):
        newton.solve_batch({'crank': t[:3]}, start=start)
    closed = Solver(mech, method='closed_form')
    with pytest.raises(ValueError, match='newton'):
        closed.solve_batch({'crank': t}, start=start)
    with pytest.raises(ValueError, match='newton BatchResult'):
        newton.solve_batch({'crank': t}, start=closed.solve_batch({'crank': t}))


def test_newton_batch_start_must_come_from_the_same_solver_and_be_intact():
    mech = four_bar(*CRANK_ROCKER)
    newton = Solver(mech, method='newton')
    t = np.linspace(0.0, 1.0, 5)
    start = newton.solve_batch({'crank': t})
    # the same width (9 unknowns) but another mechanism: its x means something else
    other = Solver(slider_crank(0.05, 0.18, 0.01), method='newton')
    assert other.system.n == newton.system.n
    with pytest.raises(ValueError, match="mechanism \\('slider_crank'.*got one of 'four_bar'"):
        other.solve_batch({'crank': t}, start=start)
    # another four-bar geometry under the same names
    with pytest.raises(ValueError, match='reference geometry'):
        Solver(four_bar(0.3, 0.1, 0.26, 0.2), method='newton').solve_batch(
            {'crank': t}, start=start
        )
    for field, bad in (
        ('det_sign', start.det_sign[:3]),
        ('x', start.x.tolist()),
        ('ok', start.ok[:2]),
    ):
        tampered = newton.solve_batch({'crank': t})
        setattr(tampered, field, bad)
        with pytest.raises(ValueError, match='wrong shape'):
            newton.solve_batch({'crank': t}, start=tampered)
    # an intact start still works, and an empty batch is an empty result, in every mode
    assert newton.solve_batch({'crank': t}, start=start).ok.all()
    for method in ('closed_form', 'newton'):
        b = Solver(mech, method=method).solve_batch({'crank': []})
        assert b.n == 0 and b.ok.shape == (0,) and b.points['B'].shape == (0, 2)
    b = newton.solve_batch({'crank': []})
    assert newton.solve_batch({'crank': []}, start=b).n == 0


def test_batch_columns_must_hold_real_numbers():
    solver = Solver(four_bar(*CRANK_ROCKER))
    for bad, kind in (
        ([True, False], 'bool'),
        (['0.5', '1.0'], '<U3'),
        ([0.5 + 1j, 1.0], 'complex'),
        ([{}, 1.0], 'object'),
    ):
        with pytest.raises(ValueError, match=f"column 'crank' must hold real numbers.*{kind}"):
            solver.solve_batch({'crank': bad})
    with pytest.raises(ValueError, match=r"column 'crank' must have shape \(n,\)"):
        solver.solve_batch({'crank': np.zeros((3, 2))})
    pts = Solver(Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism, knowns=['point:D'])
    with pytest.raises(ValueError, match=r"column 'point:D' must have shape \(n, 2\)"):
        pts.solve_batch({'point:D': np.zeros(6)})
    assert solver.solve_batch({'crank': np.array([1, 2], dtype=np.int32)}).ok.all()


def test_command_values_of_the_wrong_type_are_refused_by_name():
    mech = Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism
    solver = Solver(mech, knowns=['point:D'])
    ref = solver.solve({'point:D': tuple(mech.points['D'])})
    assert ref.success
    for bad in (
        ['0.12', '0.18'],
        [True, False],
        (0.12 + 1j, 0.18),
        '12',
        {'x': 1, 'y': 2},
        (10**400, 0.18),
    ):
        r = solver.solve({'point:D': bad})
        assert (
            not r.success
            and r.reason.startswith('point:D: a point needs two numbers')
            or 'finite' in r.reason
        ), (bad, r.reason)
    crank = Solver(four_bar(*CRANK_ROCKER))
    for big in (10**400, -(10**400)):
        r = crank.solve({'crank': big})
        # the echo is cut to 80 characters (one rule for every echoed value)
        assert (
            not r.success and r.reason == f'crank: value must be finite (got {repr(big)[:77]}...)'
        )
    # nothing changed: the same answer as before the refusals
    again = solver.solve({'point:D': tuple(mech.points['D'])})
    assert again.points == ref.points


def test_solver_arguments_of_the_wrong_type_are_refused():
    mech = four_bar(*CRANK_ROCKER)
    with pytest.raises(PlanError, match='tolerance'):
        Solver(mech, tol=True)
    with pytest.raises(PlanError, match='max_iter'):
        Solver(mech, max_iter=True)
    with pytest.raises(PlanError, match="outputs must be a list of names \\(got 'AB'\\)"):
        Solver(mech, outputs='AB')
    for knowns in ([None], [1], 'crank'):
        with pytest.raises(PlanError, match='knowns must be a list of names'):
            Solver(mech, knowns=knowns)


def test_knowns_that_do_not_determine_the_mechanism_are_refused():
    """A point on a grounded crank gives 2 values but fixes 1 motion: with it as the only known
    of a 2-DOF mechanism another link stays free (J singular everywhere). Refused at
    construction, naming the knowns; independent knowns of the same count are fine."""
    mech = Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism
    for point in ('A', 'C'):
        with pytest.raises(
            PlanError,
            match=rf"knowns \['point:{point}'\] do not determine "
            "'plagiograph'.*leave a motion of '(\\w+)' free",
        ):
            Solver(mech, knowns=[f'point:{point}'])
    for knowns in (['point:D'], ['point:E'], ['theta_A', 'link:ABD'], None):
        Solver(mech, knowns=knowns)
    # O2-A-B-C is a parallelogram: BCE turns with crank_A, so its angle and theta_A fix one
    # motion and leave crank_C free (the sparsity pattern cannot see it; J is singular in
    # every pose). This pair used to be accepted and answered with an arbitrary crank_C.
    with pytest.raises(
        PlanError,
        match=r"knowns \['theta_A', 'link:BCE'\] do not determine.*"
        'fix the same motion',
    ):
        Solver(mech, knowns=['theta_A', 'link:BCE'])
    loader = Scene.from_yaml(CONFIG / 'front_loader.yaml').mechanism
    with pytest.raises(PlanError, match='do not determine'):
        Solver(loader, knowns=['point:A'])


def test_closure_guard_refuses_a_false_assembly(monkeypatch):
    """The last line of defence: without the structural check above, the hybrid solve placed
    the crank through a known point out of its reach (two known points) and reported success
    with its loop open by 0.126 of the length scale. The closure guard refuses it, scalar and
    batch; a point on the crank circle still solves."""
    from linkage_ros.core.newton import LoopSystem

    monkeypatch.setattr(LoopSystem, 'unfixed_links', lambda self: [])
    monkeypatch.setattr(compiling, 'check_determined', lambda c, n: None)
    mech = Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism
    solver = Solver(mech, knowns=['point:A'])
    assert solver.mode == 'hybrid'
    r = solver.solve({'point:A': (0.3, 0.1)})  # |O2 A| = 0.316, the crank is 0.25
    assert not r.success and r.reason.startswith(
        'cannot assemble: the configuration found misses loop closure by 0.126'
    )
    on = tuple(mech.points['A'])
    b = solver.solve_batch({'point:A': np.array([(0.3, 0.1), on])})
    assert b.ok.tolist() == [False, True] and b.reason[0] == r.reason
    good = solver.solve({'point:A': on})
    assert good.success and good.residual <= 1e-12
    assert math.dist(good.points['A'], on) < 1e-12


def test_adopt_and_restore_refuse_what_is_not_a_configuration():
    """adopt() returns False and restore() raises for anything unusable, and neither changes
    the solver: the next solves are those of a solver that never saw them."""
    mech = four_bar(*CRANK_ROCKER)
    clean, probed = Solver(mech, method='newton'), Solver(mech, method='newton')
    first = clean.solve({'crank': 0.4})
    assert probed.solve({'crank': 0.4}).points == first.points
    broken = []
    r = Solver(mech).solve({'crank': 0.9})
    nan_point = Result(**{**r.__dict__, 'points': {**r.points, 'B': (math.nan, 0.0)}})
    moved = Result(
        **{**r.__dict__, 'points': {**r.points, 'B': (r.points['B'][0] + 1e-3, r.points['B'][1])}}
    )
    no_point = Result(**{**r.__dict__, 'points': {k: v for k, v in r.points.items() if k != 'B'}})
    bad_angle = Result(**{**r.__dict__, 'links': {**r.links, 'coupler': 'x'}})
    broken += [nan_point, moved, no_point, bad_angle, Result(False, 'no'), None, 'xyz']
    for b in broken:
        assert probed.adopt(b) is False, b
    for snap in ('xyz', [1, 2], (None,)):
        with pytest.raises(ValueError, match='restore'):
            probed.restore(snap)
    assert probed.adopt(r)  # a real configuration is adopted
    clean.adopt(r)
    for t in (1.0, 1.2, 1.5):
        assert probed.solve({'crank': t}).points == clean.solve({'crank': t}).points
