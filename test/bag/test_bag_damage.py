"""`linkage bag` on damaged bags and interrupted writes: JointState decoded by hand as recorded,
outputs written whole or not at all, a lost message, a bad receive time or a corrupt page or
chunk an error naming the bag."""

from __future__ import annotations

import numpy as np
import pytest
from test_bag import (  # noqa: F401
    JS,
    TS,
    joint_state,
    make_input,
    rclpy_bytes,
    read_csv,
    run_bag,
    write_bag,
)

from linkage_ros import bag

# ---- why JointState is decoded by hand --------------------------------------------------------


@pytest.mark.parametrize('names', [['crank'], ['Z1', 'Z2', 'Z3'], ['ab']])
def test_recorded_joint_states_need_the_hand_decoder(names):
    """rosbags' own CDR deserialiser refuses what rclpy (hence `ros2 bag record`) writes: the
    Fast-CDR size estimate leaves slack bytes after the message ("size mismatch"). The bag tool
    decodes JointState itself (vectorised over messages of one layout); when this test fails
    because rosbags reads these bytes, the hand decoder can give way to it."""
    from rosbags.serde import SerdeError

    positions = [0.25 * (k + 1) for k in range(len(names))]
    raw = bytes(rclpy_bytes(names, positions, 7, 8))
    with pytest.raises(SerdeError, match='size mismatch'):
        TS.deserialize_cdr(raw, JS)
    sec, nanosec, key, keys, _npos, values, _start = bag.reading.decode_joint_states(
        [raw], np.zeros(1, np.int8), ['/cmd'], np.zeros(1, np.int64)
    )
    assert (int(sec[0]), int(nanosec[0])) == (7, 8)
    assert keys[int(key[0])] == tuple(names) and values.tolist() == positions


# ---- outputs are written whole or not at all -------------------------------------------------


def test_a_write_cut_short_leaves_no_partial_output(tmp_path, scene):
    """Under `ulimit -f 100` (a full disk alike) the CSV write fails half-way: exit 2 with the
    reason, and nothing under the output's name (it used to leave a 100 kB file cut mid-row,
    which looks like a result); the temporary file beside it is gone too. An output that
    existed before is left as it was."""
    import resource
    import subprocess
    import sys

    msgs = [
        ('/cmd', 10**9 + i * 10**6, joint_state(['crank'], [0.001 * i], sec=1, nanosec=i * 10**6))
        for i in range(4000)
    ]
    src = make_input(tmp_path, 'mcap', msgs)
    out = tmp_path / 'out.csv'

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (100 * 1024, 100 * 1024))

    cmd = [sys.executable, '-m', 'linkage_ros.bag', str(src), '--scene', str(scene)]
    cmd += ['--command-topic', '/cmd', '--out', str(out), '--no-progress']
    for before in (None, b'an earlier result\n'):
        if before is not None:
            out.write_bytes(before)
        proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit, timeout=120)
        assert proc.returncode == 2, proc.stderr[-2000:]
        assert 'File too large' in proc.stderr and 'Traceback' not in proc.stderr, proc.stderr
        if before is None:
            assert not out.exists()
        else:
            assert out.read_bytes() == before
        assert not list(tmp_path.glob('.out.csv.*')), list(tmp_path.iterdir())
    # without the limit the same run writes the whole file
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = out.read_text().splitlines()
    assert len(rows) == 1 + len(msgs) and rows[-1].count(',') == rows[0].count(',')


# ---- a damaged bag fails loudly ----------------------------------------------------------------


