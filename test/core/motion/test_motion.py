"""Tests of linkage_ros.core.motion (ranges, toggles, oscillation, regions, tilt), CLI and plots.

Every number is checked against an oracle written here and independent of the solver: the
cosine rule for four-bar toggle angles, the seed's circle intersections and common tangents for
the non-Grashof 3R-1P chain, and hand-written triangle kinematics of two hydraulic fixtures swept
by brute force (grid of throws, scan of the bin angle with bisection).
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scenes import CONFIG, load
from scenes import four_bar as fourbar

from linkage_ros.core import motion
from linkage_ros.core.model import Scene
from linkage_ros.core.plan import spec_for
from linkage_ros.core.quantities import AngleSpec, PointSpec, SlideSpec
from linkage_ros.core.solver import Solver

TWO_PI = 2 * math.pi


def circ(a, b):
    """Distance between two angles on the circle."""
    d = (a - b) % TWO_PI
    return min(d, TWO_PI - d)


def rot(v, a):
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def ang(v):
    return math.atan2(v[1], v[0])


def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def circle_meet(c1, r1, c2, r2, side):
    """Intersection of two circles on the given side of c1 -> c2 (+1 left), or None."""
    d = np.asarray(c2, float) - np.asarray(c1, float)
    L = math.hypot(*d)
    if L == 0 or r1 + r2 < L or abs(r1 - r2) > L:
        return None
    a = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    u = d / L
    return np.asarray(c1, float) + a * u + side * h * np.array([-u[1], u[0]])


def crank_range_oracle(l1, l2, l3, l4):
    """Cosine rule: the crank assembles while |l3 - l4| <= |A - O4| <= l3 + l4 with
    |A - O4|^2 = l1^2 + l2^2 - 2 l1 l2 cos(theta2). Returns the boundary angles in [0, pi]."""
    out = {}
    for name, D in (('extended', l3 + l4), ('folded', abs(l3 - l4))):
        c = (l1 * l1 + l2 * l2 - D * D) / (2 * l1 * l2)
        if -1 < c < 1:
            out[name] = math.acos(c)
    return out


# ---- four-bar input ranges -----------------------------------------------------------------------


def test_grashof_double_rocker_input_range_is_the_toggle_pair():
    l1, l2, l3, l4 = 0.4, 0.35, 0.1, 0.3  # coupler shortest: both toggles bind
    mech = fourbar(l1, l2, l3, l4, input=1.0)
    lo, hi = motion.input_ranges(mech)['crank']
    o = crank_range_oracle(l1, l2, l3, l4)
    # |A - O4| grows with theta2 on [0, pi]: folded (|l3 - l4|) first, extended (l3 + l4) last
    assert abs(lo - o['folded']) < 1e-9 and abs(hi - o['extended']) < 1e-9
    info = motion.actuator_range(mech, 'crank')
    assert info['min_source'] == info['max_source'] == 'toggle'
    tog = motion.toggle_positions(mech, 'crank')
    assert len(tog) == 2 and abs(tog[0] - lo) < 1e-9 and abs(tog[1] - hi) < 1e-9
    # each bound assembles (a forward solve succeeds) and a hair beyond does not
    s = Solver(mech)
    for v, d in ((lo, -1), (hi, 1)):
        assert s.solve({'crank': v}).success
        assert not s.solve({'crank': v + d * 1e-7}).success


@pytest.mark.parametrize(
    'l1,l2,l3,l4,ground_angle',
    [
        (0.5, 0.3, 0.35, 0.25, 0.0),  # extended toggles bind: range symmetric about 0
        (0.5, 0.3, 0.35, 0.25, 0.7),  # same, ground line turned by 0.7 rad
        (0.3, 0.25, 0.5, 0.12, 0.0),  # folded toggles bind: range symmetric about pi
    ],
)
def test_triple_rocker_input_range_matches_cosine_rule(l1, l2, l3, l4, ground_angle):
    s, p, q, lng = sorted((l1, l2, l3, l4))
    assert s + lng > p + q  # non-Grashof
    mech = fourbar(l1, l2, l3, l4, ground_angle=ground_angle)
    lo, hi = motion.input_ranges(mech)['crank']
    o = crank_range_oracle(l1, l2, l3, l4)
    assert lo < hi
    if 'extended' in o and 'folded' not in o:
        b = o['extended']
        exp = (ground_angle - b, ground_angle + b)
    else:
        a = o['folded']
        exp = (ground_angle + a, ground_angle + TWO_PI - a)  # contains pi: max > pi
        assert hi > math.pi
    assert abs(lo - exp[0]) < 1e-9 and abs(hi - exp[1]) < 1e-9
    # both assembly modes meet at the two toggles: the motion covers both (one circuit)
    assert sorted(motion.toggle_positions(mech, 'crank')) == pytest.approx(list(exp), abs=1e-9)


def test_crank_rocker_turns_fully_and_limits_are_intersected():
    mech = fourbar(0.4, 0.1, 0.35, 0.3)
    assert motion.input_ranges(mech) == {'crank': (None, None)}
    assert motion.toggle_positions(mech, 'crank') == []
    # limits inside a full turn are the range
    lim = fourbar(0.4, 0.1, 0.35, 0.3, crank_limits={'min': -0.5, 'max': 2.0})
    assert motion.input_ranges(lim)['crank'] == (-0.5, 2.0)
    # a triple-rocker with a limit inside its toggle range: one side limit, one side toggle
    l1, l2, l3, l4 = 0.5, 0.3, 0.35, 0.25
    b = crank_range_oracle(l1, l2, l3, l4)['extended']
    mech = fourbar(l1, l2, l3, l4, input=0.2, crank_limits={'min': -1.0, 'max': 3.0})
    info = motion.actuator_range(mech, 'crank')
    assert (info['min'], info['min_source']) == (-1.0, 'limit')
    assert abs(info['max'] - b) < 1e-9 and info['max_source'] == 'toggle'


def test_slider_driven_slider_crank_range_is_the_extended_and_folded_rod():
    r, l, e = 0.1, 0.3, 0.04  # crank, rod, offset; the slider is the input
    A = [r * math.cos(1.0), r * math.sin(1.0)]
    xB = A[0] + math.sqrt(l * l - (e - A[1]) ** 2)
    text = f"""
