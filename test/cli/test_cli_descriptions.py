"""The `linkage` command line on robot descriptions (URDF, SDF) and `linkage import`.

main(argv) runs in-process (capsys), as in test_cli.py. The answers are checked against
independent consumers of the same files: Pinocchio reads each URDF, is fed the JSON's joint
values by name, and must close every loop the fixture's closure states, with the actuated
joints at the commanded values; Drake's SDF (which Pinocchio cannot read) is checked against
the geometry its own comment and poses state (pins at (-2, 0) and (2, 0); driver 1 m, rocker
2 m, coupler 4.8 m; each joint a rotation about +z from the drawn, unassembled pose).
"""

from __future__ import annotations

import csv
import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from scenes import REPO

from linkage_ros.cli.parser import main

FIXTURES = REPO / 'test' / 'fixtures' / 'robot_descriptions'
DRAKE = FIXTURES / 'drake_four_bar_loop.sdf'
DRAKE_CLOSURES = FIXTURES / 'drake_four_bar_loop.closures.yaml'
SIX_BAR = FIXTURES / 'grbda_six_bar.urdf'
ROBOTIQ = FIXTURES / 'picknik_robotiq_2f_85.expanded.urdf'
ROBOTIQ_CLOSURES = FIXTURES / 'picknik_robotiq_2f_85.closures.yaml'
LEFT_KNUCKLE = 'robotiq_85_left_knuckle_joint'
RIGHT_KNUCKLE = 'robotiq_85_right_knuckle_joint'

#: a loop closes to this fraction of the mechanism's size
CLOSED = 1e-9

# Each URDF fixture: its closure side file (or None), the command (the description's joint
# names and values) and the loop closures, as two points (link, xyz in its frame) that must
# coincide, or two link frames that must coincide ('frames').
CASES = {
    'grbda_four_bar': dict(
        path=FIXTURES / 'grbda_four_bar.urdf',
        closures=None,
        command={'joint1': 0.5},
        pins=[(('link2', (1.0, 0.0, 0.0)), ('link3', (0.5, 0.0, 0.0)))],
    ),
    'grbda_six_bar': dict(
        path=SIX_BAR,
        closures=None,
        command={'joint1': 0.2, 'joint2': 0.3, 'joint3': -0.2},
        pins=[(('link3', (0.3, 0.0, 0.0)), ('link5', (0.5, 0.0, 0.0)))],
    ),
    'gepetto_5bar': dict(
        path=FIXTURES / 'gepetto_5bar_linkage' / 'robot.urdf',
        closures=FIXTURES / 'gepetto_5bar_linkage' / 'robot.yaml',
        command={'mot1': 0.1, 'mot2': -0.1},
        frames=[('sphere', 'sphere_2')],
    ),
    'robotiq_2f_85': dict(
        path=ROBOTIQ,
        closures=ROBOTIQ_CLOSURES,
        command={LEFT_KNUCKLE: 0.5},
        follows={RIGHT_KNUCKLE: -0.5},  # its <mimic> of the left knuckle (multiplier -1)
        pins=[
            (
                ('robotiq_85_left_inner_knuckle_link', (0.0371575, 0.0, 0.04342168)),
                ('robotiq_85_left_finger_tip_link', (-0.01790114, 0.0, 0.00651548)),
            ),
            (
                ('robotiq_85_right_inner_knuckle_link', (-0.0371575, 0.0, 0.04342168)),
                ('robotiq_85_right_finger_tip_link', (0.01790114, 0.0, 0.00651548)),
            ),
        ],
    ),
}


