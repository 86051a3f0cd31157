"""Tests of which bags a fleet run takes and what it names their outputs (linkage_ros/bag/
fleet_inputs.py), for inputs an outside review found mishandled: bags whose outputs would
overwrite each other, a bag folder given as ``.``, one bag given both as its folder and as its
storage file. Oracles: the bags' own folder names and message counts (what they were written
with), and the outputs each bag must own alone."""

from __future__ import annotations

import shutil

import pytest
from test_fleet import COMMON, run, summary_rows, write_fleet_bag

from linkage_ros import bag
from linkage_ros.bag.fleet_inputs import find_bags


@pytest.fixture(scope='module')
def one_bag(tmp_path_factory):
    """An MCAP bag folder ``run`` of 30 commands and one recorded trajectory."""
    path = tmp_path_factory.mktemp('names') / 'run'
    write_fleet_bag(path, 'mcap', 30, 0.2, trajs=[[[0.1 * k] for k in range(4)]])
    return path


def test_a_bag_whose_outputs_would_overwrite_anothers_is_refused_before_any_work(
    one_bag, tmp_path, capsys
):
    """Bags x and x.trajectories: x's trajectories went to x.trajectories.csv, which the other
    bag's command table then replaced (exit 0, both manifests listing it: --resume took x as
    complete). Only two bags of one name were refused."""
    rec = tmp_path / 'rec'
    shutil.copytree(one_bag, rec / 'x')
    shutil.copytree(one_bag, rec / 'x.trajectories')
    out = tmp_path / 'out'
    code, cap = run([rec, *COMMON, '--out-dir', out, '--jobs', 1], capsys)
    assert code == 2, cap.err
    assert 'two bags would write the same output x.trajectories.csv' in cap.err, cap.err
    assert not out.exists()
    # a bag's result bag folder (x.mcap/) holding another bag's outputs (x.mcap/y.*)
    shutil.rmtree(rec / 'x.trajectories')
    shutil.copytree(one_bag, rec / 'x.mcap' / 'y')
    with pytest.raises(bag.BagError, match=r"one bag's outputs would lie in x\.mcap: "):
        find_bags([str(rec)])
    # names that share a beginning only are kept apart
    shutil.rmtree(rec / 'x.mcap')
    shutil.copytree(one_bag, rec / 'x_trajectories')
    assert [t.name for t in find_bags([str(rec)])] == ['x', 'x_trajectories']


def test_a_bag_folder_given_as_dot_is_named_after_the_folder(
    one_bag, tmp_path, capsys, monkeypatch
):
    """`cd run && linkage bag . --out-dir ../out` wrote ../out/.csv and .done.json (hidden
    files) and a summary row with an empty bag name."""
    monkeypatch.chdir(one_bag)
    out = tmp_path / 'out'
    code, cap = run(['.', *COMMON, '--out-dir', out, '--jobs', 1], capsys)
    assert code == 0, cap.err
    assert sorted(p.name for p in out.iterdir()) == [
        'run.csv',
        'run.done.json',
        'run.trajectories.csv',
        'summary.csv',
        'summary.json',
    ]
    rows, _ = summary_rows(out)
    assert list(rows) == ['run'] and rows['run']['messages'] == str(30 + 1)
    # and as '..' (from a folder inside it)
    shutil.copytree(one_bag, tmp_path / 'copy')
    (tmp_path / 'copy' / 'inner').mkdir()
    monkeypatch.chdir(tmp_path / 'copy' / 'inner')
    assert [t.name for t in find_bags(['..'])] == ['copy']