points: {{O2: [0, 0], A: [{A[0]!r}, {A[1]!r}], B: [{xB!r}, {e!r}]}}
links: {{ground: [O2], crank: [O2, A], rod: [A, B], slider: [B]}}
sliders: [{{name: s, guide: ground, slider: slider, point: B, direction: 0.0, origin: [0, {e!r}]}}]
actuators: {{s: {{type: slide, joint: s}}}}
"""
    mech = Scene.from_dict(yaml.safe_load(text)).mechanism
    info = motion.actuator_range(mech, 's')
    # B = (x, e) needs l - r <= |B - O2| <= l + r (rod and crank folded / extended)
    exp = (math.sqrt((l - r) ** 2 - e * e), math.sqrt((l + r) ** 2 - e * e))
    assert abs(info['min'] - exp[0]) < 1e-12 * mech.length_scale * 10
    assert abs(info['max'] - exp[1]) < 1e-12 * mech.length_scale * 10
    assert info['min_source'] == info['max_source'] == 'toggle'
    assert motion.toggle_positions(mech, 's') == pytest.approx(list(exp), abs=1e-11)


# ---- non-Grashof 3R-1P (seed 003 example 5) ------------------------------------------------------

LMAX, LMIN, E = 0.5, 0.35, 0.25  # lmin + e = 0.6 > lmax: non-Grashof


def _rpr_fixture():
    O4 = np.array([LMAX, 0.0])
    A = np.array([-LMIN, 0.0])  # crank at 180 degrees
    # F: foot of the perpendicular from O4 on the slide line through A (tangent point from A
    # to the offset circle (O4, e)), the one above the ground line
    w = A - O4
    d = math.hypot(*w)
    beta = math.asin(E / d)
    F = O4 + E * np.array(
        [math.cos(ang(w) - (math.pi / 2 - beta)), math.sin(ang(w) - (math.pi / 2 - beta))]
    )
    assert abs(np.dot(A - F, F - O4)) < 1e-15 and F[1] > 0
    u = (A - F) / math.hypot(*(A - F))
    A, F, u = ([float(v) for v in x] for x in (A, F, u))
    return f"""
name: rpr_nongrashof
points: {{O2: [0, 0], O4: [{LMAX!r}, 0], A: [{A[0]!r}, {A[1]!r}], F: [{F[0]!r}, {F[1]!r}]}}
links: {{ground: [O2, O4], crank: [O2, A], block: [A], rocker: [O4, F]}}
sliders:
  - {{name: slide, guide: rocker, slider: block, point: A, direction: [{u[0]!r}, {u[1]!r}],
      origin: F}}
actuators:
  crank: {{type: angle, link: crank, pivot: O2, toward: A}}
