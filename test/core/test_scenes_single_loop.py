"""The shipped single-loop scenes (and the examples in docs/SCENES.md) against exact oracles.

Oracles are independent of the solver: each scene's dimensions are read from its reference pose
(the "tracing paper") and every expected value is written out here from elementary geometry --
Thales' circle for the Scott-Russell straight line, tangency of the crank circle for the
quick-return stroke and time ratio, the seed's circle construction for the non-Grashof
inverted slider-crank, triangle closure for the four-bar and the slider-crank, and plain rigid
motions for link rigidity, slide lines and joint values.
"""

import copy
import math
import re

import numpy as np
import pytest
import yaml
from scenes import CONFIG, load
from scenes import REPO as ROOT
from scenes import raw as load_raw

from linkage_ros.core.model import AngleActuator, Scene
from linkage_ros.core.solver import Solver

DOCS = ROOT / 'docs' / 'SCENES.md'
SCENES = [
    'four_bar',
    'slider_crank',
    'inverted_slider_crank',
    'inverted_slider_crank_oscillating',
    'quick_return',
    'scott_russell',
]
TIGHT = 1e-12  # closed-form accuracy, fraction of the length scale
AGREE = 1e-9  # closed form vs Newton, fraction of the length scale
N_SWEEP = 121


def without_limits(stem):
    """The scene with its crank limits removed (to probe the true motion range)."""
    data = copy.deepcopy(load_raw(stem))
    for spec in data['actuators'].values():
        spec.pop('min', None)
        spec.pop('max', None)
    return Scene.from_dict(data, source=stem).mechanism


def dist(p, q):
    return math.hypot(q[0] - p[0], q[1] - p[1])


def direction(p, q):
    return math.atan2(q[1] - p[1], q[0] - p[0])


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def rot(v, a):
    c, s = math.cos(a), math.sin(a)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])


def reference_input(mech):
    """The crank angle of the reference pose: the direction pivot -> toward of the actuator."""
    act = mech.actuators['crank']
    return direction(mech.points[act.pivot], mech.points[act.toward])


def sweep_values(mech):
    """A sweep of the crank over its range: the limits if given, else a full turn from the
    reference pose (so continuity starts in the reference assembly mode)."""
    act = mech.actuators['crank']
    if act.min is not None and act.max is not None:
        return np.linspace(act.min, act.max, N_SWEEP)
    return reference_input(mech) + np.linspace(0.0, 2 * math.pi, N_SWEEP)


def link_rotation(mech, res, link):
    """Rotation of a link since the reference pose, from its solved points (a one-point link:
    from its reported angle, which for such a link is its rotation)."""
    pts = mech.links[link].points
    if len(pts) >= 2:
        p, q = pts[0], pts[1]
        return wrap(
            direction(res.points[p], res.points[q]) - direction(mech.points[p], mech.points[q])
        )
    if link == mech.ground:
        return 0.0
    return res.links[link]


def to_world(mech, res, link, xy_ref):
    """Where the reference-pose position xy_ref, rigidly attached to ``link``, is now."""
    anchor = mech.links[link].points[0]
    a = link_rotation(mech, res, link)
    d = rot((xy_ref[0] - mech.points[anchor][0], xy_ref[1] - mech.points[anchor][1]), a)
    return (res.points[anchor][0] + d[0], res.points[anchor][1] + d[1])


def sweep(solver, values):
    out = []
    for v in values:
        r = solver.solve({'crank': float(v)})
        assert r.success, f'{solver.mech.name}: crank {v} failed: {r.reason}'
        out.append(r)
    return out


# ---- loading and plans -----------------------------------------------------------------------


@pytest.mark.parametrize('stem', SCENES)
def test_scene_loads_with_one_crank_and_a_complete_closed_form_plan(stem):
    mech = load(stem)
    assert mech.name == stem
    assert mech.frame_id == 'base_link'
    assert mech.dof == 1
    assert list(mech.actuators) == ['crank']
    solver = Solver(mech, method='closed_form')
    assert solver.plan.complete and not solver.plan.missing
    assert Solver(mech).mode == 'closed_form'
    steps = solver.plan.describe()
    assert steps[0].startswith('ground')
    # every moving link is placed by the plan
    assert set(solver.plan.placed_links) == set(mech.links)
    assert len(solver.plan.branch_steps) >= 1


