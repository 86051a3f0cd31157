"""Property tests: random planar four-bars and slider-cranks, written as URDF+ ``<loop>`` text in
a random plane orientation, imported from text, solved, and checked against oracles written
here.

Each chain is drawn the way real files are: unassembled (the coupler and the rocker or block
at random angles or positions, the loop open), every joint frame turned at random (its axis
written in its own frame so that every revolute axis is along one random normal n, with a
random sense, and the prismatic axis perpendicular to it), every pin at a random depth along n,
the whole chain rotated and moved at random and scaled from 1 cm to 100 m. Slider-cranks are
cut at the rod-block pin (a revolute loop; the block on a prismatic joint) or at the slide (a
prismatic loop between two frames that keep one orientation), with the block's slide frame at
its pin or elsewhere on the block. The oracles:

* the four-bar's coupler pin by intersecting two circles (crank pin, coupler length; rocker
  pivot, rocker length), the slider-crank's by intersecting a circle with the block pin's
  line: reachable exactly when they meet; where the solver's plan is a dyad, its two assembly
  modes (branches '+' and '-', ``Solver.modes``) are the two intersections, and where it
  places the chain by Newton each answer is one of them;
* a numpy forward kinematics of the URDF text (parsed here with xml.etree), driven by the
  imported description's joint values, which must close the loop (a revolute loop's two frames
  meet in the plane; a prismatic loop's keep one orientation, the successor on the
  predecessor's axis) with the pin at the oracle's, and the actuated joint at its commanded
  value. All to 1e-9 of the mechanism's size.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from linkage_ros.core.description import import_description
from linkage_ros.core.solver import Solver

CLOSE = 1e-9  # of the mechanism's size
SWEEP = np.linspace(-math.pi, math.pi, 25)

# ---- rotations and the URDF forward kinematics (numpy, nothing from linkage_ros) -------------


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: Rz(y) Ry(p) Rx(r)."""
    cx, sx = math.cos(r), math.sin(r)
    cy, sy = math.cos(p), math.sin(p)
    cz, sz = math.cos(y), math.sin(y)
    rx = np.array([[1.0, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1.0, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1.0]])
    return rz @ ry @ rx


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation about a unit axis: the rotation taking the axis to z, Rz(angle), and back."""
    axis = axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    frame = np.column_stack([e1, np.cross(axis, e1), axis])
    c, s = math.cos(angle), math.sin(angle)
    return frame @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]) @ frame.T


def homogeneous(rot: np.ndarray, xyz) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rot, xyz
    return out


def origin_matrix(el: ET.Element | None) -> np.ndarray:
    if el is None:
        return np.eye(4)
    xyz = [float(v) for v in el.get('xyz', '0 0 0').split()]
    rpy = [float(v) for v in el.get('rpy', '0 0 0').split()]
    return homogeneous(rpy_matrix(*rpy), xyz)


def urdf_fk(text: str, values: dict[str, float]) -> dict[str, np.ndarray]:
    """World poses of every link of a URDF at ``values`` (every movable joint must be given)."""
    robot = ET.fromstring(text)
    joints = robot.findall('joint')
    children = {j.find('child').get('link') for j in joints}
    roots = [l.get('name') for l in robot.findall('link') if l.get('name') not in children]
    assert len(roots) == 1
    pose = {roots[0]: np.eye(4)}
    pending = list(joints)
    while pending:
        j = next(j for j in pending if j.find('parent').get('link') in pose)
        pending.remove(j)
        kind, name = j.get('type'), j.get('name')
        motion = np.eye(4)
        if kind != 'fixed':
            axis = np.array([float(v) for v in j.find('axis').get('xyz').split()])
            q = values[name]
            if kind in ('revolute', 'continuous'):
                motion = homogeneous(axis_angle(axis, q), [0, 0, 0])
            else:
                assert kind == 'prismatic'
                motion = homogeneous(np.eye(3), axis / np.linalg.norm(axis) * q)
        parent = pose[j.find('parent').get('link')]
        pose[j.find('child').get('link')] = parent @ origin_matrix(j.find('origin')) @ motion
    return pose


def loop_miss(text: str, values: dict[str, float], normal: np.ndarray) -> float:
    """How far the URDF's ``<loop>`` is from closed at ``values`` (m): a revolute loop's two
    frames' origins apart in the plane normal to ``normal``; a prismatic loop's successor
    origin off the line through the predecessor's along its axis (in the plane), and the two
    frames' rotations apart (times the successor's distance from the world origin + 1 m)."""
    robot = ET.fromstring(text)
    pose = urdf_fk(text, values)
    loop = robot.find('loop')
    xa, xb = (
        pose[loop.find(t).get('link')] @ origin_matrix(loop.find(t).find('origin'))
        for t in ('predecessor', 'successor')
    )
    gap = xb[:3, 3] - xa[:3, 3]
    gap = gap - (gap @ normal) * normal
    if loop.get('type') == 'revolute':
        return float(np.linalg.norm(gap))
    axis = xa[:3, :3] @ np.array([float(v) for v in loop.find('axis').get('xyz').split()])
    axis /= np.linalg.norm(axis)
    off = float(np.linalg.norm(gap - (gap @ axis) * axis))
    turn = float(np.abs(xa[:3, :3] - xb[:3, :3]).max())
    return max(off, turn * (1.0 + float(np.linalg.norm(xb[:3, 3]))))


def point_of(text: str, values: dict[str, float], link: str, xyz) -> np.ndarray:
    return (urdf_fk(text, values)[link] @ np.array([*xyz, 1.0]))[:3]


# ---- random chains ---------------------------------------------------------------------------


def cross2(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def fmt(v) -> str:
    return ' '.join(repr(float(x)) for x in v)


@dataclass
class Plane:
    """The chain's plane: in-plane (x, y) and depth d -> world = t + R (x, y, d)."""

    rot: np.ndarray
    origin: np.ndarray

    @property
    def normal(self) -> np.ndarray:
        return self.rot[:, 2]

    def world(self, xy, depth: float) -> np.ndarray:
        return self.origin + self.rot @ np.array([xy[0], xy[1], depth])

    def in_plane(self, p: np.ndarray) -> np.ndarray:
        return (self.rot.T @ (p - self.origin))[:2]

    def direction(self, u) -> np.ndarray:
        return self.rot @ np.array([u[0], u[1], 0.0])


