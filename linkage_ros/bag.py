"""Offline analysis of recorded commands: solve every command of a rosbag2 as the node would.

    linkage bag INPUT --scene SCENE --command-topic TOPIC [--target-topic TOPIC]
                      --out OUTPUT [--out OUTPUT2] [--out-format mcap|sqlite3]
                      [--solver S] [--branch B] [--tol T] [--max-iter N]
                      [--plot out.png] [--no-progress]

INPUT is a rosbag2 folder (sqlite3 or MCAP storage) or a single ``.mcap`` / ``.db3`` file, read
with the pure-Python ``rosbags`` library (no ROS installation needed). The command topic carries
``sensor_msgs/msg/JointState`` naming the scene's actuators, exactly like the node's ``~/command``;
the optional target topic carries ``JointState`` naming joints, links or actuators, exactly like
the node's ``~/target`` (inverse kinematics). Both topics are merged in bag time order and solved
in that order with the node's semantics (linkage_ros.node.Engine): the reference pose is the
first good state, continuity (default branch ``continuous``) carries on from the last good
state, a refused request changes nothing, and a target solver adopts the last good state.

Outputs (``--out`` may be given twice):

* ``*.csv``: one row per command, refused ones included (status ``error`` and the reason).
  Columns: ``time`` (header stamp, s), ``receive_time`` (bag time, s), ``topic``,
  ``input.<actuator>`` ..., ``joint.<joint>`` ..., ``<point>.x``, ``<point>.y`` (every point),
  ``residual``, ``margin``, ``branch``, ``status``, ``reason``.
* anything else: a new rosbag2 folder (MCAP unless ``--out-format sqlite3``) with
  ``/joint_states`` (JointState, every joint), ``/points/<name>`` (PointStamped, per output point)
  and ``/status`` (DiagnosticStatus, one per command: OK with residual, branch, margin, solver,
  iterations; ERROR with the reason). Header stamps are the commands' (a zero stamp becomes the
  bag receive time), frame_id is the scene's, and each message is logged at its command's bag time.

Speed: a closed-form scene is solved in vectorised chunks (``Solver.solve_batch`` with the branch
signs then current). A row is taken from the batch only when the node's continuity rule provably
picks the same assembly mode for it, at every branching dyad: either the dyad is clear of its
singularity now and in the previous good configuration (margin above core.plan's
CONTINUITY_MARGIN, so the node keeps the sign), or the batch's solution is nearer than the other
one to the node's prediction for every extrapolation ratio it may use (0 ... 1.5: the distance
difference is linear in it) by a clear margin. The first row where neither holds (a branch change
near a toggle) and a stretch after it are solved one by one by a continuous Solver whose history
is made identical to the node's, then the batch resumes. Refused rows get the reason a single
solve gives (the node's exact text). Newton and hybrid solvers go one command at a time.
JointState messages are decoded with numpy, many at a time (messages of one layout share one
parse); both rosbags' and rclpy's (recorded bags') CDR variants are read.

Bad input (missing, not a bag, missing topic, wrong type, truncated or corrupt) is one clear
message on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import re
import shutil
import struct
import sys
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .core.errors import LinkageError
from .core.model import Scene
from .core.solver import Solver, branch_identity_defined
from .stamps import stamp_error, stamp_valid

JOINT_STATE = 'sensor_msgs/msg/JointState'
POINT_STAMPED = 'geometry_msgs/msg/PointStamped'
DIAGNOSTIC_STATUS = 'diagnostic_msgs/msg/DiagnosticStatus'

USAGE_ERROR, OK = 2, 0
#: the node's name: its status messages are named '<NODE_NAME>: <scene name>'
NODE_NAME = 'linkage_node'

#: rows solved per vectorised chunk (adapted between these bounds)
CHUNK_MIN, CHUNK_START, CHUNK_MAX = 256, 8192, 65536
#: commands solved one by one after a row the batch could not vouch for
SEQUENTIAL_STRETCH = 16
#: a batch row is kept when the other assembly mode is farther from the node's prediction by at
#: least this fraction of the length scale (or this many radians for a guide orientation)
EASY_MARGIN = 1e-9
#: runs shorter than this are solved one by one (a batch has a fixed cost)
MIN_BATCH = 32
#: batch rows this close to a dyad tangency are left to the single-command solver
NEAR_TANGENT = 1e-6


BAG_EPILOG = """\
outputs:
  OUTPUT.csv  one row per command (refused ones too): time (header stamp, s), receive_time
              (bag time, s), topic, input.<actuator>..., joint.<joint>..., <point>.x,
              <point>.y (every point), residual, margin, branch, status (ok/error), reason
  OUTPUT      a new rosbag2 folder (--out-format mcap|sqlite3): /joint_states,
              /points/<output point>, /status (one per command; ERROR with the reason)

examples:
  linkage bag run1 --scene four_bar --command-topic /linkage_node/command --out run1.csv
  linkage bag run1.mcap --scene my.yaml --command-topic /cmd --target-topic /tgt \\
      --out answers --out answers.csv --plot run1.png

