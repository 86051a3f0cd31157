"""``linkage bag`` with the node's semantics (issue 26 item 9): its topic names, one number format
(Python's repr), a bag whose every request is refused is not a success, and a plot that shows
wraps and refusals for what they are.

Oracles: Python's own ``repr`` of each double; the node's topic names as docs/TOPICS.md gives them
(``joint_states`` relative, ``~/points/<p>``, ``~/status`` under the node name linkage_node);
the plotted data itself (no two neighbouring samples of an angle line more than pi apart)."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore
from scenes import CONFIG

from linkage_ros import bag

TS = get_typestore(Stores.ROS2_JAZZY)
JS = 'sensor_msgs/msg/JointState'
SCENE = CONFIG / 'four_bar.yaml'


def joint_state(names, positions, sec):
    m = TS.types
    return m[JS](
        header=m['std_msgs/msg/Header'](
            stamp=m['builtin_interfaces/msg/Time'](sec=sec, nanosec=0), frame_id=''
        ),
        name=list(names),
        position=np.asarray(positions, float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


def make_bag(path, commands, names=('crank',)):
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection('/cmd', JS, typestore=TS)
        for i, value in enumerate(commands):
            msg = joint_state(names, [value], 1 + i)
            w.write(c, 10**9 * (1 + i), TS.serialize_cdr(msg, JS))
    return path


def run(args, capsys):
    code = bag.main([str(a) for a in args] + ['--no-progress'])
    return code, capsys.readouterr()


def test_every_csv_number_is_pythons_repr():
    rng = np.random.default_rng(3)
    values = np.concatenate(
        [
            rng.uniform(-4, 4, 20000),
            rng.normal(0, 1, 20000) * 10.0 ** rng.integers(-30, 17, 20000),
            rng.integers(-(10**6), 10**6, 2000) / 64.0,
            [0.0, -0.0, 1.0, 2.0, 100.0, 0.1, 1e-4, 9.99e-5, 1e-5, 1.5e-7, 1e15, 1e16, 1e-300],
            [5e-324, 1.7976931348623157e308, math.pi, -math.e, 0.05403023058681398, np.inf],
        ]
    )
    text = bag.format_floats(values, b'nan')
    got = [bytes(r[r != 0]).decode() for r in text]
    assert got == [repr(v) for v in values.tolist()]


def test_the_csv_has_one_number_format(tmp_path, capsys):
    src = make_bag(tmp_path / 'in', [-3.0 + 0.37 * k for k in range(40)] + [float('nan')])
    out = tmp_path / 'o.csv'
    code, cap = run([src, '--scene', SCENE, '--command-topic', '/cmd', '--out', out], capsys)
    assert code == 0, cap.err
    with open(out, newline='') as fh:
        rows = list(csv.DictReader(fh))
    numeric = [k for k in rows[0] if k.startswith(('input.', 'joint.')) or k[-2:] in ('.x', '.y')]
    numeric += ['residual', 'margin']
    seen = 0
    for r in rows:
        for k in numeric:
            if r[k] not in ('', 'nan'):
                assert r[k] == repr(float(r[k])), (k, r[k])
                seen += 1
    assert seen > 40 * len(numeric) // 2


def test_the_output_bag_has_the_nodes_topic_names_and_remap_renames(tmp_path, capsys):
    src = make_bag(tmp_path / 'in', [0.1 * k for k in range(10)])
    common = [src, '--scene', SCENE, '--command-topic', '/cmd']
    code, cap = run([*common, '--out', tmp_path / 'a'], capsys)
    assert code == 0, cap.err
    with Reader(tmp_path / 'a') as r:
        topics = {c.topic for c in r.connections}
    assert topics == {'/joint_states', '/linkage_node/points/P', '/linkage_node/status'}
    remap = ['--remap', '/linkage_node/status:=/status', '--remap', '/joint_states:=/arm/js']
    code, cap = run([*common, '--out', tmp_path / 'b', *remap], capsys)
    assert code == 0, cap.err
    with Reader(tmp_path / 'b') as r:
        counts = {c.topic: c.msgcount for c in r.connections}
    assert counts == {'/arm/js': 10, '/linkage_node/points/P': 10, '/status': 10}
    for bad, why in [
        ('/status:=/x', '/status is not an output topic'),
        ('/linkage_node/status=/x', 'write FROM:=TO'),
        ('/linkage_node/status:=x', 'not an absolute topic name'),
        ('/linkage_node/status:=/joint_states', 'two output topics would share one name'),
    ]:
        code, cap = run([*common, '--out', tmp_path / 'c', '--remap', bad], capsys)
        assert code == 2 and why in cap.err, cap.err
        assert not (tmp_path / 'c').exists()


def test_remap_refuses_what_ros_refuses_as_a_topic_name(tmp_path, capsys):
    """'/x//y', '/1abc' and '/x?' were accepted (a result bag ROS cannot replay). Oracle: the
    ROS 2 topic name rules ('/' then tokens of [A-Za-z0-9_], none starting with a digit,
    joined by single '/')."""
    src = make_bag(tmp_path / 'in', [0.1, 0.2])
    common = [src, '--scene', SCENE, '--command-topic', '/cmd']
    for bad in ['/x//y', '/1abc', '/x?', '/x/2y', '/', '/x/', '//x', '/x y', '/é', 'x']:
        code, cap = run(
            [*common, '--out', tmp_path / 'c', '--remap', f'/joint_states:={bad}'], capsys
        )
        assert code == 2 and f'{bad!r} is not an absolute topic name' in cap.err, (bad, cap.err)
        assert not (tmp_path / 'c').exists()
    for good in ['/_x', '/a1/b_2/C', '/x__y']:
        out = tmp_path / good.replace('/', '_')
        code, cap = run([*common, '--out', out, '--remap', f'/joint_states:={good}'], capsys)
        assert code == 0, cap.err
        with Reader(out) as r:
            assert good in {c.topic for c in r.connections}


def test_remap_refuses_a_topic_name_longer_than_ros_takes(tmp_path, capsys):
    """A 251-character name was accepted. Oracle: rclpy's own validate_full_topic_name."""
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.validate_full_topic_name import validate_full_topic_name

    src = make_bag(tmp_path / 'in', [0.1, 0.2])
    common = [src, '--scene', SCENE, '--command-topic', '/cmd']
    longest = '/' + 'x' * 246
    validate_full_topic_name(longest)  # the oracle takes it
    with pytest.raises(InvalidTopicNameException):
        validate_full_topic_name(longest + 'x')  # and not one character more
    code, cap = run(
        [*common, '--out', tmp_path / 'a', '--remap', f'/joint_states:={longest}'], capsys
    )
    assert code == 0, cap.err
    code, cap = run(
        [*common, '--out', tmp_path / 'b', '--remap', f'/joint_states:={longest}x'], capsys
    )
    assert code == 2 and 'at most 247' in cap.err, cap.err
    assert not (tmp_path / 'b').exists()


