"""Tests of the `linkage` command line (linkage_ros.cli).

main(argv) runs in-process (stdout/stderr captured with capsys); one subprocess call proves the
console script is installed. Numbers are checked against independent geometry written here
(circle intersection, Freudenstein's equation, the toggle-angle cosine rule), never against the
core's own formulas.
"""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from linkage_ros.cli import parser as cli_parser
from linkage_ros.cli.parser import main
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

# four-bar lengths (m): ground l1, crank l2, coupler l3, rocker l4
CR = dict(l1=0.4, l2=0.1, l3=0.35, l4=0.3)  # Grashof crank-rocker (crank shortest)
DR = dict(l1=0.4, l2=0.35, l3=0.1, l4=0.3)  # Grashof double-rocker (coupler shortest)
CP = dict(distance=0.2, angle=0.5)  # coupler point P of the crank-rocker

FOUR_BAR = f"""\
four_bar: {{ground: {CR['l1']}, crank: {CR['l2']}, coupler: {CR['l3']}, rocker: {CR['l4']},
           coupler_point: {{distance: {CP['distance']}, angle: {CP['angle']}}}}}
"""
DOUBLE_ROCKER = f"""\
four_bar: {{ground: {DR['l1']}, crank: {DR['l2']}, coupler: {DR['l3']}, rocker: {DR['l4']},
           input: 0.8}}
"""
SLIDER_CRANK = 'slider_crank: {crank: 0.1, rod: 0.3, offset: 0.02}\n'
# 2-DOF five-bar; T is a tool point on link l2 (a point that is not a joint)
FIVE_BAR = """\
name: five_bar
points: {O2: [0, 0], O5: [0.3, 0], A: [0.0, 0.15], P: [0.15, 0.3], B: [0.3, 0.15],
         T: [0.1, 0.35]}
links: {ground: [O2, O5], l1: [O2, A], l2: [A, P, T], l3: [P, B], l4: [O5, B]}
actuators:
  a1: {type: angle, link: l1, pivot: O2, toward: A}
  a2: {type: angle, link: l4, pivot: O5, toward: B}
"""
# one actuator for a 2-DOF chain: the scene must not load
FIVE_BAR_ONE_ACTUATOR = (
    FIVE_BAR.split('actuators:')[0]
    + """actuators:
  a1: {type: angle, link: l1, pivot: O2, toward: A}
"""
)


@pytest.fixture(scope='module')
def scenes(tmp_path_factory):
    d = tmp_path_factory.mktemp('scenes')
    out = {}
    for name, text in [
        ('four_bar', FOUR_BAR),
        ('double_rocker', DOUBLE_ROCKER),
        ('slider_crank', SLIDER_CRANK),
        ('five_bar', FIVE_BAR),
        ('bad_dof', FIVE_BAR_ONE_ACTUATOR),
    ]:
        p = d / f'{name}.yaml'
        p.write_text(text)
        out[name] = str(p)
    return out


def _no_nan(text):
    raise ValueError(f'non-finite number {text} in JSON output')


def loads(text):
    """json.loads that refuses NaN / Infinity."""
    return json.loads(text, parse_constant=_no_nan)


