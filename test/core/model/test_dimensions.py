"""Dimensions stated by name (issue 18): a link's lengths and a slider's offset given in the
scene's ``dimensions`` key, with ``--dimension`` or through the API, used exactly; the drawing
then only chooses the assembly mode.

Oracles: the four-bar at 50 digits (test/oracles.py, written apart from the core) with the new
length, a scene drawn with that length, and a Jansen leg drawn from its lengths by the two-circle
construction with the crank 15 -> 16."""

from __future__ import annotations

import contextlib
import json
import math

import numpy as np
import oracles
import pytest
import scenes

from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.params import load_engine, make_config


def four_bar_drawn(lengths, theta, branch=1, scale=1.0, coupler=(0.6, 0.5)):
    """A general-form four-bar drawn from the 50-digit oracle at crank angle theta."""
    l1, l2, l3, l4 = (v * scale for v in lengths)
    o = oracles.fourbar(l1, l2, l3, l4, theta, branch, coupler_point=(coupler[0] * l3, coupler[1]))
    assert o['ok']
    pts = {k: [float(v) for v in o[k]] for k in ('O2', 'A', 'B', 'O4', 'P')}
    return {
        'name': 'fb',
        'points': pts,
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': ['A', 'B', 'P'],
            'rocker': ['O4', 'B'],
        },
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }


def points_at(mech, thetas):
    s = Solver(mech, knowns=['crank'], outputs=list(mech.points), branch='reference')
    out = []
    for t in thetas:
        r = s.solve({'crank': float(t)})
        assert r.success, r.reason
        out.append({p: np.array(r.points[p]) for p in mech.points})
    return out


LENGTHS = (0.3, 0.1, 0.25, 0.2)


@pytest.mark.parametrize('scale', [1e-6, 1.0, 1e6])
@pytest.mark.parametrize('branch', [1, -1])
def test_crank_override_equals_the_oracle_and_the_scene_drawn_with_it(scale, branch):
    theta0 = 1.0
    drawn = four_bar_drawn(LENGTHS, theta0, branch, scale)
    new = 0.12 * scale
    mech = Scene.from_dict(drawn, dimensions={'crank.O2-A': new}).mechanism
    # the stated length is the one used: exactly, not re-read from coordinates
    assert mech.dimensions[('crank', 'O2', 'A')] == new
    assert mech.stated == {'crank.O2-A': new}
    redrawn = Scene.from_dict(
        four_bar_drawn((0.3, 0.12, 0.25, 0.2), theta0, branch, scale)
    ).mechanism
    thetas = np.linspace(-0.6, 2.6, 17)
    got, want = points_at(mech, thetas), points_at(redrawn, thetas)
    for t, g, w in zip(thetas, got, want):
        o = oracles.fourbar(
            0.3 * scale,
            new,
            0.25 * scale,
            0.2 * scale,
            t,
            branch,
            coupler_point=(0.6 * 0.25 * scale, 0.5),
        )
        for p in ('A', 'B', 'P'):
            assert np.max(np.abs(g[p] - w[p])) <= 1e-12 * scale, (t, p)
            assert oracles.point_error(g[p], o[p]) <= 1e-12 * scale, (t, p)
        assert abs(math.hypot(*g['A']) - new) <= 4e-16 * new


def test_ternary_link_sides_override_and_reference_mode_kept():
    drawn = four_bar_drawn(LENGTHS, 1.0, -1)
    dims = {'coupler.A-B': 0.27, 'coupler.A-P': 0.2, 'coupler.B-P': 0.12}
    mech = Scene.from_dict(drawn, dimensions=dims).mechanism
    ref = mech.points
    for name, want in dims.items():
        _, pair = name.split('.')
        p, q = pair.split('-')
        assert abs(float(np.hypot(*(ref[p] - ref[q]))) - want) <= 1e-15
    # the crank angle is held at its drawn value and the drawn mode (-) kept: B is where the
    # 50-digit construction puts it with the new coupler on branch -1
    o = oracles.fourbar(0.3, 0.1, 0.27, 0.2, 1.0, -1)
    assert oracles.point_error(ref['B'], o['B']) <= 1e-14

    # P on the side of A -> B it is drawn on
    def side(pts):
        return oracles.cross(np.subtract(pts['B'], pts['A']), np.subtract(pts['P'], pts['A']))

    assert np.sign(float(side(ref))) == np.sign(float(side(drawn['points'])))


