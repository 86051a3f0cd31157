"""`linkage solve` and `linkage sweep` on robot descriptions (URDF, SDF): answers in the
description's joint names and values, its <mimic> rules and <limit>s, its assembly modes.

main(argv) runs in-process (capsys). The answers are checked against independent consumers of
the same files: Pinocchio reads each URDF, is fed the JSON's joint values by name, and must
close every loop the fixture's closure states, with the actuated joints at the commanded values;
Drake's SDF (which Pinocchio cannot read) is checked against the geometry its own comment and
poses state (description_helpers.check_drake).
"""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pinocchio as pin
import pytest
from cli_helpers import loads, run
from description_helpers import (
    CASES,
    CLOSED,
    DRAKE,
    DRAKE_CLOSURES,
    FIXTURES,
    LEFT_KNUCKLE,
    RIGHT_KNUCKLE,
    ROBOTIQ,
    ROBOTIQ_CLOSURES,
    SIX_BAR,
    check_drake,
    description_args,
    set_args,
    size_of,
    solve_json,
)

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
    # an actuated joint left out is held at its drawn value, in the description's terms
    rc, out, err = run(capsys, 'solve', *description_args(case), '--set', 'mot1=0.1', '--json')
    assert rc == 0 and 'note: mot2 held at its drawn value 0 rad' in err, err
    assert loads(out)['inputs'] == {'mot1': 0.1, 'mot2': 0.0}


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
    assert len(rows) == 3
    for row, q1 in zip(rows, (0.0, 0.1, 0.2)):
        joints = {j: float(row[f'joint.{j}']) for j in names}
        assert joints['joint1'] == pytest.approx(q1, abs=1e-12)
        assert max(pinocchio_misses(case, joints)) < 1e-9
    # the Robotiq: the follower is an input column too, at the mimic's value
    rows = _robotiq_sweep_rows(capsys, out_csv, '0.1:0.7:4')
    assert len(rows) == 4
    for row in rows:
        left = float(row[f'input.{LEFT_KNUCKLE}'])
        assert float(row[f'input.{RIGHT_KNUCKLE}']) == pytest.approx(-left, abs=1e-12)


def _robotiq_sweep_rows(capsys, out_csv, span: str) -> list[dict[str, str]]:
    """The CSV rows of `linkage sweep` over the Robotiq's left knuckle (``span``:
    START:STOP:COUNT), the sweep exiting 0."""
    rc, _, err = run(
        capsys, 'sweep', ROBOTIQ, '--closures', ROBOTIQ_CLOSURES,
        '--set', f'{LEFT_KNUCKLE}={span}', '--csv', out_csv,
    )  # fmt: skip
    assert rc == 0, err
    return list(csv.DictReader(out_csv.open()))


def test_sweep_rows_refused_beyond_a_limit_keep_their_command(capsys, tmp_path):
    """A description's joint commanded beyond its <limit> is refused before any solve; its CSV
    row still has the inputs it was commanded, as linkage bag's has them (angles wrapped as the
    answers give them, the mimic follower at -1 times the knuckle); they were empty."""
    rows = _robotiq_sweep_rows(capsys, tmp_path / 'refused.csv', '-6:6.5:2')
    assert [r['status'] for r in rows] == ['error', 'error']
    assert 'below its minimum' in rows[0]['reason'] and 'beyond its maximum' in rows[1]['reason']
    for row, commanded in zip(rows, (-6.0, 6.5)):
        left = math.remainder(commanded, 2 * math.pi)
        assert float(row[f'input.{LEFT_KNUCKLE}']) == pytest.approx(left, abs=1e-15)
        assert float(row[f'input.{RIGHT_KNUCKLE}']) == pytest.approx(-left, abs=1e-15)
        assert all(row[k] == '' for k in row if k.startswith('joint.'))


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