class Writer:
    """Writes the URDF of a chain joint by joint, each joint frame at a world point with a
    random rotation relative to its parent link, the axis in the joint's own frame."""

    def __init__(self, name: str):
        self.name = name
        self.frames: dict[str, np.ndarray] = {'base_link': np.eye(4)}
        self.links = ['base_link']
        self.lines: list[str] = []

    def joint(
        self, name, kind, parent, child, point, rpy, axis_world, independent: bool
    ) -> np.ndarray:
        x_parent = self.frames[parent]
        rot = x_parent[:3, :3] @ rpy_matrix(*rpy)
        x_joint = homogeneous(rot, point)
        xyz = (np.linalg.inv(x_parent) @ x_joint)[:3, 3]
        axis = rot.T @ axis_world
        self.frames[child] = x_joint
        self.links.append(child)
        flag = 'true' if independent else 'false'
        self.lines.append(
            f'  <joint name="{name}" type="{kind}" independent="{flag}">\n'
            f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
            f'    <origin xyz="{fmt(xyz)}" rpy="{fmt(rpy)}"/>\n'
            f'    <axis xyz="{fmt(axis)}"/>\n'
            f'    <limit lower="-10000" upper="10000" effort="1" velocity="1"/>\n'
            f'  </joint>'
        )
        return x_joint

    def end(self, link: str, x_world: np.ndarray) -> tuple[str, np.ndarray, tuple]:
        """A loop end: a frame with world pose ``x_world`` (in the drawing) fixed in ``link``,
        as (link, xyz, rpy) in the link's frame."""
        rel = np.linalg.inv(self.frames[link]) @ x_world
        return link, rel[:3, 3], matrix_rpy(rel[:3, :3])

    def loop(self, kind: str, ends, axis_world: np.ndarray) -> None:
        """``ends``: two (link, xyz, rpy) of :meth:`end`; the axis is written in the
        predecessor's frame."""
        parts = []
        for tag, (link, xyz, rpy) in zip(('predecessor', 'successor'), ends):
            parts.append(
                f'    <{tag} link="{link}">\n'
                f'      <origin xyz="{fmt(xyz)}" rpy="{fmt(rpy)}"/>\n'
                f'    </{tag}>'
            )
        link, _, rpy = ends[0]
        axis = (self.frames[link][:3, :3] @ rpy_matrix(*rpy)).T @ axis_world
        self.lines.append(
            f'  <loop name="cut" type="{kind}">\n'
            + '\n'.join(parts)
            + f'\n    <axis xyz="{fmt(axis)}"/>\n  </loop>'
        )

    def text(self) -> str:
        links = '\n'.join(f'  <link name="{l}"/>' for l in self.links)
        return (
            f'<?xml version="1.0"?>\n<robot name="{self.name}">\n{links}\n'
            + '\n'.join(self.lines)
            + '\n</robot>\n'
        )


