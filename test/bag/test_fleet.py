"""Tests of the fleet run (``linkage bag INPUT... --out-dir DIR``: linkage_ros/bag/fleet_*.py).

A folder of generated bags (sqlite3 and MCAP folders, a loose .mcap file, one damaged, one with
recorded trajectories) is analysed one bag after the other, in two local processes and on a
two-worker dask.distributed.LocalCluster. Oracles:

* ``linkage bag`` on each bag alone (``--out``), the single-bag tool test_bag.py checks against
  an independent four-bar solution and the node: every fleet output must equal it byte for
  byte (CSV) and value for value (Parquet, result bags);
* what the bags were written with: message counts, NaN commands (refused), bag times;
* pyarrow reading the Parquet file back (schema, row count, row groups).
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore
from scenes import CONFIG, REPO

from linkage_ros import bag
from linkage_ros.bag.fleet_inputs import find_bags

TS = get_typestore(Stores.ROS2_JAZZY)
JS = 'sensor_msgs/msg/JointState'
TRAJ = 'trajectory_msgs/msg/JointTrajectory'
SCENE = CONFIG / 'four_bar.yaml'
T0 = 1_700_000_000 * 10**9


def joint_state(names, positions, sec=0, nanosec=0):
    m = TS.types
    return m[JS](
        header=m['std_msgs/msg/Header'](
            stamp=m['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=''
        ),
        name=list(names),
        position=np.asarray(positions, float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


def trajectory(rows, sec):
    m = TS.types
    points = [
        m['trajectory_msgs/msg/JointTrajectoryPoint'](
            positions=np.asarray(r, float),
            velocities=np.zeros(0),
            accelerations=np.zeros(0),
            effort=np.zeros(0),
            time_from_start=m['builtin_interfaces/msg/Duration'](sec=k + 1, nanosec=0),
        )
        for k, r in enumerate(rows)
    ]
    header = m['std_msgs/msg/Header'](
        stamp=m['builtin_interfaces/msg/Time'](sec=sec, nanosec=0), frame_id=''
    )
    return m[TRAJ](header=header, joint_names=['crank'], points=points)


def write_fleet_bag(path: Path, storage: str, n: int, phase: float, nan_every=0, trajs=()):
    """n crank commands 10 ms apart (every nan_every-th NaN: refused), /traj with ``trajs``;
    returns (bag times, indices of the NaN commands)."""
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    times, nans = [], []
    with Writer(path, version=9, storage_plugin=plugin) as w:
        c_cmd = w.add_connection('/cmd', JS, typestore=TS)
        c_traj = w.add_connection('/traj', TRAJ, typestore=TS)
        for i in range(n):
            t = T0 + i * 10**7
            value = phase + 0.013 * i
            if nan_every and i % nan_every == nan_every - 1:
                value = math.nan
                nans.append(i)
            sec, ns = divmod(t, 10**9)
            w.write(c_cmd, t, TS.serialize_cdr(joint_state(['crank'], [value], sec, ns), JS))
            times.append(t)
        for k, rows in enumerate(trajs):
            t = T0 + (n // 2) * 10**7 + 5 * 10**6 + k
            w.write(c_traj, t, TS.serialize_cdr(trajectory(rows, 7), TRAJ))
    return times, nans


@pytest.fixture(scope='module')
def fleet(tmp_path_factory):
    """fleet/day1/a (sqlite3), fleet/day1/b.mcap (a loose MCAP file), fleet/day2/c (MCAP,
    with two recorded trajectories), fleet/day2/damaged (MCAP cut in half)."""
    root = tmp_path_factory.mktemp('fleet') / 'fleet'
    info = {}
    info['day1/a'] = write_fleet_bag(root / 'day1' / 'a', 'sqlite3', 400, 0.2, nan_every=50)
    info['day1/b'] = write_fleet_bag(root / 'tmp_b', 'mcap', 300, -2.0)
    shutil.move(next((root / 'tmp_b').glob('*.mcap')), root / 'day1' / 'b.mcap')
    shutil.rmtree(root / 'tmp_b')
    trajs = [[[0.1 * k] for k in range(5)], [[0.3], [float('nan')]]]
    info['day2/c'] = write_fleet_bag(root / 'day2' / 'c', 'mcap', 250, 1.0, trajs=trajs)
    write_fleet_bag(root / 'day2' / 'damaged', 'mcap', 200, 0.5)
    f = next((root / 'day2' / 'damaged').glob('*.mcap'))
    f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    return root, info


COMMON = ['--scene', SCENE, '--command-topic', '/cmd', '--trajectory-topic', '/traj']
FORMATS = ['--format', 'csv', '--format', 'parquet', '--format', 'mcap']


def run(args, capsys):
    code = bag.main([str(a) for a in args] + ['--no-progress'])
    return code, capsys.readouterr()


def read_csv(path: Path) -> list[dict]:
    with open(path, newline='') as fh:
        return list(csv.DictReader(fh))


def summary_rows(out: Path):
    with open(out / 'summary.csv', newline='') as fh:
        rows = {r['bag']: r for r in csv.DictReader(fh)}
    doc = json.loads((out / 'summary.json').read_text())
    return rows, doc


def bag_values(path: Path):
    """Every message of a result bag, deserialised, as comparable plain values."""
    out = []
    with Reader(path) as r:
        for conn, t, raw in r.messages():
            msg = TS.deserialize_cdr(raw, conn.msgtype)
            out.append((conn.topic, t, repr(msg)))
    return out


def outputs_of(out: Path, name: str) -> dict:
    got = {
        'csv': (out / f'{name}.csv').read_bytes(),
        'parquet': (out / f'{name}.parquet').read_bytes(),
        'mcap': bag_values(out / f'{name}.mcap'),
    }
    traj = out / f'{name}.trajectories.csv'
    if traj.exists():
        got['traj'] = traj.read_bytes()
    return got


GOOD = ['day1/a', 'day1/b', 'day2/c']


@pytest.fixture(scope='module')
def serial(fleet, tmp_path_factory, request):
    """The fleet analysed one bag after the other (--jobs 1)."""
    root, _ = fleet
    out = tmp_path_factory.mktemp('serial') / 'out'
    code = bag.main([str(a) for a in [root, *COMMON, *FORMATS, '--out-dir', out, '--jobs', 1]])
    return code, out


def test_each_bags_outputs_equal_linkage_bag_on_that_bag_alone(fleet, serial, tmp_path, capsys):
    root, _ = fleet
    code, out = serial
    assert code == 3  # the damaged bag failed; the others are complete
    for name in GOOD:
        source = root / name if (root / name).is_dir() else root / f'{name}.mcap'
        alone_csv, alone_bag = tmp_path / f'{name.replace("/", "_")}.csv', tmp_path / 'b'
        shutil.rmtree(alone_bag, ignore_errors=True)
        c, cap = run([source, *COMMON, '--out', alone_csv, '--out', alone_bag], capsys)
        assert c == 0, cap.err
        assert (out / f'{name}.csv').read_bytes() == alone_csv.read_bytes(), name
        assert bag_values(out / f'{name}.mcap') == bag_values(alone_bag), name
        plans = tmp_path / f'{name.replace("/", "_")}.trajectories.csv'
        fleet_plans = out / f'{name}.trajectories.csv'
        assert fleet_plans.exists() == plans.exists()
        if plans.exists():
            assert fleet_plans.read_bytes() == plans.read_bytes()
    assert not list(out.glob('day2/damaged*')), 'a failed bag leaves no output'


def test_the_summary_has_one_row_per_bag_and_the_damaged_bags_reason(fleet, serial):
    root, info = fleet
    _, out = serial
    rows, doc = summary_rows(out)
    assert sorted(rows) == ['day1/a', 'day1/b', 'day2/c', 'day2/damaged']
    bad = rows['day2/damaged']
    assert bad['status'] == 'failed' and 'truncated, corrupt' in bad['reason']
    assert str(root / 'day2' / 'damaged') in bad['reason']
    for name in GOOD:
        r = rows[name]
        times, nans = info[name]
        plans = 2 if name == 'day2/c' else 0
        assert r['status'] == 'ok' and r['reason'] == ''
        assert int(r['messages']) == len(times) + plans
        # refused: the NaN commands, and the trajectory with a NaN point
        assert int(r['refused']) == len(nans) + (1 if plans else 0)
        assert int(r['answered']) == len(times) + plans - int(r['refused'])
        assert int(r['first_stamp_ns']) == times[0] and int(r['last_stamp_ns']) == times[-1]
        table = read_csv(out / f'{name}.csv')
        ok = [t for t in table if t['status'] == 'ok']
        assert float(r['min_margin']) == min(float(t['margin']) for t in ok)
        assert float(r['max_residual']) == max(float(t['residual']) for t in ok)
        assert float(r['wall_s']) > 0
    assert doc['totals']['bags'] == 4 and doc['totals']['failed'] == 1
    assert [b['bag'] for b in doc['bags']] == sorted(rows)


def test_parquet_reads_back_with_typed_columns(fleet, serial):
    import pyarrow as pa
    import pyarrow.parquet as pq

    _, info = fleet
    _, out = serial
    for name in GOOD:
        path = out / f'{name}.parquet'
        table = pq.read_table(path)
        schema = table.schema
        assert schema.field('time_ns').type == pa.int64()
        assert schema.field('receive_time_ns').type == pa.int64()
        assert schema.field('input.crank').type == pa.float64()
        assert schema.field('P.x').type == pa.float64()
        assert pa.types.is_dictionary(schema.field('status').type)
        assert pa.types.is_dictionary(schema.field('topic').type)
        times, nans = info[name]
        assert table.num_rows == len(times)
        assert pq.ParquetFile(path).metadata.num_row_groups == 1
        assert table.column('receive_time_ns').to_pylist() == times
        rows = read_csv(out / f'{name}.csv')
        status = table.column('status').to_pylist()
        assert status == [r['status'] for r in rows]
        assert [i for i, s in enumerate(status) if s == 'error'] == nans
        for col in ('joint.O4', 'P.y', 'margin'):
            want = [float(r[col]) if r[col] else None for r in rows]
            assert table.column(col).to_pylist() == want, col
        # text fields: null where the CSV's is empty (a refused row's branch, an OK row's
        # reason), one convention (a refused row's branch was '')
        for col in ('branch', 'reason'):
            assert table.column(col).to_pylist() == [r[col] or None for r in rows], col


def test_one_row_group_per_block(tmp_path, fleet):
    """A Parquet file has one row group per block of rows (readers stream it)."""
    import pyarrow.parquet as pq

    from linkage_ros.bag.parquet_out import write_parquet
    from linkage_ros.bag.reading import read_commands
    from linkage_ros.bag.replay import ReplayEngine
    from linkage_ros.core.model import Scene

    root, info = fleet
    mech = Scene.from_yaml(SCENE).mechanism
    data = read_commands(str(root / 'day1' / 'a'), ['/cmd'])
    res = ReplayEngine(mech, None, 1e-12, 50, 'continuous').solve_all(data)
    write_parquet(tmp_path / 'x.parquet', data, res, mech, block=64)
    meta = pq.ParquetFile(tmp_path / 'x.parquet').metadata
    assert meta.num_rows == 400 and meta.num_row_groups == math.ceil(400 / 64)
    assert [meta.row_group(k).num_rows for k in range(meta.num_row_groups)][:-1] == [64] * 6


def test_two_local_processes_give_identical_outputs(fleet, serial, tmp_path, capsys):
    root, _ = fleet
    _, ref = serial
    out = tmp_path / 'out'
    code, cap = run([root, *COMMON, *FORMATS, '--out-dir', out, '--jobs', 2], capsys)
    assert code == 3 and 'on 2 local processes' in cap.out, cap.out
    for name in GOOD:
        assert outputs_of(out, name) == outputs_of(ref, name), name
    rows, _ = summary_rows(out)
    assert rows['day2/damaged']['status'] == 'failed'


def test_a_dask_local_cluster_gives_identical_outputs(fleet, serial, tmp_path, capsys):
    from dask.distributed import LocalCluster

    root, _ = fleet
    _, ref = serial
    out = tmp_path / 'out'
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address
        code, cap = run([root, *COMMON, *FORMATS, '--out-dir', out, '--scheduler', address], capsys)
    assert code == 3 and f'the Dask cluster at {address}' in cap.out, cap.out
    for name in GOOD:
        assert outputs_of(out, name) == outputs_of(ref, name), name
    rows, _ = summary_rows(out)
    assert rows['day2/damaged']['status'] == 'failed'
    assert 'truncated, corrupt' in rows['day2/damaged']['reason']


def test_resume_skips_finished_bags_and_redoes_the_rest(fleet, tmp_path, capsys):
    root, _ = fleet
    out = tmp_path / 'out'
    args = [root, *COMMON, '--format', 'csv', '--format', 'sqlite3', '--out-dir', out, '--jobs', 1]
    code, _ = run(args, capsys)
    assert code == 3
    first = {n: (out / f'{n}.csv').read_bytes() for n in GOOD}
    stat = {n: (out / f'{n}.csv').stat().st_mtime_ns for n in GOOD}
    # a lost worker: day1/b's outputs are there but its manifest was never written
    (out / 'day1' / 'b.done.json').unlink()
    # the same command again without --resume changes nothing and says why
    code, cap = run(args, capsys)
    assert code == 2 and '--resume' in cap.err
    assert {n: (out / f'{n}.csv').stat().st_mtime_ns for n in GOOD} == stat
    code, cap = run([*args, '--resume'], capsys)
    assert code == 3
    assert '2 bag(s) complete already, skipped (--resume)' in cap.out
    assert '2 bag(s) analysed' in cap.out  # day1/b again, and the damaged bag
    for n in ('day1/a', 'day2/c'):
        assert (out / f'{n}.csv').stat().st_mtime_ns == stat[n], n
    assert {n: (out / f'{n}.csv').read_bytes() for n in GOOD} == first
    rows, doc = summary_rows(out)
    assert [rows[n]['resumed'] for n in sorted(rows)] == ['true', 'false', 'true', 'false']
    assert doc['totals']['resumed'] == 2
    # the resumed bags count as what their manifests say: three answered, one failed
    assert (doc['totals']['ok'], doc['totals']['failed']) == (3, 1), doc['totals']
    # a bag changed since: redone
    code, cap = run([*args, '--resume'], capsys)
    assert '3 bag(s) complete already' in cap.out
    for f in (root / 'day1' / 'a').iterdir():
        f.touch()
    code, cap = run([*args, '--resume'], capsys)
    assert '2 bag(s) complete already' in cap.out and rows['day1/a']['status'] == 'ok'


def test_bag_discovery_folders_globs_and_names(fleet, tmp_path):
    root, _ = fleet
    names = [t.name for t in find_bags([str(root)])]
    assert names == ['day1/a', 'day1/b', 'day2/c', 'day2/damaged']
    # a pattern's matches are named from its folder before the first wildcard: two days'
    # bags of one name stay apart (they were named a, b, ... alone, and clashed)
    by_glob = find_bags([str(root / 'day*' / '*')])
    assert sorted(t.name for t in by_glob) == ['day1/a', 'day1/b', 'day2/c', 'day2/damaged']
    assert [t.name for t in find_bags([str(root / 'day*')])] == names
    shutil.copytree(root / 'day1' / 'a', tmp_path / 'days' / '2026-01' / 'run')
    shutil.copytree(root / 'day2' / 'c', tmp_path / 'days' / '2026-02' / 'run')
    by_glob = find_bags([str(tmp_path / 'days' / '2026-*' / '**' / '*.mcap')])
    assert [t.name for t in by_glob] == ['2026-02/run/c']  # (day2/c's storage file)
    by_glob = find_bags([str(tmp_path / 'days' / '2026-*' / 'run')])
    assert [t.name for t in by_glob] == ['2026-01/run', '2026-02/run']
    assert [t.name for t in find_bags([str(root / 'day2'), str(root / 'day2' / 'c')])] == [
        'c',
        'damaged',
    ]
    shutil.copytree(root / 'day1' / 'a', tmp_path / 'copy' / 'a')
    with pytest.raises(bag.BagError, match='the same outputs a'):
        find_bags([str(root / 'day1' / 'a'), str(tmp_path / 'copy')])
    (tmp_path / 'empty').mkdir()
    with pytest.raises(bag.BagError, match='no bag in this folder'):
        find_bags([str(tmp_path / 'empty')])
    with pytest.raises(bag.BagError, match='matches nothing'):
        find_bags([str(tmp_path / 'nope*')])


def test_usage_errors_before_any_work(fleet, tmp_path, capsys):
    root, _ = fleet
    out = tmp_path / 'out'
    for extra, why in [
        (['--out', tmp_path / 'x.csv'], '--out and --out-dir'),
        (['--jobs', 0], '--jobs must be >= 1'),
        (['--jobs', 2, '--scheduler', 'tcp://127.0.0.1:1'], '--jobs and --scheduler'),
        (['--plot', tmp_path / 'p.png'], '--plot names one file (for one bag)'),
        # (it was ignored: each output bag was mcap whatever it said)
        (['--out-format', 'sqlite3'], '--out-format names the storage of the one bag --out'),
    ]:
        code, cap = run([root, *COMMON, '--out-dir', out, *extra], capsys)
        assert code == 2 and why in cap.err, cap.err
    code, cap = run([root, *COMMON, '--out', tmp_path / 'x.csv'], capsys)
    assert code == 2 and 'need --out-dir' not in cap.err  # one folder: not a bag
    code, cap = run([root / 'day1' / 'a', root / 'day2' / 'c', *COMMON, '--out', 'x.csv'], capsys)
    assert code == 2 and 'several bags need --out-dir' in cap.err
    code, cap = run([root / 'day1' / 'a', *COMMON, '--out', 'x.csv', '--jobs', 2], capsys)
    assert code == 2 and '--jobs goes with --out-dir' in cap.err
    assert not out.exists()


def test_without_scheduler_dask_is_never_imported(fleet, tmp_path):
    root, _ = fleet
    code = (
        'import sys; from linkage_ros import bag; '
        f'c = bag.main([{str(root / "day1" / "a")!r}, "--scene", {str(SCENE)!r}, '
        f'"--command-topic", "/cmd", "--out-dir", {str(tmp_path / "o")!r}, "--jobs", "2", '
        '"--no-progress"]); '
        'print(c, sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed")))'
    )
    out = subprocess.run(
        [sys.executable, '-c', code], capture_output=True, text=True, cwd=REPO, check=True
    )
    assert out.stdout.strip().splitlines()[-1] == '0 []', out.stdout + out.stderr


def test_each_bag_shows_its_own_progress_below_the_fleets(fleet, tmp_path, capfd, monkeypatch):
    """Where stderr is a terminal, the fleet's bar and, one line below it, the bar of the bag
    being analysed (named by the bag), in this process and in a local pool's workers (theirs
    written to the file descriptor they inherit: captured at that level)."""
    root, _ = fleet
    for jobs in ('1', '2'):
        monkeypatch.setattr(sys.stderr, 'isatty', lambda: True, raising=False)
        code = bag.main(
            [str(a) for a in (root / 'day1', *COMMON, '--out-dir', tmp_path / jobs, '--jobs', jobs)]
        )
        err = capfd.readouterr().err
        assert code == 0
        assert 'bags' in err  # the fleet's bar
        assert 'a: reading' in err and 'b: solving' in err, err  # named as under --out-dir


def test_each_bag_gets_its_plot_with_format_png(fleet, tmp_path, capsys):
    root, _ = fleet
    out = tmp_path / 'plots'
    code, _ = run(
        [root / 'day1', *COMMON, '--out-dir', out, '--format', 'png', '--jobs', '1'], capsys
    )
    assert code == 0
    for name in ('a', 'b'):
        head = (out / f'{name}.png').read_bytes()[:8]
        assert head == b'\x89PNG\r\n\x1a\n'  # a PNG file, whole (written by rename)
    code, got = run(
        [root / 'day1', *COMMON, '--out-dir', tmp_path / 'x', '--plot', 'p.png'], capsys
    )
    assert code == 2 and '--format png' in got.err


def test_a_packaged_scene_goes_to_the_workers_by_its_name(tmp_path, monkeypatch):
    """FLEET.md: a worker finds "a packaged scene's name (`excavator`) ... in its own
    installation". The options sent to the workers held the client's absolute path of
    config/four_bar.yaml, which a worker installed elsewhere does not have (every bag failed
    'scene file not found'). A scene file still goes by its absolute path."""
    import argparse

    from linkage_ros.bag.command import add_arguments
    from linkage_ros.bag.options import bag_options

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    monkeypatch.chdir(tmp_path)  # no file named four_bar here
    args = parser.parse_args(['x.mcap', '--scene', 'four_bar', '--command-topic', '/cmd'])
    assert bag_options(args).scene == 'four_bar'
    local = tmp_path / 'mine.yaml'
    shutil.copy(SCENE, local)
    args = parser.parse_args(['x.mcap', '--scene', 'mine.yaml', '--command-topic', '/cmd'])
    assert bag_options(args).scene == str(local.resolve())


def test_resume_removes_every_leftover_of_the_bag_and_nothing_else(fleet, tmp_path, capsys):
    """--resume redoing a bag removes its outputs in formats no longer asked for (an MCAP beside
    a new CSV told of another input) and a killed run's staging leftovers (.NAME.PID.partial:
    they stayed forever), and refuses a folder of the user's where a file output goes (it was
    deleted with everything in it)."""
    root, _ = fleet
    out = tmp_path / 'out'
    base = [root, *COMMON, '--out-dir', out, '--jobs', 1]
    code, _ = run([*base, '--format', 'csv', '--format', 'mcap'], capsys)
    assert code == 3 and (out / 'day1' / 'a.mcap').is_dir()
    (out / 'day1' / 'a.done.json').unlink()  # day1/a to be redone
    stage = out / 'day1' / '.a.csv.4242.partial'
    stage.write_text('half')
    bag_stage = out / 'day1' / '.a.mcap.4242.partial'
    bag_stage.mkdir()
    code, cap = run([*base, '--format', 'csv', '--resume'], capsys)
    assert code == 3, cap.err
    assert (out / 'day1' / 'a.csv').is_file()
    assert not (out / 'day1' / 'a.mcap').exists()  # the old answer in the dropped format
    assert not stage.exists() and not bag_stage.exists()
    (out / 'day1' / 'a.done.json').unlink()
    (out / 'day1' / 'a.csv').unlink()
    mine = out / 'day1' / 'a.csv'
    mine.mkdir()
    (mine / 'precious.txt').write_text('keep')
    code, cap = run([*base, '--format', 'csv', '--resume'], capsys)
    assert code == 2 and f'{mine} is a folder where a file output of bag day1/a goes' in cap.err
    assert (mine / 'precious.txt').read_text() == 'keep'
    # a file where an output bag (a folder) would go: not the tool's either
    shutil.rmtree(mine)
    loose = out / 'day1' / 'a.mcap'
    loose.write_text('a recording of my own')
    code, cap = run([*base, '--format', 'csv', '--resume'], capsys)
    assert code == 2 and f'{loose} is a file where a folder (a bag) output' in cap.err, cap.err
    assert loose.read_text() == 'a recording of my own'


def test_a_message_that_is_no_joint_state_and_an_unwritable_output_are_named(
    fleet, tmp_path, capsys
):
    """README: a bag's error is "one line naming the bag, the topic and the first bad message";
    a corrupt JointState's named the topic only. A fleet bag whose output cannot be written
    said 'cannot write an output (File exists)' without the path."""
    bad = tmp_path / 'garbage'
    with Writer(bad, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection('/cmd', JS, typestore=TS)
        w.write(c, T0, TS.serialize_cdr(joint_state(['crank'], [0.1]), JS))
        w.write(c, T0 + 10**7, b'\x00\x01\x00\x00' + b'\xff' * 40)
    code, cap = run([bad, *COMMON[:4], '--out', tmp_path / 'x.csv'], capsys)
    assert code == 2
    (line,) = cap.err.strip().splitlines()
    assert f'input {bad}' in line and 'message 2 on /cmd' in line and 'JointState' in line, line
    root, _ = fleet
    out = tmp_path / 'out'
    out.mkdir()
    (out / 'day1').write_text('x')  # a file where day1's folder goes
    code, cap = run([root, *COMMON, '--format', 'csv', '--out-dir', out, '--jobs', 1], capsys)
    assert code == 3
    rows, _ = summary_rows(out)
    assert rows['day1/a']['status'] == 'failed'
    assert str(out / 'day1') in rows['day1/a']['reason'], rows['day1/a']['reason']


def test_ctrl_c_starts_no_further_bag(tmp_path):
    """README: Ctrl-C ends a run with 130. With --jobs 2 every bag was queued in the pool at
    once, and the queued ones were started and written after the interrupt (two more bags,
    2.5 s later); now the pool holds one bag per worker and nothing is written after it."""
    import os
    import signal
    import time

    root = tmp_path / 'bags'
    for k in range(6):
        write_fleet_bag(root / f'b{k}', 'mcap', 20000, 0.1 * k)
    out = tmp_path / 'out'
    cmd = [sys.executable, '-m', 'linkage_ros.cli', 'bag', str(root), '--scene', str(SCENE)]
    cmd += ['--command-topic', '/cmd', '--solver', 'newton', '--out-dir', str(out)]
    cmd += ['--format', 'csv', '--jobs', '2', '--no-progress']
    proc = subprocess.Popen(
        cmd,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # the two workers are at their first bags once the folder exists (made before the pool)
    end = time.monotonic() + 60
    while not out.exists() and time.monotonic() < end and proc.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    before = sorted(p.name for p in out.iterdir())
    os.killpg(proc.pid, signal.SIGINT)
    output, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130, output.decode()
    after = sorted(p.name for p in out.iterdir())
    assert [n for n in after if n not in before and not n.startswith('summary')] == [], after


def test_a_run_of_other_bags_into_the_folder_of_an_earlier_run_is_refused(fleet, tmp_path, capsys):
    """A second run of other bags into an --out-dir replaced the first run's summary.csv and
    summary.json with its own, silently (an outside new user): FLEET.md says an earlier run's
    outputs are an error without --resume, and the summaries are outputs too."""
    root, _ = fleet
    out = tmp_path / 'out'
    code, _ = run([root / 'day1' / 'a', *COMMON, '--out-dir', out], capsys)
    assert code == 0
    before = {n: (out / n).read_bytes() for n in ('summary.csv', 'summary.json')}
    code, cap = run([root / 'day2' / 'c', *COMMON, '--out-dir', out], capsys)
    assert code == 2 and 'summary.csv' in cap.err and '--resume' in cap.err, cap.err
    assert {n: (out / n).read_bytes() for n in before} == before
    assert not (out / 'c.csv').exists()


def test_an_out_dir_inside_the_input_folder_is_not_read_as_input(fleet, tmp_path, capsys):
    """--out-dir inside the folder of bags: the first run was accepted, and --resume then
    read its output bags as inputs and refused ('bag .../analysis/a.sqlite3 is inside
    --out-dir'): the run could not be finished (an outside new user)."""
    root, _ = fleet
    rec = tmp_path / 'rec'
    shutil.copytree(root / 'day1', rec)
    out = rec / 'analysis'
    args = [rec, *COMMON, '--format', 'sqlite3', '--format', 'csv', '--out-dir', out]
    code, cap = run(args, capsys)
    assert code == 0, cap.err
    (out / 'a.done.json').unlink()  # a lost worker
    code, cap = run([*args, '--resume'], capsys)
    assert code == 0, cap.err
    assert '1 bag(s) complete already' in cap.out and '1 bag(s) analysed' in cap.out
    rows, _ = summary_rows(out)
    assert sorted(rows) == ['a', 'b']
    # the same by a pattern that matches the result bags too (FLEET.md's own form of input)
    out2 = rec / 'analysis2'
    pattern = str(rec / '**' / '*.mcap')
    args = [pattern, *COMMON, '--format', 'mcap', '--format', 'csv', '--out-dir', out2]
    code, cap = run(args, capsys)
    assert code == 0, cap.err
    (out2 / 'b.done.json').unlink()
    code, cap = run([*args, '--resume'], capsys)
    assert code == 0, cap.err
    assert '1 bag(s) analysed' in cap.out
    # a bag inside --out-dir named itself is still refused, naming it
    code, cap = run([out / 'a.sqlite3', *COMMON, '--out-dir', out], capsys)
    assert code == 2 and 'is inside --out-dir' in cap.err, cap.err
