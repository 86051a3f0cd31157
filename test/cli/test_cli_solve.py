"""`linkage solve`: forward and inverse solves, the assembly modes and the refusals.

main(argv) runs in-process (stdout/stderr captured with capsys). Numbers are checked against
independent geometry written here and in cli_helpers (circle intersection, Freudenstein's
equation), never against the core's own formulas.
"""

import json
import math

import pytest
import yaml
from cli_helpers import CP, CR, freudenstein_residual, loads, run
from scenes import CONFIG

from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

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
    # no branch, so neither defined nor undefined (it said true beside an empty branch)
    assert d['branch'] == '' and d['branch_defined'] is None and d['margin'] is None
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
        'D': (2.5823, 2.6019),
        'T': (3.7869, 2.3165),
        'E': (1.8024, 1.9255),
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
    default naming the mode (a crank-rocker's other sign is another circuit: seed 000, 'you
    can never go from one curve to the other'); --any-mode solves it and says the mode
    changed."""
    rc, out, _ = run(capsys, 'solve', 'four_bar', '--target', 'B=-1.2', '--json')
    d = loads(out)
    assert rc == 1 and d['reason'].startswith(
        'target is reachable only in another circuit of the mechanism (signs -'
    )
    assert (
        'linkage solve --any-mode' in d['reason']
    )  # the flag that allows it, named (sweep has none)
    rc, out, _ = run(capsys, 'solve', 'four_bar', '--target', 'B=-1.2', '--any-mode', '--json')
    d = loads(out)
    assert rc == 0 and d['mode_change'] == '+ -> - (another circuit)'
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


def test_a_mode_whose_circles_coincide_says_why_its_branch_is_undefined(capsys):
    """Peaucellier's mode +++ folds the cell shut (A on B): the dyad placing Q then has two
    coincident circles and Q may turn about them. The answer says so, not 'at a toggle'."""
    rc, out, _ = run(capsys, 'solve', 'peaucellier', '--set', 'crank=0.3', '--branch', '+++')
    assert rc == 0
    pts = {
        line.split()[0]: complex(float(line.split()[1]), float(line.split()[2]))
        for line in out.split('points', 1)[1].splitlines()[1:7]
    }
    assert abs(pts['A'] - pts['B']) < 1e-12  # the cell folded shut
    assert 'branch     +++  (undefined: at a toggle, or where two circles coincide' in out


def test_the_loader_assignment_on_the_command_line_holds_z1_where_it_is_drawn(capsys):
    """Seed 003's assignment as the lecture states it: "Z1 is held fixed ... Z2 to
    three-fourths of its present value". `linkage check` gives the drawn (present) values; a
    solve that sets Z2 alone holds Z1 at its drawn value (a note says so), as the node holds an
    actuator a command leaves out: the answer is the full command's. It was refused as
    'missing --set for actuator(s) Z1' (an outside reviewer's find)."""
    rc, out, _ = run(capsys, 'check', 'front_loader', '--json')
    assert rc == 0
    drawn = {a: v['drawn'] for a, v in loads(out)['inputs'].items()}
    z2 = 0.75 * drawn['Z2']
    rc, out, err = run(capsys, 'solve', 'front_loader', '--set', f'Z2={z2!r}', '--json')
    assert rc == 0 and f'note: Z1 held at its drawn value {drawn["Z1"]:.9g} m' in err, err
    held = loads(out)
    rc, out, _ = run(
        capsys, 'solve', 'front_loader', '--set', f"Z1={drawn['Z1']!r}", '--set', f'Z2={z2!r}',
        '--json',
    )  # fmt: skip
    full = loads(out)
    assert held['status'] == full['status'] == 'ok'
    assert held['inputs'] == full['inputs'] and held['points'] == full['points']
    rc, out, _ = run(capsys, 'check', 'front_loader')
    assert f'drawn {drawn["Z2"]:.9g}' in out


TOGGLE_CLAMP = """\
name: toggle_clamp
points:
  O1: [0.0, 0.0]
  O2: [0.05, 0.0]
  A: [0.02, 0.0]
  B: {distances: {A: 0.04, O2: 0.025}, side: left}
  T: [0.15, 0.02]
links:
  ground: [O1, O2]
  handle: [O1, A]
  link: [A, B]
  arm: [O2, B, T]
actuators:
  handle: {type: angle, link: handle, pivot: O1, toward: A, min: -0.9, max: 0.47}
"""


def test_a_closed_form_target_with_a_twin_in_its_mode_names_the_twin(capsys, tmp_path):
    """A toggle clamp (an outside reviewer's): its arm at 1.38 rad is reached by the handle
    either side of its dead centre (O1, A, B in line: the cosine rule in O1 O2 B with |O1 B| =
    0.06 m), both in the answer's mode and within the handle's limits; the note named the twin
    for Newton's coordinate targets only. The twin, solved forward, puts the arm at 1.38."""
    import re

    scene = tmp_path / 'clamp.yaml'
    scene.write_text(TOGGLE_CLAMP)
    rc, out, err = run(capsys, 'solve', scene, '--target', 'arm=1.38', '--json')
    assert rc == 0
    answer = json.loads(out)
    (note,) = [ln for ln in err.splitlines() if 'another solution' in ln]
    assert f'assembly mode {answer["branch"]}' in note
    twin = float(re.search(r'handle = ([-0-9.e]+)', note).group(1))
    dead = math.acos((0.06**2 + 0.05**2 - 0.025**2) / (2 * 0.06 * 0.05))
    assert (
        sorted([twin, answer['inputs']['handle']])[0] < dead < max(twin, answer['inputs']['handle'])
    )
    assert -0.9 <= twin <= 0.47
    r = Solver(Scene.from_yaml(scene).mechanism, branch=answer['branch']).solve({'handle': twin})
    assert r.success and r.links['arm'] == pytest.approx(1.38, abs=1e-8)  # (the note's 9 digits)


def test_all_branches_of_one_circuit_are_configurations_of_one_assembly_mode(capsys):
    """A non-Grashof four-bar's two solutions at a crank angle lie on one circuit through its
    toggles: seed 002, they 'are not two distinct assembly modes but two distinct
    configurations'; --all-branches headed them 'assembly mode 1 of 2' (a seed reviewer's
    find). A crank-rocker's two are two modes (its two curves). Oracle: the 50-digit four-bar
    in each sign."""
    from oracles import fourbar

    rc, out, _ = run(capsys, 'solve', 'four_bar_non_grashof', '--set', 'crank=60deg',
                     '--all-branches')  # fmt: skip
    assert rc == 0
    assert out.startswith("one assembly mode: 2 configurations on the drawing's circuit")
    assert '--- configuration 1 of 2 (branch +) (as drawn)' in out
    assert '--- configuration 2 of 2 (branch -) (as drawn)' in out
    rc, out, _ = run(capsys, 'solve', 'four_bar_non_grashof', '--set', 'crank=60deg',
                     '--all-branches', '--json')  # fmt: skip
    got = {d['branch']: d['links']['rocker']['angle'] for d in loads(out)}
    for sign, label in ((1, '+'), (-1, '-')):
        want = float(fourbar(0.30, 0.20, 0.25, 0.22, math.radians(60), branch=sign)['theta4'])
        assert abs(math.remainder(got[label] - want, 2 * math.pi)) < 1e-12, label
    rc, out, _ = run(capsys, 'solve', 'four_bar', '--set', 'crank=60deg', '--all-branches')
    assert rc == 0 and 'one assembly mode' not in out
    assert '--- assembly mode 1 of 2 (branch +) (as drawn)' in out


def test_all_branches_on_the_mirror_loop_are_one_assembly_mode_too(capsys, tmp_path):
    """A Grashof double-rocker without crank limits: at crank -1 rad both solutions lie on
    the mirror loop (seed 000: each loop one mode of assembly); they were listed as two modes
    where the drawing's loop's were one (an adversary's find)."""
    text = (CONFIG / 'four_bar_grashof_double_rocker.yaml').read_text()
    assert 'crank_limits' in text
    scene = tmp_path / 'gdr.yaml'
    scene.write_text('\n'.join(ln for ln in text.splitlines() if 'crank_limits' not in ln) + '\n')
    rc, out, _ = run(capsys, 'solve', scene, '--set', 'crank=-1', '--all-branches')
    assert rc == 0
    assert out.startswith('one assembly mode: 2 configurations on the other circuit'), out
    assert '--- configuration 2 of 2 (branch -)\n' in out


FIVE_BAR = """name: fivebar
points: {O1: [0.0, 0.0], O2: [0.2, 0.0], A: [0.0, 0.15], B: [0.2, 0.15], P: [0.1, 0.3]}
ground: ground
links: {ground: [O1, O2], left: [O1, A], right: [O2, B], la: [A, P], rb: [B, P]}
actuators:
  q1: {type: angle, link: left, pivot: O1, toward: A}
  q2: {type: angle, link: right, pivot: O2, toward: B}
"""


def test_a_forward_command_of_two_actuators_out_of_reach_is_told_its_edge(capsys, tmp_path):
    """A five-bar's two cranks commanded apart beyond its reach: one actuator's refusal gets
    its reachable range, two got the dyad's miss alone (the last stop's leftover). Each crank
    moved alone is out of reach here: the first is named with its edge, where its arm's reach
    is spent with the other crank where it is, |A B| = |A P| + |P B| (the dyad P folded
    straight), and the other is said too."""
    scene = tmp_path / 'fivebar.yaml'
    scene.write_text(FIVE_BAR)
    rc, out, _ = run(capsys, 'solve', scene, '--set', 'q1=3.1', '--set', 'q2=0', '--json')
    d = loads(out)
    assert rc == 1 and d['status'] == 'error'
    head = d['reason'].split('; cannot assemble')[0]
    assert head.startswith('q1 = 3.1 rad with q2 as it is now is out of reach: on the way'), head
    assert head.endswith('; q2 moved alone (the others where they are) out of reach too'), head
    reach = 2 * math.hypot(0.1, 0.15)  # |A P| + |P B|
    b = (0.2 + 0.15 * math.cos(math.pi / 2), 0.15 * math.sin(math.pi / 2))  # q2 as drawn

    def apart(q1: float) -> float:
        return math.dist((0.15 * math.cos(q1), 0.15 * math.sin(q1)), b) - reach

    from scipy.optimize import brentq

    edge_q1 = brentq(apart, math.pi / 2, 3.1, xtol=1e-14)
    edge = float(head.split('up to q1 = ')[1].split(' rad')[0])
    assert abs(edge - edge_q1) < 1e-5, (edge, edge_q1)  # (the edge's 6 digits)


CRANE = """name: crane
points: {O: [0, 2], P: [0.3, 0.8], Q: [1.2, 2.3], R: [1.8, 2.9], U: [3.6, 3.6], K: [4, 3.2],
         M: [3.9, 3.9], V: [4.3, 3.7], T: [6.5, 1.5]}
links: {ground: [O, P], main: [O, K, Q, R, U], jib: [K, V, T], la: [U, M], lb: [M, V]}
cylinders: {lift: {from: P, to: Q, min: 1.5, max: 2.3}, fold: {from: R, to: M, min: 1.9, max: 2.9}}
outputs: [T]
"""


@pytest.mark.parametrize('lift', [None, '1.8'])
def test_a_cylinder_past_its_dead_centre_is_named_with_its_edge(capsys, tmp_path, lift):
    """A knuckle-boom crane's fold cylinder commanded past its dead centre (|R M| can be at
    most |R U| + |U M|, the link la folded straight), the lift held or moved a little: the
    refusal named the lift ('lift = 1.74929 m ... 2.22045e-16 m short', an outside hydraulics
    engineer). It names the known moved furthest, the fold, and its edge: the dead centre."""
    scene = tmp_path / 'crane.yaml'
    scene.write_text(CRANE)
    args = ['--set', 'fold=2.5'] + ([] if lift is None else ['--set', f'lift={lift}'])
    rc, out, _ = run(capsys, 'solve', scene, *args, '--json')
    d = loads(out)
    assert rc == 1 and d['status'] == 'error'
    head = d['reason'].split('; cannot assemble')[0]
    assert head.startswith('fold = 2.5 m with lift as '), head
    dead = math.dist((1.8, 2.9), (3.6, 3.6)) + math.dist((3.6, 3.6), (3.9, 3.9))
    assert f'up to fold = {dead:.6g} m, {2.5 - dead:.6g} m short' in head, (head, dead)


def test_of_two_cylinders_the_one_out_of_reach_alone_is_named(capsys, tmp_path):
    """C1 and C2 both commanded, C2 past its dead centre whatever C1 (Q and N on one link:
    |Q R| is at most |Q N| + |N R|): the refusal named C1, the known moved furthest ('C1 = 2.5
    m with C2 as given is out of reach ... up to C1 = 2.43871 m', a hydraulics engineer). The
    one that fails moved alone is named now, with its edge: the dead centre."""
    scene = tmp_path / 'crane2.yaml'
    scene.write_text(
        'name: crane2\n'
        'points: {O: [0, 3.0], F: [0.3, 1.5], Bm: [1.2, 3.6], K: [5.0, 4.5], Q: [2.5, 4.4],\n'
        '         N: [4.4, 4.9], R: [4.7, 5.4], W: [5.3, 4.9], Tip: [7.5, 2.0]}\n'
        'links: {ground: [O, F], main: [O, K, Bm, Q, N], jib: [K, W, Tip], rocker: [N, R],\n'
        '        knuckle: [R, W]}\n'
        'cylinders: {C1: {from: F, to: Bm, min: 1.8, max: 3.2},\n'
        '            C2: {from: Q, to: R, min: 1.9, max: 3.1}}\n'
    )
    dead = math.dist((2.5, 4.4), (4.4, 4.9)) + math.dist((4.4, 4.9), (4.7, 5.4))
    assert 2.5 < dead < 2.6
    rc, out, _ = run(capsys, 'solve', scene, '--set', 'C1=2.5', '--set', 'C2=2.6', '--json')
    d = loads(out)
    assert rc == 1 and d['status'] == 'error'
    head = d['reason'].split('; cannot assemble')[0]
    assert head == (
        'C2 = 2.6 m with C1 as it is now is out of reach: on the way there from the current '
        f'configuration it is reachable up to C2 = {dead:.6g} m, {2.6 - dead:.6g} m short (that '
        "way's edge)"
    ), head


def test_of_two_cylinders_each_out_of_reach_alone_both_are_said(capsys, tmp_path):
    """The loader with both cylinders' limits widened to 0.5 .. 4 m, Z1 = Z2 = 1 m: each alone
    is out of reach, and the refusal named Z2 (moved furthest) where its own detail blamed Z1's
    dyad (an adversary). The first is named with its edge, the other said too. Oracle: Z1's
    least length, |O4 O2| - |O4 A| (A turning about the boom's pivot O4)."""
    import yaml

    from linkage_ros.resources import scene_path

    data = yaml.safe_load(scene_path('front_loader').read_text())
    for z in ('Z1', 'Z2'):
        data['cylinders'][z].update(min=0.5, max=4.0)
    scene = tmp_path / 'loader.yaml'
    scene.write_text(yaml.safe_dump(data))
    P = data['points']
    least = abs(math.dist(P['O4'], P['O2']) - math.dist(P['O4'], P['A']))
    rc, out, _ = run(capsys, 'solve', scene, '--set', 'Z1=1.0', '--set', 'Z2=1.0', '--json')
    reason = loads(out)['reason']
    assert rc == 1
    assert reason.startswith(
        'Z1 = 1 m with Z2 as it is now is out of reach: on the way there from the current '
        f'configuration it is reachable up to Z1 = {least:.6g} m, {least - 1.0:.6g} m short'
    ), (reason, least)
    assert '; Z2 moved alone (the others where they are) out of reach too;' in reason


def test_the_note_names_every_other_solution_in_the_answers_mode(capsys, tmp_path):
    """A five-bar's point target has four solutions, three in one assembly mode (each arm's
    two elbows, one combination in the other mode): the note named one of the two others (an
    outside scene author). Oracle: each arm's angles are where its crank circle meets the
    circle about C of its coupler's length."""
    scene = tmp_path / 'fivebar.yaml'
    pts = {'O1': (0, 0), 'O2': (0.2, 0), 'A': (0.05, 0.1), 'B': (0.22, 0.12), 'C': (0.12, 0.28)}
    scene.write_text(
        yaml.safe_dump(
            {
                'name': 'fivebar',
                'points': {k: list(v) for k, v in pts.items()},
                'links': {
                    'ground': ['O1', 'O2'],
                    'c1': ['O1', 'A'],
                    'c2': ['O2', 'B'],
                    'l1': ['A', 'C'],
                    'l2': ['B', 'C'],
                },
                'actuators': {
                    'a1': {'type': 'angle', 'link': 'c1', 'pivot': 'O1'},
                    'a2': {'type': 'angle', 'link': 'c2', 'pivot': 'O2'},
                },
            }
        )
    )
    target = (0.1, 0.25)

    def arm_angles(o, tip):  # the crank angles putting the arm's tip |tip C| from C
        r1, r2 = math.dist(pts[o], pts[tip]), math.dist(pts[tip], pts['C'])
        dx, dy = target[0] - pts[o][0], target[1] - pts[o][1]
        d = math.hypot(dx, dy)
        along = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
        h = math.sqrt(r1 * r1 - along * along)
        base = math.atan2(dy, dx)
        return [base + s * math.atan2(h, along) for s in (1, -1)]

    a1s, a2s = arm_angles('O1', 'A'), arm_angles('O2', 'B')
    rc, out, err = run(capsys, 'solve', scene, '--target-point', 'C=0.1,0.25', '--json')
    assert rc == 0
    answer = loads(out)['inputs']
    (note,) = [ln for ln in err.splitlines() if ln.startswith('note: ')]
    assert note.startswith('note: 2 other solutions in assembly mode +: '), note
    listed = note.split(': ', 2)[2].split('; --all-branches')[0].split('; ')
    pairs = {(answer['a1'], answer['a2'])}
    for item in listed:
        got = dict(kv.split(' = ') for kv in item.split(', '))
        pairs.add((float(got['a1']), float(got['a2'])))
    assert len(pairs) == 3
    for a1, a2 in pairs:
        assert min(abs(math.remainder(a1 - w, 2 * math.pi)) for w in a1s) < 1e-8
        assert min(abs(math.remainder(a2 - w, 2 * math.pi)) for w in a2s) < 1e-8


def test_a_point_target_on_a_one_dof_path_names_its_coordinates(capsys):
    """`--target-point P=x,y` on a one-DOF four-bar was refused as 'the knowns give 2
    value(s)' alone (an outside scene author tried it for a foot point first): it names the
    coordinate targets that fit, and one of them solves."""
    rc, _, err = run(capsys, 'solve', 'four_bar', '--target-point', 'P=0.1,0.2')
    assert rc == 2 and 'give 2 value(s) (a point gives its x and y: one of them alone is' in err
    assert 'P.x or P.y' in err, err
    rc, out, err = run(capsys, 'solve', 'four_bar', '--target', 'P.x=0.1', '--json')
    assert rc == 0 and abs(loads(out)['points']['P'][0] - 0.1) < 1e-12, err