"""


def test_nongrashof_rpr_crank_range_is_the_seed_circle_intersection():
    mech = Scene.from_dict(yaml.safe_load(_rpr_fixture())).mechanism
    # seed: the extreme positions of link 2 are where the crank circle (O2, lmin) meets the
    # offset circle (O4, e): A''' and A''''
    Aup = circle_meet([0, 0], LMIN, [LMAX, 0], E, 1)
    Adn = circle_meet([0, 0], LMIN, [LMAX, 0], E, -1)
    a = ang(Aup)
    lo, hi = motion.input_ranges(mech)['crank']
    assert abs(lo - a) < 1e-9 and abs(hi - (ang(Adn) + TWO_PI)) < 1e-9
    assert hi > math.pi  # the range spans theta2 = pi


def test_nongrashof_rpr_rocker_oscillation_is_the_seed_common_tangent():
    mech = Scene.from_dict(yaml.safe_load(_rpr_fixture())).mechanism
    # seed: link 4 is at an extreme when the slide line is a common tangent of the crank circle
    # (O2, lmin) and the offset circle (O4, e). The circles overlap (lmin + e > lmax), so there
    # are exactly two common tangents, both external: n . x = c with n . O2 - c = lmin and
    # n . O4 - c = e, i.e. n . (O4 - O2) = e - lmin.
    O2, O4 = np.zeros(2), np.array([LMAX, 0.0])
    extremes = []
    for s in (1, -1):
        phi = ang(O4 - O2) + s * math.acos((E - LMIN) / LMAX)
        n = np.array([math.cos(phi), math.sin(phi)])
        c = float(n @ O2) - LMIN
        T1, T2 = O2 - LMIN * n, O4 - E * n  # the two tangency points
        assert abs(n @ T1 - c) < 1e-15 and abs(n @ T2 - c) < 1e-15
        extremes.append(ang(T2 - O4))  # rocker direction O4 -> F at T2
    lo, hi = motion.oscillation_range(mech, 'rocker')
    assert lo < hi
    got = sorted([lo % TWO_PI, hi % TWO_PI])
    exp = sorted(e % TWO_PI for e in extremes)
    assert circ(got[0], exp[0]) < 1e-9 and circ(got[1], exp[1]) < 1e-9
    # the reported interval is the one the rocker actually sweeps: it holds the reference angle
    ref = mech.links['rocker'].angle_ref
    assert lo <= lo + (ref - lo) % TWO_PI <= hi
    # brute force: every rocker angle seen over a dense sweep of both modes lies in [lo, hi]
    s = Solver(mech)
    clo, chi = motion.input_ranges(mech)['crank']
    for t in np.linspace(clo, chi, 2001):
        for r in s.solve_all({'crank': float(t)}):
            if r.success:
                v = r.links['rocker']
                v = lo + (v - lo) % TWO_PI
                assert v <= hi + 1e-12


def test_shipped_oscillating_rpr_matches_its_documented_range():
    path = CONFIG / 'inverted_slider_crank_oscillating.yaml'
    if not path.exists():
        pytest.skip('scene not shipped yet')
    mech = Scene.from_yaml(path).mechanism
    info = motion.actuator_range(mech, 'crank')
    a = math.acos(0.92)  # cosine rule of the scene's header
    assert info['assembly'] == pytest.approx([a, TWO_PI - a], abs=1e-9)
    assert info['toggles'] == pytest.approx([a, TWO_PI - a], abs=1e-9)
    act = mech.actuators['crank']
    assert (info['min'], info['max']) == (act.min, act.max)  # limits sit inside the toggles


def test_shipped_peaucellier_folds_where_op_equals_l_minus_s():
    path = CONFIG / 'peaucellier.yaml'
    if not path.exists():
        pytest.skip('scene not shipped yet')
    mech = Scene.from_yaml(path).mechanism
    r, l, s = 0.045, 0.15, 0.10
    # P on the circle (OP, r) through O: |OP| = 2 r cos(theta / 2) = l - s at the fold
    fold = 2 * math.acos((l - s) / (2 * r))
    info = motion.actuator_range(mech, 'crank')
    assert info['assembly'] == pytest.approx([-fold, fold], abs=1e-9)


# ---- hydraulic fixtures: boom / arm / bin with three cylinders --------------------------------

PTS = {
    'O': (0.0, 0.0),
    'C1': (0.6, -0.4),
    'B1': (1.0, 0.35),
    'B2': (1.6, 0.7),
    'E': (2.5, 0.5),
    'R2': (2.3, 1.1),
    'R3': (2.9, 0.2),
    'P': (3.2, -0.6),
    'M': (3.5, -0.3),
    'Lp': (3.0, -1.1),
}
REF = {k: np.array(v) for k, v in PTS.items()}
Z_REF = {
    'Z1': math.dist(PTS['C1'], PTS['B1']),
    'Z2': math.dist(PTS['B2'], PTS['R2']),
    'Z3': math.dist(PTS['R3'], PTS['M']),
}
LIMITS = {'Z1': (0.70, 1.05), 'Z2': (0.65, 1.00), 'Z3': (Z_REF['Z3'] - 0.12, Z_REF['Z3'] + 0.10)}
HYD = f"""
name: hydraulic_arm
points: {{{', '.join(f'{k}: [{v[0]}, {v[1]}]' for k, v in PTS.items())}}}
links:
  ground: [O, C1]
  boom: [O, B1, B2, E]
  arm: [E, R2, R3, P]
  bin: [P, M, Lp]
