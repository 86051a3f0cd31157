"""Every code block of README.md and docs/*.md runs, alone, as a user would run it, and prints
something. A block's fence says how it runs:

* ``sh``: a bash script (``-e``) in a scratch folder holding links to the repository's
  ``config``, ``test`` and ``.venv`` (so the docs' relative paths work and nothing is written
  into the repository); exit 0 and output on stdout.
* ``sh node``: each command starts a node; it must reach its start-up line ("listening on",
  or "waiting for a robot description") and stop cleanly on Ctrl-C.
* ``python``: a script, run as ``sh`` is; ``python node:SCENE``: the same with
  ``linkage_node --ros-args -p scene:=SCENE`` running (as the docs say: run the node, then the
  script in another terminal).
* ``yaml``: parsed (safe_load); ``text``: output or a listing, not code.
* ``sh norun``: cannot run here (a full ROS install, colcon, a recorded bag); its first line is
  a comment saying what it needs. Only these and ``text`` are not run.

Each test runs on its own random ROS domain, discovery limited to this host."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml
from ros_harness import random_domain_id
from scenes import REPO

DOCS = [REPO / 'README.md', *sorted((REPO / 'docs').glob('*.md'))]
VENV_BIN = Path(sys.executable).parent
KINDS = {'sh', 'sh node', 'sh norun', 'python', 'yaml', 'text'}
STARTED = ('listening on', 'waiting for a robot description')
_FENCE = re.compile(r'^```([^\n`]*)\n(.*?)^```[ \t]*$', re.DOTALL | re.MULTILINE)


@dataclass(frozen=True)
class Block:
    doc: str
    line: int
    info: str
    body: str

    @property
    def kind(self) -> str:
        return 'python' if self.info.startswith('python') else self.info

    @property
    def scene(self) -> str | None:
        """``python node:SCENE``: the scene of the node the block talks to."""
        _, _, scene = self.info.partition(' node:')
        return scene or None

    def __str__(self) -> str:
        return f'{self.doc}:{self.line} ({self.info or "no info string"})'


def _blocks() -> list[Block]:
    out = []
    for doc in DOCS:
        text = doc.read_text(encoding='utf-8')
        for m in _FENCE.finditer(text):
            line = text.count('\n', 0, m.start()) + 1
            out.append(Block(str(doc.relative_to(REPO)), line, m.group(1).strip(), m.group(2)))
    return out


BLOCKS = _blocks()


def _ids(kind: str) -> list:
    return [pytest.param(b, id=f'{b.doc}:{b.line}') for b in BLOCKS if b.kind == kind]


def test_every_block_says_how_it_runs():
    assert len(BLOCKS) > 20  # the fence pattern finds the docs' blocks
    for block in BLOCKS:
        info = block.info.split(' node:')[0] if block.info.startswith('python') else block.info
        assert info in KINDS, f'{block}: fence it as one of {sorted(KINDS)} (or python node:SCENE)'
        if block.info == 'sh norun':
            first = block.body.lstrip().splitlines()[0]
            assert first.startswith('# '), f'{block}: say on its first line what it needs'


@pytest.fixture
def scratch(tmp_path):
    """A scratch working folder in which the repository's relative paths resolve."""
    for name in ('config', 'test', '.venv'):
        (tmp_path / name).symlink_to(REPO / name)
    return tmp_path


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(
        {
            'PATH': f'{VENV_BIN}{os.pathsep}{env.get("PATH", "")}',
            'AMENT_PREFIX_PATH': str(VENV_BIN.parent),
            'ROS_DOMAIN_ID': str(random_domain_id()),
            'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
            'PYTHONUNBUFFERED': '1',
            'RCUTILS_COLORIZED_OUTPUT': '0',
        }
    )
    env.pop('ROS_LOCALHOST_ONLY', None)
    return env