def run(capsys, *argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


# ---- independent geometry ----------------------------------------------------------------------


def circle_intersections(c1, r1, c2, r2):
    """Both intersections of two circles (or [] when they miss)."""
    dx, dy = c2[0] - c1[0], c2[1] - c1[1]
    d = math.hypot(dx, dy)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h2 = r1 * r1 - a * a
    if h2 < 0:
        return []
    h = math.sqrt(h2)
    mx, my = c1[0] + a * dx / d, c1[1] + a * dy / d
    return [(mx - h * dy / d, my + h * dx / d), (mx + h * dy / d, my - h * dx / d)]


def fourbar_B(theta2, l1, l2, l3, l4):
    a = (l2 * math.cos(theta2), l2 * math.sin(theta2))
    return a, circle_intersections(a, l3, (l1, 0.0), l4)


def freudenstein_residual(theta2, theta4, l1, l2, l3, l4):
    """K1 cos t4 - K2 cos t2 + K3 - cos(t2 - t4) = 0 for an assembled four-bar."""
    k1, k2 = l1 / l2, l1 / l4
    k3 = (l2**2 - l3**2 + l4**2 + l1**2) / (2 * l2 * l4)
    return k1 * math.cos(theta4) - k2 * math.cos(theta2) + k3 - math.cos(theta2 - theta4)


def cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def close(p, q, tol=1e-9):
    return math.hypot(p[0] - q[0], p[1] - q[1]) < tol


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


# ---- solve -------------------------------------------------------------------------------------

SCHEMA_KEYS = {
    'status',
    'reason',
    'inputs',
    'joints',
    'links',
    'points',
    'residual',
    'branch',
    'branch_defined',
    'margin',
    'solver',
    'iterations',
    'cond',
}


def test_solve_json_schema_and_values_match_independent_fourbar(capsys, scenes):
    theta2 = 0.5
    rc, out, err = run(capsys, 'solve', scenes['four_bar'], '--set', f'crank={theta2}', '--json')
    assert rc == 0 and err == ''
    d = loads(out)  # exactly one JSON object
    assert isinstance(d, dict) and set(d) >= SCHEMA_KEYS
    assert d['status'] == 'ok' and d['reason'] is None
    assert d['inputs'] == {'crank': theta2}
    assert set(d['links']) == {'ground', 'crank', 'coupler', 'rocker'}
    assert d['links']['coupler']['points'] == ['A', 'B', 'P']
    assert set(d['points']) == {'O2', 'A', 'B', 'O4', 'P'}
    assert d['residual'] < 1e-12 and d['branch'] == '+' and d['margin'] > 0
    assert d['solver'] == 'closed_form'

    l1, l2, l3, l4 = CR.values()
    a, bs = fourbar_B(theta2, l1, l2, l3, l4)
    assert close(d['points']['A'], a) and close(d['points']['O4'], (l1, 0.0))
    b = d['points']['B']
    assert any(close(b, c) for c in bs)
    # default branch 'reference': the '+' assembly, B left of the line A -> O4 (the reference pose)
    assert cross(a, (l1, 0.0), b) > 0
    t4 = d['links']['rocker']['angle']
    assert t4 == pytest.approx(math.atan2(b[1], b[0] - l1), abs=1e-12)
    assert abs(freudenstein_residual(theta2, t4, l1, l2, l3, l4)) < 1e-12
    t3 = math.atan2(b[1] - a[1], b[0] - a[0])
    assert d['links']['coupler']['angle'] == pytest.approx(t3, abs=1e-12)
    p = (
        a[0] + CP['distance'] * math.cos(t3 + CP['angle']),
        a[1] + CP['distance'] * math.sin(t3 + CP['angle']),
    )
    assert close(d['points']['P'], p)
    # revolute joint value = child angle - parent angle
    assert d['joints']['O4'] == pytest.approx(t4, abs=1e-12)
    assert d['joints']['B'] == pytest.approx(wrap(t4 - t3), abs=1e-12)


def test_solve_table_output(capsys, scenes):
    rc, out, err = run(capsys, 'solve', scenes['four_bar'], '--set', 'crank=30deg')
    assert rc == 0
    for word in (
        'status     ok',
        'inputs',
        'joints',
        'links',
        'points',
        'residual',
        'branch',
        'margin',
        'solver',
        'iterations',
        '30.00000 deg',
        '[A B P]',
    ):
        assert word in out
    assert '0.523598776 rad' in out  # 30deg was converted to radians


def test_all_branches_gives_two_distinct_assemblies(capsys, scenes):
    theta2 = 1.0
    rc, out, _ = run(
        capsys, 'solve', scenes['four_bar'], '--set', f'crank={theta2}', '--all-branches', '--json'
    )
    assert rc == 0
    modes = loads(out)
    assert isinstance(modes, list) and len(modes) == 2
    assert all(m['status'] == 'ok' for m in modes)
    assert {m['branch'] for m in modes} == {'+', '-'}
    _, bs = fourbar_B(theta2, *CR.values())
    got = [m['points']['B'] for m in modes]
    assert not close(got[0], got[1], 1e-6)
    for c in bs:  # each exact assembly appears once
        assert sum(close(g, c) for g in got) == 1


def test_inverse_solve_target_rocker_reproduces_it(capsys, scenes):
    l1, l2, l3, l4 = CR.values()
    theta4 = 1.9
    rc, out, _ = run(capsys, 'solve', scenes['four_bar'], '--target', f'rocker={theta4}', '--json')
    assert rc == 0
    d = loads(out)
    assert d['status'] == 'ok' and d['targets'] == {'rocker': theta4}
    theta2 = d['inputs']['crank']
    # independent check: with this crank, |A B| = coupler where B is the rocker tip at theta4
    a = (l2 * math.cos(theta2), l2 * math.sin(theta2))
    b = (l1 + l4 * math.cos(theta4), l4 * math.sin(theta4))
    assert math.hypot(b[0] - a[0], b[1] - a[1]) == pytest.approx(l3, abs=1e-12)
    assert abs(freudenstein_residual(theta2, theta4, l1, l2, l3, l4)) < 1e-12
    # and the forward solve at that crank (same branch) gives the rocker back
    rc, out, _ = run(
        capsys,
        'solve',
        scenes['four_bar'],
        '--set',
        f'crank={theta2!r}',
        '--branch',
        d['branch'],
        '--json',
    )
    assert rc == 0
    assert loads(out)['links']['rocker']['angle'] == pytest.approx(theta4, abs=1e-9)


def test_target_point_on_five_bar(capsys, scenes):
    target = (0.12, 0.33)
    rc, out, _ = run(
        capsys,
        'solve',
        scenes['five_bar'],
        '--target-point',
        f'T={target[0]},{target[1]}',
        '--json',
    )
    assert rc == 0
    d = loads(out)
    assert d['status'] == 'ok' and d['targets'] == {'point:T': list(target)}
    pts = d['points']
    assert close(pts['T'], target)
    # link lengths from the reference pose are preserved
    ref = {
        'O2': (0, 0),
        'O5': (0.3, 0),
        'A': (0.0, 0.15),
        'P': (0.15, 0.3),
        'B': (0.3, 0.15),
        'T': (0.1, 0.35),
    }
    for u, v in [('O2', 'A'), ('A', 'P'), ('A', 'T'), ('P', 'T'), ('P', 'B'), ('O5', 'B')]:
        assert math.dist(pts[u], pts[v]) == pytest.approx(math.dist(ref[u], ref[v]), abs=1e-12)
    a1, a2 = d['inputs']['a1'], d['inputs']['a2']
    assert a1 == pytest.approx(math.atan2(pts['A'][1], pts['A'][0]), abs=1e-12)
    assert a2 == pytest.approx(math.atan2(pts['B'][1], pts['B'][0] - 0.3), abs=1e-12)
    # forward solve with the actuator values found, in the answer's assembly mode (its branch:
    # the forward dyads' signs), puts T on the target
    rc, out, _ = run(
        capsys,
        'solve',
        scenes['five_bar'],
        '--set',
        f'a1={a1!r}',
        '--set',
        f'a2={a2!r}',
        '--branch',
        d['branch'],
        '--json',
    )
    assert rc == 0 and close(loads(out)['points']['T'], target)


def test_unreachable_input_is_refused_without_nan(capsys, scenes):
    rc, out, err = run(capsys, 'solve', scenes['double_rocker'], '--set', 'crank=2.0', '--json')
    assert rc == 1
    d = loads(out)  # raises on NaN / Infinity
    assert d['status'] == 'error' and d['reason'] and 'assemble' in d['reason']
    assert d['points'] == {} and d['inputs'] == {'crank': 2.0}
    rc, out, _ = run(capsys, 'solve', scenes['double_rocker'], '--set', 'crank=2.0')
    assert rc == 1 and 'status     error' in out and 'reason' in out and 'nan' not in out.lower()


def test_one_coordinate_and_a_link_angle_place_the_loader_bin(capsys):
    """Seed 003: the bin by its hinge's x and its angle, the y decided; the coordinate is a
    length (a unit of angle is refused, naming it)."""
    rc, out, err = run(
        capsys, 'solve', 'front_loader', '--target', 'D.x=2200mm', '--target', 'bin=2.3', '--json'
    )
    assert rc == 0, err
    d = loads(out)
    assert d['status'] == 'ok' and d['targets'] == {'D.x': 2.2, 'bin': 2.3}
    assert d['points']['D'][0] == pytest.approx(2.2, abs=1e-12)
    assert math.remainder(d['links']['bin']['angle'] - 2.3, 2 * math.pi) == pytest.approx(
        0.0, abs=1e-12
    )
    rigid = [('C', 'D'), ('C', 'T'), ('D', 'T'), ('O4', 'C'), ('E', 'D')]
    ref = {
        'O4': (0.0, 1.9),
        'C': (2.7893, 2.144),
        'D': (2.8393, 2.644),
        'T': (3.7393, 1.794),
        'E': (2.0623, 1.9643),
    }
    for u, v in rigid:  # the links' lengths, from the scene's drawing
        assert math.dist(d['points'][u], d['points'][v]) == pytest.approx(
            math.dist(ref[u], ref[v]), abs=1e-12
        )
    rc, _, err = run(
        capsys, 'solve', 'front_loader', '--target', 'D.x=30deg', '--target', 'bin=2.3'
    )
    assert rc == 2 and "'D.x' is a length" in err
    # both coordinates of one point are the point, as the node takes them: the closed form
    xy = d['points']['D']
    rc, out, _ = run(
        capsys, 'solve', 'front_loader', '--target-point', f'D={xy[0]},{xy[1]}', '--json'
    )
    as_point = loads(out)
    rc2, out, _ = run(
        capsys, 'solve', 'front_loader', '--target', f'D.x={xy[0]}', '--target', f'D.y={xy[1]}',
        '--json',
    )  # fmt: skip
    as_pair = loads(out)
    assert rc == rc2 == 0 and as_pair['solver'] == as_point['solver'] == 'closed_form'
    assert as_pair['inputs'] == as_point['inputs'] and as_pair['margin'] == as_point['margin']


def test_unreachable_target_is_refused(capsys, scenes):
    rc, out, _ = run(capsys, 'solve', scenes['four_bar'], '--target', 'rocker=0.2', '--json')
    assert rc == 1
    d = loads(out)
    assert d['status'] == 'error' and d['reason'] and d['targets'] == {'rocker': 0.2}


def test_solve_keeps_the_reference_mode_and_any_mode_allows_the_other(capsys):
    """four_bar: B = -1.2 is reached only in the other assembly mode (issue 19): refused by
    default naming the mode; --any-mode solves it and says the mode changed."""
    rc, out, _ = run(capsys, 'solve', 'four_bar', '--target', 'B=-1.2', '--json')
    d = loads(out)
    assert rc == 1 and d['reason'].startswith('target is reachable only in assembly mode -')
    assert '--any-mode on the command line' in d['reason']  # the flag that allows it, named
    rc, out, _ = run(capsys, 'solve', 'four_bar', '--target', 'B=-1.2', '--any-mode', '--json')
    d = loads(out)
    assert rc == 0 and d['mode_change'] == '+ -> -'
    assert abs(math.remainder(d['joints']['B'] + 1.2, 2 * math.pi)) < 1e-9
    rc, _, err = run(capsys, 'solve', 'four_bar', '--set', 'crank=1', '--any-mode')
    assert rc == 2 and '--any-mode' in err


def test_solve_answers_excavator_targets_taken_from_in_limit_configurations(capsys):
    """Issue 19: `linkage solve excavator --target ...` with three link/joint/actuator values
    read off an in-limits forward solve was refused in 4 of 60 cases ("target needs Z1 = 0.893 m
    is below its minimum") although the source configuration is a solution within limits: the
    inverse plan's own branch landed elsewhere. Every such target must now be solved, at a
    configuration that has the target values, within limits, in the reference mode, or be
    refused for not determining the mechanism (an honest reason)."""
    import random

    from linkage_ros.core.model import Scene
    from linkage_ros.core.solver import Solver
    from linkage_ros.resources import scene_path

    mech = Scene.from_yaml(scene_path('excavator')).mechanism
    fwd = Solver(mech, branch='reference')
    ref_mode = fwd.solve(fwd.reference_values()).branch
    rng = random.Random('cli-excavator-targets')
    acts = list(mech.actuators)
    every = list(mech.joint_names) + list(mech.links) + acts
    names = [n for n in dict.fromkeys(every) if n != mech.ground]  # a cylinder is both
    solved = 0
    for _ in range(100):
        cmd = {}
        for a in acts:
            s = next(sp for sp in fwd.specs if sp.name == a)
            cmd[a] = rng.uniform(s.minimum, s.maximum)
        f = fwd.solve(cmd, commit=False)
        if not f.success or f.branch != ref_mode:
            continue
        picked = rng.sample(names, 3)
        argv = ['solve', 'excavator', '--json']
        for n in picked:
            v = f.links[n] if n in mech.links else (f.inputs[n] if n in acts else f.joints[n])
            argv += ['--target', f'{n}={v!r}']
        rc, out, err = run(capsys, *argv)
        if rc == 2:  # name sets that fix no configuration are refused when the solver is made
            assert 'do not determine' in err or 'over-constrains' in err, (picked, err)
            continue
        d = loads(out)
        assert rc == 0, (picked, d['reason'])
        solved += 1
        for n in picked:
            got = (
                d['links'][n]['angle']
                if n in mech.links
                else (d['inputs'][n] if n in acts else d['joints'][n])
            )
            want = f.links[n] if n in mech.links else (f.inputs[n] if n in acts else f.joints[n])
            assert abs(math.remainder(got - want, 2 * math.pi)) < 1e-9, (n, got, want)
        for s in fwd.specs:  # within limits
            assert s.minimum - 1e-12 <= d['inputs'][s.name] <= s.maximum + 1e-12
    assert solved >= 40, solved


# ---- sweep -------------------------------------------------------------------------------------


def _toggles(l1, l2, l3, l4):
    """Input angles (upper half-plane) at which coupler and rocker are folded / extended."""

    def opposite(d):
        return math.acos((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2))

    return opposite(abs(l3 - l4)), opposite(l3 + l4)


def test_sweep_line_count_includes_error_lines(capsys, scenes):
    rc, out, err = run(capsys, 'sweep', scenes['double_rocker'], '--set', 'crank=0:3:7', '--json')
    assert rc == 0  # the sweep ran: errors are lines
    lines = [loads(x) for x in out.splitlines()]
    assert len(lines) == 7
    lo, hi = _toggles(*DR.values())
    for i, (line, theta) in enumerate(zip(lines, [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])):
        assert line['index'] == i and line['command'] == {'crank': pytest.approx(theta)}
        assert line['status'] == ('ok' if lo < theta < hi else 'error')
        if line['status'] == 'error':
            assert line['reason']
    assert '7 command(s), 1 ok, 6 error(s)' in err
    # table form: same number of rows (+ a header), errors carry their reason
    rc, out, _ = run(capsys, 'sweep', scenes['double_rocker'], '--set', 'crank=0:3:7')
    rows = out.splitlines()
    assert rc == 0 and len(rows) == 8 and rows[0].startswith('#')
    assert sum('\terror\t' in r for r in rows) == 6
    # --strict: any error line makes the exit status 1
    rc, _, _ = run(capsys, 'sweep', scenes['double_rocker'], '--set', 'crank=0:3:7', '--strict')
    assert rc == 1


def test_sweep_grid_of_two_ranges_first_range_slowest(capsys, scenes):
    rc, out, _ = run(
        capsys, 'sweep', scenes['five_bar'], '--set', 'a1=0.5:1.5:3', '--set', 'a2=1:2:4', '--json'
    )
    assert rc == 0
    lines = [loads(x) for x in out.splitlines()]
    assert len(lines) == 12
    expect = [(a1, a2) for a1 in (0.5, 1.0, 1.5) for a2 in (1.0, 4 / 3, 5 / 3, 2.0)]
    for line, (a1, a2) in zip(lines, expect):
        assert line['command']['a1'] == pytest.approx(a1)
        assert line['command']['a2'] == pytest.approx(a2)
        assert line['status'] == 'ok'
        assert line['inputs']['a1'] == pytest.approx(a1)
        assert line['inputs']['a2'] == pytest.approx(a2)
    # the grid axis order follows the command line
    rc, out, _ = run(
        capsys, 'sweep', scenes['five_bar'], '--set', 'a2=1:2:4', '--set', 'a1=0.5:1.5:3', '--json'
    )
    first = [loads(x)['command'] for x in out.splitlines()[:3]]
    assert [c['a2'] for c in first] == [1.0, 1.0, 1.0]


def test_inverse_sweep_over_target_range(capsys, scenes):
    rc, out, _ = run(capsys, 'sweep', scenes['four_bar'], '--target', 'rocker=1.8:2.0:3', '--json')
    assert rc == 0
    lines = [loads(x) for x in out.splitlines()]
    assert len(lines) == 3
    l1, l2, l3, l4 = CR.values()
    for line in lines:
        t4 = line['command']['rocker']
        assert line['status'] == 'ok' and line['targets'] == {'rocker': t4}
        assert abs(freudenstein_residual(line['inputs']['crank'], t4, l1, l2, l3, l4)) < 1e-12


# ---- check -------------------------------------------------------------------------------------


def test_check_crank_rocker(capsys, scenes):
    rc, out, _ = run(capsys, 'check', scenes['four_bar'], '--json')
    assert rc == 0
    d = loads(out)
    assert d['dof'] == 1 and d['n_links'] == 4 and d['n_joints'] == 4
    assert d['dof_matches_actuators'] is True
    assert d['inputs']['crank']['min'] is None and d['inputs']['crank']['max'] is None
    assert d['grashof']['class'] == 'crank-rocker' and d['grashof']['input_fully_rotates']
    assert d['links']['coupler'] == ['A', 'B', 'P']
    assert d['joints']['B'] == {
        'type': 'revolute',
        'point': 'B',
        'parent': 'coupler',
        'child': 'rocker',
    }
    plan = d['plan']
    assert plan['mode'] == 'closed_form' and plan['newton_links'] == []
    assert set(plan['closed_form_links']) == {'crank', 'coupler', 'rocker'}
    assert any('RRR' in s for s in plan['closed_form_steps'])
    rc, out, _ = run(capsys, 'check', scenes['four_bar'])
    assert rc == 0
    for word in ('Kutzbach', '1 DOF', 'crank-rocker', 'unlimited', 'placed by Newton'):
        assert word in out


def test_check_names_a_crank_rocker_whose_output_is_the_crank(capsys, tmp_path):
    """Seed 000's crank-rocker turns its input: with the shortest link the output (rocker 20 of
    50 / 45 / 60 / 20) the input rocks and the output is the crank, and check says so."""
    scene = tmp_path / 'rc.yaml'
    scene.write_text(
        'name: rc\nfour_bar: {ground: 50, crank: 45, coupler: 60, rocker: 20, input: 100deg}\n'
    )
    rc, out, _ = run(capsys, 'check', scene)
    (line,) = [ln for ln in out.splitlines() if ln.startswith('grashof')]
    assert rc == 0 and 'its output the crank (a rocker-crank)' in line
    assert 'input fully rotates: no, output fully rotates: yes' in line


LOADER_WIDE = """name: loader
points:
  O2: [1.0, 0.5]
  O4: [0.0, 2.0]
  O7: [0.2, 2.5]
  A: [0.9, 1.9]
  B: [2.0, 2.6]
  C: [3.0, 2.2]
  E: [2.2, 2.0]
  F: [1.9, 3.1]
  D: [3.05, 2.75]
  T: [3.9, 1.9]
links:
  ground: [O2, O4, O7]
  boom: [O4, A, B, C]
  bell: [B, E, F]
  tilt: [E, D]
  bin: [C, D, T]
cylinders:
  Z1: {from: O2, to: A, min: 0.8, max: 2.6}
  Z2: {from: O7, to: F, min: 1.2, max: 2.6}
"""


def test_a_target_with_a_twin_in_its_mode_names_the_twin(capsys, tmp_path):
    """Seed 003: given D.x and the bin's angle, "D.y will be automatically decided", but a
    Newton inverse has two such solutions in one mode (either side of D.x's extreme): the
    answer is one, and a note names the other. Checked by the closed-form forward solve at the
    note's cylinder lengths: D.x and the bin angle are the target's, D.y differs."""
    import re

    scene = tmp_path / 'loader.yaml'
    scene.write_text(LOADER_WIDE)
    rc, out, err = run(
        capsys, 'solve', scene, '--target', 'D.x=3.1', '--target', 'bin=70deg', '--json'
    )
    assert rc == 0
    answer = json.loads(out)
    (note,) = [ln for ln in err.splitlines() if 'another solution' in ln]
    assert f'assembly mode {answer["branch"]}' in note and '--all-branches' in note
    twin = {k: float(v) for k, v in re.findall(r'(Z\d) = ([-0-9.e]+)', note)}
    assert set(twin) == {'Z1', 'Z2'}
    mech = Scene.from_yaml(scene).mechanism
    r = Solver(mech, branch=answer['branch']).solve(twin, commit=False)
    assert r.success
    assert r.points['D'][0] == pytest.approx(3.1, abs=1e-7)  # (the note's 9 digits)
    assert math.degrees(r.links['bin']) == pytest.approx(70.0, abs=1e-5)
    assert abs(r.points['D'][1] - answer['points']['D'][1]) > 0.1


def test_check_double_rocker_limits_are_the_toggle_angles(capsys, scenes):
    rc, out, _ = run(capsys, 'check', scenes['double_rocker'], '--json')
    assert rc == 0
    d = loads(out)
    assert d['grashof']['class'] == 'grashof-double-rocker'
    lo, hi = _toggles(*DR.values())  # the reference pose (input 0.8) is on this circuit
    assert d['inputs']['crank']['min'] == pytest.approx(lo, abs=1e-9)
    assert d['inputs']['crank']['max'] == pytest.approx(hi, abs=1e-9)


def test_check_five_bar_newton_plan_and_slider_crank(capsys, scenes):
    rc, out, _ = run(capsys, 'check', scenes['five_bar'], '--solver', 'newton', '--json')
    d = loads(out)
    assert rc == 0 and d['dof'] == 2 and set(d['inputs']) == {'a1', 'a2'}
    assert d['grashof'] is None
    assert d['plan']['mode'] == 'newton'
    assert set(d['plan']['newton_links']) == {'l1', 'l2', 'l3', 'l4'}
    rc, out, _ = run(capsys, 'check', scenes['slider_crank'], '--json')
    d = loads(out)
    assert rc == 0 and d['joints']['slider']['type'] == 'prismatic'


# ---- usage errors ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    'argv,needle',
    [
        (['solve', '{missing}', '--set', 'crank=1'], 'not found'),
        (['solve', '{four_bar}', '--set', 'crank'], 'NAME=VALUE'),
        (['solve', '{four_bar}', '--set', 'crank=abc'], "'abc' is not a number"),
        (['solve', '{four_bar}', '--set', 'crank=nan'], 'finite'),
        (['solve', '{four_bar}', '--set', 'cranky=1'], "'cranky' is not an actuator"),
        (['solve', '{four_bar}', '--target', 'nosuch=1'], "unknown name 'nosuch'"),
        (['solve', '{four_bar}', '--target-point', 'crank=1,2'], "'crank' is not a point"),
        (['solve', '{four_bar}', '--set', 'crank=0:1:3'], 'sweep'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--set', 'crank=2'], 'given twice'),
        (['solve', '{four_bar}'], 'nothing to solve'),
        (['solve', '{five_bar}', '--set', 'a1=1'], 'missing --set for actuator(s) a2'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--branch', 'sideways'], 'branch'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--branch', '++'], 'branching dyad'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--tol', '-1'], 'tolerance'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--solver', 'magic'], 'invalid choice'),
        (['sweep', '{four_bar}', '--set', 'crank=0:1:0'], 'COUNT must be >= 1'),
        (['sweep', '{four_bar}', '--set', 'crank=0:1:x'], 'not an integer'),
        (['check', '{bad_dof}'], 'degree(s) of freedom'),
        (['solve'], 'SCENE'),
        (['frobnicate'], 'invalid choice'),
    ],
)
def test_usage_errors_exit_2_with_one_line(capsys, scenes, tmp_path, argv, needle):
    names = dict(scenes, missing=str(tmp_path / 'nope.yaml'))
    rc, out, err = run(capsys, *[a.format(**names) for a in argv])
    assert rc == 2
    assert out == ''
    assert err.count('\n') == 1 and err.startswith('linkage') and 'error' in err
    assert needle in err
    assert 'Traceback' not in err


