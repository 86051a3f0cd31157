"""`linkage urdf`: the scene as a URDF tree, checked by an independent forward kinematics.

The oracle below shares nothing with the solver or with core.urdf: it parses the XML, builds 4x4
homogeneous transforms from each joint's origin (xyz, rpy as URDF defines them) and axis, and
composes them from the root, driven by the joint values the node would publish
(conversions.result_to_joint_state). Every point frame must land on the solver's point to 1e-9
of the length scale, and every moving link frame's x axis must point along the solver's link
angle (the ground frame is the scene's coordinate frame).
"""

from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import scenes
from builtin_interfaces.msg import Time

from linkage_ros.conversions import result_to_joint_state
from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.motion import input_ranges
from linkage_ros.core.solver import Solver
from linkage_ros.core.urdf import urdf_document

SHIPPED = sorted(p.stem for p in scenes.CONFIG.glob('*.yaml'))


# ---- the oracle: URDF forward kinematics from the XML alone -------------------------------------


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    """URDF rpy: fixed-axis roll about x, then pitch about y, then yaw about z."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _homogeneous(rot: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = rot, xyz
    return t


def _axis_angle(axis: np.ndarray, q: float) -> np.ndarray:
    """Rodrigues' rotation about a unit axis."""
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(q) * kx + (1 - math.cos(q)) * (kx @ kx)


def urdf_fk(text: str, values: dict[str, float]) -> dict[str, np.ndarray]:
    """{URDF link: 4x4 transform from the root} with joints at ``values`` (by joint name)."""
    robot = ET.fromstring(text)
    children: dict[str, list[ET.Element]] = {}
    has_parent = set()
    for j in robot.findall('joint'):
        parent = j.find('parent').get('link')
        child = j.find('child').get('link')
        assert child not in has_parent, f'link {child} has two parents: not a tree'
        has_parent.add(child)
        children.setdefault(parent, []).append(j)
    links = [l.get('name') for l in robot.findall('link')]
    roots = [l for l in links if l not in has_parent]
    assert len(roots) == 1, roots
    out = {roots[0]: np.eye(4)}
    stack = [roots[0]]
    while stack:
        parent = stack.pop()
        for j in children.get(parent, []):
            o = j.find('origin')
            xyz = np.array([float(v) for v in o.get('xyz').split()])
            rpy = [float(v) for v in o.get('rpy').split()]
            t = out[parent] @ _homogeneous(_rpy(*rpy), xyz)
            kind = j.get('type')
            if kind != 'fixed':
                axis = np.array([float(v) for v in j.find('axis').get('xyz').split()])
                q = values[j.get('name')]
                if kind == 'prismatic':
                    t = t @ _homogeneous(np.eye(3), axis * q)
                else:
                    t = t @ _homogeneous(_axis_angle(axis, q), np.zeros(3))
            child = j.find('child').get('link')
            out[child] = t
            stack.append(child)
    assert set(out) == set(links), 'links not reached from the root'
    return out


# ---- sweeps of every shipped scene ---------------------------------------------------------------


def _sweep(mech, n: int = 40, seed: int = 7):
    """Successful continuous solves along a random walk through the actuators' ranges."""
    rng = np.random.default_rng(seed)
    ranges = input_ranges(mech)
    solver = Solver(mech, knowns=list(mech.actuators), branch='continuous')
    ref = solver.reference_values()
    lows, highs = [], []
    for a, act in mech.actuators.items():
        lo, hi = ranges[a]
        if lo is None or hi is None:
            lo, hi = (-math.pi, math.pi) if act.kind == 'angle' else (ref[a] * 0.9, ref[a] * 1.1)
        span = hi - lo
        lows.append(lo + 0.02 * span)
        highs.append(hi - 0.02 * span)
    out = []
    for t in np.linspace(0.0, 1.0, n):
        wobble = 0.5 + 0.5 * math.sin(2 * math.pi * t)
        values = {
            a: lo + (hi - lo) * (wobble if k % 2 == 0 else t)
            for k, (a, lo, hi) in enumerate(zip(mech.actuators, lows, highs))
        }
        r = solver.solve(values)
        if r.success:
            out.append(r)
    rng.shuffle(out)
    return out


