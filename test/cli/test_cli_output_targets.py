"""Where a command's output file goes when the path is not a plain new file (an adversary's
findings): a FIFO, a symlink, a folder, the command's own input. Each output used to be
written beside the target and renamed onto it, which replaced a FIFO (its reader got nothing),
a symlink (the link itself), a device (as root: /dev/full became a CSV) and the scene file a
`--csv` or `-o` named again; a folder gave a traceback. Oracles: the file types before and
after, the CSV's own rows (one per grid point), the scene file's bytes."""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

from cli_helpers import run
from scenes import CONFIG


def test_a_fifo_is_written_in_place_for_its_reader(tmp_path, capsys):
    fifo = tmp_path / 'ff'
    os.mkfifo(fifo)
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()), daemon=True)
    reader.start()
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', fifo)
    reader.join(timeout=60)
    assert rc == 0, err
    assert stat.S_ISFIFO(fifo.lstat().st_mode)  # still the pipe
    assert got, 'the reader got nothing'
    rows = got[0].splitlines()
    assert rows[0].startswith('index,status') and len(rows) == 4, got


def test_a_symlink_is_followed_and_kept(tmp_path, capsys):
    link, real = tmp_path / 'link.csv', tmp_path / 'real.csv'
    link.symlink_to('real.csv')
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', link)
    assert rc == 0, err
    assert link.is_symlink() and os.readlink(link) == 'real.csv'
    assert len(real.read_text().splitlines()) == 4
    assert sorted(p.name for p in tmp_path.iterdir()) == ['link.csv', 'real.csv']


def test_a_folder_is_refused_before_any_work(tmp_path, capsys):
    rc, _, err = run(capsys, 'range', 'four_bar', '--point', 'P', '--plot', tmp_path)
    assert rc == 2 and f'--plot {tmp_path}: {tmp_path} is a folder' in err, err
    assert list(tmp_path.iterdir()) == []


def test_the_commands_own_scene_file_is_not_replaced(tmp_path, capsys):
    scene = tmp_path / 's.yaml'
    scene.write_bytes((CONFIG / 'four_bar.yaml').read_bytes())
    before = scene.read_bytes()
    for argv, said in (
        (['sweep', scene, '--set', 'crank=0:1:2', '--csv', scene], f'--csv {scene}: is the input'),
        (['urdf', scene, '-o', scene], f'cannot write {scene}: is the input'),
        (['range', scene, '--point', 'P', '--plot', scene], f'--plot {scene}: is the input'),
    ):
        rc, _, err = run(capsys, *argv)
        assert rc == 2 and said in err, (argv, err)
        assert scene.read_bytes() == before
    # (through another name of the same file too)
    other = tmp_path / 'other.yaml'
    other.symlink_to(scene)
    rc, _, err = run(capsys, 'urdf', scene, '-o', other)
    assert rc == 2 and 'is the input' in err, err
    assert scene.read_bytes() == before and Path(other).is_symlink()


def test_a_name_longer_than_the_file_system_takes_is_refused_before_any_work(tmp_path, capsys):
    """A 300-character --csv (or -o, --plot) was an OSError traceback (File name too long),
    exit 1: refused as a usage error naming its length (an adversary)."""
    long = tmp_path / ('a' * 300)
    for argv in (
        ['sweep', 'four_bar', '--set', 'crank=0:1:2', '--csv', f'{long}.csv'],
        ['urdf', 'four_bar', '-o', f'{long}.urdf'],
        ['range', 'four_bar', '--point', 'P', '--plot', f'{long}.png'],
    ):
        rc, _, err = run(capsys, *argv)
        assert rc == 2 and 'bytes, beyond the 238 its file system takes' in err, (argv, err)
    assert list(tmp_path.iterdir()) == []


def test_a_replaced_file_keeps_its_permissions_and_a_link_loop_is_refused(tmp_path, capsys):
    """Through a symlink to a 600 file the CSV came back 644 (its staging file's mode), and a
    link loop (a -> b -> a) was replaced by a file where a shell reports ELOOP (an adversary)."""
    private, link = tmp_path / 'priv.csv', tmp_path / 'l.csv'
    private.write_text('s\n')
    private.chmod(0o600)
    link.symlink_to('priv.csv')
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', link)
    assert rc == 0, err
    assert stat.S_IMODE(private.stat().st_mode) == 0o600
    assert len(private.read_text().splitlines()) == 4
    a, b = tmp_path / 'a', tmp_path / 'b'
    a.symlink_to('b')
    b.symlink_to('a')
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', a)
    assert rc == 2 and f'{a} is a symlink loop' in err, err
    assert a.is_symlink() and b.is_symlink()


def test_a_name_too_long_with_its_staging_name_is_refused_before_any_work(tmp_path, capsys):
    """240 bytes fit a file system's 255 but not with the staging name written first
    (.NAME.PID.partial): refused only after the work (an adversary). Before it now; one
    byte short of the room is written."""
    from linkage_ros.outputs import STAGING_EXTRA

    room = 255 - STAGING_EXTRA
    too = tmp_path / ('a' * (room - 3) + '.csv')  # room + 1 bytes
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', too)
    assert rc == 2 and 'with the staging name written first' in err, err
    fits = tmp_path / ('a' * (room - 4) + '.csv')
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', fits)
    assert rc == 0 and fits.is_file(), err


def test_a_count_beyond_the_largest_index_is_refused_for_csv_without_a_traceback(tmp_path, capsys):
    rc, _, err = run(
        capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:99999999999999999999999', '--csv',
        tmp_path / 'x.csv',
    )  # fmt: skip
    assert rc == 2 and '99,999,999,999,999,999,999,999 grid points' in err, err
