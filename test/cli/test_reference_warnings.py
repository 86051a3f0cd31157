"""A reference pose drawn at a toggle or folded flat is warned about whatever the plan kind
(issue 27: only closed-form plans were). Peaucellier's inversor drawn folded flat: the crank
turned until |O P| = l - s (the cosine rule, written here), where A and B meet on the line O-P-Q
and the plan is hybrid (its A and B dyads at their toggles, the Q loop singular)."""

from __future__ import annotations

import json
import math

import pytest
import yaml
from scenes import CONFIG, raw

from linkage_ros.cli.parser import main as cli_main

R, L, S = 0.045, 0.15, 0.10  # config/peaucellier.yaml: crank, long links, rhombus side (m)


def folded_flat() -> dict:
    """config/peaucellier.yaml redrawn with |O P| = l - s: crank at acos((l - s)^2 / 2r^2 - 1)
    about OP = (r, 0); A = B at |O A| = l on the ray O-P; Q at |O Q| = l + s on it."""
    theta = math.acos((L - S) ** 2 / (2 * R * R) - 1.0)
    px, py = R + R * math.cos(theta), R * math.sin(theta)
    unit = (px / (L - S), py / (L - S))
    scene = raw('peaucellier')
    at = {'A': L, 'B': L, 'Q': L + S}
    scene['points'].update({'P': [px, py]} | {k: [d * unit[0], d * unit[1]] for k, d in at.items()})
    act = scene['actuators']['crank']
    act.pop('min'), act.pop('max')  # the fold is beyond the shipped limits
    return scene


@pytest.mark.parametrize('method', [[], ['--solver', 'newton']])
def test_peaucellier_folded_flat_is_warned(tmp_path, capsys, method):
    path = tmp_path / 'folded.yaml'
    path.write_text(yaml.safe_dump(folded_flat()), encoding='utf-8')
    assert cli_main(['check', str(path), '--json', *method]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['plan']['mode'] == ('newton' if method else 'hybrid')
    assert report['warnings'], report['plan']
    assert all('reference pose is at' in w for w in report['warnings'])
    if not method:  # the hybrid plan's dyads through A and B are named
        named = ' '.join(report['warnings'])
        assert 'A from circles' in named and 'B from circles' in named


@pytest.mark.parametrize('scene', ['peaucellier', 'four_bar', 'excavator', 'quick_return'])
def test_a_pose_clear_of_toggles_gets_no_warning_with_newton(capsys, scene):
    assert cli_main(['check', str(CONFIG / f'{scene}.yaml'), '--json', '--solver', 'newton']) == 0
    assert json.loads(capsys.readouterr().out)['warnings'] == []