def jansen(crank: float) -> dict:
    """A leg with Theo Jansen's lengths (his 'holy numbers'), drawn from them by the two-circle
    construction at crank angle 0.5 rad, in a mode that runs a full crank turn."""
    a, b, c, d, e, f, g, h, i, j, k, l = (
        38,
        41.5,
        39.3,
        40.1,
        55.8,
        39.4,
        36.7,
        65.7,
        49,
        50,
        61.9,
        7.8,
    )

    def dist(p, rp, q, rq, side):
        return {'distances': {p: rp, q: rq}, 'side': side}

    return {
        'name': 'jansen',
        'points': {
            'O': [0.0, 0.0],
            'Bp': [-a, -l],
            'A': [crank * math.cos(0.5), crank * math.sin(0.5)],
            'C': dist('Bp', b, 'A', j, 'right'),
            'D': dist('Bp', e, 'C', d, 'right'),
            'E': dist('Bp', c, 'A', k, 'right'),
            'F': dist('D', f, 'E', g, 'left'),
            'G': dist('F', h, 'E', i, 'right'),  # the foot, lowest
        },
        'links': {
            'ground': ['O', 'Bp'],
            'crank': ['O', 'A'],
            'upper': ['A', 'C'],
            'rocker': ['Bp', 'C', 'D'],
            'lower': ['A', 'E'],
            'knee': ['Bp', 'E'],
            'shin': ['D', 'F'],
            'foot': ['E', 'F', 'G'],
        },
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O'}},
        'outputs': ['G'],
    }


def test_jansen_leg_crank_15_to_16_equals_the_leg_drawn_with_16():
    over = Scene.from_dict(jansen(15.0), dimensions={'crank.O-A': 16.0}).mechanism
    drawn = Scene.from_dict(jansen(16.0)).mechanism
    for p in drawn.points:  # the same drawing: the crank angle held, every mode kept
        assert np.max(np.abs(over.points[p] - drawn.points[p])) <= 1e-11, p
    thetas = np.linspace(0.0, 2 * math.pi, 25)
    for g, w in zip(points_at(over, thetas), points_at(drawn, thetas)):
        for p in drawn.points:
            assert np.max(np.abs(g[p] - w[p])) <= 1e-9, p
    # and it differs from the leg with crank 15 (the override did something)
    old = points_at(Scene.from_dict(jansen(15.0)).mechanism, thetas[:1])[0]
    assert np.hypot(*(old['G'] - points_at(over, thetas[:1])[0]['G'])) > 0.1


def test_scene_key_and_override_and_shortcuts(tmp_path):
    drawn = four_bar_drawn(LENGTHS, 1.0)
    in_file = dict(drawn, dimensions={'crank.O2-A': 0.11, 'rocker.O4-B': 0.21})
    path = tmp_path / 'fb.yaml'
    path.write_text(json.dumps(in_file))
    mech = Scene.from_yaml(path, dimensions={'crank.O2-A': 0.12}).mechanism
    assert mech.stated == {'crank.O2-A': 0.12, 'rocker.O4-B': 0.21}  # the override wins
    assert abs(float(np.hypot(*(mech.points['B'] - mech.points['O4']))) - 0.21) <= 1e-15
    # shortcut forms take them as their own parameters: equal to the shortcut with that length
    fb = {'four_bar': {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}}
    a = Scene.from_dict(fb, dimensions={'crank.O2-A': 0.12}).mechanism
    b = Scene.from_dict({'four_bar': dict(fb['four_bar'], crank=0.12)}).mechanism
    assert a.shortcut == b.shortcut and a.stated == {'crank.O2-A': 0.12}
    sc = {'slider_crank': {'crank': 0.1, 'rod': 0.3, 'offset': 0.02}}
    a = Scene.from_dict(sc, dimensions={'slider.offset': -0.03, 'rod.A-B': 0.32}).mechanism
    assert a.shortcut['offset'] == -0.03 and a.shortcut['rod'] == 0.32


def test_general_slider_offset_equals_the_offset_slider_crank():
    # an offset slider-crank in the general form: the line of stroke measured from O2
    e0, e1, r, rod, th = 0.02, 0.05, 0.1, 0.3, 1.1
    o = oracles.slider_crank(r, rod, e0, 0.0, th)
    gen = {
        'points': {
            'O2': [0.0, 0.0],
            'A': [float(v) for v in o['A']],
            'B': [float(v) for v in o['B']],
        },
        'links': {'ground': ['O2'], 'crank': ['O2', 'A'], 'rod': ['A', 'B'], 'block': ['B']},
        'sliders': [
            {
                'name': 'slide',
                'guide': 'ground',
                'slider': 'block',
                'point': 'B',
                'direction': 0.0,
                'origin': 'O2',
            }
        ],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }
    mech = Scene.from_dict(gen, dimensions={'slide.offset': e1}).mechanism
    assert abs(mech.points['B'][1] - e1) <= 1e-16
    for t, got in zip([0.3, 1.1, 2.5], points_at(mech, [0.3, 1.1, 2.5])):
        want = oracles.slider_crank(r, rod, e1, 0.0, t)
        assert oracles.point_error(got['B'], want['B']) <= 1e-14


