"""Structures: 0 DOF, no actuator (issue 18: refused as "the mechanism needs at least one
actuator"). An assembly question is valid: where the points go, in every assembly mode. The
oracle is the intersection of two circles, written here."""

from __future__ import annotations

import json
import math
import signal

import pytest
from ros_harness import NodeProcess, RosHarness, random_domain_id
from sensor_msgs.msg import JointState

from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

TRUSS = """\
name: truss
points: {{O1: [0, 0], O2: [{d}, 0], P: [{px}, {py}]}}
links: {{ground: [O1, O2], left: [O1, P], right: [O2, P]}}
"""


def circles(d, r1, r2):
    """Both intersections of the circle about (0, 0) with radius r1 and the one about (d, 0)
    with radius r2."""
    x = (d * d + r1 * r1 - r2 * r2) / (2 * d)
    h = math.sqrt(r1 * r1 - x * x)
    return (x, h), (x, -h)


@pytest.mark.parametrize('scale', [1e-6, 1e-3, 1.0, 1e3, 1e6])
def test_a_dyad_between_two_fixed_centres_is_solved_in_both_modes(scale):
    d, px, py = 0.4 * scale, 0.15 * scale, 0.2 * scale
    mech = Scene.from_dict(_yaml(d, px, py)).mechanism
    assert mech.dof == 0 and not mech.actuators
    r1, r2 = math.hypot(px, py), math.hypot(d - px, py)
    up, down = circles(d, r1, r2)
    s = Solver(mech)
    r = s.solve({})
    assert r.success and r.branch == '+'
    assert math.dist(r.points['P'], up) < 1e-14 * scale * 8
    modes = s.solve_all({})
    assert len(modes) == 2
    got = sorted((m.points['P'] for m in modes), key=lambda p: -p[1])
    for g, want in zip(got, (up, down)):
        assert math.dist(g, want) < 1e-14 * scale * 8
    assert Solver(mech, method='newton').solve({}).success


def _yaml(d, px, py):
    """TRUSS as a mapping (YAML 1.1 would read 4e-07 as a string)."""
    return {
        'name': 'truss',
        'points': {'O1': [0.0, 0.0], 'O2': [d, 0.0], 'P': [px, py]},
        'links': {'ground': ['O1', 'O2'], 'left': ['O1', 'P'], 'right': ['O2', 'P']},
    }


def test_the_cli_solves_a_structure_with_no_knowns(capsys, tmp_path):
    scene = tmp_path / 'truss.yaml'
    scene.write_text(TRUSS.format(d=0.4, px=0.15, py=0.2))
    assert cli_main(['solve', str(scene), '--all-branches', '--json']) == 0
    modes = json.loads(capsys.readouterr().out)
    assert [m['branch'] for m in modes] == ['+', '-']
    assert modes[0]['points']['P'] == pytest.approx([0.15, 0.2], abs=1e-15)
    assert modes[1]['points']['P'] == pytest.approx([0.15, -0.2], abs=1e-15)
    assert cli_main(['check', str(scene)]) == 0
    assert 'knowns none (a structure: 0 DOF)' in capsys.readouterr().out


def test_the_node_publishes_a_structure(tmp_path):
    """The node shows a structure: its reference pose on joint_states (publish_rate), and a
    demo sweep has nothing to sweep (refused at start-up, test_node_startup)."""
    scene = tmp_path / 'truss.yaml'
    scene.write_text(TRUSS.format(d=0.4, px=0.15, py=0.2))
    domain = random_domain_id()
    ros = RosHarness(domain)
    proc = NodeProcess(tmp_path, domain, {'scene': str(scene), 'publish_rate': 20.0}).start()
    try:
        joints = ros.collector(JointState, proc.topic('joint_states'))
        ros.wait_for_discovery([], [joints], 20.0, proc)
        assert ros.spin_until(lambda: len(joints) >= 1, 10.0, proc)
        got = dict(zip(joints.last.name, joints.last.position))
        # the joint at P: the right link's angle (O2 -> P) less the left link's (O1 -> P)
        assert got['P'] == pytest.approx(math.atan2(0.2, 0.15 - 0.4) - math.atan2(0.2, 0.15))
    finally:
        assert proc.stop(signal.SIGINT) == 0
        ros.close()
