"""Reading a rosbag2: the command topics, JointState decoding (many messages at a time) and
the node's message-shape check."""

from __future__ import annotations

import contextlib
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any

import numpy as np

from ..core.errors import echo
from .common import JOINT_STATE, BagError
from .progress import Progress

# ---- reading -----------------------------------------------------------------------------------


@dataclass
class Commands:
    """The recorded commands in bag time order (n rows)."""

    source: str
    topics: list[str]  # index 0: command topic, then the targets' (requests: what each is)
    topic: np.ndarray  # (n,) int8, index into topics
    log_ns: np.ndarray  # (n,) int64 bag receive time
    sec: np.ndarray  # (n,) int64 header stamp
    nanosec: np.ndarray  # (n,) int64
    key: np.ndarray  # (n,) int32 index into keys
    keys: list[tuple[str, ...]]  # the names of each distinct message shape
    npos: list[int]  # number of positions of each key
    values: np.ndarray  # every row's positions, one after the other (float64)
    start: np.ndarray  # (n + 1,) int64: row i's positions are values[start[i]:...]
    #: topic -> messages the bag's index counts but that could not be read (only with
    #: accept_missing; otherwise a missing message is an error)
    missing: dict[str, int] = field(default_factory=dict)
    #: velocities (rad/s, m/s): every row's one after the other (as values), row i's from
    #: vel_start[i] to vel_start[i + 1] (a row may have none; rows of one key may differ)
    vel_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    vel_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))
    #: each key's header.frame_id (empty: made without frames, every frame '')
    frames: list[str] = field(default_factory=list)
    #: messages read but not rows: without the mechanism's inputs (--state-completion)
    skipped: int = 0
    #: the joints the hardware publishes, which answers leave out as the node's answers to
    #: joint_states_in do (--state-completion: the inputs, and the <mimic> followers its
    #: messages name); None: the commands are ~/command's
    state_inputs: frozenset[str] | None = None
    #: the request each topic carries (as the node's status names it): 'command', 'target' or
    #: 'target_any_mode' (a target that may change the assembly mode)
    requests: tuple[str, ...] = ('command', 'target')

    def frame(self, key: int) -> str:
        """The header.frame_id of the rows of ``key``."""
        return self.frames[key] if key < len(self.frames) else ''

    @property
    def n(self) -> int:
        return int(self.topic.shape[0])

    def positions(self, a: int, b: int) -> np.ndarray:
        """(b - a, k) positions of rows a..b-1, which share one key (k positions each)."""
        k = self.npos[int(self.key[a])] if b > a else 0
        lo = int(self.start[a])
        return self.values[lo : lo + (b - a) * k].reshape(b - a, k)

    def velocity_counts(self, a: int, b: int) -> np.ndarray:
        """(b - a,) how many velocities rows a..b-1 carry."""
        if self.vel_start.size < self.n + 1:  # made without velocities
            return np.zeros(b - a, np.int64)
        return np.diff(self.vel_start[a : b + 1])

    def velocities(self, a: int, b: int, k: int) -> np.ndarray:
        """(b - a, k) velocities of rows a..b-1: those of the rows with k of them, NaN on the
        others."""
        out = np.full((b - a, k), np.nan)
        rows = np.flatnonzero(self.velocity_counts(a, b) == k) if k else np.zeros(0, np.intp)
        if rows.size:
            at = self.vel_start[a + rows][:, None] + np.arange(k)
            out[rows] = self.vel_values[at]
        return out

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


def open_reader(path: str):
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
    twice = _listed_twice(p) if p.is_dir() else None
    if twice is not None:
        raise BagError(
            f'input {path}: its metadata.yaml lists the storage file {twice} more than once (its '
            'messages would be read, and counted, twice)'
        )
    try:
        reader = Reader(p)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - every rosbags/sqlite/OS failure is "unreadable"
        raise BagError(
            f'input {path}: cannot open the bag ({exc_text(exc)}); it is truncated, '
            f'corrupt or not a rosbag2'
        ) from None
    return reader


def _listed_twice(folder: Path) -> str | None:
    """A storage file a bag folder's metadata.yaml lists more than once (rosbags reads it once
    per listing, by its name: `[dup.mcap, ./dup.mcap]` doubled every count, exit 0: an
    adversary), or None; a metadata.yaml that does not parse is rosbags' to refuse."""
    import yaml

    try:
        meta = yaml.safe_load((folder / 'metadata.yaml').read_text())
        files = meta['rosbag2_bagfile_information']['relative_file_paths']
    except Exception:  # noqa: BLE001 - any shape rosbags refuses itself, saying why
        return None
    if not isinstance(files, list):
        return None
    names = [PurePath(str(f)).name for f in files]
    twice = [n for n in dict.fromkeys(names) if names.count(n) > 1]
    if twice:
        return twice[0]
    seen: dict[tuple[int, int], str] = {}  # (two names of one file: a hard link)
    for name in names:
        try:
            st = os.stat(folder / name)
        except OSError:
            continue
        other = seen.setdefault((st.st_dev, st.st_ino), name)
        if other != name:
            return f'{other} (as {name} too)'
    return None