def test_a_bag_whose_every_command_is_refused_exits_1_with_a_hint(tmp_path, capsys):
    """Recorded for another mechanism (names the scene does not have): not a success."""
    src = make_bag(tmp_path / 'in', [0.1, 0.2, 0.3], names=('boom',))
    out = tmp_path / 'o.csv'
    code, cap = run([src, '--scene', SCENE, '--command-topic', '/cmd', '--out', out], capsys)
    assert code == 1
    assert 'every request was refused' in cap.err and '--scene' in cap.err
    with open(out, newline='') as fh:
        assert [r['status'] for r in csv.DictReader(fh)] == ['error'] * 3
    ok = make_bag(tmp_path / 'in2', [0.1, float('nan'), 0.3])
    code, cap = run([ok, '--scene', SCENE, '--command-topic', '/cmd', '--out', out], capsys)
    assert code == 0 and 'every request' not in cap.err


def test_the_plot_breaks_angles_at_wraps_and_marks_refusals_on_the_time_axis(tmp_path):
    import matplotlib.pyplot as plt

    from linkage_ros.bag.reading import read_commands
    from linkage_ros.bag.replay import ReplayEngine
    from linkage_ros.core.model import Scene

    # two crank turns in 0.42 rad steps (wrapping at +-pi), every 7th command refused (NaN)
    commands = [-3.0 + 0.42 * k if k % 7 != 3 else float('nan') for k in range(30)]
    src = make_bag(tmp_path / 'in', commands)
    mech = Scene.from_yaml(SCENE).mechanism
    data = read_commands(str(src), ['/cmd'])
    res = ReplayEngine(mech, None, 1e-12, 50, 'continuous').solve_all(data)
    fig = bag.plot_figure(data, res, mech)
    try:
        ax = fig.axes[1]
        lines = {ln.get_label(): ln for ln in ax.get_lines()}
        angles = ['input crank'] + [f'joint {j.name}' for j in mech.revolutes]
        for label in angles:
            y = np.asarray(lines[label].get_ydata(), float)
            both = np.isfinite(y[:-1]) & np.isfinite(y[1:])
            assert np.all(np.abs(np.diff(y)[both]) <= np.pi), label
        # the crank input and its joint O2 (the same angle) are drawn alike, within +-pi
        crank = np.asarray(lines['input crank'].get_ydata(), float)
        o2 = np.asarray(lines['joint O2'].get_ydata(), float)
        assert np.nanmax(np.abs(crank)) <= np.pi and crank.shape == o2.shape
        assert np.allclose(crank, o2, atol=1e-9, equal_nan=True)
        assert np.isnan(crank).sum() > int((~res.ok).sum())  # broken at wraps, not only refusals
        refused = lines['refused']
        assert refused.get_transform() == ax.get_xaxis_transform()
        t = (data.log_ns - data.log_ns[0]) * 1e-9
        assert list(refused.get_xdata()) == pytest.approx(list(t[~res.ok]))
        assert list(refused.get_ydata()) == [0.0] * int((~res.ok).sum())
    finally:
        plt.close(fig)