def test_a_bag_given_as_its_folder_and_its_storage_file_is_analysed_once(one_bag, tmp_path, capsys):
    """`linkage bag a a/a.mcap` (or 'rec/**/*.mcap' with rec/) analysed the bag twice and
    summed its messages twice in the totals."""
    rec = tmp_path / 'rec'
    shutil.copytree(one_bag, rec / 'a')
    (storage,) = (rec / 'a').glob('*.mcap')
    out = tmp_path / 'out'
    code, cap = run([rec / 'a', storage, *COMMON, '--out-dir', out, '--jobs', 1], capsys)
    assert code == 0, cap.err
    rows, doc = summary_rows(out)
    assert list(rows) == ['a'] and doc['totals']['messages'] == 30 + 1  # (as written)
    # the other way round, a pattern's match first: the first given names it
    tasks = find_bags([str(rec / '**' / '*.mcap'), str(rec)])
    assert [(t.name, t.source) for t in tasks] == [('a/' + storage.stem, str(storage))]
    # one file of a split bag is a part of it: beside the whole bag it is refused
    shutil.copy(storage, rec / 'a' / 'part_1.mcap')
    with pytest.raises(bag.BagError, match='is one storage file of the bag .*also given'):
        find_bags([str(rec / 'a'), str(rec / 'a' / 'part_1.mcap')])
    assert len(find_bags([str(rec / '**' / '*.mcap')])) == 2  # (its parts alone: two bags)


def test_a_pattern_that_climbs_out_of_its_folder_writes_nothing_outside_out_dir(
    one_bag, tmp_path, capsys, monkeypatch
):
    """`'bags/*/../../names/*.mcap'` named its match `run/../../names/b`: its CSV replaced
    names/b.csv, a file of the user's beside the input, and --out-dir got an empty folder
    (exit 0; an adversary). Refused before any work, naming the input; every file as it was."""
    monkeypatch.chdir(tmp_path)
    shutil.copytree(one_bag, tmp_path / 'bags' / 'run')
    (tmp_path / 'names').mkdir()
    storage = next((one_bag).glob('*.mcap'))
    shutil.copy(storage, tmp_path / 'names' / 'b.mcap')
    (tmp_path / 'names' / 'b.csv').write_text('mine\n')
    code, cap = run(['bags/*/../../names/*.mcap', *COMMON, '--out-dir', 'out'], capsys)
    assert code == 2, cap.err
    assert "input bags/run/../../names/b.mcap: its outputs would be named 'run/../../names/b'" in (
        cap.err
    ), cap.err
    assert (tmp_path / 'names' / 'b.csv').read_text() == 'mine\n'
    assert sorted(p.name for p in (tmp_path / 'names').iterdir()) == ['b.csv', 'b.mcap']
    assert not (tmp_path / 'out').exists()
    # a pattern whose .. stays within its leading folders names its matches as before
    code, cap = run(['bags/../names/*.mcap', *COMMON, '--out-dir', 'out2', '--jobs', 1], capsys)
    assert code == 0, cap.err
    assert (tmp_path / 'out2' / 'b.csv').is_file()


def test_a_bag_whose_output_name_is_too_long_is_refused_before_any_work(one_bag, tmp_path, capsys):
    """One bag named with 240 characters ended a whole fleet in an OSError traceback (File name
    too long, at its trajectories' CSV), leaving an empty --out-dir (an adversary); and a
    246-character --out of one bag named the trajectories' CSV in a traceback. Both are
    refused before any work, naming the bag or the output and the length (with the staging
    name each output is written under first)."""
    rec = tmp_path / 'rec'
    shutil.copytree(one_bag, rec / ('b' * 240))
    shutil.copytree(one_bag, rec / 'ok')
    out = tmp_path / 'out'
    code, cap = run([rec, *COMMON, '--out-dir', out, '--jobs', 1], capsys)
    assert code == 2, cap.err
    assert f'bag {rec / ("b" * 240)}: its output {"b" * 240}.csv: its name' in cap.err, cap.err
    assert 'is 244 bytes, beyond the 238 its file system takes' in cap.err, cap.err
    assert not out.exists()
    single = tmp_path / ('a' * 246 + '.csv')
    code, cap = run([one_bag, *COMMON, '--out', single], capsys)
    assert code == 2 and 'is 250 bytes' in cap.err and 'Traceback' not in cap.err, cap.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ['rec']


