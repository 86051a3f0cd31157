"""Tests of ``linkage bag`` (linkage_ros/bag.py): offline solving of recorded commands.

The bags are written here with ``rosbags`` in every storage the tool reads (sqlite3 folder, MCAP
folder, a single .mcap file), with JointState commands for a four-bar written to tmp_path, NaN and
malformed commands, unreachable targets, zero stamps, and messages serialised by rclpy exactly as a
recorded ROS bag holds them. Oracles:

* an independent four-bar solution (circle intersection written out below, never the core),
  and loop-closure of the published geometry for inverse (target) rows;
* the node itself: its kinematics engine in-process on long mixed streams, and the running
  ``linkage_node`` over DDS on the same commands, compared to 1e-12;
* a one-by-one run of the core Solver for the vectorised path (10^5 commands).
"""

from __future__ import annotations

import csv
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore
from scenes import REPO

from linkage_ros import bag
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

TS = get_typestore(Stores.ROS2_JAZZY)
JS = 'sensor_msgs/msg/JointState'
SCENE_YAML = (
    'four_bar: {ground: 0.4, crank: 0.1, coupler: 0.35, rocker: 0.3, '
    'coupler_point: {distance: 0.2, angle: 0.5}}\n'
)

GROUND, CRANK, COUPLER, ROCKER, CP_DIST, CP_ANGLE = 0.4, 0.1, 0.35, 0.3, 0.2, 0.5
TOL = 1e-12


# ---- helpers -----------------------------------------------------------------------------------


@pytest.fixture
def scene(tmp_path) -> Path:
    p = tmp_path / 'crank_rocker.yaml'
    p.write_text(SCENE_YAML)
    return p


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def four_bar(theta2: float) -> dict:
    """The crank-rocker at crank angle theta2, written out directly (O2 at the origin, O4 on +x).

    B is the intersection of the circles (A, coupler) and (O4, rocker) on the left of A -> O4:
    the reference pose's assembly mode, which a Grashof crank-rocker keeps for every crank angle
    (its transmission angle never reaches 0 or pi).
    """
    ax, ay = CRANK * math.cos(theta2), CRANK * math.sin(theta2)
    dx, dy = GROUND - ax, -ay
    d = math.hypot(dx, dy)
    ux, uy = dx / d, dy / d
    along = (COUPLER**2 - ROCKER**2 + d**2) / (2 * d)
    h = math.sqrt(COUPLER**2 - along**2)
    bx, by = ax + along * ux - h * uy, ay + along * uy + h * ux
    t3 = math.atan2(by - ay, bx - ax)
    t4 = math.atan2(by, bx - GROUND)
    px = ax + CP_DIST * math.cos(t3 + CP_ANGLE)
    py = ay + CP_DIST * math.sin(t3 + CP_ANGLE)
    return {
        'joints': {'O2': wrap(theta2), 'A': wrap(t3 - theta2), 'B': wrap(t4 - t3), 'O4': wrap(t4)},
        'points': {
            'O2': (0.0, 0.0),
            'A': (ax, ay),
            'B': (bx, by),
            'O4': (GROUND, 0.0),
            'P': (px, py),
        },
    }


