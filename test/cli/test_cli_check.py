"""`linkage check` and `linkage range --motion`: the mobility, the Grashof class, the input
ranges (declared and computed), the reference-pose warnings and the motion of a one-input
mechanism.

Ranges are checked against the toggle angles by the cosine rule (cli_helpers.toggles).
"""

import math

import pytest
from cli_helpers import DR, loads, run, toggles


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


def test_check_double_rocker_limits_are_the_toggle_angles(capsys, scenes):
    rc, out, _ = run(capsys, 'check', scenes['double_rocker'], '--json')
    assert rc == 0
    d = loads(out)
    assert d['grashof']['class'] == 'grashof-double-rocker'
    lo, hi = toggles(*DR.values())  # the reference pose (input 0.8) is on this circuit
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
        (
            'four_bar_non_grashof',
            'grashof    4R non-Grashof triple-rocker (a non-Grashof double-rocker: no link turns '
            'fully): s + l = 0.5 > p + q = 0.47 (input fully rotates: no, output fully rotates: '
            'no)',
        ),
    ],
)
def test_check_prints_the_chain_class_line(capsys, scene, line):
    """Lecture 003 example 5 'first verifies that this is a non-Grashof 3R-1P linkage':
    lmin + e = 0.20 + 0.14 > lmax = 0.30 (the scene file's dimensions). Lecture 000 names the
    4R chain with s + l > p + q 'non-Grashof ... double-rocker' (the line said only
    'triple-rocker', a name the lectures never use)."""
    rc, out, _ = run(capsys, 'check', scene)
    assert rc == 0
    assert line in out.splitlines()
    rc, out, _ = run(capsys, 'check', scene, '--json')
    d = loads(out)
    assert d['grashof']['chain'] == line.split()[1]


def test_check_has_no_chain_class_for_multi_loop_scenes(capsys):
    rc, out, _ = run(capsys, 'check', 'excavator', '--json')
    assert rc == 0 and loads(out)['grashof'] is None


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
    # limits a turn or more apart (degrees read as radians) limit nothing: said so, not
    # 'reachable range, computed' beside no range (a new user's find)
    scene.write_text(
        'name: deg\nslider_crank: {crank: 0.05, rod: 0.18, crank_limits: {min: 0, max: 120}}\n'
    )
    rc, out, _ = run(capsys, 'check', scene)
    (line,) = [ln for ln in out.splitlines() if ln.strip().startswith('crank   angle')]
    assert (
        'unlimited  [declared limits min 0  max 120: a turn or more apart, they limit nothing]'
        in line
    ), line


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


def test_check_gives_a_links_whole_oscillation_where_the_cranks_limits_stop_short(capsys, tmp_path):
    """Seed 003 example 5, stated as the lecture states it: 'determine the ranges of
    oscillation of these links 2 and 4' of the non-Grashof 3R-1P. The shipped scene's crank
    limits sit 0.01 rad inside its toggles, so `linkage check` gave link 4 a swing of 2.219 rad
    (half its circuit) and nothing more (an outside reviewer's find). It now adds the swing
    through the toggles. Oracle: the slide line through A at distance e = 0.14 from O4 meets the
    crank circle (O2, 0.2) while cos(psi) <= (0.2 - 0.14) / 0.3 = 0.2: psi in
    [acos 0.2, 2 pi - acos 0.2], a swing of 2 pi - 2 acos 0.2 = 3.5443 rad (203.07 deg)."""
    rc, out, _ = run(capsys, 'check', 'inverted_slider_crank_oscillating', '--json')
    assert rc == 0
    whole = loads(out)['motion_without_limits']['outputs']['link:rocker']
    assert whole['min'] == pytest.approx(math.acos(0.2), abs=1e-9)
    assert whole['max'] == pytest.approx(2 * math.pi - math.acos(0.2), abs=1e-9)
    assert whole['stroke'] == pytest.approx(2 * math.pi - 2 * math.acos(0.2), abs=1e-9)
    rc, out, _ = run(capsys, 'check', 'inverted_slider_crank_oscillating')
    assert rc == 0
    assert "without the input's limits (through its toggles): min 1.36943841" in out
    rc, out, _ = run(capsys, 'check', 'four_bar', '--json')  # no limits: nothing added
    assert rc == 0
    assert loads(out)['motion_without_limits'] is None
    # limits that take in the whole circuit (a double-rocker's toggles 0.46 and 1.51 inside
    # 0.3 .. 6): nothing added either (it printed the same motion again)
    scene = tmp_path / 'wide_limits.yaml'
    scene.write_text(
        'name: wide\nfour_bar: {ground: 0.3, crank: 0.2, coupler: 0.1, rocker: 0.25, input: 1.0, '
        'branch: 1, crank_limits: {min: 0.3, max: 6.0}}\n'
    )
    rc, out, _ = run(capsys, 'check', str(scene), '--json')
    assert rc == 0
    assert loads(out)['motion_without_limits'] is None


