"""Tests of linkage_ros.core.motion on one-DOF mechanisms: input ranges, toggles and link
oscillation of four-bars, the non-Grashof 3R-1P, shipped mechanisms (oscillating RPR,
Peaucellier, plagiograph) and the output-vs-input plots.

Every number is checked against an oracle written here and independent of the solver: the
cosine rule for four-bar toggle angles, the seed's circle intersections and common tangents for
the non-Grashof 3R-1P chain, and continuous sweeps.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from motion_helpers import TWO_PI, ang, circ, circle_meet, named_scene
from scenes import CONFIG, STEPHENSON_DRIVEN_AT_ITS_OUTPUT
from scenes import four_bar as fourbar

from linkage_ros.core import motion
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver


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
    mech = Scene.from_yaml(CONFIG / 'inverted_slider_crank_oscillating.yaml').mechanism
    info = motion.actuator_range(mech, 'crank')
    a = math.acos(0.92)  # cosine rule of the scene's header
    assert info['assembly'] == pytest.approx([a, TWO_PI - a], abs=1e-9)
    assert info['toggles'] == pytest.approx([a, TWO_PI - a], abs=1e-9)
    act = mech.actuators['crank']
    assert (info['min'], info['max']) == (act.min, act.max)  # limits sit inside the toggles


def test_shipped_peaucellier_folds_where_op_equals_l_minus_s():
    mech = Scene.from_yaml(CONFIG / 'peaucellier.yaml').mechanism
    r, l, s = 0.045, 0.15, 0.10
    # P on the circle (OP, r) through O: |OP| = 2 r cos(theta / 2) = l - s at the fold
    fold = 2 * math.acos((l - s) / (2 * r))
    info = motion.actuator_range(mech, 'crank')
    assert info['assembly'] == pytest.approx([-fold, fold], abs=1e-9)


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


def test_the_curves_of_a_newton_placed_mechanism_draw_both_halves_of_its_circuit(tmp_path):
    """A Stephenson six-bar driven at its output (Newton places it): the curves drew one
    Jacobian mode, half the drive's circuit, under the title 'every assembly mode' (an outside
    scene author). Both modes are drawn now: the crank, the Grashof crank of the four-bar
    O2-A-B-O4 inside it, turns fully over the two, and each plotted pose closes the loop the
    drive is in (D, where out puts it, at |C D| from C; C placed by the crank's four-bar:
    checked with the crank four-bar's own circle intersection)."""
    from linkage_ros.core.model import Scene
    from linkage_ros.plots import plot_output_vs_input

    scene = STEPHENSON_DRIVEN_AT_ITS_OUTPUT
    mech = Scene.from_dict(scene).mechanism
    d = plot_output_vs_input(mech, 'drive', 'crank', tmp_path / 'c.png', samples=181)
    assert set(d['branches']) == {'J+', 'J-'}
    cranks = np.sort(np.mod([v for br in d['branches'].values() for v in br['output']], TWO_PI))
    gaps = np.diff(np.append(cranks, cranks[0] + TWO_PI))
    assert gaps.max() < 0.1  # the crank's samples go all the way round
    P = {k: np.array(v, float) for k, v in scene['points'].items()}
    a, b, c = (np.linalg.norm(P[q] - P[p]) for p, q in (('O2', 'A'), ('A', 'B'), ('O4', 'B')))
    cd, out = np.linalg.norm(P['D'] - P['C']), np.linalg.norm(P['D'] - P['O6'])
    for br in d['branches'].values():
        for drive, crank in list(zip(br['input'], br['output']))[::20]:
            A = a * np.array([math.cos(crank), math.sin(crank)])
            Bs = [circle_meet(A, b, P['O4'], c, sd) for sd in (1, -1)]  # the four-bar's two B
            D = P['O6'] + out * np.array([math.cos(drive), math.sin(drive)])
            ab0, ac0 = P['B'] - P['A'], P['C'] - P['A']
            miss = []
            for B in Bs:
                if B is None:
                    continue
                rot = math.atan2(*(B - A)[::-1]) - math.atan2(*ab0[::-1])
                C = A + np.array(
                    [
                        ac0[0] * math.cos(rot) - ac0[1] * math.sin(rot),
                        ac0[0] * math.sin(rot) + ac0[1] * math.cos(rot),
                    ]
                )
                miss.append(abs(np.linalg.norm(D - C) - cd))
            assert min(miss) < 1e-9, (drive, crank, miss)


def test_the_curves_of_a_grashof_double_rocker_show_both_loops(tmp_path):
    """Seed 000: the Grashof double-rocker's theta4-theta2 plot has two loops, one per
    assembly mode; the plot drew the drawing's loop only (a seed reviewer's find). Its crank
    rocks between the toggles where coupler and rocker lie in line (|O4 A| = rocker +- coupler:
    the cosine rule) on the drawing's side of the ground line and on the mirror side; every
    point plotted closes the loop (B on both circles)."""
    from linkage_ros.plots import plot_output_vs_input

    g, c, k, r = 0.3, 0.25, 0.1, 0.22  # ground, crank, coupler, rocker
    mech = fourbar(g, c, k, r)
    d = plot_output_vs_input(mech, 'crank', 'rocker', tmp_path / 'loops.png', samples=181)
    toggles = sorted(
        math.acos((g * g + c * c - e * e) / (2 * g * c)) for e in (r - k, r + k)
    )  # the crank angle at which |O4 A| = e
    for br in d['branches'].values():
        x = np.array(br['input'])
        for lo, hi in (toggles, [-toggles[1], -toggles[0]]):
            inside = x[(x >= lo - 1e-9) & (x <= hi + 1e-9)]
            assert (
                inside.size > 50 and abs(inside.min() - lo) < 1e-9 and abs(inside.max() - hi) < 1e-9
            )
        assert np.all((np.abs(x) >= toggles[0] - 1e-9) & (np.abs(x) <= toggles[1] + 1e-9))
        for t2, t4 in zip(br['input'], br['output']):
            A = c * np.array([math.cos(t2), math.sin(t2)])
            B = np.array([g, 0]) + r * np.array([math.cos(t4), math.sin(t4)])
            assert abs(math.dist(A, B) - k) < 1e-12


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
    mech = named_scene(scene)
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
    mech = named_scene('plagiograph')
    # theta_C held: O2A and O2C collinear (theta_A = theta_C or theta_C + pi) flattens the
    # parallelogram O2ABC, the dyad A-B-C toggles there
    tc = motion.reference_value(mech, 'theta_C')
    tog = motion.toggle_positions(mech, 'theta_A')
    assert len(tog) == 2
    for t in (tc, tc + math.pi):
        assert min(circ(t, v) for v in tog) < 1e-7


def test_range_without_limits_lifts_the_named_actuators_limits(capsys):
    """--without-limits Z3: Z3's range is the geometry's (its toggles), not the scene's 1.12 ..
    1.62 m, the report says which were lifted, and a name that is no actuator is refused."""
    from linkage_ros.cli.range import main

    assert main(['excavator', '--without-limits', 'Z3', '--json']) == 0
    r = json.loads(capsys.readouterr().out)
    assert r['without_limits'] == ['Z3']
    z3 = r['inputs']['Z3']
    assert z3['min'] < 1.12 and z3['max'] > 1.62
    assert (z3['min_source'], z3['max_source']) == ('toggle', 'toggle')
    assert main(['excavator', '--json']) == 0
    assert json.loads(capsys.readouterr().out)['inputs']['Z3']['min'] == 1.12
    assert main(['excavator', '--without-limits', 'Z9']) == 2
    assert "--without-limits Z9: not an actuator of 'excavator'" in capsys.readouterr().err


def test_a_newton_placed_drives_range_ends_where_its_six_bar_turns_back(monkeypatch):
    """A Stephenson six-bar driven at its output (no closed form: Newton walks the drive):
    its range ends at the drive's extremes over the motion of the four-bar O2-A-B-O4 inside
    it (a Grashof crank turning fully). Oracle: the four-bar by its own circle intersection,
    C carried by the coupler, D where link5 from C meets out from O6 on the drawn side (the
    drive turning back at its extremes, D stays on it: its other side is another circuit), the drive
    angle's extremes over the crank refined by a bounded scalar search (the drive is flat
    there: its error is the search's squared).
    The walk's bisection probes each edge by one Newton from the accepted side (it reads
    where the range ends, not why): by the continuation walk with its halvings, past the fold,
    they took 33468 Newton iterations here (`linkage check` of the scene 28 s of CPU); bounded
    well above the 4013 they take now."""
    from oracles import extreme_near_samples, stephenson_drive

    scene = STEPHENSON_DRIVEN_AT_ITS_OUTPUT
    drive = stephenson_drive(scene['points'])
    cranks = np.linspace(0, TWO_PI, 721)
    ends = [extreme_near_samples(drive, cranks, sense, 0.01)[1] for sense in (1, -1)]
    spent = []
    solve = Solver.solve

    def counted(self, *args, **kwargs):
        r = solve(self, *args, **kwargs)
        spent.append(r.iterations or 0)
        return r

    monkeypatch.setattr(Solver, 'solve', counted)
    r = motion.actuator_range(Scene.from_dict(scene).mechanism, 'drive')
    assert (r['min_source'], r['max_source']) == ('toggle', 'toggle')
    assert abs(r['min'] - ends[0]) < 1e-9, (r['min'], ends[0])
    assert abs(r['max'] - ends[1]) < 1e-9, (r['max'], ends[1])
    assert sum(spent) < 12000, sum(spent)


@pytest.mark.parametrize('past', [2e-7, 2e-9, 5e-7])
def test_a_dead_zone_narrower_than_the_scans_step_is_found(past):
    """A four-bar just past its change point (crank 0.2 + ``past`` against ground 0.5, coupler
    0.6, rocker 0.3: s + l exceeds p + q by ``past``) cannot pass a band of its crank's turn
    2e-3 .. 7e-5 rad wide, narrower than the scan's step (2 pi / 720): it was read as turning
    fully, with one toggle or none and half the rocker's swing (a numerics reviewer). Oracle:
    the cosine rule, |A - O4| = coupler - rocker at the toggles, and the
    rocker's extremes where |O2 B| = coupler - crank, on both sides of the ground line."""
    g, c, b, r = 0.5, 0.2 + past, 0.6, 0.3
    toggle = crank_range_oracle(g, c, b, r)['folded']
    mech = fourbar(g, c, b, r, input=-0.4)
    got = motion.actuator_range(mech, 'crank')
    assert not got['full_turn']
    ends = sorted(math.remainder(t, 2 * math.pi) for t in got['toggles'])
    assert len(ends) == 2, got['toggles']
    # (the toggle moves as sqrt of the crank's excess there: rounding in the lengths' sums,
    # ~1e-17, moves it by up to ~1e-9 of itself at 2e-9)
    assert abs(ends[0] + toggle) < 1e-6 * toggle and abs(ends[1] - toggle) < 1e-6 * toggle, (
        ends,
        toggle,
    )
    extreme = math.pi - math.acos((g * g + r * r - (b - c) ** 2) / (2 * g * r))
    from linkage_ros.core.motion.quantities import input_sweep

    rocker = input_sweep(mech, ['link:rocker']).outputs['link:rocker']
    assert abs(rocker.maximum - extreme) < 1e-9 and abs(rocker.minimum + extreme) < 1e-9


def test_an_offset_slider_cranks_narrow_dead_zone_is_found():
    """An offset slider-crank whose offset exceeds rod - crank by 2e-7 m (crank 0.05, rod
    0.17, offset 0.1200002) cannot pass the crank angles where the crank pin is
    further than the rod from the slider's line (5.7e-3 rad about -pi/2): it was read as
    turning fully with no toggle. Oracle: sin(t) = (offset - rod) / crank at the toggles."""
    from scenes import slider_crank

    r, rod, e = 0.05, 0.17, 0.1200002
    mech = slider_crank(r, rod, e, input=1.0)
    got = motion.actuator_range(mech, 'crank')
    assert not got['full_turn']
    low = math.asin((e - rod) / r)
    ends = sorted(math.remainder(t, 2 * math.pi) for t in got['toggles'])
    want = sorted([low, math.remainder(math.pi - low, 2 * math.pi)])
    assert len(ends) == 2 and all(abs(a - w) < 1e-9 for a, w in zip(ends, want)), (ends, want)


@pytest.mark.parametrize(('short', 'crosses'), [(1e-14, True), (2e-10, False)])
def test_a_scan_crosses_a_change_point_where_a_sweep_does(short, crosses):
    """A crank-rocker 1e-14 inside its Grashof limit (crank 0.2 - 1e-14 against 0.5, 0.6, 0.3):
    `check` calls it a change point and a sweep crosses into the other sign there (a gap under
    ~1e-12 of the lengths is on it: docs/SCENES.md), but the scan took it as never reaching it,
    reading half its rocker's swing (a numerics reviewer). 2e-10 inside, neither crosses.
    Oracle: the rocker's extremes where |O2 B| = coupler - crank (cosine rule), on both sides
    of the ground line where the motion crosses, on the drawn side alone where it does not."""
    from linkage_ros.core.motion.quantities import input_sweep

    g, c, b, r = 0.5, 0.2 - short, 0.6, 0.3
    mech = fourbar(g, c, b, r, input=-0.4)
    extreme = math.pi - math.acos((g * g + r * r - (b - c) ** 2) / (2 * g * r))
    rocker = input_sweep(mech, ['link:rocker']).outputs['link:rocker']
    assert abs(rocker.maximum - extreme) < 1e-9
    if crosses:
        assert abs(rocker.minimum + extreme) < 1e-9, rocker.minimum
    else:
        assert rocker.minimum > 0, rocker.minimum  # (the drawn side of the ground line)