def test_shortcut_scenes_generate_the_documented_links():
    fb = load('four_bar')
    assert {n: list(l.points) for n, l in fb.links.items()} == {
        'ground': ['O2', 'O4'],
        'crank': ['O2', 'A'],
        'coupler': ['A', 'B', 'P'],
        'rocker': ['O4', 'B'],
    }
    assert fb.outputs == ('P',)
    sc = load('slider_crank')
    assert {n: list(l.points) for n, l in sc.links.items()} == {
        'ground': ['O2'],
        'crank': ['O2', 'A'],
        'rod': ['A', 'B'],
        'slider': ['B'],
    }
    assert list(sc.prismatics) == ['slider']
    assert sc.prismatics['slider'].guide == 'ground'


def test_scene_dimensions_match_their_comments():
    """The stated dimensions (the comments and the oracles below rely on them)."""
    fb = load('four_bar').points
    assert dist(fb['O2'], fb['O4']) == pytest.approx(0.30, abs=1e-15)
    assert dist(fb['O2'], fb['A']) == pytest.approx(0.10, abs=1e-15)
    assert dist(fb['A'], fb['B']) == pytest.approx(0.25, abs=1e-15)
    assert dist(fb['O4'], fb['B']) == pytest.approx(0.20, abs=1e-15)
    qr = load('quick_return').points
    assert dist(qr['O2'], qr['O4']) == pytest.approx(0.30, abs=1e-15)
    assert dist(qr['O2'], qr['A']) == pytest.approx(0.10, abs=1e-15)
    assert dist(qr['O4'], qr['B']) == pytest.approx(0.50, abs=1e-15)
    assert dist(qr['B'], qr['C']) == pytest.approx(0.25, abs=1e-15)
    sr = load('scott_russell').points
    for p, q in (('O2', 'A'), ('A', 'B'), ('A', 'C')):
        assert dist(sr[p], sr[q]) == pytest.approx(0.15, abs=1e-15)
    for stem, (l1, l2, e) in {
        'inverted_slider_crank': (0.40, 0.10, 0.14),
        'inverted_slider_crank_oscillating': (0.30, 0.20, 0.14),
    }.items():
        m = load(stem)
        p = m.points
        assert dist(p['O2'], p['O4']) == pytest.approx(l1, abs=1e-15)
        assert dist(p['O2'], p['A']) == pytest.approx(l2, abs=1e-15)
        assert slide_offset(m) == pytest.approx(e, abs=1e-15)
        # the rocker point F is the foot of the perpendicular from O4 on the slide line
        u = m.prismatics['slide'].direction
        assert abs(cross(u, (p['A'][0] - p['F'][0], p['A'][1] - p['F'][1]))) < 1e-15
    grashof = load('inverted_slider_crank').points
    oscil = load('inverted_slider_crank_oscillating').points
    assert dist(grashof['O2'], grashof['A']) + 0.14 < dist(grashof['O2'], grashof['O4'])
    assert dist(oscil['O2'], oscil['A']) + 0.14 > dist(oscil['O2'], oscil['O4'])


# ---- every scene: rigidity, closure, joint semantics, closed form vs Newton -----------------


def check_configuration(mech, res):
    """Independent checks of one solved configuration; returns the worst error (m)."""
    worst = 0.0
    pts = res.points
    assert set(pts) >= set(mech.points)
    for name, link in mech.links.items():
        # rigidity: every distance between two points of the link is its reference distance
        for i, p in enumerate(link.points):
            for q in link.points[i + 1 :]:
                worst = max(worst, abs(dist(pts[p], pts[q]) - dist(mech.points[p], mech.points[q])))
        # reported angle = direction first -> second point
        if len(link.points) >= 2:
            assert (
                abs(wrap(res.links[name] - direction(pts[link.points[0]], pts[link.points[1]])))
                < 1e-12
            )
    for p in mech.links[mech.ground].points:  # the ground does not move
        worst = max(worst, dist(pts[p], mech.points[p]))
    for rj in mech.revolutes:  # joint value = child angle - parent angle
        expect = wrap(res.links[rj.child] - res.links[rj.parent])
        assert abs(wrap(res.joints[rj.name] - expect)) < 1e-12, rj.name
    for pj in mech.prismatics.values():
        # the slider point is on the guide's line, the slider keeps its orientation relative
        # to the guide, and the joint value is the distance from the origin along the line
        a = link_rotation(mech, res, pj.guide)
        u = rot(pj.direction, a)
        on_line = to_world(mech, res, pj.guide, mech.points[pj.point])
        x = pts[pj.point]
        worst = max(worst, abs(cross(u, (x[0] - on_line[0], x[1] - on_line[1]))))
        turn = wrap(link_rotation(mech, res, pj.slider) - a)
        worst = max(worst, abs(turn) * mech.length_scale)
        o = to_world(mech, res, pj.guide, pj.origin)
        value = (x[0] - o[0]) * u[0] + (x[1] - o[1]) * u[1]
        worst = max(worst, abs(value - res.joints[pj.name]))
    return worst


