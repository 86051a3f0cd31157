"""Bad scene files and scene dictionaries get a SceneError naming the file, the key and the
value, never a raw traceback from deep inside: zero-length links, lists where a name is
expected, undecodable files, bools where a number or a sign is expected, exponent numbers, the
shortcuts' reference input for narrow assembly ranges, frame ids tf2 refuses.
"""

import math
import re

import numpy as np
import pytest
import scenes
from scenes import CONFIG

from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.analysis import fourbar_input_range
from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

FOUR_BAR = """\
points: {O2: [0, 0], A: [0.05, 0.0866], B: [0.2, 0.18], O4: [0.3, 0]}
links: {ground: [O2, O4], crank: [O2, A], coupler: [A, B], rocker: [O4, B]}
actuators: {crank: {type: angle, link: crank, pivot: O2}}
"""


def write(tmp_path, text, name='scene.yaml'):
    path = tmp_path / name
    path.write_text(text, encoding='utf-8')
    return path


def scene_error(tmp_path, text) -> str:
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as exc:
        Scene.from_yaml(path)
    msg = str(exc.value)
    assert str(path) in msg
    return msg


def general(**over):
    """The FOUR_BAR scene as a dict, with some keys replaced."""
    data = {
        'points': {'O2': [0, 0], 'A': [0.05, 0.0866], 'B': [0.2, 0.18], 'O4': [0.3, 0]},
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': ['A', 'B'],
            'rocker': ['O4', 'B'],
        },
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }
    data.update(over)
    return data


# ---- 1. zero-length links ------------------------------------------------------------------


def test_coincident_points_of_a_link_are_refused_at_load(tmp_path):
    text = FOUR_BAR.replace('B: [0.2, 0.18]', 'B: [0.05, 0.0866]')
    msg = scene_error(tmp_path, text)
    assert 'links.coupler' in msg and 'coincide' in msg and "['A', 'B']" in msg
    # through the CLI: one line, exit 2, no traceback
    rc = cli_main(['check', str(tmp_path / 'scene.yaml')])
    assert rc == 2


def test_scene_with_every_point_coincident_is_refused():
    pts = {k: [0.1, 0.2] for k in ('O2', 'A', 'B', 'O4')}
    with pytest.raises(
        SceneError,
        match=r'links\.ground: its first two points O2 and O4 '
        r'coincide',
    ):
        Scene.from_dict(general(points=pts))


def test_link_whose_first_two_points_coincide_is_refused():
    """The axis (first -> second point) defines a link's angle: a third, distinct point does
    not rescue a link whose first two coincide (it loaded, then the solver raised KeyError)."""
    data = general(
        points={
            'O2': [0, 0],
            'A': [0.05, 0.0866],
            'B': [0.05, 0.0866],
            'P': [0.1, 0.2],
            'O4': [0.3, 0],
        },
        links={
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': ['A', 'B', 'P'],
            'rocker': ['O4', 'B'],
        },
    )
    with pytest.raises(
        SceneError,
        match=r'links\.coupler: its first two points A and B '
        r"coincide.*axis.*\['A', 'B', 'P'\]",
    ):
        Scene.from_dict(data)
    # a distinct second point gives an axis, but A and B on one spot are still one point of
    # a degenerate plate (issue 18: it loaded silently)
    data['links']['coupler'] = ['A', 'P', 'B']
    with pytest.raises(
        SceneError, match=r'links\.coupler: its points A and B coincide in the reference pose'
    ):
        Scene.from_dict(data)
    data['points']['B'] = [0.06, 0.0866]
    Scene.from_dict(data)


