"""Helpers the command-line tests on robot descriptions share (test_cli_descriptions_*.py).

The fixture descriptions (URDF, SDF and their closure files) with the command and the loop
closures of each URDF, the command-line arguments that load and set one, a solve whose JSON
must be an answer, and the geometry Drake's SDF states (pins at (-2, 0) and (2, 0); driver 1 m,
rocker 2 m, coupler 4.8 m; each joint a rotation about +z from the drawn, unassembled pose).
"""

from __future__ import annotations

import math

import numpy as np
from cli_helpers import loads, run
from scenes import REPO

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
