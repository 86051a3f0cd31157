"""Messages in the user's terms (issue 26, item 8): a joint on a command says which request
takes it; a value half a turn from its limits is below the minimum it was written under; a
slider without a guide says what is missing; a link that cannot be redrawn blames the dimension
given; `linkage check` shows where every point of the reference pose is."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest
from scenes import CONFIG

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.model.limits import limit_violation
from linkage_ros.engine import Engine, EngineSettings

GENERAL_FOUR_BAR = {
    'points': {
        'O2': [0.0, 0.0],
        'A': [0.05, 0.0866025404],
        'B': [0.273679454, 0.198260508],
        'O4': [0.3, 0.0],
        'P': [0.160047787, 0.229043702],
    },
    'links': {'ground': ['O2', 'O4'], 'crank': ['O2', 'A'], 'coupler': ['A', 'B', 'P']},
    'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}},
}
GENERAL_FOUR_BAR['links']['rocker'] = ['O4', 'B']  # type: ignore[index]


@pytest.mark.parametrize('name', ['B', 'coupler', 'P'])
def test_a_joint_link_or_point_on_a_command_names_the_request_that_takes_it(name):
    mech = Scene.from_yaml(CONFIG / 'four_bar.yaml').mechanism
    engine = Engine(mech, EngineSettings())
    result = engine.command({name: 1.0})
    assert not result.success
    assert f"['{name}'] not an actuator" in result.reason and '~/target' in result.reason
    assert "actuators: ['crank']" in result.reason
    other = engine.command({'wrench': 1.0})  # not a name of the mechanism: the solver's words
    assert not other.success and 'unknown name' in other.reason


@pytest.mark.parametrize('lo, hi', [(0.0, math.pi), (-1.0, 2.0), (0.5, 0.5 + math.pi)])
def test_a_value_half_a_turn_from_the_middle_is_below_the_minimum_it_is_written_under(lo, hi):
    middle = 0.5 * (lo + hi)
    below = middle - math.pi  # as far from lo (going down) as from hi (going up), on the circle
    said = limit_violation('crank', below, lo, hi, 'rad', True)
    assert said is not None and f'below its minimum {lo:g}' in said, said
    above = middle + math.pi
    said = limit_violation('crank', above, lo, hi, 'rad', True)
    assert said is not None and f'beyond its maximum {hi:g}' in said, said


def test_a_slider_without_a_guide_says_what_is_missing():
    scene = {
        'points': {'O': [0, 0], 'A': [0.1, 0], 'B': [0.3, 0]},
        'links': {'ground': ['O'], 'crank': ['O', 'A'], 'rod': ['A', 'B'], 'block': ['B']},
        'sliders': [{'name': 's', 'slider': 'block', 'point': 'B'}],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O'}},
    }
    with pytest.raises(SceneError) as err:
        Scene.from_dict(scene)
    assert err.value.key == 'sliders.s.guide' and 'is missing' in str(err.value)
    assert 'got None' not in str(err.value)


@pytest.mark.parametrize('given', ['coupler.B-P', 'coupler.A-P'])
def test_a_link_that_is_no_triangle_blames_the_dimension_given(given):
    with pytest.raises(SceneError) as err:
        Scene.from_dict(GENERAL_FOUR_BAR, dimensions={given: 1.0})
    text = str(err.value)
    assert err.value.key == f'dimensions.{given}' and 'no triangle' in text, text
    assert err.value.value == 1.0


def test_check_shows_the_reference_pose_of_every_point(tmp_path):
    """A point placed by distances (3 from O, 4 from Q, 5 apart: a 3-4-5 triangle) shows on the
    side asked for, in text and JSON."""
    scene = tmp_path / 'tri.yaml'
    scene.write_text(
        'points: {O: [0, 0], Q: [5, 0], C: {distances: {O: 3, Q: 4}, side: right}}\n'
        'links: {ground: [O, Q], a: [O, C], b: [Q, C]}\n'
    )
    want = {'O': (0.0, 0.0), 'Q': (5.0, 0.0), 'C': (9 / 5, -12 / 5)}  # x = 3^2/5, y = -3*4/5

    def linkage(*args):
        proc = subprocess.run(
            [sys.executable, '-m', 'linkage_ros.cli', 'check', str(scene), *args],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert proc.returncode == 0, proc.stderr
        return proc.stdout

    points = json.loads(linkage('--json'))['points']
    assert set(points) == set(want)
    for name, (x, y) in want.items():
        assert points[name] == pytest.approx([x, y], abs=1e-12), name
    text = linkage()
    assert 'points (reference pose)' in text
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith('points (reference pose)'))
    rows = {ln.split()[0]: ln.split()[1:] for ln in lines[start + 1 : start + 1 + len(want)]}
    assert set(rows) == set(want), text
    for name, xy in want.items():
        assert [float(v) for v in rows[name]] == pytest.approx(xy, abs=1e-8), name
