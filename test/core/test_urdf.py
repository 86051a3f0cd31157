"""`linkage urdf`: the scene as a URDF tree, checked by an independent forward kinematics.

The oracle below shares nothing with the solver or with core.urdf: it parses the XML, builds 4x4
homogeneous transforms from each joint's origin (xyz, rpy as URDF defines them) and axis, and
composes them from the root, driven by the joint values the node would publish
(conversions.result_to_joint_state). Every point frame must land on the solver's point to 1e-9
of the length scale, and every moving link frame's x axis must point along the solver's link
angle (the ground frame is the scene's coordinate frame). The limits of passive slides must hold
every value the node publishes, in every assembly mode; a prefix must not break the XML.
test_urdf_consumers.py checks the same documents with yourdfpy, Pinocchio, urdf_parser_py and
rcl's parameter parser.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import scenes
import yaml
from builtin_interfaces.msg import Time
from oracles import homogeneous, rpy_matrix

from linkage_ros.conversions import result_to_joint_state
from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import AngleActuator, Scene
from linkage_ros.core.motion import input_ranges
from linkage_ros.core.solver import Solver
from linkage_ros.core.urdf import (
    JointKind,
    link_frames,
    point_frame,
    prefix_error,
    spanning_tree,
    urdf_document,
)
from linkage_ros.params import ConfigError, make_config

SHIPPED = scenes.SHIPPED


# ---- the oracle: URDF forward kinematics from the XML alone -------------------------------------


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
            t = out[parent] @ homogeneous(rpy_matrix(*rpy), xyz)
            kind = j.get('type')
            if kind != 'fixed':
                axis = np.array([float(v) for v in j.find('axis').get('xyz').split()])
                q = values[j.get('name')]
                if kind == 'prismatic':
                    t = t @ homogeneous(np.eye(3), axis * q)
                else:
                    t = t @ homogeneous(_axis_angle(axis, q), np.zeros(3))
            child = j.find('child').get('link')
            out[child] = t
            stack.append(child)
    assert set(out) == set(links), 'links not reached from the root'
    return out


# ---- sweeps of every shipped scene ---------------------------------------------------------------


def sweep(mech, n: int = 40, seed: int = 7):
    """Successful continuous solves along a random walk through the actuators' ranges."""
    rng = np.random.default_rng(seed)
    ranges = input_ranges(mech)
    solver = Solver(mech, knowns=list(mech.actuators), branch='continuous')
    ref = solver.reference_values()
    lows, highs = [], []
    for a, act in mech.actuators.items():
        lo, hi = ranges[a]
        if lo is None or hi is None:
            lo, hi = (
                (-math.pi, math.pi)
                if isinstance(act, AngleActuator)
                else (ref[a] * 0.9, ref[a] * 1.1)
            )
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
    results = sweep(mech)
    assert len(results) >= 20, f'{stem}: only {len(results)} solves succeeded'
    L = mech.length_scale
    for r in results:
        msg = result_to_joint_state(r, mech, Time(), mech.frame_id, prefix=prefix)
        fk = urdf_fk(text, dict(zip(msg.name, msg.position)))
        for p, (x, y) in r.points.items():
            t = fk[point_frame(p, prefix)]
            err = max(abs(t[0, 3] - x), abs(t[1, 3] - y), abs(t[2, 3]))
            assert err <= 1e-9 * L, f'{stem} point {p}: off by {err / L:.2e} L'
        frames = link_frames(mech, prefix)
        np.testing.assert_array_equal(fk[frames[mech.ground]], np.eye(4))  # scene coordinates
        for link, angle in r.links.items():
            if link == mech.ground:
                continue
            t = fk[frames[link]]
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
    links = {'m1/link_' + l if l in mech.joint_names else 'm1/' + l for l in mech.links}
    assert frames == {mech.frame_id} | links | {'m1/point_' + p for p in mech.points}
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
    # widened by the limit rule's slack (model.limits.slack: 1e-12 of the limit, at least 1e-12)
    assert float(lim.get('lower')) == -1.45 - 1.45e-12
    assert float(lim.get('upper')) == 1.45 + 1.45e-12
    # four_bar's crank turns fully: continuous, no limit
    fb = ET.fromstring(urdf_document(scenes.load('four_bar')))
    assert next(j for j in fb.findall('joint') if j.get('name') == 'O2').get('type') == (
        'continuous'
    )