cylinders:
  Z1: {{from: C1, to: B1, min: {LIMITS['Z1'][0]}, max: {LIMITS['Z1'][1]}}}
  Z2: {{from: B2, to: R2, min: {LIMITS['Z2'][0]}, max: {LIMITS['Z2'][1]}}}
  Z3: {{from: R3, to: M, min: {LIMITS['Z3'][0]!r}, max: {LIMITS['Z3'][1]!r}}}
outputs: [P, Lp]
"""


@pytest.fixture(scope='module')
def hyd(tmp_path_factory):
    p = tmp_path_factory.mktemp('motion') / 'hydraulic_arm.yaml'
    p.write_text(HYD)
    return str(p), Scene.from_yaml(p).mechanism


def side(a, b, x):
    return 1 if cross(b - a, x - a) > 0 else -1


def arm_tip(z1, z2):
    """Oracle forward kinematics of the fixture's point P from the throws (triangles)."""
    B1 = circle_meet(
        REF['O'],
        math.dist(PTS['O'], PTS['B1']),
        REF['C1'],
        z1,
        side(REF['O'], REF['C1'], REF['B1']),
    )
    if B1 is None:
        return None
    p1 = ang(B1) - ang(REF['B1'])
    E_, B2 = rot(REF['E'], p1), rot(REF['B2'], p1)
    R2 = circle_meet(
        E_, math.dist(PTS['E'], PTS['R2']), B2, z2, side(REF['E'], REF['B2'], REF['R2'])
    )
    if R2 is None:
        return None
    p2 = ang(R2 - E_) - ang(REF['R2'] - REF['E'])
    return E_ + rot(REF['P'] - REF['E'], p2)


def tilt_state(beta):
    """Oracle: the throws with Lp held at its reference and the bin at angle beta (its axis
    P -> M), or None when the chain does not close."""
    b0 = ang(REF['M'] - REF['P'])
    q = beta - b0
    P_ = REF['Lp'] + rot(REF['P'] - REF['Lp'], q)
    M_ = REF['Lp'] + rot(REF['M'] - REF['Lp'], q)
    E_ = circle_meet(
        REF['O'],
        math.dist(PTS['O'], PTS['E']),
        P_,
        math.dist(PTS['P'], PTS['E']),
        side(REF['O'], REF['P'], REF['E']),
    )
    if E_ is None:
        return None
    p1 = ang(E_) - ang(REF['E'])
    p2 = ang(P_ - E_) - ang(REF['P'] - REF['E'])
    B1, B2 = rot(REF['B1'], p1), rot(REF['B2'], p1)
    R2 = E_ + rot(REF['R2'] - REF['E'], p2)
    R3 = E_ + rot(REF['R3'] - REF['E'], p2)
    return {'Z1': math.dist(B1, REF['C1']), 'Z2': math.dist(R2, B2), 'Z3': math.dist(M_, R3)}


def tilt_ok(beta, limits=LIMITS):
    z = tilt_state(beta)
    return z is not None and all(limits[k][0] <= v <= limits[k][1] for k, v in z.items())


def test_region_of_a_point_agrees_with_a_brute_force_sweep_of_both_throws(hyd):
    _, mech = hyd
    reg = motion.reachable_region(mech, 'P', samples_per_actuator=41)
    assert reg['actuators'] == ['Z1', 'Z2']  # Z3 does not move P
    assert reg['method'] == 'extreme_arcs'
    poly = np.asarray(reg['boundary'])
    # every boundary vertex is reached: its throws are within limits and the oracle puts P there
    bi = reg['boundary_inputs']
    assert len(bi['Z1']) == len(poly)
    for z1, z2, v in zip(bi['Z1'], bi['Z2'], poly):
        assert LIMITS['Z1'][0] - 1e-12 <= z1 <= LIMITS['Z1'][1] + 1e-12
        assert LIMITS['Z2'][0] - 1e-12 <= z2 <= LIMITS['Z2'][1] + 1e-12
        assert np.hypot(*(arm_tip(z1, z2) - v)) < 1e-9
    # brute force: a fine grid of both throws; every point inside the boundary polygon
    from matplotlib.path import Path as MPath

    g1 = np.linspace(*LIMITS['Z1'], 121)
    g2 = np.linspace(*LIMITS['Z2'], 121)
    pts = np.array([arm_tip(a, b) for a in g1 for b in g2])
    inside = MPath(poly).contains_points(pts, radius=0.0)
    out = pts[~inside]
    if out.size:  # only points on the boundary itself, off the chords by the arcs' sagitta
        d = motion.distance_to_polygon(out, poly)
        assert d.max() < 1e-5
    # area: the integral of |det dP/dz| over the throw box (the map does not fold here)
    h = 1e-6
    n = 120
    m1 = LIMITS['Z1'][0] + (np.arange(n) + 0.5) * (LIMITS['Z1'][1] - LIMITS['Z1'][0]) / n
    m2 = LIMITS['Z2'][0] + (np.arange(n) + 0.5) * (LIMITS['Z2'][1] - LIMITS['Z2'][0]) / n
    dets = []
    for a in m1:
        for b in m2:
            d1 = (arm_tip(a + h, b) - arm_tip(a - h, b)) / (2 * h)
            d2 = (arm_tip(a, b + h) - arm_tip(a, b - h)) / (2 * h)
            dets.append(cross(d1, d2))
    dets = np.array(dets)
    assert np.all(dets > 0) or np.all(dets < 0)
    area = (
        np.abs(dets).mean()
        * (LIMITS['Z1'][1] - LIMITS['Z1'][0])
        * (LIMITS['Z2'][1] - LIMITS['Z2'][0])
    )
    assert reg['area'] == pytest.approx(area, rel=2e-3)
    assert reg['hull_check']['outside'] == 0