def run(capsys, *argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def loads(text):
    def no_nan(token):
        raise ValueError(f'non-finite number {token} in JSON output')

    return json.loads(text, parse_constant=no_nan)


def description_args(case) -> list:
    return [case['path']] + (['--closures', case['closures']] if case['closures'] else [])


def set_args(command) -> list:
    return [a for name, v in command.items() for a in ('--set', f'{name}={v!r}')]


def solve_json(capsys, *argv) -> dict:
    rc, out, err = run(capsys, 'solve', *argv, '--json')
    assert rc == 0, err
    d = loads(out)
    assert d['status'] == 'ok', d['reason']
    return d


def size_of(points: dict) -> float:
    """The mechanism's size: its largest distance between two points (m)."""
    pts = [np.asarray(p, float) for p in points.values()]
    return max(np.linalg.norm(p - q) for p in pts for q in pts)


# ---- Pinocchio: the independent consumer of the URDFs ------------------------------------------


def pinocchio_placements(urdf_path, joints: dict[str, float]):
    """(model, data) of the URDF posed by ``joints`` (every joint of its tree named)."""
    model = pin.buildModelFromXML(urdf_path.read_text())
    q = pin.neutral(model)
    named = {model.names[i] for i in range(1, model.njoints)}
    assert named <= set(joints), f'joints not in the answer: {named - set(joints)}'
    for i in range(1, model.njoints):
        value = joints[model.names[i]]
        jm = model.joints[i]
        if jm.nq == 2:  # continuous: (cos, sin)
            q[jm.idx_q : jm.idx_q + 2] = (math.cos(value), math.sin(value))
        else:
            assert jm.nq == 1
            q[jm.idx_q] = value
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    return model, data


def pinocchio_misses(case, joints: dict[str, float]) -> list[float]:
    """How far apart (m, and rad for frames) each closure of ``case`` is in Pinocchio."""
    model, data = pinocchio_placements(case['path'], joints)

    def placement(link):
        fid = model.getFrameId(link)
        assert fid < model.nframes, link
        return data.oMf[fid]

    misses = []
    for (la, pa), (lb, pb) in case.get('pins', []):
        a = placement(la).act(np.array(pa))
        b = placement(lb).act(np.array(pb))
        misses.append(float(np.linalg.norm(a - b)))
    for la, lb in case.get('frames', []):
        fa, fb = placement(la), placement(lb)
        misses.append(float(np.linalg.norm(fa.translation - fb.translation)))
        misses.append(float(np.linalg.norm(pin.log3(fa.rotation.T @ fb.rotation))))
    return misses


# ---- Drake's SDF: its stated geometry -----------------------------------------------------------


def drake_pins(joints: dict[str, float]) -> dict[str, np.ndarray]:
    """The SDF's joints as it states them: world_driver turns the driver (Do -> Dc: (0, 1))
    about Wd = (-2, 0); world_rocker the rocker (Ro -> Rc: (0, 2)) about Wr = (2, 0);
    driver_coupler the coupler (Co -> Cr: (4.8, 0)) about Dc, relative to the driver."""

    def rot(a, v):
        return np.array(
            [math.cos(a) * v[0] - math.sin(a) * v[1], math.sin(a) * v[0] + math.cos(a) * v[1]]
        )

    qd, qr, qc = joints['world_driver'], joints['world_rocker'], joints['driver_coupler']
    wd, wr = np.array([-2.0, 0.0]), np.array([2.0, 0.0])
    dc = wd + rot(qd, (0.0, 1.0))
    return {
        'Wd': wd,
        'Wr': wr,
        'Dc': dc,
        'Cr': dc + rot(qd + qc, (4.8, 0.0)),
        'Rc': wr + rot(qr, (0.0, 2.0)),
    }


def check_drake(d: dict) -> None:
    pts = {k: np.asarray(v) for k, v in d['points'].items()}
    tol = CLOSED * size_of(d['points'])
    # the link lengths between the pins are the SDF's
    for (p, q), length in {
        ('world_driver', 'world_rocker'): 4.0,
        ('world_driver', 'driver_coupler'): 1.0,
        ('world_rocker', 'coupler_rocker'): 2.0,
        ('driver_coupler', 'coupler_rocker'): 4.8,
    }.items():
        assert abs(np.linalg.norm(pts[p] - pts[q]) - length) < tol, (p, q)
    # the joint values, applied as the SDF states its joints, close the loop where the points are
    pins = drake_pins(d['joints'])
    assert np.linalg.norm(pins['Cr'] - pins['Rc']) < tol
    for name, pin_ in (
        ('world_driver', 'Wd'),
        ('world_rocker', 'Wr'),
        ('driver_coupler', 'Dc'),
        ('coupler_rocker', 'Rc'),
    ):
        assert np.linalg.norm(pts[name] - pins[pin_]) < tol, name


# ---- solve: the description's names and values, closed in an independent consumer -----------


@pytest.mark.parametrize('name', list(CASES))
def test_solve_answers_in_the_descriptions_joints_and_pinocchio_closes_them(capsys, name):
    case = CASES[name]
    d = solve_json(capsys, *description_args(case), *set_args(case['command']))
    joints = d['joints']
    for act, v in {**case['command'], **case.get('follows', {})}.items():
        assert joints[act] == pytest.approx(v, abs=1e-12), act
        assert d['inputs'][act] == pytest.approx(v, abs=1e-12), act
    misses = pinocchio_misses(case, joints)
    assert max(misses) < CLOSED * size_of(d['points']), misses
    # a different command moves the mechanism: the closure is no accident of one pose
    moved = {k: v + 0.1 for k, v in case['command'].items()}
    d2 = solve_json(capsys, *description_args(case), *set_args(moved))
    assert max(pinocchio_misses(case, d2['joints'])) < CLOSED * size_of(d2['points'])
    assert max(abs(d2['joints'][k] - joints[k]) for k in joints) > 0.05


def test_solve_drake_sdf_matches_its_stated_geometry(capsys):
    d = solve_json(capsys, DRAKE, '--closures', DRAKE_CLOSURES, '--set', 'world_driver=0.3')
    assert set(d['joints']) == {'world_driver', 'world_rocker', 'driver_coupler'}
    assert d['joints']['world_driver'] == pytest.approx(0.3, abs=1e-12)
    assert d['inputs'] == {'world_driver': pytest.approx(0.3, abs=1e-12)}
    check_drake(d)


def test_a_target_on_a_passive_joint_is_converted_to_the_scenes_value(capsys):
    # world_rocker's value in the description is the scene joint's minus pi/2: a value passed
    # unconverted would put the rocker a quarter turn away
    d = solve_json(capsys, DRAKE, '--closures', DRAKE_CLOSURES, '--target', 'world_rocker=-0.2')
    assert d['joints']['world_rocker'] == pytest.approx(-0.2, abs=1e-12)
    check_drake(d)
    # the same target in a sweep, and in degrees
    rc, out, err = run(
        capsys,
        'sweep',
        DRAKE,
        '--closures',
        DRAKE_CLOSURES,
        '--target',
        'world_rocker=-0.3:-0.1:3',
        '--json',
    )
    assert rc == 0, err
    lines = [loads(l) for l in out.splitlines()]
    assert [l['command']['world_rocker'] for l in lines] == pytest.approx([-0.3, -0.2, -0.1])
    for l in lines:
        assert l['status'] == 'ok', l['reason']
        assert l['joints']['world_rocker'] == pytest.approx(l['command']['world_rocker'], abs=1e-12)
        check_drake(l)
    # a passive joint of the six-bar whose scene joint has another name (joint4 is the scene's
    # joint1_link4), with two actuators set
    case = CASES['grbda_six_bar']
    d = solve_json(
        capsys, SIX_BAR, '--set', 'joint1=0.2', '--set', 'joint2=0.3', '--target', 'joint4=-0.6'
    )
    assert d['joints']['joint4'] == pytest.approx(-0.6, abs=1e-12)
    assert d['joints']['joint1'] == pytest.approx(0.2, abs=1e-12)
    assert max(pinocchio_misses(case, d['joints'])) < CLOSED * size_of(d['points'])
    # the Robotiq's inner knuckles (offset by 2.28 and 0.86 rad from the scene's joints)
    case = CASES['robotiq_2f_85']
    d = solve_json(
        capsys,
        ROBOTIQ,
        '--closures', ROBOTIQ_CLOSURES,
        '--target', 'robotiq_85_left_inner_knuckle_joint=0.3',
        '--target', 'robotiq_85_right_inner_knuckle_joint=-0.3',
    )  # fmt: skip
    assert d['joints']['robotiq_85_left_inner_knuckle_joint'] == pytest.approx(0.3, abs=1e-12)
    assert d['joints']['robotiq_85_right_inner_knuckle_joint'] == pytest.approx(-0.3, abs=1e-12)
    assert max(pinocchio_misses(case, d['joints'])) < CLOSED * size_of(d['points'])


def test_a_refused_answer_echoes_the_request_in_the_descriptions_values(capsys):
    # 0.9 is beyond the knuckle's <limit> upper="0.8"
    rc, out, _ = run(
        capsys, 'solve', ROBOTIQ, '--closures', ROBOTIQ_CLOSURES,
        '--set', f'{LEFT_KNUCKLE}=0.9', '--json',
    )  # fmt: skip
    d = loads(out)
    assert rc == 1 and d['status'] == 'error'
    assert d['inputs'] == {LEFT_KNUCKLE: 0.9}
    # out of reach: the target echoed as given (the scene's value is pi/2 more)
    rc, out, _ = run(
        capsys,
        'solve',
        DRAKE,
        '--closures',
        DRAKE_CLOSURES,
        '--target',
        'world_rocker=1.5',
        '--json',
    )
    d = loads(out)
    assert rc == 1 and 'cannot assemble' in d['reason']
    assert d['targets'] == {'world_rocker': 1.5}
    # an inverse answer in a named assembly mode echoes its target too
    d = solve_json(
        capsys, DRAKE, '--closures', DRAKE_CLOSURES, '--target', 'world_rocker=3', '--branch', '+'
    )
    assert d['targets'] == {'world_rocker': 3.0}
    assert d['joints']['world_rocker'] == pytest.approx(3.0, abs=1e-12)
    check_drake(d)


def test_text_table_names_the_descriptions_joints(capsys):
    rc, out, err = run(
        capsys,
        'solve',
        SIX_BAR,
        '--set',
        'joint1=0.2',
        '--set',
        'joint2=0.3',
        '--set',
        'joint3=-0.2',
    )
    assert rc == 0
    joints = out.split('\njoints\n')[1].split('\nlinks\n')[0].splitlines()
    assert [l.split()[0] for l in joints] == ['joint1', 'joint4', 'joint2', 'joint5', 'joint3']
    assert all(l.split()[2] == 'rad' for l in joints)
    assert err.startswith('note: the description is open by 0.3 m')


def test_mimic_follower_and_closure_frames_cannot_be_set(capsys):
    rc, _, err = run(
        capsys, 'solve', ROBOTIQ, '--closures', ROBOTIQ_CLOSURES, '--set', f'{RIGHT_KNUCKLE}=-0.5'
    )
    assert rc == 2
    line = err.strip().splitlines()[-1]
    assert f'follows {LEFT_KNUCKLE!r}' in line
    case = CASES['gepetto_5bar']
    rc, _, err = run(
        capsys, 'solve', *description_args(case), '--set', 'mot1=0.1', '--target',
        'closedloop1_A=0.1',
    )  # fmt: skip
    assert rc == 2 and 'cannot be commanded' in err.strip().splitlines()[-1]
    rc, _, err = run(capsys, 'solve', *description_args(case), '--set', 'mot1=0.1')
    assert rc == 2 and 'missing --set for actuator(s) mot2' in err


# ---- import: an editable scene that solves as the description does -------------------------


@pytest.mark.parametrize('name', [*CASES, 'drake_four_bar_loop'])
def test_import_then_solve_gives_the_descriptions_joints(capsys, tmp_path, name):
    if name == 'drake_four_bar_loop':
        case = dict(path=DRAKE, closures=DRAKE_CLOSURES, command={'world_driver': 0.3})
    else:
        case = CASES[name]
    scene = tmp_path / f'{name}.yaml'
    rc, out, err = run(capsys, 'import', *description_args(case), '-o', scene)
    assert rc == 0 and out == '', err
    text = scene.read_text()
    assert text.startswith('# linkage_ros scene imported by `linkage import` from ')
    assert str(case['path']) in text.splitlines()[0]
    assert ('# closures: ' + str(case['closures'])) in text if case['closures'] else True
    assert '\njoint_coordinates:\n' in text
    direct = solve_json(capsys, *description_args(case), *set_args(case['command']))
    imported = solve_json(capsys, scene, *set_args(case['command']))
    assert list(imported['joints']) == list(direct['joints'])
    for k, v in direct['joints'].items():
        assert imported['joints'][k] == pytest.approx(v, abs=1e-12), k
    # stdout without -o: the same text
    rc, out, _ = run(capsys, 'import', *description_args(case))
    assert rc == 0 and out == text


def test_import_writes_whole_or_not_at_all(capsys, tmp_path):
    target = tmp_path / 'six.yaml'
    target.write_text('kept\n')
    # a description that does not import leaves the file as it was
    rc, _, err = run(capsys, 'import', DRAKE, '-o', target)
    assert rc == 2 and err.strip().count('\n') == 0
    assert target.read_text() == 'kept\n'
    assert list(tmp_path.iterdir()) == [target]
    rc, _, err = run(capsys, 'import', SIX_BAR, '-o', tmp_path / 'no' / 'six.yaml')
    assert rc == 2 and 'cannot write' in err
    rc, _, err = run(capsys, 'import', 'four_bar')
    assert rc == 2 and 'not a robot description' in err
    rc, out, _ = run(capsys, 'import', '--help')
    assert rc == 0 and '--closures FILE' in out and 'joint_coordinates' in out


# ---- the options, the notes, the errors -----------------------------------------------------


def test_a_xacro_file_is_refused_as_unexpanded_xacro_by_its_name(capsys, tmp_path):
    """robot.urdf.xacro (as Robotiq's description ships, with the wiki.ros.org namespace) was
    read as a scene file ('a scene must be a YAML mapping') and refused by `linkage import` as
    no robot description: it is one, unexpanded."""
    xacro = tmp_path / 'gripper_macro.urdf.xacro'
    xacro.write_text(
        '<?xml version="1.0"?>\n<robot xmlns:xacro="http://wiki.ros.org/xacro" name="g">\n'
        '  <xacro:include filename="$(find robotiq_description)/urdf/g.xacro"/>\n</robot>\n'
    )
    for argv in (['check', xacro], ['import', xacro], ['solve', xacro, '--set', 'j=0']):
        rc, _, err = run(capsys, *argv)
        assert rc == 2 and 'an unexpanded xacro file (xacro:include' in err, err
        assert 'run xacro on it first' in err, err


def test_a_missing_closure_file_is_named_as_one(capsys, tmp_path):
    """--closures naming no file: 'closure file not found' (it read 'scene file not found')."""
    rc, _, err = run(capsys, 'check', DRAKE, '--closures', tmp_path / 'nosuch.yaml')
    assert rc == 2 and 'nosuch.yaml: closure file not found' in err, err


def test_closures_on_a_scene_file_is_a_usage_error(capsys, tmp_path):
    for argv in (
        ['solve', 'four_bar', '--closures', DRAKE_CLOSURES, '--set', 'crank=0.5'],
        ['check', 'four_bar', '--closures', DRAKE_CLOSURES],
        ['sweep', 'four_bar', '--actuated', 'crank', '--set', 'crank=0:1:3'],
        ['range', 'four_bar', '--closures', DRAKE_CLOSURES],
    ):
        rc, out, err = run(capsys, *argv)
        assert rc == 2, argv
        assert out == '' and err.count('\n') == 1, err
        assert 'applies to a robot description' in err
    # urdf takes no robot description, so it has no such option
    rc, out, err = run(capsys, 'urdf', 'four_bar', '--closures', DRAKE_CLOSURES)
    assert rc == 2 and out == '' and 'unrecognized arguments: --closures' in err
    # the bag tool refuses it before reading the bag
    rc, _, err = run(
        capsys, 'bag', tmp_path / 'none', '--scene', 'four_bar', '--closures', DRAKE_CLOSURES,
        '--command-topic', '/c', '--out', tmp_path / 'o.csv',
    )  # fmt: skip
    assert rc == 2 and err.count('\n') == 1 and 'applies to a robot description' in err
    # a missing scene keeps its message
    rc, _, err = run(capsys, 'solve', tmp_path / 'none.urdf', '--set', 'joint1=0')
    assert rc == 2 and 'not found: not a file and not a packaged scene' in err


def test_actuated_joints_that_do_not_match_the_dof_exit_2_naming_them(capsys):
    # Drake's SDF marks no joint: without its closure file all three would be actuated
    rc, out, err = run(capsys, 'solve', DRAKE, '--set', 'world_driver=0.3')
    assert rc == 2 and out == ''
    assert err.count('\n') == 1
    assert 'world_driver, world_rocker, driver_coupler' in err
    assert '1 degree(s) of freedom' in err
    # --actuated names them instead of the closure file
    d = solve_json(capsys, DRAKE, '--actuated', 'world_driver', '--set', 'world_driver=0.3')
    check_drake(d)


def test_sweep_csv_columns_are_the_descriptions_joints(capsys, tmp_path):
    out_csv = tmp_path / 'six.csv'
    rc, _, err = run(
        capsys, 'sweep', SIX_BAR, '--set', 'joint1=0:0.2:3', '--set', 'joint2=0.3',
        '--set', 'joint3=-0.2', '--csv', out_csv,
    )  # fmt: skip
    assert rc == 0, err
    rows = list(csv.DictReader(out_csv.open()))
    names = ['joint1', 'joint4', 'joint2', 'joint5', 'joint3']
    assert list(rows[0]) == ['index', 'status', 'reason'] + [
        f'input.{a}' for a in ('joint1', 'joint2', 'joint3')
    ] + [f'joint.{j}' for j in names]
    case = CASES['grbda_six_bar']
    for row, q1 in zip(rows, (0.0, 0.1, 0.2)):
        joints = {j: float(row[f'joint.{j}']) for j in names}
        assert joints['joint1'] == pytest.approx(q1, abs=1e-12)
        assert max(pinocchio_misses(case, joints)) < 1e-9
    # the Robotiq: the follower is an input column too, at the mimic's value
    rc, _, err = run(
        capsys, 'sweep', ROBOTIQ, '--closures', ROBOTIQ_CLOSURES,
        '--set', f'{LEFT_KNUCKLE}=0.1:0.7:4', '--csv', out_csv,
    )  # fmt: skip
    assert rc == 0, err
    for row in csv.DictReader(out_csv.open()):
        left = float(row[f'input.{LEFT_KNUCKLE}'])
        assert float(row[f'input.{RIGHT_KNUCKLE}']) == pytest.approx(-left, abs=1e-12)


def test_check_prints_the_notes_and_the_descriptions_joints(capsys):
    rc, out, err = run(capsys, 'check', SIX_BAR)
    assert rc == 0
    notes = [l for l in err.splitlines() if l.startswith('note: ')]
    assert len(notes) == 1
    assert notes[0].startswith('note: the description is open by 0.3 m at joint1 = 0')
    assert 'joint4 (scene joint1_link4)' in out
    rc, out, err = run(capsys, 'check', SIX_BAR, '--json')
    assert rc == 0 and err == ''
    r = loads(out)
    assert r['notes'] and r['notes'][0].startswith('the description is open by 0.3 m')
    assert r['joint_coordinates']['joints'] == ['joint1', 'joint4', 'joint2', 'joint5', 'joint3']
    assert r['dof'] == 3 and r['dof_matches_actuators']
    # a scene file: no notes, no description joints
    rc, out, _ = run(capsys, 'check', 'four_bar', '--json')
    r = loads(out)
    assert r['notes'] == [] and r['joint_coordinates'] is None


def test_input_ranges_are_in_the_descriptions_values(capsys):
    """The knuckles' ranges are their URDF <limit>s, not the scene's offset angles."""
    root = ET.fromstring(ROBOTIQ.read_text())
    limit = {
        j.get('name'): (float(j.find('limit').get('lower')), float(j.find('limit').get('upper')))
        for j in root.iter('joint')
        if j.find('limit') is not None
    }
    rc, out, _ = run(capsys, 'check', ROBOTIQ, '--closures', ROBOTIQ_CLOSURES, '--json')
    inputs = loads(out)['inputs']
    for name in (LEFT_KNUCKLE, RIGHT_KNUCKLE):
        lo, hi = limit[name]
        assert inputs[name]['declared_min'] == pytest.approx(lo, abs=1e-12)
        assert inputs[name]['declared_max'] == pytest.approx(hi, abs=1e-12)
    rc, out, _ = run(capsys, 'range', ROBOTIQ, '--closures', ROBOTIQ_CLOSURES, '--json')
    assert rc == 0
    r = loads(out)
    for name in (LEFT_KNUCKLE, RIGHT_KNUCKLE):
        lo, hi = limit[name]
        assert (r['inputs'][name]['min'], r['inputs'][name]['max']) == (
            pytest.approx(lo, abs=1e-12),
            pytest.approx(hi, abs=1e-12),
        )
        assert r['inputs'][name]['reference'] == pytest.approx(0.0, abs=1e-12)


def test_the_clis_description_suffixes_are_the_cores():
    """The CLI tells a description by its suffix without importing the readers."""
    from linkage_ros.cli.common import DESCRIPTION_SUFFIXES
    from linkage_ros.core.description import importer

    assert DESCRIPTION_SUFFIXES == importer.DESCRIPTION_SUFFIXES


def test_linkage_urdf_refuses_a_description_naming_the_description_itself(capsys):
    """A description's joint_states drive its own URDF: a scene URDF would name other joints."""
    code = main(['urdf', str(FIXTURES / 'grbda_four_bar.urdf')])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and all(line.startswith('note: ') for line in lines[:-1])
    assert 'give robot_state_publisher that description itself' in lines[-1]
    # a description its import would need --closures / --actuated for (options urdf does not
    # take): refused before it is read, with the same reason
    code = main(['urdf', str(DRAKE)])
    err = capsys.readouterr().err
    assert code == 2 and 'give robot_state_publisher that description itself' in err
    assert '--actuated' not in err and '--closures' not in err


def test_linkage_urdf_offers_no_description_options(capsys):
    """urdf refuses every robot description, so its help offers none of their options."""
    assert main(['urdf', '--help']) == 0
    help_text = capsys.readouterr().out
    assert '--closures' not in help_text and '--actuated' not in help_text
    assert 'robot description' not in help_text.split('positional arguments')[1]


def test_a_dimension_given_twice_or_with_an_underscore_is_refused(capsys):
    """--dimension NAME twice kept the last silently; 1_0 read as 10 m."""
    twice = ['--dimension', 'crank.O2-A=0.1', '--dimension', 'crank.O2-A=0.2']
    code = main(['solve', 'four_bar', '--set', 'crank=0.3', *twice])
    err = capsys.readouterr().err
    assert code == 2 and 'crank.O2-A is given twice' in err
    code = main(['solve', 'four_bar', '--set', 'crank=0.3', '--dimension', 'crank.O2-A=1_0'])
    err = capsys.readouterr().err
    assert code == 2 and "'1_0' is not a number" in err


@pytest.mark.parametrize('command', ['solve', 'sweep', 'range'])
def test_json_output_keeps_the_load_notes_on_stderr(command, capsys):
    """What loading did (the Robotiq's <mimic>s superseded by the closures) reaches a script
    too: --json answered on stdout dropped the notes altogether."""
    args = {
        'solve': ['--set', f'{LEFT_KNUCKLE}=0.5'],
        'sweep': ['--set', f'{LEFT_KNUCKLE}=0.1:0.5:3'],
        'range': [],
    }[command]
    code = main([command, str(ROBOTIQ), '--closures', str(ROBOTIQ_CLOSURES), *args, '--json'])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    assert 'note: <mimic> of ' in cap.err and 'superseded' in cap.err
    assert 'note:' not in cap.out
    # stdout is still the JSON (range's one indented document; solve's and sweep's lines)
    json.loads(cap.out) if command == 'range' else json.loads(cap.out.splitlines()[0])


def test_a_target_that_breaks_the_grippers_mimic_is_refused_and_one_that_keeps_it_closes(
    capsys,
):
    """The Robotiq's right knuckle follows the left by its <mimic> (multiplier -1): a command
    sets both. Two finger-tip targets that do not agree answered OK with the knuckles at 0.3
    and -0.5, a pose the one-motor gripper cannot take and robot_state_publisher draws as sent.
    Oracle: the URDF's <mimic> rule, and Pinocchio closing both closures."""
    case = CASES['robotiq_2f_85']
    tip = 'robotiq_85_{}_finger_tip_joint'
    rc, out, err = run(
        capsys,
        'solve',
        *description_args(case),
        '--target', f'{tip.format("left")}=-0.3', '--target', f'{tip.format("right")}=0.5',
        '--json',
    )  # fmt: skip
    d = loads(out)
    assert rc == 1 and d['status'] == 'error'
    assert f'{RIGHT_KNUCKLE} follows {LEFT_KNUCKLE} by its <mimic>' in d['reason'], d['reason']
    d = solve_json(
        capsys,
        *description_args(case),
        '--target', f'{tip.format("left")}=-0.3', '--target', f'{tip.format("right")}=0.3',
    )  # fmt: skip
    joints = d['joints']
    assert abs(joints[RIGHT_KNUCKLE] + joints[LEFT_KNUCKLE]) <= 1e-12
    assert max(pinocchio_misses(case, joints)) <= CLOSED * size_of(d['points'])


def test_the_engine_keeps_its_state_when_a_target_breaks_the_mimic():
    from linkage_ros.core.loading import load_scene
    from linkage_ros.engine import Engine, EngineSettings

    mech = load_scene(str(ROBOTIQ), closures=str(ROBOTIQ_CLOSURES)).mechanism
    e = Engine(mech, EngineSettings())
    assert e.command({LEFT_KNUCKLE: 0.4}).success
    last = e.last
    tip = 'robotiq_85_{}_finger_tip_joint'
    r = e.target({tip.format('left'): -0.3, tip.format('right'): 0.5})
    assert not r.success and 'by its <mimic>' in r.reason
    assert e.last is last


@pytest.mark.parametrize('axes', ['0 0 1', '0 0 -1'])
def test_a_points_plane_coordinates_are_its_ground_frame_coordinates_whichever_way_joints_turn(
    capsys, tmp_path, axes
):
    """`<point>.x` / `<point>.y` on a target are the ground frame's x and y (the doc's e1, e2)
    for joints about +z and about -z alike. With every axis -z the plane was turned over (e2 =
    -y), so `loop1.y=0.3` put the pin at y = -0.3, where `~/target_point` (a 3-D point) put it
    at +0.3. Oracle: Pinocchio's forward kinematics of the answer's joint values."""
    case = dict(CASES['grbda_four_bar'])
    text = case['path'].read_text().replace('<axis xyz="0 0 1"/>', f'<axis xyz="{axes}"/>')
    path = tmp_path / 'four_bar.urdf'
    path.write_text(text)
    case['path'] = path
    for target, want in (('loop1.y=0.3', (None, 0.3)), ('loop1.x=1.2', (1.2, None))):
        d = solve_json(capsys, path, '--target', target)
        model, data = pinocchio_placements(path, d['joints'])
        (la, pa), (lb, pb) = case['pins'][0]
        pin_a = data.oMf[model.getFrameId(la)].act(np.array(pa))
        assert max(pinocchio_misses(case, d['joints'])) <= CLOSED * size_of(d['points'])
        for k, w in enumerate(want):
            if w is not None:
                assert abs(pin_a[k] - w) <= 1e-12, (target, pin_a)
        # the JSON's plane points are the same coordinates
        assert np.allclose(d['points']['loop1'], pin_a[:2], atol=1e-12)


@pytest.mark.parametrize('axis', ['0 0 1', '0 0 -1'])
def test_limit_refusals_quote_the_descriptions_own_values_and_limits(capsys, tmp_path, axis):
    """joint1 limited to [-0.3, 0.4] in the description: a refusal quotes that interval and the
    value given, whichever way the joint turns about the plane's normal (about -z it said
    'joint1 = 0.35 rad is beyond its maximum 0.3' for a command of -0.35)."""
    text = CASES['grbda_four_bar']['path'].read_text()
    head, tail = text.split('<joint name="joint1"', 1)
    joint1, rest = tail.split('</joint>', 1)
    joint1 = joint1.replace('<axis xyz="0 0 1"/>', f'<axis xyz="{axis}"/>')
    joint1 = joint1.replace('lower="-13.14" upper="13.14"', 'lower="-0.3" upper="0.4"')
    path = tmp_path / 'four_bar.urdf'
    path.write_text(f'{head}<joint name="joint1"{joint1}</joint>{rest}')
    for value, want in (
        (-0.35, 'joint1 = -0.35 rad is below its minimum -0.3 by 0.05 rad'),
        (0.45, 'joint1 = 0.45 rad is beyond its maximum 0.4 by 0.05 rad'),
    ):
        rc, out, _ = run(capsys, 'solve', path, '--set', f'joint1={value}', '--json')
        assert rc == 1 and loads(out)['reason'] == want
    assert solve_json(capsys, path, '--set', 'joint1=0.35')['joints']['joint1'] == pytest.approx(
        0.35, abs=1e-12
    )


TOGGLE_AT_ZERO = """<?xml version="1.0"?>
<robot name="tog">
  <link name="base_link"/><link name="crank_l"/><link name="coupler_l"/><link name="rocker_l"/>
  <joint name="crank" type="continuous"><parent link="base_link"/><child link="crank_l"/>
    <origin xyz="0 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="cj" type="continuous" independent="false"><parent link="crank_l"/>
    <child link="coupler_l"/><origin xyz="0.3 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="rj" type="continuous" independent="false"><parent link="base_link"/>
    <child link="rocker_l"/><origin xyz="1 0 0" rpy="0 0 0.5"/><axis xyz="0 0 1"/></joint>
  <loop name="pin" type="revolute"><predecessor link="coupler_l"><origin xyz="0.9 0 0"/>
    </predecessor><successor link="rocker_l"><origin xyz="0.2 0 0"/></successor>
    <axis xyz="0 0 1"/></loop>
</robot>
"""


def test_a_description_assembled_at_a_toggle_is_calibrated_exactly(capsys, tmp_path):
    """Drawn open, this four-bar assembles at crank = 0 in its toggle (|A O4| = 0.7 = coupler -
    rocker), where the least-squares assembly is good only to the root of rounding: the joint
    map's offsets took that 2e-8 rad error into every answer (rj 0.5015629016 for 0.5015628786)
    with residual 8e-17. Oracle: the circle intersection in plain math, and Pinocchio."""
    import cmath

    path = tmp_path / 'tog.urdf'
    path.write_text(TOGGLE_AT_ZERO)
    for t in (0.8, 0.3, 1.5):
        d = solve_json(capsys, path, '--set', f'crank={t!r}')
        a = complex(0.3 * math.cos(t), 0.3 * math.sin(t))
        far = abs(1 - a)
        along = (0.9**2 - 0.2**2 + far * far) / (2 * far)
        b = a + (along + 1j * math.sqrt(0.9**2 - along * along)) * (1 - a) / far
        want = math.remainder(cmath.phase(b - 1) - 0.5, 2 * math.pi)
        assert abs(math.remainder(d['joints']['rj'] - want, 2 * math.pi)) <= 1e-12, t
        case = {
            'path': path,
            'pins': [(('coupler_l', (0.9, 0.0, 0.0)), ('rocker_l', (0.2, 0.0, 0.0)))],
        }
        assert max(pinocchio_misses(case, d['joints'])) <= 1e-12


def test_a_mimic_coupled_description_assembled_elsewhere_is_not_called_open(capsys, tmp_path):
    """The Robotiq at assemble_at knuckle = 0.3: its <mimic> rule closes both fingers there
    (drawn as parallelograms), but the note said 'open by 0.0226 m' (the passive joints held at
    0, not where the description puts them)."""
    closures = tmp_path / 'at.yaml'
    closures.write_text(ROBOTIQ_CLOSURES.read_text() + f'assemble_at: {{{LEFT_KNUCKLE}: 0.3}}\n')
    rc, _, err = run(capsys, 'check', ROBOTIQ, '--closures', closures)
    assert rc == 0 and 'superseded' in err
    assert 'is open by' not in err, err


@pytest.mark.parametrize(
    'at, said',
    [
        (
            {LEFT_KNUCKLE: 0.9},
            f'{LEFT_KNUCKLE} = 0.9 rad is beyond its maximum 0.8 by 0.1 rad where the '
            'description is assembled (assemble_at; <limit>: [0, 0.8])',
        ),
        (
            {'robotiq_85_left_inner_knuckle_joint': 0.3},
            f'not an actuated joint (the closed chain places the others); give values of '
            f'{LEFT_KNUCKLE}\n',
        ),
    ],
)
def test_assemble_at_refusals_name_the_closure_files_own_terms(capsys, tmp_path, at, said):
    """A value beyond the <limit> was blamed on 'actuators.<joint>' (a key of the scene made
    inside) with the advice to use assemble_at, the key at fault; a passive joint was answered
    with a list naming the right knuckle too, which follows the left by its <mimic>."""
    closures = tmp_path / 'at.yaml'
    ((name, value),) = at.items()
    closures.write_text(ROBOTIQ_CLOSURES.read_text() + f'assemble_at: {{{name}: {value}}}\n')
    rc, _, err = run(capsys, 'check', ROBOTIQ, '--closures', closures)
    assert rc == 2 and said in err, err
    assert 'actuators.' not in err


def test_a_description_at_a_toggle_is_told_the_remedies_it_has(capsys):
    """A robot description's reference pose is its joints' zeros: the integrator does not redraw
    it, so the toggle warning names assemble_at and the branch setting instead (the GRBDA
    four-bar's zeros are its parallelogram folded flat)."""
    code, out, _ = run(capsys, 'check', str(FIXTURES / 'grbda_four_bar.urdf'))
    assert code == 0
    (warning,) = [line for line in out.splitlines() if 'toggle of' in line]
    assert 'assemble_at in a closure file' in warning and '--branch' in warning
    assert 'draw the pose' not in warning


@pytest.mark.parametrize('solver', ['auto', 'newton'])
@pytest.mark.parametrize('crank', [0.5, 2.0, -0.5, -2.0])
def test_a_flat_drawn_four_bar_answers_the_branch_asked_for(capsys, crank, solver):
    """grbda_four_bar.urdf is drawn flat, on its change point (joint1 = 0), where the
    parallelogram's motion and the anti-parallelogram's cross: the drawing chooses neither
    circuit. Each --branch answers its own signs (the parallelogram joint2 = -joint1, joint3 =
    joint1; the anti-parallelogram joint2 = joint3: ROBOT_DESCRIPTIONS.md), and a continuous
    first command takes the parallelogram, nearest the flat drawing. A circuit scanned from
    the drawing had turned --branch - into + (the anti-parallelogram) at every crank. Newton
    from the flat drawing took the parallelogram whatever was asked and refused --branch +
    as 'not reachable without crossing a singularity' (the drawing is on one)."""
    case = CASES['grbda_four_bar']
    parallelogram = '-' if crank > 0 else '+'
    for branch in ('+', '-', 'continuous'):
        d = solve_json(
            capsys,
            *description_args(case),
            '--set',
            f'joint1={crank}',
            '--branch',
            branch,
            '--solver',
            solver,
        )
        j = d['joints']
        assert max(pinocchio_misses(case, j)) < CLOSED * size_of(d['points'])
        want = parallelogram if branch == 'continuous' else branch
        assert d['branch'] == want, branch
        if want == parallelogram:
            assert j['joint2'] == pytest.approx(-crank, abs=1e-12)
            assert j['joint3'] == pytest.approx(crank, abs=1e-12)
        else:
            assert j['joint2'] == pytest.approx(j['joint3'], abs=1e-12)
            assert abs(j['joint2'] + crank) > 0.1


def test_closure_file_limits_upside_down_or_broken_are_named_as_the_files(capsys, tmp_path):
    """limits {lower: 0.5, upper: 0.2} in a closure file was read on ("crank = 0 rad is below
    its minimum 0.2"), and assemble_at outside the file's limits was called outside a <limit>
    (an outside integrator): the pair is refused as the URDF reader refuses one, and the
    refusal of an assemble_at names the closure file's limits."""
    inverted = tmp_path / 'inverted.yaml'
    inverted.write_text(
        ROBOTIQ_CLOSURES.read_text() + f'limits: {{{LEFT_KNUCKLE}: {{lower: 0.5, upper: 0.2}}}}\n'
    )
    rc, _, err = run(capsys, 'check', ROBOTIQ, '--closures', inverted)
    assert rc == 2 and 'lower 0.5 is above upper 0.2: no value fits; swap them' in err, err
    assert f'limits.{LEFT_KNUCKLE}' in err
    outside = tmp_path / 'outside.yaml'
    outside.write_text(
        ROBOTIQ_CLOSURES.read_text()
        + f'limits: {{{LEFT_KNUCKLE}: {{lower: 0.1, upper: 0.4}}}}\n'
        + f'assemble_at: {{{LEFT_KNUCKLE}: 0.6}}\n'
    )
    rc, _, err = run(capsys, 'check', ROBOTIQ, '--closures', outside)
    assert rc == 2
    assert (
        f'{LEFT_KNUCKLE} = 0.6 rad is beyond its maximum 0.4 by 0.2 rad where the description '
        'is assembled (assemble_at; limits in the closure file: [0.1, 0.4])'
    ) in err, err


def test_a_prismatic_mimic_follower_is_printed_in_metres(capsys, tmp_path):
    """A prismatic joint following the GRBDA four-bar's crank by <mimic> (0.1 m per rad +
    0.05 m) is printed in metres: linkage solve printed 'mslide 0.300000000 rad 17.18873 deg'
    (the unit of the joint it follows; a review's find). Oracle: the <mimic> rule."""
    text = (FIXTURES / 'grbda_four_bar.urdf').read_text()
    slide = (
        '<link name="slid"/><joint name="mslide" type="prismatic"><parent link="base_link"/>'
        '<child link="slid"/><axis xyz="1 0 0"/><limit lower="-9" upper="9" effort="1" '
        'velocity="1"/><mimic joint="joint1" multiplier="0.1" offset="0.05"/></joint>'
    )
    path = tmp_path / 'mimic.urdf'
    path.write_text(text.replace('</robot>', slide + '</robot>'))
    rc, out, err = run(capsys, 'solve', path, '--set', 'joint1=2.5')
    assert rc == 0, err
    (line,) = [ln for ln in out.splitlines() if ln.split()[:1] == ['mslide']]
    assert line.split()[1:] == ['0.300000000', 'm'], line
