"""Shared by the tests of imported descriptions against consumers that share nothing with
linkage_ros's core (test_description_consumers.py, test_description_sdf.py,
test_description_frames.py): the fixtures and their closure points (read off the fixtures by
hand, not taken from the importer), a Pinocchio model built from the same URDF text, the
description's joint values of an answer, and a small SDFormat pose evaluator (SdfModel).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
from oracles import homogeneous, rpy_matrix

FIXTURES = Path(__file__).resolve().parents[2] / 'fixtures' / 'robot_descriptions'

CLOSE = 1e-9  # of the mechanism's size

EXACT = 1e-12  # rad: actuated joints against the commanded values

FOUR_BAR = FIXTURES / 'grbda_four_bar.urdf'

SIX_BAR = FIXTURES / 'grbda_six_bar.urdf'

GEPETTO = FIXTURES / 'gepetto_5bar_linkage' / 'robot.urdf'

GEPETTO_SIDE = FIXTURES / 'gepetto_5bar_linkage' / 'robot.yaml'

DRAKE = FIXTURES / 'drake_four_bar_loop.sdf'

DRAKE_SIDE = FIXTURES / 'drake_four_bar_loop.closures.yaml'

ROBOTIQ = FIXTURES / 'picknik_robotiq_2f_85.expanded.urdf'

ROBOTIQ_SIDE = FIXTURES / 'picknik_robotiq_2f_85.closures.yaml'


SIX_BAR_PIN = (('link3', (0.3, 0.0, 0.0)), ('link5', (0.5, 0.0, 0.0)))


ROBOTIQ_KNUCKLE = 'robotiq_85_left_knuckle_joint'


def angle_diff(a: float, b: float) -> float:
    return abs(math.remainder(float(a) - float(b), 2.0 * math.pi))


# ---- Pinocchio -------------------------------------------------------------------------------


class PinocchioRobot:
    """Pinocchio's model of a URDF file and its forward kinematics at named joint values."""

    def __init__(self, path: Path | str):
        text = path.read_text() if isinstance(path, Path) else path
        self.model = pin.buildModelFromXML(text)
        self.data = self.model.createData()
        self.joints = [self.model.names[i] for i in range(1, self.model.njoints)]

    def place(self, values: dict[str, float]) -> None:
        """Forward kinematics at ``values``, which must name every moving joint of the model
        (a joint left out would silently sit at 0)."""
        assert set(values) == set(self.joints), (sorted(values), sorted(self.joints))
        q = pin.neutral(self.model)
        for jid in range(1, self.model.njoints):
            v, i = float(values[self.model.names[jid]]), self.model.idx_qs[jid]
            if self.model.joints[jid].nq == 2:  # continuous: (cos, sin)
                q[i], q[i + 1] = math.cos(v), math.sin(v)
            else:
                assert self.model.joints[jid].nq == 1
                q[i] = v
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)

    def frame(self, link: str) -> pin.SE3:
        return self.data.oMf[self.model.getFrameId(link)]

    def point(self, link: str, p) -> np.ndarray:
        m = self.frame(link)
        return m.rotation @ np.asarray(p, float) + m.translation


def described(mech, result) -> dict[str, float]:
    """The description's joint values of a solved result."""
    assert result.success, result.reason
    return dict(
        zip(mech.output_joint_names, map(float, mech.output_joints(result.joints, result.inputs)))
    )


def pin_miss(robot: PinocchioRobot, values, pins) -> float:
    robot.place(values)
    return max(float(np.linalg.norm(robot.point(*a) - robot.point(*b))) for a, b in pins)


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation about a unit axis (matrix exponential of the skew matrix, by its series)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    out, term = np.eye(3), np.eye(3)
    for n in range(1, 40):
        term = term @ (k * angle) / n
        out = out + term
    return out