@pytest.mark.parametrize('stem', SHIPPED)
@pytest.mark.parametrize('prefix', ['', 'left_'])
def test_urdf_frames_follow_the_solver(stem, prefix):
    mech = scenes.load(stem)
    text = urdf_document(mech, prefix=prefix)
    results = _sweep(mech)
    assert len(results) >= 20, f'{stem}: only {len(results)} solves succeeded'
    L = mech.length_scale
    for r in results:
        msg = result_to_joint_state(r, mech.joint_names, Time(), mech.frame_id, prefix=prefix)
        fk = urdf_fk(text, dict(zip(msg.name, msg.position)))
        for p, (x, y) in r.points.items():
            t = fk[prefix + p]
            err = max(abs(t[0, 3] - x), abs(t[1, 3] - y), abs(t[2, 3]))
            assert err <= 1e-9 * L, f'{stem} point {p}: off by {err / L:.2e} L'
        np.testing.assert_array_equal(fk[prefix + mech.ground], np.eye(4))  # scene coordinates
        for link, angle in r.links.items():
            if link == mech.ground:
                continue
            t = fk[prefix + link]
            got = math.atan2(t[1, 0], t[0, 0])
            assert abs(math.remainder(got - angle, 2 * math.pi)) <= 1e-9, (stem, link)
            assert abs(t[2, 2] - 1.0) <= 1e-12  # stays planar


@pytest.mark.parametrize('stem', SHIPPED)
def test_urdf_joints_are_the_published_joints(stem):
    mech = scenes.load(stem)
    robot = ET.fromstring(urdf_document(mech, prefix='m1/'))
    moving = {j.get('name') for j in robot.findall('joint') if j.get('type') != 'fixed'}
    published = {'m1/' + n for n in mech.joint_names}
    assert moving <= published
    cut = published - moving
    # a spanning tree keeps links - 1 joints; the rest close the loops and are listed
    assert len(moving) == len(mech.links) - 1
    comments = urdf_document(mech, prefix='m1/')
    for name in cut:
        assert name in comments.split('loop-closing joints')[1].split('-->')[0]
    frames = {l.get('name') for l in robot.findall('link')}
    assert frames == {mech.frame_id} | {'m1/' + n for n in (*mech.links, *mech.points)}
    for j in robot.findall('joint'):
        if j.get('type') in ('revolute', 'prismatic'):
            lim = j.find('limit')
            assert float(lim.get('lower')) < float(lim.get('upper'))


def test_urdf_limits_are_the_scene_limits():
    exc = ET.fromstring(urdf_document(scenes.load('excavator')))
    z1 = next(j for j in exc.findall('joint') if j.get('name') == 'Z1')
    assert (z1.get('type'), z1.find('limit').get('lower'), z1.find('limit').get('upper')) == (
        'prismatic',
        '1.1',
        '1.8',
    )
    # scott_russell: crank -1.45..1.45 rad from the ground's direction, joint O2 = crank angle
    # minus the ground link's angle; the ground has one point, so its angle is 0
    sr = ET.fromstring(urdf_document(scenes.load('scott_russell')))
    o2 = next(j for j in sr.findall('joint') if j.get('name') == 'O2')
    lim = o2.find('limit')
    assert o2.get('type') == 'revolute'
    assert float(lim.get('lower')) == pytest.approx(-1.45, abs=1e-12)
    assert float(lim.get('upper')) == pytest.approx(1.45, abs=1e-12)
    # four_bar's crank turns fully: continuous, no limit
    fb = ET.fromstring(urdf_document(scenes.load('four_bar')))
    assert next(j for j in fb.findall('joint') if j.get('name') == 'O2').get('type') == (
        'continuous'
    )


def test_point_and_link_of_one_name_are_refused():
    mech = Scene.from_dict(
        {
            'name': 'clash',
            'points': {'O2': [0, 0], 'O4': [1, 0], 'A': [0, 0.4], 'crank': [1.1, 0.6]},
            'ground': 'ground',
            'links': {
                'ground': ['O2', 'O4'],
                'crank': ['O2', 'A'],
                'coupler': ['A', 'crank'],
                'rocker': ['O4', 'crank'],
            },
            'actuators': {
                'theta': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}
            },
        }
    ).mechanism
    with pytest.raises(SceneError, match=r"\['crank'\] name both a point and a link"):
        urdf_document(mech)
    with pytest.raises(SceneError, match="frame_id 'A' is also the name"):
        urdf_document(scenes.load('four_bar'), frame_id='A')


def test_cli_urdf_writes_the_file_and_refuses_bad_input(tmp_path):
    out = tmp_path / 'fb.urdf'
    run = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', 'urdf', 'four_bar', '--prefix', 'a_', '-o', out],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stderr
    robot = ET.parse(out).getroot()
    assert robot.get('name') == 'a_four_bar'
    assert [p.name for p in tmp_path.iterdir()] == ['fb.urdf']  # no temporary file left
    stdout = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', 'urdf', 'excavator', '--frame-id', 'world'],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert stdout.returncode == 0
    assert ET.fromstring(stdout.stdout).find('link').get('name') == 'world'
    bad = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', 'urdf', 'four_bar', '--prefix', 'a b'],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert bad.returncode == 2 and 'prefix' in bad.stderr and 'Traceback' not in bad.stderr
