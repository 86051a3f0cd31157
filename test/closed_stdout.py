"""A command run in its own process whose stdout is read, or closed before it writes a byte
(as `| true` does): shared by the tests of exit status under a reader that stops early."""

from __future__ import annotations

import os
import subprocess
import sys


def run_module(
    args: list[str], close: bool, unbuffered: bool = False, module: str = 'linkage_ros.cli'
) -> tuple[int, str]:
    """(exit status, stderr) of ``python -m module args``; ``unbuffered``: PYTHONUNBUFFERED=1
    (every print writes at once: a broken pipe is raised where it prints), else buffered (it
    comes at the last flush, after the command's work)."""
    env = {k: v for k, v in os.environ.items() if k != 'PYTHONUNBUFFERED'}
    if unbuffered:
        env['PYTHONUNBUFFERED'] = '1'
    proc = subprocess.Popen(
        [sys.executable, '-m', module, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    assert proc.stdout is not None and proc.stderr is not None
    if not close:
        proc.stdout.read()
    proc.stdout.close()
    err = proc.stderr.read().decode()
    return proc.wait(timeout=300), err