class SdfModel:
    """An SDFormat 1.7 model: named frames (links, frames, joints), their initial poses, and
    joint-driven poses of the links. A joint's parent side is the frame its <parent> names
    when that is a <frame> (Drake's reading, which its four-bar needs: the links are drawn
    unassembled), else the joint frame's initial pose in the parent link (SDFormat's)."""

    def __init__(self, source: Path | str):
        text = source.read_text() if isinstance(source, Path) else source
        # Drake's comment holds '--' (its ASCII figure), which expat refuses: drop comments
        text = re.sub(r'<!--.*?-->', '', text, flags=re.DOTALL)
        model = ET.fromstring(text).find('model')
        self.el = {
            el.get('name'): el for tag in ('link', 'frame', 'joint') for el in model.iter(tag)
        }
        self.tag = {el.get('name'): el.tag for el in self.el.values()}
        self.joints = [el for el in model.findall('joint')]

    def parent_side(self, joint: ET.Element) -> np.ndarray:
        """The frame a joint's value turns about, in the parent link."""
        ref = joint.findtext('parent').strip()
        if self.tag.get(ref) == 'frame':
            return self.in_link(ref)
        return np.linalg.inv(self.initial(self.link_of(ref))) @ self.initial(joint.get('name'))

    def initial(self, name: str) -> np.ndarray:
        if name in ('world', '__model__'):
            return np.eye(4)
        el = self.el[name]
        pose = el.find('pose')
        default = {
            'link': '__model__',
            'frame': el.get('attached_to', '__model__'),
            'joint': (el.findtext('child') or '').strip(),
        }[el.tag]
        rel = pose.get('relative_to', default) if pose is not None else default
        v = [float(x) for x in (pose.text or '').split()] if pose is not None else [0.0] * 6
        v = v or [0.0] * 6
        return self.initial(rel) @ homogeneous(rpy_matrix(*v[3:]), v[:3])

    def link_of(self, name: str) -> str:
        if name in ('world', '__model__'):
            return 'world'
        el = self.el[name]
        if el.tag == 'link':
            return name
        if el.tag == 'frame':
            return self.link_of(el.get('attached_to', '__model__'))
        return self.link_of((el.findtext('child') or '').strip())

    def in_link(self, name: str) -> np.ndarray:
        """A frame's fixed pose in the link it is attached to."""
        return np.linalg.inv(self.initial(self.link_of(name))) @ self.initial(name)

    def poses(self, values: dict[str, float]):
        """World poses of the links at ``values`` (tree joints from the world outwards), and
        the joints left over (their child link was already placed: the loop joints)."""
        placed = {'world': np.eye(4)}
        pending = list(self.joints)
        progress = True
        while progress:
            progress = False
            for j in list(pending):
                parent_ref, child_ref = j.findtext('parent').strip(), j.findtext('child').strip()
                parent, child = self.link_of(parent_ref), self.link_of(child_ref)
                if parent in placed and child not in placed:
                    name = j.get('name')
                    x_wp = placed[parent] @ self.parent_side(j)
                    x_cj = self.in_link(name)  # the joint frame on the child
                    xyz = j.find('axis/xyz')
                    axis = np.array([float(v) for v in xyz.text.split()])
                    frame = xyz.get('expressed_in', name)
                    # the joint frame where the model is assembled: the parent <frame> itself
                    # (its child is joined to it), else the joint frame's initial pose
                    joint_frame = parent_ref if self.tag.get(parent_ref) == 'frame' else name
                    R_J = self.initial(joint_frame)[:3, :3]
                    axis = (R_J.T @ self.initial(frame)[:3, :3]) @ axis
                    axis /= np.linalg.norm(axis)
                    motion = homogeneous(axis_rotation(axis, values[name]), [0, 0, 0])
                    placed[child] = x_wp @ motion @ np.linalg.inv(x_cj)
                    pending.remove(j)
                    progress = True
        return placed, pending

    def loop_miss(self, values: dict[str, float]) -> float:
        """How far the one loop joint's two frames (its parent side, its frame on the child)
        are apart."""
        placed, loops = self.poses(values)
        assert len(loops) == 1
        j = loops[0]
        a = placed[self.link_of(j.findtext('parent').strip())] @ self.parent_side(j)
        b = placed[self.link_of(j.get('name'))] @ self.in_link(j.get('name'))
        return float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