def joint_state(names, positions, sec=0, nanosec=0, velocity=(), frame=''):
    m = TS.types
    return m[JS](
        header=m['std_msgs/msg/Header'](
            stamp=m['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame
        ),
        name=list(names),
        position=np.asarray(positions, float),
        velocity=np.asarray(velocity, float),
        effort=np.zeros(0),
    )


def rclpy_bytes(names, positions, sec, nanosec, velocity=()) -> bytes:
    """A JointState serialised by rclpy (Fast-CDR): the bytes a recorded ROS bag holds."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    msg.velocity = [float(v) for v in velocity]
    return serialize_message(msg)


def write_bag(path: Path, storage: str, messages, extra_topics=()):
    """messages: (topic, bag time ns, message object or raw CDR bytes)."""
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns = {}
        for topic, _, _ in messages:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, JS, typestore=TS)
        for topic, msgtype, msg in extra_topics:
            c = w.add_connection(topic, msgtype, typestore=TS)
            w.write(c, 1, TS.serialize_cdr(msg, msgtype))
        for topic, t, msg in messages:
            raw = msg if isinstance(msg, bytes) else TS.serialize_cdr(msg, JS)
            w.write(conns[topic], t, raw)


def run_bag(args, capsys=None):
    code = bag.main([str(a) for a in args])
    out = capsys.readouterr() if capsys is not None else None
    return code, out


def read_csv(path: Path):
    with open(path, newline='') as fh:
        rows = list(csv.DictReader(fh))
    return rows


def read_out_bag(path: Path):
    out = {}
    with Reader(path) as r:
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, TS.deserialize_cdr(raw, conn.msgtype)))
        types = {c.topic: c.msgtype for c in r.connections}
    return out, types


def stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


# ---- a command stream with every kind of row ---------------------------------------------------


def mixed_stream():
    """(topic, bag time, stamp (sec, ns), names, positions, kind) for the round-trip test."""
    rows = []
    t = 1_700_000_000 * 10**9
    for i in range(120):
        theta = -3.0 + 0.11 * i  # sweeps past +-pi (wrapping)
        sec, ns = divmod(t + 7_000_000 * i, 10**9)
        names, pos, kind = ['crank'], [theta], 'ok'
        if i % 17 == 5:
            pos, kind = [float('nan')], 'nan'
        elif i % 29 == 7:
            names, pos, kind = ['wrench'], [0.3], 'name'
        elif i == 40:
            names, pos, kind = ['crank'], [0.1, 0.2], 'shape'
        elif i in (50, 51):
            sec, ns = 0, 0  # zero stamp -> bag receive time
        rows.append(('/cmd', t + 7_000_000 * i + 1000, (sec, ns), names, pos, kind))
    # inverse kinematics on the rocker angle (joint O4): reachable, then unreachable
    t2 = t + 7_000_000 * 120
    for j, (o4, kind) in enumerate([(1.9, 'ik'), (1.95, 'ik'), (1.0, 'unreachable'), (2.0, 'ik')]):
        sec, ns = divmod(t2 + 5_000_000 * j, 10**9)
        rows.append(('/target', t2 + 5_000_000 * j + 1000, (sec, ns), ['O4'], [o4], kind))
    t3 = t2 + 5_000_000 * 4
    for k in range(10):  # commands again: continuity after IK
        sec, ns = divmod(t3 + 7_000_000 * k, 10**9)
        rows.append(
            ('/cmd', t3 + 7_000_000 * k + 1000, (sec, ns), ['crank'], [0.5 + 0.2 * k], 'ok')
        )
    return rows


def recorded_velocity(i: int) -> list[float]:
    """The velocity array stream_messages records with row i: every other command gives one
    rate (rad/s; the streams' commands name one actuator), zero among them, the rest none."""
    return [0.1 * (i % 7) - 0.3] * (i % 2)


def stream_messages(rows, rclpy_every=0):
    msgs = []
    for i, (topic, t, (sec, ns), names, pos, _) in enumerate(rows):
        vel = recorded_velocity(i)
        if rclpy_every and i % rclpy_every == 0:
            msgs.append((topic, t, rclpy_bytes(names, pos, sec, ns, vel)))
        else:
            msgs.append((topic, t, joint_state(names, pos, sec, ns, velocity=vel)))
    return msgs


def four_bar_rates(theta2: float, rate: float, h: float = 1e-5) -> dict:
    """Every joint's velocity (rad/s) at crank angle theta2 turning at ``rate``: a central
    difference of the closed-form four_bar (an oracle independent of the core's Jacobian)."""
    up, down = four_bar(theta2 + h)['joints'], four_bar(theta2 - h)['joints']
    return {j: wrap(up[j] - down[j]) / (2 * h) * rate for j in up}


STORAGES = ['sqlite3', 'mcap', 'mcap-file']


def make_input(tmp_path: Path, storage: str, messages) -> Path:
    folder = tmp_path / f'in_{storage}'
    write_bag(folder, 'mcap' if storage.startswith('mcap') else 'sqlite3', messages)
    if storage == 'mcap-file':
        return folder / f'{folder.name}.mcap'
    return folder


# ---- round trip: CSV and output bag ------------------------------------------------------------


@pytest.mark.parametrize('storage', STORAGES)
def test_csv_and_bag_outputs(tmp_path, scene, storage, capsys):
    rows = mixed_stream()
    src = make_input(tmp_path, storage, stream_messages(rows, rclpy_every=3))
    out_csv, out_bag = tmp_path / 'out.csv', tmp_path / 'out_bag'
    code, out = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--target-topic',
            '/target',
            '--out',
            out_csv,
            '--out',
            out_bag,
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, out.err
    assert f'{len(rows)} message(s) read' in out.out and 'refused' in out.out

    table = read_csv(out_csv)
    assert len(table) == len(rows)  # one row per command, refused ones included
    header = list(table[0])
    assert header[:4] == ['time', 'receive_time', 'topic', 'input.crank']
    assert header[-5:] == ['residual', 'margin', 'branch', 'status', 'reason']
    for p in ('O2', 'A', 'B', 'O4', 'P'):
        assert f'{p}.x' in header and f'{p}.y' in header
    # commands gave velocities: every joint's velocity follows the joints (as the node answers)
    joints = ['O2', 'A', 'B', 'O4']
    at = header.index('joint.O4') + 1
    assert header[at : at + 4] == [f'velocity.{j}' for j in joints]
    refused = rated = 0
    for i, (row, (topic, t, (sec, ns), _names, pos, kind)) in enumerate(zip(table, rows)):
        assert row['topic'] == topic
        assert row['receive_time'] == f'{t // 10**9}.{t % 10**9:09d}'
        assert row['time'] == f'{sec}.{ns:09d}'
        if kind in ('nan', 'name', 'shape', 'unreachable'):
            refused += 1
            assert row['status'] == 'error' and row['reason'], row
            assert row['joint.O2'] == '' and row['P.x'] == ''
            want = {
                'nan': 'must be finite',
                'name': "unknown name(s) ['wrench']",
                'shape': 'JointState has 1 name(s)',
                'unreachable': 'cannot assemble',
            }[kind]
            assert want in row['reason']
            assert (
                row['input.crank']
                == {'nan': 'nan', 'name': '', 'shape': '', 'unreachable': ''}[kind]
            )
            continue
        assert row['status'] == 'ok' and row['reason'] == '' and row['branch'] == '+'
        got_j = {j: float(row[f'joint.{j}']) for j in ('O2', 'A', 'B', 'O4')}
        got_p = {p: (float(row[f'{p}.x']), float(row[f'{p}.y'])) for p in ('A', 'B', 'P')}
        assert float(row['residual']) < 1e-12
        if kind == 'ok':
            want = four_bar(pos[0])
            assert float(row['input.crank']) == pos[0]
            for j, v in want['joints'].items():
                assert abs(wrap(got_j[j] - v)) < TOL, (j, row)
            for p in got_p:
                assert np.allclose(got_p[p], want['points'][p], rtol=0, atol=TOL), (p, row)
            vel = recorded_velocity(i)
            if vel:
                rated += 1
                for j, v in four_bar_rates(pos[0], vel[0]).items():
                    assert abs(float(row[f'velocity.{j}']) - v) < 1e-8, (j, row)
            else:
                assert all(row[f'velocity.{j}'] == '' for j in joints), row
        else:  # IK: the target is met, the loop closes (a target's velocity is not read)
            assert all(row[f'velocity.{j}'] == '' for j in joints), row
            assert abs(got_j['O4'] - pos[0]) < TOL
            (ax, ay), (bx, by) = got_p['A'], got_p['B']
            assert abs(math.hypot(ax, ay) - CRANK) < TOL
            assert abs(math.hypot(bx - ax, by - ay) - COUPLER) < TOL
            assert abs(math.hypot(bx - GROUND, by) - ROCKER) < TOL
            assert abs(wrap(math.atan2(ay, ax) - float(row['input.crank']))) < TOL
    assert refused == sum(1 for r in rows if r[5] in ('nan', 'name', 'shape', 'unreachable'))
    assert rated == sum(1 for i, r in enumerate(rows) if r[5] == 'ok' and recorded_velocity(i))

    msgs, types = read_out_bag(out_bag)
    assert types == {
        '/joint_states': JS,
        '/linkage_node/points/P': 'geometry_msgs/msg/PointStamped',
        '/linkage_node/status': 'diagnostic_msgs/msg/DiagnosticStatus',
    }
    ok_rows = [(r, c) for r, c in zip(table, rows) if r['status'] == 'ok']
    assert len(msgs['/linkage_node/status']) == len(rows)
    assert len(msgs['/joint_states']) == len(msgs['/linkage_node/points/P']) == len(ok_rows)
    for (t, js), (tp, pt), (row, (_topic, tr, (sec, ns), *_)) in zip(
        msgs['/joint_states'], msgs['/linkage_node/points/P'], ok_rows
    ):
        want_stamp = sec * 10**9 + ns if (sec or ns) else tr
        assert t == tp == tr  # logged at the command's bag time
        assert stamp_ns(js) == stamp_ns(pt) == want_stamp
        assert js.header.frame_id == pt.header.frame_id == 'world'
        assert list(js.name) == ['O2', 'A', 'B', 'O4']
        # a command with velocities is answered with every joint's (the CSV's), else none
        want_vel = [float(row[f'velocity.{j}']) for j in js.name if row[f'velocity.{j}']]
        assert list(js.velocity) == want_vel and len(want_vel) in (0, 4)
        assert list(js.position) == [float(row[f'joint.{j}']) for j in js.name]
        assert (pt.point.x, pt.point.y, pt.point.z) == (float(row['P.x']), float(row['P.y']), 0)
    for (t, st), row, (topic, tr, *_) in zip(msgs['/linkage_node/status'], table, rows):
        assert t == tr
        assert st.name == 'linkage_node: crank_rocker' and st.hardware_id == 'crank_rocker'
        kv = {v.key: v.value for v in st.values}
        assert kv['request'] == ('command' if topic == '/cmd' else 'target')
        if row['status'] == 'ok':
            assert st.level == 0 and st.message == 'ok'
            assert kv['branch'] == '+' and kv['solver'] == 'closed_form'
            # the status of an answer with velocities says so (request_checks.status_values)
            assert ('velocity' in kv) == bool(row['velocity.O2'])
            assert kv.get('velocity', 'ok (cond ').startswith('ok (cond ')
            assert float(kv['residual']) == float(row['residual'])
            assert float(kv['margin']) == float(row['margin'])
        else:
            assert st.level == 2 and st.message == row['reason']


def test_sqlite3_output_and_zero_stamps(tmp_path, scene, capsys):
    """--out-format sqlite3 writes a sqlite3 bag; zero stamps become the bag receive time."""
    msgs = [('/cmd', 5_000_000_000 + i, joint_state(['crank'], [0.1 * i])) for i in range(40)]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'res'
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--out',
            out,
            '--out-format',
            'sqlite3',
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert list(out.glob('*.db3'))
    got, _ = read_out_bag(out)
    assert [stamp_ns(m) for _, m in got['/joint_states']] == [5_000_000_000 + i for i in range(40)]
    for i, (_, m) in enumerate(got['/joint_states']):
        want = four_bar(0.1 * i)['joints']
        assert np.allclose(m.position, [want[j] for j in m.name], rtol=0, atol=TOL)


# ---- the node's answers ------------------------------------------------------------------------


def _node_engine(scene_file, **params):
    """The node's session (linkage_ros.engine.Engine, as the node loads it), in-process, solving
    one command at a time, for a scene file."""
    if not (REPO / 'linkage_ros' / 'node.py').exists():
        pytest.skip('linkage_ros/node.py does not exist yet: no node to compare with')
    import linkage_ros.node as node

    mech = Scene.from_yaml(scene_file).mechanism
    return mech, node.load_engine(node.make_config({'scene': str(scene_file), **params}))[1]


def _compare_with_engine(table, rows, engine) -> int:
    """Every CSV row equals the node engine's answer to the same request, in the same order,
    the velocities of the commands that gave some (recorded_velocity) included; returns how
    many rows had velocities."""
    from sensor_msgs.msg import JointState

    from linkage_ros.conversions import joint_state_rates, joint_state_to_command
    from linkage_ros.core.errors import CommandError

    rated = 0
    for i, (row, (topic, _, _, names, pos, *_)) in enumerate(zip(table, rows)):
        msg = JointState()
        msg.name, msg.position = list(names), [float(v) for v in pos]
        msg.velocity = recorded_velocity(i)
        try:
            cmd = joint_state_to_command(msg)
            if topic == '/cmd':
                r = engine.command(cmd, joint_state_rates(msg))
            else:
                r = engine.target(cmd)
        except CommandError as exc:
            assert row['status'] == 'error' and row['reason'] == str(exc)
            continue
        assert row['status'] == ('ok' if r.success else 'error'), (row, r.reason)
        if not r.success:
            assert row['reason'] == r.reason
            continue
        assert row['branch'] == r.branch
        for j, v in r.joints.items():
            assert abs(float(row[f'joint.{j}']) - v) <= TOL
        for p, (x, y) in r.points.items():
            assert abs(float(row[f'{p}.x']) - x) <= TOL and abs(float(row[f'{p}.y']) - y) <= TOL
        for a, v in r.inputs.items():
            assert abs(float(row[f'input.{a}']) - v) <= TOL
        vel = r.velocity
        if vel is None or not vel.success:
            assert all(row.get(f'velocity.{j}', '') == '' for j in r.joints), row
            continue
        rated += 1
        for j, v in vel.joints.items():
            assert abs(float(row[f'velocity.{j}']) - v) <= TOL * max(1.0, abs(v)), (j, row)
    return rated


def _summary_count(text: str, what: str) -> int:
    return int(text.split(f'{what} ')[1].split(',')[0].split()[0])


@pytest.mark.parametrize('branch', ['continuous', 'reference'])
def test_matches_node_engine_on_jumpy_mixed_stream(tmp_path, scene, branch, capsys):
    """Long runs (vectorised), jumps of any size, IK in between, bad rows: the node's answers."""
    _, engine = _node_engine(scene, branch=branch)
    rng = np.random.default_rng(7)
    rows, t = [], 10**12
    for seg in range(40):
        kind = seg % 5
        n = int(rng.integers(20, 400))
        for i in range(n if kind != 3 else 3):
            t += 1_000_000
            if kind in (0, 4):
                v = [0.7 * seg + 0.013 * i]  # smooth
            elif kind == 1:
                v = [float(rng.uniform(-4, 4))]  # any jump
            elif kind == 2:
                v = [float(rng.uniform(-1, 1)) + (seg % 2) * np.pi]  # jumps near +-pi
            else:
                v = [float('nan')]
            rows.append(('/cmd', t, (0, 0), ['crank'], v, ''))
        if seg % 4 == 1:
            for o4 in (1.85, float(rng.uniform(0.5, 3.0)), 2.05):
                t += 1_000_000
                rows.append(('/target', t, (0, 0), ['O4'], [o4], ''))
    src = make_input(tmp_path, 'mcap', stream_messages(rows))
    out_csv = tmp_path / 'o.csv'
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--target-topic',
            '/target',
            '--branch',
            branch,
            '--out',
            out_csv,
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert _summary_count(cap.out, 'vectorised rows') > 0.8 * len(rows)
    # every row is counted once: batched, one by one, or refused as the message stands
    ways = ('vectorised rows', 'one-by-one rows', 'refused before any solve')
    counted = [_summary_count(cap.out, w) if f'{w} ' in cap.out else 0 for w in ways]
    assert sum(counted) == len(rows), cap.out
    table = read_csv(out_csv)
    assert len(table) == len(rows)
    assert _compare_with_engine(table, rows, engine) > 0  # velocities compared too


@pytest.mark.parametrize('linkage', ['triple_rocker', 'parallelogram', 'near_change_point'])
def test_matches_node_engine_through_toggles(tmp_path, linkage, capsys):
    """Where a dyad passes near its singularity the node decides the branch by its prediction,
    so those rows go one by one with the node's exact history.

    triple rocker: driven into and back from its toggles (|crank| <= 1.2986) and jumping about.
    parallelogram (a change-point linkage): turned smoothly through its flat positions, where the
    parallelogram motion crosses to the other side of A -> O4: continuity follows it (the dyad's
    branch sign flips, the rocker stays parallel to the crank), which a fixed-sign batch would not.
    near change point (s + l = p + q - 1e-8 of the lengths, steps of 0.06 rad): the dyad dips to
    margin ~5e-5 each turn and keeps its circuit (the side of B from A -> O4 never changes,
    written out here), where the prediction alone took the other one every turn.
    """
    yaml_text = {
        'triple_rocker': 'four_bar: {ground: 0.5, crank: 0.4, coupler: 0.25, rocker: 0.3, '
        'coupler_point: {distance: 0.1, angle: 0.3}}\n',
        'parallelogram': 'four_bar: {ground: 0.4, crank: 0.1, coupler: 0.4, rocker: 0.1, '
        'coupler_point: {distance: 0.2, angle: 0.0}}\n',
        'near_change_point': 'four_bar: {ground: 0.4, crank: 0.15, coupler: 0.549999999, '
        'rocker: 0.3, coupler_point: {distance: 0.2, angle: 0.0}}\n',
    }[linkage]
    path = tmp_path / f'{linkage}.yaml'
    path.write_text(yaml_text)
    _, engine = _node_engine(path)
    rng = np.random.default_rng(5)
    values = []
    if linkage == 'triple_rocker':
        for seg in range(9):
            if seg % 3 == 0:
                values += list(np.linspace(-1.45, 1.45, 300)) + list(np.linspace(1.45, -1.45, 300))
            elif seg % 3 == 1:
                values += list(rng.uniform(-1.4, 1.4, 200))
            else:
                values += list(1.2 + np.cumsum(rng.normal(0, 0.03, 200)))
    elif linkage == 'parallelogram':
        values = list(np.linspace(1.0, 1.0 + 6 * np.pi, 3000))
    else:
        values = list(np.linspace(1.0, 1.0 + 6 * np.pi, 300))
    rows = [
        ('/cmd', 10**12 + 10**6 * i, (0, 0), ['crank'], [float(v)], '')
        for i, v in enumerate(values)
    ]
    src = make_input(tmp_path, 'sqlite3', stream_messages(rows))
    out_csv = tmp_path / 't.csv'
    code, cap = run_bag(
        [src, '--scene', path, '--command-topic', '/cmd', '--out', out_csv, '--no-progress'], capsys
    )
    assert code == 0, cap.err
    # (a coarse step near a fold goes one by one: 48 of 300 near the change point)
    share = 0.8 if linkage == 'near_change_point' else 0.9
    assert _summary_count(cap.out, 'vectorised rows') > share * len(rows)
    assert _summary_count(cap.out, 'one-by-one rows') > 0  # near the singularities
    table = read_csv(out_csv)
    if linkage == 'triple_rocker':
        assert sum(r['status'] == 'error' for r in table) > 50  # beyond the toggles
    elif linkage == 'near_change_point':
        sides = set()
        for r in table:
            ax, ay, bx, by = (float(r[k]) for k in ('A.x', 'A.y', 'B.x', 'B.y'))
            sides.add(np.sign((GROUND - ax) * (by - ay) - (0.0 - ay) * (bx - ax)))
        assert len(sides) == 1 and all(r['status'] == 'ok' for r in table)
        assert min(float(r['margin']) for r in table) < 1e-2  # it did pass near the fold
    else:
        flips = sum(a['branch'] != b['branch'] for a, b in zip(table, table[1:]))
        assert flips == 6  # 2 flat positions a turn
        for r in table:
            assert abs(wrap(float(r['joint.O4']) - float(r['joint.O2']))) < 1e-9
    assert _compare_with_engine(table, rows, engine) > 0  # velocities compared too


def test_newton_solver_is_sequential_and_matches_node(tmp_path, scene, capsys):
    mech, engine = _node_engine(scene, solver='newton')
    from linkage_ros.conversions import result_to_status

    rows = [
        ('/cmd', 10**9 + i, (1, i), ['crank'], [0.4 * i if i != 6 else float('nan')], '')
        for i in range(25)
    ]
    src = make_input(tmp_path, 'sqlite3', stream_messages(rows))
    out_csv, out_bag = tmp_path / 'o.csv', tmp_path / 'o_bag'
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--solver',
            'newton',
            '--out',
            out_csv,
            '--out',
            out_bag,
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert 'one-by-one rows 24, refused before any solve 1' in cap.out  # (row 6: NaN)
    table = read_csv(out_csv)
    assert _compare_with_engine(table, rows, engine) > 0  # velocities compared too
    # the status messages are the node's (conversions.result_to_status), cond included
    _, replay = _node_engine(scene, solver='newton')
    got, _ = read_out_bag(out_bag)
    for i, ((_, st), r) in enumerate(zip(got['/linkage_node/status'], rows)):
        vel = recorded_velocity(i)  # the node answers a command's velocities with the joints'
        rates = {'crank': vel[0]} if vel else None
        want = result_to_status(replay.command({'crank': r[4][0]}, rates), st.name, 'command')
        assert (st.level, st.message, st.name) == (
            want.level[0] if isinstance(want.level, bytes) else want.level,
            want.message,
            f'linkage_node: {mech.name}',
        )
        assert [v.key for v in st.values] == [v.key for v in want.values]
        for a, b in zip(st.values, want.values):
            if a.key in ('residual', 'margin', 'cond'):
                assert math.isclose(float(a.value), float(b.value), rel_tol=1e-9, abs_tol=1e-15)
            else:
                assert a.value == b.value
    for i, (row, r) in enumerate(zip(table, rows)):
        if row['status'] == 'ok':
            want = four_bar(r[4][0])['joints']
            assert all(abs(wrap(float(row[f'joint.{j}']) - v)) < 1e-9 for j, v in want.items())
            vel = recorded_velocity(i)
            if vel:  # the velocities against a central difference of the closed form
                want_v = four_bar_rates(r[4][0], vel[0])
                assert all(abs(float(row[f'velocity.{j}']) - v) < 1e-8 for j, v in want_v.items())


def test_matches_running_node_over_dds(tmp_path, scene):
    """The bag's answers equal linkage_node's, over DDS, for the same commands (1e-12)."""
    if not (REPO / 'linkage_ros' / 'node.py').exists():
        pytest.skip('linkage_ros/node.py does not exist yet: no node to compare with')
    from diagnostic_msgs.msg import DiagnosticStatus
    from ros_harness import NodeProcess, RosHarness, random_domain_id
    from sensor_msgs.msg import JointState

    rows = [r for r in mixed_stream() if r[2] != (0, 0)]  # stamps identify answers
    src = make_input(tmp_path, 'mcap', stream_messages(rows))
    out_bag = tmp_path / 'answers'
    assert (
        bag.main(
            [
                str(src),
                '--scene',
                str(scene),
                '--command-topic',
                '/cmd',
                '--target-topic',
                '/target',
                '--out',
                str(out_bag),
                '--no-progress',
            ]
        )
        == 0
    )
    offline, _ = read_out_bag(out_bag)

    domain = random_domain_id()
    node = NodeProcess(tmp_path / 'node', domain, params={'scene': str(scene)}).start()
    ros = RosHarness(domain, name='bag_test')
    try:
        pubs = {
            '/cmd': ros.publisher(JointState, node.topic('~/command')),
            '/target': ros.publisher(JointState, node.topic('~/target')),
        }
        joints = ros.collector(JointState, node.topic('joint_states'))
        status = ros.collector(DiagnosticStatus, node.topic('~/status'))
        ros.wait_for_discovery(list(pubs.values()), [joints, status], timeout=30.0, process=node)
        for i, (topic, _, (sec, ns), names, pos, _) in enumerate(rows):
            msg = JointState()
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec, ns
            msg.name, msg.position = list(names), [float(v) for v in pos]
            msg.velocity = recorded_velocity(i)  # as the bag recorded it
            before = len(status)
            ros.publish(pubs[topic], msg)
            assert ros.spin_until(lambda: len(status) > before, 15.0, node), (
                f'no status for {topic} {names} {pos}'
            )
    finally:
        ros.close()
        node.stop()
    assert len(status.messages) == len(offline['/linkage_node/status'])
    for live, (_, off) in zip(status.messages, offline['/linkage_node/status']):
        level = live.level[0] if isinstance(live.level, bytes) else int(live.level)
        # the live node runs in a namespace: its status names carry it (the bag's names are
        # those of a node in the root namespace)
        ns = node.namespace.lstrip('/')
        assert (level, live.message, live.name) == (off.level, off.message, f'{ns}/{off.name}')
        lkv = {v.key: v.value for v in live.values}
        okv = {v.key: v.value for v in off.values}
        assert lkv.keys() == okv.keys()
        for k in lkv:
            if k in ('residual', 'margin'):
                assert abs(float(lkv[k]) - float(okv[k])) <= TOL
            else:
                assert lkv[k] == okv[k], k
    assert len(joints.messages) == len(offline['/joint_states'])
    rated = 0
    for live, (_, off) in zip(joints.messages, offline['/joint_states']):
        assert stamp_ns(live) == stamp_ns(off)
        assert list(live.name) == list(off.name) and live.header.frame_id == off.header.frame_id
        assert np.max(np.abs(np.asarray(live.position) - off.position)) <= TOL
        # the velocities of a command that gave some: every joint's, the node's own
        assert len(live.velocity) == len(off.velocity)
        if len(off.velocity):
            rated += 1
            assert np.max(np.abs(np.asarray(live.velocity) - off.velocity)) <= TOL
    assert rated > 0


# ---- the vectorised path -----------------------------------------------------------------------


def test_vectorised_path_matches_one_by_one_solver(tmp_path, scene, capsys):
    n = 100_000
    rng = np.random.default_rng(3)
    theta = np.cumsum(rng.normal(0.0, 0.05, n))  # a random walk, many turns
    theta[rng.choice(n, 300, replace=False)] = rng.uniform(-4, 4, 300)  # jumps
    theta[::997] = np.nan
    # serialise once, then patch stamp and value bytes (the fast way to make a big bag)
    tmpl = bytes(TS.serialize_cdr(joint_state(['crank'], [0.123456789]), JS))
    off = tmpl.index(np.float64(0.123456789).tobytes())  # where position[0] is
    buf = np.tile(np.frombuffer(tmpl, np.uint8), (n, 1))
    ns = 10**9 + np.arange(n, dtype=np.int64) * 1_000_000
    buf[:, 4:8] = (ns // 10**9).astype('<i4').view(np.uint8).reshape(n, 4)
    buf[:, 8:12] = (ns % 10**9).astype('<u4').view(np.uint8).reshape(n, 4)
    buf[:, off : off + 8] = theta.astype('<f8').view(np.uint8).reshape(n, 8)
    folder = tmp_path / 'big'
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection('/cmd', JS, typestore=TS)
        for i, t in enumerate(ns.tolist()):
            w.write(c, t, buf[i].tobytes())
    out_csv = tmp_path / 'big.csv'
    t0 = time.perf_counter()
    code, cap = run_bag(
        [folder, '--scene', scene, '--command-topic', '/cmd', '--out', out_csv, '--no-progress'],
        capsys,
    )
    elapsed = time.perf_counter() - t0
    assert code == 0, cap.err
    assert _summary_count(cap.out, 'vectorised rows') >= 0.99 * n, cap.out
    assert elapsed < 30.0, f'{n} commands took {elapsed:.1f} s'
    with open(out_csv, newline='') as fh:
        reader = csv.reader(fh)
        header = next(reader)
        table = list(reader)
    assert len(table) == n
    col = {name: k for k, name in enumerate(header)}
    # one by one, as the node does: a continuous Solver that starts from the reference pose
    mech = Scene.from_yaml(scene).mechanism
    solver = Solver(mech)
    assert solver.solve(solver.reference_values()).success
    sample = set(rng.choice(n, 3000, replace=False).tolist())
    checked = 0
    for i in range(n):
        if i not in sample and i % 50:
            continue  # continuity of a crank-rocker: a subsequence suffices
        r = solver.solve({'crank': float(theta[i])})
        row = table[i]
        assert (row[col['status']] == 'ok') == r.success
        if not r.success:
            assert row[col['reason']] == r.reason
            continue
        for j in ('O2', 'A', 'B', 'O4'):
            assert abs(float(row[col[f'joint.{j}']]) - r.joints[j]) <= TOL
        for p in ('A', 'B', 'P'):
            assert abs(float(row[col[f'{p}.x']]) - r.points[p][0]) <= TOL
            assert abs(float(row[col[f'{p}.y']]) - r.points[p][1]) <= TOL
        checked += 1
    assert checked > 2000
    assert sum(row[col['status']] == 'error' for row in table) == np.count_nonzero(np.isnan(theta))


# ---- bad input ---------------------------------------------------------------------------------


def _bad(args, capsys):
    code = bag.main([str(a) for a in args])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.count('\n') == 0 and err.startswith('linkage bag: error:'), err
    return err


def test_bad_bags_exit_2_with_one_clear_message(tmp_path, scene, capsys):
    good = make_input(
        tmp_path,
        'mcap',
        [('/cmd', 1000 + i, joint_state(['crank'], [0.1 * i])) for i in range(200)],
    )
    common = ['--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'x.csv']
    # missing
    assert 'no such file' in _bad([tmp_path / 'nothing_here', *common], capsys)
    # not a bag: a text file, a folder without metadata and storage
    text = tmp_path / 'notes.txt'
    text.write_text('hello')
    assert 'not a rosbag2' in _bad([text, *common], capsys)
    empty = tmp_path / 'emptydir'
    empty.mkdir()
    assert 'not a rosbag2' in _bad([empty, *common], capsys)
    # a folder holding one storage file and more bags below it: not that one bag alone (only
    # the file was read, the others left out without a word)
    holder = tmp_path / 'recordings'
    holder.mkdir()
    shutil.copy(good / 'in_mcap.mcap', holder / 'single.mcap')
    shutil.copytree(good, holder / 'day1' / 'run')
    err = _bad([holder, *common], capsys)
    assert 'more bags below it (day1/run, ...)' in err and '--out-dir' in err, err
    shutil.rmtree(holder / 'day1')
    code, cap = run_bag([holder, *common, '--no-progress'], capsys)
    assert code == 0, cap.err  # the one file alone is that bag, as before
    # a .mcap that is not MCAP at all
    fake = tmp_path / 'fake.mcap'
    fake.write_bytes(b'not an mcap file' * 10)
    assert 'cannot open' in _bad([fake, *common], capsys)
    # missing topic: the topics that exist are listed
    err = _bad(
        [good, '--scene', scene, '--command-topic', '/nope', '--out', tmp_path / 'x.csv'], capsys
    )
    assert 'topic /nope is not in the bag' in err and '/cmd (sensor_msgs/msg/JointState)' in err
    err = _bad([good, *common, '--target-topic', '/missing'], capsys)
    assert '/missing' in err and '/cmd' in err
    # wrong message type: expected and found named
    typed = tmp_path / 'typed'
    string = TS.types['std_msgs/msg/String'](data='x')
    write_bag(
        typed,
        'sqlite3',
        [('/cmd', 5, joint_state(['crank'], [0.2]))],
        extra_topics=[('/words', 'std_msgs/msg/String', string)],
    )
    err = _bad(
        [typed, '--scene', scene, '--command-topic', '/words', '--out', tmp_path / 'x.csv'], capsys
    )
    assert 'std_msgs/msg/String' in err and 'expected sensor_msgs/msg/JointState' in err
    # truncated MCAP (folder and single file)
    mcap = good / f'{good.name}.mcap'
    cut = tmp_path / 'cut'
    shutil.copytree(good, cut)
    data = mcap.read_bytes()
    (cut / mcap.name).write_bytes(data[: len(data) // 2])
    assert 'truncated' in _bad([cut, *common], capsys)
    cutfile = tmp_path / 'cut.mcap'
    cutfile.write_bytes(data[: len(data) // 2])
    err = _bad([cutfile, *common], capsys)
    assert 'truncated' in err or 'corrupt' in err
    # corrupt sqlite3 database
    sq = tmp_path / 'sq'
    write_bag(
        sq, 'sqlite3', [('/cmd', 1000 + i, joint_state(['crank'], [0.1 * i])) for i in range(200)]
    )
    db = next(sq.glob('*.db3'))
    raw = bytearray(db.read_bytes())
    raw[100 : len(raw)] = os.urandom(len(raw) - 100)
    db.write_bytes(bytes(raw))
    err = _bad([sq, *common], capsys)
    assert 'corrupt' in err or 'truncated' in err
    # unreadable metadata: still one line
    meta = tmp_path / 'meta'
    shutil.copytree(good, meta)
    (meta / 'metadata.yaml').write_text('rosbag2_bagfile_information: {version: [')
    assert 'cannot open the bag' in _bad([meta, *common], capsys)
    # a message whose CDR is cut short
    short = tmp_path / 'short'
    write_bag(
        short,
        'mcap',
        [('/cmd', 7, bytes(TS.serialize_cdr(joint_state(['crank'], [0.3]), JS))[:30])],
    )
    err = _bad([short, *common], capsys)
    assert 'not a valid JointState' in err and 'corrupt' in err
    # outputs: an existing output bag is not overwritten
    exists = tmp_path / 'exists'
    exists.mkdir()
    assert 'exists already' in _bad(
        [good, '--scene', scene, '--command-topic', '/cmd', '--out', exists], capsys
    )
    # a bad scene or branch is a usage error too
    assert 'scene file not found' in _bad(
        [
            good,
            '--scene',
            tmp_path / 'no.yaml',
            '--command-topic',
            '/cmd',
            '--out',
            tmp_path / 'x.csv',
        ],
        capsys,
    )
    assert 'branch' in _bad([good, *common, '--branch', '+-+'], capsys)


def test_nan_commands_are_refused_rows(tmp_path, scene, capsys):
    msgs = [
        ('/cmd', 100 + i, joint_state(['crank'], [float('nan') if i % 3 else 0.2 * i]))
        for i in range(60)
    ]
    src = make_input(tmp_path, 'sqlite3', msgs)
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--out',
            tmp_path / 'n.csv',
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0
    table = read_csv(tmp_path / 'n.csv')
    assert len(table) == 60
    for i, row in enumerate(table):
        if i % 3:
            assert row['status'] == 'error' and row['input.crank'] == 'nan'
            assert row['reason'] == 'crank: value must be finite (got nan)'
        else:
            assert row['status'] == 'ok'
    assert '40 x crank: value must be finite (got nan)' in cap.out


def test_the_summary_shows_each_kind_of_refusal_by_a_real_one(tmp_path, capsys):
    """Refusals count together by kind (their numbers blanked), and the summary printed the
    blanked kind: 'Z1 = # m is beyond its maximum # by # m', with every number in the advice
    text a '#' too (an outside new user). Each kind is now shown by its first refusal, 'e.g.'
    where the numbers differ; a bag with nothing on the topics given says so."""
    path = tmp_path / 'limited.yaml'
    path.write_text(SCENE_YAML.replace('}}', '}, crank_limits: {min: -1.5, max: 1.5}}'))
    values = [0.5, 2.0, 3.0, 2.0, float('nan')]
    msgs = [('/cmd', 100 + i, joint_state(['crank'], [v])) for i, v in enumerate(values)]
    src = make_input(tmp_path, 'sqlite3', msgs)
    code, cap = run_bag(
        [
            src,
            '--scene',
            path,
            '--command-topic',
            '/cmd',
            '--out',
            tmp_path / 'l.csv',
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert '#' not in cap.out
    lines = [line.strip() for line in cap.out.splitlines()]
    assert '3 x e.g. crank = 2 rad is beyond its maximum 1.5 by 0.5 rad' in lines, cap.out
    assert '1 x crank: value must be finite (got nan)' in lines, cap.out
    empty = tmp_path / 'empty'
    with Writer(empty, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        w.add_connection('/cmd', JS, typestore=TS)  # (the topic, and not one message on it)
    code, cap = run_bag(
        [empty, '--scene', path, '--command-topic', '/cmd', '--out', tmp_path / 'e.csv'],
        capsys,
    )
    assert code == 0 and 'nothing to solve: no message on the topics given' in cap.out


# ---- plot, progress, number text ---------------------------------------------------------------


def test_plot_and_progress(tmp_path, scene, capsys, monkeypatch):
    msgs = [
        ('/cmd', 10**9 + i * 10**7, joint_state(['crank'], [0.05 * i], sec=1, nanosec=i * 10**7))
        for i in range(300)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    png = tmp_path / 'run.png'
    monkeypatch.setattr('sys.stderr.isatty', lambda: True, raising=False)
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--out',
            tmp_path / 'p.csv',
            '--plot',
            png,
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and png.stat().st_size > 10_000
    assert 'solving' in cap.err and '100%' in cap.err and '300/300' in cap.err  # tqdm, on stderr
    assert 'wrote' in cap.out and 'time' in cap.out


def test_plot_shows_an_accepted_row_between_refused_ones(tmp_path, scene):
    """A line broken at refused rows (NaN) draws no segment through an accepted row whose
    neighbours were refused: the plot marks such a row with a dot, in both panels."""
    values = [0.1, 0.2, math.nan, 0.4, math.nan, 0.6, 0.7]
    msgs = [
        ('/cmd', 10**9 * (i + 1), joint_state(['crank'], [v], sec=i + 1))
        for i, v in enumerate(values)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    mech = Scene.from_yaml(scene).mechanism
    data = bag.read_commands(str(src), ['/cmd'])
    res = bag.solve_commands(mech, data)
    assert res.ok.tolist() == [not math.isnan(v) for v in values]
    assert bag.isolated_rows(res.ok).tolist() == [False, False, False, True, False, False, False]
    fig = bag.plot_figure(data, res, mech)
    try:
        trace, joints = fig.axes
        lone = res.points[mech.outputs[0]][3]
        dots = [ln for ln in trace.get_lines() if ln.get_marker() == '.']
        assert len(dots) == 1 and np.allclose(dots[0].get_xydata(), [lone])
        dots = [ln for ln in joints.get_lines() if ln.get_marker() == '.']
        assert len(dots) == 1 + len(mech.joint_names)  # the input and every joint
        for ln in dots:
            assert ln.get_xdata().tolist() == [3.0]  # bag time of the 4th row, s
        assert dots[0].get_ydata().tolist() == [0.4]
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)


def test_csv_numbers_round_trip_exactly():
    rng = np.random.default_rng(11)
    values = np.concatenate(
        [
            rng.uniform(-4, 4, 20000),
            rng.normal(0, 1, 20000) * 10.0 ** rng.integers(-30, 20, 20000),
            [
                0.0,
                -0.0,
                1.0,
                0.1,
                0.5,
                1e-5,
                1e-4,
                np.pi,
                -np.pi,
                1e16,
                1e17,
                2.5,
                1 / 3,
                5e-324,
                1e300,
                -1e-300,
                1.7976931348623157e308,
                np.inf,
                -np.inf,
                np.nan,
                123456789.125,
            ],
        ]
    )
    text = bag.format_floats(values, b'nan')
    for v, row in zip(values.tolist(), text):
        s = bytes(row[row != 0]).decode()
        if math.isnan(v):
            assert s == 'nan'
        else:
            assert float(s) == v and math.copysign(1, float(s)) == math.copysign(1, v), (v, s)
    for const in ([0.4] * 5, [-0.0] * 3, [np.nan] * 4, [-0.0, 0.0, -0.0]):  # the shortcut
        text = [bytes(r[r != 0]).decode() for r in bag.format_floats(np.array(const), b'nan')]
        assert text == [repr(float(v)) for v in const] or all(
            float(t) == v for t, v in zip(text, const) if v == v
        )
        assert [math.copysign(1, float(t)) for t in text] == [math.copysign(1, v) for v in const]
    ints = bag.format_ints(np.array([0, 7, -7, 10, 1234567890123, 2**62]))
    assert [bytes(r[r != 0]).decode() for r in ints] == [
        '0',
        '7',
        '-7',
        '10',
        '1234567890123',
        str(2**62),
    ]


# ---- review fixes: bad input found by hand -----------------------------------------------------


def _small_bag(tmp_path, n=40, name='small'):
    (tmp_path / name).mkdir(exist_ok=True)
    msgs = [('/cmd', 10**9 + i * 10**6, joint_state(['crank'], [0.05 * i])) for i in range(n)]
    return make_input(tmp_path / name, 'mcap', msgs)


def test_plot_path_is_checked_before_any_work(tmp_path, scene, capsys):
    """An image format matplotlib cannot write, a folder, or an --out path as --plot is a usage
    error up front (before: a ValueError traceback after the CSV was written)."""
    src = _small_bag(tmp_path)
    out_csv = tmp_path / 'r.csv'
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--out', out_csv, '--no-progress']
    err = _bad([*common, '--plot', tmp_path / 'run.txt'], capsys)
    assert 'cannot write a .txt image' in err and 'png' in err
    assert not out_csv.exists()  # nothing was written
    assert 'is a directory' in _bad([*common, '--plot', tmp_path], capsys)
    assert 'is also an --out path' in _bad([*common, '--plot', out_csv], capsys)
    assert 'does not exist' in _bad([*common, '--plot', tmp_path / 'no' / 'p.png'], capsys)


def test_an_out_path_where_a_csv_puts_its_trajectories_is_refused_before_any_work(
    tmp_path, scene, capsys
):
    """out.csv writes its trajectories and paths to out.trajectories.csv: that path as another
    --out (both wrote one temporary file: a corrupt mix was left), or a folder there, is a usage
    error up front, and nothing is written."""
    src = _small_bag(tmp_path)
    out_csv, beside = tmp_path / 'r.csv', tmp_path / 'r.trajectories.csv'
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--no-progress']
    for outs in (['--out', out_csv, '--out', beside], ['--out', beside, '--out', out_csv]):
        err = _bad([*common, *outs], capsys)
        assert 'r.trajectories.csv: is where the trajectories and paths of --out' in err, err
        assert not out_csv.exists() and not beside.exists()
    beside.mkdir()
    err = _bad([*common, '--out', out_csv], capsys)
    assert 'r.trajectories.csv (the trajectories and paths of --out' in err, err
    assert 'is a directory' in err and not out_csv.exists()


@pytest.mark.parametrize(
    ('name', 'said'),
    [
        ('r.parquet', '--out-dir DIR --format parquet'),
        ('r.PNG', '--plot FILE.png'),
        ('r.json', 'summary.json'),
    ],
)
def test_an_out_named_as_a_file_it_does_not_write_is_refused(tmp_path, scene, capsys, name, said):
    """--out r.parquet wrote a rosbag2 folder named r.parquet without a word (a new user's
    find): --out writes a CSV or a bag folder. A name that says another file is refused up
    front, saying what writes that file, and nothing is written."""
    src = _small_bag(tmp_path)
    out = tmp_path / name
    err = _bad([src, '--scene', scene, '--command-topic', '/cmd', '--out', out], capsys)
    assert f'output {out}: --out writes a CSV (*.csv) or a rosbag2 folder' in err, err
    assert said in err and not out.exists()


def test_plot_without_extension_writes_the_named_file(tmp_path, scene, capsys):
    """matplotlib appends '.png' to a name without extension: the summary named a file that was
    never written. The image is written exactly where --plot says, as PNG."""
    src = _small_bag(tmp_path, n=5)
    png = tmp_path / 'trace'
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--out',
            tmp_path / 'r.csv',
            '--plot',
            png,
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert not (tmp_path / 'trace.png').exists()
    assert f'wrote {png} (plot)' in cap.out


def test_csv_time_of_negative_and_unnormalised_stamps(tmp_path, scene, capsys):
    """The 'time' column is sec + nanosec * 1e-9 exactly (as rclpy reads a stamp): a negative
    second was printed as '-5.000000001' for -4.999999999 and a nanosec field >= 1e9 as garbage
    ('3.Z94967295'). As the node does, a stamp it cannot echo (negative, nanosec >= 1e9) refuses
    its row with the node's reason; the others keep their stamps in the output bag."""
    from decimal import Decimal

    stamps = [
        (-5, 1),
        (3, 4294967295),
        (-1, 999999999),
        (-2147483648, 0),
        (2147483647, 5),
        (0, 7),
        (12, 0),
    ]
    msgs = [
        ('/cmd', 10**9 * (i + 1) + 3, joint_state(['crank'], [0.1 * i], sec=s, nanosec=ns))
        for i, (s, ns) in enumerate(stamps)
    ]
    src = make_input(tmp_path, 'sqlite3', msgs)
    out_csv, out_bag = tmp_path / 's.csv', tmp_path / 's_bag'
    code, cap = run_bag(
        [
            src,
            '--scene',
            scene,
            '--command-topic',
            '/cmd',
            '--out',
            out_csv,
            '--out',
            out_bag,
            '--no-progress',
        ],
        capsys,
    )
    assert code == 0, cap.err
    table = read_csv(out_csv)
    assert len(table) == len(stamps)
    for row, (s, ns), (_, t, _) in zip(table, stamps, msgs):
        assert Decimal(row['time']) == Decimal(s) + Decimal(ns) / Decimal(10**9), row['time']
        assert len(row['time'].split('.')[1]) == 9
        assert Decimal(row['receive_time']) == Decimal(t) / Decimal(10**9)
    from linkage_ros.stamps import stamp_error  # the node's refusal text (node.py)

    valid = [s >= 0 and ns < 10**9 for s, ns in stamps]
    assert valid == [False, False, False, False, True, True, True]
    for row, (s, ns), ok in zip(table, stamps, valid):
        assert row['status'] == ('ok' if ok else 'error')
        if not ok:  # the node's own text for that stamp
            assert row['reason'] == stamp_error(s, ns)
    got, _ = read_out_bag(out_bag)
    assert [(m.header.stamp.sec, m.header.stamp.nanosec) for _, m in got['/joint_states']] == [
        (s, ns) if (s or ns) else divmod(t, 10**9)
        for (s, ns), (_, t, _), ok in zip(stamps, msgs, valid)
        if ok
    ]
    # negative bag receive times too
    text = bag.stamp_text(np.zeros(3, np.int64), np.array([-1, -(10**9) - 5, 10**18 + 1]))
    assert [bytes(r[r != 0]).decode() for r in text] == [
        '-0.000000001',
        '-1.000000005',
        '1000000000.000000001',
    ]


def test_one_message_with_many_positions_costs_its_own_size(tmp_path, scene, capsys):
    """A malformed command with 50000 positions for one name used to widen the (rows, positions)
    table for every row (here 2000 x 50000 doubles, 800 MB; a real bag: a MemoryError traceback).
    Now it is one refused row and the rest are solved (the closed-form four-bar as oracle)."""
    import tracemalloc

    n, wide = 2000, 50_000
    tmpl = bytes(TS.serialize_cdr(joint_state(['crank'], [0.25]), JS))
    folder = tmp_path / 'wide'
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection('/cmd', JS, typestore=TS)
        for i in range(n):
            w.write(c, 10**9 + i, tmpl)
            if i == n // 2:
                w.write(
                    c,
                    10**9 + i,
                    bytes(
                        TS.serialize_cdr(joint_state(['crank'], np.arange(wide, dtype=float)), JS)
                    ),
                )
    tracemalloc.start()
    try:
        data = bag.read_commands(str(folder), ['/cmd'])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert data.n == n + 1
    assert peak < 50 * 2**20, f'reading took {peak / 2**20:.0f} MiB'
    mech = Scene.from_yaml(scene).mechanism
    res = bag.solve_commands(mech, data)
    bad = np.flatnonzero(~res.ok).tolist()
    assert bad == [n // 2 + 1]
    assert res.reason[bad[0]] == (
        f"JointState has 1 name(s) ['crank'] but {wide} position(s); they must pair up one to one"
    )
    want = four_bar(0.25)
    for j, v in want['joints'].items():
        assert np.all(np.abs(np.delete(res.joints[j], bad) - v) <= TOL), j
    assert data.positions(0, 3).tolist() == [[0.25]] * 3
    assert data.positions(n // 2 + 1, n // 2 + 2).shape == (1, wide)


def test_storage_file_extension_in_any_case(tmp_path, scene, capsys):
    """RUN.MCAP / RUN.DB3 (a FAT-formatted stick, a Windows copy) are the same bags: accepted by
    the tool's own check, then refused by rosbags as 'truncated, corrupt or not a rosbag2'."""
    msgs = [('/cmd', 10**9 + i, joint_state(['crank'], [0.1 * i])) for i in range(40)]
    mc = make_input(tmp_path, 'mcap-file', msgs)
    sq = make_input(tmp_path, 'sqlite3', msgs)
    upper = {'RUN.MCAP': mc, 'RUN.DB3': next(sq.glob('*.db3'))}
    nometa = tmp_path / 'nometa'
    nometa.mkdir()
    shutil.copy(mc, nometa / 'X.Mcap')
    for name, orig in upper.items():
        shutil.copy(orig, tmp_path / name)
    for src in [tmp_path / n for n in upper] + [nometa]:
        out = tmp_path / f'{src.name}.csv'
        code, cap = run_bag(
            [src, '--scene', scene, '--command-topic', '/cmd', '--out', out, '--no-progress'],
            capsys,
        )
        assert code == 0, cap.err
        table = read_csv(out)
        assert len(table) == 40 and all(r['status'] == 'ok' for r in table)
        for i, row in enumerate(table):
            assert abs(wrap(float(row['joint.B']) - four_bar(0.1 * i)['joints']['B'])) < TOL


def test_unusable_output_paths_are_clear_errors(tmp_path, scene, capsys):
    """A symlink loop as --out (before: a RuntimeError traceback), a parent that is a file, a
    dangling symlink as a new output bag: one message, exit 2, before any work."""
    src = _small_bag(tmp_path)
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--no-progress']
    for name in ('loop.csv', 'loopbag'):
        (tmp_path / name).symlink_to(tmp_path / name)
    assert 'cannot use this path' in _bad([*common, '--out', tmp_path / 'loop.csv'], capsys)
    err = _bad([*common, '--out', tmp_path / 'loopbag'], capsys)
    assert 'exists already' in err or 'cannot use this path' in err
    assert 'cannot use this path' in _bad(
        [*common, '--out', tmp_path / 'r.csv', '--plot', tmp_path / 'loop.csv'], capsys
    )
    afile = tmp_path / 'afile'
    afile.write_text('x')
    err = _bad([*common, '--out', afile / 'r.csv'], capsys)
    assert f'folder {afile} is not a folder' in err
    (tmp_path / 'dangling').symlink_to(tmp_path / 'nowhere')
    assert 'exists already' in _bad([*common, '--out', tmp_path / 'dangling'], capsys)


def test_failed_bag_write_is_one_error_and_leaves_no_half_bag(tmp_path, scene, capsys, monkeypatch):
    """A storage error while writing the result bag (sqlite3's 'database or disk is full' is no
    OSError) was a traceback, and left a folder without metadata that blocked the next run."""
    import sqlite3

    from rosbags.rosbag2 import writer as rwriter

    src = _small_bag(tmp_path)
    out = tmp_path / 'res'
    args = [
        src,
        '--scene',
        scene,
        '--command-topic',
        '/cmd',
        '--out',
        out,
        '--out-format',
        'sqlite3',
        '--no-progress',
    ]
    real_write, count = rwriter.Writer.write, [0]

    def failing_write(self, *a, **k):
        count[0] += 1
        if count[0] > 20:
            raise sqlite3.OperationalError('database or disk is full')
        return real_write(self, *a, **k)

    monkeypatch.setattr(rwriter.Writer, 'write', failing_write)
    err = _bad(args, capsys)
    assert f'output {out}: cannot write the bag (database or disk is full)' in err
    assert not out.exists()
    monkeypatch.setattr(rwriter.Writer, 'write', real_write)
    code, cap = run_bag(args, capsys)  # the same command again: now it works
    assert code == 0, cap.err
    got, _ = read_out_bag(out)
    assert len(got['/linkage_node/status']) == 40


def test_error_after_a_progress_bar_starts_on_its_own_line(tmp_path, scene, capsys, monkeypatch):
    """On a terminal the progress bar has no newline: an error found after it (a corrupt message,
    found once the messages are read) was printed on the end of the bar's line."""
    good = bytes(TS.serialize_cdr(joint_state(['crank'], [0.3]), JS))
    src = make_input(
        tmp_path, 'mcap', [('/cmd', 7 + i, good) for i in range(5)] + [('/cmd', 20, good[:30])]
    )
    monkeypatch.setattr('sys.stderr.isatty', lambda: True, raising=False)
    code = bag.main(
        [
            str(src),
            '--scene',
            str(scene),
            '--command-topic',
            '/cmd',
            '--out',
            str(tmp_path / 'x.csv'),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert 'reading' in err  # the bar was shown
    last = err.split('\r')[-1]
    assert last.startswith(f'linkage bag: error: input {src}: message 6 on /cmd'), repr(err)
    assert 'not a valid JointState' in last and last.count('\n') == 1


def test_unwritable_output_folder_is_refused_before_any_work(tmp_path, scene, capsys, monkeypatch):
    """A folder the user may not write to (simulated: these tests may run as root, whom
    permissions do not stop) is named at once, not after reading and solving the whole bag."""
    src = _small_bag(tmp_path)
    locked = tmp_path / 'locked'
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(
        os,
        'access',
        lambda p, mode, **k: (
            False if Path(p) == locked.resolve() and mode & os.W_OK else real_access(p, mode, **k)
        ),
    )
    reads = []
    monkeypatch.setattr(bag.fleet_task, 'read_commands', lambda *a, **k: reads.append(a))
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--no-progress']
    for extra in (
        ['--out', locked / 'r.csv'],
        ['--out', locked / 'answers'],
        ['--out', tmp_path / 'r.csv', '--plot', locked / 'p.png'],
    ):
        err = _bad([*common, *extra], capsys)
        assert f'folder {locked.resolve()} is not writable' in err
    assert reads == []


def test_empty_topic_names_are_usage_errors(tmp_path, scene, capsys):
    """An empty --target-topic (e.g. an unset shell variable) was silently dropped, so target
    commands went unsolved without a word; an empty --command-topic read nothing. Both are now
    usage errors that name the option, before any output is written."""
    src = _small_bag(tmp_path)
    out_csv = tmp_path / 'r.csv'
    common = [src, '--scene', scene, '--out', out_csv, '--no-progress']
    err = _bad([*common, '--command-topic', '/cmd', '--target-topic', ''], capsys)
    assert '--target-topic: empty topic name' in err
    err = _bad([*common, '--command-topic', ' '], capsys)
    assert '--command-topic: empty topic name' in err
    assert not out_csv.exists()
    code, cap = run_bag([*common, '--command-topic', '/cmd'], capsys)  # and the same run works
    assert code == 0, cap.err


# ---- why JointState is decoded by hand --------------------------------------------------------


@pytest.mark.parametrize('names', [['crank'], ['Z1', 'Z2', 'Z3'], ['ab']])
def test_recorded_joint_states_need_the_hand_decoder(names):
    """rosbags' own CDR deserialiser refuses what rclpy (hence `ros2 bag record`) writes: the
    Fast-CDR size estimate leaves slack bytes after the message ("size mismatch"). The bag tool
    decodes JointState itself (vectorised over messages of one layout); when this test fails
    because rosbags reads these bytes, the hand decoder can give way to it."""
    from rosbags.serde import SerdeError

    positions = [0.25 * (k + 1) for k in range(len(names))]
    raw = bytes(rclpy_bytes(names, positions, 7, 8))
    with pytest.raises(SerdeError, match='size mismatch'):
        TS.deserialize_cdr(raw, JS)
    sec, nanosec, key, keys, _npos, values, _start = bag.reading.decode_joint_states(
        [raw], np.zeros(1, np.int8), ['/cmd'], np.zeros(1, np.int64)
    )
    assert (int(sec[0]), int(nanosec[0])) == (7, 8)
    assert keys[int(key[0])] == tuple(names) and values.tolist() == positions


# ---- outputs are written whole or not at all -------------------------------------------------


def test_a_write_cut_short_leaves_no_partial_output(tmp_path, scene):
    """Under `ulimit -f 100` (a full disk alike) the CSV write fails half-way: exit 2 with the
    reason, and nothing under the output's name (it used to leave a 100 kB file cut mid-row,
    which looks like a result); the temporary file beside it is gone too. An output that
    existed before is left as it was."""
    import resource
    import subprocess
    import sys

    msgs = [
        ('/cmd', 10**9 + i * 10**6, joint_state(['crank'], [0.001 * i], sec=1, nanosec=i * 10**6))
        for i in range(4000)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'out.csv'

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (100 * 1024, 100 * 1024))

    cmd = [sys.executable, '-m', 'linkage_ros.bag', str(src), '--scene', str(scene)]
    cmd += ['--command-topic', '/cmd', '--out', str(out), '--no-progress']
    for before in (None, b'an earlier result\n'):
        if before is not None:
            out.write_bytes(before)
        proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit, timeout=120)
        assert proc.returncode == 2, proc.stderr[-2000:]
        assert 'File too large' in proc.stderr and 'Traceback' not in proc.stderr, proc.stderr
        if before is None:
            assert not out.exists()
        else:
            assert out.read_bytes() == before
        assert not list(tmp_path.glob('.out.csv.*')), list(tmp_path.iterdir())
    # without the limit the same run writes the whole file
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = out.read_text().splitlines()
    assert len(rows) == 1 + len(msgs) and rows[-1].count(',') == rows[0].count(',')


# ---- a damaged bag fails loudly ----------------------------------------------------------------


def _sqlite_bag(tmp_path, n=200):
    msgs = [
        ('/cmd', 10**9 + i * 10**7, joint_state(['crank'], [0.01 * i], sec=1 + i // 100))
        for i in range(n)
    ]
    folder = tmp_path / 'sq'
    write_bag(folder, 'sqlite3', msgs)
    return folder, next(folder.glob('*.db3'))


def _edit(db, sql):
    import sqlite3

    con = sqlite3.connect(db)
    try:
        con.execute(sql)
        con.commit()
    finally:
        con.close()


@pytest.mark.parametrize(
    'damage',
    [
        'DELETE FROM messages WHERE id = 100',  # a message lost from the middle
        'UPDATE messages SET topic_id = 99 WHERE id = 100',  # its topic no longer matches
    ],
)
def test_a_message_lost_from_the_middle_is_an_error(tmp_path, scene, capsys, damage):
    """metadata.yaml counts 200 messages on /cmd; one is gone. This used to write 199 rows and
    exit 0. Now: exit 2 naming the bag, the topic and both counts; --accept-missing reads it
    and the summary says what is missing."""
    folder, db = _sqlite_bag(tmp_path)
    _edit(db, damage)
    out = tmp_path / 'o.csv'
    common = [folder, '--scene', scene, '--command-topic', '/cmd', '--out', out, '--no-progress']
    code, cap = run_bag(common, capsys)
    assert code == 2 and not out.exists()
    (line,) = cap.err.strip().splitlines()
    assert str(folder) in line and 'topic /cmd' in line, line
    assert 'counts 200 message(s) but 199 could be read' in line and '1 is missing' in line
    code, cap = run_bag([*common, '--accept-missing'], capsys)
    assert code == 0, cap.err
    # (it read 1 fewer than the index counts: said as it was, not as '1 more')
    assert '/cmd: 199 (MISSING 1 of the 200 the bag counts: --accept-missing)' in cap.out
    assert len(read_csv(out)) == 199


@pytest.mark.parametrize(
    ('stamp', 'shown'), [(-5, '-5'), (1.5, '1.5'), ("'x'", "'x'"), (1e30, '1e+30')]
)
def test_a_receive_time_out_of_range_is_an_error(tmp_path, scene, capsys, stamp, shown):
    """A negative receive time used to be written as a row; a non-integer one or one beyond
    64 bits ended in a ValueError / OverflowError traceback. Now: exit 2, one line naming the
    message and the value."""
    folder, db = _sqlite_bag(tmp_path, n=20)
    _edit(db, f'UPDATE messages SET timestamp = {stamp} WHERE id = 7')
    code, cap = run_bag(
        [folder, '--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'o.csv'],
        capsys,
    )
    assert code == 2
    (line,) = cap.err.strip().splitlines()
    assert 'on /cmd has the receive time ' + shown in line and 'in [0, 2^63)' in line, line


def test_a_corrupt_sqlite_page_fails_quick_check(tmp_path, scene, capsys):
    folder, db = _sqlite_bag(tmp_path, n=2000)
    raw = bytearray(db.read_bytes())
    page = 4096
    assert len(raw) > 4 * page
    for k in range(2, len(raw) // page):  # every page but the first: b-tree page headers
        if raw[k * page] in (0x02, 0x05, 0x0A, 0x0D):  # an index or table b-tree page
            raw[k * page + 3 : k * page + 8] = b'\xff' * 5  # cell count, content start
    db.write_bytes(bytes(raw))
    code, cap = run_bag(
        [folder, '--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'o.csv'],
        capsys,
    )
    assert code == 2, cap.out[-500:]
    (line,) = cap.err.strip().splitlines()
    assert str(folder) in line and 'quick_check' in line and 'corrupt' in line, line


@pytest.mark.parametrize(
    'name', ['crank\x00junk', 'crank\x00', '\x00crank', 'cr\x00\x00', 'cr\u00e9nk', 'crank' * 40]
)
def test_names_decode_as_the_node_reads_them(name):
    """One engine, one answer: a name with a NUL in it is read whole by the node's ~/command
    reader (command_cdr: `crank\x00x` is an unknown name, not `crank`), and the bag cut it at
    the NUL as rclpy's deserialiser does. The oracle is the node's reader; the name as the
    message holds it (rosbags' own serialisation) is the same."""
    from linkage_ros.command_cdr import read_joint_state

    raw = bytes(TS.serialize_cdr(joint_state([name], [0.5], sec=3), JS))
    fields = read_joint_state(raw)
    assert fields is not None
    node_reads = fields.names[0]
    assert node_reads == name
    _s, _ns, key, keys, _np, _v, _st = bag.reading.decode_joint_states(
        [raw], np.zeros(1, np.int8), ['/cmd'], np.zeros(1, np.int64)
    )
    assert keys[int(key[0])] == (node_reads,)


def test_the_bag_keeps_the_assembly_mode_like_the_node(tmp_path, capsys):
    """A recorded ~/target only the other mode reaches is refused with the node's reason, and
    the commands after it stay in the mode they were in (one engine, one answer)."""
    from scenes import CONFIG

    from linkage_ros.engine import Engine, EngineSettings

    msgs = [
        ('/cmd', 10**9, joint_state(['crank'], [1.0], sec=1)),
        ('/tgt', 2 * 10**9, joint_state(['B'], [-1.2], sec=2)),
        ('/cmd', 3 * 10**9, joint_state(['crank'], [1.0], sec=3)),
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'o.csv'
    scene = CONFIG / 'four_bar.yaml'
    args = [src, '--scene', scene, '--command-topic', '/cmd', '--target-topic', '/tgt']
    code, cap = run_bag([*args, '--out', out, '--no-progress'], capsys)
    assert code == 0, cap.err
    rows = read_csv(out)
    mech = Scene.from_yaml(scene).mechanism
    node = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    answers = [node.command({'crank': 1.0}), node.target({'B': -1.2}), node.command({'crank': 1.0})]
    assert [r['status'] for r in rows] == ['ok', 'error', 'ok']
    assert rows[1]['reason'] == answers[1].reason
    assert 'reachable only in assembly mode -' in rows[1]['reason']
    for row, ans in ((rows[0], answers[0]), (rows[2], answers[2])):
        for j in mech.joint_names:
            assert math.isclose(float(row[f'joint.{j}']), ans.joints[j], abs_tol=1e-12), j


def test_an_output_bag_appears_whole_or_not_at_all(tmp_path, scene):
    """The output bag is written in a staging folder beside the target and renamed into place
    when complete: cut short (here by `ulimit -f`; SIGKILL alike) nothing is left under the
    output's name nor beside it; complete, it is a readable bag named as asked."""
    import resource
    import subprocess
    import sys

    msgs = [
        ('/cmd', 10**9 + i * 10**6, joint_state(['crank'], [0.001 * i], sec=1 + i // 1000))
        for i in range(4000)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'solved'
    cmd = [sys.executable, '-m', 'linkage_ros.bag', str(src), '--scene', str(scene)]
    cmd += ['--command-topic', '/cmd', '--out', str(out), '--no-progress']

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (100 * 1024, 100 * 1024))

    proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit, timeout=120)
    assert proc.returncode == 2 and 'Traceback' not in proc.stderr, proc.stderr[-2000:]
    assert not out.exists() and not list(tmp_path.glob('.solved.*')), list(tmp_path.iterdir())
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (out / 'metadata.yaml').exists() and (out / 'solved.mcap').exists()
    assert not list(tmp_path.glob('.solved.*'))
    got, _types = read_out_bag(out)
    assert len(got['/joint_states']) == len(msgs)


def test_an_mcap_chunk_whose_checksum_fails_is_an_error(tmp_path, scene, capsys):
    """MCAP chunks carry a CRC where the writer set one (ros2 bag record's writer does): a
    chunk whose bytes no longer match it is an error naming the bag, never rows read from it."""
    import struct

    msgs = [('/cmd', 10**9 + i, joint_state(['crank'], [0.01 * i], sec=1)) for i in range(50)]
    folder = make_input(tmp_path, 'mcap', msgs)
    path = next(folder.glob('*.mcap'))
    raw = bytearray(path.read_bytes())
    pos, patched = 8, 0  # after the magic: records of (opcode u8, length u64, content)
    while pos + 9 <= len(raw):
        op, length = raw[pos], struct.unpack_from('<Q', raw, pos + 1)[0]
        if op == 0x06:  # a chunk: start, end, uncompressed size, then its CRC32
            struct.pack_into('<I', raw, pos + 9 + 24, 0x1234567)
            patched += 1
        pos += 9 + length
    assert patched >= 1
    path.write_bytes(bytes(raw))
    out = tmp_path / 'o.csv'
    code, cap = run_bag(
        [folder, '--scene', scene, '--command-topic', '/cmd', '--out', out, '--no-progress'],
        capsys,
    )
    assert code == 2 and not out.exists()
    (line,) = cap.err.strip().splitlines()
    assert str(folder) in line and 'checksum' in line and 'corrupt' in line, line


def test_the_bag_answers_point_coordinate_targets_like_the_node(tmp_path, capsys):
    """Recorded ~/target messages naming `J.x, J.y, K.x, K.y` (the excavator bin by its
    hinges) get the node's answers: the consistent pair solved, the stretched one refused with
    the same reason, a lone coordinate solved as a known of its own, J.y left to the
    mechanism (one engine, one answer)."""
    from scenes import CONFIG

    from linkage_ros.engine import Engine, EngineSettings

    scene = CONFIG / 'excavator.yaml'
    mech = Scene.from_yaml(scene).mechanism
    ref = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    src_cfg = ref.command({'Z1': 1.4, 'Z2': 2.1, 'Z3': 1.4})
    (jx, jy), (kx, ky) = src_cfg.points['J'], src_cfg.points['K']
    names = ['J.x', 'J.y', 'K.x', 'K.y']
    requests = [[jx, jy, kx, ky], [jx, jy, kx + 0.01, ky], [jx, jy, kx, ky]]
    msgs = [
        ('/tgt', (i + 1) * 10**9, joint_state(names, pos, sec=i + 1))
        for i, pos in enumerate(requests)
    ]
    msgs.append(('/tgt', 9 * 10**9, joint_state(['J.x', 'K.x', 'K.y'], [jx, kx, ky], sec=9)))
    start = {'Z1': 1.6, 'Z2': 1.9, 'Z3': 1.6}
    msgs.insert(0, ('/cmd', 5 * 10**8, joint_state(list(start), list(start.values()), sec=0)))
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'o.csv'
    args = [src, '--scene', scene, '--command-topic', '/cmd', '--target-topic', '/tgt']
    code, cap = run_bag([*args, '--out', out, '--no-progress'], capsys)
    assert code == 0, cap.err
    rows = read_csv(out)[1:]  # after the first command
    node = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    assert node.command(start).success
    answers = [node.target(dict(zip(names, pos))) for pos in requests]
    answers.append(node.target({'J.x': jx, 'K.x': kx, 'K.y': ky}))
    assert [r['status'] for r in rows] == ['ok', 'error', 'ok', 'ok']
    assert rows[1]['reason'] == answers[1].reason and 'the target puts them' in rows[1]['reason']
    # J.x and K: the pose the hinges came from (J.y decided by the mechanism, in its mode)
    assert math.dist(answers[3].points['J'], (jx, jy)) < 1e-9 * mech.length_scale
    for row, ans in ((rows[0], answers[0]), (rows[2], answers[2]), (rows[3], answers[3])):
        for j in mech.joint_names:
            assert math.isclose(float(row[f'joint.{j}']), ans.joints[j], abs_tol=1e-12), j
        for a in mech.actuators:
            assert math.isclose(float(row[f'joint.{a}']), src_cfg.inputs[a], abs_tol=1e-9), a


def test_the_bag_holds_actuators_a_partial_command_leaves_out_like_the_node(tmp_path, capsys):
    """A recorded command naming some actuators keeps the others at their last good values,
    as the node does, and its /status says which were held (`held`), with the node's exact
    key-values (conversions.result_to_status of the engine's answer)."""
    from scenes import CONFIG

    from linkage_ros.conversions import result_to_status
    from linkage_ros.engine import Engine, EngineSettings

    scene = CONFIG / 'plagiograph.yaml'
    mech = Scene.from_yaml(scene).mechanism
    first, second = list(mech.actuators)
    lo = {a: act.min + 0.4 * (act.max - act.min) for a, act in mech.actuators.items()}
    requests = [dict(lo)] + [{first: lo[first] + 0.01 * k} for k in range(1, 60)]
    requests.append({second: lo[second] + 0.02})
    requests.append({first: 0.3, 'wrench': 1.0})
    msgs = [
        ('/cmd', (i + 1) * 10**8, joint_state(list(r), list(r.values()), sec=i + 1))
        for i, r in enumerate(requests)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out_csv, out_bag = tmp_path / 'o.csv', tmp_path / 'o_bag'
    args = [src, '--scene', scene, '--command-topic', '/cmd', '--out', out_csv, '--out', out_bag]
    code, cap = run_bag([*args, '--no-progress'], capsys)
    assert code == 0, cap.err
    rows = read_csv(out_csv)
    node = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    answers = [node.command(r) for r in requests]
    assert [a.held for a in answers[1:4]] == [(second,)] * 3 and answers[-2].held == (first,)
    assert [r['status'] for r in rows] == ['ok' if a.success else 'error' for a in answers]
    assert 'wrench' in rows[-1]['reason']
    out, _ = read_out_bag(out_bag)
    for (_, st), ans, row in zip(out['/linkage_node/status'], answers, rows):
        want = result_to_status(ans, st.name, 'command', mech.name)
        got_kv = {v.key: v.value for v in st.values}
        want_kv = {v.key: v.value for v in want.values}
        assert list(got_kv) == list(want_kv), (got_kv, want_kv)
        assert st.level == ord(want.level) and st.message == want.message
        if ans.success:
            assert got_kv.get('held') == want_kv.get('held')
            for j in mech.joint_names:
                assert math.isclose(float(row[f'joint.{j}']), ans.joints[j], abs_tol=1e-12), j


def test_recorded_trajectories_and_paths_get_the_nodes_answers(tmp_path, capsys):
    """Recorded ~/trajectory (serialised by rclpy, as a recording holds it) and
    ~/target_path/L messages are answered at their place in bag time with the node's answers
    (trajectory.py on an Engine that saw the same commands before): /solved_trajectory and one
    /status each, a CSV beside the command CSV, and the commands after them unchanged."""
    from builtin_interfaces.msg import Duration as RclDuration
    from rclpy.serialization import serialize_message
    from scenes import CONFIG
    from trajectory_msgs.msg import JointTrajectory as RclTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint as RclPoint

    from linkage_ros.engine import Engine, EngineSettings
    from linkage_ros.trajectory import solve_trajectory, trajectory_status_values

    scene = CONFIG / 'excavator.yaml'
    mech = Scene.from_yaml(scene).mechanism
    acts = list(mech.actuators)
    start = {'Z1': 1.5, 'Z2': 1.9, 'Z3': 1.4}
    rows = [[1.5 + 0.01 * k, 1.9 - 0.01 * k, 1.4 + 0.005 * k] for k in range(12)]
    traj = RclTrajectory(joint_names=acts)
    traj.header.stamp.sec = 3
    traj.points = [
        RclPoint(positions=r, time_from_start=RclDuration(sec=k + 1)) for k, r in enumerate(rows)
    ]
    bad = RclTrajectory(joint_names=acts)
    bad.header.stamp.sec = 4
    bad.points = [
        RclPoint(positions=rows[0], time_from_start=RclDuration(sec=1)),
        RclPoint(positions=[1.5, 9.0, 1.4], time_from_start=RclDuration(sec=2)),
    ]
    # the node: an Engine that saw the first command, then the plans (each leaves the state)
    node = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous', ('bucket',)))
    node.command(start)
    lip = node.last.points['L']
    xy = [(lip[0] + 0.02 * k, lip[1] - 0.01 * k) for k in range(8)]
    want_traj = solve_trajectory(node, acts, rows, (), [(k + 1) * 10**9 for k in range(12)])
    want_bad = solve_trajectory(node, acts, [rows[0], [1.5, 9.0, 1.4]], (), [1, 2])
    bucket = node.last.links['bucket']
    path_rows = [[x, y, bucket] for x, y in xy]
    want_path = solve_trajectory(node, ['L.x', 'L.y', 'bucket'], path_rows)
    assert want_traj.success and want_path.success and want_bad.failed_index == 1
    T = TS.types
    stamp = T['builtin_interfaces/msg/Time'](sec=5, nanosec=0)
    hdr = T['std_msgs/msg/Header'](stamp=stamp, frame_id='')
    poses = [
        T['geometry_msgs/msg/PoseStamped'](
            header=hdr,
            pose=T['geometry_msgs/msg/Pose'](
                position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
                orientation=T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0),
            ),
        )
        for x, y in xy
    ]
    path_msg = T['nav_msgs/msg/Path'](header=hdr, poses=poses)
    later = {'Z1': 1.6, 'Z2': 2.0, 'Z3': 1.45}
    folder = tmp_path / 'in'
    traj_type, path_type = 'trajectory_msgs/msg/JointTrajectory', 'nav_msgs/msg/Path'
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c_cmd = w.add_connection('/cmd', JS, typestore=TS)
        c_tr = w.add_connection('/traj', traj_type, typestore=TS)
        c_path = w.add_connection('/n/target_path/L', path_type, typestore=TS)
        first = joint_state(acts, list(start.values()), sec=1)
        w.write(c_cmd, 1 * 10**9, TS.serialize_cdr(first, JS))
        w.write(c_tr, 2 * 10**9, bytes(serialize_message(traj)))
        w.write(c_tr, 3 * 10**9, bytes(serialize_message(bad)))
        w.write(c_path, 4 * 10**9, TS.serialize_cdr(path_msg, path_type))
        second = joint_state(acts, list(later.values()), sec=6)
        w.write(c_cmd, 5 * 10**9, TS.serialize_cdr(second, JS))
    out_csv, out_bag = tmp_path / 'o.csv', tmp_path / 'o_bag'
    args = [folder, '--scene', scene, '--command-topic', '/cmd', '--trajectory-topic', '/traj']
    args += ['--path-topic', '/n/target_path/L', '--target-point-hold', 'bucket']
    args += ['--out', out_csv, '--out', out_bag, '--no-progress']
    code, cap = run_bag(args, capsys)
    assert code == 0, cap.err
    out, _ = read_out_bag(out_bag)
    solved = dict(out['/linkage_node/solved_trajectory'])
    assert sorted(solved) == [2 * 10**9, 4 * 10**9]
    for t, want, k_stamp in ((2 * 10**9, want_traj, 3), (4 * 10**9, want_path, 5)):
        msg = solved[t]
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (k_stamp, 0)
        assert list(msg.joint_names) == mech.joint_names
        assert len(msg.points) == len(want.results)
        for pt, r in zip(msg.points, want.results):
            assert pt.positions.tolist() == [r.joints[j] for j in mech.joint_names]
    for k, pt in enumerate(solved[2 * 10**9].points):
        assert (pt.time_from_start.sec, pt.time_from_start.nanosec) == (k + 1, 0)
    statuses = dict(out['/linkage_node/status'])
    for t, want, request in (
        (2 * 10**9, want_traj, 'trajectory'),
        (3 * 10**9, want_bad, 'trajectory'),
        (4 * 10**9, want_path, 'target_path/L'),
    ):
        _ok, message, values = trajectory_status_values(want, request)
        st = statuses[t]
        assert st.message == message and {v.key: v.value for v in st.values} == values
    # the command after the plans is answered as if they had not been there
    rows_csv = read_csv(out_csv)
    assert [r['status'] for r in rows_csv] == ['ok', 'ok']
    again = node.command(later)
    for j in mech.joint_names:
        assert math.isclose(float(rows_csv[1][f'joint.{j}']), again.joints[j], abs_tol=1e-12), j
    plan_rows = read_csv(tmp_path / 'o.trajectories.csv')
    assert [r['status'] for r in plan_rows] == ['ok'] * 12 + ['error'] + ['ok'] * 8
    assert plan_rows[12]['failed_index'] == '1' and 'point 1: ' in plan_rows[12]['reason']
    assert 'trajectories and paths: 3 read, solved 2, refused 1' in cap.out
    # each plan topic counted, as the command topics are
    assert '    /traj: 2\n' in cap.out and '    /n/target_path/L: 1\n' in cap.out


def test_a_path_topic_must_name_a_point_and_a_trajectory_topic_its_type(tmp_path, capsys):
    from scenes import CONFIG

    msgs = [('/cmd', 10**9, joint_state(['crank'], [1.0], sec=1))]
    src = make_input(tmp_path, 'mcap', msgs)
    common = [src, '--scene', CONFIG / 'four_bar.yaml', '--command-topic', '/cmd']
    code, cap = run_bag(
        [*common, '--path-topic', '/x/target_path/Q', '--out', tmp_path / 'a.csv'], capsys
    )
    assert (
        code == 2 and "--path-topic /x/target_path/Q: its last name 'Q' is not a point" in cap.err
    )
    code, cap = run_bag(
        [*common, '--trajectory-topic', '/cmd', '--out', tmp_path / 'b.csv'], capsys
    )
    assert code == 2 and 'topic /cmd has type sensor_msgs/msg/JointState' in cap.err
    assert 'expected trajectory_msgs/msg/JointTrajectory' in cap.err
    assert not (tmp_path / 'a.csv').exists() and not (tmp_path / 'b.csv').exists()


def test_frame_id_is_the_frame_the_recorded_node_worked_in(tmp_path, capsys):
    """A node run with frame_id:=world answered paths stamped 'world'; the bag, in the scene's
    frame, refused them. --frame-id world answers them as the node did (the same joints as
    an unstamped path) and writes its outputs in that frame; a frame tf2 refuses is a usage
    error."""
    from scenes import CONFIG

    from linkage_ros.engine import Engine, EngineSettings

    scene = CONFIG / 'plagiograph.yaml'
    mech = Scene.from_yaml(scene).mechanism
    start = Engine(mech, EngineSettings())
    x0, y0 = start.last.points['E']
    T = TS.types

    def path(frame):
        hdr = T['std_msgs/msg/Header'](
            stamp=T['builtin_interfaces/msg/Time'](sec=5, nanosec=0), frame_id=frame
        )
        poses = [
            T['geometry_msgs/msg/PoseStamped'](
                header=hdr,
                pose=T['geometry_msgs/msg/Pose'](
                    position=T['geometry_msgs/msg/Point'](x=x0 + 1e-3 * k, y=y0, z=0.0),
                    orientation=T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0),
                ),
            )
            for k in range(3)
        ]
        return TS.serialize_cdr(
            T['nav_msgs/msg/Path'](header=hdr, poses=poses), 'nav_msgs/msg/Path'
        )

    acts = list(mech.actuators)
    folder = tmp_path / 'in'
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c_cmd = w.add_connection('/cmd', JS, typestore=TS)
        c_path = w.add_connection('/n/target_path/E', 'nav_msgs/msg/Path', typestore=TS)
        values = [start.last.inputs[a] for a in acts]
        w.write(c_cmd, 10**9, TS.serialize_cdr(joint_state(acts, values, sec=1), JS))
        w.write(c_path, 2 * 10**9, path('world'))
        w.write(c_path, 3 * 10**9, path(''))
    common = [folder, '--scene', scene, '--command-topic', '/cmd', '--no-progress']
    common += ['--path-topic', '/n/target_path/E']
    code, cap = run_bag([*common, '--out', tmp_path / 'a.csv'], capsys)
    rows = read_csv(tmp_path / 'a.trajectories.csv')
    assert code == 0 and [r['status'] for r in rows] == ['error'] + ['ok'] * 3, cap.err
    assert "in frame 'world' but this node works in 'plagiograph'" in rows[0]['reason']
    code, cap = run_bag(
        [*common, '--frame-id', 'world', '--out', tmp_path / 'b.csv', '--out', tmp_path / 'b'],
        capsys,
    )
    assert code == 0, cap.err
    rows = read_csv(tmp_path / 'b.trajectories.csv')
    assert [r['status'] for r in rows] == ['ok'] * 6
    joints = [c for c in rows[0] if c.startswith('joint.')]
    assert [[r[c] for c in joints] for r in rows[:3]] == [[r[c] for c in joints] for r in rows[3:]]
    out, _ = read_out_bag(tmp_path / 'b')
    assert {m.header.frame_id for _, m in out['/joint_states']} == {'world'}
    code, cap = run_bag([*common, '--frame-id', '/world', '--out', tmp_path / 'c.csv'], capsys)
    assert code == 2 and "--frame-id '/world'" in cap.err and not (tmp_path / 'c.csv').exists()


def test_a_recorded_target_in_a_foreign_frame_is_refused_as_the_node_refused_it(tmp_path, capsys):
    """The node refuses a ~/target naming link angles or point coordinates in a frame other
    than its own (no tf lookup); joint values have no frame. The bag answered such a recorded
    target in its own frame. Now the same refusal, the same words; --frame-id map answers it."""
    from scenes import CONFIG

    from linkage_ros.engine import Engine, EngineSettings
    from linkage_ros.stamps import names_frame_error

    scene = CONFIG / 'four_bar.yaml'
    mech = Scene.from_yaml(scene).mechanism
    ref = Engine(mech, EngineSettings()).last
    rocker, b = ref.links['rocker'], ref.joints['B']
    msgs = [
        ('/cmd', 10**8, joint_state(['crank'], [ref.inputs['crank']])),
        ('/tgt', 10**9, joint_state(['rocker'], [rocker], sec=1, frame='map')),
        ('/tgt', 2 * 10**9, joint_state(['rocker'], [rocker], sec=2, frame='base_link')),
        ('/tgt', 3 * 10**9, joint_state(['B'], [b], sec=3, frame='map')),
        ('/tgt', 4 * 10**9, joint_state(['rocker'], [rocker], sec=4)),
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--target-topic', '/tgt']
    common.append('--no-progress')
    code, cap = run_bag([*common, '--out', tmp_path / 'a.csv'], capsys)
    assert code == 0, cap.err
    rows = read_csv(tmp_path / 'a.csv')[1:]  # after the command
    assert [r['status'] for r in rows] == ['error', 'ok', 'ok', 'ok'], [r['reason'] for r in rows]
    node_says = names_frame_error('target', mech, ['rocker'], 'map', 'base_link')
    assert rows[0]['reason'] == node_says and "in frame 'map'" in node_says
    code, cap = run_bag([*common, '--frame-id', 'map', '--out', tmp_path / 'b.csv'], capsys)
    assert code == 0, cap.err
    assert [r['status'] for r in read_csv(tmp_path / 'b.csv')[1:]] == ['ok', 'error', 'ok', 'ok']


def test_the_summary_counts_every_row_once(tmp_path, scene, capsys):
    """A command refused as the message stands (an unknown name) reaches no solver: the
    summary's row counts said 'vectorised rows 0, one-by-one rows 49' of 50 commands; they now
    add up, naming those rows."""
    msgs = [('/cmd', 10**9 + i * 10**6, joint_state(['crank'], [0.05 * i])) for i in range(30)]
    msgs[7] = ('/cmd', msgs[7][1], joint_state(['wrench'], [0.1]))
    src = make_input(tmp_path, 'mcap', msgs)
    code, cap = run_bag(
        [src, '--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'o.csv'], capsys
    )
    assert code == 0, cap.err
    assert 'solved 29, refused 1' in cap.out and 'refused before any solve 1' in cap.out, cap.out
    ways = ('vectorised rows', 'one-by-one rows', 'refused before any solve')
    assert sum(_summary_count(cap.out, w) for w in ways) == 30, cap.out


@pytest.mark.parametrize('n', [30, 2000])
def test_the_summary_counts_a_nan_command_as_refused_before_any_solve(tmp_path, scene, capsys, n):
    """A NaN command is refused as the message stands (README: `refused before any solve`); it
    was counted as a vectorised or one-by-one row (n = 2000: the batch path, 30: one by one)."""
    msgs = [('/cmd', 10**9 + i * 10**6, joint_state(['crank'], [0.001 * i])) for i in range(n)]
    msgs[7] = ('/cmd', msgs[7][1], joint_state(['crank'], [math.nan]))
    src = make_input(tmp_path, 'mcap', msgs)
    code, cap = run_bag(
        [src, '--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'o.csv'], capsys
    )
    assert code == 0, cap.err
    assert f'solved {n - 1}, refused 1' in cap.out and 'refused before any solve 1' in cap.out
    ways = ('vectorised rows', 'one-by-one rows', 'refused before any solve')
    assert sum(_summary_count(cap.out, w) for w in ways) == n, cap.out


def test_a_command_naming_a_joint_link_or_point_is_refused_in_the_nodes_words(tmp_path, capsys):
    """A recorded ~/command naming a point (or a link) is the node's `... not an actuator of
    'four_bar' ...: use ~/target ...`; the bag said `unknown name(s) ['P']; this solve takes
    ['crank']` (a new user: "P" is no unknown name). Oracle: the engine's own refusal."""
    from scenes import load

    from linkage_ros.engine import Engine, EngineSettings

    engine = Engine(load('four_bar'), EngineSettings())
    cases = [(['crank', 'P'], [0.4, 0.1]), (['rocker'], [0.3]), (['crank'], [0.4])]
    msgs = [('/cmd', (k + 1) * 10**6, joint_state(n, v)) for k, (n, v) in enumerate(cases)]
    folder = tmp_path / 'in'
    write_bag(folder, 'mcap', msgs)
    out = tmp_path / 'out.csv'
    code, cap = run_bag(
        [folder, '--scene', 'four_bar', '--command-topic', '/cmd', '--out', out, '--no-progress'],
        capsys,
    )
    assert code == 0, cap.err
    rows = read_csv(out)
    for row, (names, values) in zip(rows, cases):
        want = engine.command(dict(zip(names, values)))
        assert row['status'] == ('ok' if want.success else 'error')
        if not want.success:
            assert row['reason'] == want.reason, row['reason']
            assert 'not an actuator' in row['reason']