@pytest.mark.parametrize(
    'edit, key, why',
    [
        (
            {'cylinders': {'Z1': {'from': 'O4', 'to': 'A', 'min': 0.5, 'max': 0.6}}},
            'cylinders.Z1',
            'm is below its minimum 0.5 by',
        ),
        (
            {
                'actuators': {
                    'crank': {
                        'type': 'angle',
                        'link': 'crank',
                        'pivot': 'O2',
                        'min': 0.2,
                        'max': 0.9,
                    }
                }
            },
            'actuators.crank',
            'is beyond its maximum 0.9',
        ),
    ],
)
def test_a_reference_pose_outside_its_own_limits_is_refused(edit, key, why):
    """Issue 18: a reference pose outside its own actuator limits loaded silently (and became
    the node's first state). Refused, naming the key, the value and the limit."""
    pts = {'O2': [0, 0], 'A': [0.05, 0.0866], 'B': [0.3, 0.2], 'O4': [0.3, 0]}  # crank 60 deg
    links = {
        'ground': ['O2', 'O4'],
        'crank': ['O2', 'A'],
        'coupler': ['A', 'B'],
        'rocker': ['O4', 'B'],
    }
    data = general(points=pts, links=links)
    if 'cylinders' in edit:  # a ram from O4 to A replaces the crank's angle as the input
        data = general(
            points={**pts, 'C': [0.0, 0.05]},
            links={**links, 'crank': ['O2', 'A', 'C']},
        )
        data.pop('actuators', None)
    data.update(edit)
    with pytest.raises(
        SceneError, match=re.escape(key) + r': the reference pose is outside'
    ) as err:
        Scene.from_dict(data)
    assert why in str(err.value)


def test_a_four_bar_input_outside_its_crank_limits_is_refused():
    data = {
        'four_bar': {
            'ground': 0.3,
            'crank': 0.1,
            'coupler': 0.25,
            'rocker': 0.2,
            'input': 2.0,
            'crank_limits': {'min': 0.0, 'max': 1.5},
        }
    }
    with pytest.raises(SceneError, match=r'four_bar\.input: the reference pose is outside'):
        Scene.from_dict(data)
    data['four_bar']['input'] = 1.0
    Scene.from_dict(data)


def test_shipped_scenes_still_load():
    stems = scenes.SHIPPED
    assert stems
    for stem in stems:
        Scene.from_yaml(CONFIG / f'{stem}.yaml')


# ---- 2. unhashable / wrong-type names and undecodable files ----------------------------------


def test_list_as_yaml_mapping_key_is_a_scene_error(tmp_path):
    msg = scene_error(tmp_path, FOUR_BAR + '? [a, b]\n: 1\n')
    assert 'line 4' in msg and "['a', 'b']" in msg
    msg = scene_error(tmp_path, FOUR_BAR + '? {a: 1}\n: 1\n')
    assert "{'a': 1}" in msg


@pytest.mark.parametrize(
    'text,key',
    [
        (FOUR_BAR.replace('coupler: [A, B]', 'coupler: [A, [B]]'), 'links.coupler'),
        (FOUR_BAR + 'outputs: [[B]]\n', 'outputs'),
        (FOUR_BAR.replace('link: crank,', 'link: [crank],'), 'actuators.crank.link'),
        (
            FOUR_BAR.replace('pivot: O2}', 'pivot: O2, relative_to: [ground]}'),
            'actuators.crank.relative_to',
        ),
        (FOUR_BAR.replace('pivot: O2}', 'pivot: [O2]}'), 'actuators.crank.pivot'),
        (FOUR_BAR.replace('pivot: O2}', 'pivot: O2, toward: {A: 1}}'), 'actuators.crank.toward'),
    ],
)
def test_list_where_a_name_is_expected_general_four_bar(tmp_path, text, key):
    msg = scene_error(tmp_path, text)
    assert f'{key}:' in msg and '(got ' in msg


SLIDER = """\
points: {O2: [0, 0], A: [0.05, 0.0866], B: [0.2, 0.0]}
links: {ground: [O2], crank: [O2, A], rod: [A, B], block: [B]}
sliders:
  - {name: s, guide: ground, slider: block, point: B, direction: 0.0}
actuators: {crank: {type: angle, link: crank, pivot: O2}}
"""

CYLINDER = """\
points: {O2: [0, 0], A: [1, 0], Z: [0, 1]}
links: {ground: [O2, Z], arm: [O2, A]}
cylinders: {C: {from: Z, to: A}}
"""


