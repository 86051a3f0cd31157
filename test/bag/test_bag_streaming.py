"""linkage bag streams recorded trajectories to its outputs as it answers them (issue 27): it
kept every answer (about 3.6 KB a point: 36 MB per 10^4-point trajectory, 1.5 GB for 40 of
them) until the end. Memory is now bounded by one plan whatever the number of plans.

Memory is measured in a subprocess per run (the growth of its peak RSS, VmHWM, over
the analysis alone): the same commands with 0, 1 and 8 recorded trajectories. One plan's cost
is what the run with one adds to the run with none; eight must not cost much more than one
(the old code paid for each of them: 8 x 4000 points took 7 x 14 MB more than one). The
outputs are checked against the closed-form four-bar (oracles.fourbar, 50 digits), the node's
trajectory code answering them whole, and the two streamed outputs (the trajectories' CSV, the
result bag) against each other.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import oracles
import test_fleet as tf
from rosbags.rosbag2 import Reader

from linkage_ros.core.model import Scene
from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.trajectory import solve_trajectory

POINTS = 4000
MANY = 8

#: the analysis in a process of its own; prints its peak RSS growth (KiB) and exit status.
#: The peak is the process's own (VmHWM: ru_maxrss starts at the parent's size after exec, so
#: a child of a big test process would see no growth)
RUN = """
import json, sys
from linkage_ros.bag import main
import linkage_ros.bag.replay, linkage_ros.trajectory, rosbags.rosbag2  # imported before

def peak_kib():
    with open('/proc/self/status') as fh:
        return next(int(l.split()[1]) for l in fh if l.startswith('VmHWM:'))