def test_check_names_a_grashof_double_rockers_other_circuit(capsys, tmp_path):
    """A Grashof double-rocker's input assembles over two intervals, mirror images about the
    ground line, each a circuit of its own (the lectures describe both); `linkage check` gave
    the drawing's alone as the 'reachable range' (an outside reviewer's find). Oracle, the
    cosine rule: the crank (O2A = 0.2, ground 0.3) assembles where 0.10 - 0.25 <= |AO4| <=
    0.10 + 0.25, cos(theta) in [0.0625, 0.8958]: the drawn circuit (0.4605 .. 1.5083) and its
    mirror."""
    scene = tmp_path / 'gdr.yaml'
    scene.write_text(
        'name: gdr\nfour_bar: {ground: 0.30, crank: 0.20, coupler: 0.10, rocker: 0.25}\n'
    )
    lo, hi = math.acos((0.13 - 0.35**2) / 0.12), math.acos((0.13 - 0.15**2) / 0.12)
    rc, out, _ = run(capsys, 'check', str(scene), '--json')
    assert rc == 0
    crank = loads(out)['inputs']['crank']
    assert (crank['min'], crank['max']) == pytest.approx((hi, lo), abs=1e-9)
    ((a, b),) = crank['other_circuits']
    assert (a, b) == pytest.approx((-lo, -hi), abs=1e-9)
    # with limits, the part of the other circuit they admit (-1 .. 1 holds -1 .. -hi of it)
    limited = tmp_path / 'gdr_limited.yaml'
    limited.write_text(
        'name: gdr_limited\nfour_bar: {ground: 0.30, crank: 0.20, coupler: 0.10, rocker: 0.25, '
        'input: 1.0, branch: 1, crank_limits: {min: -1.0, max: 1.0}}\n'
    )
    rc, out, _ = run(capsys, 'check', str(limited), '--json')
    assert rc == 0
    ((a, b),) = loads(out)['inputs']['crank']['other_circuits']
    assert (a, b) == pytest.approx((-1.0, -hi), abs=1e-9)
    for name in ('four_bar', 'four_bar_non_grashof', 'four_bar_grashof_double_rocker'):
        rc, out, _ = run(capsys, 'check', name, '--json')  # one circuit; or limits that say which
        assert rc == 0
        assert loads(out)['inputs']['crank']['other_circuits'] == [], name


@pytest.mark.parametrize('stem', ['four_bar', 'four_bar_non_grashof', 'excavator'])
def test_check_and_range_name_the_same_things_alike(capsys, stem):
    """`check --json` gave the scene's file as 'scene' and each input's drawn value as 'drawn';
    `range --json` gave the scene's name as 'scene' and the drawn value as 'reference', and
    check's inputs had no 'full_turn' (an outside review). Both now: 'scene' the file, 'name'
    the scene's name, each input's 'drawn' and 'full_turn' equal."""
    rc, out, _ = run(capsys, 'check', stem, '--json')  # (the packaged scenes)
    assert rc == 0
    check = loads(out)
    rc, out, _ = run(capsys, 'range', stem, '--json')
    assert rc == 0
    rng = loads(out)
    assert check['scene'] == rng['scene'] and check['name'] == rng['name'] == stem
    assert set(check['inputs']) == set(rng['inputs'])
    for name, c in check['inputs'].items():
        r = rng['inputs'][name]
        assert c['drawn'] == r['drawn'] and c['full_turn'] == r['full_turn'], name
        assert (c['min'], c['max']) == (r['min'], r['max']), name
    # the premise, by the cosine rule: only the Grashof crank-rocker's crank turns fully
    assert [n for n, c in check['inputs'].items() if c['full_turn']] == (
        ['crank'] if stem == 'four_bar' else []
    )


