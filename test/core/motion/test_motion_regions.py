"""Tests of linkage_ros.core.motion on hydraulic mechanisms (boom / arm / bin driven by three
cylinders): the region a point reaches, the bin's tilt with its lip held (in the mechanism's own
assembly mode), and `linkage range`'s JSON, tilt and plots.

Every number is checked against an oracle written here and independent of the solver:
hand-written triangle kinematics of two hydraulic fixtures swept by brute force (grid of
throws, scan of the bin angle with bisection) and the forward closed form in the drawing's mode.
"""

import json
import math

import numpy as np
import pytest
import yaml
from motion_helpers import ang, circle_meet, cross, side
from scenes import KNUCKLE_BOOM, load

from linkage_ros.core import motion
from linkage_ros.core.model import Scene


def rot(v, a):
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


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


def test_a_concave_hull_region_says_its_area_may_be_too_large(capsys):
    # an adversary's finding: the excavator's L region (three cylinders: the samples' concave
    # hull) bridged notches, its area 0.85 % above a finer grid's union of cell images, printed
    # as fact; the extreme arcs of two actuators carry no such caveat
    from linkage_ros.cli.range import main

    assert main(['excavator', '--point', 'L', '--samples', '21']) == 0
    out = capsys.readouterr().out
    assert 'concave_hull' in out and 'an estimate' in out and 'fills holes' in out
    assert main(['excavator', '--point', 'K', '--samples', '21']) == 0
    out = capsys.readouterr().out
    assert 'extreme_arcs' in out and 'an estimate' not in out


def test_fewer_than_three_samples_are_refused_as_the_help_says(capsys):
    """`range --samples` says 'at least 3' (the extreme arcs refine an extreme from a sample
    and its two neighbours); 2 was taken (the CLI's check said 2) and the core quietly used 3
    for a region but 2 for a path (a P path's extent 6 % short). Both refuse it now."""
    from linkage_ros.cli.range import main

    for n in ('2', '1', '0'):
        assert main(['four_bar', '--point', 'P', '--samples', n]) == 2
        assert '--samples must be at least 3' in capsys.readouterr().err
    for n in (2, 0, True):
        with pytest.raises(ValueError, match='at least 3'):
            motion.reachable_region(load('four_bar'), 'P', samples_per_actuator=n)
    assert main(['four_bar', '--point', 'P', '--samples', '3']) == 0


# ---- a dead centre inside the limits ------------------------------------------------------------

#: an arm about O lifted by a cylinder from G (1 m below O) to B on the arm (1 m from O): the
#: cylinder's dead centre is at |GB| = |GO| + |OB| = 2 m, inside its limits 0.5 .. 2.55 m (no
#: sample of the path's 161 falls on it)
ARM = {
    'name': 'arm',
    'points': {'O': [0, 0], 'G': [0, -1], 'B': [1, 0], 'T': [2, 0]},
    'links': {'ground': ['O', 'G'], 'arm': ['O', 'B', 'T']},
    'cylinders': {'lift': {'from': 'G', 'to': 'B', 'min': 0.5, 'max': 2.55}},
}


def test_a_path_reaches_a_dead_centre_inside_the_limits():
    """The arm's tip T runs up to the top, (0, 2), at the cylinder's dead centre (2 m): the
    path's samples beyond it do not assemble, and the last that does is 0.00094 m of throw
    short of it, 0.0037 m below the top; the edge between is found."""
    r = motion.reachable_region(Scene.from_dict(ARM).mechanism, 'T')
    assert r['method'] == 'path'
    k = int(np.argmax([p[1] for p in r['boundary']]))
    top, throw = r['boundary'][k], r['boundary_inputs']['lift'][k]
    assert abs(top[1] - 2.0) < 1e-12 and abs(top[0]) < 1e-6, top
    assert abs(throw - 2.0) < 1e-9
    assert r['extent'][1][1] == top[1]
    throws = r['boundary_inputs']['lift']
    assert throws == sorted(throws)  # the edge in its place along the path


def test_a_region_reaches_a_dead_centre_inside_the_limits():
    """The crane's jib tip T2 over both throw ranges: its highest point is at full lift with the
    fold cylinder at its dead centre (the jib then lies along B2 -> T1), worked out here by
    circle intersection and rotation; the region's samples stopped a step short of it (y up to
    2.785 m against 3.208 m) and now reach it."""
    mech = Scene.from_dict(KNUCKLE_BOOM).mechanism
    p = {k: np.array(v, float) for k, v in KNUCKLE_BOOM['points'].items()}
    ob1 = np.linalg.norm(p['B1'] - p['O'])
    b1 = circle_meet(p['O'], ob1, p['G1'], 1.60, side(p['O'], p['G1'], p['B1']))

    def turned(v, angle):
        c, s = math.cos(angle), math.sin(angle)
        return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])

    boom = ang(b1 - p['O']) - ang(p['B1'] - p['O'])
    t1 = p['O'] + turned(p['T1'] - p['O'], boom)
    b2 = p['O'] + turned(p['B2'] - p['O'], boom)
    j1 = t1 + np.linalg.norm(p['J1'] - p['T1']) * (t1 - b2) / np.linalg.norm(t1 - b2)
    jib = ang(j1 - t1) - ang(p['J1'] - p['T1'])
    top = t1 + turned(p['T2'] - p['T1'], jib)
    r = motion.reachable_region(mech, 'T2')
    assert r['extent'][1][1] == pytest.approx(top[1], abs=1e-9)
    cloud = np.asarray(r['cloud'])
    assert np.min(np.hypot(*(cloud - top).T)) < 1e-6  # reached at that configuration


