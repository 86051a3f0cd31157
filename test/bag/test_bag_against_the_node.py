"""`linkage bag` against the node: its engine in-process on long mixed streams and through
toggles, Newton one by one, the running linkage_node over DDS, and the vectorised path against
a one-by-one run of the core Solver."""

from __future__ import annotations

import csv
import math
import time

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from test_bag import (
    GROUND,
    JS,
    TOL,
    TS,
    four_bar,
    four_bar_rates,
    joint_state,
    make_input,
    mixed_stream,
    read_csv,
    read_out_bag,
    recorded_velocity,
    run_bag,
    stamp_ns,
    stream_messages,
    summary_count,
    wrap,
)

from linkage_ros import bag
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

# ---- the node's answers ------------------------------------------------------------------------


def _node_engine(scene_file, **params):
    """The node's session (linkage_ros.engine.Engine, as the node loads it), in-process, solving
    one command at a time, for a scene file."""
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
    assert summary_count(cap.out, 'vectorised rows') > 0.8 * len(rows)
    # every row is counted once: batched, one by one, or refused as the message stands
    ways = ('vectorised rows', 'one-by-one rows', 'refused before any solve')
    counted = [summary_count(cap.out, w) if f'{w} ' in cap.out else 0 for w in ways]
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
    assert summary_count(cap.out, 'vectorised rows') > share * len(rows)
    assert summary_count(cap.out, 'one-by-one rows') > 0  # near the singularities
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
    assert summary_count(cap.out, 'vectorised rows') >= 0.99 * n, cap.out
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
