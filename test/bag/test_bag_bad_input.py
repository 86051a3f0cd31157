"""`linkage bag` on bad input: unusable bags, options and output paths refused with one clear
message before any work; refused rows, the summary, the plot and the CSV's number text."""

from __future__ import annotations

import math
import os
import shutil
import warnings

import numpy as np
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from test_bag import (  # noqa: F401
    JS,
    SCENE_YAML,
    TS,
    joint_state,
    make_input,
    read_csv,
    refused_stderr,
    run_bag,
    write_bag,
)

from linkage_ros import bag
from linkage_ros.core.model import Scene

# ---- bad input ---------------------------------------------------------------------------------


def test_bad_bags_exit_2_with_one_clear_message(tmp_path, scene, capsys):
    good = make_input(
        tmp_path,
        'mcap',
        [('/cmd', 1000 + i, joint_state(['crank'], [0.1 * i])) for i in range(200)],
    )
    common = ['--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'x.csv']
    # missing
    assert 'no such file' in refused_stderr([tmp_path / 'nothing_here', *common], capsys)
    # a tolerance of the whole length scale answers targets OK far from them: refused
    err = refused_stderr([good, *common, '--tol', '1'], capsys)
    assert '--tol must be at most 0.001 (got 1.0)' in err, err
    # a missing .db3 (rosbag2's own name for a split file, run_0.db3, guessed) is missing, not
    # a corrupt database (sqlite3 cannot open it either)
    err = refused_stderr([tmp_path / 'run_0.db3', *common], capsys)
    assert 'no such file or folder' in err and 'quick_check' not in err, err
    # not a bag: a text file, a folder without metadata and storage
    text = tmp_path / 'notes.txt'
    text.write_text('hello')
    assert 'not a rosbag2' in refused_stderr([text, *common], capsys)
    empty = tmp_path / 'emptydir'
    empty.mkdir()
    assert 'not a rosbag2' in refused_stderr([empty, *common], capsys)
    # a folder holding one storage file and more bags below it: not that one bag alone (only
    # the file was read, the others left out without a word)
    holder = tmp_path / 'recordings'
    holder.mkdir()
    shutil.copy(good / 'in_mcap.mcap', holder / 'single.mcap')
    shutil.copytree(good, holder / 'day1' / 'run')
    err = refused_stderr([holder, *common], capsys)
    assert 'more bags below it (day1/run, ...)' in err and '--out-dir' in err, err
    shutil.rmtree(holder / 'day1')
    code, cap = run_bag([holder, *common, '--no-progress'], capsys)
    assert code == 0, cap.err  # the one file alone is that bag, as before
    # a .mcap that is not MCAP at all
    fake = tmp_path / 'fake.mcap'
    fake.write_bytes(b'not an mcap file' * 10)
    assert 'cannot open' in refused_stderr([fake, *common], capsys)
    # missing topic: the topics that exist are listed
    err = refused_stderr(
        [good, '--scene', scene, '--command-topic', '/nope', '--out', tmp_path / 'x.csv'], capsys
    )
    assert 'topic /nope is not in the bag' in err and '/cmd (sensor_msgs/msg/JointState)' in err
    err = refused_stderr([good, *common, '--target-topic', '/missing'], capsys)
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
    err = refused_stderr(
        [typed, '--scene', scene, '--command-topic', '/words', '--out', tmp_path / 'x.csv'], capsys
    )
    assert 'std_msgs/msg/String' in err and 'expected sensor_msgs/msg/JointState' in err
    # truncated MCAP (folder and single file)
    mcap = good / f'{good.name}.mcap'
    cut = tmp_path / 'cut'
    shutil.copytree(good, cut)
    data = mcap.read_bytes()
    (cut / mcap.name).write_bytes(data[: len(data) // 2])
    assert 'truncated' in refused_stderr([cut, *common], capsys)
    cutfile = tmp_path / 'cut.mcap'
    cutfile.write_bytes(data[: len(data) // 2])
    err = refused_stderr([cutfile, *common], capsys)
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
    err = refused_stderr([sq, *common], capsys)
    assert 'corrupt' in err or 'truncated' in err
    # unreadable metadata: still one line
    meta = tmp_path / 'meta'
    shutil.copytree(good, meta)
    (meta / 'metadata.yaml').write_text('rosbag2_bagfile_information: {version: [')
    assert 'cannot open the bag' in refused_stderr([meta, *common], capsys)
    # a message whose CDR is cut short
    short = tmp_path / 'short'
    write_bag(
        short,
        'mcap',
        [('/cmd', 7, bytes(TS.serialize_cdr(joint_state(['crank'], [0.3]), JS))[:30])],
    )
    err = refused_stderr([short, *common], capsys)
    assert 'not a valid JointState' in err and 'corrupt' in err
    # outputs: an existing output bag is not overwritten
    exists = tmp_path / 'exists'
    exists.mkdir()
    assert 'exists already' in refused_stderr(
        [good, '--scene', scene, '--command-topic', '/cmd', '--out', exists], capsys
    )
    # a bad scene or branch is a usage error too
    assert 'not found: not a file and not a packaged scene' in refused_stderr(
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
    assert 'branch' in refused_stderr([good, *common, '--branch', '+-+'], capsys)


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
    assert 'nothing to solve: no message on the topics given' in cap.out
    # nothing answered is no success (it exited 0, as if every command had been answered)
    assert code == 1 and 'is --command-topic the topic' in cap.err, cap.err
    assert read_csv(tmp_path / 'e.csv') == []  # (the outputs are written, as when all refused)


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


def test_plot_of_infinite_commands_warns_of_nothing(tmp_path, scene, capsys):
    """A refused +-inf command leaked numpy's 'invalid value encountered in sin/cos' (the
    plot wraps each input angle) with --plot and with the fleet's --format png: the row is a
    gap in the plot, nothing to warn of."""
    values = [0.5, math.inf, 0.6, -math.inf, math.nan, 0.7]
    msgs = [('/cmd', 10**9 + i, joint_state(['crank'], [v])) for i, v in enumerate(values)]
    src = make_input(tmp_path, 'mcap', msgs)
    common = [src, '--scene', scene, '--command-topic', '/cmd', '--no-progress']
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        code, cap = run_bag([*common, '--out', tmp_path / 'p.csv', '--plot', tmp_path / 'p.png'])
        assert code == 0 and (tmp_path / 'p.png').stat().st_size > 1000
        code = bag.main([str(a) for a in [*common, '--out-dir', tmp_path / 'all', '--jobs', 1]]
                        + ['--format', 'png'])  # fmt: skip
        assert code == 0 and (tmp_path / 'all' / f'{src.name}.png').stat().st_size > 1000
    assert [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)] == []


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
        assert text == ['nan' if v != v else repr(float(v)) for v in const], (const, text)
    ints = bag.format_ints(np.array([0, 7, -7, 10, 1234567890123, 2**62]))
    assert [bytes(r[r != 0]).decode() for r in ints] == [
        '0',
        '7',
        '-7',
        '10',
        '1234567890123',
        str(2**62),
    ]


def test_an_unknown_scene_name_is_said_as_every_command_says_it(tmp_path, capsys):
    """`--scene nosuchscene` said 'nosuchscene: scene file not found' where `linkage solve`
    says it is neither a file nor a packaged scene and lists the packaged ones (an outside
    bag analyst); nothing is written."""
    src = make_input(tmp_path, 'mcap', [('/cmd', 10**9, joint_state(['crank'], [0.1], 1))])
    out = tmp_path / 'o.csv'
    code, cap = run_bag(
        [src, '--scene', 'nosuchscene', '--command-topic', '/cmd', '--out', out], capsys
    )
    assert code == 2
    line = cap.err.strip()
    assert "scene 'nosuchscene' not found: not a file and not a packaged scene" in line, line
    assert 'four_bar' in line and 'slider_crank' in line and '\n' not in line
    assert not out.exists()