def test_help(capsys):
    rc, out, _ = run(capsys, '--help')
    assert rc == 0 and all(c in out for c in ('solve', 'sweep', 'check'))
    for sub, word in (('solve', '--target-point'), ('sweep', 'slowest'), ('check', 'Kutzbach')):
        rc, out, _ = run(capsys, sub, '--help')
        assert rc == 0 and word in out


# ---- plug-in subcommands -----------------------------------------------------------------------


def test_external_commands_register_when_importable(capsys, tmp_path, monkeypatch):
    (tmp_path / 'cli_plugin_ok.py').write_text(
        '"""Say hello."""\n'
        'def add_arguments(p):\n    p.add_argument("who")\n'
        'def run(args):\n    print("hello", args.who)\n    return 0\n'
    )
    (tmp_path / 'cli_plugin_broken.py').write_text('import no_such_dependency_xyz\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(
        cli_parser,
        'EXTERNAL_COMMANDS',
        {'hello': 'cli_plugin_ok', 'broken': 'cli_plugin_broken', 'absent': 'cli_plugin_absent'},
    )
    rc, out, _ = run(capsys, 'hello', 'world')
    assert rc == 0 and out == 'hello world\n'
    rc, out, _ = run(capsys, '--help')
    assert 'hello' in out and 'unavailable: broken' in out and 'absent' not in out
    rc, out, err = run(capsys, 'broken')
    assert rc == 2 and 'no_such_dependency_xyz' in err


