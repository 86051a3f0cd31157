"""`linkage bag` answers as the node does: the assembly mode, point targets, partial commands,
recorded trajectories and paths, frames, and the summary's counts."""

from __future__ import annotations

import math

import pytest
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from test_bag import (  # noqa: F401
    JS,
    TS,
    four_bar,
    joint_state,
    make_input,
    read_csv,
    read_out_bag,
    run_bag,
    summary_count,
    write_bag,
)

from linkage_ros.core.model import Scene


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
    assert 'reachable only in another circuit of the mechanism (signs -' in rows[1]['reason']
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
    assert sum(summary_count(cap.out, w) for w in ways) == 30, cap.out


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
    assert sum(summary_count(cap.out, w) for w in ways) == n, cap.out


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
    assert len(rows) == len(cases)
    for row, (names, values) in zip(rows, cases):
        want = engine.command(dict(zip(names, values)))
        assert row['status'] == ('ok' if want.success else 'error')
        if not want.success:
            assert row['reason'] == want.reason, row['reason']
            assert 'not an actuator' in row['reason']
