"""`linkage urdf` read by real URDF consumers: yourdfpy, Pinocchio, urdf_parser_py, and rcl's
parameter parser (``--ros-args -p robot_description:="$(linkage urdf SCENE)"``).

rcl reads a ``-p name:=value`` override as YAML and needs a string: the document must be one
plain YAML scalar (no ': ', ' #', line-ending ':'), which YAML folds (each line break and the
next line's indentation become one space: the same XML). Pinocchio keeps joints and links in
one namespace of frames, so every name must be unique, and its forward kinematics of every point
frame, driven by the joint_states the node publishes, must land on the solver's points (a second
oracle beside test_urdf.py's own numpy FK).
"""

from __future__ import annotations

import io
import math
import xml.etree.ElementTree as ET
from collections import Counter

import numpy as np
import pinocchio
import pytest
import rclpy
import scenes
import yaml
import yourdfpy
from builtin_interfaces.msg import Time
from rclpy.context import Context
from rclpy.node import Node
from test_urdf import SHIPPED, sweep
from urdf_parser_py.urdf import URDF

from linkage_ros.conversions import result_to_joint_state
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.core.urdf import link_frames, point_frame, urdf_document

PREFIXES = ['', 'left_', 'm1/']


def _folded(text: str) -> str:
    """``text`` as a YAML plain scalar: lines stripped and joined by single spaces."""
    return ' '.join(line.strip() for line in text.strip().splitlines())


def _canonical(text: str) -> str:
    return ET.canonicalize(text, strip_text=True)


def _names(text: str) -> tuple[list[str], list[str]]:
    """(URDF link names, URDF joint names) in document order."""
    robot = ET.fromstring(text)
    return [l.get('name') for l in robot.findall('link')], [
        j.get('name') for j in robot.findall('joint')
    ]


@pytest.mark.parametrize('stem', SHIPPED)
@pytest.mark.parametrize('prefix', PREFIXES)
def test_the_urdf_is_one_yaml_string(stem, prefix):
    """What rcl does with `-p robot_description:=TEXT`: parse TEXT as YAML; it must be a string
    (a ': ' in a comment made it a mapping, and every scene's override was refused), and that
    string the same XML."""
    text = urdf_document(scenes.load(stem), prefix=prefix)
    value = yaml.safe_load(text)
    assert isinstance(value, str)
    assert value == _folded(text)
    assert _canonical(value) == _canonical(text)  # still well-formed, the same document
    assert value.startswith('<?xml') and value.endswith('</robot>')


def test_rcl_takes_every_urdf_as_a_parameter_override():
    """The documented command line, parsed by rcl itself (rclpy.init with the arguments): the
    node gets a string parameter holding the URDF."""
    for stem in SHIPPED:
        text = urdf_document(scenes.load(stem), prefix='left_').rstrip('\n')  # as "$(...)"
        ctx = Context()
        rclpy.init(args=['rsp', '--ros-args', '-p', f'robot_description:={text}'], context=ctx)
        try:
            node = Node(
                'rsp_args', context=ctx, automatically_declare_parameters_from_overrides=True
            )
            value = node.get_parameter('robot_description').value
            node.destroy_node()
        finally:
            rclpy.shutdown(context=ctx)
        assert isinstance(value, str), (stem, value)
        assert _canonical(value) == _canonical(text), stem


@pytest.mark.parametrize('stem', SHIPPED)
@pytest.mark.parametrize('prefix', PREFIXES)
def test_yourdfpy_pinocchio_and_urdf_parser_py_read_every_scene(stem, prefix):
    mech = scenes.load(stem)
    text = urdf_document(mech, prefix=prefix)
    links, joints = _names(text)
    moving = [j for j in ET.fromstring(text).findall('joint') if j.get('type') != 'fixed']
    # yourdfpy
    robot = yourdfpy.URDF.load(io.BytesIO(text.encode()), build_scene_graph=True, load_meshes=False)
    assert [l.name for l in robot.robot.links] == links
    assert sorted(robot.actuated_joint_names) == sorted(j.get('name') for j in moving)
    assert robot.base_link == mech.frame_id
    robot.update_cfg(np.zeros(len(robot.actuated_joint_names)))
    # urdf_parser_py
    parsed = URDF.from_xml_string(text)
    assert [l.name for l in parsed.links] == links
    assert [j.name for j in parsed.joints] == joints
    assert parsed.get_root() == mech.frame_id
    # Pinocchio
    model = pinocchio.buildModelFromXML(text)
    assert sorted(model.names[1:]) == sorted(j.get('name') for j in moving)
    assert model.nv == len(moving)


