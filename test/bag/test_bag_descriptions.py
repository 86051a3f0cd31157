"""linkage bag on a robot description: the recorded commands and targets are in the
description's own joint names and values, exactly as the node receives them, and the outputs
are in them too. Oracle: the same requests answered one by one by the engine (which converts
them at its edge), and the description's own limits."""

from __future__ import annotations

import math

import numpy as np
from scenes import REPO
from test_bag import joint_state, read_csv, run_bag, write_bag

from linkage_ros.core.loading import load_scene
from linkage_ros.engine import Engine, EngineSettings

FIXTURES = REPO / 'test' / 'fixtures' / 'robot_descriptions'
ROBOTIQ = FIXTURES / 'picknik_robotiq_2f_85.expanded.urdf'
ROBOTIQ_CLOSURES = FIXTURES / 'picknik_robotiq_2f_85.closures.yaml'
DRAKE = FIXTURES / 'drake_four_bar_loop.sdf'
DRAKE_CLOSURES = FIXTURES / 'drake_four_bar_loop.closures.yaml'


def _run(tmp_path, capsys, desc, closures, messages, targets=False):
    folder = tmp_path / 'in'
    write_bag(folder, 'mcap', messages)
    out = tmp_path / 'out.csv'
    args = [folder, '--scene', desc, '--closures', closures, '--command-topic', '/cmd']
    args += (['--target-topic', '/tgt'] if targets else []) + ['--out', out, '--no-progress']
    code, cap = run_bag(args, capsys)
    assert code == 0, cap.err
    return read_csv(out)


def test_robotiq_commands_in_the_descriptions_values_are_all_answered(tmp_path, capsys):
    """The knuckle's URDF range is 0..0.8 rad: every command inside it is answered, and the
    right knuckle follows by its mimic (-1), as the description says."""
    name = 'robotiq_85_left_knuckle_joint'
    values = np.linspace(0.0, 0.8, 17)
    msgs = [('/cmd', (k + 1) * 10**6, joint_state([name], [v])) for k, v in enumerate(values)]
    rows = _run(tmp_path, capsys, ROBOTIQ, ROBOTIQ_CLOSURES, msgs)
    assert [r['status'] for r in rows] == ['ok'] * len(values)
    for r, v in zip(rows, values):
        assert abs(float(r[f'input.{name}']) - v) < 1e-12
        assert abs(float(r['joint.robotiq_85_right_knuckle_joint']) + v) < 1e-12
        assert abs(float(r['joint.robotiq_85_left_inner_knuckle_joint']) - v) < 1e-9


def test_drake_commands_and_passive_targets_match_the_engine(tmp_path, capsys):
    """Commands (the driver) and targets naming a passive joint (the rocker) are answered as the
    engine answers them one by one, in the description's values."""
    scene = load_scene(str(DRAKE), closures=str(DRAKE_CLOSURES))
    mech = scene.mechanism
    engine = Engine(mech, EngineSettings())
    msgs, expected = [], []
    for k, v in enumerate(np.linspace(-0.4, 0.4, 9)):
        msgs.append(('/cmd', (2 * k + 1) * 10**6, joint_state(['world_driver'], [v])))
        expected.append(engine.command({'world_driver': float(v)}))
        rocker = dict(zip(mech.output_joint_names, mech.output_joints(expected[-1].joints)))[
            'world_rocker'
        ]
        target = rocker + 0.01
        msgs.append(('/tgt', (2 * k + 2) * 10**6, joint_state(['world_rocker'], [target])))
        expected.append(engine.target({'world_rocker': target}))
    rows = _run(tmp_path, capsys, DRAKE, DRAKE_CLOSURES, msgs, targets=True)
    assert len(rows) == len(expected)
    for r, e in zip(rows, expected):
        assert e.success and r['status'] == 'ok', (r['reason'], e.reason)
        want = dict(zip(mech.output_joint_names, mech.output_joints(e.joints)))
        for j, v in want.items():
            got = float(r[f'joint.{j}'])
            assert abs(math.remainder(got - v, 2 * math.pi)) < 1e-9, (j, got, v)


def test_the_bag_refuses_what_the_node_refuses_in_the_descriptions_terms(tmp_path, capsys):
    """A command naming the mimic follower alone, or a passive joint, is refused with the
    node's words (before: the follower was taken as an input, breaking its mimic)."""
    msgs = [
        ('/cmd', 10**6, joint_state(['robotiq_85_left_knuckle_joint'], [0.3])),
        ('/cmd', 2 * 10**6, joint_state(['robotiq_85_right_knuckle_joint'], [-0.2])),
        ('/cmd', 3 * 10**6, joint_state(['robotiq_85_left_inner_knuckle_joint'], [0.1])),
    ]
    rows = _run(tmp_path, capsys, ROBOTIQ, ROBOTIQ_CLOSURES, msgs)
    assert [r['status'] for r in rows] == ['ok', 'error', 'error']
    assert "follows 'robotiq_85_left_knuckle_joint' by its <mimic>" in rows[1]['reason']
    assert "'robotiq_85_left_inner_knuckle_joint' is passive" in rows[2]['reason']
    scene = load_scene(str(ROBOTIQ), closures=str(ROBOTIQ_CLOSURES))
    engine = Engine(scene.mechanism, EngineSettings())
    for msg, row in zip(msgs[1:], rows[1:]):
        name, value = msg[2].name[0], float(msg[2].position[0])
        assert engine.command({name: value}).reason == row['reason']