def _run(argv: list[str], cwd: Path, env: dict[str, str], timeout: float = 300):
    """Run to the end in its own process group (a node a block leaves behind is ended too)."""
    proc = subprocess.Popen(
        argv,
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = proc.communicate(timeout=timeout)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
    return proc.returncode, out, err


class _Node:
    """A node started as a doc command; its output in a file (no pipe to fill up)."""

    def __init__(self, command: str, cwd: Path, env: dict[str, str]):
        self.log = cwd / f'node{id(self)}.log'
        with open(self.log, 'wb') as sink:
            self.proc = subprocess.Popen(
                ['bash', '-c', f'exec {command}'],
                cwd=cwd,
                env=env,
                stdout=sink,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )

    def output(self) -> str:
        return self.log.read_text(errors='replace')

    def wait_started(self, timeout: float = 60) -> str:
        end = time.monotonic() + timeout
        while time.monotonic() < end and self.proc.poll() is None:
            if any(s in self.output() for s in STARTED):
                return self.output()
            time.sleep(0.05)
        raise AssertionError(f'the node did not start:\n{self.output()[-3000:]}')

    def stop(self) -> int | None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
                return None
        return self.proc.returncode


@pytest.mark.parametrize('block', _ids('sh'))
def test_sh_block_runs(block, scratch):
    code, out, err = _run(['bash', '-e', '-c', block.body], scratch, _env())
    assert code == 0, f'{block} exit {code}\n{out[-2000:]}\n{err[-3000:]}'
    assert out.strip(), f'{block} printed nothing'
    assert 'Traceback' not in err, err[-3000:]


@pytest.mark.parametrize('block', _ids('sh node'))
def test_node_block_starts_and_stops(block, scratch):
    commands = [
        line.split(' #')[0].strip()
        for line in re.sub(r'\\\n\s*', ' ', block.body).splitlines()
        if line.strip() and not line.lstrip().startswith('#')
    ]
    assert commands, block
    env = _env()
    for command in commands:
        node = _Node(command, scratch, env)
        try:
            node.wait_started()
        finally:
            code = node.stop()
        assert code == 0 and 'Traceback' not in node.output(), f'{command}:\n{node.output()}'


@pytest.mark.parametrize('block', _ids('python'))
def test_python_block_runs(block, scratch):
    script = scratch / 'block.py'
    script.write_text(block.body, encoding='utf-8')
    env = _env()
    node = None
    if block.scene is not None:
        node = _Node(f'linkage_node --ros-args -p scene:={block.scene}', scratch, env)
    try:
        if node is not None:
            node.wait_started()
        code, out, err = _run([sys.executable, str(script)], scratch, env, timeout=120)
    finally:
        if node is not None:
            node.stop()
    assert code == 0, f'{block} exit {code}\n{out[-2000:]}\n{err[-3000:]}'
    assert out.strip(), f'{block} printed nothing'


@pytest.mark.parametrize('block', _ids('yaml'))
def test_yaml_block_parses(block):
    assert yaml.safe_load(block.body) is not None, block


def test_the_client_prints_levels_by_name_and_one_answer_per_request(scratch):
    """TOPICS.md's client prints each answer once, its level as a name (not b'\\x00')."""
    (block,) = [b for b in BLOCKS if b.doc == 'docs/TOPICS.md' and b.scene == 'four_bar']
    script = scratch / 'client.py'
    script.write_text(block.body, encoding='utf-8')
    env = _env()
    node = _Node('linkage_node --ros-args -p scene:=four_bar', scratch, env)
    try:
        node.wait_started()
        code, out, err = _run([sys.executable, str(script)], scratch, env, timeout=120)
    finally:
        node.stop()
    assert code == 0, err
    lines = out.splitlines()
    assert [ln.split()[0] for ln in lines if not ln.startswith(' ')] == ['OK', 'OK', 'ERROR']
    assert sum(ln.startswith('  joints') for ln in lines) == 2, out
    assert "b'" not in out, out