@pytest.mark.parametrize('stem', SCENES)
def test_sweep_keeps_links_rigid_and_loops_closed(stem):
    mech = load(stem)
    values = sweep_values(mech)
    for v, res in zip(values, sweep(Solver(mech, branch='continuous'), values)):
        assert res.solver == 'closed_form'
        assert res.residual <= TIGHT, (v, res.residual)
        assert check_configuration(mech, res) <= TIGHT * mech.length_scale, v
        assert res.inputs['crank'] == pytest.approx(float(v), abs=0.0)


@pytest.mark.parametrize('stem', SCENES)
def test_closed_form_and_newton_agree_over_the_sweep(stem):
    mech = load(stem)
    values = sweep_values(mech)
    closed = sweep(Solver(mech, method='closed_form', branch='continuous'), values)
    newton = sweep(Solver(mech, method='newton', branch='continuous'), values)
    for v, rc, rn in zip(values, closed, newton):
        assert rn.solver == 'newton'
        assert rn.residual <= TIGHT, (v, rn.residual)
        gap = max(dist(rc.points[p], rn.points[p]) for p in mech.points)
        assert gap <= AGREE * mech.length_scale, (v, gap)
        assert check_configuration(mech, rn) <= AGREE * mech.length_scale


# ---- four-bar and slider-crank: triangle closure written out ---------------------------------


def test_four_bar_matches_the_circle_intersection():
    raw = load_raw('four_bar')['four_bar']
    l1, l2, l3, l4 = raw['ground'], raw['crank'], raw['coupler'], raw['rocker']
    cp = raw['coupler_point']
    mech = load('four_bar')
    values = sweep_values(mech)
    o4 = (l1 * math.cos(raw['ground_angle']), l1 * math.sin(raw['ground_angle']))
    for v, res in zip(values, sweep(Solver(mech), values)):
        a = (l2 * math.cos(v), l2 * math.sin(v))
        d = dist(a, o4)
        u = ((o4[0] - a[0]) / d, (o4[1] - a[1]) / d)
        along = (d * d + l3 * l3 - l4 * l4) / (2 * d)
        h = math.sqrt(l3 * l3 - along * along)  # branch +1: left of A -> O4
        b = (a[0] + along * u[0] - h * u[1], a[1] + along * u[1] + h * u[0])
        t3 = direction(a, b)
        p = (
            a[0] + cp['distance'] * math.cos(t3 + cp['angle']),
            a[1] + cp['distance'] * math.sin(t3 + cp['angle']),
        )
        for name, expect in (('A', a), ('B', b), ('P', p)):
            assert dist(res.points[name], expect) <= TIGHT * l1, (v, name)
        assert res.links['crank'] == pytest.approx(wrap(v), abs=1e-12)
        assert res.joints['O2'] == pytest.approx(wrap(v), abs=1e-12)  # ground axis is +x


def test_slider_crank_matches_the_offset_slider_formula():
    raw = load_raw('slider_crank')['slider_crank']
    r, l, e = raw['crank'], raw['rod'], raw['offset']
    mech = load('slider_crank')
    values = sweep_values(mech)
    for v, res in zip(values, sweep(Solver(mech), values)):
        x = r * math.cos(v) + math.sqrt(l * l - (r * math.sin(v) - e) ** 2)
        assert dist(res.points['B'], (x, e)) <= TIGHT * l, v
        assert res.joints['slider'] == pytest.approx(x, abs=TIGHT * l)
    # stroke between the dead centres: sqrt((l + r)^2 - e^2) - sqrt((l - r)^2 - e^2)
    batch = Solver(mech, branch='reference').solve_batch(
        {'crank': np.linspace(0, 2 * math.pi, 20001)}
    )
    assert batch.ok.all()
    stroke = np.ptp(batch.points['B'][:, 0])
    expect = math.sqrt((l + r) ** 2 - e * e) - math.sqrt((l - r) ** 2 - e * e)
    assert stroke == pytest.approx(expect, abs=1e-8)  # sampling error ~ 1e-9


# ---- inverted slider-cranks --------------------------------------------------------------------