# ---- the installed console script -------------------------------------------------------------


def test_console_script_is_installed(scenes):
    exe = Path(sys.executable).parent / 'linkage'
    assert exe.exists(), f'console script not installed next to {sys.executable}'
    proc = subprocess.run(
        [str(exe), 'solve', scenes['four_bar'], '--set', 'crank=0.5', '--json'],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    assert loads(proc.stdout)['status'] == 'ok'


@pytest.mark.parametrize(
    'scene,line',
    [
        (
            'inverted_slider_crank_oscillating',
            'grashof    3R-1P non-grashof: lmin + e = 0.34 > lmax = 0.3 (input fully rotates: no, '
            'output fully rotates: no)',
        ),
        (
            'slider_crank',
            'grashof    3R-1P grashof: lmin + e = 0.06 < lmax = 0.18 (input fully rotates: yes)',
        ),
        (
            'four_bar',
            'grashof    4R crank-rocker: s + l = 0.4 < p + q = 0.45 (input fully rotates: '
            'yes, output fully rotates: no)',
        ),
    ],
)
def test_check_prints_the_chain_class_line(capsys, scene, line):
    """Lecture 003 example 5 'first verifies that this is a non-Grashof 3R-1P linkage':
    lmin + e = 0.20 + 0.14 > lmax = 0.30 (the scene file's dimensions)."""
    rc, out, _ = run(capsys, 'check', scene)
    assert rc == 0
    assert line in out.splitlines()
    rc, out, _ = run(capsys, 'check', scene, '--json')
    d = loads(out)
    assert d['grashof']['chain'] == line.split()[1]


def test_check_has_no_chain_class_for_multi_loop_scenes(capsys):
    rc, out, _ = run(capsys, 'check', 'excavator', '--json')
    assert rc == 0 and loads(out)['grashof'] is None


def test_ctrl_c_is_one_line_and_exit_130(capsys, monkeypatch):
    """Ctrl-C during a command (here inside the check) ends with the shell's SIGINT status and
    one line on stderr, not a traceback."""
    from linkage_ros.cli import check

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(check, 'check_report', interrupted)
    rc, out, err = run(capsys, 'check', 'four_bar')
    assert rc == 130
    assert err.strip() == 'linkage check: interrupted' and 'Traceback' not in err


def test_a_refused_sweep_row_keeps_its_commanded_input(capsys, tmp_path):
    """A double-rocker swept past its limits: the refused rows' CSV keeps the crank value it
    was commanded (as linkage bag's CSV does; it was empty, so which command failed showed only
    by its index), the joints empty; the answered rows are as before."""
    import csv as _csv

    out = tmp_path / 'dr.csv'
    rc, _, err = run(
        capsys, 'sweep', 'four_bar_grashof_double_rocker', '--set', 'crank=0:2:5', '--csv', out
    )
    assert rc == 0 and '3 ok, 2 error(s)' in err, err
    rows = list(_csv.DictReader(out.open()))
    assert [r['status'] for r in rows] == ['error', 'ok', 'ok', 'ok', 'error']
    assert [float(r['input.crank']) for r in rows] == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert rows[0]['joint.O4'] == rows[4]['joint.O4'] == ''
    assert 'minimum' in rows[0]['reason'] and 'maximum' in rows[4]['reason']


def test_sweep_csv_is_the_actuator_trajectory_of_a_path(capsys, tmp_path):
    """`linkage sweep --target-point L=... --target bucket=... --csv FILE`: the CSV's actuator
    values, solved forward, put the lip L on the path (what a controller would be fed)."""
    import csv as _csv

    from linkage_ros.core.model import Scene
    from linkage_ros.core.solver import Solver
    from linkage_ros.resources import scene_path

    out = tmp_path / 'throws.csv'
    rc, _, err = run(
        capsys,
        'sweep',
        'excavator',
        '--target-point',
        'L=2.0,-0.2:2.3,-0.4:7',
        '--target',
        'bucket=-0.9',
        '--csv',
        out,
    )
    assert rc == 0 and '7 ok' in err
    rows = list(_csv.DictReader(out.open()))
    mech = Scene.from_yaml(scene_path('excavator')).mechanism
    fwd = Solver(mech)
    assert [r['index'] for r in rows] == [str(i) for i in range(7)]
    for k, row in enumerate(rows):
        assert row['status'] == 'ok'
        r = fwd.solve({a: float(row[f'input.{a}']) for a in mech.actuators})
        want = (2.0 + 0.3 * k / 6, -0.2 - 0.2 * k / 6)
        assert math.dist(r.points['L'], want) < 1e-9 * mech.length_scale
        for j in mech.joint_names:
            assert abs(math.remainder(float(row[f'joint.{j}']) - r.joints[j], 2 * math.pi)) < 1e-9
    rc, _, err = run(
        capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', tmp_path / 'no' / 'x.csv'
    )
    assert rc == 2 and 'folder' in err and 'does not exist' in err
    assert '0\t0' not in capsys.readouterr().out  # refused before any solve


@pytest.mark.skipif(not Path('/dev/full').exists(), reason='needs /dev/full')
@pytest.mark.parametrize(
    'argv', [['solve', 'four_bar', '--set', 'crank=1'], ['check', 'four_bar'], ['urdf', 'four_bar']]
)
def test_a_standard_output_that_cannot_be_written_is_one_error_line(argv):
    """stdout on a full disk (/dev/full): one line naming it and exit 2 (a usage error), not
    a traceback with exit 1 (which says 'solve refused')."""
    exe = Path(sys.executable).parent / 'linkage'
    with open('/dev/full', 'w') as full:
        proc = subprocess.run(
            [str(exe), *argv], stdout=full, stderr=subprocess.PIPE, text=True, timeout=60
        )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().endswith('cannot write standard output: No space left on device')
    assert 'Traceback' not in proc.stderr and proc.stderr.count('\n') == 1, proc.stderr


def test_sweep_csv_is_written_whole_when_the_reader_stops_early(scenes, tmp_path):
    """`linkage sweep ... --csv FILE | head -1`: the reader stopping ends the table, not the
    sweep: the CSV is written with every row (it was lost, with exit 0 and no word)."""
    exe = Path(sys.executable).parent / 'linkage'
    out = tmp_path / 'p.csv'
    cmd = [str(exe), 'sweep', scenes['four_bar'], '--set', 'crank=0:6:5000', '--csv', str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()  # as `| head -1` does
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    assert first.startswith(b'#\tcrank') and '5000 command(s)' in err, err
    with out.open() as fh:
        assert sum(1 for _ in fh) == 5001  # the header and every row


def test_check_prints_declared_limits_beside_a_tighter_computed_range(capsys, tmp_path):
    """Issue 18: `linkage check` replaced a declared limit by a tighter computed one without
    saying so. The reachable range of this non-Grashof crank (the toggle angles, from the cosine
    rule written here) is printed with the declared limits beside it, in text and JSON."""
    scene = tmp_path / 'wide.yaml'
    scene.write_text(
        'name: wide\nfour_bar: {ground: 0.30, crank: 0.20, coupler: 0.25, rocker: 0.22,\n'
        '           input: 1.0, crank_limits: {min: -3.0, max: 3.0}}\n'
    )
    l1, l2, l3, l4 = 0.30, 0.20, 0.25, 0.22
    toggle = math.acos((l1 * l1 + l2 * l2 - (l3 + l4) ** 2) / (2 * l1 * l2))
    rc, out, _ = run(capsys, 'check', scene, '--json')
    d = loads(out)['inputs']['crank']
    assert rc == 0 and d['declared_min'] == -3.0 and d['declared_max'] == 3.0
    assert d['min'] == pytest.approx(-toggle, abs=1e-9) and d['max'] == pytest.approx(
        toggle, abs=1e-9
    )
    rc, out, _ = run(capsys, 'check', scene)
    (line,) = [ln for ln in out.splitlines() if ln.strip().startswith('crank    angle')]
    assert '[reachable range, computed; declared limits: min -3  max 3]' in line, line
    rc, out, _ = run(capsys, 'check', 'four_bar')  # nothing computed: nothing added
    assert 'declared limits' not in out


def test_check_warns_about_a_reference_pose_drawn_at_a_toggle(capsys, tmp_path):
    """Issue 18: a drawing at a toggle (coupler and rocker stretched out in line: the circles
    about A and O4 touch, 0.15 + 0.15 = |A O4| = 0.3) loaded silently, its assembly mode left to
    rounding. `linkage check` warns naming the dyad; a drawing off the toggle gets no warning."""
    scene = tmp_path / 'flat.yaml'
    text = (
        'name: flat\n'
        'points: {{O2: [0, 0], A: [0.1, 0], B: [0.25, {y}], O4: [0.4, 0]}}\n'
        'links: {{ground: [O2, O4], crank: [O2, A], coupler: [A, B], rocker: [O4, B]}}\n'
        'actuators: {{crank: {{type: angle, link: crank, pivot: O2}}}}\n'
    )
    scene.write_text(text.format(y=0))
    rc, out, _ = run(capsys, 'check', scene, '--json')
    (warning,) = loads(out)['warnings']
    assert rc == 0 and 'at the toggle of RRR dyad: B from circles about A' in warning
    rc, out, _ = run(capsys, 'check', scene)
    assert 'warning    the reference pose is at the toggle' in out
    scene.write_text(text.format(y=0.05))
    rc, out, _ = run(capsys, 'check', scene, '--json')
    assert rc == 0 and loads(out)['warnings'] == []


def test_check_prints_the_motion_of_a_one_input_mechanism(capsys):
    """`linkage check` (text and JSON): the rocker's swing with the crank angles at its ends,
    the time ratio and the transmission angle extremes (their values are checked against the
    closed forms in test_quantities)."""
    rc, out, _ = run(capsys, 'check', 'four_bar', '--json')
    m = loads(out)['motion']
    assert rc == 0 and m['actuator'] == 'crank' and m['full_turn'] is True
    rocker = m['outputs']['link:rocker']
    assert rocker['stroke'] == pytest.approx(rocker['max'] - rocker['min'])
    assert rocker['time_ratio'] > 1.0
    mu = m['transmission_angle']['A-B-O4']
    assert 0 < mu['min'] < mu['max'] < math.pi
    rc, out, _ = run(capsys, 'check', 'four_bar')
    assert 'motion     crank over a full turn' in out
    assert '  rocker (angle)  min ' in out and 'time ratio ' in out
    assert '  transmission angle A-B-O4  min ' in out
    rc, out, _ = run(capsys, 'check', 'excavator', '--json')
    assert loads(out)['motion'] is None


def test_range_motion_gives_what_check_gives(capsys):
    rc, out, _ = run(capsys, 'range', 'quick_return', '--motion', '--json')
    motion = loads(out)['motion']
    rc2, out2, _ = run(capsys, 'check', 'quick_return', '--json')
    assert rc == rc2 == 0 and motion == loads(out2)['motion']
    rc, out, _ = run(capsys, 'range', 'quick_return', '--motion')
    assert 'lever (angle)  min ' in out and 'time ratio 1.55215' in out
    rc, _, err = run(capsys, 'range', 'excavator', '--motion')
    assert rc == 2 and '--motion needs a scene with one actuator' in err
