"""A command whose reader of stdout stops early (`| head -1`, `| true`) exits with its own
status (linkage_ros/cli/parser.py, cli/process.say): a refused solve exited 0 when its output
went unread (an outside reviewer, on `linkage bag`; the rule is the parser's, for every
command). Oracle: the same command with stdout read."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from closed_stdout import run_module as _run


@pytest.mark.parametrize(
    'args',
    [
        ['solve', 'four_bar_non_grashof', '--set', 'crank=3.1'],  # does not assemble: 1
        ['solve', 'four_bar', '--set', 'crank=1'],  # 0
        ['solve', 'four_bar', '--set', 'crank=1', '--json'],  # 0
        ['check', 'nosuchscene'],  # 2
        ['solve', 'four_bar_non_grashof', '--set', 'crank=3.1', '--all-branches'],  # 1
        ['range', 'excavator', '--tilt', 'bucket', '--lip', 'L', '--hold', '100,100'],  # 1
        ['sweep', 'four_bar_non_grashof', '--set', 'crank=3.1', '--strict'],  # 1
    ],
)
@pytest.mark.parametrize('unbuffered', [False, True])
def test_the_status_is_the_commands_own_whether_stdout_is_read_or_not(args, unbuffered):
    """(unbuffered: the adversary's PYTHONUNBUFFERED=1, where range's and solve's text lines
    raised the broken pipe as they printed, and the parser's fallback said 0)"""
    read, _ = _run(args, close=False, unbuffered=unbuffered)
    closed, err = _run(args, close=True, unbuffered=unbuffered)
    assert closed == read, err
    assert 'Traceback' not in err and 'Exception ignored' not in err, err
    if args[0] == 'sweep':  # its summary on stderr, the rows solved counted
        assert 'linkage sweep: 1 command(s)' in err and '1 error(s)' in err, err


@pytest.mark.parametrize('unbuffered', [False, True])
def test_a_stand_alone_entry_point_ends_as_linkage_does(unbuffered):
    """`python -m linkage_ros.cli.range SCENE | true` ended in a traceback (unbuffered) or
    'Exception ignored ... BrokenPipeError' and status 120: the stand-alone entry points run
    their command as `linkage X` does (cli/process.run_command)."""
    from scenes import CONFIG

    args = [str(CONFIG / 'four_bar.yaml')]
    read, _ = _run(args, close=False, unbuffered=unbuffered, module='linkage_ros.cli.range')
    closed, err = _run(args, close=True, unbuffered=unbuffered, module='linkage_ros.cli.range')
    assert read == closed == 0, err
    assert 'Traceback' not in err and 'Exception ignored' not in err, err


def test_a_parameter_integer_beyond_64_bits_is_a_usage_error_before_any_wait():
    """`linkage param set NODE queue_depth 99999999999999999999` was a SystemError traceback
    from rclpy (an adversary's find): the value is refused first, naming it (exit 2)."""
    code, err = _run(['param', 'set', '/nobody_here', 'queue_depth', '99999999999999999999'], False)
    assert code == 2 and "beyond a parameter's 64-bit integers" in err, err
    assert 'waiting for' not in err and 'Traceback' not in err, err


@pytest.mark.parametrize(
    'args',
    [
        ['check', 'four_bar', '--json'],  # 0
        ['solve', 'four_bar_non_grashof', '--set', 'crank=3.1'],  # does not assemble: 1
        ['urdf', 'four_bar'],  # 0 (its document to stdout)
    ],
)
def test_a_stdout_closed_before_the_start_is_a_reader_gone(args):
    """`linkage check four_bar --json >&-` was an AttributeError traceback ('NoneType' has no
    'write': Python's sys.stdout is None when fd 1 is closed; an adversary), exit 1: the
    command's own status, as with a reader that stopped."""
    read, _ = _run(args, close=False)
    proc = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: os.close(1),
        timeout=300,
    )
    assert proc.returncode == read, proc.stderr
    assert 'Traceback' not in proc.stderr, proc.stderr