def slide_offset(mech):
    """e: the perpendicular distance from O4 to the slide line through A (reference pose)."""
    u = mech.prismatics['slide'].direction
    a, o4 = mech.points['A'], mech.points['O4']
    return abs(cross(u, (a[0] - o4[0], a[1] - o4[1])))


@pytest.mark.parametrize('stem', ['inverted_slider_crank', 'inverted_slider_crank_oscillating'])
def test_inverted_slider_crank_line_is_tangent_to_the_offset_circle(stem):
    """The slide line through A stays at distance e from O4 (tangent to the circle (O4, e)):
    F is the tangent point, |FA| = sqrt(|O4A|^2 - e^2) is the slide value."""
    mech = load(stem)
    e = slide_offset(mech)
    o4 = mech.points['O4']
    values = sweep_values(mech)
    for _v, res in zip(values, sweep(Solver(mech), values)):
        a, f = res.points['A'], res.points['F']
        assert dist(o4, f) == pytest.approx(e, abs=TIGHT * mech.length_scale)
        fa = (a[0] - f[0], a[1] - f[1])
        o4f = (f[0] - o4[0], f[1] - o4[1])
        assert abs(fa[0] * o4f[0] + fa[1] * o4f[1]) <= TIGHT * mech.length_scale**2
        rho = dist(o4, a)
        assert res.joints['slide'] == pytest.approx(
            math.sqrt(rho * rho - e * e), abs=1e-11 * mech.length_scale
        )


def test_grashof_inverted_slider_crank_turns_fully_and_rocker_oscillates():
    mech = load('inverted_slider_crank')
    theta = np.linspace(-math.pi, math.pi, 3601)
    batch = Solver(mech, branch='reference').solve_batch({'crank': theta})
    assert batch.ok.all()
    rocker = np.unwrap(batch.links['rocker'])
    assert np.ptp(rocker) < math.pi  # the rocker only oscillates
    assert abs(rocker[-1] - rocker[0]) < 1e-12


def boundary(solver, inside, outside, tol=1e-13):
    """Bisect between a crank angle that solves and one that does not."""
    while abs(outside - inside) > tol:
        mid = 0.5 * (inside + outside)
        if solver.solve({'crank': mid}, commit=False).success:
            inside = mid
        else:
            outside = mid
    return inside


def test_non_grashof_crank_range_matches_the_tangent_construction():
    """Seed 003 example 5: the crank's extreme positions are where A reaches the circle of
    radius e about O4 (the points A''' and A'''' of the lecture): there the slide line through A
    is tangent to that circle at A itself and link 4 and 'link 3 to B at infinity' are
    collinear. Computed here as the intersections of the circles (O2, lmin) and (O4, e)."""
    mech = without_limits('inverted_slider_crank_oscillating')
    o2, o4, a_ref = mech.points['O2'], mech.points['O4'], mech.points['A']
    lmax, lmin, e = dist(o2, o4), dist(o2, a_ref), slide_offset(mech)
    assert lmin + e > lmax  # non-Grashof
    # circle-circle intersection, written out
    along = (lmax * lmax + lmin * lmin - e * e) / (2 * lmax)
    h = math.sqrt(lmin * lmin - along * along)
    g = direction(o2, o4)
    ends = sorted(
        [(g + math.atan2(h, along)) % (2 * math.pi), (g - math.atan2(h, along)) % (2 * math.pi)]
    )
    for end in ends:  # |O4A| = e exactly there
        a = (o2[0] + lmin * math.cos(end), o2[1] + lmin * math.sin(end))
        assert dist(o4, a) == pytest.approx(e, abs=1e-15)

    # brute force: where does the solver assemble over a full turn?
    solver = Solver(mech, branch='reference')
    theta = np.linspace(0.0, 2 * math.pi, 7201)
    ok = solver.solve_batch({'crank': theta}).ok
    inside = np.flatnonzero(ok)
    assert inside.size and not ok[0] and not ok[-1]
    assert np.all(np.diff(inside) == 1)  # one contiguous arc
    lo = boundary(solver, theta[inside[0]], theta[inside[0] - 1])
    hi = boundary(solver, theta[inside[-1]], theta[inside[-1] + 1])
    assert lo == pytest.approx(ends[0], abs=1e-9)
    assert hi == pytest.approx(ends[1], abs=1e-9)
    assert ends == pytest.approx([math.acos(0.92), 2 * math.pi - math.acos(0.92)], abs=1e-12)

    # the shipped limits sit a little inside that range
    act = load('inverted_slider_crank_oscillating').actuators['crank']
    assert ends[0] < act.min < ends[0] + 0.02
    assert ends[1] - 0.02 < act.max < ends[1]
    # and the shipped scene refuses a command beyond them
    limited = Solver(load('inverted_slider_crank_oscillating'))
    assert not limited.solve({'crank': 0.5 * (ends[0] + act.min)}).success
    assert limited.solve({'crank': act.min + 1e-6}).success


