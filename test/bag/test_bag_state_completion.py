"""`linkage bag --state-completion`: a robot's recorded /joint_states (joint_state_broadcaster:
every joint of the robot, NaN velocities where a joint has no velocity interface) read as the
node's joint_states_in reads it. Without it every row was refused ('not an actuator').

Oracles: the node's own rule, the engine answering each message's inputs as a command
(Engine.command, as node_requests.on_joint_states_in does), and the 50-digit four-bar for
the rocker."""

from __future__ import annotations

import math

from scenes import CONFIG
from test_bag import joint_state, make_input, read_csv, run_bag

from linkage_ros.core.loading import load_scene
from linkage_ros.engine import Engine, EngineSettings

SCENE = CONFIG / 'four_bar.yaml'


def test_a_robots_joint_states_command_the_mechanism_by_its_inputs(tmp_path, capsys):
    from oracles import fourbar

    msgs = []
    t = 10**9
    cranks = [0.3 + 0.05 * k for k in range(40)]
    for k, c in enumerate(cranks):
        vel = [0.5, float('nan')] if k % 3 == 0 else [0.5, 0.2]
        msgs.append(('/joint_states', t, joint_state(['arm', 'crank'], [1.0, c], 1 + k, 0, vel)))
        t += 10**7
        if k % 10 == 4:  # another robot's message: no input, no row
            msgs.append(('/joint_states', t, joint_state(['wrist'], [0.1], 1 + k, 5)))
            t += 10**7
    # names and positions that do not pair up: refused in the node's words
    msgs.append(('/joint_states', t, joint_state(['arm', 'crank'], [1.0], 99, 0)))
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'o.csv'
    args = [src, '--scene', SCENE, '--command-topic', '/joint_states', '--out', out]
    code, cap = run_bag([*args, '--no-progress'], capsys)
    assert code == 1  # without it every row is refused ('arm' is not an actuator)
    code, cap = run_bag([*args, '--state-completion', '--no-progress'], capsys)
    assert code == 0, cap.err  # (one row refused of 41)
    rows = read_csv(out)
    assert len(rows) == len(cranks) + 1  # the other robot's messages have no row
    skipped = len(msgs) - len(rows)
    assert f'{len(msgs)} message(s) read from' in cap.out
    assert f"({skipped} without the mechanism's inputs skipped: --state-completion)" in cap.out
    assert f'  /joint_states: {len(msgs)} ({skipped} skipped)' in cap.out  # read, not rows
    mech = load_scene(str(SCENE)).mechanism
    node = Engine(mech, EngineSettings())
    for k, (row, c) in enumerate(zip(rows, cranks)):
        rate = None if k % 3 == 0 else {'crank': 0.2}  # a NaN velocity: positions alone
        want = node.command({'crank': c}, rate)
        assert row['status'] == 'ok', row['reason']
        for j in mech.joint_names:
            assert math.isclose(float(row[f'joint.{j}']), want.joints[j], abs_tol=1e-12), j
        exact = fourbar(0.3, 0.1, 0.25, 0.2, c, branch=1)
        assert (
            abs(math.remainder(want.links['rocker'] - float(exact['theta4']), 2 * math.pi)) < 1e-12
        )
        if rate is None:
            assert row['velocity.O4'] == ''
        else:
            assert math.isclose(
                float(row['velocity.O4']), want.velocity.joints['O4'], abs_tol=1e-12
            )
    last = rows[-1]
    assert last['status'] == 'error'
    assert last['reason'] == "JointState has 2 name(s) but 1 position(s): cannot read ['crank']"