def matrix_rpy(r: np.ndarray) -> tuple[float, float, float]:
    """The roll, pitch, yaw of a rotation (away from pitch +-pi/2, which the callers avoid)."""
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    out = (math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0]))
    assume(abs(math.cos(pitch)) > 1e-3)
    assert np.abs(rpy_matrix(*out) - r).max() < 1e-12
    return out


angles = st.floats(-math.pi, math.pi, allow_nan=False)
rpys = st.tuples(angles, angles, angles)
planes = st.one_of(
    st.sampled_from([(0.0, 0.0, 0.0), (math.pi / 2, 0.0, 0.0), (0.0, math.pi / 2, 0.0)]),
    rpys,
)
scales = st.floats(-2.0, 2.0).map(lambda e: 10.0**e)
unit = st.floats(-1.0, 1.0, allow_nan=False)
senses = st.sampled_from([1.0, -1.0])


@dataclass
class Chain:
    text: str
    plane: Plane
    size: float
    crank_sense: float  # +1: joint1 turns the crank counter-clockwise in the plane
    crank_pivot: np.ndarray  # in the plane
    crank: float
    crank_zero: float  # the crank's in-plane angle at joint1 = 0
    pin: tuple[str, np.ndarray]  # the coupler's far pin: a point (link frame) the oracle places
    closed_form: bool  # the solver's plan is a dyad (two modes) rather than Newton

    def crank_pin(self, q: float) -> np.ndarray:
        t = self.crank_zero + self.crank_sense * q
        return self.crank_pivot + self.crank * np.array([math.cos(t), math.sin(t)])


def start(draw):
    s = draw(scales)
    plane = Plane(rpy_matrix(*draw(planes)), 3 * s * np.array([draw(unit) for _ in range(3)]))
    crank = draw(st.floats(0.15, 0.8)) * s
    theta0 = draw(angles)
    b0 = crank * np.array([math.cos(theta0), math.sin(theta0)])
    return s, plane, crank, theta0, b0


def placed(plane: Plane, xy, depth: float, rot: np.ndarray) -> np.ndarray:
    return homogeneous(rot, plane.world(xy, depth))


@st.composite
def four_bars(draw):
    s, plane, crank, theta0, b0 = start(draw)
    n = plane.normal
    a_pt, d_pt = np.zeros(2), np.array([draw(st.floats(0.4, 1.0)), 0.0]) * s
    phi = draw(angles)
    coupler = draw(st.floats(0.3, 1.5)) * s
    c0 = b0 + coupler * np.array([math.cos(phi), math.sin(phi)])
    rocker = float(np.linalg.norm(c0 - d_pt))
    assume(rocker > 0.15 * s)
    # not drawn near a toggle (B, C, D nearly in line): the assembly is well conditioned
    assume(abs(cross2(c0 - b0, d_pt - c0) / (coupler * rocker)) > 0.05)
    depth = [draw(unit) * s for _ in range(6)]
    sense = [draw(senses) for _ in range(4)]
    w = Writer('four_bar')
    w.joint('joint1', 'revolute', 'base_link', 'link1', plane.world(a_pt, depth[0]),
            draw(rpys), sense[0] * n, True)  # fmt: skip
    w.joint('joint2', 'revolute', 'link1', 'link2', plane.world(b0, depth[1]),
            draw(rpys), sense[1] * n, False)  # fmt: skip
    w.joint('joint3', 'revolute', 'base_link', 'link3', plane.world(d_pt, depth[2]),
            draw(rpys), sense[2] * n, False)  # fmt: skip
    # drawn open: the coupler and the rocker at random angles
    alpha, beta = draw(angles), draw(angles)
    pin_c = b0 + coupler * np.array([math.cos(alpha), math.sin(alpha)])
    pin_r = d_pt + rocker * np.array([math.cos(beta), math.sin(beta)])
    ends = [
        w.end('link2', placed(plane, pin_c, depth[3], rpy_matrix(*draw(rpys)))),
        w.end('link3', placed(plane, pin_r, depth[4], rpy_matrix(*draw(rpys)))),
    ]
    w.loop('revolute', ends, sense[3] * n)
    chain = Chain(w.text(), plane, 2 * s, sense[0], a_pt, crank, theta0, ends[0][:2], True)
    return chain, lambda b: circle_circle(b, coupler, d_pt, rocker)


