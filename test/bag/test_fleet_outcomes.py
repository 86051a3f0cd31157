"""Tests of a fleet run's outcome per bag (linkage_ros/bag/fleet_task.py: the summary row,
its status and counts; fleet_run.py: the exit status) for bags an outside review found
miscounted. Oracles: what each bag was written with (its messages, how many of them name the
mechanism's inputs) and FLEET.md's definitions of the summary's columns."""

from __future__ import annotations

from pathlib import Path

from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from scenes import CONFIG
from test_bag import joint_state, make_input, write_bag
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
    assert '2 bag(s): 1 ok, 1 with no request answered, 0 failed' in cap.out


def test_messages_counts_every_message_read_with_state_completion(tmp_path, capsys):
    """summary.csv's messages left out those --state-completion skipped: 25 where 27 were
    read, and 0 for a bag whose every message was skipped while its reason said 'none of the
    5 message(s) read'. FLEET.md: messages read; answered + refused are the requests."""
    crank = [
        ('/joint_states', 10**9 + k * 10**7, joint_state(['arm', 'crank'], [1.0, 0.1 * k], 1, k))
        for k in range(25)
    ]
    other = [
        ('/joint_states', 2 * 10**9 + k, joint_state(['wrist'], [0.1], 2, k)) for k in range(5)
    ]
    mixed, skipped = tmp_path / 'mixed', tmp_path / 'skipped'
    write_bag(mixed, 'mcap', crank + other[:2])  # 27 messages, 2 without the crank
    write_bag(skipped, 'mcap', other)  # 5, none with it
    out = tmp_path / 'out'
    code, cap = run([mixed, skipped, '--scene', SCENE, '--command-topic', '/joint_states',
                     '--state-completion', '--out-dir', out, '--jobs', 1], capsys)  # fmt: skip
    assert code == 1, cap.out + cap.err  # (the bag with none of the inputs)
    rows, doc = summary_rows(out)
    m, s = rows['mixed'], rows['skipped']
    assert (m['status'], m['messages'], m['answered'], m['refused']) == ('ok', '27', '25', '0')
    assert (s['status'], s['messages'], s['answered'], s['refused']) == (
        'all refused',
        '5',
        '0',
        '0',
    )
    assert 'none of the 5 message(s) read' in s['reason']
    assert doc['totals']['messages'] == 27 + 5


def test_a_sigterm_to_the_fleet_stops_its_workers_and_resume_finishes(tmp_path):
    """`kill PID` of a `--jobs 2` fleet (a supervisor stopping the main process alone) left
    both workers running their bags and then idle for good, orphaned (an adversary). The run
    ends as Ctrl-C ends it (exit 143, 'terminated'), its workers stopped; --resume finishes
    it. Oracle: the processes whose command line names this run's --out-dir, read from /proc."""
    import os
    import shutil
    import signal
    import subprocess
    import sys
    import time

    from test_fleet import COMMON, write_fleet_bag

    src = tmp_path / 'bags'
    write_fleet_bag(src / 'b0', 'mcap', 20000, 0.1)
    for k in range(1, 6):
        shutil.copytree(src / 'b0', src / f'b{k}')
    out = tmp_path / 'out'
    argv = [sys.executable, '-m', 'linkage_ros.cli', 'bag', str(src), *map(str, COMMON)]
    argv += ['--out-dir', str(out), '--jobs', '2', '--no-progress']

    def ours() -> list[int]:
        pids = []
        for entry in os.listdir('/proc'):
            if entry.isdigit():
                try:
                    cmd = Path(f'/proc/{entry}/cmdline').read_bytes().split(b'\0')
                except OSError:
                    continue
                if str(out).encode() in cmd:
                    pids.append(int(entry))
        return pids

    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 240
    while not list(out.glob('*.done.json')) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert proc.poll() is None, 'the run ended before it could be stopped'
    os.kill(proc.pid, signal.SIGTERM)  # the main process alone
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143 and 'linkage bag: terminated' in err, (proc.returncode, err)
    for _ in range(100):  # (a stopped worker's exit takes a moment)
        if not ours():
            break
        time.sleep(0.1)
    assert ours() == []
    done = subprocess.run(argv + ['--resume'], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert len(list(out.glob('*.done.json'))) == 6