@pytest.mark.parametrize(
    'text,key',
    [
        (SLIDER.replace('guide: ground', 'guide: [ground]'), 'sliders.s.guide'),
        (SLIDER.replace('slider: block', 'slider: [block]'), 'sliders.s.slider'),
        (SLIDER.replace('point: B', 'point: [B]'), 'sliders.s.point'),
        (SLIDER.replace('direction: 0.0', 'direction: 0.0, origin: [[O2]]'), 'sliders.s.origin'),
        (
            SLIDER.replace(
                '{crank: {type: angle, link: crank, pivot: O2}}',
                '{push: {type: slide, joint: [s]}}',
            ),
            'actuators.push.joint',
        ),
        (CYLINDER.replace('from: Z', 'from: [O2]'), 'cylinders.C.from'),
        (CYLINDER.replace('to: A', 'to: {A: 1}'), 'cylinders.C.to'),
    ],
)
def test_list_where_a_name_is_expected_sliders_cylinders(tmp_path, text, key):
    msg = scene_error(tmp_path, text)
    assert f'{key}' in msg and '(got ' in msg


def test_valid_slider_and_cylinder_scenes_load(tmp_path):
    Scene.from_yaml(write(tmp_path, SLIDER, 's.yaml'))
    Scene.from_yaml(write(tmp_path, CYLINDER, 'c.yaml'))


def test_mixed_type_link_names_without_ground_is_a_scene_error():
    with pytest.raises(SceneError, match='must contain the ground link'):
        Scene.from_dict(general(links={1: ['O2'], 'crank': ['O2', 'A']}))


@pytest.mark.parametrize('pad', [0, 20000])
def test_non_utf8_scene_file_names_the_file(tmp_path, pad):
    path = tmp_path / 'latin1.yaml'
    # pad: past the YAML reader's first buffer, whose offsets are not the file's
    path.write_bytes(b'#\n' * pad + FOUR_BAR.encode() + b'# caf\xe9\n')
    with pytest.raises(SceneError) as exc:
        Scene.from_yaml(path)
    msg = str(exc.value)
    assert str(path) in msg and 'not UTF-8' in msg
    assert f"byte b'\\xe9' on line {pad + 4} cannot be decoded" in msg


# ---- 3. bools are not numbers or signs ------------------------------------------------------


@pytest.mark.parametrize(
    'form,spec',
    [
        ('four_bar', {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}),
        ('slider_crank', {'crank': 0.05, 'rod': 0.18, 'offset': 0.01}),
    ],
)
@pytest.mark.parametrize('flag', [True, False])
def test_bool_branch_is_refused(form, spec, flag):
    with pytest.raises(SceneError, match=rf'{form}\.branch: must be \+1 or -1.*got {flag}'):
        Scene.from_dict({form: dict(spec, branch=flag)})
    # the accepted spellings still work
    for ok in (1, -1, '+', '-', '+1', '-1', 1.0):
        Scene.from_dict({form: dict(spec, branch=ok)})


def test_bool_where_a_number_is_expected_is_refused():
    spec = {'ground': 0.3, 'crank': True, 'coupler': 0.25, 'rocker': 0.2}
    with pytest.raises(SceneError, match='four_bar.crank: must be a number'):
        Scene.from_dict({'four_bar': spec})


# ---- 4. exponent numbers without a dot -----------------------------------------------------


def test_exponent_forms_read_as_numbers(tmp_path):
    text = (
        'four_bar: {ground: 3e-1, crank: 1E-1, coupler: 2.5e-1, rocker: .2e0, '
        'input: 1.0471975511965976, ground_angle: -2e-3, crank_limits: {min: -1E+5, '
        'max: 1e5}}\n'
    )
    mech = Scene.from_yaml(write(tmp_path, text)).mechanism
    sc = mech.shortcut
    assert (sc['ground'], sc['crank'], sc['coupler'], sc['rocker']) == (0.3, 0.1, 0.25, 0.2)
    assert sc['ground_angle'] == -2e-3
    assert (mech.actuators['crank'].min, mech.actuators['crank'].max) == (-1e5, 1e5)


def test_exponent_resolver_leaves_other_scalars_alone(tmp_path):
    import yaml

    from linkage_ros.core.model.scene import UniqueKeyLoader

    data = yaml.load(
        '{a: 1e3, b: e3, c: 1e, d: 12, e: 1.5, f: E5x, g: -2e3}', Loader=UniqueKeyLoader
    )
    assert data == {
        'a': 1000.0,
        'b': 'e3',
        'c': '1e',
        'd': 12,
        'e': 1.5,
        'f': 'E5x',
        'g': -2000.0,
    }
    assert isinstance(data['d'], int)
    # an underscore is YAML 1.1's digit separator (1_0e2 = 1000): refused as a number that
    # reads as another value than it shows
    with pytest.raises(yaml.YAMLError, match="'1_0e2' is a YAML 1.1 number form"):
        yaml.load('h: 1_0e2', Loader=UniqueKeyLoader)
    # plain safe_load is not changed
    assert yaml.safe_load('a: 1e3') == {'a': '1e3'}


