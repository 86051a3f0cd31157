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

This file holds the round trip through every storage and the helpers every bag test file
imports (conftest.py gives them the ``scene`` fixture); the other test_bag_*.py files hold the
comparisons with the node, bad and damaged input, and the review fixes.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore

from linkage_ros import bag

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


def summary_count(text: str, what: str) -> int:
    return int(text.split(f'{what} ')[1].split(',')[0].split()[0])


def refused_stderr(args, capsys):
    code = bag.main([str(a) for a in args])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.count('\n') == 0 and err.startswith('linkage bag: error:'), err
    return err


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
