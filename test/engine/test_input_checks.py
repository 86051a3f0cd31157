"""Bad input gets a clear error naming what was wrong, never a raw traceback from deep inside.

Scene files and dictionaries: SceneError naming the file, the key and the value. API arguments
of linkage_ros.core.analysis: ValueError naming the argument. The CLI: a usage error (exit 2)
or, for a huge sweep, output that starts at once instead of a list built first.
"""

import math
import re
import sys

import numpy as np
import pytest
import scenes
from scenes import CONFIG

from linkage_ros.cli import common as cli_common
from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.analysis import (
    fourbar_input_intervals,
    fourbar_input_range,
    fourbar_output_intervals,
    fourbar_output_range,
    fourbar_toggle_angles,
    transmission_angle,
)
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
        '{a: 1e3, b: e3, c: 1e, d: 12, e: 1.5, f: E5x, g: -2e3, h: 1_0e2}', Loader=UniqueKeyLoader
    )
    assert data == {
        'a': 1000.0,
        'b': 'e3',
        'c': '1e',
        'd': 12,
        'e': 1.5,
        'f': 'E5x',
        'g': -2000.0,
        'h': 1000.0,
    }
    assert isinstance(data['d'], int)
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


# ---- 6. analysis argument checks ------------------------------------------------------------

RANGE_FUNCS = [
    fourbar_input_range,
    fourbar_output_range,
    fourbar_input_intervals,
    fourbar_output_intervals,
    fourbar_toggle_angles,
]


@pytest.mark.parametrize('func', RANGE_FUNCS)
@pytest.mark.parametrize('pos', range(4))
@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf, -0.3, 0.0, None, 'x'])
def test_range_functions_refuse_bad_lengths(func, pos, bad):
    args = [0.3, 0.1, 0.25, 0.2]
    args[pos] = bad
    with pytest.raises(ValueError, match=f'l{pos + 1} must be'):
        func(*args)


@pytest.mark.parametrize('scale', [1e300, 2.0**1021, 1e-300])
def test_range_functions_are_scale_invariant_for_huge_and_tiny_lengths(scale):
    for lengths in [(0.3, 0.1, 0.25, 0.2), (0.5, 0.4, 0.25, 0.3), (4.0, 3.0, 1.5, 4.5)]:
        big = [v * scale for v in lengths]
        for func in RANGE_FUNCS:
            want, got = func(*lengths), func(*big)
            assert (
                np.allclose(np.asarray(got, float), np.asarray(want, float), rtol=1e-12, atol=1e-12)
                if want is not None
                else got is None
            )


def test_toggle_angles_of_equal_huge_lengths():
    assert fourbar_toggle_angles(1e308, 1e308, 1e308, 1e308) == fourbar_toggle_angles(1, 1, 1, 1)


def test_unassemblable_message_shows_lengths_as_given():
    with pytest.raises(ValueError, match=r'sides 1e\+308, 1e\+300, 1e\+300, 1e\+300'):
        fourbar_input_range(1e308, 1e300, 1e300, 1e300)
    with pytest.raises(ValueError, match=r'sides 10.0, 1.0, 1.0, 1.0'):
        fourbar_output_range(10, 1, 1, 1)


def test_transmission_angle_with_huge_lengths():
    want = transmission_angle(3, 1, 2.5, 2, 1.0)
    assert transmission_angle(3e200, 1e200, 2.5e200, 2e200, 1.0) == want
    assert transmission_angle(3e300, 1e300, 2.5e300, 2e300, 1.0) == want
    both = transmission_angle([3, 3e300], [1, 1e300], [2.5, 2.5e300], [2, 2e300], 1.0)
    assert np.all(both == want)


@pytest.mark.parametrize(
    'pos,bad',
    [
        (4, math.nan),
        (4, None),
        (4, [1.0, None]),
        (4, math.inf),
        (4, 'x'),
        (0, math.nan),
        (1, -1.0),
        (2, [1.0, math.inf]),
        (3, None),
        (2, 0.0),
    ],
)
def test_transmission_angle_refuses_bad_arguments(pos, bad):
    args = [3, 1, 2.5, 2, 1.0]
    args[pos] = bad
    name = ['l1', 'l2', 'l3', 'l4', 'theta2'][pos]
    with pytest.raises(ValueError, match=f'{name} must be'):
        transmission_angle(*args)


# ---- 7. huge sweeps start at once -----------------------------------------------------------


def test_sweep_range_values_are_lazy():
    name, values, readings = cli_common.parse_known('--set', 'crank=0:1:1000000000001', True)
    assert name == 'crank' and all(r.unit is None for r in readings)
    assert len(values) == 10**12 + 1
    assert values[0] == 0.0 and values[-1] == 1.0 and values[1] == 1e-12
    assert list(cli_common.parse_known('--set', 'crank=0:3:7', True)[1]) == [
        0.0,
        0.5,
        1.0,
        1.5,
        2.0,
        2.5,
        3.0,
    ]
    _, pts, _ = cli_common.parse_known('--target-point', 'P=0,0:1,2:3', True)
    assert list(pts) == [(0.0, 0.0), (0.5, 1.0), (1.0, 2.0)]


