"""`linkage bag`: bad input and output paths found by hand in reviews, each refused up front
with nothing written, and stamps, storages and outputs as the node and rosbag2 give them."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from test_bag import (  # noqa: F401
    JS,
    TOL,
    TS,
    four_bar,
    joint_state,
    make_input,
    read_csv,
    read_out_bag,
    refused_stderr,
    run_bag,
    wrap,
    write_bag,
)

from linkage_ros import bag
from linkage_ros.core.model import Scene

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
    err = refused_stderr([*common, '--plot', tmp_path / 'run.txt'], capsys)
    assert 'cannot write a .txt image' in err and 'png' in err
    assert not out_csv.exists()  # nothing was written
    assert 'is a folder' in refused_stderr([*common, '--plot', tmp_path], capsys)
    assert 'is also an --out path' in refused_stderr([*common, '--plot', out_csv], capsys)
    assert 'does not exist' in refused_stderr(
        [*common, '--plot', tmp_path / 'no' / 'p.png'], capsys
    )


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
        err = refused_stderr([*common, *outs], capsys)
        assert 'r.trajectories.csv: is where the trajectories and paths of --out' in err, err
        assert not out_csv.exists() and not beside.exists()
    beside.mkdir()
    err = refused_stderr([*common, '--out', out_csv], capsys)
    assert 'r.trajectories.csv (the trajectories and paths of --out' in err, err
    assert 'is a folder' in err and not out_csv.exists()


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
    err = refused_stderr([src, '--scene', scene, '--command-topic', '/cmd', '--out', out], capsys)
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


def test_a_plot_alone_is_an_output(tmp_path, scene, capsys):
    """`--plot run.png` without --out failed 'no output: give --out ...' though an output (the
    plot) was asked for. It is written; with no output at all the message names --plot too."""
    src = _small_bag(tmp_path, n=5)
    png = tmp_path / 'run.png'
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--no-progress']
    code, cap = run_bag([*common, '--plot', png], capsys)
    assert code == 0, cap.err
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and f'wrote {png} (plot)' in cap.out
    assert not list(tmp_path.glob('*.csv'))  # (nothing else)
    code, cap = run_bag(common, capsys)
    assert code == 2 and 'no output: give --out OUTPUT and/or --plot IMAGE' in cap.err


def test_a_trajectory_naming_a_joint_twice_is_refused_in_its_own_words(tmp_path, scene, capsys):
    """A JointTrajectory with joint_names ['crank', 'crank'] was refused as 'joint_names:
    JointState names ['crank'] more than once' (a JointState's words for a trajectory)."""
    m = TS.types
    point = m['trajectory_msgs/msg/JointTrajectoryPoint'](
        positions=np.array([0.1, 0.2]),
        velocities=np.zeros(0),
        accelerations=np.zeros(0),
        effort=np.zeros(0),
        time_from_start=m['builtin_interfaces/msg/Duration'](sec=1, nanosec=0),
    )
    stamp = m['builtin_interfaces/msg/Time'](sec=1, nanosec=0)
    header = m['std_msgs/msg/Header'](stamp=stamp, frame_id='')
    traj = m['trajectory_msgs/msg/JointTrajectory'](
        header=header, joint_names=['crank', 'crank'], points=[point]
    )
    src = tmp_path / 'in'
    msgs = [('/cmd', 10**9 + i, joint_state(['crank'], [0.1 * i])) for i in range(3)]
    write_bag(src, 'mcap', msgs, [('/traj', 'trajectory_msgs/msg/JointTrajectory', traj)])
    out = tmp_path / 'o.csv'
    code, cap = run_bag([src, '--scene', scene, '--command-topic', '/cmd', '--trajectory-topic',
                         '/traj', '--out', out, '--no-progress'], capsys)  # fmt: skip
    assert code == 0, cap.err
    (row,) = read_csv(tmp_path / 'o.trajectories.csv')
    assert row['reason'] == "JointTrajectory joint_names ['crank'] more than once", row


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
    assert 'cannot use this path' in refused_stderr(
        [*common, '--out', tmp_path / 'loop.csv'], capsys
    )
    err = refused_stderr([*common, '--out', tmp_path / 'loopbag'], capsys)
    assert 'exists already' in err or 'cannot use this path' in err
    assert 'cannot use this path' in refused_stderr(
        [*common, '--out', tmp_path / 'r.csv', '--plot', tmp_path / 'loop.csv'], capsys
    )
    afile = tmp_path / 'afile'
    afile.write_text('x')
    err = refused_stderr([*common, '--out', afile / 'r.csv'], capsys)
    assert f'folder {afile} is not a folder' in err
    (tmp_path / 'dangling').symlink_to(tmp_path / 'nowhere')
    assert 'exists already' in refused_stderr([*common, '--out', tmp_path / 'dangling'], capsys)


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
    err = refused_stderr(args, capsys)
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
        err = refused_stderr([*common, *extra], capsys)
        assert f'folder {locked.resolve()} is not writable' in err
    assert reads == []


def test_empty_topic_names_are_usage_errors(tmp_path, scene, capsys):
    """An empty --target-topic (e.g. an unset shell variable) was silently dropped, so target
    commands went unsolved without a word; an empty --command-topic read nothing. Both are now
    usage errors that name the option, before any output is written."""
    src = _small_bag(tmp_path)
    out_csv = tmp_path / 'r.csv'
    common = [src, '--scene', scene, '--out', out_csv, '--no-progress']
    err = refused_stderr([*common, '--command-topic', '/cmd', '--target-topic', ''], capsys)
    assert '--target-topic: empty topic name' in err
    err = refused_stderr([*common, '--command-topic', ' '], capsys)
    assert '--command-topic: empty topic name' in err
    assert not out_csv.exists()
    code, cap = run_bag([*common, '--command-topic', '/cmd'], capsys)  # and the same run works
    assert code == 0, cap.err


def test_zero_stamped_answers_in_the_result_bag_never_repeat_or_go_back(tmp_path, scene, capsys):
    """TOPICS.md: the stamps the node chooses come strictly after the last joint_states (tf
    keeps the first transform of a stamp). A command stamped T0 + 1 s received at T0 + 1 ns,
    then two zero-stamped ones received at T0 + 2 ns: the bag stamped them T0 + 2 ns twice,
    before the first (an outside review). Oracle: the node's rule written out here, and that
    the poses' stamps strictly increase."""
    from test_bag import stamp_ns

    t0 = 1_700_000_000 * 10**9
    msgs = [
        ('/cmd', t0 + 1, joint_state(['crank'], [0.3], (t0 + 10**9) // 10**9, 0)),
        ('/cmd', t0 + 2, joint_state(['crank'], [0.4])),
        ('/cmd', t0 + 2, joint_state(['crank'], [0.5])),
        ('/cmd', t0 + 5 * 10**9, joint_state(['crank'], [0.6])),  # the clock past them all
        ('/cmd', t0 + 6 * 10**9, joint_state(['crank'], [0.7], (t0 + 3600 * 10**9) // 10**9)),
        ('/cmd', t0 + 7 * 10**9, joint_state(['crank'], [0.8])),  # an hour ahead: not followed
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'out'
    code, cap = run_bag([src, '--scene', scene, '--command-topic', '/cmd', '--out', out], capsys)
    assert code == 0, cap.err
    got, _ = read_out_bag(out)
    stamps = [stamp_ns(m) for _, m in got['/joint_states']]
    want = [t0 + 10**9, t0 + 10**9 + 1, t0 + 10**9 + 2, t0 + 5 * 10**9, t0 + 3600 * 10**9]
    want.append(t0 + 7 * 10**9)
    assert stamps == want
