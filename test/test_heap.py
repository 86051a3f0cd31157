"""heap.keep_large_buffers: a process that takes MB-sized messages one after another (the
node beside a flood of 2 MB ~/target requests) reuses its freed buffers instead of faulting
their pages in anew for every message. The oracle is the kernel's count of the process's
minor page faults, in a fresh interpreter for each case."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest

from linkage_ros.heap import keep_large_buffers

pytestmark = pytest.mark.skipif(
    platform.libc_ver()[0] != 'glibc', reason='glibc malloc thresholds only'
)

#: like one taken ~/target: rmw's copy and Python's copy of a 2 MB message, alive together
CHILD = """
import json, resource, sys
from linkage_ros.heap import keep_large_buffers
applied = keep_large_buffers() if sys.argv[1] == 'tuned' else None
def message():
    rmw_copy = b'\\x01' * (2 << 20)
    python_copy = bytes(bytearray(rmw_copy))
    return len(python_copy)
for _ in range(5):  # warm-up: the heap grows to its working size
    message()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(50):
    message()
faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
print(json.dumps({'applied': applied, 'faults': faults}))
"""
PAGES_PER_MESSAGE = 2 * (2 << 20) // os.sysconf('SC_PAGE_SIZE')


def run_child(mode: str, **env: str) -> dict:
    environ = {k: v for k, v in os.environ.items() if not k.startswith('MALLOC_')}
    environ.pop('GLIBC_TUNABLES', None)
    out = subprocess.run(
        [sys.executable, '-c', CHILD, mode],
        env={**environ, **env},
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    return json.loads(out.stdout)


def test_messages_of_mbs_reuse_their_buffers():
    """50 messages of two 2 MB copies: with the thresholds raised, fewer faults than 1 % of
    the pages they touch (glibc's defaults fault most of them in again for every message)."""
    tuned = run_child('tuned')
    assert tuned['applied'] is True
    assert tuned['faults'] < 0.01 * 50 * PAGES_PER_MESSAGE, tuned


def test_a_users_own_malloc_settings_are_left_alone():
    assert run_child('tuned', MALLOC_TRIM_THRESHOLD_='131072')['applied'] is False
    assert keep_large_buffers({'GLIBC_TUNABLES': 'glibc.malloc.trim_threshold=131072'}) is False
    assert keep_large_buffers({'MALLOC_MMAP_THRESHOLD_': '131072'}) is False


#: a batch solve of 20000 four-bar inputs after the ``linkage`` command line's start: each
#: (20000,) column is 160 kB, above glibc's default mmap threshold
CLI_CHILD = """
import contextlib, io, json, resource, sys
import numpy as np
from linkage_ros.cli.parser import main
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.resources import scene_path
with contextlib.redirect_stdout(io.StringIO()):
    assert main(['solve', 'four_bar', '--set', 'crank=0.3']) == 0
solver = Solver(Scene.from_yaml(scene_path('four_bar')).mechanism)
theta = np.linspace(-3.0, 3.0, 20000)
for _ in range(3):  # warm-up
    solver.solve_batch({'crank': theta})
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    solver.solve_batch({'crank': theta})
print(json.dumps({'faults': resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before}))
"""


def test_the_command_line_keeps_a_batchs_arrays():
    """The ``linkage`` command line raises the thresholds at its start (sweeps, bags and ranges
    solve batches of 10^4 rows and more): 20 batches of 20000 inputs then fault fewer pages in
    than one of their 160 kB columns has (with glibc's defaults here: about 500 per batch, the
    batch's arrays given back to the kernel and faulted in again)."""
    environ = {k: v for k, v in os.environ.items() if not k.startswith('MALLOC_')}
    environ.pop('GLIBC_TUNABLES', None)
    out = subprocess.run(
        [sys.executable, '-c', CLI_CHILD],
        env=environ,
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    faults = json.loads(out.stdout)['faults']
    assert faults < 20000 * 8 // os.sysconf('SC_PAGE_SIZE'), faults