class _Stop(Exception):
    pass


class _FewLines:
    """stdout that stops the sweep after a few lines."""

    def __init__(self, limit):
        self.lines, self.limit = [], limit

    def write(self, text):
        self.lines.append(text)
        if sum(t.count('\n') for t in self.lines) >= self.limit:
            raise _Stop

    def flush(self):
        pass


def test_huge_sweep_starts_printing_at_once(monkeypatch):
    out = _FewLines(4)
    monkeypatch.setattr(sys, 'stdout', out)
    with pytest.raises(_Stop):
        cli_main(['sweep', 'four_bar', '--set', 'crank=0:1:1000000000'])
    text = ''.join(out.lines).splitlines()
    assert text[0].startswith('#\tcrank\tstatus')
    assert text[1].startswith('0\t0\tok') and text[2].startswith('1\t1e-09\tok')


def test_sweep_grid_is_lazy_and_first_axis_slowest():
    import itertools

    huge = cli_common.parse_known('--set', 'a=0:1:1000000000001', True)[1]
    head = list(itertools.islice(cli_common.command_grid([huge, [5.0, 6.0], [7.0]]), 3))
    assert head == [(0.0, 5.0, 7.0), (0.0, 6.0, 7.0), (1e-12, 5.0, 7.0)]
    small = [[1, 2], cli_common.parse_known('--set', 'b=0:1:3', True)[1]]
    assert list(cli_common.command_grid(small)) == list(itertools.product(*small))
    assert list(cli_common.command_grid([])) == [()]


def test_two_known_points_on_one_link_are_its_pose_and_more_knowns_are_refused():
    """The lecture moves the excavator bin by giving J and K: 3 values (its pose), solved as K
    and the bin's angle (test_point_pairs checks the positions); a known beyond that is refused
    with the count, saying what two points of one link give."""
    mech = Scene.from_yaml(scenes.CONFIG / 'excavator.yaml').mechanism
    from linkage_ros.core.errors import PlanError

    solver = Solver(mech, knowns=['point:K', 'point:J'])
    assert solver.plan_knowns == ['point:K', 'link:bucket'] and solver.knowns == [
        'point:K',
        'point:J',
    ]
    with pytest.raises(PlanError) as err:  # two points on different links: 4 values for 3 DOF
        Solver(mech, knowns=['point:K', 'point:A'])
    assert 'give 4 value(s)' in str(err.value) and 'two points of one link' not in str(err.value)
    with pytest.raises(PlanError) as err:  # the pose and one more value
        Solver(mech, knowns=['point:K', 'point:J', 'Z1'])
    assert 'give 4 value(s) (two points of one link give 3: its pose)' in str(err.value)
    with pytest.raises(PlanError, match='angle of a link twice'):
        Solver(mech, knowns=['point:K', 'point:J', 'link:bucket'])
    ref = Solver(mech).solve({'Z1': 1.5, 'Z2': 1.9, 'Z3': 1.4})
    r = solver.solve({'point:K': ref.points['K'], 'point:J': ref.points['J']})
    assert r.success
    for a in ('Z1', 'Z2', 'Z3'):
        assert r.inputs[a] == pytest.approx(ref.inputs[a], abs=1e-9)


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


def test_explicit_branch_signs_for_a_plan_without_branching_dyads_say_so():
    """The four-bar solved from its coupler angle places every link without a branch choice:
    explicit signs are then refused with a reason that says there is none to give (the message
    used to end in an empty list)."""
    from linkage_ros.core.errors import PlanError

    mech = Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml').mechanism
    assert not Solver(mech, knowns=['coupler']).plan.branch_steps
    with pytest.raises(PlanError) as err:
        Solver(mech, knowns=['coupler'], branch='+')
    assert str(err.value) == (
        "branch '+' has 1 sign(s) but this solve has no branching dyad (no sign to give)"
    )
    with pytest.raises(PlanError) as err:  # with dyads: they are listed
        Solver(mech, knowns=['crank'], branch='+-')
    assert '1 branching dyad(s): ' in str(err.value)


def test_the_node_refuses_a_dimension_given_twice():
    from linkage_ros.params import ConfigError, make_config

    with pytest.raises(ConfigError, match="'dimensions'.*given twice"):
        make_config({'dimensions': ['crank.O2-A=0.1', 'crank.O2-A=0.2']})


def test_a_huge_value_or_frame_is_not_echoed_whole():
    """Messages quote at most ECHO_CHARS of what they were given (a 10^5-character frame id or
    parameter value was echoed whole)."""
    from linkage_ros.core.errors import ECHO_CHARS
    from linkage_ros.params import ConfigError, make_config
    from linkage_ros.setting_checks import SETTING_ECHO_CHARS
    from linkage_ros.stamps import frame_error

    huge = 'x' * 100_000
    why = frame_error('target point', huge, 'base_link')
    assert why is not None and len(why) < 300 + ECHO_CHARS
    with pytest.raises(ConfigError) as err:
        make_config({'frame_id': huge + ' '})
    assert len(str(err.value)) < 400 + SETTING_ECHO_CHARS
