"""A command answers on the circuit the actuator moves the mechanism through, as targets are.

Seed 000: a Grashof double-rocker has "two distinct loops for two different modes of assembly
... you can never pass on from one mode of assembly to the other"; a non-Grashof four-bar has
"only one curve" that takes up the mirror configuration. A limit-free double-rocker drawn on
one loop answered a command on the mirror loop (same dyad sign, mirrored input interval) with
status OK, while `linkage check` gave the drawing's loop as the input's reachable range: the
published pose jumped to a configuration the machine cannot reach without being taken apart.

Oracle: the cosine rule. With ground g, crank c, coupler b and rocker r, the crank angle t
closes where |r - b| <= |A - O4| <= r + b, |A - O4|^2 = g^2 + c^2 - 2 g c cos t: for the
double-rocker (0.30, 0.20, 0.10, 0.25) that is acos(0.8958..) <= |t| <= acos(0.0625), one
interval for each loop; the drawing (t = 60 deg) is on the upper one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scenes import four_bar

from linkage_ros import bag
from linkage_ros.cli.parser import main as cli_main
from linkage_ros.engine import Engine, EngineSettings

G, C, B, R = 0.30, 0.20, 0.10, 0.25


def _crank_interval(g: float, c: float, b: float, r: float) -> tuple[float, float]:
    """The crank angles (rad, 0..pi) where the four-bar closes, by the cosine rule."""
    lo = (g * g + c * c - (r - b) ** 2) / (2 * g * c)  # |A - O4| = |r - b|
    hi = (g * g + c * c - (r + b) ** 2) / (2 * g * c)  # |A - O4| = r + b
    return math.acos(min(1.0, lo)), math.acos(max(-1.0, hi))


def _double_rocker():
    return four_bar(G, C, B, R, input=math.radians(60.0), branch=1)


def test_a_command_on_the_mirror_loop_is_refused_and_changes_nothing():
    lo, hi = _crank_interval(G, C, B, R)
    e = Engine(_double_rocker(), EngineSettings())
    inside = [lo + 1e-6, 0.5 * (lo + hi), hi - 1e-6]
    for t in inside:
        assert e.command({'crank': t}).success, t
    last = e.last
    for t in (-0.5 * (lo + hi), -lo - 1e-3, -hi + 1e-3):
        r = e.command({'crank': t})
        assert not r.success, t
        assert 'reachable only on the other loop of the mechanism' in r.reason
        assert f'{lo:.6g}..{hi:.6g} rad (its reachable range)' in r.reason, r.reason
        assert r.inputs == {'crank': t}  # the request is echoed
        assert e.last is last  # nothing changed
    # the next command continues from the last good state, on the drawing's loop: as if the
    # refused ones had not been sent
    untouched = Engine(_double_rocker(), EngineSettings())
    for t in inside:
        untouched.command({'crank': t})
    again = e.command({'crank': inside[1]})
    assert again.success and again.points == untouched.command({'crank': inside[1]}).points
    # where the cosine rule does not close at all, the reason stays the closure's
    assert e.command({'crank': 0.0}).reason.startswith('cannot assemble')


def test_a_non_grashof_four_bar_answers_its_whole_range_through_its_toggles():
    """One circuit: every crank angle that closes is answered, in both signs (the commands pass
    the toggles at +-t_max, where |A - O4| = coupler + rocker)."""
    g, c, b, r = 0.30, 0.20, 0.25, 0.22  # s + l = 0.5 > p + q = 0.47: non-Grashof
    t_max = math.acos((g * g + c * c - (b + r) ** 2) / (2 * g * c))
    e = Engine(four_bar(g, c, b, r, input=math.radians(60.0), branch=1), EngineSettings())
    path = np.concatenate(
        [np.linspace(1.0, t_max - 1e-4, 40), np.linspace(t_max - 1e-4, -t_max + 1e-4, 120)]
    )
    signs = set()
    for t in path.tolist():
        res = e.command({'crank': t})
        assert res.success, (t, res.reason)
        signs.add(res.branch)
    assert signs == {'+', '-'}  # the toggle was passed: the mirror configuration, one circuit


def test_the_command_line_refuses_the_mirror_loop_too(tmp_path, capsys):
    scene = tmp_path / 'dr.yaml'
    scene.write_text(
        f'four_bar: {{ground: {G}, crank: {C}, coupler: {B}, rocker: {R}, '
        f'input: {math.radians(60.0)!r}, branch: 1}}\n'
    )
    lo, hi = _crank_interval(G, C, B, R)
    assert cli_main(['solve', str(scene), '--set', 'crank=-1.0']) == 1
    assert 'reachable only on the other loop' in capsys.readouterr().out
    assert cli_main(['solve', str(scene), '--set', 'crank=1.0']) == 0
    capsys.readouterr()
    cli_main(['sweep', str(scene), '--set', f'crank={hi - 1e-3}:{-hi + 1e-3}:21', '--json'])
    import json

    rows = [json.loads(ln) for ln in capsys.readouterr().out.splitlines() if ln.startswith('{')]
    assert len(rows) == 21
    for row in rows:
        t = row['inputs']['crank']
        want = lo <= t <= hi
        assert (row['status'] == 'ok') == want, (t, row.get('reason'))
        if t < 0 and -hi <= t <= -lo:
            assert 'other loop' in row['reason']


def test_the_bag_answers_as_the_node(tmp_path):
    """The bag's vectorised replay stops at the first answer on the mirror loop and refuses it
    as Engine.command does (rows 0..99: in, mirror, in)."""
    from bag.test_bag_node_semantics import make_bag

    lo, hi = _crank_interval(G, C, B, R)
    values = (
        list(np.linspace(lo + 0.01, hi - 0.01, 40))
        + list(np.linspace(-hi + 0.01, -lo - 0.01, 20))
        + list(np.linspace(hi - 0.01, lo + 0.01, 40))
    )
    src = make_bag(tmp_path / 'in', values)
    mech = _double_rocker()
    data = bag.read_commands(str(src), ['/cmd'])
    res = bag.solve_commands(mech, data)
    e = Engine(mech, EngineSettings())
    for i, t in enumerate(values):
        want = e.command({'crank': float(t)})
        assert bool(res.ok[i]) == want.success, (i, t)
        if not want.success:
            assert res.reason[i] == want.reason
    assert res.ok.tolist() == [True] * 40 + [False] * 20 + [True] * 40


def test_a_trajectory_onto_the_mirror_loop_is_refused_saying_so():
    """Forward: the mirror point is refused as a command is. Inverse (the rocker's angle, which
    the reflection in the ground line negates): the status says the circuit changes (it said
    'the assembly mode changes from + to -', which the drawing's loop passes through itself)."""
    from linkage_ros.trajectory import solve_trajectory

    lo, hi = _crank_interval(G, C, B, R)
    e = Engine(_double_rocker(), EngineSettings())
    before = e.last
    mid = 0.5 * (lo + hi)
    ans = solve_trajectory(e, ['crank'], [[mid], [-mid]], (), [0, 1])
    assert not ans.success and ans.failed_index == 1
    assert 'reachable only on the other loop' in ans.reason
    phi = e.command({'crank': mid}).links['rocker']
    e = Engine(_double_rocker(), EngineSettings())
    ans = solve_trajectory(e, ['rocker'], [[phi], [-phi]], (), [0, 1])
    assert not ans.success and ans.failed_index == 1, ans.reason
    assert 'point 1: the mechanism changes circuit (signs + -> ' in ans.reason, ans.reason
    assert e.last.points == before.points


def test_a_target_on_the_mirror_loop_is_named_as_another_circuit_whatever_its_signs():
    """The mirror loop holds both signs: a target there whose answer has the other sign was
    refused as 'reachable only in assembly mode -' (a sign the drawing's loop takes up too),
    and allowed with mode_change '+ -> -' without '(another circuit)'."""
    lo, hi = _crank_interval(G, C, B, R)
    e = Engine(_double_rocker(), EngineSettings())
    for t in np.linspace(lo + 0.01, hi - 0.01, 7).tolist():
        phi = e.command({'crank': t}).links['rocker']
        e.command({'crank': math.radians(60.0)})
        r = e.target({'rocker': -phi})  # the reflection in the ground line: the mirror loop
        assert not r.success
        assert 'reachable only in another circuit of the mechanism' in r.reason, r.reason
        moved = e.target({'rocker': -phi}, allow_mode_change=True)
        assert moved.success and moved.mode_change.endswith('(another circuit)')
        assert -hi - 1e-9 <= moved.inputs['crank'] <= -lo + 1e-9  # the cosine rule's other loop
        e = Engine(_double_rocker(), EngineSettings())


def test_all_branches_marks_as_drawn_the_solutions_on_the_drawings_circuit(tmp_path, capsys):
    """`--all-branches` marked a solution '(as drawn)' by its signs alone: the non-Grashof
    four-bar's solutions in sign - (on the drawing's one circuit: seed 000's "only one mode
    of assembly") were not, and the double-rocker's mirror-loop solution in the drawn sign was.
    Oracle: the cosine rule's crank intervals (the drawing's loop is lo..hi)."""
    import json

    assert (
        cli_main(
            ['solve', 'four_bar_non_grashof', '--target', 'rocker=4.0', '--all-branches', '--json']
        )
        == 0
    )
    rows = json.loads(capsys.readouterr().out)
    assert {r['branch'] for r in rows} == {'-'} and all(r['drawn_mode'] for r in rows)
    scene = tmp_path / 'dr.yaml'
    scene.write_text(
        f'four_bar: {{ground: {G}, crank: {C}, coupler: {B}, rocker: {R}, '
        f'input: {math.radians(60.0)!r}, branch: 1}}\n'
    )
    lo, hi = _crank_interval(G, C, B, R)
    for t in (-0.5 * (lo + hi), 0.5 * (lo + hi)):
        assert (
            cli_main(['solve', str(scene), '--set', f'crank={t!r}', '--all-branches', '--json'])
            == 0
        )
        rows = json.loads(capsys.readouterr().out)
        assert len(rows) == 2
        assert all(r['drawn_mode'] == (lo <= t <= hi) for r in rows), (t, rows)


@pytest.mark.parametrize(
    'stem, fold_deg, line_x',
    [('hart', 132.8, 0.0528), ('peaucellier', 112.5, 0.1388888888888889)],
)
def test_jumpy_commands_of_a_limit_free_inversor_stay_on_its_straight_line(
    tmp_path, stem, fold_deg, line_x
):
    """Without crank limits the circuit scan passes the inversor's folds, where two dyads
    degenerate at once, and branches into sign combinations that are no loop of it; the
    circuit rule then refused commands with a reason quoting a range that contained them. The
    forward rule is for one-dyad circuits (the four-bar's loops); here commands are answered
    by continuity, as before. Oracle: the seed's inversion, Q on the straight line x = OT
    (scene comments) for every crank short of the folds; and the bag answers as the engine."""
    import yaml
    from bag.test_bag_node_semantics import make_bag
    from scenes import CONFIG

    data = yaml.safe_load((CONFIG / f'{stem}.yaml').read_text())
    for act in data['actuators'].values():
        act.pop('min', None)
        act.pop('max', None)
    scene = tmp_path / f'{stem}.yaml'
    scene.write_text(yaml.safe_dump(data))
    from linkage_ros.core.model import Scene

    mech = Scene.from_yaml(scene).mechanism
    e = Engine(mech, EngineSettings())
    rng = np.random.default_rng(3)
    edge = math.radians(fold_deg) - 0.3  # (a jump that ends at a fold may take either branch)
    values = rng.uniform(-edge, edge, 300).tolist()
    answers = [e.command({'crank': t}) for t in values]
    for t, r in zip(values, answers):
        assert r.success, (t, r.reason)
        assert abs(r.points['Q'][0] - line_x) <= 1e-12, (t, r.branch, r.points['Q'])
    res = bag.solve_commands(
        mech, bag.read_commands(str(make_bag(tmp_path / 'in', values)), ['/cmd'])
    )
    assert res.ok.all()
    assert np.allclose(res.points['Q'][:, 0], line_x, rtol=0, atol=1e-12)
    # a command at the fold's edge, then back to the drawing's crank: answered (the rule refused
    # the second, 'reachable only on the other loop ... over crank -2.31856..2.31856 rad')
    e2 = Engine(mech, EngineSettings())
    for t in (math.radians(fold_deg) - 1e-4, 0.6):
        assert e2.command({'crank': t}).success, t


GDR_MINUS_Z = """<?xml version="1.0"?>
<robot name="fb">
  <link name="base_link"/><link name="link1"/><link name="link2"/><link name="link3"/>
  <joint name="joint1" type="revolute" independent="true">
    <parent link="base_link"/><child link="link1"/><origin xyz="0 0 0" rpy="0 0 1"/>
    <axis xyz="0 0 -1"/><limit effort="1" velocity="1" lower="-100" upper="100"/></joint>
  <joint name="joint2" type="revolute" independent="false">
    <parent link="link1"/><child link="link2"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 0 -1"/><limit effort="1" velocity="1" lower="-100" upper="100"/></joint>
  <joint name="joint3" type="revolute" independent="false">
    <parent link="base_link"/><child link="link3"/><origin xyz="0.3 0 0" rpy="0 0 2"/>
    <axis xyz="0 0 -1"/><limit effort="1" velocity="1" lower="-100" upper="100"/></joint>
  <loop name="loop1" type="revolute">
    <predecessor link="link2"><origin xyz="0.1 0 0"/></predecessor>
    <successor link="link3"><origin xyz="0.25 0 0"/></successor><axis xyz="0 0 1"/></loop>
</robot>
"""


def test_the_mirror_loop_refusal_speaks_the_descriptions_values(tmp_path, capsys):
    """The double-rocker as a description whose joints turn about -z, crank drawn at yaw 1:
    joint1 = 1 - (the crank's angle from +x). The refusal quoted the scene's values (joint1 =
    -2 for a command of 2, the interval turned over). Oracle: the cosine rule's interval,
    mapped by joint1 = 1 - angle."""
    path = tmp_path / 'gdr.urdf'
    path.write_text(GDR_MINUS_Z)
    lo, hi = _crank_interval(G, C, B, R)
    assert cli_main(['solve', str(path), '--set', 'joint1=2.0']) == 1
    out = capsys.readouterr().out
    assert 'joint1 = 2 rad is reachable only on the other loop' in out, out
    assert f'over joint1 {1 - hi:.6g}..{1 - lo:.6g} rad (its reachable range)' in out, out


@pytest.mark.parametrize('branch', ['+', 'reference'])
def test_under_a_branch_setting_targets_keep_the_circuit_as_commands_do(branch):
    """A branch setting holds signs; the mirror loop has them too. A target there was answered
    (crank on the mirror interval) while the command for the same pose was refused. Oracle:
    the cosine rule's interval of the drawing's loop."""
    lo, hi = _crank_interval(G, C, B, R)
    e = Engine(_double_rocker(), EngineSettings(branch=branch))
    # rocker -2.8197 rad: only the mirror loop reaches it, its nearest solution in sign +
    free = Engine(_double_rocker(), EngineSettings())
    there = free.target({'rocker': -2.8197}, allow_mode_change=True)
    assert there.success and -hi <= there.inputs['crank'] <= -lo and there.branch == '+'
    r = e.target({'rocker': -2.8197})
    assert not r.success and 'reachable only in another circuit' in r.reason, r.reason
    assert e.command({'crank': there.inputs['crank']}).success is False  # as the command
    mid = 0.5 * (lo + hi)
    ok = e.target({'rocker': e.command({'crank': mid}).links['rocker']})
    assert ok.success and lo <= ok.inputs['crank'] <= hi


def test_a_branch_setting_refusal_does_not_advise_another_mode():
    """Under --branch + (or the node's branch parameter) ~/target_any_mode changes nothing and
    --any-mode is refused: the out-of-reach reason no longer advises them."""
    from scenes import load

    e = Engine(load('four_bar'), EngineSettings(branch='+'))
    r = e.target({'P.x': 0.2})
    assert not r.success and 'is out of reach' in r.reason
    assert 'searched on request' not in r.reason


def test_a_command_that_does_not_close_names_the_reachable_range():
    """A command inside the actuator's declared limits but beyond the assembly's reach was
    refused with the dyad's miss alone (a new user's landing gear at its cylinder's min); the
    refusal now also names what the actuator does reach from the drawing, as `linkage check`
    gives it. Oracle: the cosine rule's crank interval of the double-rocker's drawn loop."""
    lo, hi = _crank_interval(G, C, B, R)
    e = Engine(_double_rocker(), EngineSettings())
    r = e.command({'crank': 0.5 * lo})  # (|A - O4| below |r - b|: no assembly)
    assert not r.success
    assert r.reason.startswith('cannot assemble'), r.reason
    assert r.reason.endswith(
        f'from its drawing the actuator moves it over crank {lo:.6g}..{hi:.6g} rad '
        '(its reachable range)'
    ), r.reason


def test_a_branch_setting_off_the_drawings_circuit_is_not_told_the_drawings_range():
    """A command the branch setting's signs cannot assemble was told the drawing's circuit's
    range, which held the command (an integrator's landing gear under --branch +-: -0.03 m
    refused as lying in the -+ circuit's -0.1..0.06 m). A Stephenson-III six-bar driven by its
    crank within limits, drawn with both dyads +: with the four-bar's B mirrored (-+), its C
    is too far from O6 for link5 and output to close. Oracle: |C - O6| against link5 + output,
    C carried by the mirrored coupler (B the four-bar's other circle intersection)."""
    import copy

    from scenes import STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT

    from linkage_ros.core.model import Scene

    scene = copy.deepcopy(STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT)
    scene['actuators'] = {
        'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'min': 0.6, 'max': 1.5}
    }
    P = {k: np.array(v, float) for k, v in scene['points'].items()}

    def far_side_gap(t: float) -> float:
        """|C - O6| - (link5 + output) with B on the side of O4 -> A opposite the drawing's."""
        a, b, c = (np.linalg.norm(P[q] - P[p]) for p, q in (('O2', 'A'), ('A', 'B'), ('O4', 'B')))
        A = a * np.array([math.cos(t), math.sin(t)])
        d = A - P['O4']
        L = float(np.hypot(*d))
        x = (c * c - b * b + L * L) / (2 * L)
        u, n = d / L, np.array([-d[1], d[0]]) / L
        drawn = np.sign(
            np.dot(P['B'] - P['O4'], np.array([-(P['A'] - P['O4'])[1], (P['A'] - P['O4'])[0]]))
        )
        B = P['O4'] + x * u - drawn * math.sqrt(c * c - x * x) * n
        turn = math.atan2(*(B - A)[::-1]) - math.atan2(*(P['B'] - P['A'])[::-1])
        ac = P['C'] - P['A']
        C = A + np.array(
            [
                ac[0] * math.cos(turn) - ac[1] * math.sin(turn),
                ac[0] * math.sin(turn) + ac[1] * math.cos(turn),
            ]
        )
        span = np.linalg.norm(P['D'] - P['C']) + np.linalg.norm(P['D'] - P['O6'])
        return float(np.linalg.norm(C - P['O6']) - span)

    mech = Scene.from_dict(scene).mechanism
    drawn = Engine(mech, EngineSettings())
    mirrored = Engine(mech, EngineSettings(branch='-+'))
    for t in (0.7, 1.0, 1.4):
        assert far_side_gap(t) > 0  # the oracle: link5 and output cannot span C - O6
        r = mirrored.command({'crank': t})
        assert not r.success and r.reason.startswith('cannot assemble'), r.reason
        assert 'its reachable range' not in r.reason, r.reason
        assert drawn.command({'crank': t}).success