def test_a_descriptions_full_joint_states_take_its_actuated_joints(tmp_path, capsys):
    """The six-bar's hardware publishes every joint it has, passive ones too (stale values):
    the actuated joints command it, the passive ones are the node's to give. Oracle: the
    engine on the actuated values, published as the node publishes them."""
    from scenes import REPO

    urdf = REPO / 'test' / 'fixtures' / 'robot_descriptions' / 'grbda_six_bar.urdf'
    qs = [(0.2 + 0.01 * k, 0.3 - 0.01 * k, -0.2) for k in range(40)]
    msgs = [
        (
            '/joint_states',
            10**9 + k * 10**7,
            joint_state(
                ['joint1', 'joint2', 'joint3', 'joint4', 'joint5', 'wrist'],
                [*q, 0.0, 0.0, 0.7],
                1 + k,
            ),
        )
        for k, q in enumerate(qs)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'o.csv'
    code, cap = run_bag(
        [src, '--scene', urdf, '--command-topic', '/joint_states', '--state-completion',
         '--out', out, '--no-progress'],
        capsys,
    )  # fmt: skip
    assert code == 0, cap.err
    rows = read_csv(out)
    mech = load_scene(str(urdf)).mechanism
    node = Engine(mech, EngineSettings())
    names = list(mech.output_joint_names)
    for row, q in zip(rows, qs, strict=True):
        want = node.command(dict(zip(('joint1', 'joint2', 'joint3'), q)))
        assert row['status'] == 'ok' and want.success
        got = {n: float(row[f'joint.{n}']) for n in names}
        coords = mech.joint_coordinates
        published = dict(zip(coords.names, coords.positions(want.joints)))
        for n in names:
            assert abs(math.remainder(got[n] - published[n], 2 * math.pi)) <= 1e-12, n
        assert got['joint4'] != 0.0  # the loop's, not the stale recorded 0


def test_a_bag_whose_every_message_is_skipped_is_no_success(tmp_path, capsys):
    """--state-completion on joint states that never name the scene's input (another robot,
    or the wrong --scene): every message is skipped. It exited 0 with a header-only CSV and
    '/joint_states: 0'; now exit 1 (as for a bag whose every command is refused) with the
    reason, and the summary counts the messages read."""
    msgs = [
        ('/joint_states', 10**9 + k * 10**7, joint_state(['wrist', 'elbow'], [0.1, 0.2], 1 + k, 0))
        for k in range(29)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'o.csv'
    args = [src, '--scene', SCENE, '--command-topic', '/joint_states', '--out', out]
    code, cap = run_bag([*args, '--state-completion', '--no-progress'], capsys)
    assert code == 1, cap.out + cap.err
    assert "none of the 29 message(s) read carried the mechanism's inputs" in cap.err
    assert '--scene' in cap.err
    assert '  /joint_states: 29 (29 skipped)' in cap.out
    assert read_csv(out) == []  # the outputs are written, as for every refused bag


def test_a_repeated_input_is_named_alone(tmp_path, capsys):
    """['Z1', 'Z1', 'Z2'] was refused as "JointState names ['Z1', 'Z2'] more than once": the
    rule the node and the bag share (request_checks.pick_refusal) listed every input the
    message carried, not the repeated ones. Oracle: the names each message was written with."""
    twice = 'JointState names {} more than once'
    written = [
        (['Z1', 'Z2', 'Z3'], [1.6, 1.9, 1.5], None),
        (['Z1', 'Z1', 'Z2'], [1.6, 1.61, 1.9], twice.format("['Z1']")),
        (['Z1', 'Z2', 'Z1', 'Z3'], [1.6, 1.9, 1.61, 1.5], twice.format("['Z1']")),
        (['Z3', 'Z3', 'Z1', 'Z1', 'arm'], [1.5] * 5, twice.format("['Z1', 'Z3']")),
    ]
    msgs = [
        ('/joint_states', 10**9 + k * 10**7, joint_state(names, pos, 1 + k, 0))
        for k, (names, pos, _) in enumerate(written)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'o.csv'
    args = [src, '--scene', CONFIG / 'excavator.yaml', '--command-topic', '/joint_states']
    code, cap = run_bag([*args, '--state-completion', '--out', out, '--no-progress'], capsys)
    assert code == 0, cap.err
    rows = read_csv(out)
    assert rows[0]['status'] == 'ok', rows[0]['reason']
    assert [r['reason'] for r in rows[1:]] == [why for _, _, why in written[1:]]


def test_the_result_bag_answers_as_the_node_answers_joint_states_in(tmp_path, capsys):
    """TOPICS.md, State completion: the node's answers to joint_states_in leave the inputs out
    of joint_states (the hardware publishes them) and their statuses say request
    joint_states_in; the result bag carried every joint and 'command' (an outside review).
    --publish-inputs (the node's parameter) puts them back. Oracle: the scene's joint names
    less its inputs, and the node's own status key."""
    from test_bag import read_out_bag

    scene = CONFIG / 'excavator.yaml'
    mech = load_scene(str(scene)).mechanism
    inputs = set(mech.commanded_input_names)
    assert inputs <= set(mech.output_joint_names)  # the premise: Z1..Z3 are joints too
    names = ['boom_light', *sorted(inputs)]
    msgs = [
        (
            '/joint_states',
            (k + 1) * 10**8,
            joint_state(names, [1.0, 1.6, 1.9, 1.5 + 0.01 * k], 1 + k),
        )
        for k in range(5)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    common = [src, '--scene', scene, '--command-topic', '/joint_states', '--no-progress']
    want = {
        False: [j for j in mech.output_joint_names if j not in inputs],
        True: list(mech.output_joint_names),
    }
    for publish in (False, True):
        out = tmp_path / f'out_{publish}'
        extra = ['--publish-inputs'] if publish else []
        code, cap = run_bag([*common, '--state-completion', *extra, '--out', out], capsys)
        assert code == 0, cap.err
        got, _ = read_out_bag(out)
        joint_states = [m for _, m in got['/joint_states']]
        assert len(joint_states) == 5
        assert all(list(m.name) == want[publish] for m in joint_states)
        statuses = [m for _, m in got['/linkage_node/status']]
        requests = {kv.value for m in statuses for kv in m.values if kv.key == 'request'}
        assert requests == {'joint_states_in'}, requests
    code, cap = run_bag([*common, '--publish-inputs', '--out', tmp_path / 'x'], capsys)
    assert code == 2 and '--publish-inputs goes with --state-completion' in cap.err