before = peak_kib()
code = main(sys.argv[1:])
print(json.dumps({'code': code, 'growth_kib': peak_kib() - before}))
"""


def crank_rows(k: int) -> list[list[float]]:
    """Trajectory k: the crank (a full-turning Grashof crank) from 0.2 + 0.05 k rad."""
    return [[0.2 + 0.05 * k + 1e-4 * i] for i in range(POINTS)]


def analyse(folder: Path, plans: int) -> tuple[dict, Path]:
    folder.mkdir()
    trajs = [crank_rows(k) for k in range(plans)]
    tf.write_fleet_bag(folder / 'bag', 'mcap', 200, 0.3, trajs=trajs)
    args = [str(folder / 'bag'), '--scene', str(tf.SCENE), '--command-topic', '/cmd']
    args += ['--trajectory-topic', '/traj', '--out', str(folder / 'o.csv')]
    args += ['--out', str(folder / 'obag'), '--no-progress']
    done = subprocess.run(
        [sys.executable, '-c', RUN, *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=folder,
    )
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert got['code'] == 0, done.stdout
    return got, folder


def fourbar_joints(theta2: float) -> dict[str, float]:
    """The four_bar scene's joint angles (O2: crank, A and B: relative, O4: rocker) from
    the closed form."""
    o = oracles.fourbar(0.30, 0.10, 0.25, 0.20, theta2, 1)
    t3, t4 = float(o['theta3']), float(o['theta4'])
    return {'O2': theta2, 'A': t3 - theta2, 'B': t4 - t3, 'O4': t4}


def test_many_trajectories_cost_the_memory_of_one(tmp_path):
    none, _ = analyse(tmp_path / 'none', 0)
    one, _ = analyse(tmp_path / 'one', 1)
    many, folder = analyse(tmp_path / 'many', MANY)
    plan = one['growth_kib'] - none['growth_kib']
    more = many['growth_kib'] - one['growth_kib']
    assert plan > 0, (none, one)  # the measurement sees a plan
    assert more < 2 * plan, f'{MANY} plans cost {more} KiB more than one ({plan} KiB a plan)'

    # the trajectories' CSV: every point of every plan, in bag order, as the closed form has it
    with open(folder / 'o.trajectories.csv', newline='') as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == MANY * POINTS
    assert {r['status'] for r in rows} == {'ok'}
    for k in range(MANY):
        mine = rows[k * POINTS : (k + 1) * POINTS]
        assert {r['request'] for r in mine} == {str(k)}
        assert [int(r['point']) for r in mine] == list(range(POINTS))
        assert [int(r['time_from_start_ns']) for r in mine] == [
            (i + 1) * 10**9 for i in range(POINTS)
        ]
        for i in range(0, POINTS, 97):
            want = fourbar_joints(crank_rows(k)[i][0])
            for j, v in want.items():
                assert math.isclose(float(mine[i][f'joint.{j}']), v, abs_tol=1e-12), (k, i, j)

    # the same as answered whole, one after another, by the node's trajectory code on an
    # engine that saw the commands before them (each plan leaves the state as it was)
    engine = Engine(Scene.from_yaml(tf.SCENE).mechanism, EngineSettings())
    for i in range(101):  # write_fleet_bag's commands received before the plans
        engine.command({'crank': 0.3 + 0.013 * i})
    times = [(i + 1) * 10**9 for i in range(POINTS)]
    for k in (0, MANY - 1):
        whole = solve_trajectory(engine, ['crank'], crank_rows(k), (), times)
        assert whole.success
        mine = rows[k * POINTS : (k + 1) * POINTS]
        for r, row in zip(whole.results, mine):
            assert [repr(float(r.joints[j])) for j in ('O2', 'A', 'B', 'O4')] == [
                row[f'joint.{j}'] for j in ('O2', 'A', 'B', 'O4')
            ]

    # the result bag: one solved trajectory and one status per plan, equal to the CSV's rows
    solved, statuses = [], []
    with Reader(folder / 'obag') as r:
        for conn, _t, raw in r.messages():
            if conn.topic == '/linkage_node/solved_trajectory':
                solved.append(tf.TS.deserialize_cdr(raw, conn.msgtype))
            elif conn.topic == '/linkage_node/status':
                msg = tf.TS.deserialize_cdr(raw, conn.msgtype)
                values = {v.key: v.value for v in msg.values}
                if values.get('request') == 'trajectory':
                    statuses.append(values)
    assert len(solved) == MANY and len(statuses) == MANY
    assert {s['points'] for s in statuses} == {str(POINTS)}
    for k, msg in enumerate(solved):
        assert len(msg.points) == POINTS
        names = list(msg.joint_names)
        for i in range(0, POINTS, 13):
            csv_row = rows[k * POINTS + i]
            assert [repr(float(v)) for v in msg.points[i].positions] == [
                csv_row[f'joint.{j}'] for j in names
            ]

    # the commands are answered as if no plan had been there (a plan leaves the state)
    assert (folder / 'o.csv').read_bytes() == (tmp_path / 'none' / 'o.csv').read_bytes()


def test_a_damaged_plan_found_while_streaming_leaves_no_output(tmp_path, capsys):
    """A trajectory that does not decode is found when its turn comes (after the plans
    before it went to the outputs): exit 2 naming the message, and no output at all (no
    command CSV, no trajectories' CSV, no result bag, no partial file)."""
    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin

    from linkage_ros.bag import main

    good = bytes(tf.TS.serialize_cdr(tf.trajectory(crank_rows(0)[:5], 7), tf.TRAJ))
    folder = tmp_path / 'in'
    with Writer(folder / 'bag', version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c_cmd = w.add_connection('/cmd', tf.JS, typestore=tf.TS)
        c_traj = w.add_connection('/traj', tf.TRAJ, typestore=tf.TS)
        for i in range(20):
            t = tf.T0 + i * 10**7
            sec, ns = divmod(t, 10**9)
            msg = tf.joint_state(['crank'], [0.3 + 0.01 * i], sec, ns)
            w.write(c_cmd, t, tf.TS.serialize_cdr(msg, tf.JS))
        for k, raw in enumerate([good, good[: len(good) // 2], good]):
            w.write(c_traj, tf.T0 + (5 + 5 * k) * 10**7 + 1, raw)
    out = tmp_path / 'out'
    out.mkdir()
    args = [str(folder / 'bag'), '--scene', str(tf.SCENE), '--command-topic', '/cmd']
    args += ['--trajectory-topic', '/traj', '--out', str(out / 'o.csv')]
    args += ['--out', str(out / 'obag'), '--no-progress']
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2
    assert f'message 2 on /traj is not a {tf.TRAJ}' in err
    assert sorted(p.name for p in out.iterdir()) == []