def test_a_descriptions_recorded_inputs_come_back_as_recorded(tmp_path, capsys):
    """The bag turned a description's command into the scene's value and back through an array
    wrap that shifted by pi and back: input.joint1 read 0.04999999999999982 for a command of
    0.05 (the node, on floats, 0.05). Oracle: the recorded values themselves, and
    math.remainder for the array wrap."""
    from linkage_ros.core.model.joint_map import wrap

    values = [0.05, 0.1, -0.3, 1.2, 2.9, -2.9]
    msgs = [('/cmd', (k + 1) * 10**6, joint_state(['joint1'], [v])) for k, v in enumerate(values)]
    folder = tmp_path / 'in'
    write_bag(folder, 'mcap', msgs)
    out = tmp_path / 'out.csv'
    urdf = FIXTURES / 'grbda_four_bar.urdf'
    args = [folder, '--scene', urdf, '--command-topic', '/cmd', '--out', out, '--no-progress']
    code, cap = run_bag(args, capsys)
    assert code == 0, cap.err
    rows = read_csv(out)
    assert [r['input.joint1'] for r in rows] == [repr(v) for v in values]
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.uniform(-40.0, 40.0, 20000), [math.pi, -math.pi, 0.0, 7.0, -7.0]])
    exact = [math.remainder(v, 2 * math.pi) for v in x.tolist()]
    assert wrap(x).tolist() == [math.pi if r == -math.pi else r for r in exact]  # (-pi, pi]


def test_a_command_beyond_a_passive_limit_is_refused_as_the_node_refuses_it(tmp_path, capsys):
    """The batch's rows are cut where a passive joint leaves its <limit>: that row is refused
    one by one, with the engine's reason, and the rows around it are answered."""
    from core.description.test_passive_limits import SLIDER, slide

    desc = tmp_path / 'slider_limited.urdf'
    desc.write_text(SLIDER)
    closures = tmp_path / 'slider_limited.yaml'
    closures.write_text('actuated: [crank_joint]\n')
    # a long run (the batch path): down through the limit and back up
    cranks = np.concatenate([np.linspace(1.4, -0.2, 400), np.linspace(-0.2, 1.4, 400)])
    msgs = [
        ('/cmd', (k + 1) * 10**6, joint_state(['crank_joint'], [float(v)]))
        for k, v in enumerate(cranks)
    ]
    rows = _run(tmp_path, capsys, desc, closures, msgs)
    beyond = [slide(float(q)) < -0.03 - 1e-12 for q in cranks]
    assert any(beyond) and not all(beyond)
    for r, q, out in zip(rows, cranks, beyond):
        if out:
            assert r['status'] == 'error' and 'passive joint slide_joint' in r['reason'], q
        else:
            assert r['status'] == 'ok', (q, r['reason'])
            assert abs(float(r['joint.slide_joint']) - slide(float(q))) < 1e-12


def test_a_value_beyond_a_revolute_joints_limits_is_refused_as_the_node_refuses_it(
    tmp_path, capsys
):
    """The knuckle's <limit> is [0, 0.8]: a recorded 6.3 rad (its wrap, 0.017, within) is
    refused in the engine's words, row by row, and the rows around it are answered at their
    values."""
    name = 'robotiq_85_left_knuckle_joint'
    values = [0.2, 6.3, 0.4, -6.0, 0.9, 0.6, 0.3, 6.5, 0.35]
    topics = ['/cmd'] * 6 + ['/tgt'] * 3  # (a run of targets refused on one row too)
    msgs = [
        (t, (k + 1) * 10**6, joint_state([name], [v]))
        for k, (t, v) in enumerate(zip(topics, values))
    ]
    rows = _run(tmp_path, capsys, ROBOTIQ, ROBOTIQ_CLOSURES, msgs, targets=True)
    scene = load_scene(str(ROBOTIQ), closures=str(ROBOTIQ_CLOSURES))
    engine = Engine(scene.mechanism, EngineSettings())
    statuses = ['ok', 'error', 'ok', 'error', 'error', 'ok', 'ok', 'error', 'ok']
    assert [r['status'] for r in rows] == statuses
    for r, v, t in zip(rows, values, topics):
        want = engine.command({name: v}) if t == '/cmd' else engine.target({name: v})
        if want.success:
            assert abs(float(r[f'joint.{name}']) - v) < 1e-12
        else:
            assert r['reason'] == want.reason, (r['reason'], want.reason)
            assert 'its maximum 0.8' in want.reason or 'its minimum 0' in want.reason


GRBDA = FIXTURES / 'grbda_four_bar.urdf'


def test_an_infinite_command_on_a_description_is_refused_as_infinite(tmp_path, capsys):
    """The description's angle wrap turned +-inf into NaN before the finiteness check: the bag
    refused +inf as 'got nan' and showed nan as the input, where the node says 'got inf'."""
    values = [1.0, math.inf, -math.inf, math.nan]
    msgs = [('/cmd', (k + 1) * 10**6, joint_state(['joint1'], [v])) for k, v in enumerate(values)]
    folder = tmp_path / 'in'
    write_bag(folder, 'mcap', msgs)
    out = tmp_path / 'out.csv'
    args = [folder, '--scene', GRBDA, '--command-topic', '/cmd', '--out', out, '--no-progress']
    code, cap = run_bag(args, capsys)
    assert code == 0, cap.err
    rows = read_csv(out)
    assert [r['status'] for r in rows] == ['ok', 'error', 'error', 'error']
    for r, given in zip(rows[1:], ['inf', '-inf', 'nan']):
        assert r['reason'] == f'joint1: value must be finite (got {given})', r['reason']
        assert r['input.joint1'] == given
    # the node's path says the same
    engine = Engine(load_scene(str(GRBDA)).mechanism, EngineSettings())
    for v, given in zip(values[1:], ['inf', '-inf', 'nan']):
        assert engine.command({'joint1': v}).reason == f'joint1: value must be finite (got {given})'