def test_a_link_named_like_a_point_or_a_joint_gets_a_frame_of_its_own():
    """SCENES.md: a link named like a joint is framed ``link_<link>`` (it was refused as naming
    "both a point and a link"); the oracle FK still puts every point frame on the solver's."""
    mech = Scene.from_dict(
        {
            'name': 'clash',
            'points': {'O2': [0, 0], 'O4': [1, 0], 'A': [0, 0.4], 'crank': [1.1, 0.6]},
            'ground': 'ground',
            'links': {
                'ground': ['O2', 'O4'],
                'A': ['O2', 'A'],
                'coupler': ['A', 'crank'],
                'crank': ['O4', 'crank'],
            },
            'actuators': {'theta': {'type': 'angle', 'link': 'A', 'pivot': 'O2', 'toward': 'A'}},
        }
    ).mechanism
    robot = ET.fromstring(urdf_document(mech))
    links = [l.get('name') for l in robot.findall('link')]
    joints = [j.get('name') for j in robot.findall('joint')]
    # (the pin at point 'crank' closes the loop: a comment, not a URDF joint)
    assert {'link_A', 'link_crank'} <= set(links) and 'A' in joints
    assert len(set(links + joints)) == len(links) + len(joints)  # one namespace, no repeats
    text = urdf_document(mech)
    for theta in (1.3, 2.0, -1.0):
        r = Solver(mech).solve({'theta': theta})
        assert r.success
        msg = result_to_joint_state(r, mech, Time(), mech.frame_id)
        fk = urdf_fk(text, dict(zip(msg.name, msg.position)))
        for p, (x, y) in r.points.items():
            t = fk[point_frame(p)]
            assert max(abs(t[0, 3] - x), abs(t[1, 3] - y)) <= 1e-12, (theta, p)


#: angle actuators measured from +x beside a ground whose axis is not +x (the ground's
#: reported angle, which joint values count from): shortcut, general and pivots forms
TILTED_GROUNDS = {
    'shortcut ground_angle': {
        'four_bar': {
            'ground': 0.3,
            'crank': 0.1,
            'coupler': 0.25,
            'rocker': 0.2,
            'ground_angle': '10deg',
            'input': '60deg',
            'crank_limits': {'min': '-90deg', 'max': '170deg'},
        }
    },
    'general tilted ground': {
        'points': {'O2': [0, 0], 'A': [0.05, 0.0866], 'B': [0.3, 0.25], 'O4': [0.3, 0.1]},
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': ['A', 'B'],
            'rocker': ['O4', 'B'],
        },
        'actuators': {
            'crank': {
                'type': 'angle',
                'link': 'crank',
                'pivot': 'O2',
                'min': '-20deg',
                'max': '90deg',
            }
        },
    },
    'shortcut pivots': {
        'four_bar': {
            'crank': 0.1,
            'coupler': 0.25,
            'rocker': 0.2,
            'pivots': {'O2': [1.0, 1.0], 'O4': [1.3, 0.9]},
            'input': '20deg',
            'crank_limits': {'min': '-30deg', 'max': '100deg'},
        }
    },
}