@pytest.mark.parametrize(
    ('dims', 'key', 'words'),
    [
        ({'crank.O2-B': 0.1}, 'dimensions.crank.O2-B', "'B' is not a point of link 'crank'"),
        ({'bogus.O2-A': 0.1}, 'dimensions.bogus.O2-A', 'is not a link'),
        ({'crank': 0.1}, 'override crank', 'a dimension name is link.P-Q'),
        ({'crank.O2-A': -0.1}, 'override crank.O2-A', 'a length > 0'),
        ({'crank.O2-A': float('nan')}, 'override crank.O2-A', 'a length > 0'),
        ({'crank.O2-A': '0.1'}, 'override crank.O2-A', 'must be a number'),
        ({'coupler.A-P': 0.5}, 'dimensions.coupler.A-P', 'no triangle'),
        ({'crank.O2-A': 0.6}, 'dimensions', 'cannot be closed'),
        ({'ground.offset': 0.1}, 'dimensions.ground.offset', 'is not a slider'),
    ],
)
def test_bad_dimensions_are_refused_naming_them(dims, key, words):
    with pytest.raises(SceneError) as err:
        Scene.from_dict(four_bar_drawn(LENGTHS, 1.0), dimensions=dims)
    assert key in str(err.value) and words in str(err.value)


def test_quaternary_link_names_its_dimensions():
    drawn = four_bar_drawn(LENGTHS, 1.0)
    drawn['points']['Q'] = [0.2, 0.3]
    drawn['links']['coupler'] = ['A', 'B', 'P', 'Q']
    with pytest.raises(SceneError, match=r'coupler\.A-B, coupler\.A-P, coupler\.A-Q'):
        Scene.from_dict(drawn, dimensions={'coupler.P-Q': 0.1})


def test_a_redraw_past_the_toggle_is_refused_and_one_short_of_it_is_not():
    # at the drawn crank angle |A O4| = d: the dyad closes for rocker >= d - coupler and no
    # shorter; the redraw follows the drawn mode up to that toggle and refuses past it
    a = oracles.fourbar(*LENGTHS, 1.0)['A']
    d = math.hypot(float(a[0]) - 0.3, float(a[1]))
    short = d - 0.25
    with pytest.raises(SceneError, match='cannot be closed') as err:
        Scene.from_dict(four_bar_drawn(LENGTHS, 1.0), dimensions={'rocker.O4-B': short * 0.9})
    assert 'rocker.O4-B' in str(err.value)
    mech = Scene.from_dict(
        four_bar_drawn(LENGTHS, 1.0), dimensions={'rocker.O4-B': short * 1.1}
    ).mechanism
    o = oracles.fourbar(0.3, 0.1, 0.25, short * 1.1, 1.0, 1)
    assert oracles.point_error(mech.points['B'], o['B']) <= 1e-13


def test_cli_and_node_parameter(capsys, tmp_path):
    path = tmp_path / 'fb.yaml'
    path.write_text(json.dumps(four_bar_drawn(LENGTHS, 1.0)))
    rc = cli_main(
        ['solve', str(path), '--dimension', 'crank.O2-A=0.12', '--set', 'crank=0.4', '--json']
    )
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    assert abs(math.hypot(*out['points']['A']) - 0.12) <= 1e-16
    rc = cli_main(['check', str(path), '--dimension', 'crank.O2-A=0.12'])
    assert rc == 0 and 'crank.O2-A = 0.12 m' in capsys.readouterr().out
    assert cli_main(['solve', str(path), '--dimension', 'crank.O2-A', '--set', 'crank=0']) == 2
    assert 'NAME=VALUE' in capsys.readouterr().err
    scene, engine = load_engine(
        make_config({'scene': str(path), 'dimensions': ['crank.O2-A=0.12']})
    )
    assert scene.mechanism.stated == {'crank.O2-A': 0.12}