def test_a_pattern_of_any_depth_does_not_follow_symlinked_folders(one_bag, tmp_path, capsys):
    """`'L/**/*.mcap'` over a folder holding a link to its parent (`up -> ..`) and one to
    itself searched without end (glob.glob's ** follows symlinks; an adversary): it finds the
    one bag, as a folder input's search does, and names it from the pattern's folder."""
    tree = tmp_path / 'L'
    shutil.copytree(one_bag, tree / 'a' / 'run')
    (tree / 'a' / 'up').symlink_to('..')
    (tree / 'self').symlink_to(tree)
    (tree / '.hidden').mkdir()
    shutil.copytree(one_bag, tree / '.hidden' / 'run')
    assert [t.name for t in find_bags([f'{tree}/**/*.mcap'])] == ['a/run/run']
    assert [t.name for t in find_bags([f'{tree}/.hidden/**/*.mcap'])] == ['run/run']


def test_names_that_a_spreadsheet_reads_as_formulas_are_text_in_the_csvs(tmp_path, capsys):
    """A bag named `@SUM(A1)` and a command topic `=1+2` reached summary.csv and the bag's
    CSV as cells a spreadsheet runs as formulas (an adversary). The CSVs quote them as text
    (a leading '); summary.json keeps the names as they are."""
    import csv as csvlib
    import json

    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin
    from test_bag import joint_state
    from test_fleet import JS, SCENE, T0, TS

    rec = tmp_path / 'rec'
    rec.mkdir()
    with Writer(rec / '@SUM(A1)', version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection('=1+2', JS, typestore=TS)
        for i in range(5):
            t = T0 + i * 10**7
            w.write(
                c, t, TS.serialize_cdr(joint_state(['crank'], [0.1 * i], *divmod(t, 10**9)), JS)
            )
    out = tmp_path / 'out'
    code, cap = run(
        [rec, '--scene', SCENE, '--command-topic', '=1+2', '--out-dir', out, '--jobs', 1], capsys
    )
    assert code == 0, cap.err
    with open(out / 'summary.csv', newline='') as fh:
        (row,) = list(csvlib.DictReader(fh))
    assert row['bag'] == "'@SUM(A1)", row
    assert json.loads((out / 'summary.json').read_text())['bags'][0]['bag'] == '@SUM(A1)'
    with open(out / '@SUM(A1).csv', newline='') as fh:
        rows = list(csvlib.DictReader(fh))
    assert len(rows) == 5 and {r['topic'] for r in rows} == {"'=1+2"}, rows[0]


def test_an_output_through_a_symlink_to_the_recording_is_refused(one_bag, tmp_path, capsys):
    """`--out out.csv` where out.csv links to the bag's own storage file replaced the
    recording with the CSV, exit 0 (an adversary): refused, naming the input."""
    rec = tmp_path / 'run'
    shutil.copytree(one_bag, rec)
    storage = next(rec.glob('*.mcap'))
    before = storage.read_bytes()
    (tmp_path / 'out.csv').symlink_to(storage)
    code, cap = run([rec, *COMMON, '--out', tmp_path / 'out.csv'], capsys)
    assert code == 2 and f'is the input {storage}' in cap.err, cap.err
    assert storage.read_bytes() == before


def test_a_pattern_part_with_a_double_star_inside_it_matches_as_glob_did(one_bag, tmp_path):
    """`'tree/**/r1**/*.mcap'` was pathlib's ValueError ('**' can only be an entire path
    component): a part holding ** is read as glob.glob reads it, as *."""
    shutil.copytree(one_bag, tmp_path / 'tree' / 'a' / 'r1')
    assert [t.name for t in find_bags([f'{tmp_path}/tree/**/r1**/*.mcap'])] == ['a/r1/run']
