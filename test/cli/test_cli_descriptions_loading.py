"""Loading a robot description on the command line: the options (--closures, --actuated,
--dimension), the closure file's terms (limits, assemble_at), the notes loading writes and the
refusals (an unexpanded xacro, a missing file, `linkage urdf` given a description); `linkage
check` and `linkage range` in the description's joints and limits.

main(argv) runs in-process (capsys).
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest
from cli_helpers import loads, run
from description_helpers import (
    DRAKE,
    DRAKE_CLOSURES,
    FIXTURES,
    LEFT_KNUCKLE,
    RIGHT_KNUCKLE,
    ROBOTIQ,
    ROBOTIQ_CLOSURES,
    SIX_BAR,
    check_drake,
    solve_json,
)

from linkage_ros.cli.parser import main


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


def test_check_prints_the_notes_and_the_descriptions_joints(capsys):
    rc, out, err = run(capsys, 'check', SIX_BAR)
    assert rc == 0
    notes = [l for l in err.splitlines() if l.startswith('note: ')]
    assert len(notes) == 2  # open, and drawn flat between two assembly modes
    assert notes[0].startswith('note: the description is open by 0.3 m at joint1 = 0')
    assert notes[1].startswith("note: the description's pose is as near two assembly modes")
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
        assert r['inputs'][name]['drawn'] == pytest.approx(0.0, abs=1e-12)


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


def test_a_description_at_a_toggle_is_told_the_remedies_it_has(capsys):
    """A robot description's reference pose is its joints' zeros: the integrator does not redraw
    it, so the toggle warning names assemble_at and the branch setting instead (the GRBDA
    four-bar's zeros are its parallelogram folded flat)."""
    code, out, _ = run(capsys, 'check', str(FIXTURES / 'grbda_four_bar.urdf'))
    assert code == 0
    (warning,) = [line for line in out.splitlines() if 'toggle of' in line]
    assert 'assemble_at in a closure file' in warning and '--branch' in warning
    assert 'draw the pose' not in warning


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