@pytest.mark.parametrize('z3', [LIMITS['Z3'], (0.3, 1.3)], ids=['Z3 binds', 'Z2 binds'])
def test_max_tilt_with_the_lip_held_agrees_with_a_brute_force_scan(z3):
    limits = {**LIMITS, 'Z3': z3}
    text = HYD.replace(
        f'min: {LIMITS["Z3"][0]!r}, max: {LIMITS["Z3"][1]!r}', f'min: {z3[0]!r}, max: {z3[1]!r}'
    )
    mech = Scene.from_dict(yaml.safe_load(text)).mechanism
    assert (mech.actuators['Z3'].min, mech.actuators['Z3'].max) == z3
    res = motion.max_tilt(mech, 'Lp', 'bin')
    b0 = ang(REF['M'] - REF['P'])
    assert res['ok'] and abs(res['start'] - b0) < 1e-15
    assert res['hold_point'] == pytest.approx(list(PTS['Lp']), abs=0)
    assert tilt_ok(b0, limits)
    for d, key in ((1, 'max'), (-1, 'min')):
        # brute force: march the oracle in 1e-3 rad steps, then bisect on it to 1e-13
        b = b0
        while tilt_ok(b + d * 1e-3, limits):
            b += d * 1e-3
            assert abs(b - b0) < math.pi
        good, bad = b, b + d * 1e-3
        for _ in range(60):
            mid = 0.5 * (good + bad)
            good, bad = (mid, bad) if tilt_ok(mid, limits) else (good, mid)
        assert abs(res[key] - good) < 1e-9, (key, res[key], good)
        # the reason names the constraint that binds just beyond
        z = tilt_state(bad)
        if z is None:
            assert 'close' in res['reason'][key]
        else:
            binding = [k for k, v in z.items() if not limits[k][0] <= v <= limits[k][1]]
            assert binding and binding[0] in res['reason'][key]
            word = 'maximum' if z[binding[0]] > limits[binding[0]][1] else 'minimum'
            assert word in res['reason'][key]
        # the solver's actuator values at the bound are the oracle's
        zg = tilt_state(good)
        for k, v in res['inputs_at'][key].items():
            assert abs(v - zg[k]) < 1e-8
    assert res['tilt_up'] == pytest.approx(res['max'] - b0)
    assert res['tilt_down'] == pytest.approx(b0 - res['min'])


def test_cli_range_json_region_tilt_and_plots(hyd, tmp_path, capsys):
    from linkage_ros.cli.range import main

    path, mech = hyd
    png, cur = tmp_path / 'region.png', tmp_path / 'curves.png'
    rc = main(
        [
            path,
            '--json',
            '--point',
            'P',
            '--tilt',
            'bin',
            '--lip',
            'Lp',
            '--plot',
            str(png),
            '--curves',
            str(cur),
            '--input',
            'Z2',
            '--output',
            'arm',
        ]
    )
    out = capsys.readouterr().out
    assert rc == 0
    data = json.loads(out)
    assert set(data['inputs']) == {'Z1', 'Z2', 'Z3'}
    for k, (lo, hi) in LIMITS.items():
        assert (data['inputs'][k]['min'], data['inputs'][k]['max']) == pytest.approx((lo, hi))
    assert data['region']['P']['area'] > 0 and len(data['region']['P']['boundary']) > 100
    assert data['tilt']['ok'] and data['tilt']['max'] > data['tilt']['min']
    for p in (png, cur):
        b = p.read_bytes()
        assert len(b) > 5000 and b[:8] == b'\x89PNG\r\n\x1a\n'
    # human-readable output and usage errors
    assert main([path]) == 0
    assert 'input ranges' in capsys.readouterr().out
    assert main([path, '--tilt', 'bin']) == 2
    assert 'go together' in capsys.readouterr().err
    assert main([path, '--point', 'nope']) == 2
    # a plot into a folder that does not exist: refused before the analysis, nothing made
    # (it made the folder, where --csv and the bag's outputs refuse it)
    for option in ('--plot', '--curves'):
        missing = tmp_path / 'no' / 'such' / 'x.png'
        extra = ['--input', 'Z2', '--output', 'arm'] if option == '--curves' else []
        assert main([path, '--point', 'P', option, str(missing), *extra]) == 2
        assert f'folder {missing.parent} does not exist' in capsys.readouterr().err
        assert not (tmp_path / 'no').exists()
    # registered as `linkage range`
    from linkage_ros.cli.parser import main as cli_main

    assert cli_main(['range', path, '--json']) == 0
    assert set(json.loads(capsys.readouterr().out)['inputs']) == {'Z1', 'Z2', 'Z3'}