exit status: 0 done (refused commands are rows, not failures); 2 unusable input, output or
options (missing file, not a bag, missing topic, wrong type, truncated or corrupt bag).
"""


class BagError(LinkageError):
    """The input bag or an output path cannot be used; one message, exit status 2."""


# ---- command line ------------------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``linkage bag`` options (the CLI registers this module as the ``bag`` subcommand)."""
    parser.description = (
        'Solve every command recorded in a rosbag2 the way the node would and '
        'write a CSV and/or a result bag.'
    )
    parser.epilog = BAG_EPILOG
    parser.add_argument(
        'input',
        metavar='INPUT',
        help='rosbag2 folder (sqlite3 or mcap) or a single .mcap/.db3 file',
    )
    parser.add_argument('--scene', required=True, help='scene file or packaged scene name')
    parser.add_argument(
        '--command-topic',
        required=True,
        metavar='TOPIC',
        help='sensor_msgs/msg/JointState commands naming the actuators',
    )
    parser.add_argument(
        '--target-topic',
        metavar='TOPIC',
        default=None,
        help='sensor_msgs/msg/JointState targets naming joints, links or '
        "actuators (the node's ~/target: inverse kinematics)",
    )
    parser.add_argument(
        '--out',
        action='append',
        required=True,
        metavar='OUTPUT',
        help='*.csv for a table, else a new rosbag2 folder; may be given twice',
    )
    parser.add_argument(
        '--out-format',
        choices=('mcap', 'sqlite3'),
        default='mcap',
        help='storage of an output bag (default mcap)',
    )
    parser.add_argument(
        '--solver',
        choices=('auto', 'closed_form', 'newton'),
        default=None,
        help="solver (default: the scene's)",
    )
    parser.add_argument(
        '--branch',
        default='continuous',
        help="continuous (default, like the node), reference, or signs like '+-'",
    )
    parser.add_argument(
        '--tol',
        type=float,
        default=1e-12,
        help='Newton tolerance relative to the length scale (default 1e-12)',
    )
    parser.add_argument(
        '--max-iter', type=int, default=50, help='Newton iteration cap (default 50)'
    )
    parser.add_argument(
        '--plot',
        metavar='PNG',
        default=None,
        help='write coupler-point traces and input/joint curves to this image '
        '(format from the extension: png, svg, pdf, ...; PNG if none)',
    )
    parser.add_argument(
        '--no-progress',
        action='store_true',
        help='no progress bar (it is shown only when stderr is a terminal)',
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m linkage_ros.bag ...``."""
    from .cli import standalone_main

    return standalone_main('linkage bag', add_arguments, run, argv)


def run(args: argparse.Namespace) -> int:
    """Run ``linkage bag``; returns the exit status (0 done, 2 unusable input or options)."""
    try:
        return _run(args)
    except (BagError, LinkageError) as exc:
        print(f'linkage bag: error: {exc}', file=sys.stderr)
        return USAGE_ERROR


def _run(args) -> int:
    from .resources import scene_path

    t_start = time.perf_counter()
    scene = Scene.from_yaml(scene_path(args.scene))
    mech = scene.mechanism
    outs = _check_outputs(args.out, args.plot)
    for opt, topic in (
        ('--command-topic', args.command_topic),
        ('--target-topic', args.target_topic),
    ):
        if topic is not None and not topic.strip():
            raise BagError(
                f'{opt}: empty topic name (leave the option out for no such topic)'
                if opt == '--target-topic'
                else f'{opt}: empty topic name'
            )
    if args.command_topic == args.target_topic:
        raise BagError('--command-topic and --target-topic must be different topics')
    if not (isinstance(args.tol, float) and math.isfinite(args.tol) and args.tol > 0):
        raise BagError(f'--tol must be a positive number (got {args.tol!r})')
    if args.max_iter < 1:
        raise BagError(f'--max-iter must be >= 1 (got {args.max_iter})')
    progress = _Progress(enabled=not args.no_progress and sys.stderr.isatty())

    try:
        engine = _Engine(mech, args.solver, args.tol, args.max_iter, args.branch)  # PlanError early
        topics = [args.command_topic] + ([args.target_topic] if args.target_topic else [])
        data = read_commands(args.input, topics, progress)
        t_read = time.perf_counter()
        res = engine.solve_all(data, progress)
        t_solve = time.perf_counter()
        for kind, path in outs:
            try:
                if kind == 'csv':
                    write_csv(path, data, res, mech, progress)
                else:
                    write_bag(path, data, res, mech, scene.frame_id, args.out_format, progress)
            except OSError as exc:
                raise BagError(f'output {path}: cannot write ({exc.strerror or exc})') from None
        if args.plot:
            write_plot(args.plot, data, res, mech)
        t_end = time.perf_counter()
    finally:
        progress.clear()  # an error message starts on a line of its own
    _summary(data, res, outs, args.plot, t_start, t_read, t_solve, t_end)
    return OK


def _resolved(path: Path, what: str) -> Path:
    """The absolute path with symlinks resolved; a symlink loop is a clear error."""
    try:
        return path.resolve()
    except (RuntimeError, OSError) as exc:  # Python < 3.13: RuntimeError on a loop
        raise BagError(f'{what}: cannot use this path ({_exc_text(exc)})') from None


def _check_parent(path: Path, what: str) -> Path:
    full = _resolved(path, what)
    parent = full.parent
    if not parent.is_dir():
        raise BagError(
            f'{what}: folder {parent} '
            + ('is not a folder' if parent.exists() else 'does not exist')
        )
    if not os.access(parent, os.W_OK | os.X_OK):
        raise BagError(f'{what}: folder {parent} is not writable (permission denied)')
    return full


def plot_formats() -> list[str]:
    """The image formats (file extensions) matplotlib can write."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(FigureCanvasBase.get_supported_filetypes())


def _plot_format(path: str) -> str:
    """The image format of a --plot path: its extension, or PNG for a name without one."""
    ext = Path(path).suffix.lower().lstrip('.')
    if not ext:
        return 'png'
    formats = plot_formats()
    if ext not in formats:
        raise BagError(
            f'--plot {path}: cannot write a .{ext} image (image formats: {", ".join(formats)})'
        )
    return ext


def _check_outputs(outs: list[str], plot: str | None):
    checked = []
    for path in outs:
        p = Path(path)
        what = f'output {path}'
        if p.suffix.lower() == '.csv':
            kind = 'csv'
            if p.is_dir():
                raise BagError(f'{what}: is a directory')
        else:
            kind = 'bag'
            if p.exists() or p.is_symlink():
                raise BagError(
                    f'{what}: exists already (an output bag must be a new folder; not overwriting)'
                )
        checked.append((kind, p, _check_parent(p, what)))
    if len({str(full) for _, _, full in checked}) != len(checked):
        raise BagError('the same --out path is given twice')
    if plot is not None:
        what = f'--plot {plot}'
        full = _check_parent(Path(plot), what)
        if full.is_dir():
            raise BagError(f'{what}: is a directory')
        if any(full == out for _, _, out in checked):
            raise BagError(f'{what}: is also an --out path')
        _plot_format(plot)
    return [(kind, p) for kind, p, _ in checked]


# ---- progress and summary ----------------------------------------------------------------------


class _Progress:
    """A one-line text progress bar on stderr (only when it is a terminal)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.label, self.total, self.t0, self.last = '', 0, 0.0, 0.0
        self.shown = False

    def start(self, label: str, total: int):
        self.label, self.total = label, max(int(total), 0)
        self.t0 = self.last = time.perf_counter()
        self.update(0, force=True)

    def update(self, done: int, force: bool = False):
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self.last < 0.1:
            return
        self.last = now
        width = 30
        frac = min(done / self.total, 1.0) if self.total else 1.0
        bar = '#' * int(frac * width) + '-' * (width - int(frac * width))
        sys.stderr.write(
            f'\r{self.label:<8} [{bar}] {100 * frac:5.1f}% {done}/{self.total} '
            f'{now - self.t0:6.1f}s'
        )
        sys.stderr.flush()
        self.shown = True

    def finish(self):
        if self.enabled:
            self.update(self.total, force=True)

    def clear(self):
        if self.enabled and self.shown:
            sys.stderr.write('\r' + ' ' * 79 + '\r')
            sys.stderr.flush()
            self.shown = False


_NUM = re.compile(r'(?<![A-Za-z_0-9.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?')


def _reason_class(reason: str) -> str:
    """A reason with its numbers blanked, so refusals of one kind count together."""
    return _NUM.sub('#', reason)


def _summary(data, res, outs, plot, t0, t_read, t_solve, t_end):
    n = data.n
    lines = [f'linkage bag: {n} message(s) read from {data.source}']
    for k, topic in enumerate(data.topics):
        lines.append(f'  {topic}: {int(np.count_nonzero(data.topic == k))}')
    solved = int(np.count_nonzero(res.ok))
    lines.append(f'  solved {solved}, refused {n - solved}')
    counts = Counter(_reason_class(r) for r, ok in zip(res.reason, res.ok) if not ok)
    for cls, c in counts.most_common(8):
        lines.append(f'    {c} x {cls}')
    if len(counts) > 8:
        lines.append(f'    ... and {len(counts) - 8} other kind(s) of refusal')
    lines.append(f'  vectorised rows {res.batched}, one-by-one rows {res.sequential}')
    for kind, path in outs:
        lines.append(f'  wrote {path} ({"csv" if kind == "csv" else "rosbag2"})')
    if plot:
        lines.append(f'  wrote {plot} (plot)')
    total = t_end - t0
    lines.append(
        f'  time {total:.2f} s (read {t_read - t0:.2f}, solve {t_solve - t_read:.2f}, '
        f'write {t_end - t_solve:.2f})'
        + (f', {n / total:,.0f} commands/s' if total > 0 and n else '')
    )
    print('\n'.join(lines))


# ---- reading -----------------------------------------------------------------------------------


@dataclass
class Commands:
    """The recorded commands in bag time order (n rows)."""

    source: str
    topics: list[str]  # index 0: command topic, 1: target topic
    topic: np.ndarray  # (n,) int8, index into topics
    log_ns: np.ndarray  # (n,) int64 bag receive time
    sec: np.ndarray  # (n,) int64 header stamp
    nanosec: np.ndarray  # (n,) int64
    key: np.ndarray  # (n,) int32 index into keys
    keys: list[tuple[str, ...]]  # the names of each distinct message shape
    npos: list[int]  # number of positions of each key
    values: np.ndarray  # every row's positions, one after the other (float64)
    start: np.ndarray  # (n + 1,) int64: row i's positions are values[start[i]:...]

    @property
    def n(self) -> int:
        return int(self.topic.shape[0])

    def positions(self, a: int, b: int) -> np.ndarray:
        """(b - a, k) positions of rows a..b-1, which share one key (k positions each)."""
        k = self.npos[int(self.key[a])] if b > a else 0
        lo = int(self.start[a])
        return self.values[lo : lo + (b - a) * k].reshape(b - a, k)

    @property
    def pos(self) -> np.ndarray:
        """(n, kmax) positions, NaN padded (small data only: one malformed message with many
        positions makes it as wide for every row)."""
        counts = np.diff(self.start)
        out = np.full((self.n, int(counts.max()) if self.n else 0), np.nan)
        for i in range(self.n):
            out[i, : counts[i]] = self.values[self.start[i] : self.start[i + 1]]
        return out

    @property
    def stamp_zero(self) -> np.ndarray:
        return (self.sec == 0) & (self.nanosec == 0)


class _AnyCase(dict):
    """rosbags' storage plugins by file extension, found in any case ('.MCAP' too)."""

    def get(self, key, default=None):
        return super().get(key if key == 'dir' else str(key).lower(), default)


def _reader_class():
    from rosbags.rosbag2 import Reader

    class _Reader(Reader):
        STORAGE_PLUGINS = _AnyCase(Reader.STORAGE_PLUGINS)

    return _Reader


STORAGE_SUFFIXES = ('.mcap', '.db3')


def _open_reader(path: str):
    Reader = _reader_class()
    p = Path(path)
    if not p.exists():
        raise BagError(f'input {path}: no such file or folder')
    if p.is_dir() and not (p / 'metadata.yaml').exists():
        # a bag folder without metadata: fall back to its single storage file, if any
        try:
            files = sorted(
                f for f in p.iterdir() if f.suffix.lower() in STORAGE_SUFFIXES and f.is_file()
            )
        except OSError as exc:
            raise BagError(
                f'input {path}: cannot list the folder ({exc.strerror or exc})'
            ) from None
        if len(files) == 1:
            p = files[0]
        else:
            raise BagError(
                f'input {path}: not a rosbag2 (a folder without metadata.yaml'
                + (
                    f' and with {len(files)} storage files'
                    if files
                    else ' and no .mcap or .db3 file'
                )
                + ')'
            )
    elif p.is_file() and p.suffix.lower() not in STORAGE_SUFFIXES:
        raise BagError(
            f'input {path}: not a rosbag2 (expected a bag folder, a .mcap or a .db3 file)'
        )
    try:
        reader = Reader(p)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - every rosbags/sqlite/OS failure is "unreadable"
        raise BagError(
            f'input {path}: cannot open the bag ({_exc_text(exc)}); it is truncated, '
            f'corrupt or not a rosbag2'
        ) from None
    return reader


def _exc_text(exc: BaseException) -> str:
    text = ' '.join(str(exc).split()) or type(exc).__name__
    return text if len(text) < 300 else text[:300] + '...'


def read_commands(path: str, topics: list[str], progress: _Progress | None = None) -> Commands:
    """Read the JointState messages of ``topics`` from a bag, in bag time order, decoded."""
    progress = progress or _Progress(False)
    reader = _open_reader(path)
    try:
        try:
            available = {c.topic: c.msgtype for c in reader.connections}
        except Exception as exc:  # noqa: BLE001
            raise BagError(f'input {path}: cannot list topics ({_exc_text(exc)})') from None
        conns = []
        for topic in topics:
            if topic not in available:
                listing = ', '.join(f'{t} ({m})' for t, m in sorted(available.items())) or 'none'
                raise BagError(
                    f'input {path}: topic {topic} is not in the bag; topics in the bag: {listing}'
                )
            types = {c.msgtype for c in reader.connections if c.topic == topic}
            if types != {JOINT_STATE}:
                raise BagError(
                    f'input {path}: topic {topic} has type '
                    f'{", ".join(sorted(types))}; expected {JOINT_STATE}'
                )
            conns.append([c for c in reader.connections if c.topic == topic])
        index = {c.id: k for k, group in enumerate(conns) for c in group}
        total = sum(c.msgcount for group in conns for c in group)
        progress.start('reading', total)
        raws: list[bytes] = []
        tops: list[int] = []
        stamps: list[int] = []
        try:
            for i, (conn, t, raw) in enumerate(reader.messages([c for g in conns for c in g])):
                raws.append(raw)
                tops.append(index[conn.id])
                stamps.append(t)
                if not i & 0x3FFF:
                    progress.update(i)
        except BagError:
            raise
        except Exception as exc:  # noqa: BLE001 - truncated chunk, corrupt database, ...
            raise BagError(
                f'input {path}: cannot read message {len(raws) + 1} '
                f'({_exc_text(exc)}); the bag is truncated or corrupt'
            ) from None
        progress.finish()
    finally:
        with contextlib.suppress(Exception):
            reader.close()
    n = len(raws)
    log_ns = np.array(stamps, np.int64)
    order = np.argsort(log_ns, kind='stable')
    if n and np.any(order != np.arange(n)):
        raws = [raws[i] for i in order]
        log_ns = log_ns[order]
        tops = np.asarray(tops, np.int8)[order]
    topic = np.asarray(tops, np.int8).reshape(n)
    sec, nanosec, key, keys, npos, values, start = decode_joint_states(raws, topic, topics, log_ns)
    return Commands(
        str(path), list(topics), topic, log_ns, sec, nanosec, key, keys, npos, values, start
    )


# -- JointState CDR decoding (vectorised over messages of one layout) ------------------------------


@dataclass
class _Layout:
    little: bool
    names: tuple[str, ...]
    sec_off: int
    arrays: list[tuple[int, int]]  # (offset, count) of position, velocity, effort
    structural: np.ndarray  # byte indices that must match for the same layout
    end: int


def _parse_layout(raw: bytes) -> _Layout:
    """Parse one CDR-encoded JointState: where its stamp and numbers are. ValueError if bad."""
    n = len(raw)
    if n < 4 or raw[0] != 0 or raw[1] not in (0, 1):
        raise ValueError('not a CDR-encoded message (bad encapsulation header)')
    little = raw[1] == 1
    e = '<' if little else '>'
    struct_idx = [0, 1]
    pos = 4

    def need(k):
        if pos + k > n:
            raise ValueError(f'truncated message ({n} bytes, needs at least {pos + k})')

    def align(k):
        nonlocal pos
        pos += (-(pos - 4)) % k

    def u32():
        nonlocal pos
        align(4)
        need(4)
        v = struct.unpack_from(e + 'I', raw, pos)[0]
        struct_idx.extend(range(pos, pos + 4))
        pos += 4
        return v

    def string():
        nonlocal pos
        k = u32()
        if k == 0:
            return ''
        need(k)
        s = raw[pos : pos + k]
        struct_idx.extend(range(pos, pos + k))
        pos += k
        return s.rstrip(b'\x00').decode('utf-8', errors='replace')

    need(8)
    sec_off = pos
    pos += 8
    string()  # frame_id
    count = u32()
    if count > n:
        raise ValueError(f'implausible name count {count}')
    names = tuple(string() for _ in range(count))
    head_pos, head_idx = pos, list(struct_idx)
    # float64[] position, velocity, effort: an empty sequence has no alignment padding (rosbags
    # and Fast-CDR alike); rclpy-serialised messages (hence recorded bags) may end with up to a
    # few bytes of slack from its size estimate. A serialiser that aligns empty sequences is
    # tried second.
    found = []
    for align_empty in (False, True):
        pos, struct_idx[:] = head_pos, head_idx
        try:
            arrays = []
            for _ in range(3):
                count = u32()
                if count > n:
                    raise ValueError(f'implausible array length {count}')
                if count or align_empty:
                    align(8)
                need(8 * count)
                arrays.append((pos, count))
                pos += 8 * count
        except ValueError as exc:
            found.append(exc)
            continue
        if n - pos > 16:
            found.append(ValueError(f'{n - pos} unexpected bytes after the message'))
            continue
        return _Layout(little, names, sec_off, arrays, np.asarray(struct_idx, np.intp), pos)
    raise found[0]


def decode_joint_states(
    raws: list[bytes], topic: np.ndarray, topics: list[str], log_ns: np.ndarray
):
    """Stamps, name sets and positions of CDR JointState messages.

    Messages of one byte length usually share one layout (same names, same frame_id): they are
    decoded together as an (m, L) byte array; the layout is parsed once from the first of them
    and checked on all (every structural byte equal), the rest get their own layout.
    The positions of all rows are returned one after the other (values, with row i's from
    start[i] to start[i + 1]): a malformed message with thousands of positions costs its own
    size, not that width for every row.
    """
    n = len(raws)
    sec = np.zeros(n, np.int64)
    nanosec = np.zeros(n, np.int64)
    key = np.zeros(n, np.int32)
    keys: list[tuple[str, ...]] = []
    npos: list[int] = []
    key_of: dict[tuple, int] = {}
    positions: list[tuple[np.ndarray, np.ndarray]] = []  # (rows, (m, k) values)
    counts = np.zeros(n, np.int64)
    if n == 0:
        return sec, nanosec, key, keys, npos, np.zeros(0), np.zeros(1, np.int64)
    lens = np.fromiter((len(r) for r in raws), np.int64, n)
    order = np.argsort(lens, kind='stable')
    bounds = np.flatnonzero(np.diff(lens[order])) + 1
    for group in np.split(order, bounds):
        length = int(lens[group[0]])
        buf = np.frombuffer(b''.join([raws[i] for i in group]), np.uint8).reshape(
            len(group), length
        )
        todo = np.arange(len(group))
        while todo.size:
            first = int(todo[0])
            try:
                lay = _parse_layout(raws[group[first]])
            except (ValueError, UnicodeDecodeError) as exc:
                g = int(group[first])
                raise BagError(
                    f'message {g + 1} on {topics[topic[g]]} (bag time '
                    f'{_fmt_time(int(log_ns[g]))} s) is not a valid JointState: '
                    f'{exc}; the bag is corrupt'
                ) from None
            sub = buf[todo]
            same = np.all(sub[:, lay.structural] == buf[first, lay.structural], axis=1)
            rows = todo[same]
            todo = todo[~same]
            block = buf[rows]
            g_rows = group[rows]
            e = '<' if lay.little else '>'
            sec[g_rows] = np.ascontiguousarray(block[:, 4:8]).view(e + 'i4').ravel()
            nanosec[g_rows] = np.ascontiguousarray(block[:, 8:12]).view(e + 'u4').ravel()
            off, count = lay.arrays[0]
            vals = (
                np.ascontiguousarray(block[:, off : off + 8 * count])
                .view(e + 'f8')
                .reshape(len(rows), count)
                .astype(float)
                if count
                else np.zeros((len(rows), 0))
            )
            k = (lay.names, count)
            if k not in key_of:
                key_of[k] = len(keys)
                keys.append(lay.names)
                npos.append(count)
            key[g_rows] = key_of[k]
            counts[g_rows] = count
            positions.append((g_rows, vals))
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    values = np.empty(int(start[-1]))
    for rows, vals in positions:
        if vals.shape[1]:
            values[start[rows][:, None] + np.arange(vals.shape[1])] = vals
    return sec, nanosec, key, keys, npos, values, start


def _fmt_time(ns: int) -> str:
    s, r = divmod(int(ns), 10**9)
    return f'{s}.{r:09d}'


# ---- command checks (the node's, message shape only) ----------------------------------------


def command_shape_error(names: Sequence[str], npos: int) -> str | None:
    """The node's message-shape check of a JointState command or target (conversions.py):
    names and positions pair up, no empty or repeated name."""
    names = list(names)
    if not names and not npos:
        return 'empty JointState: name and position are both empty'
    if len(names) != npos:
        return (
            f'JointState has {len(names)} name(s) {names} but {npos} position(s); they must '
            f'pair up one to one'
        )
    empty = [i for i, nm in enumerate(names) if not nm]
    if empty:
        return f'JointState name[{empty[0]}] is an empty string'
    seen: set[str] = set()
    dups = [nm for nm in names if nm in seen or seen.add(nm)]
    if dups:
        return f'JointState names {sorted(set(dups))} more than once'
    return None


# ---- solving -----------------------------------------------------------------------------------


@dataclass
class Results:
    """Per-row answers (n rows), NaN where a row was refused."""

    ok: np.ndarray
    reason: list
    residual: np.ndarray
    margin: np.ndarray
    branch_code: np.ndarray  # (n,) index into branch_names ('' for refused rows)
    branch_defined: np.ndarray
    iterations: np.ndarray
    cond: np.ndarray
    solver_code: np.ndarray  # (n,) index into solver_names
    inputs: dict[str, np.ndarray]  # solved, or as commanded (NaN too) on refused rows
    input_given: dict[str, np.ndarray]  # (n,) bool: the request named this actuator
    joints: dict[str, np.ndarray]
    points: dict[str, np.ndarray]
    batched: int = 0
    sequential: int = 0
    branch_names: list = field(default_factory=lambda: [''])
    solver_names: list = field(default_factory=lambda: [''])

    def _code(self, table: list, name: str) -> int:
        try:
            return table.index(name)
        except ValueError:
            table.append(name)
            return len(table) - 1

    def branch_code_of(self, name: str) -> int:
        return self._code(self.branch_names, name)

    def solver_code_of(self, name: str) -> int:
        return self._code(self.solver_names, name)

    def branch(self, i: int) -> str:
        return self.branch_names[self.branch_code[i]]

    def solver(self, i: int) -> str:
        return self.solver_names[self.solver_code[i]]

    @classmethod
    def empty(cls, mech, n):
        return cls(
            ok=np.zeros(n, bool),
            reason=[None] * n,
            residual=np.full(n, np.nan),
            margin=np.full(n, np.nan),
            branch_code=np.zeros(n, np.int32),
            branch_defined=np.ones(n, bool),
            iterations=np.zeros(n, np.int64),
            cond=np.full(n, np.nan),
            solver_code=np.zeros(n, np.int32),
            inputs={a: np.full(n, np.nan) for a in mech.actuators},
            input_given={a: np.zeros(n, bool) for a in mech.actuators},
            joints={j: np.full(n, np.nan) for j in mech.joint_names},
            points={p: np.full((n, 2), np.nan) for p in mech.points},
        )


class _Entry:
    """One configuration in a solver's continuity history, as the node's solver holds it:
    ('adopt', result) after switching solvers, or ('solve', command, signs) after a success."""

    __slots__ = ('kind', 'cmd', 'signs', '_result', 'batch', 'i', 'solver')

    def __init__(self, kind, *, cmd=None, signs=(), result=None, batch=None, i=0, solver=None):
        self.kind, self.cmd, self.signs = kind, cmd, tuple(signs)
        self._result, self.batch, self.i, self.solver = result, batch, i, solver

    def result(self):
        if self._result is None:
            self._result = self.batch.row(self.i, self.solver)
        return self._result

    def point(self, p) -> np.ndarray:
        if self._result is None and self.batch is not None:
            return self.batch.points[p][self.i]
        return np.asarray(self.result().points[p], float)

    def link(self, l) -> float:
        if self._result is None and self.batch is not None:
            return float(self.batch.links[l][self.i])
        return float(self.result().links[l])


class _Context:
    """One solver (one set of knowns) and its node-equivalent continuity history."""

    def __init__(self, engine, knowns):
        self.engine = engine
        self.knowns = list(knowns)
        self.solver = engine.make_solver(knowns, engine.branch)
        self.hist: list[_Entry] = []
        self.synced = True  # the solver's own history equals self.hist
        self.seen_version: int | None = None  # the node's Engine._synced[key]
        self._explicit: dict[tuple, Solver] = {}

    def explicit(self, signs) -> Solver:
        signs = tuple(signs)
        s = self._explicit.get(signs)
        if s is None:
            s = self._explicit[signs] = self.engine.make_solver(
                self.knowns, ''.join('+' if x > 0 else '-' for x in signs)
            )
        return s

    def push(self, entry: _Entry):
        """A success of this solver (the node: last = result, version += 1)."""
        self.hist = (self.hist + [entry])[-2:]
        eng = self.engine
        eng.last = entry
        eng.version += 1
        self.seen_version = eng.version

    def sync(self):
        """Give the solver exactly the history the node's solver has (self.hist)."""
        if self.synced:
            return
        S = self.solver
        S.reset()
        states = []
        for e in self.hist:
            if e.kind == 'adopt':
                S.adopt(e.result())
                states.append(S.snapshot()[-1])
            else:
                # the same command with the same branch signs gives the same state
                sx = self.explicit(e.signs)
                sx.reset()
                sx.solve(e.cmd)
                states.append(sx.snapshot()[-1])
                sx.reset()
        S.restore(states)
        self.synced = True


class _Engine:
    """Solves the commands in order with the node's semantics (linkage_ros.node.Engine): one
    continuous Solver for commands, one per set of target names (an LRU cache of 32), one shared
    'last good state' that a solver adopts when another solver has succeeded since it was last
    used, and the reference pose solved first as the initial good state."""

    TARGET_CACHE = 32

    def __init__(self, mech, method, tol, max_iter, branch):
        self.mech, self.method, self.tol, self.max_iter = mech, method, tol, max_iter
        self.branch = branch
        self.version = 0
        self.last: _Entry | None = None
        # the command solver exists from the start (a bad --solver/--branch fails here)
        self.forward = _Context(self, list(mech.actuators))
        self.targets: dict[frozenset, _Context | str] = {}
        # like the node: the reference pose is the first good state
        S = self.forward.solver
        reference = S.reference_values()
        ref = S.solve(reference)
        if ref.success:
            self.forward.hist = [
                _Entry('solve', cmd=reference, signs=_signs_of(ref.branch), result=ref)
            ]
            self.last = self.forward.hist[-1]
        self.forward.seen_version = self.version

    def make_solver(self, knowns, branch) -> Solver:
        return Solver(
            self.mech,
            knowns=list(knowns),
            method=self.method,
            tol=self.tol,
            max_iter=self.max_iter,
            branch=branch,
        )

    def context_for(self, names) -> _Context | str:
        """The node's Engine.solver_for: the forward solver for the actuator set, else one
        cached solver per set of names (compiled in the order first seen), or why not."""
        key = frozenset(names)
        if key == frozenset(self.forward.knowns):
            return self.forward
        ctx = self.targets.get(key)
        if ctx is None:
            try:
                ctx = _Context(self, list(names))
            except LinkageError as exc:
                ctx = str(exc)
            self.targets[key] = ctx
            while len(self.targets) > self.TARGET_CACHE:
                self.targets.pop(next(iter(self.targets)))
        else:
            self.targets[key] = self.targets.pop(key)  # most recently used
        return ctx

    # -- driver ----------------------------------------------------------------------------------
    def solve_all(self, data: Commands, progress: _Progress | None = None) -> Results:
        progress = progress or _Progress(False)
        n = data.n
        self.res = res = Results.empty(self.mech, n)
        self.progress = progress
        self.done = 0
        progress.start('solving', n)
        if n:
            # the node refuses a request whose stamp it cannot echo (negative, nanosec >= 1e9)
            self.bad_stamp = ~stamp_valid(data.sec, data.nanosec)
            change = (
                np.flatnonzero(
                    (data.topic[1:] != data.topic[:-1])
                    | (data.key[1:] != data.key[:-1])
                    | (self.bad_stamp[1:] != self.bad_stamp[:-1])
                )
                + 1
            )
            starts = np.concatenate([[0], change])
            ends = np.concatenate([change, [n]])
            for a, b in zip(starts.tolist(), ends.tolist()):
                self._run(data, a, b)
                self.done = b
                progress.update(b)
        progress.finish()
        return res

    def _refuse_all(self, a, b, reason):
        for g in range(a, b):
            self.res.reason[g] = reason

    def _run(self, data: Commands, a: int, b: int):
        """Rows a..b-1: one topic, one message shape (the same names in the same order), all
        with valid stamps or all not."""
        if self.bad_stamp[a]:  # node.py _answer: refused before solving
            for g in range(a, b):
                self.res.reason[g] = stamp_error(int(data.sec[g]), int(data.nanosec[g]))
            return
        k = int(data.key[a])
        names, npos = data.keys[k], data.npos[k]
        why = command_shape_error(names, npos)
        if why:  # conversions.joint_state_to_command
            self._refuse_all(a, b, why)
            return
        vals = data.positions(a, b)
        columns = {nm: vals[:, j] for j, nm in enumerate(names)}
        for nm, col in columns.items():
            if nm in self.res.inputs:
                self.res.inputs[nm][a:b] = col
                self.res.input_given[nm][a:b] = True
        ctx = self.forward if int(data.topic[a]) == 0 else self.context_for(names)
        if isinstance(ctx, str):  # no solver for these target names
            self._refuse_all(a, b, ctx)
            return
        S = ctx.solver
        # the node's Engine._solve: adopt the last good state if another solver moved on
        if (
            ctx.seen_version != self.version
            and self.last is not None
            and S.adopt(self.last.result())
        ):
            ctx.hist = [_Entry('adopt', result=self.last.result(), signs=_adopted_signs(S))]
            ctx.synced = True
        ctx.seen_version = self.version
        if set(columns) != set(ctx.knowns):
            # wrong names: the solver's own message (it depends on the names only)
            r = S.solve(_command(columns, 0), commit=False)
            self._refuse_all(a, b, r.reason)
            return
        if S.mode == 'closed_form' and b - a >= MIN_BATCH:
            self._vectorised(ctx, columns, a, b)
        else:
            self._sequential(ctx, columns, a, b, 0, b - a)

    # -- one by one ------------------------------------------------------------------------------
    def _sequential(self, ctx: _Context, columns, a, b, i0, i1):
        ctx.sync()
        S = ctx.solver
        for i in range(i0, i1):
            cmd = _command(columns, i)
            r = S.solve(cmd)
            self._store(a + i, r)
            if r.success:
                ctx.push(_Entry('solve', cmd=cmd, signs=_signs_of(r.branch), result=r))
            if not i & 0xFF:
                self.progress.update(self.done + i)
        self.res.sequential += i1 - i0

    def _store(self, g, r):
        res = self.res
        if not r.success:
            res.reason[g] = r.reason
            for nm, v in r.inputs.items():
                if nm in res.inputs:
                    res.inputs[nm][g] = v
            return
        res.ok[g] = True
        res.residual[g] = r.residual
        res.margin[g] = r.margin if r.margin is not None else np.nan
        res.branch_code[g] = res.branch_code_of(r.branch)
        res.branch_defined[g] = r.branch_defined
        res.iterations[g] = r.iterations
        res.cond[g] = r.cond if r.cond is not None else np.nan
        res.solver_code[g] = res.solver_code_of(r.solver)
        for nm, v in r.inputs.items():
            if nm in res.inputs:
                res.inputs[nm][g] = v
        for nm, v in r.joints.items():
            res.joints[nm][g] = v
        for nm, v in r.points.items():
            res.points[nm][g] = v

    # -- vectorised ------------------------------------------------------------------------------
    def _vectorised(self, ctx: _Context, columns, a, b):
        S = ctx.solver
        m = b - a
        continuous = (
            S.branch_mode == 'continuous'
            if hasattr(S, 'branch_mode')
            else self.branch == 'continuous'
        )
        pos = 0
        chunk = CHUNK_START
        stretch = SEQUENTIAL_STRETCH // 2
        while pos < m:
            if continuous and not ctx.hist:
                # the very first configuration: the reference assembly mode, no prediction
                self._sequential(ctx, columns, a, b, pos, pos + 1)
                pos += 1
                continue
            end = min(m, pos + chunk)
            cols = {nm: c[pos:end] for nm, c in columns.items()}
            if continuous:
                signs0 = ctx.hist[-1].signs
                solver = ctx.explicit(signs0)
            else:
                solver = S
                signs0 = None
            B = solver.solve_batch(cols)
            take = self._easy_prefix(ctx, solver, B, cols, end - pos) if continuous else end - pos
            # next to a tangency the batched and single dyad formulas may disagree on closing
            near = np.flatnonzero(
                np.asarray(B.ok[:take]) & (np.asarray(B.margin[:take]) < NEAR_TANGENT)
            )
            if near.size:
                take = int(near[0])
            if take:
                take = self._accept(ctx, solver, B, cols, a + pos, take)
                pos += take
            if pos < end:
                # a row the batch cannot vouch for: one by one for a while; when batches keep
                # breaking at once (jumpy commands), back off to longer one-by-one stretches
                stretch = SEQUENTIAL_STRETCH if take >= 64 else min(2 * stretch, 4096)
                stop = min(m, pos + stretch)
                self._sequential(ctx, columns, a, b, pos, stop)
                pos = stop
                chunk = max(CHUNK_MIN, min(chunk, 4 * take))
            else:
                stretch = SEQUENTIAL_STRETCH // 2
                chunk = min(CHUNK_MAX, chunk * 4)
            self.progress.update(self.done + pos)

    def _accept(self, ctx, solver, B, cols, g0, take) -> int:
        """Copy the first ``take`` batch rows into the results; returns how many were taken
        (fewer if a single solve accepts a command the batch refused: from there on the rows
        go one by one)."""
        res = self.res
        # refused rows: the node's exact reason (the same solve, with the same branch choices)
        reasons = {}
        cache: dict[bytes, str] = {}
        finite = _finite_rows({nm: c[:take] for nm, c in cols.items()}, take)
        for i in np.flatnonzero(~B.ok[:take]).tolist():
            keyb = None
            if not finite[i]:
                keyb = b''.join(np.asarray(c[i], float).tobytes() for c in cols.values())
                if keyb in cache:
                    reasons[i] = cache[keyb]
                    continue
            r = solver.solve(_command(cols, i), commit=False)
            if r.success:  # a tangency the batch refused: leave it to Solver
                take = i
                break
            reasons[i] = r.reason
            if keyb is not None:
                cache[keyb] = r.reason
        if not take:
            return 0
        sl = slice(g0, g0 + take)
        ok = B.ok[:take]
        okr = np.flatnonzero(ok)
        for i, why in reasons.items():
            if i < take:
                res.reason[g0 + i] = why
        res.ok[sl] = ok
        res.residual[sl] = np.where(ok, B.residual[:take], np.nan)
        res.margin[sl] = np.where(ok, B.margin[:take], np.nan)
        res.iterations[sl] = 0
        nsg = B.signs.shape[1]
        if nsg:
            res.branch_defined[sl] = np.where(
                ok, branch_identity_defined(B.margin[:take], B.residual[:take]), True
            )
            sg = np.asarray(B.signs[:take]) > 0
            keyv = sg.astype(np.int64) @ (np.int64(1) << np.arange(nsg, dtype=np.int64))
            uniq, first, inv = np.unique(keyv, return_index=True, return_inverse=True)
            table = np.array(
                [
                    res.branch_code_of(''.join('+' if x else '-' for x in sg[f]))
                    for f in first.tolist()
                ],
                np.int32,
            )
            res.branch_code[sl] = np.where(ok, table[inv.reshape(-1)], 0)
        else:
            res.branch_code[sl] = np.where(ok, res.branch_code_of(''), 0)
        res.solver_code[sl] = np.where(ok, res.solver_code_of(B.solver), 0)
        for nm, arr in B.inputs.items():
            if nm in res.inputs:
                res.inputs[nm][sl] = np.where(ok, arr[:take], res.inputs[nm][sl])
        for nm, arr in B.joints.items():
            res.joints[nm][sl] = np.where(ok, arr[:take], np.nan)
        for nm, arr in B.points.items():
            if nm in res.points:
                res.points[nm][sl] = np.where(ok[:, None], arr[:take], np.nan)
        # the last two successes become the node's history
        if okr.size:
            self.version += okr.size - min(okr.size, 2)
            for i in okr[-2:].tolist():
                ctx.push(
                    _Entry(
                        'solve',
                        cmd=_command(cols, i),
                        signs=tuple(B.signs[i]),
                        batch=B,
                        i=i,
                        solver=solver,
                    )
                )
            ctx.synced = False
        res.batched += take
        return take

    def _easy_prefix(self, ctx: _Context, solver: Solver, B, cols, m) -> int:
        """How many leading batch rows the node's continuity rule provably solves the same way."""
        plan = solver.plan
        bsteps = plan.branch_steps
        if not bsteps:
            return m
        mech = self.mech
        signs0 = list(ctx.hist[-1].signs)
        finite = _finite_rows(cols, m)
        safe = []
        for s in solver.specs:
            v = np.asarray(cols[s.name], float)
            v = v.reshape(m, 2) if s.kind == 'point' else v.reshape(m)
            safe.append(np.where(np.isfinite(v), v, 0.0))
        okb = np.asarray(B.ok[:m], bool)
        okr = np.flatnonzero(okb)
        step_index = {id(st): k for k, st in enumerate(plan.steps)}
        # the configuration the batch chose (signs0) at each branching step: the batch rows,
        # plus a run for refused rows that still reach some branching step
        reached = {k: okb.copy() for k in range(len(bsteps))}
        names, guides = _step_inputs(mech, bsteps)
        rowpts = {p: np.array(B.points[p][:m], float) for p in names}
        rowphi = {g: np.asarray(B.links[g][:m], float) - mech.links[g].angle_ref for g in guides}
        fin_fail = np.flatnonzero(~okb & finite)
        if fin_fail.size:
            poses_f, pts_f, info_f = plan.run([v[fin_fail] for v in safe], fin_fail.size, signs0)
            for k, st in enumerate(bsteps):
                reached[k][fin_fail] = info_f['ok'] | (info_f['failure'] > step_index[id(st)])
            for p in names:
                if p in pts_f:
                    rowpts[p][fin_fail] = pts_f[p]
            for g in guides:
                if g in poses_f.phi:
                    rowphi[g][fin_fail] = poses_f.phi[g]
        # the previous good configurations of every row: the history, then the batch's ok rows
        seqpts = {
            p: np.concatenate(
                [np.array([e.point(p) for e in ctx.hist]).reshape(-1, 2), rowpts[p][okr]]
            )
            for p in names
        }
        seqphi = {
            g: np.concatenate(
                [np.array([e.link(g) - mech.links[g].angle_ref for e in ctx.hist]), rowphi[g][okr]]
            )
            for g in guides
        }
        nh = len(ctx.hist)
        last_idx = nh + (np.cumsum(okb) - okb) - 1  # into hist + ok batch rows
        prev_idx = last_idx - 1
        has_last = last_idx >= 0
        has_prev = prev_idx >= 0
        li = np.maximum(last_idx, 0)
        pi = np.maximum(prev_idx, 0)
        eps = EASY_MARGIN * mech.length_scale
        gate = _continuity_margin()
        easy = np.ones(m, bool)
        for k, st in enumerate(bsteps):
            need = reached[k] & has_last
            if not np.any(need):
                continue
            if gate is not None:
                # the node keeps the previous sign where the dyad is clear of its singularity
                # now and in the previous configuration (core.plan.CONTINUITY_MARGIN)
                m_now = _step_margin(mech, st, rowpts, rowphi)
                m_seq = _step_margin(mech, st, seqpts, seqphi)
                keep = (m_now > gate + 1e-9) & (m_seq[li] > gate + 1e-9)
                need &= ~keep
                if not np.any(need):
                    continue
            flipped = list(signs0)
            flipped[k] = -flipped[k]
            poses1, pts1, _ = plan.run(safe, m, flipped)
            if st.op == 'line_through':
                gl = mech.prismatics[st.args[0]].guide
                phs = rowphi[gl]
                last = seqphi[gl][li]
                ds = np.abs(_wrap(phs - last))
                do = np.abs(_wrap(poses1.phi[gl] - last))
                good = do - ds > EASY_MARGIN
            else:
                x = st.point
                xs, xo = rowpts[x], pts1[x]
                L, P = seqpts[x][li], seqpts[x][pi]
                good = _dist(xo, L) - _dist(xs, L) > eps
                T = L + 1.5 * (L - P)
                good &= ~has_prev | (_dist(xo, T) - _dist(xs, T) > eps)
            easy &= ~need | good
        easy |= ~finite
        # refused on an input limit: the node checks limits before any branch choice
        limited = [
            (k, s)
            for k, s in enumerate(solver.specs)
            if s.kind != 'point' and (s.minimum is not None or s.maximum is not None)
        ]
        if limited:
            for i in np.flatnonzero(~easy & ~okb).tolist():
                if any(solver.limit_violation(s, float(safe[k][i])) for k, s in limited):
                    easy[i] = True
        bad = np.flatnonzero(~easy)
        return int(bad[0]) if bad.size else m


def _continuity_margin() -> float | None:
    """The dyad margin above which the core's continuity keeps the previous branch sign."""
    try:
        from .core.plan import CONTINUITY_MARGIN

        return float(CONTINUITY_MARGIN)
    except ImportError:
        return None


def _step_inputs(mech, bsteps):
    """The points and guide links whose positions decide each branching step."""
    names, guides = [], []
    for st in bsteps:
        pts = [st.point, st.args[1]] + ([st.args[3]] if st.op == 'circle_circle' else [])
        names += [p for p in pts if p not in names]
        if st.op != 'circle_circle':
            g = mech.prismatics[st.args[0] if st.op == 'line_through' else st.args[2]].guide
            if g not in guides:
                guides.append(g)
    return names, guides


def _step_margin(mech, st, pts, phi) -> np.ndarray:
    """Margin of one branching dyad (|sin| of its transmission angle, 0 at the singularity),
    read off positions as core.plan.branch_geometry_one does, vectorised."""
    x = pts[st.point]
    if st.op == 'circle_circle':
        va, vb = x - pts[st.args[1]], x - pts[st.args[3]]
        den = np.hypot(va[:, 0], va[:, 1]) * np.hypot(vb[:, 0], vb[:, 1])
        num = np.abs(va[:, 0] * vb[:, 1] - va[:, 1] * vb[:, 0])
    else:
        pj = mech.prismatics[st.args[0] if st.op == 'line_through' else st.args[2]]
        ang = phi[pj.guide]
        c, s = np.cos(ang), np.sin(ang)
        ux = c * pj.direction[0] - s * pj.direction[1]
        uy = s * pj.direction[0] + c * pj.direction[1]
        v = x - pts[st.args[1]]
        den = np.hypot(v[:, 0], v[:, 1])
        num = np.abs(v[:, 0] * ux + v[:, 1] * uy)
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.clip(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0), 0.0, 1.0)


