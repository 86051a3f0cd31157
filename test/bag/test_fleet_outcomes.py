"""Tests of a fleet run's outcome per bag (linkage_ros/bag/fleet_task.py: the summary row,
its status and counts; fleet_run.py: the exit status) for bags an outside review found
miscounted. Oracles: what each bag was written with (its messages, how many of them name the
mechanism's inputs) and FLEET.md's definitions of the summary's columns."""

from __future__ import annotations

from pathlib import Path

from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from scenes import CONFIG
from test_bag import joint_state, make_input
from test_fleet import JS, TS, run, summary_rows

SCENE = CONFIG / 'four_bar.yaml'


def empty_topic_bag(path: Path) -> Path:
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        w.add_connection('/cmd', JS, typestore=TS)  # (the topic, and not one message on it)
    return path


def test_a_bag_with_no_command_is_not_ok(tmp_path, capsys):
    """A command topic with no message counted as success (exit 0, status ok) while the tool
    said 'nothing to solve ... (the right topic?)'."""
    empty = empty_topic_bag(tmp_path / 'rec' / 'empty')
    msgs = [('/cmd', 10**9 + k * 10**7, joint_state(['crank'], [0.1 * k], 1, k)) for k in range(5)]
    good = make_input(tmp_path / 'rec', 'mcap', msgs)
    out = tmp_path / 'out'
    code, cap = run([empty, good, '--scene', SCENE, '--command-topic', '/cmd', '--out-dir', out,
                     '--jobs', 1], capsys)  # fmt: skip
    assert code == 1, cap.out + cap.err
    rows, doc = summary_rows(out)
    assert rows['empty']['status'] == 'all refused' and rows['empty']['messages'] == '0'
    assert 'no message on the topics given' in rows['empty']['reason']
    assert rows[good.name]['status'] == 'ok' and rows[good.name]['messages'] == '5'
    assert doc['totals']['all_refused'] == 1