def test_cli_tilt_starts_from_the_angle_given(capsys):
    """Seed 003 example 6, part 3: the bin tilted about its lip held at L2, from the pose the
    hinges J2, K2 gave it (bucket -0.79323 rad), not from the drawing's angle (from which the
    same lip position needs Z3 below its minimum: refused at the start). The CLI had no way to
    say the start; its answer is the API's."""
    from linkage_ros.cli.range import main
    from linkage_ros.core.motion import max_tilt

    mech = load('excavator')
    hold = (1.867934199, -0.169618455)
    argv = ['excavator', '--tilt', 'bucket', '--lip', 'L', '--hold', f'{hold[0]},{hold[1]}']
    assert main([*argv, '--json']) == 1  # from the drawing's angle: refused at the start
    capsys.readouterr()
    assert main([*argv, '--tilt-from=-0.79323', '--json']) == 0
    got = json.loads(capsys.readouterr().out)['tilt']
    want = max_tilt(mech, 'L', 'bucket', hold_point=hold, start_angle=-0.79323)
    assert got['tilt_up'] == pytest.approx(want['tilt_up'], abs=1e-12)
    assert got['tilt_down'] == pytest.approx(want['tilt_down'], abs=1e-12)
    assert main([*argv, '--tilt-from=-45.449deg', '--json']) == 0
    capsys.readouterr()
    assert main([*argv, '--tilt-from', '2m']) == 2
    assert "'m'), but an angle" in capsys.readouterr().err
    assert main(['excavator', '--tilt-from', '1.0']) == 2


def test_links_report_the_whole_circuit_where_crank_limits_stop_short_of_the_toggles(capsys):
    """Seed 003 example 5: 'find the angle through which link number 2 and link number 4 can
    oscillate' in the non-Grashof 3R-1P. The shipped scene's crank limits sit 0.01 rad inside its
    toggles, so `--links` gave the rocker 127.1 deg (half its circuit) and nothing said so. The
    report adds the swing without the crank's limits. Oracle: A on the slide line at distance
    e = 0.14 from O4, 0.2 cos(theta - psi) = 0.14 + 0.3 cos(psi), closes while cos(psi) <= 0.2:
    psi in [acos 0.2, 2 pi - acos 0.2], 203.1 deg."""
    from linkage_ros.cli.range import main

    assert main(['inverted_slider_crank_oscillating', '--links', '--json']) == 0
    rocker = json.loads(capsys.readouterr().out)['oscillation']['links']['rocker']
    free = rocker['without_limits']
    assert free['min'] == pytest.approx(math.acos(0.2), abs=1e-9)
    assert free['max'] == pytest.approx(2 * math.pi - math.acos(0.2), abs=1e-9)
    assert rocker['max'] - rocker['min'] < free['max'] - free['min'] - 1.0  # the limits' half
    assert main(['inverted_slider_crank_oscillating', '--links']) == 0
    assert "without the input's limits (through its toggles)" in capsys.readouterr().out
    assert main(['four_bar', '--links']) == 0  # no limits: nothing added
    assert 'without the input' not in capsys.readouterr().out


def test_plots_write_pngs_with_both_branches(tmp_path):
    from linkage_ros.plots import plot_output_vs_input, plot_region

    mech = fourbar(0.4, 0.1, 0.35, 0.3, coupler_point={'distance': 0.2, 'angle': 0.5})
    d = plot_output_vs_input(mech, 'crank', 'rocker', tmp_path / 'theta4.png', samples=181)
    assert Path(d['path']).stat().st_size > 5000
    assert set(d['branches']) == {'+', '-'}
    # each branch is a closed-form rocker angle: check one point of each against Freudenstein's
    # geometry (B on both circles)
    for _key, br in d['branches'].items():
        t2, t4 = br['input'][40], br['output'][40]
        A = 0.1 * np.array([math.cos(t2), math.sin(t2)])
        B = np.array([0.4, 0]) + 0.3 * np.array([math.cos(t4), math.sin(t4)])
        assert abs(math.dist(A, B) - 0.35) < 1e-12
    reg = motion.reachable_region(mech, 'P')
    assert reg['method'] == 'path' and reg['area'] == 0.0
    p = plot_region(mech, reg, tmp_path / 'region.png')
    assert Path(p).stat().st_size > 5000