def test_a_redraw_is_bounded_in_size():
    # 25 four-bars on one ground: 75 moving links, more than a dense redraw takes; refused at
    # once naming the bound (a scene of thousands would take hours and GBs otherwise)
    pts, links, acts = {}, {'ground': []}, {}
    for k in range(25):
        x = float(k)
        pts |= {
            f'O{k}': [x, 0.0],
            f'A{k}': [x + 0.05, 0.0866],
            f'B{k}': [x + 0.32, 0.19],
            f'Q{k}': [x + 0.3, 0.0],
        }
        links['ground'] += [f'O{k}', f'Q{k}']
        links |= {
            f'c{k}': [f'O{k}', f'A{k}'],
            f'k{k}': [f'A{k}', f'B{k}'],
            f'r{k}': [f'Q{k}', f'B{k}'],
        }
        acts[f'a{k}'] = {'type': 'angle', 'link': f'c{k}', 'pivot': f'O{k}'}
    data = {'points': pts, 'links': links, 'actuators': acts}
    assert Scene.from_dict(data).mechanism.dof == 25
    with pytest.raises(SceneError, match='at most 64 moving links; this one has 75'):
        Scene.from_dict(data, dimensions={'c0.O0-A0': 0.11})


def test_four_bar_coupler_point_distance_by_name():
    fb = {
        'four_bar': {
            'ground': 0.3,
            'crank': 0.1,
            'coupler': 0.25,
            'rocker': 0.2,
            'coupler_point': {'name': 'P', 'distance': 0.15, 'angle': 0.5},
        }
    }
    mech = Scene.from_dict(fb, dimensions={'coupler.A-P': 0.18}).mechanism
    res = points_at(mech, [0.9])[0]
    o = oracles.fourbar(0.3, 0.1, 0.25, 0.2, 0.9, 1, coupler_point=(0.18, 0.5))
    assert oracles.point_error(res['P'], o['P']) <= 1e-14


def test_every_scene_command_takes_dimension(capsys, tmp_path):
    path = tmp_path / 'fb.yaml'
    path.write_text(json.dumps(four_bar_drawn(LENGTHS, 1.0)))
    out = tmp_path / 'fb.urdf'
    assert cli_main(['urdf', str(path), '--dimension', 'crank.O2-A=0.125', '-o', str(out)]) == 0
    assert '0.125' in out.read_text()  # the crank's pin, 0.125 m along its frame
    assert cli_main(['range', str(path), '--dimension', 'crank.O2-A=0.125', '--json']) == 0
    assert (
        cli_main(
            [
                'sweep',
                str(path),
                '--dimension',
                'crank.O2-A=0.125',
                '--set',
                'crank=0:1:3',
                '--json',
            ]
        )
        == 0
    )
    capsys.readouterr()
    with contextlib.suppress(SystemExit):  # argparse's --help exits
        cli_main(['bag', '--help'])
    assert '--dimension NAME=VALUE' in capsys.readouterr().out


def test_a_shortcut_that_cannot_assemble_with_its_dimensions_names_them():
    """An override of 1e308 m made the four-bar unassemblable, and the refusal blamed
    four_bar.input alone: it names the dimensions now."""
    from linkage_ros.core.errors import SceneError
    from linkage_ros.core.model import Scene

    with pytest.raises(SceneError, match=r'with the dimensions crank\.O2-A=1e\+308'):
        Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml', {'crank.O2-A': 1e308})


def test_a_length_far_from_its_drawing_is_named_as_a_likely_unit_slip():
    """crank.O2-A = 16 meant as mm (the drawing's is 0.1 m): the refusal says how far it is
    from the drawn length and that lengths are in m. A length near its drawing gets no hint."""
    from linkage_ros.core.errors import SceneError
    from linkage_ros.core.model import Scene

    with pytest.raises(SceneError) as info:
        Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml', {'crank.O2-A': 16.0})
    assert 'crank.O2-A = 16 m is 160x its drawn 0.1 m: lengths are in m' in str(info.value)
    assert 'write 16mm for millimetres' in str(info.value)
    with pytest.raises(SceneError) as info:  # 10x: no assembly, and no unit slip
        Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml', {'crank.O2-A': 1.0})
    assert 'with the dimensions crank.O2-A=1)' in str(info.value), str(info.value)


def test_a_shortcut_whose_lengths_never_close_blames_the_lengths_not_its_input():
    """A coupler longer than the other three links together closes at no crank angle: the
    refusal named the scene's `input` ('does not assemble at this crank angle')."""
    with pytest.raises(SceneError) as err:
        Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml', dimensions={'coupler.A-B': 1.5})
    text = str(err.value)
    assert 'these lengths do not assemble at any crank angle' in text
    assert 'four_bar.input' not in text