def test_check_names_the_branch_of_an_extreme_where_the_circuit_passes_two(capsys):
    """The non-Grashof four-bar's rocker extremes lie on the two branches its circuit passes
    (each crank value has a configuration on each): the motion lines say which, as the JSON
    does; a crank-rocker's keep one and say none. Branches, not modes: seed 002, the two are
    'two distinct configurations' of one assembly mode (a seed reviewer's find)."""
    rc, out, err = run(capsys, 'check', 'four_bar_non_grashof')
    assert rc == 0, err
    (line,) = [ln for ln in out.splitlines() if ln.strip().startswith('rocker (angle)')]
    assert ' on branch +' in line and ' on branch -' in line and 'in mode' not in line
    data = loads(run(capsys, 'check', 'four_bar_non_grashof', '--json')[1])
    rocker = data['motion']['outputs']['link:rocker']
    assert {rocker['mode_at_min'], rocker['mode_at_max']} == {'+', '-'}
    rc, out, err = run(capsys, 'check', 'four_bar')
    assert rc == 0 and ' on branch ' not in out


def test_range_links_of_a_newton_placed_mechanism(capsys, tmp_path):
    """`linkage range --links` on a Stephenson six-bar driven at its output (Newton places four
    links) ended in a traceback ('oscillation_range needs a closed-form plan', an outside scene
    author). It sweeps the drive's circuit both ways: the crank turns fully, the rocker's max
    is the four-bar O2-A-B-O4's by the cosine rule (|O2 B| = coupler - crank, B above O2 O4)."""
    import yaml
    from scenes import STEPHENSON_DRIVEN_AT_ITS_OUTPUT as scene

    path = tmp_path / 'stephenson.yaml'
    path.write_text(yaml.safe_dump(scene))
    rc, out, err = run(capsys, 'range', str(path), '--links', '--json')
    assert rc == 0, err
    links = loads(out)['oscillation']['links']
    assert links['crank']['full_turn'] and not links['rocker']['full_turn']
    p = scene['points']
    a, b = math.dist(p['O2'], p['A']), math.dist(p['A'], p['B'])
    c, d = math.dist(p['O4'], p['B']), p['O4'][0]
    x = ((b - a) ** 2 - c * c + d * d) / (2 * d)
    want = math.atan2(math.sqrt((b - a) ** 2 - x * x), x - d)
    assert abs(links['rocker']['max'] - want) < 1e-9, (links['rocker']['max'], want)


def test_a_motion_that_cannot_be_swept_says_why(capsys, monkeypatch):
    """Where the input's sweep fails (a Newton-placed circuit the scan cannot follow), check
    and range --motion left the motion section out without a word (an adversary): they say it
    was not computed, and why; the JSON carries the reason."""
    from linkage_ros.core.motion import quantities

    def fails(*a, **k):
        raise ValueError("'drive' = -2.7316 does not assemble")

    monkeypatch.setattr(quantities, 'input_sweep', fails)
    rc, out, _ = run(capsys, 'check', 'four_bar')
    assert rc == 0
    assert "motion     crank: not computed ('drive' = -2.7316 does not assemble)" in out
    rc, out, _ = run(capsys, 'range', 'four_bar', '--motion', '--json')
    assert rc == 0
    assert loads(out)['motion'] == {
        'actuator': 'crank',
        'unavailable': "'drive' = -2.7316 does not assemble",
    }