def exc_text(exc: BaseException) -> str:
    text = ' '.join(str(exc).split()) or type(exc).__name__
    return text if len(text) < 300 else text[:300] + '...'


#: The latest bag receive time read (ns since the epoch): int64, as rosbag2 stores it
MAX_LOG_NS = 2**63 - 1


def read_commands(
    path: str,
    topics: list[str],
    progress: Progress | None = None,
    accept_missing: bool = False,
    requests: tuple[str, ...] = ('command', 'target'),
) -> Commands:
    """Read the JointState messages of ``topics`` from a bag, in bag time order, decoded.

    What can be checked is: every message's receive time is an integer in [0, 2^63), and the
    messages read per topic are as many as the bag's index (metadata.yaml, the MCAP summary)
    counts; a message lost from the middle of a bag (a deleted row, a row whose topic no longer
    matches, a damaged record) is a BagError naming the topic, unless ``accept_missing``, when
    the shortfall per topic is kept in ``Commands.missing``. A .db3 file must pass SQLite's
    quick_check first."""
    progress = progress or Progress(False)
    _check_sqlite(path)
    reader = open_reader(path)
    try:
        conns = topic_connections(reader, path, [(t, JOINT_STATE) for t in topics])
        index = {c.id: k for k, group in enumerate(conns) for c in group}
        total = sum(c.msgcount for group in conns for c in group)
        progress.start('reading', total)
        raws: list[bytes] = []
        tops: list[int] = []
        stamps: list[int] = []
        read: dict[int, int] = {}
        try:
            for i, (conn, t, raw) in enumerate(reader.messages([c for g in conns for c in g])):
                check_log_time(path, i, conn.topic, t)
                raws.append(raw)
                tops.append(index[conn.id])
                stamps.append(t)
                read[conn.id] = read.get(conn.id, 0) + 1
                if not i & 0x3FFF:
                    progress.update(i)
        except BagError:
            raise
        except Exception as exc:  # noqa: BLE001 - truncated chunk, corrupt database, ...
            raise BagError(
                f'input {path}: cannot read message {len(raws) + 1} '
                f'({exc_text(exc)}); the bag is truncated or corrupt'
            ) from None
        progress.finish()
        missing = shortfall(path, conns, read, accept_missing)
    finally:
        with contextlib.suppress(Exception):
            reader.close()
    n = len(raws)
    log_ns = np.array(stamps, np.int64)
    order = np.argsort(log_ns, kind='stable')
    topic = np.asarray(tops, np.int8).reshape(n)
    if n and np.any(order != np.arange(n)):
        raws = [raws[i] for i in order]
        log_ns = log_ns[order]
        topic = topic[order]
    rates: list[tuple[np.ndarray, np.ndarray]] = []
    frames: list[str] = []
    try:
        sec, nanosec, key, keys, npos, values, start = decode_joint_states(
            raws, topic, topics, log_ns, rates, frames
        )
    except BagError as exc:  # a message that is no JointState: named with its bag
        raise BagError(f'input {path}: {exc}') from None
    counts = np.zeros(n, np.int64)
    for rows, vel in rates:
        counts[rows] = vel.shape[1]
    vel_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    vel_values = np.empty(int(vel_start[-1]))
    for rows, vel in rates:
        vel_values[vel_start[rows][:, None] + np.arange(vel.shape[1])] = vel
    return Commands(
        str(path),
        list(topics),
        topic,
        log_ns,
        sec,
        nanosec,
        key,
        keys,
        npos,
        values,
        start,
        missing,
        vel_values,
        vel_start,
        frames,
        requests=tuple(requests)[: len(topics)],
    )


def topic_connections(reader: Any, path: str, topics: list[tuple[str, str]]) -> list[list[Any]]:
    """The bag's connections of each (topic, message type), grouped per topic; BagError naming
    the bag and the topic for a topic the bag lacks or holds with another type."""
    try:
        available = {c.topic: c.msgtype for c in reader.connections}
    except Exception as exc:  # noqa: BLE001
        raise BagError(f'input {path}: cannot list topics ({exc_text(exc)})') from None
    conns = []
    for topic, want in topics:
        if topic not in available:
            listing = ', '.join(f'{t} ({m})' for t, m in sorted(available.items())) or 'none'
            raise BagError(
                f'input {path}: topic {topic} is not in the bag; topics in the bag: {listing}'
            )
        types = {c.msgtype for c in reader.connections if c.topic == topic}
        if types != {want}:
            raise BagError(
                f'input {path}: topic {topic} has type {", ".join(sorted(types))}; expected {want}'
            )
        conns.append([c for c in reader.connections if c.topic == topic])
    return conns


