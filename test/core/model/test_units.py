"""One unit grammar (core.units) for scene files, the command line and the node: ``60deg``,
``0.5rad``, ``10mm``; a unit where another quantity (or none) is meant is refused naming the
key; a bare angle or limit span beyond a full turn (likely degrees) loads with a warning."""

from __future__ import annotations

import math
import subprocess
import sys
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st
from ros_harness import NodeProcess, random_domain_id

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.units import UnitError, parse_text

FOUR_BAR = {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}


def four_bar(**extra) -> Scene:
    return Scene.from_dict({'four_bar': {**FOUR_BAR, **extra}})


def crank_angle(scene: Scene) -> float:
    """The reference crank angle (rad), from the drawn points O2 -> A (ground along +x)."""
    (ox, oy), (ax, ay) = scene.mechanism.points['O2'], scene.mechanism.points['A']
    return math.atan2(ay - oy, ax - ox)


def test_degrees_load_in_yaml_as_radians(tmp_path):
    path = tmp_path / 'deg.yaml'
    path.write_text(
        'four_bar: {ground: 0.3, crank: 100mm, coupler: 25cm, rocker: 0.2m, input: 60deg,\n'
        '           crank_limits: {min: -10 deg, max: 120deg}}\n'
    )
    scene = Scene.from_yaml(path)
    assert crank_angle(scene) == pytest.approx(math.radians(60), abs=1e-12)
    crank = scene.mechanism.actuators['crank']
    assert crank.min == pytest.approx(math.radians(-10), abs=1e-15)
    assert crank.max == pytest.approx(math.radians(120), abs=1e-15)
    (ox, oy), (ax, ay) = scene.mechanism.points['O2'], scene.mechanism.points['A']
    assert math.hypot(ax - ox, ay - oy) == pytest.approx(0.1, rel=1e-12)
    assert scene.warnings == ()


def test_a_bare_angle_beyond_a_full_turn_warns():
    scene = four_bar(input=60)
    (warning,) = scene.warnings
    assert 'four_bar.input' in warning and '60deg' in warning
    assert four_bar(input=1.0).warnings == ()  # radians as meant: no warning


def test_a_limit_span_beyond_a_full_turn_warns():
    scene = four_bar(input=1.0, crank_limits={'min': 0, 'max': 120})
    (warning,) = scene.warnings
    assert 'four_bar.crank_limits' in warning and 'span 120 rad' in warning
    general = {
        'points': {'O': [0, 0], 'A': [1, 0]},
        'links': {'ground': ['O'], 'arm': ['O', 'A']},
        'actuators': {'t': {'type': 'angle', 'link': 'arm', 'pivot': 'O', 'min': -90, 'max': 90}},
    }
    (warning,) = Scene.from_dict(general).warnings
    assert 'actuators.t' in warning and '-90deg and 90deg' in warning


@pytest.mark.parametrize(
    ('extra', 'key', 'words'),
    [
        ({'crank': '60deg'}, 'four_bar.crank', "has a unit of angle ('deg')"),
        ({'input': '10mm'}, 'four_bar.input', "has a unit of length ('mm')"),
        ({'input': '60degree'}, 'four_bar.input', "unknown unit 'degree'"),
        ({'input': '60 DEG'}, 'four_bar.input', "did you mean 'deg'"),
        ({'input': '1.0'}, 'four_bar.input', 'a quoted number'),
        ({'crank_limits': {'min': '0mm'}}, 'four_bar.crank_limits.min', 'an angle (rad'),
    ],
)
def test_a_unit_not_meant_is_refused_naming_the_key(extra, key, words):
    with pytest.raises(SceneError) as err:
        four_bar(**extra)
    assert err.value.key == key and words in str(err.value), str(err.value)


def test_a_direction_vector_takes_no_unit():
    scene = {
        'points': {'O': [0, 0], 'A': [0.1, 0], 'B': [0.3, 0]},
        'links': {'ground': ['O'], 'crank': ['O', 'A'], 'rod': ['A', 'B'], 'block': ['B']},
        'sliders': [
            {
                'name': 's',
                'guide': 'ground',
                'slider': 'block',
                'point': 'B',
                'direction': ['1mm', 0],
            }
        ],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O'}},
    }
    with pytest.raises(SceneError) as err:
        Scene.from_dict(scene)
    assert err.value.key == 'sliders.s.direction[0]' and 'without a unit' in str(err.value)


@given(
    st.floats(-1e6, 1e6, allow_nan=False),
    st.sampled_from([('deg', math.radians), ('mm', lambda v: v / 1000), ('rad', float)]),
)
def test_text_with_a_unit_reads_in_si(value, unit_and_oracle):
    unit, oracle = unit_and_oracle
    assert parse_text(f'{value!r}{unit}').value == pytest.approx(oracle(value), rel=1e-15, abs=0)


@pytest.mark.parametrize('text', ['', 'deg', '1_0', '1e400', 'nan', '1.2.3', '5 m m'])
def test_text_that_is_not_a_finite_number_is_refused(text):
    with pytest.raises(UnitError):
        parse_text(text)


def linkage(*args):
    return subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', *args], capture_output=True, text=True, timeout=60
    )


def test_cli_sweep_in_bare_degrees_warns_on_stderr():
    proc = linkage('sweep', 'four_bar', '--set', 'crank=0:360:13')
    assert proc.returncode == 0, proc.stderr
    assert 'warning: --set crank = 360 is read as 360 rad' in proc.stderr
    assert '360deg' in proc.stderr
    quiet = linkage('sweep', 'four_bar', '--set', 'crank=0deg:360deg:13')
    assert quiet.returncode == 0 and 'warning' not in quiet.stderr, quiet.stderr


def test_cli_units_agree_with_the_scene_grammar():
    deg = linkage('solve', 'four_bar', '--set', 'crank=45deg', '--json')
    rad = linkage('solve', 'four_bar', '--set', f'crank={math.radians(45)!r}', '--json')
    assert deg.returncode == 0 and deg.stdout == rad.stdout, deg.stderr
    mm = linkage('solve', 'four_bar', '--set', 'crank=1', '--dimension', 'crank.O2-A=45mm')
    m = linkage('solve', 'four_bar', '--set', 'crank=1', '--dimension', 'crank.O2-A=0.045')
    assert mm.returncode == 0 and mm.stdout == m.stdout, mm.stderr
    bad = linkage('solve', 'four_bar', '--set', 'crank=10mm')
    assert bad.returncode == 2 and "--set crank: 'mm' is a unit of length" in bad.stderr
    bad = linkage('solve', 'four_bar', '--set', 'crank=1', '--dimension', 'crank.O2-A=5deg')
    assert bad.returncode == 2 and "crank.O2-A: '5deg'" in bad.stderr, bad.stderr


def test_node_warns_at_startup_about_a_bare_angle_in_degrees(tmp_path):
    scene = tmp_path / 'deg.yaml'
    scene.write_text('four_bar: {ground: 0.3, crank: 0.1, coupler: 0.25, rocker: 0.2, input: 60}\n')
    proc = NodeProcess(tmp_path / 'node', random_domain_id(), {'scene': str(scene)}).start()
    try:
        t_end = time.monotonic() + 30
        while 'listening on' not in proc.output() and proc.alive() and time.monotonic() < t_end:
            time.sleep(0.05)
        out = proc.output()
        (line,) = [ln for ln in out.splitlines() if 'four_bar.input = 60' in ln]
        assert 'WARN' in line and '60deg' in line, out
    finally:
        proc.stop()
