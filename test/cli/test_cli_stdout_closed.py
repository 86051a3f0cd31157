"""A command whose reader of stdout stops early (`| head -1`, `| true`) exits with its own
status (linkage_ros/cli/parser.py, cli/common.say): a refused solve exited 0 when its output
went unread (an outside reviewer, on `linkage bag`; the rule is the parser's, for every
command). Oracle: the same command with stdout read."""

from __future__ import annotations

import subprocess
import sys

import pytest


def _run(args: list[str], close: bool) -> int:
    proc = subprocess.Popen(
        [sys.executable, '-m', 'linkage_ros.cli', *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    if close:
        proc.stdout.close()  # before the command writes a byte
    else:
        proc.stdout.read()
        proc.stdout.close()
    proc.stderr.read()
    return proc.wait(timeout=300)


@pytest.mark.parametrize(
    'args',
    [
        ['solve', 'four_bar_non_grashof', '--set', 'crank=3.1'],  # does not assemble: 1
        ['solve', 'four_bar', '--set', 'crank=1'],  # 0
        ['solve', 'four_bar', '--set', 'crank=1', '--json'],  # 0
        ['check', 'nosuchscene'],  # 2
    ],
)
def test_the_status_is_the_commands_own_whether_stdout_is_read_or_not(args):
    read = _run(args, close=False)
    assert _run(args, close=True) == read