def check_log_time(path: str, i: int, topic: str, t: Any) -> None:
    """A receive time is an integer number of ns in [0, 2^63): BagError naming message i + 1."""
    if not (type(t) is int and 0 <= t <= MAX_LOG_NS):
        raise BagError(
            f'input {path}: message {i + 1} on {topic} has the receive time {echo(t)}; a bag '
            'time is an integer number of ns in [0, 2^63)'
        )


def shortfall(path: str, conns: list, read: dict[int, int], accept: bool) -> dict[str, int]:
    """Messages the bag's index counts per topic but that were not read: a BagError, or (with
    ``accept``) {topic: how many}. More read than counted is always an error (made up rows)."""
    missing: dict[str, int] = {}
    for group in conns:
        topic = group[0].topic
        counted = sum(int(c.msgcount) for c in group)
        got = sum(read.get(c.id, 0) for c in group)
        if got > counted or (got < counted and not accept):
            raise BagError(
                f'input {path}: topic {topic}: the bag counts {counted} message(s) but '
                f'{got} could be read; '
                + (
                    'it holds messages its index does not know'
                    if got > counted
                    else f'{counted - got} {"is" if counted - got == 1 else "are"} missing (a '
                    'damaged or edited bag; '
                    '--accept-missing reads it anyway and says how many are missing)'
                )
            )
        if got < counted:
            missing[topic] = counted - got
    return missing


def _check_sqlite(path: str) -> None:
    """SQLite's own consistency check on every .db3 file of the bag (read-only)."""
    import sqlite3

    p = Path(path)
    if not p.exists():  # (sqlite3 would call a missing file a database it cannot open)
        raise BagError(f'input {path}: no such file or folder')
    files = sorted(p.glob('*.db3')) if p.is_dir() else [p] if p.suffix.lower() == '.db3' else []
    for f in files:
        try:
            con = sqlite3.connect(f'file:{f}?mode=ro', uri=True)
            try:
                rows = con.execute('PRAGMA quick_check').fetchall()
            finally:
                con.close()
        except sqlite3.Error as exc:
            raise BagError(
                f'input {path}: {f.name} fails SQLite quick_check ({exc_text(exc)}); '
                'the bag is truncated or corrupt'
            ) from None
        if rows != [('ok',)]:
            first = rows[0][0] if rows else 'no answer'
            raise BagError(
                f'input {path}: {f.name} fails SQLite quick_check ({echo(first)}); '
                'the bag is corrupt'
            )


# -- JointState CDR decoding (vectorised over messages of one layout) ------------------------------
# By hand, not rosbags' deserialize_cdr: that refuses every JointState rclpy serialises (hence
# every recorded bag: slack bytes after the message, "size mismatch"; test_bag checks it) and
# costs ~18 us per message where this costs ~0.5 (100,000 messages, load ~1).


@dataclass
class _Layout:
    little: bool
    names: tuple[str, ...]
    frame: str  # header.frame_id
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
        # whole, as the node reads its requests' names (command_cdr: a NUL inside is part of
        # the name, where rclpy's deserialiser would end it there); bad UTF-8 replaced
        return (s[:-1] if s.endswith(b'\x00') else s).decode('utf-8', errors='replace')

    need(8)
    sec_off = pos
    pos += 8
    frame = string()
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
        return _Layout(little, names, frame, sec_off, arrays, np.asarray(struct_idx, np.intp), pos)
    raise found[0]


def decode_joint_states(
    raws: list[bytes],
    topic: np.ndarray,
    topics: list[str],
    log_ns: np.ndarray,
    rates: list[tuple[np.ndarray, np.ndarray]] | None = None,
    frames: list[str] | None = None,
):
    """Stamps, name sets and positions of CDR JointState messages.

    Messages of one byte length usually share one layout (same names, same frame_id): they are
    decoded together as an (m, L) byte array; the layout is parsed once from the first of them
    and checked on all (every structural byte equal), the rest get their own layout.
    The positions of all rows are returned one after the other (values, with row i's from
    start[i] to start[i + 1]): a malformed message with thousands of positions costs its own
    size, not that width for every row. ``rates``, when given, gets (rows, (m, k) velocities)
    of the rows that have velocities (a key is the names and the number of positions: rows
    with and without velocities share one). ``frames``, when given, gets each key's
    header.frame_id (a key is then the names, the number of positions and the frame).
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
            voff, vcount = lay.arrays[1]
            if vcount and rates is not None:
                vel = (
                    np.ascontiguousarray(block[:, voff : voff + 8 * vcount])
                    .view(e + 'f8')
                    .reshape(len(rows), vcount)
                    .astype(float)
                )
                rates.append((g_rows, vel))
            k = (lay.names, count, lay.frame if frames is not None else '')
            if k not in key_of:
                key_of[k] = len(keys)
                keys.append(lay.names)
                npos.append(count)
                if frames is not None:
                    frames.append(lay.frame)
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