@st.composite
def slider_cranks(draw):
    """A crank, a rod and a block on a straight line, cut at the rod-block pin (a revolute
    <loop>, the block on a prismatic joint) or at the slide (a prismatic <loop> between the
    ground and the block, the block on a revolute joint at the rod's end). The block's slide
    frame is at the pin (the usual drawing: a dyad with two modes) or anywhere on the block (a
    slide moves every point of the block alike; the solver places it by Newton)."""
    s, plane, crank, theta0, b0 = start(draw)
    n = plane.normal
    gamma = draw(angles)
    u = np.array([math.cos(gamma), math.sin(gamma)])
    line0 = np.array([draw(unit), draw(unit)]) * s  # the block pin's line: line0 + t u
    c0 = line0 + draw(st.floats(-1.5, 1.5)) * s * u  # the pin where the chain assembles
    rod = float(np.linalg.norm(c0 - b0))
    assume(rod > 0.2 * s)
    assume(abs(cross2(u, (c0 - b0) / rod)) > 0.05)  # not at a toggle
    depth = [draw(unit) * s for _ in range(6)]
    sense = [draw(senses) for _ in range(4)]
    cut_at_slide, slide_at_pin = draw(st.booleans()), draw(st.booleans())
    # where the slide frame is on the block, from the pin (zero: at the pin)
    offset = np.zeros(2) if slide_at_pin else np.array([draw(unit), draw(unit)]) * s
    assume(slide_at_pin or np.linalg.norm(offset) > 0.01 * s)
    w = Writer('slider_crank')
    w.joint('joint1', 'revolute', 'base_link', 'crank', plane.world(np.zeros(2), depth[0]),
            draw(rpys), sense[0] * n, True)  # fmt: skip
    w.joint('joint2', 'revolute', 'crank', 'rod', plane.world(b0, depth[1]),
            draw(rpys), sense[1] * n, False)  # fmt: skip
    alpha = draw(angles)  # the rod drawn at a random angle: the loop open
    pin_drawn = b0 + rod * np.array([math.cos(alpha), math.sin(alpha)])
    if not cut_at_slide:
        # the block drawn elsewhere on the line; its slide frame at the pin + offset
        at = line0 + draw(st.floats(-1.5, 1.5)) * s * u
        w.joint('slide', 'prismatic', 'base_link', 'block', plane.world(at + offset, depth[2]),
                draw(rpys), sense[2] * plane.direction(u), False)  # fmt: skip
        ends = [
            w.end('rod', placed(plane, pin_drawn, depth[3], rpy_matrix(*draw(rpys)))),
            w.end('block', placed(plane, at, depth[4], rpy_matrix(*draw(rpys)))),
        ]
        w.loop('revolute', ends, sense[3] * n)
        pin = ends[0][:2]
    else:
        x_block = w.joint('joint3', 'revolute', 'rod', 'block', plane.world(pin_drawn, depth[2]),
                          draw(rpys), sense[2] * n, False)  # fmt: skip
        # the slide's two frames: one fixed in the ground on the line of the block's slide
        # frame, and the block's, which coincides with it (origins on the line, same
        # orientation) when the chain is assembled: the block then turned by delta about n
        # and its pin at c0
        r_ground = rpy_matrix(*draw(rpys))
        ground = placed(plane, c0 + offset + draw(unit) * s * u, depth[3], r_ground)
        turn = axis_angle(n, draw(angles))
        x_assembled = homogeneous(turn @ x_block[:3, :3], plane.world(c0, depth[2]))
        slide_frame = np.linalg.inv(x_assembled) @ placed(plane, c0 + offset, depth[4], r_ground)
        ends = [w.end('base_link', ground), w.end('block', x_block @ slide_frame)]
        w.loop('prismatic', ends, sense[3] * plane.direction(u))
        pin = ('block', np.zeros(3))
    chain = Chain(w.text(), plane, 3 * s, sense[0], np.zeros(2), crank, theta0, pin, slide_at_pin)
    return chain, lambda b: circle_line(b, rod, c0, u)


# ---- the oracles -----------------------------------------------------------------------------


