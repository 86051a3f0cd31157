"""`linkage bag` whose reader of stdout stops early (`| head`, `| true`): the exit status and
the hints on stderr are the run's own (linkage_ros/cli/parser.py, cli/process.say). An outside
bag analyst found every such run exiting 0, a bag whose every command was refused too: under
`set -o pipefail` a wrong --scene passed as good. Oracle: the same run with stdout read."""

from __future__ import annotations

import subprocess
import sys

from closed_stdout import run_module
from test_bag_node_semantics import SCENE, make_bag


def _exit_with_stdout_closed(args: list[str], module: str = 'linkage_ros.cli') -> tuple[int, str]:
    return run_module(args, close=True, module=module)  # (buffered: as `| true` takes it)


def test_a_refused_bag_exits_1_with_its_hint_when_stdout_is_closed(tmp_path):
    src = make_bag(tmp_path / 'in', [0.1, 0.2, 0.3], names=('boom',))
    args = ['bag', str(src), '--scene', str(SCENE), '--command-topic', '/cmd', '--no-progress']
    read = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', *args, '--out', str(tmp_path / 'a.csv')],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert read.returncode == 1 and 'every request was refused' in read.stderr
    code, err = _exit_with_stdout_closed([*args, '--out', str(tmp_path / 'b.csv')])
    assert code == 1, err
    assert 'every request was refused' in err and 'Traceback' not in err, err
    assert (tmp_path / 'b.csv').read_bytes() == (tmp_path / 'a.csv').read_bytes()
    # a fleet run: its summary on stdout, its status 1 as well
    code, err = _exit_with_stdout_closed([*args, '--out-dir', str(tmp_path / 'fleet')])
    assert code == 1, err
    assert (tmp_path / 'fleet' / 'summary.json').is_file()


def test_a_missing_topic_exits_2_with_its_reason_when_stdout_is_closed(tmp_path):
    src = make_bag(tmp_path / 'in', [0.1, 0.2])
    code, err = _exit_with_stdout_closed(
        [
            'bag',
            str(src),
            '--scene',
            str(SCENE),
            '--command-topic',
            '/nope',
            '--out',
            str(tmp_path / 'o.csv'),
        ]
    )
    assert code == 2 and '/nope' in err, err


def test_python_m_linkage_ros_bag_ends_as_linkage_bag_does(tmp_path):
    """`python -m linkage_ros.bag ... | true` ("the same as linkage bag") exited 120 with
    'Exception ignored ... BrokenPipeError' after a good run (an adversary's find)."""
    src = make_bag(tmp_path / 'in', [0.1, 0.2, 0.3])
    args = [str(src), '--scene', str(SCENE), '--command-topic', '/cmd', '--no-progress']
    code, err = _exit_with_stdout_closed(
        [*args, '--out', str(tmp_path / 'o.csv')], module='linkage_ros.bag'
    )
    assert code == 0, err
    assert 'Exception ignored' not in err and 'Traceback' not in err, err