def test_a_dead_centre_on_a_sample_is_not_a_second_vertex():
    """With the arm's limits 0.5 .. 3.5 m and 3 samples (a path of 9), a sample falls on the
    dead centre (2 m): it is the path's end, once (the edge found beside it is that sample, to
    the tangency band's hair past it)."""
    arm = {**ARM, 'cylinders': {'lift': {'from': 'G', 'to': 'B', 'min': 0.5, 'max': 3.5}}}
    r = motion.reachable_region(Scene.from_dict(arm).mechanism, 'T', samples_per_actuator=3)
    throws = r['boundary_inputs']['lift']
    assert throws[-1] == 2.0 and throws.count(2.0) == 1 and len(throws) == len(set(throws))
    assert len(r['boundary']) == len(throws)


def _even_odd(p, poly):
    """Inside by the even-odd rule, one point, written out (the ray to +x)."""
    inside = False
    for (x1, y1), (x2, y2) in zip(poly, np.roll(poly, -1, axis=0)):
        crosses = (y1 > p[1]) != (y2 > p[1])
        if crosses and p[0] < x1 + (p[1] - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def test_polygon_tests_hold_their_memory_whatever_the_sizes():
    """The region's hull check (which samples lie inside the boundary, how far outside) over
    20,000 points and a 6,400-vertex star: the answers of a point-by-point loop, in tables of
    at most POINT_BLOCK x EDGE_BLOCK entries (one table of every point against every edge took
    ~15 GB for a 401 x 401 throw grid: 1 GB each here)."""
    import tracemalloc

    from linkage_ros.core.motion import region

    rng = np.random.default_rng(7)
    k = np.arange(6400)
    r = 1.0 + 0.3 * np.sin(7 * 2 * np.pi * k / 6400)
    poly = np.stack([r * np.cos(2 * np.pi * k / 6400), r * np.sin(2 * np.pi * k / 6400)], axis=1)
    pts = rng.uniform(-1.4, 1.4, (20000, 2))
    tracemalloc.start()
    try:
        inside = motion.points_in_polygon(pts, poly)
        far = motion.distance_to_polygon(pts[:3000], poly)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 64 * 2**20, peak
    assert region.POINT_BLOCK * region.EDGE_BLOCK * 8 <= 4 * 2**20
    for i in range(0, 20000, 97):  # a sample of the points, each by the loop
        assert inside[i] == _even_odd(pts[i], poly), i
    for i in range(0, 3000, 101):
        d = np.min(
            [
                np.hypot(
                    *(
                        pts[i]
                        - (
                            a
                            + np.clip(np.dot(pts[i] - a, b - a) / np.dot(b - a, b - a), 0, 1)
                            * (b - a)
                        )
                    )
                )
                for a, b in zip(poly, np.roll(poly, -1, axis=0))
            ]
        )
        assert far[i] == pytest.approx(d, rel=1e-12, abs=1e-15)


def test_a_paths_extent_is_refined_between_its_samples():
    """One actuator's path: its extent was its samples' (161 at the default --samples 41), a
    Jansen leg's foot 2.4e-4 m short while printed to six digits (an outside scene author).
    Oracle: the four-bar's coupler point P by its own circle intersection (B on the drawn
    side), each coordinate's extremes over the crank by a bounded scalar search around the
    best of 3600 samples."""
    from scipy.optimize import minimize_scalar

    mech = load('four_bar')
    P = {k: np.asarray(v, float) for k, v in mech.points.items()}
    a, b, c = (np.linalg.norm(P[q] - P[p]) for p, q in (('O2', 'A'), ('A', 'B'), ('O4', 'B')))
    drawn = side(P['A'], P['O4'], P['B'])
    ab0, ap0 = P['B'] - P['A'], P['P'] - P['A']

    def coupler_point(t: float) -> np.ndarray:
        A = P['O2'] + a * np.array([math.cos(t), math.sin(t)])
        B = circle_meet(A, b, P['O4'], c, drawn)
        turn = math.atan2(*(B - A)[::-1]) - math.atan2(*ab0[::-1])
        cs, sn = math.cos(turn), math.sin(turn)
        return A + np.array([ap0[0] * cs - ap0[1] * sn, ap0[0] * sn + ap0[1] * cs])

    ts = np.linspace(-math.pi, math.pi, 3600, endpoint=False)
    want = []
    for axis in (0, 1):
        ends = []
        for sense in (1, -1):
            k = int(np.argmin([sense * coupler_point(t)[axis] for t in ts]))
            got = minimize_scalar(
                lambda t, ax=axis, sg=sense: sg * coupler_point(t)[ax],
                bounds=(ts[k] - 0.01, ts[k] + 0.01),
                method='bounded',
                options={'xatol': 1e-10},
            )
            ends.append(sense * got.fun)
        want.append(ends)
    got = motion.reachable_region(mech, 'P')['extent']
    assert np.allclose(got, want, rtol=0, atol=1e-12), (got, want)
