"""A 0-DOF structure that cannot assemble with its stated dimensions (issue 27) is a solve
refusal like any other: the JSON refusal with the true miss in m and of the length scale, exit
status 1; `linkage check` warns with the same miss and `linkage urdf` writes no drawing that is
not the structure's shape. Oracle: the triangle inequality, written here (two bars of lengths
r1 + r2 < d between pivots d apart miss by d - r1 - r2)."""

from __future__ import annotations

import json
import re

import pytest
import yaml

from linkage_ros.cli.parser import main as cli_main

D, R1, R2 = 0.4, 0.1, 0.2  # pivots apart, stated bar lengths (m): 0.1 + 0.2 < 0.4
DRAWN_P = [0.15, 0.2]  # the drawing closes; the stated lengths do not


@pytest.fixture
def truss(tmp_path):
    path = tmp_path / 'truss.yaml'
    scene = {
        'name': 'truss',
        'points': {'O1': [0.0, 0.0], 'O2': [D, 0.0], 'P': DRAWN_P},
        'links': {'ground': ['O1', 'O2'], 'left': ['O1', 'P'], 'right': ['O2', 'P']},
        'dimensions': {'left.O1-P': R1, 'right.O2-P': R2},
    }
    path.write_text(yaml.safe_dump(scene), encoding='utf-8')
    return path


def _miss(reason: str) -> tuple[float, float]:
    m = re.search(r'misses by ([0-9.eE+-]+) m \(([0-9.eE+-]+) of the length scale\)', reason)
    assert m, reason
    return float(m.group(1)), float(m.group(2))


def test_solve_refuses_with_the_true_miss(truss, capsys):
    code = cli_main(['solve', str(truss), '--json'])
    out = json.loads(capsys.readouterr().out)
    assert code == 1  # a refusal, not a scene error (2)
    assert out['status'] == 'error'
    miss, of_scale = _miss(out['reason'])
    want = D - (R1 + R2)
    assert miss == pytest.approx(want, rel=1e-6)
    assert of_scale == pytest.approx(want / D, rel=1e-6)  # the drawing's longest link: D
    assert 'actuator' not in out['reason']


def test_check_warns_and_urdf_refuses(truss, capsys):
    assert cli_main(['check', str(truss), '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    (warning,) = [w for w in report['warnings'] if 'does not assemble' in w]
    assert _miss(warning)[0] == pytest.approx(D - (R1 + R2), rel=1e-6)
    assert cli_main(['urdf', str(truss)]) == 2
    err = capsys.readouterr().err
    assert 'does not assemble' in err and 'misses by' in err


def test_a_bad_dimension_name_is_still_a_scene_error(truss, capsys):
    scene = yaml.safe_load(truss.read_text())
    scene['dimensions'] = {'left.O1-Q': R1}
    truss.write_text(yaml.safe_dump(scene), encoding='utf-8')
    assert cli_main(['solve', str(truss), '--json']) == 2
    assert 'O1-Q' in capsys.readouterr().err
