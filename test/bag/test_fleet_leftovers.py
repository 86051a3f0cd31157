"""What a fleet run leaves behind and takes in (linkage_ros/bag/fleet_run.py, fleet_inputs.py,
run_outputs.py), for faults an outside bag analyst found. Oracles: FLEET.md's rules ("a
damaged bag ... fails alone: its row says why, it leaves no output"; result bags are named
NAME.mcap beside NAME.done.json) and the files each run was given."""

from __future__ import annotations

import resource
import shutil
import subprocess
import sys
from pathlib import Path

from test_fleet import COMMON, fleet, run, summary_rows  # noqa: F401 (fleet: a fixture)


def _files_and_folders(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob('*')}


def test_a_failed_bag_leaves_no_empty_folder(fleet, tmp_path, capsys):  # noqa: F811
    """A damaged bag deep in the input tree left its output folders (site/truck7/) behind,
    empty; a folder another bag wrote to stays."""
    root, _ = fleet
    rec = tmp_path / 'rec'
    shutil.copytree(root / 'day2' / 'damaged', rec / 'site' / 'truck7' / 'run')
    shutil.copytree(root / 'day2' / 'damaged', rec / 'site' / 'shared' / 'bad')
    shutil.copytree(root / 'day1' / 'a', rec / 'site' / 'shared' / 'good')
    out = tmp_path / 'out'
    (out / 'site' / 'mine').mkdir(parents=True)  # folders the user made: they stay, empty
    (out / 'site' / 'truck7' / 'x').mkdir(parents=True)  # (or not; their own)
    (out / 'site' / 'truck7' / 'x').rmdir()
    code, cap = run([rec, *COMMON, '--out-dir', out, '--jobs', 1], capsys)
    assert code == 3, cap.err
    rows, _ = summary_rows(out)
    assert rows['site/truck7/run']['status'] == 'failed'
    assert rows['site/shared/bad']['status'] == 'failed'
    assert rows['site/shared/good']['status'] == 'ok'
    assert _files_and_folders(out) == {
        'summary.csv',
        'summary.json',
        'site',
        'site/mine',
        'site/truck7',
        'site/shared',
        'site/shared/good.csv',
        'site/shared/good.done.json',
    }
    # and the folders a run made for its failed bag alone go
    out2 = tmp_path / 'out2'
    code, cap = run([rec, *COMMON, '--out-dir', out2, '--jobs', 1], capsys)
    assert code == 3 and not (out2 / 'site' / 'truck7').exists(), cap.err


def test_a_write_failure_names_the_output(fleet, tmp_path):  # noqa: F811
    """Under `ulimit -f` (a full disk alike) a fleet bag's row said 'cannot write an output
    (File too large)': which of its outputs was left for the analyst to guess. It names the
    path, as a single bag's --out does; the other bag finishes."""
    root, _ = fleet
    rec = tmp_path / 'rec'
    shutil.copytree(root / 'day1' / 'a', rec / 'a')
    out = tmp_path / 'out'

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (20 * 1024, 20 * 1024))

    cmd = [sys.executable, '-m', 'linkage_ros.bag', str(rec), *map(str, COMMON)]
    cmd += ['--out-dir', str(out), '--format', 'csv', '--jobs', '1', '--no-progress']
    proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit, timeout=300)
    assert proc.returncode == 3, proc.stderr[-2000:]
    rows, _ = summary_rows(out)
    reason = rows['a']['reason']
    assert rows['a']['status'] == 'failed'
    assert f'output {out / "a.csv"}: cannot write (File too large)' in reason, reason
    assert not (out / 'a.csv').exists()


def test_an_earlier_runs_result_bags_are_not_read_as_recordings(fleet, tmp_path, capsys):  # noqa: F811
    """A second run over a folder holding the first run's --out-dir read its result bags
    (analysis/a.mcap, beside analysis/a.done.json) as recordings: they failed ('topic /cmd is
    not in the bag') and the run exited 3. They are left out with a note."""
    root, _ = fleet
    rec = tmp_path / 'rec'
    shutil.copytree(root / 'day1' / 'a', rec / 'a')
    first = [rec, *COMMON, '--format', 'mcap', '--format', 'csv', '--jobs', 1]
    code, cap = run([*first, '--out-dir', rec / 'analysis'], capsys)
    assert code == 0, cap.err
    assert (rec / 'analysis' / 'a.mcap' / 'metadata.yaml').is_file()
    code, cap = run([*first, '--out-dir', rec / 'analysis2'], capsys)
    assert code == 0, cap.err
    rows, doc = summary_rows(rec / 'analysis2')
    assert list(rows) == ['a'] and doc['totals']['bags'] == 1
    assert 'note: 1 result bag(s) of an earlier run left out' in cap.err, cap.err
    assert str(rec / 'analysis' / 'a.mcap') in cap.err
    assert not (rec / 'analysis2' / 'analysis').exists()
    # the same through a glob pattern (it matches the result bag's folder and its file)
    pattern = str(rec / '**' / '*.mcap')
    code, cap = run([pattern, rec / 'a', *COMMON, '--out-dir', tmp_path / 'p'], capsys)
    assert code == 0 and 'note: 2 result bag(s) of an earlier run' in cap.err, cap.err  # both runs'
    rows, _ = summary_rows(tmp_path / 'p')
    assert list(rows) == ['a']