def circle_circle(c1, r1, c2, r2):
    """The two intersections of two circles, or None (with how far from tangency they are:
    the half-chord)."""
    d = float(np.linalg.norm(c2 - c1))
    along = (d * d + r1 * r1 - r2 * r2) / (2 * d)
    h2 = r1 * r1 - along * along
    if h2 <= 0:
        return None, -math.sqrt(-h2)
    h = math.sqrt(h2)
    e = (c2 - c1) / d
    f = np.array([-e[1], e[0]])
    base = c1 + along * e
    return (base + h * f, base - h * f), h


def circle_line(c, r, p0, u):
    """The two points of the line p0 + t u at distance r from c, or None."""
    w = p0 - c
    mid = -float(w @ u)
    h2 = r * r - float(w @ w) + mid * mid
    if h2 <= 0:
        return None, -math.sqrt(-h2)
    h = math.sqrt(h2)
    return (p0 + (mid + h) * u, p0 + (mid - h) * u), h


def check_sweep(chain: Chain, oracle) -> int:
    """Solve the imported chain over a sweep of joint1; returns how many commands solved.

    A dyad plan (``chain.closed_form``) is asked for every assembly mode of each command
    (``Solver.modes``: each branch sign; provably complete), which must be the oracle's two
    pins. A chain the solver places by Newton is swept in one mode (continuity from the last
    answer), which must be one of the oracle's pins, and its multi-start mode search is
    checked at some commands (its modes must be oracle pins; it may miss one)."""
    imported = import_description(chain.text, text=True)
    assert imported.actuated == ('joint1',)
    mech = imported.mechanism
    names = set(mech.output_joint_names)
    solver = Solver(mech)
    sweep = SWEEP if chain.closed_form else SWEEP[::3]
    tol = CLOSE * chain.size
    solved = 0

    def check(result, q, pins) -> np.ndarray:
        values = dict(zip(mech.output_joint_names, map(float, mech.output_joints(result.joints))))
        assert set(values) == names
        assert abs(math.remainder(values['joint1'] - q, 2 * math.pi)) <= 1e-12
        assert loop_miss(chain.text, values, chain.plane.normal) <= tol, (q, values)
        pin = chain.plane.in_plane(point_of(chain.text, values, *chain.pin))
        assert min(float(np.linalg.norm(pin - p)) for p in pins) <= tol, (q, pins, pin)
        return pin

    for k, q in enumerate(sweep):
        pins, height = oracle(chain.crank_pin(q))
        if abs(height) < 1e-6 * chain.size:
            continue  # at a toggle: reachable or not is decided by rounding
        cmd = mech.joint_coordinates.to_scene({'joint1': q})
        if chain.closed_form or k % 4 == 0:
            modes = solver.modes(cmd)
            assert modes.complete == chain.closed_form
            results = [r for r in modes.results if r.success]
        else:
            results = [r for r in [solver.solve(cmd)] if r.success]
        assert bool(results) == (pins is not None), (q, height, solver.solve(cmd).reason)
        if pins is None:
            continue
        solved += 1
        got = [check(r, q, pins) for r in results]
        if chain.closed_form:  # the two modes are the oracle's two pins, one each
            assert len(got) == 2
            for pin in pins:
                assert min(float(np.linalg.norm(pin - g)) for g in got) <= tol
    return solved


PROPERTY = settings(
    max_examples=50,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)


@PROPERTY
@given(four_bars())
def test_random_four_bars_solve_as_circles_meet(case):
    check_sweep(*case)


@PROPERTY
@given(slider_cranks())
def test_random_slider_cranks_solve_as_circle_and_line_meet(case):
    check_sweep(*case)


def test_the_oracles_on_a_known_four_bar():
    """The oracles themselves: a 3-4-5 triangle."""
    pins, h = circle_circle(np.zeros(2), 3.0, np.array([5.0, 0.0]), 4.0)
    assert h == pytest.approx(2.4)
    assert {tuple(np.round(p, 12)) for p in pins} == {(1.8, 2.4), (1.8, -2.4)}
    pins, h = circle_line(np.zeros(2), 5.0, np.array([-10.0, 3.0]), np.array([1.0, 0.0]))
    assert {tuple(np.round(p, 12)) for p in pins} == {(4.0, 3.0), (-4.0, 3.0)}
    assert circle_line(np.zeros(2), 1.0, np.array([0.0, 3.0]), np.array([1.0, 0.0]))[0] is None
