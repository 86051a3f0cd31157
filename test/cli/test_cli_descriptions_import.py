"""`linkage import`: a robot description (URDF, SDF) written as an editable scene that solves
as the description does, written whole or not at all."""

from __future__ import annotations

import pytest
from cli_helpers import run
from description_helpers import (
    CASES,
    DRAKE,
    DRAKE_CLOSURES,
    SIX_BAR,
    description_args,
    set_args,
    solve_json,
)


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


@pytest.mark.parametrize(
    'edit, named',
    [
        (('  actuated:', '  actuatd:'), "joint_coordinates: unknown key(s) ['actuatd']"),
        (
            ('    revolute: true', '    revolute: "false"'),
            "joint_coordinates.outputs[0]: revolute must be true or false (got 'false')",
        ),
        (('  outputs:', '  outputz:'), "joint_coordinates: unknown key(s) ['outputz']"),
    ],
)
def test_an_edited_joint_coordinates_names_the_key_it_refuses(capsys, tmp_path, edit, named):
    """A misspelt key inside an imported scene's joint_coordinates is named (it was told only
    as "must be a mapping of ..." with the whole mapping echoed), and a revolute flag written as
    the string 'false' is refused (bool('false') read it as true: a prismatic joint published as
    revolute)."""
    scene = tmp_path / 'six.yaml'
    rc, _, err = run(capsys, 'import', SIX_BAR, '-o', scene)
    assert rc == 0, err
    text = scene.read_text()
    old, new = edit
    assert f'\n{old}' in text
    scene.write_text(text.replace(f'\n{old}', f'\n{new}', 1))
    rc, out, err = run(capsys, 'check', scene)
    assert rc == 2 and out == ''
    assert named in err, err