# ---- 5. the shortcut's reference input for narrow assembly ranges ----------------------------


def _reference_ok(mech):
    theta = math.atan2(mech.points['A'][1], mech.points['A'][0])
    assert Solver(mech).solve({'crank': theta}).success


@pytest.mark.parametrize(
    'spec',
    [
        {'crank': 1, 'rod': 1e-4, 'offset': 0.5},
        {'crank': 1, 'rod': 1e-4, 'offset': 0.5, 'direction': 2.0, 'branch': -1},
        {'crank': 1, 'rod': 1e-4, 'offset': -0.999},
    ],
)
def test_slider_crank_with_a_narrow_range_loads(spec):
    mech = Scene.from_dict({'slider_crank': spec}).mechanism
    a, b = mech.points['A'], mech.points['B']
    assert math.hypot(*(b - a)) == pytest.approx(spec['rod'], rel=1e-9)
    _reference_ok(mech)


@pytest.mark.parametrize('lengths', [(1, 0.999999, 1e-6, 1e-6), (1, 1, 1, 3)])
def test_four_bar_with_a_narrow_range_loads(lengths):
    spec = dict(zip(('ground', 'crank', 'coupler', 'rocker'), lengths))
    mech = Scene.from_dict({'four_bar': spec}).mechanism
    p = mech.points
    assert math.hypot(*(p['B'] - p['A'])) == pytest.approx(lengths[2], rel=1e-9)
    assert math.hypot(*(p['B'] - p['O4'])) == pytest.approx(lengths[3], rel=1e-9)


def test_unassemblable_shortcuts_are_still_refused():
    with pytest.raises(SceneError, match='do not assemble at any crank angle'):
        Scene.from_dict({'four_bar': {'ground': 1, 'crank': 1, 'coupler': 1, 'rocker': 3.1}})
    with pytest.raises(SceneError, match='do not assemble at any crank angle'):
        Scene.from_dict({'slider_crank': {'crank': 1, 'rod': 0.1, 'offset': 1.2}})


def test_reference_input_unchanged_where_the_grid_finds_one():
    # a double-rocker whose crank reaches 0.39..0.90 rad: the reference stays the grid angle
    # nearest 60 degrees (pi/3 - k 0.01 rad), not the middle of the range
    mech = Scene.from_dict(
        {'four_bar': {'ground': 0.5, 'crank': 0.4, 'coupler': 0.1, 'rocker': 0.3}}
    ).mechanism
    theta = math.atan2(mech.points['A'][1], mech.points['A'][0])
    hi = fourbar_input_range(0.5, 0.4, 0.1, 0.3)[1]
    steps = np.linspace(0.01, np.pi, 315)
    want = next(math.pi / 3 - s for s in steps if math.pi / 3 - s < hi)
    assert theta == pytest.approx(want, abs=1e-14)
    mech = Scene.from_dict({'slider_crank': {'crank': 0.1, 'rod': 0.3, 'offset': 0.02}}).mechanism
    assert math.atan2(mech.points['A'][1], mech.points['A'][0]) == pytest.approx(math.pi / 3)


# ---- 6. frame ids ---------------------------------------------------------------------------


@pytest.mark.parametrize('frame', ['/base_link', 'base link', ' base_link', 'base_link\t', ''])
def test_scene_frame_id_must_be_a_tf2_frame_name(frame):
    """tf2 refuses a leading '/' and whitespace; the node's frame_id parameter has the same rule,
    so a scene cannot bring such a frame in through the back door."""
    with pytest.raises(SceneError) as err:
        Scene.from_dict(
            {
                'name': 'fb',
                'frame_id': frame,
                'four_bar': {
                    'ground': 0.3,
                    'crank': 0.1,
                    'coupler': 0.25,
                    'rocker': 0.2,
                    'input': 1.0,
                },
            }
        )
    assert 'frame_id' in str(err.value)
    assert Scene.from_dict(
        {
            'name': 'fb',
            'frame_id': 'base_link',
            'four_bar': {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2, 'input': 1.0},
        }
    )