# ---- quick-return ----------------------------------------------------------------------------


def tool_x(solver, theta):
    batch = solver.solve_batch({'crank': np.atleast_1d(np.asarray(theta, float))})
    assert batch.ok.all()
    return batch.points['C'][:, 0]


def refine_extreme(solver, theta0, step, sense, h=1e-5):
    """Bisect on the sign of the tool's central-difference slope around a sampled extreme
    (sense +1: maximum, -1: minimum) until the bracket is 1e-13 rad wide."""

    def slope(t):
        xm, xp = tool_x(solver, [t - h, t + h])
        return sense * (xp - xm)  # > 0 before the extreme, < 0 after

    lo, hi = theta0 - step, theta0 + step
    assert slope(lo) > 0 > slope(hi)
    while hi - lo > 1e-13:
        mid = 0.5 * (lo + hi)
        if slope(mid) > 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def test_quick_return_stroke_and_time_ratio():
    """Lever O4B swings between the two positions where it is tangent to the crank circle
    (O2A perpendicular to O4A): +-beta about O4O2 with sin(beta) = r / d. With the tool line
    y = h above O4 and phi the lever angle from O4O2, the tool is at
        x(phi) = L sin(phi) + sqrt(l5^2 - (h - L cos(phi))^2)
    which increases with phi over [-beta, beta], and the square root is even in phi, so
        stroke = x(beta) - x(-beta) = 2 L sin(beta) = 2 L r / d.
    The extremes occur at the crank angles -beta (tool furthest +x) and pi + beta (furthest
    -x) measured from +x, so with the crank turning counter-clockwise the stroke towards -x
    (A passing over the top) takes pi + 2 beta and the return pi - 2 beta."""
    mech = load('quick_return')
    p = mech.points
    r, d, L = dist(p['O2'], p['A']), dist(p['O2'], p['O4']), dist(p['O4'], p['B'])
    beta = math.asin(r / d)
    solver = Solver(mech, branch='reference')
    theta = np.linspace(-math.pi, math.pi, 7201)
    x = tool_x(solver, theta)
    step = theta[1] - theta[0]
    t_max = refine_extreme(solver, theta[np.argmax(x)], step, +1)
    t_min = refine_extreme(solver, theta[np.argmin(x)], step, -1)
    stroke = tool_x(solver, t_max)[0] - tool_x(solver, t_min)[0]
    assert stroke == pytest.approx(2 * L * r / d, abs=1e-9)
    assert stroke == pytest.approx(1 / 3, abs=1e-9)
    assert t_max == pytest.approx(-beta, abs=1e-9)
    assert t_min % (2 * math.pi) == pytest.approx(math.pi + beta, abs=1e-9)
    forward = (t_min - t_max) % (2 * math.pi)  # tool moving -x, crank counter-clockwise
    ret = 2 * math.pi - forward
    assert forward / ret == pytest.approx((math.pi + 2 * beta) / (math.pi - 2 * beta), abs=1e-9)
    # the slot value is |O4A| = sqrt(d^2 + r^2 + 2 d r sin(theta2)) (O2 straight above O4)
    batch = solver.solve_batch({'crank': theta})
    assert np.allclose(
        batch.joints['slot'], np.sqrt(d * d + r * r + 2 * d * r * np.sin(theta)), rtol=0, atol=1e-12
    )
    # the tool runs on the ground line y = 0.57 and its slide value is x(C) - x(D)
    assert np.allclose(batch.points['C'][:, 1], p['D'][1], rtol=0, atol=1e-12)
    assert np.allclose(batch.joints['ram'], batch.points['C'][:, 0] - p['D'][0], rtol=0, atol=1e-12)


# ---- Scott-Russell -----------------------------------------------------------------------------