def _command(columns, i) -> dict:
    out = {}
    for nm, c in columns.items():
        v = c[i]
        out[nm] = (float(v[0]), float(v[1])) if np.ndim(v) else float(v)
    return out


def _finite_rows(cols, m) -> np.ndarray:
    f = np.ones(m, bool)
    for c in cols.values():
        f &= np.all(np.isfinite(np.asarray(c, float).reshape(m, -1)), axis=1)
    return f


def _adopted_signs(S: Solver) -> tuple[int, ...]:
    """The branch signs a solver holds after adopt() (its plan's signs of that pose)."""
    return S.current_signs


def _signs_of(branch: str) -> tuple[int, ...]:
    return tuple(1 if c == '+' else -1 for c in branch)


def _wrap(a):
    return np.arctan2(np.sin(a), np.cos(a))


def _dist(a, b):
    d = a - b
    return np.hypot(d[:, 0], d[:, 1])


def solve_commands(
    mech, data: Commands, method=None, tol=1e-12, max_iter=50, branch='continuous'
) -> Results:
    """Solve decoded commands in order as the node would (library entry point)."""
    return _Engine(mech, method, tol, max_iter, branch).solve_all(data)


# ---- writing: CSV ------------------------------------------------------------------------------
# Python formats a float in ~0.6 us; a million rows of twenty numbers is seconds of it. The text
# is built here with numpy instead: each column as an (n, width) byte array in which a zero byte
# means "nothing", the columns side by side, the zero bytes dropped.