def _sqlite_bag(tmp_path, n=200):
    msgs = [
        ('/cmd', 10**9 + i * 10**7, joint_state(['crank'], [0.01 * i], sec=1 + i // 100))
        for i in range(n)
    ]
    folder = tmp_path / 'sq'
    write_bag(folder, 'sqlite3', msgs)
    return folder, next(folder.glob('*.db3'))


def _edit(db, sql):
    import sqlite3

    con = sqlite3.connect(db)
    try:
        con.execute(sql)
        con.commit()
    finally:
        con.close()


@pytest.mark.parametrize(
    'damage',
    [
        'DELETE FROM messages WHERE id = 100',  # a message lost from the middle
        'UPDATE messages SET topic_id = 99 WHERE id = 100',  # its topic no longer matches
    ],
)
def test_a_message_lost_from_the_middle_is_an_error(tmp_path, scene, capsys, damage):
    """metadata.yaml counts 200 messages on /cmd; one is gone. This used to write 199 rows and
    exit 0. Now: exit 2 naming the bag, the topic and both counts; --accept-missing reads it
    and the summary says what is missing."""
    folder, db = _sqlite_bag(tmp_path)
    _edit(db, damage)
    out = tmp_path / 'o.csv'
    common = [folder, '--scene', scene, '--command-topic', '/cmd', '--out', out, '--no-progress']
    code, cap = run_bag(common, capsys)
    assert code == 2 and not out.exists()
    (line,) = cap.err.strip().splitlines()
    assert str(folder) in line and 'topic /cmd' in line, line
    assert 'counts 200 message(s) but 199 could be read' in line and '1 is missing' in line
    code, cap = run_bag([*common, '--accept-missing'], capsys)
    assert code == 0, cap.err
    # (it read 1 fewer than the index counts: said as it was, not as '1 more')
    assert '/cmd: 199 (MISSING 1 of the 200 the bag counts: --accept-missing)' in cap.out
    assert len(read_csv(out)) == 199


@pytest.mark.parametrize(
    ('stamp', 'shown'), [(-5, '-5'), (1.5, '1.5'), ("'x'", "'x'"), (1e30, '1e+30')]
)
def test_a_receive_time_out_of_range_is_an_error(tmp_path, scene, capsys, stamp, shown):
    """A negative receive time used to be written as a row; a non-integer one or one beyond
    64 bits ended in a ValueError / OverflowError traceback. Now: exit 2, one line naming the
    message and the value."""
    folder, db = _sqlite_bag(tmp_path, n=20)
    _edit(db, f'UPDATE messages SET timestamp = {stamp} WHERE id = 7')
    code, cap = run_bag(
        [folder, '--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'o.csv'],
        capsys,
    )
    assert code == 2
    (line,) = cap.err.strip().splitlines()
    assert 'on /cmd has the receive time ' + shown in line and 'in [0, 2^63)' in line, line


def test_a_corrupt_sqlite_page_fails_quick_check(tmp_path, scene, capsys):
    folder, db = _sqlite_bag(tmp_path, n=2000)
    raw = bytearray(db.read_bytes())
    page = 4096
    assert len(raw) > 4 * page
    for k in range(2, len(raw) // page):  # every page but the first: b-tree page headers
        if raw[k * page] in (0x02, 0x05, 0x0A, 0x0D):  # an index or table b-tree page
            raw[k * page + 3 : k * page + 8] = b'\xff' * 5  # cell count, content start
    db.write_bytes(bytes(raw))
    code, cap = run_bag(
        [folder, '--scene', scene, '--command-topic', '/cmd', '--out', tmp_path / 'o.csv'],
        capsys,
    )
    assert code == 2, cap.out[-500:]
    (line,) = cap.err.strip().splitlines()
    assert str(folder) in line and 'quick_check' in line and 'corrupt' in line, line


@pytest.mark.parametrize(
    'name', ['crank\x00junk', 'crank\x00', '\x00crank', 'cr\x00\x00', 'cr\u00e9nk', 'crank' * 40]
)
def test_names_decode_as_the_node_reads_them(name):
    """One engine, one answer: a name with a NUL in it is read whole by the node's ~/command
    reader (command_cdr: `crank\x00x` is an unknown name, not `crank`), and the bag cut it at
    the NUL as rclpy's deserialiser does. The oracle is the node's reader; the name as the
    message holds it (rosbags' own serialisation) is the same."""
    from linkage_ros.command_cdr import read_joint_state

    raw = bytes(TS.serialize_cdr(joint_state([name], [0.5], sec=3), JS))
    fields = read_joint_state(raw)
    assert fields is not None
    node_reads = fields.names[0]
    assert node_reads == name
    _s, _ns, key, keys, _np, _v, _st = bag.reading.decode_joint_states(
        [raw], np.zeros(1, np.int8), ['/cmd'], np.zeros(1, np.int64)
    )
    assert keys[int(key[0])] == (node_reads,)


def _listed_twice(folder, names) -> str:
    """Rewrite ``folder``'s metadata.yaml to list ``names`` as its storage files, every count
    doubled to match (a lie about one file read twice); returns the text it had."""
    import yaml

    meta_path = folder / 'metadata.yaml'
    original = meta_path.read_text()
    meta = yaml.safe_load(original)
    info = meta['rosbag2_bagfile_information']
    info['relative_file_paths'] = list(names)
    info['message_count'] *= 2
    for t in info['topics_with_message_count']:
        t['message_count'] *= 2
    meta_path.write_text(yaml.safe_dump(meta))
    return original


def test_a_storage_file_listed_twice_is_an_error(tmp_path, scene, capsys):
    """A metadata.yaml listing its one storage file twice (`[x.db3, ./x.db3]`, every count
    doubled to match) was read twice by rosbags: 400 rows from 200 commands, exit 0 (an
    adversary). Refused, naming the file; with the listing fixed the bag reads 200."""
    folder, db = _sqlite_bag(tmp_path)
    original = _listed_twice(folder, [db.name, f'./{db.name}'])
    out = tmp_path / 'o.csv'
    common = [folder, '--scene', scene, '--command-topic', '/cmd', '--out', out, '--no-progress']
    code, cap = run_bag(common, capsys)
    assert code == 2 and not out.exists(), cap.err
    assert f'lists the storage file {db.name} more than once' in cap.err, cap.err
    (folder / 'metadata.yaml').write_text(original)
    code, cap = run_bag(common, capsys)
    assert code == 0 and len(read_csv(out)) == 200, cap.err


def test_a_storage_file_listed_under_two_names_of_one_file_is_an_error(tmp_path, scene, capsys):
    """The same file twice under two names (a hard link) passed the name check: 400 rows from
    200 commands (an adversary). Refused, naming both."""
    import os

    folder, db = _sqlite_bag(tmp_path)
    twin = folder / f'twin{db.suffix}'
    os.link(db, twin)
    _listed_twice(folder, [db.name, twin.name])
    out = tmp_path / 'o.csv'
    common = [folder, '--scene', scene, '--command-topic', '/cmd', '--out', out, '--no-progress']
    code, cap = run_bag(common, capsys)
    assert code == 2 and not out.exists(), cap.err
    assert f'{db.name} (as {twin.name} too) more than once' in cap.err, cap.err
