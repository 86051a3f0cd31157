"""docs/ROBOT_DESCRIPTIONS.md is true: every `linkage` command it shows runs and exits 0 (from a
scratch folder, the repository's paths made absolute), and every node command names parameters
the node has with files that exist."""

from __future__ import annotations

import re
import shlex

import pytest
from scenes import REPO

from linkage_ros.cli.parser import main
from linkage_ros.params import PARAMETERS

DOC = REPO / 'docs' / 'ROBOT_DESCRIPTIONS.md'


def _commands(prefix: str) -> list[str]:
    """Commands starting with ``prefix`` in sh blocks (continuations joined) and in code spans
    that name a fixture (the others are prose: `linkage check DESCRIPTION`)."""
    text = DOC.read_text(encoding='utf-8')
    spans = re.finditer(r'`(' + re.escape(prefix) + r' [^`]+)`', text)
    out = [m.group(1) for m in spans if 'test/fixtures/' in m.group(1)]
    for block in re.findall(r'```sh\n(.*?)```', text, re.DOTALL):
        joined = re.sub(r'\\\n\s*', ' ', block)
        out += [
            line.split('#')[0].strip()
            for line in joined.splitlines()
            if line.strip().startswith(prefix + ' ')
        ]
    return list(dict.fromkeys(out))


def _absolute(words: list[str]) -> list[str]:
    return [str(REPO / w) if w.startswith('test/') else w for w in words]


CLI = _commands('linkage')
NODE = _commands('linkage_node')


def test_the_doc_shows_every_fixture_on_the_command_line_and_in_the_node():
    for fixture in (
        'grbda_four_bar.urdf',
        'grbda_six_bar.urdf',
        'robot.urdf',
        'drake_four_bar_loop.sdf',
        'picknik_robotiq_2f_85.expanded.urdf',
    ):
        assert any(fixture in c and ' solve ' in f' {c} ' for c in CLI), fixture
        assert any(fixture in c for c in NODE), fixture


@pytest.mark.parametrize('command', CLI)
def test_every_linkage_command_of_the_doc_runs(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    words = _absolute(shlex.split(command))[1:]
    if words[0] == 'solve' and words[1] == 'six_bar.yaml':  # the import example's second line
        assert (
            main(
                [
                    'import',
                    str(REPO / 'test/fixtures/robot_descriptions/grbda_six_bar.urdf'),
                    '-o',
                    'six_bar.yaml',
                ]
            )
            == 0
        )
    assert main(words) == 0, capsys.readouterr().err


@pytest.mark.parametrize('command', NODE)
def test_every_node_command_of_the_doc_names_real_parameters(command):
    names = {p.name for p in PARAMETERS}
    words = shlex.split(command)
    assert words[1] == '--ros-args'
    for flag, assignment in zip(words[2::2], words[3::2]):
        assert flag == '-p'
        name, _, value = assignment.partition(':=')
        assert name in names, name
        if value.startswith('test/'):
            assert (REPO / value).is_file(), value


def test_the_python_sections_solver_and_engine_modes_are_as_it_says():
    """'From Python': on the GRBDA four-bar at joint1 = 0.5 a Solver of its own answers the
    anti-parallelogram (joint2 = joint3) and the engine, or branch '-', the parallelogram
    (joint2 = -joint1, joint3 = joint1): the relations the section quotes, to 1e-12 rad."""
    from linkage_ros.core.loading import load_scene
    from linkage_ros.core.solver import Solver
    from linkage_ros.engine import Engine, EngineSettings

    text = DOC.read_text(encoding='utf-8')
    assert 'joint2 = joint3 = -1.3074 at' in text and "`Solver(mech, branch='-')`" in text
    mech = load_scene(str(REPO / 'test/fixtures/robot_descriptions/grbda_four_bar.urdf')).mechanism
    jc = mech.joint_coordinates
    known = jc.to_scene({'joint1': 0.5}, command=True)

    def values(joints):
        return dict(zip(jc.names, jc.positions(joints)))

    own = values(Solver(mech).solve(known).joints)
    assert abs(own['joint2'] - own['joint3']) < 1e-12 and round(own['joint2'], 4) == -1.3074
    for joints in (
        Solver(mech, branch='-').solve(known).joints,
        Engine(mech, EngineSettings()).command({'joint1': 0.5}).joints,
    ):
        got = values(joints)
        assert abs(got['joint2'] + 0.5) < 1e-12 and abs(got['joint3'] - 0.5) < 1e-12