@pytest.mark.parametrize('case', sorted(TILTED_GROUNDS))
def test_a_limited_crank_beside_a_tilted_ground_has_the_joint_limits_it_is_published_with(case):
    """The crank's URDF <limit> are the joint values published at its limits (the joint counts
    from the ground's axis, the actuator from +x: the limits were written unshifted, so a
    command at the lower limit was published below the URDF's lower limit)."""
    mech = Scene.from_dict(TILTED_GROUNDS[case]).mechanism
    assert mech.links[mech.ground].angle_ref != 0.0  # the premise: a tilted ground
    lo, hi = _limits(urdf_document(mech))['O2']
    act = mech.actuators['crank']
    solver = Solver(mech, branch='continuous')
    published = []
    for v in np.linspace(act.min, act.max, 41):
        r = solver.solve({'crank': float(v)})
        assert r.success, (v, r.reason)
        msg = result_to_joint_state(r, mech, Time(), mech.frame_id)
        published.append(dict(zip(msg.name, msg.position))['O2'])
    # the limits are the published values at the limits, widened by the limit rule's slack
    # (1e-12 of the limit) so that a value an ulp past them still lies inside, as the node
    # answers it; strictly inside, no tolerance
    assert 0.0 <= published[0] - lo <= 2e-12 * max(1.0, abs(lo))
    assert 0.0 <= hi - published[-1] <= 2e-12 * max(1.0, abs(hi))
    assert all(lo <= q <= hi for q in published)
    with pytest.raises(SceneError, match="frame_id 'A' is also the name"):
        urdf_document(scenes.load('four_bar'), frame_id='A')
    with pytest.raises(SceneError, match="frame_id 'point_A' is also the name"):
        urdf_document(scenes.load('four_bar'), frame_id='point_A')
    # a link named like a point's frame: two frames 'point_P'
    renamed = {
        'name': 'clash',
        'points': {'O2': [0, 0], 'O4': [1, 0], 'A': [0, 0.4], 'B': [1.1, 0.6], 'P': [0.5, 0.9]},
        'ground': 'ground',
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'point_P': ['A', 'B', 'P'],
            'rocker': ['O4', 'B'],
        },
        'actuators': {'theta': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}},
    }
    with pytest.raises(SceneError, match=r"\['point_P'\] would each name two frames"):
        urdf_document(Scene.from_dict(renamed).mechanism)


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


# ---- limits of passive slides: every assembly mode -----------------------------------------------


def _limits(text: str) -> dict[str, tuple[float, float]]:
    robot = ET.fromstring(text)
    return {
        j.get('name'): (float(j.find('limit').get('lower')), float(j.find('limit').get('upper')))
        for j in robot.findall('joint')
        if j.find('limit') is not None
    }