@pytest.mark.parametrize(
    'scene',
    [
        'four_bar',
        'hart',
        'peaucellier',
        'quick_return',
        'inverted_slider_crank_oscillating',
        'slider_crank',
    ],
)
def test_link_oscillation_matches_a_continuous_sweep_within_the_limits(scene):
    """Within its limits (away from the toggles) the crank cannot change assembly mode: every
    link's range is what a fine, branch-continuous sweep of the crank shows."""
    mech = _scene(scene)
    act = mech.actuators['crank']
    x0 = motion.reference_value(mech, 'crank')
    ends = (act.max, act.min) if act.min is not None else (x0 + math.pi, x0 - math.pi)
    s = Solver(mech, branch='continuous')
    seen = {l: [] for l in mech.moving_links if len(mech.links[l].points) >= 2}
    # walk from the reference value to each limit (or half a turn each way)
    for end in ends:
        s.reset()
        for v in np.linspace(x0, end, 1501):
            r = s.solve({'crank': float(v)})
            assert r.success, r.reason
            for l in seen:
                seen[l].append(r.links[l])
    for link, vals in seen.items():
        lo_l, hi_l = motion.oscillation_range(mech, link)
        v = np.unwrap(np.array(vals))
        if np.ptp(v) >= TWO_PI - 0.01:
            assert lo_l is None and hi_l is None, link
            continue
        # shift the sweep into the reported window
        v = v + TWO_PI * round((lo_l - v.min()) / TWO_PI)
        assert v.min() >= lo_l - 1e-9 and v.max() <= hi_l + 1e-9, link
        assert v.min() - lo_l < 2e-5 and hi_l - v.max() < 2e-5, link


def test_shipped_plagiograph_toggles_where_the_parallelogram_folds():
    mech = _scene('plagiograph')
    # theta_C held: O2A and O2C collinear (theta_A = theta_C or theta_C + pi) flattens the
    # parallelogram O2ABC, the dyad A-B-C toggles there
    tc = motion.reference_value(mech, 'theta_C')
    tog = motion.toggle_positions(mech, 'theta_A')
    assert len(tog) == 2
    for t in (tc, tc + math.pi):
        assert min(circ(t, v) for v in tog) < 1e-7


# ---- inverse kinematics round trips on the shipped scenes ---------------------------------------


def _scene(name):
    path = CONFIG / f'{name}.yaml'
    if not path.exists():
        pytest.skip(f'{name}.yaml not shipped yet')
    return Scene.from_yaml(path).mechanism


def _target_value(mech, name, r):
    """The value of known `name` (a point, a link angle or a joint value) in a solved Result."""
    spec = spec_for(mech, name)
    if isinstance(spec, PointSpec):
        return np.asarray(r.points[spec.point])
    if isinstance(spec, SlideSpec):
        return r.joints[spec.joint]
    bare = name.split(':')[-1]
    return r.links[bare] if bare in mech.links and spec.reference == mech.ground else r.joints[bare]


def _err(mech, name, a, b):
    """Round-trip error: angles on the circle (rad), lengths as a fraction of the scale."""
    spec = spec_for(mech, name)
    if isinstance(spec, PointSpec):
        return float(np.hypot(*(np.asarray(a) - np.asarray(b)))) / mech.length_scale
    if isinstance(spec, AngleSpec):
        return circ(a, b)
    return abs(a - b) / mech.length_scale


ROUND_TRIPS = [
    ('four_bar', lambda m: [motion.link_key(m, 'rocker')]),
    ('slider_crank', lambda m: ['slider']),
    ('plagiograph', lambda m: [motion.point_key(m, 'D')]),
    ('front_loader', lambda m: [motion.point_key(m, 'D')]),
    ('excavator', lambda m: [motion.point_key(m, 'J'), motion.link_key(m, 'bucket')]),
    ('excavator', lambda m: [motion.point_key(m, 'K'), motion.link_key(m, 'bucket')]),
]


