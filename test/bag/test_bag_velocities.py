"""``linkage bag`` keeps the velocities recorded in the commands (issue 26 item 9): a ~/command
JointState with one velocity per name is answered, as the node answers it, with every joint's
velocity (CSV/Parquet ``velocity.<joint>``, the output bag's joint_states, the status's
``velocity`` key); a bad velocity is refused with the node's words, the rest stays vectorised.

Oracles: the node's engine (linkage_ros.engine.Engine) answering the same JointState messages
through the node's own conversions (conversions.joint_state_to_command / joint_state_rates);
central differences of the engine's positions (no Jacobian); a description's mimic multiplier.
"""

from __future__ import annotations

import csv
import math

import numpy as np
import pyarrow.parquet as pq
from scenes import CONFIG, REPO
from test_bag import joint_state, make_input, read_out_bag, run_bag

from linkage_ros.core.errors import CommandError
from linkage_ros.core.loading import load_scene
from linkage_ros.core.model import Scene
from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.request_checks import status_values

JS = 'sensor_msgs/msg/JointState'
SCENE = CONFIG / 'four_bar.yaml'
INF, NAN = float('inf'), float('nan')


def node_answers(mech, requests, settings=None):
    """The engine's answers to JointState commands ((names, positions, velocities) each) made
    as the node makes them from the message: (Result or None, reason) per request."""
    from sensor_msgs.msg import JointState

    from linkage_ros.conversions import joint_state_rates, joint_state_to_command

    engine = Engine(mech, settings or EngineSettings('auto', 1e-12, 50, 'continuous'))
    out = []
    for names, pos, vel in requests:
        msg = JointState()
        msg.name, msg.position, msg.velocity = list(names), list(pos), list(vel)
        try:
            r = engine.command(joint_state_to_command(msg), joint_state_rates(msg))
        except CommandError as exc:
            out.append((None, str(exc)))
            continue
        out.append((r, r.reason))
    return out