def _inputs(mech, n: int, seed: int = 11) -> list[dict[str, float]]:
    """Commands over the actuators' ranges (the scene's limits, else a full turn or +-L): a fine
    grid for one actuator (and its assembly's own range), random points for more."""
    rng = np.random.default_rng(seed)
    own = input_ranges(mech)
    axes = {}
    for a, act in mech.actuators.items():
        lo, hi = act.min, act.max
        if lo is None or hi is None:
            ref = Solver(mech).reference_values()[a]
            lo, hi = (
                (-math.pi, math.pi) if isinstance(act, AngleActuator) else (ref - 1.0, ref + 1.0)
            )
        axes[a] = (lo, hi)
    if len(axes) == 1:
        ((a, (lo, hi)),) = axes.items()
        grid = list(np.linspace(lo, hi, n)) + list(rng.uniform(lo, hi, n // 2))
        if None not in own[a]:
            grid += list(np.linspace(*own[a], n // 2))
        return [{a: float(v)} for v in grid]
    return [{a: float(rng.uniform(lo, hi)) for a, (lo, hi) in axes.items()} for _ in range(n)]


#: the shipped scenes with a prismatic joint in their URDF tree (inverted_slider_crank's slides
#: close its loop: they are not in the tree)
SLIDERS = [
    s
    for s in SHIPPED
    if any(j.kind is JointKind.PRISMATIC for j in spanning_tree(scenes.load(s)).joints)
]


@pytest.mark.parametrize('stem', SLIDERS)
def test_published_joint_values_lie_within_the_urdf_limits_in_every_mode(stem):
    """Every branch (each sign combination of the dyad plan, as `linkage solve --branch` and the
    node's branch parameter give it) and the continuous walk: no joint_states value of a joint
    with a <limit> lies outside it (the passive slides' limits once covered only the reference
    mode: slider_crank's slider at crank = 1.0 on branch '-' was below its lower limit)."""
    mech = scenes.load(stem)
    limits = _limits(urdf_document(mech))
    commands = _inputs(mech, 1201 if len(mech.actuators) == 1 else 200)
    k = Solver(mech).branch_count
    branches = [''.join(s) for s in itertools.product('+-', repeat=k)] if k else ['reference']
    checked = 0
    for branch in [*branches, 'continuous']:
        solver = Solver(mech, branch=branch)
        for values in commands:
            r = solver.solve(values)
            if not r.success:
                continue
            msg = result_to_joint_state(r, mech, Time(), mech.frame_id)
            for name, q in zip(msg.name, msg.position):
                if name in limits:
                    lo, hi = limits[name]
                    assert lo - 1e-12 <= q <= hi + 1e-12, (stem, branch, values, name, q, lo, hi)
                    checked += 1
    assert checked > 1000, checked  # 2000+ for a lone crank, 3000+ for the excavator


def test_a_newton_scene_bounds_its_slides_in_every_mode_found():
    """Where Newton places the links no plan lists the modes: the limits are a bound that holds
    in all of them (the shortest chain of rigid distances from the slide's origin to its point)."""
    mech = dataclasses.replace(scenes.load('slider_crank'), solver='newton')
    solver = Solver(mech)
    assert solver.mode == 'newton'
    lo, hi = _limits(urdf_document(mech))['slider']
    seen = []
    for crank in np.linspace(-math.pi, math.pi, 25):
        modes = solver.modes({'crank': float(crank)})
        seen += [r.joints['slider'] for r in modes.results]
    assert len(seen) >= 45  # both modes nearly everywhere
    assert lo <= min(seen) < 0 < max(seen) <= hi
    assert hi - lo < 0.5  # crank + rod + offset = 0.24 m each way, not an arbitrary span


# ---- names and text that cannot break the XML ---------------------------------------------------


def test_prefix_must_be_a_frame_prefix():
    for good in ('', 'left_', 'm1/', 'arm-2.', 'a/b_'):
        assert prefix_error(good) is None, good
        assert make_config({'prefix': good}).prefix == good
    for bad in ('x--><injected/><!--', 'a--b', '/left', 'a b', 'a<b', 'a>b', 'a&b', "a'b", 'a"b'):
        assert prefix_error(bad), bad
        with pytest.raises(ConfigError, match="'prefix': must be a string without whitespace"):
            make_config({'prefix': bad})
        with pytest.raises(ValueError, match="no '--'"):
            urdf_document(scenes.load('four_bar'), prefix=bad)
    assert prefix_error(3) and prefix_error(None)
    run = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', 'urdf', 'four_bar', '--prefix', 'x--><i/><!--'],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2 and run.stdout == ''
    (line,) = run.stderr.splitlines()
    assert line.startswith('linkage urdf: error: --prefix must be a string without whitespace')
    assert "(got 'x--><i/><!--')" in line


def test_comments_cannot_be_closed_by_the_scene_path(tmp_path):
    """The scene's path goes into a comment: '--' (which ends an XML comment), '-->', and YAML's
    ': ' and ' #' in it are quoted, so the document stays well-formed and one YAML string."""
    folder = tmp_path / 'x--><injected/><!-- a: b #c -'
    folder.mkdir(parents=True)  # its '/' makes two folders
    path = folder / 'fb--.yaml'
    shutil.copy(scenes.CONFIG / 'four_bar.yaml', path)
    run = subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', 'urdf', str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stderr
    robot = ET.fromstring(run.stdout)
    assert {e.tag for e in robot} == {'material', 'link', 'joint'}
    assert yaml.safe_load(run.stdout).startswith('<?xml')
    (comment,) = re.findall(r'<!--(.*?)-->', run.stdout.split('loop-closing')[0], re.S)
    assert '--' not in comment and 'x-%2D%3E%3Cinjected' in comment, comment