@pytest.mark.parametrize('scene,knowns', ROUND_TRIPS)
def test_inverse_kinematics_round_trip_on_shipped_scenes(scene, knowns):
    mech = _scene(scene)
    keys = knowns(mech)
    fwd = Solver(mech, branch='reference')
    inv = Solver(mech, knowns=keys, branch='reference')
    rng = np.random.default_rng(11)
    ranges = {a: motion.actuator_range(mech, a) for a in mech.actuators}
    tested = 0
    for _ in range(12):
        cmd = {}
        for a, info in ranges.items():
            lo, hi = info['min'], info['max']
            if lo is None:
                lo, hi = -math.pi, math.pi
            cmd[a] = float(rng.uniform(lo, hi))
        r = fwd.solve(cmd)
        assert r.success, r.reason
        target = {
            k: (
                _target_value(mech, k, r).tolist()
                if np.ndim(_target_value(mech, k, r))
                else _target_value(mech, k, r)
            )
            for k in keys
        }
        answers = [x for x in inv.solve_all(target) if x.success]
        assert answers, inv.solve(target).reason
        for x in answers:
            # forward(inverse(x)) = x: the actuator values reproduce the target in some mode
            back = Solver(mech).solve_all(x.inputs)
            worst = min(
                max(_err(mech, k, _target_value(mech, k, b), target[k]) for k in keys)
                for b in back
                if b.success
            )
            assert worst < 1e-10, (cmd, target, x.inputs)
        tested += 1
    assert tested == 12


@pytest.mark.parametrize('scene,knowns', ROUND_TRIPS)
def test_unreachable_and_beyond_limit_targets_are_refused_with_a_reason(scene, knowns):
    mech = _scene(scene)
    keys = knowns(mech)
    inv = Solver(mech, knowns=keys)
    # unreachable: points far away, link / slider values outside the motion
    far = {}
    for k in keys:
        bare = k.split(':')[-1]
        if bare in mech.points and (k.startswith('point:') or bare not in mech.links):
            far[k] = [100.0 * mech.length_scale, -100.0 * mech.length_scale]
        elif bare in mech.links:
            lo, hi = motion.oscillation_range(mech, bare) if mech.dof == 1 else (None, None)
            far[k] = (lo + hi) / 2 + math.pi if lo is not None else 0.0
        else:
            far[k] = 100.0 * mech.length_scale
    r = inv.solve(far)
    assert not r.success and r.reason
    assert (
        'close' in r.reason or 'assemble' in r.reason or 'beyond' in r.reason or 'below' in r.reason
    ), r.reason
    # beyond a limit: a pose reached with one actuator past its limit, solved by an unlimited
    # copy, then asked of the limited scene
    limited = [a for a, act in mech.actuators.items() if act.max is not None]
    if not limited:
        return
    a = limited[0]
    act = mech.actuators[a]
    free = motion.without_limits(mech)
    cmd = {b: motion.reference_value(mech, b) for b in mech.actuators}
    span = act.max - (act.min if act.min is not None else act.max - 1.0)
    cmd[a] = act.max + 0.05 * span
    r = Solver(free, branch='reference').solve(cmd)
    assert r.success, r.reason
    target = {k: (np.asarray(_target_value(mech, k, r)).tolist()) for k in keys}
    res = Solver(mech, knowns=keys, branch='reference').solve(target)
    assert not res.success
    assert a in res.reason and 'maximum' in res.reason, res.reason


def test_the_tilt_is_of_the_mechanism_as_it_stands_in_its_assembly_mode():
    """A tilt's start (lip held, bin at an angle) solved continuously from the drawing may land
    in another assembly mode with the same lip and angle: the excavator held at this lip
    position and angle was tilted 1.212 .. 1.398 rad in mode +-++, limited by Z3 there, while
    the mechanism is in +--+. Oracle: the forward closed form in the drawing's mode at the
    actuator values of each bound puts the lip at the hold point and the bin at the bound's
    angle; the start that only another mode reaches is refused naming it."""
    from linkage_ros.core.motion import max_tilt
    from linkage_ros.core.solver import Solver

    mech = load('excavator')
    odd = max_tilt(
        mech, 'L', 'bucket', hold_point=(3.2629924685627913, -0.2834644322931385),
        start_angle=1.3675331280709948,
    )  # fmt: skip
    assert not odd['ok'] and 'reachable only in assembly mode +-++' in odd['reason']['start']
    forward = Solver(mech, method='closed_form', branch='reference')
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(12):
        z = {a: rng.uniform(act.min, act.max) for a, act in mech.actuators.items()}
        pose = forward.solve(z, commit=False)
        hold = pose.points['L']
        res = max_tilt(mech, 'L', 'bucket', hold_point=hold, start_angle=pose.links['bucket'])
        assert res['ok'], res['reason']
        for key in ('min', 'max'):
            if res[key] is None:
                continue
            at = forward.solve(res['inputs_at'][key], commit=False)
            assert at.success and math.dist(at.points['L'], hold) <= 1e-9
            turn = math.remainder(at.links['bucket'] - res[key], 2 * math.pi)
            assert abs(turn) <= 1e-6, (key, turn)
            checked += 1
    assert checked >= 12