@pytest.mark.parametrize('joint1', [-0.4, -0.2, -2.0])
def test_an_explicit_branch_is_never_answered_in_another_mode(capsys, tmp_path, joint1):
    """grbda's four-bar is a parallelogram linkage: at joint1 < 0 its '-' mode is the
    anti-parallelogram (joint2 = joint3), off the drawing's circuit once a closure file's
    assemble_at redraws the pose at joint1 = 0.3 (the drawing's circuit is the parallelogram,
    '+'). `--branch -` came back '+', the parallelogram, with status ok (an outside review):
    the circuit's configuration in another mode than the one asked. A branch setting fixes
    the mode: refused now, saying so; '+' is answered, and is the parallelogram (oracle:
    joint2 = -joint1, joint3 = joint1)."""
    closures = tmp_path / 'asm.yaml'
    closures.write_text('assemble_at: {joint1: 0.3}\n')
    urdf = FIXTURES / 'grbda_four_bar.urdf'
    common = ['solve', urdf, '--closures', closures, '--set', f'joint1={joint1}', '--json']
    rc, out, _ = run(capsys, *common, '--branch=-')
    refused = loads(out)
    assert rc == 1 and refused['status'] == 'error'
    assert "in the assembly mode asked ('-') is off the drawing's circuit" in refused['reason']
    assert "passes there in mode '+'" in refused['reason']
    rc, out, _ = run(capsys, *common, '--branch=+')
    got = loads(out)
    assert rc == 0 and got['branch'] == '+'
    assert got['joints']['joint2'] == pytest.approx(-joint1, abs=1e-12)
    assert got['joints']['joint3'] == pytest.approx(joint1, abs=1e-12)


def _grbda_joint2_limited(tmp_path):
    """The GRBDA four-bar with joint2's <limit> narrowed to [0, 3] rad (a copy in tmp_path)."""
    text = (FIXTURES / 'grbda_four_bar.urdf').read_text()
    joint2 = text.index('<joint name="joint2"')
    wide = 'lower="-13.14" upper="13.14"'
    limit = text.index(wide, joint2)
    narrow = tmp_path / 'grbda_joint2_limited.urdf'
    narrow.write_text(text[:limit] + 'lower="0.0" upper="3.0"' + text[limit + len(wide) :])
    return narrow


def test_the_twin_note_speaks_the_descriptions_values_and_its_limits(capsys, tmp_path):
    """A target with a second solution in its mode names it in a note: in the values a command
    takes (the description's joints: gepetto's mot2 is offset by pi from the scene's actuator),
    so that commanding them reaches the target; and only where the robot can take it (the
    GRBDA four-bar's twin puts joint2 at -0.5 rad: with joint2 limited to [0, 3] there is none
    to name)."""
    import re

    g5 = CASES['gepetto_5bar']
    target = '0.05,-0.8'
    args = ['solve', g5['path'], '--closures', g5['closures']]
    rc, out, err = run(
        capsys, *args, '--target-point', f'{"closedloop1_A__closedloop1_B"}={target}', '--json'
    )
    assert rc == 0, err
    (note,) = [ln for ln in err.splitlines() if 'other solution' in ln]
    # (each solution the note names: every one in the mode, separated by '; ')
    listed = note.partition(' in assembly mode ')[2].partition(': ')[2].split('; --all')[0]
    branch = json.loads(out)['branch']
    for item in listed.split('; '):
        twin = dict(re.findall(r'(\w+) = ([-0-9.e]+)', item))
        assert set(twin) == {'mot1', 'mot2'}
        sets = [w for k, v in twin.items() for w in ('--set', f'{k}={v}')]
        rc, out, err = run(capsys, *args, *sets, '--branch', branch, '--json')
        assert rc == 0, err
        got = json.loads(out)['points']['closedloop1_A__closedloop1_B']
        assert math.dist(got, (0.05, -0.8)) < 1e-8  # (the note's 9 digits)

    grbda = FIXTURES / 'grbda_four_bar.urdf'
    rc, _, err = run(capsys, 'solve', grbda, '--target', 'joint3=0.5')
    assert rc == 0 and 'another solution in assembly mode -: joint1 = 0.5;' in err, err
    rc, out, err = run(capsys, 'solve', _grbda_joint2_limited(tmp_path), '--target', 'joint3=0.5')
    assert rc == 0 and 'another solution' not in err, err


def test_a_target_whose_first_answer_breaks_a_passive_limit_takes_the_one_in_mode_that_keeps_it(
    capsys, tmp_path
):
    """The GRBDA four-bar with joint2 limited to [0, 3] rad: joint3 = -2 is reached in the
    drawn mode by joint1 = -2 with joint2 = 2 (the parallelogram: joint2 = -joint1, joint3 =
    joint1), within the limit. The inverse plan's first answer put joint2 at -2, and the target
    was refused as beyond the limit though that solution in the same mode keeps it (an
    adversary's find)."""
    narrow = _grbda_joint2_limited(tmp_path)
    rc, out, err = run(capsys, 'solve', narrow, '--target', 'joint3=-2', '--json')
    assert rc == 0, err
    j = json.loads(out)['joints']
    assert j['joint3'] == pytest.approx(-2.0, abs=1e-12)
    assert j['joint1'] == pytest.approx(-2.0, abs=1e-12)
    assert j['joint2'] == pytest.approx(2.0, abs=1e-12) and 0.0 <= j['joint2'] <= 3.0