@pytest.mark.parametrize('stem', SHIPPED)
@pytest.mark.parametrize('prefix', ['', 'left_'])
def test_every_pinocchio_frame_name_is_unique(stem, prefix):
    """A point frame named like the joint at the point (a pin 'A', a frame 'A') made
    getFrameId('A') answer whichever came first; a link named like its slide joint
    (slider_crank's 'slider') too. Now each URDF link and joint is exactly one frame."""
    mech = scenes.load(stem)
    text = urdf_document(mech, prefix=prefix)
    links, joints = _names(text)
    model = pinocchio.buildModelFromXML(text)
    count = Counter(f.name for f in model.frames)
    assert [n for n, k in count.items() if k > 1] == []
    assert set(count) == {'universe', *links, *joints}
    for name in links:
        assert model.existFrame(name)
        assert model.frames[model.getFrameId(name)].type == pinocchio.FrameType.BODY
    for name in joints:
        assert model.existFrame(name)
        assert model.frames[model.getFrameId(name)].type in (
            pinocchio.FrameType.JOINT,
            pinocchio.FrameType.FIXED_JOINT,
        )
    for p in mech.points:
        assert point_frame(p, prefix) in links
    assert set(link_frames(mech, prefix).values()) <= set(links)


def _configuration(model, values: dict[str, float]) -> np.ndarray:
    """Pinocchio's q from joint values by name (a continuous joint is (cos, sin) in q)."""
    q = pinocchio.neutral(model)
    for jid in range(1, model.njoints):
        joint, v = model.joints[jid], values[model.names[jid]]
        if joint.nq == 2:
            q[joint.idx_q : joint.idx_q + 2] = (math.cos(v), math.sin(v))
        else:
            assert joint.nq == 1, joint.shortname()
            q[joint.idx_q] = v
    return q


@pytest.mark.parametrize('stem', SHIPPED)
@pytest.mark.parametrize('prefix', ['', 'left_'])
def test_pinocchio_places_every_point_frame_where_the_solver_does(stem, prefix):
    mech = scenes.load(stem)
    model = pinocchio.buildModelFromXML(urdf_document(mech, prefix=prefix))
    data = model.createData()
    results = sweep(mech, n=12)
    assert len(results) >= 6, stem
    L = mech.length_scale
    frames = {p: model.getFrameId(point_frame(p, prefix)) for p in mech.points}
    for r in results:
        msg = result_to_joint_state(r, mech, Time(), mech.frame_id, prefix=prefix)
        pinocchio.framesForwardKinematics(
            model, data, _configuration(model, dict(zip(msg.name, msg.position)))
        )
        for p, (x, y) in r.points.items():
            got = data.oMf[frames[p]].translation
            err = max(abs(got[0] - x), abs(got[1] - y), abs(got[2]))
            assert err <= 1e-9 * L, f'{stem} point {p}: off by {err / L:.2e} L'


@pytest.mark.parametrize('drawn_side', [1, -1])
def test_pinocchio_places_a_roller_on_either_side_of_its_face(drawn_side):
    # a roller's prismatic joint is left out of the tree (its line is the drawn side's): the
    # tree through the pin's revolute joint places the roller in every mode, both sides
    mech = Scene.from_dict(scenes.roller_crank(drawn_side)).mechanism
    model = pinocchio.buildModelFromXML(urdf_document(mech))
    data = model.createData()
    frames = {p: model.getFrameId(point_frame(p)) for p in mech.points}
    modes = Solver(mech).modes({'crank': 2.0})
    assert len(modes.results) == 4
    for r in modes.results:
        msg = result_to_joint_state(r, mech, Time(), mech.frame_id)
        pinocchio.framesForwardKinematics(
            model, data, _configuration(model, dict(zip(msg.name, msg.position)))
        )
        for p, (x, y) in r.points.items():
            got = data.oMf[frames[p]].translation
            assert max(abs(got[0] - x), abs(got[1] - y), abs(got[2])) <= 1e-12, (r.branch, p)