def run_to_csv(tmp_path, capsys, requests, scene=SCENE, extra=()):
    msgs = [
        ('/cmd', (i + 1) * 10**7, joint_state(names, pos, sec=i + 1, velocity=vel))
        for i, (names, pos, vel) in enumerate(requests)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out_csv, out_bag = tmp_path / 'o.csv', tmp_path / 'o_bag'
    args = [src, '--scene', scene, *extra, '--command-topic', '/cmd']
    code, cap = run_bag([*args, '--out', out_csv, '--out', out_bag, '--no-progress'], capsys)
    assert code == 0, cap.err
    with open(out_csv, newline='') as fh:
        table = list(csv.DictReader(fh))
    msgs = {topic: [m for _, m in got] for topic, got in read_out_bag(out_bag)[0].items()}
    return src, args, table, msgs, cap.out


def crank_stream(n=400):
    """Smooth crank commands (a batch), every fifth without velocities, and bad ones between:
    a rate not finite, two rates for one name, a NaN position with a rate."""
    requests = []
    for i in range(n):
        vel = [] if i % 5 == 0 else [0.6 - 0.003 * i]
        requests.append((['crank'], [0.2 + 0.011 * i], vel))
    requests[100] = (['crank'], [1.3], [INF])
    requests[201] = (['crank'], [2.4], [1.0, 2.0])
    requests[250] = (['crank'], [NAN], [0.3])
    requests[251] = (['crank'], [2.9], [-INF])
    return requests


def test_recorded_velocities_are_the_nodes_answers(tmp_path, capsys):
    """CSV, output bag (joint_states velocity, status velocity) and Parquet carry what the
    node's engine answers to the same commands; the batch path stays in use."""
    requests = crank_stream()
    src, args, table, msgs, out = run_to_csv(tmp_path, capsys, requests)
    batched = int(out.split('vectorised rows ')[1].split(',')[0])
    assert batched > 0.8 * len(requests), out  # velocities do not cost the fast path
    mech = Scene.from_yaml(SCENE).mechanism
    want = node_answers(mech, requests)
    header = list(table[0])
    joints = mech.output_joint_names
    at = header.index(f'joint.{joints[-1]}') + 1
    assert header[at : at + len(joints)] == [f'velocity.{j}' for j in joints]
    js_msgs = iter(msgs['/joint_states'])
    rated = refused = 0
    for (result, reason), row, st in zip(want, table, msgs['/linkage_node/status'], strict=True):
        ok = result is not None and result.success
        assert row['status'] == ('ok' if ok else 'error'), (row, reason)
        got_kv = {v.key: v.value for v in st.values}
        if not ok:
            refused += 1
            assert row['reason'] == st.message == reason and got_kv == {'request': 'command'}
            continue
        want_kv = status_values(result, 'command')
        assert list(got_kv) == list(want_kv)
        js = next(js_msgs)
        assert list(js.position) == [float(row[f'joint.{j}']) for j in joints]
        if result.velocity is None:
            assert 'velocity' not in got_kv and len(js.velocity) == 0
            assert all(row[f'velocity.{j}'] == '' for j in joints)
            continue
        rated += 1
        assert got_kv['velocity'] == want_kv['velocity']
        want_rates = mech.output_joint_rates(result.velocity.joints)
        assert np.allclose(js.velocity, want_rates, rtol=1e-12, atol=1e-12)
        for j, v in zip(joints, want_rates):
            assert math.isclose(float(row[f'velocity.{j}']), v, rel_tol=1e-12, abs_tol=1e-12)
            assert float(row[f'velocity.{j}']) == js.velocity[joints.index(j)]
    assert refused == 4 and rated == sum(1 for _, _, v in requests if len(v) == 1) - 3
    assert next(js_msgs, None) is None
    # the reasons are the node's words for each bad velocity
    assert 'is not finite' in table[100]['reason'] and 'is not finite' in table[251]['reason']
    assert '2 velocities' in table[201]['reason'] and 'finite' in table[250]['reason']
    # the Parquet table of a fleet run has the same velocities
    code, cap = run_bag([src, *args[1:], '--out-dir', tmp_path / 'fleet', '--format', 'parquet'])
    assert code == 0
    pt = pq.read_table(tmp_path / 'fleet' / f'{src.name}.parquet')
    for j in joints:
        want_col = [float(r[f'velocity.{j}']) if r[f'velocity.{j}'] else None for r in table]
        assert pt.column(f'velocity.{j}').to_pylist() == want_col


def test_velocities_agree_with_central_differences_of_the_positions(tmp_path, capsys):
    """d(joint)/dt = d(joint)/d(crank) * crank rate, the derivative a central difference of
    the engine's positions (no Jacobian), for rows of the batch and after refusals."""
    requests = crank_stream()
    _, _, table, _, _ = run_to_csv(tmp_path, capsys, requests)
    mech = Scene.from_yaml(SCENE).mechanism
    h = 1e-6
    checked = 0
    for i in (1, 57, 99, 102, 202, 252, 333, 398):
        (_, (theta,), (rate,)) = requests[i]
        engine = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
        engine.command({'crank': theta - h})
        below = mech.output_joints(engine.command({'crank': theta - h}).joints)
        above = mech.output_joints(engine.command({'crank': theta + h}).joints)
        for j, lo, hi in zip(mech.output_joint_names, below, above):
            want = math.remainder(hi - lo, 2 * math.pi) / (2 * h) * rate
            got = float(table[i][f'velocity.{j}'])
            assert abs(got - want) <= 1e-7 * max(1.0, abs(want)), (i, j, got, want)
            checked += 1
    assert checked == 8 * len(mech.output_joint_names)


def test_a_partial_command_holds_the_others_still(tmp_path, capsys):
    """A two-actuator scene commanded one actuator at a time: the held one moves at 0 rad/s,
    as Engine.command holds it; every answer is the engine's."""
    scene = CONFIG / 'plagiograph.yaml'
    mech = Scene.from_yaml(scene).mechanism
    first, second = list(mech.actuators)
    lo = {a: act.min + 0.4 * (act.max - act.min) for a, act in mech.actuators.items()}
    requests = [([first, second], [lo[first], lo[second]], [0.2, -0.1])]
    requests += [([first], [lo[first] + 0.004 * k], [0.3]) for k in range(1, 80)]
    requests += [([second], [lo[second] + 0.02], [0.5]), ([second], [lo[second] + 0.03], [])]
    _, _, table, msgs, _ = run_to_csv(tmp_path, capsys, requests, scene)
    want = node_answers(mech, requests)
    assert [a.held for a, _ in want[1:3]] == [(second,)] * 2 and want[-2][0].held == (first,)
    rated = 0
    for (result, _), row in zip(want, table, strict=True):
        assert result is not None and result.success and row['status'] == 'ok', row
        if result.velocity is None:
            assert all(row[f'velocity.{j}'] == '' for j in mech.output_joint_names)
            continue
        rated += 1
        for j, v in zip(mech.output_joint_names, mech.output_joint_rates(result.velocity.joints)):
            assert math.isclose(float(row[f'velocity.{j}']), v, rel_tol=1e-12, abs_tol=1e-12)
    assert rated == len(requests) - 1


def test_a_descriptions_velocities_are_in_its_own_joints(tmp_path, capsys):
    """Robotiq 2F-85 (URDF): the left knuckle commanded with a rate in the description's
    values; the right knuckle follows by its mimic (multiplier -1) at minus that rate, and
    every joint's rate is the engine's."""
    fixtures = REPO / 'test' / 'fixtures' / 'robot_descriptions'
    desc = fixtures / 'picknik_robotiq_2f_85.expanded.urdf'
    closures = fixtures / 'picknik_robotiq_2f_85.closures.yaml'
    name = 'robotiq_85_left_knuckle_joint'
    requests = [([name], [v], [0.5 - v]) for v in np.linspace(0.05, 0.75, 40)]
    _, _, table, msgs, _ = run_to_csv(tmp_path, capsys, requests, desc, ['--closures', closures])
    mech = load_scene(str(desc), closures=str(closures)).mechanism
    want = node_answers(mech, requests, EngineSettings())
    for (result, _), row, (_, _, (rate,)), js in zip(
        want, table, requests, msgs['/joint_states'], strict=True
    ):
        assert result is not None and result.success and row['status'] == 'ok'
        assert math.isclose(float(row[f'velocity.{name}']), rate, rel_tol=1e-12, abs_tol=1e-15)
        right = float(row['velocity.robotiq_85_right_knuckle_joint'])
        assert math.isclose(right, -rate, rel_tol=1e-12, abs_tol=1e-15)
        want_rates = mech.output_joint_rates(result.velocity.joints)
        assert list(js.name) == list(mech.output_joint_names)
        assert np.allclose(js.velocity, want_rates, rtol=1e-12, atol=1e-12)


def test_a_bag_without_velocities_has_no_velocity_columns(tmp_path, capsys):
    """Commands without velocities: no velocity columns, empty joint_states velocity, no
    status velocity key (the node's answers to them)."""
    requests = [(['crank'], [0.1 * i], []) for i in range(50)]
    _, _, table, msgs, _ = run_to_csv(tmp_path, capsys, requests)
    assert not [c for c in table[0] if c.startswith('velocity.')]
    assert all(len(js.velocity) == 0 for js in msgs['/joint_states'])
    assert all('velocity' not in {v.key for v in st.values} for st in msgs['/linkage_node/status'])
    assert len(msgs['/joint_states']) == len(requests)  # every command answered