def test_scott_russell_traces_the_vertical_through_o2():
    """O2A = AB = AC = a and A is the midpoint of BC, so B, O2, C lie on Thales' circle about A:
    with B on the horizontal through O2, C is on the vertical through O2 and
    |O2C| = 2 a |sin(theta2)|, |O2B| = 2 a cos(theta2)."""
    mech = without_limits('scott_russell')
    o2 = mech.points['O2']
    a = dist(o2, mech.points['A'])
    scale = mech.length_scale
    solver = Solver(mech, branch='reference')
    theta = np.linspace(-math.pi / 2, math.pi / 2, 1001)[1:-1]
    for t in theta:
        res = solver.solve({'crank': float(t)})
        assert res.success, (t, res.reason)
        b, c = res.points['B'], res.points['C']
        assert abs(c[0] - o2[0]) <= TIGHT * scale, t
        assert abs(b[1] - o2[1]) <= TIGHT * scale, t
        assert abs(dist(o2, c) - 2 * a * abs(math.sin(t))) <= TIGHT * scale, t
        assert abs((c[1] - o2[1]) - 2 * a * math.sin(t)) <= TIGHT * scale, t
        assert abs((b[0] - o2[0]) - 2 * a * math.cos(t)) <= TIGHT * scale, t
        assert abs(res.joints['slider'] - 2 * a * math.cos(t)) <= TIGHT * scale, t
    # the shipped scene (limits +-1.45 rad) solves across its whole range on the same line
    shipped = load('scott_russell')
    batch = Solver(shipped, branch='reference').solve_batch(
        {'crank': np.linspace(-1.45, 1.45, 301)}
    )
    assert batch.ok.all()
    assert np.max(np.abs(batch.points['C'][:, 0] - o2[0])) <= TIGHT * scale


# ---- docs/SCENES.md ----------------------------------------------------------------------------


def doc_text():
    return DOCS.read_text(encoding='utf-8')


def yaml_blocks(text):
    return re.findall(r'^```yaml\n(.*?)^```', text, flags=re.S | re.M)


def test_every_yaml_example_in_the_scene_doc_loads():
    blocks = yaml_blocks(doc_text())
    assert len(blocks) >= 4
    forms = set()
    for block in blocks:
        data = yaml.safe_load(block)
        mech = Scene.from_dict(data, source='docs/SCENES.md').mechanism
        forms.add(mech.form)
        if 'cylinders' in data:
            forms.add('cylinder')
        if data.get('sliders'):
            forms.add('slider')
        forms |= {k for k in ('dimensions', 'slots', 'distances') if k in data}
        for name, value in mech.stated.items():  # stated dimensions are the ones in use
            dim = name.split('.')
            if dim[1] != 'offset':
                p, q = dim[1].split('-')
                assert abs(float(np.hypot(*(mech.points[p] - mech.points[q]))) - value) <= (
                    1e-14 * mech.length_scale
                )
        assert Solver(mech).solve({a: reference_value(mech, a) for a in mech.actuators}).success
    assert {'four_bar', 'slider_crank', 'general', 'slider', 'cylinder'} <= forms
    assert {'dimensions', 'slots', 'distances'} <= forms


def reference_value(mech, actuator):
    """An actuator's value in the reference pose, from the reference points."""
    act = mech.actuators[actuator]
    if isinstance(act, AngleActuator):
        return direction(mech.points[act.pivot], mech.points[act.toward])
    pj = mech.prismatics[act.joint]
    x = mech.points[pj.point]
    return (x[0] - pj.origin[0]) * pj.direction[0] + (x[1] - pj.origin[1]) * pj.direction[1]


def scene_table(text):
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if line.startswith('|') and len(cells) == 5 and cells[0].endswith('.yaml'):
            rows[cells[0]] = cells
    return rows


def test_scene_table_lists_every_shipped_scene_and_matches_it():
    rows = scene_table(doc_text())
    for name in (
        'peaucellier.yaml',
        'hart.yaml',
        'plagiograph.yaml',
        'front_loader.yaml',
        'excavator.yaml',
    ):
        assert name in rows
    for path in sorted(CONFIG.glob('*.yaml')):
        with open(path, encoding='utf-8') as fh:
            data = yaml.safe_load(fh)
        if isinstance(data, dict) and {'four_bar', 'slider_crank', 'points'} & set(data):
            assert path.name in rows, f'{path.name} is missing from the table in docs/SCENES.md'
    for stem in SCENES:
        mech = load(stem)
        _, _, dof, actuators, outputs = rows[f'{stem}.yaml']
        assert int(dof) == mech.dof
        assert [a.strip() for a in actuators.split(',')] == list(mech.actuators)
        listed = [] if outputs == '(none)' else [o.strip() for o in outputs.split(',')]
        assert listed == list(mech.outputs)
