"""`linkage sweep`: ranges and grids of commands and targets, one line per command (errors
too), and the CSV it writes.

main(argv) runs in-process (capsys); the CSV that must survive its reader stopping early is
written by the installed console script.
"""

import math
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import CR, DR, freudenstein_residual, loads, run, toggles


def test_sweep_line_count_includes_error_lines(capsys, scenes):
    rc, out, err = run(capsys, 'sweep', scenes['double_rocker'], '--set', 'crank=0:3:7', '--json')
    assert rc == 0  # the sweep ran: errors are lines
    lines = [loads(x) for x in out.splitlines()]
    assert len(lines) == 7
    lo, hi = toggles(*DR.values())
    for i, (line, theta) in enumerate(zip(lines, [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])):
        assert line['index'] == i and line['command'] == {'crank': pytest.approx(theta)}
        assert line['status'] == ('ok' if lo < theta < hi else 'error')
        if line['status'] == 'error':
            assert line['reason']
    assert '7 command(s), 1 ok, 6 error(s)' in err
    # table form: same number of rows (+ a header), errors carry their reason
    rc, out, _ = run(capsys, 'sweep', scenes['double_rocker'], '--set', 'crank=0:3:7')
    rows = out.splitlines()
    assert rc == 0 and len(rows) == 8 and rows[0].startswith('#')
    assert sum('\terror\t' in r for r in rows) == 6
    # --strict: any error line makes the exit status 1
    rc, _, _ = run(capsys, 'sweep', scenes['double_rocker'], '--set', 'crank=0:3:7', '--strict')
    assert rc == 1


def test_sweep_grid_of_two_ranges_first_range_slowest(capsys, scenes):
    rc, out, _ = run(
        capsys, 'sweep', scenes['five_bar'], '--set', 'a1=0.5:1.5:3', '--set', 'a2=1:2:4', '--json'
    )
    assert rc == 0
    lines = [loads(x) for x in out.splitlines()]
    assert len(lines) == 12
    expect = [(a1, a2) for a1 in (0.5, 1.0, 1.5) for a2 in (1.0, 4 / 3, 5 / 3, 2.0)]
    for line, (a1, a2) in zip(lines, expect):
        assert line['command']['a1'] == pytest.approx(a1)
        assert line['command']['a2'] == pytest.approx(a2)
        assert line['status'] == 'ok'
        assert line['inputs']['a1'] == pytest.approx(a1)
        assert line['inputs']['a2'] == pytest.approx(a2)
    # the grid axis order follows the command line
    rc, out, _ = run(
        capsys, 'sweep', scenes['five_bar'], '--set', 'a2=1:2:4', '--set', 'a1=0.5:1.5:3', '--json'
    )
    first = [loads(x)['command'] for x in out.splitlines()[:3]]
    assert [c['a2'] for c in first] == [1.0, 1.0, 1.0]


def test_inverse_sweep_over_target_range(capsys, scenes):
    rc, out, _ = run(capsys, 'sweep', scenes['four_bar'], '--target', 'rocker=1.8:2.0:3', '--json')
    assert rc == 0
    lines = [loads(x) for x in out.splitlines()]
    assert len(lines) == 3
    l1, l2, l3, l4 = CR.values()
    for line in lines:
        t4 = line['command']['rocker']
        assert line['status'] == 'ok' and line['targets'] == {'rocker': t4}
        assert abs(freudenstein_residual(line['inputs']['crank'], t4, l1, l2, l3, l4)) < 1e-12


def test_a_refused_sweep_row_keeps_its_commanded_input(capsys, tmp_path):
    """A double-rocker swept past its limits: the refused rows' CSV keeps the crank value it
    was commanded (as linkage bag's CSV does; it was empty, so which command failed showed only
    by its index), the joints empty; the answered rows are as before."""
    import csv as _csv

    out = tmp_path / 'dr.csv'
    rc, _, err = run(
        capsys, 'sweep', 'four_bar_grashof_double_rocker', '--set', 'crank=0:2:5', '--csv', out
    )
    assert rc == 0 and '3 ok, 2 error(s)' in err, err
    rows = list(_csv.DictReader(out.open()))
    assert [r['status'] for r in rows] == ['error', 'ok', 'ok', 'ok', 'error']
    assert [float(r['input.crank']) for r in rows] == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert rows[0]['joint.O4'] == rows[4]['joint.O4'] == ''
    assert 'minimum' in rows[0]['reason'] and 'maximum' in rows[4]['reason']


def test_sweep_csv_is_the_actuator_trajectory_of_a_path(capsys, tmp_path):
    """`linkage sweep --target-point L=... --target bucket=... --csv FILE`: the CSV's actuator
    values, solved forward, put the lip L on the path (what a controller would be fed)."""
    import csv as _csv

    from linkage_ros.core.model import Scene
    from linkage_ros.core.solver import Solver
    from linkage_ros.resources import scene_path

    out = tmp_path / 'throws.csv'
    rc, _, err = run(
        capsys,
        'sweep',
        'excavator',
        '--target-point',
        'L=2.0,-0.2:2.3,-0.4:7',
        '--target',
        'bucket=-0.9',
        '--csv',
        out,
    )
    assert rc == 0 and '7 ok' in err
    rows = list(_csv.DictReader(out.open()))
    mech = Scene.from_yaml(scene_path('excavator')).mechanism
    fwd = Solver(mech)
    assert [r['index'] for r in rows] == [str(i) for i in range(7)]
    for k, row in enumerate(rows):
        assert row['status'] == 'ok'
        r = fwd.solve({a: float(row[f'input.{a}']) for a in mech.actuators})
        want = (2.0 + 0.3 * k / 6, -0.2 - 0.2 * k / 6)
        assert math.dist(r.points['L'], want) < 1e-9 * mech.length_scale
        for j in mech.joint_names:
            assert abs(math.remainder(float(row[f'joint.{j}']) - r.joints[j], 2 * math.pi)) < 1e-9
    rc, _, err = run(
        capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv', tmp_path / 'no' / 'x.csv'
    )
    assert rc == 2 and 'folder' in err and 'does not exist' in err
    assert '0\t0' not in capsys.readouterr().out  # refused before any solve


def test_sweep_csv_is_written_whole_when_the_reader_stops_early(scenes, tmp_path):
    """`linkage sweep ... --csv FILE | head -1`: the reader stopping ends the table, not the
    sweep: the CSV is written with every row (it was lost, with exit 0 and no word)."""
    exe = Path(sys.executable).parent / 'linkage'
    out = tmp_path / 'p.csv'
    cmd = [str(exe), 'sweep', scenes['four_bar'], '--set', 'crank=0:6:5000', '--csv', str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()  # as `| head -1` does
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    assert first.startswith(b'#\tcrank') and '5000 command(s)' in err, err
    with out.open() as fh:
        assert sum(1 for _ in fh) == 5001  # the header and every row