_P10 = np.array([10.0**k for k in range(23)])  # exact doubles
_SPLIT = 134217729.0  # 2**27 + 1 (Veltkamp split)
_U4 = np.uint64(10000)
_LUT4 = np.array(
    [
        [48 + (k // 1000) % 10, 48 + (k // 100) % 10, 48 + (k // 10) % 10, 48 + k % 10]
        for k in range(10000)
    ],
    np.uint8,
)
_TZ4 = np.array(
    [
        4 if k == 0 else 3 if k % 1000 == 0 else 2 if k % 100 == 0 else 1 if k % 10 == 0 else 0
        for k in range(10000)
    ],
    np.int16,
)
_LUT4W = _LUT4.copy().view('<u4').ravel()  # the four digits as one word
_KEEPW = np.array([0, 0xFF, 0xFFFF, 0xFFFFFF, 0xFFFFFFFF], '<u4')  # keep the first k bytes
FLOAT_WIDTH = 28


def _two_prod(a, b):
    """a * b == p + e exactly (Dekker's error-free product)."""
    p = a * b
    t = a * _SPLIT
    ah = t - (t - a)
    al = a - ah
    t = b * _SPLIT
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _digits17(a):
    """For 1e-28 <= a < 1e16: the correctly rounded 17 significant digits D (uint64,
    1e16 <= D < 1e17) and the decimal exponent e, a ~ D * 10**(e - 16)."""
    e = np.floor(np.log10(a)).astype(np.int64)
    for _ in range(3):
        k = 16 - e
        k1 = np.minimum(k, 22)
        p, err = _two_prod(a, _P10[k1])
        k2 = k - k1
        if np.any(k2):  # tiny values: a second exact power of ten
            m = k2 > 0
            P2 = _P10[k2]
            p2, e2 = _two_prod(p, P2)
            err = np.where(m, e2 + err * P2, err)
            p = np.where(m, p2, p)
        D = p.astype(np.uint64) + np.rint(err).astype(np.int64).astype(np.uint64)
        hi = np.uint64(10**17) <= D
        lo = np.uint64(10**16) > D
        if not (hi.any() or lo.any()):
            break
        e = e + hi - lo  # log10 was off by one next to a power of ten
    return D, e


def _exact_value(D, exp10):
    """D * 10**exp10 correctly rounded (as float() would parse it) where that is one exact
    operation (D < 2**53, |exp10| <= 22); NaN elsewhere."""
    ok = (np.abs(exp10) <= 22) & (np.uint64(2**53) > D)
    pe = _P10[np.minimum(np.abs(exp10), 22)]
    Df = D.astype(float)
    return np.where(ok, np.where(exp10 >= 0, Df * pe, Df / pe), np.nan)


def format_floats(values, nan: bytes = b'') -> np.ndarray:
    """Text of float64 values as an (n, FLOAT_WIDTH) uint8 array, zero bytes meaning nothing.

    Scientific notation (``9.479697413828935e-01``, ``-1.2566383147671889e-05``, ``5e-01``) whose
    text parses back to exactly the same double: 17 correctly rounded significant digits,
    shortened to 15 or 16 where those provably round-trip, trailing zeros dropped. Zero is
    ``0.0``, NaN ``nan`` (default: empty); infinities and extreme magnitudes go through repr().
    """
    v = np.asarray(values, float).ravel()
    n = v.size
    bits = v.view(np.int64)
    if n > 1 and (bits == bits[0]).all():
        return np.broadcast_to(format_floats(v[:1], nan), (n, FLOAT_WIDTH))  # e.g. ground
    a = np.abs(v)
    with np.errstate(invalid='ignore'):
        regular = np.isfinite(v) & (a >= 1e-28) & (a < 1e16)
    allreg = bool(regular.all())
    if allreg:
        ar, m, vr = a, n, v
    else:
        idx = np.flatnonzero(regular)
        ar, m, vr = a[idx], idx.size, v[idx]
    rows = np.zeros((m, FLOAT_WIDTH), np.uint8)
    if m:
        D, e = _digits17(ar)
        for drop in (2, 1):  # 15, then 16 digits where they round-trip
            q, r = np.divmod(D, np.uint64(10**drop))
            half = np.uint64(5 * 10 ** (drop - 1))
            q = q + ((r > half) | ((r == half) & ((q & np.uint64(1)) == 1))).astype(np.uint64)
            good = (q < np.uint64(10 ** (17 - drop))) & (_exact_value(q, e - (16 - drop)) == ar)
            D = np.where(good, q * np.uint64(10**drop), D)
        q, g4 = np.divmod(D, _U4)
        q, g3 = np.divmod(q, _U4)
        q, g2 = np.divmod(q, _U4)
        g0, g1 = np.divmod(q, _U4)
        tz = _TZ4[g4]  # trailing zeros, four digits at a time
        full = tz == 4
        for g in (g3, g2, g1):
            t = _TZ4[g]
            tz = tz + np.where(full, t, 0)
            full &= t == 4
        keep = 16 - tz  # significant digits after the first
        rows[:, 0] = np.signbit(vr) * np.uint8(45)  # '-'
        rows[:, 1] = g0.astype(np.uint8) + np.uint8(48)  # d0
        rows[:, 2] = (keep > 0) * np.uint8(46)  # '.'
        words = rows.view(np.uint32)  # digits 2..17 as four 4-byte words
        for w, g in enumerate((g1, g2, g3, g4)):
            words[:, 1 + w] = _LUT4W[g] & _KEEPW[np.clip(keep - 4 * w, 0, 4)]
        ex = np.abs(e)
        rows[:, 20] = 101  # 'e'
        rows[:, 21] = np.where(e < 0, 45, 43)
        rows[:, 22] = (ex >= 100) * (ex // 100 + 48).astype(np.uint8)
        rows[:, 23] = (ex // 10) % 10 + 48
        rows[:, 24] = ex % 10 + 48
    if allreg:
        return rows
    out = np.zeros((n, FLOAT_WIDTH), np.uint8)
    out[idx] = rows
    zero = v == 0
    if zero.any():  # '0.0' / '-0.0'
        z = np.flatnonzero(zero)
        neg = np.signbit(v[z])
        out[z, 0] = neg * np.uint8(45)
        out[z, 1:4] = np.frombuffer(b'0.0', np.uint8)
    isnan = np.isnan(v)
    if isnan.any() and nan:
        out[np.flatnonzero(isnan), : len(nan)] = np.frombuffer(nan, np.uint8)
    for i in np.flatnonzero(~regular & ~zero & ~isnan).tolist():
        b = repr(float(v[i])).encode()
        out[i, : len(b)] = np.frombuffer(b, np.uint8)
    return out


def format_ints(values) -> np.ndarray:
    """Decimal text of int64 values as an (n, 20) uint8 array (zero bytes = nothing)."""
    v = np.asarray(values, np.int64).ravel()
    neg = v < 0
    u = np.abs(v).astype(np.uint64)
    groups = []
    for _ in range(5):
        u, g = np.divmod(u, _U4)
        groups.append(g)
    dig = np.concatenate([_LUT4[g] for g in groups[::-1]], axis=1)  # 20 digits
    nz = dig != 48
    first = np.where(nz.any(axis=1), np.argmax(nz, axis=1), 19)  # keep one '0'
    dig[np.arange(20)[None, :] < first[:, None]] = 0
    return np.concatenate([(neg * np.uint8(45))[:, None], dig], axis=1)


def _stamp_text(sec, nsec) -> np.ndarray:
    """'sec.nnnnnnnnn' (exact decimal seconds of sec + nsec * 1e-9) as a byte array; a negative
    time is '-' and its magnitude ('-4.999999999' for sec -5, nsec 1), and a nanosec field of a
    second or more (not normalised) carries into the seconds, as rclpy's Time reads a stamp."""
    total = np.asarray(sec, np.int64) * np.int64(10**9) + np.asarray(nsec, np.int64)
    mag = np.abs(total).astype(np.uint64)
    s, ns = np.divmod(mag, np.uint64(10**9))
    hi, lo = np.divmod(ns, _U4)
    a, b = np.divmod(hi, _U4)
    frac = np.concatenate(
        [(a.astype(np.uint8) + np.uint8(48))[:, None], _LUT4[b], _LUT4[lo]], axis=1
    )
    whole = format_ints(s.astype(np.int64))
    whole[:, 0] = (total < 0) * np.uint8(45)  # '-'
    return np.concatenate([whole, np.full((len(ns), 1), 46, np.uint8), frac], axis=1)


def _table(strings: list[str], codes: np.ndarray) -> np.ndarray:
    """Byte array of strings[codes]."""
    enc = [s.encode('utf-8') for s in strings]
    w = max([len(b) for b in enc] + [1])
    lut = np.zeros((len(enc), w), np.uint8)
    for i, b in enumerate(enc):
        lut[i, : len(b)] = np.frombuffer(b, np.uint8)
    return lut[np.asarray(codes)]


def csv_header(mech) -> list[str]:
    return (
        ['time', 'receive_time', 'topic']
        + [f'input.{a}' for a in mech.actuators]
        + [f'joint.{j}' for j in mech.joint_names]
        + [f'{p}.{c}' for p in mech.points for c in ('x', 'y')]
        + ['residual', 'margin', 'branch', 'status', 'reason']
    )


def _csv_field(s: str) -> str:
    if any(c in s for c in ',"\n\r'):
        return '"' + s.replace('"', '""') + '"'
    return s


def write_csv(
    path: Path,
    data: Commands,
    res: Results,
    mech,
    progress: _Progress | None = None,
    block: int = 50_000,
):
    """One row per command, in bag order (see the module docstring for the columns)."""
    progress = progress or _Progress(False)
    n = data.n
    progress.start('csv', n)
    comma = None
    topics = [_csv_field(t) for t in data.topics]
    status_names = ['error', 'ok']
    with open(path, 'wb') as fh:
        fh.write((','.join(csv_header(mech)) + '\n').encode())
        for a in range(0, n, block):
            b = min(n, a + block)
            m = b - a
            sl = slice(a, b)
            if comma is None or comma.shape[0] != m:
                comma = np.full((m, 1), 44, np.uint8)
                newline = np.full((m, 1), 10, np.uint8)
            ns = data.log_ns[sl]
            cols = [
                _stamp_text(data.sec[sl], data.nanosec[sl]),
                comma,
                _stamp_text(0, ns),
                comma,
                _table(topics, data.topic[sl]),
                comma,
            ]
            for nm in mech.actuators:
                text = format_floats(res.inputs[nm][sl], b'nan')
                absent = ~(res.ok[sl] | res.input_given[nm][sl])
                if absent.any():  # a refused request that did not name it
                    text = text.copy()
                    text[absent] = 0
                cols += [text, comma]
            for nm in mech.joint_names:
                cols += [format_floats(res.joints[nm][sl]), comma]
            for p in mech.points:
                cols += [
                    format_floats(res.points[p][sl, 0]),
                    comma,
                    format_floats(res.points[p][sl, 1]),
                    comma,
                ]
            cols += [
                format_floats(res.residual[sl]),
                comma,
                format_floats(res.margin[sl]),
                comma,
                _table(res.branch_names, res.branch_code[sl]),
                comma,
                _table(status_names, res.ok[sl].astype(np.int64)),
                comma,
            ]
            bad = [
                (i, _csv_field(res.reason[a + i] or '').encode('utf-8'))
                for i in np.flatnonzero(~res.ok[sl]).tolist()
            ]
            width = max([len(r) for _, r in bad] + [1])
            reason = np.zeros((m, width), np.uint8)
            for i, r in bad:
                reason[i, : len(r)] = np.frombuffer(r, np.uint8)
            cols += [reason, newline]
            flat = np.concatenate(cols, axis=1).ravel()
            fh.write(flat[flat != 0].tobytes())
            progress.update(b)
    progress.finish()


# ---- writing: rosbag2 ----------------------------------------------------------------------


class _Cdr:
    """A little-endian CDR writer for the few fixed message shapes written here."""

    def __init__(self):
        self.buf = bytearray(b'\x00\x01\x00\x00')

    def align(self, k):
        self.buf += b'\x00' * ((-(len(self.buf) - 4)) % k)

    def u8(self, v):
        self.buf.append(v & 0xFF)

    def u32(self, v):
        self.align(4)
        self.buf += struct.pack('<I', v)

    def i32(self, v):
        self.align(4)
        self.buf += struct.pack('<i', v)

    def string(self, s: str):
        b = s.encode('utf-8')
        self.u32(len(b) + 1)
        self.buf += b + b'\x00'

    def f64s(self, values) -> int:
        self.align(8)
        off = len(self.buf)
        for v in values:
            self.buf += struct.pack('<d', v)
        return off

    def header(self, frame_id):
        self.i32(0)
        self.u32(0)
        self.string(frame_id)


def _joint_state_template(names, frame_id):
    c = _Cdr()
    c.header(frame_id)
    c.u32(len(names))
    for nm in names:
        c.string(nm)
    c.u32(len(names))
    off = c.f64s([0.0] * len(names)) if names else len(c.buf)
    c.u32(0)
    c.u32(0)
    return np.frombuffer(bytes(c.buf), np.uint8), off


def _point_template(frame_id):
    c = _Cdr()
    c.header(frame_id)
    off = c.f64s([0.0, 0.0, 0.0])
    return np.frombuffer(bytes(c.buf), np.uint8), off


def _cdr_str_block(s: str) -> bytes:
    """A CDR string starting at a 4-aligned offset, padded to the next 4-aligned offset."""
    b = s.encode('utf-8')
    k = len(b) + 1
    return struct.pack('<I', k) + b + b'\x00' * (1 + (-k) % 4)


_LEN = [struct.pack('<I', k + 1) for k in range(256)]
_PAD = [b'\x00' * (1 + (-(k + 1)) % 4) for k in range(256)]


def _float_blocks(values: list[float]) -> list[bytes]:
    """CDR string blocks of repr(value) (what the node's status key-values hold)."""
    out = []
    for x in values:
        b = repr(x).encode()
        k = len(b)
        out.append(_LEN[k] + b + _PAD[k])
    return out


class _StatusWriter:
    """Serialises diagnostic_msgs/DiagnosticStatus as conversions.result_to_status builds it:
    name '<node>: <scene>', hardware_id '', OK + 'ok' + residual, branch, branch_defined, margin,
    solver, iterations[, cond], request; or ERROR + the reason + request."""

    OK_LEVEL, ERROR_LEVEL = 0, 2

    def __init__(self, name: str, hardware_id: str = ''):
        self.name = _cdr_str_block(name)
        self.hw = _cdr_str_block(hardware_id)
        self.cache: dict[Any, bytes] = {}

    def blk(self, s: str) -> bytes:
        b = self.cache.get(s)
        if b is None:
            b = self.cache[s] = _cdr_str_block(s)
        return b

    def _head(self, level: int, message: str, count: int) -> bytes:
        return b''.join(
            [
                b'\x00\x01\x00\x00',
                bytes([level, 0, 0, 0]),
                self.name,
                self.blk(message),
                self.hw,
                struct.pack('<I', count),
            ]
        )

    def ok_parts(
        self, has_cond: bool, branch: str, bdef: bool, solver: str, iterations: int, request: str
    ):
        """The constant pieces of an OK status around the residual and margin (and cond)."""
        key = (has_cond, branch, bdef, solver, iterations, request)
        hit = self.cache.get(key)
        if hit is None:
            k = self.blk
            head = self._head(self.OK_LEVEL, 'ok', 8 if has_cond else 7) + k('residual')
            mid = b''.join(
                [
                    k('branch'),
                    k(branch),
                    k('branch_defined'),
                    k('true' if bdef else 'false'),
                    k('margin'),
                ]
            )
            tail = b''.join([k('solver'), k(solver), k('iterations'), k(str(iterations))])
            end = k('request') + k(request)
            hit = self.cache[key] = (head, mid, tail + (k('cond') if has_cond else b''), end)
        return hit

    def error(self, reason: str, request: str) -> bytes:
        return b''.join(
            [self._head(self.ERROR_LEVEL, reason, 1), self.blk('request'), self.blk(request)]
        )


def write_bag(
    path: Path,
    data: Commands,
    res: Results,
    mech,
    frame_id: str,
    storage: str | None,
    progress: _Progress | None = None,
    status_name: str | None = None,
    block: int = 100_000,
):
    """A new rosbag2 with /joint_states, /points/<name> and /status, one set per command, each
    logged at its command's bag time, in the node's order (joint_states, points, status)."""
    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin
    from rosbags.typesys import Stores, get_typestore

    progress = progress or _Progress(False)
    plugin = StoragePlugin.MCAP if (storage or 'mcap') == 'mcap' else StoragePlugin.SQLITE3
    ts = get_typestore(Stores.ROS2_JAZZY)
    n = data.n
    joints = list(mech.joint_names)
    outputs = list(mech.outputs)
    progress.start('writing', n)
    # stamps: the command's, a zero stamp -> the bag receive time
    zero = data.stamp_zero
    sec = np.where(zero, data.log_ns // 10**9, data.sec).astype('<i4')
    nsec = np.where(zero, data.log_ns % 10**9, data.nanosec).astype('<u4')
    js_t, js_off = _joint_state_template(joints, frame_id)
    pt_t, pt_off = _point_template(frame_id)
    status = _StatusWriter(status_name if status_name is not None else f'{NODE_NAME}: {mech.name}')
    requests = ['command', 'target']
    try:
        writer = Writer(path, version=9, storage_plugin=plugin)
        writer.open()
    except Exception as exc:  # noqa: BLE001
        raise BagError(f'output {path}: cannot create the bag ({_exc_text(exc)})') from None
    try:
        c_js = writer.add_connection('/joint_states', JOINT_STATE, typestore=ts)
        c_pts = [
            writer.add_connection(f'/points/{p}', POINT_STAMPED, typestore=ts) for p in outputs
        ]
        c_st = writer.add_connection('/status', DIAGNOSTIC_STATUS, typestore=ts)
        write = writer.write
        for a in range(0, n, block):
            b = min(n, a + block)
            okr = a + np.flatnonzero(res.ok[a:b])
            js = _stamped_rows(js_t, okr, sec, nsec)
            if joints and okr.size:
                vals = np.stack([res.joints[j][okr] for j in joints], axis=1).astype('<f8')
                js[:, js_off : js_off + 8 * len(joints)] = vals.view(np.uint8).reshape(okr.size, -1)
            js_rows = _rows_bytes(js)
            pt_rows = []
            for p in outputs:
                arr = _stamped_rows(pt_t, okr, sec, nsec)
                xyz = np.zeros((okr.size, 3), '<f8')
                xyz[:, :2] = res.points[p][okr]
                arr[:, pt_off : pt_off + 24] = xyz.view(np.uint8).reshape(okr.size, 24)
                pt_rows.append(_rows_bytes(arr))
            statuses = _status_rows(status, res, data.topic, requests, a, b, okr)
            ok = res.ok[a:b].tolist()
            log = data.log_ns[a:b].tolist()
            j = 0
            for i in range(b - a):
                t = log[i]
                if ok[i]:
                    write(c_js, t, js_rows[j])
                    for conn, rows in zip(c_pts, pt_rows):
                        write(conn, t, rows[j])
                    j += 1
                write(c_st, t, statuses[i])
            progress.update(b)
        writer.close()
    except BaseException as exc:
        # the folder is this run's own (it did not exist before): a half-written bag without
        # metadata is no result, and would only block the next run ('exists already')
        with contextlib.suppress(Exception):
            writer.abort()
        shutil.rmtree(path, ignore_errors=True)
        if isinstance(exc, (BagError, OSError)) or not isinstance(exc, Exception):
            raise
        # sqlite3 ('database or disk is full'), rosbags' WriterError, ...
        raise BagError(
            f'output {path}: cannot write the bag ({_exc_text(exc)}); nothing was kept'
        ) from None
    progress.finish()


def _stamped_rows(template: np.ndarray, rows: np.ndarray, sec, nsec) -> np.ndarray:
    """The message template once per row, with each row's header stamp."""
    out = np.tile(template, (rows.size, 1))
    out[:, 4:8] = sec[rows].view(np.uint8).reshape(rows.size, 4)
    out[:, 8:12] = nsec[rows].view(np.uint8).reshape(rows.size, 4)
    return out


def _status_rows(status: _StatusWriter, res: Results, topic, requests, a, b, okr) -> list[bytes]:
    """Serialised DiagnosticStatus of rows a..b-1 (okr: their successful rows)."""
    res_blk = _float_blocks(res.residual[okr].tolist())
    mar_blk = _float_blocks(res.margin[okr].tolist())
    cond = res.cond[okr]
    has_cond = ~np.isnan(cond)
    cond_blk = _float_blocks(cond[has_cond].tolist()) if has_cond.any() else []
    bcode, bnames = res.branch_code[okr].tolist(), res.branch_names
    scode, snames = res.solver_code[okr].tolist(), res.solver_names
    bdef = res.branch_defined[okr].tolist()
    iters = res.iterations[okr].tolist()
    hc = has_cond.tolist()
    ok = res.ok[a:b].tolist()
    tops = topic[a:b].tolist()
    out: list[bytes] = []
    j = c = 0
    for i in range(b - a):
        req = requests[tops[i]]
        if ok[i]:
            head, mid, tail, end = status.ok_parts(
                hc[j], bnames[bcode[j]], bdef[j], snames[scode[j]], iters[j], req
            )
            if hc[j]:
                out.append(b''.join([head, res_blk[j], mid, mar_blk[j], tail, cond_blk[c], end]))
                c += 1
            else:
                out.append(b''.join([head, res_blk[j], mid, mar_blk[j], tail, end]))
            j += 1
        else:
            out.append(status.error(res.reason[a + i] or 'failed', req))
    return out


def _rows_bytes(arr: np.ndarray) -> list[bytes]:
    """The rows of a 2-D uint8 array as bytes objects."""
    if not arr.shape[0]:
        return []
    width = arr.shape[1]
    buf = arr.tobytes()
    return [buf[k : k + width] for k in range(0, len(buf), width)]


# ---- plot --------------------------------------------------------------------------------------


def _isolated(ok: np.ndarray) -> np.ndarray:
    """The ok samples without an ok neighbour: a line broken at the refused rows (NaN) has no
    segment through them, so they need a marker of their own."""
    prev = np.concatenate(([False], ok[:-1]))
    after = np.concatenate((ok[1:], [False]))
    return ok & ~prev & ~after


def _series(ax, x, y, ok, **style):
    """A line with gaps where not ok, plus a dot for every ok sample the line cannot show."""
    (line,) = ax.plot(x, np.where(ok, y, np.nan), **style)
    lone = _isolated(ok)
    if lone.any():
        ax.plot(x[lone], y[lone], '.', ms=6, color=line.get_color())


def plot_figure(data: Commands, res: Results, mech, max_points: int = 20000):
    """The matplotlib figure of :func:`write_plot` (the caller closes it)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    n = data.n
    step = max(1, n // max_points)
    idx = np.arange(0, n, step)
    t = (data.log_ns[idx] - (data.log_ns[0] if n else 0)) * 1e-9
    ok = res.ok[idx]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 5.5))
    outs = list(mech.outputs) or [p for p in mech.points][-1:]
    for p in outs:
        xy = res.points[p][idx]
        _series(ax1, xy[:, 0], xy[:, 1], ok, ls='-', lw=1.0, label=p)
    ax1.set_aspect('equal', adjustable='datalim')
    ax1.set_xlabel('x (m)')
    ax1.set_ylabel('y (m)')
    ax1.set_title(f'{mech.name}: coupler point trace' + ('s' if len(outs) > 1 else ''))
    if outs:
        ax1.legend(loc='best', fontsize='small')
    ax1.grid(True, alpha=0.3)
    for a in mech.actuators:
        _series(ax2, t, res.inputs[a][idx], ok, lw=1.6, label=f'input {a}')
    for j in mech.joint_names:
        _series(ax2, t, res.joints[j][idx], ok, lw=0.9, label=f'joint {j}')
    bad = ~ok
    if np.any(bad):
        ax2.plot(t[bad], np.zeros(int(bad.sum())), 'rx', ms=4, label='refused')
    ax2.set_xlabel('bag time (s)')
    ax2.set_ylabel('rad / m')
    ax2.set_title('inputs and joints')
    ax2.legend(loc='best', fontsize='small', ncol=2)
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def write_plot(path: str, data: Commands, res: Results, mech, max_points: int = 20000):
    """Coupler-point traces (x-y) and inputs/joints against time (refused rows are gaps; an
    accepted row between two refused ones is a dot)."""
    import matplotlib.pyplot as plt

    fmt = _plot_format(str(path))  # the file named is the file written (no '.png' added)
    fig = plot_figure(data, res, mech, max_points)
    try:
        fig.savefig(path, dpi=110, format=fmt)
    except OSError as exc:
        raise BagError(f'--plot {path}: {exc.strerror or exc}') from None
    except Exception as exc:  # noqa: BLE001 - e.g. a format whose writer is missing (pgf: LaTeX)
        raise BagError(f'--plot {path}: cannot write the image ({_exc_text(exc)})') from None
    finally:
        plt.close(fig)


if __name__ == '__main__':
    sys.exit(main())
